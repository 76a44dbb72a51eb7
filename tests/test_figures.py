"""Figures (issue 6): drawing on synthetic data, caching, and the ``figure`` command.

The finite-element data come from :mod:`skfem_sheet.sweep`; here a stand-in
with the same contract (``grid`` = cartesian product, ``run_sweep`` = journal
table in which points already present are not recomputed) returns synthetic
rows, so these tests run in seconds.
"""
import itertools
import sys
import types

import numpy as np
import pytest

pd = pytest.importorskip("pandas")

from skfem_sheet import figures  # noqa: E402
from skfem_sheet.cli import main  # noqa: E402

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def _synthetic_row(p):
    L, b, k, path = p["length"], p["tip_width"], p["curvature"], p["path"]
    d = 0.35 * L**2 * (1 + b) / 2 - 0.08 * k
    snapped = False
    if path == "gravity-first" and k >= 2.5 and 1.1 < L < 1.8:
        d += 0.5  # the drooped branch of a bistable sheet
    if path == "curvature-first" and b == 1.0 and k == 5.0 and L == 2.2:
        snapped, d = True, d + 0.5  # landed on the drooped branch
    converged = not (b == 0.0 and k == 5.0 and L == 0.6 and path == "curvature-first")
    return {**p, "deflection": d, "converged": converged, "snapped": snapped,
            "branch": "gravity-dominated" if d > 0.3 else "curvature-dominated",
            "stable": True, "newton_iterations": 10, "wall_time_s": 1.0}


class FakeSweep(types.ModuleType):
    """Stand-in for skfem_sheet.sweep: a CSV journal per table."""

    def __init__(self):
        super().__init__("skfem_sheet.sweep")
        self.computed = 0
        self.tables = []

    @staticmethod
    def grid(**axes):
        keys = list(axes)
        vals = [v if isinstance(v, (list, tuple)) else [v] for v in axes.values()]
        return [dict(zip(keys, combo)) for combo in itertools.product(*vals)]

    @staticmethod
    def add_sweep_subparser(sub):
        """The real module registers a ``sweep`` command; the stand-in has none."""

    def run_sweep(self, points, table, workers=None, progress=True):
        self.tables.append(str(table))
        try:
            old = pd.read_csv(table)
        except FileNotFoundError:
            old = pd.DataFrame()
        have = set()
        if len(old):
            have = {(r.length, r.tip_width, r.curvature, r.path, r.hmax)
                    for r in old.itertuples()}
        new = [_synthetic_row(p) for p in points
               if (p["length"], p["tip_width"], p["curvature"], p["path"], p["hmax"]) not in have]
        self.computed += len(new)
        df = pd.concat([old, pd.DataFrame(new)], ignore_index=True) if new else old
        df.to_csv(table, index=False)
        return pd.read_csv(table)


@pytest.fixture
def sweep(monkeypatch):
    fake = FakeSweep()
    monkeypatch.setitem(sys.modules, "skfem_sheet.sweep", fake)
    return fake


def _legend_texts(fig):
    texts = []
    for ax in fig.axes:
        for child in ax.get_children():
            if child.__class__.__name__ == "Legend":
                texts += [t.get_text() for t in child.get_texts()]
    for leg in fig.legends:
        texts += [t.get_text() for t in leg.get_texts()]
    return texts


def test_fig2_png_axes_legend(sweep, tmp_path):
    out = tmp_path / "fig2.png"
    fig = figures.make_figure("fig2", "quick", out=str(out), data_dir=tmp_path, progress=False)
    assert out.read_bytes()[:8] == PNG_MAGIC
    a, b = fig.axes
    assert b.get_xlabel() == "$L/a$" and a.get_ylabel() == b.get_ylabel() == "$d/a$"
    texts = _legend_texts(fig)
    for k in ("0", "1", "2.5", "5"):
        assert f"$a/R={k}$" in texts
    assert {"curvature-first", "gravity-first"} <= set(texts)
    # the failed triangle point is counted, the snapped rectangle point flagged
    assert "(b) 1 not converged, omitted" in texts and "(a) snapped (1)" in texts
    # omitted means omitted: the failed point is not among the plotted ones
    n = len(figures.quality_settings("quick")["lengths"])
    curves = [ln for ln in b.get_lines() if ln.get_marker() == "o"]
    assert sorted(len(ln.get_xdata()) for ln in curves) == [n - 1, n, n, n]
    assert 0.6 not in [ln for ln in curves if len(ln.get_xdata()) == n - 1][0].get_xdata()
    assert sweep.computed == len(figures.fig2_points("quick"))


def test_points_match_the_grids(sweep):
    n = len(figures.quality_settings("quick")["lengths"])
    p2 = figures.fig2_points("quick")
    p4 = figures.fig4_points("quick")
    paper = figures.fig2_points("paper")
    # rect+tri at a/R=0 (one path), rectangles both paths, triangles curvature-first
    assert len(p2) == n * (2 + 3 * 2 + 3)
    assert {p["hmax"] for p in p2} == {0.1}
    assert {p["hmax"] for p in paper} == {0.03}
    assert len(paper) == 47 * (2 + 3 * 2 + 3 * 2)
    assert {p["tip_width"] for p in p4} == {0.0, 0.2, 0.4, 0.6, 0.8, 1.0}
    gf = {p["tip_width"] for p in p4 if p["path"] == "gravity-first"}
    assert gf == {0.6, 0.8, 1.0} and all(p["curvature"] == 2.5 for p in p4
                                         if p["path"] == "gravity-first")
    assert len({(p["length"], p["tip_width"], p["curvature"], p["path"]) for p in p2}) == len(p2)


def test_drawing_twice_computes_nothing_twice(sweep, tmp_path):
    figures.fig2("quick", data_dir=tmp_path, progress=False)
    n = sweep.computed
    assert n > 0
    figures.fig2("quick", data_dir=tmp_path, progress=False)
    figures.fig4("quick", data_dir=tmp_path, progress=False)
    m = sweep.computed
    figures.fig4("quick", data_dir=tmp_path, progress=False)
    assert sweep.computed == m and m - n == len(figures.fig4_points("quick"))
    # one table per figure and quality; fig5 reads fig2's
    assert sweep.tables[0].endswith("fig2-quick.csv")
    assert sweep.tables[-1].endswith("fig4-quick.csv")


def test_select_filters_other_points_and_duplicates():
    pts = [dict(length=1.0, tip_width=1.0, curvature=2.5, path="gravity-first", hmax=0.1)]
    df = pd.DataFrame([
        {**pts[0], "deflection": 0.1},
        {**pts[0], "deflection": 0.2},                     # recomputed later: keep the last
        {**pts[0], "hmax": 0.03, "deflection": 0.3},       # another mesh
        {**pts[0], "path": "curvature-first", "deflection": 0.4},
    ])
    out = figures._select(df, pts)
    assert out["deflection"].tolist() == [0.2]


class _FakeBranch:
    def __init__(self, lengths, direction, tip, k):
        L = np.sort(np.asarray(lengths, float))
        if direction == "decreasing":
            L = L[::-1]
        self.lengths = L
        up = (direction == "increasing") & (L < 1.4)
        self.deflection = np.where(up | (L < 1.3), 0.0, 0.5) + 0.1 * L * (1 + tip) - 0.01 * k
        self.converged = np.ones(L.size, bool)
        self.converged[-1] = tip != 0.0 or k != 1.0  # one failed ribbon point
        self.jumped = np.zeros(L.size, bool)
        j = np.flatnonzero(np.diff(self.deflection) != np.diff(self.deflection).mean())
        self.jumped[j[:1] + 1] = tip == 1.0 and k == 2.5


def test_fig5_fe_from_fig2_table_and_cached_ribbon(sweep, tmp_path, monkeypatch):
    import skfem_sheet.reduced as reduced

    calls = []

    def fake_continuation(template, lengths, direction="increasing", **kw):
        calls.append((template.tip_width, template.curvature, direction))
        return _FakeBranch(lengths, direction, template.tip_width, template.curvature)

    monkeypatch.setattr(reduced, "ribbon_continuation", fake_continuation)
    figures.fig2("quick", data_dir=tmp_path, progress=False)
    n = sweep.computed
    fig = figures.make_figure("fig5", "quick", out=str(tmp_path / "f5.png"),
                              data_dir=tmp_path, progress=False)
    assert sweep.computed == n  # FE points are fig2's
    assert sweep.tables[-1].endswith("fig2-quick.csv")
    assert len(calls) == 8  # 2 shapes x 2 curvatures x 2 directions
    figures.fig5("quick", data_dir=tmp_path, progress=False)
    assert len(calls) == 8  # cached
    assert len(fig.axes) == 4
    assert [ax.get_xlabel() for ax in fig.axes] == ["", "", "$L/a$", "$L/a$"]
    assert fig.axes[0].get_ylabel() == "$d/a$"
    texts = _legend_texts(fig)
    assert {"FE, curvature-first", "FE, gravity-first", "ribbon, $L$ increasing",
            "ribbon, $L$ decreasing", "ribbon: 2 not converged, omitted"} <= set(texts)
    # the ribbon branch is broken (NaN) at its jump
    ax_c = fig.axes[2]
    dashed = [ln for ln in ax_c.get_lines() if ln.get_linestyle() == "--"]
    assert any(np.isnan(ln.get_ydata().astype(float)).any() for ln in dashed)


def test_fig3_one_colour_scale_and_cache(tmp_path, monkeypatch):
    calls = []

    def fake_surface(sheet, path, hmax):
        calls.append((sheet.tip_width, path))
        x, y = np.meshgrid(np.linspace(0, sheet.length, 4), np.linspace(-0.5, 0.5, 3))
        X = np.c_[x.ravel(), y.ravel() * (1 - (1 - sheet.tip_width) * x.ravel() / sheet.length),
                  -0.2 * x.ravel()]
        tri = np.array([[0, 1, 4], [0, 4, 3], [4, 5, 8], [4, 8, 7]])
        psi = np.full(len(tri), 0.01 * (1 + sheet.tip_width))
        return {"X": X, "tri": tri, "psi": psi, "deflection": 0.26, "converged": True,
                "message": "", "snapped": False, "hmax": float(hmax)}

    monkeypatch.setattr(figures, "_solve_surface", fake_surface)
    fig = figures.make_figure("fig3", "quick", out=str(tmp_path / "f3.png"),
                              data_dir=tmp_path, progress=False)
    assert len(calls) == 6 and {p for _, p in calls} == {"curvature-first", "gravity-first"}
    assert sorted(b for b, _ in calls) == [0.0, 0.4, 0.6, 0.8, 1.0, 1.0]
    assert (tmp_path / "f3.png").read_bytes()[:8] == PNG_MAGIC
    sheets = [ax for ax in fig.axes if ax.name == "3d"]
    assert len(sheets) == 6 and len(fig.axes) == 7  # six sheets + one colour bar
    assert fig.axes[-1].get_ylabel().startswith(r"$\psi/\mu$")
    assert all(ax.get_xlabel() == "$x/a$" and ax.get_zlabel() == "$z/a$" for ax in sheets)
    # one colour scale: the colour bar spans 0 .. the 99th percentile of all sheets
    assert fig.axes[-1].get_ylim()[1] == pytest.approx(0.02, rel=1e-9)
    assert sheets[0].get_title().startswith("(d) rectangle, gravity-dominated")
    figures.fig3("quick", data_dir=tmp_path, progress=False)
    assert len(calls) == 6  # read from the npz cache


def test_fig4_axes_insets_legend(sweep, tmp_path):
    fig = figures.fig4("quick", data_dir=tmp_path, progress=False)
    axes = fig.axes + [c for ax in fig.axes for c in ax.child_axes]
    labels = [(ax.get_xlabel(), ax.get_ylabel()) for ax in axes]
    assert labels.count(("$A/a^2$", "$d/a$")) == 2  # two insets against the area
    assert ("$L/a$", "$d/a$") in labels
    texts = _legend_texts(fig)
    assert {f"$b/a={b:g}$" for b in (0, 0.2, 0.4, 0.6, 0.8, 1)} <= set(texts)
    assert "gravity-first" in texts


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


def test_cli_writes_png(sweep, tmp_path, capsys):
    out = tmp_path / "f.png"
    assert main(["figure", "fig2", "--out", str(out), "--data-dir", str(tmp_path / "d"),
                 "--quiet"]) == 0
    assert out.read_bytes()[:8] == PNG_MAGIC
    assert (tmp_path / "d" / "fig2-quick.csv").exists()
    assert "wrote" in capsys.readouterr().out


def test_with_the_real_sweep(tmp_path):
    """The real sweep's table (dtypes, NA) goes through selection and drawing; cached."""
    sweep_mod = pytest.importorskip("skfem_sheet.sweep")
    pts = sweep_mod.grid(length=0.3, curvature=[0.0, 2.5], hmax=0.2)
    table = str(tmp_path / "t.csv")
    df = figures._sweep_table(pts, table, progress=False, workers=1)
    assert len(df) == len(pts) and df["converged"].all()
    fig = figures.draw_fig2(df)
    assert "$a/R=2.5$" in _legend_texts(fig)
    again = sweep_mod.run_sweep(pts, table=table, workers=1, progress=False)
    assert again.attrs["sweep"]["new"] == 0
    assert figures._select(again, pts[:1])["deflection"].tolist() == [df["deflection"][0]]
