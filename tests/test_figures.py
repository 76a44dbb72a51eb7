"""Figures (issue 6): drawing from fold-map tables, caching, and the ``figure`` command.

The finite-element data of fig2 and fig4-fig7 come from one fold-map table
(:func:`skfem_sheet.foldmap.fold_map`).  Here its one-point computation
(``foldmap._run_map_point``) is replaced by synthetic records with the same
contract (both branch curves as JSON, folds, stability), while the real
journal and table are used, so these tests run in seconds; the drawing tests
build small map tables directly.  One test runs a real (tiny) map point.
"""
import ast
import inspect
import json
import math
import os
from pathlib import Path

import numpy as np
import pytest

pd = pytest.importorskip("pandas")

from skfem_sheet import figures  # noqa: E402
from skfem_sheet.cli import main  # noqa: E402
from skfem_sheet.figures import cache, figure3  # noqa: E402
from skfem_sheet.figures import data as figure_data  # noqa: E402
from skfem_sheet.figures.figure7 import region_mesh  # noqa: E402
from skfem_sheet.params import ParameterError  # noqa: E402
from skfem_sheet.studies import foldmap  # noqa: E402

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"

#: The quick grid as the issue states it (the lead's map run uses exactly these points).
ISSUE_GRID = {0.0: [0, .2, .4, .6, .8, 1], 1.0: [0, .5, .6, .7, .8, .9, 1],
              1.5: [.5, .6, .7, .8, .9, 1], 2.0: [.5, .6, .7, .8, .9, 1],
              2.5: [0, .2, .4, .5, .6, .7, .8, .9, 1], 3.5: [.5, .6, .7, .8, .9, 1],
              5.0: [0, .2, .4, .5, .6, .7, .8, .9, 1]}


# -- synthetic map rows ---------------------------------------------------------------------
def _folds(b, c):
    """Synthetic folds: bistable for a/R >= 2 and b/a > 0.65, widening with both."""
    if c >= 2.0 and b > 0.65:
        L1 = 1.2 + 0.1 * c + 0.3 * (b - 0.65)
        return L1 - 1.5 * (b - 0.65) * (c / 5.0), L1
    return None


def _curve(L, d, stable=None):
    stable = [True] * len(L) if stable is None else stable
    return json.dumps({"lengths": [float(x) for x in L], "deflection": [float(x) for x in d],
                       "stable": stable})


def _gravity(L, b, c):
    return 0.3 * L**2 * (1 + b) / 2 - 0.02 * c


def _aloft(L, c):
    return -0.01 * c * L


def synthetic_row(point):
    """A map-table row like :func:`foldmap._run_map_point`'s, from a toy model."""
    b, c = float(point["tip_width"]), float(point["curvature"])
    lo, hi = float(point["length_min"]), float(point["length_max"])
    L = np.round(np.arange(lo, hi + 1e-9, 0.1), 6)
    rec = foldmap._empty_record(dict(point), foldmap.map_key(point))
    folds = _folds(b, c)
    if folds is not None:
        L0, L1 = folds
        Lc = np.r_[L[L < L1 - 0.01], L1 - 0.0025]
        Lg = np.r_[L0 + 0.0025, L[L > L0 + 0.01]]
        rec.update(popup_length=L0, standout_length=L1, bistable=True,
                   bistable_width=L1 - L0,
                   curvature_dominated=_curve(Lc, _aloft(Lc, c)),
                   gravity_dominated=_curve(Lg[::-1], _gravity(Lg, b, c)[::-1]))
    else:
        t = 1.0 + 0.1 * c
        d = _gravity(L, b, c) if c == 0 else np.where(L < t, _aloft(L, c), _gravity(L, b, c))
        rec.update(curvature_dominated=_curve(L, d), gravity_dominated=_curve(L[::-1], d[::-1]),
                   transition_length=math.nan if c == 0 else t)
    # neither branch started on the other one (the fold map's ``start_snapped`` flags)
    rec.update(converged=True, newton_iterations=10, wall_time_s=1.0,
               curvature_dominated_snapped=False, gravity_dominated_snapped=False)
    return rec


def _table(grid, changes=None):
    """A map table (like fold_map's) of synthetic rows for ``{a/R: [b/a]}``."""
    pts = [p for c, bs in grid.items() for p in foldmap.map_points(bs, [c])]
    recs = [synthetic_row(p) for p in pts]
    for (b, c), upd in (changes or {}).items():
        for r in recs:
            if r["tip_width"] == b and r["curvature"] == c:
                r.update(upd)
    return foldmap._frame(recs)


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    import matplotlib.pyplot as plt

    plt.close("all")


@pytest.fixture
def compute(monkeypatch):
    """Count the map points computed; each yields a synthetic row."""
    calls = []

    def fake(point):
        calls.append((point["curvature"], point["tip_width"]))
        return synthetic_row(point)

    monkeypatch.setattr(foldmap, "_run_map_point", fake)
    # these tests count grid points: fig6/fig7 drawn by the grid method (their
    # default traces fold curves, which a synthetic row cannot stand in for)
    monkeypatch.setattr(figure_data, "FIGURE_METHOD", "grid")
    return calls


def _legend_texts(fig):
    texts = []
    for ax in fig.axes:
        leg = ax.get_legend()
        if leg is not None:
            texts += [t.get_text() for t in leg.get_texts()]
    for leg in fig.legends:
        texts += [t.get_text() for t in leg.get_texts()]
    return texts


def _lines(ax, prefix):
    return [ln for ln in ax.get_lines() if (ln.get_gid() or "").startswith(prefix)]


def _row_lines(ax, b, k):
    tag = f"|b={b:g}|k={k:g}"
    return {m: [ln for ln in ax.get_lines() if ln.get_gid() == m + tag]
            for m in ("curvature_dominated", "gravity_dominated")}


def _xs(lines):
    return np.concatenate([np.asarray(ln.get_xdata(), float) for ln in lines])


# -- points and caching -----------------------------------------------------------------------
def test_points_are_the_issues_map_points():
    keys = {foldmap.map_key(p) for c, bs in ISSUE_GRID.items()
            for p in foldmap.map_points(bs, [c], lengths=(0.5, 3.0), hmax=0.1)}
    quick = figures.map_grid_points("quick")
    assert {foldmap.map_key(p) for p in quick} == keys and len(quick) == len(keys) == 49
    for fn in (figures.fig2_points, figures.fig4_points, figures.fig5_points,
               figures.fig6_points, figures.fig7_points):
        assert {foldmap.map_key(p) for p in fn("quick")} <= keys
        paper = fn("paper")
        assert {foldmap.map_key(p) for p in paper} <= {foldmap.map_key(p)
                                                    for p in figures.map_grid_points("paper")}
        assert {(p["hmax"], p["step"]) for p in paper} == {(0.03, 0.05)}
    assert {(p["curvature"], p["tip_width"]) for p in figures.fig2_points()} == {
        (c, b) for c in (0.0, 1.0, 2.5, 5.0) for b in (0.0, 1.0)}
    assert {(p["curvature"], p["tip_width"]) for p in figures.fig7_points()} == {
        (c, b) for c in (1.0, 1.5, 2.0, 2.5, 3.5, 5.0) for b in (.5, .6, .7, .8, .9, 1.0)}
    # paper quality: finer in both b/a and a/R
    pg = figures.PAPER_GRID
    assert len(pg) > len(figures.QUICK_GRID) and len(pg[2.5]) > len(figures.QUICK_GRID[2.5])


def test_drawing_twice_computes_nothing_twice(compute, tmp_path, monkeypatch):
    from skfem_sheet.reduced import maps

    ribbon_calls = []

    def fake_ribbon_map(c, lengths, tips, **kw):
        ribbon_calls.append((c, len(tips)))
        return [dict(curvature=c, tip_width=float(b), length=float(L), direction=dr,
                     deflection=float(L) - 1.0, converged=True, stable=True, jumped=False)
                for b in tips for dr in ("increasing", "decreasing") for L in lengths]

    monkeypatch.setattr(maps, "ribbon_map", fake_ribbon_map)
    kw = dict(data_dir=tmp_path, progress=False, workers=1)
    figures.fig2("quick", **kw)
    assert len(compute) == 8
    figures.fig2("quick", **kw)
    assert len(compute) == 8
    figures.fig4("quick", **kw)
    assert len(compute) == 8 + 8  # fig4's b/a = 0 and 1 rows are fig2's
    figures.fig6("quick", **kw)
    figures.fig7("quick", **kw)
    n, nr = len(compute), len(ribbon_calls)
    assert n == len(set(compute)) == 8 + 8 + 10 + 23 == 49  # the whole quick grid
    for name in ("fig2", "fig4", "fig6", "fig7"):
        figures.FIGURES[name]("quick", **kw)
    assert len(compute) == n and len(ribbon_calls) == nr  # nothing computed twice
    # one map table for all figures, holding every point once
    table = pd.read_csv(tmp_path / "foldmap-quick.csv")
    assert len(table) == n and table["key"].is_unique
    assert (tmp_path / "fig6-quick-ribbon.csv").exists()


def test_fig5_fe_from_the_map_and_cached_ribbon(compute, tmp_path, monkeypatch):
    import skfem_sheet.reduced as reduced

    calls = []

    class Branch:
        def __init__(self, lengths, direction, tip, k):
            L = np.sort(np.asarray(lengths, float))
            L = L[::-1] if direction == "decreasing" else L
            self.lengths = L
            jump = (tip == 1.0) & (k == 2.5)
            self.deflection = 0.1 * L + np.where(jump & (L > 1.38), 0.5, 0.0)
            self.converged = np.ones(L.size, bool)
            self.converged[-1] = tip != 0.0 or k != 1.0  # one failed ribbon point
            self.jumped = np.zeros(L.size, bool)
            if jump:
                self.jumped[np.flatnonzero(np.abs(np.diff(self.deflection)) > 0.3)[:1] + 1] = True

    def fake_continuation(template, lengths, direction="increasing", **kw):
        calls.append((template.tip_width, template.curvature, direction))
        return Branch(lengths, direction, template.tip_width, template.curvature)

    monkeypatch.setattr(reduced, "ribbon_continuation", fake_continuation)
    figures.fig2("quick", data_dir=tmp_path, progress=False, workers=1)
    n = len(compute)
    fig = figures.make_figure("fig5", "quick", out=str(tmp_path / "f5.png"),
                              data_dir=tmp_path, progress=False, workers=1)
    assert len(compute) == n  # FE rows are fig2's
    assert len(calls) == 8  # 2 shapes x 2 curvatures x 2 directions
    figures.fig5("quick", data_dir=tmp_path, progress=False, workers=1)
    assert len(calls) == 8  # cached
    assert (tmp_path / "f5.png").read_bytes()[:8] == PNG_MAGIC
    assert [ax.get_xlabel() for ax in fig.axes] == ["", "", "$L/a$", "$L/a$"]
    texts = _legend_texts(fig)
    assert {"FE, curvature-dominated", "FE, gravity-dominated", "ribbon, $L$ increasing",
            "ribbon, $L$ decreasing", "ribbon: 2 not converged, omitted"} <= set(texts)
    # (c) rectangle at a/R = 2.5 is bistable in the toy map: both FE branches and jumps
    ax_c = fig.axes[2]
    lines = _row_lines(ax_c, 1.0, 2.5)
    assert len(lines["curvature_dominated"]) == len(lines["gravity_dominated"]) == 1
    assert len([t for t in ax_c.texts if (t.get_gid() or "").startswith("jump")]) == 2
    dotted = [ln for ln in ax_c.get_lines() if ln.get_linestyle() == "--"
              and ln.get_gid() is None]
    assert any(np.isnan(ln.get_ydata().astype(float)).any() for ln in dotted)  # ribbon jump


# -- drawing --------------------------------------------------------------------------------
def test_fig2_branches_modes_and_failures(tmp_path):
    grid = {0.0: [0.0, 1.0], 1.0: [0.0, 1.0], 2.5: [0.0, 1.0], 5.0: [0.0, 1.0]}
    df = _table(grid, {(0.0, 5.0): dict(error="RuntimeError", message="boom",
                                        curvature_dominated="", gravity_dominated="")})
    # an unstable point on the rectangle's curvature-dominated branch at a/R = 2.5
    i = df.index[(df.tip_width == 1.0) & (df.curvature == 2.5)][0]
    c = json.loads(df.at[i, "curvature_dominated"])
    c["lengths"].append(1.452)
    c["deflection"].append(5.0)
    c["stable"].append(False)
    df.at[i, "curvature_dominated"] = json.dumps(c)
    fig = figures.draw_fig2(df, "quick")
    fig.savefig(tmp_path / "f2.png")
    a, b = fig.axes
    assert b.get_xlabel() == "$L/a$" and a.get_ylabel() == b.get_ylabel() == "$d/a$"
    texts = _legend_texts(fig)
    assert {f"$a/R={k}$" for k in ("0", "1", "2.5", "5")} <= set(texts)
    assert {"curvature-dominated", "gravity-dominated", "jump at a fold ($L_1^*$, $L_0^*$)",
            "1 map point failed, omitted"} <= set(texts)
    # bistable rows (rectangles, a/R = 2.5 and 5): both branches, overlapping on [L0*, L1*]
    for k in (2.5, 5.0):
        L0, L1 = _folds(1.0, k)
        lines = _row_lines(a, 1.0, k)
        assert len(lines["curvature_dominated"]) == len(lines["gravity_dominated"]) == 1
        xc, xg = _xs(lines["curvature_dominated"]), _xs(lines["gravity_dominated"])
        assert xc.max() == pytest.approx(L1, abs=0.005)
        assert xg.min() == pytest.approx(L0, abs=0.005)
        jumps = [t for t in a.texts if (t.get_gid() or "").endswith(f"|b=1|k={k:g}")]
        assert sorted(t.get_gid().split("|")[0] for t in jumps) == ["jump-L0", "jump-L1"]
        down = [t for t in jumps if t.get_gid().startswith("jump-L1")][0]
        assert down.xy[1] > down.xyann[1]  # at L1* the tip drops onto the drooped branch
    # the unstable point is not drawn
    assert 1.452 not in _xs(_row_lines(a, 1.0, 2.5)["curvature_dominated"])
    # not bistable (a/R = 1): one curve, solid below the transition, dashed from it on
    for ax, tip in ((a, 1.0), (b, 0.0)):
        lines = _row_lines(ax, tip, 1.0)
        xc, xg = _xs(lines["curvature_dominated"]), _xs(lines["gravity_dominated"])
        assert xc.max() < 1.1 <= xg[1] and xg[0] == xc.max()  # joined, no overlap
    # a flat clamp has no curvature-dominated mode; the failed row draws nothing
    assert not _row_lines(a, 1.0, 0.0)["curvature_dominated"]
    assert len(_row_lines(a, 1.0, 0.0)["gravity_dominated"]) == 1
    assert not any(_row_lines(b, 0.0, 5.0).values())
    assert not [t for t in b.texts if (t.get_gid() or "").startswith("jump")]
    assert a.get_lines()[0].get_linestyle() in ("-", "--")


def test_fig4_insets_against_area():
    df = _table({0.0: [0.0, 0.2, 0.4, 0.6, 0.8, 1.0], 2.5: [0.0, 0.2, 0.4, 0.6, 0.8, 1.0]})
    fig = figures.draw_fig4(df, "quick")
    axes = fig.axes + [c for ax in fig.axes for c in ax.child_axes]
    labels = [(ax.get_xlabel(), ax.get_ylabel()) for ax in axes]
    assert labels.count(("$A/a^2$", "$d/a$")) == 2
    assert ("$L/a$", "$d/a$") in labels
    texts = _legend_texts(fig)
    assert {f"$b/a={b:g}$" for b in (0, 0.2, 0.4, 0.6, 0.8, 1)} <= set(texts)
    assert "gravity-dominated" in texts
    # insets: the same curves against A/a^2 = (1 + b/a) L / 2
    main_b, inset_b = fig.axes[1], fig.axes[1].child_axes[0]
    for b in (0.0, 0.8):
        for mode in ("curvature_dominated", "gravity_dominated"):
            m, i = _row_lines(main_b, b, 2.5)[mode], _row_lines(inset_b, b, 2.5)[mode]
            assert len(m) == len(i) == 1
            np.testing.assert_allclose(i[0].get_xdata(), 0.5 * (1 + b) * m[0].get_xdata())
    # b/a = 0.8 is bistable at a/R = 2.5 in the toy map, b/a = 0.6 is not
    assert len(_xs(_row_lines(main_b, 0.8, 2.5)["gravity_dominated"])) > 0
    assert _xs(_row_lines(main_b, 0.8, 2.5)["curvature_dominated"]).max() > \
        _xs(_row_lines(main_b, 0.8, 2.5)["gravity_dominated"]).min()
    assert _xs(_row_lines(main_b, 0.6, 2.5)["curvature_dominated"]).max() <= \
        _xs(_row_lines(main_b, 0.6, 2.5)["gravity_dominated"]).min()


def _ribbon_rows(curvatures=(2.5, 5.0)):
    rows = []
    for c in curvatures:
        for b in np.linspace(0, 1, 6):
            for dr in ("increasing", "decreasing"):
                for L in np.round(np.arange(0.5, 3.0 + 1e-9, 0.1), 6):
                    up = dr == "increasing" and b > 0.5 and L > 1.0 + 0.1 * c
                    rows.append(dict(curvature=c, tip_width=b, length=L, direction=dr,
                                     deflection=L + up, converged=True, stable=True,
                                     jumped=bool(up and L < 1.05 + 0.1 * c + 0.1)))
    return pd.DataFrame(rows)


def test_fig6_modes_boundary_and_ribbon_jumps(tmp_path):
    grid = {2.5: [0, .2, .4, .5, .6, .7, .8, .9, 1], 5.0: [0, .2, .4, .5, .6, .7, .8, .9, 1]}
    df = _table(grid)
    Lm = np.round(np.arange(0.6, 2.8 + 1e-9, 0.2), 6)
    fig = figures.draw_fig6(df, _ribbon_rows(), "quick", mode_lengths=Lm)
    fig.savefig(tmp_path / "f6.png")
    ax_a, ax_b, cax = fig.axes
    assert ax_b.get_xlabel() == "$L/a$" and ax_a.get_ylabel() == "$b/a$"
    assert cax.get_ylabel() == "$d/a$ (ribbon model)"
    crit = foldmap.critical_tip_width(df)
    for ax, c in ((ax_a, 2.5), (ax_b, 5.0)):
        rows = df[df.curvature == c]
        cd = {(L, b) for _, r in rows.iterrows() for L, m in zip(Lm, foldmap.modes(r, Lm)[0])
              if m for b in [r.tip_width]}
        gd = {(L, b) for _, r in rows.iterrows() for L, m in zip(Lm, foldmap.modes(r, Lm)[1])
              if m for b in [r.tip_width]}
        (dia,) = _lines(ax, "fe-curvature")
        (sq,) = _lines(ax, "fe-gravity")
        assert dia.get_marker() == "D" and sq.get_marker() == "s"
        assert set(zip(dia.get_xdata(), dia.get_ydata())) == cd
        assert set(zip(sq.get_xdata(), sq.get_ydata())) == gd
        both = cd & gd
        assert both and all(_folds(b, c) is not None for _, b in both)  # only where bistable
        # the solid boundary passes through (L0*, b) and (L1*, b), closed at (b/a)*
        (bd,) = _lines(ax, "fe-folds")
        pts = set(zip(np.round(bd.get_xdata(), 9), np.round(bd.get_ydata(), 9)))
        for b in (0.7, 0.8, 0.9, 1.0):
            L0, L1 = _folds(b, c)
            assert (round(L0, 9), round(b, 9)) in pts and (round(L1, 9), round(b, 9)) in pts
        assert min(bd.get_ydata()) == pytest.approx(crit[c][0])
        assert 0.6 <= crit[c][0] <= 0.7
        assert not np.isnan(bd.get_xdata()).any()  # one closed curve
        # the ribbon model's jumps (L increasing), dashed
        (jl,) = _lines(ax, "ribbon-jump")
        assert jl.get_linestyle() == "--"
        assert np.nanmin(jl.get_xdata()) == pytest.approx(1.0 + 0.1 * c + 0.05, abs=0.051)
    texts = _legend_texts(fig)
    assert {"FE: curvature-dominated mode", "FE: gravity-dominated mode",
            "ribbon: jump ($L$ increasing)"} <= set(texts)


def test_fig6_ribbon_map_cached(tmp_path, monkeypatch):
    from skfem_sheet.reduced import maps

    calls = []

    def fake(c, lengths, tips, **kw):
        calls.append(len(tips))
        return [
            dict(curvature=c, tip_width=float(b), length=float(L), direction=dr,
                 deflection=0.1 * L, converged=True, stable=True, jumped=False)
            for b in tips for dr in ("increasing", "decreasing") for L in lengths]

    monkeypatch.setattr(maps, "ribbon_map", fake)
    df = figures.fig6_ribbon("quick", tmp_path, progress=False, workers=2)
    s = figures.quality_settings("quick")
    assert sum(calls) == 2 * s["fig6_ribbon_tips"]  # every shape of both curvatures once
    assert len(df) == 2 * 2 * 26 * s["fig6_ribbon_tips"]
    again = figures.fig6_ribbon("quick", tmp_path, progress=False)
    assert sum(calls) == 2 * s["fig6_ribbon_tips"] and len(again) == len(df)


def test_fig7_surfaces_only_where_bistable(tmp_path):
    grid = {c: [.5, .6, .7, .8, .9, 1.0] for c in (1.0, 1.5, 2.0, 2.5, 3.5, 5.0)}
    df = _table(grid)
    fig = figures.draw_fig7(df, "quick")
    fig.savefig(tmp_path / "f7.png")
    ax = fig.axes[0]
    assert (ax.get_xlabel(), ax.get_ylabel(), ax.get_zlabel()) == ("$b/a$", "$a/R$", "$L/a$")
    assert "standout" in fig._suptitle.get_text() and "pop-up" in fig._suptitle.get_text()
    region = figures.bistable_region(df)
    nodes, tris = region_mesh(region)
    bistable = {(b, c) for c, bs in grid.items() for b in bs if _folds(b, c) is not None}
    critical = {(round(b, 9), round(c, 9)) for b, c, _ in region["critical"]}
    # every node is a bistable (b, a/R) or a point of the critical curve, and every
    # bistable row is a node: no surface over a row that is not bistable
    node_set = {(round(b, 9), round(c, 9)) for b, c, *_ in nodes}
    assert node_set == {(round(b, 9), round(c, 9)) for b, c in bistable} | critical
    for b, c, L0, L1 in nodes:
        if (round(b, 9), round(c, 9)) in critical:
            assert L0 == L1
        else:
            assert (L0, L1) == pytest.approx(_folds(b, c))
    assert len(tris) >= len(nodes) - 2
    # the critical curve of the toy map: (b/a)* in (0.6, 0.7) at a/R >= 2
    assert all(0.6 <= b <= 0.7 for b, c, _ in region["critical"] if c >= 2.0)
    surfaces = {c.get_gid() for c in ax.collections if c.get_gid()}
    assert {"surface-L1", "surface-L0"} <= surfaces
    # (b): one pair of curves per bistable a/R
    ax2 = fig.axes[1]
    assert ax2.get_xlabel() == "$b/a$" and ax2.get_ylabel() == "$L/a$"
    assert {t for t in _legend_texts(fig)} >= {"$a/R=2$", "$a/R=2.5$", "$a/R=3.5$", "$a/R=5$"}
    for c in (2.0, 5.0):
        (l1,) = [ln for ln in ax2.get_lines() if ln.get_gid() == f"L1|k={c:g}"]
        (l0,) = [ln for ln in ax2.get_lines() if ln.get_gid() == f"L0|k={c:g}"]
        assert l1.get_xdata()[0] == l0.get_xdata()[0] and l1.get_ydata()[0] == l0.get_ydata()[0]


def test_fig7_without_bistability_draws_no_surface():
    fig = figures.draw_fig7(_table({1.0: [.5, .6, .7, .8, .9, 1.0]}), "quick")
    assert not [c for c in fig.axes[0].collections if c.get_gid()]


# -- the command line -----------------------------------------------------------------------
def test_cli_rejects_bad_name_and_quality(capsys, tmp_path):
    for argv in (["figure", "fig9"], ["figure", "fig2", "--quality", "draft"]):
        with pytest.raises(SystemExit) as err:
            main(argv)
        assert err.value.code == 2
        msg = capsys.readouterr().err
        assert msg.count("\n") == 1 and "invalid choice" in msg
    assert main(["figure", "fig2", "--out", str(tmp_path / "x.txt")]) == 2
    msg = capsys.readouterr().err
    assert msg.count("\n") == 1 and "--out must end with .png" in msg
    assert main(["figure", "fig2", "--out", str(tmp_path / "nope" / "x.png")]) == 2
    assert capsys.readouterr().err.count("\n") == 1


def test_cli_draws_from_the_cached_map(compute, tmp_path, capsys):
    d = tmp_path / "d"
    figures.fig7("quick", data_dir=d, progress=False, workers=1)
    n = len(compute)
    out = tmp_path / "f.png"
    assert main(["figure", "fig7", "--out", str(out), "--data-dir", str(d), "--quiet"]) == 0
    assert len(compute) == n
    assert out.read_bytes()[:8] == PNG_MAGIC
    assert (d / "foldmap-quick.csv").exists()
    assert "wrote" in capsys.readouterr().out


def test_with_a_real_map_point(tmp_path):
    """A real (tiny) fold-map point goes through the table, the drawing and the cache."""
    pts = foldmap.map_points([0.0], [2.5], lengths=(0.8, 1.0), hmax=0.2, step=0.2)
    table = str(tmp_path / "t.csv")
    df = foldmap.fold_map(pts, table=table, workers=1, progress=False)
    assert bool(df.converged[0]) and not bool(df.bistable[0])
    fig = figures.draw_fig2(df)
    lines = _row_lines(fig.axes[1], 0.0, 2.5)
    drawn = [ln for v in lines.values() for ln in v]
    assert len(drawn) == 1  # a triangle: one curve
    # both points are named curvature-dominated (the transition at the row's end,
    # foldmap.transition_length), so the curvature-dominated curve is drawn whole
    assert lines["curvature_dominated"] == drawn
    L, d, _ = foldmap.branch_curve(df.iloc[0], "curvature_dominated")
    np.testing.assert_allclose(drawn[0].get_ydata(), d)
    again = foldmap.fold_map(pts, table=table, workers=1, progress=False)
    assert again.attrs["fold_map"]["new"] == 0
    assert again["curvature_dominated"][0] == df["curvature_dominated"][0]


# -- structured columns, old tables, the cache, the package ----------------------------------
def _snap_variants():
    """One non-bistable row (a/R = 2.5, b/a = 0) as a dict, and its two curves' lengths."""
    (p,) = foldmap.map_points([0.0], [2.5])
    row = dict(synthetic_row(p))
    row.pop("curvature_dominated_snapped", None)
    row.pop("gravity_dominated_snapped", None)
    return row


def _same_branches(a, b):
    assert a.keys() == b.keys()
    for k in a:
        if isinstance(a[k], tuple):
            for x, y in zip(a[k], b[k]):
                np.testing.assert_array_equal(x, y)
        else:
            assert a[k] == b[k] or (a[k] != a[k] and b[k] != b[k])


def test_row_branches_reads_the_snapped_columns():
    row = _snap_variants()
    sentence = "the gravity-dominated branch does not exist at L/a = 3 (raise length_max)"
    full = figures.row_branches(dict(row, curvature_dominated_snapped=False,
                                     gravity_dominated_snapped=False))
    assert len(full["curvature_dominated"][0]) and len(full["gravity_dominated"][0])
    new = figures.row_branches(dict(row, curvature_dominated_snapped=False,
                                    gravity_dominated_snapped=True))
    assert len(new["gravity_dominated"][0]) == 0  # started on the other branch: not drawn
    np.testing.assert_array_equal(new["curvature_dominated"][0], full["curvature_dominated"][0])
    # the column decides, not the prose: a message alone does not hide a branch of a new row
    prose = figures.row_branches(dict(row, message=sentence, curvature_dominated_snapped=False,
                                      gravity_dominated_snapped=False))
    _same_branches(prose, full)
    # an old row (no columns, or missing values) is read from its message as before
    for old in (dict(row, message=sentence),
                dict(row, message=sentence, curvature_dominated_snapped=None,
                     gravity_dominated_snapped=pd.NA),
                dict(row, message=sentence, curvature_dominated_snapped=math.nan,
                     gravity_dominated_snapped=math.nan)):
        _same_branches(figures.row_branches(old), new)
    # both ways through a table, as the drawing reads it
    df_new = _table({2.5: [0.0]}).assign(curvature_dominated_snapped=False,
                                         gravity_dominated_snapped=True)
    # an old table has no snapped columns (the synthetic rows carry them: drop them)
    df_old = _table({2.5: [0.0]}).drop(columns=["curvature_dominated_snapped",
                                                "gravity_dominated_snapped"]).assign(message=sentence)
    lines_new = _row_lines(figures.draw_fig2(df_new).axes[1], 0.0, 2.5)
    lines_old = _row_lines(figures.draw_fig2(df_old).axes[1], 0.0, 2.5)
    assert not lines_new["gravity_dominated"] and not lines_old["gravity_dominated"]
    np.testing.assert_array_equal(_xs(lines_new["curvature_dominated"]),
                                  _xs(lines_old["curvature_dominated"]))
    # the boolean column as a CSV gives it back (strings) is read too
    assert figures.row_branches(dict(row, gravity_dominated_snapped="True"))[
        "gravity_dominated"][0].size == 0


def test_old_curves_with_nan_literals_read_as_null():
    """Tables written before the one JSON convention hold NaN literals; both read alike."""
    row = _snap_variants()
    c = json.loads(row["curvature_dominated"])
    c["deflection"][1] = math.nan
    old = json.dumps(c)  # NaN literal
    assert "NaN" in old
    from skfem_sheet.io import dumps_json

    new = dumps_json(c, indent=None)  # null
    assert "NaN" not in new and "null" in new
    a = figures.row_branches(dict(row, curvature_dominated=old))
    b = figures.row_branches(dict(row, curvature_dominated=new))
    _same_branches(a, b)
    assert np.isnan(a["curvature_dominated"][1]).sum() == 1


def test_cached_tables(tmp_path):
    calls = []

    def compute(n=3):
        calls.append(n)
        return pd.DataFrame({"x": np.arange(n, dtype=float), "ok": [True] * n})

    fn = tmp_path / "t.csv"
    first = cache.cached(fn, compute)
    again = cache.cached(fn, compute)
    assert calls == [3] and again.equals(first)
    # a table that is not the one wanted is recomputed and replaced
    third = cache.cached(fn, lambda: compute(4), accept=lambda df: len(df) == 4)
    assert calls == [3, 4] and len(third) == 4 and len(pd.read_csv(fn)) == 4
    # arrays: a compressed .npz, read back as a dict
    arrays = {"X": np.eye(3), "message": np.array("hi")}
    got = cache.cached(tmp_path / "a.npz", lambda: arrays)
    back = cache.cached(tmp_path / "a.npz", lambda: 1 / 0)
    np.testing.assert_array_equal(back["X"], got["X"])
    assert str(back["message"]) == "hi"
    # a failed computation writes nothing; no temporary file is ever left behind
    with pytest.raises(ZeroDivisionError):
        cache.cached(tmp_path / "b.csv", lambda: 1 / 0)
    assert sorted(os.listdir(tmp_path)) == ["a.npz", "t.csv"]
    with pytest.raises(ParameterError, match="path must end with .csv or .npz"):
        cache.cached(tmp_path / "t.json", compute)
    with pytest.raises(ParameterError, match="a .csv cache holds a DataFrame"):
        cache.cached(tmp_path / "c.csv", lambda: arrays)
    blocker = tmp_path / "file"
    blocker.write_text("")
    with pytest.raises(ParameterError, match="data_dir must be a writable folder"):
        cache.data_folder(blocker)


def test_fig3_surfaces_cached(tmp_path, monkeypatch):
    calls = []

    def fake(sheet, path, hmax):
        calls.append((sheet.tip_width, path))
        X = np.array([[0, -.5, 0], [1, -.5, -.2], [1, .5, -.2], [0, .5, 0.]])
        X = X * (1 + sheet.tip_width)
        return {"X": X, "tri": np.array([[0, 1, 2], [0, 2, 3]]), "psi": np.array([.01, .02]),
                "deflection": 0.2, "converged": True, "message": "", "snapped": False,
                "hmax": float(hmax)}

    monkeypatch.setattr(figure3, "_solve_surface", fake)
    first = figures.fig3_data("quick", tmp_path, progress=False)
    assert len(calls) == 6 and [p for p, *_ in first] == list("defghi")
    again = figures.fig3_data("quick", tmp_path, progress=False)
    assert len(calls) == 6  # read from data_dir/fig3-quick/*.npz
    assert len(os.listdir(tmp_path / "fig3-quick")) == 6
    for a, b in zip(first, again):
        np.testing.assert_array_equal(a[4]["X"], b[4]["X"])
        assert {k: type(v) for k, v in a[4].items() if k not in ("X", "tri", "psi")} == \
            {k: type(v) for k, v in b[4].items() if k not in ("X", "tri", "psi")} == \
            {"deflection": float, "converged": bool, "message": str, "snapped": bool,
             "hmax": float}
    figures.draw_fig3(again, "quick")


def _package_imports():
    """``{module file: [(imported module, names), ...]}`` of skfem_sheet/figures/."""
    out = {}
    for path in sorted(Path(figures.__file__).parent.glob("*.py")):
        found = []
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                found += [(a.name, ()) for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                mod = "." * node.level + (node.module or "")
                found.append((mod, tuple(a.name for a in node.names)))
        out[path.name] = found
    return out


def test_figures_package_has_no_argparse_and_one_door_to_the_studies():
    imports = _package_imports()
    assert {"__init__.py", "figure2.py", "figure7.py", "cache.py", "data.py"} <= set(imports)
    for name, found in imports.items():
        mods = [m for m, _ in found]
        assert not any(m.split(".")[0] == "argparse" for m in mods), name
        studies = [(m, n) for m, n in found
                   if {"foldmap", "sweep", "studies"} & set(m.strip(".").split("."))
                   or (m.strip(".") in ("", "skfem_sheet") and {"foldmap", "sweep"} & set(n))]
        assert not studies or name == "data.py", (name, studies)
        # what a module takes from another is public there
        private = [(m, n) for m, names in found for n in names if n.startswith("_")
                   and n != "annotations"]
        assert not private, (name, private)
    assert not hasattr(figures, "add_figure_subparser")
    # the command line calls make_figure with these arguments
    assert list(inspect.signature(figures.make_figure).parameters) == [
        "name", "quality", "out", "data_dir", "progress", "workers", "log"]


# -- fig6's rows below the cusp: traced on the fine mesh around their transition ---------------
#: The toy transition of each (b/a, a/R) on the fine mesh, and how far the coarse one lies
#: from it: 0.02 (inside the window), 0.35 (the fine transition outside the window).
_TOY_TRANSITION = {(0.3, 5.0): (1.71, 0.02), (0.1, 5.0): (1.9, 0.35), (0.4, 5.0): (1.8, 0.0),
                   (0.5, 5.0): (1.65, 0.0)}


def _toy_transition_row(point):
    """A monotone row, d(L) rising through one steep part at the toy transition
    (shifted on the coarse mesh); the coarse (0.5, 5) row has a fold."""
    b, c = float(point["tip_width"]), float(point["curvature"])
    t, shift = _TOY_TRANSITION[(b, c)]
    coarse = float(point["hmax"]) >= 0.1
    t += shift if coarse else 0.0
    lo, hi, h = (float(point[k]) for k in ("length_min", "length_max", "step"))
    L = np.round(lo + h * np.arange(round((hi - lo) / h) + 1), 9)
    d = 0.5 * (1 + np.tanh((L - t) / 0.15))
    rec = foldmap._empty_record(dict(point), foldmap.map_key(point))
    rec.update(curvature_dominated=_curve(L, d), gravity_dominated=_curve(L[::-1], d[::-1]),
               converged=True, newton_iterations=10, wall_time_s=1.0,
               curvature_dominated_snapped=False, gravity_dominated_snapped=False)
    if coarse and (b, c) == (0.5, 5.0):
        rec.update(popup_length=t, standout_length=t)
    rec["transition_length"] = foldmap.transition_length(rec)
    return rec


def test_transition_rows_trace_the_fine_mesh_around_the_coarse_transition(tmp_path,
                                                                           monkeypatch):
    calls = []

    def fake(point):
        calls.append((point["tip_width"], point["hmax"], point["length_min"],
                      point["length_max"]))
        return _toy_transition_row(point)

    monkeypatch.setattr(foldmap, "_run_map_point", fake)
    pts = figure_data.map_grid_points("paper", lambda c, b: c == 5.0
                                      and b in (0.1, 0.3, 0.4, 0.5))
    assert [p["tip_width"] for p in pts] == [0.1, 0.3, 0.4, 0.5]
    full = [p for p in pts if p["tip_width"] == 0.4]
    df = figure_data.transition_rows(pts, "paper", str(tmp_path), progress=False, workers=1,
                                     full=full)
    rows = {float(r.tip_width): r for _, r in df.iterrows()}
    # b 0.3: windowed around the coarse 1.73 on the grid of the whole row, and its
    # transition is the whole row's (the same steepest interval of the same grid)
    assert (rows[0.3].length_min, rows[0.3].length_max) == (1.5, 1.95)
    whole = _toy_transition_row({**pts[1]})
    assert foldmap.transition_length(rows[0.3]) == foldmap.transition_length(whole)
    # b 0.1: the fine steepest interval at the window's edge -> the whole row
    # b 0.4: drawn whole elsewhere -> the whole row, no coarse row
    # b 0.5: a fold on the coarse mesh -> the whole row
    for b in (0.1, 0.4, 0.5):
        assert (rows[b].length_min, rows[b].length_max) == (0.5, 3.0)
    assert (0.4, 0.1, 0.5, 3.0) not in calls
    assert [c for c in calls if c[0] == 0.3] == [(0.3, 0.1, 0.5, 3.0), (0.3, 0.03, 1.5, 1.95)]
    assert [c[1:] for c in calls if c[0] == 0.1] == [(0.1, 0.5, 3.0), (0.03, 2.0, 2.45),
                                                     (0.03, 0.5, 3.0)]
    # a second call computes nothing again (every row is journalled)
    calls.clear()
    again = figure_data.transition_rows(pts, "paper", str(tmp_path), progress=False, workers=1,
                                        full=full)
    assert calls == [] and list(again.key) == list(df.key)


def test_transition_rows_of_the_quick_quality_are_the_whole_rows(tmp_path, monkeypatch):
    """Without a coarser mesh (hmax 0.1) nothing is windowed."""
    calls = []

    def fake(point):
        calls.append(point["hmax"])
        return _toy_transition_row(point)

    monkeypatch.setattr(foldmap, "_run_map_point", fake)
    pts = figure_data.map_grid_points("quick", lambda c, b: c == 5.0 and b == 0.4)
    df = figure_data.transition_rows(pts, "quick", str(tmp_path), progress=False, workers=1)
    assert calls == [0.1] and (df.length_min[0], df.length_max[0]) == (0.5, 3.0)
