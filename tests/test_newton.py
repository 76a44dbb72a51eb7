"""newton.timed (the time of a call is added to the counter, also on errors), the
pseudo-transient settle and the polish of an end state with the last factorisation."""
import time

import numpy as np
import pytest

from skfem_sheet import Sheet
from skfem_sheet.analyses.stability import stability
from skfem_sheet.continuation import follow_path
from skfem_sheet.linalg import make_linear_solver
from skfem_sheet.newton import NewtonOptions, Stats, newton, polish, pseudo_transient, timed
from skfem_sheet.params import ParameterError
from skfem_sheet.solve import build_problem


def test_timed_adds_the_wall_time_and_returns_the_result():
    stats = Stats()
    assert timed(stats, "assembly_s", lambda a, b: a + b, 2, 3) == 5
    t0 = stats.assembly_s
    timed(stats, "assembly_s", time.sleep, 0.02)
    assert stats.assembly_s - t0 >= 0.02 and stats.linear_solve_s == 0.0


def test_timed_counts_a_call_that_raises():
    stats = Stats()

    def fail():
        time.sleep(0.01)
        raise RuntimeError("boom")

    with pytest.raises(RuntimeError, match="boom"):
        timed(stats, "linear_solve_s", fail)
    assert stats.linear_solve_s >= 0.01


# --------------------------------------------------------------------------------------
# pseudo-transient settle and unstable directions (issue 17)
# --------------------------------------------------------------------------------------
def _flat_problem():
    return build_problem(Sheet(length=0.6, tip_width=0.8, curvature=1.5), 0.2, None, 2, half=True)


def _negatives(problem, solver):
    return stability(problem, solver)[1]


def test_pseudo_transient_settles_where_newton_converges():
    """From the reference state at full gravity (with the clamp's curvature
    imposed) the settle and a tight Newton solve reach the state Newton's load
    stepping reaches, and stop on a certified plain Newton step."""
    problem = _flat_problem()
    solver = make_linear_solver("auto")
    ref = follow_path(problem, "curvature-first", problem.sheet.curvature, solver)
    assert ref.converged
    w0 = np.zeros(problem.ndof)
    w0[problem.clamp_dofs] = problem.clamp_values(problem.sheet.curvature)
    stats = Stats()
    loose = NewtonOptions(rtol=1.0, utol=1e-3)
    pt = pseudo_transient(problem, w0, 1.0, solver, loose, stats, negatives=_negatives)
    assert pt.converged and pt.reason == ""
    assert pt.corrections[-1] <= 1e-3 < max(pt.corrections)
    assert stats.factorizations >= pt.iterations == stats.newton_iterations
    final = newton(problem, pt.w, 1.0, solver, NewtonOptions(), stats)
    assert final.converged and final.iterations <= 4
    d = np.abs(final.w[: problem.nu_dof] - ref.w[: problem.nu_dof]).max()
    assert d < 1e-5
    # the same inputs give the same iteration and the same state, bit for bit
    again = pseudo_transient(problem, w0, 1.0, solver, loose, Stats(), negatives=_negatives)
    assert again.iterations == pt.iterations and np.array_equal(again.w, pt.w)


def test_pseudo_transient_refuses_steps_on_an_indefinite_model():
    """A shifted tangent reported indefinite is refactorised with a larger
    shift, never used for a step; a back-end that never certifies it ends the
    settle with a reason instead of a step."""
    problem = _flat_problem()
    solver = make_linear_solver("auto")
    w0 = np.zeros(problem.ndof)
    w0[problem.clamp_dofs] = problem.clamp_values(problem.sheet.curvature)
    stats = Stats()
    res = pseudo_transient(problem, w0, 1.0, solver, NewtonOptions(rtol=1.0, utol=1e-3), stats,
                           negatives=lambda p, s: 1)
    # sigma from 100 by factors of 4, 16, 64 and then to the cap, 1e6 times the
    # shift, tried too: 5 factorisations
    assert not res.converged and "positive definite" in res.reason
    assert res.iterations == 0 and stats.newton_iterations == 0 and stats.factorizations == 5
    with pytest.raises(ParameterError, match="radius"):
        pseudo_transient(problem, w0, 1.0, solver, NewtonOptions(), Stats(), radius=0.0)


def test_mip_newton_converges_to_the_exact_newton_state_and_leaves_the_hessian():
    """Same residual, so the same equilibrium (to the tolerance); a converged
    MIP solve leaves the exact tangent at its state factorised, whose inertia
    is the one of the Hessian there."""
    problem = _flat_problem()
    w0 = np.zeros(problem.ndof)
    w0[problem.clamp_dofs] = problem.clamp_values(problem.sheet.curvature)
    ends = {}
    for lin in ("exact", "mip"):
        solver = make_linear_solver("auto")
        opts = NewtonOptions(utol=1e-9, max_iterations=30, linearization=lin)
        res = newton(problem, w0, 0.3, solver, opts, Stats())
        assert res.converged, res.reason
        ends[lin] = (res.w, stability(problem, solver))
    d = np.abs(ends["mip"][0] - ends["exact"][0])[: problem.nu_dof].max()
    assert d < 1e-8
    check = make_linear_solver("auto")
    check.factorize(problem.tangent(ends["mip"][0]), ends["mip"][0])
    assert ends["mip"][1] == stability(problem, check) == ends["exact"][1]


def test_a_chord_step_takes_the_residual_left_after_a_correction_below_utol():
    """From an equilibrium moved by 1e-3 a, the second correction is below
    utol while the residual there is still above rtol: the third iteration
    reuses the last factorisation (a chord step) instead of a new one, and
    the state converges to the equilibrium as Newton's would (to 1e-8, a
    hundredth of utol); the factorisation left is the Hessian's inertia."""
    problem = _flat_problem()
    solver = make_linear_solver("auto")
    path = follow_path(problem, "curvature-first", problem.sheet.curvature, solver)
    tight = NewtonOptions(utol=1e-12, rtol=1e-10, max_iterations=40, linearization="exact")
    ref = newton(problem, path.w, 1.0, solver, tight, Stats())
    assert ref.converged
    inertia = stability(problem, solver)
    opts = NewtonOptions(linearization="exact")
    w = ref.w.copy()
    w[problem.free[problem.free < problem.nu_dof]] += 1e-3
    stats = Stats()
    res = newton(problem, w, 1.0, solver, opts, stats)
    assert res.converged and res.iterations == 3 and stats.factorizations == 2
    # the chord step: its correction below utol, the residual before it above rtol
    rref = np.linalg.norm(problem.gravity_load[problem.free])
    assert res.corrections[2] <= opts.utol < res.corrections[1]
    assert res.residuals[2] > opts.rtol * rref >= res.residuals[3]
    assert np.abs(res.w - ref.w)[: problem.nu_dof].max() <= 1e-8
    assert stability(problem, solver) == inertia


def test_bad_linearization_raises():
    with pytest.raises(ParameterError, match="linearization"):
        NewtonOptions(linearization="secant")
    with pytest.raises(ParameterError, match="mip_threshold"):
        NewtonOptions(mip_threshold=-1.0)


def test_polish_applies_corrections_until_final_utol():
    # solve's end-state polish (NewtonOptions.final_utol, polish_iterations)
    FINAL_UTOL, POLISH_ITERATIONS = NewtonOptions().final_utol, NewtonOptions().polish_iterations

    sheet = Sheet(length=0.8, curvature=2.0)
    problem = build_problem(sheet, 0.15, None, 2, half=True)
    linear = make_linear_solver("auto")
    res = newton(problem, np.zeros(problem.ndof), 1.0, linear, NewtonOptions(max_iterations=30),
                 Stats())
    assert res.converged
    stats = Stats()
    w, n = polish(problem, res.w, 1.0, linear, stats, utol=FINAL_UTOL,
                  max_iterations=POLISH_ITERATIONS)
    assert n >= 1 and stats.factorizations == 0
    free = problem.free
    r0 = np.linalg.norm(problem.residual(res.w, 1.0)[0][free])
    r1 = np.linalg.norm(problem.residual(w, 1.0)[0][free])
    assert r1 < 1e-2 * r0
    # the next correction is below FINAL_UTOL
    du = linear.solve(-problem.residual(w, 1.0)[0][free])
    assert np.abs(du[free < problem.nu_dof]).max() <= FINAL_UTOL
    # nothing applied without iterations, or if the first correction exceeds `first`
    # (a state not solved to that tolerance): the state is kept
    same, k = polish(problem, res.w, 1.0, linear, Stats(), utol=FINAL_UTOL, max_iterations=0)
    assert k == 0 and np.array_equal(same, res.w)
    same, k = polish(problem, res.w, 1.0, linear, Stats(), utol=FINAL_UTOL,
                     max_iterations=POLISH_ITERATIONS, first=1e-300)
    assert k == 0 and np.array_equal(same, res.w)
