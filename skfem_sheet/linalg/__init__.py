"""Sparse linear-solver back-ends for the symmetric-indefinite Newton systems.

All back-ends share one small interface::

    solver = make_linear_solver("auto")
    if solver.needs_layout:  # pyamg: the saddle-point structure of K
        solver.attach(layout)  # a SaddlePointLayout (SheetProblem.saddle_point_layout())
    solver.factorize(K, state=w)  # K: CSR, same sparsity pattern at every call;
                                  # w (optional): the state K was formed at
    x = solver.solve(b)      # b: (n,) or (n, k)
    solver.inertia()         # (n_positive, n_negative, n_zero) of K, or None
    solver.counts            # SolverCounts: factorizations, back_substitutions, ...

The Taylor-Hood tangent ``[[A, B^T], [B, 0]]`` is symmetric indefinite with a
zero pressure block.  Back-ends:

``"pardiso"``
    Intel MKL PARDISO through pypardiso's low-level handle, symmetric
    indefinite (matrix type -2, Bunch-Kaufman pivoting with weighted matching
    and scaling), the symbolic analysis reused while the pattern stays; the
    inertia is reported unknown where pivots were perturbed; reproducible by
    default (:class:`PardisoSolver`).  Needs the ``fast`` extra.
``"superlu"``
    scipy's SuperLU with a symmetric minimum-degree ordering on ``A + A^T``
    (no pressure row eliminated before all its neighbours), diagonal
    pivoting, symmetric mode (scipy's default does not finish on these
    matrices).
``"pyamg"``
    FGMRES with a block-triangular preconditioner on a smoothed-aggregation
    hierarchy of the displacement block (:class:`PyAMGSolver`): no
    factorisation, for meshes too big to factor; needs
    :meth:`PyAMGSolver.attach` and, on a deformed sheet, the state; no inertia.
``"auto"``
    pardiso when importable, else superlu.
"""
from __future__ import annotations

from ..discretisation import SaddlePointLayout
from .amg import PyAMGSolver, near_null_space
from .base import SOLVERS, LinearSolverError, SolverCounts
from .factory import available_solvers, make_linear_solver
from .pardiso import PardisoSolver
from .superlu import SuperLUSolver

__all__ = ["make_linear_solver", "available_solvers", "SOLVERS", "LinearSolverError",
           "PardisoSolver", "SuperLUSolver", "PyAMGSolver", "SaddlePointLayout",
           "SolverCounts", "near_null_space"]
