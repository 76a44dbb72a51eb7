"""``figure all`` (skfem_sheet.figures.batch, .work): every figure in one run, its summary.

The computations under the figures' caches are replaced by cheap stand-ins
with known counters (a map point: 10 Newton linearisations; a fold curve: 12
factorisations; fig3's solves 20, figS1's 7, figS3's and figS4's 5 each),
while the real data functions, caches, journals and drawings run: the
summary's counts must be the stand-ins' sums, the figures share the fold map
and the fold curves, and a second run computes nothing.
"""
import concurrent.futures
import contextlib
import json
import math
from types import SimpleNamespace

import numpy as np
import pytest

pd = pytest.importorskip("pandas")

import skfem_sheet.reduced as reduced  # noqa: E402
from skfem_sheet import figures  # noqa: E402
from skfem_sheet.cli import main  # noqa: E402
from skfem_sheet.figures import (  # noqa: E402
    batch,
    figure3,
    figure_switching,
    figureS1,
    figureS3,
    figureS4,
    work,
)
from skfem_sheet.params import ParameterError  # noqa: E402
from skfem_sheet.reduced import maps  # noqa: E402
from skfem_sheet.studies import foldmap, runner  # noqa: E402

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
COST = {"map": 10, "curve": 12, "fig3": 20, "figS1": 7, "figS3": 5, "figS4": 5,
        "switching": 4}


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    import matplotlib.pyplot as plt

    plt.close("all")


def _curve_json(L, d):
    return json.dumps({"lengths": [float(x) for x in L], "deflection": [float(x) for x in d],
                       "stable": [True] * len(L)})


def _map_row(point):
    """A fold-map record (not bistable) with the stand-in's counter."""
    b, c = float(point["tip_width"]), float(point["curvature"])
    L = np.round(np.arange(point["length_min"], point["length_max"] + 1e-9, 0.1), 6)
    t = 1.0 + 0.1 * c
    d = np.where((L < t) & (c > 0), -0.01 * c * L, 0.15 * L**2 * (1 + b))
    rec = foldmap._empty_record(dict(point), foldmap.map_key(point))
    rec.update(curvature_dominated=_curve_json(L, d), gravity_dominated=_curve_json(L[::-1],
                                                                                  d[::-1]),
               transition_length=math.nan if c == 0 else t, converged=True,
               newton_iterations=COST["map"], wall_time_s=1.0 + c,
               curvature_dominated_snapped=False, gravity_dominated_snapped=False)
    return foldmap.computed_record(point, foldmap.map_key, foldmap._empty_record,
                                   lambda p, r: r.update(rec))


def _trace(c, **kw):
    """A fold curve in (L, b/a) through a cusp at b/a 0.6."""
    L1, L0, Ls = 1.3 + 0.05 * c, 1.1 + 0.03 * c, 1.2 + 0.04 * c
    return SimpleNamespace(
        second="tip_width", cusp={"tip_width": 0.6, "length": Ls}, standout_length=L1,
        popup_length=L0, cusp_located="fold coefficient", bistable=True, completed=True,
        points=({"tip_width": 1.0, "length": L1, "kind": "standout"},
                {"tip_width": 0.8, "length": 0.5 * (L1 + Ls), "kind": "standout"},
                {"tip_width": 0.6, "length": Ls, "kind": "standout"},
                {"tip_width": 0.8, "length": 0.5 * (L0 + Ls), "kind": "popup"},
                {"tip_width": 1.0, "length": L0, "kind": "popup"}),
        factorizations=COST["curve"], factorizations_per_point=2.4, remeshes=0, reason="",
        wall_time_s=c)


def _trace_in_curvature(b, c, **kw):
    """The rectangle's curve in (L, a/R), its cusp at a/R 1.2."""
    return SimpleNamespace(
        second="curvature", cusp={"curvature": 1.2, "length": 0.95}, standout_length=1.4,
        popup_length=1.2, cusp_located="fold coefficient", bistable=True, completed=True,
        points=({"curvature": c, "length": 1.4, "kind": "standout"},
                {"curvature": 1.2, "length": 0.95, "kind": "standout"},
                {"curvature": c, "length": 1.2, "kind": "popup"}),
        factorizations=COST["curve"], factorizations_per_point=4.0, remeshes=0, reason="",
        wall_time_s=2.0)


def _surface(sheet, path, hmax):
    X = np.array([[0, -.5, 0], [1, -.5, -.2], [1, .5, -.2], [0, .5, 0.]]) * (1 + sheet.tip_width)
    return {"X": X, "tri": np.array([[0, 1, 2], [0, 2, 3]]), "psi": np.array([.01, .02]),
            "deflection": 0.2, "converged": True, "message": "", "snapped": False,
            "hmax": float(hmax), "factorizations": COST["fig3"], "wall_time_s": 0.5}


def _convergence_row(m):
    h = m["hmax"] / 2 ** m["refine"]
    return pd.DataFrame([{**m, "h": h, "dofs": 100, "deflection": -0.077 + 0.3 * h**2,
                          "converged": True, "wall_time_s": 0.1,
                          "factorizations": COST["figS1"]}])


def _grid(sheet, hmax, n_s, n_t):
    s = np.linspace(0, sheet.length, n_s)
    t = np.tile(np.linspace(-.5, .5, n_t), (n_s, 1))
    f = np.outer(s, np.ones(n_t)) * 1e-4
    return {"s": s, "t": t, "E_ss": f, "E_st": f, "E_tt": f, "T_ss": f, "T_tt": f, "u": f,
            "v": f, "w": f, "hmax": float(hmax), "dofs": 10, "layers": 2, "converged": True,
            "deflection": 0.0, "factorizations": COST["figS3"], "wall_time_s": 0.2}


def _sections(sheet, hmax, n_t):
    t = np.tile(np.linspace(-.5, .5, n_t), (3, 1))
    return {"s": np.array([.4, .8, 1.2]), "t": t, "u": t**4 * 1e-3, "v": t**3 * 1e-3,
            "w": t**2 * 1e-2, "angle": np.zeros(3), "hmax": float(hmax), "dofs": 10,
            "layers": 2, "converged": True, "factorizations": COST["figS4"],
            "wall_time_s": 0.2}


def _switching(sheet, **kw):
    """The switching figure's inset: a toy S (the synthetic map has no bistable
    window, so no other length is analysed)."""
    csv = ("force,tip_displacement,deflection,energy,stiffness,negative_eigenvalues,kind\n"
           "0.0,-0.04,0.05,0.0,0.06,0,start\n-0.0015,-0.08,0.08,0.0,0.0,0,fold\n"
           "0.0,-0.11,0.11,0.0,-0.06,1,saddle\n0.0027,-0.29,0.3,0.0,0.0,0,fold\n"
           "0.0,-0.57,0.57,0.0,0.02,0,end\n")
    return SimpleNamespace(curve=SimpleNamespace(to_csv=lambda: csv, wall_time_s=0.1,
                                                 factorizations=COST["switching"]))


class _Branch:
    def __init__(self, lengths, direction):
        L = np.sort(np.asarray(lengths, float))
        self.lengths = L[::-1] if direction == "decreasing" else L
        self.deflection = 0.1 * self.lengths
        self.converged = np.ones(L.size, bool)
        self.jumped = np.zeros(L.size, bool)


@pytest.fixture
def stand_ins(monkeypatch):
    """Every computation under the caches replaced; returns the calls of each kind."""
    calls = {k: [] for k in ("map", "curve", "fig3", "figS1", "figS3", "figS4", "ribbon",
                             "switching")}

    def record(kind, fn):
        def wrapped(*args, **kw):
            calls[kind].append(args[:2])
            return fn(*args, **kw)
        return wrapped

    monkeypatch.setattr(foldmap, "_run_map_point", record("map", _map_row))
    monkeypatch.setattr(foldmap, "trace_fold_curve", record("curve", _trace))
    monkeypatch.setattr(foldmap, "trace_curvature_fold_curve",
                        record("curve", _trace_in_curvature))
    monkeypatch.setattr(figure3, "_solve_surface", record("fig3", _surface))
    monkeypatch.setattr(figureS1, "_solve_row", record("figS1", _convergence_row))
    monkeypatch.setattr(figureS3, "_grid_data", record("figS3", _grid))
    monkeypatch.setattr(figureS4, "_sections_data", record("figS4", _sections))
    monkeypatch.setattr(figure_switching, "switching", record("switching", _switching))
    monkeypatch.setattr(reduced, "ribbon_continuation", record(
        "ribbon", lambda template, lengths, direction="increasing", **kw:
        _Branch(lengths, direction)))
    monkeypatch.setattr(maps, "ribbon_map", record(
        "ribbon", lambda c, lengths, tips, **kw: [
            dict(curvature=c, tip_width=float(b), length=float(L), direction=dr,
                 deflection=float(L) - 1.0, converged=True, stable=True, jumped=False)
            for b in tips for dr in ("increasing", "decreasing") for L in lengths]))
    return calls


def _by_name(runs):
    return {r.name: r for r in runs}


def _step(run, what):
    (step,) = [s for s in run.steps if s.what == what]
    return step


def test_figure_all_draws_every_figure_and_sums_the_stand_ins(stand_ins, tmp_path):
    data, out = tmp_path / "data", tmp_path / "out"
    runs = figures.make_all("quick", out, data, progress=False, workers=1)
    names = [r.name for r in runs]
    # fig2's and fig4's rows first, in one batch; then every figure
    assert names[0] == "fig2+fig4-rows" and runs[0].out == ""
    assert sorted(names[1:]) == sorted(figures.FIGURES)
    assert names.index("fig7") < names.index("fig6")
    assert not [r.error for r in runs if r.error]
    for name in figures.FIGURES:
        assert (out / f"{name}.png").read_bytes()[:8] == PNG_MAGIC
    # the summary's counts are the stand-ins': every call once, each at its cost
    n = {k: len(v) for k, v in stand_ins.items()}
    assert n["fig3"] == 6 and n["figS3"] == n["figS4"] == 1
    assert n["curve"] == len(figures.data.fold_curve_points("quick")) == 18
    # no map point computed twice
    assert n["map"] == len({(p["curvature"], p["tip_width"]) for p, in stand_ins["map"]})
    solves = sum(n[k] for k in COST)
    factorizations = sum(n[k] * COST[k] for k in COST)
    assert sum(r.solves for r in runs) == solves
    assert sum(r.factorizations for r in runs) == factorizations
    by = _by_name(runs)
    assert by["fig3"].solves == 6 and by["fig3"].factorizations == 6 * COST["fig3"]
    assert by["figS1"].factorizations == n["figS1"] * COST["figS1"]
    # shared data: fig5's map points are fig2's, fig6's two curves are among fig7's 18
    # fig4's b/a = 0, 1 rows are fig2's: 8 + 12 - 4 rows in the batch, which the figures read
    assert _step(by["fig2+fig4-rows"], "fold map").computed == 16
    assert _step(by["fig2+fig4-rows"], "fold map").factorizations == 16 * COST["map"]
    assert (_step(by["fig2"], "fold map").computed, _step(by["fig2"], "fold map").cached) == (0, 8)
    assert _step(by["fig5"], "fold map").computed == 0
    assert _step(by["fig5"], "fold map").cached == 4
    assert (_step(by["fig4"], "fold map").computed, _step(by["fig4"], "fold map").cached) == (0, 12)
    assert _step(by["fig7"], "fold curves").computed == 18
    assert _step(by["fig7"], "fold curves").factorizations == 18 * COST["curve"]
    assert _step(by["fig7"], "fold curves").longest == "a/R 5 (5 s)"
    fig6_curves = _step(by["fig6"], "fold curves")
    assert (fig6_curves.computed, fig6_curves.cached) == (0, 2)
    # the summary files say the same
    summary = json.loads((out / "summary.json").read_text())
    assert [f["name"] for f in summary["figures"]] == names
    assert summary["total"]["solves"] == solves
    assert summary["total"]["factorizations"] == factorizations
    assert summary["quality"] == "quick" and summary["total"]["failed"] == []
    text = (out / "summary.txt").read_text().splitlines()
    assert text[1].split()[:2] == ["figure", "wall"]
    assert [line.split()[0] for line in text[2:]] == names + ["total"]
    assert text[-1].split()[3:5] == [str(solves), str(factorizations)]

    # again, from the filled data folder, by command: nothing is computed
    before = {k: len(v) for k, v in stand_ins.items()}
    assert main(["figure", "all", "--quality", "quick", "--data-dir", str(data),
                 "--out-dir", str(out), "--workers", "1", "--quiet"]) == 0
    assert {k: len(v) for k, v in stand_ins.items()} == before
    again = json.loads((out / "summary.json").read_text())
    assert again["total"]["solves"] == again["total"]["factorizations"] == 0
    # each figure reads back what it computed or read the first time
    assert {f["name"]: f["cached"] for f in again["figures"]} == {
        r.name: r.solves + r.cached for r in runs}
    assert not [s for f in again["figures"] for s in f["steps"] if s["computed"]]
    assert all(f["dominated"].startswith(("drawing", "fold", "FE", "ribbon"))
               for f in again["figures"])


def test_a_failing_figure_is_recorded_and_the_others_drawn(stand_ins, tmp_path, monkeypatch,
                                                          capsys):
    def broken(**kw):
        raise RuntimeError("boom")

    monkeypatch.setitem(figures.FIGURES, "fig3", broken)
    runs = figures.make_all("quick", tmp_path / "o", tmp_path / "d", progress=False,
                            names=["fig3", "figS4"])
    by = _by_name(runs)
    assert by["fig3"].error == "RuntimeError: boom" and by["fig3"].out == ""
    assert by["fig3"].dominated == "failed: RuntimeError: boom"
    assert not by["figS4"].error and (tmp_path / "o" / "figS4.png").exists()
    assert not (tmp_path / "o" / "fig3.png").exists()
    summary = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert summary["total"]["failed"] == ["fig3"]
    # by command: exit code 1, the failure named on stderr
    assert main(["figure", "all", "--data-dir", str(tmp_path / "d"), "--workers", "1",
                 "--out-dir", str(tmp_path / "o2"), "--quiet"]) == 1
    assert "fig3 failed: RuntimeError: boom" in capsys.readouterr().err


def test_bad_input_before_anything_is_computed(tmp_path):
    with pytest.raises(ParameterError, match="names must be some of fig2, fig3"):
        figures.make_all("quick", tmp_path, tmp_path, names=["fig9"])
    with pytest.raises(ParameterError, match="quality must be one of quick, paper"):
        figures.make_all("draft", tmp_path, tmp_path)
    blocker = tmp_path / "file"
    blocker.write_text("")
    with pytest.raises(ParameterError, match="out_dir must be a writable folder"):
        figures.make_all("quick", blocker, tmp_path)
    assert not list(tmp_path.glob("*.png"))


def test_cli_accepts_all_and_names_the_allowed_figures(capsys, tmp_path):
    from skfem_sheet.cli import build_parser

    args = build_parser().parse_args(["figure", "all", "--out-dir", "o", "--quality", "paper"])
    assert (args.name, args.out_dir, args.quality) == ("all", "o", "paper")
    with pytest.raises(SystemExit) as err:
        main(["figure", "fig9"])
    assert err.value.code == 2
    msg = capsys.readouterr().err
    assert msg.count("\n") == 1 and "invalid choice: 'fig9'" in msg
    assert all(f"'{name}'" in msg for name in [*figures.FIGURES, "all"])
    # --out is one file: not with all; --out and --out-dir not together
    assert main(["figure", "all", "--out", str(tmp_path / "x.png")]) == 2
    msg = capsys.readouterr().err
    assert msg.count("\n") == 1 and "with NAME all give --out-dir" in msg
    assert main(["figure", "fig2", "--out", "a.png", "--out-dir", str(tmp_path)]) == 2
    assert "not both" in capsys.readouterr().err


def test_summary_table_and_dominant_step():
    steps = (work.DataStep("fold map", computed=3, cached=5, solves=3, factorizations=30,
                           wall_time_s=9.0, longest="b/a 1, a/R 5 (6 s)"),
             work.DataStep("ribbon model", cached=8, wall_time_s=0.5, finite_elements=False))
    run = work.FigureRun("fig5", "fig5.png", 10.0, steps)
    assert (run.solves, run.factorizations, run.cached) == (3, 30, 5)  # not the ribbon's
    assert run.draw_s == pytest.approx(0.5)
    assert run.dominated == "fold map: 3 computed (90%), longest b/a 1, a/R 5 (6 s)"
    cached = work.FigureRun("fig2", "fig2.png", 2.0, (work.DataStep("fold map", cached=8,
                                                                    wall_time_s=0.4),))
    assert cached.dominated == "drawing (80%)"
    lines = work.summary_text([run, cached], "title").splitlines()
    assert lines[0] == "title" and lines[-1].split() == ["total", "12.0", "2.1", "3", "30",
                                                        "13"]
    assert len({len(line.split("  dominated")[0]) for line in lines[1:2]}) == 1
    assert batch.run_order(["fig7", "fig6"]) == ["fig7", "fig6"]
    assert batch.run_order(["fig6", "fig2", "fig7"]) == ["fig7", "fig6", "fig2"]


def test_the_figures_with_their_own_solves_are_drawn_beside_the_others(stand_ins, tmp_path,
                                                                       monkeypatch):
    # where the others run on two workers, fig3, figS1, figS3 and figS4 go to one
    # side process; the summary keeps the order of the figures drawn in turn
    # (the switching figure's analyses are drawn in turn, after the fold map's figures)
    assert batch.plan(list(figures.FIGURES), workers=2) == (
        ["fig2", "fig4", "fig5", "fig7", "fig6", "switching"],
        ["fig3", "figS1", "figS3", "figS4"])
    assert batch.plan(list(figures.FIGURES), workers=1)[1] == []
    assert batch.plan(["fig3", "figS1"], workers=2) == (["fig3", "figS1"], [])
    # the orchestration, with the side process run in this one (the stand-ins are
    # patched here only) and the fold map on one worker
    side = []

    @contextlib.contextmanager
    def here(task, names, *args):
        side.append(list(names))
        fut = concurrent.futures.Future()
        fut.set_result(task(names, *args))
        yield fut

    monkeypatch.setattr(batch, "beside", here)
    monkeypatch.setattr(batch, "plan", lambda names, workers=None: (
        [n for n in batch.run_order(names) if n not in batch.ALONGSIDE],
        [n for n in batch.run_order(names) if n in batch.ALONGSIDE]))
    out = tmp_path / "out"
    runs = figures.make_all("quick", out, tmp_path / "data", progress=False, workers=1)
    assert side == [["fig3", "figS1", "figS3", "figS4"]]
    assert [r.name for r in runs] == ["fig2+fig4-rows"] + batch.run_order(figures.FIGURES)
    assert not [r.error for r in runs if r.error]
    assert all((out / f"{n}.png").exists() for n in figures.FIGURES)
    assert _by_name(runs)["fig3"].solves == 6
    summary = json.loads((out / "summary.json").read_text())
    assert summary["beside"] == ["fig3", "figS1", "figS3", "figS4"]
    text = (out / "summary.txt").read_text().splitlines()
    assert "fig3, figS1, figS3, figS4 in a process beside them" in text[0]
    assert text[-1].startswith("elapsed ") and "the walls overlap" in text[-1]


def _on_dask() -> bool:
    """Whether this runs as a task of a Dask worker."""
    distributed = pytest.importorskip("distributed")
    try:
        distributed.get_worker()
    except ValueError:
        return False
    return True


def test_figure_all_on_a_dask_cluster_gives_the_pool_run(stand_ins, tmp_path, monkeypatch):
    """``make_all(..., scheduler=)``: the fold-map rows and the fold curves are the
    cluster's tasks, the rest stays here; the journals, PNGs' data and counts are
    the local run's, and a second run from the same data folder computes nothing."""
    import logging

    distributed = pytest.importorskip("distributed")
    where = {"map": [], "curve": []}
    for name, kind in (("_run_map_point", "map"), ("trace_fold_curve", "curve"),
                       ("trace_curvature_fold_curve", "curve")):
        fn = getattr(foldmap, name)
        monkeypatch.setattr(foldmap, name, lambda *a, fn=fn, kind=kind, **k: (
            where[kind].append(_on_dask()), fn(*a, **k))[1])
    names = ["fig2", "fig4", "fig5", "fig6", "fig7"]
    local = figures.make_all("quick", tmp_path / "o1", tmp_path / "d1", progress=False,
                             workers=1, names=names)
    assert set(where["map"]) == set(where["curve"]) == {False}
    n_local = {k: len(v) for k, v in where.items()}
    where["map"].clear()
    where["curve"].clear()
    # an in-process cluster: its worker threads see this test's stand-ins
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None, silence_logs=logging.ERROR) as cluster:
        with distributed.Client(cluster, set_as_default=False) as client:
            runs = figures.make_all("quick", tmp_path / "o2", tmp_path / "d2", progress=False,
                                    workers=1, names=names, scheduler=client)
            # every computed row and curve ran on the cluster, each once
            assert set(where["map"]) == set(where["curve"]) == {True}
            assert {k: len(v) for k, v in where.items()} == n_local
            again = figures.make_all("quick", tmp_path / "o2", tmp_path / "d2", progress=False,
                                     names=names, scheduler=client)
    assert sum(r.solves for r in again) == 0  # resumed from the data folder
    assert not [r.error for r in runs if r.error]
    # the same work; on the cluster the fold curves are traced with the shared rows
    assert [r.name for r in runs] == ["fig2+fig4-rows+curves"] + [r.name for r in local[1:]]
    for count in ("solves", "factorizations"):
        assert sum(getattr(r, count) for r in runs) == sum(getattr(r, count) for r in local)
    by = _by_name(runs)
    assert _step(by["fig2+fig4-rows+curves"], "fold curves").computed == 18
    assert (_step(by["fig7"], "fold curves").computed, _step(by["fig7"], "fold curves").cached) \
        == (0, 18)
    summary = json.loads((tmp_path / "o2" / "summary.json").read_text())
    assert summary["scheduler"].startswith("inproc://") and summary["cluster_threads"] == 2
    # the tables the PNGs are drawn from: the same records, computed elsewhere
    stamps = {"finished_at", "host", "pid", "wall_time_s", "traceback"}
    for table in ("foldmap-quick.csv", "foldcurves-quick.csv"):
        a, b = (runner.read_journal(tmp_path / d / f"{table}.journal.jsonl",
                                     key_of=lambda r: r["key"], required=("key",))
                for d in ("d1", "d2"))
        assert sorted(a) == sorted(b) and a
        for key in a:
            assert ({k: v for k, v in a[key].items() if k not in stamps}
                    == {k: v for k, v in b[key].items() if k not in stamps}), key


@pytest.mark.slow  # two coarse fold curves and four rows, on the pool and on a cluster
def test_coarse_rows_and_curves_on_a_local_cluster_are_the_local_ones(tmp_path):
    """The figures' door to the studies with a Dask cluster of two worker
    processes: the same fold-map rows and fold curves, to the bit, as on the
    studies' pool of two processes (the same code on the same machine, with
    one BLAS thread a worker on both: in a process with two, the dot products
    sum in another order, and the a/R 5 curve's points differ by 2e-7)."""
    import logging

    distributed = pytest.importorskip("distributed")
    from skfem_sheet.figures.data import Workers, fold_curve_table, fold_map_table

    rows = foldmap.map_points([0.0, 1.0], [2.5, 5.0], lengths=(0.8, 1.2), hmax=0.2, step=0.2)
    curves = foldmap.curve_points([2.5, 5.0], hmax=0.25)
    local_rows = fold_map_table(rows, "quick", tmp_path / "d1", False, 2)
    local_curves = fold_curve_table(curves, "quick", tmp_path / "d1", False, 2)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None, silence_logs=logging.ERROR) as cluster:
        w = Workers(scheduler=cluster.scheduler_address)
        dask_rows = fold_map_table(rows, "quick", tmp_path / "d2", False, w)
        dask_curves = fold_curve_table(curves, "quick", tmp_path / "d2", False, w)
    assert {r["host"] for r in [*runner.read_journal(
        tmp_path / "d2" / "foldcurves-quick.csv.journal.jsonl", key_of=lambda r: r["key"],
        required=("key",)).values()]} and dask_curves.attrs["fold_curves"]["new"] == 2
    assert len(set(dask_rows.attrs["fold_map"]["new_keys"])) == 4
    same_rows = ["key", "popup_length", "standout_length", "bistable", "converged",
                 "curvature_dominated", "gravity_dominated", "newton_iterations"]
    pd.testing.assert_frame_equal(dask_rows[same_rows], local_rows[same_rows])
    same_curves = ["key", "standout_length", "popup_length", "cusp_tip_width", "cusp_length",
                   "points", "n_points", "factorizations", "converged", "message"]
    pd.testing.assert_frame_equal(dask_curves[same_curves], local_curves[same_curves])
    assert local_curves.converged.all() and local_curves.bistable.all()
