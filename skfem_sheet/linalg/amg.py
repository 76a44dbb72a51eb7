"""The iterative back-end (:class:`PyAMGSolver`): FGMRES with a block-triangular
preconditioner on a smoothed-aggregation hierarchy of the displacement block,
whose near-null space is the rigid-body modes (:func:`near_null_space`).
"""
from __future__ import annotations

import time

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import LinearOperator, splu

from ..discretisation import SaddlePointLayout
from .base import LinearSolverError, Timed


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


class PyAMGSolver(Timed):
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
