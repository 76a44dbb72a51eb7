"""Quality levels of the figures: mesh sizes, fold-map grids, the data folder.

``"quick"`` is the fold map at hmax 0.1 (:data:`QUICK_GRID`), ``"paper"`` at
hmax 0.03 on finer grids (:data:`PAPER_GRID`); :func:`quality_settings`
gives every number a figure takes from its quality.

Examples
--------
>>> quality_settings("quick")["hmax"]
0.1
>>> sorted(QUICK_GRID)
[0.0, 1.0, 1.5, 2.0, 2.5, 3.5, 5.0]
"""
from __future__ import annotations

import numpy as np

from ..params import ParameterError

__all__ = ["QUALITIES", "DEFAULT_DATA_DIR", "QUICK_GRID", "PAPER_GRID", "quality_settings",
           "arange"]

QUALITIES = ("quick", "paper")
DEFAULT_DATA_DIR = "skfem_sheet_data"

#: The fold map of quick quality, ``{a/R: [b/a, ...]}``: every figure's points are in it.
QUICK_GRID = {0.0: [0.0, 0.2, 0.4, 0.6, 0.8, 1.0],
              1.0: [0.0, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0],
              1.5: [0.5, 0.6, 0.7, 0.8, 0.9, 1.0],
              2.0: [0.5, 0.6, 0.7, 0.8, 0.9, 1.0],
              2.5: [0.0, 0.2, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0],
              3.5: [0.5, 0.6, 0.7, 0.8, 0.9, 1.0],
              5.0: [0.0, 0.2, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0]}

_FINE_TIPS = [round(0.5 + 0.05 * i, 6) for i in range(11)]       # 0.5, 0.55, ..., 1
_TAPERED = [0.0, 0.1, 0.2, 0.3, 0.4]
#: The fold map of paper quality: b/a in steps of 0.05 where bistability can
#: appear (b/a >= 0.5), a/R in steps of 0.25 up to 2.5 and 0.5 beyond.
PAPER_GRID = {0.0: [0.0, 0.2, 0.4, 0.6, 0.8, 1.0],
              **{c: (_TAPERED + _FINE_TIPS if c in (1.0, 2.5, 5.0) else list(_FINE_TIPS))
                 for c in (1.0, 1.25, 1.5, 1.75, 2.0, 2.25, 2.5, 3.0, 3.5, 4.0, 4.5, 5.0)}}

_SETTINGS = {
    "quick": {
        "hmax": 0.1, "hmax_fig3": 0.08, "lengths": (0.5, 3.0), "step": 0.1, "tol": 0.005,
        "grid": QUICK_GRID,
        "fig6_lengths": (0.6, 2.8, 0.1),        # FE mode markers
        "fig6_ribbon_lengths": (0.5, 3.0, 0.1),  # ribbon background (26 x 26)
        "fig6_ribbon_tips": 26,
        "fig7_curvatures": (1.0, 1.5, 2.0, 2.5, 3.5, 5.0),
        "ribbon_step": 0.05,                     # fig5's ribbon curves
        "marker_gap": 0.06,                      # least L/a between two markers of a curve
        "hmax_supplement": 0.1,                  # figS3, figS4 (paper: hmax 0.03)
        "supplement_grid": (61, 41),             # figS3's sections x points across
        # figS1: nested families (base hmax, layers, refinements 0..k) and the default mesh
        "figS1_families": ((0.24, 2, 1), (0.2, 2, 1), (0.16, 2, 1)),
        "figS1_fit_max_h": 0.24,
        "figS1_fit_powers": (2,),                # coarse meshes: d_inf + A h^2
    },
    "paper": {
        "hmax": 0.03, "hmax_fig3": 0.03, "lengths": (0.5, 3.0), "step": 0.05, "tol": 0.005,
        "grid": PAPER_GRID,
        "fig6_lengths": (0.6, 2.8, 0.1),
        "fig6_ribbon_lengths": (0.5, 3.0, 0.02),
        "fig6_ribbon_tips": 51,
        "fig7_curvatures": (1.0, 1.25, 1.5, 1.75, 2.0, 2.25, 2.5, 3.0, 3.5, 4.0, 4.5, 5.0),
        "ribbon_step": 0.01,
        "marker_gap": 0.1,
        "hmax_supplement": 0.03,
        "supplement_grid": (151, 81),
        # the recorded study (benchmarks/results/convergence_nested*_L1.8_aR5.json and
        # convergence_fit_L1.8_aR5.txt: three nested families, fitted over h <= 0.12)
        "figS1_families": ((0.16, 2, 2), (0.14, 2, 2), (0.12, 2, 2)),
        "figS1_fit_max_h": 0.12,
        "figS1_fit_powers": (2, 3),              # d_inf + A h^2 + B h^3
    },
}


def quality_settings(quality: str) -> dict:
    """Mesh size and grids of a quality level (``"quick"`` or ``"paper"``).

    Examples
    --------
    >>> s = quality_settings("paper")
    >>> s["hmax"], s["step"], len(s["grid"])
    (0.03, 0.05, 13)
    >>> quality_settings("draft")
    Traceback (most recent call last):
    ...
    skfem_sheet.params.ParameterError: quality must be one of quick, paper, got 'draft'
    """
    if quality not in _SETTINGS:
        raise ParameterError(f"quality must be one of {', '.join(QUALITIES)}, got {quality!r}")
    return dict(_SETTINGS[quality])



def arange(lo, hi, step):
    """``lo, lo + step, ..., hi`` (``hi`` included), rounded to 6 decimals.

    Examples
    --------
    >>> arange(0.5, 0.7, 0.1).tolist()
    [0.5, 0.6, 0.7]
    """
    return np.round(np.arange(lo, hi + 1e-9, step), 6)
