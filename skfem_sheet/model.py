"""The incompressible neo-Hookean sheet: kernels and the discrete Newton system.

Continuum model (paper, SI "Numerical Method")::

    Pi(U, p) = int  mu/2 (I_C - 3) - mu ln J + g U_z - p (J - 1)  dV

with ``F = I + grad U``, ``J = det F``, ``I_C = tr(F^T F)``, dimensionless
units (lengths / a, energy densities / (rho g a), so the weight density is 1
and ``g`` is the gravity *load factor*, 1 at full gravity).

About ``- mu ln J``: it vanishes wherever ``J = 1``, so the continuum problem is
the paper's; it only shifts the Lagrange multiplier, ``p_paper = p + mu`` (the
paper's pressure is ``mu`` in the stress-free state, ours is 0).  Without it
the displacement block of the tangent carries ``-mu D^2 J``, which with one
element through the thickness (where P1 pressure enforces ``J = 1`` only
weakly) made Newton stall at mesh-dependent, unphysical loads (see
``shared/notes/measured-facts.md``).  Outputs report ``p_paper``.

Discretisation: Taylor-Hood tetrahedra, P2 displacement, P1 pressure;
displacement dofs are numbered node by node, ``3 * node + component``, then
pressure dofs ``3 * n_nodes + vertex``.  Element matrices are computed for all
elements at once with a few batched products (no per-basis-pair callbacks),
as 3 x 3 node-node and 3 x 1 node-vertex blocks; the blocks are summed per
global block pair with two sparse products and gathered into a CSR matrix
whose sparsity pattern is computed once.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np
import scipy.sparse as sp

from .mesh import SheetMesh
from .params import Sheet

__all__ = ["clamp_displacement", "clamp_displacement_rate", "kinematics",
           "first_piola", "SheetProblem"]


# ----------------------------------------------------------------------------
# pure kernels
# ----------------------------------------------------------------------------
def clamp_displacement(y, z, kappa):
    """Clamp displacement ``U0(y, z)`` for clamp curvature ``kappa = a/R``.

    SI eq. for U0::

        U0 = [(R - z) sin(y/R) - y] e_y + (R - z) [1 - cos(y/R)] e_z,  U0_x = 0,

    written in a form that is exact and smooth as ``kappa -> 0`` (``U0 = 0``):
    ``R sin(y/R) = y sinc(kappa y / pi)`` and
    ``R (1 - cos(y/R)) = y sin(kappa y / 2) sinc(kappa y / (2 pi))``.

    Returns an array of shape ``y.shape + (3,)``.
    """
    y = np.asarray(y, dtype=float)
    z = np.asarray(z, dtype=float)
    s = np.sin(kappa * y)
    r_sin = y * np.sinc(kappa * y / np.pi)  # R sin(y/R)
    r_vers = y * np.sin(0.5 * kappa * y) * np.sinc(kappa * y / (2 * np.pi))  # R (1 - cos)
    out = np.zeros(y.shape + (3,))
    out[..., 1] = r_sin - z * s - y
    out[..., 2] = r_vers - z * (1.0 - np.cos(kappa * y))
    return out


def clamp_displacement_rate(y, z, kappa, dk=1e-6):
    """``d U0 / d kappa`` (central difference of :func:`clamp_displacement`)."""
    return (clamp_displacement(y, z, kappa + dk)
            - clamp_displacement(y, z, kappa - dk)) / (2 * dk)


def kinematics(Ue, dphi):
    """Deformation gradient at quadrature points.

    Parameters
    ----------
    Ue : ndarray (nel, 10, 3)
        Nodal displacements of each element.
    dphi : ndarray (nel, nq, 10, 3)
        Reference gradients of the P2 basis.

    Returns
    -------
    F : ndarray (nel, nq, 3, 3), ``F_iJ = delta_iJ + dU_i/dX_J``.
    """
    # F_ij = sum_a U_ai dphi_aj as a batched matmul (3-5x faster than einsum)
    F = np.matmul(Ue.transpose(0, 2, 1)[:, None], dphi)
    F[..., 0, 0] += 1.0
    F[..., 1, 1] += 1.0
    F[..., 2, 2] += 1.0
    return F


def det_inv(F):
    """Determinant and inverse of a stack of 3x3 matrices (explicit cofactors,
    several times faster than ``np.linalg`` on many tiny matrices)."""
    a, b, c = F[..., 0, 0], F[..., 0, 1], F[..., 0, 2]
    d, e, f = F[..., 1, 0], F[..., 1, 1], F[..., 1, 2]
    g, h, i = F[..., 2, 0], F[..., 2, 1], F[..., 2, 2]
    A, B, C = e * i - f * h, f * g - d * i, d * h - e * g
    J = a * A + b * B + c * C
    cof = np.stack([np.stack([A, c * h - b * i, b * f - c * e], -1),
                    np.stack([B, a * i - c * g, c * d - a * f], -1),
                    np.stack([C, b * g - a * h, a * e - b * d], -1)], -2)
    with np.errstate(divide="ignore", invalid="ignore"):
        Finv = cof / J[..., None, None]
    return J, Finv


def first_piola(F, p, mu):
    """First Piola stress of ``psi = mu/2 (I_C - 3) - mu ln J - p (J - 1)``.

    ``P = mu F - (mu + p J) F^{-T}``.  Returns ``(P, J, Finv)``.
    """
    J, Finv = det_inv(F)
    P = mu * F - (mu + p * J)[..., None, None] * np.swapaxes(Finv, -1, -2)
    return P, J, Finv


# ----------------------------------------------------------------------------
# the discrete problem
# ----------------------------------------------------------------------------
class SheetProblem:
    """Taylor-Hood discretisation of one sheet on one mesh.

    Holds everything that does not change between Newton iterations or load
    steps: basis gradients and weights, dof maps, the CSR sparsity pattern of
    the reduced (free-dof) tangent and the assembly operators into it.

    Parameters
    ----------
    sheet : Sheet
    mesh : SheetMesh
    quadrature_order : int
        Order of the tetrahedral quadrature (2: 4 points, exact for the
        linearised stiffness of P2; 4: 11 points).
    """

    def __init__(self, sheet: Sheet, mesh: SheetMesh, quadrature_order: int = 2):
        # everything but the material is shared by all problems on one mesh
        self.__dict__.update(_discretization(mesh, quadrature_order))
        self.quadrature_order = quadrature_order
        self.sheet = sheet
        self.mu = sheet.mu
        self.length = mesh.length  # current sheet length (see with_length)
        self._constants = {}  # assembled constant matrices (see _tangent_constant)

    def with_length(self, length: float) -> "SheetProblem":
        """The same problem for a sheet of another length, on the same mesh
        stretched in x (``x -> x length / mesh.length``).

        The mesh topology, dof numbering and sparsity pattern are kept, so a
        nodal solution at one length is a valid initial guess at the next:
        the length is a continuous parameter of one discrete problem (used by
        :mod:`skfem_sheet.bistability`).  The stretch is affine, so only the
        x-derivatives of the basis, the volume weights, the node coordinates
        and the loads change.  Elements degrade when the stretch is large;
        callers remesh beyond a factor of about 1.4.
        """
        from .params import check_range

        length = check_range("length", length, 0, None, lo_open=True)
        ref = _discretization(self.sheet_mesh, self.quadrature_order)
        s = length / self.sheet_mesh.length
        new = object.__new__(SheetProblem)
        new.__dict__.update(self.__dict__)
        new.sheet = self.sheet.replace(length=length)
        new.length = length
        new.dphi = ref["dphi"].copy()
        new.dphi[..., 0] /= s
        new.dx = ref["dx"] * s
        new.nodes = ref["nodes"] * np.array([s, 1.0, 1.0])
        new._lap = np.einsum("eq,eqaj,eqbj->eab", new.dx, new.dphi, new.dphi)
        new._constants = {}
        new.gravity_load = ref["gravity_load"] * s
        new.volume0 = ref["volume0"] * s
        return new

    @property
    def n_free(self) -> int:
        return len(self.free)

    # -- state helpers -------------------------------------------------------
    def split(self, w):
        """Nodal displacements (n_nodes, 3) and vertex pressures of ``w``."""
        return w[: self.nu_dof].reshape(-1, 3), w[self.nu_dof:]

    def clamp_values(self, kappa):
        """Values of the clamped dofs ``clamp_dofs`` for clamp curvature ``kappa``.

        (The other fixed dofs, ``U_y = 0`` on the symmetry plane of a half
        model, are always zero.)
        """
        X = self.nodes[self.clamp_nodes]
        return clamp_displacement(X[:, 1], X[:, 2], kappa).ravel()

    def clamp_rate(self, kappa):
        """``d clamp_values / d kappa``."""
        X = self.nodes[self.clamp_nodes]
        return clamp_displacement_rate(X[:, 1], X[:, 2], kappa).ravel()

    def _fields(self, w, elements=None):
        U, pv = self.split(w)
        sel = slice(None) if elements is None else elements
        F = kinematics(U[self.element_nodes[sel]], self.dphi[sel])
        p = np.einsum("ec,eqc->eq", pv[self.element_vertices[sel]], self.phi1[sel])
        return F, p

    # -- residual, tangent, energy ------------------------------------------
    def _element_residuals(self, w, sel, R):
        """Element residuals of the elements ``sel`` written into ``R`` (n, 34):
        ``int P_ij dphi_aj`` for the displacement dofs and ``-int (J - 1) psi_c``
        for the pressure dofs.  Returns the smallest ``det F``."""
        F, p = self._fields(w, sel)
        P, J, _ = first_piola(F, p, self.mu)
        wq = self.dx[sel]
        # ru_ai = sum_q w_q dphi_aj P_ij (batched matmul, then the sum over q)
        ru = np.matmul(self.dphi[sel], (wq[..., None, None] * P).transpose(0, 1, 3, 2)).sum(1)
        R[:, :30] = ru.reshape(len(wq), 30)
        R[:, 30:] = -np.einsum("eq,eqc->ec", wq * (J - 1.0), self.phi1[sel])
        return float(J.min())

    def residual(self, w, g):
        """Full residual vector ``dPi/dw`` at gravity factor ``g``.

        Returns ``(r, Jmin)`` where ``Jmin`` is the smallest ``det F`` over
        quadrature points (``<= 0`` means an inverted element; then ``r`` is
        meaningless and filled with NaN).  The element residuals are computed
        on chunks of elements in threads, like the tangent.
        """
        nel = len(self.dx)
        if "residual" not in self._workspace:
            self._workspace["residual"] = np.empty((nel, 34))
        R = self._workspace["residual"]
        Jmin = float(np.min(_on_element_chunks(self._element_residuals, w, R)))  # NaN propagates
        if not Jmin > 0:
            return np.full(self.ndof, np.nan), Jmin
        r = np.bincount(self.edofs.ravel(), weights=R.ravel(), minlength=self.ndof)
        r += g * self.gravity_load
        return r, Jmin

    def _element_blocks(self, w, sel, Kb, Kpu, chunk=256):
        """The state-dependent part of the element tangents, written in place.

        ``Kb`` (n, 10, 10, 3, 3) receives the 3 x 3 node-node blocks
        ``Kb[a, b, i, k] = int (mu + p J) b_ak b_bi - p J b_ai b_bk``
        (the constant ``mu d_ik grad phi_a . grad phi_b`` is left out: see
        :meth:`_constant_blocks`), ``Kpu`` (n, 4, 10, 3) receives
        ``Kpu[c, a, i] = -int J b_ai psi_c``, with the spatial gradients
        ``b_a = F^{-T} grad phi_a``.  ``sel`` selects the elements (a slice or
        an index array).  The two 30 x 30 products and their rearrangement into
        blocks run on ``chunk`` elements at a time, in cache.
        """
        F, p = self._fields(w, sel)
        J, Finv = det_inv(F)
        nel, nq = J.shape
        bs = np.matmul(self.dphi[sel], Finv).reshape(nel, nq, 30)  # b_ai = dphi_am Finv_mi
        wq = self.dx[sel]
        wpJ = wq * p * J
        c3 = -wpJ[..., None] * bs  # - p J b_ai b_bk
        c2 = (self.mu * wq + wpJ)[..., None] * bs  # (mu + p J) b_ak b_bi
        m = min(chunk, nel)
        Y2, Y3 = np.empty((m, 30, 30)), np.empty((m, 30, 30))
        for lo in range(0, nel, m):
            hi = min(lo + m, nel)
            y2, y3 = Y2[: hi - lo], Y3[: hi - lo]
            bt = bs[lo:hi]
            np.matmul(c3[lo:hi].transpose(0, 2, 1), bt, out=y3)  # (a, i, b, k)
            np.matmul(c2[lo:hi].transpose(0, 2, 1), bt, out=y2)  # (a, k, b, i)
            np.add(y3.reshape(-1, 10, 3, 10, 3).transpose(0, 1, 3, 2, 4),
                   y2.reshape(-1, 10, 3, 10, 3).transpose(0, 1, 3, 4, 2), out=Kb[lo:hi])
        np.matmul(self.phi1[sel].transpose(0, 2, 1), -(wq * J)[..., None] * bs,
                  out=Kpu.reshape(nel, 4, 30))

    def element_matrices(self, w, elements=None):
        """Element tangents, shape (nel, 34, 34): the Hessian of Pi.

        ``K[(a,i),(b,k)] = int mu d_ik grad phi_a . grad phi_b
        + (mu + p J) b_ak b_bi - p J b_ai b_bk``, with the spatial gradients
        ``b_a = F^{-T} grad phi_a``, and ``K[(a,i), c] = -int J b_ai psi_c``.
        (:meth:`tangent` assembles the same blocks without forming these.)
        """
        sel = slice(None) if elements is None else elements
        nel = len(self.dx[sel])
        Kb, Kpu = np.empty((nel, 10, 10, 3, 3)), np.empty((nel, 4, 10, 3))
        self._element_blocks(w, sel, Kb, Kpu)
        lap = self.mu * self._lap[sel]
        for i in range(3):
            Kb[:, :, :, i, i] += lap
        K = np.zeros((nel, 34, 34))
        K[:, :30, :30] = Kb.transpose(0, 1, 3, 2, 4).reshape(nel, 30, 30)
        K[:, 30:, :30] = Kpu.reshape(nel, 4, 30)
        K[:, :30, 30:] = K[:, 30:, :30].transpose(0, 2, 1)
        return K

    def _buffers(self):
        """The element blocks ``Kb`` (nel, 10, 10, 3, 3) and ``Kpu`` (nel, 4,
        10, 3): work arrays shared by all problems on this mesh (stretched
        copies too; problems are used one at a time within a process).  Fresh
        100 MB arrays at every tangent would cost more in page faults than the
        arithmetic, hence the reuse."""
        if "tangent" not in self._workspace:
            nel = len(self.dx)
            self._workspace["tangent"] = (np.empty((nel, 10, 10, 3, 3)), np.empty((nel, 4, 10, 3)))
        return self._workspace["tangent"]

    def _summed_vector(self):
        """The reused vector ``V = [Guu | Gup | 0]`` that :meth:`_gather` reads
        (the trailing zero is the pressure diagonal's entry)."""
        if "summed" not in self._workspace:
            n_uu, n_up = self._sum_uu.shape[0], self._sum_up.shape[0]
            self._workspace["summed"] = np.zeros(9 * n_uu + 3 * n_up + 1)
        return self._workspace["summed"]

    def _summed_blocks(self):
        """Views ``Guu`` (n_uu, 9) and ``Gup`` (n_up, 3) of the summed node-node
        and node-vertex blocks, to be filled before :meth:`_gather`."""
        V = self._summed_vector()
        n_uu = self._sum_uu.shape[0]
        return V[: 9 * n_uu].reshape(n_uu, 9), V[9 * n_uu:-1].reshape(-1, 3)

    def _gather(self):
        """Free-free CSR data (a new array) from the summed blocks."""
        return np.take(self._summed_vector(), self._gather_ff)

    def _constant_blocks(self, block):
        """Summed node-node blocks ``block_ab d_ik`` for element matrices
        ``block`` (nel, 10, 10), shape (n_uu, 9)."""
        g = self._sum_uu @ block.reshape(-1)
        return g[:, None] * np.eye(3).ravel()

    def _tangent_constant(self):
        """Summed blocks of the constant part ``mu d_ik int grad phi_a .
        grad phi_b`` of the tangent (computed once per problem)."""
        if "tangent" not in self._constants:
            self._constants["tangent"] = self._constant_blocks(self.mu * self._lap)
        return self._constants["tangent"]

    @property
    def mass_data(self):
        """Displacement mass matrix ``d_ik int phi_a phi_b`` as data on the
        tangent's pattern (the pseudo-transient shift; computed on first use)."""
        if "mass" not in self._constants:
            mass = np.einsum("eq,eqa,eqb->eab", self.dx, self.phi2, self.phi2)
            Guu, Gup = self._summed_blocks()
            Guu[...] = self._constant_blocks(mass)
            Gup[...] = 0.0
            self._constants["mass"] = self._gather()
        return self._constants["mass"]

    def tangent(self, w):
        """Reduced tangent ``K_ff`` (free dofs) as a CSR matrix.

        Its sparsity pattern is fixed for the problem's lifetime, and the zero
        diagonal entries of the pressure block are stored explicitly.  The
        element blocks are computed on chunks of elements in threads (numpy
        releases the GIL), summed per global block pair (node-node 3 x 3 and
        node-vertex 3 x 1) with two sparse products, and gathered into the
        free-dof CSR data; the constant part is added to the summed blocks.
        """
        Kb, Kpu = self._buffers()
        _on_element_chunks(self._element_blocks, w, Kb, Kpu)
        nel = len(self.dx)
        Guu, Gup = self._summed_blocks()
        Guu[...] = self._tangent_constant()
        _add_product(self._sum_uu, Kb.reshape(nel * 100, 9), Guu)
        Gup[...] = 0.0
        _add_product(self._sum_up, Kpu.reshape(nel * 40, 3), Gup)
        nf = self.n_free
        return sp.csr_matrix((self._gather(), self._indices_ff, self._indptr_ff), shape=(nf, nf))

    def clamp_coupling(self, w):
        """``K_fc``: free rows, clamped columns (``clamp_dofs``; only the
        elements touching the clamp are computed)."""
        Ke = self.element_matrices(w, self.clamp_elements).ravel()
        data = self._scatter_fd @ Ke
        return sp.csr_matrix((data, self._indices_fd, self._indptr_fd),
                             shape=(self.n_free, len(self.clamp_dofs)))

    def energy(self, w, g):
        """Total potential energy Pi of the whole sheet (the constraint term
        vanishes at equilibrium; a half model counts twice)."""
        F, p = self._fields(w)
        J = np.linalg.det(F)
        IC = np.einsum("eqij,eqij->eq", F, F)
        dens = 0.5 * self.mu * (IC - 3) - self.mu * np.log(J) - p * (J - 1)
        U, _ = self.split(w)
        e = float(np.sum(self.dx * dens) + g * U[:, 2] @ (self.gravity_load[2:self.nu_dof:3]))
        return 2.0 * e if self.sheet_mesh.half else e

    def energy_density(self, w):
        """psi/mu = (I_C - 3)/2, averaged over each element (paper Fig. 3)."""
        F, _ = self._fields(w)
        IC = np.einsum("eqij,eqij->eq", F, F)
        return np.sum(self.dx * 0.5 * (IC - 3), axis=1) / self.dx.sum(axis=1)

    def jacobians(self, w):
        """det F at all quadrature points, shape (nel, nq)."""
        F, _ = self._fields(w)
        return np.linalg.det(F)

    def deformed_volume(self, w):
        """int J dV over the reference domain."""
        return float(np.sum(self.dx * self.jacobians(w)))

    def paper_pressure(self, w):
        """Nodal pressure in the paper's convention, ``p + mu``."""
        return self.split(w)[1] + self.mu


@lru_cache(maxsize=8)
def _discretization(mesh: SheetMesh, quadrature_order: int) -> dict:
    """Bases, dof maps and the sparsity pattern of one mesh (cached: the
    pattern takes a few seconds to build at hmax = 0.03)."""
    from skfem import Basis, ElementTetP1, ElementTetP2

    self = _Namespace()
    self.sheet_mesh = mesh
    m = mesh.mesh
    b2 = Basis(m, ElementTetP2(), intorder=quadrature_order)
    b1 = Basis(m, ElementTetP1(), intorder=quadrature_order)
    self.basis_u, self.basis_p = b2, b1
    nel = m.t.shape[1]
    # (nel, nq, 10, 3) gradients, (nel, nq, 10) P2 values, (nel, nq, 4) P1 values
    self.dphi = np.ascontiguousarray(
        np.stack([b2.basis[a][0].grad for a in range(10)], axis=0).transpose(2, 3, 0, 1))
    self.phi2 = np.stack([np.asarray(b2.basis[a][0]) for a in range(10)], axis=-1)
    self.phi1 = np.stack([np.asarray(b1.basis[c][0]) for c in range(4)], axis=-1)
    self.dx = np.asarray(b2.dx)
    self.n_nodes = b2.N
    self.n_vertices = b1.N
    self.nodes = b2.doflocs.T  # (n_nodes, 3) node coordinates
    self.ndof = 3 * self.n_nodes + self.n_vertices
    self.nu_dof = 3 * self.n_nodes
    en = b2.element_dofs.T  # (nel, 10) node numbers
    self.element_nodes = en
    self.element_vertices = b1.element_dofs.T  # (nel, 4)
    edofs_u = (3 * en[:, :, None] + np.arange(3)).reshape(nel, 30)
    self.edofs = np.hstack([edofs_u, self.nu_dof + self.element_vertices])  # (nel, 34)

    # clamp x = 0: all displacement dofs of those nodes
    tol = 1e-9 * max(1.0, mesh.length)
    x = self.nodes[:, 0]
    self.clamp_nodes = np.flatnonzero(np.abs(x) < tol)
    self.clamp_dofs = (3 * self.clamp_nodes[:, None] + np.arange(3)).ravel()
    is_fixed = np.zeros(self.ndof, bool)
    is_fixed[self.clamp_dofs] = True
    if mesh.half:  # symmetry plane y = 0: U_y = 0
        self.symmetry_nodes = np.flatnonzero(np.abs(self.nodes[:, 1]) < tol)
        is_fixed[3 * self.symmetry_nodes + 1] = True
    self.fixed = np.flatnonzero(is_fixed)
    self.free = np.flatnonzero(~is_fixed)
    _build_pattern(self)

    # constant parts: mu grad.grad (per element, scalar 10x10) and gravity load
    w = self.dx
    self._lap = np.einsum("eq,eqaj,eqbj->eab", w, self.dphi, self.dphi)
    fg = np.zeros(self.ndof)
    np.add.at(fg, 3 * en + 2, np.einsum("eq,eqa->ea", w, self.phi2))
    self.gravity_load = fg  # d/dg of the residual
    self.volume0 = float(w.sum())
    self._workspace = {}  # reused work arrays (see SheetProblem.tangent)

    return vars(self)


class _Namespace:
    pass


#: Below this many elements the tangent is computed in one thread.
_THREAD_MIN_ELEMENTS = 4000
#: The thread pool of the element kernels, created on first use and shared by
#: every problem of the process (one pool per mesh would leave idle threads
#: behind in long sweeps).  Threads only ever write disjoint slices.
_POOL = []


def _threads() -> int:
    """Threads for the element kernels: the BLAS/OpenMP thread setting if there
    is one (sweep workers get ``cores // workers``), else the usable cores (at most 4)."""
    import os

    for var in ("OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        v = os.environ.get(var, "")
        if v.isdigit() and int(v) > 0:
            return min(4, int(v))
    try:
        return max(1, min(4, len(os.sched_getaffinity(0))))
    except AttributeError:  # not on Linux
        return max(1, min(4, os.cpu_count() or 1))


def _pool():
    """A process-wide thread pool for the element kernels (created on first use)."""
    if not _POOL:
        from concurrent.futures import ThreadPoolExecutor

        _POOL.append(ThreadPoolExecutor(_threads(), thread_name_prefix="skfem_sheet"))
    return _POOL[0]


def _element_chunks(nel):
    """Slices of the elements, one per thread (one slice for small meshes)."""
    n = _threads() if nel >= _THREAD_MIN_ELEMENTS else 1
    bounds = np.linspace(0, nel, n + 1).astype(int)
    return [slice(a, b) for a, b in zip(bounds[:-1], bounds[1:])]


def _on_element_chunks(kernel, w, *outs):
    """``kernel(w, chunk, *out_chunks)`` on every chunk of elements (in the
    thread pool when there are several), the ``outs`` (nel, ...) sliced per
    chunk; returns the kernel's results in chunk order."""
    chunks = _element_chunks(len(outs[0]))
    if len(chunks) == 1:
        return [kernel(w, chunks[0], *outs)]
    futures = [_pool().submit(kernel, w, sl, *(o[sl] for o in outs)) for sl in chunks]
    return [f.result() for f in futures]


def _scatter(slots, entries, n_slots, n_entries):
    """Sparse 0/1 operator adding the ``entries`` (columns, strictly increasing)
    of a flat element array into ``slots`` (rows).  Built as CSC (at most one
    entry per column, no sorting) and turned into CSR by scipy's linear-time
    transpose: several times faster than from COO at millions of entries."""
    entries = np.asarray(entries)
    n = len(entries)
    if n > 1 and not np.all(np.diff(entries) > 0):
        raise ValueError("_scatter needs strictly increasing entries")
    itype = np.int32 if max(n, n_slots, n_entries) < 2 ** 31 else np.int64
    colptr = np.zeros(n_entries + 1, dtype=itype)
    colptr[entries + 1] = 1
    np.cumsum(colptr, out=colptr)
    S = sp.csc_matrix((np.ones(n), np.asarray(slots).astype(itype), colptr),
                      shape=(n_slots, n_entries))
    return S.tocsr()


def _build_pattern(self):
    """CSR patterns of the free-free and free-clamped blocks and the operators
    that assemble element matrices into them (:func:`_block_assembly` for the
    free-free block, a dof-level scatter for the small free-clamped one).

    The free-free pattern is found at the level of *blocks* (a P2 node with its
    free displacement components, or a P1 vertex with its pressure): the
    unique (block, block) pairs of all elements (14 x 14 per element, instead
    of 34 x 34 dof pairs), expanded to dofs.  Pressure-pressure couplings are
    structurally zero and left out, except the diagonal, which is stored as
    explicit zeros for the symmetric-indefinite solvers.
    """
    nel = len(self.edofs)
    nn, n = self.n_nodes, self.ndof
    red = np.full(n, -1, dtype=np.int64)
    red[self.free] = np.arange(len(self.free))
    nf = len(self.free)
    # blocks: node k -> k, vertex c -> nn + c; dof -> (block, component)
    nb = nn + self.n_vertices
    dof_block = np.concatenate([np.repeat(np.arange(nn), 3), nn + np.arange(self.n_vertices)])
    is_free = red >= 0
    # free components of each block, and each free dof's rank among them
    nfree_block = np.bincount(dof_block, weights=is_free, minlength=nb).astype(np.int64)
    rank = np.full(n, -1, dtype=np.int64)
    fb = dof_block[self.free]
    first = np.concatenate([[0], np.cumsum(nfree_block)[:-1]])
    rank[self.free] = np.arange(nf) - first[fb]
    # unique block pairs over the elements
    # int64: the pair keys A * nb + B overflow int32 beyond 46k blocks
    eblocks = np.hstack([self.element_nodes, nn + self.element_vertices]).astype(np.int64)
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
    free_by_block = self.free[np.argsort(fb, kind="stable")]  # grouped by block
    seg = np.repeat(first[bB[ok]] - cum[ok], width[ok]) + np.arange(width[ok].sum())
    colseq = red[free_by_block[seg]]  # all block rows, concatenated
    seg_start = np.zeros(nb, dtype=np.int64)
    seg_start[bA[starts]] = cum[starts] - cum[ok][0]
    src = np.repeat(seg_start[fb] - indptr[:-1], counts) + np.arange(indptr[-1])
    indices = colseq[src]
    _block_assembly(self, ukeys, binv, blk_off, indptr, red, rank)
    self._indptr_ff = indptr.astype(np.int32)
    self._indices_ff = indices.astype(np.int32)
    _build_clamp_pattern(self, red)


def _add_product(S, X, Y):
    """``Y += S @ X`` for a CSR matrix ``S`` and C-contiguous ``X``, ``Y``,
    written into ``Y`` (scipy's own kernel; ``S @ X`` would allocate a fresh
    result, whose page faults cost as much as the product at these sizes)."""
    if not (X.flags.c_contiguous and Y.flags.c_contiguous):
        raise ValueError("_add_product needs C-contiguous X and Y")
    try:
        from scipy.sparse._sparsetools import csr_matvecs
    except ImportError:  # a scipy without the private kernel: same result, one copy
        Y += S @ X
        return
    csr_matvecs(S.shape[0], S.shape[1], X.shape[1], S.indptr, S.indices, S.data,
                X.ravel(), Y.ravel())


def _block_assembly(self, ukeys, binv, blk_off, indptr, red, rank):
    """Operators of the tangent's assembly (see :meth:`SheetProblem.tangent`).

    The element blocks are summed per global block pair, node-node pairs
    (``_sum_uu``: element block (e, a, b) -> pair) and node-vertex pairs
    (``_sum_up``: element block (e, c, a) -> pair), and the free-dof CSR data
    is a gather from the summed blocks (``_gather_ff``: for every entry of the
    pattern, its index in ``[Guu.ravel(), Gup.ravel(), 0]``).  Vertex-node
    entries read their node-vertex partner (the tangent is symmetric) and the
    pressure diagonal reads the trailing zero.  Working on blocks instead of
    the 34 x 34 entries of every element makes the operators ten times
    smaller than a dof-level scatter.

    The position of the entry (row dof r, column dof c) of a pair is
    ``indptr[r] + blk_off[pair] + rank[c]`` (the row's first entry, the offset
    of the column's block in that row, the column's rank in its block).
    """
    nn, nb = self.n_nodes, self.n_nodes + self.n_vertices
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
    self._sum_uu = _scatter(uu_index[binv[:, :10, :10]].ravel(), np.arange(n_uu_el), n_uu,
                            n_uu_el)
    self._sum_up = _scatter(up_index[binv[:, :10, 10:].transpose(0, 2, 1)].ravel(),
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
    _, r0 = rows_of(self.nu_dof + bA[u] - nn)
    ck = rank[3 * bB[u, None] + comp]
    pos = r0[:, None] + blk_off[u, None] + ck
    src[pos[ck >= 0]] = (9 * n_uu + 3 * up_index[partner, None] + comp)[ck >= 0]
    # pressure diagonal: explicit zero
    u = np.flatnonzero(pp)
    _, r0 = rows_of(self.nu_dof + bA[u] - nn)
    src[r0 + blk_off[u]] = zero
    if (src < 0).any():
        raise AssertionError("block assembly does not cover the sparsity pattern")
    self._gather_ff = src  # intp: numpy's take would convert int32 at every call


def _build_clamp_pattern(self, red):
    """Free rows x clamped columns, from the elements touching the clamp."""
    nd = self.edofs.shape[1]
    nf, nx = len(self.free), len(self.clamp_dofs)
    fix = np.full(self.ndof, -1, dtype=np.int64)
    fix[self.clamp_dofs] = np.arange(nx)
    self.clamp_elements = np.flatnonzero((fix[self.edofs] >= 0).any(axis=1))
    ed = self.edofs[self.clamp_elements]
    rows = np.repeat(ed, nd, axis=1).ravel()
    cols = np.tile(ed, (1, nd)).ravel()
    fd = np.flatnonzero((red[rows] >= 0) & (fix[cols] >= 0))
    keys = red[rows[fd]] * nx + fix[cols[fd]]
    uniq, inv = np.unique(keys, return_inverse=True)
    self._scatter_fd = _scatter(inv, fd, len(uniq), len(ed) * nd * nd)
    r, c = np.divmod(uniq, nx)
    self._indptr_fd = np.concatenate([[0], np.cumsum(np.bincount(r, minlength=nf))]).astype(np.int32)
    self._indices_fd = c.astype(np.int32)
