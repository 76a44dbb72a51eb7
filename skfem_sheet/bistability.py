"""Bistability: continuation in the sheet length, fold lengths, stability, the S-curve.

In the bistable range a sheet has two stable equilibria (paper, Figs. 2, 4, 6
and 7): the curvature-dominated (aloft) one, which exists up to the
*standout length* ``L1*``, and the gravity-dominated (drooped) one, which
exists down to the *pop-up length* ``L0*``.  The sheet is bistable for
``L0* < L < L1*``; between the two stable branches lies an unstable one, and
the three form an S-shaped curve of ``d`` against ``L`` whose turning points
(folds) are ``L0*`` and ``L1*``.

How the length is made a continuous parameter: a problem built on a mesh of
length ``L_m`` is stretched in x to any nearby length
(:meth:`skfem_sheet.problem.SheetProblem.with_length`), so one mesh topology
carries the nodal solution from one length to the next; beyond the remesh
rule's stretch (:data:`~skfem_sheet.sheet_shape.REMESH_STRETCH`) the sheet
is remeshed at the current length and the solution is interpolated onto the
new mesh (:func:`transfer`).

Every continuation here runs on the engine's drivers
(:func:`skfem_sheet.engine.natural`, :func:`skfem_sheet.engine.arclength`),
with the sheet adapted to the engine's problem protocol by
:class:`~skfem_sheet.sheet_shape.SheetShapeProblem` (one parameter, L or a/R,
on a stretched and remeshed mesh) and corrected with the sheet's Newton
stopping rule (:func:`_chord_linearization`).

Functions
---------
:func:`follow_length`
    natural continuation in L from a solved sheet, until the branch is lost:
    the fold is bracketed by step halving to ``tol`` (bisection);
:func:`fold_lengths`
    ``L0*`` and ``L1*`` of one (b, a/R): curvature-first from a short sheet
    with increasing L, gravity-first from a long sheet with decreasing L;
:func:`follow_curvature`
    the same in the clamp curvature at fixed L (critical curvatures
    ``1/R0*`` and ``1/R1*``);
:func:`s_curve`
    pseudo-arclength continuation in L through both folds, tracing the
    unstable middle branch;
:func:`stability`
    stable or not, from the inertia of the constrained tangent.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np
from tqdm.auto import tqdm

from .analyses.stability import stability
from .analyses.transfer import transfer
from .continuation import StepOptions
from .engine import EngineFailure, Tolerances, arclength, correct, natural
from .engine.protocol import Counting
from .newton import NewtonOptions, Stats
from .params import ParameterError, Sheet, check_range
from .sheet_shape import REMESH_STRETCH, SheetShapeProblem
from .solve import build_problem
from .starts import CoarseStart, Job
from .version import __version__

__all__ = ["BranchPoint", "Branch", "Bistability", "SCurve", "stability", "transfer",
           "follow_length", "follow_curvature", "fold_lengths", "s_curve"]


@dataclass(frozen=True)
class BranchPoint:
    """One equilibrium at full load: length, tip deflection, stability."""

    length: float
    deflection: float
    stable: object  # bool or None (solver cannot tell)
    negative_eigenvalues: object = None
    newton_iterations: int = 0


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
    """Result of :func:`follow_length`.

    Attributes
    ----------
    points : tuple of BranchPoint
        The converged equilibria, in the order of the continuation.
    fold : float or None
        The length where the branch was lost (midpoint of the bracket), or
        None if it held over the whole range.
    bracket : tuple
        ``(last length on the branch, first length where it was not found)``.
    reason : str
        Why the branch was declared lost at the bracket's end.
    start_snapped : bool
        The starting solve (along its load path) snapped to the other
        branch: the branch the path selects does not exist at the start
        length, and the points are on the other one.
    """

    points: tuple
    fold: object = None
    bracket: tuple = ()
    reason: str = ""
    newton_iterations: int = 0
    wall_time_s: float = 0.0
    start_snapped: bool = False


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
    the last factorisation reused for the residual that is left once the
    state has converged.

    At every iterate after the first the correction is first computed with
    the last factorisation (a back-substitution).  If the residual there is
    below ``rtol`` and that correction below ``utol``, the corrector stops
    and returns the iterate (no factorisation spent only to confirm
    convergence).  If the correction is below ``utol`` and at most half the
    last one, but the residual is above ``rtol``, it is taken as it is (a
    chord step): a thin sheet one correction of 1e-6 a away from its
    equilibrium still has residuals of a percent of its weight in the stiff
    membrane directions, which the factorisation at a state that close
    removes as well as a new one (measured on the rectangle at a/R 2.5,
    hmax 0.05, steps in L of 0.025 and 0.05: residuals 1.4e-2 and 1.9e-4 of
    the weight brought to 2.9e-5 and 7.8e-8 by one chord step each, two
    factorisations per step instead of three).  Otherwise the tangent is
    factorised at the iterate, at most ``max_factorizations`` times per
    correction.
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


def _check_common(sheet, hmax, step, tol):
    if not isinstance(sheet, Sheet):
        raise ParameterError(f"sheet must be a skfem_sheet.Sheet, got {type(sheet).__name__}")
    check_range("hmax", hmax, 0, None, lo_open=True)
    check_range("step", step, 0, 1, lo_open=True)
    check_range("tol", tol, 0, step, lo_open=True)


def follow_length(sheet: Sheet, stop: float, *, path: str = "curvature-first", hmax: float = 0.06,
                  layers=None, solver: str = "auto", symmetric: bool = True, step: float = 0.1,
                  tol: float = 0.005, jump: float = 0.1, progress=None,
                  on_point=None, start=None) -> Branch:
    """Follow the branch selected by ``path`` at ``sheet.length`` to ``stop``.

    Natural continuation in L at full load: each step is predicted with
    ``dw/dL`` and corrected by Newton.  A step fails if Newton does not
    converge, if the equilibrium found is unstable, or if the deflection
    jumps by more than ``jump`` (it landed on another branch); then the step
    is halved from the last equilibrium.  When a failing step is no longer
    than ``2 tol`` the branch is lost there: the fold is the middle of the
    bracket, to ``+- tol`` (bisection).

    Parameters
    ----------
    sheet : Sheet
        Start: its length, tip width and curvature.
    stop : float
        Length at which to stop if the branch holds (above or below the start).
    path : {"curvature-first", "gravity-first"}
        Load path of the starting solve (selects the branch).
    step : float
        Largest length step.
    tol : float
        Half-width of the final fold bracket.
    on_point : callable(problem, w, length) or None
        Called with the state of each point of the branch (e.g.
        ``skfem_sheet.io.Series().on_point``, then ``Branch.write_series``).
    start : start strategy, optional
        How the sheet at the start is solved: None, the load path on this
        mesh; or one of :func:`~skfem_sheet.solve.solve`'s strategies, e.g.
        :class:`~skfem_sheet.starts.CoarseStart` (the load path on a coarse
        mesh, carried here: a few factorisations on a fine mesh instead of the
        whole path).

    Returns
    -------
    Branch

    Examples
    --------
    >>> b = follow_length(Sheet(length=0.5, curvature=2.5), 0.7, hmax=0.15, step=0.1)
    >>> b.fold is None, len(b.points)
    (True, 3)
    """
    return _follow("L", sheet, stop, path=path, hmax=hmax, layers=layers,
                   solver=solver, symmetric=symmetric, step=step, tol=tol, jump=jump,
                   progress=progress, on_point=on_point, start=start)


def follow_curvature(sheet: Sheet, stop: float, *, path: str = "gravity-first", hmax: float = 0.06,
                     layers=None, solver: str = "auto", symmetric: bool = True,
                     step: float = 0.25, tol: float = 0.005, jump: float = 0.1,
                     progress=None, on_point=None) -> Branch:
    """Follow a branch in the clamp curvature a/R at fixed length, to ``stop``.

    The same natural continuation as :func:`follow_length`, with the clamp
    curvature as the parameter (the clamped values change; the mesh does
    not).  From the gravity-dominated state at a small curvature, increasing
    a/R finds where it pops up (``1/R0*``); from the curvature-dominated state
    at a large curvature, decreasing a/R finds where it falls (``1/R1*``).
    ``Branch.fold`` and the branch points' ``length`` field then hold
    curvatures.

    Examples
    --------
    >>> b = follow_curvature(Sheet(length=0.6, curvature=1.0), 1.5, hmax=0.15, step=0.25)
    >>> b.fold is None, len(b.points)
    (True, 3)
    """
    return _follow("a/R", sheet, stop, path=path, hmax=hmax,
                   layers=layers, solver=solver, symmetric=symmetric, step=step, tol=tol,
                   jump=jump, progress=progress, on_point=on_point)


#: Allowed range of the end ``stop`` of a continuation in L and in a/R (:func:`_follow`).
_STOP_RANGE = {"L": dict(lo=0.05, hi=20.0), "a/R": dict(lo=0.0, hi=2 * np.pi, hi_open=True)}


def _follow(name, sheet, stop, *, path, hmax, layers, solver, symmetric, step, tol, jump,
            progress, on_point=None, start=None, record=None, guide=None, twin=None):
    """Natural continuation in ``name`` ("L" or "a/R") with fold bisection
    (see :func:`follow_length`), on the engine's driver
    :func:`skfem_sheet.engine.natural`: predictor ``dw/dp`` with the last
    factorisation, the sheet's Newton stopping rule, a step failing when
    Newton fails, the equilibrium is unstable or the deflection jumps,
    halved down to the bracket ``2 tol``; in L the mesh is remeshed (and the
    state transferred) before a step beyond the stretch limit.  The arguments
    are checked here (``stop`` against :data:`_STOP_RANGE` of ``name``).

    ``start``: how the first point (and a remeshed state that Newton cannot
    finish) is reached (:func:`_along_path`).
    ``record``: a list to append each point's :class:`_GuidePoint` to (the
    branch as the guide of a finer one).  ``guide``: the points so recorded
    of the same branch on a coarser mesh, whose second-order part corrects
    each step's prediction (:class:`_Guide`; in L only).  ``twin``:
    ``(problem, w)``, an equilibrium of the same sheet at the start on
    another mesh (the end of the continuation the other way): if Newton from
    it, carried here, lands on the start state, both continuations trace one
    branch, and a :class:`_SameBranch` (the work of the start and the check)
    is returned instead of tracing it again."""
    _check_common(sheet, hmax, step, tol)
    stop = check_range("stop", stop, **_STOP_RANGE[name])
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
        points.append(BranchPoint(float(pt.p[0]), d, st, k, its))
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

    b = natural(counter, out.w[P.free], p0, 0, stop, step=step, min_step=tol, bracket=2 * tol,
                tol=_tolerances(guard, pair_contraction=True), locate=False,
                inertia_change=False, grow_after=None, check=check, before_step=before_step,
                on_step=on_step, keep_states=False, linearization=_chord_linearization,
                progress=progress, start=(out.w[P.free], P.held(out.w[P.free], p0)),
                guide=_Guide(guide, P) if guide and name == "L" else None)
    fold = None
    if b.bracket and not b.reason.startswith("remeshing") and not b.completed:
        fold = 0.5 * (b.bracket[0] + b.bracket[1])
    nits = stats.newton_iterations + b.stats.factorizations
    return Branch(tuple(points), fold, tuple(b.bracket) if fold is not None else (), b.reason,
                  nits, time.perf_counter() - t0, start_snapped=len(out.snaps) > 0)


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
    continuation's prediction (:func:`~skfem_sheet.engine.natural`'s
    ``guide``).

    The fine step from ``L0`` to ``L1`` predicts ``u(L0) + (L1 - L0) u'(L0)``
    (its tangent), whose error is the branch's curvature term.  Where ``L0``
    and ``L1`` are points of the coarse branch on one coarse mesh, the coarse
    branch's own curvature term ``w_c(L1) - w_c(L0) - (L1 - L0) w_c'(L0)``,
    interpolated onto the fine mesh at ``L1``, is added: the prediction's
    error is then the difference of the two meshes' curvature terms (measured
    on the rectangle at a/R 2.5, hmax 0.05 guided by 0.1, steps of 0.05: 1e-5
    to 4e-4 instead of 9e-4 to 4e-3 of a, and 1-2 Newton iterations instead
    of 2-3).  Elsewhere (a step halved off the coarse points, past the coarse
    fold, across a coarse remesh) no correction: the tangent as without a
    guide.
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


@dataclass(frozen=True)
class Bistability:
    """Pop-up and standout lengths of one (tip width, curvature).

    Attributes
    ----------
    popup_length : float or None
        ``L0*``: below it the gravity-dominated branch does not exist (None if
        it held down to the lower end of the range).
    standout_length : float or None
        ``L1*``: above it the curvature-dominated branch does not exist (None
        if it held up to the upper end).
    bistable : bool
        Both folds found with ``L0* < L1*`` and their brackets disjoint
        (``L1* - L0* > 2 tol``): a bistable range narrower than the fold
        resolution is not claimed (near the cusp where it closes, e.g. the
        rectangle at a/R = 1).
    increasing, decreasing : Branch
        The two continuations (curvature-first from the short end,
        gravity-first from the long end; one and the same at a/R = 0, and
        where the gravity-first state at the long end is the end of the
        curvature-first continuation: a single branch, traced once).
        ``start_snapped`` on either means its branch does not exist at the
        end of the range it started from (widen ``lengths``).
    coarse_hmax : float or None
        The mesh the branches were first traced on (coarse to fine), or None.
    coarse_newton_iterations : int
        The linearisations of those coarse traces.
    """

    tip_width: float
    curvature: float
    hmax: float
    length_range: tuple
    popup_length: object
    standout_length: object
    bistable: bool
    increasing: Branch
    decreasing: Branch
    tol: float = 0.005
    wall_time_s: float = 0.0
    coarse_hmax: object = None
    coarse_newton_iterations: int = 0

    def summary(self) -> dict:
        """JSON-ready summary (the CLI's ``--json``)."""
        def branch(b):
            return {"lengths": b.lengths.tolist(), "deflection": b.deflections.tolist(),
                    "stable": b.stable, "fold": b.fold,
                    "bracket": list(b.bracket), "reason": b.reason,
                    "newton_iterations": b.newton_iterations, "wall_time_s": b.wall_time_s}

        width = (self.standout_length - self.popup_length
                 if self.popup_length is not None and self.standout_length is not None else None)
        return {"popup_length": self.popup_length, "standout_length": self.standout_length,
                "bistable": self.bistable, "bistable_width": width, "tip_width": self.tip_width,
                "curvature": self.curvature, "hmax": self.hmax, "tol": self.tol,
                "length_range": list(self.length_range),
                "curvature_dominated": branch(self.increasing),
                "gravity_dominated": branch(self.decreasing),
                "one_branch": self.decreasing is self.increasing,
                "coarse_hmax": self.coarse_hmax,
                "coarse_newton_iterations": self.coarse_newton_iterations,
                "wall_time_s": self.wall_time_s, "version": __version__}


def fold_lengths(tip_width: float = 1.0, curvature: float = 2.5, *, lengths=(0.6, 2.4),
                 hmax: float = 0.06, layers=None, solver: str = "auto", step: float = 0.1,
                 tol: float = 0.005, thickness: float = 0.03, modulus: float = 735.0,
                 progress: bool = False, on_point=(None, None),
                 coarse_hmax: float | None = None) -> Bistability:
    """Standout and pop-up lengths by continuation in L in both directions.

    The curvature-dominated branch is followed from ``lengths[0]``
    (curvature-first) with increasing L until it is lost (``L1*``), the
    gravity-dominated one from ``lengths[1]`` (gravity-first) with decreasing
    L (``L0*``).  Each fold is located to ``+- tol``.  ``on_point`` is the
    pair of the two continuations' ``on_point`` (see :func:`follow_length`).

    ``coarse_hmax`` (coarser than ``hmax``): coarse to fine.  Both branches
    are traced on that mesh first; the fine ones start from the sheet solved
    by :class:`~skfem_sheet.starts.CoarseStart` (the load path on the coarse
    mesh, carried), and each fine step's prediction is corrected by the
    coarse branch's second-order part (:class:`_Guide`).

    Where the curvature-dominated branch reaches ``lengths[1]`` without a
    fold (and, coarse to fine, neither coarse branch has one), the
    gravity-first start there is checked to be that branch's end
    (:func:`_same_state`) and the branch is traced once (``decreasing is
    increasing``; unless ``on_point[1]`` asks for its states): the
    continuation in L from one equilibrium is unique as long as no fold is
    passed, so the gravity-dominated branch is the same curve traced back.
    The equilibria are the fine mesh's (to Newton's tolerance), the folds
    bracketed on it; measured at hmax 0.03 from 0.1 (rows L/a 0.5-3, steps
    0.05): 0.71 of the wall time of the fine mesh alone on the bistable
    rectangle at a/R 2.5, 0.42 on the monotone b/a 0.4
    (``benchmarks/results/speed/fold_map_rows_hmax0.03.txt``).

    Examples
    --------
    >>> r = fold_lengths(0.0, 2.5, lengths=(0.8, 1.2), hmax=0.15, step=0.2)
    >>> r.bistable
    False
    """
    lo, hi = (check_range("lengths", float(x), 0.05, 20.0) for x in lengths)
    if not lo < hi:
        raise ParameterError(f"lengths must be (short, long) with short < long, got {lengths!r}")
    t0 = time.perf_counter()
    base = Sheet(length=lo, tip_width=tip_width, curvature=curvature, thickness=thickness,
                 modulus=modulus)
    _check_common(base, hmax, step, tol)
    if coarse_hmax is not None:
        check_range("coarse_hmax", coarse_hmax, hmax, None, lo_open=True)
    common = dict(layers=layers, solver=solver, symmetric=True, step=step, tol=tol, jump=0.1)
    flat = base.curvature == 0.0  # a flat clamp: both load paths are one problem, one branch
    coarse = [None, None]
    guides = [None, None]
    start = None
    if coarse_hmax is not None:
        # the branches on the coarse mesh first: their points guide the fine
        # ones, and the fine starts are reached from the coarse mesh too
        start = CoarseStart(hmax=coarse_hmax)
        for k, (sheet, stop, path) in enumerate(((base, hi, "curvature-first"),
                                                 (base.replace(length=hi), lo, "gravity-first"))):
            if k == 1 and flat:
                break
            guides[k] = []
            coarse[k] = _follow("L", sheet, stop, path=path, hmax=coarse_hmax,
                                **{**common, "layers": None}, progress=None, record=guides[k])
    last = []

    def keep_last(problem, w, length, user=on_point[0]):
        last[:] = [problem, w]
        if user is not None:
            user(problem, w, length)

    # the gravity-dominated branch is the curvature-dominated one where neither
    # has a fold on the coarse mesh and the fine one has none either: then the
    # gravity-first start is tried against the curvature-first end (_same_state)
    bars = _bars(progress, lo, hi)
    try:
        up = _follow("L", base, hi, path="curvature-first", hmax=hmax, **common,
                     progress=bars[0], on_point=keep_last, start=start, guide=guides[0])
        down = up if flat else None
        if not flat:
            twin = None
            no_coarse_fold = coarse_hmax is None or (
                coarse[0].fold is None and coarse[1].fold is None
                and not coarse[1].start_snapped)
            if (no_coarse_fold and up.fold is None and not up.reason and last
                    and on_point[1] is None):  # whose states were asked for is traced
                twin = tuple(last)
            down = _follow("L", base.replace(length=hi), lo, path="gravity-first", hmax=hmax,
                           **common, progress=bars[1], on_point=on_point[1], start=start,
                           guide=guides[1], twin=twin)
            if isinstance(down, _SameBranch):
                up = replace(up, newton_iterations=up.newton_iterations
                             + down.newton_iterations)
                down = up
    finally:  # also when a continuation raises: no bar left open on the terminal
        for b in bars:
            if b is not None:
                b.close()
    # a branch missing where it starts (its path snapped there) has no fold of its own
    L1 = None if up.start_snapped else up.fold
    L0 = None if down.start_snapped else down.fold
    return Bistability(tip_width, curvature, hmax, (lo, hi), L0, L1,
                       bool(L0 is not None and L1 is not None and L1 - L0 > 2 * tol), up, down,
                       tol, time.perf_counter() - t0, coarse_hmax,
                       sum(c.newton_iterations for c in coarse if c is not None))


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
        Lengths of the turning points (where dL/ds changes sign), in order.
    """

    points: tuple
    folds: tuple
    converged: bool
    message: str = ""
    newton_iterations: int = 0
    wall_time_s: float = 0.0

    def summary(self) -> dict:
        return {"lengths": self.lengths.tolist(), "deflection": self.deflections.tolist(),
                "stable": self.stable, "folds": list(self.folds),
                "converged": self.converged, "message": self.message,
                "newton_iterations": self.newton_iterations, "wall_time_s": self.wall_time_s}


def s_curve(sheet: Sheet, stop: float, *, hmax: float = 0.06, layers=None, solver: str = "auto",
            symmetric: bool = True, ds: float = 0.05, ds_max: float = 0.15, max_points: int = 200,
            progress=None, on_point=None) -> SCurve:
    """Pseudo-arclength continuation in L from the curvature-dominated state
    at ``sheet.length`` until the length exceeds ``stop`` (on whatever branch).

    Unknowns ``(w, L)``; the equilibrium equations are bordered by the
    arclength condition ``<t_u, u - u_0> + t_L (L - L_0) = ds`` with the inner
    product ``<a, b> = a_tip b_tip + theta a . b``: the vertical displacement
    of the tip's centre (so that steps are even along the plotted curve
    d(L)) plus the root-mean-square of all displacements (``theta = 1 /
    number of displacement unknowns``), all in units of a; the pressures
    are left out of the norm.  The continuation is the engine's
    (:func:`skfem_sheet.engine.arclength`): each corrector iteration solves
    the bordered system by block elimination with the one factorisation of
    the tangent, which stays usable through the fold where the tangent alone
    is singular.  Turning points are located where ``t_L`` changes sign, by
    the vertex of the parabola ``L(s)`` through the three points around it.

    One mesh, stretched, serves the whole curve: ``sheet.length`` and ``stop``
    must be within a factor 1.8 of each other.  ``on_point(problem, w, L)``,
    if given, is called with the state of each point (see :func:`follow_length`).
    """
    _check_common(sheet, hmax, 0.5, 0.01)
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
                  ds_max=max(ds_max, ds), tol=_ARCLENGTH_TOLERANCES, max_points=max_points, locate=False,
                  keep_states=False, progress=progress, on_step=on_step,
                  start=(u0, P.held(u0, p0)))
    message = "" if b.completed else b.reason
    folds = _turning_points(np.array(s_hist), np.array(tL_hist), points)
    return SCurve(tuple(points), tuple(folds), b.completed, message,
                  stats.newton_iterations + b.stats.factorizations, time.perf_counter() - t0)


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

