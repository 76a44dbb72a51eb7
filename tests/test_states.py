"""Both load paths in one call (skfem_sheet.states, ``solve --path both``): whether the two
end states differ, both deflections and stability, where a length sits against the fold
lengths; the ``bistability`` command's verdict about the planform vs one sheet."""
import json
import re
from dataclasses import replace

import numpy as np
import pytest

import skfem_sheet.cli.bistability as cli_bistability
import skfem_sheet.states as states_module
from skfem_sheet import Sheet, solve
from skfem_sheet.bistability import FOLD_TOL, Branch, BranchPoint, Fold, FoldLengths
from skfem_sheet.cli import main
from skfem_sheet.params import ParameterError
from skfem_sheet.states import fold_position, solve_both, with_path

SI = ("base_width=0.05,length=0.065,tip_width=0.05,thickness=1.5875e-3,radius=0.02,"
      "youngs_modulus=4.5e5,density=1250")


@pytest.fixture(scope="module")
def bistable():
    """The paper's rectangle, L/a 1.3, a/R 2.5, on hmax 0.2 (both paths: 2 s)."""
    return solve_both(Sheet(length=1.3, curvature=2.5), hmax=0.2)


def test_a_bistable_sheet_has_two_distinct_stable_states_as_two_solves_give(bistable):
    sheet = bistable.sheet
    up = solve(sheet, path="curvature-first", hmax=0.2)
    down = solve(sheet, path="gravity-first", hmax=0.2)
    assert bistable.deflections == (up.deflection, down.deflection)   # the same solves
    assert bistable.distinct is True and bistable.bistable is True
    assert len(bistable.states) == 2 and bistable.converged
    assert bistable.curvature_first.stable and bistable.gravity_first.stable
    assert bistable.separation > 0.4        # aloft vs drooped: half a base width apart
    assert bistable.separation >= abs(down.deflection - up.deflection)
    text = str(bistable)
    assert "two distinct states" in text and "this sheet is bistable" in text
    assert "curvature-dominated, stable" in text and "gravity-dominated, stable" in text


def test_outside_the_bistable_range_both_paths_reach_one_state():
    s = solve_both(Sheet(length=0.5, curvature=2.5), hmax=0.2)
    assert s.converged and s.distinct is False and s.bistable is False
    assert s.separation < 1e-9 and len(s.states) == 1
    lines = s.lines()
    assert "one state: both load paths reach it" in lines[-1]
    # one state, one name, whichever path reached it (the name is read from the
    # state; the paths' histories are their snaps)
    assert s.names == ("curvature-dominated", "curvature-dominated")
    assert sum("curvature-dominated" in line for line in lines) == 2


def test_a_failed_path_makes_the_verdict_unknown(bistable):
    failed = replace(bistable.gravity_first, converged=False, message="step too small")
    s = states_module.States(bistable.curvature_first, failed, float("nan"))
    assert s.distinct is None and s.bistable is None and not s.converged
    assert s.states == (bistable.curvature_first,)
    assert "NOT converged: step too small" in str(s)
    assert "bistable: unknown" in str(s)


def test_summary_and_files(bistable, tmp_path):
    (js,) = bistable.write(tmp_path / "both.json")
    data = json.loads(open(js).read())
    assert data["distinct"] is True and data["bistable"] is True
    assert data["deflections"]["gravity-first"] == bistable.gravity_first.deflection
    assert data["curvature_first"]["branch"] == "curvature-dominated"
    assert data["sheet"]["length"] == 1.3 and data["folds"] is None
    written = bistable.write(tmp_path / "s.vtu")
    assert written == [str(tmp_path / "s.curvature-first.vtu"),
                       str(tmp_path / "s.gravity-first.vtu")]
    assert all((tmp_path / f).stat().st_size > 0 for f in written)
    assert with_path("a/b.c.png", "both") == "a/b.c.both.png"


@pytest.mark.parametrize("kw, match", [
    (dict(path="gravity-first"), "path is not an option of solve_both"),
    (dict(series=object()), "series is not an option of solve_both"),
    (dict(hmax_coarse=0.1), "hmax_coarse is not an option"),
    (dict(same_tol=0), "same_tol must be in"),
    (dict(folds=True, gravity=0.5), "folds needs gravity 1"),
    (dict(folds=True, lengths=(0.6, 1.0)), "lengths must hold the sheet's length 1.3"),
])
def test_bad_arguments_name_the_parameter(kw, match):
    with pytest.raises(ParameterError, match=match):
        solve_both(Sheet(length=1.3, curvature=2.5), hmax=0.2, **kw)


def test_a_planform_has_fold_lengths_too():
    """folds=True for any planform (the mesh stretched in L, the profile with
    it): the rectangle given as sampled profile has the rectangle's folds, to
    the difference of the two unstructured meshes (about 0.02 a at hmax 0.2)."""
    from skfem_sheet.params import Planform
    sheet = Sheet.from_planform(Planform.from_samples([0, 0.5, 1.3], [1, 1, 1]), curvature=2.5)
    s = solve_both(sheet, hmax=0.2, folds=True, lengths=(1.0, 1.7))
    rect = solve_both(Sheet(length=1.3, curvature=2.5), hmax=0.2, folds=True,
                      lengths=(1.0, 1.7))
    assert s.folds.bistable and s.position.where == "between" and s.bistable
    assert s.folds.popup_length == pytest.approx(rect.folds.popup_length, abs=0.03)
    assert s.folds.standout_length == pytest.approx(rect.folds.standout_length, abs=0.03)
    assert s.names == ("curvature-dominated", "gravity-dominated")


# -- where a length sits against the fold lengths ---------------------------------------------
def _branch(lengths, fold, snapped=False, reason=""):
    pts = tuple(BranchPoint(L, 0.1, True, 0, 3) for L in lengths)
    bracket = () if fold is None else (fold - 0.005, fold + 0.005)
    return Branch(pts, fold, bracket, reason or ("" if fold is None else "fold"),
                  start_snapped=snapped)


def _folds(L0=1.202, L1=1.347, up=None, down=None, curvature=2.5):
    up = up or _branch([0.6, 1.0, L1 - 0.005], L1)
    down = down or _branch([2.4, 1.6, L0 + 0.005], L0)
    fold = (lambda kind, L: None if L is None else
            Fold(kind, L, 0.1, (0, 1) if kind == "standout" else (1, 0), 0, 0.1, 1.35))
    return FoldLengths(Sheet(length=1.3, curvature=curvature), 0.1, (0.6, 2.4),
                       fold("standout", L1), fold("popup", L0), up, down, 0.1)


@pytest.mark.parametrize("length, where, states", [
    (1.3, "between", 2), (1.0, "below", 1), (2.0, "above", 1), (1.347, "at a fold", None),
    (1.202 + 0.5 * FOLD_TOL, "at a fold", None), (1.349, "above", 1), (3.0, "unknown", None),
])
def test_fold_position(length, where, states):
    pos = fold_position(_folds(), length)
    assert (pos.where, pos.states) == (where, states), pos.text


def test_fold_position_when_a_branch_holds_or_is_missing():
    held = _folds(L0=None, down=_branch([2.4, 1.0, 0.6], None))   # drooped branch to 0.6
    pos = fold_position(held, 0.7)
    assert pos.where == "between" and "L0* not in [0.6, 2.4]" in pos.text
    snapped = _folds(L0=None, down=_branch([2.4, 1.0], None, snapped=True))
    assert fold_position(snapped, 1.3).where == "unknown"
    assert "snapped where it started" in fold_position(snapped, 1.3).text
    flat = _folds(curvature=0.0)
    assert fold_position(flat, 1.3).where == "one branch"


# -- the command line ----------------------------------------------------------------------
def test_solve_path_both_prints_the_verdict_and_writes_both(tmp_path, capsys):
    js = tmp_path / "both.json"
    rc = main(["solve", "--length", "1.3", "--curvature", "2.5", "--thickness", "0.03",
               "--path", "both", "--hmax", "0.2", "--quiet", "--json", str(js),
               "--vtu", str(tmp_path / "s.vtu")])
    out = capsys.readouterr().out
    assert rc == 0
    first = out.splitlines()[0]
    for shown in ("L/a = 1.3", "b/a = 1", "a/R = 2.5", "h/a = 0.03", "E/(rho g a) = 735",
                  "gravity 1", "hmax 0.2"):
        assert shown in first, first
    assert "this sheet is bistable" in out
    assert json.loads(js.read_text())["bistable"] is True
    assert (tmp_path / "s.gravity-first.vtu").exists()


def test_solve_si_echoes_every_quantity_and_the_deflection_in_mm(capsys):
    assert main(["solve", "--si", SI, "--path", "both", "--hmax", "0.2", "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "youngs_modulus=450000, density=1250" in out
    assert "h/a = 0.03175, E/(rho g a) = 733.945" in out
    # d = d/a * a, a = 5 cm
    d = [float(x) for x in re.findall(r"d/a = +([-\d.]+) \(d = ([-\d.]+) mm",
                                                    out)[0]]
    assert d[1] == pytest.approx(50 * d[0], rel=1e-3)


@pytest.mark.parametrize("argv, name", [
    (["solve", "--length", "1", "--folds"], "--folds is for --path both"),
    (["solve", "--length", "1", "--path", "both", "--series", "x"], "--series is for one"),
    (["solve", "--length", "1", "--path", "both", "--folds", "2:1x"], "--folds must be"),
    (["bistability", "--si", SI, "--curvature", "2"], "--si cannot be combined with "
                                                      "--curvature"),
    (["bistability", "--length", "1.3", "--at-length", "1.3"], "--length cannot be combined"),
    (["bistability", "--length", "3", "--lengths", "0.6:2.4"], "lengths must hold"),
])
def test_bad_arguments_are_one_line(argv, name, capsys):
    assert main(argv + ["--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and name in err, err


def test_bistability_says_what_it_is_about(monkeypatch, capsys, tmp_path):
    """The verdict names the planform and curvature over a range of lengths, and says
    where this sheet sits, in SI units for a sheet given in SI; no solver jargon
    beside a fold that was found."""
    seen = {}

    def fake(sheet, **kw):
        seen.update(kw, sheet=sheet)
        f = _folds()
        return replace(f, sheet=sheet)

    monkeypatch.setattr(cli_bistability, "fold_lengths", fake)
    js = tmp_path / "b.json"
    assert main(["bistability", "--si", SI, "--quiet", "--json", str(js)]) == 0
    out = capsys.readouterr().out
    sheet = seen["sheet"]
    assert sheet.thickness == pytest.approx(0.03175) and sheet.curvature == 2.5
    assert sheet.si.base_width == 0.05 and seen["hmax"] == 0.03
    assert "h/a = 0.03175, E/(rho g a) = 733.945" in out
    assert ("this planform (b/a = 1) at a/R = 2.5 is bistable for 1.20200 < L/a < 1.34700"
            in out)
    assert "this sheet (L/a = 1.3, L = 65 mm): L/a = 1.3 lies between" in out
    # the fold lengths in mm too: L1* = 1.347 a = 67.35 mm
    assert "1.34700 (L* = 67.35 mm)" in out
    assert "bistable: yes" not in out and "Newton" not in out
    data = json.loads(js.read_text())
    assert data["position"]["where"] == "between"
    assert data["popup_length"] == 1.202 and data["standout_length"] == 1.347
    assert data["si"]["standout_length_m"] == pytest.approx(0.06735)
    monkeypatch.setattr(cli_bistability, "fold_lengths",
                        lambda sheet, **k: replace(_folds(L0=None, L1=None,
                                                          up=_branch([0.6, 2.4], None),
                                                          down=_branch([2.4, 0.6], None)),
                                                   sheet=sheet))
    assert main(["bistability", "--curvature", "0.5", "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "is not bistable for any L/a in [0.6, 2.4]" in out
    assert "none in range (the branch followed from L/a = 0.6 held to L/a = 2.4)" in out
    np.testing.assert_equal(seen["lengths"], (0.6, 2.4))


def test_solve_path_both_with_sensitivities_gives_one_set_per_path(tmp_path, capsys):
    js = tmp_path / "both.json"
    assert main(["solve", "--length", "1.3", "--curvature", "2.5", "--path", "both",
                 "--hmax", "0.25", "--quiet", "--sensitivities", "modulus", "--json",
                 str(js)]) == 0
    out = capsys.readouterr().out
    assert out.count("d(d/a)/d(modulus)") == 2
    data = json.loads(js.read_text())
    up, down = (data[k]["sensitivities"]["modulus"] for k in ("curvature_first",
                                                                "gravity_first"))
    # a stiffer sheet sags less on both branches, the drooped one far more so
    assert up < 0 and down < 0 and abs(down) > abs(up)


# -- --si on every command that takes one sheet ---------------------------------------------
class _Stop(Exception):
    pass


def test_fold_curve_si_gives_curvature_and_material_and_places_the_sheet(monkeypatch, capsys):
    import skfem_sheet.cli.fold_curve as cli_fold_curve
    seen = {}

    def fake(curvature, **kw):
        seen.update(kw, curvature=curvature)
        raise _Stop

    monkeypatch.setattr(cli_fold_curve, "trace_fold_curve", fake)
    with pytest.raises(_Stop):
        main(["fold-curve", "--si", SI.replace("tip_width=0.05", "tip_width=0.04"), "--quiet"])
    assert seen["curvature"] == 2.5 and seen["thickness"] == pytest.approx(0.03175)
    assert seen["modulus"] == pytest.approx(733.945, abs=1e-3)
    assert "b/a = 0.8" in capsys.readouterr().out
    assert main(["fold-curve", "--si", SI, "--thickness", "0.02"]) == 2
    assert "--si cannot be combined with --thickness" in capsys.readouterr().err


def test_place_a_sheet_against_a_fold_curve():
    from types import SimpleNamespace

    from skfem_sheet.cli.fold_curve import place

    # standout from b 1 (L 1.35) down to the cusp (b 0.6, L 1.25), pop-up back to (1, 1.2)
    pts = [dict(tip_width=b, length=L, kind=k) for b, L, k in [
        (1.0, 1.35, "standout"), (0.8, 1.30, "standout"), (0.6, 1.25, "standout"),
        (0.8, 1.22, "popup"), (1.0, 1.20, "popup")]]
    curve = SimpleNamespace(second="tip_width", points=pts,
                            cusp={"tip_width": 0.6, "length": 1.25})
    assert place(curve, 1.26, 0.8)["where"] == "between"
    assert place(curve, 1.26, 0.8)["states"] == 2
    assert place(curve, 1.1, 0.8)["where"] == "below"
    assert place(curve, 1.4, 0.8)["where"] == "above"
    assert place(curve, 1.26, 0.5)["where"] == "beyond the cusp"
    assert "L0* = 1.220, L1* = 1.300 at b/a = 0.8" in place(curve, 1.26, 0.8)["text"]


@pytest.mark.parametrize("model", ["persistence", "cantilever", "elastica"])
def test_rom_si(model, capsys):
    assert main(["rom", model, "--si", SI]) == 0
    out = capsys.readouterr().out
    assert "L/a=1.3 b/a=1" in out and "h/a=0.03175 E=733.945" in out
    if model == "elastica":
        assert "a/R = 2.5 is left out" in out
    assert main(["rom", model, "--si", SI, "--length", "1"]) == 2
    assert "--si cannot be combined with --length" in capsys.readouterr().err


def test_si_to_the_end(tmp_path, capsys):
    """A sheet given in SI: the --json of --path both has the dimensionless keys as before
    and the SI ones beside them (the deflections in metres), the VTU is in metres."""
    import meshio

    js, vtu = tmp_path / "both.json", tmp_path / "s.vtu"
    assert main(["solve", "--si", SI, "--path", "both", "--hmax", "0.25", "--quiet", "--json",
                 str(js), "--vtu", str(vtu)]) == 0
    data = json.loads(js.read_text())
    a = 0.05
    for path in ("curvature-first", "gravity-first"):
        d = data["deflections"][path]
        assert data["si"]["deflections_m"][path] == pytest.approx(a * d, rel=1e-12)
    up = data["curvature_first"]
    assert up["si"]["deflection_m"] == pytest.approx(a * up["deflection"], rel=1e-12)
    assert up["si"]["youngs_modulus_Pa"] == pytest.approx(4.5e5)
    assert up["params"]["si"] == {"base_width": 0.05, "density": 1250.0, "gravity": 9.81}
    assert data["si"]["separation_m"] == pytest.approx(a * data["separation"], rel=1e-12)
    m = meshio.read(tmp_path / "s.gravity-first.vtu")
    # the reference sheet spans 0 <= x <= L = 65 mm, |y| <= a/2 = 25 mm
    assert m.points[:, 0].max() == pytest.approx(0.065, rel=1e-9)
    assert m.points[:, 1].max() == pytest.approx(0.025, rel=1e-9)
    text = vtu.with_name("s.gravity-first.vtu").read_text(errors="ignore")
    assert 'Name="coordinates_in_metres"' in text and 'Name="base_width_m"' in text
