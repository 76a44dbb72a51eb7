"""The branch drivers' hooks (natural, arclength) on cheap problems with known answers.

The sheet's continuations in L and a/R (:mod:`skfem_sheet.bistability`) and the
ribbon model's (:mod:`skfem_sheet.reduced.ribbon`) run on these hooks: a
bisection bracket, acceptance checks, a remesh before a step, callbacks per
point, a converged start and a custom linearisation.
"""
import numpy as np
import pytest

from skfem_sheet.engine import (
    EngineFailure,
    FunctionProblem,
    Tolerances,
    arclength,
    correct,
    natural,
    sweep,
)
from skfem_sheet.engine.corrector import plain_linearization
from skfem_sheet.engine.protocol import Counting, DenseFactorization

LAM_STAR = 2.0 / (3.0 * np.sqrt(3.0))


def cubic():
    """u^3 - u + lam = 0: folds at lam = +-2/(3 sqrt 3), u = -+1/sqrt 3."""
    return FunctionProblem(lambda u, p: u**3 - u + p[0], lambda u, p: np.diag(3 * u**2 - 1),
                           ("lam",))


def root(lam):
    """The upper root of u^3 - u + lam (the branch through u = 1 at lam = 0)."""
    r = np.roots([1.0, 0.0, -1.0, lam])
    return float(np.max(r[np.abs(r.imag) < 1e-9].real))


def test_bisection_bracket_holds_the_fold_to_tol():
    """Without fold location, a failed step is halved until it is no longer than
    ``bracket``: the fold lies in the last bracket, of width at most 2 tol."""
    tol = 0.005
    b = natural(cubic(), np.array([1.0]), np.array([0.0]), 0, 1.0, step=0.1, min_step=tol,
                bracket=2 * tol, locate=False, jump=0.3, grow_after=None)
    lo, hi = b.bracket
    assert not b.completed and b.fold is None
    assert 0 < hi - lo <= 2 * tol + 1e-12
    assert lo < LAM_STAR < hi
    # every point is on the upper branch
    for pt in b.points:
        assert pt.u[0] == pytest.approx(root(pt.p[0]), abs=1e-8)


def test_growth_is_unconditional_with_grow_after_none():
    """Steps grow by ``growth`` after every accepted point (up to max_step)."""
    P = FunctionProblem(lambda u, p: u - p[0], lambda u, p: np.eye(1), ("lam",))
    b = natural(P, np.zeros(1), np.zeros(1), 0, 10.0, step=0.1, max_step=1.0, growth=2.0,
                grow_after=None, locate=False)
    steps = np.diff(b.values)
    assert steps[:4] == pytest.approx([0.1, 0.2, 0.4, 0.8])
    assert np.all(steps[4:-1] == pytest.approx(1.0))
    assert b.completed


def test_check_rejects_steps_and_names_the_reason():
    """A failing acceptance check acts as a lost branch: bisection to its edge."""
    def check(u, p, res):
        return "beyond 0.3" if p[0] > 0.3 else ""

    b = natural(cubic(), np.array([1.0]), np.array([0.0]), 0, 1.0, step=0.1, min_step=0.005,
                bracket=0.01, locate=False, check=check)
    lo, hi = b.bracket
    assert lo <= 0.3 < hi and hi - lo <= 0.01 + 1e-12
    assert b.reason == "beyond 0.3"
    assert b.values.max() <= 0.3


def test_on_step_sees_every_point_and_the_distance_travelled():
    seen = []
    b = natural(cubic(), np.array([1.0]), np.array([0.0]), 0, -0.5, step=0.1,
                on_step=lambda pt, res: seen.append((float(pt.p[0]), pt.s, res.converged)))
    assert b.completed
    assert [v for v, _, _ in seen] == pytest.approx(list(b.values))
    assert all(ok for _, _, ok in seen)
    # s is the parameter distance from the first point
    assert [s for _, s, _ in seen] == pytest.approx(list(np.abs(b.values)))


def test_before_step_replaces_the_state_and_can_end_the_branch():
    """A remesh-like hook: at lam >= 0.2 the state is perturbed (as if
    interpolated onto a new mesh) and re-converged by the caller; later a
    hook failure ends the branch with its message."""
    P = Counting(cubic())
    calls = []

    def before_step(u, p, value, fact):
        calls.append(value)
        if value > 0.3:
            raise EngineFailure("remeshing failed")
        if len(calls) == 3:
            res = correct(P, u + 1e-3, p, plain_linearization(P), _tight())
            assert res.converged
            return res.u, res.factorization
        return None

    b = natural(P, np.array([1.0]), np.array([0.0]), 0, 1.0, step=0.1, before_step=before_step,
                locate=False)
    assert b.reason == "remeshing failed" and not b.completed
    assert b.values.max() <= 0.3 + 1e-12
    for pt in b.points:  # the replaced state re-converged onto the same branch
        assert pt.u[0] == pytest.approx(root(pt.p[0]), abs=1e-8)


def _tight():
    return Tolerances(rtol=1e-12, utol=1e-12)


def test_converged_start_costs_no_correction():
    P = cubic()
    u0 = np.array([root(0.0)])
    fact = DenseFactorization(P.jacobian(u0, np.zeros(1)))
    b = natural(P, u0, np.zeros(1), 0, 0.1, step=0.1, start=(u0, fact))
    assert b.points[0].iterations == 0 and b.points[0].u[0] == u0[0]
    assert b.completed and b.points[-1].u[0] == pytest.approx(root(0.1), abs=1e-9)


def test_custom_linearization_is_used_for_every_correction():
    made = []

    def linearization(counter):
        made.append(1)
        return plain_linearization(counter)

    b = natural(cubic(), np.array([1.0]), np.array([0.0]), 0, 0.3, step=0.1,
                linearization=linearization)
    assert b.completed
    assert len(made) == len(b.points)  # the first point and every step


def test_arclength_reports_arclength_and_on_step():
    """``s`` grows by the arclength step; on_step sees every point; a converged
    start is taken as it is."""
    P = cubic()
    u0 = np.array([-1.5])
    lam0 = -(u0[0]**3 - u0[0])
    fact = DenseFactorization(P.jacobian(u0, np.array([lam0])))
    seen = []
    b = arclength(P, u0, np.array([lam0]), 0, (-2.0, 2.0), ds=0.2, direction=-1,
                  on_step=lambda pt, res: seen.append(pt.s), start=(u0, fact))
    assert b.completed and len(b.folds) == 2
    s = np.array([pt.s for pt in b.points])
    assert seen == pytest.approx(list(s)) and s[0] == 0.0 and np.all(np.diff(s) > 0)
    # each step is the projection of the chord onto the tangent: no longer
    # than the chord, and close to it on this smooth curve
    u = np.array([pt.u[0] for pt in b.points])
    chord = np.hypot(np.diff(u), np.diff(b.values))
    assert np.all(np.diff(s) <= chord + 1e-12)
    assert s[-1] == pytest.approx(chord.sum(), rel=0.02)
    assert b.points[0].iterations == 0


# ---------------------------------------------------------------------------
# sweeps through prescribed values
# ---------------------------------------------------------------------------
def test_sweep_keeps_failures_and_goes_on_from_the_last_converged_state():
    """Past the fold of the upper branch Newton (at most 5 iterations) fails at
    lam = 0.5 and 0.6; back at 0.3 the sweep restarts from the state at 0.2."""
    tol = Tolerances(max_iterations=5)
    values = [0.1, 0.2, 0.5, 0.6, 0.3]
    out = sweep(cubic(), np.array([1.0]), np.array([0.0]), 0, values, tol=tol)
    assert [r.converged for r in out] == [True, True, False, False, True]
    for r, v in zip(out, values):
        assert r.p[0] == v
        if r.converged:
            assert r.u[0] == pytest.approx(root(v), abs=1e-9)


def test_sweep_predictor_saves_iterations():
    values = np.linspace(0.02, 0.3, 15)
    plain = sweep(cubic(), np.array([1.0]), np.array([0.0]), 0, values)
    pred = sweep(cubic(), np.array([1.0]), np.array([0.0]), 0, values, predict=True)
    assert all(r.converged for r in plain + pred)
    assert [r.u[0] for r in pred] == pytest.approx([r.u[0] for r in plain], abs=1e-10)
    assert sum(r.iterations for r in pred) < sum(r.iterations for r in plain)


def test_sweep_revise_replaces_a_result_and_the_sweep_follows_it():
    """The revised result (here: the lower root instead of the upper) is where
    the sweep goes on from."""
    P = Counting(cubic())
    seen = []

    def revise(k, value, res, last):
        seen.append((k, value, last is None))
        if k == 1:
            return correct(P, np.array([-1.2]), res.p, plain_linearization(P), _tight())
        return res

    out = sweep(P, np.array([1.0]), np.array([0.0]), 0, [0.1, 0.2, 0.3], revise=revise)
    assert seen == [(0, 0.1, True), (1, 0.2, False), (2, 0.3, False)]
    assert out[0].u[0] == pytest.approx(root(0.1))
    lower = np.min(np.roots([1.0, 0.0, -1.0, 0.3]).real)
    assert out[2].u[0] == pytest.approx(lower, abs=1e-9)  # followed the revised state


def test_inertia_change_ends_a_branch_only_when_asked():
    """The trivial branch u = 0 of u^3 - lam u = 0 loses stability at the
    pitchfork lam = 0 (the tangent -lam changes sign) without a fold."""
    P = FunctionProblem(lambda u, p: u**3 - p[0] * u, lambda u, p: np.diag(3 * u**2 - p[0]),
                        ("lam",))
    kw = dict(step=0.1, min_step=0.01, locate=False)
    strict = natural(P, np.zeros(1), np.array([-0.95]), 0, 0.95, **kw)
    assert not strict.completed and "inertia changed from 0 to 1" in strict.reason
    lo, hi = strict.bracket
    assert lo < 0 < hi and hi - lo <= 0.01 * (1 + 1e-9)
    loose = natural(P, np.zeros(1), np.array([-0.95]), 0, 0.95, inertia_change=False, **kw)
    assert loose.completed
    k = [pt.negative_eigenvalues for pt in loose.points]
    assert k[0] == 0 and k[-1] == 1


def test_guide_corrects_the_prediction_and_none_leaves_it():
    """``guide(p_from, p_to)`` is added to the tangent prediction: with the
    branch's exact second-order part each step starts within third order of
    the root and converges in fewer linearisations, at the same points; a
    guide that returns None changes nothing."""
    P = cubic()

    def second_order(p_from, p_to):
        # the branch's own u(p_to) - u(p_from) - (p_to - p_from) u'(p_from)
        u0 = root(p_from[0])
        du = -1.0 / (3 * u0**2 - 1)
        return np.array([root(p_to[0]) - u0 - (p_to[0] - p_from[0]) * du])

    tol = Tolerances(rtol=1e-12, utol=1e-12)
    kw = dict(step=0.05, tol=tol, locate=False, grow_after=None, max_step=0.05)
    plain = natural(P, np.array([1.0]), np.zeros(1), 0, 0.3, **kw)
    guided = natural(P, np.array([1.0]), np.zeros(1), 0, 0.3, guide=second_order, **kw)
    none = natural(P, np.array([1.0]), np.zeros(1), 0, 0.3, guide=lambda a, b: None, **kw)
    assert plain.completed and guided.completed
    np.testing.assert_allclose(guided.values, plain.values)
    np.testing.assert_allclose([pt.u[0] for pt in guided.points],
                               [root(v) for v in guided.values], atol=1e-12)
    assert guided.stats.factorizations < plain.stats.factorizations
    assert [pt.iterations for pt in none.points] == [pt.iterations for pt in plain.points]
    assert [pt.u[0] for pt in none.points] == [pt.u[0] for pt in plain.points]
