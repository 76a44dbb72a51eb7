"""The whole S-curve d(L) by pseudo-arclength continuation through both folds
(:func:`s_curve`, :class:`SCurve`).
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ..engine import Tolerances, arclength
from ..engine.protocol import Counting
from ..newton import Stats
from ..params import DEFAULT_HMAX, ParameterError, Sheet, check_range
from ..sheet_shape import REMESH_STRETCH
from .branch import BranchPoint, Curve
from .follow import OPTIONS, branch_problem, check_common, stability_of


# ----------------------------------------------------------------------------
# pseudo-arclength continuation: the whole S-curve
# ----------------------------------------------------------------------------
@dataclass(frozen=True)
class SCurve(Curve):
    """The curve of equilibria d(L) traced by pseudo-arclength continuation.

    Attributes
    ----------
    points : tuple of skfem_sheet.bistability.branch.BranchPoint
        In arclength order (the length goes up, back at ``L1*``, up again after ``L0*``).
    folds : tuple of float
        Lengths of the turning points (where dL/ds changes sign), in order:
        located with the minimally augmented system where that converges
        (:func:`skfem_sheet.engine.arclength` with ``locate``), else the
        vertex of the parabola ``L(s)`` through the three points around the
        sign change (``located`` says which).
    located : tuple of bool
        Per fold: located by the fold system (True) or the parabola (False).
    """

    points: tuple
    folds: tuple
    converged: bool
    message: str = ""
    newton_iterations: int = 0
    wall_time_s: float = 0.0
    located: tuple = ()

    def summary(self) -> dict:
        return {"lengths": self.lengths.tolist(), "deflection": self.deflections.tolist(),
                "stable": self.stable, "folds": list(self.folds),
                "located": list(self.located),
                "converged": self.converged, "message": self.message,
                "newton_iterations": self.newton_iterations, "wall_time_s": self.wall_time_s}


def s_curve(sheet: Sheet, stop: float, *, hmax: float = DEFAULT_HMAX, layers=None,
            solver: str = "auto",
            symmetric: bool = True, ds: float = 0.05, ds_max: float = 0.15, max_points: int = 200,
            progress=None, on_point=None) -> SCurve:
    """Pseudo-arclength continuation in L from the curvature-dominated state
    at ``sheet.length`` until the length exceeds ``stop`` (on whatever branch).

    The engine's :func:`skfem_sheet.engine.arclength` on ``(w, L)``, with the
    inner product ``<a, b> = a_tip b_tip + theta a . b`` (the tip's vertical
    displacement, so that steps are even along the plotted d(L), plus the mean
    square of the displacements; pressures left out).  Turning points are
    located with the minimally augmented system where ``t_L`` changes sign,
    else taken at the vertex of the parabola ``L(s)`` (``SCurve.located``).  One
    mesh, stretched, serves the whole curve: ``sheet.length`` and ``stop`` must
    be within a factor 1.8 of each other.  ``on_point(problem, w, L)`` as in
    :func:`follow_length`.
    """
    check_common(sheet, hmax, 0.5)
    stop = check_range("stop", stop, sheet.length, 20.0, lo_open=True)
    if stop / sheet.length > REMESH_STRETCH**2:
        raise ParameterError(f"stop must be at most {REMESH_STRETCH**2:.2f} times the start length "
                             f"({sheet.length:g}) for one stretched mesh, got {stop:g}")
    t0 = time.perf_counter()
    stats = Stats()
    mid = np.sqrt(sheet.length * stop)
    P = branch_problem(sheet.replace(length=mid), "L", hmax, layers, solver, symmetric)
    counter = Counting(P)
    p0 = np.array([sheet.length])
    out = P.along_path(p0, "curvature-first", stats)
    if not out.converged:
        raise ParameterError(f"the starting sheet could not be solved: {out.reason}")
    points, s_hist, tL_hist = [], [], []

    def on_step(pt, res):
        st, k = stability_of(res.factorization)
        L = float(pt.p[0])
        points.append(BranchPoint(L, P.deflection(pt.u, pt.p), st, k,
                                  res.iterations if points else 0))
        s_hist.append(pt.s)
        tL_hist.append(pt.tangent_p)
        if on_point is not None:
            on_point(P.problem(pt.p), P.full(pt.u, pt.p), L)

    u0 = out.w[P.free]
    b = arclength(counter, u0, p0, 0, (0.0, stop), ds=ds, ds_min=min(1e-3, ds),
                  ds_max=max(ds_max, ds), tol=_ARCLENGTH_TOLERANCES, max_points=max_points,
                  locate=True,
                  keep_states=False, progress=progress, on_step=on_step,
                  start=(u0, P.held(u0, p0)))
    message = "" if b.completed else b.reason
    turns = _turning_points(np.array(s_hist), np.array(tL_hist), points)
    # each turning point by the fold system where it located one next to it
    exact = [float(f.value) for f in b.folds]
    folds, located = [], []
    for x in turns:
        near = [f for f in exact if abs(f - x) <= 0.05]
        folds.append(near[0] if near else x)
        located.append(bool(near))
    return SCurve(tuple(points), tuple(folds), b.completed, message,
                  stats.newton_iterations + b.stats.factorizations, time.perf_counter() - t0,
                  tuple(located))


#: The S-curve's corrector: the sheet's tolerances, a full Newton step at every
#: iterate of the bordered system, no first correction beyond 0.5 a.
_ARCLENGTH_TOLERANCES = Tolerances(rtol=OPTIONS.rtol, utol=OPTIONS.utol,
                                   max_iterations=OPTIONS.max_iterations,
                                   max_halvings=OPTIONS.max_halvings, max_correction=0.5)


def _turning_points(s, tL, points):
    """Lengths where ``dL/ds`` changes sign: vertex of the parabola through
    the three points around the sign change."""
    L = np.array([p.length for p in points])
    folds = []
    for i in range(1, len(tL)):
        if np.sign(tL[i]) != np.sign(tL[i - 1]):
            j = min(max(i - 1, 1), len(L) - 2)  # centre of a 3-point stencil
            c = np.polyfit(s[j - 1:j + 2], L[j - 1:j + 2], 2)
            sv = -c[1] / (2 * c[0]) if c[0] != 0 else s[j]
            folds.append(float(np.polyval(c, np.clip(sv, s[j - 1], s[j + 1]))))
    return folds
