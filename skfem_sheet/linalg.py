"""Sparse linear-solver back-ends for the symmetric-indefinite Newton systems.

All back-ends share one small interface::

    solver = make_linear_solver("auto")
    solver.factorize(K)      # K: CSR, same sparsity pattern at every call
    x = solver.solve(b)      # b: (n,) or (n, k)

The Taylor-Hood tangent ``[[A, B^T], [B, 0]]`` is symmetric indefinite with a
zero pressure block.  Back-ends:

``"pardiso"``
    Intel MKL PARDISO through pypardiso's low-level handle, in symmetric
    indefinite mode (matrix type -2, upper triangle, Bunch-Kaufman pivoting with
    weighted matching and scaling).  The symbolic analysis (METIS ordering) is
    done once and reused while the sparsity pattern stays the same.  Needs the
    optional ``fast`` extra (``pip install .[fast]``).
``"superlu"``
    scipy's SuperLU configured for this structure: minimum-degree ordering on
    ``A + A^T``, diagonal pivoting preference, symmetric mode.  scipy's default
    (COLAMD, partial pivoting) does not finish on these matrices.
``"auto"``
    pardiso when importable, else superlu.
"""
from __future__ import annotations

import time

import numpy as np

from .params import ParameterError
import scipy.sparse as sp

__all__ = ["make_linear_solver", "available_solvers", "SOLVERS", "LinearSolverError"]

SOLVERS = ("auto", "pardiso", "superlu")


class LinearSolverError(RuntimeError):
    """The factorisation failed (singular or numerically unusable matrix)."""


def _have_pardiso() -> bool:
    try:
        import pypardiso  # noqa: F401
    except (ImportError, OSError):
        return False
    return True


def available_solvers():
    """Names of the back-ends usable on this machine (besides ``"auto"``)."""
    return [s for s in ("pardiso", "superlu") if s != "pardiso" or _have_pardiso()]


def make_linear_solver(name: str = "auto"):
    """Create a linear-solver back-end by name (see module docstring)."""
    if name not in SOLVERS:
        raise ParameterError(f"solver must be one of {', '.join(SOLVERS)}, got {name!r}")
    if name == "auto":
        name = "pardiso" if _have_pardiso() else "superlu"
    if name == "pardiso":
        if not _have_pardiso():
            raise ParameterError("solver 'pardiso' needs pypardiso: pip install 'skfem_sheet[fast]'")
        return PardisoSolver()
    return SuperLUSolver()


class _Timed:
    name = "?"

    def __init__(self):
        self.factor_time = 0.0
        self.solve_time = 0.0
        self.n_factorizations = 0
        self.n_solves = 0


class SuperLUSolver(_Timed):
    """SuperLU with a symmetric (MMD on A+A^T) ordering and diagonal pivoting."""

    name = "superlu"

    def factorize(self, K):
        from scipy.sparse.linalg import splu

        t = time.perf_counter()
        try:
            self._lu = splu(sp.csc_matrix(K), permc_spec="MMD_AT_PLUS_A",
                            diag_pivot_thresh=0.0, options=dict(SymmetricMode=True))
        except RuntimeError as err:  # "Factor is exactly singular"
            raise LinearSolverError(f"SuperLU factorisation failed: {err}") from None
        finally:
            self.factor_time += time.perf_counter() - t
        self.n_factorizations += 1

    def solve(self, b):
        t = time.perf_counter()
        x = self._lu.solve(np.asarray(b, dtype=float))
        self.solve_time += time.perf_counter() - t
        self.n_solves += 1
        return x


class PardisoSolver(_Timed):
    """MKL PARDISO, symmetric indefinite, symbolic analysis reused."""

    name = "pardiso"

    def __init__(self):
        super().__init__()
        from pypardiso import PyPardisoSolver

        self._ps = PyPardisoSolver(mtype=-2)
        ip = self._ps.iparm
        ip[:] = 0
        ip[0] = 1    # iparm(1): use the values below
        ip[1] = 2    # nested dissection (METIS)
        ip[3] = 0
        ip[7] = 2    # iterative refinement steps
        ip[9] = 8    # pivot perturbation 1e-8
        ip[10] = 1   # symmetric scaling
        ip[12] = 1   # weighted matching (with scaling: robust for saddle points)
        ip[20] = 1   # Bunch-Kaufman pivoting
        ip[23] = 0
        ip[34] = 0   # one-based indices (pypardiso adds 1)
        self._pattern = None
        self._U = None

    def _upper(self, K):
        if (self._pattern is None or self._pattern[0].shape != K.indices.shape
                or not np.array_equal(self._pattern[0], K.indices)):
            U = sp.triu(K, format="csr")
            U.sort_indices()
            self._pattern = (K.indices.copy(), U.indptr, U.indices)
            # positions of the upper-triangle entries inside K.data
            Kc = K.tocoo()
            keep = Kc.col >= Kc.row
            self._take = np.flatnonzero(keep)
            order = np.lexsort((Kc.col[keep], Kc.row[keep]))
            self._take = self._take[order]
            self._analysed = False
        _, indptr, indices = self._pattern
        return sp.csr_matrix((K.data[self._take], indices, indptr), shape=K.shape)

    def _call(self, phase, A, b):
        self._ps.set_phase(phase)
        return self._ps._call_pardiso(A, b)

    def factorize(self, K):
        from pypardiso.pardiso_wrapper import PyPardisoError

        t = time.perf_counter()
        U = self._upper(K)
        b = np.zeros((K.shape[0], 1))
        try:
            if not self._analysed:
                self._call(11, U, b)
                self._analysed = True
            self._call(22, U, b)
        except PyPardisoError as err:
            raise LinearSolverError(f"PARDISO factorisation failed: {err}") from None
        finally:
            self.factor_time += time.perf_counter() - t
        self._U = U
        self.n_factorizations += 1

    def solve(self, b):
        t = time.perf_counter()
        b = np.asarray(b, dtype=float)
        x = self._call(33, self._U, np.asfortranarray(b))
        self.solve_time += time.perf_counter() - t
        self.n_solves += 1
        return x.reshape(b.shape)

    def __del__(self):
        try:
            if self._U is not None:
                self._ps.set_phase(-1)
                self._ps._call_pardiso(self._U, np.zeros((self._U.shape[0], 1)))
        except Exception:  # noqa: BLE001 - best-effort release of MKL memory at exit
            pass
