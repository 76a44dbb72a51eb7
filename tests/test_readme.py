"""The README's code blocks run as written (as scikit-fem's tests run its examples).

Every ``python`` block runs in a fresh interpreter in a temporary folder, every
``python -m skfem_sheet`` line of a ``bash`` block as a command there; the two
set-up commands (a fresh virtual environment and ``pip install``) are not run
here: ``.ci/run`` runs them, and the test checks that it runs the README's.
"""
import json
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
README = (ROOT / "README.md").read_text()
BLOCKS = re.findall(r"^```(\w+)\n(.*?)^```", README, flags=re.S | re.M)
PYTHON = [code for lang, code in BLOCKS if lang == "python"]
COMMANDS = [line for lang, code in BLOCKS if lang == "bash" for line in code.splitlines()
            if line.startswith("python -m skfem_sheet")]
SETUP = [code.strip() for lang, code in BLOCKS if lang == "bash" and "python3 -m venv" in code]


def test_the_readme_is_short_and_says_no_internal_constant():
    assert len(README.splitlines()) <= 100
    for name in ("LATE_SNAP", "FOLD_SHIFT", "MIN_COARSENING", "FINAL_UTOL", "RESUME_",
                 "POLISH_ITERATIONS"):
        assert name not in README
    assert not re.search(r"issue \d+", README, flags=re.I)
    assert PYTHON and COMMANDS and len(SETUP) == 2


def test_ci_runs_the_readmes_set_up_and_test_commands():
    """.ci/run installs what the README's test command installs and runs its commands."""
    ci = (ROOT / ".ci" / "run").read_text()
    tests = next(s for s in SETUP if "pytest" in s)
    install = re.search(r'pip install "(\.\[[^\]]*\])"', tests).group(1)
    assert f'pip install --quiet "{install}"' in ci
    for command in tests.split(" && ")[3:]:        # after venv, activate, install
        assert command in ci, command


@pytest.mark.parametrize("code", PYTHON, ids=[f"python-{i}" for i in range(len(PYTHON))])
def test_python_block_runs_as_written(code, tmp_path):
    p = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True,
                       text=True, timeout=600)
    assert p.returncode == 0, p.stderr
    if "up.write" in code:       # the two-state example: two distinct states, both stable
        assert "this sheet is bistable" in p.stdout
        assert "curvature-dominated, stable" in p.stdout and "gravity-dominated, stable" in p.stdout
        up, down = (float(x) for x in re.findall(r"aloft d/a = ([-\d.]+), drooped d/a = "
                                                 r"([-\d.]+)", p.stdout)[0])
        assert abs(up) < 0.1 and down > 0.5
        assert (tmp_path / "up.vtu").stat().st_size > 0
        # the README's text block is what print(both) printed, timings aside
        shown = next(c for lang, c in BLOCKS if lang == "text").splitlines()
        printed = p.stdout.splitlines()
        assert printed[0] == shown[0] and printed[3] == shown[3]
        for a, b in zip(printed[1:3], shown[1:3]):
            assert a.split("(")[0] == b.split("(")[0], (a, b)


def test_command_lines_run_as_written(tmp_path):
    for line in COMMANDS:
        if line.split()[3:4] == ["demo"]:
            continue      # the set-up command runs it (a solve at the paper's hmax 0.03)
        args = shlex.split(line)
        p = subprocess.run([sys.executable, *args[1:], "--quiet"], cwd=tmp_path,
                           capture_output=True, text=True, timeout=600)
        assert p.returncode == 0, (line, p.stderr)
    both = json.loads((tmp_path / "both.json").read_text())
    assert both["distinct"] is True and both["bistable"] is True
    up, down = both["curvature_first"], both["gravity_first"]
    assert up["branch"] == "curvature-dominated" and down["branch"] == "gravity-dominated"
    assert abs(up["deflection"]) < 0.1 and down["deflection"] > 0.5
