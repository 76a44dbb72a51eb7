"""What every linear-solver back-end shares: the names :data:`SOLVERS`, the
error :class:`LinearSolverError`, the work counts :class:`SolverCounts` and the
timing of factorisations and back-substitutions (:class:`Timed`).
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

SOLVERS = ("auto", "pardiso", "superlu", "pyamg")


class LinearSolverError(RuntimeError):
    """The factorisation failed (singular or numerically unusable matrix), or
    an iterative solve did not reach its tolerance."""


@dataclass(frozen=True)
class SolverCounts:
    """How much work a linear-solver back-end has done (see ``solver.counts``).

    Attributes
    ----------
    factorizations : int
        Numerical factorisations (pyamg: preconditioner set-ups).
    back_substitutions : int
        Right-hand sides solved: a ``solve`` with ``b`` of shape ``(n, k)``
        counts ``k`` (pyamg: Krylov solves).
    solves : int
        Calls of ``solve``.
    perturbed_factorizations : int
        Factorisations in which PARDISO perturbed at least one pivot (their
        inertia is unknown); 0 for the other back-ends.

    Examples
    --------
    >>> SolverCounts(3, 4, 4, 0).as_dict()["back_substitutions"]
    4
    """

    factorizations: int = 0
    back_substitutions: int = 0
    solves: int = 0
    perturbed_factorizations: int = 0

    def as_dict(self) -> dict:
        """The counts as a plain dict (for JSON records)."""
        return asdict(self)


class Timed:
    name = "?"
    #: Whether :meth:`attach` needs a :class:`SaddlePointLayout` before ``factorize``.
    needs_layout = False

    def __init__(self):
        self.factor_time = 0.0
        self.solve_time = 0.0
        self.n_factorizations = 0
        self.n_solves = 0
        self.n_back_substitutions = 0
        self.n_perturbed_factorizations = 0

    @property
    def counts(self) -> SolverCounts:
        """Factorisations, back-substitutions, solves and factorisations with
        perturbed pivots so far (a :class:`SolverCounts`)."""
        return SolverCounts(self.n_factorizations, self.n_back_substitutions,
                            self.n_solves, self.n_perturbed_factorizations)

    def _count_solve(self, b):
        self.n_solves += 1
        self.n_back_substitutions += 1 if np.ndim(b) == 1 else int(np.shape(b)[1])

    def attach(self, layout):
        """Saddle-point structure hook (unused by the direct solvers)."""

    def inertia(self):
        """``(n_positive, n_negative, n_zero)`` of the last factorised matrix,
        or None if this back-end cannot tell."""
        return None
