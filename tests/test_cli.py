import json
import subprocess
import sys

import pytest

from skfem_sheet import Sheet, solve
from skfem_sheet.cli import main


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
    (["solve", "--length", "1", "--json", "/nonexistent/dir/out.json"], "--json"),
    (["solve", "--length", "1", "--vtu", "out.txt"], "--vtu"),
    (["solve", "--length", "1", "--png", "/nonexistent/x.png"], "--png"),
    (["demo", "--hmax", "-1"], "hmax"),
    (["frobnicate"], "invalid choice"),
    ([], "COMMAND"),
]


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
