"""The Taylor-Hood space of one sheet mesh: bases, dof layout, dof sets.

P2 displacement, P1 pressure on tetrahedra.  Displacement dofs are numbered
node by node, ``3 * node + component``, then the pressure dofs
``nu_dof + vertex`` (``nu_dof = 3 * n_nodes``).  The clamp ``x = 0`` fixes all
displacement components of its nodes; a half model (``mesh.half``) also fixes
``U_y = 0`` on the symmetry plane ``y = 0``.  ``free`` is sorted, so in every
reduced (free-dof) vector or matrix the free displacement dofs come first.

:meth:`TaylorHoodSpace.build` builds the space of a mesh (a solve or a
study keeps it in its :class:`~skfem_sheet.build.BuildChain`);
:meth:`TaylorHoodSpace.stretched` gives the same space on the mesh stretched
in x, which is how a sheet's length becomes a continuous parameter, and
:meth:`TaylorHoodSpace.mapped` the same space on the mesh with its vertices
moved (the map of one trapezoid onto another, for the tip width).
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np
from skfem import Basis, ElementTetP1, ElementTetP2

from .mesh import SheetMesh
from .params import check_range

__all__ = ["TaylorHoodSpace", "SaddlePointLayout", "det_inv", "element_laplacian"]


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


def element_laplacian(dx, dphi):
    """``int grad phi_a . grad phi_b`` per element, shape (nel, 10, 10).

    One batched product over the quadrature points and components together
    (a tenth of the time of the equivalent ``einsum``, which loops in C
    without BLAS: 0.006 s against 0.063 s on 11k elements)."""
    nel, nq, na, nd = dphi.shape
    W = (dphi * dx[:, :, None, None]).transpose(0, 2, 1, 3).reshape(nel, na, nq * nd)
    return np.matmul(W, dphi.transpose(0, 1, 3, 2).reshape(nel, nq * nd, na))


@dataclass(frozen=True, eq=False)
class TaylorHoodSpace:
    """P2/P1 Taylor-Hood discretisation of one sheet mesh (possibly stretched).

    Attributes
    ----------
    mesh : SheetMesh
        The mesh, as built (at length ``mesh.length``).
    quadrature_order : int
        Order of the tetrahedral quadrature (2: 4 points, exact for the
        linearised stiffness of P2; 4: 11 points).
    length : float
        Length of the sheet this space describes: ``mesh.length``, or the
        length it was stretched to (:meth:`stretched`).
    basis_u, basis_p : skfem.Basis
        P2 and P1 bases on the mesh *as built* (not stretched): for
        evaluation at points in the mesh's own coordinates.
    dphi : ndarray (nel, nq, 10, 3)
        Gradients of the P2 basis at the quadrature points (stretched).
    phi2 : ndarray (nel, nq, 10)
        P2 basis values.
    phi1 : ndarray (nel, nq, 4)
        P1 basis values.
    dx : ndarray (nel, nq)
        Quadrature weights times the volume element (stretched).
    nodes : ndarray (n_nodes, 3)
        Coordinates of the P2 nodes (stretched); the P1 vertices are the
        first ``n_vertices`` of them (scikit-fem's numbering).
    n_nodes, n_vertices, ndof, nu_dof : int
        P2 nodes, P1 vertices, all dofs, displacement dofs (``3 n_nodes``).
    element_nodes : ndarray (nel, 10)
        P2 nodes of each element.
    element_vertices : ndarray (nel, 4)
        P1 vertices of each element.
    edofs : ndarray (nel, 34)
        Dofs of each element: the 30 displacement dofs node-major, then the
        4 pressure dofs.
    clamp_nodes : ndarray
        Nodes on the clamp ``x = 0``.
    clamp_dofs : ndarray
        Their displacement dofs (``3 node + component``), all fixed.
    symmetry_nodes : ndarray
        Nodes on the symmetry plane ``y = 0`` of a half model (``U_y`` fixed
        there); empty for a whole sheet.
    fixed, free : ndarray
        Sorted fixed and free dofs (``fixed``: the clamp dofs and, for a half
        model, ``U_y`` on the symmetry plane).
    load_z : ndarray (ndof,)
        ``int phi_a`` on the z-displacement dofs, 0 elsewhere: the derivative
        of ``int U_z dV`` (the weight vector at unit weight density).
    volume : float
        Reference volume ``int dV`` (stretched).
    reference : TaylorHoodSpace or None
        The unstretched space this one was stretched from (None: this is it).
    """

    mesh: SheetMesh
    quadrature_order: int
    length: float
    basis_u: Basis
    basis_p: Basis
    dphi: np.ndarray
    phi2: np.ndarray
    phi1: np.ndarray
    dx: np.ndarray
    nodes: np.ndarray
    n_nodes: int
    n_vertices: int
    ndof: int
    nu_dof: int
    element_nodes: np.ndarray
    element_vertices: np.ndarray
    edofs: np.ndarray
    clamp_nodes: np.ndarray
    clamp_dofs: np.ndarray
    symmetry_nodes: np.ndarray
    fixed: np.ndarray
    free: np.ndarray
    load_z: np.ndarray
    volume: float
    reference: TaylorHoodSpace | None = None

    @classmethod
    def build(cls, mesh: SheetMesh, quadrature_order: int = 2) -> TaylorHoodSpace:
        """The space of ``mesh`` (built afresh; a :class:`~skfem_sheet.build.BuildChain`
        keeps the spaces it builds)."""
        m = mesh.mesh
        b2 = Basis(m, ElementTetP2(), intorder=quadrature_order)
        b1 = Basis(m, ElementTetP1(), intorder=quadrature_order)
        nel = m.t.shape[1]
        dphi = np.ascontiguousarray(
            np.stack([b2.basis[a][0].grad for a in range(10)], axis=0).transpose(2, 3, 0, 1))
        phi2 = np.stack([np.asarray(b2.basis[a][0]) for a in range(10)], axis=-1)
        phi1 = np.stack([np.asarray(b1.basis[c][0]) for c in range(4)], axis=-1)
        dx = np.asarray(b2.dx)
        n_nodes, n_vertices = b2.N, b1.N
        nodes = b2.doflocs.T
        ndof = 3 * n_nodes + n_vertices
        nu_dof = 3 * n_nodes
        en = b2.element_dofs.T
        ev = b1.element_dofs.T
        edofs_u = (3 * en[:, :, None] + np.arange(3)).reshape(nel, 30)
        edofs = np.hstack([edofs_u, nu_dof + ev])

        # clamp x = 0: all displacement dofs of those nodes
        tol = 1e-9 * max(1.0, mesh.length)
        clamp_nodes = np.flatnonzero(np.abs(nodes[:, 0]) < tol)
        clamp_dofs = (3 * clamp_nodes[:, None] + np.arange(3)).ravel()
        is_fixed = np.zeros(ndof, bool)
        is_fixed[clamp_dofs] = True
        symmetry_nodes = np.zeros(0, dtype=clamp_nodes.dtype)
        if mesh.half:  # symmetry plane y = 0: U_y = 0
            symmetry_nodes = np.flatnonzero(np.abs(nodes[:, 1]) < tol)
            is_fixed[3 * symmetry_nodes + 1] = True

        load_z = np.zeros(ndof)
        np.add.at(load_z, 3 * en + 2, np.einsum("eq,eqa->ea", dx, phi2))
        return cls(mesh=mesh, quadrature_order=quadrature_order, length=mesh.length,
                   basis_u=b2, basis_p=b1, dphi=dphi, phi2=phi2, phi1=phi1, dx=dx,
                   nodes=nodes, n_nodes=n_nodes, n_vertices=n_vertices, ndof=ndof,
                   nu_dof=nu_dof, element_nodes=en, element_vertices=ev, edofs=edofs,
                   clamp_nodes=clamp_nodes, clamp_dofs=clamp_dofs,
                   symmetry_nodes=symmetry_nodes, fixed=np.flatnonzero(is_fixed),
                   free=np.flatnonzero(~is_fixed), load_z=load_z, volume=float(dx.sum()))

    def __repr__(self):
        m = self.mesh
        return (f"TaylorHoodSpace(hmax={m.hmax:g}, layers={m.layers}, half={m.half}, "
                f"refine={m.refine}, length={self.length:g}, "
                f"quadrature_order={self.quadrature_order}, n_elements={self.n_elements}, "
                f"ndof={self.ndof}, n_free={self.n_free})")

    @cached_property
    def _edge_inverse(self) -> np.ndarray:
        """The inverses of the elements' edge matrices (nel, 3, 3), the
        columns of each the edges from its first vertex (of the mesh as
        built; :meth:`mapped` maps from them)."""
        X0 = self.mesh.mesh.p[:, self.mesh.mesh.t]  # (3, 4, nel)
        return det_inv(np.transpose(X0[:, 1:] - X0[:, :1], (2, 0, 1)))[1]

    @cached_property
    def laplacian(self) -> np.ndarray:
        """``int grad phi_a . grad phi_b`` per element (stretched or mapped),
        shape (nel, 10, 10): the constant part of the tangent, computed on
        first use (a space made for residuals alone, e.g. at a difference
        step in a parameter, never needs it)."""
        return element_laplacian(self.dx, self.dphi)

    # -- sizes ---------------------------------------------------------------
    @property
    def n_elements(self) -> int:
        return len(self.dx)

    @property
    def n_free(self) -> int:
        return len(self.free)

    # -- dof vectors ---------------------------------------------------------
    def split(self, w):
        """Nodal displacements (n_nodes, 3) and vertex pressures of ``w`` (views)."""
        return w[: self.nu_dof].reshape(-1, 3), w[self.nu_dof:]

    def join(self, U, p):
        """The dof vector of nodal displacements ``U`` (n_nodes, 3) and vertex
        pressures ``p`` (n_vertices,): the inverse of :meth:`split`."""
        U = np.asarray(U, dtype=float)
        p = np.asarray(p, dtype=float)
        if U.shape != (self.n_nodes, 3) or p.shape != (self.n_vertices,):
            raise ValueError(f"join needs U of shape ({self.n_nodes}, 3) and p of shape "
                             f"({self.n_vertices},), got {U.shape} and {p.shape}")
        return np.concatenate([U.ravel(), p])

    # -- another length ------------------------------------------------------
    def stretched(self, length: float) -> TaylorHoodSpace:
        """The same space on the mesh stretched in x to ``length``
        (``x -> x length / mesh.length``).

        Topology, dof numbering and dof sets are those of this space; the
        stretch is affine, so only the x-derivatives of the basis, the volume
        weights, the node coordinates and the integrals change.  Always
        computed from the unstretched space (stretching twice is exactly one
        stretch).
        """
        length = check_range("length", length, 0, None, lo_open=True)
        ref = self if self.reference is None else self.reference
        s = length / ref.mesh.length
        dphi = ref.dphi.copy()
        dphi[..., 0] /= s
        dx = ref.dx * s
        return replace(ref, length=length, dphi=dphi, dx=dx,
                       nodes=ref.nodes * np.array([s, 1.0, 1.0]), load_z=ref.load_z * s,
                       volume=ref.volume * s, reference=ref)

    def mapped(self, mesh: SheetMesh) -> TaylorHoodSpace:
        """This space carried onto ``mesh``: the same tetrahedra with moved
        vertices (the map of a trapezoid onto another, :mod:`skfem_sheet.sheet_shape`).

        Each tetrahedron of ``mesh`` is the image of the one of ``self.mesh``
        under an affine map ``x -> A_e x + c_e``, so the P2 gradients are
        ``grad phi A_e^{-1}`` (as rows), the volume weights ``dx |det A_e|``,
        the P2 nodes the images of the old ones (straight edges), and the values
        of the basis at the quadrature points the same: what :meth:`build`
        computes on ``mesh``, without building scikit-fem bases (the
        topology, dof numbering and dof sets are kept).  ``basis_u`` and
        ``basis_p`` stay those of ``self.mesh``: do not interpolate with the
        result (build a space for that).

        Examples
        --------
        >>> from dataclasses import replace
        >>> from skfem import MeshTet
        >>> from skfem_sheet.mesh import sheet_mesh
        >>> from skfem_sheet.params import Sheet
        >>> m = sheet_mesh(Sheet(length=1.0, tip_width=1.0, curvature=1.0), 0.3, half=True)
        >>> s = TaylorHoodSpace.build(m)
        >>> P = m.mesh.p * np.array([[1.2], [0.9], [1.0]])
        >>> m2 = replace(m, mesh=MeshTet(P, m.mesh.t), length=1.2)
        >>> a, b = s.mapped(m2), TaylorHoodSpace.build(m2)
        >>> bool(np.allclose(a.dphi, b.dphi) and np.allclose(a.dx, b.dx)
        ...      and np.allclose(a.nodes, b.nodes) and np.allclose(a.load_z, b.load_z))
        True
        """
        t = self.mesh.mesh.t
        X1 = mesh.mesh.p[:, t]
        E1 = np.transpose(X1[:, 1:] - X1[:, :1], (2, 0, 1))  # (nel, 3, 3): columns are edges
        A = E1 @ self._edge_inverse  # x1 - x1_0 = A (x0 - x0_0)
        det, Ainv = det_inv(A)
        dphi = np.matmul(self.dphi, Ainv[:, None])  # (batched products, not einsum)
        dx = self.dx * np.abs(det)[:, None]
        # the P2 nodes: the vertices, then the midpoints of the (straight) edges
        # in the order of the mesh's edges (scikit-fem's numbering, see build)
        V, edges = mesh.mesh.p.T, self.mesh.mesh.edges
        nodes = np.concatenate([V, 0.5 * (V[edges[0]] + V[edges[1]])])
        en = self.element_nodes
        load_z = np.zeros(self.ndof)
        load_z[:self.nu_dof] = np.bincount(
            (3 * en + 2).ravel(), np.matmul(dx[:, None, :], self.phi2).ravel(),
            minlength=self.nu_dof)
        return replace(self, mesh=mesh, length=mesh.length, dphi=dphi, dx=dx, nodes=nodes,
                       load_z=load_z,
                       volume=float(dx.sum()), reference=None)


@dataclass(frozen=True, eq=False)
class SaddlePointLayout:
    """The structure of a reduced saddle-point matrix ``[[A, B^T], [B, 0]]``,
    for linear solvers that need more than the matrix (the pyamg back-end).

    Unknowns ``0 .. n_displacement - 1`` are displacement components of
    nodes, the ``n_pressure`` after them pressures (Lagrange multipliers).

    Attributes
    ----------
    n_displacement, n_pressure : int
    displacement_nodes, displacement_components : ndarray (n_displacement,)
        Node and component (0, 1, 2) of every displacement unknown.
    coordinates : ndarray (n_nodes, 3)
        Reference node coordinates (for the near-null space of ``A``).
    pressure_schur : scipy.sparse matrix (n_pressure, n_pressure)
        Symmetric positive definite stand-in for the Schur complement
        ``B A^-1 B^T`` (the pressure mass matrix over the shear modulus).
    displacements : callable or None
        ``displacements(w) -> (n_nodes, 3)``: nodal displacements of a full
        state vector ``w`` (the deformed near-null space).
    rotations : callable or None
        ``rotations(w) -> (n_nodes, 3, 3)``: the local rotation of the
        material at each node.
    """

    n_displacement: int
    n_pressure: int
    displacement_nodes: np.ndarray
    displacement_components: np.ndarray
    coordinates: np.ndarray
    pressure_schur: object
    displacements: object = None
    rotations: object = None

    def __post_init__(self):
        nu = self.n_displacement
        if len(self.displacement_nodes) != nu or len(self.displacement_components) != nu:
            raise ValueError("displacement_nodes and displacement_components need "
                             f"n_displacement = {nu} entries")
        if self.pressure_schur.shape != (self.n_pressure, self.n_pressure):
            raise ValueError(f"pressure_schur must be {self.n_pressure} x {self.n_pressure}, "
                             f"got {self.pressure_schur.shape}")

    @property
    def n_unknowns(self) -> int:
        return self.n_displacement + self.n_pressure
