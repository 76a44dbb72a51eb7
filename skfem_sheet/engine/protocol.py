"""The problem protocol of the continuation engine, and counters.

A problem is anything with these methods (:class:`Problem` supplies defaults
for all but the first two)::

    residual(u, p)          -> ndarray (n,)      R(u, p); non-finite = inadmissible state
    jacobian(u, p)          -> matrix (n, n)     dR/du, anything with ``@`` (dense or sparse)
    newton_jacobian(u, p, previous) -> matrix    optional: the matrix of Newton corrections
                                                 (default: jacobian; ``previous`` the iterate
                                                 before ``u`` in the same correction)
    factorize(J)            -> Factorization     solve(b), inertia()
    dresidual(u, p, i)      -> ndarray (n,)      dR/dp_i (default: central difference)
    dual(a)                 -> ndarray (n,)      the vector c with c . b = <a, b>
    inner(a, b)             -> float             the state inner product (default: dual(a) . b)
    residual_norm(r)        -> float             for the stopping rule (default: 2-norm)
    correction_norm(du)     -> float             for the stopping rule (default: max-norm)

``u`` is the state (a 1D array), ``p`` the parameter vector (a 1D array);
``parameter_names`` (a tuple of str) lets drivers take a parameter by name.
A :class:`Factorization` has ``solve(b)`` (one back-substitution) and
``inertia()``: the number of negative eigenvalues of the factorised (symmetric)
matrix, or None if unknown.  The tangent is assumed symmetric by the fold
drivers (the left and right null vectors agree), as for an energy Hessian.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..params import ParameterError

__all__ = [
    "DenseFactorization",
    "EngineFailure",
    "FunctionProblem",
    "Problem",
    "SparseLUFactorization",
    "Stats",
    "parameter_index",
]


class EngineFailure(RuntimeError):
    """A step of a driver that cannot be carried out (singular factorisation,
    non-finite values); drivers turn it into a reported failure."""


@dataclass(frozen=True)
class Stats:
    """Work done by a driver (a snapshot; drivers count while they run).

    Attributes
    ----------
    factorizations : int
        Tangent factorisations (the expensive operation).
    solves : int
        Back-substitutions with a factorisation.
    jacobians : int
        Tangent assemblies (including those of finite differences).
    residuals : int
        Residual evaluations (including those of finite differences).
    newton_iterations : int
        Linearisations by the Newton corrector (one factorisation each).
    """

    factorizations: int = 0
    solves: int = 0
    jacobians: int = 0
    residuals: int = 0
    newton_iterations: int = 0

    def __add__(self, other: Stats) -> Stats:
        return Stats(*(getattr(self, f) + getattr(other, f) for f in self.__dataclass_fields__))

    def __sub__(self, other: Stats) -> Stats:
        return Stats(*(getattr(self, f) - getattr(other, f) for f in self.__dataclass_fields__))


class DenseFactorization:
    """LU of a small dense matrix; the inertia from its symmetric part.

    Pivots below ``1e-13 max(1, max|A|)`` are perturbed to that size (as PARDISO
    does), so that an exactly singular tangent (at a fold) still has a
    factorisation: the bordered solves built on it
    (:class:`~skfem_sheet.engine.corrector.Bordered`) remain accurate because
    they refine on the unperturbed matrix.  ``perturbed_pivots`` counts them.

    Examples
    --------
    >>> f = DenseFactorization(np.array([[2.0, 0.0], [0.0, -1.0]]))
    >>> f.solve(np.array([2.0, 1.0])), f.inertia()
    (array([ 1., -1.]), 1)
    """

    def __init__(self, A):
        A = np.atleast_2d(np.asarray(A, dtype=float))
        if not np.all(np.isfinite(A)):
            raise EngineFailure("non-finite entries in the matrix")
        self._A = A
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", sla.LinAlgWarning)
            lu, piv = sla.lu_factor(A, check_finite=False)
        tiny = 1e-13 * max(float(np.abs(A).max()), 1.0)
        d = np.diag(lu).copy()
        small = np.abs(d) < tiny
        self.perturbed_pivots = int(small.sum())
        if small.any():
            d[small] = np.where(d[small] < 0, -tiny, tiny)
            lu[np.diag_indices_from(lu)] = d
        self._lu = (lu, piv)

    def solve(self, b):
        return sla.lu_solve(self._lu, np.asarray(b, dtype=float), check_finite=False)

    def inertia(self):
        """Number of negative eigenvalues of ``(A + A^T) / 2``."""
        return int(np.sum(np.linalg.eigvalsh(0.5 * (self._A + self._A.T)) < 0))


class SparseLUFactorization:
    """SuperLU of a sparse matrix; the inertia is not known (None)."""

    def __init__(self, A):
        try:
            self._lu = spla.splu(sp.csc_matrix(A))
        except RuntimeError as err:
            raise EngineFailure(f"sparse LU failed: {err}") from None

    def solve(self, b):
        return self._lu.solve(np.asarray(b, dtype=float))

    def inertia(self):
        return None


class Problem:
    """Base class of engine problems: the defaults of the protocol.

    Subclasses define :meth:`residual` and :meth:`jacobian`, and may set
    ``parameter_names`` and override any default (an exact
    :meth:`dresidual`, a weighted :meth:`dual`, a sparse symmetric-indefinite
    :meth:`factorize` with a known inertia).

    Examples
    --------
    >>> class Bar(Problem):  # a spring softening under the load p[0]
    ...     parameter_names = ("load",)
    ...     def residual(self, u, p):
    ...         return np.sin(u) - p[0]
    ...     def jacobian(self, u, p):
    ...         return np.diag(np.cos(u))
    >>> from skfem_sheet.engine import locate_fold
    >>> fold, _ = locate_fold(Bar(), np.array([1.0]), np.array([0.8]), "load")
    >>> round(fold.value, 12), round(float(fold.u[0]), 8)
    (1.0, 1.57079633)
    """

    #: Names of the entries of the parameter vector (optional).
    parameter_names: tuple = ()
    #: Relative step of the default finite difference in a parameter.
    fd_parameter_step: float = 1e-6
    #: Step of finite differences in the state (in the correction norm).
    fd_state_step: float = 1e-6

    def residual(self, u, p):  # pragma: no cover - protocol
        raise NotImplementedError

    def jacobian(self, u, p):  # pragma: no cover - protocol
        raise NotImplementedError

    def factorize(self, J):
        """A :class:`DenseFactorization` or :class:`SparseLUFactorization`."""
        if sp.issparse(J):
            return SparseLUFactorization(J)
        return DenseFactorization(J)

    def dresidual(self, u, p, i):
        """``dR/dp_i`` by a central difference of residuals."""
        p = np.asarray(p, dtype=float)
        h = self.fd_parameter_step * max(1.0, abs(p[i]))
        pp, pm = p.copy(), p.copy()
        pp[i] += h
        pm[i] -= h
        return (self.residual(u, pp) - self.residual(u, pm)) / (2 * h)

    def dual(self, a):
        """The vector ``c`` with ``c . b = <a, b>`` (default: ``a``)."""
        return np.asarray(a, dtype=float)

    def inner(self, a, b) -> float:
        """The state inner product of the arclength (default: the dot product)."""
        return float(np.dot(self.dual(a), b))

    def residual_norm(self, r) -> float:
        return float(np.linalg.norm(r))

    def correction_norm(self, du) -> float:
        du = np.asarray(du, dtype=float)
        return float(np.abs(du).max()) if du.size else 0.0


class FunctionProblem(Problem):
    """A problem from plain functions (small problems, tests, examples).

    Parameters
    ----------
    residual : callable(u, p) -> array
    jacobian : callable(u, p) -> array or sparse matrix
    parameter_names : tuple of str
    dresidual : callable(u, p, i) -> array, optional
        Exact parameter derivative (default: central difference).

    Examples
    --------
    >>> P = FunctionProblem(lambda u, p: u**3 - u + p[0],
    ...                     lambda u, p: np.diag(3 * u**2 - 1), ("lam",))
    >>> P.residual(np.array([1.0]), np.array([0.5])), P.dresidual(np.array([1.0]), [0.5], 0)
    (array([0.5]), array([1.]))
    """

    def __init__(self, residual, jacobian, parameter_names=(), dresidual=None):
        self._residual, self._jacobian, self._dresidual = residual, jacobian, dresidual
        self.parameter_names = tuple(parameter_names)

    def residual(self, u, p):
        return np.atleast_1d(np.asarray(self._residual(np.asarray(u, float),
                                                       np.asarray(p, float)), dtype=float))

    def jacobian(self, u, p):
        J = self._jacobian(np.asarray(u, float), np.asarray(p, float))
        return J if sp.issparse(J) else np.atleast_2d(np.asarray(J, dtype=float))

    def dresidual(self, u, p, i):
        if self._dresidual is None:
            return super().dresidual(u, p, i)
        return np.atleast_1d(np.asarray(self._dresidual(np.asarray(u, float),
                                                        np.asarray(p, float), i), dtype=float))


def parameter_index(problem, param, n_params: int) -> int:
    """Index of ``param`` (an int or one of ``problem.parameter_names``)."""
    names = tuple(getattr(problem, "parameter_names", ()) or ())
    if isinstance(param, str):
        if param not in names:
            raise ParameterError(f"parameter must be one of {names}, got {param!r}")
        return names.index(param)
    if isinstance(param, (bool, np.bool_)) or not isinstance(param, (int, np.integer)) \
            or not 0 <= param < n_params:
        raise ParameterError(f"parameter must be an index in [0, {n_params - 1}] or a name "
                             f"in {names}, got {param!r}")
    return int(param)


class Counting:
    """The problem seen through counters: every driver calls it, not the problem."""

    def __init__(self, problem):
        self.problem = problem
        self.f = self.s = self.j = self.r = self.n = 0

    def stats(self) -> Stats:
        return Stats(self.f, self.s, self.j, self.r, self.n)

    def residual(self, u, p):
        self.r += 1
        return np.asarray(self.problem.residual(u, p), dtype=float)

    def jacobian(self, u, p):
        self.j += 1
        return self.problem.jacobian(u, p)

    def newton_jacobian(self, u, p, previous):
        """The matrix of a Newton correction at ``u`` (``previous``: the
        iterate before it in the same correction, None at the first): the
        problem's ``newton_jacobian`` if it has one (e.g. a linearisation
        that converges faster), else :meth:`jacobian`."""
        own = getattr(self.problem, "newton_jacobian", None)
        if own is None:
            return self.jacobian(u, p)
        self.j += 1
        return own(u, p, previous)

    def factorize(self, J):
        self.f += 1
        try:
            fact = self.problem.factorize(J)
        except EngineFailure:
            raise
        except Exception as err:  # noqa: BLE001 - a back-end's own error type (singular matrix)
            raise EngineFailure(f"factorisation failed: {err}") from None
        return _CountedFactorization(fact, self)

    def dresidual(self, u, p, i):
        own = getattr(type(self.problem), "dresidual", None)
        if own is not None and own is not Problem.dresidual:
            return np.asarray(self.problem.dresidual(u, p, i), dtype=float)
        return Problem.dresidual(self, u, p, i)  # through the counted residual

    def __getattr__(self, name):  # dual, inner, norms, names, fd steps
        try:
            return getattr(self.problem, name)
        except AttributeError:
            default = getattr(Problem, name)  # the protocol's default
            return default.__get__(self.problem) if callable(default) else default


class _CountedFactorization:
    def __init__(self, fact, counter):
        self.fact, self.counter = fact, counter

    def solve(self, b):
        self.counter.s += 1
        x = np.asarray(self.fact.solve(b), dtype=float)
        if not np.all(np.isfinite(x)):
            raise EngineFailure("non-finite solution of a linear system")
        return x

    def inertia(self):
        inertia = getattr(self.fact, "inertia", None)
        return None if inertia is None else inertia()
