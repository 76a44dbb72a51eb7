"""What a solved state is: curvature-dominated or gravity-dominated, from the state itself.

The paper's two modes (its Fig. 3): in the *curvature-dominated* mode the
clamp's transverse curvature persists along the sheet and holds it aloft; in
the *gravity-dominated* mode the curvature relaxes near the base and the
sheet beyond it, flat, bends down under its weight.  Which one a sheet is in
is decided by where its state lies on its *S-curve*: the curve ``d(L)`` of
the equilibria of its planform, curvature and material as the length
varies (:mod:`skfem_sheet.bistability`).

The criterion: the bend of the S-curve at the state
---------------------------------------------------
Along the S-curve the sag first grows ever faster with the length -- the
curvature-held sheet is a stiff beam whose free part's weight and lever grow
together (the paper's cantilever estimate ``d ~ (L - L_p)^4``), or the tip
even rises as the curved sheet lengthens -- and then ever more slowly, as the
drooped sheet hangs from the relaxed region near the base (its slope
``dd/dL`` falling towards 1, each added length hanging almost straight down).
The transition between the two is the S-curve's inflection, the steepest
point of ``d(L)``; where the sheet is bistable, the S-curve turns back
between its folds and the whole unstable middle branch lies between the two
regimes.  So, at a state with slope ``d' = dd/dL`` and bend ``d'' =
d^2d/dL^2`` along its S-curve::

    gravity-dominated    if  d' > 0  and  d'' < 0   (the sag decelerating),
    curvature-dominated  otherwise                   (accelerating, or the tip rising).

Why a bistable pair always gets two names near its folds: at a fold ``L*``
the S-curve is a parabola in the state, ``L - L* ~ -(d - d*)^2``, so on the
stable branch ending at the standout length ``L1*`` (a maximum of ``L``)
``d'' -> +infinity`` and on the one ending at the pop-up length ``L0*`` (a
minimum) ``d'' -> -infinity`` (with ``d' -> +infinity`` on both): the
curvature-dominated branch is the one that ends at ``L1*``, the
gravity-dominated one the one that ends at ``L0*``, as the paper names them.
Near the cusp, where the bistable window closes, the whole window is near
its folds.  Where the sheet is not bistable, the name changes at the
inflection, the single transition length the figures mark
(:func:`skfem_sheet.studies.foldmap.transition_length`, the middle of the
steepest interval of a row's ``d(L)``).  The name depends on the state
only: one state gets one name whichever load path reached it, and the load
path's history is kept apart (``Result.snaps``).

Two limits are named by what is missing: a flat clamp (``a/R = 0``) has no
transverse curvature to dominate -- gravity-dominated (as the figures
have it); a sheet without gravity (load factor 0) has no weight to dominate
-- curvature-dominated.

How ``d'`` and ``d''`` are computed: at the equilibrium ``R(w(L), L) = 0``
on the mesh stretched in L (the family of lengths of
:func:`~skfem_sheet.bistability.fold_lengths`), ``K w' = -R_L`` and
``K w'' = -D^2 R[(w', 1), (w', 1)]``, the second directional derivative of
the residual along the tangent ``(w', 1)`` in ``(w, L)`` (a central second
difference of three residuals on the stretched meshes); ``d' = T(w')`` and
``d'' = T(w'')`` with ``T`` the tip deflection (linear in the state).  Two
back-substitutions with the solve's factorisation and four residuals: a
small fraction of one Newton iteration.

Examples
--------
>>> from skfem_sheet import Sheet, solve
>>> r = solve(Sheet(length=1.3, curvature=2.5), "gravity-first", hmax=0.2)
>>> m = mode_of(r.problem, r.w, 1.0)
>>> m.name, m.slope > 0 > m.bend
('gravity-dominated', True)
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..linalg import LinearSolverError, make_linear_solver
from ..params import ParameterError
from .observables import tip_deflection
from .sensitivity import parameter_derivatives, scaled_problem

__all__ = ["CURVATURE_DOMINATED", "GRAVITY_DOMINATED", "MODES", "Mode", "mode_of",
           "name_of_bend"]

CURVATURE_DOMINATED = "curvature-dominated"
GRAVITY_DOMINATED = "gravity-dominated"
#: The two names, in the order of the load paths that select them.
MODES = (CURVATURE_DOMINATED, GRAVITY_DOMINATED)

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
    reason : str
        In words: ``"the sag decelerates"``, ``"the sag accelerates"``,
        ``"the tip rises"``, ``"a flat clamp"``, ``"no gravity"``.
    """

    name: str
    slope: float = math.nan
    bend: float = math.nan
    reason: str = ""

    def to_json(self) -> dict:
        return {"name": self.name, "slope": self.slope, "bend": self.bend,
                "reason": self.reason}


def name_of_bend(slope: float, bend: float) -> str:
    """The name from the S-curve's slope and bend at a state (the criterion
    of the module docstring).

    Examples
    --------
    >>> name_of_bend(1.2, -0.3), name_of_bend(0.4, 2.0), name_of_bend(-0.1, -0.2)
    ('gravity-dominated', 'curvature-dominated', 'curvature-dominated')
    """
    return GRAVITY_DOMINATED if (slope > 0 and bend < 0) else CURVATURE_DOMINATED


def _solve(problem, w, B, linear):
    """``K(w)^-1 B`` with the factorisation ``linear`` holds (the solve's, at
    the state), or with a fresh one at ``w``."""
    if linear is not None:
        try:
            X = linear.solve(B)
        except (AttributeError, TypeError, ValueError, RuntimeError, LinearSolverError):
            X = None
        if X is not None and np.all(np.isfinite(X)):
            return np.asarray(X, dtype=float)
    solver = make_linear_solver("auto")
    solver.factorize(problem.tangent(w), w)
    return np.asarray(solver.solve(B), dtype=float)


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
        (the solve's); default: factorise it at ``w``.

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
    free = problem.free
    L = float(problem.length)
    # the tangent of the S-curve: K w' = -R_L (the clamp values do not depend on L)
    R_L, _, _ = parameter_derivatives(problem, w, gravity, ("length",))
    du = -_solve(problem, w, R_L, linear)[:, 0]
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
            raise ParameterError(f"the mode: the state inverts an element at L = {L + s * e:g}")
        r.append(rr[free])
    q = (r[2] - 2.0 * r[1] + r[0]) / e**2
    d2u = -_solve(problem, w, q[:, None], linear)[:, 0]
    dw2 = np.zeros_like(w)
    dw2[free] = d2u
    def along(x):
        # the tip deflection is piecewise linear in the state (its lowest nodes):
        # a step small against the state's own scale gives its derivative
        h = 1e-7 / max(1.0, float(np.abs(x).max()))
        return (tip_deflection(problem, w + h * x) - tip_deflection(problem, w - h * x)) / (2 * h)

    slope, bend = along(dw), along(dw2)
    name = name_of_bend(slope, bend)
    reason = ("the sag decelerates" if name == GRAVITY_DOMINATED
              else "the tip rises" if slope <= 0 else "the sag accelerates")
    return Mode(name, float(slope), float(bend), reason)
