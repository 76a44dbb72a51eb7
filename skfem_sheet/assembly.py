"""Assembly of element arrays into the reduced (free-dof) Newton system.

:class:`Assembler` owns, for one dof layout (:class:`TaylorHoodSpace`):

- the CSR sparsity pattern of the free-free tangent (fixed for its lifetime,
  pressure diagonal stored as explicit zeros) and of the small free-clamped
  block, with the operators that sum element blocks into them;
- the work buffers of the element kernels (:class:`Workspace`), reused from
  call to call (fresh 100 MB arrays at every tangent cost more in page faults
  than the arithmetic), guarded by a lock;
- the chunking of the elements over its own threads (numpy releases the
  GIL; threads only ever write disjoint slices): a pool made on the first
  assembly large enough to be split (:data:`THREAD_MIN_ELEMENTS`), ended when
  the assembler is dropped.  No pool is shared by the process: whoever holds
  the assembler (a solve, a study's :class:`~skfem_sheet.build.BuildChain`,
  a result) holds its threads.

Element matrices are assembled as 3 x 3 node-node and 3 x 1 node-vertex
blocks: summed per global block pair with two sparse products, then gathered
into the CSR data.  Working on blocks instead of the 34 x 34 entries of every
element makes the operators ten times smaller than a dof-level scatter.
"""
from __future__ import annotations

import os
import threading
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from .discretisation import TaylorHoodSpace

try:  # scipy's own CSR x dense kernel, written into the output (private in scipy)
    from scipy.sparse._sparsetools import csr_matvecs
except ImportError:  # a scipy without it: same result, one copy
    csr_matvecs = None

__all__ = ["Assembler", "Workspace", "THREAD_MIN_ELEMENTS", "threads",
           "element_chunks", "on_element_chunks", "scatter_operator", "add_product"]

#: Below this many elements the element kernels run in one thread.
THREAD_MIN_ELEMENTS = 4000


def threads() -> int:
    """Threads for the element kernels: the BLAS/OpenMP thread setting if there
    is one (sweep workers get ``cores // workers``), else the usable cores (at most 4)."""
    for var in ("OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        v = os.environ.get(var, "")
        if v.isdigit() and int(v) > 0:
            return min(4, int(v))
    try:
        return max(1, min(4, len(os.sched_getaffinity(0))))
    except AttributeError:  # not on Linux
        return max(1, min(4, os.cpu_count() or 1))


def element_chunks(nel):
    """Slices of the elements, one per thread (one slice for small meshes)."""
    n = threads() if nel >= THREAD_MIN_ELEMENTS else 1
    bounds = np.linspace(0, nel, n + 1).astype(int)
    return [slice(a, b) for a, b in zip(bounds[:-1], bounds[1:])]


def on_element_chunks(kernel, w, *outs, executor=None):
    """``kernel(w, chunk, *out_chunks)`` on every chunk of elements (on the
    threads of ``executor`` when there are several; without one, in turn),
    the ``outs`` (nel, ...) sliced per chunk; returns the kernel's results in
    chunk order (the same numbers either way: the chunks do not depend on
    the executor).

    Examples
    --------
    >>> out = np.zeros((5000, 2))
    >>> def kernel(w, sl, o):
    ...     o[:] = w
    ...     return sl.stop - sl.start
    >>> sum(on_element_chunks(kernel, 1.0, out)) == len(out) and bool(np.all(out == 1.0))
    True
    """
    chunks = element_chunks(len(outs[0]))
    if len(chunks) == 1:
        return [kernel(w, chunks[0], *outs)]
    if executor is None:
        return [kernel(w, sl, *(o[sl] for o in outs)) for sl in chunks]
    futures = [executor.submit(kernel, w, sl, *(o[sl] for o in outs)) for sl in chunks]
    return [f.result() for f in futures]


def scatter_operator(slots, entries, n_slots, n_entries):
    """Sparse 0/1 operator adding the ``entries`` (columns, strictly increasing)
    of a flat element array into ``slots`` (rows).  Built as CSC (at most one
    entry per column, no sorting) and turned into CSR by scipy's linear-time
    transpose: several times faster than from COO at millions of entries."""
    entries = np.asarray(entries)
    n = len(entries)
    if n > 1 and not np.all(np.diff(entries) > 0):
        raise ValueError("scatter_operator needs strictly increasing entries")
    itype = np.int32 if max(n, n_slots, n_entries) < 2 ** 31 else np.int64
    colptr = np.zeros(n_entries + 1, dtype=itype)
    colptr[entries + 1] = 1
    np.cumsum(colptr, out=colptr)
    S = sp.csc_matrix((np.ones(n), np.asarray(slots).astype(itype), colptr),
                      shape=(n_slots, n_entries))
    return S.tocsr()


def add_product(S, X, Y):
    """``Y += S @ X`` for a CSR matrix ``S`` and C-contiguous ``X``, ``Y``,
    written into ``Y`` (scipy's own kernel; ``S @ X`` would allocate a fresh
    result, whose page faults cost as much as the product at these sizes)."""
    if not (X.flags.c_contiguous and Y.flags.c_contiguous):
        raise ValueError("add_product needs C-contiguous X and Y")
    if csr_matvecs is None:
        Y += S @ X
        return
    csr_matvecs(S.shape[0], S.shape[1], X.shape[1], S.indptr, S.indices, S.data,
                X.ravel(), Y.ravel())


class Workspace:
    """Work buffers and element threads of one :class:`Assembler`, made on
    first use, and the lock that serialises their use.

    Every assembly call holds ``lock`` while it writes and reads the buffers
    and returns fresh arrays, so problems that share an assembler (all
    problems on one mesh, and their :meth:`SheetProblem.with_length` copies)
    can be used from several threads: their assemblies then take turns.
    Pickling drops the buffers and the threads (they are made again on use).

    Attributes
    ----------
    residual : ndarray (nel, 34) or None
        Element residuals.
    blocks : tuple of ndarray or None
        Element tangent blocks ``Kb`` (nel, 10, 10, 3, 3) and ``Kpu`` (nel, 4, 10, 3).
    summed : ndarray or None
        The summed-block vector ``V = [Guu | Gup | 0]`` (see :meth:`Assembler.summed_blocks`).
    lock : threading.RLock

    Examples
    --------
    >>> ws = Workspace()
    >>> ws.executor() is ws.executor(), ws.residual is None
    (True, True)
    """

    __slots__ = ("residual", "blocks", "summed", "lock", "_executor")

    def __init__(self):
        self.residual = None
        self.blocks = None
        self.summed = None
        self.lock = threading.RLock()
        self._executor = None

    def executor(self):
        """The element threads: a pool of :func:`threads` threads, made on
        first use and ended with this workspace (when its assembler is dropped)."""
        with self.lock:
            if self._executor is None:
                self._executor = ThreadPoolExecutor(threads(), thread_name_prefix="skfem_sheet")
            return self._executor

    def __reduce__(self):
        return (Workspace, ())


@dataclass(frozen=True, eq=False)
class Assembler:
    """Sparsity patterns, assembly operators and work buffers of one dof layout.

    Build with :meth:`build` (a :class:`~skfem_sheet.build.BuildChain` keeps
    the assemblers it builds: the pattern takes a few seconds to build at hmax
    0.03).  The
    position of the free-free entry (row dof r, column dof c) of a block pair
    is ``indptr_ff[r] + blk_off[pair] + rank[c]`` (see :meth:`build`).

    Attributes
    ----------
    n_elements, ndof, n_free, n_clamp : int
    edofs : ndarray (nel, 34)
        Dofs of each element (residual assembly).
    sum_uu : scipy.sparse.csr_matrix
        Element node-node blocks ``(e, a, b)`` -> global node pairs.
    sum_up : scipy.sparse.csr_matrix
        Element node-vertex blocks ``(e, c, a)`` -> global node-vertex pairs.
    gather_ff : ndarray
        For every entry of the free-free pattern, its index in the summed-block
        vector ``[Guu.ravel(), Gup.ravel(), 0]`` (vertex-node entries read
        their node-vertex partner: the tangent is symmetric; the pressure
        diagonal reads the trailing zero).
    indptr_ff, indices_ff : ndarray (int32)
        CSR pattern of the free-free block (sorted indices).
    clamp_elements : ndarray
        Elements touching the clamped dofs.
    scatter_fd : scipy.sparse.csr_matrix
        Entries of those elements' 34 x 34 matrices -> free-clamped pattern.
    indptr_fd, indices_fd : ndarray (int32)
        CSR pattern of the free rows x clamped columns block.
    workspace : Workspace
        The buffers (owned by this assembler, shared by every problem using it).
    """

    n_elements: int
    ndof: int
    n_free: int
    n_clamp: int
    edofs: np.ndarray
    sum_uu: sp.csr_matrix
    sum_up: sp.csr_matrix
    gather_ff: np.ndarray
    indptr_ff: np.ndarray
    indices_ff: np.ndarray
    clamp_elements: np.ndarray
    scatter_fd: sp.csr_matrix
    indptr_fd: np.ndarray
    indices_fd: np.ndarray
    workspace: Workspace = field(default_factory=Workspace, repr=False)

    def __repr__(self):
        return (f"Assembler(n_elements={self.n_elements}, ndof={self.ndof}, "
                f"n_free={self.n_free}, nnz={len(self.indices_ff)})")

    # -- construction --------------------------------------------------------
    @classmethod
    def build(cls, space: TaylorHoodSpace) -> Assembler:
        """Patterns and operators of ``space``'s free dofs (uncached).

        The free-free pattern is found at the level of *blocks* (a P2 node with
        its free displacement components, or a P1 vertex with its pressure):
        the unique (block, block) pairs of all elements (14 x 14 per element,
        instead of 34 x 34 dof pairs), expanded to dofs.  Pressure-pressure
        couplings are structurally zero and left out, except the diagonal,
        which is stored as explicit zeros for the symmetric-indefinite solvers.
        """
        free = space.free
        nel = len(space.edofs)
        nn, n = space.n_nodes, space.ndof
        red = np.full(n, -1, dtype=np.int64)
        red[free] = np.arange(len(free))
        nf = len(free)
        # blocks: node k -> k, vertex c -> nn + c; dof -> (block, component)
        nb = nn + space.n_vertices
        dof_block = np.concatenate([np.repeat(np.arange(nn), 3), nn + np.arange(space.n_vertices)])
        is_free = red >= 0
        # free components of each block, and each free dof's rank among them
        nfree_block = np.bincount(dof_block, weights=is_free, minlength=nb).astype(np.int64)
        rank = np.full(n, -1, dtype=np.int64)
        fb = dof_block[free]
        first = np.concatenate([[0], np.cumsum(nfree_block)[:-1]])
        rank[free] = np.arange(nf) - first[fb]
        # unique block pairs over the elements
        # int64: the pair keys A * nb + B overflow int32 beyond 46k blocks
        eblocks = np.hstack([space.element_nodes, nn + space.element_vertices]).astype(np.int64)
        nbe = eblocks.shape[1]
        A = np.repeat(eblocks, nbe, axis=1).ravel()
        B = np.tile(eblocks, (1, nbe)).ravel()
        keep = ~((A >= nn) & (B >= nn) & (A != B))  # pressure-pressure: diagonal only
        keys = A * nb + B
        keys[~keep] = -1
        ukeys, binv = np.unique(keys, return_inverse=True)
        binv = binv.reshape(nel, nbe, nbe)
        bA, bB = np.divmod(ukeys, nb)
        # offset of each block column inside its block row, counted in free dofs
        width = nfree_block[bB]
        width[bA < 0] = 0
        cum = np.cumsum(width) - width
        row_first = np.full(nb, 0, dtype=np.int64)
        ok = bA >= 0
        # first entry of each block row (ukeys sorted: rows contiguous)
        starts = np.flatnonzero(ok & np.concatenate([[True], bA[1:] != bA[:-1]]))
        row_first[bA[starts]] = cum[starts]
        blk_off = cum - np.where(ok, row_first[np.maximum(bA, 0)], 0)
        row_len = np.bincount(bA[ok], weights=width[ok], minlength=nb).astype(np.int64)
        # dof-level CSR: every free dof of block A has row_len[A] entries
        counts = row_len[fb]
        indptr = np.concatenate([[0], np.cumsum(counts)])
        # column indices: for each block row, the free dofs of its block columns
        free_by_block = free[np.argsort(fb, kind="stable")]  # grouped by block
        seg = np.repeat(first[bB[ok]] - cum[ok], width[ok]) + np.arange(width[ok].sum())
        colseq = red[free_by_block[seg]]  # all block rows, concatenated
        seg_start = np.zeros(nb, dtype=np.int64)
        seg_start[bA[starts]] = cum[starts] - cum[ok][0]
        src = np.repeat(seg_start[fb] - indptr[:-1], counts) + np.arange(indptr[-1])
        indices = colseq[src]
        sum_uu, sum_up, gather_ff = _block_assembly(space, ukeys, binv, blk_off, indptr,
                                                    red, rank)
        clamp = _clamp_pattern(space, red)
        return cls(n_elements=nel, ndof=n, n_free=nf, n_clamp=len(space.clamp_dofs),
                   edofs=space.edofs, sum_uu=sum_uu, sum_up=sum_up, gather_ff=gather_ff,
                   indptr_ff=indptr.astype(np.int32), indices_ff=indices.astype(np.int32),
                   **clamp)

    # -- element kernels on chunks -------------------------------------------
    def on_element_chunks(self, kernel, w, *outs):
        """``kernel(w, chunk, *out_chunks)`` on chunks of this mesh's elements,
        on this assembler's threads (:func:`on_element_chunks`, :meth:`Workspace.executor`)."""
        if len(element_chunks(len(outs[0]))) == 1:
            return on_element_chunks(kernel, w, *outs)
        return on_element_chunks(kernel, w, *outs, executor=self.workspace.executor())

    # -- buffers (call with workspace.lock held) -----------------------------
    def residual_buffer(self):
        """The element residual buffer (nel, 34)."""
        ws = self.workspace
        if ws.residual is None:
            ws.residual = np.empty((self.n_elements, 34))
        return ws.residual

    def tangent_buffers(self):
        """The element blocks ``Kb`` (nel, 10, 10, 3, 3) and ``Kpu`` (nel, 4, 10, 3)."""
        ws = self.workspace
        if ws.blocks is None:
            nel = self.n_elements
            ws.blocks = (np.empty((nel, 10, 10, 3, 3)), np.empty((nel, 4, 10, 3)))
        return ws.blocks

    def _summed_vector(self):
        """The reused vector ``V = [Guu | Gup | 0]`` that :meth:`gather` reads
        (the trailing zero is the pressure diagonal's entry)."""
        ws = self.workspace
        if ws.summed is None:
            n_uu, n_up = self.sum_uu.shape[0], self.sum_up.shape[0]
            ws.summed = np.zeros(9 * n_uu + 3 * n_up + 1)
        return ws.summed

    def summed_blocks(self):
        """Views ``Guu`` (n_uu, 9) and ``Gup`` (n_up, 3) of the summed node-node
        and node-vertex blocks, to be filled before :meth:`gather`."""
        V = self._summed_vector()
        n_uu = self.sum_uu.shape[0]
        return V[: 9 * n_uu].reshape(n_uu, 9), V[9 * n_uu:-1].reshape(-1, 3)

    def gather(self):
        """Free-free CSR data (a new array) from the summed blocks."""
        return np.take(self._summed_vector(), self.gather_ff)

    # -- assembled objects ---------------------------------------------------
    def vector(self, R):
        """Global vector (ndof,) of element vectors ``R`` (nel, 34)."""
        return np.bincount(self.edofs.ravel(), weights=R.ravel(), minlength=self.ndof)

    def constant_blocks(self, block):
        """Summed node-node blocks ``block_ab d_ik`` for element matrices
        ``block`` (nel, 10, 10), shape (n_uu, 9)."""
        g = self.sum_uu @ block.reshape(-1)
        return g[:, None] * np.eye(3).ravel()

    def sum_blocks(self, constant, Kb, Kpu):
        """Fill the summed blocks with ``constant`` (n_uu, 9) plus the sums of
        the element blocks ``Kb`` and ``Kpu`` (``Kpu`` may be None: zero)."""
        Guu, Gup = self.summed_blocks()
        Guu[...] = constant
        if Kb is not None:
            add_product(self.sum_uu, Kb.reshape(self.n_elements * 100, 9), Guu)
        Gup[...] = 0.0
        if Kpu is not None:
            add_product(self.sum_up, Kpu.reshape(self.n_elements * 40, 3), Gup)

    def matrix(self, data):
        """The free-free CSR matrix with ``data`` on the fixed pattern."""
        nf = self.n_free
        return sp.csr_matrix((data, self.indices_ff, self.indptr_ff), shape=(nf, nf))

    def clamp_matrix(self, Ke):
        """``K_fc`` (free rows, clamped columns) from the element matrices ``Ke``
        (n, 34, 34) of :attr:`clamp_elements`."""
        data = self.scatter_fd @ Ke.ravel()
        return sp.csr_matrix((data, self.indices_fd, self.indptr_fd),
                             shape=(self.n_free, self.n_clamp))


def _block_assembly(space, ukeys, binv, blk_off, indptr, red, rank):
    """``sum_uu``, ``sum_up`` and ``gather_ff`` of :class:`Assembler` (see there).

    The position of the entry (row dof r, column dof c) of a pair is
    ``indptr[r] + blk_off[pair] + rank[c]`` (the row's first entry, the offset
    of the column's block in that row, the column's rank in its block).
    """
    nn, nb = space.n_nodes, space.n_nodes + space.n_vertices
    nnz = int(indptr[-1])
    start = indptr[:-1]
    bA, bB = np.divmod(ukeys, nb)
    ok = ukeys >= 0
    uu = ok & (bA < nn) & (bB < nn)
    up = ok & (bA < nn) & (bB >= nn)
    pu = ok & (bA >= nn) & (bB < nn)
    pp = ok & (bA >= nn) & (bB >= nn)  # the diagonal only
    uu_index, up_index = np.cumsum(uu) - 1, np.cumsum(up) - 1
    n_uu, n_up = int(uu.sum()), int(up.sum())
    n_uu_el, n_up_el = 100 * len(binv), 40 * len(binv)  # element blocks (e, a, b), (e, c, a)
    sum_uu = scatter_operator(uu_index[binv[:, :10, :10]].ravel(), np.arange(n_uu_el), n_uu,
                              n_uu_el)
    sum_up = scatter_operator(up_index[binv[:, :10, 10:].transpose(0, 2, 1)].ravel(),
                              np.arange(n_up_el), n_up, n_up_el)

    comp = np.arange(3)
    zero = 9 * n_uu + 3 * n_up
    src = np.full(nnz, -1, dtype=np.int64)

    def rows_of(dofs):
        r = red[dofs]
        return r >= 0, start[np.maximum(r, 0)]

    # node-node: row (A, i), column (B, k) <- Guu[pair, 3 i + k]
    u = np.flatnonzero(uu)
    rok, r0 = rows_of(3 * bA[u, None] + comp)
    ck = rank[3 * bB[u, None] + comp]
    pos = r0[:, :, None] + blk_off[u, None, None] + ck[:, None, :]
    valid = rok[:, :, None] & (ck >= 0)[:, None, :]
    val = 9 * uu_index[u, None, None] + 3 * comp[:, None] + comp
    src[pos[valid]] = val[valid]
    # node-vertex: row (A, i), column C <- Gup[pair, i]
    u = np.flatnonzero(up)
    rok, r0 = rows_of(3 * bA[u, None] + comp)
    pos = r0 + blk_off[u, None]
    src[pos[rok]] = (9 * n_uu + 3 * up_index[u, None] + comp)[rok]
    # vertex-node: row C, column (A, k) <- Gup[partner, k]
    u = np.flatnonzero(pu)
    partner = np.searchsorted(ukeys, bB[u] * nb + bA[u])
    _, r0 = rows_of(space.nu_dof + bA[u] - nn)
    ck = rank[3 * bB[u, None] + comp]
    pos = r0[:, None] + blk_off[u, None] + ck
    src[pos[ck >= 0]] = (9 * n_uu + 3 * up_index[partner, None] + comp)[ck >= 0]
    # pressure diagonal: explicit zero
    u = np.flatnonzero(pp)
    _, r0 = rows_of(space.nu_dof + bA[u] - nn)
    src[r0 + blk_off[u]] = zero
    if (src < 0).any():
        raise AssertionError("block assembly does not cover the sparsity pattern")
    return sum_uu, sum_up, src  # intp: numpy's take would convert int32 at every call


def _clamp_pattern(space, red):
    """Free rows x clamped columns, from the elements touching the clamp."""
    edofs = space.edofs
    nd = edofs.shape[1]
    nf, nx = len(space.free), len(space.clamp_dofs)
    fix = np.full(space.ndof, -1, dtype=np.int64)
    fix[space.clamp_dofs] = np.arange(nx)
    clamp_elements = np.flatnonzero((fix[edofs] >= 0).any(axis=1))
    ed = edofs[clamp_elements]
    rows = np.repeat(ed, nd, axis=1).ravel()
    cols = np.tile(ed, (1, nd)).ravel()
    fd = np.flatnonzero((red[rows] >= 0) & (fix[cols] >= 0))
    keys = red[rows[fd]] * nx + fix[cols[fd]]
    uniq, inv = np.unique(keys, return_inverse=True)
    r, c = np.divmod(uniq, nx)
    return dict(
        clamp_elements=clamp_elements,
        scatter_fd=scatter_operator(inv, fd, len(uniq), len(ed) * nd * nd),
        indptr_fd=np.concatenate([[0], np.cumsum(np.bincount(r, minlength=nf))]).astype(np.int32),
        indices_fd=c.astype(np.int32))
