"""Folds: the minimally augmented test function, fold location, fold points.

For a symmetric tangent ``K = dR/du`` and a bordering vector ``v0`` (an
approximate null vector, normalised), the bordered system (Govaerts,
*Numerical methods for bifurcations of dynamical equilibria*, SIAM 2000)::

    [[K, v0], [v0^T, 0]] [v; sigma] = [0; 1]

defines ``sigma(u, p)``, which vanishes exactly where ``K`` is singular, and
the (right = left) null vector ``v``.  The bordered matrix stays nonsingular
at a fold although ``K`` does not.  Its derivatives (``w = v`` because the
bordered matrix is symmetric)::

    d sigma / du = -v^T (dK/du) v = -D^2 R[v, v]  ~  -(R(u + e v) - 2 R(u) + R(u - e v)) / e^2
    d sigma / dp = -v^T (dK/dp) v,   v^T K v  ~  v . (R(u + e v) - R(u - e v)) / (2 e)

(the last differenced in ``p``: residuals only, no tangent assembled and no
further factorisation; :meth:`FoldSystem.sigma_derivatives`).  The quadratic fold
coefficient is ``a = v . D^2 R[v, v] = -(d sigma / du) . v``; near a fold in
``p_i`` the branch is ``p_i - p_i* ~ -a s^2 / (2 v . R_{p_i})``, so solutions
exist on the side ``-sign(a v . R_{p_i})`` of the fold (with the null vector
at the fold itself; :func:`fold_on_branch`, whose last section lies within
the load tolerance before the fold, reads the side off the branch's own
curvature in ``p_i`` instead).

A fold is located by Newton's method on ``R = 0, sigma = 0`` in ``(u, p_i)``:
each iteration costs one factorisation (the bordered solves are
back-substitutions with it).  Where that fails from an equilibrium, the fold
can be approached along the branch first (pseudo-arclength steps until the
tangent turns in ``p_i``, :func:`locate_fold` with ``approach``): the fold
system's basin is small where the fold is flat in the parameter and the
branch curves strongly in a stiff direction of the state.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, field

import numpy as np

from ..params import ParameterError, check_range
from .corrector import (
    DEFAULT_TOLERANCES,
    Bordered,
    ChordTest,
    NewtonResult,
    Tolerances,
    correct,
)
from .protocol import Counting, EngineFailure, Stats, parameter_index

log = logging.getLogger(__name__)

__all__ = ["FoldPoint", "equilibrium_on_section", "fold_on_branch", "fold_on_section", "fold_test",
           "locate_fold"]


@dataclass(frozen=True)
class FoldPoint:
    """A located fold.

    Attributes
    ----------
    u, p : ndarray
        State and parameters at the fold.
    v : ndarray
        Null vector of the tangent (``max |v| = 1``).
    sigma : float
        The test function there (``~ 0``).
    a : float
        Quadratic fold coefficient ``v . D^2 R[v, v]`` (0 at a cusp).
    side : int
        For the located parameter ``p_i``: solutions exist for ``p_i`` on this
        side of the fold (``-1`` below, ``+1`` above).
    parameter : int
        Index of the located parameter.
    negative_eigenvalues : int or None
        Negative eigenvalues of the tangent other than the critical one: the
        two branches meeting at the fold have ``k`` and ``k + 1``.
    crossing : tuple or None
        ``(n(u - e v), n(u + e v))``: negative eigenvalue counts of the tangent
        on both sides of the fold along ``v`` (if checked): they differ by one
        when exactly one eigenvalue crosses zero.
    iterations : int
    stats : ~skfem_sheet.engine.protocol.Stats
    """

    u: np.ndarray = field(repr=False)
    p: np.ndarray
    v: np.ndarray = field(repr=False)
    sigma: float
    a: float
    side: int
    parameter: int
    negative_eigenvalues: object = None
    crossing: object = None
    iterations: int = 0
    stats: Stats = field(default_factory=Stats)

    @property
    def value(self) -> float:
        """The located parameter's value at the fold."""
        return float(self.p[self.parameter])


def _unit(v):
    v = np.asarray(v, dtype=float)
    n = float(np.abs(v).max()) if v.size else 0.0
    if not n > 0 or not np.isfinite(n):
        raise EngineFailure("zero or non-finite bordering vector")
    return v / n


def fold_test(factorization, matvec, v0):
    """``(sigma, v)`` of the bordered system with ``K`` factorised.

    Parameters
    ----------
    factorization : object with ``solve``
    matvec : callable, ``x -> K x``
    v0 : ndarray
        Bordering vector (approximate null vector).

    Returns
    -------
    sigma : float
    v : ndarray
        With ``v0 . v = 1`` (``v0`` scaled to unit 2-norm).

    Examples
    --------
    >>> from skfem_sheet.engine.protocol import DenseFactorization
    >>> K = np.diag([2.0, 1e-3])
    >>> s, v = fold_test(DenseFactorization(K), lambda x: K @ x, np.array([0.1, 1.0]))
    >>> round(s, 6), np.round(v / v[1], 3).tolist()
    (-0.00101, [0.0, 1.0])
    """
    v0 = np.asarray(v0, dtype=float)
    v0 = v0 / np.linalg.norm(v0)
    M = Bordered(factorization, matvec, v0[:, None], v0[:, None], np.zeros((1, 1)))
    v, s = M.solve(np.zeros(len(v0)), np.ones(1))
    return float(s[0]), v


class _Bordered(Bordered):
    """:class:`~skfem_sheet.engine.corrector.Bordered` with ``K^-1 B`` given
    (solved beforehand together with other right-hand sides), and a
    first back-substitution ``z = K^-1 f`` that may be given too."""

    def __init__(self, factorization, matvec, B, C, D, X, refine: int = 1):
        self.fact, self.matvec, self.refine = factorization, matvec, int(refine)
        self.B = np.asarray(B, dtype=float).reshape(len(B), -1)
        self.C = np.asarray(C, dtype=float).reshape(len(C), -1)
        self.D = np.atleast_2d(np.asarray(D, dtype=float))
        self.X = np.asarray(X, dtype=float).reshape(len(B), -1)
        self.S = self.D - self.C.T @ self.X
        if not np.all(np.isfinite(self.S)) or np.linalg.cond(self.S) > self.MAX_COND:
            raise EngineFailure("singular bordered system")

    #: Largest condition number of the Schur complement accepted.  With ``K``
    #: singular to working precision (at a fold) the Schur complement of the
    #: fold system carries ``1 / lambda_min(K)`` in the direction of the null
    #: vector; near a cusp the fold row loses that term (``a -> 0``) and only
    #: the arclength row keeps it, so its condition number reaches
    #: ``1 / (lambda_min eps)`` although the bordered matrix is regular; the
    #: step of iterative refinement on the whole bordered system recovers
    #: the solution there.
    MAX_COND = 1e17

    def solve(self, f, g, z=None):
        if z is None:
            return super().solve(f, g)
        f = np.asarray(f, dtype=float)
        g = np.atleast_1d(np.asarray(g, dtype=float))
        y = np.linalg.solve(self.S, g - self.C.T @ z)
        return self.refined(f, g, z - self.X @ y, y)


class FoldSystem:
    """Linearisation of ``R = 0, sigma = 0`` (+ an arclength row) in the
    free parameters ``idx``; the bordering vector is updated to the last null
    vector at every iterate."""

    def __init__(self, counter, v0, idx, arclength=None):
        self.c, self.v0, self.idx = counter, _unit(v0), list(idx)
        self.arclength = arclength  # (t_u, t_p (all params), u_ref, p_ref, ds) or None
        self.last = None
        self.previous = None  # the previous iterate (for the Newton matrix)
        self.one_sided = bool(getattr(counter, "fd_one_sided", False))
        #: The first linearisation: ``{"residual", "du", "dp", "dudp"}`` (the
        #: residual norm and the Newton correction at the start, and the
        #: tangents ``du/dp_idx`` there, one column per free parameter).
        self.first = None

    def sigma_derivatives(self, u, p, v):
        """``d sigma/du = -D^2 R[v, v]`` and ``d sigma/dp_idx = -v . (dK/dp) v``
        by differences of residuals along ``v`` (no tangent assembled).

        ``D^2 R[v, v]`` is the central second difference of the residual at
        ``u +- e v`` (the vector ``(dK/du[v]) v``, which a difference of
        tangents along ``v`` gives too), and ``v . K v`` is the central first
        difference ``v . (R(u + e v) - R(u - e v)) / (2 e)``; its difference
        in each parameter gives ``v . (dK/dp) v``: central, or forward from
        ``p`` (one residual pair per parameter instead of two) if the problem
        sets ``fd_one_sided = True`` (e.g. where every new parameter value
        costs a mapped mesh; ``sigma`` itself is exact, so the converged point
        is not changed, only the rate of convergence).  ``e`` is the square
        root of ``fd_state_step`` (in the correction norm), as for the second
        difference of :func:`fold_on_branch`: its truncation error
        ``O(e^2)`` and round-off ``O(eps / e^2)`` balance there.  A residual
        costs a fraction of a tangent assembly."""
        c = self.c
        one_sided = bool(getattr(c, "fd_one_sided", False))
        e = (c.fd_state_step ** 0.5 * max(1.0, float(np.abs(u).max()) if u.size else 1.0)
             / max(float(np.abs(v).max()), 1e-300))
        r0 = c.residual(u, p)
        rp, rm = c.residual(u + e * v, p), c.residual(u - e * v, p)
        g_u = -(rp - 2.0 * r0 + rm) / e**2

        def vkv(pp, rpm=None):
            a, b = rpm if rpm is not None else (c.residual(u + e * v, pp),
                                                c.residual(u - e * v, pp))
            return float(v @ (a - b)) / (2.0 * e)

        g_p = []
        for i in self.idx:
            h = c.fd_parameter_step * max(1.0, abs(p[i]))
            pp, pm = p.copy(), p.copy()
            pp[i] += h
            pm[i] -= h
            if one_sided:
                g_p.append(-(vkv(pp) - vkv(p, (rp, rm))) / h)
            else:
                g_p.append(-(vkv(pp) - vkv(pm)) / (2 * h))
        return g_u, np.array(g_p)

    def __call__(self, u, p):
        c = self.c
        r = c.residual(u, p)
        if not np.all(np.isfinite(r)):
            raise EngineFailure("non-finite residual")
        # the Newton matrix (e.g. a MIP linearisation from the previous
        # iterate): at convergence it is the tangent, so sigma vanishes at the
        # fold itself; the derivatives of sigma use the tangent
        J = c.newton_jacobian(u, p, self.previous) if not self.one_sided else c.jacobian(u, p)
        self.previous = u
        fact = c.factorize(J)

        def matvec(x):
            return J @ x
        R_p = np.column_stack([c.dresidual(u, p, i) for i in self.idx])
        # every right-hand side known now in one solve with several columns
        # (K^-1 of the bordering vector, of dR/dp and of the residual):
        # the back-substitutions cost less together than one by one
        v0 = self.v0 / np.linalg.norm(self.v0)
        Y = fact.solve(np.column_stack([v0, R_p, -r]))
        Y = Y.reshape(len(r), -1)
        fold = _Bordered(fact, matvec, v0[:, None], v0[:, None], np.zeros((1, 1)), Y[:, :1])
        v, s_ = fold.solve(np.zeros(len(r)), np.ones(1), z=np.zeros(len(r)))
        sigma = float(s_[0])
        # the derivatives of sigma need the v of its own normalisation (v0 . v = 1)
        g_u, g_p = self.sigma_derivatives(u, p, v)
        scale = float(np.abs(v).max())
        a = -float(g_u @ v) / scale**3  # for the unit null vector below
        v = _unit(v)
        B, C = R_p, g_u[:, None]
        D = g_p[None, :]
        f, g = -r, [-sigma]
        if self.arclength is not None:
            t_u, t_p, u_ref, p_ref, ds = self.arclength
            N = c.inner(t_u, u - u_ref) + float(t_p @ (p - p_ref)) - ds
            C = np.column_stack([g_u, c.dual(t_u)])
            D = np.vstack([g_p, t_p[self.idx]])
            g = [-sigma, -N]
        M = _Bordered(fact, matvec, B, C, D, Y[:, 1:1 + len(self.idx)])
        du, dq = M.solve(f, np.array(g, dtype=float), z=Y[:, -1])
        dp = np.zeros_like(p)
        dp[self.idx] = dq
        self.last = {"v": v, "sigma": sigma, "a": a, "R_p": R_p, "g_u": g_u, "g_p": g_p,
                     "bordered": M, "inertia": fact.inertia()}
        self.v0 = v
        rn = c.residual_norm(r)
        if self.first is None:
            self.first = {"residual": rn, "du": du, "dp": dp,
                          "dudp": -Y[:, 1:1 + len(self.idx)]}
        return rn, du, dp, fact, self.last


def negative_besides_critical(inertia, sigma):
    """Negative eigenvalues other than the critical one (``sign(lambda) = -sign(sigma)``)."""
    if inertia is None:
        return None
    return int(inertia) - (1 if sigma > 0 else 0)


def inertia_crossing(counter, u, p, v, step):
    """Negative eigenvalue counts of the tangent at ``u -+ e v``."""
    e = step * max(1.0, float(np.abs(u).max()))
    out = []
    for s in (-1.0, 1.0):
        try:
            out.append(counter.factorize(counter.jacobian(u + s * e * v, p)).inertia())
        except EngineFailure:
            out.append(None)
    return None if None in out else tuple(int(x) for x in out)


def fold_point(counter, res: NewtonResult, i, check_inertia, inertia_step, stats):
    ex = res.extra
    v, sigma, a = ex["v"], ex["sigma"], ex["a"]
    if "side" in ex:
        side = int(ex["side"])
    else:
        vr = float(v @ ex["R_p"][:, 0])
        side = int(-np.sign(a * vr)) if a * vr != 0 else 0
    crossing = inertia_crossing(counter, res.u, res.p, v, inertia_step) if check_inertia else None
    return FoldPoint(res.u, res.p, v, sigma, a, side, i,
                     negative_besides_critical(ex["inertia"], sigma), crossing,
                     res.iterations, stats)


def unit_tangent(counter, t_u, t_p, prev=None):
    n = np.sqrt(counter.inner(t_u, t_u) + t_p**2)
    t_u, t_p = t_u / n, t_p / n
    if prev is not None and counter.inner(t_u, prev[0]) + t_p * prev[1] < 0:
        t_u, t_p = -t_u, -t_p
    return t_u, float(t_p)


def arclength_point(counter, i, t, u_ref, p_ref, h, tol):
    """The equilibrium at arclength ``h`` along the unit tangent ``t`` from
    ``(u_ref, p_ref)`` (``res.extra`` is its bordered matrix)."""
    t_u, t_p = t
    linearize = section_linearization(
        counter, i, t_u, t_p,
        lambda uu, pp: counter.inner(t_u, uu - u_ref) + t_p * (pp[i] - p_ref[i]) - h)
    p_pred = p_ref.copy()
    p_pred[i] += h * t_p
    return correct(counter, u_ref + h * t_u, p_pred, linearize, tol)


def section_linearization(counter, i, t_u, t_pi, distance, reference=None):
    """Newton's linearisation of an equilibrium with the parameter ``p[i]``
    free on a linear section ``distance(u, p) = 0`` whose gradient is
    ``(t_u, t_pi)``: the bordered system ``[[K, R_p], [t_u^T, t_pi]]``
    (one factorisation of ``K``, the Newton matrix of
    :meth:`~skfem_sheet.engine.protocol.Counting.newton_jacobian`; ``extra``
    is the :class:`Bordered` matrix).  The one such linearisation of the arclength step and of
    :func:`equilibrium_on_section`.  ``reference``: the state passed to the
    Newton matrix as the previous iterate of the first one (e.g. the
    equilibrium the start was predicted from)."""

    previous = [reference]

    def linearize(uu, pp):
        r = counter.residual(uu, pp)
        if not np.all(np.isfinite(r)):
            raise EngineFailure("non-finite residual")
        J = counter.newton_jacobian(uu, pp, previous[0])
        previous[0] = uu
        f = counter.factorize(J)
        N = distance(uu, pp)
        M = Bordered(f, lambda x: J @ x, counter.dresidual(uu, pp, i)[:, None],
                     counter.dual(t_u)[:, None], [[t_pi]])
        du, dq = M.solve(-r, [-N])
        dp = np.zeros_like(pp)
        dp[i] = dq[0]
        return counter.residual_norm(r), du, dp, f, M

    return linearize


def tangent_at(counter, res, prev):
    """Unit tangent at a corrected point from its bordered matrix:
    ``[[K, R_p], [t_prev^T]] t = [0; 1]``."""
    tu_new, tp_new = res.extra.solve(np.zeros(len(res.u)), [1.0])
    return unit_tangent(counter, tu_new, float(tp_new[0]), prev=prev)


def _turning_point(counter, i, t, u, p, h, t_end, tol, check_inertia, s_tol=1e-9,
                   max_iterations=40):
    """The fold between ``(u, p)`` and the point at arclength ``h``: regula
    falsi (Illinois) on the tangent's parameter component ``t_p(s)``, each
    evaluation an arclength correction; then the fold system from there."""
    s0, f0, s1, f1 = 0.0, t[1], h, t_end[1]
    best, side = None, 0
    for _ in range(max_iterations):
        s = s1 - f1 * (s1 - s0) / (f1 - f0)
        res = arclength_point(counter, i, t, u, p, s, tol)
        if not res.converged:
            return None
        try:
            ts = tangent_at(counter, res, t)
        except EngineFailure:
            return None
        best = (res, ts)
        if abs(s1 - s0) <= s_tol or ts[1] == 0:
            break
        if np.sign(ts[1]) == np.sign(f1):
            s1, f1 = s, ts[1]
            if side == 1:
                f0 *= 0.5
            side = 1
        else:
            s0, f0 = s, ts[1]
            if side == -1:
                f1 *= 0.5
            side = -1
        if abs(s1 - s0) <= s_tol:
            break
    if best is None:
        return None
    res, ts = best
    fold, _ = locate_fold(counter, res.u, res.p, i, v0=ts[0], tol=tol,
                          check_inertia=check_inertia, approach=0)
    if fold is not None:
        return fold
    # the fold system still does not converge: the point where t_p = 0 is the fold
    system = FoldSystem(counter, ts[0], [i])
    try:
        system(res.u, res.p)
    except EngineFailure:
        return None
    out = NewtonResult(res.u, res.p, True, 0, "", (), None, Stats(), system.last)
    return fold_point(counter, out, i, check_inertia, 1e-4, Stats())


def fold_between(counter, i, t, u, p, h, res, t_new, tol, check_inertia):
    """The fold between the equilibrium ``(u, p)`` (unit tangent ``t``) and
    the point ``res`` at arclength ``h`` along it (unit tangent ``t_new``),
    whose tangents' parameter components differ in sign: Newton on the fold
    system from the point nearer to it (the smaller ``|t_p|``), else
    :func:`_turning_point`.  None if neither converges."""
    near_u, near_p, near_t = ((u, p, t) if abs(t[1]) < abs(t_new[1])
                              else (res.u, res.p, t_new))
    fold, _ = locate_fold(counter, near_u, near_p, i, v0=near_t[0], tol=tol,
                          check_inertia=check_inertia, approach=0)
    if fold is None:  # outside Newton's basin for the fold system: t_p = 0 first
        fold = _turning_point(counter, i, t, u, p, h, t_new, tol, check_inertia)
    return fold


def _approach(counter, i, u, p, first, tol, check_inertia, max_points):
    """The fold near the equilibrium ``(u, p)`` where Newton on the fold
    system from there failed: pseudo-arclength steps along the branch
    towards the fold until the tangent's parameter component changes sign,
    then :func:`fold_between` the last two points.

    The steps are half as long as the first correction of the fold system
    (``first``, :attr:`FoldSystem.first`) and go its way: near a quadratic
    fold that correction is the straight line to the fold's state (with twice
    the parameter distance: it overshoots the fold in the parameter), so
    the sign change comes after about two steps.  Each step is an arclength
    correction, regular at the fold, from an equilibrium close to the last:
    it stays inside Newton's basin where the fold system's full step (onto
    the straight line, off the curved branch) does not.  A step that does
    not converge is halved (four times at most).  None after ``max_points``
    corrections without a sign change."""
    du, dq = first["du"], float(first["dp"][i])
    h = 0.5 * float(np.sqrt(counter.inner(du, du) + dq**2))
    if not (h > 0 and np.isfinite(h)):
        return None
    t = unit_tangent(counter, first["dudp"][:, 0], 1.0)
    if counter.inner(t[0], du) + t[1] * dq < 0:
        t = (-t[0], -t[1])
    h_min = h / 16
    for _ in range(max_points):
        res = arclength_point(counter, i, t, u, p, h, tol)
        if not res.converged:
            h *= 0.5
            if h < h_min * (1 - 1e-12):
                return None
            continue
        try:
            t_new = tangent_at(counter, res, t)
        except EngineFailure:
            return None
        if np.sign(t_new[1]) != np.sign(t[1]):
            return fold_between(counter, i, t, u, p, h, res, t_new, tol, check_inertia)
        u, p, t = res.u, res.p, t_new
    return None


def locate_fold(problem, u, p, param, *, v0=None, tol: Tolerances = DEFAULT_TOLERANCES,
                check_inertia: bool = False, inertia_step: float = 1e-4, approach: int = 0):
    """Locate a fold in parameter ``param`` near ``(u, p)``.

    Newton's method on ``R(u, p) = 0, sigma(u, p) = 0`` in ``(u, p_param)``,
    the other parameters fixed.  With ``approach``, if that fails from an
    equilibrium (residual at the start within ``tol.rtol``), the fold is
    approached along the branch first: pseudo-arclength steps from ``(u, p)`` the way of the
    fold system's first correction, half as long, until the tangent's
    parameter component changes sign, and Newton on the fold system from the
    nearer of those two points (else the point between them where it
    vanishes).  Newton's basin for the fold system can be much smaller than
    for the equilibrium: its first step goes straight to the fold's state,
    off a branch that curves strongly in the state where the fold is flat in
    the parameter (the second example).

    Parameters
    ----------
    problem : Problem
    u, p : ndarray
        Start (an equilibrium near the fold, or any guess).
    param : int or str
        The parameter in which the branch turns.
    v0 : ndarray, optional
        Bordering vector; default: ``du/dp`` at the start (near a fold it is
        dominated by the null vector).
    tol : Tolerances
    check_inertia : bool
        Also factorise the tangent at ``u -+ e v`` (two factorisations) and
        report the negative eigenvalue counts there (``FoldPoint.crossing``).
    inertia_step : float
        ``e`` relative to ``max(1, max |u|)``.
    approach : int
        Most arclength corrections of the approach along the branch (0, the
        default: Newton on the fold system only, for callers with a fallback
        of their own; :func:`natural` approaches at its last step, with 8).

    Returns
    -------
    (FoldPoint or None, NewtonResult)
        The result of Newton on the fold system; after an approach, one
        result for all the work (``iterations``: every linearisation,
        ``stats`` all of it).

    Examples
    --------
    >>> from skfem_sheet.engine import FunctionProblem
    >>> P = FunctionProblem(lambda u, p: u**3 - u + p[0],
    ...                     lambda u, p: np.diag(3 * u**2 - 1), ("lam",))
    >>> fold, _ = locate_fold(P, np.array([0.7]), np.array([0.38]), "lam")
    >>> bool(abs(fold.value - 2 / (3 * np.sqrt(3))) < 1e-12), fold.side
    (True, -1)

    A fold flat in the parameter on a branch curved in the state, ``y = 10
    x^2``, ``lam = x^2``, with the stiffness ``1e5`` along ``y`` (energy
    ``1e5 (y - 10 x^2)^2 / 2 + x^3 / 3 - lam x``): from the equilibrium at
    ``x = 0.01`` Newton on the fold system diverges; approached along the
    branch, the fold is located.

    >>> def R(u, p):
    ...     m = u[1] - 10 * u[0]**2
    ...     return np.array([-2e6 * u[0] * m + u[0]**2 - p[0], 1e5 * m])
    >>> def K(u, p):
    ...     m = u[1] - 10 * u[0]**2
    ...     return np.array([[-2e6 * m + 4e7 * u[0]**2 + 2 * u[0], -2e6 * u[0]],
    ...                      [-2e6 * u[0], 1e5]])
    >>> P = FunctionProblem(R, K, ("lam",))
    >>> u0, p0 = np.array([0.01, 10 * 0.01**2]), np.array([0.01**2])
    >>> locate_fold(P, u0, p0, "lam")[1].reason
    'diverging'
    >>> fold, res = locate_fold(P, u0, p0, "lam", approach=8)
    >>> bool(abs(fold.value) < 1e-12), fold.side, res.converged
    (True, 1, True)
    """
    approach = int(check_range("approach", approach, 0, 1000))
    counter = problem if isinstance(problem, Counting) else Counting(problem)
    start = counter.stats()
    u = np.array(u, dtype=float)
    p = np.array(p, dtype=float)
    i = parameter_index(counter, param, len(p))
    if v0 is None:
        try:
            fact = counter.factorize(counter.jacobian(u, p))
            v0 = fact.solve(-counter.dresidual(u, p, i))
        except EngineFailure:
            v0 = np.ones_like(u)
    system = FoldSystem(counter, v0, [i])
    res = correct(counter, u, p, system, tol)
    if res.converged:
        fold = fold_point(counter, res, i, check_inertia, inertia_step, None)
        return FoldPoint(**{**fold.__dict__, "stats": counter.stats() - start}), res
    first = system.first
    if not (approach and first is not None and first["residual"] <= tol.rtol):
        return None, res
    fold = _approach(counter, i, u, p, first, tol, check_inertia, approach)
    stats = counter.stats() - start
    if fold is None:
        return None, NewtonResult(res.u, res.p, False, stats.newton_iterations,
                                  f"{res.reason}; the approach along the branch failed too",
                                  res.history, res.factorization, stats, res.extra)
    out = NewtonResult(fold.u, fold.p, True, stats.newton_iterations, "", (), None, stats)
    return FoldPoint(**{**fold.__dict__, "stats": stats}), out


def fold_on_section(problem, u, p, params, section, *, v0, tol: Tolerances = DEFAULT_TOLERANCES):
    """The fold in two free parameters on a section of the fold curve.

    Newton's method on ``R(u, p) = 0, sigma(u, p) = 0, <t_u, u> + t_p . p = c``
    in ``(u, p_i, p_j)``: one point of the fold curve in ``(p_i, p_j)``,
    picked by the linear condition ``section = (t_u, t_p, c)`` (``t_p`` over
    all parameters; ``<., .>`` the problem's inner product), e.g. a fixed
    value of one displacement, which parametrises the curve through a cusp
    (where neither parameter does).  One factorisation per iteration.

    Parameters
    ----------
    problem : Problem
    u, p : ndarray
        Start (e.g. a fold of a coarser discretisation, carried over).
    params : (int or str, int or str)
        ``(p_i, p_j)``; the point reports its kind in ``p_i``.
    section : (ndarray, ndarray, float)
    v0 : ndarray
        Bordering vector (an approximate null vector).
    tol : Tolerances

    Returns
    -------
    (FoldPoint or None, NewtonResult)

    Examples
    --------
    The cusp normal form ``u^3 - mu u - lam = 0`` on the section ``u = 0.5``:
    the fold there is ``mu = 3 u^2, lam = -2 u^3``.

    >>> from skfem_sheet.engine import FunctionProblem
    >>> P = FunctionProblem(lambda u, p: u**3 - p[1] * u - p[0],
    ...                     lambda u, p: np.diag(3 * u**2 - p[1]), ("lam", "mu"))
    >>> f, _ = fold_on_section(P, np.array([0.4]), np.array([-0.2, 0.6]), ("lam", "mu"),
    ...                        (np.array([1.0]), np.zeros(2), 0.5), v0=np.ones(1))
    >>> np.round(f.p, 12).tolist()
    [-0.25, 0.75]
    """
    counter = problem if isinstance(problem, Counting) else Counting(problem)
    start = counter.stats()
    u = np.array(u, dtype=float)
    p = np.array(p, dtype=float)
    idx = [parameter_index(counter, q, len(p)) for q in params]
    t_u, t_p, c = section
    t_u = np.asarray(t_u, dtype=float)
    t_p = np.asarray(t_p, dtype=float)
    system = FoldSystem(counter, v0, idx,
                        arclength=(t_u, t_p, np.zeros_like(u), np.zeros_like(p), float(c)))
    res = correct(counter, u, p, system, tol)
    if not res.converged:
        return None, res
    fold = fold_point(counter, res, idx[0], False, 0.0, None)
    return FoldPoint(**{**fold.__dict__, "stats": counter.stats() - start}), res


def equilibrium_on_section(problem, u, p, param, section, *,
                           tol: Tolerances = DEFAULT_TOLERANCES, chord: bool = False):
    """An equilibrium on a hyperplane, one parameter free.

    Newton's method on ``R(u, p) = 0, <t_u, u> + t_p . p = c`` in
    ``(u, p_param)`` (the bordered matrix ``[[K, R_p], [t_u^T, t_p]]`` stays
    nonsingular at a fold in ``p_param`` if ``t_u`` is not orthogonal to
    the null vector): e.g. a state carried over from another discretisation
    near a fold, settled on the section ``<v0, u - u0> = 0`` of its
    approximate null vector ``v0`` before the fold is located from it.

    Parameters
    ----------
    problem : Problem
    u, p : ndarray
    param : int or str
    section : (ndarray, ndarray, float)
        ``(t_u, t_p, c)``, ``t_p`` over all parameters.
    tol : Tolerances
    chord : bool
        Confirm convergence by the simplified (chord) correction with the
        last factorisation (:class:`~skfem_sheet.engine.corrector.ChordTest`,
        from the second linearisation on) instead of a further factorisation.

    Returns
    -------
    NewtonResult

    Examples
    --------
    On ``u^2 + lam = 0`` (a fold at ``lam = 0``) the section ``u = 0.5``
    gives ``lam = -0.25``:

    >>> from skfem_sheet.engine import FunctionProblem
    >>> P = FunctionProblem(lambda u, p: u**2 + p[0], lambda u, p: np.diag(2 * u), ("lam",))
    >>> r = equilibrium_on_section(P, np.array([0.4]), np.array([0.0]), "lam",
    ...                            (np.ones(1), np.zeros(1), 0.5))
    >>> r.converged, round(float(r.p[0]), 12)
    (True, -0.25)
    """
    counter = problem if isinstance(problem, Counting) else Counting(problem)
    p = np.array(p, dtype=float)
    i = parameter_index(counter, param, len(p))
    t_u, t_p, c = section
    t_u = np.asarray(t_u, dtype=float)
    t_p = np.asarray(t_p, dtype=float)
    def distance(uu, pp):
        return counter.inner(t_u, uu) + float(t_p @ pp) - float(c)

    linearize = section_linearization(counter, i, t_u, t_p[i], distance)
    u = np.array(u, dtype=float)
    test = ChordTest(counter, tol, distance, start=u) if chord else None
    return correct(counter, u, p, linearize, tol, converged=test)


def fold_on_branch(problem, u, p, param, v, *, tol: Tolerances = DEFAULT_TOLERANCES,
                   ptol: float = 1e-9, max_iterations: int = 12, check_inertia: bool = False,
                   reach: float = np.inf):
    """The fold near the equilibrium ``(u, p)`` located on the branch itself.

    The branch near a fold is parametrised by the section coordinate
    ``c = <v, u>`` along the approximate null vector ``v`` (the equilibrium
    on each section ``<v, u> = c`` with ``p_param`` free is regular at the
    fold, :func:`equilibrium_on_section`).  The fold is where the branch
    turns in the parameter, ``g = dp/dc = 0``, i.e. where the test function
    ``sigma`` of the minimally augmented system vanishes on the branch.  At
    each section's equilibrium the bordered matrix ``M = [[K, R_p], [v^T,
    0]]`` of its last Newton step gives the branch's derivatives by
    back-substitutions, no further factorisation:

        M (u', g) = (0, 1),    M (u'', g') = (-D^2 R[t, t], 0),  t = (u', g),

    the second from differentiating ``R(u(c), p(c)) = 0`` twice, with
    ``D^2 R[t, t]`` a central second difference of three residuals.  Newton's
    method on ``g(c) = 0`` then steps ``dc = -g / g'`` to the next section
    (predicted along the branch to second order); it stops when the load
    would move by at most ``ptol`` (relative to ``max(1, |p|)``) on the way
    to the fold, ``|g^2 / (2 g')| <= ptol``, and the fold is the point that
    step predicts (``u + dc u' + dc^2 u''/2``, ``p + dc g + dc^2 g'/2``: its
    residual and the error of its load are of third order in ``dc``, its
    load within ``ptol`` of the last equilibrium's).  Every iterate is an
    equilibrium: unlike Newton on the whole fold system, the iteration never
    leaves a strongly curved branch.  It gives up where an iterate's ``g``
    keeps its sign without shrinking (a minimum of ``|g|``, not a zero).  The
    null vector, ``sigma`` and the fold coefficient ``a`` come from the last
    factorisation and the same residual differences.

    Parameters
    ----------
    problem : Problem
    u, p : ndarray
        An equilibrium (or a point close to the branch) near the fold.
    param : int or str
    v : ndarray
        Approximate null vector (e.g. the branch's direction there).
    tol : Tolerances
        Of the section solves.
    ptol : float
        The fold load's tolerance (relative to ``max(1, |p|)``).
    max_iterations : int
    check_inertia : bool
        As in :func:`locate_fold`.
    reach : float
        Give up as soon as the fold is predicted further than this from the
        first section (in the section coordinate ``c``, i.e. along the unit
        ``v``): to ask whether a fold lies within a given stretch of the
        branch, at the cost of one section solve where none does.

    Returns
    -------
    (FoldPoint or None, NewtonResult)

    Examples
    --------
    The softening spring ``u - u^3 / 3 = lam`` turns at ``lam = 2/3``:

    >>> from skfem_sheet.engine import FunctionProblem
    >>> P = FunctionProblem(lambda u, p: u - u**3 / 3 - p[0],
    ...                     lambda u, p: np.diag(1 - u**2), ("lam",))
    >>> f, _ = fold_on_branch(P, np.array([0.8]), np.array([0.63]), "lam", np.ones(1))
    >>> round(f.value, 12), round(float(f.u[0]), 6), f.side
    (0.666666666667, 1.0, -1)
    """
    counter = problem if isinstance(problem, Counting) else Counting(problem)
    start = counter.stats()
    p = np.array(p, dtype=float)
    i = parameter_index(counter, param, len(p))
    ptol = check_range("ptol", ptol, 0, None, lo_open=True)
    v = np.asarray(v, dtype=float)
    n = np.sqrt(counter.inner(v, v))
    if not (n > 0 and np.isfinite(n)):
        raise ParameterError("v must be a non-zero vector")
    v = v / n
    zero = np.zeros_like(p)
    e_p = np.zeros_like(p)
    e_p[i] = 1.0

    def on_section(uu, pp, c):
        """The equilibrium on the section ``<v, u> = c`` from ``(uu, pp)`` and
        the branch's derivatives there (``<v, u'> = 1``): ``(result, u', g,
        u'', g')`` or None."""
        res = equilibrium_on_section(counter, uu, pp, i, (v, zero, c), tol=tol, chord=True)
        if not res.converged:
            return None
        M = res.extra
        try:
            tu, tq = M.solve(np.zeros(len(res.u)), [1.0])
            g = float(tq[0])
            # D^2 R[t, t] along t = (u', g): central second difference
            e = counter.fd_state_step ** 0.5 * max(1.0, counter.correction_norm(res.u)) \
                / max(counter.correction_norm(tu), 1e-300)
            r0 = counter.residual(res.u, res.p)
            rp = counter.residual(res.u + e * tu, res.p + e * g * e_p)
            rm = counter.residual(res.u - e * tu, res.p - e * g * e_p)
            q = (rp - 2.0 * r0 + rm) / e**2
            if not np.all(np.isfinite(q)):
                return None
            uu2, gq = M.solve(-q, [0.0])
        except EngineFailure:
            return None
        return res, tu, g, uu2, float(gq[0]), q

    def failed(reason, last=None):
        stats = counter.stats() - start
        return None, NewtonResult(u if last is None else last.u, p if last is None else last.p,
                                  False, stats.newton_iterations, reason, (), None, stats)

    def along(pt, dc):
        """From the point ``pt`` to the section ``dc`` further, predicted
        along the branch to second order, halved (three times at most) where
        the section solve fails: the next point or None."""
        res, tu, g, uu2, g2 = pt[:5]
        c0 = counter.inner(v, res.u)
        for _ in range(4):
            pp = res.p.copy()
            pp[i] += dc * g + 0.5 * dc**2 * g2
            nxt = on_section(res.u + dc * tu + 0.5 * dc**2 * uu2, pp, c0 + dc)
            if nxt is not None:
                return nxt
            dc *= 0.5
        return None

    c_first = counter.inner(v, u)
    pt = on_section(np.array(u, dtype=float), p, c_first)
    if pt is None:
        return failed("the equilibrium on the first section did not converge")
    scale = max(1.0, abs(float(p[i])))
    g_last = c_last = pt_last = None
    bracket = None  # (c, g, point) of two sections with g of opposite signs: a fold between
    for _ in range(max_iterations):
        g, g2 = pt[2], pt[4]
        if not (g2 != 0 and np.isfinite(g2)):
            return failed("the branch has no curvature in the parameter here (g' = 0)", pt[0])
        c_here = counter.inner(v, pt[0].u)
        if g_last is not None and g * g_last < 0:
            bracket = ((c_last, g_last, pt_last), (c_here, g, pt))
        elif bracket is not None:
            (ca, ga, pa), (cb, gb, pb) = bracket
            bracket = (((c_here, g, pt), (cb, gb, pb)) if g * ga > 0
                       else ((ca, ga, pa), (c_here, g, pt)))
        dc = -g / g2
        start_pt = pt
        if bracket is not None:
            (ca, ga, pa), (cb, gb, pb) = bracket
            if not min(ca, cb) < c_here + dc < max(ca, cb):
                # Newton would leave the bracket (past an inflection of g,
                # towards another fold, e.g. onto a middle branch and its
                # other fold): the secant
                # through the bracket's ends instead, which stays inside it,
                # predicted from the nearer end
                c_new = (ca * gb - cb * ga) / (gb - ga)
                start_pt = pa if abs(c_new - ca) < abs(c_new - cb) else pb
                dc = c_new - counter.inner(v, start_pt[0].u)
        if abs(c_here + dc - c_first) > reach:
            return failed(f"the fold is predicted further than {reach:.3g} along v", pt[0])
        log.debug("fold_on_branch: p %.10g, dp/dc %.3g, d2p/dc2 %.3g: the fold %.3g further "
                  "in p (%d factorisations so far)", pt[0].p[i], g, g2, -0.5 * g * dc,
                  (counter.stats() - start).factorizations)
        if 0.5 * abs(g * dc) <= ptol * scale:
            break
        if (bracket is None and g_last is not None and g * g_last > 0
                and not abs(g) < abs(g_last)):
            # Newton's method contracts |g| on its way to a simple zero, or
            # overshoots it (g changes sign: a fold between the two
            # sections); an iterate where g keeps its sign and does not
            # shrink straddles a minimum of |dp/dc|, not a fold, about which
            # the sections would alternate
            return failed(f"Newton on dp/dc = 0 does not contract (dp/dc {g:.3g} after "
                          f"{g_last:.3g}, the same sign): no fold near", pt[0])
        g_last, c_last, pt_last = g, c_here, pt
        nxt = along(start_pt, dc)
        if nxt is None:
            return failed("a section solve on the way to the fold did not converge", pt[0])
        pt = nxt
    else:
        return failed(f"no convergence to the fold in {max_iterations} iterations", pt[0])
    res, tu, g, uu2, g2, q = pt
    # the fold itself, predicted from the last section's equilibrium along the
    # branch to second order (its residual is of third order in dc)
    u_fold = res.u + dc * tu + 0.5 * dc**2 * uu2
    p_fold = res.p.copy()
    p_fold[i] += dc * g + 0.5 * dc**2 * g2
    # the fold's null vector, sigma and coefficient a from the last
    # factorisation (back-substitutions) and the residual differences: at the
    # fold the branch's direction u' is the null vector and D^2 R[v, v] is q
    M = res.extra
    try:
        sigma, _ = fold_test(M.fact, M.matvec, tu)
    except EngineFailure as err:
        return failed(f"the fold test at the located point: {err}", res)
    scale_v = float(np.abs(tu).max())
    vn = tu / scale_v
    a = float(tu @ q) / scale_v**3
    r_p = counter.dresidual(res.u, res.p, i)
    stats = counter.stats() - start
    # the side of the fold from the branch's own curvature in the parameter,
    # p - p* = g' (c - c*)^2 / 2: the solutions lie where g' points.  (Not
    # from -sign(a v . R_p): that holds with the null vector at the fold
    # itself, but the last section lies up to the load tolerance before it,
    # where t = u' differs from the null vector by O(g) and v . R_p picks up
    # -g R_p K^-1 R_p off the null direction, which outweighs it where the
    # load barely moves the mode: docs/decisions.md, "The side of a fold".)
    out = NewtonResult(u_fold, p_fold, True, stats.newton_iterations, "", (), None, stats,
                       {"v": vn, "sigma": sigma, "a": a, "R_p": r_p[:, None],
                        "side": int(np.sign(g2)), "inertia": res.factorization.inertia()})
    fold = fold_point(counter, out, i, check_inertia, 1e-4, stats)
    return fold, out
