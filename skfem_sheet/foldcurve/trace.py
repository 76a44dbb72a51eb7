"""The direct trace of a fold curve on the sheet's own mesh (remeshed on the way).

The fold is located once at the start value of the second parameter by
natural continuation in L (:func:`standout_fold`), then continued in ``(L,
b)`` or ``(L, a/R)`` with the minimally augmented system
(:func:`skfem_sheet.engine.fold_curve`) inside the box one mesh serves
(:meth:`~skfem_sheet.sheet_shape.SheetShapeProblem.remesh_box`); at the
box's edge the sheet is meshed afresh there, the fold point and its null
vector carried over, and the curve continues (:func:`trace`).
"""
from __future__ import annotations

import dataclasses
import sys
import time

import numpy as np
from tqdm.auto import tqdm

from ..engine import EngineFailure, fold_curve, locate_fold, natural
from ..engine import FoldCurve as EngineFoldCurve
from ..engine.fold import equilibrium_on_section
from ..params import ParameterError, check_range
from ..sheet_shape import REMESH_STRETCH, TOLERANCES, SheetFoldProblem
from .cusp import turning_point
from .options import (
    MAX_REMESHES,
    PREDICTOR,
    SECOND,
    SEED_TOLERANCES,
    TARGET_CORRECTION,
    FoldCurveOptions,
    default_start_length,
    kind,
)
from .result import FoldCurve

__all__ = ["MeshMaker", "Progress", "as_fold_in_L", "fold_near", "standout_fold", "trace"]


class Progress:
    """The tqdm bar of a trace (on stderr): the way travelled in the second
    parameter ``p_j``, out of the whole way from its start down to the lowest
    value it may reach and back (``2 (start - low)``); once the curve has
    turned (past the cusp, on the pop-up side) the rest of the way is known,
    back up to the start, and the total becomes exact."""

    def __init__(self, enabled, j=1, name="b", start=1.0, low=0.0):
        self.j, self.name = j, name
        self.start, self.last, self.travelled, self.turned = start, start, 0.0, False
        self.bar = None
        if enabled:
            self.bar = tqdm(desc="fold curve", total=round(2.0 * max(start - low, 1e-9), 6),
                            file=sys.stderr, bar_format="{desc}: {percentage:3.0f}%|{bar}| "
                            "[{elapsed}<{remaining}{postfix}]")

    def __call__(self, pt):
        if self.bar is None:
            return
        value = float(pt.p[self.j])
        self.travelled += abs(value - self.last)
        self.last = value
        if not self.turned and kind(pt.side) == "popup":
            self.turned = True
            self.bar.total = round(self.travelled + max(self.start - value, 0.0), 6)
        self.bar.n = round(min(self.travelled, self.bar.total), 6)
        self.bar.set_postfix_str(f"{self.name} = {value:.4f}, L/a = {pt.p[0]:.4f}, "
                                 f"{kind(pt.side)}", refresh=True)

    def close(self):
        if self.bar is not None:
            self.bar.close()


class MeshMaker:
    """Fresh fold problems of one trace (same sheet and discretisation, another mesh)."""

    def __init__(self, curvature, hmax, kw):
        self.args = (curvature, hmax)
        self.kw = dict(kw)
        self.count = 0
        self.made = []  # (L_m, b_m) of each mesh made

    def __call__(self, mesh_length, mesh_tip_width):
        self.count += 1
        P = SheetFoldProblem(*self.args, mesh_length=mesh_length,
                             mesh_tip_width=min(1.0, mesh_tip_width), **self.kw)
        self.made.append(P.mesh_parameters)
        return P

    def remesh(self, P, u, p, v=None):
        """A problem on a fresh mesh at ``p``'s (L, b), with ``u`` (and ``v``) on it."""
        Q = self(float(p[0]), float(p[1]))
        return (Q, P.transferred(Q, u, p),
                None if v is None else P.transferred(Q, v, p, state=False))


def standout_fold(make, P, u, p, hi, tol):
    """Natural continuation in L from ``(u, p)`` to the first fold, remeshing
    every :data:`REMESH_STRETCH`; where Newton fails short of the fold without
    locating it, the fold is located from the last point, or (twice at most)
    the continuation goes on from there on a fresh mesh.  Returns ``(P, fold or None, factorisations,
    reason)``; ``reason`` is ``""`` when the branch reached ``hi`` without a fold."""
    # a step past the fold is given up once a correction outgrows the one
    # two linearisations before (the rows' continuation in L does the same,
    # ``Tolerances.pair_contraction``): a step that cannot converge stops
    # early instead of using its whole budget
    steps = dataclasses.replace(tol, pair_contraction=True)
    nfact, retries = 0, 0
    for _ in range(MAX_REMESHES + 1):
        stop = min(hi, P.mesh_parameters[0] * REMESH_STRETCH)
        branch = natural(P, u, p, "L", stop, step=0.05, min_step=1e-3, tol=steps, jump=0.1,
                         keep_states=False)
        nfact += branch.stats.factorizations
        if branch.fold is not None:
            return P, branch.fold, nfact, f"fold: {branch.reason}"
        if not branch.completed:
            if not branch.points or retries >= 2:
                return P, None, nfact, branch.reason or "natural continuation in L failed"
            # Newton failed short of the fold without locating it: locate it
            # from the last point directly, else go on from there on a fresh mesh
            last = branch.points[-1]
            fold, res = locate_fold(P, last.u, last.p, "L", tol=tol)
            nfact += res.iterations
            if (fold is not None and fold.side < 0
                    and -1e-3 <= fold.value - last.p[0] <= 0.1):
                return P, fold, nfact, f"fold located from the last point ({branch.reason})"
            retries += 1
            P, u, _ = make.remesh(P, last.u, last.p)
            p = last.p
            # on the fresh mesh the fold may lie just below the last point
            # (no equilibrium there to continue from): locate it directly
            # from the carried state, settled on the section of the branch
            # direction if the fold system does not converge from it
            fold, lost = fold_near(P, u, p, tol)
            nfact += lost
            if (fold is not None and fold.side < 0
                    and -0.1 <= fold.value - last.p[0] <= 0.1):
                return P, fold, nfact, f"fold located on a fresh mesh ({branch.reason})"
            continue
        last = branch.points[-1]
        if stop >= hi - 1e-12:
            return P, None, nfact, ""
        P, u, _ = make.remesh(P, last.u, last.p)
        p = last.p
    return P, None, nfact, f"more than {MAX_REMESHES} remeshes"


def fold_near(P, u, p, tol):
    """A fold in L near ``(u, p)``: from there, or from the equilibrium on
    the section of ``du/dL`` through it.  Returns ``(fold or None,
    factorisations)``."""
    fold, res = locate_fold(P, u, p, "L", tol=tol)
    lost = res.stats.factorizations
    if fold is not None:
        return fold, lost
    try:
        fact = P.factorize(P.jacobian(u, p))
        d = fact.solve(-P.dresidual(u, p, 0))
        lost += 1
    except EngineFailure:  # a singular tangent: no direction to settle along
        return None, lost
    settled = equilibrium_on_section(P, u, p, "L", (d, np.zeros_like(p), P.inner(d, u)),
                                     tol=tol)
    lost += settled.stats.factorizations
    if not settled.converged:
        return None, lost
    fold, res = locate_fold(P, settled.u, settled.p, "L", v0=d, tol=tol)
    return fold, lost + res.stats.factorizations


def as_fold_in_L(P, fold, tol):
    """A fold located in the second parameter, located again in L from there
    (fold_curve starts from a fold in L); None if that fails."""
    again, _ = locate_fold(P, fold.u, fold.p, "L", v0=fold.v, tol=tol)
    return again


def _strip(pt):
    """A fold-curve point without its state (memory)."""
    return dataclasses.replace(pt, u=None)


def trace(curvature, tip_width, j, bounds_j, options: FoldCurveOptions, collect=None,
          seeds=False):
    """Standout fold at ``(tip_width, curvature)``, then its fold curve in
    ``(L, p_j)`` from the start value of ``p_j`` (``bounds_j[1]``) downward
    and back, remeshing on the way (:func:`~skfem_sheet.foldcurve.trace_fold_curve`).

    ``collect(P, point, u, v)``, if given, sees every point of the curve
    with its problem, state and null vector (and ``collect.drop_last()``,
    if it has one, is called where a remesh repeats a point).

    ``seeds``: the curve's points only seed a refinement on finer meshes
    (coarse to fine, :func:`~skfem_sheet.foldcurve.refine.run`), where each
    is corrected again and the cusp is located.  Newton then stops on its
    own error estimate (:data:`SEED_TOLERANCES`) and the cusp is not
    located on the way (the curve's cusp is the turn of ``p_j``).
    """
    o = options
    hmax = check_range("hmax", o.hmax, 0.02, 0.5)
    start_length, length_range, mesh_length = o.start_length, o.length_range, o.mesh_length
    ds, ds_max, check_inertia, max_points = o.ds, o.ds_max, o.check_inertia, o.max_points
    lo, hi = (check_range("length_range", float(x), 0.05, 20.0) for x in length_range)
    if start_length is None:
        start_length = min(max(default_start_length(curvature), lo + 0.02 * (hi - lo)),
                           0.5 * (lo + hi))
    if not lo < start_length < hi:
        raise ParameterError(f"start_length must be inside length_range {length_range!r}, "
                             f"got {start_length!r}")
    t0 = time.perf_counter()
    make = MeshMaker(curvature, hmax, o.mesh_keywords)
    P = make(mesh_length or 1.08 * start_length, tip_width)
    tol = SEED_TOLERANCES if seeds else TOLERANCES
    p0 = np.array([start_length, tip_width, curvature])
    u0, f_start = P.solve_state(p0, "curvature-first")
    P, fold, f_branch, why = standout_fold(make, P, u0, p0, hi, tol)
    name, key = SECOND[j]
    where = f"b/a = {tip_width:g}, a/R = {curvature:g}"
    if fold is None:
        total = f_start + f_branch
        if not why:
            return FoldCurve(curvature, (), None, int(total), float("nan"),
                             time.perf_counter() - t0, hmax, False,
                             f"not bistable at {where}: the curvature-dominated branch reached "
                             f"L/a = {hi:g} from {start_length:g} without a fold",
                             second=key, tip_width=tip_width, bistable=False,
                             remeshes=make.count - 1, meshes=tuple(make.made))
        raise ParameterError(f"no standout fold found in L from {start_length:g} to {hi:g} at "
                             f"{where}: {why}")
    hi_j = bounds_j[1]
    bar = Progress(o.progress, j, name, start=float(fold.p[j]), low=float(bounds_j[0]))
    points, cusps, per_point, stats = [], [], [], None
    engine_refact = 0
    direction, completed, reason = -1, False, ""
    try:
        while True:
            box = P.remesh_box(j, (lo, hi), bounds_j)
            seg = fold_curve(P, fold, ("L", name), box, ds=ds, ds_min=1e-4, ds_max=ds_max,
                             direction=direction, tol=tol, cusp_tol=1e-4,
                             max_cusp_iterations=0 if seeds else 40,
                             check_inertia=check_inertia, easy_iterations=3,
                             predictor=PREDICTOR, target_correction=TARGET_CORRECTION,
                             max_points=max(2, max_points - len(points)), keep_states=True,
                             on_point=(None if collect is None else
                                       (lambda pt, u, v, P=P: collect(P, pt, u, v))),
                             progress=bar)
            stats = seg.stats if stats is None else stats + seg.stats
            engine_refact += P.refactorizations
            cusps += list(seg.cusps)
            pts = list(seg.points)
            per_point += [pt.factorizations for pt in pts[1:]]
            if not seg.completed or not pts:
                points += [_strip(pt) for pt in pts]
                reason = seg.reason or "the fold curve stopped"
                break
            last = pts[-1]
            Lc, qc = float(last.p[0]), float(last.p[j])
            real_end = (qc >= hi_j - 1e-9 or qc <= bounds_j[0] + 1e-9
                        or Lc <= lo + 1e-9 or Lc >= hi - 1e-9)
            if real_end:
                points += [_strip(pt) for pt in pts]
                completed = qc >= hi_j - 1e-9
                if not completed:
                    reason = (f"the curve left the box at L/a = {Lc:.4f}, {name} = {qc:.4f} "
                              f"before returning to {name} = {hi_j:g}")
                break
            if make.count > MAX_REMESHES:
                points += [_strip(pt) for pt in pts]
                reason = f"more than {MAX_REMESHES} remeshes"
                break
            points += [_strip(pt) for pt in pts[:-1]]
            if collect is not None and hasattr(collect, "drop_last"):
                collect.drop_last()  # the next segment starts at this point again
            prev = pts[-2].p if len(pts) > 1 else (points[-1].p if points else p0)
            step_j = float(last.p[j] - prev[j])
            direction = direction if step_j == 0 else (1 if step_j > 0 else -1)
            if len(points) >= max_points:
                reason = "max_points"
                break
            # a fresh mesh at the fold, the state and the null vector moved onto it
            P, u, _ = make.remesh(P, last.u, last.p)
            fold, res = locate_fold(P, u, last.p, "L", tol=tol)
            if fold is None:  # near the cusp the fold in L degenerates: in p_j at fixed L
                fold, res = locate_fold(P, u, last.p, name, tol=tol)
                if fold is not None:
                    fold = as_fold_in_L(P, fold, tol)
            if fold is None:
                reason = (f"the fold was not found again after remeshing at L/a = {Lc:.4f}, "
                          f"{name} = {qc:.4f}: {res.reason}")
                break
            stats = stats + fold.stats
    finally:
        bar.close()
    out_points = tuple({key: float(pt.p[j]), "length": float(pt.p[0]), "kind": kind(pt.side)}
                       for pt in points)
    cusp = None
    if cusps:
        c = cusps[0]
        cusp = {key: float(c.p[j]), "length": float(c.p[0])}
    elif completed:
        cusp = turning_point(out_points, key)
    located = ("fold coefficient" if cusps else "turning point" if cusp is not None else "")
    total = f_start + f_branch + stats.factorizations + engine_refact
    curve = EngineFoldCurve(tuple(points), (0, j), tuple(cusps), completed, reason, stats)
    return FoldCurve(curvature, out_points, cusp, int(total),
                     float(np.median(per_point)) if per_point else float("nan"),
                     time.perf_counter() - t0, hmax, completed, reason,
                     tuple(pt.negative_eigenvalues for pt in points),
                     tuple(pt.crossing for pt in points), curve, key, tip_width,
                     remeshes=make.count - 1, meshes=tuple(make.made), cusp_located=located)
