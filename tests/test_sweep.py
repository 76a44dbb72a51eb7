"""Parameter sweeps (skfem_sheet.studies.sweep): grids, keys, the journal, resume, kill -9, Dask.

Logic tests replace the solver by a fake (fast, and able to fail on purpose);
the kill -9 and Dask tests solve real, coarse sheets (hmax 0.2, L <= 0.5).
"""
import json
import logging
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import skfem_sheet.studies.sweep as sw
from skfem_sheet import __version__
from skfem_sheet.cli import main
from skfem_sheet.cli.ranges import parse_values
from skfem_sheet.continuation import Snap
from skfem_sheet.mesh import estimate_dofs
from skfem_sheet.params import ParameterError, Sheet
from skfem_sheet.solve import MAX_DOFS, Result, solve
from skfem_sheet.studies import runner
from skfem_sheet.studies.sweep import grid, journal_path, point_key, read_journal, run_sweep


# -- a fake solver ---------------------------------------------------------------------------
class FakeSolve:
    """Stands in for skfem_sheet.solve.solve; its behaviour depends on the length.

    0.9: raises RuntimeError; 0.8: full load not reached; 0.7: the path snapped;
    0.6: the result knows its branch and stability.  ``interrupt_at`` raises
    KeyboardInterrupt on that call (1-based).
    """

    def __init__(self, interrupt_at=None):
        self.calls = []
        self.interrupt_at = interrupt_at

    def __call__(self, sheet, path="curvature-first", hmax=0.03, **kw):
        self.calls.append((sheet.length, sheet.curvature, path))
        if self.interrupt_at is not None and len(self.calls) == self.interrupt_at:
            raise KeyboardInterrupt
        L = sheet.length
        if L == 0.9:
            raise RuntimeError("boom in the solver")
        snaps = ((Snap("gravity", 0.5, 2.5, 0.5, 0.1, 0.6),) if L == 0.7 else ())
        # the load path's branch, the other one if it snapped (as solve labels it)
        branch = [("curvature-dominated", "gravity-dominated")[(path == "gravity-first")
                                                             != bool(snaps)]]
        stable = None
        if L == 0.6:
            branch, stable = ["gravity-dominated"], False
        return Result(
            sheet=sheet, path=path, hmax=hmax,
            deflection=L + 0.01 * sheet.curvature + (0.001 if path == "gravity-first" else 0),
            converged=L != 0.8, message="step too small at kappa=1.2" if L == 0.8 else "",
            snaps=snaps, newton_iterations=7,
            load_steps=3, wall_time_s=0.01, assembly_s=0.001, linear_solve_s=0.002, dofs=100,
            energy=-1.0, volume_change=1e-9, kappa=sheet.curvature, gravity=1.0,
            factorizations=7, rejected_steps=0, solver="fake", layers=kw.get("layers") or 2,
            branch=branch[0], stable=stable, refine=kw.get("refine", 0),
            symmetric=kw.get("symmetric", True))


@pytest.fixture
def fake(monkeypatch):
    f = FakeSolve()
    monkeypatch.setattr(sw, "solve", f)
    return f


# -- grids and keys ----------------------------------------------------------------------------
def test_grid_is_the_cartesian_product_in_signature_order():
    pts = grid(length=[1.0, 1.3], tip_width=[1.0, 0.0], curvature=[0.0, 2.5],
               path=["curvature-first", "gravity-first"], hmax=0.1)
    assert len(pts) == 16
    assert pts[0] == dict(length=1.0, tip_width=1.0, curvature=0.0, thickness=0.03,
                          modulus=735.0, path="curvature-first", hmax=0.1, layers=None,
                          solver="auto")
    # length outermost, path innermost (of the lists given)
    assert [p["path"] for p in pts[:2]] == ["curvature-first", "gravity-first"]
    assert [p["curvature"] for p in pts[:4]] == [0.0, 0.0, 2.5, 2.5]
    assert [p["length"] for p in pts] == [1.0] * 8 + [1.3] * 8
    assert len({point_key(p) for p in pts}) == 16
    both = grid(length=np.array([0.5, 1.0]), path="both", layers=[2, 3], solver="superlu")
    assert len(both) == 8 and {p["path"] for p in both} == {"curvature-first", "gravity-first"}
    assert all(type(p["length"]) is float and type(p["layers"]) is int for p in both)


def test_grid_rejects_empty_lists_and_unknown_parameters():
    with pytest.raises(ParameterError, match="curvature"):
        grid(length=1.0, curvature=[])
    with pytest.raises(TypeError):
        grid(length=1.0, width=2)
    with pytest.raises(ParameterError, match="'width'"):
        run_sweep([{"length": 1.0, "width": 2}], workers=1, progress=False)
    with pytest.raises(ParameterError, match="length"):
        run_sweep([{"curvature": 1.0}], workers=1, progress=False)


def test_key_normalises_float_noise_but_not_real_differences():
    base = point_key({"length": 1.3, "curvature": 0.0, "layers": 2})
    same = [{"length": 1.30000000001, "curvature": -0.0, "layers": 2.0},
            {"length": np.arange(0.5, 1.5, 0.1)[8], "curvature": 0, "layers": np.int64(2)},
            {"layers": 2, "curvature": 0.0, "length": np.float64(1.3)},   # order of the dict
            {"length": 1.3, "layers": 2, "thickness": 0.03, "modulus": 735, "path":
             "curvature-first", "hmax": 0.03, "solver": "auto", "tip_width": 1}]
    assert np.arange(0.5, 1.5, 0.1)[8] != 1.3  # the float noise is real
    for p in same:
        assert point_key(p) == base, p
    different = [{"length": 1.3000001, "layers": 2}, {"length": 1.3, "layers": 3},
                 {"length": 1.3, "layers": 2, "path": "gravity-first"},
                 {"length": 1.3, "layers": 2, "curvature": 1e-9},
                 {"length": 1.3, "layers": 2, "hmax": 0.031},
                 {"length": 1.3, "layers": 2, "solver": "superlu"}]
    assert len({point_key(p) for p in different} | {base}) == len(different) + 1
    assert len(base) == 16 and int(base, 16) >= 0


def test_key_does_not_depend_on_the_process():
    code = "from skfem_sheet.studies.sweep import point_key; print(point_key({'length': 1.3}))"
    env = dict(os.environ, PYTHONHASHSEED="123")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env=env, timeout=120, check=True).stdout.strip()
    assert out == point_key({"length": 1.3})


# -- rows, failures, resume ------------------------------------------------------------------
def test_failures_are_rows_and_the_sweep_carries_on(fake, tmp_path):
    pts = grid(length=[0.5, 0.6, 0.7, 0.8, 0.9], curvature=2.5, path="both")
    pts.append(dict(pts[0], tip_width=2.0))  # refused by Sheet: a ParameterError row
    df = run_sweep(pts, table=tmp_path / "t.csv", workers=1, progress=False)
    assert list(df.key) == [point_key(p) for p in pts]
    assert len(fake.calls) == 10  # the bad point never reaches the solver
    by = {(r.length, r.tip_width, r.path): r for r in df.itertuples()}
    ok = by[(0.5, 1.0, "gravity-first")]
    assert ok.converged and ok.error == "" and ok.deflection == pytest.approx(0.526)
    assert ok.branch == "gravity-dominated" and not ok.snapped and pd.isna(ok.stable)
    assert by[(0.5, 1.0, "curvature-first")].branch == "curvature-dominated"
    snapped = by[(0.7, 1.0, "curvature-first")]   # snapped: the other branch
    assert snapped.converged and snapped.snapped and snapped.branch == "gravity-dominated"
    assert by[(0.7, 1.0, "gravity-first")].branch == "curvature-dominated"
    told = by[(0.6, 1.0, "curvature-first")]      # the solver's own branch and stability win
    assert told.branch == "gravity-dominated" and told.stable == False  # noqa: E712
    nc = by[(0.8, 1.0, "curvature-first")]
    assert not nc.converged and nc.message == "step too small at kappa=1.2" and nc.error == ""
    boom = by[(0.9, 1.0, "gravity-first")]
    assert not boom.converged and boom.message == "boom in the solver"
    assert boom.error == "RuntimeError" and math.isnan(boom.deflection)
    bad = by[(0.5, 2.0, "curvature-first")]
    assert not bad.converged and bad.error == "ParameterError" and "tip_width" in bad.message
    journal = read_journal(journal_path(tmp_path / "t.csv"))
    assert "Traceback" in journal[boom.key]["traceback"]
    assert set(df.columns) >= {
        "length", "tip_width", "curvature", "thickness", "modulus", "path", "hmax", "layers",
        "solver", "deflection", "converged", "message", "branch", "stable", "snapped",
        "newton_iterations", "load_steps", "wall_time_s", "assembly_s", "linear_solve_s",
        "dofs", "energy", "volume_change", "version", "key"}
    assert set(df.version) == {__version__}


def test_the_shared_chunk_task_and_failed_record_keep_order_and_reason(fake):
    """runner.EachPoint and runner.failed_record, the two pieces every study shares."""
    import pickle

    from skfem_sheet.studies import foldmap

    pts = grid(length=[0.5, 0.9, 0.6])
    recs = pickle.loads(pickle.dumps(sw._JOB.task))(pts)  # as a spawned worker gets it
    assert [r["key"] for r in recs] == [point_key(p) for p in pts]  # one record each, in order
    assert [r["converged"] for r in recs] == [True, False, True]  # 0.9 raises: a failed record
    assert recs[1]["message"] == "boom in the solver" and recs[1]["error"] == "RuntimeError"
    died = sw._JOB.failed(pts[2], "the worker process died", "WorkerDied")
    assert died["key"] == point_key(pts[2]) and died["length"] == 0.6
    assert died["message"] == "the worker process died" and died["error"] == "WorkerDied"
    assert not died["converged"] and math.isnan(died["deflection"]) and died["finished_at"]
    mp = foldmap.map_points([0.5], [1.0])[0]
    lost = foldmap._MAP_JOB.failed(mp, "the Dask task failed: KilledWorker", "KilledWorker")
    assert lost["key"] == foldmap.map_key(mp) and lost["error"] == "KilledWorker"
    assert not lost["converged"] and math.isnan(lost["popup_length"])
    cp = foldmap.curve_points([2.5])[0]
    assert foldmap._CURVE_JOB.failed(cp, "gone", "WorkerDied")["key"] == foldmap._curve_key(cp)


def test_resume_computes_only_the_missing_points(fake, tmp_path):
    table = tmp_path / "t.csv"
    first = grid(length=[0.3, 0.4], curvature=[0.0, 2.5])
    df1 = run_sweep(first, table=table, workers=1, progress=False)
    assert len(fake.calls) == 4 and df1.attrs["sweep"]["new"] == 4
    more = grid(length=[0.3, 0.4, 0.5], curvature=[0.0, 2.5])
    more = [more[5], *more, more[0]]  # a point twice: computed once, two rows
    df2 = run_sweep(more, table=table, workers=1, progress=False)
    assert len(fake.calls) == 6  # only the two new points
    assert df2.attrs["sweep"]["new"] == 2 and df2.attrs["sweep"]["cached"] == 4
    assert list(df2.key) == [point_key(p) for p in more]
    old = df1.set_index("key")
    for r in df2[df2.key.isin(old.index)].itertuples():  # cached rows are the stored rows
        assert r.finished_at == old.loc[r.key, "finished_at"]
    run_sweep(more, table=table, workers=1, progress=False)  # drawing twice ...
    assert len(fake.calls) == 6                                # ... computes nothing twice
    lines = (tmp_path / "t.csv.journal.jsonl").read_text().splitlines()
    assert len(lines) == 6
    on_disk = pd.read_csv(table)
    assert len(on_disk) == 6 and on_disk.key.is_unique
    assert list(on_disk.key) == list(dict.fromkeys(df2.key))  # this sweep's order


def test_journal_survives_a_cut_line_garbage_and_duplicates(fake, tmp_path):
    table = tmp_path / "t.csv"
    pts = grid(length=[0.3, 0.4, 0.5])
    run_sweep(pts, table=table, workers=1, progress=False)
    jp = journal_path(table)
    lines = Path(jp).read_bytes().splitlines(keepends=True)
    assert len(lines) == 3
    dup = json.loads(lines[0])
    dup["deflection"] = 123.0  # a later line for the same point wins
    cut = lines[2][: len(lines[2]) // 2]  # a write cut short by kill -9
    with open(jp, "wb") as fh:
        fh.write(lines[0] + b"not json at all\n" + lines[1] + b"\xff\xfe\n"
                 + (json.dumps(dup) + "\n").encode() + cut)
    got = read_journal(jp)
    assert list(got) == [point_key(pts[0]), point_key(pts[1])]
    assert got[point_key(pts[0])]["deflection"] == 123.0
    df = run_sweep(pts, table=table, workers=1, progress=False)
    assert fake.calls[3:] == [(0.5, 0.0, "curvature-first")]  # only the cut point again
    assert list(df.deflection) == [123.0, pytest.approx(0.4), pytest.approx(0.5)]
    text = Path(jp).read_bytes()
    assert text.endswith(b"\n") and cut + b"\n" in text  # the cut line was ended, not extended
    assert list(read_journal(jp)) == [point_key(p) for p in pts]


def test_retry_failed_computes_failed_points_again(fake, tmp_path):
    table = tmp_path / "t.csv"
    pts = grid(length=[0.5, 0.8, 0.9])
    df = run_sweep(pts, table=table, workers=1, progress=False)
    assert list(df.converged) == [True, False, False]
    run_sweep(pts, table=table, workers=1, progress=False)
    assert len(fake.calls) == 3
    df = run_sweep(pts, table=table, workers=1, progress=False, retry_failed=True)
    assert [c[0] for c in fake.calls[3:]] == [0.8, 0.9]
    assert len(read_journal(journal_path(table))) == 3 and len(pd.read_csv(table)) == 3


def test_ctrl_c_stops_cleanly_and_keeps_finished_points(monkeypatch, tmp_path):
    table = tmp_path / "t.csv"
    monkeypatch.setattr(sw, "solve", FakeSolve(interrupt_at=3))
    pts = grid(length=[0.3, 0.4, 0.5, 0.6])
    with pytest.raises(KeyboardInterrupt) as info:
        run_sweep(pts, table=table, workers=1, progress=False)
    err = info.value
    assert isinstance(err, runner.StudyInterrupted)
    assert (err.finished, err.points, err.new, err.table) == (2, 4, 2, str(table))
    assert f"2 of 4 points are finished (2 in this run) and kept in {table}" in str(err)
    assert len(pd.read_csv(table)) == 2 and len(read_journal(journal_path(table))) == 2
    again = FakeSolve()
    monkeypatch.setattr(sw, "solve", again)
    df = run_sweep(pts, table=table, workers=1, progress=False)
    assert [c[0] for c in again.calls] == [0.5, 0.6] and df.converged.all()


def test_ctrl_c_right_after_a_journal_line_counts_that_point_as_kept(fake, monkeypatch,
                                                                      tmp_path):
    """Ctrl-C lands while a finished point's line is being written (the line is on disk,
    the loop has not counted it): the message counts what the journal holds."""
    table = tmp_path / "t.csv"
    write = runner.Journal.append
    calls = []

    def append(self, rec):
        write(self, rec)
        calls.append(rec)
        if len(calls) == 2:
            raise KeyboardInterrupt

    monkeypatch.setattr(runner.Journal, "append", append)
    with pytest.raises(runner.StudyInterrupted) as info:
        run_sweep(grid(length=[0.3, 0.4, 0.5]), table=table, workers=1, progress=False)
    assert (info.value.finished, info.value.new) == (2, 2)
    assert len(pd.read_csv(table)) == 2


def test_parquet_table_has_the_same_contents(fake, tmp_path):
    pytest.importorskip("pyarrow")
    pts = grid(length=[0.5, 0.8, 0.9], path="both")
    df = run_sweep(pts, table=tmp_path / "t.parquet", workers=1, progress=False)
    back = pd.read_parquet(tmp_path / "t.parquet")
    pd.testing.assert_frame_equal(back, df, check_dtype=False)
    assert not [f for f in os.listdir(tmp_path) if f.endswith(".tmp")]  # no temp files left


def test_bad_sweep_arguments_raise_parameter_error(fake, tmp_path, monkeypatch):
    pts = grid(length=0.5)
    with pytest.raises(ParameterError, match="table must end with"):
        run_sweep(pts, table=tmp_path / "t.txt", workers=1)
    (tmp_path / "old.csv").write_text("a,b\n1,2\n")
    with pytest.raises(ParameterError, match="without its journal"):
        run_sweep(pts, table=tmp_path / "old.csv", workers=1)
    assert (tmp_path / "old.csv").read_text() == "a,b\n1,2\n"  # untouched
    with pytest.raises(ParameterError, match="workers"):
        run_sweep(pts, workers=0)
    with pytest.raises(ParameterError, match="workers"):
        run_sweep(pts, workers=2, scheduler="tcp://127.0.0.1:1")
    monkeypatch.setitem(sys.modules, "pyarrow", None)  # as if not installed
    with pytest.raises(ParameterError, match=r"pyarrow.*skfem_sheet\[parquet\]"):
        run_sweep(pts, table=tmp_path / "t.parquet", workers=1)
    monkeypatch.setitem(sys.modules, "distributed", None)
    with pytest.raises(ParameterError, match=r"scheduler.*skfem_sheet\[cluster\]"):
        run_sweep(pts, scheduler="tcp://127.0.0.1:8786")
    assert fake.calls == []


BAD_CLI = [
    (["--lengths", "1:0:0.1"], "--lengths"),
    (["--lengths", "abc"], "--lengths"),
    (["--lengths", "0.5:1:0"], "--lengths"),
    (["--lengths=-1,1"], "length"),
    (["--lengths", "-1,1"], "--lengths"),  # argparse: an option, not a value
    (["--lengths", "1", "--tip-widths", "0:2:1"], "tip_width"),
    (["--lengths", "1", "--curvatures", "nan"], "--curvatures"),
    (["--lengths", "1", "--paths", "sideways"], "--paths"),
    (["--lengths", "1", "--hmax", "0"], "hmax"),
    (["--lengths", "1", "--layers", "1.5"], "--layers"),
    (["--lengths", "1", "--solver", "magic"], "solver"),
    (["--lengths", "1", "--workers", "0"], "--workers"),
    (["--lengths", "1", "--table", "out.txt"], "--table"),
    (["--lengths", "1", "--table", "/nonexistent/dir/out.csv"], "--table"),
]


@pytest.mark.parametrize("args, name", BAD_CLI, ids=[" ".join(a) for a, _ in BAD_CLI])
def test_bad_cli_input_exit_2_with_one_line(args, name, capsys, tmp_path):
    if not any(a.startswith("--table") for a in args):
        args = [*args, "--table", str(tmp_path / "t.csv")]
    try:
        code = main(["sweep", *args, "--quiet"])
    except SystemExit as exit_:  # argparse's own errors (also one line, exit 2)
        code = exit_.code
    assert code == 2
    err = capsys.readouterr().err
    assert name in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1
    assert not (tmp_path / "t.csv").exists()


def test_parse_values_ranges_include_the_stop():
    assert parse_values("0.5:1.5:0.25", "--lengths") == [0.5, 0.75, 1.0, 1.25, 1.5]
    assert parse_values("0:0.3:0.1", "x") == [0.0, 0.1, 0.2, 0.3]  # 0.3/0.1 = 2.9999...
    assert parse_values("0:0.35:0.1", "x") == [0.0, 0.1, 0.2, 0.3]
    assert parse_values("2", "x", int) == [2]


# -- the size check and the solve options ----------------------------------------------------
@pytest.mark.parametrize("refine", [0, 1])
def test_a_point_solve_accepts_near_the_size_limit_is_accepted_by_sweep(refine, fake, tmp_path,
                                                                         capsys):
    """solve refuses a mesh by the size of what it solves (the symmetric half, refined):
    the sweep refuses exactly the same points, up front and in the CLI."""
    sheet = Sheet(length=3.0)
    hs = np.round(np.arange(0.002, 0.5, 0.001), 6)
    fits = [h for h in hs if estimate_dofs(sheet, h, None, half=True, refine=refine) <= MAX_DOFS]
    h = float(min(fits))  # the finest mesh of the 1/1000 grid that solve accepts
    assert estimate_dofs(sheet, h, None, half=False, refine=refine) > MAX_DOFS  # near the limit
    too_fine = float(np.round(h - 0.001, 6))
    point = {"length": 3.0, "hmax": h, "refine": refine}

    def solve_refuses_size(hmax, symmetric):
        # a bad solver name is refused after the size check: it tells whether the size passed
        with pytest.raises(ParameterError) as err:
            solve(sheet, hmax=hmax, refine=refine, symmetric=symmetric, solver="magic")
        return "hmax must be larger" in str(err.value)

    assert not solve_refuses_size(h, True)
    sw.check_point(point)  # accepted
    assert solve_refuses_size(too_fine, True)
    with pytest.raises(ParameterError, match="hmax must be larger"):
        sw.check_point({**point, "hmax": too_fine})
    assert solve_refuses_size(h, False)  # the whole sheet is twice as big
    with pytest.raises(ParameterError, match="hmax must be larger"):
        sw.check_point({**point, "symmetric": False})

    args = ["sweep", "--lengths", "3", "--hmax", str(h), "--refine", str(refine), "--workers",
            "1", "--quiet"]  # one worker: the fake solver, in this process
    assert main([*args, "--table", str(tmp_path / "a.csv")]) == 0
    assert fake.calls == [(3.0, 0.0, "curvature-first")]
    assert main([*args, "--symmetric", "no", "--table", str(tmp_path / "b.csv")]) == 2
    assert "hmax must be larger" in capsys.readouterr().err
    assert len(fake.calls) == 1


def test_solve_options_are_swept_and_keep_old_keys(fake, tmp_path):
    pts = grid(length=0.5, refine=[0, 1], symmetric=[True, False])
    assert len(pts) == 4 and "refine" not in pts[0] and "symmetric" not in pts[0]
    assert pts[3]["refine"] == 1 and pts[3]["symmetric"] is False
    assert len({point_key(p) for p in pts}) == 4
    # a solve option at its default is not part of the point: keys from before stay valid
    assert point_key({"length": 0.5, "refine": 0, "symmetric": True}) == point_key({"length": 0.5})
    with pytest.raises(TypeError):
        grid(length=0.5, quadrature=3)
    table = tmp_path / "t.csv"
    df = run_sweep(pts, table=table, workers=1, progress=False)
    assert list(df.refine) == [0, 0, 1, 1] and list(df.symmetric) == [True, False, True, False]
    assert [c[0] for c in fake.calls] == [0.5] * 4
    # an older journal line (no option columns) is the point at the defaults
    recs = [json.loads(line) for line in Path(journal_path(table)).read_text().splitlines()]
    for rec in recs:
        if rec["refine"] == 0 and rec["symmetric"]:
            del rec["refine"], rec["symmetric"]
    Path(journal_path(table)).write_text("".join(json.dumps(r) + "\n" for r in recs))
    again = run_sweep(pts, table=table, workers=1, progress=False)
    assert again.attrs["sweep"]["new"] == 0 and bool(again.symmetric[0]) is True
    assert again.refine[0] == 0


def test_a_sweep_row_is_the_results_record():
    """The row of a point holds Result.to_record() of its solve (the one row definition)."""
    pts = grid(length=0.3, curvature=2.5, hmax=0.2, refine=[0, 1], symmetric=[True, False])
    df = run_sweep(pts, workers=1, progress=False)
    timing = {"wall_time_s", "assembly_s", "linear_solve_s"}
    for p, (_, row) in zip(pts, df.iterrows()):
        rec = solve(Sheet(length=0.3, curvature=2.5), hmax=0.2, refine=p.get("refine", 0),
                    symmetric=p.get("symmetric", True)).to_record()
        for k, v in rec.items():
            if v is None:  # not known (a whole sheet's antisymmetric count): missing in the table
                assert pd.isna(row[k]), k
            elif k not in timing:
                assert row[k] == (pytest.approx(v, rel=1e-9) if isinstance(v, float) else v), k
    half, whole = df[df.refine == 1].deflection  # symmetric half and whole sheet agree
    assert half == pytest.approx(whole, rel=1e-7)
    assert list(df.layers_used[df.refine == 1]) == [2 * df.layers_used[0]] * 2


# -- real solves: kill -9 and Dask -------------------------------------------------------------
KILL_GRID = dict(length=0.3, tip_width=[1.0, 0.0], curvature=[0.0, 2.5], hmax=0.2)
KILL_ARGS = ["--lengths", "0.3", "--tip-widths", "1,0", "--curvatures", "0,2.5", "--hmax", "0.2"]
N_KILL = 4


def _cli(table, workers):
    return [sys.executable, "-m", "skfem_sheet", "sweep", *KILL_ARGS, "--table", str(table),
            "--workers", str(workers), "--quiet"]


def _valid_lines(data):
    """The records of the complete JSON lines of journal bytes."""
    out = []
    for line in data.split(b"\n"):
        try:
            out.append(json.loads(line))
        except (ValueError, UnicodeDecodeError):
            pass
    return out


@pytest.fixture(scope="module")
def killed_and_resumed(tmp_path_factory):
    """A 2-process sweep killed with SIGKILL (with its workers) halfway, then run again."""
    table = tmp_path_factory.mktemp("kill") / "t.csv"
    jp = journal_path(table)
    proc = subprocess.Popen(_cli(table, 2), start_new_session=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 240
    try:
        while time.monotonic() < deadline and proc.poll() is None:
            if os.path.exists(jp) and Path(jp).read_bytes().count(b"\n") >= 1:
                break
            time.sleep(0.02)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)  # the sweep and its worker processes
        proc.communicate()
    before = Path(jp).read_bytes() if os.path.exists(jp) else b""
    resumed = subprocess.run(_cli(table, 2), capture_output=True, text=True, timeout=300)
    return dict(table=table, kill_rc=proc.returncode, before=before, resumed=resumed)


def test_kill_9_halfway_then_restart_gives_every_point_exactly_once(killed_and_resumed):
    k = killed_and_resumed
    assert k["kill_rc"] == -signal.SIGKILL, "the sweep finished before it could be killed"
    n_before = len(_valid_lines(k["before"]))
    assert 1 <= n_before < N_KILL
    r = k["resumed"]
    assert r.returncode == 0, r.stderr
    assert f"{N_KILL} points, {N_KILL} converged, 0 failed ({N_KILL - n_before} computed now, " \
           f"{n_before} from earlier runs)" in r.stdout
    journal = Path(journal_path(k["table"])).read_bytes()
    assert journal.startswith(k["before"])  # finished points were never rewritten
    keys = [rec["key"] for rec in _valid_lines(journal)]
    expected = [point_key(p) for p in grid(**KILL_GRID)]
    assert sorted(keys) == sorted(expected)  # every point exactly once
    table = pd.read_csv(k["table"])
    assert list(table.key) == expected and table.converged.all()


def test_dask_local_cluster_gives_the_process_pool_table(killed_and_resumed, tmp_path):
    distributed = pytest.importorskip("distributed")
    pool = pd.read_csv(killed_and_resumed["table"])
    with distributed.LocalCluster(n_workers=2, processes=True, threads_per_worker=1,
                                  dashboard_address=None, silence_logs=logging.ERROR) as cluster:
        df = run_sweep(grid(**KILL_GRID), table=tmp_path / "dask.csv",
                       scheduler=cluster.scheduler_address, progress=False)
    dask = pd.read_csv(tmp_path / "dask.csv")
    assert len(df) == len(dask) == len(pool) == N_KILL
    same = ["key", "length", "tip_width", "curvature", "thickness", "modulus", "path", "hmax",
            "layers", "solver", "converged", "message", "branch", "stable", "snapped",
            "newton_iterations", "load_steps", "dofs", "version", "error", "layers_used",
            "linear_solver"]
    pd.testing.assert_frame_equal(dask[same], pool[same])
    for col in ("deflection", "energy", "volume_change"):
        np.testing.assert_allclose(dask[col], pool[col], rtol=0, atol=1e-12, err_msg=col)


def _crashing_task(points):
    """A stand-in for the worker's chunk task: length 0.9 kills its worker process."""
    out = []
    for p in points:
        if p["length"] == 0.9:
            os._exit(3)
        rec = sw._record(p, point_key(p))
        rec.update(deflection=p["length"], converged=True)
        out.append(rec)
    return out


@pytest.mark.slow  # about 5 worker processes start (10 s on a busy 2-core machine)
def test_a_point_that_kills_its_worker_is_a_failed_row_and_the_rest_go_on():
    pts = grid(length=[0.5, 0.6, 0.7, 0.8, 0.9, 1.0])
    recs = [r for batch in runner.pool(sw._chunks(pts, 2, chunk_size=2), 2,
                                       task=_crashing_task, failed=sw._failed)
            for r in batch]
    assert sorted(r["key"] for r in recs) == sorted(point_key(p) for p in pts)  # each once
    by = {r["length"]: r for r in recs}
    assert by[0.9]["error"] == "WorkerDied" and not by[0.9]["converged"]
    assert "worker process died" in by[0.9]["message"]
    assert all(by[L]["converged"] and by[L]["deflection"] == L for L in (0.5, 0.6, 0.7, 0.8, 1.0))


def test_an_old_row_without_start_is_a_path_row_never_reused_for_the_coarse_default(
        fake, tmp_path):
    """``start="coarse"`` is solve's default, but keys leave out the frozen key
    defaults (``start="path"``): a journal line from before ``start`` existed
    is a path row, reused for ``start="path"`` points only."""
    assert sw.OPTIONS["start"] == "coarse" and sw._KEY_DEFAULTS["start"] == "path"
    # every sweepable option has a frozen key default
    assert set(sw.OPTIONS) == set(sw._KEY_DEFAULTS)
    coarse_pts, path_pts = grid(length=0.5), grid(length=0.5, start="path")
    assert point_key(coarse_pts[0]) == point_key({**coarse_pts[0], "start": "coarse"})
    assert point_key(coarse_pts[0]) != point_key(path_pts[0])
    # the old key of a point (made before start was an option) is the path point's
    assert point_key(path_pts[0]) == sw.hash_key(
        [[k, sw.key_value(path_pts[0][k])] for k in sw.PARAMETERS])
    table = tmp_path / "t.csv"
    run_sweep(path_pts, table=table, workers=1, progress=False)
    assert len(fake.calls) == 1
    # make its journal line old: no start, no coarse_hmax
    recs = [json.loads(line) for line in Path(journal_path(table)).read_text().splitlines()]
    assert [r["start"] for r in recs] == ["path"]
    for rec in recs:
        del rec["start"], rec["coarse_hmax"]
    Path(journal_path(table)).write_text("".join(json.dumps(r) + "\n" for r in recs))
    again = run_sweep(path_pts, table=table, workers=1, progress=False)
    assert again.attrs["sweep"]["new"] == 0 and again.start[0] == "path"
    assert len(fake.calls) == 1
    coarse = run_sweep(coarse_pts, table=table, workers=1, progress=False)
    assert coarse.attrs["sweep"]["new"] == 1 and coarse.start[0] == "coarse"
    assert len(fake.calls) == 2
    # both rows are in the journal under their own keys
    assert len(read_journal(journal_path(table))) == 2


def test_the_sweep_command_sweeps_the_start(fake, tmp_path):
    from skfem_sheet.studies.sweep import check_point

    args = ["sweep", "--lengths", "0.5", "--hmax", "0.2", "--workers", "1", "--quiet"]
    assert main([*args, "--start", "both", "--table", str(tmp_path / "a.csv")]) == 0
    df = pd.read_csv(tmp_path / "a.csv")
    assert sorted(df.start) == ["coarse", "path"] and len(fake.calls) == 2
    assert main([*args, "--table", str(tmp_path / "b.csv")]) == 0
    assert list(pd.read_csv(tmp_path / "b.csv").start) == ["coarse"]
    with pytest.raises(ParameterError, match="start"):
        check_point({"length": 0.5, "start": "fine"})


_SLEEPY_SCRIPT = """
import os, sys, time
from dataclasses import replace
from skfem_sheet.studies import runner
from skfem_sheet.studies import sweep as sw

def task(points):  # length 0.5 at once; the others hold their worker for 5 minutes
    out = []
    for p in points:
        if p["length"] > 0.5:
            open(os.path.join(sys.argv[2], str(os.getpid())), "w").close()
            time.sleep(300)
        rec = sw._record(p, sw.point_key(p))
        rec.update(deflection=p["length"], converged=True)
        out.append(rec)
    return out

if __name__ == "__main__":
    pts = sw.grid(length=[0.5, 0.6, 0.7])
    try:
        runner.execute(pts, [sw.point_key(p) for p in pts], replace(sw._JOB, task=task),
                       table=sys.argv[1], workers=2, scheduler=None, progress=False,
                       retry_failed=False, chunker=lambda todo, n: [[p] for p in todo])
    except runner.StudyInterrupted as err:
        print(err, file=sys.stderr)
        sys.exit(130)
"""


def _alive(pid):
    try:
        with open(f"/proc/{pid}/status") as fh:
            return "\nState:\tZ" not in fh.read()
    except FileNotFoundError:
        return False


def test_ctrl_c_on_a_process_pool_abandons_the_running_points_within_seconds(tmp_path):
    """Ctrl-C (SIGINT to the process group, as a terminal sends it) while two
    workers are each in a 5-minute point: the study exits within seconds (it
    took 37-67 s, the points' remaining time, when the pool forgot its workers
    before killing them), the workers are gone, the finished point is kept."""
    script, pids, table = tmp_path / "study.py", tmp_path / "pids", tmp_path / "t.csv"
    script.write_text(_SLEEPY_SCRIPT)
    pids.mkdir()
    proc = subprocess.Popen([sys.executable, str(script), str(table), str(pids)],
                            start_new_session=True, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 120
        while len(os.listdir(pids)) < 2 and time.monotonic() < deadline:
            assert proc.poll() is None, proc.communicate()
            time.sleep(0.05)
        assert len(os.listdir(pids)) == 2, "the workers did not start their points"
        t0 = time.monotonic()
        os.killpg(proc.pid, signal.SIGINT)
        _, err = proc.communicate(timeout=60)
        took = time.monotonic() - t0
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.communicate()
    assert proc.returncode == 130, err
    assert took < 10, f"{took:.1f} s to exit after Ctrl-C"
    time.sleep(0.5)
    assert not [p for p in os.listdir(pids) if _alive(int(p))], "workers still running"
    assert f"1 of 3 points are finished (1 in this run) and kept in {table}" in err
    assert list(pd.read_csv(table).length) == [0.5]


def test_the_points_of_a_chunk_share_one_build_chain(fake, monkeypatch):
    """One chunk is one mesh: its points are solved with one BuildChain (the
    mesh, space and assembler built once), a new chunk gets a new one."""
    from skfem_sheet.build import BuildChain

    chains = []

    def spy(sheet, path="curvature-first", hmax=0.03, **kw):
        chains.append(kw.get("chain"))
        return fake(sheet, path=path, hmax=hmax, **kw)

    monkeypatch.setattr(sw, "solve", spy)
    pts = grid(length=[0.5], curvature=[0.0, 1.0, 2.5])
    sw._JOB.task(pts)
    sw._JOB.task(pts[:1])
    assert all(isinstance(c, BuildChain) for c in chains) and len(chains) == 4
    assert chains[0] is chains[1] is chains[2] and chains[3] is not chains[0]


def test_beside_runs_its_task_in_another_process_and_is_killed_by_an_exception():
    from skfem_sheet.studies.runner import beside

    with beside(os.getpid) as fut:
        other = fut.result(timeout=120)
    assert other != os.getpid()
    # leaving the block by an exception does not wait for the task: its process is
    # killed (in a process of its own, as Ctrl-C would end one, not in pytest's)
    code = ("import time\n"
            "from skfem_sheet.studies.runner import beside\n"
            "try:\n"
            "    with beside(time.sleep, 120) as fut:\n"
            "        time.sleep(1)\n"
            "        raise RuntimeError('stop')\n"
            "except RuntimeError:\n"
            "    print('stopped', flush=True)\n")
    t0 = time.perf_counter()
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=110)
    assert out.returncode == 0 and out.stdout.strip() == "stopped", out.stderr
    assert time.perf_counter() - t0 < 60  # not the task's 120 s
