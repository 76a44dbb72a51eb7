"""The user guide's Python examples run as written (each in a fresh interpreter in a
temporary folder), as the README's do (tests/test_readme.py).

The pages the README's long sections became carried the same defects (an example without its
import, a sweep without the ``__main__`` guard its error asks for, two examples writing one
table); running them keeps them honest.  Examples that take more than a few seconds (3D solves
at the paper's mesh, sweeps, fold maps) run with ``-m slow``.
"""
import re
import subprocess
import sys
from pathlib import Path

import pytest

GUIDE = Path(__file__).resolve().parent.parent / "docs" / "guide"
#: The pages whose examples run here (the others are tested by their owners' tests).
PAGES = ("solving", "reduced", "paraview", "studies")
#: Examples that run in the default suite: a few seconds each.
QUICK = {("reduced", 0)}


def _examples():
    for page in PAGES:
        text = (GUIDE / f"{page}.md").read_text()
        blocks = [code for lang, code in
                  re.findall(r"^```(\w+)\n(.*?)^```", text, flags=re.S | re.M) if lang == "python"]
        for i, code in enumerate(blocks):
            marks = () if (page, i) in QUICK else (pytest.mark.slow,)
            yield pytest.param(code, id=f"{page}-{i}", marks=marks)


@pytest.mark.parametrize("code", list(_examples()))
def test_guide_example_runs_as_written(code, tmp_path):
    p = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True,
                       text=True, timeout=3600)
    assert p.returncode == 0, p.stderr[-3000:]
    if "solve_both" in code:        # the solving page's verdict, as shown there
        assert "this sheet is bistable" in p.stdout and "lies between" in p.stdout
    if "run_sweep" in code:
        assert (tmp_path / "sweep_py.csv").exists() and "gravity-dominated" in p.stdout


def test_every_page_has_examples_and_none_is_lost():
    ids = [p.id for p in _examples()]
    assert {i.split("-")[0] for i in ids} == set(PAGES)
    assert len(ids) >= 6
