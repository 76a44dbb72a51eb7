"""The fold map: points and keys, reading the table (modes, transition, (b/a)*), resuming."""
import json
import math
import subprocess
import sys
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from skfem_sheet.params import ParameterError
from skfem_sheet.studies import foldmap as fm
from skfem_sheet.studies.sweep import journal_path


def _row(b, c, L0=math.nan, L1=math.nan, curve=None):
    bistable = np.isfinite(L0) and np.isfinite(L1) and L1 - L0 > 0.01
    rec = {**fm.MAP_PARAMETERS, "tip_width": b, "curvature": c, "popup_length": L0,
           "standout_length": L1, "bistable": bistable,
           "bistable_width": L1 - L0 if bistable else math.nan, "converged": True,
           "curvature_dominated": json.dumps(curve or {"lengths": [], "deflection": [],
                                                       "stable": []}),
           "gravity_dominated": ""}
    rec["transition_length"] = fm.transition_length(rec)
    return rec


def test_map_points_grid_order_and_keys():
    pts = fm.map_points([0.5, 1.0], [2.5, 5.0], lengths=(0.6, 2.4), hmax=0.1)
    assert [(p["curvature"], p["tip_width"]) for p in pts] == \
        [(2.5, 0.5), (2.5, 1.0), (5.0, 0.5), (5.0, 1.0)]
    assert all(p["length_min"] == 0.6 and p["length_max"] == 2.4 for p in pts)
    # the key is that of the rounded parameters: arange noise does not make a new point
    noisy = fm.map_points([0.1 + 0.2], [2.5])[0]
    assert fm.map_key(noisy) == fm.map_key(fm.map_points([0.3], [2.5])[0])
    assert fm.map_key(pts[0]) != fm.map_key(pts[1])
    # and it is not a sweep point's key
    assert len({fm.map_key(p) for p in pts}) == 4


@pytest.mark.parametrize("bad, match", [
    (dict(tip_widths=[], curvatures=[2.5]), "tip_widths"),
    (dict(tip_widths=[1.0], curvatures=[2.5], lengths=(1.0,)), "lengths"),
])
def test_map_points_bad_input(bad, match):
    with pytest.raises(ParameterError, match=match):
        fm.map_points(**bad)


def test_fold_map_bad_input(tmp_path):
    with pytest.raises(ParameterError, match="unknown"):
        fm.fold_map([{"tip_width": 1.0, "length": 2.0}], progress=False)
    with pytest.raises(ParameterError, match="workers"):
        fm.fold_map(fm.map_points([1.0], [2.5]), workers=0, progress=False)
    with pytest.raises(ParameterError, match="table"):
        fm.fold_map(fm.map_points([1.0], [2.5]), table=tmp_path / "x.txt", progress=False)


def test_modes_bistable_row():
    row = _row(1.0, 2.5, L0=1.2, L1=1.35)
    cur, grav = fm.modes(row, [1.0, 1.2, 1.3, 1.35, 1.5])
    assert cur.tolist() == [True, True, True, True, False]
    assert grav.tolist() == [False, True, True, True, True]
    assert fm.transition_length(row) is None


def test_transition_of_a_continuous_curve_is_its_steepest_interval():
    L = np.arange(0.5, 2.01, 0.1)
    d = 0.5 * (1 + np.tanh((L - 1.23) / 0.05))  # steepest at 1.23
    row = _row(0.0, 2.5, curve={"lengths": L.tolist(), "deflection": d.tolist(),
                                "stable": [True] * len(L)})
    t = fm.transition_length(row)
    assert abs(t - 1.25) < 1e-9  # the middle of [1.2, 1.3], the interval holding 1.23
    cur, grav = fm.modes(row, [1.0, 1.4])
    assert cur.tolist() == [True, False] and grav.tolist() == [False, True]


def test_one_fold_only_is_the_transition():
    row = _row(0.6, 2.5, L0=1.24)  # the gravity-dominated branch lost, no standout
    assert not row["bistable"]
    assert fm.transition_length(row) == pytest.approx(1.24)


def test_flat_clamp_is_gravity_dominated_everywhere():
    L = [0.5, 1.0, 1.5]
    row = _row(1.0, 0.0, curve={"lengths": L, "deflection": [0.1, 0.5, 0.9],
                                "stable": [True] * 3})
    cur, grav = fm.modes(row, L)
    assert not cur.any() and grav.all()


def test_critical_tip_width_bracket_and_linear_estimate():
    rows = [_row(b, 2.5, L0, L1) for b, L0, L1 in
            [(0.5, math.nan, math.nan), (0.6, 1.24, math.nan), (0.7, 1.23, 1.27),
             (0.8, 1.22, 1.31), (1.0, 1.2, 1.35)]]
    rows += [_row(b, 1.0) for b in (0.8, 1.0)]
    rows += [_row(b, 5.0, 2.0, 2.4) for b in (0.5, 1.0)]
    crit = fm.critical_tip_width(pd.DataFrame(rows))
    est, lo, hi = crit[2.5]
    assert (lo, hi) == (0.6, 0.7)
    # widths 0.04 at 0.7 and 0.09 at 0.8: zero at 0.7 - 0.04 * 0.1 / 0.05 = 0.62
    assert est == pytest.approx(0.62)
    assert math.isnan(crit[1.0][0]) and crit[1.0][1] == 1.0
    assert math.isnan(crit[5.0][0]) and crit[5.0][2] == 0.5


def test_branch_curve_sorted_by_length():
    row = {"curvature_dominated": json.dumps({"lengths": [1.0, 0.8, 0.9],
                                              "deflection": [3, 1, 2],
                                              "stable": [True, None, False]})}
    L, d, st = fm.branch_curve(row)
    assert L.tolist() == [0.8, 0.9, 1.0] and d.tolist() == [1, 2, 3]
    assert st.tolist() == [None, False, True]
    with pytest.raises(ParameterError, match="which"):
        fm.branch_curve(row, "up")


def test_flat_sheet_map_point_is_one_increasing_branch_and_resumes(tmp_path):
    """a/R = 0: one branch (both load paths are one problem); d grows with L (a
    heavier, longer cantilever sags more); a second run computes nothing."""
    table = tmp_path / "map.csv"
    pts = fm.map_points([1.0], [0.0], lengths=(0.5, 0.7), hmax=0.15, step=0.1)
    df = fm.fold_map(pts, table=table, workers=1, progress=False)
    r = df.iloc[0]
    assert r.converged and not r.bistable
    assert math.isnan(r.popup_length) and math.isnan(r.standout_length)
    L, d, st = fm.branch_curve(r)
    assert L[0] == pytest.approx(0.5) and L[-1] == pytest.approx(0.7)
    assert np.all(np.diff(d) > 0) and all(st)
    assert r.gravity_dominated == r.curvature_dominated
    assert df.attrs["fold_map"]["new"] == 1
    # resume: nothing recomputed, the same row back; a line cut short is ignored
    with open(journal_path(table), "a") as fh:
        fh.write('{"tip_width": 1.0, "curv')
    again = fm.fold_map(pts, table=table, workers=1, progress=False)
    assert again.attrs["fold_map"]["new"] == 0
    assert again.iloc[0].curvature_dominated == r.curvature_dominated
    assert len(pd.read_csv(table)) == 1


def test_cli_bad_input_is_one_line():
    out = subprocess.run([sys.executable, "-m", "skfem_sheet", "fold-map", "--tip-widths", "x"],
                         capture_output=True, text=True)
    assert out.returncode == 2
    assert "tip-widths" in out.stderr and "Traceback" not in out.stderr


def _fake_fold_lengths(up_snapped, down_snapped):
    def branch(snapped, L, name):
        return SimpleNamespace(lengths=np.array(L), deflections=np.array([0.1, 0.2]),
                               stable=[True, True], names=[name, name], reason="",
                               start_snapped=snapped,
                               newton_iterations=5, fold=None, fold_deflection=float("nan"))

    def fold_lengths(sheet, *, lengths, **kw):
        return SimpleNamespace(increasing=branch(up_snapped, [lengths[0], lengths[0] + 0.1],
                                                 "curvature-dominated"),
                               decreasing=branch(down_snapped, [lengths[1], lengths[1] - 0.1],
                                                 "gravity-dominated"),
                               popup=None, standout=None, bistable=False,
                               width=float("nan"), message="", wall_time_s=0.1,
                               factorizations=3, trace_factorizations=0)
    return fold_lengths


@pytest.mark.parametrize("up, down", [(False, False), (True, False), (False, True)])
def test_snapped_starts_are_structured_columns(up, down, monkeypatch, tmp_path):
    """The branches' start_snapped flags are boolean columns (figures read them, not the
    message); journal lines from before the columns get them from their message."""
    monkeypatch.setattr(fm, "fold_lengths", _fake_fold_lengths(up, down))
    table = tmp_path / "map.csv"
    df = fm.fold_map(fm.map_points([1.0], [2.5]), table=table, workers=1, progress=False)
    r = df.iloc[0]
    assert r.curvature_dominated_snapped == up and r.gravity_dominated_snapped == down
    assert bool(r.converged) == (not up and not down)
    assert ("curvature-dominated branch does not exist" in r.message) == up
    back = pd.read_csv(table)
    assert list(back.curvature_dominated_snapped) == [up]
    # an older journal line without the columns
    line = json.loads(open(journal_path(table)).read())
    del line["curvature_dominated_snapped"], line["gravity_dominated_snapped"]
    open(journal_path(table), "w").write(json.dumps(line) + "\n")
    again = fm.fold_map(fm.map_points([1.0], [2.5]), table=table, workers=1, progress=False)
    assert again.attrs["fold_map"]["new"] == 0
    assert again.curvature_dominated_snapped[0] == up
    assert again.gravity_dominated_snapped[0] == down


# -- the map from fold curves (issue 19, item 4) ----------------------------------------------
def _curve_row(c, b_star, L_star, points, second="tip_width"):
    return {"curvature": c, "second": second, "tip_width": 1.0, "hmax": 0.1, "bistable": True,
            "cusp_tip_width": b_star if second == "tip_width" else 1.0,
            "cusp_curvature": c if second == "tip_width" else b_star,
            "cusp_length": L_star, "error": "", "points": json.dumps(points)}


def test_curve_points_keys_and_bad_input():
    pts = fm.curve_points([1.0, 2.5], hmax=0.1, rectangle_from=2.5)
    assert [(p["second"], p["curvature"]) for p in pts] == [
        ("tip_width", 1.0), ("tip_width", 2.5), ("curvature", 2.5)]
    keys = {fm._curve_key(p) for p in pts}
    assert len(keys) == 3
    assert fm._curve_key(dict(pts[0], hmax=0.06)) not in keys
    with pytest.raises(ParameterError, match="second"):
        fm.fold_curves([dict(pts[0], second="length")], workers=1, progress=False)
    with pytest.raises(ParameterError, match="workers"):
        fm.fold_curves(pts, workers=0, progress=False)


def test_curve_halves_split_at_the_turning_point():
    pts = [[1.0, 1.35, "standout"], [0.8, 1.3, "standout"], [0.65, 1.26, "standout"],
           [0.7, 1.24, "popup"], [1.0, 1.2, "popup"]]
    h = fm.curve_halves(_curve_row(2.5, 0.64, 1.25, pts))
    (bs, Ls), (bp, Lp) = h["standout"], h["popup"]
    assert bs.tolist() == [0.64, 0.65, 0.8, 1.0] and Ls.tolist() == [1.25, 1.26, 1.3, 1.35]
    assert bp.tolist() == [0.64, 0.7, 1.0] and Lp.tolist() == [1.25, 1.24, 1.2]
    assert h["cusp"] == (0.64, 1.25)
    # a curve that never turned: one half, no cusp
    h = fm.curve_halves(dict(_curve_row(2.5, math.nan, math.nan, pts[:3])))
    assert h["cusp"] is None and h["popup"][0].size == 0


def test_critical_curve_from_the_cusps_and_the_rectangle():
    rows = [_curve_row(2.5, 0.63, 1.25, []), _curve_row(5.0, 0.60, 1.69, []),
            _curve_row(2.5, 1.15, 0.9, [], second="curvature"),
            dict(_curve_row(0.75, math.nan, math.nan, []), bistable=False)]
    assert fm.critical_curve(pd.DataFrame(rows)) == [(1.0, 1.15, 0.9), (0.63, 2.5, 1.25),
                                                     (0.6, 5.0, 1.69)]


def test_fold_curves_resume_through_the_journal(tmp_path, monkeypatch):
    """Each curve is traced once: a second call reads the journal; a failed
    trace is a failed row, not an exception."""
    calls = []

    class Fake:
        def __init__(self, c):
            self.c = c

    def fake_trace(c, **kw):
        calls.append(c)
        if c == 1.0:
            raise RuntimeError("boom")
        return SimpleNamespace(
            second="tip_width", cusp={"tip_width": 0.6, "length": 1.3}, standout_length=1.4,
            popup_length=1.2, cusp_located="fold coefficient", bistable=True, completed=True,
            points=({"tip_width": 1.0, "length": 1.4, "kind": "standout"},
                    {"tip_width": 0.6, "length": 1.3, "kind": "standout"},
                    {"tip_width": 1.0, "length": 1.2, "kind": "popup"}),
            factorizations=12, factorizations_per_point=4.0, remeshes=0, reason="",
            wall_time_s=0.1)

    monkeypatch.setattr(fm, "trace_fold_curve", fake_trace)
    table = tmp_path / "curves.csv"
    pts = fm.curve_points([1.0, 2.5])
    df = fm.fold_curves(pts, table=table, workers=1, progress=False)
    assert sorted(calls) == [1.0, 2.5]
    assert set(df.attrs["fold_curves"]["new_keys"]) == set(df.key)  # computed in this run
    ok = df[df.curvature == 2.5].iloc[0]
    assert ok.converged and ok.cusp_tip_width == 0.6 and ok.cusp_curvature == 2.5
    assert ok.n_points == 3 and fm.curve_halves(ok)["cusp"] == (0.6, 1.3)
    bad = df[df.curvature == 1.0].iloc[0]
    assert not bad.converged and bad.error == "RuntimeError" and "boom" in bad.message
    again = fm.fold_curves(pts, table=table, workers=1, progress=False)
    assert sorted(calls) == [1.0, 2.5] and again.attrs["fold_curves"]["new"] == 0
    assert again.attrs["fold_curves"]["new_keys"] == ()
    assert len(pd.read_csv(table)) == 2


def test_cli_fold_map_curves_bad_input_is_one_line():
    out = subprocess.run([sys.executable, "-m", "skfem_sheet", "fold-map", "--method", "grid",
                          "--rectangle", "2.5"], capture_output=True, text=True)
    assert out.returncode == 2 and out.stderr.count("\n") == 1 and "--rectangle" in out.stderr


def _synthetic_curve(c):
    """A fold curve of the shape traced: L1*(b) down to the cusp, L0*(b) back up."""
    b_star, L_star = 0.6, 1.0 + 0.1 * c
    bs = np.linspace(1.0, b_star + 0.01, 8)
    up = [[b, L_star + 0.05 * c * (b - b_star) ** 0.5, "standout"] for b in bs]
    down = [[b, L_star - 0.02 * c * (b - b_star) ** 0.5, "popup"] for b in bs[::-1]]
    return dict(_curve_row(c, b_star, L_star, up + down), converged=True, completed=True)


def test_figures_draw_the_bistable_region_from_fold_curves(tmp_path):
    """fig7: one chain per a/R from the cusp up, the critical curve through
    the cusps and the rectangle's critical a/R; fig6: the traced curve as the
    boundary with its cusp, markers above the cusp from the curve."""
    import matplotlib

    matplotlib.use("Agg")
    from skfem_sheet.figures.data import curve_region
    from skfem_sheet.figures.figure6 import draw_fig6
    from skfem_sheet.figures.figure7 import draw_fig7

    rows = [_synthetic_curve(c) for c in (2.5, 5.0)]
    rows.append(dict(_curve_row(2.5, 1.2, 0.95, [], second="curvature"), converged=True))
    df = pd.DataFrame(rows)
    reg = curve_region(df)
    assert sorted(reg["chains"]) == [1.2, 2.5, 5.0] and reg["edge"] == (1.0, 1.2, 0.95)
    chain = reg["chains"][2.5]
    assert chain[0] == (0.6, 1.25, 1.25)  # the cusp first
    assert all(l0 < l1 for _, l0, l1 in chain[1:])
    assert [c[1] for c in reg["critical"]] == [1.2, 2.5, 5.0]
    fig = draw_fig7(df, "quick", region=reg)
    fig.savefig(tmp_path / "f7.png")
    rom = pd.DataFrame([dict(curvature=k, tip_width=b, length=L, direction=dr, deflection=L - 1,
                             converged=True, stable=True, jumped=False)
                        for k in (2.5, 5.0) for b in (0.0, 1.0) for L in (1.0, 2.0)
                        for dr in ("increasing", "decreasing")])
    fe = pd.DataFrame(columns=list(fm.MAP_COLUMNS))
    fig = draw_fig6(fe, rom, "quick", mode_lengths=np.arange(0.6, 2.81, 0.2), curves=df)
    fig.savefig(tmp_path / "f6.png")
    ax = fig.axes[0]
    (cusp,) = [ln for ln in ax.get_lines() if ln.get_gid() == "fe-cusp|k=2.5"]
    assert cusp.get_xdata()[0] == pytest.approx(1.25) and cusp.get_ydata()[0] == 0.6
    (dia,) = [ln for ln in ax.get_lines() if ln.get_gid() == "fe-curvature|k=2.5"]
    assert min(dia.get_ydata()) > 0.6  # markers only above the cusp (no map rows below)
