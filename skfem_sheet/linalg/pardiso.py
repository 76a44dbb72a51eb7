"""Intel MKL PARDISO through pypardiso's low-level handle (:class:`PardisoSolver`):
symmetric indefinite, the symbolic analysis reused while the pattern stays,
reproducible by default, the inertia unknown where pivots were perturbed.
"""
from __future__ import annotations

import time

import numpy as np
import scipy.sparse as sp

from ..params import ParameterError
from .base import LinearSolverError, Timed
from .mkl import locate_mkl, mkl_threads, remember_mkl


class PardisoSolver(Timed):
    """MKL PARDISO, symmetric indefinite, symbolic analysis reused.

    The ``iparm`` array is given in full (``iparm(1) = 1``; 1-based numbers as
    in the MKL manual, ``iparm[i - 1]`` in pypardiso's array): nested
    dissection (METIS) ordering, Bunch-Kaufman pivoting, two steps of
    iterative refinement, and, for the zero pressure block of the
    saddle-point system, symmetric scaling (``iparm(11)``) with weighted
    matching (``iparm(13)``), which move large entries next to the diagonal
    so that 2x2 pivots can take them.

    :meth:`inertia` reads PARDISO's counts of positive and negative pivots,
    ``iparm(22)`` and ``iparm(23)`` (scaling and matching are congruences, so
    they keep the inertia), *unless* the factorisation perturbed pivots: the
    count of pivots smaller than ``10**-pivot_perturbation`` times the
    matrix's scale that were replaced by that value is ``iparm(14)``, read
    after every factorisation into :attr:`perturbed_pivots`.  The pivot
    counts are then those of a nearby matrix (a zero eigenvalue, as at a
    fold, can be counted on either side), so :meth:`inertia` returns None and
    the stability of the state is unknown; the untrusted counts stay in
    :attr:`pivot_inertia`.

    With ``reproducible`` (the default) PARDISO runs in conditional numerical
    reproducibility mode (``iparm(34)`` > 0, the number of OpenMP threads it
    partitions the work for): the same matrix gives the same bits in every
    process and with any number of threads (threaded PARDISO otherwise sums
    supernode updates in an order that depends on thread timing, and a
    pseudo-transient snap amplifies that round-off into different Newton
    iteration counts and end states).  ``iparm(34)`` alone switches the mode
    on (``MKL_CBWR`` is not needed; set, it also does).  It costs no time
    (the record: ``benchmarks/results/speed/solve_sample_reproducible_hmax0.06.txt``).

    Parameters
    ----------
    reproducible : bool
        Conditional numerical reproducibility (``iparm(34)``), default True.
    scaling, matching : bool
        Symmetric scaling (``iparm(11)``) and weighted matching
        (``iparm(13)``), default True (both are needed for the zero block).
    pivot_perturbation : int
        ``iparm(10)``: pivots below ``10**-pivot_perturbation`` (relative) are
        perturbed, 1 to 20 (default 8, MKL's for symmetric indefinite
        matrices).

    Attributes
    ----------
    perturbed_pivots : int
        ``iparm(14)`` of the last factorisation.
    pivot_inertia : tuple or None
        PARDISO's ``(n_positive, n_negative, rest)`` of the last
        factorisation, trusted or not.
    counts : SolverCounts
        Factorisations, back-substitutions, factorisations with perturbed
        pivots.
    """

    name = "pardiso"

    def __init__(self, reproducible=True, scaling=True, matching=True, pivot_perturbation=8):
        super().__init__()
        for nm, v in (("reproducible", reproducible), ("scaling", scaling),
                      ("matching", matching)):
            if not isinstance(v, (bool, np.bool_)):
                raise ParameterError(f"{nm} must be True or False, got {v!r}")
        if (isinstance(pivot_perturbation, bool)
                or not isinstance(pivot_perturbation, (int, np.integer))
                or not 1 <= pivot_perturbation <= 20):
            raise ParameterError("pivot_perturbation must be an integer in [1, 20], "
                                 f"got {pivot_perturbation!r}")
        locate_mkl()
        from pypardiso import PyPardisoSolver  # optional dependency (the fast extra)

        self._ps = PyPardisoSolver(mtype=-2)
        remember_mkl(self._ps)
        self.reproducible = bool(reproducible)
        ip = self._ps.iparm   # ip[i - 1] is the manual's iparm(i)
        ip[:] = 0
        ip[0] = 1    # iparm(1): all values are given here, no defaults
        ip[1] = 2    # iparm(2): nested dissection (METIS); not 3, which rules out CNR
        ip[3] = 0
        # iparm(8) = 0: PARDISO's default, two steps of iterative refinement
        # only where the factorisation perturbed pivots; an exact factorisation
        # solves to a relative residual of 1e-10 without them, and each step
        # (a product and a solve) makes a back-substitution 2.4x as long
        # (docs/decisions.md, "No iterative refinement in PARDISO")
        ip[7] = 0
        ip[9] = int(pivot_perturbation)   # iparm(10): perturb pivots below 10^-value
        ip[10] = int(bool(scaling))       # iparm(11): symmetric scaling
        ip[12] = int(bool(matching))      # iparm(13): weighted matching
        ip[20] = 1   # iparm(21): Bunch-Kaufman pivoting
        ip[23] = 0   # iparm(24): classic factorisation (CNR is defined for it)
        ip[33] = mkl_threads(self._ps) if reproducible else 0   # iparm(34): CNR
        ip[34] = 0   # iparm(35): one-based indices (pypardiso adds 1)
        self._pattern = None
        self._U = None
        self._inertia = None
        self.pivot_inertia = None
        self.perturbed_pivots = 0
        self.refinement_steps = 0

    def _upper(self, K):
        if (self._pattern is None or self._pattern[0].shape != K.indices.shape
                or not np.array_equal(self._pattern[0], K.indices)
                or (self._U is not None and self._U.shape != K.shape)):
            if self._U is not None:
                # another matrix: PARDISO's memory of the last one is released
                # first (a new analysis on a handle that holds factors of
                # another size aborts the process inside MKL)
                self._call(-1, self._U, np.zeros((self._U.shape[0], 1)))
                self._U = None
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

    def factorize(self, K, state=None):
        """Numerical factorisation of ``K`` (``state`` is ignored); reads the
        inertia and the number of perturbed pivots."""
        from pypardiso.pardiso_wrapper import PyPardisoError  # optional dependency

        t = time.perf_counter()
        U = self._upper(K)
        b = np.zeros((K.shape[0], 1))
        self._inertia = None
        self.pivot_inertia = None
        try:
            if not self._analysed:
                self._call(11, U, b)
                self._analysed = True
            self._call(22, U, b)
        except PyPardisoError as err:
            raise LinearSolverError(f"PARDISO factorisation failed: {err}") from None
        finally:
            self.factor_time += time.perf_counter() - t
        ip = self._ps.iparm
        npos, nneg = int(ip[21]), int(ip[22])           # iparm(22), iparm(23)
        self.pivot_inertia = (npos, nneg, K.shape[0] - npos - nneg)
        self.perturbed_pivots = int(ip[13])             # iparm(14)
        if self.perturbed_pivots == 0:
            self._inertia = self.pivot_inertia
        else:
            self.n_perturbed_factorizations += 1
        self._U = U
        self.n_factorizations += 1

    def solve(self, b):
        t = time.perf_counter()
        b = np.asarray(b, dtype=float)
        x = self._call(33, self._U, np.asfortranarray(b))
        self.refinement_steps += int(self._ps.iparm[6])  # iparm(7): steps taken
        self.solve_time += time.perf_counter() - t
        self._count_solve(b)
        return x.reshape(b.shape)

    def inertia(self):
        """``(n_positive, n_negative, n_zero)`` of the last factorised K
        (PARDISO's ``iparm(22)``, ``iparm(23)``; zero = the rest), or None
        if that factorisation perturbed pivots (``perturbed_pivots > 0``)."""
        return self._inertia

    def __del__(self):
        try:
            if self._U is not None:
                self._ps.set_phase(-1)
                self._ps._call_pardiso(self._U, np.zeros((self._U.shape[0], 1)))
        except Exception:  # noqa: BLE001 - best-effort release of MKL memory at exit
            pass
