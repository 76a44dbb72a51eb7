"""The force-deflection curve traced: pseudo-arclength continuation in the tip
force ``F`` (:class:`~skfem_sheet.sheet_engine.SheetForceProblem`) with the
inertia of every point, each fold located on the branch
(:func:`~skfem_sheet.engine.fold.fold_on_branch`, else
:func:`~skfem_sheet.engine.locate_fold`): :func:`force_curve`, on one mesh
(:class:`Tracer`), with the corrector :data:`TOLERANCES`.  The half model (``symmetric=True``)
sees no switch through an asymmetric state; on the whole sheet a branch point
shows as an inertia change without a turn (:attr:`ForceCurve.notes`).
"""
from __future__ import annotations

import math
import time
from dataclasses import replace

import numpy as np

from ..continuation import newton_tolerances
from ..engine import EngineFailure, arclength, newton
from ..engine.fold import fold_on_branch, locate_fold
from ..engine.protocol import Counting
from ..linalg import make_linear_solver
from ..newton import NewtonOptions, polish
from ..params import ParameterError, check_range
from ..sheet_engine import SheetForceProblem
from .curve import CurvePoint, ForceCurve

#: The mesh the curve is traced on for a finer ``hmax`` (the folds, the saddle
#: and the drooped state are then located again on ``hmax``).
CURVE_HMAX = 0.1

#: The corrector of the curve's points, the folds and the states at F = 0: the
#: sheet's Newton tolerances (residual to 1e-4 of the weight, displacements to
#: 1e-6 a), stopping on Newton's own error estimate where the corrections
#: contract (no factorisation only to confirm convergence).
TOLERANCES = replace(newton_tolerances(NewtonOptions()), error_estimate=True)

#: The located folds' tolerance in F (absolute, ``rho g a^3``; the forces are
#: of the order of 1e-3 on the paper's sheets).
FOLD_TOLERANCE = 1e-9

#: The states at F = 0 (saddle, stable states) are polished to this (units of
#: a, largest displacement correction; back-substitutions only).
POLISH_UTOL = 1e-9


class Tracer:
    """The sheet in its tip force on one mesh: points, folds and states at F = 0.

    The engine sees the parameter ``F / unit`` (:class:`SheetForceProblem`'s
    ``force_unit``); everything here takes and returns F itself."""

    def __init__(self, problem, curvature, gravity, solver, unit=1.0):
        linear = make_linear_solver(solver)
        if getattr(linear, "needs_layout", False):
            linear.attach(problem.saddle_point_layout())
        self.P = SheetForceProblem(problem, linear, curvature, gravity, force_unit=unit,
                                   tip_norm=True)
        self.unit = float(unit)
        self.counter = Counting(self.P)
        self.f = np.asarray(problem.tip_load)[self.P.free]  # dR/dF = -f
        self.scale = 2.0 if problem.sheet_mesh.half else 1.0

    def p(self, F):
        return np.array([float(F) / self.unit])

    def point(self, u, F, fact, kind="point"):
        """The CurvePoint of the equilibrium ``u`` at ``F`` (``fact``: the
        tangent factorised there, for the slope and the inertia)."""
        P, p = self.P, self.p(F)
        k = fact.inertia()
        try:
            dwdF = self.scale * float(self.f @ fact.solve(self.f))  # K du = f dF
            stiffness = 1.0 / dwdF if dwdF != 0 else math.inf
        except EngineFailure:
            stiffness = math.nan
        return CurvePoint(float(F), P.tip_displacement(u, p), P.deflection(u, p),
                          P.energy(u, p, load_potential=False), float(stiffness),
                          None if k is None else int(k), kind)

    def at_zero(self, u):
        """The equilibrium at F = 0 from ``u`` (Newton, then polished):
        ``(u, factorisation)`` or None."""
        res = newton(self.counter, u, np.zeros(1), tol=TOLERANCES)
        if not res.converged:
            return None
        w, _ = polish(self.P.problem, self.P.full(res.u, [0.0]), self.P.g, self.P.solver,
                      self.P.stats, utol=POLISH_UTOL, max_iterations=4,
                      first=10 * TOLERANCES.utol)
        # the last factorisation (within utol of u): its inertia and the slope
        return w[self.P.free], res.factorization

    def fold(self, u, F, v):
        """The fold near the equilibrium ``u`` at ``F`` (approximate null vector
        ``v``): on the branch, else by Newton on the fold system (approached
        along the branch): a FoldPoint (in the engine's parameter) or None."""
        p = self.p(F)
        try:
            fold, _ = fold_on_branch(self.counter, u, p, 0, v, tol=TOLERANCES,
                                     ptol=FOLD_TOLERANCE)
            if fold is None:
                fold, _ = locate_fold(self.counter, u, p, 0, v0=v, tol=TOLERANCES, approach=8)
        except EngineFailure:
            return None
        return fold

    def fold_point(self, fold):
        """The CurvePoint of a located fold (slope 0: the curve turns in F)."""
        P = self.P
        u, p = fold.u, fold.p
        return CurvePoint(float(fold.value) * self.unit, P.tip_displacement(u, p),
                          P.deflection(u, p), P.energy(u, p, load_potential=False), 0.0,
                          fold.negative_eigenvalues, "fold")


def check_curve_args(max_force, ds, ds_max, max_points, turn=0.1):
    max_force = check_range("max_force", max_force, 0, None, lo_open=True,
                            hint="in units of the sheet's weight")
    ds = check_range("ds", ds, 0, 1, lo_open=True)
    ds_max = check_range("ds_max", ds_max, ds, 10)
    max_points = int(check_range("max_points", max_points, 2, 100000))
    check_range("turn", turn, 0, 1, lo_open=True, hint="radians")
    return max_force, ds, ds_max, max_points


#: The unit of the continuation parameter
#: (:class:`~skfem_sheet.sheet_engine.SheetForceProblem`'s ``force_unit``):
#: the force that moves the tip of the start state by this many base widths
#: (its tip stiffness ``dF/dw_tip`` times it), so that the arclength norm
#: (the tip's displacement and the parameter) weighs the two alike and the
#: points fall along the curve of F against the tip on its stiff and its
#: soft parts (the paper's sheets switch at a few per cent of their weight,
#: short stiff ones at more than their weight).
FORCE_UNIT = 0.1


def force_curve(problem, w, curvature: float, *, gravity: float = 1.0, direction: int = -1,
                solver: str = "auto", max_force: float = 2.0, ds: float = 0.01,
                ds_max: float = 0.5, turn: float = 0.2, max_points: int = 400,
                progress=None) -> ForceCurve:
    """The curve of equilibria in the tip force from the equilibrium ``w`` at F = 0.

    Pseudo-arclength continuation in F (:func:`skfem_sheet.engine.arclength`)
    from ``w`` in ``direction``, in the plane of the tip's vertical
    displacement and ``F / F_u`` (``F_u`` moves the start's tip by
    :data:`FORCE_UNIT` a), steps controlled by the curve's bending
    (``turn``), to the first crossing of F = 0 (solved there exactly) and on
    to the second; a segment also ends where ``|F|`` exceeds ``max_force``
    weights.  Folds are located on the branch
    (:func:`~skfem_sheet.engine.fold.fold_on_branch`, to
    :data:`FOLD_TOLERANCE`); every point carries its inertia and ``dF/dw_tip``.

    Parameters
    ----------
    problem : SheetProblem
        The discrete sheet (its tip force, if any, is the curve's parameter).
    w : ndarray
        An equilibrium at F = 0 (full dof vector; corrected first).
    curvature : float
        The clamp curvature a/R of ``w``.
    gravity : float
    direction : {-1, 1}
        Push down (-1: from the aloft state) or pull up (1).
    solver : str
    max_force : float
        The range of ``|F|`` traced, in units of the sheet's weight
        (``area x thickness``, ``rho g a^3``).
    ds, ds_max : float
        First and largest arclength step, per unit of the sheet's size
        ``max(1, L/a)``.
    turn : float
        The angle (radians) the curve's tangent turns by from one point to
        the next, aimed at (:func:`~skfem_sheet.engine.arclength`).
    max_points : int
        Most points per segment.
    progress : callable(F, d) or None

    Returns
    -------
    ForceCurve

    Examples
    --------
    A sheet far from bistable (L/a 0.6, flat clamp) pushed down: no fold
    within a tenth of its weight.

    >>> from skfem_sheet.params import Sheet
    >>> from skfem_sheet.solve import build_problem
    >>> prob = build_problem(Sheet(length=0.6), 0.3, half=True)
    >>> c = force_curve(prob, np.zeros(prob.ndof), 0.0, max_force=0.1, ds=0.02, ds_max=0.05)
    >>> c.shape, c.completed, round(float(c.forces.min() / (0.6 * 0.03)), 1) <= -0.1
    ('no fold', True, True)
    """
    if direction not in (-1, 1):
        raise ParameterError(f"direction must be -1 (push down) or 1 (pull up), got {direction!r}")
    max_force, ds, ds_max, max_points = check_curve_args(max_force, ds, ds_max, max_points, turn)
    t0 = time.perf_counter()
    sheet = problem.sheet
    if problem.tip_force:
        problem = problem.with_tip_force(0.0)
    weight = sheet.area * sheet.thickness
    tr = Tracer(problem, curvature, gravity, solver)
    P, counter = tr.P, tr.counter
    size = max(1.0, sheet.length)
    start0 = counter.stats()
    notes, states, nulls = [], {}, {}

    first = tr.at_zero(np.asarray(w, dtype=float)[P.free])
    if first is None:
        raise ParameterError("w must be an equilibrium at F = 0 (Newton from it did not "
                             "converge)")
    u0, fact0 = first
    points = [tr.point(u0, 0.0, fact0, "start")]
    k0 = points[0].stiffness
    tr.unit = P.force_unit = FORCE_UNIT * (k0 if 0 < k0 < math.inf else weight)
    p_max = max_force * weight / tr.unit  # |F| <= max_force x weight
    states["start"] = P.full(u0, [0.0])
    n_folds = 0
    reason = ""
    crossings = 0
    seg_dir = direction
    u_seg, fact_seg = u0, fact0
    for _segment in range(2):
        bounds = (-p_max, 0.0) if seg_dir < 0 else (0.0, p_max)
        seg = []  # (BranchPoint, CurvePoint)

        def on_step(pt, res, seg=seg):
            if not seg:  # the first point is the segment's start (already recorded)
                seg.append((pt, None))
                return
            cp = tr.point(pt.u, P.force(pt.p), res.factorization)
            seg.append((pt, cp))
            if progress is not None:
                progress(cp.force, cp.deflection)

        b = arclength(counter, u_seg, np.zeros(1), 0, bounds, ds=ds * size,
                      ds_min=1e-3 * ds * size, ds_max=ds_max * size, direction=seg_dir,
                      tol=TOLERANCES, max_points=max_points, locate=False, keep_states=True,
                      on_step=on_step, start=(u_seg, fact_seg), turn=turn)
        # the folds: where the tangent turns in F between two points
        merged = []  # (CurvePoint, u, F) in the order traced, the start excluded
        prev = seg[0][0]
        for pt, cp in seg[1:]:
            if np.sign(pt.tangent_p) != np.sign(prev.tangent_p):
                near = prev if abs(prev.tangent_p) < abs(pt.tangent_p) else pt
                fold = tr.fold(near.u, P.force(near.p), pt.u - prev.u)
                if fold is None:
                    notes.append(f"the turn in F between F = {P.force(prev.p):.6g} and "
                                 f"{P.force(pt.p):.6g} could not be located")
                else:
                    n_folds += 1
                    name = f"fold {n_folds}"
                    states[name] = P.full(fold.u, fold.p)
                    nulls[name] = np.asarray(fold.v, dtype=float)
                    merged.append((tr.fold_point(fold), fold.u, P.force(fold.p)))
            merged.append((cp, pt.u, P.force(pt.p)))
            prev = pt
        crossed = b.completed and merged and merged[-1][2] * seg_dir < 0
        if not crossed:
            points += [m[0] for m in merged]
            reason = (f"|F| reached {max_force:g} times the sheet's weight" if b.completed
                      else b.reason)
            break
        # F came back through 0: the state there, from the last two entries
        _, u1, F1 = merged[-2] if len(merged) > 1 else (None, u_seg, 0.0)
        _, u2, F2 = merged[-1]
        t = F1 / (F1 - F2) if F1 != F2 else 0.0
        zero = tr.at_zero(u1 + t * (u2 - u1))
        points += [m[0] for m in merged[:-1]]
        if zero is None:
            reason = (f"the equilibrium at F = 0 between F = {F1:.6g} and {F2:.6g} did not "
                      f"converge")
            break
        crossings += 1
        kind = "saddle" if crossings == 1 else "end"
        u_seg, fact_seg = zero
        points.append(tr.point(u_seg, 0.0, fact_seg, kind))
        states[kind] = P.full(u_seg, [0.0])
        seg_dir = -seg_dir
    shape = _shape(points, crossings, notes)
    stats = counter.stats() - start0
    return ForceCurve(tuple(points), float(problem.sheet_mesh.hmax), int(direction),
                      not reason or reason.startswith("|F|"), reason, shape, tuple(notes),
                      int(stats.factorizations), time.perf_counter() - t0, problem, states,
                      nulls)


def _shape(points, crossings, notes) -> str:
    """``"one S"`` or what the curve is instead (with notes on what is odd).

    One S: two folds, F back at 0 twice (the saddle, the end state), no
    negative eigenvalue before the first fold and after the second, one
    between them.  Between two points whose inertia is known, a change with
    no fold between them is a branch point (or a fold the steps did not
    resolve), and a fold across which the inertia does not change by one is
    not confirmed."""
    folds = [i for i, p in enumerate(points) if p.kind == "fold"]
    known = [(i, p.negative_eigenvalues) for i, p in enumerate(points)
             if p.kind != "fold" and p.negative_eigenvalues is not None]
    branch_point = False
    for (i, ki), (j, kj) in zip(known[:-1], known[1:]):
        between = [f for f in folds if i < f < j]
        if not between and ki != kj:
            branch_point = True
            notes.append(f"the inertia changed from {ki} to {kj} between F = "
                         f"{points[i].force:.6g} and {points[j].force:.6g} without a turn in F: "
                         f"a branch point (bifurcation), or a fold the steps did not resolve")
        elif len(between) == 1 and abs(ki - kj) != 1:
            notes.append(f"the fold at F = {points[between[0]].force:.6g} is not confirmed by "
                         f"the inertia ({ki} negative eigenvalue(s) before it, {kj} after)")
    w = np.array([p.tip_displacement for p in points])
    if len(w) > 2 and not (np.all(np.diff(w) <= 0) or np.all(np.diff(w) >= 0)):
        notes.append("the tip turns along the curve (w_tip not monotone: a snap-back under "
                     "displacement control)")
    if not folds:
        return "no fold"
    if len(folds) > 2:
        notes.append(f"{len(folds)} folds in F: more than the two of an S")
        return f"{len(folds)} folds"
    if len(folds) == 2 and crossings == 2 and not branch_point:
        ks = [p.negative_eigenvalues for p in points]
        parts = (ks[:folds[0]], ks[folds[0] + 1:folds[1]], ks[folds[1] + 1:])
        if all(k == want for part, want in zip(parts, (0, 1, 0)) for k in part if k is not None):
            return "one S"
    if crossings < 2:
        return (f"{len(folds)} fold{'s' if len(folds) > 1 else ''}, "
                f"{'no return' if crossings == 0 else 'one return'} to F = 0")
    return "not one S"
