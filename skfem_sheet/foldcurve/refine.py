"""Coarse to fine: a fold curve traced on a coarse mesh, a few of its points corrected on finer ones.

The curve is traced on the coarse mesh (:func:`~skfem_sheet.foldcurve.trace.trace`,
every point kept, :class:`Collector`), and a few of its points (both ends,
points spaced evenly in the parameter plane, the neighbours of the cusp:
:func:`select`) are carried onto the finer mesh (state and null vector) and
corrected there with the minimally augmented system (:func:`refine`) -- the
ends as folds in L at the start value, the others on the hyperplane through
the coarse point normal to the coarse curve -- level by level.  A carried
state outside Newton's basin of the fold system is settled first as an
equilibrium, and on the next level too (:func:`settled_fold`).  An end that
does not converge on the finer mesh is traced there instead
(:func:`continue_to_end`).  :func:`run` is the whole of it, and the cusp on
the fine mesh (:mod:`~skfem_sheet.foldcurve.cusp`).
"""
from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field

import numpy as np

from ..engine import fold_curve, fold_on_section, locate_fold
from ..engine.fold import FoldPoint, equilibrium_on_section, inertia_crossing
from ..params import ParameterError, check_range
from ..sheet_shape import REMESH_STRETCH, SheetFoldProblem
from .cusp import cusp_by_coefficient, fine_cusp
from .options import (
    FINE_TOLERANCES,
    MESH_LENGTH_GRID,
    PREDICTOR,
    REFILL_DS,
    SECOND,
    SETTLE_STEP,
    TARGET_CORRECTION,
    FoldCurveOptions,
    kind,
)
from .result import FoldCurve
from .series import SeriesCollector, add_frame
from .trace import trace

__all__ = ["Collector", "FineMeshes", "KeptPoint", "RefinedPoint", "continue_to_end",
           "fold_from", "neighbours", "refine", "run", "select", "settled_fold"]


@dataclass(frozen=True)
class KeptPoint:
    """A fold-curve point on one mesh with what refining it needs: its
    problem, parameters, state and null vector, fold coefficient, side and
    tip deflection; ``settle``: its state, carried from the coarser mesh it
    was refined from, lay outside Newton's basin of the fold system there
    and was settled first (:func:`refine` then settles it first on the next
    mesh too).

    Examples
    --------
    >>> q = KeptPoint(None, np.array([1.3, 0.8]), np.zeros(3), np.ones(3), 0.1, -1, 0.05)
    >>> q.side, q.tip, q.settle
    (-1, 0.05, False)
    """

    problem: object = field(repr=False)
    p: np.ndarray
    u: np.ndarray = field(repr=False)
    v: np.ndarray = field(repr=False)
    a: float
    side: int
    tip: float
    settle: bool = False


@dataclass(frozen=True)
class RefinedPoint:
    """A fold-curve point corrected on a finer mesh (or traced there, ``refill``).

    Attributes
    ----------
    p : ndarray
        ``(L, b)`` or ``(L, b, a/R)`` of the fold.
    a : float
        Its fold coefficient.
    side : int
        The side its branch exists on (-1 standout, +1 pop-up).
    tip : float
        Tip deflection of its state.
    negative : int or None
        Negative eigenvalues besides the critical one.
    crossing : tuple or None
        Negative eigenvalue counts on both sides along the null vector (where checked).
    iterations, factorizations : int
        Of its correction (factorisations also of the failed tries it needed).
    end : bool
        An end of the curve (a fold in L at the start value).
    refill : bool
        Traced on the fine mesh (:func:`continue_to_end`) rather than refined.
    kept : KeptPoint or None
        The fold on the finer mesh, to refine further (None once dropped).

    Examples
    --------
    >>> q = RefinedPoint(np.array([1.3, 1.0]), 0.1, -1, 0.05, 0, None, 3, 4, True)
    >>> q.end, q.refill, q.without_state().kept
    (True, False, None)
    """

    p: np.ndarray
    a: float
    side: int
    tip: float
    negative: object
    crossing: object
    iterations: int
    factorizations: int
    end: bool
    refill: bool = False
    kept: KeptPoint | None = field(default=None, repr=False)

    def without_state(self) -> RefinedPoint:
        """The record without its fold on the mesh (its state, null vector and problem)."""
        return dataclasses.replace(self, kept=None)


class Collector:
    """Keeps every point of a coarse trace (states at the coarse mesh: small)."""

    def __init__(self):
        self.points = []

    def __call__(self, P, pt, u, v):
        self.points.append(KeptPoint(P, np.array(pt.p, dtype=float), np.array(u, dtype=float),
                                 np.array(v, dtype=float), float(pt.a), int(pt.side),
                                 float(u[P.tip_index])))


def select(kept, n_points):
    """Indices of the coarse points to refine: both ends, ``n_points``
    spaced evenly in the plane of the two parameters (L/a and the second
    parameter, each relative to its range on the curve), and the two points
    around the sign change of the fold coefficient with their neighbours
    (the cusp: there the curve hardly moves in the plane)."""
    P = np.array([k.p for k in kept])
    q = (P - P.min(axis=0)) / np.maximum(np.ptp(P, axis=0), 1e-12)
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(q, axis=0), axis=1))])
    chosen = {0, len(kept) - 1}
    for target in np.linspace(0.0, s[-1], max(2, n_points)):
        chosen.add(int(np.argmin(np.abs(s - target))))
    a = np.array([k.a for k in kept])
    change = np.flatnonzero(np.sign(a[1:]) * np.sign(a[:-1]) < 0)
    if len(change):
        c = int(change[0])
        chosen.update(k for k in range(c - 1, c + 3) if 0 <= k < len(kept))
    # one point per tip deflection (a remesh repeats the point where it happens)
    out = []
    for k in sorted(chosen):
        if not out or abs(kept[k].tip - kept[out[-1]].tip) > 1e-9:
            out.append(k)
    return out


class FineMeshes:
    """Fine problems of a refinement, one mesh per band of lengths (remeshed
    beyond :data:`REMESH_STRETCH`), each holding one factorisation."""

    def __init__(self, curvature, hmax, tip_width, kw):
        self.curvature, self.hmax, self.tip_width, self.kw = curvature, hmax, tip_width, kw
        self.meshes = []

    def for_length(self, L, band):
        for P in self.meshes:
            L_m = P.mesh_parameters[0]
            if L_m / REMESH_STRETCH <= L <= L_m * REMESH_STRETCH:
                return P
        # the median of the band, within 20% of L, on the grid
        L_m = float(np.clip(np.median(band), L / 1.2, L * 1.2))
        L_m = max(MESH_LENGTH_GRID, round(L_m / MESH_LENGTH_GRID) * MESH_LENGTH_GRID)
        P = SheetFoldProblem(self.curvature, self.hmax, mesh_length=L_m,
                             mesh_tip_width=self.tip_width, solver_slots=1, cache=4, **self.kw)
        self.meshes.append(P)
        return P


def refine(kept, chosen, j, make_fine, tol, check_inertia, last_is_end=True, ends=None):
    """The fold curve on the fine meshes from the coarse points ``kept[chosen]``.

    Each chosen coarse point is carried onto a fine mesh (state and null
    vector, :meth:`SheetFoldProblem.transferred`) and corrected there with
    the minimally augmented system: the two ends, at the start value of the
    second parameter, as folds in L (:func:`~skfem_sheet.engine.locate_fold`);
    the others on the hyperplane through the coarse point normal to the
    coarse curve's secant there (:func:`~skfem_sheet.engine.fold_on_section`,
    L and the second parameter free), which is transversal to the curve also
    at the cusp, where neither parameter parametrises it.  Returns
    ``(points, failures, spent)``: the :class:`RefinedPoint` of each
    point refined (with the fine point as a :class:`KeptPoint`, ``kept``,
    to refine further), in the order of the coarse curve;
    ``spent``: the factorisations of the points that failed.  ``ends``:
    the positions in ``chosen`` of the ends (default: the first, and the
    last if ``last_is_end``); an end that comes out as the other kind of
    fold (the pop-up fold found from a standout one) counts as failed."""
    name = SECOND[j][0]
    band = [kept[k].p[0] for k in chosen]
    out, failures, spent = [], [], 0
    for n, k in enumerate(chosen):
        c = kept[k]
        Pf = make_fine.for_length(float(c.p[0]), band)
        f0 = Pf.refactorizations
        u = c.problem.transferred(Pf, c.u, c.p)
        v = c.problem.transferred(Pf, c.v, c.p, state=False)
        end = (n == 0 or (last_is_end and n == len(chosen) - 1)) if ends is None else n in ends
        section = None
        if not end:
            lo, hi = neighbours(kept, k)
            t_u = c.problem.transferred(Pf, kept[hi].u - kept[lo].u, c.p, state=False)
            t_p = kept[hi].p - kept[lo].p
            section = (t_u, t_p, Pf.inner(t_u, u) + float(t_p @ c.p))
        fold, res, lost, settled = settled_fold(Pf, section, name, u, c.p, v, tol, c.settle)
        if fold is not None and end and int(fold.side) != c.side:
            lost += fold.stats.factorizations
            fold, res = None, dataclasses.replace(res, reason="the other kind of fold")
        if fold is None:
            failures.append(f"{name} = {c.p[j]:.4f}, L/a = {c.p[0]:.4f}: {res.reason}")
            spent += lost + Pf.refactorizations - f0
            continue
        crossing, extra = None, 0
        if check_inertia and (end or n % int(check_inertia) == 0):
            crossing, extra = inertia_crossing(Pf, fold.u, fold.p, fold.v, 1e-4), 2
        tip = float(fold.u[Pf.tip_index])
        out.append(RefinedPoint(
            np.array(fold.p), float(fold.a), int(fold.side), tip, fold.negative_eigenvalues,
            crossing, int(res.iterations),
            int(fold.stats.factorizations + extra + lost + Pf.refactorizations - f0), end,
            refill=False, kept=KeptPoint(Pf, np.array(fold.p), fold.u, fold.v, float(fold.a),
                                         int(fold.side), tip, settle=settled)))
    return out, failures, spent


def settled_fold(P, section, name, u, p, v, tol, settle_first=False):
    """The fold from a state carried onto ``P``: located from it directly
    (:func:`fold_from`), and if that fails (the state outside Newton's
    basin of the fold system) from the state settled first by one Newton
    step of the equilibrium on the section of its null vector ``v`` (L
    free, :func:`~skfem_sheet.engine.fold.equilibrium_on_section`,
    :data:`~skfem_sheet.foldcurve.options.SETTLE_STEP`: it is the
    carried state's membrane stress in the tangent that the fold system
    cannot start from, and one step removes it).  With
    ``settle_first`` (the point needed settling on the coarser mesh it
    comes from) the two are tried the other way round: the carried state's
    distance to the fold comes from the difference of two meshes, of one
    order from one level to the next, so a point that left the basin on one
    level leaves it on the next too.
    Returns ``(fold or None, result, factorisations of the failed tries,
    settled)``: ``settled`` whether the fold was located from the settled
    state; without a fold, ``result`` is the last try's (all tries failed).

    Examples
    --------
    The fold ``lam = 2 / (3 sqrt 3)`` of ``u^3 - u + lam = 0`` from a
    state near it, directly and settled first:

    >>> from skfem_sheet.engine import FunctionProblem
    >>> P = FunctionProblem(lambda u, p: u**3 - u + p[0],
    ...                     lambda u, p: np.diag(3 * u**2 - 1), ("L",))
    >>> u, p, v = np.array([0.6]), np.array([0.38]), np.ones(1)
    >>> [(round(float(f.p[0]), 9), settled) for f, _, _, settled in
    ...  (settled_fold(P, None, "L", u, p, v, FINE_TOLERANCES, first) for first in (False, True))]
    [(0.384900179, False), (0.384900179, True)]
    """
    lost = 0
    for settle in ((True, False) if settle_first else (False, True)):
        if settle:
            start = equilibrium_on_section(P, u, p, "L", (v, np.zeros_like(p), P.inner(v, u)),
                                           tol=SETTLE_STEP)
            lost += start.stats.factorizations
            if not start.converged:
                res = start
                continue
            fold, res = fold_from(P, section, name, start.u, start.p, v, tol)
        else:
            fold, res = fold_from(P, section, name, u, p, v, tol)
        if fold is not None:
            return fold, res, lost, settle
        lost += res.stats.factorizations
    return None, res, lost, False


def continue_to_end(pts, last, want, j, bounds_j, length_range, tol, check_inertia):
    """An end of a refined curve that could not be refined, traced on the fine
    mesh instead: the fold curve continued there
    (:func:`skfem_sheet.engine.fold_curve`) from the refined point next to
    it (``last``: the last end, else the first) to the start value of the
    second parameter, away from the cusp if that point is of the end's kind
    (``want``: its side) and through the cusp otherwise.

    A fallback for a curve whose coarse ends lie outside the fine fold
    system's basin (at a/R = 1 the two folds at b = 1 are 0.0013 apart in
    L/a while the fine folds lie 0.01 lower than the coarse ones).  Returns
    ``(points, lost, reason)``: the new points in the order of the curve
    (the end included, flagged ``end``; the start point left out), as the
    :class:`RefinedPoint` of :func:`refine`, and the factorisations not
    counted in their ``factorizations``; or ``([], factorisations, reason)``.
    """
    name = SECOND[j][0]
    K = (pts[-1] if last else pts[0]).kept
    P = K.problem
    f0 = P.refactorizations
    start = FoldPoint(K.u, np.array(K.p), K.v, 0.0, K.a, K.side, 0)
    seen = []
    box = P.remesh_box(j, length_range, bounds_j)
    c = fold_curve(P, start, ("L", name), box, ds=REFILL_DS[0], ds_min=1e-4, ds_max=REFILL_DS[1],
                   direction=1 if K.side == want else -1, tol=tol, cusp_tol=1e-4,
                   check_inertia=0, easy_iterations=3, predictor=PREDICTOR,
                   target_correction=TARGET_CORRECTION, max_points=60, keep_states=True,
                   on_point=lambda pt, u, v: seen.append((np.array(u), np.array(v))))
    total = c.stats.factorizations + P.refactorizations - f0
    end = c.points[-1] if c.points else None
    if not (c.completed and end is not None and abs(end.p[j] - bounds_j[1]) < 1e-9
            and end.side == want):
        return [], total, (f"continued on the fine mesh to {name} = {bounds_j[1]:g}: "
                           f"{c.reason or 'ended elsewhere'}")
    out = []
    for n, (pt, (u, v)) in enumerate(zip(c.points[1:], seen[1:]), start=1):
        is_end = n == len(c.points) - 1
        crossing, extra = None, 0
        if check_inertia and is_end:
            f1 = P.refactorizations
            crossing = inertia_crossing(P, u, pt.p, v, 1e-4)
            extra = 2 + P.refactorizations - f1
        tip = float(u[P.tip_index])
        out.append(RefinedPoint(
            np.array(pt.p), float(pt.a), int(pt.side), tip, pt.negative_eigenvalues, crossing,
            int(pt.iterations), int(pt.factorizations + extra), is_end, refill=not is_end,
            kept=KeptPoint(P, np.array(pt.p), u, v, float(pt.a), int(pt.side), tip)))
    lost = total - sum(pt.factorizations for pt in c.points[1:])
    if not last:
        out.reverse()
    return out, lost, ""


def fold_from(P, section, name, u, p, v, tol):
    """The fold in L at fixed ``p`` (``section`` None), or on ``section``."""
    if section is None:
        return locate_fold(P, u, p, "L", v0=v, tol=tol)
    return fold_on_section(P, u, p, ("L", name), section, v0=v, tol=tol)


def neighbours(kept, k):
    """The points around ``k`` on the same coarse mesh (for a secant)."""
    lo = k - 1 if k > 0 and kept[k - 1].problem is kept[k].problem else k
    hi = k + 1 if k + 1 < len(kept) and kept[k + 1].problem is kept[k].problem else k
    if lo == hi:
        raise ParameterError("a coarse fold-curve point without a neighbour on its mesh")
    return lo, hi


def run(curvature, tip_width, j, bounds_j, options: FoldCurveOptions, series=None):
    """A fold curve traced at ``options.hmax``, or coarse to fine (see
    :func:`~skfem_sheet.foldcurve.trace_fold_curve`): the curve in ``(L,
    p_j)`` of the sheet ``(tip_width, curvature)``, from the start value
    ``bounds_j[1]`` of ``p_j`` down to at most ``bounds_j[0]`` and back."""
    hmax = check_range("hmax", options.hmax, 0.02, 0.5)
    coarse_hmax, fine_points = options.coarse_hmax, options.fine_points
    check_inertia = options.check_inertia
    coarse_levels = []
    if coarse_hmax is not None:
        values = np.atleast_1d(np.asarray(coarse_hmax, dtype=object))
        if not 1 <= len(values) <= 4:
            raise ParameterError(f"coarse_hmax must be a mesh size or up to four, got "
                                 f"{coarse_hmax!r}")
        coarse_levels = sorted((check_range("coarse_hmax", x, 0.02, 0.5) for x in values),
                               reverse=True)
        coarse_hmax = coarse_levels[0]
    if coarse_hmax is None or coarse_hmax <= hmax:
        collect = None if series is None else SeriesCollector(series)
        return trace(curvature, tip_width, j, bounds_j, dataclasses.replace(options, hmax=hmax),
                     collect=collect)
    if isinstance(fine_points, bool) or not isinstance(fine_points, (int, np.integer)) \
            or not 2 <= fine_points <= 200:
        raise ParameterError(f"fine_points must be an integer in [2, 200], got {fine_points!r}")
    t0 = time.perf_counter()
    kept = Collector()
    coarse = trace(curvature, tip_width, j, bounds_j,
                   dataclasses.replace(options, hmax=coarse_hmax, check_inertia=0), collect=kept,
                   seeds=True)
    info = dict(hmax=hmax, coarse_hmax=coarse_hmax, coarse_points=len(coarse.points),
                coarse_factorizations=coarse.factorizations)
    if not coarse.bistable or len(kept.points) < 2:
        return dataclasses.replace(coarse, **info, wall_time_s=time.perf_counter() - t0,
                                   reason=f"{coarse.reason} (at the coarse mesh, "
                                          f"hmax {coarse_hmax:g})".strip())
    name, key = SECOND[j]
    levels = [h for h in sorted(set(coarse_levels[1:]), reverse=True) if h > hmax] + [hmax]
    # the last point is a fold in L at the start value only if the coarse curve came back
    points, chosen = kept.points, select(kept.points, fine_points)
    sides = (kept.points[0].side, kept.points[-1].side)  # the kinds of the two ends
    stages, failures, meshes, spent, ends = [], [], 0, 0, None
    for h in levels:
        fine = FineMeshes(curvature, h, 1.0 if j == 1 else tip_width, options.mesh_keywords)
        ci = check_inertia if h == hmax else 0
        pts, failed, lost = refine(points, chosen, j, fine, FINE_TOLERANCES, ci,
                                    last_is_end=coarse.completed, ends=ends)
        # an end not refined (outside the fine fold system's basin): the curve
        # continued on this mesh from the refined point next to it instead
        refilled = 0
        for last in ((False, True) if coarse.completed else (False,)):
            if len(pts) < 2 or (pts[-1] if last else pts[0]).end:
                continue
            new, extra, why = continue_to_end(pts, last, sides[int(last)], j, bounds_j,
                                              options.length_range, FINE_TOLERANCES, ci)
            lost += extra
            refilled += len(new)
            if new:
                pts = pts + new if last else new + pts
            else:
                failed.append(why)
        failures += [f"hmax {h:g}: {f}" for f in failed]
        spent += lost
        meshes += len(fine.meshes)
        per = [q.factorizations for q in pts]
        stages.append(dict(hmax=h, points=len(pts), failed=len(failed), refilled=refilled,
                           settled=sum(q.kept.settle for q in pts),
                           factorizations=int(sum(per)) + lost,
                           factorizations_per_point=float(np.median(per)) if per else None))
        for P in {id(q.problem): q.problem for q in points}.values():
            P.release()  # the coarser level's factorisations and mapped meshes
        # the next level refines this one's points except those of a
        # continuation (they serve as neighbours; its end is refined)
        points = [q.kept for q in pts]
        pts = [q.without_state() for q in pts]
        chosen = [k for k, q in enumerate(pts) if not q.refill or h == hmax]
        ends = {n for n, k in enumerate(chosen) if pts[k].end}
        if len(points) < 2:
            break
    del kept
    if series is not None:
        for q in points:
            add_frame(series, q.problem, q.u, q.p)
    cusp, located, cusp_cost = None, "", 0
    if stages[-1]["hmax"] == hmax and len(points) == len(pts):
        cusp, cusp_cost = cusp_by_coefficient(points, j, FINE_TOLERANCES)
        located = "fold coefficient on the fine mesh" if cusp is not None else ""
    del points
    # complete: both ends refined at hmax (a point lost on the way only thins the curve)
    completed = coarse.completed and len(pts) >= 2 and pts[0].end and pts[-1].end
    reason = "; ".join(failures) if failures else coarse.reason
    if failures:
        reason = f"{len(failures)} point(s) not refined: {reason}"
    out_points = tuple({key: float(q.p[j]), "length": float(q.p[0]), "kind": kind(q.side)}
                       for q in pts)
    if pts and pts[0].end:  # the ends lie on the start value exactly
        out_points[0][key] = float(bounds_j[1])
        if completed:
            out_points[-1][key] = float(bounds_j[1])
    if cusp is None:
        cusp = fine_cusp(pts, j)
        located = "refined points" if cusp is not None else ""
    per_point = [q.factorizations for q in pts]
    total = (coarse.factorizations + int(sum(st["factorizations"] for st in stages))
             + cusp_cost)
    return FoldCurve(curvature, out_points, cusp, int(total),
                     float(np.median(per_point)) if per_point else float("nan"),
                     time.perf_counter() - t0, hmax, completed, reason,
                     tuple(q.negative for q in pts), tuple(q.crossing for q in pts),
                     None, key, tip_width, remeshes=coarse.remeshes + len(fine.meshes),
                     meshes=coarse.meshes + tuple(P.mesh_parameters for P in fine.meshes),
                     cusp_located=located, cusp_factorizations=cusp_cost,
                     coarse_hmax=coarse_hmax, coarse_points=len(coarse.points),
                     coarse_factorizations=coarse.factorizations, stages=tuple(stages))
