"""The switching figure (issue 58): its lengths, its cached table, its drawing.

The analysis of one length (``figure_switching._row``) and the windows from the fold
map (``_windows``) are replaced by the normal form near each fold, so that the
table's caching and the drawing are tested in seconds; the analysis itself is
``tests/test_switching.py``'s.
"""
import math
import types

import numpy as np
import pytest

pd = pytest.importorskip("pandas")

from skfem_sheet.cli import main  # noqa: E402
from skfem_sheet.figures import FIGURES, make_figure  # noqa: E402
from skfem_sheet.figures import figure_switching as fs  # noqa: E402
from skfem_sheet.params import Sheet  # noqa: E402
from skfem_sheet.switch import CurvePoint, ForceCurve  # noqa: E402

WINDOWS = {2.5: (1.2, 1.35), 5.0: (1.72, 2.02)}


def _toy_row(sheet, hmax):
    """Normal form: F* linear and the barrier ^(3/2) in the distance to each fold."""
    L0, L1 = WINDOWS[sheet.curvature]
    L, W = sheet.length, sheet.area * sheet.thickness
    out = dict.fromkeys(fs.COLUMNS, math.nan)
    out.update(curvature=sheet.curvature, length=L, hmax=hmax, bistable=True, shape="one S",
               error="", weight=W, force_down=-0.5 * W * (L1 - L), force_up=0.4 * W * (L - L0),
               barrier_down=0.2 * W * (L1 - L) ** 1.5, barrier_up=0.3 * W * (L - L0) ** 1.5,
               factorizations=10, wall_time_s=1.0)
    return pd.DataFrame([out], columns=fs.COLUMNS)


@pytest.fixture
def toy(monkeypatch):
    calls = []

    def row(sheet, hmax):
        calls.append((sheet.curvature, sheet.length))
        return _toy_row(sheet, hmax)

    monkeypatch.setattr(fs, "_row", row)
    monkeypatch.setattr(fs, "_windows", lambda *a, **k: dict(WINDOWS))
    # the inset's curve: a toy S (aloft, fold, saddle, fold, drooped)
    pts = (CurvePoint(0.0, -0.04, 0.05, 0.0, 0.06, 0, "start"),
           CurvePoint(-0.0015, -0.08, 0.08, 0.0, 0.0, 0, "fold"),
           CurvePoint(0.0, -0.11, 0.11, 0.0, -0.06, 1, "saddle"),
           CurvePoint(0.0027, -0.29, 0.30, 0.0, 0.0, 0, "fold"),
           CurvePoint(0.0, -0.57, 0.57, 0.0, 0.02, 0, "end"))
    curve = ForceCurve(pts, 0.1, -1, True, "", "one S", factorizations=5)
    monkeypatch.setattr(fs, "switching", lambda *a, **k: types.SimpleNamespace(curve=curve))
    return calls


def test_the_lengths_lie_inside_each_window():
    L = fs.switching_lengths(1.2, 1.35, 5)
    assert len(L) == 5 and L.min() > 1.2 and L.max() < 1.35
    assert np.allclose(np.diff(L), 0.03)
    assert len(fs.switching_lengths(math.nan, math.nan, 5)) == 0   # not bistable: none


def test_the_table_is_cached_point_by_point(toy, tmp_path):
    log = []
    t = fs.switching_table("quick", tmp_path, progress=False, log=log)
    n = fs.LENGTHS_PER_WINDOW["quick"]
    assert len(t) == 2 * n and len(toy) == 2 * n
    assert log[-1].what == "switching" and log[-1].computed == 2 * n
    for c, (L0, L1) in WINDOWS.items():
        rows = t[np.isclose(t["curvature"], c)]
        assert ((rows["length"] > L0) & (rows["length"] < L1)).all()
    again = fs.switching_table("quick", tmp_path, progress=False, log=log)
    assert len(toy) == 2 * n and log[-1].cached == 2 * n   # nothing computed twice
    pd.testing.assert_frame_equal(t, again, check_dtype=False)


def test_the_drawing_extrapolates_to_the_folds(toy, tmp_path):
    t = fs.switching_table("quick", tmp_path, progress=False)
    curve = fs.switching_curve("quick", tmp_path, progress=False)
    assert list(curve["kind"]) == ["start", "fold", "saddle", "fold", "end"]
    fig = fs.draw_switching(t, curve, "quick")
    ax_f, ax_b = fig.axes[:2]
    gids = {ln.get_gid() for ln in ax_f.get_lines()} | {ln.get_gid() for ln in ax_b.get_lines()}
    assert {"force_up|k=2.5", "force_down|k=5", "barrier_up|k=2.5", "barrier_down|k=5"} <= gids
    # the dotted normal-form lines end on F = 0 at the windows' folds (the toy is linear)
    ends = [ln.get_xdata()[-1] for ln in ax_f.get_lines()
            if ln.get_linestyle() == ":" and ln.get_ydata()[-1] == 0]
    for L0, L1 in WINDOWS.values():
        assert min(abs(e - L0) for e in ends) < 1e-9 and min(abs(e - L1) for e in ends) < 1e-9
    assert len(ax_f.child_axes) == 1  # the inset


def test_registered_and_drawn_by_the_command(toy, tmp_path):
    assert FIGURES["switching"] is fs.fig_switching
    out = tmp_path / "switching.png"
    make_figure("switching", "quick", out=str(out), data_dir=str(tmp_path), progress=False)
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert main(["figure", "switching", "--data-dir", str(tmp_path), "--out",
                 str(tmp_path / "b.png"), "--quiet"]) == 0


def test_a_failed_length_is_a_row_not_an_exception(monkeypatch):
    from skfem_sheet.result import SolveError

    def fail(*a, **k):
        raise SolveError("the path did not reach full load")

    monkeypatch.setattr(fs, "switching", fail)
    row = fs._row(Sheet(length=1.3, curvature=2.5), 0.1).iloc[0]
    assert row["bistable"] is False or not row["bistable"]
    assert row["error"].startswith("SolveError")
