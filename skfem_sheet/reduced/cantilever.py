"""Cantilever estimate: flat part beyond L_p as an Euler--Bernoulli plate.

Supplement, section "Vertical displacement in the absence of curvature"::

    D [p W_1'']'' + rho g h p = 0  on L_p < s < L,
    W_1(L_p) = W_0(L_p), W_1'(L_p) = 0, (p W_1'')(L) = 0, (p W_1'')'(L) = 0.

(The natural conditions are on the moment p W_1'' and the shear (p W_1'')';
for p(L) > 0 they are the printed W_1''(L) = W_1'''(L) = 0, and they stay
correct for the triangle.)  Integrating twice from the free end gives the
moment m(s) = D p W_1'' = -rho g h int_s^L (xi - s) p(xi) dxi, so the drop of
the flat part, reported positive downward, is

    d_flat = W_1(L_p) - W_1(L) = rho g h / D int_{L_p}^L (L - s) J(s) / p(s) ds,
    J(s) = int_s^L (xi - s) p(xi) dxi,

evaluated with Gauss--Legendre quadrature (exact up to the 1/p factor).  It
equals C rho g h (L - L_p)^4 / D with C = 1/8 for a rectangle and C = 1/24 for
a triangle (supplement; ERRATA: the main text's C rho g (L - L_p)^4/(E h^2)
with C = 3/2, 1/2 drops the factor 1 - nu^2).

The curved part 0 < s < L_p follows the gravity-free small-rotation model,
where the line t = 0 moves by W_0(L_p) = -3/56 int_0^{L_p} c' p^2 ds (eq. U0W0b),
an upward motion (c' < 0).  By default the estimate is the paper's
d = W_1(L_p) - W_1(L); ``include_curved_part=True`` also subtracts W_0(L_p).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from skfem_sheet.params import ParameterError, Sheet
from skfem_sheet.reduced._common import as_sheet, weight_per_area
from skfem_sheet.reduced.persistence import PersistenceResult, persistence_length

__all__ = [
    "CantileverResult",
    "cantilever_coefficient",
    "cantilever_deflection",
    "flat_cantilever_drop",
]

_GAUSS = np.polynomial.legendre.leggauss(64)


@dataclass(frozen=True)
class CantileverResult:
    """Cantilever estimate of the tip deflection (positive downward).

    Attributes
    ----------
    deflection : float
        d = d_flat (default) or d_flat - W_0(L_p) with ``include_curved_part``.
    flat_drop : float
        W_1(L_p) - W_1(L) >= 0, drop of the flat part.
    curved_rise : float
        W_0(L_p) >= 0, rise of the centre line of the curved part (eq. U0W0b).
    persistence_length : float
        L_p used (from :func:`persistence_length`; capped at L).
    coefficient : float
        d_flat D / (rho g h (L - L_p)^4): 1/8 rectangle, 1/24 triangle.
    """

    deflection: float
    flat_drop: float
    curved_rise: float
    persistence_length: float
    coefficient: float


def _gauss(a, b):
    x, w = _GAUSS
    return 0.5 * (b - a) * x + 0.5 * (a + b), 0.5 * (b - a) * w


def flat_cantilever_drop(sheet, Lp: float) -> float:
    """d_flat = rho g h / D int_{Lp}^L (L - s) J(s)/p(s) ds for a clamp at s = Lp.

    Examples
    --------
    >>> from skfem_sheet.params import Sheet
    >>> s = Sheet(length=2.0, tip_width=0.0)
    >>> abs(flat_cantilever_drop(s, 0.5) - 0.03 * 1.5**4 / (24 * s.bending_modulus)) < 1e-10
    True
    """
    sheet = as_sheet(sheet)
    if sheet.planform is not None:
        return _flat_drop_planform(sheet, Lp)
    L, b = sheet.length, sheet.tip_width
    if Lp >= L:
        return 0.0
    k = (b - 1.0) / L           # p(x) = 1 + k x
    s, w = _gauss(Lp, L)
    # J(s) = int_s^L (xi - s)(1 + k xi) dxi, in closed form
    u = L - s
    J = (1.0 + k * s) * u**2 / 2.0 + k * u**3 / 3.0
    p = 1.0 + k * s
    ratio = np.divide(J, p, out=np.zeros_like(J), where=p > 0)
    return float(weight_per_area(sheet) / sheet.bending_modulus * np.sum(w * (L - s) * ratio))


def _flat_drop_planform(sheet, Lp: float) -> float:
    """d_flat for any planform: J(s) = int_s^L I by Gauss-Legendre, I = ``sheet.width_integral``."""
    L = sheet.extent
    if Lp >= L:
        return 0.0
    s, w = _gauss(Lp, L)
    x, v = _GAUSS
    # J(s_i) = int_{s_i}^L I(eta) d eta, one Gauss rule per s_i
    eta = 0.5 * (L - s)[:, None] * x[None, :] + 0.5 * (L + s)[:, None]
    J = 0.5 * (L - s) * np.sum(v[None, :] * sheet.width_integral(eta), axis=1)
    p = np.asarray(sheet.width(s), dtype=float)
    ratio = np.divide(J, p, out=np.zeros_like(J), where=p > 0)
    return float(weight_per_area(sheet) / sheet.bending_modulus * np.sum(w * (L - s) * ratio))


def cantilever_coefficient(tip_width: float, length: float, Lp: float) -> float:
    """C in d_flat = C rho g h (L - L_p)^4 / D for the linear profile p = 1 + (b-1)s/L."""
    sheet = Sheet(length=length, tip_width=tip_width, thickness=min(0.03, 0.5 * length))
    return flat_cantilever_drop(sheet, Lp) * sheet.bending_modulus / (
        weight_per_area(sheet) * (length - Lp) ** 4)


def _curved_rise(result, sheet) -> float:
    """W_0(L_p) = -3/56 int_0^{L_p} c' p^2 ds from the persistence profile."""
    if result.s.size < 2:
        return 0.0
    s, c = result.s, result.c
    dc = np.gradient(c, s, edge_order=2)
    if sheet.planform is None:
        p = 1.0 + (sheet.tip_width - 1.0) * s / sheet.length
    else:
        p = np.asarray(sheet.width(s), dtype=float)
    f = -3.0 / 56.0 * dc * p**2
    return float(np.sum(0.5 * (f[1:] + f[:-1]) * np.diff(s)))


def cantilever_deflection(sheet, include_curved_part: bool = False,
                          persistence=None) -> CantileverResult:
    """Cantilever estimate of the tip deflection beyond the persistence length.

    Parameters
    ----------
    sheet : Sheet
        Sheet parameters; L_p is computed from ``curvature`` and ``thickness``.
        With a planform, p = ``sheet.width`` on ``0 <= s <= sheet.extent``.
    include_curved_part : bool
        Also count the (upward) motion W_0(L_p) of the curved part.
    persistence : PersistenceResult, optional
        Precomputed :func:`persistence_length` of ``sheet``.

    Returns
    -------
    CantileverResult
        ``deflection`` is positive downward; 0 if L <= L_p.

    Examples
    --------
    >>> from skfem_sheet.params import Sheet
    >>> s = Sheet(length=1.0)            # flat clamp: L_p = 0, d = rho g h L^4/(8 D)
    >>> r = cantilever_deflection(s)
    >>> abs(r.deflection - 0.03 / (8 * s.bending_modulus)) < 1e-10
    True
    """
    sheet = as_sheet(sheet)
    if persistence is not None and not isinstance(persistence, PersistenceResult):
        raise ParameterError(f"persistence must be a PersistenceResult of persistence_length "
                             f"or None, got {type(persistence).__name__}")
    res = persistence_length(sheet) if persistence is None else persistence
    Lp = min(res.persistence_length, sheet.extent)
    flat = flat_cantilever_drop(sheet, Lp)
    rise = _curved_rise(res, sheet) if res.s.size else 0.0
    denom = weight_per_area(sheet) * (sheet.extent - Lp) ** 4 / sheet.bending_modulus
    coef = flat / denom if denom > 0 else float("nan")
    d = flat - rise if include_curved_part else flat
    return CantileverResult(float(d), float(flat), float(rise), float(Lp), float(coef))
