"""Fold curves: two-parameter continuation of folds, and cusps on them.

The fold curve of ``R(u, p) = 0`` in the parameters ``(p_i, p_j)`` is the
solution set of the minimally augmented system (see :mod:`.fold`)::

    R(u, p) = 0,   sigma(u, p) = 0,   <t_u, u - u_k> + t_p . (p - p_k) = ds

in ``(u, p_i, p_j)``; the last row is the pseudo-arclength condition with the
unit tangent ``t`` at the previous point ``k``.  A Newton iteration costs one
factorisation of the tangent ``K``: the bordered solve for ``sigma`` and the
Newton system bordered by two rows and columns are back-substitutions with it
(:class:`~skfem_sheet.engine.corrector.Bordered`); the derivatives of
``sigma`` come from residuals (second differences along ``v`` in the state,
differences of ``v . K v`` in the parameters; see :mod:`.fold`).  The tangent of the
curve at a converged point is one more bordered solve with its last
factorisation.

A *cusp* is where the quadratic fold coefficient ``a = v . D^2 R[v, v]``
changes sign along the curve (there the two folds of an S-curve meet, and
the curve's projection on the parameter plane turns back: the tangent's
parameter components vanish, one changing sign).  It is located by
regula falsi (Illinois) in the arclength between the two points, each
evaluation a corrected fold point.

Each point also reports the kind of fold in ``p_i`` (the side on which
solutions exist) and ``k``, the negative eigenvalues besides the critical
one (``check_inertia``: confirmed on both sides along ``v``).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..params import ParameterError, check_range
from .corrector import DEFAULT_TOLERANCES, Tolerances, correct
from .fold import (
    FoldPoint,
    FoldSystem,
    inertia_crossing,
    locate_fold,
    negative_besides_critical,
)
from .protocol import Counting, EngineFailure, Stats, parameter_index

__all__ = ["Cusp", "FoldCurve", "FoldCurvePoint", "fold_curve"]


@dataclass(frozen=True)
class FoldCurvePoint:
    """One fold on a fold curve.

    Attributes
    ----------
    p : ndarray
        Parameters.
    u : ndarray or None
        State (None unless states are kept).
    a : float
        Quadratic fold coefficient.
    side : int
        Solutions exist on this side (-1, +1) of the fold in ``p_i``.
    negative_eigenvalues : int or None
        Besides the critical eigenvalue.
    crossing : tuple or None
        Negative eigenvalue counts on both sides along ``v`` (if checked).
    iterations : int
        Newton iterations (= factorisations) of the point.
    factorizations : int
        All factorisations spent on the point (failed attempts and inertia
        checks included).
    tangent_p : ndarray
        Parameter components ``(t_i, t_j)`` of the unit tangent.
    clipped : bool
        The last point, put on the boundary of the parameter range.
    """

    p: np.ndarray
    u: object = field(default=None, repr=False)
    a: float = 0.0
    side: int = 0
    negative_eigenvalues: object = None
    crossing: object = None
    iterations: int = 0
    factorizations: int = 0
    tangent_p: object = None
    clipped: bool = False


@dataclass(frozen=True)
class Cusp:
    """A located cusp.

    Attributes
    ----------
    p : ndarray
        Parameters.
    u : ndarray
        State.
    a : float
        The quadratic fold coefficient there (``~ 0``).
    iterations, factorizations : int
        Regula-falsi steps and their factorisations.
    tangent_reversal : tuple of bool
        For ``(p_i, p_j)``: whether that component of the curve's unit tangent
        changed sign between the two points around the cusp (the projection
        on the parameter plane turns back: at least one does).
    """

    p: np.ndarray
    u: object = field(default=None, repr=False)
    a: float = 0.0
    iterations: int = 0
    factorizations: int = 0
    tangent_reversal: tuple = ()


@dataclass(frozen=True)
class FoldCurve:
    """Result of :func:`fold_curve`.

    Attributes
    ----------
    points : tuple of FoldCurvePoint
    parameters : tuple of int
        ``(i, j)``: the fold parameter and the second parameter.
    cusps : tuple of Cusp
    completed : bool
        The curve left the parameter bounds (the last point is clipped onto them).
    reason : str
    stats : ~skfem_sheet.engine.protocol.Stats
    """

    points: tuple
    parameters: tuple
    cusps: tuple = ()
    completed: bool = False
    reason: str = ""
    stats: Stats = field(default_factory=Stats)

    @property
    def params(self):
        """Parameters of the points, shape (n_points, n_params)."""
        return np.array([pt.p for pt in self.points])

    @property
    def factorizations_per_point(self):
        """Factorisations of each point (the start and the clipped end included)."""
        return np.array([pt.factorizations for pt in self.points])


def _tangent(counter, M, n, prev_norm_row=None):
    t_u, t_q = M.solve(np.zeros(n), np.array([0.0, 1.0]))
    return t_u, t_q


def fold_curve(problem, start, params, bounds, *, ds: float = 0.05, ds_min: float = 1e-5,
               ds_max: float = 0.2, direction: int = 1, tol: Tolerances = DEFAULT_TOLERANCES,
               max_points: int = 500, cusp_tol: float = 1e-9, max_cusp_iterations: int = 40,
               check_inertia=False, inertia_step: float = 1e-4, keep_states: bool = False,
               easy_iterations: int = 3, target_correction=None, predictor: str = "tangent",
               on_point=None, progress=None) -> FoldCurve:
    """Continue a fold in two parameters, detecting and locating cusps.

    Parameters
    ----------
    problem : Problem
        With a symmetric tangent.
    start : FoldPoint
        A located fold in ``params[0]`` (:func:`~skfem_sheet.engine.fold.locate_fold`).
    params : (int or str, int or str)
        ``(p_i, p_j)``: the parameter the fold is in and the second parameter.
    bounds : ((lo_i, hi_i), (lo_j, hi_j))
        Stop when the curve leaves this box; the last point is then put on
        its boundary (a fold located at the bound of the parameter that left).
    ds, ds_min, ds_max : float
        Arclength steps (norm ``sqrt(<u, u> + p_i^2 + p_j^2)``).
    direction : {1, -1}
        Initial direction of ``p_j``.
    tol : Tolerances
    cusp_tol : float
        Arclength tolerance of the cusp location.
    max_cusp_iterations : int
        Most fold corrections of one cusp location; 0: cusps are not
        located (the sign change of the fold coefficient stays in the
        points' ``a``).
    check_inertia : bool or int
        Factorise on both sides of every fold (True) or of every n-th point (a
        check due at a cusp is made at the next regular point).
    keep_states : bool
        Keep the state of every point (cusps always keep theirs).
    easy_iterations : int
        The step grows (x 1.5) after a point corrected in at most this many
        iterations, is kept after one more, shrinks (x 0.7) after more.
    target_correction : float, optional
        Step control by the predictor's error instead: the next step is
        ``h (target / c)^(1/q)`` (within ``[h/2, 2 h]``), ``c`` the first
        Newton correction, ``q`` the predictor's order.
    predictor : {"tangent", "quadratic"}
        ``"quadratic"``: the tangent predictor plus the curvature term
        ``h^2 / 2 (t_k - t_{k-1}) / h_{k-1}`` (an error of order ``h^3``).
    on_point : callable(FoldCurvePoint, u, v), optional
        Called with every point of the curve, its state and its null vector
        (also when ``keep_states`` is False; e.g. to write a series).

    Returns
    -------
    FoldCurve

    Examples
    --------
    The cusp normal form ``u^3 - mu u - lam = 0``: folds on ``27 lam^2 = 4 mu^3``.

    >>> from skfem_sheet.engine import FunctionProblem
    >>> P = FunctionProblem(lambda u, p: u**3 - p[1] * u - p[0],
    ...                     lambda u, p: np.diag(3 * u**2 - p[1]), ("lam", "mu"))
    >>> f, _ = locate_fold(P, np.array([0.8]), np.array([-0.5, 1.0]), "lam")
    >>> c = fold_curve(P, f, ("lam", "mu"), ((-1, 1), (-0.5, 1.0)), ds=0.1, direction=-1)
    >>> c.completed, len(c.cusps), bool(np.abs(c.cusps[0].p).max() < 1e-6)
    (True, 1, True)
    """
    counter = problem if isinstance(problem, Counting) else Counting(problem)
    start_stats = counter.stats()
    if not isinstance(start, FoldPoint):
        raise ParameterError(f"start must be a FoldPoint (from locate_fold), got "
                             f"{type(start).__name__}")
    p = np.array(start.p, dtype=float)
    i, j = (parameter_index(counter, q, len(p)) for q in params)
    if i == j:
        raise ParameterError(f"params must be two different parameters, got {params!r}")
    (lo_i, hi_i), (lo_j, hi_j) = ((float(a), float(b)) for a, b in bounds)
    if not (lo_i < hi_i and lo_j < hi_j):
        raise ParameterError(f"bounds must be ((lo, hi), (lo, hi)) with lo < hi, got {bounds!r}")
    if direction not in (1, -1):
        raise ParameterError(f"direction must be 1 or -1, got {direction!r}")
    ds = check_range("ds", ds, 0, None, lo_open=True)
    ds_min = check_range("ds_min", ds_min, 0, ds, lo_open=True)
    ds_max = check_range("ds_max", ds_max, ds, None)
    if predictor not in ("tangent", "quadratic"):
        raise ParameterError(f"predictor must be 'tangent' or 'quadratic', got {predictor!r}")
    if target_correction is not None:
        target_correction = check_range("target_correction", target_correction, 0, None,
                                        lo_open=True)
    idx = [i, j]
    every = int(check_inertia) if not isinstance(check_inertia, bool) else (1 if check_inertia else 0)

    def inside(q):
        return lo_i <= q[i] <= hi_i and lo_j <= q[j] <= hi_j

    def finish(points, cusps, completed=False, reason=""):
        return FoldCurve(tuple(points), (i, j), tuple(cusps), completed, reason,
                         counter.stats() - start_stats)

    def unit(t_u, t_q, prev=None):
        n = np.sqrt(counter.inner(t_u, t_u) + float(t_q @ t_q))
        t_u, t_q = t_u / n, t_q / n
        if prev is not None and counter.inner(t_u, prev[0]) + float(t_q @ prev[1]) < 0:
            t_u, t_q = -t_u, -t_q
        return t_u, t_q

    def full(t_q):
        t_p = np.zeros_like(p)
        t_p[idx] = t_q
        return t_p

    check = {"due": False, "a_max": 0.0}

    def make_point(u, q, ex, its, fcount, t_q, clipped=False, n_point=0):
        vr = float(ex["v"] @ ex["R_p"][:, 0])
        side = int(-np.sign(ex["a"] * vr)) if ex["a"] * vr != 0 else 0
        crossing = None
        f0 = counter.f
        check["a_max"] = max(check["a_max"], abs(float(ex["a"])))
        check["due"] = check["due"] or bool(every and n_point % every == 0)
        # at (next to) a cusp the fold degenerates (a -> 0): no eigenvalue
        # crosses zero along v at first order there, so a check due at such
        # a point is made at the next regular one
        if check["due"] and abs(float(ex["a"])) >= 1e-2 * check["a_max"]:
            check["due"] = False
            crossing = inertia_crossing(counter, u, q, ex["v"], inertia_step)
        return FoldCurvePoint(q.copy(), u if keep_states else None, ex["a"], side,
                              negative_besides_critical(ex["inertia"], ex["sigma"]), crossing,
                              its, fcount + counter.f - f0, None if t_q is None else t_q.copy(),
                              clipped)

    # the first point: linearise at the start fold with the row t = e_j (t_j = 1)
    f0 = counter.f
    u = np.array(start.u, dtype=float)
    system = FoldSystem(counter, start.v, idx,
                         arclength=(np.zeros_like(u), full(np.array([0.0, 1.0])), u, p, 0.0))
    try:
        system(u, p)
        t = unit(*_tangent(counter, system.last["bordered"], len(u)))
    except EngineFailure as err:
        return finish([], [], reason=f"tangent at the start: {err}")
    if t[1][1] * direction < 0:
        t = (-t[0], -t[1])
    points = [make_point(u, p, system.last, start.iterations, counter.f - f0, t[1])]
    if on_point is not None:
        on_point(points[-1], u, system.last["v"])
    if progress is not None:
        progress(points[-1])
    cusps = []
    v = system.last["v"]
    a_prev = system.last["a"]
    h = ds
    order = 2
    curv = None  # (t_k - t_{k-1}) / h_{k-1}: the quadratic predictor's curvature
    spent = 0  # factorisations of failed attempts, charged to the next point
    while len(points) < max_points:
        f0 = counter.f
        # a step that would leave the box is cut to end a little beyond it
        # (the last point is then put on the bound from a short interval)
        for k, (lo, hi) in ((i, (lo_i, hi_i)), (j, (lo_j, hi_j))):
            tk = t[1][idx.index(k)]
            room = (hi - p[k]) if tk > 0 else (p[k] - lo)
            if tk != 0 and room > 0 and h * abs(tk) > room + 0.25 * ds_min:
                h = max(ds_min, min(h, 1.02 * room / abs(tk) + 0.25 * ds_min))
        bend = None if curv is None else (0.5 * h * h * curv[0], 0.5 * h * h * curv[1])
        res, ex = _corrected(counter, v, idx, t, u, p, h, tol, full, bend)
        if res is None or not res.converged:
            spent += counter.f - f0
            h *= 0.5
            if h < ds_min:
                return finish(points, cusps, reason="arclength step below ds_min at "
                              f"p = {p[idx].tolist()} ({getattr(res, 'reason', '')})")
            continue
        try:
            t_new = unit(*_tangent(counter, ex["bordered"], len(u)), prev=t)
        except EngineFailure as err:
            return finish(points, cusps, reason=f"tangent: {err}")
        if np.sign(ex["a"]) != np.sign(a_prev) and a_prev != 0 and max_cusp_iterations > 0:
            f_cusp = counter.f
            cusp = _locate_cusp(counter, v, idx, t, u, p, h, a_prev, ex["a"], tol, full,
                                cusp_tol, max_cusp_iterations)
            if cusp is not None:
                rev = tuple(bool(x) for x in np.sign(t[1]) != np.sign(t_new[1]))
                cusps.append(Cusp(**{**cusp.__dict__, "tangent_reversal": rev}))
            f0 += counter.f - f_cusp  # the cusp's factorisations are its own
        if not inside(res.p):
            clip = _clip(counter, u, p, res.u, res.p, ex["v"], i, j, (lo_i, hi_i), (lo_j, hi_j),
                         tol)
            if clip is not None:
                fold, r = clip
                ex_c = {"v": fold.v, "a": fold.a, "sigma": fold.sigma, "inertia": None,
                        "R_p": counter.dresidual(fold.u, fold.p, i)[:, None]}
                ex_c["inertia"] = r.factorization.inertia()
                points.append(make_point(fold.u, fold.p, ex_c, r.iterations,
                                         counter.f - f0 + spent, None, True, len(points)))
                if on_point is not None:
                    on_point(points[-1], fold.u, fold.v)
                if progress is not None:
                    progress(points[-1])
                return finish(points, cusps, completed=True)
            return finish(points, cusps, reason="the curve left the bounds and could not be "
                          "clipped onto them")
        points.append(make_point(res.u, res.p, ex, res.iterations, counter.f - f0 + spent,
                                 t_new[1], False, len(points)))
        spent = 0
        if on_point is not None:
            on_point(points[-1], res.u, ex["v"])
        if progress is not None:
            progress(points[-1])
        if predictor == "quadratic":
            curv = ((t_new[0] - t[0]) / h, (t_new[1] - t[1]) / h)
            order = 3
        u, p, t, v, a_prev = res.u, res.p, t_new, ex["v"], ex["a"]
        if target_correction is not None:
            first = res.history[0][1] if res.history else 0.0
            grow = 2.0 if not first > 0 else float(np.clip(
                (target_correction / first) ** (1.0 / order), 0.5, 2.0))
        else:  # aim at easy_iterations to easy_iterations + 1 iterations per point
            grow = (1.5 if res.iterations <= easy_iterations
                    else 1.0 if res.iterations == easy_iterations + 1 else 0.7)
        h = min(ds_max, max(ds_min, h * grow))
    return finish(points, cusps, reason="max_points")


def _corrected(counter, v, idx, t, u, p, s, tol, full, bend=None):
    """The fold point at arclength ``s`` along ``t`` from ``(u, p)``; the
    predictor is ``(u, p) + s t`` plus ``bend = (du, dq)`` if given."""
    t_u, t_q = t
    system = FoldSystem(counter, v, idx, arclength=(t_u, full(t_q), u, p, s))
    u_pred, q = u + s * t_u, p + s * full(t_q)
    if bend is not None:
        u_pred, q = u_pred + bend[0], q + full(bend[1])
    res = correct(counter, u_pred, q, system, tol)
    return res, (system.last if res.converged else None)


def _locate_cusp(counter, v, idx, t, u, p, h, a0, a1, tol, full, cusp_tol, max_iterations):
    """Regula falsi (Illinois) on ``a(s)`` over ``(0, h)``."""
    f0 = counter.f
    s0, s1 = 0.0, h
    best = None
    side = 0
    for it in range(1, max_iterations + 1):
        s = s1 - a1 * (s1 - s0) / (a1 - a0)
        res, ex = _corrected(counter, v, idx, t, u, p, s, tol, full)
        if ex is None:
            return None
        a = ex["a"]
        best = Cusp(res.p.copy(), res.u, a, it, counter.f - f0)
        if abs(s1 - s0) <= cusp_tol or a == 0:
            return best
        if np.sign(a) == np.sign(a1):
            s1, a1 = s, a
            if side == 1:
                a0 *= 0.5
            side = 1
        else:
            s0, a0 = s, a
            if side == -1:
                a1 *= 0.5
            side = -1
        if abs(s1 - s0) <= cusp_tol:
            return best
    return best


def _clip(counter, u0, p0, u1, p1, v, i, j, bi, bj, tol):
    """A fold on the boundary of the box, between the last two points."""
    # which bound was crossed, and the fraction of the step where
    for k, (lo, hi), other in ((j, bj, i), (i, bi, j)):
        for bound in (lo, hi):
            if (p0[k] - bound) * (p1[k] - bound) <= 0 and p1[k] != p0[k]:
                f = (bound - p0[k]) / (p1[k] - p0[k])
                u = u0 + f * (u1 - u0)
                q = p0 + f * (p1 - p0)
                q[k] = bound
                fold, res = locate_fold(counter, u, q, other, v0=v, tol=tol)
                if fold is not None:
                    return fold, res
    return None
