"""``solve(start="coarse")``: the load path on a coarse mesh, finished on the fine one."""
import numpy as np
import pytest

from skfem_sheet import Sheet, solve
from skfem_sheet.analyses.observables import tip_deflection
from skfem_sheet.linalg import make_linear_solver
from skfem_sheet.newton import NewtonOptions, Stats, newton
from skfem_sheet.params import ParameterError
from skfem_sheet.solve import Result

solve_module = __import__("skfem_sheet.solve", fromlist=["solve"])


def _polished(r):
    """d of ``r``'s end state after a tight Newton solve (both starts then agree
    to round-off if they ended on the same equilibrium)."""
    res = newton(r.problem, r.w, r.gravity, make_linear_solver(r.solver),
                 NewtonOptions(rtol=1e-9, utol=1e-10, max_iterations=6), Stats())
    assert res.converged
    return tip_deflection(r.problem, res.w)


@pytest.mark.parametrize("path", ["curvature-first", "gravity-first"])
def test_coarse_start_finds_the_path_s_branch_with_fewer_fine_factorisations(path):
    # the bistable rectangle: each path selects its own branch (d 0.05 aloft, 0.59 drooped)
    sheet = Sheet(1.3, 1.0, 2.5)
    full = solve(sheet, path=path, hmax=0.1, start="path")
    fast = solve(sheet, path=path, hmax=0.1, start="coarse", coarse_hmax=0.12)
    assert fast.converged and fast.coarse_fallback == ""
    assert fast.branch == full.branch and fast.stable is True
    # same equilibrium: the stopping tolerance (utol 1e-6) bounds the difference,
    # a tight solve from either end state makes it round-off
    assert fast.deflection == pytest.approx(full.deflection, rel=1e-4)
    assert _polished(fast) == pytest.approx(_polished(full), rel=1e-9)
    assert fast.dofs == full.dofs
    # the fine mesh only finishes: a few Newton iterations, one load step
    assert fast.steps[-1][0] == "fine" and fast.steps[-1][2] == fast.newton_iterations
    assert fast.factorizations <= 6 < full.factorizations
    assert fast.coarse_factorizations > 0 and fast.coarse_newton_iterations > 0
    assert full.coarse_factorizations == 0 and full.start == "path"
    rec = fast.to_record()
    assert list(rec) == [name for name, _, _ in Result.RECORD_FIELDS]
    assert (rec["start"], rec["coarse_hmax"], rec["coarse_fallback"]) == ("coarse", 0.12, "")
    assert rec["coarse_factorizations"] == fast.coarse_factorizations
    assert fast.summary()["coarse_factorizations"] == fast.coarse_factorizations


def test_no_coarser_mesh_runs_the_path():
    sheet = Sheet(length=0.8, curvature=2.0)
    full = solve(sheet, hmax=0.15, start="path")
    same = solve(sheet, hmax=0.15, start="coarse", coarse_hmax=0.15)
    assert "not coarser" in same.coarse_fallback
    assert same.deflection == full.deflection
    assert same.factorizations == full.factorizations and same.coarse_factorizations == 0
    # the default start is "coarse": on a mesh at least as coarse as COARSE_HMAX it runs the path
    default = solve(sheet, hmax=0.15)
    assert default.start == "coarse" and "not coarser" in default.coarse_fallback
    assert default.deflection == full.deflection


@pytest.fixture(scope="module")
def popping_sheet_full_path():
    # a/R = 6, L/a = 1.3: gravity-first loses the drooped branch in the curvature
    # ramp (at about 0.47 of it on these meshes) and pops up
    sheet = Sheet(1.3, 1.0, 6.0)
    return sheet, solve(sheet, path="gravity-first", hmax=0.15, symmetric=False, start="path")


# FOLD_SHIFT -1: no end of the fine branch counts as near the coarse fold (0 is
# not enough: since the jump guard both meshes' paths take the same steps here,
# and the fine branch ends exactly at the coarse snap's load)
@pytest.mark.parametrize("fold_shift", [None, -1.0])
def test_a_late_coarse_snap_resumes_the_fine_path_before_it(monkeypatch, popping_sheet_full_path,
                                                            fold_shift):
    # A snap that late in the last phase does not decide the fine mesh's branch:
    # with LATE_SNAP = 0.6 the fine path resumes from the coarse state
    # RESUME_MARGIN before the snap, and the fine mesh decides: its branch ends
    # near the coarse fold (FOLD_SHIFT), so the sheet snaps there and the coarse
    # end state is finished; with FOLD_SHIFT < 0 the fine path goes on from where
    # its branch ended and snaps itself.  Either way the state, the snap and the
    # label are those of the fine mesh's full path
    sheet, full = popping_sheet_full_path
    monkeypatch.setattr(solve_module, "LATE_SNAP", 0.6)
    if fold_shift is not None:
        monkeypatch.setattr(solve_module, "FOLD_SHIFT", fold_shift)
    back = solve(sheet, path="gravity-first", hmax=0.15, symmetric=False, start="coarse",
                 coarse_hmax=0.2)
    assert len(full.snaps) == 1 and full.snaps[0][1] > 0.4
    assert back.converged and back.coarse_fallback == "" and back.stable is True
    assert "snapped late in its curvature phase" in back.coarse_resume
    assert back.branch == full.branch == "curvature-dominated"
    # one snap, the fine mesh's (to about a snap step: the last load its branch held)
    assert len(back.snaps) == 1 and back.snaps[0][0] == "curvature"
    # The full path records its snap at the first load past the fold (0.5 here),
    # the resumed one at the last load its branch held: the fine fold lies
    # between the full path's last held load and its snap, so the resumed
    # record lies in [last held - 0.03, snap] (the bound was abs=0.03 around the
    # snap, which one snap step, 1/32, already exceeds when both meshes' paths
    # take the same steps, as they do since the jump guard)
    held = max(lam for phase, lam, _ in full.steps
               if phase == "curvature" and lam < full.snaps[0][1])
    assert held - 0.03 <= back.snaps[0][1] <= full.snaps[0][1]
    # the resumed load: a fine Newton step RESUME_MARGIN before the coarse snap
    resumed = next(s for s in back.steps if s[0] == "fine")
    assert resumed[1] < back.snaps[0][1] - solve_module.RESUME_MARGIN
    if fold_shift is None:
        assert "snapped onto the coarse path's branch" in back.coarse_resume
        assert back.steps[-1][:2] == ("fine", 1.0)
        # the fine snap settle is skipped: far less fine work than the full path
        assert back.factorizations < 0.8 * full.factorizations
    else:
        assert back.steps[-1][:2] == ("curvature", 1.0)
    # the same equilibrium, both polished to FINAL_UTOL
    assert back.deflection == pytest.approx(full.deflection, rel=1e-7)
    assert back.coarse_factorizations > 0 and back.factorizations > 0
    assert back.to_record()["coarse_resume"] == back.coarse_resume


def test_a_coarse_snap_before_the_late_window_is_finished_without_a_resume(
        popping_sheet_full_path):
    # the coarse snap (about 0.47 of the curvature ramp) lies further than
    # FOLD_SHIFT from full load, so the fine fold lies before full load too: the
    # sheet snaps on the fine mesh as well, and the coarse end state is finished
    # there with no fine path through the fold (which is what made the resumed
    # probe cost 37 fine factorisations at hmax 0.03 on L 1.474, a/R 4.845)
    sheet, full = popping_sheet_full_path
    assert solve_module.LATE_SNAP == solve_module.FOLD_SHIFT
    r = solve(sheet, path="gravity-first", hmax=0.15, symmetric=False, start="coarse",
              coarse_hmax=0.2)
    assert len(full.snaps) == 1 and full.snaps[0][1] < 1 - solve_module.LATE_SNAP
    assert r.converged and r.coarse_fallback == "" and r.coarse_resume == ""
    assert r.stable is True and r.branch == full.branch == "curvature-dominated"
    assert len(r.snaps) == 1 and r.steps[-1][:2] == ("fine", 1.0)
    assert r.deflection == pytest.approx(full.deflection, rel=1e-7)
    assert r.factorizations < 0.5 * full.factorizations


def test_a_fine_branch_that_holds_to_full_load_is_not_snapped(monkeypatch):
    # the bistable rectangle's gravity-first path holds its branch on both meshes;
    # a late snap recorded on the coarse path (made up here) makes the fine path
    # resume before it, and the fine mesh, whose branch reaches full load, decides:
    # no snap, the path's own branch, the full path's state
    sheet = Sheet(1.3, 1.0, 2.5)
    full = solve(sheet, path="gravity-first", hmax=0.1, start="path")
    real = solve_module.follow_path

    def coarse_snaps_late(problem, *args, **kwargs):
        out = real(problem, *args, **kwargs)
        if problem.sheet_mesh.hmax == 0.12 and out.converged:
            # late: within LATE_SNAP of full load
            out.snaps.append(("curvature", 0.95, 2.375, 1.0))
        return out

    monkeypatch.setattr(solve_module, "follow_path", coarse_snaps_late)
    r = solve(sheet, path="gravity-first", hmax=0.1, coarse_hmax=0.12)
    assert r.converged and r.coarse_fallback == "" and "resumed at curvature" in r.coarse_resume
    assert r.snaps == () and r.branch == full.branch == "gravity-dominated"
    assert r.deflection == pytest.approx(full.deflection, rel=1e-7)
    fine = next(s for s in r.steps if s[0] == "fine")
    assert fine[1] <= 0.95 - solve_module.RESUME_MARGIN and r.steps[-1][:2] == ("curvature", 1.0)


def test_no_late_snap_means_no_resume():
    # the bistable rectangle's gravity-first path holds its branch: nothing to resume
    r = solve(Sheet(1.3, 1.0, 2.5), path="gravity-first", hmax=0.1, coarse_hmax=0.12)
    assert r.coarse_resume == "" and r.coarse_fallback == "" and not r.snaps


@pytest.mark.parametrize("path", ["curvature-first", "gravity-first"])
def test_both_starts_are_polished_to_the_same_deflection(path):
    # the final polish (back-substitutions with the last factorisation) makes
    # the two starts agree in d to FINAL_UTOL, far below the Newton utol 1e-6
    sheet = Sheet(1.3, 1.0, 2.5)
    full = solve(sheet, path=path, hmax=0.1, start="path")
    fast = solve(sheet, path=path, hmax=0.1, start="coarse", coarse_hmax=0.12)
    assert full.polish_iterations >= 1 and fast.polish_iterations >= 1
    assert abs(fast.deflection - full.deflection) <= 1e-7 * abs(full.deflection)
    # the polish is the tight solve's answer
    assert full.deflection == pytest.approx(_polished(full), rel=1e-8)
    assert full.to_record()["polish_iterations"] == full.polish_iterations


def test_a_failed_fine_finish_falls_back(monkeypatch):
    # a transferred state that Newton cannot finish (here: the reference state
    # at full load, whose first correction exceeds the branch guard) must not
    # be reported: the path runs on the fine mesh, and the failed attempt's
    # factorisation is counted with the fine mesh's work
    sheet = Sheet(length=0.8, curvature=2.0)
    full = solve(sheet, hmax=0.1, start="path")
    monkeypatch.setattr(solve_module, "transfer", lambda old, w, new: np.zeros(new.ndof))
    back = solve(sheet, hmax=0.1, start="coarse", coarse_hmax=0.2)
    assert back.coarse_fallback.startswith("fine Newton from the coarse state failed")
    # (the same path; the fine solver's earlier use may change round-off)
    assert back.deflection == pytest.approx(full.deflection, rel=1e-12) and back.converged
    assert back.factorizations == full.factorizations + 1
    assert back.coarse_factorizations > 0


def test_a_coarse_state_too_far_for_newton_goes_through_an_intermediate_mesh(monkeypatch):
    # the first Newton finish (coarse -> fine) is made to fail; the detour
    # coarse -> mid -> fine must then find the fine path's equilibrium, with
    # the mid mesh's work counted as coarse
    from skfem_sheet.newton import NewtonResult

    sheet = Sheet(length=0.8, curvature=2.0)
    full = solve(sheet, hmax=0.1)
    real, meshes = solve_module.newton, []

    def fails_once(problem, w, *args, **kwargs):
        meshes.append(problem.sheet_mesh.hmax)
        if len(meshes) == 1:
            return NewtonResult(w, False, 0, "max iterations")
        return real(problem, w, *args, **kwargs)

    monkeypatch.setattr(solve_module, "newton", fails_once)
    via = solve(sheet, hmax=0.1, start="coarse", coarse_hmax=0.2)
    assert meshes == pytest.approx([0.1, np.sqrt(0.02), 0.1])
    assert via.coarse_fallback == "" and via.converged and via.stable is True
    assert [s[0] for s in via.steps[-2:]] == ["intermediate", "fine"]
    assert via.factorizations == via.steps[-1][2]
    assert via.coarse_factorizations > via.steps[-2][2] > 0
    assert via.deflection == pytest.approx(full.deflection, rel=1e-4)


def _fake_fine_inertia(monkeypatch, fake):
    """Make the inertia of the fine mesh (hmax 0.1) read ``fake(solver, calls)``
    while ``fake`` returns a verdict (the real one once it returns None);
    patched wherever a verdict is read, so a check of its own in
    :mod:`skfem_sheet.solve` would see it too."""
    import skfem_sheet.continuation as continuation

    real, calls = continuation.stability, []

    def inertia(problem, solver):
        if problem.sheet_mesh.hmax == 0.1:
            calls.append(getattr(solver, "name", ""))
            out = fake(solver, calls)
            if out is not None:
                return out
        return real(problem, solver)

    monkeypatch.setattr(continuation, "stability", inertia)
    monkeypatch.setattr(solve_module, "stability", inertia, raising=False)
    return calls


def test_coarse_finish_rechecks_a_singular_looking_verdict(monkeypatch):
    # (False, 0): "not positive definite" without a negative eigenvalue, read off
    # Newton's last tangent; the shared end-state check refactorises at the end
    # state and reads it again, as the load path does, instead of falling back
    from skfem_sheet.continuation import end_state_verdict

    assert solve_module.end_state_verdict is end_state_verdict
    sheet = Sheet(length=0.8, curvature=2.0)
    calls = _fake_fine_inertia(monkeypatch, lambda s, calls: (False, 0) if len(calls) == 1 else None)
    r = solve(sheet, hmax=0.1, start="coarse", coarse_hmax=0.2)
    assert len(calls) == 2  # the first read, then once more at the end state
    assert r.coarse_fallback == "" and r.stable is True and r.negative_eigenvalues == 0
    assert r.factorizations == r.steps[-1][2] + 1


def test_coarse_finish_asks_superlu_when_the_solver_cannot_tell(monkeypatch):
    # the solver's inertia unknown (e.g. perturbed pivots) at the end state and
    # after refactorising there: the shared check asks a SuperLU factorisation
    sheet = Sheet(length=0.8, curvature=2.0)
    full = solve(sheet, hmax=0.1)
    calls = _fake_fine_inertia(monkeypatch,
                               lambda s, calls: None if s.name == "superlu" else (None, None))
    r = solve(sheet, hmax=0.1, start="coarse", coarse_hmax=0.2)
    assert calls[-1] == "superlu" and len(calls) == 3
    assert r.coarse_fallback == "" and r.stable is True
    assert r.factorizations == r.steps[-1][2] + 2
    assert r.deflection == pytest.approx(full.deflection, rel=1e-4)


@pytest.mark.parametrize("kwargs, name", [
    (dict(start="fine"), "start"), (dict(start="coarse", coarse_hmax=0.0), "coarse_hmax"),
    (dict(coarse_hmax=-1.0), "coarse_hmax")])
def test_bad_start_arguments(kwargs, name):
    with pytest.raises(ParameterError, match=name):
        solve(Sheet(length=0.5), hmax=0.2, **kwargs)


@pytest.mark.slow
def test_flat_rectangle_from_a_coarse_start_matches_heavy_elastica_at_paper_resolution():
    from tests.test_solve import heavy_elastica

    r = solve(Sheet(length=1.0), hmax=0.03, start="coarse")
    assert r.coarse_fallback == "" and r.factorizations <= 10
    assert r.deflection == pytest.approx(heavy_elastica(1.0), rel=5e-3)


def test_the_default_coarse_mesh_runs_only_where_it_is_twice_as_coarse(monkeypatch):
    """With ``coarse_hmax`` at its default (0.1) and hmax 0.08 the coarse path
    would cost about as much as the path (issue-17 sheet: 98 coarse + 38 fine
    Newton iterations against 75): the path runs, and says why; an explicit
    coarse mesh as close is still used."""
    import sys

    solve_module = sys.modules["skfem_sheet.solve"]  # (the package exports the function)
    calls = []
    real = solve_module._coarse_to_fine
    monkeypatch.setattr(solve_module, "_coarse_to_fine",
                        lambda *a, **k: calls.append(1) or real(*a, **k))
    sheet = Sheet(length=0.5, curvature=1.0)
    near = solve(sheet, hmax=0.08)
    assert near.converged and not calls and near.coarse_factorizations == 0
    assert "less than 2 times coarser" in near.coarse_fallback
    explicit = solve(sheet, hmax=0.08, coarse_hmax=0.12)
    assert explicit.converged and calls and explicit.coarse_fallback == ""
    assert explicit.deflection == pytest.approx(near.deflection, rel=1e-6)
