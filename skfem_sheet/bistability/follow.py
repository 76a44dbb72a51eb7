"""Continuation of one branch in the sheet length L or the curvature a/R.

The length is a continuous parameter: a mesh made at ``L_m`` is stretched
in x to nearby lengths (:meth:`skfem_sheet.problem.SheetProblem.with_length`)
and remeshed beyond :data:`~skfem_sheet.sheet_shape.REMESH_STRETCH`, the state
interpolated (:func:`transfer`).  Every continuation runs on the engine's
drivers with the sheet as :class:`~skfem_sheet.sheet_shape.SheetShapeProblem`;
a branch's end is located with the minimally augmented fold system, never
bracketed by failed solves, and a branch that ends without a fold says why
(:func:`follow_length`, :func:`follow_curvature`).
"""
from __future__ import annotations

import math
import time
import warnings
from dataclasses import dataclass

import numpy as np

from ..analyses.mode import mode_of
from ..analyses.transfer import transfer
from ..continuation import StepOptions
from ..engine import EngineFailure, Tolerances, correct, natural
from ..engine.fold import fold_on_branch
from ..engine.protocol import Counting
from ..newton import NewtonOptions, Stats
from ..params import DEFAULT_HMAX, ParameterError, Sheet, check_range
from ..sheet_shape import TOLERANCES, SheetShapeProblem
from ..solve import build_problem
from ..starts import Job
from .branch import Branch, BranchPoint

#: The folds of :func:`fold_lengths` are located to this in L/a (the fold
#: system's own tolerance on the load, ``ptol`` of
#: :func:`~skfem_sheet.engine.fold_on_branch`, relative to ``max(1, L)``: the
#: last section's remaining move towards the fold, whose prediction is
#: exact to second order, so that the error is far smaller): far below the
#: discretisation's effect on them (about 1e-3 a from hmax 0.06 to 0.03) and
#: the mesh's own (about 1e-4 a between two unstructured meshes of one size
#: at hmax 0.03, see :data:`~skfem_sheet.foldcurve.options.MESH_LENGTH_GRID`).
FOLD_TOL = 1e-6


#: Smallest step of a continuation in L or a/R: a step this short that fails
#: where no fold can be located ends the branch (``Branch.reason`` says why).
MIN_STEP = 0.005


# ----------------------------------------------------------------------------
# the sheet as an engine problem in one parameter (L or a/R)
# ----------------------------------------------------------------------------
def branch_problem(sheet, name, hmax, layers, solver, symmetric):
    """The sheet at full load as an engine problem in ``name`` ("L" or
    "a/R"), on its mesh stretched in x (remeshed by the remesh rule)."""
    return SheetShapeProblem(sheet, hmax, parameters=(name,), geometry="stretch",
                             layers=layers, half=symmetric, solver=solver, cache=5)


#: The sheet's Newton options (:class:`skfem_sheet.newton.NewtonOptions`) as
#: the engine's stopping rule: the residual relative to the weight, the
#: largest displacement correction (see :func:`_chord_linearization`).
OPTIONS = NewtonOptions()


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
    return Tolerances(rtol=OPTIONS.rtol, utol=OPTIONS.utol,
                      max_iterations=2 * OPTIONS.max_iterations + 1,
                      max_halvings=OPTIONS.max_halvings, max_correction=max_correction,
                      pair_contraction=pair_contraction)


def _chord_linearization(counter, max_factorizations=OPTIONS.max_iterations):
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
    tol = OPTIONS

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


def check_common(sheet, hmax, step):
    if not isinstance(sheet, Sheet):
        raise ParameterError(f"sheet must be a skfem_sheet.Sheet, got {type(sheet).__name__}")
    check_range("hmax", hmax, 0, None, lo_open=True)
    check_range("step", step, MIN_STEP, 1)


def resolve_min_step(tol, min_step):
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
    return follow_branch("L", sheet, stop, path=path, hmax=hmax, layers=layers,
                   solver=solver, symmetric=symmetric, step=step,
                   min_step=resolve_min_step(tol, min_step), jump=jump, progress=progress,
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
    return follow_branch("a/R", sheet, stop, path=path, hmax=hmax,
                   layers=layers, solver=solver, symmetric=symmetric, step=step,
                   min_step=resolve_min_step(tol, min_step), jump=jump, progress=progress,
                   on_point=on_point)


#: Allowed range of the end ``stop`` of a continuation in L and in a/R (:func:`follow_branch`).
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


def follow_branch(name, sheet, stop, *, path, hmax, layers, solver, symmetric, step, jump,
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
    start state, both continuations trace one branch and a :class:`SameBranch`
    is returned instead.  ``locate`` False: no fold is looked for.  ``names``
    (in L): each point named as ``solve`` names a state
    (:func:`~skfem_sheet.analyses.mode.mode_of`).
    """
    check_common(sheet, hmax, step)
    stop = check_range("stop", stop, **_STOP_RANGE[name])
    min_step = min(float(min_step), float(step))
    t0 = time.perf_counter()
    stats = Stats()
    P = branch_problem(sheet, name, hmax, layers, solver, symmetric)
    counter = Counting(P)
    p0 = np.array([sheet.length if name == "L" else sheet.curvature])
    out = _along_path(P, p0, path, stats, start)
    if not out.converged:
        raise ParameterError(f"the starting sheet (length {sheet.length:g}, a/R "
                             f"{sheet.curvature:g}) could not be solved along {path}: {out.reason}")
    if twin is not None and not out.snaps and _same_state(P, counter, p0, out.w, *twin):
        return SameBranch(stats.newton_iterations + counter.stats().factorizations)
    guard = 0.25 * max(1.0, sheet.length)
    points, accepted = [], {}

    def check(u, p, res):
        st, k = stability_of(res.factorization)
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
            st, k = stability_of(res.factorization)
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
class SameBranch:
    """What :func:`follow_branch` returns where its start lies on its twin's branch."""

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
                counter.correction_norm(res.u - w[P.free]) <= 10 * OPTIONS.utol)


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


def stability_of(fact):
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
