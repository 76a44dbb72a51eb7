"""Branches of equilibria in one parameter: natural and pseudo-arclength continuation.

:func:`natural`
    steps the parameter, predicts with ``du/dp = -K^{-1} R_p`` and corrects
    with Newton at fixed parameter; a failed step (Newton failed, the inertia
    changed, or the state jumped) locates a fold from the last equilibrium
    (:func:`~skfem_sheet.engine.fold.locate_fold`), which ends the branch if
    it lies inside the step; else the step is halved.
:func:`arclength`
    pseudo-arclength continuation in ``(u, p_i)``: the equilibrium equations
    bordered by ``<t_u, u - u_k> + t_p (p_i - p_k) = ds``, solved by block
    elimination with one factorisation of the tangent per iteration
    (:class:`~skfem_sheet.engine.corrector.Bordered`, usable at folds); folds
    are detected by a sign change of ``t_p`` and located from the nearer point.
:func:`sweep`
    continuation through prescribed values of one parameter (load ramps, a
    grid of lengths): no step control, failed corrections kept, a ``revise``
    hook to re-do a step (e.g. in sub-steps).

The drivers take hooks for the problems that need more than the protocol
(``start``, ``linearization``, and for :func:`natural` ``check``,
``before_step``, ``on_step``, ``bracket``, ``growth``): see their parameters.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..params import ParameterError, check_range
from .corrector import (
    DEFAULT_TOLERANCES,
    NewtonResult,
    Tolerances,
    correct,
    plain_linearization,
)
from .fold import (
    arclength_point,
    fold_between,
    locate_fold,
    tangent_at,
    unit_tangent,
)
from .protocol import Counting, EngineFailure, Stats, parameter_index

__all__ = ["Branch", "BranchPoint", "arclength", "natural", "sweep"]


@dataclass(frozen=True)
class BranchPoint:
    """One equilibrium of a branch.

    Attributes
    ----------
    p : ndarray
        Parameters.
    u : ndarray or None
        State (None when the driver was asked not to keep states).
    negative_eigenvalues : int or None
        From the factorised tangent (None if unknown).
    iterations : int
        Newton iterations (factorisations) of its correction.
    tangent_p : float
        Parameter component of the unit tangent (arclength), or 1 (natural).
    s : float
        Arclength from the first point (arclength; natural: the distance
        travelled in the parameter).
    distance : float
        The corrector distance of the step that reached it (the distance
        from its prediction; :func:`~skfem_sheet.engine.loadpath.ramp`).
    """

    p: np.ndarray
    u: object = field(default=None, repr=False)
    negative_eigenvalues: object = None
    iterations: int = 0
    tangent_p: float = 1.0
    s: float = 0.0
    distance: float = 0.0


@dataclass(frozen=True)
class Branch:
    """Result of :func:`natural` and :func:`arclength`.

    Attributes
    ----------
    points : tuple of BranchPoint
    parameter : int
        Index of the continuation parameter.
    folds : tuple of FoldPoint
        Located folds, in the order met.
    completed : bool
        The parameter reached ``stop`` (natural) or left the range (arclength).
    reason : str
        Why the continuation ended otherwise.
    bracket : tuple
        Natural continuation: ``(last value on the branch, first value where
        it was not found)`` when it ended without reaching ``stop``.
    stats : ~skfem_sheet.engine.protocol.Stats
    rejected : int
        Steps tried and rejected (counted by :func:`~skfem_sheet.engine.loadpath.ramp`).
    """

    points: tuple
    parameter: int
    folds: tuple = ()
    completed: bool = False
    reason: str = ""
    bracket: tuple = ()
    stats: Stats = field(default_factory=Stats)
    rejected: int = 0

    @property
    def values(self):
        """The continuation parameter at every point."""
        return np.array([pt.p[self.parameter] for pt in self.points])

    @property
    def fold(self):
        """The first located fold, or None."""
        return self.folds[0] if self.folds else None


def _start(counter, u0, p0, tol, linearization=None, start=None):
    """The first point: corrected at fixed parameters, or ``start`` (an
    already converged point ``(u, factorization)``, taken as it is)."""
    if start is not None:
        u, fact = start
        return NewtonResult(np.array(u, dtype=float), np.array(p0, dtype=float), True, 0, "",
                            (), fact, Stats())
    return _correct(counter, u0, p0, tol, linearization)


def _correct(counter, u, p, tol, linearization=None):
    """One corrector run with the linearisation made by ``linearization(counter)``
    (a ``linearize``, or a pair ``(linearize, admissible)``; default full Newton)."""
    lin = plain_linearization(counter) if linearization is None else linearization(counter)
    linearize, admissible = lin if isinstance(lin, tuple) else (lin, None)
    return correct(counter, u, p, linearize, tol, admissible)


def _without_state(pt):
    return BranchPoint(pt.p, None, pt.negative_eigenvalues, pt.iterations, pt.tangent_p, pt.s,
                       pt.distance)


def natural(problem, u0, p0, param, stop, *, step: float = 0.1, min_step: float = 1e-4,
            max_step=None, tol: Tolerances = DEFAULT_TOLERANCES, jump=np.inf, locate: bool = True,
            check_inertia: bool = False, max_points: int = 10000, keep_states: bool = True,
            progress=None, growth: float = 1.5, grow_after=3, bracket=None,
            inertia_change: bool = True, check=None, before_step=None, on_step=None,
            linearization=None, start=None, approach: int = 8, guide=None) -> Branch:
    """Natural continuation in one parameter with fold detection and location.

    Parameters
    ----------
    problem : Problem
    u0, p0 : ndarray
        Initial guess and parameters of the first point (corrected first).
    param : int or str
        The continuation parameter.
    stop : float
        Continue until ``p[param]`` reaches this value (either direction).
    step, min_step, max_step : float
        First, smallest and largest parameter step (``max_step`` default ``step``).
    tol : Tolerances
    jump : float
        A step whose equilibrium moved further than this (correction norm)
        from its prediction failed: it landed on another branch.
    locate : bool or callable
        Locate a fold when a step fails.  A callable ``locate(counter, u, p,
        i, dudp, factorization, last_try) -> FoldPoint or None`` locates it
        instead of :func:`~skfem_sheet.engine.fold.locate_fold` (e.g.
        :func:`~skfem_sheet.engine.fold.fold_on_branch`), from the last
        equilibrium; ``last_try`` at the last failed step.
    check_inertia : bool
        Passed to :func:`~skfem_sheet.engine.fold.locate_fold`.
    keep_states : bool
        Keep the state of every point (else only of the last).
    progress : callable(value) or None
    growth : float
        Factor by which a step grows after an accepted point ...
    grow_after : int or None
        ... whose correction took at most this many iterations (None: always).
    bracket : float or None
        The branch is lost (bisection ended) when a failed step is no longer
        than this (default ``min_step``): ``Branch.bracket`` is then the last
        value on the branch and the failed one.
    inertia_change : bool
        A step whose tangent has another inertia than the last point's fails.
    check : callable(u, p, result) -> str, optional
        Further acceptance test of a converged step (``result`` its
        :class:`~skfem_sheet.engine.corrector.NewtonResult`): a non-empty
        string rejects the step, with that reason.
    before_step : callable(u, p, value, factorization) -> None or (u, factorization)
        Called before each step to ``value`` (e.g. to remesh the problem):
        a pair replaces the current state and its factorised tangent (same
        parameters); raising :class:`EngineFailure` ends the branch with its
        message as ``reason``.
    on_step : callable(point, result), optional
        Called with every point of the branch (the first included) as it is
        accepted, and the corrector's result (e.g. to write a series).
    linearization : callable(counter) -> linearize or (linearize, admissible), optional
        The corrector's linearisation and trial test (see
        :func:`~skfem_sheet.engine.corrector.correct`), made afresh for every
        correction; default a full Newton step at every iterate.
    start : (u, factorization), optional
        The first point is already converged at ``p0``: take ``u`` as it is,
        with this factorised tangent at (or near) it.
    guide : callable(p_from, p_to) -> ndarray or None, optional
        A correction added to the tangent prediction of the step from
        ``p_from`` to ``p_to``, e.g. the second-order part of the same branch
        on a coarser discretisation (the prediction's error is then the
        difference of the two branches' curvatures).
    approach : int
        The ``approach`` of :func:`~skfem_sheet.engine.fold.locate_fold` at the
        last failed step (for a fold flat in the parameter, whose fold-system
        basin can be smaller than ``min_step``).

    Returns
    -------
    Branch
        ``fold`` is the located fold where the branch ended, if any.

    Examples
    --------
    >>> from skfem_sheet.engine import FunctionProblem
    >>> P = FunctionProblem(lambda u, p: u**3 - u + p[0],
    ...                     lambda u, p: np.diag(3 * u**2 - 1), ("lam",))
    >>> b = natural(P, np.array([1.0]), np.array([0.0]), "lam", 1.0, step=0.1, jump=0.3)
    >>> b.completed, bool(abs(b.fold.value - 2 / (3 * np.sqrt(3))) < 1e-10)
    (False, True)
    """
    counter = problem if isinstance(problem, Counting) else Counting(problem)
    start_stats = counter.stats()
    p = np.array(p0, dtype=float)
    i = parameter_index(counter, param, len(p))
    stop = float(stop)
    step = check_range("step", step, 0, None, lo_open=True)
    min_step = check_range("min_step", min_step, 0, step, lo_open=True)
    max_step = step if max_step is None else check_range("max_step", max_step, step, None)
    growth = check_range("growth", growth, 1.0, None)
    end_at = min_step if bracket is None else check_range("bracket", bracket, min_step, None)
    approach = int(check_range("approach", approach, 0, 1000))
    direction = 1.0 if stop >= p[i] else -1.0

    def finish(points, folds=(), completed=False, reason="", bracket=()):
        return Branch(tuple(points), i, tuple(folds), completed, reason, bracket,
                      counter.stats() - start_stats)

    res = _start(counter, u0, p, tol, linearization, start)
    if not res.converged:
        return finish([], reason=f"the first point did not converge: {res.reason}")
    u, p, fact = res.u, res.p, res.factorization
    k = fact.inertia()
    points = [BranchPoint(p.copy(), u, k, res.iterations)]
    if on_step is not None:
        on_step(points[-1], res)
    h = step
    dudp = None
    while (stop - p[i]) * direction > 1e-14 and len(points) < max_points:
        lam_try = p[i] + direction * min(h, abs(stop - p[i]))
        try:
            if before_step is not None:
                moved = before_step(u, p, lam_try, fact)
                if moved is not None:
                    u, fact = moved
                    dudp = None
            if dudp is None:  # at a new point (kept through failed steps)
                dudp = fact.solve(-counter.dresidual(u, p, i))
        except EngineFailure as err:
            return finish(points, reason=str(err) or "tangent failed")
        pt = p.copy()
        pt[i] = lam_try
        u_pred = u + (lam_try - p[i]) * dudp
        extra = guide(p, pt) if guide is not None else None
        if extra is not None:
            u_pred = u_pred + extra
        res = _correct(counter, u_pred, pt, tol, linearization)
        why = "" if res.converged else f"Newton: {res.reason}"
        if res.converged:
            k_new = res.factorization.inertia()
            if counter.correction_norm(res.u - u_pred) > jump:
                why = "the state jumped (another branch)"
            elif (inertia_change and k is not None and k_new is not None and k_new != k):
                why = f"the inertia changed from {k} to {k_new}"
            elif check is not None:
                why = check(res.u, res.p, res)
        if not why:
            s = points[-1].s + abs(lam_try - p[i])
            u, p, fact, k = res.u, res.p, res.factorization, k_new
            dudp = None
            if not keep_states:
                points[-1] = _without_state(points[-1])
            points.append(BranchPoint(p.copy(), u, k, res.iterations, 1.0, s))
            if on_step is not None:
                on_step(points[-1], res)
            if progress is not None:
                progress(float(p[i]))
            grow = grow_after is None or res.iterations <= grow_after
            h = min(max_step, h * (growth if grow else 1.0))
            continue
        last_try = abs(lam_try - p[i]) <= end_at * (1 + 1e-9)
        if locate:
            # approached along the branch (if Newton on the fold system fails)
            # only before the branch is given up: after a failed step far from
            # a fold the approach would be spent for nothing
            if callable(locate):
                fold = locate(counter, u, p, i, dudp, fact, last_try)
            else:
                fold, _ = locate_fold(counter, u, p, i, v0=dudp, tol=tol,
                                      check_inertia=check_inertia,
                                      approach=approach if last_try else 0)
            # a fold ahead, within the failed step (Newton at fixed parameter
            # also fails just before a fold, so allow twice the step)
            # and a turning point of this branch: solutions exist behind it
            ahead = (fold.value - p[i]) * direction if fold is not None else -1.0
            if (fold is not None and -1e-12 <= ahead <= 2 * abs(lam_try - p[i]) + 1e-12
                    and fold.side != direction):
                return finish(points, [fold], reason=f"fold at {fold.value:.10g} ({why})",
                              bracket=(float(p[i]), float(lam_try)))
        if last_try:
            return finish(points, reason=(f"step below min_step ({why})" if bracket is None
                                          else why),
                          bracket=(float(p[i]), float(lam_try)))
        h = max(0.5 * abs(lam_try - p[i]), min_step)
    return finish(points, completed=(stop - p[i]) * direction <= 1e-14,
                  reason="" if (stop - p[i]) * direction <= 1e-14 else "max_points")


def sweep(problem, u0, p0, param, values, *, tol: Tolerances = DEFAULT_TOLERANCES,
          linearization=None, predict: bool = False, revise=None) -> tuple:
    """Continuation through prescribed values of one parameter (no step control).

    The first value is corrected from ``u0``, every next one from the last
    converged state (predicted along the tangent ``du/dp`` if ``predict``).
    A correction that fails is kept (``converged=False``) and the next value
    starts again from the last converged state (a descent method lands on
    the branch that still exists: the jump).

    Parameters
    ----------
    problem : Problem
    u0, p0 : ndarray
        Initial guess for the first value, and the other parameters.
    param : int or str
    values : sequence of float
        The values of ``p[param]``, in order.
    tol : Tolerances
    linearization : callable(counter) -> linearize or (linearize, admissible), optional
        As in :func:`natural`.
    predict : bool
        Predict along the tangent (one back-substitution) instead of starting
        from the last state as it is.
    revise : callable(k, value, result, last) -> result, optional
        May replace the result of the ``k``-th value (e.g. by re-doing the
        step in sub-steps); ``last`` is the last converged result before it
        (None for the first value).

    Returns
    -------
    tuple of NewtonResult
        One per value, in order.

    Examples
    --------
    >>> from skfem_sheet.engine import FunctionProblem
    >>> P = FunctionProblem(lambda u, p: u**3 - u + p[0],
    ...                     lambda u, p: np.diag(3 * u**2 - 1), ("lam",))
    >>> out = sweep(P, np.array([1.0]), np.array([0.0]), 0, [0.1, 0.2, 0.3])
    >>> [bool(r.converged) for r in out], round(float(out[-1].u[0]), 6)
    ([True, True, True], 0.786483)
    """
    counter = problem if isinstance(problem, Counting) else Counting(problem)
    p = np.array(p0, dtype=float)
    i = parameter_index(counter, param, len(p))
    u = np.array(u0, dtype=float)
    last, out = None, []
    for k, value in enumerate(values):
        pt = p.copy()
        pt[i] = float(value)
        guess = u
        if predict and last is not None and last.factorization is not None:
            try:
                guess = u + (pt[i] - p[i]) * last.factorization.solve(
                    -counter.dresidual(u, p, i))
            except EngineFailure:
                guess = u
        res = _correct(counter, guess, pt, tol, linearization)
        if revise is not None:
            res = revise(k, float(value), res, last)
        out.append(res)
        if res.converged:
            u, p, last = res.u, res.p, res
    return tuple(out)


def arclength(problem, u0, p0, param, bounds, *, ds: float = 0.05, ds_min: float = 1e-6,
              ds_max: float = 0.2, direction: int = 1, tol: Tolerances = DEFAULT_TOLERANCES,
              max_points: int = 1000, locate: bool = True, check_inertia: bool = False,
              keep_states: bool = True, progress=None, on_step=None, start=None,
              turn=None) -> Branch:
    """Pseudo-arclength continuation in one parameter, through folds.

    Parameters
    ----------
    problem : Problem
    u0, p0 : ndarray
        First point (corrected first at fixed parameters).
    param : int or str
    bounds : (float, float)
        Stop when ``p[param]`` leaves ``[lo, hi]`` (``completed``).
    ds, ds_min, ds_max : float
        First, smallest and largest arclength step (in the norm
        ``sqrt(<u, u> + p^2)``).
    direction : {1, -1}
        Initial direction in the parameter.
    tol : Tolerances
    locate : bool
        Locate every fold met (sign change of ``t_p``).
    keep_states : bool
        Keep the state of every point.
    on_step : callable(point, result), optional
        Called with every point (the first included) as it is accepted, and
        the corrector's result; ``point.s`` is its arclength from the first.
    start : (u, factorization), optional
        The first point is already converged at ``p0``: take ``u`` as it is,
        with this factorised tangent at (or near) it.
    turn : float, optional
        Step control by the curve's bending (radians): the angle between
        consecutive unit tangents is kept near ``turn``.  A step that turned
        by more than twice as much is rejected and halved, as is one whose
        new tangent points back along its chord (a sharp fold crossed) or
        across which the inertia changes while ``t_p`` keeps its sign; the
        next step is scaled by ``turn / angle`` (between 1/2 and 1.5).
        Default: none (the steps grow after easy corrections).

    Returns
    -------
    Branch

    Examples
    --------
    >>> from skfem_sheet.engine import FunctionProblem
    >>> P = FunctionProblem(lambda u, p: u**3 - u + p[0],
    ...                     lambda u, p: np.diag(3 * u**2 - 1), ("lam",))
    >>> b = arclength(P, np.array([-1.5]), np.array([1.875]), 0, (-2.0, 2.0), ds=0.2,
    ...               direction=-1)
    >>> b.completed, [round(float(f.value), 10) for f in b.folds]
    (True, [-0.3849001795, 0.3849001795])

    With the step control by the bending, the points crowd at the folds:

    >>> b = arclength(P, np.array([-1.5]), np.array([1.875]), 0, (-2.0, 2.0), ds=0.05,
    ...               ds_max=1.0, direction=-1, turn=0.1)
    >>> s = np.array([pt.s for pt in b.points]); u = np.array([pt.u[0] for pt in b.points])
    >>> step = np.diff(s)
    >>> bool(step[np.argmin(np.abs(u[1:] - 0.577))] < 0.5 * step.max())  # near a fold
    True
    """
    counter = problem if isinstance(problem, Counting) else Counting(problem)
    start_stats = counter.stats()
    p = np.array(p0, dtype=float)
    i = parameter_index(counter, param, len(p))
    lo, hi = (float(x) for x in bounds)
    if not lo < hi:
        raise ParameterError(f"bounds must be (low, high) with low < high, got {bounds!r}")
    if direction not in (1, -1):
        raise ParameterError(f"direction must be 1 or -1, got {direction!r}")
    ds = check_range("ds", ds, 0, None, lo_open=True)
    ds_min = check_range("ds_min", ds_min, 0, ds, lo_open=True)
    ds_max = check_range("ds_max", ds_max, ds, None)
    if turn is not None:
        turn = check_range("turn", turn, 0, np.pi / 2, lo_open=True)

    def finish(points, folds, completed=False, reason=""):
        return Branch(tuple(points), i, tuple(folds), completed, reason, (),
                      counter.stats() - start_stats)

    res = _start(counter, u0, p, tol, start=start)
    if not res.converged:
        return finish([], [], reason=f"the first point did not converge: {res.reason}")
    u, p, fact = res.u, res.p, res.factorization
    try:
        t = unit_tangent(counter, fact.solve(-counter.dresidual(u, p, i)), 1.0)
    except EngineFailure as err:
        return finish([], [], reason=f"tangent at the first point: {err}")
    if t[1] * direction < 0:
        t = (-t[0], -t[1])
    points = [BranchPoint(p.copy(), u, fact.inertia(), res.iterations, t[1])]
    if on_step is not None:
        on_step(points[-1], res)
    folds = []
    h = ds
    while len(points) < max_points:
        res = arclength_point(counter, i, t, u, p, h, tol)
        if not res.converged:
            h *= 0.5
            if h < ds_min:
                return finish(points, folds, reason=f"arclength step below ds_min at "
                              f"p = {p[i]:.6g} (Newton: {res.reason})")
            continue
        try:
            t_new = tangent_at(counter, res, t)
        except EngineFailure as err:
            return finish(points, folds, reason=f"tangent: {err}")
        angle = None
        if turn is not None:
            cos = counter.inner(t[0], t_new[0]) + t[1] * t_new[1]
            angle = float(np.arccos(np.clip(cos, -1.0, 1.0)))
            # the new tangent is oriented along the last one (within a right
            # angle of it): where the curve turned by more within the step (a
            # sharp fold crossed), it points back along the chord, and the
            # continuation would run back the way it came
            back = (counter.inner(res.u - u, t_new[0])
                    + (res.p[i] - p[i]) * t_new[1]) < 0
            # ... or it did and the chord does not show it, but the inertia
            # does: one eigenvalue crossed zero while the tangent kept its
            # parameter component's sign
            k_last, k_step = points[-1].negative_eigenvalues, res.factorization.inertia()
            hidden = (k_last is not None and k_step is not None and k_step != k_last
                      and np.sign(t_new[1]) == np.sign(t[1]))
            if (back or hidden or angle > 2.0 * turn) and 0.5 * h >= ds_min:
                h *= 0.5  # the step turned too far: the same step, halved
                continue
        k_new = res.factorization.inertia()
        prev_point = points[-1]
        if not keep_states:
            points[-1] = _without_state(prev_point)
        new_point = BranchPoint(res.p.copy(), res.u, k_new, res.iterations, t_new[1],
                                prev_point.s + h)
        if locate and np.sign(t_new[1]) != np.sign(t[1]):
            fold = fold_between(counter, i, t, u, p, h, res, t_new, tol, check_inertia)
            if fold is not None:
                folds.append(fold)
        points.append(new_point)
        if on_step is not None:
            on_step(new_point, res)
        u, p, t = res.u, res.p, t_new
        if progress is not None:
            progress(float(p[i]))
        if not lo <= p[i] <= hi:
            return finish(points, folds, completed=True)
        grow = 1.5 if res.iterations <= 3 else 1.0
        if angle is not None:
            grow = min(grow, max(0.5, turn / angle if angle > 0 else np.inf))
        h = max(ds_min, min(ds_max, h * grow))
    return finish(points, folds, reason="max_points")
