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

import importlib.metadata as md
import os
import time
from dataclasses import asdict, dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import LinearOperator, splu

from .discretisation import SaddlePointLayout
from .params import ParameterError

__all__ = ["make_linear_solver", "available_solvers", "SOLVERS", "LinearSolverError",
           "PardisoSolver", "SuperLUSolver", "PyAMGSolver", "SaddlePointLayout",
           "SolverCounts", "near_null_space"]

SOLVERS = ("auto", "pardiso", "superlu", "pyamg")


class LinearSolverError(RuntimeError):
    """The factorisation failed (singular or numerically unusable matrix), or
    an iterative solve did not reach its tolerance."""


def _locate_mkl() -> None:
    """Tell pypardiso where MKL's ``mkl_rt`` is before it looks for itself.

    Importing pypardiso creates a solver, which (unless ``PYPARDISO_MKL_RT``
    is set) globs ``sys.prefix`` recursively for ``mkl_rt``: 1-2 s per
    process, a visible share of a coarse solve and of every sweep worker.
    The ``mkl`` wheel's file list (``importlib.metadata``) names the library
    in milliseconds.  Nothing is set if it is not found there (pypardiso then
    searches as usual) or if the user set the variable.
    """
    if "PYPARDISO_MKL_RT" in os.environ:
        return
    try:
        files = md.files("mkl") or []
    except md.PackageNotFoundError:
        return
    for f in sorted((f for f in files if f.name.startswith("libmkl_rt.so")
                     or f.name == "mkl_rt.dll" or f.name.startswith("libmkl_rt.")),
                    key=lambda f: len(str(f))):
        path = os.path.realpath(f.locate())
        if os.path.isfile(path):
            os.environ["PYPARDISO_MKL_RT"] = path
            return


def _have_pardiso() -> bool:
    _locate_mkl()
    try:
        import pypardiso  # noqa: F401  (optional dependency: only probed)
    except (ImportError, OSError):
        return False
    return True


def _have_pyamg() -> bool:
    try:
        import pyamg  # noqa: F401  (deferred, probed only: see PyAMGSolver._setup)
    except ImportError:
        return False
    return True


def available_solvers():
    """Names of the back-ends usable on this machine (besides ``"auto"``).

    Examples
    --------
    >>> "superlu" in available_solvers()
    True
    """
    have = {"pardiso": _have_pardiso, "pyamg": _have_pyamg}
    return [s for s in SOLVERS[1:] if have.get(s, lambda: True)()]


def make_linear_solver(name: str = "auto", **options):
    """Create a linear-solver back-end by name (see the module docstring).

    Parameters
    ----------
    name : {"auto", "pardiso", "superlu", "pyamg"}
    **options
        Passed to the back-end's constructor (e.g. ``rtol`` of
        :class:`PyAMGSolver`, ``reproducible`` or ``pivot_perturbation`` of
        :class:`PardisoSolver`; every back-end takes ``reproducible``, the
        serial ones are reproducible whatever it says).

    Examples
    --------
    >>> import scipy.sparse as sp
    >>> s = make_linear_solver("superlu")
    >>> s.factorize(sp.csr_matrix([[2.0, 1.0], [1.0, -1.0]]))
    >>> s.solve([3.0, 0.0]), s.inertia()
    (array([1., 1.]), (1, 1, 0))
    """
    if name not in SOLVERS:
        raise ParameterError(f"solver must be one of {', '.join(SOLVERS)}, got {name!r}")
    if name == "auto":
        name = "pardiso" if _have_pardiso() else "superlu"
    if name == "pardiso":
        if not _have_pardiso():
            raise ParameterError("solver 'pardiso' needs pypardiso: "
                                 "pip install 'skfem_sheet[fast]'")
        return PardisoSolver(**options)
    if name == "pyamg":
        if not _have_pyamg():
            raise ParameterError("solver 'pyamg' needs pyamg: pip install pyamg")
        return PyAMGSolver(**options)
    return SuperLUSolver(**options)


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


class _Timed:
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


class SuperLUSolver(_Timed):
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


def _remember_mkl(ps):
    """Remember where pypardiso found MKL.

    Without ``PYPARDISO_MKL_RT`` (pypardiso's own setting) every
    ``PyPardisoSolver()`` scans ``sys.prefix`` recursively for ``mkl_rt``,
    about 1 s per solve, which dominates coarse solves in a sweep.  Setting it
    once makes later solvers (and sweep worker processes, which inherit the
    environment) load the library directly.
    """
    name = getattr(ps.libmkl, "_name", None)
    if name and "PYPARDISO_MKL_RT" not in os.environ:
        os.environ["PYPARDISO_MKL_RT"] = name


def _mkl_threads(ps):
    """MKL's thread count in this process (``MKL_Get_Max_Threads``), at least 1.

    The value only sets how PARDISO's reproducible mode partitions the work:
    the results are the same bits for any value and any actual thread count
    (checked with 1, 2 and 3 threads on the sheet tangent).
    """
    try:
        return max(1, int(ps.libmkl.MKL_Get_Max_Threads()))
    except (AttributeError, OSError):  # an MKL without the service function
        return max(1, os.cpu_count() or 1)


class PardisoSolver(_Timed):
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
        _locate_mkl()
        from pypardiso import PyPardisoSolver  # optional dependency (the fast extra)

        self._ps = PyPardisoSolver(mtype=-2)
        _remember_mkl(self._ps)
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
        ip[33] = _mkl_threads(self._ps) if reproducible else 0   # iparm(34): CNR
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


def near_null_space(X, comp=None, bending=True, x=None, R=None):
    """Rigid-body (and plate-bending) modes of a sheet, one row per dof.

    Parameters
    ----------
    X : ndarray (n, 3)
        Reference node coordinates (the sheet lies in the xy-plane, normal z).
    comp : ndarray (m,), optional
        Rows wanted, as ``3 * node + component`` (default: all ``3 n``).
    bending : bool
        Add the three Kirchhoff plate modes (constant curvature or twist,
        ``w = X^2/2, Y^2/2, X Y`` with the matching in-plane ``u = -Z grad w``):
        their energy is ``O(h^3)`` against ``O(h)`` for membrane modes, so with
        them the AMG coarse spaces carry the sheet's soft bending.
    x : ndarray (n, 3), optional
        Deformed node positions (default ``X``): the rigid rotations of the
        deformed body, ``omega x (x - mean x)``, are the near-null space of the
        tangent there, not those of the reference.
    R : ndarray (n, 3, 3), optional
        Local rotation of the material at each node (polar factor of ``F``):
        the bending modes are rotated with it, ``R m(X)``.

    Returns
    -------
    ndarray (m, 6) or (m, 9)
        Columns: 3 translations, 3 rotations (about the centroid), then the
        bending modes.

    Examples
    --------
    >>> X = np.array([[0.0, 0, 0], [1.0, 0, 0]])
    >>> near_null_space(X, bending=False)[:, 5] + 0.0   # rotation about z: u = (-y, x, 0)
    array([ 0. , -0.5,  0. ,  0. ,  0.5,  0. ])
    """
    X = np.asarray(X, dtype=float)
    x = X if x is None else np.asarray(x, dtype=float)
    if comp is None:
        comp = np.arange(3 * len(X))
    node, c = np.divmod(np.asarray(comp), 3)
    B = np.zeros((len(node), 9 if bending else 6))
    B[c == 0, 0] = B[c == 1, 1] = B[c == 2, 2] = 1.0
    xc = x[node] - x.mean(axis=0)
    for k in range(3):  # rotation about axis k: e_k x (x - c)
        rot = np.cross(np.eye(3)[k], xc)
        B[:, 3 + k] = rot[np.arange(len(node)), c]
    if bending:
        X0, Y0, Z0 = (X[node] - X.mean(axis=0)).T
        m = np.zeros((len(node), 3, 3))  # (row, component, mode)
        m[:, 0, 0], m[:, 2, 0] = -X0 * Z0, 0.5 * X0**2
        m[:, 1, 1], m[:, 2, 1] = -Y0 * Z0, 0.5 * Y0**2
        m[:, 0, 2], m[:, 1, 2], m[:, 2, 2] = -Y0 * Z0, -X0 * Z0, X0 * Y0
        if R is not None:
            m = np.einsum("nij,njm->nim", np.asarray(R)[node], m)
        B[:, 6:] = m[np.arange(len(node)), c]
    return B


class PyAMGSolver(_Timed):
    """Block-preconditioned flexible GMRES with a pyamg hierarchy (no factorisation).

    ``K = [[A, B^T], [B, 0]]`` (displacement, pressure) is solved by FGMRES,
    right-preconditioned by the block upper-triangular matrix
    ``[[A~, B^T], [0, -S~]]``:

    - ``A~^-1``: one V-cycle of smoothed-aggregation AMG on ``A``, stored
      node-wise as 3x3 blocks (nodes with fewer free components, e.g. on the
      symmetry plane, are padded with decoupled rows), symmetric block
      Gauss-Seidel smoothing, energy-minimising prolongators, a sparse direct
      solve on the coarsest level;
    - near-null space: the 6 rigid-body modes *of the deformed sheet* plus 3
      plate-bending modes rotated with the material
      (:func:`near_null_space`, with the layout's nodal displacements and
      rotations; pass the state to :meth:`factorize`);
    - ``S~ = M_p / mu``: the P1 pressure mass matrix over the shear modulus
      (``B A^-1 B^T ~ M_p / mu`` for incompressible elasticity; the
      eigenvalues of ``M_p^-1 S`` lie in ``[0.14, 1.5] / mu`` on the
      reference tangent), factorised once in :meth:`attach`.

    The choices (bending modes, ``theta``, the triangular preconditioner,
    deformed-configuration modes, reused prolongators): ``docs/decisions.md``,
    "The pyamg solver".

    Parameters
    ----------
    rtol : float
        Required ``||K x - b|| / ||b||``, checked on the true residual;
        :class:`LinearSolverError` if not reached (the default ``1e-6``: the
        same Newton iterations and deflections as PARDISO).
    maxiter : int
        Most FGMRES iterations per solve (no restarts; memory ``2 maxiter``
        vectors).
    theta : float
        Strength-of-connection threshold of the aggregation.
    reuse : bool
        Keep the aggregates and prolongators between factorisations and only
        redo the Galerkin products and smoothers (a Newton sequence changes
        ``A`` little); the hierarchy is rebuilt from scratch when a solve
        needs more than ``rebuild_factor`` times the iterations the first
        solve after the last full setup needed (+5), or fails.
    bending_modes : bool
        Add the three plate-bending modes to the near-null space.
    max_coarse : int
        Coarsening stops below this many block rows (then a sparse LU).

    Attributes
    ----------
    iterations : list of int
        FGMRES iterations of every solve.
    residuals : list of float
        Final relative residual of every solve.
    setup_time, krylov_time : float
        Seconds spent building hierarchies, and in FGMRES.
    n_setups, n_refreshes : int
        Full hierarchy builds, and Galerkin-only refreshes.

    Examples
    --------
    >>> from skfem_sheet import Sheet
    >>> from skfem_sheet.solve import build_problem
    >>> p = build_problem(Sheet(length=0.5), 0.15, None, 2)
    >>> K = p.tangent(np.zeros(p.ndof))
    >>> s = PyAMGSolver(rtol=1e-8)
    >>> s.attach(p.saddle_point_layout()); s.factorize(K, state=np.zeros(p.ndof))
    >>> b = -p.gravity_load[p.free]
    >>> x = s.solve(b)
    >>> bool(np.linalg.norm(K @ x - b) <= 1e-8 * np.linalg.norm(b)), s.iterations[-1] < 60
    (True, True)
    """

    name = "pyamg"
    needs_layout = True

    def __init__(self, rtol=1e-6, maxiter=200, theta=0.02, reuse=True, rebuild_factor=1.5,
                 bending_modes=True, max_coarse=300, reproducible=True):
        super().__init__()
        self.reproducible = True   # serial: the same bits every time, whatever asked
        self.rtol = float(rtol)
        self.maxiter = int(maxiter)
        self.theta = float(theta)
        self.reuse = bool(reuse)
        self.rebuild_factor = float(rebuild_factor)
        self.bending_modes = bool(bending_modes)
        self.max_coarse = int(max_coarse)
        self.iterations = []
        self.residuals = []
        self.setup_time = 0.0
        self.krylov_time = 0.0
        self.n_setups = 0
        self.n_refreshes = 0
        self._attached = False
        self._ml = None
        self._maps = None
        self._fresh_iterations = None  # iterations of the first solve after a full setup
        self._stale = False
        self._refreshed = False
        self._stale_retry = False

    # -- the saddle-point structure -------------------------------------------
    def attach(self, layout):
        """Take the dof layout, near-null-space data and Schur stand-in of the
        systems to come.

        Parameters
        ----------
        layout : SaddlePointLayout
            Displacement unknowns first (node-wise components), then
            pressures; ``layout.pressure_schur`` is factorised here.  An
            object with a ``saddle_point_layout()`` method (a
            :class:`~skfem_sheet.problem.SheetProblem`) is asked for its layout.
        """
        if not isinstance(layout, SaddlePointLayout):
            layout = layout.saddle_point_layout()
        nu = layout.n_displacement
        node, comp = layout.displacement_nodes, layout.displacement_components
        nodes = np.unique(node)
        pad = 3 * np.searchsorted(nodes, node) + comp
        self._n, self._nu = layout.n_unknowns, nu
        self._npad = 3 * len(nodes)
        self._pad = None if self._npad == nu else pad
        self._padded_rows = pad
        self._layout, self._nodes = layout, nodes
        self._state = None
        self._schur = splu(sp.csc_matrix(layout.pressure_schur))
        self._attached = True
        self._ml = None
        self._maps = None

    def _near_null_space(self):
        """Modes of the last state passed to :meth:`factorize` (reference if none)."""
        lay, nodes = self._layout, self._nodes
        X = lay.coordinates[nodes]
        x = R = None
        if self._state is not None:
            x = X + lay.displacements(self._state)[nodes]
            if self.bending_modes:
                R = lay.rotations(self._state)[nodes]
        B = np.zeros((self._npad, 9 if self.bending_modes else 6))
        B[self._padded_rows] = near_null_space(X, self._padded_rows, self.bending_modes, x, R)
        return B

    def _index_maps(self, K):
        """Positions of A's 3x3 blocks and of B^T inside ``K.data``."""
        nu, npad = self._nu, self._npad
        pos = sp.csr_matrix((np.arange(1, K.nnz + 1, dtype=float), K.indices, K.indptr),
                            shape=K.shape)
        Auu = pos[:nu, :nu].tocoo()
        r, c, v = Auu.row, Auu.col, Auu.data
        if self._pad is not None:
            r, c = self._pad[r], self._pad[c]
            missing = np.setdiff1d(np.arange(npad), self._pad)
            r = np.concatenate([r, missing])
            c = np.concatenate([c, missing])
            v = np.concatenate([v, np.full(len(missing), -1.0)])
        Ab = sp.csr_matrix((v, (r, c)), shape=(npad, npad)).tobsr(blocksize=(3, 3))
        Ab.sort_indices()
        take_a = np.rint(Ab.data.ravel()).astype(np.int64)  # 0: zero, -1: padding
        Bt = pos[:nu, nu:].tocsr()
        Bt.sort_indices()
        self._maps = dict(indices=K.indices.copy(), take_a=take_a, a_indices=Ab.indices,
                          a_indptr=Ab.indptr, pad_pos=np.flatnonzero(take_a < 0),
                          take_b=np.rint(Bt.data).astype(np.int64) - 1,
                          b_indices=Bt.indices, b_indptr=Bt.indptr)

    def _blocks(self, K):
        m = self._maps
        kd = np.concatenate([[0.0], K.data])
        a = kd[np.maximum(m["take_a"], 0)]
        if len(m["pad_pos"]):
            diag = K.diagonal()[: self._nu]
            a[m["pad_pos"]] = np.abs(diag).mean()  # decoupled rows of the right scale
        A = sp.bsr_matrix((a.reshape(-1, 3, 3), m["a_indices"], m["a_indptr"]),
                          shape=(self._npad, self._npad))
        Bt = sp.csr_matrix((K.data[m["take_b"]], m["b_indices"], m["b_indptr"]),
                           shape=(self._nu, self._n - self._nu))
        return A, Bt

    # -- hierarchy -----------------------------------------------------------
    _PRE = ("block_gauss_seidel", {"sweep": "symmetric"})
    _POST = ("block_gauss_seidel", {"sweep": "symmetric"})

    def _setup(self, A):
        # deferred: only this back-end needs pyamg (~0.05 s to import)
        import pyamg

        self._ml = pyamg.smoothed_aggregation_solver(
            A, B=self._near_null_space(), strength=("symmetric", {"theta": self.theta}),
            smooth=("energy", {"degree": 2, "maxiter": 8}),
            presmoother=self._PRE, postsmoother=self._POST,
            max_coarse=self.max_coarse, coarse_solver="splu")
        self.n_setups += 1
        self._fresh_iterations = None
        self._stale = False
        self._refreshed = False

    def _refresh(self, A):
        """New operators on the old aggregates and prolongators."""
        from pyamg.multilevel import coarse_grid_solver  # deferred: see _setup
        from pyamg.relaxation.smoothing import change_smoothers

        levels = self._ml.levels
        A.symmetry = "hermitian"
        levels[0].A = A
        for lv, nxt in zip(levels[:-1], levels[1:]):
            Ac = lv.R @ lv.A @ lv.P
            Ac.symmetry = "hermitian"
            nxt.A = Ac
        change_smoothers(self._ml, self._PRE, self._POST)
        self._ml.coarse_solver = coarse_grid_solver("splu")
        self.n_refreshes += 1
        self._refreshed = True

    def factorize(self, K, state=None):
        """Set up the preconditioner for ``K``.

        ``state``: the full dof vector ``w`` at which ``K`` was formed.  A new
        hierarchy then takes the rigid-body and bending modes of the deformed
        sheet as near-null space (2-5x fewer iterations on a drooped sheet
        than reference-configuration modes); without it the last state given
        (or the reference configuration) is used.
        """
        if state is not None:
            self._state = np.array(state, dtype=float)
        if not self._attached:
            raise RuntimeError("the pyamg back-end needs solver.attach(layout) before factorize")
        t = time.perf_counter()
        try:
            if self._maps is None or not np.array_equal(self._maps["indices"], K.indices):
                self._index_maps(K)
                self._ml = None
            A, self._Bt = self._blocks(K)
            if self._ml is None or not self.reuse or self._stale:
                self._setup(A)
            else:
                self._refresh(A)
        except (ValueError, RuntimeError, np.linalg.LinAlgError) as err:
            self._ml = None
            raise LinearSolverError(f"pyamg setup failed: {type(err).__name__}: {err}") from None
        finally:
            dt = time.perf_counter() - t
            self.factor_time += dt
            self.setup_time += dt
        self._K = K
        self.n_factorizations += 1

    # -- solve ---------------------------------------------------------------
    def _preconditioner(self):
        nu, npad, pad = self._nu, self._npad, self._pad
        cycle = self._ml.aspreconditioner(cycle="V")
        Bt, schur = self._Bt, self._schur

        def apply(r):
            r = np.ravel(r)
            out = np.empty_like(r)
            yp = -schur.solve(r[nu:])
            out[nu:] = yp
            ru = r[:nu] - Bt @ yp
            if pad is None:
                out[:nu] = cycle @ ru
            else:
                rp = np.zeros(npad)
                rp[pad] = ru
                out[:nu] = (cycle @ rp)[pad]
            return out

        return LinearOperator(self._K.shape, matvec=apply, dtype=float)

    def _krylov(self, b):
        """FGMRES to ``||K x - b|| <= rtol ||b||`` on the true residual.

        FGMRES's recurrence residual can drift below the true one (the
        preconditioned vectors of the soft bending modes are large and cancel),
        so on a miss the iteration restarts from the current ``x`` with the
        recomputed residual (iterative refinement), within ``maxiter`` in all.
        """
        from pyamg.krylov import fgmres  # deferred: see _setup

        nb = np.linalg.norm(b)
        x = np.zeros_like(b)
        its, rel = 0, 1.0
        M = self._preconditioner()
        for _ in range(4):
            res = []
            try:
                x, _ = fgmres(self._K, b, x0=x, tol=self.rtol, maxiter=self.maxiter - its,
                              restart=None, M=M, residuals=res)
            except RuntimeError as err:  # e.g. the coarsest level's LU is singular
                raise LinearSolverError(f"pyamg: {err}") from None
            its += len(res) - 1
            rel = float(np.linalg.norm(self._K @ x - b) / nb)
            if rel <= self.rtol or its >= self.maxiter or not np.isfinite(rel):
                break
        return x, its, rel

    def _solve1(self, b):
        if not np.any(b):
            self.iterations.append(0)
            self.residuals.append(0.0)
            return np.zeros_like(b)
        x, its, rel = self._krylov(b)
        if not rel <= self.rtol and self._refreshed and not self._stale_retry:
            # a reused hierarchy may have gone stale: rebuild once and retry
            t = time.perf_counter()
            try:
                self._setup(self._blocks(self._K)[0])
            except (ValueError, RuntimeError, np.linalg.LinAlgError) as err:
                raise LinearSolverError(
                    f"pyamg setup failed: {type(err).__name__}: {err}") from None
            finally:
                self.setup_time += time.perf_counter() - t
                self.factor_time += time.perf_counter() - t
            self._stale_retry = True
            x, its2, rel = self._krylov(b)
            its += its2
        self.iterations.append(its)
        self.residuals.append(rel)
        if not rel <= self.rtol:
            raise LinearSolverError(f"pyamg: FGMRES reached a relative residual of {rel:.2e} "
                                    f"(> rtol={self.rtol:g}) in {its} iterations")
        if self._fresh_iterations is None:
            self._fresh_iterations = its
        elif its > self.rebuild_factor * self._fresh_iterations + 5:
            self._stale = True  # rebuild at the next factorisation
        return x

    def solve(self, b):
        if self._ml is None:
            raise RuntimeError("solve before factorize")
        t = time.perf_counter()
        b = np.asarray(b, dtype=float)
        self._stale_retry = False
        try:
            if b.ndim == 1:
                x = self._solve1(b)
            else:
                x = np.column_stack([self._solve1(b[:, j]) for j in range(b.shape[1])])
        finally:
            dt = time.perf_counter() - t
            self.solve_time += dt
            self.krylov_time += dt
        self._count_solve(b)
        return x
