"""Dimensionless parameters of a clamped, curved, sagging sheet.

Everything in skfem_sheet is dimensionless: lengths are scaled by the base
width ``a`` and energy densities by ``rho g a`` (paper, section
"Finite-element simulations").  So ``length = L/a``, ``tip_width = b/a``,
``curvature = a/R``, ``thickness = h/a`` and ``modulus = E/(rho g a)``.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass

__all__ = ["Sheet", "ParameterError", "check_finite", "check_range", "POISSON_RATIO"]


class ParameterError(ValueError):
    """A bad input: the message names the parameter and the allowed range."""

#: Poisson's ratio of the incompressible neo-Hookean solid.
POISSON_RATIO = 0.5

#: Clamp curvatures a/R must stay below this: the clamped base (width 1) is
#: bent into a circular arc of angle a/R, which closes on itself at 2 pi.
MAX_CURVATURE = 2.0 * math.pi


def check_finite(name: str, value) -> float:
    """Return ``value`` as a float, or raise ``ValueError`` naming ``name``."""
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(x):
        raise ParameterError(f"{name} must be finite, got {value!r}")
    return x


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


@dataclass(frozen=True)
class Sheet:
    """A trapezoidal sheet clamped on a circular arc, in units of its base width.

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

    def __post_init__(self):
        # Validate up front, with a message naming the parameter and the range.
        set_ = object.__setattr__
        set_(self, "length", check_range("length", self.length, 0, 100, lo_open=True))
        set_(self, "tip_width", check_range(
            "tip_width", self.tip_width, 0, 1,
            hint="b/a: 1 is a rectangle, 0 a triangle; wider tips are not supported"))
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
        """A/a^2, the plan-view area of the trapezoid."""
        return 0.5 * (1.0 + self.tip_width) * self.length

    def width(self, x):
        """Width profile p(x) = 1 + (b - 1) x / L (ERRATA: the /L is missing in the SI)."""
        return 1.0 + (self.tip_width - 1.0) * x / self.length

    def replace(self, **changes) -> "Sheet":
        """A copy with some parameters changed (validated again)."""
        return Sheet(**{**asdict(self), **changes})

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_si(cls, base_width, length, tip_width, thickness, radius,
                youngs_modulus, density, gravity=9.81) -> "Sheet":
        """Build a dimensionless sheet from SI quantities.

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
        """
        a = check_range("base_width", base_width, 0, None, lo_open=True)
        for name, v in [("length", length), ("thickness", thickness)]:
            check_range(name, v, 0, None, lo_open=True)
        check_range("tip_width", tip_width, 0, a, hint="0 <= b <= base_width")
        r = float(radius)
        if math.isnan(r) or r <= 0:
            raise ParameterError(f"radius must be in (0, inf], got {radius!r}")
        E = check_range("youngs_modulus", youngs_modulus, 0, None, lo_open=True)
        rho = check_range("density", density, 0, None, lo_open=True)
        g = check_range("gravity", gravity, 0, None, lo_open=True)
        return cls(length=length / a, tip_width=tip_width / a,
                   curvature=0.0 if math.isinf(r) else a / r,
                   thickness=thickness / a, modulus=E / (rho * g * a))
