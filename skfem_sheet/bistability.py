"""Bistability: continuation in the sheet length, fold lengths located, the S-curve.

In the bistable range ``L0* < L < L1*`` a sheet has two stable equilibria
(paper, Figs. 2, 4, 6 and 7): the curvature-dominated one, which exists up to
the *standout length* ``L1*``, and the gravity-dominated one, down to the
*pop-up length* ``L0*``; with the unstable branch between them they form an
S-shaped curve ``d(L)`` whose folds are ``L0*`` and ``L1*``.

The length is a continuous parameter: a mesh made at ``L_m`` is stretched
in x to nearby lengths (:meth:`skfem_sheet.problem.SheetProblem.with_length`)
and remeshed beyond :data:`~skfem_sheet.sheet_shape.REMESH_STRETCH`, the state
interpolated (:func:`transfer`).  Every continuation runs on the engine's
drivers with the sheet as :class:`~skfem_sheet.sheet_shape.SheetShapeProblem`;
a branch's end is located with the minimally augmented fold system, never
bracketed by failed solves, and a branch that ends without a fold says why.
:func:`fold_lengths` locates each fold once more on a mesh made at it
(:func:`locate_on_mesh`).  Also here: :func:`follow_length`,
:func:`follow_curvature` (critical curvatures), :func:`s_curve` (through both
folds), :func:`fold_position` and :func:`stability`.
"""
from __future__ import annotations

import math
import numbers
import time
import warnings
from dataclasses import dataclass, field, replace

import numpy as np
from tqdm.auto import tqdm

from .analyses.mode import mode_of
from .analyses.stability import stability
from .analyses.transfer import transfer
from .continuation import StepOptions
from .engine import EngineFailure, Tolerances, arclength, correct, natural
from .engine.fold import fold_on_branch, inertia_crossing
from .engine.protocol import Counting
from .foldcurve.options import MESH_LENGTH_GRID
from .foldcurve.refine import settled_fold
from .newton import NewtonOptions, Stats
from .params import DEFAULT_HMAX, QUICK_HMAX, ParameterError, Sheet, check_range
from .sheet_shape import REMESH_STRETCH, TOLERANCES, SheetShapeProblem
from .solve import build_problem
from .starts import CoarseStart, Job
from .version import __version__

__all__ = ["BranchPoint", "Branch", "Fold", "FoldLengths", "FoldPosition",
           "SCurve", "FOLD_TOL", "TRACE_HMAX", "FOLD_CURVE_LEVELS", "FOLD_CURVE_POINTS",
           "fold_curve", "stability", "transfer", "follow_length",
           "follow_curvature", "fold_lengths", "fold_lengths_of", "fold_position", "fold_range",
           "locate_on_mesh", "s_curve", "trace_mesh"]

#: The folds of :func:`fold_lengths` are located to this in L/a (the fold
#: system's own tolerance on the load, ``ptol`` of
#: :func:`~skfem_sheet.engine.fold_on_branch`, relative to ``max(1, L)``: the
#: last section's remaining move towards the fold, whose prediction is
#: exact to second order, so that the error is far smaller): far below the
#: discretisation's effect on them (about 1e-3 a from hmax 0.06 to 0.03) and
#: the mesh's own (about 1e-4 a between two unstructured meshes of one size
#: at hmax 0.03, see :data:`~skfem_sheet.foldcurve.options.MESH_LENGTH_GRID`).
FOLD_TOL = 1e-6

#: The mesh on which :func:`fold_lengths` traces the branches where the
#: results' mesh is finer (coarse to fine, :func:`trace_mesh`): its folds are
#: then located again on the fine mesh, a few factorisations each.
TRACE_HMAX = QUICK_HMAX

#: Smallest step of a continuation in L or a/R: a step this short that fails
#: where no fold can be located ends the branch (``Branch.reason`` says why).
MIN_STEP = 0.005


def trace_mesh(hmax: float, coarse_hmax=None) -> float:
    """The mesh the branches of :func:`fold_lengths` are traced on for
    results on ``hmax``: ``coarse_hmax`` if given (coarser than ``hmax``;
    0 or ``hmax``: none, the results' mesh itself), else :data:`TRACE_HMAX`
    where ``hmax`` is finer, else ``hmax``.

    Examples
    --------
    >>> trace_mesh(0.03), trace_mesh(0.1), trace_mesh(0.2), trace_mesh(0.03, 0)
    (0.1, 0.1, 0.2, 0.03)
    """
    hmax = check_range("hmax", hmax, 0, None, lo_open=True)
    if coarse_hmax is None:
        return max(hmax, TRACE_HMAX)
    if coarse_hmax == 0 or coarse_hmax == hmax:
        return hmax
    return check_range("coarse_hmax", coarse_hmax, hmax, None, lo_open=True,
                       hint="a coarser mesh than hmax, or 0 for none")


def fold_range(length: float, lengths=None) -> tuple:
    """The range of L/a searched for the folds of a sheet of ``length``:
    ``lengths`` (checked to hold it), or 0.6 to 2.4 widened to hold it with a
    margin (0.8 and 1.25 times it).

    Examples
    --------
    >>> fold_range(1.375), fold_range(3.0), fold_range(1.3, (1.0, 1.7))
    ((0.6, 2.4), (0.6, 3.75), (1.0, 1.7))
    """
    if lengths is None:
        return (min(0.6, 0.8 * length), max(2.4, min(20.0, 1.25 * length)))
    try:
        lo, hi = (float(x) for x in lengths)
    except (TypeError, ValueError):
        raise ParameterError(f"lengths must be (short, long), got {lengths!r}") from None
    lo, hi = (check_range("lengths", x, 0.05, 20.0) for x in (lo, hi))
    if not lo < hi:
        raise ParameterError(f"lengths must be (short, long) with short < long, got {lengths!r}")
    if not lo <= length <= hi:
        raise ParameterError(f"lengths must hold the sheet's length {length:g}: "
                             f"short <= {length:g} <= long, got {lengths!r}")
    return lo, hi


@dataclass(frozen=True)
class BranchPoint:
    """One equilibrium at full load: length, tip deflection, stability, and (where
    asked for, ``names=True``) its name (:func:`skfem_sheet.analyses.mode.mode_of`:
    "curvature-dominated" or "gravity-dominated", as ``solve`` names it)."""

    length: float
    deflection: float
    stable: object  # bool or None (solver cannot tell)
    negative_eigenvalues: object = None
    newton_iterations: int = 0
    name: str = ""


class _Curve:
    """Arrays over the ``points`` (BranchPoint) of a continuation result."""

    @property
    def lengths(self):
        """Parameter values (lengths; curvatures for :func:`follow_curvature`)."""
        return np.array([p.length for p in self.points])

    @property
    def deflections(self):
        return np.array([p.deflection for p in self.points])

    @property
    def stable(self):
        return [p.stable for p in self.points]

    @property
    def names(self):
        """Each point's name ("" where not asked for)."""
        return [p.name for p in self.points]

    def write_series(self, directory, name, series) -> str:
        """Write the states of this curve as a ParaView series, ``directory/name.pvd``.

        ``series`` is the :class:`skfem_sheet.io.Series` passed as ``on_point``
        (its :meth:`~skfem_sheet.io.Series.on_point`) to the continuation that
        made this curve: one state per point.  Each VTU also holds the
        point's ``deflection`` and ``stable`` (1, 0, or -1 unknown) as field data.
        """
        if len(series) != len(self.points) or not np.allclose(
                [f.time for f in series.frames], self.lengths, rtol=0, atol=1e-12):
            raise ParameterError(f"series must hold one state per point of this curve "
                                 f"({len(self.points)}), got {len(series)} that do not match")
        data = [{"deflection": p.deflection, "stable": -1 if p.stable is None else int(p.stable)}
                for p in self.points]
        return series.write(directory, name, data=data)


@dataclass(frozen=True)
class Branch(_Curve):
    """Result of :func:`follow_length` (and :func:`follow_curvature`).

    Attributes
    ----------
    points : tuple of BranchPoint
        The converged equilibria, in the order of the continuation.
    fold : float or None
        The parameter value (length, or curvature) of the fold where the
        branch ends, located with the minimally augmented system; None if
        the branch held over the whole range, or ended without a located
        fold (``reason`` says why).
    bracket : tuple
        ``(last value on the branch, the value of the step that failed)``
        where the branch ended short of its range (a fold or not).
    reason : str
        Why the continuation ended short of its range ("" if it did not).
    start_snapped : bool
        The starting solve (along its load path) snapped to the other
        branch: the branch the path selects does not exist at the start
        length, and the points are on the other one.
    fold_deflection : float
        d/a at the fold (NaN without one).
    fold_point : FoldPoint or None
        The located fold (:class:`skfem_sheet.engine.FoldPoint`: state,
        parameter, null vector) on ``problem``, the continuation's problem
        (its mesh at the fold); dropped from the branches :func:`fold_lengths`
        returns.
    """

    points: tuple
    fold: object = None
    bracket: tuple = ()
    reason: str = ""
    newton_iterations: int = 0
    wall_time_s: float = 0.0
    start_snapped: bool = False
    fold_deflection: float = math.nan
    fold_point: object = field(default=None, repr=False, compare=False)
    problem: object = field(default=None, repr=False, compare=False)

    def without_states(self) -> Branch:
        """The branch without its fold's state and problem (memory)."""
        return replace(self, fold_point=None, problem=None)

    def summary(self) -> dict:
        """JSON-ready: the points, the fold and why the branch ended."""
        return {"lengths": self.lengths.tolist(), "deflection": self.deflections.tolist(),
                "stable": self.stable, "fold": self.fold,
                "fold_deflection": self.fold_deflection, "bracket": list(self.bracket),
                "reason": self.reason, "start_snapped": self.start_snapped,
                "newton_iterations": self.newton_iterations, "wall_time_s": self.wall_time_s}


# ----------------------------------------------------------------------------
# the sheet as an engine problem in one parameter (L or a/R)
# ----------------------------------------------------------------------------
def _branch_problem(sheet, name, hmax, layers, solver, symmetric):
    """The sheet at full load as an engine problem in ``name`` ("L" or
    "a/R"), on its mesh stretched in x (remeshed by the remesh rule)."""
    return SheetShapeProblem(sheet, hmax, parameters=(name,), geometry="stretch",
                             layers=layers, half=symmetric, solver=solver, cache=5)


#: The sheet's Newton options (:class:`skfem_sheet.newton.NewtonOptions`) as
#: the engine's stopping rule: the residual relative to the weight, the
#: largest displacement correction (see :func:`_chord_linearization`).
_OPTIONS = NewtonOptions()


def _tolerances(max_correction=np.inf, pair_contraction=False):
    # linearisations: the factorisations, the chord steps after them (see
    # _chord_linearization: each at least halves a correction already below
    # utol), and the last one, which only confirms.  pair_contraction (for the
    # continuation's steps, not for a state carried to a new mesh, which is
    # near its equilibrium however slowly Newton gets there): a step
    # past a fold, where no equilibrium is near, is given up once a
    # correction outgrows the one two linearisations before (at the 3rd or
    # 4th instead of the 9th on the rectangle at a/R 2.5, where the rows'
    # failed steps were a third of the fine work; converging steps shrink
    # pairwise, a third correction at most 0.23 times the first)
    return Tolerances(rtol=_OPTIONS.rtol, utol=_OPTIONS.utol,
                      max_iterations=2 * _OPTIONS.max_iterations + 1,
                      max_halvings=_OPTIONS.max_halvings, max_correction=max_correction,
                      pair_contraction=pair_contraction)


def _chord_linearization(counter, max_factorizations=_OPTIONS.max_iterations):
    """Newton steps with the sheet's stopping rule (:func:`skfem_sheet.newton.newton`),
    the last factorisation reused for the residual left once the state has converged.

    After the first iterate the correction is first computed with the last
    factorisation.  Residual below ``rtol`` and correction below ``utol``: the
    iterate is returned.  Correction below ``utol`` and at most half the last
    one, residual above ``rtol``: it is taken as it is (a chord step; a thin
    sheet that close to its equilibrium still has membrane residuals that the
    factorisation at hand removes as well as a new one: ``docs/decisions.md``,
    "Chord steps").  Otherwise the tangent is factorised at the iterate, at most
    ``max_factorizations`` times per correction.
    """
    state = {"fact": None, "n": 0, "last": None}
    tol = _OPTIONS

    def linearize(u, p):
        r = counter.residual(u, p)
        if not np.all(np.isfinite(r)):
            raise EngineFailure("inverted element or NaN in the residual")
        rn = counter.residual_norm(r)
        if state["fact"] is not None:
            du = state["fact"].solve(-r)
            dn = counter.correction_norm(du)
            if rn <= tol.rtol and dn <= tol.utol:
                # converged at this iterate: it is returned as it is (the
                # estimate ``du`` of the remaining error, below utol, is not
                # applied), as skfem_sheet.newton.newton does, so that the
                # sheet's continuations give that Newton's numbers
                return rn, np.zeros_like(du), np.zeros_like(p), state["fact"], None
            if dn <= tol.utol and dn <= 0.5 * state["last"]:
                state["last"] = dn
                return rn, du, np.zeros_like(p), state["fact"], None
        if state["n"] >= max_factorizations:
            raise EngineFailure("max iterations")
        J = counter.jacobian(u, p)
        fact = counter.factorize(J)
        du = fact.solve(-r)
        state["fact"], state["n"], state["last"] = fact, state["n"] + 1, counter.correction_norm(du)
        return rn, du, np.zeros_like(p), fact, J
    return linearize


def _check_common(sheet, hmax, step):
    if not isinstance(sheet, Sheet):
        raise ParameterError(f"sheet must be a skfem_sheet.Sheet, got {type(sheet).__name__}")
    check_range("hmax", hmax, 0, None, lo_open=True)
    check_range("step", step, MIN_STEP, 1)


def _min_step(tol, min_step):
    """``min_step``, or the deprecated ``tol`` (the half-width of the old
    bisection's bracket) in its place, with a warning."""
    if tol is not None:
        warnings.warn("tol is deprecated: folds are located, not bracketed; pass min_step "
                      "(the shortest step tried before a branch is given up)",
                      DeprecationWarning, stacklevel=3)
        if min_step is None:
            min_step = tol
    return MIN_STEP if min_step is None else check_range("min_step", min_step, 0, 1,
                                                        lo_open=True)


def follow_length(sheet: Sheet, stop: float, *, path: str = "curvature-first",
                  hmax: float = DEFAULT_HMAX, layers=None, solver: str = "auto",
                  symmetric: bool = True, step: float = 0.1, min_step=None, jump: float = 0.1,
                  progress=None, on_point=None, start=None, tol=None) -> Branch:
    """Follow the branch selected by ``path`` at ``sheet.length`` to ``stop``.

    Natural continuation in L at full load.  A step fails if Newton does not
    converge, the equilibrium is unstable, or the deflection jumps by more
    than ``jump``; the fold is then located along the branch from the last
    equilibrium (:func:`_branch_end`) and ends the branch if it lies within
    the failed step, else the step is halved, down to ``min_step``.

    Parameters
    ----------
    sheet : Sheet
        Start: its length, planform, curvature and material.
    stop : float
        Length at which to stop if the branch holds (above or below the start).
    path : {"curvature-first", "gravity-first"}
        Load path of the starting solve (selects the branch).
    step : float
        Largest length step.
    min_step : float
        Shortest step tried (default :data:`MIN_STEP`): a step this short
        that fails where no fold is located ends the branch, with the reason.
    on_point : callable(problem, w, length) or None
        Called with the state of each point of the branch (e.g.
        ``skfem_sheet.io.Series().on_point``, then ``Branch.write_series``).
    start : start strategy, optional
        How the sheet at the start is solved: None, the load path on this
        mesh; or one of :func:`~skfem_sheet.solve.solve`'s strategies.
    tol : float
        Deprecated: read as ``min_step``.

    Returns
    -------
    Branch
        ``fold``: the located fold on the continuation's mesh (stretched by
        up to :data:`~skfem_sheet.sheet_shape.REMESH_STRETCH` from where it
        was made; :func:`fold_lengths` locates it again on a mesh made at it).

    Examples
    --------
    >>> b = follow_length(Sheet(length=0.5, curvature=2.5), 0.7, hmax=0.15, step=0.1)
    >>> b.fold is None, len(b.points)
    (True, 3)
    """
    return _follow("L", sheet, stop, path=path, hmax=hmax, layers=layers,
                   solver=solver, symmetric=symmetric, step=step,
                   min_step=_min_step(tol, min_step), jump=jump, progress=progress,
                   on_point=on_point, start=start)


def follow_curvature(sheet: Sheet, stop: float, *, path: str = "gravity-first",
                     hmax: float = DEFAULT_HMAX, layers=None, solver: str = "auto",
                     symmetric: bool = True, step: float = 0.25, min_step=None,
                     jump: float = 0.1, progress=None, on_point=None, tol=None) -> Branch:
    """Follow a branch in the clamp curvature a/R at fixed length, to ``stop``.

    The same natural continuation as :func:`follow_length`, with the clamp
    curvature as the parameter (the clamped values change; the mesh does
    not, so the fold located is the fold on this mesh).  From the
    gravity-dominated state at a small curvature, increasing a/R finds where
    it pops up (``1/R0*``); from the curvature-dominated state at a large
    curvature, decreasing a/R finds where it falls (``1/R1*``).
    ``Branch.fold`` and the branch points' ``length`` field then hold
    curvatures.

    Examples
    --------
    >>> b = follow_curvature(Sheet(length=0.6, curvature=1.0), 1.5, hmax=0.15, step=0.25)
    >>> b.fold is None, len(b.points)
    (True, 3)
    """
    return _follow("a/R", sheet, stop, path=path, hmax=hmax,
                   layers=layers, solver=solver, symmetric=symmetric, step=step,
                   min_step=_min_step(tol, min_step), jump=jump, progress=progress,
                   on_point=on_point)


#: Allowed range of the end ``stop`` of a continuation in L and in a/R (:func:`_follow`).
_STOP_RANGE = {"L": dict(lo=0.05, hi=20.0), "a/R": dict(lo=0.0, hi=2 * np.pi, hi_open=True)}


#: How far along the branch (in the section coordinate of
#: :func:`~skfem_sheet.engine.fold_on_branch`, units of a) the end of a
#: continuation is looked for from its last equilibrium: the state moves by at
#: most a few tenths of a between an equilibrium a step before a fold and
#: the fold.
_END_REACH = 0.5


def _branch_end(direction, ahead):
    """The locator of a continuation's end (``natural``'s ``locate``) in the
    direction ``direction`` (+1: the parameter increases): the fold where a step
    failed, followed along the branch from the last equilibrium
    (:func:`~skfem_sheet.engine.fold_on_branch`, the load to :data:`FOLD_TOL`),
    or None.

    Along the branch, not by Newton on the whole fold system, which leaves a
    thin sheet's strongly curved branch at its first step.  First, without a
    factorisation, the branch's quadratic model (``u' = dw/dp``, ``K u'' =
    -D^2 R[t, t]``, the section coordinate ``c = <v, u>`` along ``v = u'/|u'|``)
    puts the vertex of ``p(c)`` ``c'/(2 c'')`` away; where it lies behind or
    further than ``ahead``, the step failed for another reason and no search is
    made (but at the last try before the branch is given up).
    """
    def locate(counter, u, p, i, dudp, fact, last_try):
        if fact is not None and not last_try:  # the last try searches whatever the model says
            try:
                e = counter.fd_state_step ** 0.5 * max(1.0, abs(float(p[i])))
                e /= max(1.0, float(np.abs(dudp).max()))
                pp, pm = p.copy(), p.copy()
                pp[i] += e
                pm[i] -= e
                q = (counter.residual(u + e * dudp, pp) - 2.0 * counter.residual(u, p)
                     + counter.residual(u - e * dudp, pm)) / e**2
                u2 = fact.solve(-q)
                c1 = float(np.sqrt(counter.inner(dudp, dudp)))
                c2 = float(counter.inner(dudp, u2)) / c1
            except EngineFailure:
                c2 = math.nan
            if np.isfinite(c2) and c2 != 0:
                to_fold = c1 / (2.0 * c2)
                if not 0 < to_fold * direction <= ahead:
                    return None
        fold, _ = fold_on_branch(counter, u, p, i, dudp, tol=TOLERANCES, ptol=FOLD_TOL,
                                 reach=_END_REACH)
        return fold
    return locate


def _follow(name, sheet, stop, *, path, hmax, layers, solver, symmetric, step, jump,
            progress, min_step=MIN_STEP, on_point=None, start=None, record=None, guide=None,
            twin=None, locate=True, names=False):
    """Natural continuation in ``name`` ("L" or "a/R") to ``stop``, its end
    located (see :func:`follow_length`), on :func:`skfem_sheet.engine.natural`
    (in L remeshed, the state transferred, before a step beyond the stretch
    limit; ``stop`` checked against :data:`_STOP_RANGE`).

    ``start``: how the first point (and a remeshed state that Newton cannot
    finish) is reached (:func:`_along_path`).  ``record``: a list to append each
    point's :class:`_GuidePoint` to.  ``guide``: those points of the same branch
    on a coarser mesh (:class:`_Guide`; in L only).  ``twin``: ``(problem, w)``,
    an equilibrium at the start on another mesh; if Newton from it lands on the
    start state, both continuations trace one branch and a :class:`_SameBranch`
    is returned instead.  ``locate`` False: no fold is looked for.  ``names``
    (in L): each point named as ``solve`` names a state
    (:func:`~skfem_sheet.analyses.mode.mode_of`).
    """
    _check_common(sheet, hmax, step)
    stop = check_range("stop", stop, **_STOP_RANGE[name])
    min_step = min(float(min_step), float(step))
    t0 = time.perf_counter()
    stats = Stats()
    P = _branch_problem(sheet, name, hmax, layers, solver, symmetric)
    counter = Counting(P)
    p0 = np.array([sheet.length if name == "L" else sheet.curvature])
    out = _along_path(P, p0, path, stats, start)
    if not out.converged:
        raise ParameterError(f"the starting sheet (length {sheet.length:g}, a/R "
                             f"{sheet.curvature:g}) could not be solved along {path}: {out.reason}")
    if twin is not None and not out.snaps and _same_state(P, counter, p0, out.w, *twin):
        return _SameBranch(stats.newton_iterations + counter.stats().factorizations)
    guard = 0.25 * max(1.0, sheet.length)
    points, accepted = [], {}

    def check(u, p, res):
        st, k = _stability_of(res.factorization)
        d = P.deflection(u, p)
        accepted[id(res)] = (d, st, k)
        if st is False:
            return f"unstable equilibrium ({k} negative eigenvalues)"
        if abs(d - points[-1].deflection) > jump:
            return f"deflection jumped from {points[-1].deflection:.4g} to {d:.4g}"
        return ""

    def on_step(pt, res):
        if points:
            d, st, k = accepted.pop(id(res))
            its = res.stats.factorizations
        else:
            st, k = _stability_of(res.factorization)
            d, its = P.deflection(pt.u, pt.p), stats.newton_iterations
        accepted.clear()
        label = ""
        if names and name == "L":
            label = mode_of(P.problem(pt.p), P.full(pt.u, pt.p), 1.0,
                            linear=res.factorization).name
        points.append(BranchPoint(float(pt.p[0]), d, st, k, its, label))
        if on_point is not None:
            on_point(P.problem(pt.p), P.full(pt.u, pt.p), float(pt.p[0]))
        if record is not None:
            rate = np.zeros(P.base.ndof)
            rate[P.free] = res.factorization.solve(-counter.dresidual(pt.u, pt.p, 0))
            record.append(_GuidePoint(float(pt.p[0]), P.base, P.full(pt.u, pt.p), rate))

    def before_step(u, p, value, fact):
        if name != "L" or not P.needs_remesh([value]):
            return None
        moved = _remeshed(P, counter, u, p, path, stats, start)
        d_here = P.deflection(moved[0], p) if moved is not None else np.nan
        if not abs(d_here - points[-1].deflection) <= jump:
            raise EngineFailure(
                f"remeshing at L = {p[0]:.4g} failed" if moved is None else
                f"remeshing at L = {p[0]:.4g} landed on another branch "
                f"(d = {d_here:.4g} instead of {points[-1].deflection:.4g})")
        return moved

    # a step grows only after an easy correction (at most 3 linearisations): one
    # that needed more came near the edge of Newton's basin, and the longer step
    # after it would fail (on a drooped, hanging branch, one step in three)
    b = natural(counter, out.w[P.free], p0, 0, stop, step=step, min_step=min_step,
                tol=_tolerances(guard, pair_contraction=True),
                locate=(_branch_end(1.0 if stop >= p0[0] else -1.0, 4 * step) if locate
                        else False),
                inertia_change=False, grow_after=3, check=check, before_step=before_step,
                on_step=on_step, keep_states=False, linearization=_chord_linearization,
                progress=progress, start=(out.w[P.free], P.held(out.w[P.free], p0)),
                guide=_Guide(guide, P) if guide and name == "L" else None)
    fold = b.fold
    nits = stats.newton_iterations + b.stats.factorizations
    return Branch(tuple(points), None if fold is None else fold.value, tuple(b.bracket),
                  b.reason, nits, time.perf_counter() - t0, start_snapped=len(out.snaps) > 0,
                  fold_deflection=(math.nan if fold is None else P.deflection(fold.u, fold.p)),
                  fold_point=fold, problem=None if fold is None else P)


def _along_path(P, p, path, stats, start=None):
    """The sheet of ``P`` at ``p`` at full load along ``path``, on ``P``'s
    solver (check ``converged``; ``w``, ``snaps``, ``reason``), which then
    holds the tangent at the end state (:meth:`~SheetShapeProblem.held`):
    the load path on ``P``'s mesh (``start`` None,
    :meth:`~skfem_sheet.sheet_shape.SheetShapeProblem.along_path`), or a
    start strategy of :func:`~skfem_sheet.solve.solve` (e.g.
    :class:`~skfem_sheet.starts.CoarseStart`: the path on a coarse mesh of
    the sheet at ``p``, made afresh, its folds and end state carried to
    ``P``'s mesh)."""
    if start is None:
        return P.along_path(p, path, stats)
    prob = P.problem(p)
    job = Job(problem=prob, path=path, kappa=P.kappa(p), gravity=1.0, linear=P.solver,
              solver=P.solver_name, newton_options=NewtonOptions(), step_options=StepOptions(),
              stats=stats, build=lambda h: build_problem(prob.sheet, h, None,
                                                         prob.quadrature_order, P.half))
    out = start.reach(job)
    P.solver_used()
    return out


@dataclass(frozen=True)
class _SameBranch:
    """What :func:`_follow` returns where its start lies on its twin's branch."""

    newton_iterations: int


def _same_state(P, counter, p, w, other, w_other) -> bool:
    """Whether the equilibrium ``w`` of ``P`` at ``p`` is the equilibrium
    ``w_other`` of the problem ``other`` (another mesh of the same sheet):
    Newton from ``w_other`` carried onto ``P`` converges to within ten
    times Newton's tolerance of ``w`` (two distinct equilibria of a sheet
    are O(0.1 a) apart; the carried state is off by the two meshes'
    difference, which Newton removes).  Costs the factorisations of that
    Newton solve."""
    u0 = transfer(other, w_other, P.problem(p))[P.free]
    res = correct(counter, u0, np.asarray(p, dtype=float), _chord_linearization(counter),
                  _tolerances())
    return bool(res.converged and
                counter.correction_norm(res.u - w[P.free]) <= 10 * _OPTIONS.utol)


@dataclass(frozen=True)
class _GuidePoint:
    """One point of a branch in L kept to guide a finer mesh's: its length,
    the mesh's problem at the length it was made for (``base``), the full
    state and ``dw/dL`` (zero on the clamp, whose values do not depend on L)."""

    length: float
    base: object
    w: np.ndarray
    rate: np.ndarray


class _Guide:
    """The coarse branch's second-order part as the correction of the fine
    continuation's prediction (:func:`~skfem_sheet.engine.natural`'s ``guide``).

    Where ``L0`` and ``L1`` are points of the coarse branch on one coarse mesh,
    the coarse curvature term ``w_c(L1) - w_c(L0) - (L1 - L0) w_c'(L0)``,
    interpolated onto the fine mesh, is added to the tangent prediction: its
    error is then the difference of the two meshes' curvature terms
    (``docs/decisions.md``, "A guided fine branch").  Elsewhere no correction.
    """

    def __init__(self, points, fine):
        self.points = tuple(points)
        self.lengths = np.array([g.length for g in self.points])
        self.fine = fine

    def _at(self, length):
        k = np.flatnonzero(np.abs(self.lengths - length) <= 1e-9 * max(1.0, abs(length)))
        return self.points[int(k[0])] if k.size else None

    def __call__(self, p_from, p_to):
        a, b = self._at(float(p_from[0])), self._at(float(p_to[0]))
        if a is None or b is None or a.base is not b.base:
            return None
        d = b.w - a.w - (b.length - a.length) * a.rate
        return transfer(a.base.with_length(b.length), d, self.fine.problem(p_to))[self.fine.free]


def _stability_of(fact):
    """``(stable, negative eigenvalues)`` of a factorisation of the branch problem
    (seen through the engine's counter)."""
    return getattr(fact, "fact", fact).stability()


def _remeshed(P, counter, u, p, path, stats, start=None):
    """A fresh mesh at the current length: ``(u, factorisation)`` there, or None.

    The state is interpolated onto the new mesh and re-converged (engine
    corrector).  An interpolated thin-sheet state is not exactly
    incompressible on the new mesh, and Newton may need many iterations from
    it; if it fails, the new mesh is solved afresh along the branch's own
    load path (which selects the same branch inside the bistable range; the
    caller checks the deflection for continuity).
    """
    u_new = P.remesh(u, p)
    res = correct(counter, u_new, p, _chord_linearization(counter), _tolerances())
    if res.converged:
        return res.u, res.factorization
    out = _along_path(P, p, path, stats, start)
    if not out.converged:
        return None
    return out.w[P.free], P.held(out.w[P.free], p)


#: The kind of fold at the end of each branch, and the side its branch lies on
#: (:attr:`skfem_sheet.engine.FoldPoint.side`: the curvature-dominated branch
#: exists below ``L1*``, the gravity-dominated one above ``L0*``).
_KINDS = {"standout": ("curvature-dominated", -1), "popup": ("gravity-dominated", +1)}


@dataclass(frozen=True)
class Fold:
    """A fold length located on one mesh: the end of one stable branch.

    Attributes
    ----------
    kind : str
        ``"standout"`` (``L1*``: the curvature-dominated branch ends there,
        longer sheets have none) or ``"popup"`` (``L0*``: the
        gravity-dominated one ends there, shorter sheets have none).
    length : float
        ``L*/a``, located to :data:`FOLD_TOL`.
    deflection : float
        d/a at the fold.
    crossing : tuple or None
        ``(n-, n+)``: the negative eigenvalue counts of the tangent on both
        sides of the fold along its null vector.
    negative_eigenvalues : int or None
        Besides the critical one: 0 for a fold at the end of a stable branch.
    hmax : float
        The mesh it was located on ...
    mesh_length : float
        ... made at this length (on the grid
        :data:`~skfem_sheet.foldcurve.options.MESH_LENGTH_GRID`, next to the
        fold).
    factorizations : int
        Work of locating it on that mesh (the crossing's two included).
    point, problem
        The located fold (:class:`skfem_sheet.engine.FoldPoint`: state, null
        vector) and its :class:`~skfem_sheet.sheet_shape.SheetShapeProblem`,
        kept only with ``fold_lengths(..., keep_states=True)`` (the fold's
        sensitivities, :func:`skfem_sheet.calibration.fold_length_sensitivities`).

    Examples
    --------
    >>> f = Fold("standout", 1.3472, 0.105, (0, 1), 0, 0.1, 1.35, 5)
    >>> f.confirmed, f.branch
    (True, 'curvature-dominated')
    """

    kind: str
    length: float
    deflection: float
    crossing: object
    negative_eigenvalues: object
    hmax: float
    mesh_length: float
    factorizations: int = 0
    point: object = field(default=None, repr=False, compare=False)
    problem: object = field(default=None, repr=False, compare=False)

    @property
    def branch(self) -> str:
        """The branch that ends at this fold."""
        return _KINDS[self.kind][0]

    @property
    def confirmed(self):
        """Exactly one eigenvalue crosses zero at the fold (True), not (False),
        or unknown (None: the linear solver gives no inertia)."""
        if self.crossing is None:
            return None
        return abs(int(self.crossing[1]) - int(self.crossing[0])) == 1

    def to_json(self) -> dict:
        return {"kind": self.kind, "length": self.length, "deflection": self.deflection,
                "crossing": None if self.crossing is None else list(self.crossing),
                "confirmed": self.confirmed, "negative_eigenvalues": self.negative_eigenvalues,
                "hmax": self.hmax, "mesh_length": self.mesh_length,
                "factorizations": self.factorizations}


@dataclass(frozen=True)
class FoldPosition:
    """Where a length sits against the fold lengths of its planform and curvature.

    Attributes
    ----------
    length : float
        L/a.
    where : str
        ``"between"`` (both branches exist: two states), ``"below"`` (shorter
        than the pop-up length ``L0*``: only the curvature-dominated state),
        ``"above"`` (longer than the standout length ``L1*``: only the
        gravity-dominated state), ``"at a fold"`` (within :data:`FOLD_TOL`
        of one), ``"one branch"`` (a flat clamp: both paths are one problem;
        or no fold at all: one state at every length) or ``"unknown"``
        (outside what the continuations covered).
    states : int or None
        Number of stable states at this length (2, 1, or None if unknown).
    text : str
        The verdict in words.
    """

    length: float
    where: str
    states: object
    text: str

    def to_json(self) -> dict:
        return {"length": self.length, "where": self.where, "states": self.states,
                "text": self.text}


def _exists(branch, length, fold, up):
    """Whether the branch of a continuation (from the short end if ``up``, else
    the long end) exists at ``length``: True, False, "fold" or None (unknown)."""
    if branch.start_snapped or not len(branch.points):
        return None
    if fold is not None and math.isfinite(fold):
        if abs(length - fold) <= FOLD_TOL * max(1.0, fold):
            return "fold"
        return (length < fold) if up else (length > fold)
    if branch.reason:  # lost without a fold, short of the range: known where it was followed
        covered = branch.lengths.max() if up else branch.lengths.min()
        return True if (length <= covered + 1e-12 if up else length >= covered - 1e-12) else None
    return True


def fold_position(folds: FoldLengths, length: float) -> FoldPosition:
    """Where ``length`` sits against the fold lengths ``folds``.

    Parameters
    ----------
    folds : FoldLengths
        From :func:`fold_lengths`.
    length : float
        L/a of a sheet of that planform, curvature and material.

    Examples
    --------
    >>> def branch(Ls, fold):
    ...     return Branch(tuple(BranchPoint(L, 0.1, True, 0, 3) for L in Ls), fold,
    ...                   reason="" if fold is None else "fold")
    >>> sheet = Sheet(length=1.3, curvature=2.5)
    >>> f = FoldLengths(sheet, 0.1, (0.6, 2.4),
    ...                 Fold("standout", 1.347, 0.1, (0, 1), 0, 0.1, 1.35),
    ...                 Fold("popup", 1.202, 0.3, (1, 0), 0, 0.1, 1.2),
    ...                 branch([0.6, 1.3], 1.347), branch([2.4, 1.21], 1.202), 0.1)
    >>> fold_position(f, 1.3).where, fold_position(f, 1.0).where, fold_position(f, 2).states
    ('between', 'below', 1)
    >>> print(fold_position(f, 1.0).text)
    L/a = 1 is below the pop-up length L0* = 1.20200: one state, curvature-dominated (aloft)
    """
    L = float(length)
    lo, hi = folds.length_range
    L0, L1 = folds.popup_length, folds.standout_length

    def fmt(name, x, end):
        return (f"{name} = {x:.5f}" if math.isfinite(x) else
                f"{name} not in [{lo:g}, {hi:g}] (the branch held to L/a = {end:g})")

    if folds.sheet.curvature == 0.0:
        return FoldPosition(L, "one branch", 1, f"a flat clamp (a/R = 0): one state at every "
                                                 f"length, L/a = {L:g} too")
    if not lo <= L <= hi:
        return FoldPosition(L, "unknown", None, f"L/a = {L:g} lies outside the lengths searched, "
                                                f"[{lo:g}, {hi:g}]")
    if folds.decreasing is folds.increasing and not math.isfinite(L1):
        return FoldPosition(L, "one branch", 1,
                            f"no fold in [{lo:g}, {hi:g}]: one state at every length (the "
                            f"curvature-first branch from L/a = {lo:g} is the gravity-first "
                            f"one from {hi:g}), L/a = {L:g} too")
    cd = _exists(folds.increasing, L, L1, up=True)
    gd = _exists(folds.decreasing, L, L0, up=False)
    if "fold" in (cd, gd):
        which = "standout length L1*" if cd == "fold" else "pop-up length L0*"
        x = L1 if cd == "fold" else L0
        return FoldPosition(L, "at a fold", None,
                            f"L/a = {L:g} is within {FOLD_TOL:g} of the {which} = {x:.5f}: at "
                            f"the fold, where one of the two states ends")
    if cd is True and gd is True:
        return FoldPosition(L, "between", 2,
                            f"L/a = {L:g} lies between the pop-up length "
                            f"{fmt('L0*', L0, lo)} and the standout length "
                            f"{fmt('L1*', L1, hi)}: two states (bistable)")
    if cd is True and gd is False:
        return FoldPosition(L, "below", 1,
                            f"L/a = {L:g} is below the pop-up length L0* = {L0:.5f}: one "
                            f"state, curvature-dominated (aloft)")
    if cd is False and gd is True:
        return FoldPosition(L, "above", 1,
                            f"L/a = {L:g} is above the standout length L1* = {L1:.5f}: one "
                            f"state, gravity-dominated (drooped)")
    why = []
    for name, b, e in (("curvature-dominated", folds.increasing, cd),
                       ("gravity-dominated", folds.decreasing, gd)):
        if e is None:
            why.append(f"the {name} branch was not followed to L/a = {L:g}"
                       + (f" ({b.reason})" if b.reason else "")
                       + (" (its load path snapped where it started)" if b.start_snapped else ""))
    return FoldPosition(L, "unknown", None, f"where L/a = {L:g} sits is unknown: "
                        + "; ".join(why or ["neither branch was found there"]))


@dataclass(frozen=True)
class FoldLengths:
    """The fold lengths of a sheet's planform at its curvature and material.

    :func:`fold_lengths` returns it: ``L1*`` (standout), where the
    curvature-dominated branch ends, and ``L0*`` (pop-up), where the
    gravity-dominated one ends, each located on the mesh ``hmax``
    (:class:`Fold`), and where the sheet's own length sits against them.

    Attributes
    ----------
    sheet : Sheet
        The sheet asked about (its planform, curvature and material make the
        family of lengths; its length is placed against the folds).
    hmax : float
        The mesh the folds were located on.
    length_range : (float, float)
        The lengths searched.
    standout, popup : Fold or None
        The located folds (None where the branch held over the range, or
        was lost without a fold: ``message`` says which).
    increasing, decreasing : Branch
        The two continuations (curvature-first from the short end,
        gravity-first from the long end; possibly one and the same): their
        points on ``branch_hmax``, their ``fold`` the located one on ``hmax``.
    trace_hmax : float
        The mesh the branches were traced on and their folds first located
        (:func:`trace_mesh`).
    branch_hmax : float
        The mesh of ``increasing`` and ``decreasing`` (``hmax`` with
        ``branches=True``, else ``trace_hmax``).
    message : str
        Why a fold is missing, or "".
    factorizations : int
        Factorisations on the mesh ``hmax`` (the folds located there; with
        ``branches=True`` also the branches).
    trace_factorizations : int
        Factorisations of the traces on ``trace_hmax`` (when it is another mesh).
    wall_time_s : float

    Examples
    --------
    >>> f = fold_lengths(Sheet(length=1.3, curvature=2.5), hmax=0.2,
    ...                  lengths=(1.0, 1.7))  # doctest: +SKIP
    >>> f.popup_length, f.standout_length, f.bistable, f.in_window  # doctest: +SKIP
    """

    sheet: Sheet
    hmax: float
    length_range: tuple
    standout: Fold | None
    popup: Fold | None
    increasing: Branch
    decreasing: Branch
    trace_hmax: float
    branch_hmax: float = math.nan
    message: str = ""
    factorizations: int = 0
    trace_factorizations: int = 0
    wall_time_s: float = 0.0

    # -- the answer -----------------------------------------------------------
    @property
    def standout_length(self) -> float:
        """``L1*/a``, NaN where none was found."""
        return self.standout.length if self.standout is not None else math.nan

    @property
    def popup_length(self) -> float:
        """``L0*/a``, NaN where none was found."""
        return self.popup.length if self.popup is not None else math.nan

    @property
    def standout_deflection(self) -> float:
        return self.standout.deflection if self.standout is not None else math.nan

    @property
    def popup_deflection(self) -> float:
        return self.popup.deflection if self.popup is not None else math.nan

    @property
    def bistable(self) -> bool:
        """Both folds found with ``L0* < L1*``: the lengths in between have two
        stable states."""
        return bool(self.popup_length < self.standout_length)

    @property
    def window(self) -> tuple:
        """``(L0*, L1*)`` of a bistable family, else ``(nan, nan)``."""
        return (self.popup_length, self.standout_length) if self.bistable else (math.nan,) * 2

    @property
    def width(self) -> float:
        """``L1* - L0*`` (NaN unless both were found)."""
        return self.standout_length - self.popup_length

    @property
    def position(self) -> FoldPosition:
        """Where ``sheet.length`` sits against the folds (:func:`fold_position`)."""
        return fold_position(self, self.sheet.length)

    @property
    def in_window(self):
        """Whether ``sheet.length`` lies in the bistable window (two stable
        states), or None where that is unknown."""
        pos = self.position
        return None if pos.states is None else pos.states == 2

    # -- the old names ----------------------------------------------------------
    @property
    def tip_width(self) -> float:
        return self.sheet.tip_width

    @property
    def curvature(self) -> float:
        return self.sheet.curvature

    @property
    def coarse_hmax(self):
        """The trace mesh where it is not ``hmax`` (else None)."""
        return None if self.trace_hmax == self.hmax else self.trace_hmax

    @property
    def coarse_newton_iterations(self) -> int:
        return self.trace_factorizations

    @property
    def tol(self) -> float:
        """The folds' location tolerance in L/a (:data:`FOLD_TOL`)."""
        return FOLD_TOL

    # -- SI ---------------------------------------------------------------------
    def in_si(self) -> dict | None:
        """The fold lengths and deflections in metres (None for a sheet
        without SI scales): ``popup_length_m``, ``standout_length_m``,
        ``popup_deflection_m``, ``standout_deflection_m``, ``length_m``
        (the sheet's), ``length_range_m``."""
        si = self.sheet.si
        if si is None:
            return None
        return {"popup_length_m": si.metres(self.popup_length),
                "standout_length_m": si.metres(self.standout_length),
                "popup_deflection_m": si.metres(self.popup_deflection),
                "standout_deflection_m": si.metres(self.standout_deflection),
                "length_m": si.metres(self.sheet.length),
                "length_range_m": [si.metres(x) for x in self.length_range],
                "base_width_m": si.base_width}

    # -- in words -----------------------------------------------------------------
    def fold_text(self, kind: str) -> str:
        """One fold and what it is, in words (the command line's table).

        Examples
        --------
        >>> f = FoldLengths(Sheet(length=1.3, curvature=2.5), 0.1, (0.6, 2.4), None, None,
        ...                 Branch(()), Branch(()), 0.1)
        >>> f.fold_text("standout")
        'none in range (the branch followed from L/a = 0.6 held to L/a = 2.4)'
        """
        fold = self.standout if kind == "standout" else self.popup
        branch = self.increasing if kind == "standout" else self.decreasing
        name = _KINDS[kind][0]
        lo, hi = self.length_range
        si = self.sheet.si
        if fold is not None:
            mm = "" if si is None else f" (L* = {1e3 * si.metres(fold.length):.5g} mm)"
            check = {True: "", False: ", the eigenvalue crossing NOT confirmed",
                     None: ", crossing unknown"}[fold.confirmed]
            return (f"{fold.length:.5f}{mm}, d/a {fold.deflection:.4f} there  (the {name} "
                    f"branch ends there{check})")
        if branch.start_snapped:
            end = lo if kind == "standout" else hi
            return (f"none: the {name} branch does not exist at L/a = {end:g}, where it was "
                    f"started (widen the lengths)")
        if branch.reason:
            return f"not found: the {name} branch was lost without a fold ({branch.reason})"
        start, end = (lo, hi) if kind == "standout" else (hi, lo)
        # the branch is named for the state it starts from; with no fold the
        # states along it may change names, so say where it was followed
        return f"none in range (the branch followed from L/a = {start:g} held to L/a = {end:g})"

    def lines(self) -> list:
        """The answer in words, a line each (what ``bistability`` prints)."""
        lo, hi = self.length_range
        sheet = self.sheet
        family = (f"this planform (b/a = {sheet.tip_width:g}) at a/R = {sheet.curvature:g}"
                  if sheet.planform is None else
                  f"this planform ({sheet.planform!r}) at a/R = {sheet.curvature:g}")
        out = [f"fold lengths of {sheet.describe().split(', ', 1)[1]}; hmax {self.hmax:g}"
               + (f" (branches traced on {self.trace_hmax:g})"
                  if self.trace_hmax != self.hmax else "")
               + f", L/a searched in [{lo:g}, {hi:g}]  ({self.wall_time_s:.0f} s):",
               f"  standout length L1*/a = {self.fold_text('standout')}",
               f"  pop-up length   L0*/a = {self.fold_text('popup')}"]
        if self.bistable:
            out.append(f"  {family} is bistable for {self.popup_length:.5f} < L/a < "
                       f"{self.standout_length:.5f}: two stable states at each length in "
                       f"between")
        elif math.isfinite(self.width):
            out.append(f"  {family}: L1* <= L0*, no length with two stable states")
        else:
            out.append(f"  {family} is not bistable for any L/a in [{lo:g}, {hi:g}] searched")
        out.append(f"  this sheet (L/a = {sheet.length:g}"
                   + ("" if sheet.si is None else
                      f", L = {1e3 * sheet.si.metres(sheet.length):.4g} mm")
                   + f"): {self.position.text}")
        return out

    def __str__(self) -> str:
        return "\n".join(self.lines())

    def __repr__(self) -> str:
        def f(x):
            return "nan" if not math.isfinite(x) else f"{x:.5f}"
        return (f"FoldLengths({self.sheet!r}, hmax={self.hmax:g}: L0* = {f(self.popup_length)}, "
                f"L1* = {f(self.standout_length)}, bistable={self.bistable}, "
                f"in_window={self.in_window})")

    def _repr_pretty_(self, p, cycle) -> None:
        p.text(repr(self) if cycle else str(self))

    def _repr_html_(self) -> str:
        from html import escape

        return "<pre>" + escape(str(self)) + "</pre>"

    def summary(self) -> dict:
        """JSON-ready summary (the command line's ``--json``): ``popup_length``,
        ``standout_length`` (None where none), ``bistable``, the located
        folds, both branches, where the sheet's length sits, and the SI
        values (``si``) of a sheet made from SI quantities."""
        def num(x):
            return x if math.isfinite(x) else None

        one = self.decreasing is self.increasing
        return {"popup_length": num(self.popup_length),
                "standout_length": num(self.standout_length),
                "bistable": self.bistable, "bistable_width": num(self.width),
                "popup": None if self.popup is None else self.popup.to_json(),
                "standout": None if self.standout is None else self.standout.to_json(),
                "tol": FOLD_TOL, "sheet": self.sheet.to_dict(),
                "tip_width": self.sheet.tip_width, "curvature": self.sheet.curvature,
                "thickness": self.sheet.thickness, "modulus": self.sheet.modulus,
                "hmax": self.hmax, "trace_hmax": self.trace_hmax,
                "branch_hmax": self.branch_hmax, "length_range": list(self.length_range),
                "position": self.position.to_json(), "in_window": self.in_window,
                "curvature_dominated": self.increasing.summary(),
                "gravity_dominated": self.decreasing.summary(), "one_branch": one,
                "message": self.message, "factorizations": self.factorizations,
                "trace_factorizations": self.trace_factorizations,
                "wall_time_s": self.wall_time_s, "si": self.in_si(), "version": __version__}


def __getattr__(name):
    """``Bistability``: the old name of :class:`FoldLengths` (before the folds
    were located and the function took a Sheet), with a DeprecationWarning;
    kept one release."""
    if name == "Bistability":
        warnings.warn("skfem_sheet.bistability.Bistability is deprecated: it is FoldLengths",
                      DeprecationWarning, stacklevel=2)
        return FoldLengths
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def _mesh_length(L: float) -> float:
    """The length a fold's mesh is made at: ``L`` on the grid
    :data:`~skfem_sheet.foldcurve.options.MESH_LENGTH_GRID` (the fold
    curves' rule, so that a fold is located on the same mesh whichever code
    finds it, and does not follow round-off in where it was first found)."""
    return round(max(MESH_LENGTH_GRID, round(L / MESH_LENGTH_GRID) * MESH_LENGTH_GRID), 10)


def locate_on_mesh(sheet: Sheet, point, problem, kind: str, hmax: float, *, layers=None,
                   solver: str = "auto", keep_state: bool = False, mesh_length=None):
    """A fold located on the mesh ``hmax`` made next to its length.

    The fold ``point`` (a :class:`skfem_sheet.engine.FoldPoint` in L on
    ``problem``) is carried onto a mesh of size ``hmax`` made at its length
    rounded to :data:`~skfem_sheet.foldcurve.options.MESH_LENGTH_GRID` and
    located there along its branch (:func:`~skfem_sheet.engine.fold_on_branch`,
    the load to :data:`FOLD_TOL`), the negative eigenvalue counts on both sides
    checked (where they do not differ by one, located once more a thousand
    times closer); where that does not converge, by Newton on the minimally
    augmented system, from the carried state or from it settled
    (:func:`~skfem_sheet.foldcurve.refine.settled_fold`).  A fold more than a
    grid step from its mesh's length is located once more on the mesh made next
    to it.  ``mesh_length``: make the mesh at this length instead, and keep it.

    Returns
    -------
    (Fold or None, factorisations, reason)
        ``reason`` says why there is none ("" if there is).
    """
    side = _KINDS[kind][1]
    total = 0
    for attempt in range(2):
        L_m = _mesh_length(point.value) if mesh_length is None else float(mesh_length)
        p = np.array(point.p, dtype=float)
        if problem.hmax == hmax and abs(problem.mesh_parameters[0] - L_m) < 1e-12:
            Q = problem  # already the mesh made there
            u, v = np.array(point.u, dtype=float), np.array(point.v, dtype=float)
        else:
            Q = _branch_problem(sheet.replace(length=L_m), "L", hmax, layers, solver, True)
            u = problem.transferred(Q, point.u, p)
            v = problem.transferred(Q, point.v, p, state=False)
        counter = Counting(Q)
        fold, res = fold_on_branch(counter, u, p, "L", v, tol=TOLERANCES, ptol=FOLD_TOL,
                                   check_inertia=True, reach=0.25)
        if fold is None or int(fold.side) != side:
            why = res.reason if fold is None else "the other kind of fold"
            fold, res, _, _ = settled_fold(counter, None, "L", u, p, v, TOLERANCES)
            if fold is not None and int(fold.side) == side:
                fold = replace(fold, crossing=inertia_crossing(counter, fold.u, fold.p,
                                                               fold.v, 1e-4))
            elif fold is not None:
                fold, why = None, f"{why}; the fold system: the other kind of fold"
            else:
                why = f"{why}; the fold system: {res.reason}"
        if fold is not None and fold.crossing is not None and \
                abs(int(fold.crossing[1]) - int(fold.crossing[0])) != 1:
            # the crossing not seen along the null vector: at a flat fold (a small
            # fold coefficient) the critical eigenvalue changes slowly along it, and
            # the located state, within the tolerance of the fold, is not near enough;
            # located once more from there, closer, and checked again
            closer, _ = fold_on_branch(counter, fold.u, fold.p, "L", fold.v, tol=TOLERANCES,
                                       ptol=FOLD_TOL * 1e-3, check_inertia=True)
            if closer is not None and int(closer.side) == side:
                fold = closer
        total += counter.stats().factorizations
        if fold is None:
            return None, total, why
        # on the mesh made next to it (within a grid step: meshes made a grid
        # step apart are other unstructured meshes, whose folds differ by their
        # discretisation error), or on the second mesh, made next to where it
        # came out on the first
        if (attempt == 1 or mesh_length is not None
                or abs(fold.value - L_m) <= MESH_LENGTH_GRID + 1e-9):
            d = Q.deflection(fold.u, fold.p)
            if not keep_state:
                Q.release()
            return (Fold(kind, fold.value, d, fold.crossing, fold.negative_eigenvalues, hmax,
                         L_m, total, fold if keep_state else None, Q if keep_state else None),
                    total, "")
        point, problem = fold, Q


def fold_lengths(sheet: Sheet, *legacy, hmax: float = DEFAULT_HMAX, lengths=None,
                 branches: bool = False, coarse_hmax=None, step: float = 0.1, layers=None,
                 solver: str = "auto", progress: bool = False, on_point=(None, None),
                 keep_states: bool = False, min_step=None, tol=None, names: bool = False,
                 **legacy_keywords) -> FoldLengths:
    """The fold lengths ``L0*`` and ``L1*`` of a sheet's planform at its
    curvature and material, located, and where the sheet's length sits.

    1. **The branches, traced** on the mesh :func:`trace_mesh` gives: the
       curvature-dominated branch from ``lengths[0]`` with increasing L, the
       gravity-dominated one from ``lengths[1]`` with decreasing L
       (:func:`follow_length`), each to its located fold (traced once where
       the one reaches the other's start without a fold, :func:`_same_state`).
    2. **The folds, located on the mesh ``hmax``** made at each
       (:func:`locate_on_mesh`: a few factorisations per fold).
    3. **The branches on ``hmax``** (``branches=True``, or ``on_point``): each
       followed on ``hmax`` up to its located fold, guided by the traced one.

    Parameters
    ----------
    sheet : Sheet
        The planform, clamp curvature, thickness and modulus of the family
        of lengths (any planform); its own length is placed against the
        folds (:attr:`FoldLengths.position`).
    hmax : float
        The mesh the folds are located on (default
        :data:`~skfem_sheet.params.DEFAULT_HMAX`, the paper's;
        :data:`~skfem_sheet.params.QUICK_HMAX` for a quick look).
    lengths : (float, float), optional
        The range of L/a searched (default :func:`fold_range`: 0.6 to 2.4,
        widened to hold the sheet's length).
    branches : bool
        Also follow both branches on the mesh ``hmax`` (step 3; else the
        returned branches are the traced ones).
    coarse_hmax : float, optional
        The trace mesh (:func:`trace_mesh`; 0: none, everything on ``hmax``).
    step : float
        Largest length step of the continuations.
    layers, solver
        Of the meshes (:func:`~skfem_sheet.mesh.sheet_mesh`) and the linear
        solver (:func:`~skfem_sheet.linalg.make_linear_solver`).
    progress : bool
        Progress bars on stderr.
    on_point : (callable or None, callable or None)
        The ``on_point`` of the two continuations on the mesh ``hmax``
        (:func:`follow_length`; implies ``branches``).
    keep_states : bool
        Keep each fold's state, null vector and problem (:attr:`Fold.point`,
        :attr:`Fold.problem`: for its sensitivities).
    min_step, tol
        The shortest step (:func:`follow_length`; ``tol`` deprecated).
    names : bool
        Name each point of the returned branches as ``solve`` names a state
        (:attr:`BranchPoint.name`).
    legacy, legacy_keywords
        The old call, ``fold_lengths(tip_width, curvature, thickness=...,
        modulus=..., ...)``, still works for one release, with a
        :class:`DeprecationWarning` (:func:`fold_lengths_of`).

    Returns
    -------
    FoldLengths
        ``popup_length``, ``standout_length`` (NaN where none), ``bistable``,
        ``in_window``, ``position``; a branch that held over the range or
        was lost without a fold is said so in ``message`` and in
        :meth:`FoldLengths.fold_text`.

    Examples
    --------
    >>> f = fold_lengths(Sheet(length=1.3, curvature=2.5), hmax=0.2, lengths=(1.0, 1.7),
    ...                  step=0.15)
    >>> f.bistable, f.in_window, round(f.popup_length, 2), round(f.standout_length, 2)
    (True, True, 1.24, 1.36)
    """
    options = dict(hmax=hmax, lengths=lengths, branches=branches, coarse_hmax=coarse_hmax,
                   step=step, layers=layers, solver=solver, progress=progress,
                   on_point=on_point, keep_states=keep_states, min_step=min_step, tol=tol,
                   names=names)
    if not isinstance(sheet, Sheet):
        if isinstance(sheet, numbers.Real) and not isinstance(sheet, bool):
            # the old call fold_lengths(tip_width, curvature, ...): one release more
            return fold_lengths_of(sheet, *legacy, **legacy_keywords, **options)
        raise ParameterError(f"sheet must be a skfem_sheet.Sheet, got {type(sheet).__name__}")
    if legacy or legacy_keywords:
        names = ", ".join(sorted(legacy_keywords)) or f"{len(legacy)} positional"
        raise ParameterError(f"fold_lengths(sheet, ...) takes the planform, curvature, "
                             f"thickness and modulus from the Sheet, got also {names} "
                             f"(give them to the Sheet)")
    t0 = time.perf_counter()
    hmax = check_range("hmax", hmax, 0, None, lo_open=True)
    lo, hi = fold_range(sheet.length, lengths)
    h_trace = trace_mesh(hmax, coarse_hmax)
    min_step = _min_step(tol, min_step)
    _check_common(sheet, hmax, step)
    on_point = tuple(on_point) if on_point is not None else (None, None)
    if len(on_point) != 2:
        raise ParameterError(f"on_point must be a pair (curvature-dominated, "
                             f"gravity-dominated), got {on_point!r}")
    fine_branches = bool(branches) or any(f is not None for f in on_point)
    flat = sheet.curvature == 0.0  # a flat clamp: both load paths are one problem, one branch
    base = sheet.replace(length=lo)
    common = dict(layers=layers, solver=solver, symmetric=True, step=step, min_step=min_step,
                  jump=0.1)
    guided = fine_branches and h_trace != hmax
    guides = [[] if guided else None, [] if guided else None]
    trace_on = (None, None) if (fine_branches and h_trace != hmax) else on_point
    last = []

    def keep_last(problem, w, length, user=trace_on[0]):
        last[:] = [problem, w]
        if user is not None:
            user(problem, w, length)

    trace_names = bool(names) and not (fine_branches and h_trace != hmax)
    bars = _bars(progress, lo, hi)
    try:
        up = _follow("L", base, hi, path="curvature-first", hmax=h_trace,
                     **{**common, "layers": layers if h_trace == hmax else None},
                     progress=bars[0], on_point=keep_last, record=guides[0],
                     names=trace_names)
        down = up
        if not flat:
            # the gravity-dominated branch is the curvature-dominated one where
            # the latter reaches the long end without a fold and the
            # gravity-first start there is its end (whose states were asked
            # for is traced)
            twin = (tuple(last) if up.fold is None and not up.reason and last
                    and trace_on[1] is None else None)
            down = _follow("L", base.replace(length=hi), lo, path="gravity-first",
                           hmax=h_trace, **{**common,
                                            "layers": layers if h_trace == hmax else None},
                           progress=bars[1], on_point=trace_on[1], record=guides[1],
                           twin=twin, names=trace_names)
            if isinstance(down, _SameBranch):
                up = replace(up, newton_iterations=up.newton_iterations
                             + down.newton_iterations)
                down = up
    finally:  # also when a continuation raises: no bar left open on the terminal
        for b in bars:
            if b is not None:
                b.close()
    trace_work = up.newton_iterations + (0 if down is up else down.newton_iterations)
    # the folds on the results' mesh, made at their lengths
    located, notes, fine_work = {}, [], 0
    for kind, b in (("standout", up), ("popup", down)):
        if b.start_snapped:
            notes.append(f"the {_KINDS[kind][0]} branch does not exist at L/a = "
                         f"{lo if kind == 'standout' else hi:g}, where it was started")
            continue
        if b.fold_point is None:
            if b.reason and not (kind == "popup" and down is up):
                notes.append(f"the {_KINDS[kind][0]} branch was lost without a fold at L/a "
                             f"{b.lengths[-1] if len(b.points) else float('nan'):.4g}: "
                             f"{b.reason}")
            continue
        if kind == "popup" and down is up:
            continue
        fold, n, why = locate_on_mesh(sheet, b.fold_point, b.problem, kind, hmax,
                                      layers=layers, solver=solver, keep_state=keep_states)
        fine_work += n
        if fold is None:
            notes.append(f"the {kind} fold found at L/a {b.fold:.5f} on hmax {h_trace:g} was "
                         f"not located on hmax {hmax:g}: {why}")
        elif fold.confirmed is False:
            notes.append(f"at the {kind} fold (L/a {fold.length:.5f}) the negative eigenvalue "
                         f"counts on both sides, {fold.crossing}, do not differ by one")
        located[kind] = fold
    # the branches end at their folds as located on hmax (their points are the trace's)
    one = down is up
    up = _ending_at(up.without_states(), located.get("standout"))
    down = up if one else _ending_at(down.without_states(), located.get("popup"))
    if fine_branches and h_trace != hmax:
        up, down, n = _fine_branches(sheet, base, lo, hi, hmax, h_trace, common, guides,
                                     located, up, down, on_point, progress, flat, solver,
                                     names)
        fine_work += n
    return FoldLengths(sheet, hmax, (lo, hi), located.get("standout"), located.get("popup"),
                       up, down, h_trace, hmax if fine_branches else h_trace,
                       "; ".join(notes), int(fine_work if h_trace != hmax
                                             else fine_work + trace_work),
                       int(trace_work if h_trace != hmax else 0), time.perf_counter() - t0)


def _ending_at(branch, fold):
    """``branch`` with its fold the located ``fold`` (its length and deflection on
    the results' mesh), or as it is without one."""
    if fold is None:
        return branch
    return replace(branch, fold=fold.length, fold_deflection=fold.deflection)


#: A branch followed on the fine mesh up to its located fold stops this far
#: (L/a) before it (where Newton at fixed length still converges: the state
#: moves like the square root of the distance to the fold).
FOLD_GAP = 0.01


def _fine_branches(sheet, base, lo, hi, hmax, h_trace, common, guides, located, up, down,
                   on_point, progress, flat, solver, names=False):
    """The two branches on the mesh ``hmax`` (:func:`fold_lengths`, step 3):
    from their starts (reached from the trace mesh) up to their located folds
    (or the range's end), guided by the traced branches; ``(up, down,
    factorisations)``."""
    start = CoarseStart(hmax=h_trace)
    out, work = [], 0
    bars = _bars(progress, lo, hi)
    try:
        for k, (kind, sheet_at, stop_end, path, traced) in enumerate((
                ("standout", base, hi, "curvature-first", up),
                ("popup", base.replace(length=hi), lo, "gravity-first", down))):
            if k == 1 and (flat or (down is up and on_point[1] is None
                                    and out[0].fold is None)):
                out.append(out[0])
                break
            fold = located.get(kind)
            direction = 1.0 if k == 0 else -1.0
            stop = stop_end if fold is None else fold.length - direction * FOLD_GAP
            if traced.start_snapped or (stop - sheet_at.length) * direction <= 0:
                out.append(replace(traced, points=(), newton_iterations=0))
                continue
            b = _follow("L", sheet_at, stop, path=path, hmax=hmax, **common,
                        progress=bars[k], on_point=on_point[k], start=start,
                        guide=guides[k], locate=fold is None, names=names)
            work += b.newton_iterations
            if fold is None and b.fold_point is not None:
                # a fold on this mesh that the trace did not have (near the cusp, where
                # the window opens between the two meshes): located on its own mesh too
                fold, n, _ = locate_on_mesh(sheet, b.fold_point, b.problem, kind, hmax,
                                            layers=common["layers"], solver=solver)
                work += n
                located[kind] = fold
            if fold is not None:
                b = replace(b, fold=fold.length, fold_deflection=fold.deflection,
                            reason=b.reason or traced.reason,
                            bracket=b.bracket or traced.bracket)
            out.append(b.without_states())
    finally:
        for bar in bars:
            if bar is not None:
                bar.close()
    return out[0], out[1], work


def fold_lengths_of(tip_width: float = 1.0, curvature: float = 2.5, *, thickness: float = 0.03,
                    modulus: float = 735.0, lengths=(0.6, 2.4), hmax: float = DEFAULT_HMAX,
                    **options) -> FoldLengths:
    """Deprecated: the old ``fold_lengths(tip_width, curvature, ...)``, whose
    material was loose keyword arguments that defaulted to the paper's (so
    that a sheet of another material got the paper's fold lengths without a
    word).  Use :func:`fold_lengths` with a :class:`~skfem_sheet.params.Sheet`."""
    warnings.warn("fold_lengths(tip_width, curvature, thickness=, modulus=) is deprecated: "
                  "pass the Sheet, fold_lengths(Sheet(length=..., tip_width=..., "
                  "curvature=..., thickness=..., modulus=...), hmax=...)",
                  DeprecationWarning, stacklevel=2)
    lengths = (0.6, 2.4) if lengths is None else lengths
    lo, hi = (float(x) for x in lengths)
    sheet = Sheet(length=lo, tip_width=tip_width, curvature=curvature, thickness=thickness,
                  modulus=modulus)
    return fold_lengths(sheet, hmax=hmax, lengths=(lo, hi), **options)


#: Fold curves on meshes finer than the first of these are traced coarse to
#: fine: at that mesh size first, then points of it corrected level by level on
#: the finer ones and on the curve's own mesh (a step from hmax 0.1 straight to
#: 0.03 leaves some points outside the fold system's basin); the fold map's
#: curves too (:data:`skfem_sheet.studies.foldmap.COARSE_HMAX`).
FOLD_CURVE_LEVELS = (0.1, 0.06)
#: Points of the coarse curve refined on the fine meshes (besides its ends and
#: the cusp's neighbours).
FOLD_CURVE_POINTS = 6


def fold_curve(sheet: Sheet, hmax: float = DEFAULT_HMAX, *, second: str = "tip_width",
               lengths=None, progress: bool = False, **options):
    """The fold curve of a sheet's family: where its bistable window opens and closes.

    ``second="tip_width"``: the curve in (L, b/a) at the sheet's curvature
    (:func:`~skfem_sheet.foldcurve.trace_fold_curve`): ``L1*(b)`` from b/a =
    1 down to the cusp ``(b/a)*`` and back up as ``L0*(b)``.
    ``second="curvature"``: the curve in (L, a/R) at the sheet's tip width
    from its curvature down round the cusp where bistability starts
    (:func:`~skfem_sheet.foldcurve.trace_curvature_fold_curve`).  The
    thickness and modulus are the sheet's.  On meshes finer than
    :data:`FOLD_CURVE_LEVELS`' first the curve is traced coarse to fine, as
    the fold map's are.

    Parameters
    ----------
    sheet : Sheet
        A trapezoid (the curve maps its tip width; a planform has no b/a to
        vary).
    hmax : float
        Default :data:`~skfem_sheet.params.DEFAULT_HMAX`.
    second : {"tip_width", "curvature"}
    lengths : (float, float), optional
        The range of L/a of the curve (default 0.6 to 2.4, widened to hold
        the sheet's length).
    progress : bool
    **options
        Any other option of the trace (``min_tip_width``, ``min_curvature``,
        ``layers``, ``solver``, ``ds``, ``check_inertia``, ``coarse_hmax``,
        ``fine_points``, ``series``, ...).

    Returns
    -------
    FoldCurve
        ``standout_length``, ``popup_length`` (at b/a 1, or the sheet's
        curvature), ``cusp``, ``points``.

    Examples
    --------
    >>> c = fold_curve(Sheet(length=1.3, curvature=2.5), hmax=0.1)  # doctest: +SKIP
    >>> c.standout_length, c.popup_length, c.cusp  # doctest: +SKIP
    """
    from .foldcurve import trace_curvature_fold_curve, trace_fold_curve

    if not isinstance(sheet, Sheet):
        raise ParameterError(f"sheet must be a skfem_sheet.Sheet, got {type(sheet).__name__}")
    if sheet.planform is not None:
        raise ParameterError("fold_curve maps a trapezoid's tip width: a sheet with a planform "
                             "has none to vary (fold_lengths gives its fold lengths)")
    if second not in ("tip_width", "curvature"):
        raise ParameterError(f"second must be 'tip_width' or 'curvature', got {second!r}")
    hmax = check_range("hmax", hmax, 0, None, lo_open=True)
    fine = hmax < FOLD_CURVE_LEVELS[0]
    kw = dict(thickness=sheet.thickness, modulus=sheet.modulus, progress=progress,
              length_range=fold_range(sheet.length, lengths),
              check_inertia=5 if fine else 10,
              coarse_hmax=FOLD_CURVE_LEVELS if fine else None, fine_points=FOLD_CURVE_POINTS)
    kw.update(options)
    if second == "tip_width":
        return trace_fold_curve(sheet.curvature, hmax, **kw)
    return trace_curvature_fold_curve(sheet.tip_width, sheet.curvature, hmax, **kw)


class _Bar:
    def __init__(self, desc, start, stop):
        self.start = start
        self.bar = tqdm(total=round(abs(stop - start), 3), desc=desc, unit="L",
                        bar_format="{desc}: {percentage:3.0f}%|{bar}| [{elapsed}{postfix}]")

    def __call__(self, length):
        self.bar.n = round(abs(length - self.start), 3)
        self.bar.set_postfix_str(f"L/a = {length:.3f}", refresh=True)

    def close(self):
        self.bar.close()


def _bars(progress, lo, hi):
    if not progress:
        return None, None
    return _Bar("curvature-dominated, L up", lo, hi), _Bar("gravity-dominated, L down", hi, lo)


# ----------------------------------------------------------------------------
# pseudo-arclength continuation: the whole S-curve
# ----------------------------------------------------------------------------
@dataclass(frozen=True)
class SCurve(_Curve):
    """The curve of equilibria d(L) traced by pseudo-arclength continuation.

    Attributes
    ----------
    points : tuple of BranchPoint
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
    _check_common(sheet, hmax, 0.5)
    stop = check_range("stop", stop, sheet.length, 20.0, lo_open=True)
    if stop / sheet.length > REMESH_STRETCH**2:
        raise ParameterError(f"stop must be at most {REMESH_STRETCH**2:.2f} times the start length "
                             f"({sheet.length:g}) for one stretched mesh, got {stop:g}")
    t0 = time.perf_counter()
    stats = Stats()
    mid = np.sqrt(sheet.length * stop)
    P = _branch_problem(sheet.replace(length=mid), "L", hmax, layers, solver, symmetric)
    counter = Counting(P)
    p0 = np.array([sheet.length])
    out = P.along_path(p0, "curvature-first", stats)
    if not out.converged:
        raise ParameterError(f"the starting sheet could not be solved: {out.reason}")
    points, s_hist, tL_hist = [], [], []

    def on_step(pt, res):
        st, k = _stability_of(res.factorization)
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
_ARCLENGTH_TOLERANCES = Tolerances(rtol=_OPTIONS.rtol, utol=_OPTIONS.utol,
                                   max_iterations=_OPTIONS.max_iterations,
                                   max_halvings=_OPTIONS.max_halvings, max_correction=0.5)


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

