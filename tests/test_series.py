"""ParaView time series (skfem_sheet.io.Series, write_series): load paths and branches.

The series are read back with meshio (the ``.pvd`` is parsed as XML for the
list of files and times): one VTU per accepted load step (or branch point),
times strictly increasing, the last step identical to ``Result.write``'s VTU.
"""
import json
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import meshio
import numpy as np
import pytest

from skfem_sheet import Sheet, solve
from skfem_sheet.bistability import follow_length
from skfem_sheet.cli import main
from skfem_sheet.io import Series, read_pvd, write_series
from skfem_sheet.params import ParameterError

RECT = Sheet(length=1.3, curvature=2.5)  # the paper's bistable rectangle
HMAX = 0.2


def _pvd(path):
    """(times, files) parsed from the pvd XML directly (independent of read_pvd)."""
    path = Path(path)
    root = ET.parse(path).getroot()
    assert root.tag == "VTKFile" and root.get("type") == "Collection"
    sets = list(root.iter("DataSet"))
    return ([float(d.get("timestep")) for d in sets],
            [path.parent / d.get("file") for d in sets])


@pytest.fixture(scope="module")
def curvature_first(tmp_path_factory):
    d = tmp_path_factory.mktemp("series")
    s = Series()
    r = solve(RECT, path="curvature-first", hmax=HMAX, series=s)
    pvd = s.write(d / "out", "curvature-first")
    r.write(d / "final.vtu")
    return r, s, d, pvd


def test_curvature_first_series_reads_back(curvature_first):
    r, s, d, pvd = curvature_first
    assert r.converged and r.branch == "curvature-dominated"
    times, files = _pvd(d / "out" / "curvature-first.pvd")
    assert str(pvd) == str(d / "out" / "curvature-first.pvd")
    assert len(files) == len(s) == r.load_steps == len(r.steps)
    assert all(np.diff(times) > 0)
    # curvature ramp on 0..1, then gravity on 1..2: full load is t = 2
    assert times[-1] == pytest.approx(2.0, abs=1e-12)
    assert any(abs(t - 1.0) < 1e-12 for t in times)  # the end of the curvature phase
    assert [(t, str(f)) for t, f in zip(times, files)] == read_pvd(pvd)
    # each step carries its load; the load parameter is kappa/(a/R) + g
    for t, f in zip(times, files):
        m = meshio.read(f)
        k, g = float(m.field_data["kappa"][0]), float(m.field_data["gravity"][0])
        assert t == pytest.approx(k / RECT.curvature + g, abs=1e-12)
        assert float(m.field_data["time"][0]) == pytest.approx(t, abs=1e-12)
        assert set(m.point_data) == {"displacement", "pressure"}
        assert set(m.cell_data) == {"psi_over_mu"}


def test_last_step_equals_result_write(curvature_first):
    r, s, d, pvd = curvature_first
    _, files = _pvd(pvd)
    last, final = meshio.read(files[-1]), meshio.read(d / "final.vtu")
    np.testing.assert_array_equal(last.points, final.points)
    np.testing.assert_array_equal(last.cells_dict["tetra"], final.cells_dict["tetra"])
    for name in ("displacement", "pressure"):
        np.testing.assert_array_equal(last.point_data[name], final.point_data[name])
    np.testing.assert_array_equal(last.cell_data["psi_over_mu"][0], final.cell_data["psi_over_mu"][0])
    # the whole sheet, mirrored: y symmetric about 0, and the tip deflection read off the VTU
    y = last.points[:, 1]
    assert y.min() == pytest.approx(-y.max())
    # earlier steps differ (the sheet moves along the path)
    first = meshio.read(files[0])
    assert not np.allclose(first.point_data["displacement"], last.point_data["displacement"])


def test_series_is_collected_only_when_asked(tmp_path, monkeypatch):
    """Without series no hook is passed to the load path (nothing is kept)."""
    starts_module = sys.modules["skfem_sheet.starts"]

    seen = []
    real = starts_module.follow_path

    def spy(*a, **kw):
        seen.append(kw.get("on_step"))
        return real(*a, **kw)

    monkeypatch.setattr(starts_module, "follow_path", spy)
    solve(Sheet(length=0.4), hmax=0.3)
    assert seen == [None]
    with pytest.raises(ParameterError, match="series"):
        solve(Sheet(length=0.4), hmax=0.3, series="out/")


def test_cli_series_writes_pvd_and_steps(tmp_path, capsys):
    out = tmp_path / "s"
    rc = main(["solve", "--length", "0.5", "--curvature", "1.0", "--path", "gravity-first",
               "--hmax", "0.25", "--series", str(out), "--quiet"])
    assert rc == 0
    times, files = _pvd(out / "gravity-first.pvd")
    assert len(files) >= 2 and all(f.exists() for f in files)
    assert all(np.diff(times) > 0) and times[-1] == pytest.approx(2.0)
    assert "gravity-first.pvd" in capsys.readouterr().out
    # not asked: no series written
    rc = main(["solve", "--length", "0.5", "--hmax", "0.25", "--quiet"])
    assert rc == 0 and sorted(p.name for p in out.iterdir()) == ["gravity-first",
                                                                  "gravity-first.pvd"]


def test_cli_series_bad_directory_one_line(tmp_path, capsys):
    f = tmp_path / "file"
    f.write_text("x")
    assert main(["solve", "--length", "0.5", "--series", str(f), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "--series" in err and len(err.strip().splitlines()) == 1
    assert main(["solve", "--length", "0.5", "--series", str(tmp_path / "no" / "dir"),
                 "--quiet"]) == 2
    assert "--series" in capsys.readouterr().err


def test_branch_series_stretched_sheet(tmp_path):
    """A branch in L: one state per point, each VTU on the sheet of its own length."""
    s = Series()
    b = follow_length(Sheet(length=0.5, curvature=2.5), 0.7, hmax=0.2, step=0.1,
                      on_point=s.on_point)
    pvd = b.write_series(tmp_path, "branch", s)
    entries = read_pvd(pvd)
    assert len(entries) == len(b.points) == 3
    np.testing.assert_allclose([t for t, _ in entries], b.lengths, atol=1e-12)
    for (_, f), p in zip(entries, b.points):
        m = meshio.read(f)
        assert m.points[:, 0].max() == pytest.approx(p.length, rel=1e-12)
        assert float(m.field_data["deflection"][0]) == pytest.approx(p.deflection)
        # the VTU's tip deflection: -U_z at the tip centre (positive downward)
        tip = np.argmin(np.abs(m.points[:, 0] - p.length) + np.abs(m.points[:, 1])
                        + np.abs(m.points[:, 2]))
        assert -m.point_data["displacement"][tip, 2] == pytest.approx(p.deflection, abs=0.02)
    with pytest.raises(ParameterError, match="series"):
        b.write_series(tmp_path, "bad", Series())


def test_decreasing_parameter_gives_distance_as_time(curvature_first, tmp_path):
    """Non-increasing parameters (a branch followed down, the S-curve) are timed by the
    distance travelled in the parameter."""
    r, _, _, _ = curvature_first
    s = Series()
    for v in (1.3, 1.2, 1.25, 1.0):
        s.on_point(r.problem, r.w, v)
    np.testing.assert_allclose(s.times(), [0.0, 0.1, 0.15, 0.4], atol=1e-12)
    times = [t for t, _ in read_pvd(s.write(tmp_path, "down"))]
    np.testing.assert_allclose(times, [0.0, 0.1, 0.15, 0.4], atol=1e-12)


@pytest.mark.parametrize("name", ["", "a/b", "../x", ".hidden", "a b"])
def test_write_series_bad_name(tmp_path, name):
    with pytest.raises(ParameterError, match="name"):
        write_series(tmp_path, name, [])


def test_write_series_rejects_non_increasing_times(curvature_first, tmp_path):
    r, s, _, _ = curvature_first
    with pytest.raises(ParameterError, match="times"):
        write_series(tmp_path, "x", s.frames[:2], times=[1.0, 1.0])


def test_cli_bistability_series(tmp_path):
    """bistability --series: one series per branch, one VTU per branch point, timed by the
    length going up and by the distance travelled going down."""
    out, js = tmp_path / "b", tmp_path / "b.json"
    rc = main(["bistability", "--curvature", "2.5", "--lengths", "0.5:0.7", "--hmax", "0.2",
               "--step", "0.1", "--quiet", "--series", str(out), "--json", str(js)])
    assert rc == 0
    data = json.loads(js.read_text())
    up = read_pvd(out / "curvature-dominated.pvd")
    down = read_pvd(out / "gravity-dominated.pvd")
    L_up = data["curvature_dominated"]["lengths"]
    L_down = data["gravity_dominated"]["lengths"]
    assert len(up) == len(L_up) >= 2 and len(down) == len(L_down) >= 2
    np.testing.assert_allclose([t for t, _ in up], L_up, atol=1e-12)
    np.testing.assert_allclose([t for t, _ in down],
                               np.concatenate([[0], np.cumsum(np.abs(np.diff(L_down)))]),
                               atol=1e-12)
    for (_, f), L in zip(down, L_down):
        m = meshio.read(f)
        assert m.points[:, 0].max() == pytest.approx(L, rel=1e-9)
        assert float(m.field_data["parameter"][0]) == pytest.approx(L)


def test_s_curve_series_through_both_folds(tmp_path, rectangle_s_curve):
    """The S-curve as a series: L goes up, back between the folds and up again; the time is
    the distance travelled in L (strictly increasing), each VTU keeps its length and its
    stability, and the frames between the folds are the unstable middle branch."""
    # s_curve(Sheet(length=1.2, curvature=2.5), 1.45, hmax=0.2, ds=0.1, ds_max=0.4,
    # on_point=Series().on_point), shared with test_bistability (conftest.py)
    sc, s = rectangle_s_curve
    assert sc.converged and len(sc.folds) == 2
    entries = read_pvd(sc.write_series(tmp_path, "s-curve", s))
    assert len(entries) == len(sc.points)
    times = np.array([t for t, _ in entries])
    assert np.all(np.diff(times) > 0)
    np.testing.assert_allclose(np.diff(times), np.abs(np.diff(sc.lengths)), atol=1e-12)
    stable = []
    for (_, f), p in zip(entries, sc.points):
        m = meshio.read(f)
        assert float(m.field_data["parameter"][0]) == pytest.approx(p.length)
        assert m.points[:, 0].max() == pytest.approx(p.length, rel=1e-9)
        stable.append(int(m.field_data["stable"][0]))
    assert stable == [int(p.stable) for p in sc.points]
    L = sc.lengths
    back = np.flatnonzero(np.diff(L) < 0)  # the steps where L goes back: the middle branch
    assert back.size > 0 and not any(stable[i + 1] for i in back[1:-1])
