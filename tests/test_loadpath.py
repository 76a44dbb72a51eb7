"""The engine's load-path driver (engine/loadpath.py): step control, snaps, stops;
and the one-loop rule: the sheet's Newton and load paths run on the engine."""
import numpy as np
import pytest

from skfem_sheet import Sheet, newton
from skfem_sheet.continuation import StepOptions, follow_path
from skfem_sheet.engine import corrector, transient
from skfem_sheet.engine.loadpath import Attempt, RampControl, growth, ramp
from skfem_sheet.linalg import make_linear_solver
from skfem_sheet.params import ParameterError
from skfem_sheet.solve import build_problem


def test_easy_steps_grow_to_the_end_in_few_attempts():
    seen = []

    def attempt(lam, lam_new, snapping):
        seen.append(lam_new)
        return Attempt(True, 1)

    out = ramp(0.0, RampControl(initial_step=0.25), attempt)
    assert out.converged and out.lam == 1.0 and out.rejected == 0
    assert seen == [0.25, 0.75, 1.0]  # 0.25, then 0.5, then what is left


def test_growth_aims_at_the_easy_iteration_count():
    c = RampControl(grow=2.0, easy_iterations=2)
    assert [growth(k, c) for k in (1, 2, 3, 4, 5, 9)] == [2.0, 2.0, 1.5, 1.0, 0.7, 0.7]


def test_a_wall_without_snapping_fails_below_min_step_at_the_last_accepted_load():
    def attempt(lam, lam_new, snapping):
        assert not snapping
        return Attempt(lam_new <= 0.3, 3, "no equilibrium")

    out = ramp(0.0, RampControl(min_step=1e-3), attempt)
    assert not out.converged and out.reason == "step below min_step"
    assert out.last_failure == "no equilibrium"
    assert 0.3 - 1e-3 <= out.lam <= 0.3 and out.rejected > 5


def test_a_stop_ends_the_ramp_at_once():
    calls = []

    def attempt(lam, lam_new, snapping):
        calls.append(lam_new)
        return Attempt(True, 1, stop="unstable end state") if len(calls) == 2 else Attempt(True, 1)

    out = ramp(0.0, RampControl(), attempt)
    assert not out.converged and out.reason == "unstable end state" and out.lam == 0.25
    assert len(calls) == 2


def test_bad_control_raises():
    with pytest.raises(ParameterError, match="snap_step"):
        RampControl(snap_step=0.0)
    with pytest.raises(ParameterError, match="min_step"):
        RampControl(initial_step=0.1, min_step=0.2)


def test_the_sheet_newton_and_load_path_run_on_the_engine(monkeypatch):
    """Every Newton iteration of a load path is one of engine.corrector.correct:
    the iterations counted inside correct's linearisations are all of the solve's."""
    calls = {"correct": 0, "transient": 0}
    real_correct, real_transient = corrector.correct, transient.pseudo_transient

    def spy_correct(*a, **k):
        calls["correct"] += 1
        return real_correct(*a, **k)

    def spy_transient(*a, **k):
        calls["transient"] += 1
        return real_transient(*a, **k)

    monkeypatch.setattr(newton, "correct", spy_correct)
    monkeypatch.setattr(transient, "pseudo_transient", spy_transient)
    problem = build_problem(Sheet(length=0.6, tip_width=0.8, curvature=1.5), 0.2, None, 2,
                            half=True)
    stats = newton.Stats()
    out = follow_path(problem, "curvature-first", 1.5, make_linear_solver("auto"), stats=stats)
    assert out.converged and out.stable is True
    assert calls["correct"] == len(out.steps) + out.rejected_steps >= 2
    # a settle from the reference state goes through the engine's transient iteration
    w0 = np.zeros(problem.ndof)
    w0[problem.clamp_dofs] = problem.clamp_values(1.5)
    res = newton.pseudo_transient(problem, w0, 1.0, make_linear_solver("auto"),
                                  newton.NewtonOptions(rtol=1.0, utol=1e-3), newton.Stats())
    assert res.converged and calls["transient"] == 1


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


def test_the_first_snapping_attempt_retries_the_failed_load():
    """A branch that ends at 0.6: once the steps are cut below snap_step the
    snap is tried at the load that has just failed (beyond the fold), not at
    half the step (which may be short of the fold: a settle that does not
    snap); with snap_at_failure=False, at half the step."""
    for at_failure in (True, False):
        calls = []
        branch = ["first"]

        def attempt(lam, lam_new, snapping, calls=calls, branch=branch):
            calls.append((lam, lam_new, snapping))
            if snapping:
                branch[0] = "second"
            ok = lam_new <= 0.6 or branch[0] == "second"
            return Attempt(ok, 2 if ok else 5, "" if ok else "no equilibrium")

        out = ramp(0.0, RampControl(snap_step=0.05, snap_at_failure=at_failure), attempt)
        assert out.converged and len(out.snapped) == 1
        i = next(k for k, c in enumerate(calls) if c[2])
        failed = calls[i - 1][1]
        assert not calls[i - 1][2] and calls[i][0] == calls[i - 1][0]
        if at_failure:
            assert calls[i][1] == failed and out.snapped[0] == failed
        else:
            assert calls[i][1] < failed and out.snapped[0] < failed


def test_the_jump_guard_options_are_checked():
    for name in ("jump_ratio", "jump_floor", "max_move"):
        with pytest.raises(ParameterError, match=name):
            StepOptions(**{name: 0.0})
        with pytest.raises(ParameterError, match=name):
            StepOptions(**{name: float("nan")})


def test_a_smooth_step_corrects_to_second_order_and_passes_the_jump_guard():
    """The premise of the jump guard (``StepOptions.jump_ratio``): on a smooth
    branch the tangent predictor is first order in the step and the
    corrector's move second order, so halving the first step (predicted from
    the exact tangent at the reference state) halves the predicted move and
    cuts the correction by about four; a whole path on a branch without folds
    is never cut by the guard."""
    problem = build_problem(Sheet(length=0.8, tip_width=0.8, curvature=2.0), 0.2, None, 2,
                            half=True)
    first = []
    for step in (0.25, 0.125, 0.0625):
        out = follow_path(problem, "curvature-first", 2.0, make_linear_solver("auto"),
                          step_options=StepOptions(initial_step=step))
        assert out.converged and out.stable is True and not out.snaps
        assert out.rejected_steps == 0 and all(m[-1] for m in out.moves)
        assert len(out.moves) == len(out.steps)
        name, lam, predicted, corrected, moved, _ = out.moves[0]
        assert (name, lam) == ("curvature", step)
        first.append((predicted, corrected))
    for (p0, c0), (p1, c1) in zip(first, first[1:]):
        assert p1 / p0 == pytest.approx(0.5, rel=0.05)
        assert c1 / c0 < 0.35
