"""scipy's SuperLU on the symmetric-indefinite tangent (:class:`SuperLUSolver`):
a symmetric minimum-degree ordering on ``A + A^T``, diagonal pivoting,
symmetric mode, the inertia from U's diagonal where no pivot left it.
"""
from __future__ import annotations

import time

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from .base import LinearSolverError, Timed


class SuperLUSolver(Timed):
    """SuperLU with a symmetric fill-reducing ordering and diagonal pivoting.

    The ordering is SuperLU's minimum degree on ``A + A^T`` (scipy's default,
    COLAMD with partial pivoting, does not finish on these matrices), computed
    once per sparsity pattern, then adjusted so that a row with a zero
    diagonal (the pressure block) is eliminated only after all its neighbours:
    before the first one its pivot is exactly zero (SuperLU then pivots off
    the diagonal), before the last one it can be a tiny cancellation residue
    (the diagonal pivot is taken and the factors are garbage); after all of
    them it is minus a local Schur complement, safely away from zero.
    The matrix is permuted symmetrically with that ordering (a precomputed
    index map) and factorised in natural order with diagonal pivoting.

    :meth:`inertia` is known when no off-diagonal pivot was taken (SuperLU's
    ``perm_r`` is the identity): then ``P^T K P = L U`` with ``U = D L^T`` up
    to positive row/column scalings, and by Sylvester's law the signs of
    ``diag(U)`` are the inertia of ``K``.
    """

    name = "superlu"

    def __init__(self, reproducible=True):
        super().__init__()
        self.reproducible = True   # serial: the same bits every time, whatever asked
        self._pattern = None
        self._lu = None
        self._inertia = None

    @staticmethod
    def _splu(A, permc_spec):
        try:
            return splu(A, permc_spec=permc_spec, diag_pivot_thresh=0.0,
                        options=dict(SymmetricMode=True))
        except RuntimeError as err:  # "Factor is exactly singular"
            raise LinearSolverError(f"SuperLU factorisation failed: {err}") from None

    def _ordering(self, K):
        """Symmetric ordering for ``K``'s pattern and the map ``K.data -> P^T K P``."""
        n = K.shape[0]
        K = sp.csr_matrix(K)
        first = self._splu(sp.csc_matrix(K), "MMD_AT_PLUS_A")
        pos = np.empty(n)
        pos[np.argsort(first.perm_c)] = np.arange(n)  # elimination step of each row
        key = pos.copy()
        for i in np.flatnonzero(K.diagonal() == 0):
            nb = K.indices[K.indptr[i]:K.indptr[i + 1]]
            nb = nb[nb != i]
            if len(nb) and pos[i] < pos[nb].max():
                key[i] = pos[nb].max() + 0.5 + pos[i] / (2.0 * n)  # just after the last
        order = np.argsort(key, kind="stable")
        marks = sp.csr_matrix((np.arange(1, K.nnz + 1, dtype=float), K.indices, K.indptr),
                              shape=K.shape)
        P = marks[order][:, order].tocsc()
        self._pattern = (K.indices.copy(), order, np.rint(P.data).astype(np.int64) - 1,
                         P.indices, P.indptr)

    def factorize(self, K, state=None):
        """LU of ``K`` (``state`` is ignored)."""
        t = time.perf_counter()
        self._lu = None
        self._inertia = None
        try:
            if self._pattern is None or not np.array_equal(self._pattern[0], K.indices):
                self._ordering(K)
            _, order, take, indices, indptr = self._pattern
            Kp = sp.csc_matrix((K.data[take], indices, indptr), shape=K.shape)
            self._lu = self._splu(Kp, "NATURAL")
            if np.array_equal(self._lu.perm_r, np.arange(K.shape[0])):
                d = self._lu.U.diagonal()
                self._inertia = (int(np.sum(d > 0)), int(np.sum(d < 0)), int(np.sum(d == 0)))
        finally:
            self.factor_time += time.perf_counter() - t
        self.n_factorizations += 1

    def solve(self, b):
        t = time.perf_counter()
        b = np.asarray(b, dtype=float)
        order = self._pattern[1]
        x = np.empty_like(b)
        x[order] = self._lu.solve(np.ascontiguousarray(b[order]))
        self.solve_time += time.perf_counter() - t
        self._count_solve(b)
        return x

    def inertia(self):
        """``(n_positive, n_negative, n_zero)`` of the last factorised K, or
        None if SuperLU pivoted off the diagonal (then the signs of U's
        diagonal say nothing)."""
        return self._inertia
