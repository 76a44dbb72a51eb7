"""Small helpers shared by the reduced-order models (no state, no I/O).

All quantities are dimensionless as in :mod:`skfem_sheet.params`: lengths in
units of the base width ``a`` and energy densities in units of ``rho g a``, so
the weight per unit area is ``rho g h = sheet.thickness``.
"""
from __future__ import annotations

import numpy as np

from skfem_sheet.params import POISSON_RATIO, ParameterError, Sheet

__all__ = ["POISSON_RATIO", "as_sheet", "integrated_profile", "weight_per_area",
           "width_profile"]


def as_sheet(sheet) -> Sheet:
    """Return ``sheet`` if it is a :class:`Sheet`, else raise ``ValueError``."""
    if not isinstance(sheet, Sheet):
        raise ParameterError(f"sheet must be a skfem_sheet.params.Sheet, got {type(sheet).__name__}")
    return sheet


def weight_per_area(sheet: Sheet) -> float:
    """rho g h in units of rho g a (i.e. the relative thickness h/a)."""
    return float(sheet.thickness)


def width_profile(S, tip_width):  # the trapezoid's; a planform's is Sheet.width
    """p = 1 + (b - 1) S on the unit interval S = s/L (ERRATA: p(x) = a + (b-a) x/L)."""
    return 1.0 + (tip_width - 1.0) * np.asarray(S, dtype=float)


def integrated_profile(S, length, tip_width):
    """I(s) = int_s^L p(xi) dxi at s = L S (supplement, eq. phODE).

    For the linear profile this is ``L [(1 - S) + (b - 1)(1 - S^2)/2]``.
    """
    S = np.asarray(S, dtype=float)
    return length * ((1.0 - S) + 0.5 * (tip_width - 1.0) * (1.0 - S**2))
