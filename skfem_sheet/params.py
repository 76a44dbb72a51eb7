"""Dimensionless parameters of a clamped, curved, sagging sheet.

Everything in skfem_sheet is computed dimensionless: lengths are scaled by
the base width ``a`` and energy densities by ``rho g a`` (paper, section
"Finite-element simulations").  So ``length = L/a``, ``tip_width = b/a``,
``curvature = a/R``, ``thickness = h/a`` and ``modulus = E/(rho g a)``.  A
sheet made from SI quantities (:meth:`Sheet.from_si`) keeps the scales it
was made with (:class:`SIScale`: ``a``, ``rho``, ``g``), so that its answers
can be reported in SI units too (:attr:`Sheet.si`).

The mesh size of results is :data:`DEFAULT_HMAX` (the paper's, about 0.03 a);
:data:`QUICK_HMAX` is the documented quick value (a first look, tests,
notebooks: numbers within a few per cent of the results' mesh).
"""
from __future__ import annotations

import csv
import math
from collections import OrderedDict
from dataclasses import dataclass, field, fields

import numpy as np
from scipy.interpolate import PchipInterpolator
from scipy.optimize import brentq

__all__ = [
    "DEFAULT_HMAX",
    "POISSON_RATIO",
    "QUICK_HMAX",
    "ParameterError",
    "Planform",
    "SIScale",
    "Sheet",
    "check_finite",
    "check_integer",
    "check_range",
    "read_planform_csv",
]


class ParameterError(ValueError):
    """A bad input: the message names the parameter and the allowed range."""

#: Poisson's ratio of the incompressible neo-Hookean solid.
POISSON_RATIO = 0.5

#: The mesh size (in-plane edge length, units of a) of results: the paper's
#: (its FE meshes have a largest element diameter of about 0.03 a; tip
#: deflections converge at second order in it, within 1% beyond).  The
#: default of every analysis (``solve``, ``solve_both``, ``fold_lengths``,
#: ``s_curve``, ``fold_curve``, ``sweep``, ``calibrate``).
DEFAULT_HMAX = 0.03
#: The documented quick mesh size: a first look, the tests, the notebooks
#: (about 1/10 of the unknowns of :data:`DEFAULT_HMAX`; deflections within a
#: few per cent, fold lengths 0.004 to 0.007 a longer: docs/guide/accuracy.md).
QUICK_HMAX = 0.1

#: Clamp curvatures a/R must stay below this: the clamped base (width 1) is
#: bent into a circular arc of angle a/R, which closes on itself at 2 pi.
MAX_CURVATURE = 2.0 * math.pi


def check_finite(name: str, value) -> float:
    """Return ``value`` as a float, or raise ``ValueError`` naming ``name``."""
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be a number, got {value!r}") from None
    except OverflowError:  # an int too large for a float
        raise ParameterError(f"{name} must be finite, got {value!r}") from None
    if not math.isfinite(x):
        raise ParameterError(f"{name} must be finite, got {value!r}")
    return x


def check_integer(name: str, value, lo=None, hi=None) -> int:
    """Return ``value`` as an int in ``[lo, hi]``, or raise ``ParameterError`` naming ``name``.

    Examples
    --------
    >>> check_integer("n_nodes", 7.0, 5)
    7
    """
    bad = isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating))
    if not bad:
        x = check_finite(name, value)
        bad = not x.is_integer() or (lo is not None and x < lo) or (hi is not None and x > hi)
    if bad:
        lo_s = "-inf" if lo is None else f"{lo:g}"
        hi_s = "inf" if hi is None else f"{hi:g}"
        raise ParameterError(f"{name} must be an integer in [{lo_s}, {hi_s}], got {value!r}")
    return int(value)


def check_range(name: str, value, lo=None, hi=None, *, lo_open=False,
                hi_open=False, hint: str = "") -> float:
    """Check ``lo <= value <= hi`` (strict where ``*_open``) and return it.

    The error message names the parameter and the allowed range, e.g.
    ``length must be in (0, 100], got -1``.
    """
    x = check_finite(name, value)
    bad_lo = lo is not None and (x <= lo if lo_open else x < lo)
    bad_hi = hi is not None and (x >= hi if hi_open else x > hi)
    if bad_lo or bad_hi:
        left = "(" if lo_open else "["
        right = ")" if hi_open else "]"
        lo_s = "-inf" if lo is None else f"{lo:g}"
        hi_s = "inf" if hi is None else f"{hi:g}"
        extra = f" ({hint})" if hint else ""
        raise ParameterError(
            f"{name} must be in {left}{lo_s}, {hi_s}{right}, got {value!r}{extra}")
    return x


# -- plan-view outlines ----------------------------------------------------------------
#: Samples used to locate where bites meet the sides of a planform.
_N_SCAN = 4001


def _samples(name, values) -> np.ndarray:
    """A 1-D float array of at least two finite values, or a ParameterError naming ``name``."""
    try:
        a = np.asarray(values, dtype=float).ravel()
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be numbers, got {values!r}") from None
    if a.size < 2:
        raise ParameterError(f"{name} must have at least 2 samples, got {a.size}")
    bad = ~np.isfinite(a)
    if bad.any():
        raise ParameterError(f"{name} must be finite, got {float(a[bad][0])!r} at sample {int(np.argmax(bad))}")
    return a


def _pchip(xi: tuple, width: tuple):
    """The PCHIP interpolant of the samples, its derivative and its antiderivative."""
    f = PchipInterpolator(np.asarray(xi), np.asarray(width), extrapolate=True)
    return f, f.derivative(), f.antiderivative()


#: Outlines a planform keeps, at its last lengths (:meth:`Planform.outline`).
_OUTLINES_KEPT = 16


@dataclass(frozen=True)
class Planform:
    """Plan view of a sheet: a width profile p on x/L in [0, 1] and optional tip bites.

    The sheet occupies ``0 <= x <= L``, ``|y| <= p(x/L)/2`` (mirror-symmetric
    about the axis ``y = 0``), minus the bites.  The profile is the
    shape-preserving cubic (PCHIP) through the samples: it reproduces linear
    data exactly (a sampled trapezoid *is* the trapezoid), never overshoots, and
    stays ``>= 0`` between samples ``>= 0``.  Because it is defined on ``x/L``, a
    sheet of another length (:meth:`Sheet.replace`, continuation in L) has the
    profile stretched along x.

    Bites are circles centred on the axis, radii in units of ``a``: the first is
    centred at the tip ``x = L``, each next one at the innermost point the
    previous one left on the axis (``c_1 = L``, ``c_{k+1} = c_k - r_k``), the way
    one eats a slice of pizza.  The bites' radii do not stretch with ``L``
    (but a mesh stretched without remeshing, ``SheetProblem.with_length``,
    stretches its bites into ellipses until the next remesh).

    Parameters
    ----------
    xi : tuple of float
        Sample abscissae x/L, strictly increasing from 0 to 1.
    width : tuple of float
        p at the samples (units of the base width a): ``width[0] = 1``, all
        ``>= 0``, and ``> 0`` except at the tip (a zero inside would cut the
        sheet in two).
    bites : tuple of float, default ()
        Radii of the successive circular bites at the tip.
    length : float, optional
        The length L the samples were given at (:meth:`from_samples`,
        :func:`read_planform_csv`); only the default length of
        :meth:`Sheet.from_planform`.  Not part of the geometry (not compared).

    Examples
    --------
    >>> P = Planform.trapezoid(1.5)
    >>> float(P.profile(0.5))
    1.25
    >>> Planform.from_samples([0, 2, 4], [1, 2, 1]).length
    4.0
    >>> try:
    ...     Planform.from_samples([0, 1], [2, 1])
    ... except ParameterError as err:
    ...     print(err)
    planform width at x = 0 must be 1 (p is in units of the base width a, p(0) = 1), got 2.0
    """

    xi: tuple
    width: tuple
    bites: tuple = ()
    length: float | None = field(default=None, compare=False)

    def __post_init__(self):
        set_ = object.__setattr__
        xi = _samples("planform x", self.xi)
        w = _samples("planform width", self.width)
        if xi.size != w.size:
            raise ParameterError(f"planform x and width must have the same number of samples, "
                                 f"got {xi.size} and {w.size}")
        steps = np.diff(xi)
        if np.any(steps <= 0):
            k = int(np.argmax(steps <= 0))
            raise ParameterError(f"planform x must be strictly increasing, got x[{k}] = {float(xi[k])!r} "
                                 f"then x[{k + 1}] = {float(xi[k + 1])!r}")
        if abs(xi[0]) > 1e-12 or abs(xi[-1] - 1.0) > 1e-12:
            raise ParameterError(f"planform xi = x/L must run from 0 to 1, got [{float(xi[0])!r}, {float(xi[-1])!r}] "
                                 "(use Planform.from_samples for samples in x)")
        xi[0], xi[-1] = 0.0, 1.0
        if abs(w[0] - 1.0) > 1e-9:
            raise ParameterError("planform width at x = 0 must be 1 (p is in units of the base "
                                 f"width a, p(0) = 1), got {float(w[0])!r}")
        w[0] = 1.0
        if np.any(w < 0):
            k = int(np.argmax(w < 0))
            raise ParameterError(f"planform width must be >= 0, got {float(w[k])!r} at x/L = {xi[k]:g}")
        if np.any(w[:-1] == 0):
            k = int(np.argmax(w[:-1] == 0))
            raise ParameterError(f"planform width must be > 0 except at the tip x = L (a zero width "
                                 f"inside pinches the sheet in two), got 0 at x/L = {xi[k]:g}")
        try:
            bites = tuple(float(r) for r in np.asarray(self.bites, dtype=float).ravel())
        except (TypeError, ValueError):
            raise ParameterError(f"planform bites must be radii (numbers), got {self.bites!r}") from None
        for r in bites:
            if not (math.isfinite(r) and r > 0):
                raise ParameterError(f"planform bites must be radii in (0, inf), got {r!r}")
        if self.length is not None:
            set_(self, "length", check_range("planform length", self.length, 0, 100, lo_open=True))
        set_(self, "xi", tuple(float(v) for v in xi))
        set_(self, "width", tuple(float(v) for v in w))
        set_(self, "bites", bites)

    # -- construction --------------------------------------------------------------
    @classmethod
    def from_samples(cls, x, width, bites=()) -> Planform:
        """Profile samples at ``x`` from 0 to L (L = the last x, kept as :attr:`length`)."""
        x = _samples("planform x", x)
        if abs(x[0]) > 1e-12 * max(1.0, abs(x[-1])):
            raise ParameterError(f"planform x must start at the clamp x = 0, got {float(x[0])!r}")
        if not x[-1] > 0:
            raise ParameterError(f"planform x must end at the length L > 0, got {float(x[-1])!r}")
        return cls(tuple(x / x[-1]), tuple(_samples("planform width", width)), tuple(bites),
                   length=float(x[-1]))

    @classmethod
    def from_function(cls, f, n: int = 65, bites=(), length=None) -> Planform:
        """Sample ``p = f(xi)`` (xi = x/L in [0, 1]) at ``n`` points, denser near both ends.

        With ``length``, ``f`` is a function of x in [0, length] instead (and
        ``length`` is kept as :attr:`length`).

        Examples
        --------
        >>> leaf = Planform.from_function(lambda s: 1 + 1.2 * s - 2.2 * s**2)
        >>> round(float(leaf.profile(0.5)), 6), leaf.width[-1] == 0.0
        (1.05, True)
        """
        n = int(n)
        if n < 2:
            raise ParameterError(f"n must be an integer in [2, inf), got {n!r}")
        xi = 0.5 * (1.0 - np.cos(np.linspace(0.0, np.pi, n)))   # Chebyshev-Lobatto
        xi[0], xi[-1] = 0.0, 1.0
        if length is not None:
            length = check_range("length", length, 0, 100, lo_open=True)
        try:
            w = np.array([float(f(s if length is None else s * length)) for s in xi])
        except (TypeError, ValueError) as err:
            raise ParameterError(f"planform function must return a number, got: {err}") from None
        w[np.abs(w) < 1e-14] = 0.0
        return cls(tuple(xi), tuple(w), tuple(bites), length)

    @classmethod
    def trapezoid(cls, tip_width: float, bites=()) -> Planform:
        """The trapezoid p = 1 + (b - 1) x/L (any ``b >= 0``, also flaring ``b > 1``)."""
        b = check_range("tip_width", tip_width, 0, 100)
        return cls((0.0, 1.0), (1.0, b), tuple(bites))

    def __repr__(self) -> str:
        """Its kind and sample count (the samples themselves: :meth:`to_dict`).

        Examples
        --------
        >>> Planform.from_function(lambda s: 1 + 0.2 * s * s)
        Planform(profile of 65 samples, tip width 1.2)
        >>> Planform.trapezoid(0.5, bites=(0.2,))
        Planform(trapezoid, tip width 0.5, 1 bite)
        """
        kind = "trapezoid" if self.is_linear else f"profile of {len(self.xi)} samples"
        bites = (f", {len(self.bites)} bite{'s' if len(self.bites) > 1 else ''}"
                 if self.bites else "")
        return f"Planform({kind}, tip width {self.tip_width:.4g}{bites})"

    def replace_bites(self, bites) -> Planform:
        """The same profile with other bites."""
        return Planform(self.xi, self.width, tuple(bites), self.length)

    def to_dict(self) -> dict:
        d = {"xi": list(self.xi), "width": list(self.width), "bites": list(self.bites)}
        if self.length is not None:
            d["length"] = self.length
        return d

    @classmethod
    def from_dict(cls, d) -> Planform:
        if isinstance(d, Planform):
            return d
        if not isinstance(d, dict) or not {"xi", "width"} <= set(d):
            raise ParameterError(f"planform must be a Planform or a dict with xi and width, got {d!r}")
        return cls(tuple(d["xi"]), tuple(d["width"]), tuple(d.get("bites", ())), d.get("length"))

    # -- the profile -----------------------------------------------------------------
    @property
    def tip_width(self) -> float:
        """p(1) = b/a, the profile's width at x = L (before any bite)."""
        return self.width[-1]

    @property
    def is_linear(self) -> bool:
        """The samples lie on one straight line (a trapezoid)."""
        xi, w = np.asarray(self.xi), np.asarray(self.width)
        return bool(np.all(np.abs(w - (1.0 + (w[-1] - 1.0) * xi)) <= 1e-12))

    def _memo(self) -> dict:
        """What this (immutable) planform computed from itself, kept with it:
        its interpolants and its outlines at the last few lengths (dropped
        when it is pickled or copied, made again on use)."""
        memo = self.__dict__.get("_memo_")
        if memo is None:
            memo = {"outlines": OrderedDict()}
            object.__setattr__(self, "_memo_", memo)
        return memo

    def __getstate__(self):
        state = dict(self.__dict__)
        state.pop("_memo_", None)
        return state

    def _interpolants(self):
        memo = self._memo()
        if "pchip" not in memo:
            memo["pchip"] = _pchip(self.xi, self.width)
        return memo["pchip"]

    def profile(self, s):
        """p at ``s = x/L`` (PCHIP; linear continuation outside [0, 1])."""
        s = np.asarray(s, dtype=float)
        f, df, _ = self._interpolants()
        inside = np.clip(s, 0.0, 1.0)
        out = f(inside) + df(inside) * (s - inside)
        return out if out.ndim else float(out)

    def profile_slope(self, s):
        """dp/d(x/L) at ``s`` (constant continuation outside [0, 1])."""
        s = np.asarray(s, dtype=float)
        out = self._interpolants()[1](np.clip(s, 0.0, 1.0))
        return out if out.ndim else float(out)

    def profile_integral(self, s):
        """int_0^s p(sigma) d sigma (s in [0, 1])."""
        s = np.clip(np.asarray(s, dtype=float), 0.0, 1.0)
        out = self._interpolants()[2](s)
        return out if out.ndim else float(out)

    def outline(self, length: float) -> Outline:
        """The bite geometry of the sheet of this planform at ``length`` (validated;
        the last few are kept with the planform)."""
        length = float(length)
        outlines = self._memo()["outlines"]
        out = outlines.get(length)
        if out is None:
            out = outlines[length] = _outline(self, length)
            while len(outlines) > _OUTLINES_KEPT:
                outlines.popitem(last=False)
        return out


@dataclass(frozen=True)
class Outline:
    """Where the bites of a :class:`Planform` cut a sheet of one length.

    Attributes
    ----------
    length : float
        L.
    centres, radii : tuple of float
        The bite circles (centred on the axis).
    axis_end : float
        x where the outline leaves the axis: L without bites (or a pointed
        tip), else the innermost bite point ``L - sum(radii)``.
    extent : float
        x of the farthest material point: L, or where the bites meet the sides.
    arcs : tuple of (centre, radius, x_start, x_stop)
        The lower envelope of the bites in the upper half, from the axis to
        ``extent``, in increasing x (one piece per circle that shows).
    cut : tuple (y_low, y_high) or None
        The part of the straight tip cut ``x = L`` that remains (half plane).
    """

    length: float
    centres: tuple
    radii: tuple
    axis_end: float
    extent: float
    arcs: tuple
    cut: tuple | None

    def lower(self, x):
        """Inner edge of the upper half: ``max_k sqrt(r_k^2 - (x - c_k)^2)`` (0 off the bites)."""
        x = np.asarray(x, dtype=float)
        out = np.zeros_like(x)
        for c, r in zip(self.centres, self.radii):
            out = np.maximum(out, np.sqrt(np.clip(r * r - (x - c) ** 2, 0.0, None)))
        return out

    def lower_slope(self, x):
        """d lower / dx (infinite only at the axis point of a bite, where it is not used)."""
        x = np.asarray(x, dtype=float)
        out = np.zeros_like(x)
        for c, r, a, b in self.arcs:
            on = (x > a) & (x <= b)
            u = x[on] - c
            out[on] = -u / np.sqrt(np.clip(r * r - u * u, 1e-300, None))
        return out

    def lower_integral(self, x):
        """int_0^x lower, piecewise in closed form."""
        x = np.asarray(x, dtype=float)
        out = np.zeros_like(x)
        for c, r, a, b in self.arcs:
            out += _circle_area(np.clip(x, a, b), c, r) - _circle_area(a, c, r)
        return out


def _circle_area(x, c, r):
    """An antiderivative of sqrt(r^2 - (x - c)^2)."""
    u = np.clip(x - c, -r, r)
    return 0.5 * (u * np.sqrt(np.clip(r * r - u * u, 0.0, None)) + r * r * np.arcsin(u / r))


def _outline(planform: Planform, L: float) -> Outline:
    """Locate the bites of ``planform`` on a sheet of length ``L`` (see :class:`Outline`)."""
    if not planform.bites:
        cut = (0.0, 0.5 * planform.tip_width) if planform.tip_width > 0 else None
        return Outline(L, (), (), L, L, (), cut)
    radii = planform.bites
    centres = tuple(L - sum(radii[:k]) for k in range(len(radii)))
    x0 = min(c - r for c, r in zip(centres, radii))
    if x0 <= 1e-9 * L:
        raise ParameterError(
            f"planform bites must stay clear of the clamp: their radii sum to {sum(radii):g}, "
            f"which must be < the length {L:g} (the outline would self-intersect)")
    base = Outline(L, centres, radii, x0, L, (), None)

    def gap(x):
        return 0.5 * planform.profile(x / L) - float(base.lower(x))

    xs = np.linspace(x0, L, _N_SCAN)
    g = 0.5 * planform.profile(xs / L) - base.lower(xs)
    tol = 1e-12
    if g[0] <= tol:
        raise ParameterError(f"planform bites must leave material at the axis point x = {x0:g}")
    closed = g <= tol
    if closed.any():
        k = int(np.argmax(closed))
        extent = brentq(gap, xs[k - 1], xs[k], xtol=1e-15, rtol=1e-15) if g[k] < -tol else xs[k]
        if np.any(g[k:] > 1e-9):
            j = k + int(np.argmax(g[k:] > 1e-9))
            raise ParameterError(
                f"planform bites cut the outline into pieces (it self-intersects): the bites "
                f"meet the sides at x = {extent:g}, but material is left at x = {xs[j]:g}")
        cut = None
    else:
        extent = L
        cut = (float(base.lower(L)), 0.5 * planform.tip_width)
    # lower envelope: which circle is on top, piece by piece
    xe = np.linspace(x0, extent, _N_SCAN)
    vals = np.stack([np.sqrt(np.clip(r * r - (xe - c) ** 2, 0.0, None))
                     for c, r in zip(centres, radii)])
    vals[:, 0] = [0.0 if abs(c - r - x0) < 1e-12 else -1.0 for c, r in zip(centres, radii)]
    active = np.argmax(vals, axis=0)
    arcs, start, cur = [], x0, int(active[0])
    for j in range(1, len(xe)):
        nxt = int(active[j])
        if nxt != cur:
            ci, ri, cj, rj = centres[cur], radii[cur], centres[nxt], radii[nxt]
            xc = (rj * rj - ri * ri + ci * ci - cj * cj) / (2.0 * (ci - cj))
            arcs.append((ci, ri, start, xc))
            start, cur = xc, nxt
    arcs.append((centres[cur], radii[cur], start, extent))
    return Outline(L, centres, radii, x0, float(extent), tuple(arcs), cut)


def read_planform_csv(path) -> Planform:
    """Read a planform from a CSV file with columns ``x,width`` (header required).

    ``x`` runs from the clamp 0 to the length L (L is the last x, kept as
    :attr:`Planform.length`), ``width`` is p(x) in units of the base width
    (so the first width is 1).  Build the sheet with
    ``Sheet.from_planform(read_planform_csv(path), curvature=...)``.
    """
    try:
        with open(path, newline="") as fh:
            rows = list(csv.DictReader(fh))
    except OSError as err:
        raise ParameterError(f"planform file {path!s} cannot be read: {err}") from None
    if not rows or not {"x", "width"} <= set(rows[0]):
        raise ParameterError(f"planform file {path!s} must have a header with columns x,width")
    try:
        x = [float(r["x"]) for r in rows]
        w = [float(r["width"]) for r in rows]
    except (TypeError, ValueError) as err:
        raise ParameterError(f"planform file {path!s} has a non-numeric x or width: {err}") from None
    return Planform.from_samples(x, w)


@dataclass(frozen=True)
class SIScale:
    """The SI scales of a sheet made from SI quantities (:meth:`Sheet.from_si`).

    The dimensionless problem depends on them only through the ratios it is
    written in (``L/a``, ``E/(rho g a)``, ...); they turn its answers back
    into SI units: a length ``x`` (units of ``a``) is ``x a`` metres, a
    stress ``s`` (units of ``rho g a``) ``s rho g a`` pascals, an energy
    ``e`` (units of ``rho g a^4``) ``e rho g a^4`` joules.

    Parameters
    ----------
    base_width : float
        a in metres.
    density : float
        rho in kg/m^3.
    gravity : float
        g in m/s^2.

    Examples
    --------
    >>> s = SIScale(0.04, 1150.0)
    >>> s.metres(1.375), round(s.stress, 3)
    (0.055, 451.26)
    """

    base_width: float
    density: float
    gravity: float = 9.81

    def __post_init__(self):
        set_ = object.__setattr__
        set_(self, "base_width", check_range("base_width", self.base_width, 0, None,
                                             lo_open=True, hint="a in metres"))
        set_(self, "density", check_range("density", self.density, 0, None, lo_open=True,
                                          hint="rho in kg/m^3"))
        set_(self, "gravity", check_range("gravity", self.gravity, 0, None, lo_open=True,
                                          hint="g in m/s^2"))

    @property
    def stress(self) -> float:
        """rho g a in Pa: the unit of the moduli and stresses."""
        return self.density * self.gravity * self.base_width

    @property
    def energy(self) -> float:
        """rho g a^4 in J: the unit of the energies."""
        return self.stress * self.base_width**3

    @property
    def force(self) -> float:
        """rho g a^3 in N: the unit of the forces (the tip force)."""
        return self.stress * self.base_width**2

    def metres(self, x):
        """A length in units of a, in metres (NaN stays NaN)."""
        return x * self.base_width

    def to_dict(self) -> dict:
        return {"base_width": self.base_width, "density": self.density,
                "gravity": self.gravity}

    def to_json(self) -> dict:
        """Its fields and the units they make (``force_unit_N``, ``energy_unit_J``)."""
        return {**self.to_dict(), "force_unit_N": self.force, "energy_unit_J": self.energy}

    @classmethod
    def of(cls, value):
        """An SIScale from itself, a dict of its fields, or None."""
        if value is None or isinstance(value, SIScale):
            return value
        if isinstance(value, dict):
            unknown = set(value) - {"base_width", "density", "gravity"}
            if unknown:
                raise ParameterError(f"si must have the keys base_width, density, gravity, "
                                     f"got {', '.join(sorted(unknown))}")
            return cls(**value)
        raise ParameterError(f"si must be an SIScale, a dict of its fields or None, got "
                             f"{value!r}")


@dataclass(frozen=True)
class Sheet:
    """A sheet clamped on a circular arc, in units of its base width: a trapezoid,
    or any :class:`Planform`.

    Parameters
    ----------
    length : float
        L/a, length of the sheet from the clamp to the free edge.
    tip_width : float, default 1.0
        b/a, width of the free edge (1 = rectangle, 0 = triangle).
    curvature : float, default 0.0
        a/R, curvature of the arc the base is clamped on (0 = flat clamp).
    thickness : float, default 0.03
        h/a, as in the paper's experiments.
    modulus : float, default 735.0
        E/(rho g a), the dimensionless Young's modulus (paper: 735).
    planform : Planform or callable, optional
        Any plan view instead of the trapezoid (a width profile on x/L and tip
        bites; a dict from :meth:`to_dict` is accepted, and a callable p(x) on
        [0, L] is sampled by :meth:`Planform.from_function`).  ``tip_width`` is then
        the profile's width at x = L (leave it at the default or pass that
        value; it may exceed 1).  Without a planform the sheet is the
        trapezoid exactly as before.
    si : SIScale, optional
        The SI scales of a sheet made from SI quantities (:meth:`from_si`
        sets it; a dict of its fields is accepted): the answers about this
        sheet are then reported in SI units too.  It does not enter the
        dimensionless problem.

    Examples
    --------
    >>> s = Sheet(length=1.3, curvature=2.5)
    >>> s.mu
    245.0
    >>> round(s.area, 3)
    1.3
    """

    length: float
    tip_width: float = 1.0
    curvature: float = 0.0
    thickness: float = 0.03
    modulus: float = 735.0
    planform: Planform | None = None
    si: SIScale | None = None

    def __post_init__(self):
        # Validate up front, with a message naming the parameter and the range.
        set_ = object.__setattr__
        set_(self, "length", check_range("length", self.length, 0, 100, lo_open=True))
        if self.planform is None:
            set_(self, "tip_width", check_range(
                "tip_width", self.tip_width, 0, 1,
                hint="b/a: 1 is a rectangle, 0 a triangle; wider tips (b > a) need a planform"))
        else:
            if callable(self.planform) and not isinstance(self.planform, Planform):
                # p(x) on [0, L], sampled once (the sheet stays hashable and picklable)
                set_(self, "planform", Planform.from_function(self.planform, length=self.length))
            pf = Planform.from_dict(self.planform)
            if pf.length is not None:   # the Sheet's length is the length
                pf = Planform(pf.xi, pf.width, pf.bites)
            b = check_finite("tip_width", self.tip_width)
            if b != 1.0 and b != pf.tip_width:
                raise ParameterError(
                    f"tip_width must be the planform's width at x = L ({pf.tip_width:g}) or left "
                    f"at its default, got {self.tip_width!r}")
            set_(self, "planform", pf)
            set_(self, "tip_width", pf.tip_width)
            pf.outline(self.length)          # bites checked against this length
        set_(self, "curvature", check_range(
            "curvature", self.curvature, 0, MAX_CURVATURE, hi_open=True,
            hint="a/R; at 2*pi the clamped base would wrap onto itself"))
        set_(self, "thickness", check_range(
            "thickness", self.thickness, 0, 0.5, lo_open=True,
            hint="h/a; skfem_sheet models thin sheets"))
        set_(self, "modulus", check_range("modulus", self.modulus, 0, 1e9, lo_open=True))
        if self.thickness > 0.5 * self.length:
            raise ParameterError(
                f"thickness must be at most half the length ({0.5 * self.length:g}), "
                f"got {self.thickness!r}")
        set_(self, "si", SIScale.of(self.si))

    # -- derived quantities ------------------------------------------------------
    @property
    def mu(self) -> float:
        """Shear modulus mu = E / (2 (1 + nu)) = E/3 for nu = 1/2."""
        return self.modulus / (2.0 * (1.0 + POISSON_RATIO))

    @property
    def bending_modulus(self) -> float:
        """Plate modulus D = E h^3 / (12 (1 - nu^2)) (per unit width)."""
        return self.modulus * self.thickness**3 / (12.0 * (1.0 - POISSON_RATIO**2))

    @property
    def stretching_modulus(self) -> float:
        """Stretching modulus Y = E h / (1 - nu^2)."""
        return self.modulus * self.thickness / (1.0 - POISSON_RATIO**2)

    @property
    def radius(self) -> float:
        """R/a, the clamp radius (``inf`` for a flat clamp)."""
        return math.inf if self.curvature == 0 else 1.0 / self.curvature

    @property
    def area(self) -> float:
        """A/a^2, the plan-view area (of the trapezoid, or of the planform)."""
        if self.planform is None:
            return 0.5 * (1.0 + self.tip_width) * self.length
        return float(self.width_integral(0.0))

    @property
    def outline(self) -> Outline:
        """Where the bites cut the sheet (:class:`Outline`; the trapezoid has none)."""
        pf = self.planform if self.planform is not None else Planform.trapezoid(self.tip_width)
        return pf.outline(self.length)

    @property
    def extent(self) -> float:
        """x of the farthest material point: L, or less where bites meet the sides.

        The reduced (one-dimensional) models run over ``0 <= s <= extent``.
        """
        return self.length if self.planform is None else self.outline.extent

    def width(self, x):
        """Width p(x) of the cross-section at x.

        For the trapezoid p(x) = 1 + (b - 1) x / L (ERRATA: the /L is missing in
        the SI).  For a planform: the profile p(x/L) minus what the bites take
        (twice the inner edge of the upper half), 0 beyond :attr:`extent`.
        """
        if self.planform is None:
            return 1.0 + (self.tip_width - 1.0) * x / self.length
        x = np.asarray(x, dtype=float)
        out = self.planform.profile(x / self.length)
        if self.planform.bites:
            out = np.where(x <= self.extent,
                           np.maximum(out - 2.0 * self.outline.lower(x), 0.0), 0.0)
        return out if np.ndim(out) else float(out)

    def width_slope(self, x):
        """dp/dx of :meth:`width`."""
        if self.planform is None:
            return np.zeros_like(np.asarray(x, dtype=float)) + (self.tip_width - 1.0) / self.length
        x = np.asarray(x, dtype=float)
        out = self.planform.profile_slope(x / self.length) / self.length
        if self.planform.bites:
            out = np.where(x <= self.extent, out - 2.0 * self.outline.lower_slope(x), 0.0)
        return out if np.ndim(out) else float(out)

    def width_integral(self, x):
        """I(x) = int_x^extent p, the area beyond x (the load's lever in eq. phODE)."""
        L = self.length
        if self.planform is None:
            S = np.asarray(x, dtype=float) / L
            return L * ((1.0 - S) + 0.5 * (self.tip_width - 1.0) * (1.0 - S**2))
        x = np.clip(np.asarray(x, dtype=float), 0.0, self.extent)
        pf, e = self.planform, self.extent
        out = L * (pf.profile_integral(e / L) - pf.profile_integral(x / L))
        if pf.bites:
            o = self.outline
            out = out - 2.0 * (o.lower_integral(e) - o.lower_integral(x))
        return out if np.ndim(out) else float(out)

    def replace(self, **changes) -> Sheet:
        """A copy with some parameters changed (validated again).

        With a planform, changing ``length`` stretches the profile (it lives
        on x/L), and ``tip_width`` follows the planform.
        """
        values = {f.name: getattr(self, f.name) for f in fields(self)}
        if "planform" in changes or self.planform is not None:
            values["tip_width"] = 1.0
        return Sheet(**{**values, **changes})

    def to_dict(self) -> dict:
        """The parameters as a dict (``Sheet(**d)`` rebuilds the sheet); a planform
        appears as ``{"xi": [...], "width": [...], "bites": [...]}``, the
        trapezoid has no ``planform`` key; the SI scales of a sheet made from
        SI quantities as ``"si": {"base_width", "density", "gravity"}``
        (a dimensionless sheet has no ``si`` key)."""
        d = {f.name: getattr(self, f.name) for f in fields(self)
             if f.name not in ("planform", "si")}
        if self.planform is not None:
            d["planform"] = self.planform.to_dict()
        if self.si is not None:
            d["si"] = self.si.to_dict()
        return d

    # -- what it is, in words ----------------------------------------------------------
    def in_si(self) -> dict | None:
        """The sheet's quantities in SI units (None for a sheet without
        :attr:`si`): ``base_width``, ``length``, ``tip_width``, ``thickness``,
        ``radius`` (m; ``inf`` for a flat clamp), ``youngs_modulus`` (Pa),
        ``density`` (kg/m^3), ``gravity`` (m/s^2) -- the arguments of
        :meth:`from_si`.

        Examples
        --------
        >>> s = Sheet.from_si(0.04, 0.055, 0.036, 1.2e-3, 0.016, 6.0e5, 1150)
        >>> s
        Sheet(L/a = 1.375, b/a = 0.9, a/R = 2.5, h/a = 0.03, E/(rho g a) = 1329.61; SI: a = 0.04 m)
        >>> {k: round(v, 6) for k, v in s.in_si().items()}["length"]
        0.055
        >>> Sheet(length=1.3).in_si() is None
        True
        """
        si = self.si
        if si is None:
            return None
        a = si.base_width
        return {"base_width": a, "length": self.length * a, "tip_width": self.tip_width * a,
                "thickness": self.thickness * a,
                "radius": math.inf if self.curvature == 0 else a / self.curvature,
                "youngs_modulus": self.modulus * si.stress, "density": si.density,
                "gravity": si.gravity}

    def describe(self) -> str:
        """Every parameter in one line (what ``repr`` and the command line show).

        Examples
        --------
        >>> Sheet(length=1.3, curvature=2.5).describe()
        'L/a = 1.3, b/a = 1, a/R = 2.5, h/a = 0.03, E/(rho g a) = 735'
        """
        width = (f"b/a = {self.tip_width:.6g}" if self.planform is None
                 else f"{self.planform!r} (b/a = {self.tip_width:.6g} at the tip)")
        return (f"L/a = {self.length:.6g}, {width}, a/R = {self.curvature:.6g}, "
                f"h/a = {self.thickness:.6g}, E/(rho g a) = {self.modulus:.6g}")

    def describe_si(self) -> str:
        """The SI quantities in one line ("" without :attr:`si`).

        Examples
        --------
        >>> print(Sheet.from_si(0.04, 0.055, 0.036, 1.2e-3, 0.016, 6.0e5, 1150).describe_si())
        a = 40 mm, L = 55 mm, b = 36 mm, h = 1.2 mm, R = 16 mm, E = 6e+05 Pa, rho = 1150 kg/m^3, g = 9.81 m/s^2
        """
        q = self.in_si()
        if q is None:
            return ""
        mm = {k: f"{1e3 * q[k]:.4g} mm" for k in ("base_width", "length", "tip_width",
                                                  "thickness", "radius")}
        return (f"a = {mm['base_width']}, L = {mm['length']}, b = {mm['tip_width']}, "
                f"h = {mm['thickness']}, R = {mm['radius']}, E = {q['youngs_modulus']:.4g} Pa, "
                f"rho = {q['density']:.6g} kg/m^3, g = {q['gravity']:.6g} m/s^2")

    def __repr__(self) -> str:
        si = "" if self.si is None else f"; SI: a = {self.si.base_width:g} m"
        return f"Sheet({self.describe()}{si})"

    def _repr_pretty_(self, p, cycle) -> None:
        p.text(repr(self) if cycle else "\n".join(
            line for line in (f"Sheet: {self.describe()}", self.describe_si()) if line))

    def _repr_html_(self) -> str:
        from html import escape

        rows = [("dimensionless", self.describe())]
        if self.si is not None:
            rows.append(("SI", self.describe_si()))
        return ("<table><caption>Sheet</caption>" + "".join(
            f"<tr><th>{escape(k)}</th><td>{escape(v)}</td></tr>" for k, v in rows)
            + "</table>")

    @classmethod
    def from_planform(cls, planform: Planform, length=None, **params) -> Sheet:
        """A sheet of ``planform``, of length ``length`` (default: ``planform.length``).

        Examples
        --------
        >>> s = Sheet.from_planform(Planform.from_samples([0, 1.2], [1, 1.5]), curvature=2.5)
        >>> s.length, s.tip_width, round(s.area, 12)
        (1.2, 1.5, 1.5)
        """
        if length is None:
            if planform.length is None:
                raise ParameterError("length must be given for a planform without a length")
            length = planform.length
        return cls(length=length, planform=planform, **params)

    @classmethod
    def from_si(cls, base_width, length, tip_width, thickness, radius,
                youngs_modulus, density, gravity=9.81) -> Sheet:
        """Build a sheet from SI quantities: the dimensionless parameters, and
        the scales to report its answers in SI units (:attr:`si`).

        Parameters
        ----------
        base_width, length, tip_width, thickness : float
            a, L, b, h in metres.
        radius : float
            R in metres (``math.inf`` for a flat clamp).
        youngs_modulus : float
            E in Pa.
        density : float
            rho in kg/m^3.
        gravity : float
            g in m/s^2.

        Examples
        --------
        The paper's silicone sheet (rho 1250 kg/m^3, h = 1/16 in, a = 5 cm,
        E = 4.5e5 Pa) has E/(rho g a) close to 735:

        >>> s = Sheet.from_si(0.05, 0.065, 0.05, 1.5875e-3, 0.02, 4.5e5, 1250)
        >>> round(s.modulus), s.length, s.curvature
        (734, 1.3, 2.5)
        >>> s.si.base_width, s.in_si()["youngs_modulus"]
        (0.05, 450000.0)
        """
        a = check_range("base_width", base_width, 0, None, lo_open=True)
        length = check_range("length", length, 0, None, lo_open=True)
        thickness = check_range("thickness", thickness, 0, None, lo_open=True)
        tip_width = check_range("tip_width", tip_width, 0, a, hint="0 <= b <= base_width")
        try:
            r = float(radius)
        except (TypeError, ValueError):
            raise ParameterError(f"radius must be a number in (0, inf], got {radius!r}") from None
        except OverflowError:  # an int too large for a float: a flat clamp
            r = math.inf
        if math.isnan(r) or r <= 0:
            raise ParameterError(f"radius must be in (0, inf], got {radius!r}")
        E = check_range("youngs_modulus", youngs_modulus, 0, None, lo_open=True)
        rho = check_range("density", density, 0, None, lo_open=True)
        g = check_range("gravity", gravity, 0, None, lo_open=True)
        weight = rho * g * a
        if not (weight > 0 and math.isfinite(weight) and math.isfinite(E / weight)):
            # each factor is valid, but rho g a under- or overflows
            raise ParameterError(
                f"gravity must make rho g a (density * gravity * base_width) a positive finite "
                f"number that E/(rho g a) stays finite for, got {gravity!r} "
                f"(rho g a = {weight!r})")
        return cls(length=length / a, tip_width=tip_width / a,
                   curvature=0.0 if math.isinf(r) else a / r,
                   thickness=thickness / a, modulus=E / weight,
                   si=SIScale(a, rho, g))
