"""The one Newton corrector of the engine, and bordered solves.

Every driver (natural and pseudo-arclength continuation, fold location,
fold-curve continuation) corrects with :func:`correct`: it linearises the
(possibly extended) system at the iterate, which costs one factorisation of
the tangent, and takes the full Newton correction, halved only where the
trial state is inadmissible (non-finite residual).  Stopping rule: the
residual at the iterate is below ``rtol`` *and* the correction computed there
is below ``utol``; then the corrected point is returned.  A failure is
returned as a failure (``converged=False`` with a reason), never as a
converged point.

Bordered systems ``[[K, B], [C^T, D]]`` with a factorised ``K`` are solved by
block elimination with one step of iterative refinement on the whole bordered
system (:class:`Bordered`): all solves are back-substitutions with the one
factorisation of ``K``, and the refinement keeps them accurate where ``K`` is
nearly singular (at a fold), while the bordered matrix is not.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..params import ParameterError, check_range
from .protocol import Counting, EngineFailure, Stats

__all__ = ["Bordered", "ChordTest", "NewtonResult", "Tolerances", "correct", "newton",
           "plain_linearization"]


@dataclass(frozen=True)
class Tolerances:
    """Stopping rule and limits of the Newton corrector.

    Attributes
    ----------
    rtol : float
        Bound on ``problem.residual_norm`` of the residual at the iterate
        (``inf``: none, the correction alone decides).
    utol : float
        Bound on ``problem.correction_norm`` of the Newton correction (and on
        the parameter corrections) computed there.
    max_iterations : int
        Linearisations (factorisations) before giving up.
    max_halvings : int
        Halvings of a correction whose trial state is inadmissible.
    max_correction : float
        Give up if the first correction is larger than this (a guard against
        jumping to another branch); ``inf`` for no guard.
    divergence_floor : float or None
        From the third linearisation on, a correction larger than
        ``10 max(first, utol)`` (``None``) or ``max(10 first,
        divergence_floor)`` stops the iteration as "diverging" (a floor for
        corrections non-monotone for a few iterations).
    pair_contraction : bool
        From the third linearisation on, a correction larger than the one two
        linearisations before (and than ``utol``) stops the iteration as "not
        contracting": Deuflhard's monotonicity test (*Newton Methods for
        Nonlinear Problems*, Springer 2004, sec. 5.1) on pairs of
        corrections, for systems whose consecutive corrections alternate in
        size.  Off by default.
    error_estimate : bool
        Also stop on Newton's error estimate (Deuflhard, ch. 2): with the
        contraction ``theta = c_k / c_{k-1} <= 1/2`` of the last two
        corrections, the corrected iterate is within ``theta / (1 - theta)
        c_k`` of the solution; when that is at most ``utol`` it is returned,
        whatever the residual at the iterate.  Off by default.
    """

    rtol: float = 1e-10
    utol: float = 1e-10
    max_iterations: int = 12
    max_halvings: int = 6
    max_correction: float = np.inf
    divergence_floor: float | None = None
    pair_contraction: bool = False
    error_estimate: bool = False

    def __post_init__(self):
        if self.rtol != np.inf:  # inf: no bound on the residual, the correction decides
            check_range("rtol", self.rtol, 0, None, lo_open=True)
        check_range("utol", self.utol, 0, None, lo_open=True)
        check_range("max_iterations", self.max_iterations, 1, 1000)
        check_range("max_halvings", self.max_halvings, 0, 60)
        if not isinstance(self.error_estimate, (bool, np.bool_)):
            raise ParameterError(f"error_estimate must be True or False, got "
                                 f"{self.error_estimate!r}")
        if not self.max_correction > 0:  # inf allowed (no guard)
            raise ParameterError(f"max_correction must be in (0, inf], got {self.max_correction!r}")
        if self.divergence_floor is not None:
            check_range("divergence_floor", self.divergence_floor, 0, None)


#: The default stopping rule of the drivers.
DEFAULT_TOLERANCES = Tolerances()


@dataclass(frozen=True)
class NewtonResult:
    """Outcome of :func:`newton` (and of every corrector run).

    Attributes
    ----------
    u : ndarray
        The corrected state if converged, else the last iterate.
    p : ndarray
        The parameters (corrected too in extended systems).
    converged : bool
    iterations : int
        Linearisations, i.e. factorisations.
    reason : str
        Why not converged ("" if converged).
    history : tuple
        ``(residual norm, correction norm)`` at each iterate.
    factorization : object
        The factorised tangent at the last iterate (within ``utol`` of ``u``).
    stats : ~skfem_sheet.engine.protocol.Stats
    """

    u: np.ndarray
    p: np.ndarray
    converged: bool
    iterations: int
    reason: str = ""
    history: tuple = ()
    factorization: object = field(default=None, repr=False, compare=False)
    stats: Stats = field(default_factory=Stats)
    extra: object = field(default=None, repr=False, compare=False)


class Bordered:
    """Solves of ``[[K, B], [C^T, D]] [x; y] = [f; g]`` with ``K`` factorised.

    ``B`` and ``C`` are (n, k), ``D`` (k, k); ``matvec(x) = K @ x``.  Block
    elimination (``k`` back-substitutions once, two per solve) with one step of
    iterative refinement on the bordered residual.

    Examples
    --------
    >>> from skfem_sheet.engine.protocol import DenseFactorization
    >>> K = np.diag([1.0, 1e-14])  # nearly singular; the bordered matrix is not
    >>> v = np.array([[0.0], [1.0]])
    >>> M = Bordered(DenseFactorization(K), lambda x: K @ x, v, v, np.zeros((1, 1)))
    >>> x, y = M.solve(np.zeros(2), np.ones(1))
    >>> np.round(x, 12).tolist(), float(np.round(y[0], 12))
    ([0.0, 1.0], -0.0)
    """

    def __init__(self, factorization, matvec, B, C, D, refine: int = 1):
        self.fact, self.matvec, self.refine = factorization, matvec, int(refine)
        self.B = np.asarray(B, dtype=float).reshape(len(B), -1)
        self.C = np.asarray(C, dtype=float).reshape(len(C), -1)
        self.D = np.atleast_2d(np.asarray(D, dtype=float))
        self.X = np.column_stack([factorization.solve(b) for b in self.B.T])
        self.S = self.D - self.C.T @ self.X
        if not np.all(np.isfinite(self.S)) or np.linalg.cond(self.S) > 1e14:
            raise EngineFailure("singular bordered system")

    def _eliminate(self, f, g):
        z = self.fact.solve(f)
        y = np.linalg.solve(self.S, g - self.C.T @ z)
        return z - self.X @ y, y

    def solve(self, f, g):
        f = np.asarray(f, dtype=float)
        g = np.atleast_1d(np.asarray(g, dtype=float))
        return self.refined(f, g, *self._eliminate(f, g))

    def refined(self, f, g, x, y):
        """``(x, y)`` after ``refine`` steps of iterative refinement on the
        bordered residual of ``[f; g]``."""
        for _ in range(self.refine):
            rf = f - self.matvec(x) - self.B @ y
            rg = g - self.C.T @ x - self.D @ y
            dx, dy = self._eliminate(rf, rg)
            x, y = x + dx, y + dy
        return x, y


def correct(counter: Counting, u, p, linearize, tol: Tolerances, admissible=None, *,
            converged=None):
    """Newton's method on a (possibly extended) system: the one loop.

    Every Newton iteration of the package runs here: the drivers of the
    engine, and the callers' Newton solves built on it.

    Parameters
    ----------
    counter : the counted problem
    u, p : ndarray
        Initial state and parameters.
    linearize : callable(u, p) -> (residual_norm, du, dp, factorization, extra)
        Linearise at ``(u, p)`` (one factorisation) and return the full
        Newton correction (``dp`` of the shape of ``p``, zero for fixed
        parameters); may raise :class:`EngineFailure`.
    tol : Tolerances
    admissible : callable(u, p) -> bool, optional
        Whether a trial point may be used (default: finite residual).
    converged : callable(u, p, factorization, extra) -> bool, optional
        A stopping test at the new iterate with the previous factorisation at
        hand (e.g. :class:`ChordTest`); it replaces the default test.

    Returns
    -------
    NewtonResult
    """
    start = counter.stats()
    u = np.array(u, dtype=float)
    p = np.array(p, dtype=float)
    history = []
    fact = extra = None
    if admissible is None:
        def admissible(uu, pp):
            return bool(np.all(np.isfinite(counter.residual(uu, pp))))

    def result(ok, reason, it):
        return NewtonResult(u, p, ok, it, reason, tuple(history), fact,
                            counter.stats() - start, extra)

    first = None
    for it in range(1, tol.max_iterations + 1):
        try:
            rn, du, dp, fact, extra = linearize(u, p)
        except EngineFailure as err:
            return result(False, str(err), it)
        counter.n += 1
        dn = max(counter.correction_norm(du), float(np.abs(dp).max()) if np.size(dp) else 0.0)
        history.append((float(rn), float(dn)))
        if not (np.isfinite(rn) and np.isfinite(dn)):
            return result(False, "non-finite residual or correction", it)
        if converged is None and rn <= tol.rtol and dn <= tol.utol:
            u, p = u + du, p + dp
            return result(True, "", it)
        if converged is None and tol.error_estimate and it >= 2 and history[-2][1] > 0:
            theta = dn / history[-2][1]  # the contraction of the last two corrections
            if theta <= 0.5 and theta / (1.0 - theta) * dn <= tol.utol:
                u, p = u + du, p + dp
                return result(True, "", it)
        if first is None:
            first = dn
            if dn > tol.max_correction:
                return result(False, f"first correction too large ({dn:.3g} > "
                              f"{tol.max_correction:.3g})", it)
        elif it >= 3 and dn > (10.0 * max(first, tol.utol) if tol.divergence_floor is None
                               else max(10.0 * first, tol.divergence_floor)):
            return result(False, "diverging", it)
        if (tol.pair_contraction and it >= 3
                and dn > max(history[-3][1], tol.utol)):
            return result(False, "not contracting (a correction larger than the one two "
                          "linearisations before)", it)
        alpha = 1.0
        for _ in range(tol.max_halvings + 1):
            ut, pt = u + alpha * du, p + alpha * dp
            if admissible(ut, pt):
                break
            alpha *= 0.5
        else:
            return result(False, "inadmissible trial states (halved "
                          f"{tol.max_halvings} times)", it)
        u, p = ut, pt
        if converged is not None and converged(u, p, fact, extra):
            return result(True, "", it)
    return result(False, "max iterations", tol.max_iterations)


def newton(problem, u0, p, *, tol: Tolerances = DEFAULT_TOLERANCES) -> NewtonResult:
    """Solve ``R(u, p) = 0`` for ``u`` at fixed parameters ``p``.

    Parameters
    ----------
    problem : Problem (see :mod:`skfem_sheet.engine.protocol`)
    u0 : ndarray
        Initial guess.
    p : array_like
        Parameters.
    tol : Tolerances

    Returns
    -------
    NewtonResult
        Converged only if the residual and the correction met the stopping rule.

    Examples
    --------
    >>> from skfem_sheet.engine import FunctionProblem
    >>> P = FunctionProblem(lambda u, p: u**2 - p[0], lambda u, p: np.diag(2 * u))
    >>> r = newton(P, np.array([1.0]), [2.0])
    >>> r.converged, round(float(r.u[0]), 12), r.stats.factorizations == r.iterations
    (True, 1.414213562373, True)
    >>> newton(P, np.array([1.0]), [-1.0], tol=Tolerances(max_iterations=5)).converged
    False
    """
    counter = problem if isinstance(problem, Counting) else Counting(problem)
    return correct(counter, u0, np.asarray(p, dtype=float), plain_linearization(counter),
                   tol)


def plain_linearization(counter, reference=None):
    """Newton's linearisation at fixed parameters: one factorisation of the
    Newton matrix (:meth:`Counting.newton_jacobian`, the previous iterate of
    this correction passed on; at the first iterate ``reference``, e.g. the
    equilibrium it was predicted from, or None); ``extra`` is that matrix."""
    previous = [reference]

    def linearize(u, p):
        r = counter.residual(u, p)
        if not np.all(np.isfinite(r)):
            raise EngineFailure("non-finite residual")
        J = counter.newton_jacobian(u, p, previous[0])
        previous[0] = u
        fact = counter.factorize(J)
        du = fact.solve(-r)
        return counter.residual_norm(r), du, np.zeros_like(p), fact, J
    return linearize


class ChordTest:
    """A stopping test for :func:`correct` (its ``converged``) that spends no
    factorisation only to confirm convergence.

    At the new iterate: the residual within ``tol.rtol`` and the
    simplified-Newton correction there -- one back-substitution with the
    factorisation of the previous iterate (``fact.solve``), or with the
    bordered matrix (``extra.solve``) where ``distance(u, p)`` gives the
    extra rows' residual -- within ``tol.utol``.  The iterate is returned as
    it is (the small correction is not applied).  The parameter part of the
    correction counts divided by ``parameter_scale``: on a branch of slope
    ``t_p`` (the unit tangent's parameter component) a state error ``e``
    along it is a parameter error ``e t_p``, so ``parameter_scale = |t_p|``
    asks of the parameter the accuracy asked of the state.  ``norms`` keeps
    the simplified corrections computed.

    The simplified correction estimates the error only if the factorised
    matrix is close to the one at the iterate, so with ``start`` (the
    prediction) the test waits for the second linearisation
    (``docs/decisions.md``, "The chord test waits for a second
    linearisation").

    Examples
    --------
    >>> from skfem_sheet.engine import FunctionProblem
    >>> from skfem_sheet.engine.protocol import Counting
    >>> P = Counting(FunctionProblem(lambda u, p: u**2 - p[0], lambda u, p: np.diag(2 * u)))
    >>> tol = Tolerances(rtol=1e-8, utol=1e-8)
    >>> test = ChordTest(P, tol)
    >>> r = correct(P, np.array([1.0]), np.array([2.0]), plain_linearization(P), tol,
    ...             converged=test)
    >>> r.converged, round(float(r.u[0]), 8), r.iterations, P.f
    (True, 1.41421356, 4, 4)
    """

    def __init__(self, counter, tol: Tolerances, distance=None, parameter_scale: float = 1.0,
                 start=None):
        self.counter, self.tol, self.distance = counter, tol, distance
        self.scale = float(parameter_scale)
        self.start = None if start is None else np.array(start, dtype=float)
        self.calls = 0
        self.norms = []

    def __call__(self, u, p, fact, extra):
        c = self.counter
        self.calls += 1
        if self.start is not None and self.calls == 1:
            return False  # the matrix at the prediction: wait for the next one
        r = c.residual(u, p)
        if not np.all(np.isfinite(r)):
            return False
        rn = c.residual_norm(r)
        try:
            if self.distance is None:
                du, dq = fact.solve(-r), np.zeros(0)
            else:
                du, dq = extra.solve(-r, [-self.distance(u, p)])
        except EngineFailure:
            return False
        dq = float(np.abs(dq).max()) / self.scale if np.size(dq) else 0.0
        dn = max(c.correction_norm(du), dq)
        self.norms.append(dn)
        return rn <= self.tol.rtol and dn <= self.tol.utol
