"""What a solved state is: curvature-dominated or gravity-dominated, from the state itself.

The paper's two modes (its Fig. 3): in the *curvature-dominated* mode the
clamp's transverse curvature persists along the sheet and holds it aloft; in
the *gravity-dominated* mode it relaxes within the persistence length and the
flat sheet beyond bends down under its weight.  A state is gravity-dominated
if it shows either sign of the second mode:

1. **The transverse curvature relaxes inside the sheet**: the lateral
   curvature ``c(s)`` of the mid-surface
   (:meth:`~skfem_sheet.analyses.midsurface.Midsurface.lateral_curvature`)
   changes sign over ``0 <= s <= 0.9 L``.
2. **The sag decelerates with the length**: on the state's S-curve ``d(L)``
   the slope ``d'`` is positive and the bend ``d''`` negative (a hanging
   sheet; held aloft, the sag accelerates, ``d ~ (L - L_p)^4``, or the tip
   rises).

Each sign alone misses states the other catches (the record:
``benchmarks/results/robustness/labels_n100_seed1_hmax0.1.txt``).  At a fold
the S-curve is a parabola, ``L - L* ~ -(d - d*)^2``, so the stable branch
ending at ``L0*`` is gravity-dominated and the one ending at ``L1*``
curvature-dominated: a bistable pair gets two names, and one state one name
whichever load path reached it.  A flat clamp is gravity-dominated, a sheet
without gravity curvature-dominated; a planform with bites is read by (2.)
only.  ``d' = T(w')`` and ``d'' = T(w'')`` (``T`` the tip deflection) come
from ``K w' = -R_L`` and ``K w'' = -D^2 R[(w', 1), (w', 1)]`` on the mesh
stretched in L, with the solve's factorisation.

Examples
--------
>>> from skfem_sheet import Sheet, solve
>>> r = solve(Sheet(length=1.3, curvature=2.5), "gravity-first", hmax=0.2)
>>> m = mode_of(r.problem, r.w, 1.0)
>>> m.name, m.slope > 0 > m.bend, m.relaxed
('gravity-dominated', True, True)
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..linalg import LinearSolverError
from ..params import ParameterError
from .midsurface import midsurface
from .observables import tip_deflection
from .sensitivity import parameter_derivatives, scaled_problem, solve_refined

__all__ = ["CURVATURE_DOMINATED", "GRAVITY_DOMINATED", "MODES", "Mode", "PERSISTENCE_SPAN",
           "mode_of", "name_of", "transverse_curvature"]

CURVATURE_DOMINATED = "curvature-dominated"
GRAVITY_DOMINATED = "gravity-dominated"
#: The two names, in the order of the load paths that select them.
MODES = (CURVATURE_DOMINATED, GRAVITY_DOMINATED)

#: The sections over which the transverse curvature is read: 19 over
#: ``0 <= s <= PERSISTENCE_SPAN L`` (a tapered sheet's last sections are too
#: narrow for a fit across), 21 points across each.
PERSISTENCE_SPAN = 0.9
_SECTIONS, _ACROSS = 19, 21

#: Relative step in L of the second difference of the residual (and at most
#: this in a of the state's step along ``w'``): truncation ``O(e^2)`` and
#: round-off ``O(eps / e^2)`` of the second difference balance near it.
BEND_STEP = 1e-3


@dataclass(frozen=True)
class Mode:
    """The name of a state and what it was read from.

    Attributes
    ----------
    name : str
        :data:`CURVATURE_DOMINATED` or :data:`GRAVITY_DOMINATED`.
    slope : float
        ``dd/dL`` along the state's S-curve (NaN where not computed).
    bend : float
        ``d^2d/dL^2`` along it (NaN where not computed).
    relaxed : bool or None
        The transverse curvature changes sign inside the sheet (None where
        not read: a flat clamp, a planform with bites).
    curvature_min : float
        The smallest lateral curvature over the sections, relative to the
        clamp's ``a/R`` (NaN where not read).
    reason : str
        In words: ``"the curvature relaxes inside the sheet"``, ``"the sag
        decelerates"``, ``"the sag accelerates"``, ``"the tip rises"``,
        ``"a flat clamp"``, ``"no gravity"``.
    """

    name: str
    slope: float = math.nan
    bend: float = math.nan
    relaxed: object = None
    curvature_min: float = math.nan
    reason: str = ""

    def to_json(self) -> dict:
        return {"name": self.name, "slope": self.slope, "bend": self.bend,
                "relaxed": self.relaxed, "curvature_min": self.curvature_min,
                "reason": self.reason}


def name_of(slope: float, bend: float, relaxed=None) -> str:
    """The name from the state's two signs (the criterion of the module
    docstring): the S-curve's slope and bend there, and whether the
    transverse curvature relaxes inside the sheet.

    Examples
    --------
    >>> name_of(1.2, -0.3), name_of(0.4, 2.0), name_of(-0.1, -0.2)
    ('gravity-dominated', 'curvature-dominated', 'curvature-dominated')
    >>> name_of(1.2, 0.3, relaxed=True)
    'gravity-dominated'
    """
    return GRAVITY_DOMINATED if (relaxed or (slope > 0 and bend < 0)) else CURVATURE_DOMINATED


def transverse_curvature(problem, w):
    """``(relaxed, min c/(a/R))``: whether the lateral curvature of the
    mid-surface changes sign over ``0 <= s <= PERSISTENCE_SPAN L``, and its
    smallest value there relative to the clamp's; ``(None, nan)`` for a flat
    clamp or a planform with bites (no single section across)."""
    kappa = problem.sheet.curvature
    if kappa == 0.0:
        return None, math.nan
    s = np.linspace(0.0, PERSISTENCE_SPAN * float(problem.length), _SECTIONS)
    try:
        c = midsurface(problem, w, s, n_across=_ACROSS).lateral_curvature() / kappa
    except ParameterError:
        return None, math.nan
    return bool(np.any(c < 0)), float(c.min())


def mode_of(problem, w, gravity: float = 1.0, linear=None) -> Mode:
    """The mode of the equilibrium ``w`` of ``problem`` at the load factor ``gravity``.

    Parameters
    ----------
    problem : SheetProblem
        The solved problem (``Result.problem``).
    w : ndarray
        Its equilibrium (``Result.w``).
    gravity : float
        The load factor of the state.
    linear : linear solver, optional
        A back-end holding the factorised tangent at (or next to) ``w``
        (the solve's, a continuation step's), refined against the tangent
        assembled at ``w`` (:func:`~skfem_sheet.analyses.sensitivity.solve_refined`:
        near a steep part of the S-curve the tangent is nearly singular, and a
        factorisation made at the step's prediction instead of its state
        moves ``d''`` by more than its size); default: factorise it at ``w``.

    Returns
    -------
    Mode
        See the module docstring for the criterion.
    """
    sheet = problem.sheet
    if sheet.curvature == 0.0:
        return Mode(GRAVITY_DOMINATED, reason="a flat clamp (no transverse curvature)")
    if gravity == 0.0:
        return Mode(CURVATURE_DOMINATED, reason="no gravity")
    w = np.asarray(w, dtype=float)
    relaxed, c_min = transverse_curvature(problem, w)
    try:
        slope, bend = _slope_and_bend(problem, w, gravity, linear)
    except (ParameterError, LinearSolverError) as err:
        # the S-curve's sign not read (a state that inverts an element at a length
        # next to it, a tangent the solver cannot factorise): the curvature's alone
        name = GRAVITY_DOMINATED if relaxed else CURVATURE_DOMINATED
        return Mode(name, math.nan, math.nan, relaxed, c_min,
                    f"{'the curvature relaxes inside the sheet' if relaxed else 'the curvature persists'}"
                    f" (the S-curve's slope not read: {err})")
    name = name_of(slope, bend, relaxed)
    if name == GRAVITY_DOMINATED:
        reason = ("the curvature relaxes inside the sheet" if relaxed
                  else "the sag decelerates with the length")
    else:
        reason = "the tip rises with the length" if slope <= 0 else \
            "the sag accelerates with the length"
    return Mode(name, float(slope), float(bend), relaxed, c_min, reason)


def _slope_and_bend(problem, w, gravity, linear):
    """``(d', d'')`` of the tip deflection along the S-curve at the equilibrium ``w``."""
    free = problem.free
    L = float(problem.length)
    # the tangent of the S-curve: K w' = -R_L (the clamp values do not depend on L)
    R_L, _, _ = parameter_derivatives(problem, w, gravity, ("length",))
    du = -solve_refined(problem, w, R_L, linear)[:, 0]
    # D^2 R along (w', 1), a central second difference on the stretched meshes
    e = BEND_STEP * L
    scale = float(np.abs(du).max()) if du.size else 0.0
    if scale * e > BEND_STEP:
        e = BEND_STEP / scale
    dw = np.zeros_like(w)
    dw[free] = du
    r = []
    for s in (-1.0, 0.0, 1.0):
        prob = problem if s == 0.0 else scaled_problem(problem, length=L + s * e)
        rr, jmin = prob.residual(w + s * e * dw, gravity)
        if not jmin > 0:
            raise ParameterError(f"the state inverts an element at L = {L + s * e:g}")
        r.append(rr[free])
    q = (r[2] - 2.0 * r[1] + r[0]) / e**2
    d2u = -solve_refined(problem, w, q[:, None], linear)[:, 0]
    dw2 = np.zeros_like(w)
    dw2[free] = d2u

    def along(x):
        # the tip deflection is piecewise linear in the state (its lowest nodes):
        # a step small against the state's own scale gives its derivative
        h = 1e-7 / max(1.0, float(np.abs(x).max()))
        return (tip_deflection(problem, w + h * x) - tip_deflection(problem, w - h * x)) / (2 * h)

    return along(dw), along(dw2)
