"""Persistence length of the imposed curvature without gravity (small rotations).

Supplement, section "Persistence length in the absence of gravity".  The
reduced energy (eq. Energy1)

    E = int_0^L  Y p^9 c'^4 / (140 * 8!) + D p c^2 / 2  ds,   c(0) = 1/R,

has a minimiser with compact support: c vanishes, together with c', at the
persistence length L_p.  In the variables S = s/L_p, C = R c, P = p/a the
Euler--Lagrange equation is the over-constrained BVP (eq. code2)

    [P^3 C']^2 [P^3 C']' = 8 Lhat^4 P C,   C(0) = 1, C(1) = 0, C'(1) = 0,

with P = 1 - Dhat S, Dhat = (a - b) L_p / L and Lhat = sqrt(70 h R) L_p / a^2.

Well-posed formulation used here
--------------------------------
The equation degenerates at S = 1 where C' -> 0.  Writing C = y^2 (y >= 0)
cancels the degenerate factor exactly::

    y (P^3 y')' + P^3 y'^2 = Lhat^4 / (P^5 y'^2),

whose only singular point is the regular-singular point y = 0 at S = 1, with
C(1) = C'(1) = 0 automatically and the regular solution fixed by
``y'(1) = -Lhat / P(1)^2``.  The ODE is homogeneous: if C solves it with
``Lhat = 1`` then ``C / C(0)`` solves it with ``Lhat = C(0)^(-1/2)``.  So, for a
given Dhat, one backward initial-value integration from S = 1 (started with
the two-term Frobenius series y = a1 sigma + a2 sigma^2, sigma = 1 - S,
a1 = P(1)^-2, a2 = -11 Dhat / (10 P(1)^3); perturbations of the regular
solution decay like sigma^-4, so the integration is stable) gives
``Lhat(Dhat) = 1 / y(S=0)``.  The remaining scalar consistency condition
``Dhat = (1 - b) L_p(Lhat) / L`` is solved with Brent's method.  For the
rectangle y = 1 - S exactly and Lhat = 1.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from skfem_sheet.params import ParameterError, check_integer, check_range
from skfem_sheet.reduced._common import as_sheet

__all__ = [
    "PersistenceResult",
    "lhat_of_delta",
    "persistence_length",
    "persistence_length_asymptotic",
    "persistence_scale",
]

#: Smallest admissible tip width of the curved part, P(1) = p(L_p)/a, in the
#: backward integration (a triangle with L_p -> L makes the ODE singular).
_MIN_P1 = 1e-3
_SIGMA0 = 1e-4


@dataclass(frozen=True)
class PersistenceResult:
    """Persistence length of a gravity-free sheet (lengths in units of a).

    Attributes
    ----------
    persistence_length : float
        L_p from the BVP (eq. code3); ``inf`` if the curvature reaches the tip
        (``reaches_tip``), 0 for a flat clamp.
    persistence_length_asymptotic : float
        Small-width-change formula L_p ~ alpha (1 - 9 alpha (1 - b)/(10 L)),
        alpha = a^2/sqrt(70 h R) (supplement, last equation of the section).
    rectangle_length : float
        alpha = a^2 / sqrt(70 h R), the rectangle's closed form.
    lhat, delta_hat : float
        The unknowns Lhat_p and Dhat of eq. (code3).
    reaches_tip : bool
        True if the curvature persists to the tip, L_p >= L.  For a tapered
        sheet the BVP then has no solution (P would change sign) and
        ``persistence_length`` is ``inf``; the rectangle keeps its closed form.
    S, C : ndarray
        Curvature profile C(S) = R c(s) on S = s / L_p in [0, 1] (empty if undefined).
    s, c : ndarray
        The same profile in physical variables, s = L_p S and c = C / R.
    """

    persistence_length: float
    persistence_length_asymptotic: float
    rectangle_length: float
    lhat: float
    delta_hat: float
    reaches_tip: bool
    S: np.ndarray = field(repr=False)
    C: np.ndarray = field(repr=False)
    s: np.ndarray = field(repr=False)
    c: np.ndarray = field(repr=False)


def persistence_scale(thickness: float, curvature: float) -> float:
    """alpha = a^2 / sqrt(70 h R) = 1/sqrt(70 h / kappa) in units of a (0 if kappa = 0)."""
    if curvature <= 0:
        return 0.0
    return 1.0 / math.sqrt(70.0 * thickness / curvature)


def persistence_length_asymptotic(sheet) -> float:
    """Small-Delta_p asymptote L_p ~ alpha a (1 - 9 alpha a (1 - b/a) / (10 L)).

    This is the supplement's explicit form of eq. (persistence),
    L_p = a (a - 9 Delta_p / 10) / sqrt(70 h R) + O(Delta_p^2) with
    Delta_p = (a - b) L_p / L; both agree to O(Delta_p^2).

    Examples
    --------
    >>> from skfem_sheet.params import Sheet
    >>> round(persistence_length_asymptotic(Sheet(20.0, 0.9, 2.5)), 4)
    1.0857
    """
    sheet = as_sheet(sheet)
    alpha = persistence_scale(sheet.thickness, sheet.curvature)
    if sheet.planform is not None:   # Delta_p / L_p: the mean taper over [0, alpha]
        return alpha * (1.0 - 0.9 * (1.0 - _profile(sheet, alpha)))
    return alpha * (1.0 - 0.9 * alpha * (1.0 - sheet.tip_width) / sheet.length)


def _profile(sheet, x):
    """p(x) of a planform sheet, continued beyond its end (for L_p > L)."""
    x = np.asarray(x, dtype=float)
    if sheet.planform.bites:
        return sheet.width(np.minimum(x, sheet.extent))
    return sheet.planform.profile(x / sheet.length)


def _profile_slope(sheet, x):
    x = np.asarray(x, dtype=float)
    if sheet.planform.bites:
        return sheet.width_slope(np.minimum(x, sheet.extent))
    return sheet.planform.profile_slope(x / sheet.length) / sheet.length


def _rhs_general(sigma, z, sheet, Lp):
    """:func:`_rhs` for any profile: P(sigma) = p(L_p (1 - sigma))."""
    y, v = z
    x = Lp * (1.0 - sigma)
    P = float(_profile(sheet, x))
    dP = -Lp * float(_profile_slope(sheet, x))
    f = 1.0 / (P**5 * v**2) - P**3 * v**2
    return [v, (f / y - 3.0 * P**2 * dP * v) / P**3]


def _integrate_backward(rhs, args, P1, dP0, rtol, n_profile):
    """Integrate the backward ODE ``rhs`` in sigma = 1 - S from the tip: ``(Lhat, S, C)``.

    Shared by :func:`lhat_of_delta` and :func:`_lhat_general`.  Near the tip
    (sigma < ``_SIGMA0 P1``) the regular solution is its series
    y = a1 sigma + a2 sigma^2, a1 = P1^-2, a2 = -1.1 dP0 / P1^3; beyond, ``rhs``
    is integrated to sigma = 1 (DOP853) and normalised so that C(0) = 1, with
    Lhat = 1 / y(1).

    Parameters
    ----------
    rhs : callable
        ``rhs(sigma, z, *args)`` for z = (y, y_sigma).
    args : tuple
        Extra arguments of ``rhs``.
    P1 : float
        Profile at the tip, P(1).
    dP0 : float
        dP/dsigma at the tip sigma = 0, i.e. -dP/dS at S = 1 (Dhat for the
        linear profile).
    rtol : float
        Relative tolerance of the integration.
    n_profile : int
        Number of points of the returned profile C(S) on [0, 1].
    """
    a1, a2 = P1**-2, -1.1 * dP0 / P1**3
    s0 = _SIGMA0 * P1
    z0 = [a1 * s0 + a2 * s0**2, a1 + 2.0 * a2 * s0]
    sig = np.linspace(0.0, 1.0, n_profile)
    sol = solve_ivp(rhs, (s0, 1.0), z0, args=args, method="DOP853",
                    rtol=rtol, atol=1e-14, dense_output=True)
    if not sol.success:  # pragma: no cover - the regular solution is smooth
        raise RuntimeError(f"persistence ODE failed: {sol.message}")
    y = np.where(sig < s0, a1 * sig + a2 * sig**2, 0.0)
    inner = sig >= s0
    y[inner] = sol.sol(sig[inner])[0]
    y0 = y[-1]
    return float(1.0 / y0), 1.0 - sig[::-1], (y[::-1] / y0) ** 2


def _lhat_general(sheet, Lp, rtol=1e-11, n_profile=201):
    """:func:`lhat_of_delta` for the profile P(S) = p(L_p S) of a planform sheet."""
    P1 = float(_profile(sheet, Lp))
    dP0 = -Lp * float(_profile_slope(sheet, Lp))
    return _integrate_backward(_rhs_general, (sheet, Lp), P1, dP0, rtol, n_profile)


def _persistence_planform(sheet, alpha, asym, rtol, n_profile) -> PersistenceResult:
    """Solve L_p = alpha Lhat(L_p) with P(S) = p(L_p S) for any planform.

    The linear profile's one-parameter family (Dhat) is replaced by L_p
    itself; for a sampled trapezoid the two agree to the solver tolerance.
    """
    empty = np.empty(0)
    # L_p may not reach where the width falls to _MIN_P1 (P(1) must stay positive)
    xs = np.linspace(0.0, 50.0 * alpha, 20001)[1:]
    low = np.asarray(_profile(sheet, xs)) <= _MIN_P1
    top = xs[int(np.argmax(low)) - 1] if low.any() else xs[-1]

    def mismatch(Lp):
        return Lp - alpha * _lhat_general(sheet, Lp, rtol, 2)[0]

    grid = np.concatenate([np.geomspace(1e-3 * alpha, 0.5 * alpha, 4),
                           np.linspace(0.5 * alpha, top, 16)[1:]])
    grid = grid[grid <= top]
    vals = [mismatch(g) for g in grid]
    root = None
    for k in range(1, len(grid)):
        if vals[k - 1] < 0.0 <= vals[k]:
            root = brentq(mismatch, grid[k - 1], grid[k], xtol=1e-14, rtol=1e-13)
            break
    if root is None:
        return PersistenceResult(math.inf, asym, alpha, math.nan, math.nan, True,
                                 empty, empty, empty, empty)
    lhat, S, C = _lhat_general(sheet, root, rtol, n_profile)
    Lp = float(root)
    delta = 1.0 - float(_profile(sheet, Lp))
    return PersistenceResult(Lp, float(asym), alpha, float(lhat), delta, Lp >= sheet.extent,
                             S, C, Lp * S, sheet.curvature * C)


def _rhs(sigma, z, delta):
    """Backward ODE in sigma = 1 - S for z = (y, y_sigma) with Lhat = 1."""
    y, v = z
    P = 1.0 - delta + delta * sigma
    f = 1.0 / (P**5 * v**2) - P**3 * v**2
    return [v, (f / y - 3.0 * P**2 * delta * v) / P**3]


def lhat_of_delta(delta: float, rtol: float = 1e-11, n_profile: int = 201):
    """Solve eq. (code3) for a given Dhat: return ``(Lhat, S, C)``.

    Parameters
    ----------
    delta : float
        Dhat = (a - b) L_p / (a L), in [0, 1 - 1e-3].
    rtol : float
        Relative tolerance of the backward integration.
    n_profile : int
        Number of points of the returned profile C(S) on [0, 1].

    Examples
    --------
    >>> lhat, S, C = lhat_of_delta(0.0)
    >>> bool(abs(lhat - 1.0) < 1e-12), bool(abs(C[100] - 0.25) < 1e-12)
    (True, True)
    """
    delta = float(delta)
    if not 0.0 <= delta <= 1.0 - _MIN_P1:
        raise ParameterError(f"delta must be in [0, {1 - _MIN_P1:g}], got {delta!r}")
    return _integrate_backward(_rhs, (delta,), 1.0 - delta, delta, rtol, n_profile)


def persistence_length(sheet, rtol: float = 1e-11, n_profile: int = 201) -> PersistenceResult:
    """Persistence length of the clamp curvature without gravity (eqs. code2-code3).

    Solves the over-constrained BVP [P^3 C']^2 [P^3 C']' = 8 Lhat^4 P C,
    C(0) = 1, C(1) = C'(1) = 0, P = 1 - Dhat S, with Dhat = (a - b) L_p / L
    consistent with L_p (see the module docstring for the formulation).

    Parameters
    ----------
    sheet : Sheet
        Uses ``length``, ``tip_width``, ``curvature`` and ``thickness``.  With a
        planform the profile is P(S) = p(L_p S) (``sheet.width``, continued
        beyond the tip) and the scalar condition is solved for L_p directly;
        ``delta_hat`` is then 1 - p(L_p).
    rtol : float
        Tolerance of the inner integration; L_p is accurate to about 1e-9.
    n_profile : int
        Points of the returned curvature profile.

    Returns
    -------
    PersistenceResult

    Examples
    --------
    >>> from skfem_sheet.params import Sheet
    >>> r = persistence_length(Sheet(length=20.0, curvature=2.5))
    >>> round(r.persistence_length, 6) == round((2.5 / (70 * 0.03)) ** 0.5, 6)
    True
    >>> r = persistence_length(Sheet(length=20.0, tip_width=0.9, curvature=2.5))
    >>> round(r.persistence_length, 4)
    1.0858
    """
    sheet = as_sheet(sheet)
    n_profile = check_integer("n_profile", n_profile, 2)
    rtol = check_range("rtol", rtol, 0, 1e-2, lo_open=True, hi_open=True)
    alpha = persistence_scale(sheet.thickness, sheet.curvature)
    asym = persistence_length_asymptotic(sheet)
    empty = np.empty(0)
    if alpha == 0.0:
        return PersistenceResult(0.0, 0.0, 0.0, 1.0, 0.0, False, empty, empty, empty, empty)
    if sheet.planform is not None:
        return _persistence_planform(sheet, alpha, asym, rtol, n_profile)
    taper = 1.0 - sheet.tip_width

    def mismatch(delta):
        return delta - taper * alpha * lhat_of_delta(delta, rtol, 2)[0] / sheet.length

    if taper == 0.0:
        delta = 0.0           # rectangle: L_p = alpha, even beyond the tip
    else:
        hi = min(taper, 1.0 - _MIN_P1)
        if mismatch(hi) < 0.0:
            return PersistenceResult(math.inf, asym, alpha, math.nan, math.nan, True,
                                     empty, empty, empty, empty)
        delta = brentq(mismatch, 0.0, hi, xtol=1e-14, rtol=1e-13)
    lhat, S, C = lhat_of_delta(delta, rtol, n_profile)
    Lp = float(alpha * lhat)
    reaches_tip = Lp >= sheet.length
    return PersistenceResult(Lp, float(asym), alpha, float(lhat), float(delta), reaches_tip, S, C,
                             Lp * S, sheet.curvature * C)
