"""What a solved state is: curvature-dominated or gravity-dominated, from the state itself.

The paper's two modes (its Fig. 3): in the *curvature-dominated* mode the
clamp's transverse curvature persists along the sheet and holds it aloft; in
the *gravity-dominated* mode the curvature relaxes near the base and the
sheet beyond it, flat, bends down under its weight ("which mode is selected
depends on the length of the sheet relative to a persistence length, the
distance along the sheet over which the transverse curvature relaxes").
Two signs of the second mode are read from the state, and a state is
gravity-dominated if it shows either:

1. **The transverse curvature relaxes inside the sheet.**  The lateral
   curvature ``c(s)`` of the mid-surface (the quadratic fit of its
   deflection across each section,
   :meth:`~skfem_sheet.analyses.midsurface.Midsurface.lateral_curvature`)
   changes sign somewhere over ``0 <= s <= 0.9 L`` (the last tenth left
   out, where a tapered sheet's sections are too narrow to fit): the
   paper's persistence length ``L_p``, where ``c`` vanishes, lies inside
   the sheet, and beyond it the sheet is flat (its small curvature of the
   other sign is the anticlastic response of a bent strip).  Along the
   curvature-dominated branch ``c`` keeps the clamp's sign to the tip.
2. **The sag decelerates with the length.**  On the state's *S-curve*, the
   curve ``d(L)`` of the equilibria of its planform, curvature and material
   as the length varies (:mod:`skfem_sheet.bistability`), the slope
   ``d' = dd/dL`` is positive and the bend ``d'' = d^2d/dL^2`` negative:
   the sheet hangs, each added length hanging further down but ever closer
   to straight down.  Held aloft by its curvature, a sheet is a stiff beam
   whose free part's weight and lever grow together, so its sag accelerates
   (the paper's cantilever estimate ``d ~ (L - L_p)^4``), or the tip even
   rises as the curved sheet lengthens (``d' < 0``).

Otherwise the state is curvature-dominated.  Each sign alone misses states
the other catches: a weakly curved clamp (a/R about 0.4) lets a sheet hang
while the little curvature it has never changes sign (2.), and a long
hanging sheet on a strongly curved clamp (a/R 3.5 to 5) can have a sag that
accelerates again far out on its branch (1.); on the stress set both
together name every hanging state gravity-dominated
(``benchmarks/bistability.py --names``, record in
``benchmarks/results/robustness/labels_n100_seed1_hmax0.1.txt``).

Why a bistable pair gets two names: at a fold ``L*`` the S-curve is a
parabola in the state, ``L - L* ~ -(d - d*)^2``, so on the stable branch
ending at the pop-up length ``L0*`` (a minimum of ``L``) ``d'' -> -infinity``
with ``d' -> +infinity``: gravity-dominated (2.); on the one ending at the
standout length ``L1*`` (a maximum) ``d'' -> +infinity``, and the curvature
persists along the aloft sheet: curvature-dominated.  The names change
where the curvature first relaxes or the S-curve has its inflection (its
steepest point, the transition length the figures mark for sheets that are
not bistable, :func:`skfem_sheet.studies.foldmap.transition_length`); for a
bistable S-curve both lie on its unstable middle branch.  The name depends
on the state only: one state gets one name whichever load path reached it,
and the load path's history is kept apart (``Result.snaps``).

Two limits are named by what is missing: a flat clamp (``a/R = 0``) has no
transverse curvature to dominate -- gravity-dominated (as the figures have
it); a sheet without gravity (load factor 0) has no weight to dominate --
curvature-dominated.  A planform with bites has no single section to fit
across: only the S-curve's sign (2.) is read.

How ``d'`` and ``d''`` are computed: at the equilibrium ``R(w(L), L) = 0``
on the mesh stretched in L (the family of lengths of
:func:`~skfem_sheet.bistability.fold_lengths`), ``K w' = -R_L`` and
``K w'' = -D^2 R[(w', 1), (w', 1)]``, the second directional derivative of
the residual along the tangent ``(w', 1)`` in ``(w, L)`` (a central second
difference of three residuals on the stretched meshes); ``d' = T(w')`` and
``d'' = T(w'')`` with ``T`` the tip deflection (linear in the state).  Two
solves with the solve's factorisation refined against the tangent at the
state (one assembly), four residuals and one evaluation of the mid-surface
at 19 x 21 points: a few per cent of a solve.

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
