import argparse
import json
import subprocess
import sys

import numpy as np
import pytest

from skfem_sheet import Sheet, solve
from skfem_sheet.cli import main
from skfem_sheet.cli.solve import _start, add_solve_args


def run(*args):
    return subprocess.run([sys.executable, "-m", "skfem_sheet", *args],
                          capture_output=True, text=True, timeout=600)


def test_solve_writes_json_with_the_contract_keys(tmp_path):
    out = tmp_path / "out.json"
    vtu = tmp_path / "out.vtu"
    p = run("solve", "--length", "0.5", "--tip-width", "1", "--curvature", "1.0",
            "--path", "gravity-first", "--hmax", "0.12", "--json", str(out),
            "--vtu", str(vtu), "--quiet")
    assert p.returncode == 0, p.stderr
    assert "tip deflection d/a" in p.stdout
    data = json.loads(out.read_text())
    for key in ("deflection", "converged", "path", "dofs", "newton_iterations", "load_steps",
                "wall_time_s", "linear_solve_s", "assembly_s", "params"):
        assert key in data
    assert data["converged"] is True and data["path"] == "gravity-first"
    assert set(data["params"]) >= {"length", "tip_width", "curvature", "thickness",
                                   "modulus", "hmax"}
    assert vtu.stat().st_size > 1000
    assert p.stderr == ""  # --quiet: no progress bar


def test_demo_writes_picture_and_vtu(tmp_path):
    png, vtu = tmp_path / "d.png", tmp_path / "d.vtu"
    code = main(["demo", "--length", "0.5", "--hmax", "0.12", "--png", str(png),
                 "--vtu", str(vtu), "--quiet"])
    assert code == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert vtu.exists()


BAD = [
    (["solve", "--length", "-1"], "length"),
    (["solve", "--length", "0"], "length"),
    (["solve", "--length", "nan"], "length"),
    (["solve", "--length", "inf"], "length"),
    (["solve", "--length", "abc"], "length"),
    (["solve"], "length"),
    (["solve", "--length", "1", "--tip-width", "2"], "tip_width"),
    (["solve", "--length", "1", "--tip-width", "-0.5"], "tip_width"),
    (["solve", "--length", "1", "--curvature", "-2"], "curvature"),
    (["solve", "--length", "1", "--curvature", "7"], "curvature"),
    (["solve", "--length", "1", "--thickness", "0"], "thickness"),
    (["solve", "--length", "1", "--thickness", "-0.03"], "thickness"),
    (["solve", "--length", "1", "--modulus", "-735"], "modulus"),
    (["solve", "--length", "1", "--hmax", "0"], "hmax"),
    (["solve", "--length", "1", "--hmax", "5"], "hmax"),
    (["solve", "--length", "1", "--hmax", "1e-5"], "hmax"),
    (["solve", "--length", "1", "--path", "sideways"], "path"),
    (["solve", "--length", "1", "--solver", "magic"], "solver"),
    (["solve", "--length", "1", "--layers", "0"], "layers"),
    (["solve", "--length", "1", "--gravity", "-1"], "gravity"),
    (["solve", "--length", "1", "--json", "/nonexistent/dir/out.json"], "--json"),
    (["solve", "--length", "1", "--vtu", "out.txt"], "--vtu"),
    (["solve", "--length", "1", "--png", "/nonexistent/x.png"], "--png"),
    (["demo", "--hmax", "-1"], "hmax"),
    (["frobnicate"], "invalid choice"),
    ([], "COMMAND"),
]


def test_solve_without_gravity(tmp_path):
    out = tmp_path / "out.json"
    p = run("solve", "--length", "1", "--curvature", "0.5", "--gravity", "0", "--hmax", "0.15",
            "--json", str(out), "--quiet")
    assert p.returncode == 0, p.stderr
    data = json.loads(out.read_text())
    assert data["params"]["gravity"] == 0.0 and data["gravity_reached"] == 0.0
    assert [s[0] for s in data["steps"]] == ["curvature"] * len(data["steps"])


@pytest.mark.parametrize("args, name", BAD, ids=[" ".join(a) or "empty" for a, _ in BAD])
def test_bad_arguments_one_line_exit_2(args, name, capsys):
    with pytest.raises(SystemExit) if not args or args[0] == "frobnicate" or args == ["solve"] \
            or "abc" in args else _no_raise():
        code = main(args)
        assert code == 2
    err = capsys.readouterr().err
    assert name in err
    assert "Traceback" not in err
    assert len(err.strip().splitlines()) == 1


class _no_raise:
    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False


def test_bad_argument_through_the_interpreter():
    p = run("solve", "--length", "1", "--curvature", "9")
    assert p.returncode == 2
    assert "curvature must be in" in p.stderr and "Traceback" not in p.stderr


def test_solve_refine_is_passed_and_reported(tmp_path):
    """--refine 1 halves every edge: twice the layers, several times the unknowns; the
    JSON records it."""
    out = tmp_path / "r.json"
    rc = main(["solve", "--length", "0.3", "--hmax", "0.3", "--refine", "1", "--json", str(out),
               "--quiet"])
    assert rc == 0
    s = json.loads(out.read_text())
    base = solve(Sheet(length=0.3), hmax=0.3)
    assert s["params"]["refine"] == 1 and s["params"]["layers"] == 2 * base.layers
    assert s["dofs"] > 4 * base.dofs


def test_fold_curve_bad_input_is_one_line_exit_2(capsys):
    from skfem_sheet.cli import main

    assert main(["fold-curve", "--curvature", "7", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "curvature" in err and "Traceback" not in err and len(err.strip().splitlines()) == 1
    assert main(["fold-curve", "--lengths", "2:1", "--quiet"]) == 2
    assert "lengths" in capsys.readouterr().err


# -- CLI parity with the API: --version, --full-sheet, the solver list, --si ------------------
def test_version_flag():
    from skfem_sheet import __version__

    p = run("--version")
    assert p.returncode == 0, p.stderr
    assert p.stdout.strip() == f"skfem-sheet {__version__}"


def test_version_flag_imports_no_numerics():
    """``--version`` answers without loading numpy, scipy or the solver (it took 2.8 s)."""
    from skfem_sheet.version import __version__

    code = ("import sys, runpy; sys.argv = ['skfem_sheet', '--version']\n"
            "try:\n    runpy.run_module('skfem_sheet', run_name='__main__')\n"
            "except SystemExit as e:\n    assert e.code == 0, e.code\n"
            "print(sorted(m for m in ('numpy', 'scipy', 'skfem', 'skfem_sheet.solve')"
            " if m in sys.modules))")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert p.returncode == 0, p.stderr
    assert p.stdout.splitlines() == [f"skfem-sheet {__version__}", "[]"]


def test_package_names_resolve_lazily_to_the_api():
    """``skfem_sheet.solve`` is the function even after its submodule is imported."""
    code = ("import skfem_sheet.studies.sweep, skfem_sheet\n"
            "from skfem_sheet import Result, Sheet, solve\n"
            "print(callable(solve), solve.__module__, skfem_sheet.solve is solve,"
            " Result.__name__, Sheet.__name__)")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    assert p.stdout.split() == ["True", "skfem_sheet.solve", "True", "Result", "Sheet"]


def test_full_sheet_solves_the_whole_sheet(tmp_path):
    """--full-sheet is symmetric=False: about twice the unknowns, the same (symmetric)
    equilibrium as the half solve."""
    half, full = tmp_path / "half.json", tmp_path / "full.json"
    common = ["solve", "--length", "0.4", "--curvature", "1", "--hmax", "0.3", "--quiet"]
    assert main([*common, "--json", str(half)]) == 0
    assert main([*common, "--full-sheet", "--json", str(full)]) == 0
    h, f = json.loads(half.read_text()), json.loads(full.read_text())
    assert h["symmetric"] is True and f["symmetric"] is False
    assert 1.6 * h["dofs"] < f["dofs"] < 2.2 * h["dofs"]
    assert abs(f["deflection"] - h["deflection"]) < 1e-6
    api = solve(Sheet(length=0.4, curvature=1.0), hmax=0.3, symmetric=False)
    assert api.dofs == f["dofs"] and abs(api.deflection - f["deflection"]) < 1e-12


def _subparsers(parser):
    import argparse

    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield name, sub
                yield from ((f"{name} {n}", s) for n, s in _subparsers(sub))


def test_every_solver_option_lists_every_solver():
    """Each --solver help text names every back-end of the one list linalg.SOLVERS."""
    from skfem_sheet.cli import build_parser
    from skfem_sheet.linalg import SOLVERS

    seen = []
    for name, sub in _subparsers(build_parser()):
        for action in sub._actions:
            if "--solver" in action.option_strings:
                seen.append(name)
                for s in SOLVERS:
                    assert s in action.help, (name, s, action.help)
    assert {"solve", "demo", "sweep", "bistability", "fold-map"} <= set(seen)
    assert "pyamg" in SOLVERS


SI = dict(base_width=0.05, length=0.02, tip_width=0.05, thickness=1.5e-3, radius=0.05,
          youngs_modulus=4.5e5, density=1250.0)


def test_si_input_maps_through_from_si_and_echoes(tmp_path, capsys):
    out = tmp_path / "si.json"
    text = ",".join(f"{k}={v!r}" for k, v in SI.items())
    assert main(["solve", "--si", text, "--hmax", "0.3", "--json", str(out), "--quiet"]) == 0
    expect = Sheet.from_si(**SI)
    printed = capsys.readouterr().out
    assert "SI input -> L/a = 0.4, b/a = 1, a/R = 1, h/a = 0.03" in printed
    assert f"E/(rho g a) = {expect.modulus:.6g}" in printed
    params = json.loads(out.read_text())["params"]
    for k, v in expect.to_dict().items():
        assert params[k] == v, k
    # gravity is optional (9.81) and changes the modulus as 1/g
    assert main(["solve", "--si", text + ",gravity=1.635", "--hmax", "0.3", "--json", str(out),
                 "--quiet"]) == 0
    assert json.loads(out.read_text())["params"]["modulus"] == \
        Sheet.from_si(**SI, gravity=1.635).modulus


SI_TEXT = ",".join(f"{k}={v!r}" for k, v in SI.items())
BAD_SI = [
    (SI_TEXT.replace("density=1250.0,", "").replace(",density=1250.0", ""), "density"),
    (SI_TEXT + ",colour=3", "colour"),
    (SI_TEXT + ",length=0.03", "length"),
    (SI_TEXT.replace("radius=0.05", "radius=-1"), "radius"),
    (SI_TEXT.replace("radius=0.05", "radius=nan"), "radius"),
    (SI_TEXT.replace("density=1250.0", "density=inf"), "density"),
    (SI_TEXT.replace("density=1250.0", "density=heavy"), "density"),
    (SI_TEXT.replace("tip_width=0.05", "tip_width=0.06"), "tip_width"),
    ("base_width", "--si"),
]


@pytest.mark.parametrize("text, name", BAD_SI)
def test_bad_si_one_line_exit_2(text, name, capsys):
    assert main(["solve", "--si", text, "--quiet"]) == 2
    err = capsys.readouterr().err
    assert name in err and "Traceback" not in err and len(err.strip().splitlines()) == 1


def test_si_excludes_the_dimensionless_flags(capsys):
    assert main(["solve", "--si", SI_TEXT, "--tip-width", "0.5", "--quiet"]) == 2
    assert "--tip-width" in capsys.readouterr().err
    with pytest.raises(SystemExit):  # argparse: --length and --si are exclusive
        main(["solve", "--si", SI_TEXT, "--length", "1"])
    assert "not allowed with" in capsys.readouterr().err


def test_planform_csv_of_a_trapezoid_gives_the_trapezoid(tmp_path, capsys):
    """``--planform FILE.csv`` (columns x,width; L from the last x) on solve and the
    reduced models: a sampled trapezoid answers exactly as ``--tip-width``."""
    import json

    from skfem_sheet.cli import main

    csv = tmp_path / "trapezoid.csv"
    csv.write_text("x,width\n0,1\n0.65,0.8\n1.3,0.6\n")
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    assert main(["solve", "--planform", str(csv), "--curvature", "2.5", "--hmax", "0.2",
                 "--json", str(a), "--quiet"]) == 0
    assert main(["solve", "--length", "1.3", "--tip-width", "0.6", "--curvature", "2.5",
                 "--hmax", "0.2", "--json", str(b), "--quiet"]) == 0
    da, db = json.loads(a.read_text())["deflection"], json.loads(b.read_text())["deflection"]
    assert abs(da - db) <= 1e-6 * abs(db)
    for cmd in (["rom", "elastica"], ["rom", "ribbon", "--curvature", "2.5",
                                      "--lengths", "1.2:1.3:0.1"]):
        assert main(cmd + ["--planform", str(csv), "--json", str(a)]) == 0
        length = [] if cmd[1] == "ribbon" else ["--length", "1.3"]
        assert main(cmd + length + ["--tip-width", "0.6", "--json", str(b)]) == 0
        ra, rb = json.loads(a.read_text()), json.loads(b.read_text())
        assert np.allclose(ra["deflection"], rb["deflection"], rtol=1e-6, atol=1e-9)
    capsys.readouterr()
    assert main(["solve", "--planform", str(csv), "--tip-width", "0.5"]) == 2
    assert "--tip-width cannot be combined with --planform" in capsys.readouterr().err
    bad = tmp_path / "bad.csv"
    bad.write_text("x,width\n0,1\n1,-0.2\n")
    assert main(["solve", "--planform", str(bad)]) == 2
    assert "width" in capsys.readouterr().err


@pytest.fixture(scope="module")
def coarse_cli(tmp_path_factory):
    """One CLI solve with the default start (coarse, --coarse-hmax 0.12 for hmax 0.05),
    shared by the two tests below: ``(process, its JSON)``."""
    out = tmp_path_factory.mktemp("coarse") / "c.json"
    p = run("solve", "--length", "0.8", "--curvature", "2.0", "--hmax", "0.05",
            "--coarse-hmax", "0.12", "--json", str(out), "--quiet")
    assert p.returncode == 0, p.stderr
    return p, json.loads(out.read_text())


def test_solve_start_coarse_reports_the_coarse_work_separately(coarse_cli):
    _, data = coarse_cli
    assert data["start"] == "coarse" and data["coarse_hmax"] == 0.12
    assert data["start_record"]["fallback"] == "" and data["coarse_factorizations"] > 0
    assert 0 < data["factorizations"] <= 6 and data["back_substitutions"] > 0
    ref = solve(Sheet(length=0.8, curvature=2.0), hmax=0.05, start="path")
    assert data["deflection"] == pytest.approx(ref.deflection, rel=1e-7)
    bad = run("solve", "--length", "0.8", "--start", "fine", "--quiet")
    assert bad.returncode != 0 and "start" in bad.stderr


def test_solve_starts_coarse_by_default_and_path_with_a_series(tmp_path, coarse_cli):
    p = argparse.ArgumentParser()
    add_solve_args(p)
    assert _start(p.parse_args([])) == "coarse"
    assert _start(p.parse_args(["--series", str(tmp_path)])) == "path"
    assert _start(p.parse_args(["--series", str(tmp_path), "--start", "coarse"])) == "coarse"
    assert _start(p.parse_args(["--start", "path"])) == "path"
    r, data = coarse_cli          # run without --start
    assert data["start"] == "coarse" and data["coarse_factorizations"] > 0
    assert "on the coarse mesh" in r.stdout
