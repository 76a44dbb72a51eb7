"""The start strategies of ``solve`` (skfem_sheet/starts.py): the load path on
a coarse mesh carried to the fine one by its located folds, against the load
path on the fine mesh itself."""
from dataclasses import replace

import numpy as np
import pytest

from skfem_sheet import Sheet, solve
from skfem_sheet.analyses.observables import tip_deflection
from skfem_sheet.continuation import StepOptions
from skfem_sheet.linalg import make_linear_solver
from skfem_sheet.newton import NewtonOptions, NewtonResult, Stats, newton
from skfem_sheet.params import ParameterError, Planform
from skfem_sheet.result import Result
from skfem_sheet.starts import CoarseStart, PathStart, make_start

starts_module = __import__("skfem_sheet.starts", fromlist=["starts"])

#: coarse meshes as close as these are cheap enough in the tests (the cost rule
#: ``min_coarsening`` is measured at the paper's meshes)
NEAR = dict(min_coarsening=1.0)


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
    fast = solve(sheet, path=path, hmax=0.1, start=CoarseStart(hmax=0.12, **NEAR))
    assert fast.converged and fast.coarse_fallback == "" and not fast.snaps
    assert fast.branch == full.branch and fast.stable is True
    # the same equilibrium, both polished
    assert abs(fast.deflection - full.deflection) <= 1e-7 * abs(full.deflection)
    assert _polished(fast) == pytest.approx(_polished(full), rel=1e-9)
    assert full.deflection == pytest.approx(_polished(full), rel=1e-8)
    assert fast.polish_iterations >= 1 and full.polish_iterations >= 1
    assert fast.dofs == full.dofs
    # the fine mesh only finishes: a few Newton iterations, one load step
    assert fast.steps[-1][0] == "fine" and fast.steps[-1][2] == fast.newton_iterations
    assert fast.factorizations <= 6 < full.factorizations
    assert fast.coarse_factorizations > 0 and fast.coarse_newton_iterations > 0
    assert full.coarse_factorizations == 0 and full.start == "path"
    rec = fast.to_record()
    assert list(rec) == [name for name, _, _ in Result.RECORD_FIELDS]
    assert (rec["start"], rec["coarse_hmax"]) == ("coarse", 0.12)
    assert rec["coarse_factorizations"] == fast.coarse_factorizations
    summary = fast.summary()
    assert summary["coarse_factorizations"] == fast.coarse_factorizations
    assert summary["start_record"]["name"] == "coarse"
    assert summary["start_record"]["fallback"] == "" and summary["start_record"]["folds"] == []


def test_a_thin_fold_pair_the_coarse_steps_crossed_is_found_and_snaps_on_the_fine_mesh():
    """Near the cusp of the bistable range (L 0.985, b 0.84, a/R 5.71
    gravity-first) the pop-up fold pair is thin: hmax 0.1 turns at 0.2618 of
    the curvature ramp, and on hmax 0.2 the ramp's steps crossed the pair
    whole (the load monotone over each step, the inertia the same at its
    ends), so the coarse start lost the snap and the branch label with it.
    The minimum of the load's rate along the coarse branch is where the fold
    search on the branch finds it (at 0.2421 on hmax 0.2); carried to hmax
    0.1 it is located at the fine path's own fold."""
    sheet = Sheet(0.985, 0.84, 5.71)
    full = solve(sheet, path="gravity-first", hmax=0.1, start="path")
    fast = solve(sheet, path="gravity-first", hmax=0.1, start=CoarseStart(hmax=0.2))
    assert fast.converged and fast.coarse_fallback == ""
    assert [s.phase for s in full.snaps] == [s.phase for s in fast.snaps] == ["curvature"]
    assert fast.snaps[0].load == pytest.approx(full.snaps[0].load, abs=1e-6)
    assert fast.snaps[0].hmax == 0.1 and fast.snaps[0].negative_eigenvalues == (0, 1)
    (fold,) = fast.start_record.folds
    assert fold["snapped"] and fold["load"] == fast.snaps[0].load
    assert abs(fold["coarse_load"] - fold["load"]) < 0.05     # hmax 0.2 against 0.1
    assert fast.factorizations < full.factorizations / 2
    assert fast.branch == full.branch
    assert fast.deflection == pytest.approx(full.deflection, rel=1e-7)


@pytest.mark.parametrize("path", ["gravity-first", "curvature-first"])
def test_the_automatic_coarse_path_is_itself_reached_from_a_coarser_mesh(path):
    """At hmax 0.05 the automatic coarse mesh is 0.1, which has one of its own
    (0.2): the path runs on 0.2, its folds and end state are carried to 0.1
    and from there to 0.05, by the same rule at each.  The rectangle at a/R 6
    gravity-first pops up (a fold inside the curvature ramp); curvature-first
    it has none.  Against the single coarse mesh 0.1: the same fold, located
    on 0.05 to the fold tolerance, the same end state, and fewer
    factorisations on 0.1."""
    sheet = Sheet(1.3, 1.0, 6.0)
    one = solve(sheet, path=path, hmax=0.05, start=CoarseStart(hmax=0.1))
    two = solve(sheet, path=path, hmax=0.05)
    assert one.converged and two.converged and two.coarse_fallback == ""
    assert one.start_record.levels == ()
    (level,) = two.start_record.levels
    assert level["hmax"] == 0.2 and level["fallback"] == "" and level["factorizations"] > 0
    assert two.coarse_hmax == 0.1
    assert two.coarse_factorizations > level["factorizations"]
    # the work on 0.1 itself (all but the 0.2 level's) is a fraction of its path's
    assert two.coarse_factorizations - level["factorizations"] < one.coarse_factorizations / 3
    assert [s.phase for s in two.snaps] == [s.phase for s in one.snaps]
    assert len(two.snaps) == (1 if path == "gravity-first" else 0)
    for a, b in zip(one.snaps, two.snaps):
        assert a.hmax == b.hmax == 0.05 and b.negative_eigenvalues == (0, 1)
        assert b.load == pytest.approx(a.load, abs=2 * StepOptions().fold_tolerance)
    assert two.branch == one.branch == "curvature-dominated"
    assert two.deflection == pytest.approx(one.deflection, rel=1e-7)
    assert two.stable is True
    assert two.summary()["start_record"]["levels"][0]["hmax"] == 0.2


def test_no_coarser_mesh_runs_the_path():
    sheet = Sheet(length=0.8, curvature=2.0)
    full = solve(sheet, hmax=0.15, start="path")
    same = solve(sheet, hmax=0.15, start="coarse", coarse_hmax=0.15)
    assert "not coarser" in same.coarse_fallback
    assert same.deflection == full.deflection
    assert same.factorizations == full.factorizations and same.coarse_factorizations == 0
    # the default start is the coarse one: at hmax 0.15 its mesh would be the
    # coarsest, 0.2, not twice as coarse, so it runs the path
    default = solve(sheet, hmax=0.15)
    assert default.start == "coarse" and "less than 2 times coarser" in default.coarse_fallback
    assert default.coarse_hmax == 0.2 and default.deflection == full.deflection


def test_the_coarse_mesh_runs_only_where_it_is_coarse_enough_to_pay():
    """``min_coarsening`` (2 by default): at hmax 0.08 the coarse path on hmax
    0.1 would cost about as much as the path itself, so the path runs, and the
    record says why; with the rule relaxed the coarse start is used and
    reaches the same state."""
    sheet = Sheet(length=0.5, curvature=1.0)
    near = solve(sheet, hmax=0.08, coarse_hmax=0.1)
    assert near.converged and near.coarse_factorizations == 0
    assert "less than 2 times coarser" in near.coarse_fallback
    used = solve(sheet, hmax=0.08, start=CoarseStart(hmax=0.1, **NEAR))
    assert used.converged and used.coarse_fallback == "" and used.coarse_factorizations > 0
    assert used.deflection == pytest.approx(near.deflection, rel=1e-7)


@pytest.fixture(scope="module")
def popping():
    """The rectangle at a/R 6, gravity-first: the drooped branch ends at a fold
    in the curvature ramp (a/R 2.72 at hmax 0.25, 2.91 at hmax 0.12) and the
    sheet pops up; the load path on hmax 0.12 and the coarse start from 0.25."""
    sheet = Sheet(1.3, 1.0, 6.0)
    full = solve(sheet, path="gravity-first", hmax=0.12, start="path")
    fast = solve(sheet, path="gravity-first", hmax=0.12, start=CoarseStart(hmax=0.25, **NEAR))
    return full, fast


def test_a_coarse_fold_inside_its_phase_is_located_on_the_fine_mesh_and_snapped_from(popping):
    full, fast = popping
    assert full.converged and fast.converged and fast.coarse_fallback == ""
    assert len(full.snaps) == len(fast.snaps) == 1
    fine, path_snap = fast.snaps[0], full.snaps[0]
    # the fine fold, located from the carried coarse one, is the fine path's own
    assert fine.hmax == 0.12 and fine.phase == "curvature"
    # Both folds are located to StepOptions.fold_tolerance (1e-5 of the phase) and
    # reported where the last Newton step on dp/dc predicts them: measured 2.8e-7
    # apart in the load.  The fold's state is known along the branch to about
    # sqrt(fold_tolerance) ~ 3e-3 (the load is quadratic there): its tip deflection
    # is asserted to 1e-3 (measured 6.4e-5 apart; 1e-5 when both folds were
    # located to 1e-9).  The landing is a point on the way, solved to the path's
    # intermediate tolerance (StepOptions.intermediate_utol: 0.0065 here; measured
    # 1.8e-4 apart; 1e-5 when it was solved to the end tolerance).
    options = StepOptions()
    assert fine.load == pytest.approx(path_snap.load, abs=2 * options.fold_tolerance)
    assert fine.fold_deflection == pytest.approx(path_snap.fold_deflection, abs=1e-3)
    assert fine.landing_deflection == pytest.approx(path_snap.landing_deflection,
                                                    abs=options.intermediate_utol(1.3))
    folds = fast.start_record.folds
    assert len(folds) == 1 and folds[0]["snapped"] and folds[0]["load"] == fine.load
    assert folds[0]["coarse_load"] < fine.load  # the fold moved with the mesh (0.454 -> 0.485)
    # the same end state (the other branch), the same label, far less fine work
    assert fast.branch == full.branch == "curvature-dominated"
    assert fast.deflection == pytest.approx(full.deflection, rel=1e-7)
    assert fast.factorizations < full.factorizations / 3


def test_a_coarse_fold_that_the_fine_mesh_has_beyond_full_load_is_not_snapped_from():
    """a/R 2.8: the coarse mesh's fold (a/R 2.72, 0.97 of the ramp) lies inside
    the curvature phase, the fine mesh's (a/R 2.91) beyond it: the fine sheet
    does not snap, and ends on the drooped branch, as the fine path does."""
    sheet = Sheet(1.3, 1.0, 2.8)
    full = solve(sheet, path="gravity-first", hmax=0.12, start="path")
    fast = solve(sheet, path="gravity-first", hmax=0.12, start=CoarseStart(hmax=0.25, **NEAR))
    assert full.converged and fast.converged and fast.coarse_fallback == ""
    assert full.snaps == () and fast.snaps == ()
    folds = fast.start_record.folds
    assert len(folds) == 1 and not folds[0]["snapped"]
    assert folds[0]["coarse_load"] < 1.0 < folds[0]["load"]
    assert fast.branch == full.branch == "gravity-dominated"
    assert fast.deflection == pytest.approx(full.deflection, rel=1e-7)
    assert fast.stable is True


def test_a_failed_fine_finish_falls_back_to_the_path(monkeypatch):
    # a transferred state that Newton cannot finish (nor the settle after it)
    # must not be reported: the path runs on the fine mesh, and the failed
    # attempt's work is counted
    sheet = Sheet(length=0.8, curvature=2.0)
    full = solve(sheet, hmax=0.1, start="path")
    real, calls = starts_module.newton, []

    def fails(problem, w, *args, **kwargs):
        calls.append(1)
        return NewtonResult(w, False, 1, "max iterations")

    monkeypatch.setattr(starts_module, "newton", fails)
    # (nor can the settle that follows a failed Newton)
    monkeypatch.setattr(starts_module, "settle", lambda problem, w, *args: (
        NewtonResult(w, False, 1, "diverging"), None))
    back = solve(sheet, hmax=0.1, start=CoarseStart(hmax=0.2, **NEAR))
    monkeypatch.setattr(starts_module, "newton", real)
    assert calls and back.coarse_fallback.startswith("fine Newton from the coarse end state failed")
    assert back.converged and back.deflection == pytest.approx(full.deflection, rel=1e-10)
    assert back.coarse_factorizations > 0


def test_a_carried_state_outside_newton_s_basin_is_settled_onto_the_path_s_state(monkeypatch):
    """Newton from the carried end state fails (measured on long sheets from
    hmax 0.2 to 0.1; here forced): the pseudo-transient settles it, and the
    end state is the path's, accepted by the same rule, without falling back."""
    sheet = Sheet(length=0.8, curvature=2.0)
    full = solve(sheet, hmax=0.1, start="path")
    real, calls = starts_module.newton, []

    def fails_once(problem, w, *args, **kwargs):
        calls.append(1)
        if len(calls) == 1:
            return NewtonResult(w, False, 1, "diverging")
        return real(problem, w, *args, **kwargs)

    monkeypatch.setattr(starts_module, "newton", fails_once)
    fast = solve(sheet, hmax=0.1, start=CoarseStart(hmax=0.2, **NEAR))
    assert len(calls) == 1     # the settle's own Newton is the continuation module's
    assert fast.converged and fast.coarse_fallback == "" and fast.stable is True
    assert fast.deflection == pytest.approx(full.deflection, rel=1e-7)
    # pseudo-transient steps and Newton on the mesh hmax, far fewer than the path's
    assert fast.steps[-1][0] == "fine" and fast.steps[-1][2] >= 2
    assert fast.factorizations < full.factorizations


def test_a_carried_snap_whose_end_state_newton_cannot_finish_goes_on_from_the_landing(
        popping, monkeypatch):
    """With a snap carried, a failed Newton at the end is settled, as without
    one (accepted by the same distance rule); where the settle fails too (here
    forced), the whole path is not run again: the load path goes on from the
    fine landing state at the fine fold (measured: L 1.3, b 1, a/R 2.5, E 100,
    curvature-first at hmax 0.1 from 0.2, 130 fine factorisations with the
    path run again, 48 from the landing, the same end state and snap)."""
    full, _ = popping
    real, calls, settles, paths = starts_module.newton, [], [], []

    def counted(*args, **kwargs):
        calls.append(1)
        return real(*args, **kwargs)

    args = (Sheet(1.3, 1.0, 6.0),)
    kwargs = dict(path="gravity-first", hmax=0.12, start=CoarseStart(hmax=0.25, **NEAR))
    monkeypatch.setattr(starts_module, "newton", counted)
    solve(*args, **kwargs)
    last = len(calls)       # the end state's Newton is the start's last call

    def fails_last(problem, w, *rest, **options):
        calls.append(1)
        if len(calls) == 2 * last:
            return NewtonResult(w, False, 1, "diverging")
        return real(problem, w, *rest, **options)

    real_path = starts_module._path

    def path(job, w0=None, resume=None, on_step=...):
        paths.append(resume)
        return real_path(job, w0=w0, resume=resume, on_step=on_step)

    def settle_fails(problem, w, *rest):
        settles.append(1)
        return NewtonResult(w, False, 1, "forced"), None

    monkeypatch.setattr(starts_module, "newton", fails_last)
    monkeypatch.setattr(starts_module, "settle", settle_fails)
    monkeypatch.setattr(starts_module, "_path", path)
    back = solve(*args, **kwargs)
    assert len(calls) >= 2 * last and settles == [1]
    assert back.coarse_fallback == ""
    # the coarse path's, then the fine path resumed at the fine fold's load
    fold = back.start_record.folds[0]
    assert fold["snapped"] and paths[-1] == ("curvature", fold["load"])
    assert [s.phase for s in back.snaps] == [s.phase for s in full.snaps] == ["curvature"]
    # the fine fold is located from the carried state to the fold tolerance, the
    # path's own from its steps (measured 5.8e-7 apart); the end state is the
    # same equilibrium (measured 1.1e-15 in d)
    assert back.snaps[0].load == pytest.approx(full.snaps[0].load,
                                               abs=StepOptions().fold_tolerance)
    assert back.deflection == pytest.approx(full.deflection, rel=1e-9)
    assert back.stable
    assert back.factorizations < full.factorizations


def test_a_coarse_fold_located_where_the_load_turns_up_is_not_snapped_from(popping,
                                                                          monkeypatch):
    """A fold where the branch's solutions lie above the fold load (side +1:
    a branch begins there as the load grows) is not where a load path's
    branch ends; the fine mesh has a fold pair there, and the path runs on the
    fine mesh instead of snapping at the wrong fold of it (measured: L 1.63,
    b 0.65, a/R 3.37, h 0.02, curvature-first at hmax 0.1 from 0.2, the
    coarse fold at 0.2349 located on the fine pair's lower fold, 0.1814; the
    path's is at 0.2185)."""
    full, _ = popping
    real = starts_module._fold_on_fine

    def lower_fold(*args):
        located = real(*args)
        return replace(located, side=1)

    monkeypatch.setattr(starts_module, "_fold_on_fine", lower_fold)
    back = solve(Sheet(1.3, 1.0, 6.0), path="gravity-first", hmax=0.12,
                 start=CoarseStart(hmax=0.25, **NEAR))
    assert "a fold where the load turns up" in back.coarse_fallback
    assert back.start_record.folds == ()
    # the path's own snap, on the fine mesh (to round-off: measured 3e-14 in the load)
    assert [s.phase for s in back.snaps] == [s.phase for s in full.snaps] == ["curvature"]
    assert back.snaps[0].load == pytest.approx(full.snaps[0].load, rel=1e-9)
    assert back.deflection == pytest.approx(full.deflection, rel=1e-9)


def test_a_fine_finish_that_leaves_the_coarse_branch_falls_back(monkeypatch):
    """The fine finish is accepted by the load path's step rule: a Newton that
    moves further than four nominal corrector distances from the carried
    state has found another branch (here: the carried state replaced by the
    reference state, from which Newton converges to the hanging sheet)."""
    sheet = Sheet(length=0.8, curvature=2.0)
    monkeypatch.setattr(starts_module, "transfer",
                        lambda old, w, new: np.zeros(new.ndof))
    back = solve(sheet, hmax=0.1, start=CoarseStart(hmax=0.2, **NEAR), on_failure="return")
    assert "another branch" in back.coarse_fallback or "failed" in back.coarse_fallback
    assert back.converged


@pytest.mark.parametrize("kwargs, name", [
    (dict(start="fine"), "start"), (dict(start="coarse", coarse_hmax=0.0), "coarse_hmax"),
    (dict(coarse_hmax=-1.0), "coarse_hmax")])
def test_bad_start_arguments(kwargs, name):
    with pytest.raises(ParameterError, match=name):
        solve(Sheet(length=0.5), hmax=0.2, **kwargs)
    with pytest.raises(ParameterError, match="min_coarsening"):
        CoarseStart(min_coarsening=0.5)


def test_the_default_coarse_mesh_is_twice_the_solve_s_between_0_1_and_0_2():
    auto = CoarseStart()
    assert [auto.coarse_mesh(h) for h in (0.02, 0.03, 0.05, 0.06, 0.08, 0.1, 0.15)] == \
        pytest.approx([0.1, 0.1, 0.1, 0.12, 0.16, 0.2, 0.2])
    assert [auto.usable_for(h) == "" for h in (0.03, 0.06, 0.1, 0.12, 0.15)] == \
        [True, True, True, False, False]
    assert CoarseStart(hmax=0.25).coarse_mesh(0.1) == 0.25
    # at hmax 0.08 the default coarse path runs on 0.16 and reaches the state
    # of the path on 0.08
    sheet = Sheet(length=0.5, curvature=1.0)
    r = solve(sheet, hmax=0.08)
    assert r.coarse_hmax == pytest.approx(0.16) and r.coarse_fallback == ""
    assert r.coarse_factorizations > 0 and r.factorizations <= 6
    assert r.deflection == pytest.approx(solve(sheet, hmax=0.08, start="path").deflection,
                                         rel=1e-7)


def test_make_start_takes_names_and_strategies():
    assert make_start("path") == PathStart()
    assert make_start("coarse", 0.2) == CoarseStart(hmax=0.2)
    assert make_start("coarse") == CoarseStart() and CoarseStart().hmax is None
    s = CoarseStart(hmax=0.3, min_coarsening=1.5)
    assert make_start(s) is s


@pytest.mark.slow
def test_flat_rectangle_from_a_coarse_start_matches_heavy_elastica_at_paper_resolution():
    from tests.test_solve import heavy_elastica

    r = solve(Sheet(length=1.0), hmax=0.03, start="coarse")
    assert r.coarse_fallback == "" and r.factorizations <= 10
    assert r.deflection == pytest.approx(heavy_elastica(1.0), rel=5e-3)


def test_a_nested_refinement_is_coarsened_by_its_edge_length_not_its_base_mesh():
    """A mesh refined ``k`` times has edges ``hmax / 2**k``: the coarse start
    chooses its coarse mesh from that (base 0.2 refined once: edges 0.1, the
    coarse path on 0.2), where by the base size it would find no coarser mesh
    and run the path on the refined mesh; the same equilibrium either way."""
    sheet = Sheet(length=0.6, curvature=2.0)
    path = solve(sheet, hmax=0.2, refine=1, start="path")
    fast = solve(sheet, hmax=0.2, refine=1)
    assert fast.coarse_fallback == "" and fast.coarse_hmax == 0.2
    assert fast.coarse_factorizations > 0 and fast.factorizations < path.factorizations
    assert fast.deflection == pytest.approx(path.deflection, rel=1e-7)


def test_two_coarse_folds_that_lead_to_one_fine_fold_are_one_snap():
    """Issue 55's rectangle (L 1.5702, a/R 5, gravity-first, hmax 0.1): the
    coarse path (hmax 0.2) snaps in two steps, at 0.7940 and 0.7951 of the
    curvature ramp, the first landing 0.057 a from its fold; both lead to one
    fold on the fine mesh.  The sheet snaps from it once and lands where the
    coarse path's second snap landed (before issue 56 it snapped twice at the
    same load, the first 'landing' within 0.002 a of its own fold).  The load
    path on the fine mesh has the same single snap (slow test below)."""
    r = solve(Sheet(length=1.5702, tip_width=1.0, curvature=5.0), path="gravity-first", hmax=0.1)
    assert r.converged and r.stable is True
    assert r.start_record.coarse_hmax == 0.2 and r.coarse_fallback == ""
    coarse_folds = r.start_record.folds
    assert len(coarse_folds) == 2 and coarse_folds[1].get("same_fine_fold") is True
    assert coarse_folds[0]["load"] == pytest.approx(coarse_folds[1]["load"], abs=2e-5)
    assert len(r.snaps) == 1
    snap = r.snaps[0]
    assert abs(snap.landing_deflection - snap.fold_deflection) > 0.1   # it moved: a snap


#: issue 56's sheets (and issue 55's rectangle), each on the path that failed
ISSUE_SHEETS = [
    (Sheet.from_planform(Planform.from_function(lambda s: 1 + 0.2 * s * s), length=1.6,
                         curvature=3.0), "curvature-first"),     # crashed in the transfer
    (Sheet.from_planform(Planform.from_function(lambda s: 1 + 0.5 * s - 0.9 * s * s),
                         length=2.0, curvature=4.0), "curvature-first"),  # the snap failed
    (Sheet.from_planform(Planform.from_function(lambda s: 1 + 0.114 * s * s), length=2.186,
                         curvature=5.476), "curvature-first"),   # the coarse path stalled
    (Sheet(length=1.5702, tip_width=1.0, curvature=5.0), "gravity-first"),  # two snaps
]


@pytest.mark.slow
@pytest.mark.parametrize("sheet, path", ISSUE_SHEETS, ids=["flare", "leaf", "flare-tip1.114",
                                                           "rectangle"])
def test_the_issue_sheets_reach_full_load_and_agree_with_the_path(sheet, path):
    """Each reaches full load with the default start and ends where the load
    path on the fine mesh ends: d to 1e-6, the same snaps (phase, and load to
    the fold tolerance of each of the two locations)."""
    fast = solve(sheet, path=path, hmax=0.1)
    full = solve(sheet, path=path, hmax=0.1, start="path")
    for r in (fast, full):
        assert r.converged and r.stable is True and r.negative_eigenvalues == (0, 0)
    assert fast.deflection == pytest.approx(full.deflection, abs=1e-6)
    assert [s.phase for s in fast.snaps] == [s.phase for s in full.snaps]
    for a, b in zip(fast.snaps, full.snaps):
        assert a.load == pytest.approx(b.load, abs=2 * StepOptions().fold_tolerance)
