"""The engine's load-path driver (engine/loadpath.py: continuation in a load,
ending at a located fold) on toy problems, the one step rule (engine/steps.py),
and the sheet's load paths on it (continuation.follow_path)."""
import numpy as np
import pytest

from skfem_sheet import Sheet, newton
from skfem_sheet.continuation import StepOptions, follow_path, load_phases
from skfem_sheet.engine import FunctionProblem, StepRule, corrector, ramp, transient
from skfem_sheet.linalg import make_linear_solver
from skfem_sheet.params import ParameterError
from skfem_sheet.solve import build_problem

#: u - u^3/3 = lam: a spring that softens; the branch through u = 0 turns at
#: lam = 2/3 (u = 1), where the tangent 1 - u^2 becomes singular
SPRING = FunctionProblem(lambda u, p: u - u**3 / 3 - p[0],
                         lambda u, p: np.diag(1 - u**2), ("lam",))

#: lam = 1/2 + u/50 + u^3/3: monotone (dlam/du > 0), steep where u ~ 0
#: (du/dlam = 50 at lam = 1/2), no fold
STEEP = FunctionProblem(lambda u, p: 0.5 + u / 50 + u**3 / 3 - p[0],
                        lambda u, p: np.diag(1 / 50 + u**2), ("lam",))


def _steep_u(lam):
    return float(np.roots([1 / 3, 0, 1 / 50, 0.5 - lam]).real[np.argmin(
        np.abs(np.roots([1 / 3, 0, 1 / 50, 0.5 - lam]).imag))])


def test_a_turning_point_of_the_load_is_located_and_confirmed_by_the_inertia():
    b = ramp(SPRING, np.zeros(1), np.zeros(1), "lam", 1.0,
             rule=StepRule(initial=0.1, delta=0.01))
    assert not b.completed and len(b.folds) == 1
    fold = b.fold
    assert fold.value == pytest.approx(2 / 3, abs=1e-10)      # lam* = 2/3
    assert float(fold.u[0]) == pytest.approx(1.0, abs=1e-6)
    assert fold.side == -1                                     # solutions below lam*
    assert fold.crossing == (0, 1)                             # one eigenvalue crossed zero
    lam = [float(pt.p[0]) for pt in b.points]
    assert all(np.diff(lam) > 0) and lam[-1] < 2 / 3          # the branch up to the fold


def test_a_steep_branch_without_a_turning_point_is_followed_to_the_end():
    """STEEP's rate of the load along the branch falls to a minimum at u = 0
    and rises again: the fold searched there is not found (none is), the
    branch goes on."""
    b = ramp(STEEP, np.array([_steep_u(0.0)]), np.zeros(1), "lam", 1.0,
             rule=StepRule(initial=0.1, delta=0.02))
    assert b.completed and not b.folds
    assert float(b.points[-1].p[0]) == 1.0
    assert float(b.points[-1].u[0]) == pytest.approx(_steep_u(1.0), abs=1e-9)
    lam = np.array([float(pt.p[0]) for pt in b.points])
    assert np.all(np.diff(lam) > 0)                            # never turned
    # the steep part was stepped by arclength: small parameter steps there,
    # large ones (natural) where the branch is flat
    steps = np.diff(lam)
    mid = (lam[1:] > 0.45) & (lam[1:] < 0.55)
    assert steps[mid].max() < 0.05 < steps.max()


def test_a_fold_of_the_s_curve_is_not_jumped_over_by_a_long_first_step():
    """u^3 - u + lam = 0 from the left branch: the branch ends at the fold
    lam* = 2/(3 sqrt 3); beyond it Newton would converge on the right branch
    (a jump).  Whatever the first step, the driver locates the fold."""
    P = FunctionProblem(lambda u, p: u**3 - u + p[0], lambda u, p: np.diag(3 * u**2 - 1),
                        ("lam",))
    lam0 = -0.5
    u0 = np.array([np.roots([1, 0, -1, lam0]).real.min()])   # the left branch
    for initial in (0.05, 0.5, 2.0):
        b = ramp(P, u0, np.array([lam0]), "lam", 1.0,
                 rule=StepRule(initial=initial, maximum=max(1.0, initial), delta=0.01))
        assert b.fold is not None, initial
        assert b.fold.value == pytest.approx(2 / (3 * np.sqrt(3)), abs=1e-9)


def _thin_s(eps):
    """lam = 1/2 - eps u + u^3/3: an S whose two folds, at u = -+sqrt(eps)
    and lam = 1/2 +- (2/3) eps^(3/2), are a thin pair (0.0005 apart in lam at
    eps 0.005, while the state jumps by 0.2 between its outer branches)."""
    P = FunctionProblem(lambda u, p: 0.5 - eps * u + u**3 / 3 - p[0],
                        lambda u, p: np.diag(u**2 - eps), ("lam",))
    r = np.roots([1 / 3, 0, -eps, 0.5])
    return P, np.array([float(r.real[np.argmin(np.abs(r.imag))])])


def test_a_thin_s_shaped_fold_pair_crossed_within_one_step_is_located():
    """Steps long against the S (nominal distance 0.4) cross both folds: the
    parameter is monotone over the step's ends and the inertia the same at
    both, so neither turns the ramp.  The rate of the load along the branch
    has its minimum at the point landed on; the fold searched on the branch
    from there (and from the point before) is the turning point the sheet
    snaps at.  (Before the search the ramp completed here without a fold.)"""
    for eps in (0.02, 0.005, 0.001):
        P, u0 = _thin_s(eps)
        b = ramp(P, u0, np.zeros(1), "lam", 1.0,
                 rule=StepRule(initial=0.25, delta=0.4, maximum=1.0))
        assert not b.completed and b.fold is not None, eps
        assert b.fold.value == pytest.approx(0.5 + 2 / 3 * eps**1.5, abs=1e-10)
        assert float(b.fold.u[0]) == pytest.approx(-np.sqrt(eps), abs=1e-5)
        assert b.fold.crossing == (0, 1) and b.fold.side == -1
        # the branch ends before the fold: no point of the other branch kept
        assert all(float(pt.u[0]) < -np.sqrt(eps) for pt in b.points)


def _hairpin(eps):
    """``x/eps - (x/eps)^3/3 = lam``: the spring's fold at ``lam = 2/3``,
    ``x = eps``, with the branch's radius of curvature in ``(x, lam)`` of the
    order of ``eps^2``: a turn too sharp for steps of ``1e-4``."""
    return FunctionProblem(lambda u, p: u / eps - (u / eps) ** 3 / 3 - p[0],
                           lambda u, p: np.diag(1 / eps - u**2 / eps**3), ("lam",))


@pytest.mark.parametrize("eps", [1e-2, 1e-3, 1e-4])
def test_a_fold_sharper_than_the_smallest_step_is_located_where_the_steps_stall(eps):
    """Every step near the turn fails (natural ones beyond the fold, the
    pseudo-arclength sections past the hairpin), so the steps shrink below the
    minimum; the driver then locates the fold ahead of the last point of the
    branch instead of ending in "step below" (before issue 56 it did, at every
    eps here): the exact fold, where one eigenvalue crosses zero and the load
    turns back."""
    b = ramp(_hairpin(eps), np.zeros(1), np.zeros(1), "lam", 1.0,
             rule=StepRule(delta=0.01, minimum=1e-4), tol=corrector.Tolerances(rtol=1e-6,
                                                                                 utol=1e-3),
             end_tol=corrector.Tolerances(rtol=1e-12, utol=1e-12))
    assert not b.completed and "where the steps stalled" in b.reason
    fold = b.fold
    assert fold.value == pytest.approx(2 / 3, abs=1e-10)
    assert float(fold.u[0]) == pytest.approx(eps, rel=1e-6)
    assert fold.side == -1 and fold.crossing == (0, 1)
    assert all(float(pt.p[0]) <= fold.value for pt in b.points)  # none past it is kept


def test_a_branch_point_is_named_where_the_steps_stall_at_it():
    """A pitchfork, ``x = lam``, ``(1 - lam) y + y^3 = 0``: on the branch y = 0
    one eigenvalue crosses zero at lam = 1 and the load does not turn, so no
    step across it is accepted (an inertia change without a turn); the ramp
    ends there and says that it is a branch point, bracketing it, not a
    fold."""
    pitchfork = FunctionProblem(
        lambda u, p: np.array([u[0] - p[0], (1 - p[0]) * u[1] + u[1] ** 3]),
        lambda u, p: np.diag([1.0, 1 - p[0] + 3 * u[1] ** 2]), ("lam",))
    b = ramp(pitchfork, np.zeros(2), np.zeros(1), "lam", 2.0, rule=StepRule(delta=0.01))
    assert not b.completed and b.fold is None
    assert b.reason.startswith("a branch point between p = ")
    lo, hi = (float(x) for x in b.reason.split("p = ")[1].split(":")[0].split(" and "))
    assert lo < 1.0 < hi and hi - lo < 1e-3


def test_the_step_rule_grows_and_cuts_by_the_corrector_distance():
    rule = StepRule(initial=0.1, delta=0.01, maximum=1.0)
    assert rule.next_step(0.1, 0.01) == pytest.approx(0.1)        # nominal: the same
    assert rule.next_step(0.1, 0.0025) == pytest.approx(0.2)      # h^2 law: twice as long
    assert rule.next_step(0.1, 1e-9) == pytest.approx(0.2)        # at most doubled
    assert rule.next_step(0.1, 0.03) == pytest.approx(0.1 / np.sqrt(3))
    assert not rule.rejects(0.04) and rule.rejects(0.0401) and rule.rejects(np.nan)
    with pytest.raises(ParameterError, match="delta"):
        StepRule(delta=0.0)
    with pytest.raises(ParameterError, match="minimum"):
        StepRule(initial=0.1, minimum=0.2)


def _parabola(linearised_at):
    """u = 50 lam^2: the tangent at lam = 0 is flat, so a step of length h
    predicts u = 0 and is 50 h^2 off the branch; R is linear in u, so Newton's
    first correction is that distance exactly.  Every linearisation appends
    its lam to ``linearised_at``."""
    def jacobian(u, p):
        linearised_at.append(float(p[0]))
        return np.eye(1)
    return FunctionProblem(lambda u, p: u - 50 * p[0] ** 2, jacobian, ("lam",))


def test_a_step_whose_first_correction_is_beyond_the_bound_costs_one_linearisation():
    """Newton's first correction estimates the corrector distance: a step
    whose first correction is over the rule's bound is stopped there and
    rejected (one linearisation), not corrected to the end to be rejected
    after (two here; all of Newton's iterations where Newton fails)."""
    rule = StepRule(initial=0.5, delta=0.01, maximum=1.0)
    linearised_at = []
    b = ramp(_parabola(linearised_at), np.zeros(1), np.zeros(1), "lam", 1.0, rule=rule)
    assert b.completed and float(b.points[-1].u[0]) == pytest.approx(50.0, abs=1e-8)
    # the first steps, natural ones to lam = h, are 50 h^2 = 12.5, 3.1, 0.78,
    # 0.20, 0.049 off the branch (over the bound 0.04): each is linearised
    # once and rejected; then the branch is followed
    assert b.rejected >= 5
    for h in (0.5, 0.25, 0.125, 0.0625, 0.03125):
        assert linearised_at.count(h) == 1, h
    assert all(pt.distance <= rule.bound for pt in b.points)


def test_the_sheet_newton_and_load_path_run_on_the_engine(monkeypatch):
    """Every Newton iteration of a load path is one of engine.corrector.correct,
    and a settle goes through the engine's transient iteration."""
    calls = {"correct": 0, "transient": 0}
    real_correct, real_transient = corrector.correct, transient.pseudo_transient

    def spy_correct(*a, **k):
        calls["correct"] += 1
        return real_correct(*a, **k)

    def spy_transient(*a, **k):
        calls["transient"] += 1
        return real_transient(*a, **k)

    from skfem_sheet.engine import loadpath
    monkeypatch.setattr(loadpath, "correct", spy_correct)
    monkeypatch.setattr(newton, "correct", spy_correct)
    monkeypatch.setattr(transient, "pseudo_transient", spy_transient)
    problem = build_problem(Sheet(length=0.6, tip_width=0.8, curvature=1.5), 0.2, None, 2,
                            half=True)
    stats = newton.Stats()
    out = follow_path(problem, "curvature-first", 1.5, make_linear_solver("auto"), stats=stats)
    assert out.converged and out.stable is True
    assert calls["correct"] >= len(out.steps) >= 2
    w0 = np.zeros(problem.ndof)
    w0[problem.clamp_dofs] = problem.clamp_values(1.5)
    res = newton.pseudo_transient(problem, w0, 1.0, make_linear_solver("auto"),
                                  newton.NewtonOptions(rtol=1.0, utol=1e-3), newton.Stats())
    assert res.converged and calls["transient"] == 1


def test_on_a_smooth_branch_the_corrector_distance_falls_fourfold_when_the_step_halves():
    """The premise of the step rule and its halving test on the sheet itself:
    the first step of the curvature ramp (predicted along the tangent at the
    reference state) lands at a distance at least second order in its
    length.  (Here third order as the step shrinks: the ramp from the flat
    state is odd in a/R to leading order, so the quadratic term of the
    branch nearly vanishes; measured ratios 4.9 and 6.6.)"""
    problem = build_problem(Sheet(length=0.8, tip_width=0.8, curvature=2.0), 0.2, None, 2,
                            half=True)
    first = []
    for step in (0.2, 0.1, 0.05):
        out = follow_path(problem, "curvature-first", 2.0, make_linear_solver("auto"),
                          step_options=StepOptions(initial_step=step, corrector_distance=0.2))
        assert out.converged and out.stable is True and not out.snaps
        first.append(out.distances[0])
    ratios = [a / b for a, b in zip(first, first[1:])]
    assert all(r > 3.5 for r in ratios), ratios


def test_a_path_resumed_from_one_of_its_own_states_ends_on_the_same_equilibrium():
    """``follow_path(resume=(phase, lam), w0=...)`` starts part-way: from the
    state the full path accepted in its second phase, it reaches the same end
    state (to the Newton tolerance), with only the remaining steps recorded."""
    problem = build_problem(Sheet(length=0.8, tip_width=0.8, curvature=2.0), 0.2, None, 2,
                            half=True)
    states = []
    full = follow_path(problem, "curvature-first", 2.0, make_linear_solver("auto"),
                       on_step=lambda pr, w, k, g: states.append(w.copy()))
    assert full.converged and full.stable is True
    i = next(j for j, s in enumerate(full.steps) if s[0] == "gravity" and s[1] < 1.0)
    phase, lam = full.steps[i][:2]
    part = follow_path(problem, "curvature-first", 2.0, make_linear_solver("auto"),
                       w0=states[i], resume=(phase, lam))
    assert part.converged and part.stable is True
    assert all(s[0] == "gravity" and s[1] > lam for s in part.steps)
    assert (part.kappa, part.g) == (full.kappa, full.g) == (2.0, 1.0)
    nu = problem.nu_dof
    assert np.abs(part.w[:nu] - full.w[:nu]).max() < 1e-5


def test_resume_needs_a_known_phase_and_a_start_state():
    problem = build_problem(Sheet(length=0.6), 0.2, None, 2, half=True)
    solver = make_linear_solver("auto")
    with pytest.raises(ParameterError, match="resume needs w0"):
        follow_path(problem, "curvature-first", 1.0, solver, resume=("gravity", 0.5))
    with pytest.raises(ParameterError, match="resume must be"):
        follow_path(problem, "curvature-first", 1.0, solver, w0=np.zeros(problem.ndof),
                    resume=("bending", 0.5))
    with pytest.raises(ParameterError, match="resume lam"):
        follow_path(problem, "curvature-first", 1.0, solver, w0=np.zeros(problem.ndof),
                    resume=("gravity", 1.5))


def test_the_step_options_are_checked_and_scaled_by_the_sheet_size():
    for name in ("initial_step", "corrector_distance"):
        with pytest.raises(ParameterError, match=name):
            StepOptions(**{name: 0.0})
        with pytest.raises(ParameterError, match=name):
            StepOptions(**{name: float("nan")})
    rule = StepOptions().rule(2.5)
    assert rule.delta == pytest.approx(2.5 * StepOptions().corrector_distance)
    assert StepOptions().intermediate_utol(2.5) == pytest.approx(0.1 * rule.delta)
    assert load_phases("curvature-first", 2.0)[1] == ("gravity", (2.0, 0.0), (2.0, 1.0))
