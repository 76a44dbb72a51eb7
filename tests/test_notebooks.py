"""The notebooks run top to bottom (each asserts its own numbers).

Each is executed with nbclient in a temporary folder (files it writes land
there), with a time limit per cell; a failing ``assert`` or any error in a cell
fails the test with the cell's traceback.  The documentation build runs them too
(raising on a cell's error), so the slowest runs here only with ``-m slow``.
"""
from pathlib import Path

import pytest

nbformat = pytest.importorskip("nbformat")
nbclient = pytest.importorskip("nbclient")

NOTEBOOKS = Path(__file__).resolve().parent.parent / "notebooks"
#: Seconds per cell: the slowest cell (two 3D solves at hmax 0.08) takes about a
#: minute on 2 busy cores.
CELL_TIMEOUT = 600


def _run(name, tmp_path):
    nb = nbformat.read(NOTEBOOKS / name, as_version=4)
    client = nbclient.NotebookClient(nb, timeout=CELL_TIMEOUT, kernel_name="python3",
                                     resources={"metadata": {"path": str(tmp_path)}})
    client.execute()
    # each notebook asserts its own numbers, and every code cell ran (an error in a
    # cell would have raised CellExecutionError already)
    assert _has_assert(nb)
    assert all(c.get("execution_count") for c in nb.cells if c.cell_type == "code")
    return nb


def _outputs(nb):
    return "".join(o.get("text", "") for c in nb.cells if c.cell_type == "code"
                   for o in c.get("outputs", []))


def _has_assert(nb):
    return any("assert " in c.source for c in nb.cells if c.cell_type == "code")


def test_notebooks_present():
    assert ({"quickstart.ipynb", "reduced_models.ipynb", "bistability.ipynb", "calibration.ipynb"}
            <= {p.name for p in NOTEBOOKS.iterdir()})


def test_quickstart(tmp_path):
    nb = _run("quickstart.ipynb", tmp_path)
    assert "aloft:   d/a = " in _outputs(nb)
    assert (tmp_path / "aloft.vtu").stat().st_size > 0


def test_reduced_models(tmp_path):
    out = _outputs(_run("reduced_models.ipynb", tmp_path))
    assert "closed form" in out and "jumps at L/a" in out


# The slowest notebook (2 min on the loaded machine): the default suite leaves it to the
# documentation build, which runs every notebook and fails on a cell's error
# (docs/conf.py: nb_execution_raise_on_error; .ci/run builds the docs before the tests).
@pytest.mark.slow
def test_bistability(tmp_path):
    out = _outputs(_run("bistability.ipynb", tmp_path))
    assert "pop-up length   L0*/a = " in out and "folds at L/a = " in out


def test_calibration(tmp_path):
    out = _outputs(_run("calibration.ipynb", tmp_path))
    assert "E/(rho g a) = " in out and "refused: J^T J is singular" in out
    assert "window" in out


# A minute on the loaded machine (two switching analyses on hmax 0.2, a force ramp): like
# the bistability notebook, left to the documentation build in the default suite.
@pytest.mark.slow
def test_switching(tmp_path):
    out = _outputs(_run("switching.ipynb", tmp_path))
    assert "two states at F = 0 (bistable)" in out and "work identity" in out
    assert "microjoules" in out and "one state" in out
