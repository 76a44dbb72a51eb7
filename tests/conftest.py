import os
import sys

import matplotlib
import pytest

matplotlib.use("Agg")
os.environ.setdefault("MPLBACKEND", "Agg")

# The benchmark scripts import their helper module ``harness`` from their own folder
# (Python puts a script's folder on the path); tests that load a script by its file
# path need that folder on the path too.
BENCHMARKS = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))),
                          "benchmarks")
if BENCHMARKS not in sys.path:
    sys.path.append(BENCHMARKS)


@pytest.fixture(scope="session")
def rectangle_s_curve():
    """The S-curve of the paper's rectangle (a/R 2.5) on hmax 0.2, L/a 1.2 to 1.45,
    recorded as a series: ``(s_curve, series)``.  One continuation (about 7 s)
    shared by test_bistability (folds against the bisected ones, an unstable
    middle) and test_series (the ParaView series of the same points)."""
    from skfem_sheet import Sheet
    from skfem_sheet.bistability import s_curve
    from skfem_sheet.io import Series

    series = Series()
    sc = s_curve(Sheet(length=1.2, curvature=2.5), 1.45, hmax=0.2, ds=0.1, ds_max=0.4,
                 on_point=series.on_point)
    return sc, series
