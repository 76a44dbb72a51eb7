"""Heavy elastica with a varying width (large rotations, no transverse curvature).

Supplement eq. (phODE2), the kappa = 0 reference of the ribbon model and of the
3D solver::

    D [p(s) phi'(s)]' = rho g h I(s) cos phi(s),   phi(0) = 0,  phi'(L) = 0,

with I(s) = int_s^L p.  The tangent d_1 = cos phi e_1 + sin phi e_3 points
downward under gravity (phi < 0), and the tip deflection is reported positive
downward, d = -int_0^L sin phi ds.

It is solved as the first-order system for (phi, m, z) with the bending moment
m = D p phi' and the height z = int_0^s sin phi, using
:func:`scipy.integrate.solve_bvp` (collocation, residual tolerance 1e-9), with
continuation in the load if the direct solve fails.  At a triangle's tip
p -> 0 and m ~ (L - s)^3, so phi' = m/(D p) -> 0 is used there.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import solve_bvp

from skfem_sheet.params import check_integer, check_range
from skfem_sheet.reduced._common import (
    as_sheet,
    integrated_profile,
    weight_per_area,
    width_profile,
)

__all__ = ["ElasticaResult", "elastica", "elastica_linear_deflection"]

#: Collocation tolerance used for bitten planforms (see :func:`elastica`).
_BITE_TOL = 1e-6


@dataclass(frozen=True)
class ElasticaResult:
    """Solution of the heavy elastica (eq. phODE2).

    Attributes
    ----------
    deflection : float
        d = -int_0^L sin phi ds, positive downward (units of a).
    s, phi, moment : ndarray
        Arclength mesh, tangent angle (negative = downward) and m = D p phi'.
    converged : bool
        Whether :func:`scipy.integrate.solve_bvp` met its tolerance.
    """

    deflection: float
    s: np.ndarray = field(repr=False)
    phi: np.ndarray = field(repr=False)
    moment: np.ndarray = field(repr=False)
    converged: bool = True


def elastica_linear_deflection(sheet) -> float:
    """Small-load limit of eq. (phODE2): d = rho g h int_0^L (L - s) M(s)/(D p(s)) ds.

    For a rectangle this is rho g h L^4 / (8 D), for a triangle rho g h L^4 / (24 D).

    Examples
    --------
    >>> from skfem_sheet.params import Sheet
    >>> s = Sheet(length=1.0)
    >>> abs(elastica_linear_deflection(s) - 0.03 / (8 * s.bending_modulus)) < 1e-12
    True
    """
    # deferred: cantilever imports this module (a cycle at import time)
    from skfem_sheet.reduced.cantilever import flat_cantilever_drop
    sheet = as_sheet(sheet)
    return flat_cantilever_drop(sheet, 0.0)


def _system(sheet, load):
    L, b = sheet.length, sheet.tip_width
    D = sheet.bending_modulus
    q = load * weight_per_area(sheet)

    if sheet.planform is None:
        def fun(s, y):
            phi, m, _ = y
            p = width_profile(s / L, b)
            dphi = np.divide(m, D * p, out=np.zeros_like(m), where=p > 1e-12)
            return np.vstack([dphi, q * integrated_profile(s / L, L, b) * np.cos(phi), np.sin(phi)])
    else:   # any planform: its cross-section width and the area beyond s
        def fun(s, y):
            phi, m, _ = y
            p = np.asarray(sheet.width(s), dtype=float)
            dphi = np.divide(m, D * p, out=np.zeros_like(m), where=p > 1e-12)
            return np.vstack([dphi, q * sheet.width_integral(s) * np.cos(phi), np.sin(phi)])

    def bc(ya, yb):
        return np.array([ya[0], yb[1], ya[2]])

    return fun, bc


def _physical(phi) -> bool:
    """The stable heavy elastica hangs monotonically: 0 >= phi >= -pi."""
    return bool(np.all(np.diff(phi) <= 1e-12) and phi[-1] > -np.pi)


def elastica(sheet, tol: float = 1e-9, n_nodes: int = 101, max_nodes: int = 100000) -> ElasticaResult:
    """Solve the heavy elastica with varying width, eq. (phODE2).

    Parameters
    ----------
    sheet : Sheet
        Uses ``length``, ``tip_width`` (or the ``planform``: p = ``sheet.width``,
        on ``0 <= s <= sheet.extent``), ``thickness`` (rho g h) and ``modulus``
        (D).  The clamp curvature is ignored.
    tol : float
        Residual tolerance of :func:`scipy.integrate.solve_bvp` (at least 1e-6
        for a bitten planform, whose width has a square-root edge where a
        bite leaves the axis).
    n_nodes : int
        Initial mesh size.
    max_nodes : int
        Mesh size limit of the adaptive collocation.

    Returns
    -------
    ElasticaResult

    Examples
    --------
    >>> from skfem_sheet.params import Sheet
    >>> r = elastica(Sheet(length=1.0))
    >>> round(r.deflection, 3)
    0.768
    """
    sheet = as_sheet(sheet)
    tol = check_range("tol", tol, 0, 1e-2, lo_open=True, hi_open=True)
    n_nodes = check_integer("n_nodes", n_nodes, 5)
    s = np.linspace(0.0, sheet.extent, int(n_nodes))   # extent: L, or where bites end
    if sheet.planform is not None and sheet.planform.bites:
        # p ~ sqrt(x - x0) where a bite leaves the axis: the collocation residual
        # cannot reach 1e-9 next to that point with any mesh, so 1e-6 is asked
        # for there (the deflection then agrees with finer requests to ~1e-9)
        tol = max(tol, _BITE_TOL)
        x0, n = sheet.outline.axis_end, int(n_nodes)
        k = min(max(2, round(n * x0 / sheet.extent)), n - 2)
        s = np.concatenate([np.linspace(0.0, x0, k), np.linspace(x0, sheet.extent, n - k + 1)[1:]])
    y = np.zeros((3, s.size))
    # Continuation in the load from the straight sheet: a cold start at large
    # loads can land on spurious looping solutions of the BVP.
    G = weight_per_area(sheet) * sheet.length**3 / sheet.bending_modulus
    n_steps = max(1, int(np.ceil(G / 4.0)))
    state = {"sol": None, "s": s, "y": y}

    def attempt(load):
        fun, bc = _system(sheet, load)
        trial = solve_bvp(fun, bc, state["s"], state["y"], tol=tol, max_nodes=max_nodes)
        if trial.status == 0 and _physical(trial.y[0]):
            state.update(sol=trial, s=trial.x, y=trial.y)
            return True
        return False

    # equal load steps 1/n_steps from the straight sheet, halved after a
    # failure; the ramp gives up once a step would be below 1e-4 of the load
    step = 1.0 / n_steps
    done = 0.0
    while done < 1.0 and step >= 1e-4:
        load = min(1.0, done + step)
        if attempt(load):
            done = load
        else:
            step *= 0.5
    sol, s, y = state["sol"], state["s"], state["y"]
    converged = True
    if sol is None or done < 1.0:
        converged = False
    if sol is None:
        return ElasticaResult(float("nan"), s, y[0], y[1], False)
    return ElasticaResult(float(-sol.y[2, -1]), sol.x, sol.y[0], sol.y[1], bool(converged))
