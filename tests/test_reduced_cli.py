"""The ``rom`` command line (JSON keys are a contract)."""
import argparse
import json

import pytest

from skfem_sheet.cli.ranges import parse_range
from skfem_sheet.cli.rom import register


def run(argv):
    p = argparse.ArgumentParser()
    sub = p.add_subparsers(dest="command")
    register(sub)
    args = p.parse_args(argv)
    return args.run(args)


def test_persistence(tmp_path, capsys):
    out = tmp_path / "p.json"
    assert run(["rom", "persistence", "--tip-width", "0.9", "--curvature", "2.5",
                "--length", "20", "--json", str(out)]) == 0
    data = json.loads(out.read_text())
    assert data["persistence_length"] == pytest.approx(1.0857567, rel=1e-6)
    assert data["persistence_length_asymptotic"] == pytest.approx(1.0857323, rel=1e-6)
    assert "L_p/a" in capsys.readouterr().out


def test_elastica_and_cantilever(tmp_path):
    out = tmp_path / "e.json"
    assert run(["rom", "elastica", "--length", "1", "--tip-width", "1", "--json", str(out)]) == 0
    assert json.loads(out.read_text())["deflection"] == pytest.approx(0.768087, rel=1e-5)
    out = tmp_path / "c.json"
    assert run(["rom", "cantilever", "--length", "1.5", "--tip-width", "0", "--curvature",
                "2.5", "--json", str(out)]) == 0
    data = json.loads(out.read_text())
    # triangle: d = (L - L_p)^4 rho g h / (24 D), L_p = 0.65126
    assert data["deflection"] == pytest.approx((1.5 - 0.6512626) ** 4 * 0.03 / (24 * 0.002205),
                                               rel=1e-5)


def test_ribbon(tmp_path):
    out = tmp_path / "r.json"
    assert run(["rom", "ribbon", "--tip-width", "1", "--curvature", "2.5", "--lengths",
                "1.0:1.7:0.01", "--direction", "increasing", "--json", str(out)]) == 0
    data = json.loads(out.read_text())
    assert len(data["lengths"]) == len(data["deflection"]) == len(data["converged"]) == 71
    assert data["lengths"][0] == 1.0 and data["lengths"][-1] == pytest.approx(1.7)
    assert all(isinstance(c, bool) for c in data["converged"]) and all(data["converged"])
    assert data["jump_lengths"] and abs(data["jump_lengths"][0] - 1.38) < 0.03
    out = tmp_path / "d.json"
    assert run(["rom", "ribbon", "--curvature", "2.5", "--lengths", "1.2:1.5:0.05",
                "--direction", "decreasing", "--json", str(out)]) == 0
    data = json.loads(out.read_text())
    assert data["lengths"] == sorted(data["lengths"], reverse=True)


def test_map(tmp_path, capsys):
    csv, png = tmp_path / "m.csv", tmp_path / "m.png"
    assert run(["rom", "map", "--curvature", "2.5", "--lengths", "1.2:1.5:0.1",
                "--tip-widths", "0:1:1", "--workers", "1", "--csv", str(csv),
                "--png", str(png)]) == 0
    assert len(csv.read_text().splitlines()) == 1 + 4 * 2 * 2
    assert png.exists()
    assert "map:" in capsys.readouterr().out


@pytest.mark.parametrize("text", ["1:2", "a:2:0.1", "1:2:0", "2:1:0.1", "1:2:-1", "1:inf:1", ""])
def test_bad_lengths_raise_value_error_naming_option(text):
    with pytest.raises(ValueError, match="--lengths"):
        run(["rom", "ribbon", "--curvature", "2.5", "--lengths", text])


def test_bad_parameters_raise_value_error():
    with pytest.raises(ValueError, match="tip_width"):
        run(["rom", "elastica", "--length", "1", "--tip-width", "1.5"])
    with pytest.raises(ValueError, match="thickness"):
        run(["rom", "persistence", "--length", "1", "--curvature", "1", "--thickness", "-1"])
    with pytest.raises(ValueError, match="tip-widths"):
        run(["rom", "map", "--curvature", "2.5", "--tip-widths", "0:2:1"])


def test_parse_range():
    assert parse_range("0.5:0.6:0.05").tolist() == [0.5, 0.55, 0.6]
    assert parse_range("1:1:0.1").tolist() == [1.0]
