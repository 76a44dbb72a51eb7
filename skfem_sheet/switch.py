"""How hard is it to switch? The tip force that snaps a bistable sheet, and the barrier.

A bistable sheet has, at zero load, two stable equilibria (aloft and
drooped) and between them the unstable **saddle** of the energy that a
switch passes over.  A vertical tip force ``F``
(:meth:`~skfem_sheet.problem.SheetProblem.with_tip_force`: a dead load over
the tip face, positive upward, units of ``rho g a^3``) connects the three on
an S-shaped curve of equilibria: the aloft branch ends at the fold
``F_down < 0`` (the **switching force down**), the unstable branch passes
``F = 0`` at the saddle, and the drooped branch ends at ``F_up > 0``.
:func:`force_curve` traces it by pseudo-arclength continuation in ``F``
(:class:`~skfem_sheet.sheet_engine.SheetForceProblem`) with the inertia of
every point, and locates each fold on the branch
(:func:`~skfem_sheet.engine.fold.fold_on_branch`, else
:func:`~skfem_sheet.engine.locate_fold`).

The **barriers** ``barrier_down = Pi(saddle) - Pi(aloft)`` and
``barrier_up = Pi(saddle) - Pi(drooped)`` (units of ``rho g a^4``) are the
work a quasi-static switch takes.  The tests check: the work identity
``dPi = F dw_tip`` along the curve (integrated in ``w_tip`` with the tip
stiffness ``k = dF/dw_tip``, Hermite cubics); the saddle equal to the S-curve
in L's middle state (:func:`skfem_sheet.bistability.s_curve`); and the
saddle-node scaling near ``L1*`` (and ``L0*``): ``F_down ~ L1* - L``,
``barrier_down ~ (L1* - L)^{3/2}`` (normal form ``a x^3/3 - mu x - F x``).

:func:`switching` analyses one :class:`~skfem_sheet.params.Sheet`: the curve
on the mesh ``curve_hmax``, the folds, saddle and drooped state located
again on ``hmax`` from the carried states (the curve traced on ``hmax``
itself where they do not converge).  :func:`apply_tip_force` is the
force-controlled solve.  The half model (``symmetric=True``) sees no switch
through an asymmetric state; on the whole sheet a branch point shows as an
inertia change without a turn (:attr:`ForceCurve.notes`).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace

import numpy as np

from .analyses.observables import tip_deflection
from .analyses.transfer import transfer
from .build import BuildChain
from .continuation import StepOptions, end_state_verdict, newton_tolerances, snap_from_fold
from .engine import EngineFailure, StepRule, arclength, newton, ramp
from .engine.fold import fold_on_branch, locate_fold
from .engine.protocol import Counting
from .io import atomic_write, check_writable, dumps_json, write_json
from .linalg import LinearSolverError, make_linear_solver
from .newton import NewtonOptions, Stats, polish
from .params import ParameterError, Sheet, SIScale, check_range
from .result import Result, SolveError
from .sheet_engine import LoadPhase, SheetForceProblem, SheetLoadProblem
from .solve import build_problem, solve
from .states import SAME_TOL
from .version import __version__

__all__ = ["CURVE_HMAX", "CurvePoint", "ForceCurve", "SIScale", "Switching", "TipForceRamp",
           "apply_tip_force", "force_curve", "si_scales", "switching"]

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


# -----------------------------------------------------------------------------
# SI units
# -----------------------------------------------------------------------------
def si_scales(sheet: Sheet):
    """The SI scales a sheet was made with, or None (a dimensionless sheet).

    The one place where the switching analysis reads them from a
    :class:`~skfem_sheet.params.Sheet`: its ``si`` (the scales a sheet made
    by :meth:`~skfem_sheet.params.Sheet.from_si` keeps: base width,
    density, gravity), where it has them; without, :func:`switching` takes
    them from its ``si`` argument.

    Examples
    --------
    >>> si_scales(Sheet(length=1.3, curvature=2.5)) is None
    True
    """
    return sheet.si


# -----------------------------------------------------------------------------
# the curve
# -----------------------------------------------------------------------------
@dataclass(frozen=True)
class CurvePoint:
    """One equilibrium of the force-deflection curve.

    Attributes
    ----------
    force : float
        The tip force F (``rho g a^3``, positive upward).
    tip_displacement : float
        ``w_tip``: the tip face's mean vertical displacement (a, upward).
    deflection : float
        d/a (positive downward; :func:`~skfem_sheet.analyses.observables.tip_deflection`).
    energy : float
        The sheet's own energy Pi (elastic and gravitational, without the
        tip force's potential; ``rho g a^4``).
    stiffness : float
        ``dF/dw_tip`` along the curve (``rho g a^2``): positive on a stable
        branch, 0 at a fold, negative on the unstable branch.
    negative_eigenvalues : int or None
        Of the constrained Hessian (None: unknown).
    kind : str
        ``"point"``, ``"fold"``, or the states at ``F = 0``: ``"start"``,
        ``"saddle"`` (the first crossing of F = 0 after the start), ``"end"``.
    """

    force: float
    tip_displacement: float
    deflection: float
    energy: float
    stiffness: float
    negative_eigenvalues: object
    kind: str = "point"

    @property
    def stable(self):
        """No negative eigenvalue (None: unknown; a fold: False)."""
        if self.kind == "fold":
            return False
        k = self.negative_eigenvalues
        return None if k is None else k == 0


def _hermite(w0, F0, k0, w1, F1, k1) -> float:
    """``int F dw`` over ``[w0, w1]`` of the cubic Hermite interpolant of F(w)
    with the slopes ``k = dF/dw`` at both ends (exact for cubics)."""
    h = w1 - w0
    return 0.5 * h * (F0 + F1) + h * h * (k0 - k1) / 12.0


@dataclass(frozen=True)
class ForceCurve:
    """The curve of equilibria in the tip force F, traced from a state at F = 0.

    Attributes
    ----------
    points : tuple of CurvePoint
        In the order traced: the start state, the points, the folds where
        they lie, the crossings of F = 0 (``kind`` says which).
    hmax : float
        The mesh it was traced on.
    direction : int
        ``-1``: traced pushing down from the start (the aloft state), ``+1``:
        pulling up.
    completed : bool
        It came back to F = 0 twice (saddle and end state), or ended where
        ``|F|`` left the range traced (``reason`` says which).
    reason : str
        Why the trace ended ("" for an S traced to its other end).
    shape : str
        ``"one S"`` (two folds, one negative eigenvalue between them and none
        outside), or what it is instead (the notes say more).
    notes : tuple of str
        More folds than an S has, an inertia change without a turn (a branch
        point), a fold not confirmed by the inertia, a tip that turns.
    factorizations : int
    wall_time_s : float
    problem : SheetProblem
        The discrete sheet (at F = 0) the states belong to.
    states : dict
        Full dof vectors of the start, ``fold 1``, ``fold 2`` ..., the
        ``saddle`` and the ``end`` state, by kind.
    null_vectors : dict
        The null vectors (free dofs) of the folds, ``fold 1`` ...
    """

    points: tuple
    hmax: float
    direction: int
    completed: bool
    reason: str
    shape: str
    notes: tuple = ()
    factorizations: int = 0
    wall_time_s: float = 0.0
    problem: object = field(default=None, repr=False)
    states: dict = field(default_factory=dict, repr=False)
    null_vectors: dict = field(default_factory=dict, repr=False)

    # -- arrays ----------------------------------------------------------------
    @property
    def forces(self):
        return np.array([p.force for p in self.points])

    @property
    def tip_displacements(self):
        return np.array([p.tip_displacement for p in self.points])

    @property
    def deflections(self):
        return np.array([p.deflection for p in self.points])

    @property
    def energies(self):
        return np.array([p.energy for p in self.points])

    @property
    def stable(self):
        return [p.stable for p in self.points]

    def names(self) -> list:
        """The name of every point: its kind, the folds numbered in the order
        traced (``"start"``, ``"point"``, ``"fold 1"``, ..., ``"saddle"``,
        ``"fold 2"``, ..., ``"end"``)."""
        out, n = [], 0
        for p in self.points:
            if p.kind == "fold":
                n += 1
                out.append(f"fold {n}")
            else:
                out.append(p.kind)
        return out

    def index(self, name: str) -> int:
        """The position of the point named ``name`` (:meth:`names`)."""
        names = self.names()
        if name == "point" or name not in names:
            allowed = ", ".join(n for n in names if n != "point")
            raise ParameterError(f"name must be one of the curve's points ({allowed}), got "
                                 f"{name!r}")
        return names.index(name)

    @property
    def folds(self) -> tuple:
        """The fold points, in the order traced."""
        return tuple(p for p in self.points if p.kind == "fold")

    def point(self, name: str):
        """The point named ``name`` (``"saddle"``, ``"end"``, ``"fold 1"`` ...), or None."""
        try:
            return self.points[self.index(name)]
        except ParameterError:
            return None

    def work(self, start: str = "start", end: str = "saddle") -> float:
        """``int F dw_tip`` along the curve from the point ``start`` to ``end``
        (names as :meth:`names`; Hermite cubics in ``w_tip`` with the slopes at
        the points; trapezoids where the tip turns, ``w_tip`` not monotone): by
        the work identity ``Pi(end) - Pi(start)``.

        Examples
        --------
        On ``F = w^2`` from ``w = 0`` to 1 (slope ``2 w``; exact: 1/3):

        >>> pts = [CurvePoint(w * w, w, 0.0, 0.0, 2 * w, 0, k)
        ...        for w, k in ((0.0, "start"), (0.5, "point"), (1.0, "saddle"))]
        >>> round(ForceCurve(tuple(pts), 0.1, -1, True, "", "one S").work(), 12)
        0.333333333333
        """
        i, j = self.index(start), self.index(end)
        sign = 1.0
        if j < i:
            i, j, sign = j, i, -1.0
        total = 0.0
        pts = self.points[i:j + 1]
        w = np.array([p.tip_displacement for p in pts])
        monotone = bool(np.all(np.diff(w) <= 0) or np.all(np.diff(w) >= 0))
        for a, b in zip(pts[:-1], pts[1:]):
            if monotone and np.isfinite(a.stiffness) and np.isfinite(b.stiffness):
                total += _hermite(a.tip_displacement, a.force, a.stiffness,
                                  b.tip_displacement, b.force, b.stiffness)
            else:
                total += 0.5 * (b.tip_displacement - a.tip_displacement) * (a.force + b.force)
        return sign * total

    def to_csv(self) -> str:
        """The points as CSV text: ``force, tip_displacement, deflection, energy,
        stiffness, negative_eigenvalues, kind`` (units of ``rho g a^3``, a,
        ``rho g a^4``, ``rho g a^2``; an unknown inertia empty)."""
        lines = ["force,tip_displacement,deflection,energy,stiffness,negative_eigenvalues,kind"]
        for p in self.points:
            k = "" if p.negative_eigenvalues is None else str(p.negative_eigenvalues)
            lines.append(f"{p.force!r},{p.tip_displacement!r},{p.deflection!r},{p.energy!r},"
                         f"{p.stiffness!r},{k},{p.kind}")
        return "\n".join(lines) + "\n"

    def write(self, filename) -> None:
        """Write :meth:`to_csv` to ``filename`` (atomically)."""
        check_writable("filename", filename, [".csv"])
        atomic_write(filename, self.to_csv())

    def summary(self) -> dict:
        """JSON-ready: the arrays, the folds, the shape."""
        return {"hmax": self.hmax, "direction": self.direction, "completed": self.completed,
                "reason": self.reason, "shape": self.shape, "notes": list(self.notes),
                "force": self.forces.tolist(), "tip_displacement": self.tip_displacements.tolist(),
                "deflection": self.deflections.tolist(), "energy": self.energies.tolist(),
                "stiffness": [p.stiffness for p in self.points],
                "negative_eigenvalues": [p.negative_eigenvalues for p in self.points],
                "kind": [p.kind for p in self.points],
                "factorizations": self.factorizations, "wall_time_s": self.wall_time_s}


class _Tracer:
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


def _check_curve_args(max_force, ds, ds_max, max_points, turn=0.1):
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

    >>> from skfem_sheet.solve import build_problem
    >>> prob = build_problem(Sheet(length=0.6), 0.3, half=True)
    >>> c = force_curve(prob, np.zeros(prob.ndof), 0.0, max_force=0.1, ds=0.02, ds_max=0.05)
    >>> c.shape, c.completed, round(float(c.forces.min() / (0.6 * 0.03)), 1) <= -0.1
    ('no fold', True, True)
    """
    if direction not in (-1, 1):
        raise ParameterError(f"direction must be -1 (push down) or 1 (pull up), got {direction!r}")
    max_force, ds, ds_max, max_points = _check_curve_args(max_force, ds, ds_max, max_points, turn)
    t0 = time.perf_counter()
    sheet = problem.sheet
    if problem.tip_force:
        problem = problem.with_tip_force(0.0)
    weight = sheet.area * sheet.thickness
    tr = _Tracer(problem, curvature, gravity, solver)
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


# -----------------------------------------------------------------------------
# the analysis of one sheet
# -----------------------------------------------------------------------------
@dataclass(frozen=True)
class Switching:
    """How hard it is to switch one sheet (:func:`switching`).

    Attributes
    ----------
    sheet : Sheet
    hmax : float
    bistable : bool
        Two stable states at F = 0 on one S, the saddle between them.
    states : str
        The verdict in words ("two states ..." or "one state: ...").
    force_down : float
        ``F_down < 0``: the push down (``rho g a^3``) at which the aloft
        state ends (its fold); NaN where there is none.
    force_up : float
        ``F_up > 0``: the pull up at which the drooped state ends; NaN where none.
    fold_down_deflection, fold_up_deflection : float
        d/a at those folds.
    barrier_down, barrier_up : float
        ``Pi(saddle) - Pi(aloft)``, ``Pi(saddle) - Pi(drooped)`` (``rho g a^4``).
    saddle_deflection, saddle_energy : float
        d/a and Pi of the saddle (the unstable state at F = 0).
    saddle_negative_eigenvalues : int or None
    aloft_deflection, aloft_energy, drooped_deflection, drooped_energy : float
    weight : float
        The sheet's weight, ``area x thickness`` (``rho g a^3``).
    shape : str
        The curve's shape (``"one S"``, or what it is instead).
    notes : tuple of str
    curve : ForceCurve
        The force-deflection curve (on its own mesh, ``curve.hmax``).
    work_down, work_up : float
        ``int F dw_tip`` from the aloft (drooped) state to the saddle: the
        barriers on the curve's mesh by the work identity.
    curve_barrier_down, curve_barrier_up : float
        The barriers on the curve's mesh, from its states' energies.
    si : SIScale or None
        The SI scales (then :meth:`summary` holds the SI values too).
    factorizations : int
        On the mesh ``hmax`` (the curve's and the solve's included).
    wall_time_s, solve_wall_time_s : float
        All of it, and the solve of the aloft state within it.
    problem : SheetProblem
        The discrete sheet on ``hmax`` (F = 0) of the states.
    saddle_state, aloft_state, drooped_state : ndarray or None
        Full dof vectors on ``problem``.
    """

    sheet: Sheet
    hmax: float
    bistable: bool
    states: str
    force_down: float
    force_up: float
    fold_down_deflection: float
    fold_up_deflection: float
    barrier_down: float
    barrier_up: float
    saddle_deflection: float
    saddle_energy: float
    saddle_negative_eigenvalues: object
    aloft_deflection: float
    aloft_energy: float
    drooped_deflection: float
    drooped_energy: float
    weight: float
    shape: str
    notes: tuple
    curve: ForceCurve = field(repr=False)
    work_down: float = math.nan
    work_up: float = math.nan
    curve_barrier_down: float = math.nan
    curve_barrier_up: float = math.nan
    si: object = None
    factorizations: int = 0
    wall_time_s: float = 0.0
    solve_wall_time_s: float = 0.0
    problem: object = field(default=None, repr=False)
    saddle_state: object = field(default=None, repr=False)
    aloft_state: object = field(default=None, repr=False)
    drooped_state: object = field(default=None, repr=False)

    def __repr__(self) -> str:
        s = self.sheet
        head = (f"Switching(L/a {s.length:g}, b/a {s.tip_width:g}, a/R {s.curvature:g}, "
                f"hmax {self.hmax:g}: ")
        if not self.bistable:
            return head + f"{self.states})"
        return head + (f"bistable, force_down {self.force_down:.4g} ({self._w(self.force_down)}"
                       f" of the weight), force_up {self.force_up:+.4g} "
                       f"({self._w(self.force_up)}), barrier_down {self.barrier_down:.4g}, "
                       f"barrier_up {self.barrier_up:.4g})")

    def _w(self, F) -> str:
        return f"{100 * F / self.weight:+.3g}%"

    def with_si(self, si: SIScale) -> Switching:
        """The same analysis reported in SI units too (``si``: the sheet's scales)."""
        if not isinstance(si, SIScale):
            raise ParameterError(f"si must be a SIScale, got {type(si).__name__}")
        return replace(self, si=si)

    def in_si(self) -> dict:
        """The forces in newtons, the barriers in joules, d in metres (``si`` needed)."""
        if self.si is None:
            raise ParameterError("in_si needs the sheet's SI scales: switching(..., si=...) or "
                                 "with_si(...)")
        f, e, a = self.si.force, self.si.energy, self.si.base_width
        return {"force_down_N": self.force_down * f, "force_up_N": self.force_up * f,
                "weight_N": self.weight * f,
                "barrier_down_J": self.barrier_down * e, "barrier_up_J": self.barrier_up * e,
                "saddle_deflection_m": self.saddle_deflection * a,
                "aloft_deflection_m": self.aloft_deflection * a,
                "drooped_deflection_m": self.drooped_deflection * a,
                "fold_down_deflection_m": self.fold_down_deflection * a,
                "fold_up_deflection_m": self.fold_up_deflection * a,
                "scales": self.si.to_json()}

    def summary(self) -> dict:
        """JSON-ready (the command line's ``--json``): the interface's names as keys."""
        out = {"sheet": self.sheet.to_dict(), "hmax": self.hmax, "bistable": self.bistable,
               "states": self.states, "force_down": self.force_down, "force_up": self.force_up,
               "fold_down_deflection": self.fold_down_deflection,
               "fold_up_deflection": self.fold_up_deflection,
               "barrier_down": self.barrier_down, "barrier_up": self.barrier_up,
               "saddle_deflection": self.saddle_deflection, "saddle_energy": self.saddle_energy,
               "saddle_negative_eigenvalues": self.saddle_negative_eigenvalues,
               "aloft_deflection": self.aloft_deflection, "aloft_energy": self.aloft_energy,
               "drooped_deflection": self.drooped_deflection,
               "drooped_energy": self.drooped_energy, "weight": self.weight,
               "force_down_per_weight": self.force_down / self.weight,
               "force_up_per_weight": self.force_up / self.weight,
               "shape": self.shape, "notes": list(self.notes),
               "work_down": self.work_down, "work_up": self.work_up,
               "curve_barrier_down": self.curve_barrier_down,
               "curve_barrier_up": self.curve_barrier_up,
               "curve": self.curve.summary(), "factorizations": self.factorizations,
               "wall_time_s": self.wall_time_s, "solve_wall_time_s": self.solve_wall_time_s,
               "units": {"force": "rho g a^3", "energy": "rho g a^4", "deflection": "a"},
               "version": __version__}
        if self.si is not None:
            out["si"] = self.in_si()
        return out

    def to_json(self) -> str:
        return dumps_json(self.summary())

    def write(self, filename) -> None:
        """Write :meth:`summary` as JSON (atomically)."""
        write_json(self.summary(), filename)

    def lines(self) -> list:
        """The analysis in words, one line each (``print(result)``)."""
        s = self.sheet
        out = [f"switching: L/a = {s.length:g}, b/a = {s.tip_width:g}, a/R = {s.curvature:g}, "
               f"h/a = {s.thickness:g}, E/(rho g a) = {s.modulus:g}, hmax {self.hmax:g} "
               f"(curve on hmax {self.curve.hmax:g})", f"  {self.states}"]
        si = self.in_si() if self.si is not None else None

        def force(name, F, d):
            if not np.isfinite(F):
                return
            line = (f"  {name} = {F:+.6g} rho g a^3 ({100 * F / self.weight:+.3g}% of the "
                    f"weight), d/a {d:.5f} at its fold")
            if si is not None:
                line += f"; {1e3 * F * self.si.force:+.4g} mN"
            out.append(line)

        force("force_down", self.force_down, self.fold_down_deflection)
        force("force_up", self.force_up, self.fold_up_deflection)
        if self.bistable:
            for name, e in (("barrier_down", self.barrier_down), ("barrier_up", self.barrier_up)):
                line = f"  {name} = {e:.6g} rho g a^4"
                if si is not None:
                    line += f" ({1e6 * e * self.si.energy:.4g} microjoules)"
                out.append(line)
            out.append(f"  saddle: d/a {self.saddle_deflection:.6f}, "
                       f"{self.saddle_negative_eigenvalues} negative eigenvalue(s); aloft d/a "
                       f"{self.aloft_deflection:.6f}, drooped d/a {self.drooped_deflection:.6f}")
            out.append(f"  work identity on hmax {self.curve.hmax:g}: int F dw_tip "
                       f"{self.work_down:.6g} / {self.work_up:.6g} against the barriers "
                       f"{self.curve_barrier_down:.6g} / {self.curve_barrier_up:.6g}")
        w = f"  the sheet's weight: {self.weight:.6g} rho g a^3"
        if si is not None:
            w += f" = {1e3 * self.weight * self.si.force:.4g} mN"
        out.append(w)
        out.append(f"  the curve: {self.shape}, {len(self.curve.points)} points; "
                   f"{self.factorizations} factorisations on hmax {self.hmax:g}, "
                   f"{self.wall_time_s:.1f} s")
        out += [f"  note: {n}" for n in self.notes]
        return out

    def __str__(self) -> str:
        return "\n".join(self.lines())

    def _repr_pretty_(self, p, cycle):
        p.text(repr(self) if cycle else str(self))


def _branch_of(result: Result) -> str:
    """The name of the state a solve ended on."""
    return result.branch


def _curve_mesh(hmax, curve_hmax):
    if curve_hmax is None:
        return max(float(hmax), CURVE_HMAX)
    return check_range("curve_hmax", curve_hmax, hmax, None,
                       hint="the curve is traced on hmax or a coarser mesh")


def switching(sheet: Sheet, hmax: float = 0.03, *, curve_hmax: float | None = None,
              layers=None, solver: str = "auto", symmetric: bool = True,
              max_force: float = 2.0, max_points: int = 400, si: SIScale | None = None,
              progress: bool = False, chain: BuildChain | None = None) -> Switching:
    """The switching forces and energy barriers of one sheet.

    The sheet is solved curvature-first, the force-deflection curve traced
    from that state (:func:`force_curve`, pushing down; pulling up if it
    ended drooped) on ``curve_hmax``; where that is coarser than ``hmax`` its
    folds, saddle and other state at F = 0 are located again on ``hmax``
    (where that fails, or the coarse curve is not one S, the curve is traced
    on ``hmax``).

    Parameters
    ----------
    sheet : Sheet
        With a tip face (``tip_width > 0``, or a planform whose cut ``x = L``
        remains).
    hmax : float
        The mesh of the answer.
    curve_hmax : float, optional
        The mesh the curve is traced on (default: ``hmax`` from 0.1 up, else
        :data:`CURVE_HMAX`); ``curve_hmax=hmax`` traces it on ``hmax``.
    layers, solver, symmetric
        As for :func:`~skfem_sheet.solve.solve` (``symmetric=False``: the
        whole sheet, whose curve can show asymmetric branch points).
    max_force : float
        The range of ``|F|`` traced, in units of the sheet's weight.
    max_points : int
        Most points per segment of the curve.
    si : SIScale, optional
        The sheet's SI scales (default :func:`si_scales` of the sheet):
        the summary then holds newtons and joules too.
    progress : bool
        A progress bar on stderr (F and d of the curve's points).
    chain : BuildChain, optional
        Keeps the meshes (the solve's and the curve's) for the next call.

    Returns
    -------
    Switching

    Raises
    ------
    ParameterError
        Bad input (the sheet has no tip face ...).
    SolveError
        The curvature-first solve did not reach full load.

    Examples
    --------
    >>> s = switching(Sheet(length=1.3, curvature=2.5), hmax=0.2)
    >>> s.bistable, s.force_down < 0 < s.force_up, s.barrier_down > 0
    (True, True, True)
    """
    if not isinstance(sheet, Sheet):
        raise ParameterError(f"sheet must be a skfem_sheet.Sheet, got {type(sheet).__name__}")
    hmax = check_range("hmax", hmax, 0, None, lo_open=True)
    trace_h = _curve_mesh(hmax, curve_hmax)
    max_force, _, _, max_points = _check_curve_args(max_force, 0.01, 0.04, max_points)
    if si is None:
        si = si_scales(sheet)
    elif not isinstance(si, SIScale):
        raise ParameterError(f"si must be a SIScale or None, got {type(si).__name__}")
    if chain is not None and not isinstance(chain, BuildChain):
        raise ParameterError(f"chain must be a skfem_sheet.build.BuildChain or None, got "
                             f"{type(chain).__name__}")
    chain = chain if chain is not None else BuildChain(max_meshes=3)
    # the tip face, before anything is solved
    _ = build_problem(sheet, trace_h, None if trace_h != hmax else layers, 2, bool(symmetric),
                      chain=chain).tip_load
    t0 = time.perf_counter()
    bar = _Progress(sheet) if progress else None
    common = dict(solver=solver, max_force=max_force, max_points=max_points, progress=bar)
    try:
        r = solve(sheet, "curvature-first", hmax, layers=layers, solver=solver,
                  symmetric=symmetric, on_failure="return", chain=chain)
        if not r.converged:
            raise SolveError(f"the sheet could not be solved curvature-first: {r.message}", r)
        solve_time = time.perf_counter() - t0
        fine_work = r.factorizations
        direction = -1 if _branch_of(r) == "curvature-dominated" else 1
        notes, located, curve = [], None, None
        if trace_h > hmax:
            rc = solve(sheet, "curvature-first", trace_h, solver=solver, symmetric=symmetric,
                       on_failure="return", chain=chain)
            if rc.converged and _branch_of(rc) == _branch_of(r):
                curve = force_curve(rc.problem, rc.w, sheet.curvature, direction=direction,
                                    **common)
                if curve.shape == "one S":
                    located = _locate_on(r, curve, sheet.curvature, solver)
                    if located is None:
                        notes.append(f"the folds and states of the curve on hmax {trace_h:g} "
                                     f"could not all be located on hmax {hmax:g}: the curve "
                                     f"was traced on hmax {hmax:g}")
                else:
                    # not an S on the coarse mesh: is the sheet bistable on hmax?
                    rg = solve(sheet, "gravity-first", hmax, layers=layers, solver=solver,
                               symmetric=symmetric, on_failure="return", chain=chain)
                    fine_work += rg.factorizations
                    if rg.converged and _separation(r, rg) <= SAME_TOL:
                        located = _locate_on(r, curve, sheet.curvature, solver, partial=True)
                        notes.append(f"the curve on hmax {trace_h:g} is not one S "
                                     f"({curve.shape}), and on hmax {hmax:g} both load paths "
                                     f"reach one state")
                    else:
                        notes.append(f"the curve on hmax {trace_h:g} is not one S "
                                     f"({curve.shape}) but on hmax {hmax:g} the load paths "
                                     f"reach two states: the curve was traced on hmax "
                                     f"{hmax:g}")
            else:
                notes.append(f"on hmax {trace_h:g} the curvature-first solve "
                             + ("failed" if not rc.converged else
                                f"ended on the {_branch_of(rc)} state")
                             + f": the curve was traced on hmax {hmax:g}")
        if located is None:
            curve = force_curve(r.problem, r.w, sheet.curvature, direction=direction, **common)
            located = _from_curve(curve)
    finally:
        if bar is not None:
            bar.close()
    notes += located["notes"] + list(curve.notes)
    out = _assemble(sheet, hmax, r, curve, located, direction, notes, si)
    return replace(out, factorizations=fine_work + located["factorizations"],
                   wall_time_s=time.perf_counter() - t0, solve_wall_time_s=solve_time)


def _separation(a: Result, b: Result) -> float:
    """Largest distance between a node's deformed positions in two end states
    on one mesh (base widths; :data:`~skfem_sheet.states.SAME_TOL` tells one
    state from two)."""
    ua, ub = a.displacement, b.displacement
    if ua.shape != ub.shape:
        return math.inf
    return float(np.linalg.norm(ua - ub, axis=1).max())


class _Progress:
    def __init__(self, sheet):
        from tqdm.auto import tqdm

        self.bar = tqdm(desc=f"switching L={sheet.length:g} b={sheet.tip_width:g} "
                        f"a/R={sheet.curvature:g}", unit="pt", leave=False)

    def __call__(self, F, d):
        self.bar.update(1)
        self.bar.set_postfix_str(f"F {F:+.3g}, d/a {d:.3f}", refresh=True)

    def close(self):
        self.bar.close()


def _from_curve(curve: ForceCurve) -> dict:
    """The folds and states at F = 0 of a curve traced on the answer's mesh."""
    return {"folds": curve.folds, "saddle": curve.point("saddle"), "end": curve.point("end"),
            "start": curve.points[0], "states": curve.states, "notes": [],
            "factorizations": curve.factorizations}


def _locate_on(r: Result, curve: ForceCurve, curvature, solver, partial: bool = False):
    """The coarse curve's folds, saddle and end state carried to the mesh of
    the solve ``r`` and located there (the folds on the branch from the
    carried fold state and null vector, the states at F = 0 by Newton): the
    located points, or None where one fails or lands elsewhere (a fold on
    the other side of F = 0, a saddle without its one negative eigenvalue, an
    end state that is not stable).  ``partial``: the folds that fail are left
    out (with a note) instead."""
    fine = r.problem
    sheet = fine.sheet
    tr = _Tracer(fine, curvature, 1.0, solver, FORCE_UNIT * sheet.area * sheet.thickness)
    P = tr.P
    coarse = curve.problem
    start = tr.at_zero(r.w[P.free])
    if start is None:
        return None
    out = {"start": tr.point(start[0], 0.0, start[1], "start"),
           "states": {"start": P.full(start[0], [0.0])}, "notes": []}
    folds = []
    for n, cp in enumerate(curve.folds, 1):
        name = f"fold {n}"
        w = transfer(coarse, curve.states[name], fine)
        vc = np.zeros(coarse.ndof)
        vc[coarse.free] = curve.null_vectors[name]
        v = transfer(coarse, vc, fine)[fine.free]
        fold = tr.fold(w[fine.free], cp.force, v)
        if fold is None or np.sign(fold.value) != np.sign(cp.force):
            if not partial:
                return None
            out["notes"].append(f"the fold at F = {cp.force:.6g} on hmax {curve.hmax:g} was "
                                f"not located on hmax {fine.sheet_mesh.hmax:g}")
            continue
        folds.append(tr.fold_point(fold))
        out["states"][name] = P.full(fold.u, fold.p)
    for kind, want in (("saddle", 1), ("end", 0)):
        if kind not in curve.states:
            continue
        w = transfer(coarse, curve.states[kind], fine)
        w[fine.clamp_dofs] = fine.clamp_values(curvature)
        found = tr.at_zero(w[fine.free])
        if found is None:
            return None
        cp = tr.point(found[0], 0.0, found[1], kind)
        if cp.negative_eigenvalues is not None and cp.negative_eigenvalues != want:
            return None
        out[kind] = cp
        out["states"][kind] = P.full(found[0], [0.0])
    out["folds"] = tuple(folds)
    out["factorizations"] = int(tr.counter.stats().factorizations)
    return out


def _assemble(sheet, hmax, r, curve, located, direction, notes, si) -> Switching:
    """The Switching of the located points (on the mesh ``hmax``) and the curve."""
    weight = float(sheet.area * sheet.thickness)
    start, saddle, end = located["start"], located.get("saddle"), located.get("end")
    folds = located["folds"]
    states = located["states"]
    bistable = bool(curve.shape == "one S" and saddle is not None and end is not None
                    and saddle.negative_eigenvalues == 1 and end.stable and start.stable)
    nan = math.nan
    fd = fu = fdd = fud = nan
    aloft, drooped = (start, end) if direction < 0 else (end, start)
    aloft_state, drooped_state = ((states.get("start"), states.get("end")) if direction < 0
                                  else (states.get("end"), states.get("start")))
    for f in folds:
        if f.force < 0 and not np.isfinite(fd):
            fd, fdd = f.force, f.deflection
        elif f.force > 0 and not np.isfinite(fu):
            fu, fud = f.force, f.deflection
    if bistable:
        what = (f"two states at F = 0 (bistable): aloft d/a {aloft.deflection:.5f}, drooped "
                f"d/a {drooped.deflection:.5f}, the saddle between them at d/a "
                f"{saddle.deflection:.5f}")
        bd = saddle.energy - aloft.energy
        bu = saddle.energy - drooped.energy
        sd, se, sk = saddle.deflection, saddle.energy, saddle.negative_eigenvalues
    else:
        name = _branch_of(r)
        word = "aloft" if name == "curvature-dominated" else "drooped"
        what = f"one state at F = 0: {name} ({word}), d/a {r.deflection:.5f}: no switching"
        if folds:
            what += (f"; under load the curve has {len(folds)} fold(s) in F ("
                     + ", ".join(f"{f.force:+.4g}" for f in folds) + f"): {curve.shape}")
        else:
            side = "pushed down" if direction < 0 else "pulled up"
            what += (f"; {side} to F = {curve.forces[np.argmax(np.abs(curve.forces))]:+.4g} "
                     f"({curve.reason or 'the end of the trace'}) without a fold")
        bd = bu = sd = se = nan
        sk = None
        if direction < 0:
            drooped = None
            drooped_state = None
        else:
            aloft = None
            aloft_state = None
    # the barriers on the curve's own mesh and the work along it
    wd = wu = cbd = cbu = nan
    cs, cz, ce = curve.points[0], curve.point("saddle"), curve.point("end")
    if cz is not None:
        first = "start"
        w1 = curve.work(first, "saddle")
        b1 = cz.energy - cs.energy
        if ce is not None:
            w2 = curve.work("end", "saddle")
            b2 = cz.energy - ce.energy
        else:
            w2 = b2 = nan
        (wd, cbd, wu, cbu) = (w1, b1, w2, b2) if direction < 0 else (w2, b2, w1, b1)
    return Switching(
        sheet=sheet, hmax=float(hmax), bistable=bistable, states=what,
        force_down=fd, force_up=fu, fold_down_deflection=fdd, fold_up_deflection=fud,
        barrier_down=bd, barrier_up=bu, saddle_deflection=sd, saddle_energy=se,
        saddle_negative_eigenvalues=sk,
        aloft_deflection=nan if aloft is None else aloft.deflection,
        aloft_energy=nan if aloft is None else aloft.energy,
        drooped_deflection=nan if drooped is None else drooped.deflection,
        drooped_energy=nan if drooped is None else drooped.energy,
        weight=weight, shape=curve.shape, notes=tuple(notes), curve=curve,
        work_down=wd, work_up=wu, curve_barrier_down=cbd, curve_barrier_up=cbu, si=si,
        problem=r.problem, saddle_state=states.get("saddle") if bistable else None,
        aloft_state=aloft_state, drooped_state=drooped_state)


# -----------------------------------------------------------------------------
# the force-controlled solve
# -----------------------------------------------------------------------------
@dataclass(frozen=True)
class TipForceRamp:
    """A solved sheet under a tip force ramped from zero (:func:`apply_tip_force`).

    Attributes
    ----------
    force : float
        The tip force reached (``rho g a^3``).
    converged : bool
        The force was reached on a stable equilibrium.
    reason : str
    start_deflection, deflection : float
        d/a of the start state (F = 0) and of the end state (at ``force``).
    tip_displacement : float
        ``w_tip`` at the end.
    stable : bool or None
    negative_eigenvalues : int or None
    snaps : tuple of Snap
        One per fold met on the way (``phase`` ``"tip force"``, ``load`` the
        fold's F), the sheet landing on the stable state at that force.
    factorizations : int
        Every factorisation of the ramp, the snaps and the end state's verdict.
    problem : SheetProblem
        The sheet with the tip force ``force``.
    w : ndarray
        The end state.
    """

    force: float
    converged: bool
    reason: str
    start_deflection: float
    deflection: float
    tip_displacement: float
    stable: object
    negative_eigenvalues: object
    snaps: tuple = ()
    factorizations: int = 0
    problem: object = field(default=None, repr=False)
    w: object = field(default=None, repr=False)

    @property
    def snapped(self) -> bool:
        return bool(self.snaps)


def apply_tip_force(result: Result, force: float, *, solver: str = "auto",
                    newton_options: NewtonOptions | None = None,
                    step_options: StepOptions | None = None) -> TipForceRamp:
    """The force-controlled solve: ramp the tip force from 0 to ``force`` on
    the end state of a solve.

    The load paths' ramp (:func:`skfem_sheet.engine.ramp`) in F at full
    load; at a fold the sheet snaps as on a load path
    (:func:`~skfem_sheet.continuation.snap_from_fold`) and the ramp goes on.

    Parameters
    ----------
    result : Result
        A converged solve (its state at F = 0, its mesh).
    force : float
        The tip force (``rho g a^3``, positive upward).
    solver : str
    newton_options : NewtonOptions, optional
    step_options : StepOptions, optional
        The snap's settle (its corrector distance and intermediate tolerance).

    Returns
    -------
    TipForceRamp

    Examples
    --------
    >>> r = solve(Sheet(length=0.6, curvature=1.0), hmax=0.25)
    >>> out = apply_tip_force(r, -0.002)
    >>> out.converged, out.snapped, out.deflection > r.deflection
    (True, False, True)
    """
    if not isinstance(result, Result) or not result.converged or result.problem is None:
        raise ParameterError("result must be a converged Result of skfem_sheet.solve")
    force = float(check_range("force", force, -1e6, 1e6))
    newton_options = newton_options or NewtonOptions()
    step_options = step_options or StepOptions()
    problem = result.problem.with_tip_force(0.0)
    _ = problem.tip_load  # a sheet without a tip face is refused here
    kappa, g = float(result.kappa), float(result.gravity)
    linear = make_linear_solver(solver)
    if getattr(linear, "needs_layout", False):
        linear.attach(problem.saddle_point_layout())
    stats = Stats()
    P = SheetForceProblem(problem, linear, kappa, g, stats)
    counter = Counting(P)
    size = max(1.0, problem.sheet.length)
    # steps in the sheet's arclength norm (displacements; F adds little):
    # a hundredth of the sheet's size to start, the corrector distance of
    # the load paths' points
    rule = StepRule(initial=0.01 * size, minimum=1e-5 * size, maximum=0.1 * size,
                    delta=0.2 * step_options.corrector_distance * size)
    tight = newton_tolerances(newton_options)
    loose = newton_tolerances(newton_options, 0.1 * rule.delta)
    u, F, snaps, reason = result.w[P.free], 0.0, [], ""
    held = None
    while True:
        b = ramp(counter, u, [F], 0, force, rule=rule, tol=loose, end_tol=tight,
                 start=held, fold_tol=FOLD_TOLERANCE)
        if b.points:
            u, F = b.points[-1].u, float(b.points[-1].p[0])
        if b.completed:
            break
        if b.fold is None:
            reason = f"the ramp stopped at F = {F:.6g}: {b.reason}"
            break
        fold = b.fold
        at = SheetLoadProblem(problem.with_tip_force(fold.value), linear, stats, newton_options)
        phase = LoadPhase(at, (kappa, g), (kappa, g))  # the loads held, F the fold's
        found, why, _ = snap_from_fold(at, phase, "tip force", fold,
                                       newton_options=newton_options, step_options=step_options,
                                       negative_eigenvalues=fold.crossing or (None, None))
        if found is None:
            reason = f"the snap at the fold F = {fold.value:.6g} failed: {why}"
            break
        snaps.append(found.snap)
        u, F = found.landing[P.free], float(fold.value)
        held = None
        if len(snaps) > 8:
            reason = "more than 8 snaps"
            break
    end = problem.with_tip_force(F)
    w = P.full(u, [F])
    stable = k = None
    if not reason:
        # the verdict from the Hessian at the end state itself
        try:
            linear.factorize(end.tangent(w), w)
            stats.factorizations += 1
            stable, k = end_state_verdict(end, linear, w, stats)
        except LinearSolverError as err:
            reason = f"singular tangent at the end state ({err})"
        if stable is False:
            reason = f"ended on an unstable equilibrium ({k} negative eigenvalue(s))"
    return TipForceRamp(F, not reason, reason, float(result.deflection),
                        tip_deflection(end, w), end.tip_displacement(w), stable, k,
                        tuple(snaps), int(stats.factorizations), end, w)
