"""Continuation in a load parameter up to its full value: the load paths' driver.

:func:`ramp` follows the branch of equilibria through a start point as one
parameter (the load) goes to ``stop``, and ends either there or at the first
*turning point* of the load, located:

- **steps**: natural where the branch's direction has a parameter component
  of at least ``1/sqrt(2)`` (as BifurcationKit's ``AutoSwitch``), else
  pseudo-arclength; a natural step whose Newton fails is retried as a
  pseudo-arclength one.  The direction is the unit tangent at the first
  point, then the secant of the last two (``docs/decisions.md``, "The secant
  direction").
- **acceptance** (the one step rule, :class:`~skfem_sheet.engine.steps.StepRule`):
  the corrector converged (:class:`~skfem_sheet.engine.corrector.ChordTest`),
  its distance from the prediction is at most four times the nominal one,
  and above the nominal one the *halving test*: the half step must land at
  most half as far (a smooth branch: a quarter).  The next step aims at the
  nominal distance.
- **turning points**: the secant's parameter component changes sign,
  confirmed by one more negative eigenvalue past the turn, and the fold is
  located on the branch (:func:`~skfem_sheet.engine.fold.fold_on_branch`,
  else :func:`~skfem_sheet.engine.fold.locate_fold`).  A step across which
  the inertia changes without a turn is rejected.
- **folds within a step**: from the parabola the parameter makes near a
  fold, the next step is at most three times the distance to where the line
  of the falling rate ``|t_p|`` vanishes (:func:`_turn_bound`), and at a
  minimum of the rate the fold is searched on the branch either side.
- **turns too sharp for the steps**: a point's error must be at most a tenth
  of its distance from the last point (:class:`SecantTest`); where the steps
  shrink below the minimum, the last points are checked to the end tolerance
  and the turn ahead is located along the tangent
  (:func:`_fold_where_stalled`); a stall without a turn ahead is a failure
  that says what was found.

The driver ends at the fold: what happens there (a snap onto another branch)
is the caller's.

Examples
--------
A spring that softens, ``R = u - u^3/3 - lam``, turns at ``lam = 2/3``
(``u = 1``); from ``lam = 0`` the ramp to ``lam = 1`` ends there:

>>> from skfem_sheet.engine import FunctionProblem
>>> P = FunctionProblem(lambda u, p: u - u**3 / 3 - p[0],
...                     lambda u, p: np.diag(1 - u**2), ("lam",))
>>> b = ramp(P, np.zeros(1), np.zeros(1), "lam", 1.0, rule=StepRule(delta=0.01))
>>> b.completed, round(b.fold.value, 10), round(float(b.fold.u[0]), 6)
(False, 0.6666666667, 1.0)
"""
from __future__ import annotations

import logging
from dataclasses import replace

import numpy as np

from ..params import ParameterError, check_range
from .branch import Branch, BranchPoint
from .corrector import (
    DEFAULT_TOLERANCES,
    ChordTest,
    NewtonResult,
    Tolerances,
    correct,
    plain_linearization,
)
from .fold import (
    arclength_point,
    fold_between,
    fold_on_branch,
    locate_fold,
    section_linearization,
    tangent_at,
    unit_tangent,
)
from .protocol import Counting, EngineFailure, Stats, parameter_index
from .steps import StepRule, corrector_distance

__all__ = ["NATURAL_SLOPE", "SecantTest", "ramp"]

log = logging.getLogger(__name__)

#: Natural steps while the tangent's parameter component is at least this
#: (a branch closer to the parameter axis than to the state space).
NATURAL_SLOPE = 1.0 / np.sqrt(2.0)


def _first(counter, u0, p0, tol, start):
    if start is not None:
        u, fact = start
        return NewtonResult(np.array(u, dtype=float), np.array(p0, dtype=float), True, 0, "",
                            (), fact, Stats())
    return correct(counter, np.array(u0, dtype=float), np.array(p0, dtype=float),
                   plain_linearization(counter), tol, converged=ChordTest(counter, tol))


def _predict(points, i, at, value, t):
    """Prediction ``(u, p)`` along the direction ``t`` of the last point (the
    unit tangent at the first point, then the secant of the last two), at
    the arclength ``value`` from it (``at="s"``) or at the parameter
    ``value`` (``at="p"``).  Its error is second order in the step (not
    third: ``docs/decisions.md``, "The secant direction")."""
    last = points[-1]
    h = value - (last.s if at == "s" else last.p[i])
    if at == "s":
        du, dq = h * t[0], h * t[1]
    else:
        du, dq = h * t[0] / t[1], h
    p = last.p.copy()
    p[i] += dq
    return last.u + du, p


class SecantTest:
    """The step corrector's stopping test: :class:`~skfem_sheet.engine.corrector.ChordTest`
    (the residual and the simplified-Newton correction at the iterate within
    the tolerances), and the iterate's error small against its distance from
    the last point: the simplified correction (the error estimate) at most
    :attr:`SECANT_ACCURACY` times that distance.

    The next step is predicted along the secant of the last two points, so a
    point's error ``e`` turns the secant's direction by about ``e / chord``;
    a tenth keeps it within the accuracy that the points on the way are
    solved to anyway (a tenth of the nominal corrector distance,
    ``StepOptions.intermediate_utol``), where the steps are nominal; only
    short steps, near a fold, ask more of their points than that.  Past a
    fold, where no equilibrium is near, Newton's iterates wander about the
    fold state (the Newton map of ``x^2 + e = 0`` is chaotic) with
    corrections of the size of the short steps that led there; one of them
    can meet a loose tolerance, but not a tenth of its distance from the
    last point, and such a point is not taken for a point of the branch (the
    secant through it would point anywhere).  The parameter part of the
    distance counts divided by the chord test's ``parameter_scale``.

    Examples
    --------
    >>> from skfem_sheet.engine import FunctionProblem
    >>> P = Counting(FunctionProblem(lambda u, p: u**2 - p[0], lambda u, p: np.diag(2 * u)))
    >>> tol = DEFAULT_TOLERANCES
    >>> test = SecantTest(ChordTest(P, tol), P, np.array([1.0]), np.array([1.0]))
    >>> r = correct(P, np.array([1.0]), np.array([2.0]), plain_linearization(P), tol,
    ...             converged=test)
    >>> r.converged, round(float(r.u[0]), 10)
    (True, 1.4142135624)
    """

    #: Largest error of an accepted point, relative to its distance from the
    #: last point (see the class).
    SECANT_ACCURACY = 0.1

    def __init__(self, test: ChordTest, counter, u_last, p_last):
        self.test, self.counter = test, counter
        self.last = (np.asarray(u_last, dtype=float), np.asarray(p_last, dtype=float))

    def __call__(self, u, p, fact, extra):
        if not self.test(u, p, fact, extra):
            return False
        u0, p0 = self.last
        dp = np.asarray(p, dtype=float) - p0
        chord = max(self.counter.correction_norm(np.asarray(u) - u0),
                    float(np.abs(dp).max()) / self.test.scale if dp.size else 0.0)
        return self.test.norms[-1] <= self.SECANT_ACCURACY * chord


def _natural(counter, u, p, u_pred, p_pred, tol):
    """Newton at the prediction's parameter from the prediction (the last
    point ``(u, p)``)."""
    test = SecantTest(ChordTest(counter, tol, start=u_pred), counter, u, p)
    return correct(counter, u_pred, p_pred, plain_linearization(counter, reference=u), tol,
                   converged=test)


def _arclength(counter, u, p, u_pred, p_pred, i, tol):
    """The equilibrium on the hyperplane through the prediction normal to the
    chord from the last point ``(u, p)`` to it."""
    du, dq = u_pred - u, float(p_pred[i] - p[i])
    h = float(np.sqrt(counter.inner(du, du) + dq**2))
    t_u, t_p = du / h, dq / h

    def distance(uu, pp):
        return counter.inner(t_u, uu - u) + t_p * (pp[i] - p[i]) - h

    test = ChordTest(counter, tol, distance, max(abs(t_p), 1e-12), start=u_pred)
    return correct(counter, u_pred, p_pred,
                   section_linearization(counter, i, t_u, t_p, distance, reference=u),
                   tol, converged=SecantTest(test, counter, u, p))


def _turn_bound(points, rate_at):
    """The longest next step that keeps a turning point ahead detectable.

    Near a fold the parameter is a parabola in the arclength and the rate
    ``|t_p|`` at which it moves is linear in it, vanishing at the turn.
    Where the secants' rates fell over the last two steps, the line through
    the last secant's rate (the parabola's slope at the secant's midpoint)
    and the rate of the tangent at the last point (``rate_at()``, from the
    factorisation its correction ended with) vanishes ``a`` beyond the last
    point, and a step of ``3 a`` ends past the turn with the parameter below
    the last point's (``2 a`` ends level with it), which :func:`ramp` detects
    and locates.  A longer step can cross a sharp fold, or a thin S-shaped
    fold pair, turning (and turning back) within the step with no sign of it
    at its ends (``docs/decisions.md``, "Folds within a step").  None where the rates did not fall, or the tangent's rate is not
    below the secant's (no turn ahead by this line).
    """
    if len(points) < 2:
        return None
    b, c = points[-2], points[-1]
    r0, r1 = abs(float(b.tangent_p)), abs(float(c.tangent_p))
    if not r1 < r0:
        return None
    r = rate_at()
    if r is None or not r < r1:
        return None
    half = 0.5 * (c.s - b.s)  # from the secant's midpoint to the point
    return 3.0 * r * half / (r1 - r)


def _tangent(counter, res, i):
    """The unit tangent ``(t_u, t_p)`` at a corrected point ``res``, from the
    factorisation its correction ended with (one back-substitution); raises
    :class:`EngineFailure`."""
    return unit_tangent(counter, res.factorization.solve(-counter.dresidual(res.u, res.p, i)),
                        1.0)


def _tangent_rate(counter, res, i):
    """``|t_p|`` of :func:`_tangent`, or None where it fails."""
    try:
        return abs(float(_tangent(counter, res, i)[1]))
    except EngineFailure:
        return None


def _hessian_inertia(counter, u, p):
    """Negative eigenvalues of the Hessian at ``(u, p)`` (one factorisation)."""
    try:
        return counter.factorize(counter.jacobian(u, p)).inertia()
    except EngineFailure:
        return None


def _turn_estimate(counter, i, nodes):
    """Where the parameter turns on the branch through ``nodes`` (the last
    points, ``(s, u, p_i)``, two or three, the last past the turn): the
    vertex ``s*`` of the parabola of ``p_i(s)`` through three of them (the
    midpoint of the last two with two), and the state and unit direction of
    the interpolant of ``u(s)`` there."""
    s = np.array([x[0] for x in nodes])
    q = np.array([x[2] for x in nodes])
    U = [x[1] for x in nodes]
    s_star = 0.5 * (s[-2] + s[-1])
    if len(nodes) == 3:
        c = np.polyfit(s, q, 2)
        if c[0] != 0:
            vertex = -c[1] / (2 * c[0])
            if s[0] <= vertex <= s[-1]:
                s_star = float(vertex)
    # Lagrange weights and their derivatives at s*
    n = len(s)
    w, dw = np.ones(n), np.zeros(n)
    for a in range(n):
        others = [b for b in range(n) if b != a]
        den = np.prod([s[a] - s[b] for b in others])
        w[a] = np.prod([s_star - s[b] for b in others]) / den
        dw[a] = sum(np.prod([s_star - s[b] for b in others if b != c]) for c in others) / den
    u = sum(wk * uk for wk, uk in zip(w, U))
    p = float(w @ q)
    du = sum(wk * uk for wk, uk in zip(dw, U))
    return u, p, du


def _locate(counter, i, p_ref, nodes, tol, check_inertia, ptol):
    """The fold where the parameter turns among ``nodes`` (see
    :func:`_turn_estimate`): on the branch from the interpolated turning
    point, along the branch's direction there (the approximate null vector;
    :func:`~skfem_sheet.engine.fold.fold_on_branch`); if that fails, by Newton
    on the minimally augmented system from the last point before the turn,
    approaching the fold along the branch where the fold system's basin is
    smaller than the distance to it (:func:`~skfem_sheet.engine.fold.locate_fold`)."""
    u_star, p_star, du = _turn_estimate(counter, i, nodes)
    p = p_ref.copy()
    p[i] = p_star
    if counter.inner(du, du) > 0:
        fold, _ = fold_on_branch(counter, u_star, p, i, du, tol=tol, ptol=ptol,
                                 check_inertia=check_inertia)
        if fold is not None:
            return fold
    s0, u0, q0 = nodes[-2]
    p0 = p_ref.copy()
    p0[i] = q0
    res = correct(counter, u0, p0, plain_linearization(counter), tol)
    if not res.converged:
        return None
    fold, _ = locate_fold(counter, res.u, res.p, i, v0=du, tol=tol,
                          check_inertia=check_inertia, approach=8)
    return fold


def _turn_ahead(counter, i, u, p, t, h, tol, check_inertia, max_corrections=24):
    """The fold ahead of the equilibrium ``(u, p)`` (unit tangent ``t``, the
    branch's direction) within about the arclength ``2 h``: pseudo-arclength
    corrections along the tangent of each point (not a secant), to ``tol``,
    halved where they fail (the section lies past a sharp turn, which the
    branch does not reach; a correction is given up once its first Newton
    step is longer than the section's distance, the first-order estimate of
    how far it must go), until the tangent's load component changes sign;
    then the fold between those two points
    (:func:`~skfem_sheet.engine.fold.fold_between`).  None if no sign
    change within ``max_corrections`` corrections."""
    h_min = h * 2.0**-14
    for _ in range(max_corrections):
        try:
            res = arclength_point(counter, i, t, u, p, h,
                                  replace(tol, max_correction=min(tol.max_correction, h)))
            t_new = tangent_at(counter, res, t) if res.converged else None
        except EngineFailure:
            res, t_new = None, None
        log.debug("turn ahead of %.8g: step %.3g %s%s", p[i], h,
                  "failed" if t_new is None else f"to {res.p[i]:.8g}, t_p {t_new[1]:.3g}",
                  "" if res is None else f" ({res.iterations} iterations)")
        if t_new is None:
            h *= 0.5
            if h < h_min:
                return None
            continue
        if np.sign(t_new[1]) != np.sign(t[1]):
            try:
                return fold_between(counter, i, t, u, p, h, res, t_new, tol, check_inertia)
            except EngineFailure:
                return None
        u, p, t = res.u, res.p, t_new
    return None


def _on_the_branch(counter, point, tol, end_tol) -> bool:
    """Whether a point accepted to the loose tolerance ``tol`` is a point of
    the branch: Newton from it converges to ``end_tol`` within ``tol.utol``
    of it (past a fold, where no equilibrium is near, it does not)."""
    try:
        res = correct(counter, point.u, point.p, plain_linearization(counter), end_tol)
    except EngineFailure:
        return False
    return bool(res.converged and counter.correction_norm(res.u - point.u) <= tol.utol)


def _behind(fold, p_last, direction, fold_tol) -> bool:
    """Whether ``fold`` lies behind ``p_last`` in the direction of the ramp
    (by more than the fold tolerance): not the turn of a branch that went
    on to ``p_last``."""
    return (fold.value - float(p_last)) * direction < -fold_tol * max(1.0, abs(fold.value))


def _fold_where_stalled(counter, points, i, direction, tol, end_tol, fold_tol, k,
                        minimum):
    """The fold at which the steps stalled: ``(fold, kept)`` (``kept`` the
    number of points that lie on the branch before it), or ``(None, why)``.

    Steps shrink below the minimum, Newton failing for every one however
    short, where the branch ends ahead in a turn too sharp for the steps:
    natural corrections fail beyond a fold, pseudo-arclength sections past a
    hairpin turn miss the branch, and along a secant whose direction is off
    (through a point accepted to the loose tolerance of the points on the
    way past the fold, where Newton's iterates wander about the fold state,
    :class:`SecantTest`) every section does.  The last points are checked
    first, latest first: a point of the branch is an equilibrium to
    ``end_tol`` within the loose tolerance ``tol.utol`` of itself (Newton from
    it converges there); points that are not lie past the fold and are
    dropped.  From the last point of the branch the turn is approached along
    the branch (:func:`_turn_ahead`, from its tangent, within the arclength
    to the first point dropped, or the minimum step) and located there, and
    kept if it is the branch's turning point ahead: the load turns back
    there (solutions behind it) and one eigenvalue crosses zero (the count
    ``k`` of the branch and one more)."""
    reach = None
    for kept in range(len(points), max(0, len(points) - 4), -1):
        pt = points[kept - 1]
        try:
            res = correct(counter, pt.u, pt.p, plain_linearization(counter), end_tol)
        except EngineFailure:
            res = None
        if res is None or not res.converged or \
                counter.correction_norm(res.u - pt.u) > tol.utol:  # (as _on_the_branch)
            log.debug("stalled: the point at %.6g is not on the branch", pt.p[i])
            reach = pt
            continue
        try:
            t = _tangent(counter, res, i)
        except EngineFailure as err:
            return None, f"no tangent at the last point of the branch ({err})"
        if t[1] * direction < 0:
            t = (-t[0], -t[1])
        if reach is not None:  # the fold lies before the first point dropped
            h = 0.5 * (reach.s - pt.s)
        else:  # within the steps that failed from the last point: the last step's length
            h = 0.5 * (pt.s - points[kept - 2].s) if kept > 1 else minimum
        fold = _turn_ahead(counter, i, res.u, res.p, t, h, end_tol, True)
        if fold is None:
            return None, f"no turn of the load found ahead of {pt.p[i]:.6g}"
        log.debug("stalled: fold from %.6g at %.8g, side %s, crossing %s", pt.p[i], fold.value,
                  fold.side, fold.crossing)
        lo, hi = sorted(fold.crossing) if fold.crossing is not None else (None, None)
        if _behind(fold, pt.p[i], direction, fold_tol) or fold.side != -direction or lo is None or hi - lo != 1 \
                or (k is not None and lo != k):
            return None, (f"the turn located ahead of {pt.p[i]:.6g}, at {fold.value:.6g} (side "
                          f"{fold.side}, inertia {fold.crossing}), is not where the branch "
                          f"turns back with one eigenvalue crossing")
        return replace(fold, crossing=(lo, hi)), kept
    return None, "no point near the end is an equilibrium to the end tolerance"


def ramp(problem, u0, p0, param, stop, *, rule: StepRule = StepRule(),
         tol: Tolerances = DEFAULT_TOLERANCES, end_tol: Tolerances | None = None,
         start=None, on_step=None, progress=None, max_points: int = 1000,
         check_inertia: bool = False, fold_tol: float = 1e-9) -> Branch:
    """Follow the branch through ``(u0, p0)`` until ``p[param]`` reaches
    ``stop`` or the parameter turns (a fold, located).

    Parameters
    ----------
    problem : Problem
    u0, p0 : ndarray
        Start (corrected first at fixed parameters, unless ``start``).
    param : int or str
        The load parameter.
    stop : float
        Its end value (either direction).
    rule : StepRule
        Step lengths and acceptance (the one rule of the drivers).
    tol : Tolerances
        Newton's tolerances at the points on the way.
    end_tol : Tolerances, optional
        The end point (``p[param] = stop``), reached with ``tol`` like every
        point, is then corrected to these (from there: one or two Newton
        iterations), and a fold is located to them (default ``tol``).
    start : (u, factorization), optional
        ``(u0, p0)`` is already an equilibrium, with this factorised tangent.
    on_step : callable(point, result), optional
        Called with every accepted point after the first (also with a point
        that a fold found later within the step into it withdraws from
        ``points``: it lies past that fold).
    progress : callable(value), optional
    max_points : int
    check_inertia : bool
        Also count the negative eigenvalues on both sides of a located fold
        (two factorisations; :attr:`FoldPoint.crossing`).
    fold_tol : float
        The located fold's tolerance in the parameter (relative to ``max(1,
        |p|)``; ``ptol`` of :func:`~skfem_sheet.engine.fold.fold_on_branch`).

    Returns
    -------
    Branch
        ``completed`` if ``stop`` was reached; else ``fold`` is the located
        turning point (``reason`` says where), or ``reason`` says why the
        branch could not be followed (a step below ``rule.minimum``, a
        turning point that could not be located, an inertia change without
        a turn).  ``points`` are the accepted points (``tangent_p`` the
        parameter component of the direction there; ``negative_eigenvalues``
        where the Hessian's inertia was read), ``rejected`` the rejected steps.
    """
    counter = problem if isinstance(problem, Counting) else Counting(problem)
    start_stats = counter.stats()
    p = np.array(p0, dtype=float)
    i = parameter_index(counter, param, len(p))
    stop = float(stop)
    if not np.isfinite(stop):
        raise ParameterError(f"stop must be finite, got {stop!r}")
    max_points = int(check_range("max_points", max_points, 1, None))
    end_tol = tol if end_tol is None else end_tol
    # the corrections of the steps: stopped after a first Newton correction
    # beyond the rule's bound on the distance (the step is rejected)
    step_tol = replace(tol, max_correction=min(tol.max_correction, rule.bound))
    direction = 1.0 if stop >= p[i] else -1.0
    points, rejected = [], 0

    def finish(completed=False, reason="", folds=()):
        return Branch(tuple(points), i, tuple(folds), completed, reason, (),
                      counter.stats() - start_stats, rejected)

    res = _first(counter, u0, p, tol, start)
    if not res.converged:
        return finish(reason=f"the first point did not converge: {res.reason}")
    try:
        t = _tangent(counter, res, i)
    except EngineFailure as err:
        return finish(reason=f"tangent at the first point: {err}")
    if t[1] * direction < 0:
        t = (-t[0], -t[1])
    k = res.factorization.inertia()  # of the Hessian along the branch (None: not known)
    points.append(BranchPoint(res.p.copy(), res.u, k, res.iterations, t[1], 0.0))

    def attempt(h, natural_ok=True):
        """A step of length ``h`` from the last point: ``(result, distance,
        natural)`` (distance None if Newton failed).  With ``natural_ok``
        False, pseudo-arclength also where the branch is gentle (Newton at
        fixed parameter fails ahead of a fold that the slope did not show)."""
        u, p = points[-1].u, points[-1].p
        remaining = (stop - p[i]) * direction
        slope = abs(t[1])
        natural = h * slope >= remaining or (natural_ok and slope >= NATURAL_SLOPE)
        if natural:
            value = p[i] + direction * min(h * slope, remaining)
            u_pred, p_pred = _predict(points, i, "p", value, t)
            res = _natural(counter, u, p, u_pred, p_pred, step_tol)
        else:
            u_pred, p_pred = _predict(points, i, "s", points[-1].s + h, t)
            res = _arclength(counter, u, p, u_pred, p_pred, i, step_tol)
            if res.converged and (stop - res.p[i]) * direction < 0:
                # the branch passes the end within the step: land on the end
                # from the interpolation between the two points
                a = (stop - p[i]) / (res.p[i] - p[i])
                u_pred, p_pred = u + a * (res.u - u), res.p.copy()
                p_pred[i] = stop
                res = _natural(counter, u, p, u_pred, p_pred, step_tol)
        dist = corrector_distance(counter, res, u_pred, p_pred) if res.converged else None
        log.debug("step h=%.4g (%s, slope %.3g): p %.6g -> %.6g, converged %s, distance %s, "
                  "%d iterations %s", h, "natural" if natural else "arclength", slope, p[i],
                  res.p[i], res.converged, dist, res.iterations, res.reason)
        return res, dist, natural

    def examine(res):
        """The checks of a point on the branch after the last one: ``("",
        point data)`` to accept it, ``("fold", FoldPoint or None)`` where the
        parameter turned (one eigenvalue crossing), or ``(why, None)``."""
        nonlocal k
        u, p = points[-1].u, points[-1].p
        du, dq = res.u - u, float(res.p[i] - p[i])
        chord = float(np.sqrt(counter.inner(du, du) + dq**2))
        turned = dq * direction <= 0
        k_new = res.factorization.inertia()
        if turned or (k is not None and k_new is not None and k_new != k):
            k_new = _hessian_inertia(counter, res.u, res.p)  # at the point itself
        if turned and (k is None or k_new is None or k_new == k + 1):
            nodes = [(pt.s, pt.u, float(pt.p[i])) for pt in points[-2:]]
            nodes.append((points[-1].s + chord, res.u, float(res.p[i])))
            f0 = counter.stats().factorizations
            fold = _locate(counter, i, p, nodes, end_tol, check_inertia, fold_tol)
            if fold is not None and _behind(fold, p[i], direction, fold_tol) \
                    and not _on_the_branch(counter, points[-1], tol, end_tol):
                # the last point, accepted to the loose tolerance of the points
                # on the way, lies past the fold (no equilibrium there): the
                # fold is the branch's turn, and the point is withdrawn
                points.pop()
                return "fold", replace(fold, crossing=fold.crossing or (k, k_new))
            if fold is None or _behind(fold, p[i], direction, fold_tol):
                # not located from the interpolated turn, or a fold behind the
                # last point (the branch reached p: another fold, where the
                # interpolated start led): the turn lies within the step from
                # the last point, approached along the branch
                log.debug("fold %s: the turn approached along the branch from %.8g",
                          "not located" if fold is None else f"located at {fold.value:.8g}, "
                          "behind the last point", p[i])
                fold = _turn_ahead(counter, i, u, p, t, 0.5 * chord, end_tol, check_inertia)
                if fold is not None and _behind(fold, p[i], direction, fold_tol):
                    fold = None
            log.debug("fold located with %d factorisations: %s",
                      counter.stats().factorizations - f0, None if fold is None else fold.value)
            if fold is not None and fold.crossing is None:
                fold = replace(fold, crossing=(k, k_new))
            return "fold", fold
        if turned:
            return (f"the parameter turned but the inertia went from {k} to {k_new} "
                    f"(not one eigenvalue crossing)"), None
        if k is not None and k_new is not None and k_new != k:
            without_turn.append((float(p[i]), float(res.p[i]), k, k_new))
            return f"the inertia changed from {k} to {k_new} without a turning point", None
        return "", (du / chord, dq / chord, chord, k_new)  # the secant

    def hidden_fold(res, data):
        """A fold that the ends of the steps do not show: where the rate
        ``|t_p|`` of the load along the branch has a minimum at the last
        point (it fell to it and rises to ``res``), the branch came nearest to
        turning there, and a sharp fold -- or a thin S-shaped fold pair,
        turning and turning back -- can lie within the step into it or the
        step out of it.  Each is searched on the branch from its start
        (:func:`~skfem_sheet.engine.fold.fold_on_branch` along the step's
        chord, given up where the fold is predicted beyond the chord: one
        section solve where there is none); a fold found is the branch's
        turning point if the load turns back there (solutions behind it),
        ahead of the step's start, and one eigenvalue crosses zero there.
        Returns ``(fold, in_the_step_into_the_minimum)`` or None (the branch
        only steepened)."""
        if len(points) < 2:
            return None
        rates = [abs(float(points[-2].tangent_p)), abs(float(points[-1].tangent_p)),
                 abs(float(data[1]))]
        if not (rates[1] < rates[0] and rates[1] < rates[2]):
            return None
        for into, (a, b_u) in ((True, (points[-2], points[-1].u)),
                               (False, (points[-1], res.u))):
            v = b_u - a.u
            n = float(np.sqrt(counter.inner(v, v)))
            if not n > 0:
                continue
            try:
                fold, _ = fold_on_branch(counter, a.u, a.p, i, v, tol=end_tol, ptol=fold_tol,
                                         check_inertia=True, reach=n)
            except EngineFailure:
                fold = None
            log.debug("rate minimum at %.6g, the step %s it: fold %s", points[-1].p[i],
                      "into" if into else "out of",
                      None if fold is None else (fold.value, fold.side, fold.crossing))
            if fold is None or fold.crossing is None or fold.side != -direction:
                continue
            if (fold.value - a.p[i]) * direction < 0:
                continue
            lo, hi = sorted(fold.crossing)
            if hi - lo != 1 or (k is not None and lo != k):
                continue
            return replace(fold, crossing=(lo, hi)), into
        return None

    def accept(res, data, distance):
        nonlocal t, k
        t_u, t_p, chord, k_new = data
        if end_tol is not tol and (stop - res.p[i]) * direction <= 1e-12 * max(1.0, abs(stop)):
            # the end point to the end tolerance, from the point landed there
            fin = correct(counter, res.u, res.p, plain_linearization(counter), end_tol,
                          converged=None)
            if not fin.converged:
                return f"the end point did not converge to the end tolerance: {fin.reason}"
            res = replace(fin, iterations=res.iterations + fin.iterations)
        t = (t_u, t_p)
        if k is None:
            k = k_new
        points.append(BranchPoint(res.p.copy(), res.u, k_new, res.iterations, t_p,
                                  points[-1].s + chord, distance))
        if on_step is not None:
            on_step(points[-1], res)
        if progress is not None:
            progress(float(res.p[i]))
        return ""

    h, retried, candidate, natural_ok = rule.initial, False, None, True
    without_turn = []  # (p, p of the step, k, k_new): inertia changes without a turn
    while True:
        if (stop - points[-1].p[i]) * direction <= 1e-12 * max(1.0, abs(stop)):
            return finish(completed=True)
        if len(points) >= max_points:
            return finish(reason="max_points")
        res, dist, natural = candidate if candidate is not None else attempt(h, natural_ok)
        candidate = None
        queue, why = [], ""
        dists = {}
        if dist is None:
            why = f"Newton: {res.reason}"
            natural_ok = natural_ok and not natural  # retried as pseudo-arclength
        elif rule.rejects(dist):
            why = f"corrector distance {dist / rule.delta:.3g} times the nominal one"
        elif dist > rule.delta:
            # the halving test, where the distance is above nominal: on the
            # branch the distance of the half step falls (fourfold, at least
            # twofold); after a jump it does not (docs/decisions.md, "The
            # halving test")
            half = attempt(0.5 * h, natural_ok)
            if half[1] is not None and half[1] <= 0.5 * dist:
                queue = [half[0], res]
                dists = {id(half[0]): half[1]}
            else:
                why = (f"the corrector distance {dist:.3g} did not fall when the step was "
                       f"halved (a jump onto another branch)")
                candidate = half if half[1] is not None else None
        else:
            queue = [res]
        for item in queue:
            what, data = examine(item)
            if what == "fold":
                if data is None:
                    return finish(reason=f"the parameter turns after {points[-1].p[i]:.6g}, "
                                  f"but the fold system did not converge")
                return finish(reason=f"fold at {data.value:.10g}", folds=(data,))
            if not what:
                hidden = hidden_fold(item, data)
                if hidden is not None:
                    fold, into = hidden
                    if into:  # the last point lies past the fold: not on this branch
                        points.pop()
                    return finish(reason=f"fold at {fold.value:.10g} (within a step, at the "
                                  f"minimum of the load's rate)", folds=(fold,))
            why = what or accept(item, data, dists.get(id(item), dist))
            if why:
                break
        if why:
            rejected += 1
            retried = True
            h *= 0.5
            if h < rule.minimum:
                fold, kept = _fold_where_stalled(counter, points, i, direction, tol, end_tol,
                                                 fold_tol, k, rule.minimum)
                if fold is not None:
                    del points[kept:]
                    return finish(reason=f"fold at {fold.value:.10g} (where the steps stalled)",
                                  folds=(fold,))
                last = float(points[-1].p[i])
                near = [x for x in without_turn if x[0] == last]
                if near:  # an eigenvalue crosses zero ahead, and the load does not turn
                    a, b, k0, k1 = near[-1]
                    return finish(reason=f"a branch point between p = {a:.6g} and {b:.6g}: "
                                  f"the inertia changes from {k0} to {k1} there without a turn "
                                  f"of the load (one eigenvalue crosses zero; the load path does "
                                  f"not switch branches there)")
                return finish(reason=f"step below {rule.minimum:g} at p = {last:.6g} ({why}); "
                              f"{kept}")
            continue
        # the next step does not grow after a rejection (this one was just
        # found too long), nor after a correction that used more than half of
        # Newton's budget (the step is at the edge of Newton's basin)
        h_next = rule.next_step(h, dist)
        if retried or queue[-1].iterations > tol.max_iterations // 2:
            h_next = min(h, h_next)
        bound = _turn_bound(points, lambda res=queue[-1]: _tangent_rate(counter, res, i))
        if bound is not None:
            h_next = max(min(h_next, bound), rule.minimum)
        h, retried, natural_ok = h_next, False, True
