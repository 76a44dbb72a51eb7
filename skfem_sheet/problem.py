"""The discrete Newton system of one sheet: residual, tangent, energy.

:class:`SheetProblem` joins a :class:`~skfem_sheet.params.Sheet` (the
material and the clamp), a :class:`~skfem_sheet.discretisation.TaylorHoodSpace`
(bases and dof layout) and an :class:`~skfem_sheet.assembly.Assembler`
(sparsity pattern, work buffers, threads); the material is
:mod:`skfem_sheet.kernels`.  The unknown is the dof vector ``w`` (displacements
node by node, then vertex pressures); the residual is ``dPi/dw`` at gravity
factor ``g``, the tangent its Jacobian on the free dofs, ``K_ff``.

A problem may carry a tip force (:meth:`SheetProblem.with_tip_force`): a
dead load ``F`` (total, positive upward, units of ``rho g a^3``) spread as a
uniform traction over the tip face ``x = L``.  It adds ``-F f`` to the
residual (``f``: :attr:`SheetProblem.tip_load`, the face's traction at unit
total force on the displacement basis) and ``-F w_tip`` to the energy
(``w_tip``: :meth:`SheetProblem.tip_displacement`, the face's mean vertical
displacement, the load's work-conjugate); the tangent does not change.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from skfem import BilinearForm, ElementTetP2, FacetBasis, LinearForm, asm

from .assembly import Assembler
from .discretisation import SaddlePointLayout, TaylorHoodSpace
from .kernels import (
    clamp_displacement,
    clamp_displacement_rate,
    element_residuals,
    element_tangent_blocks,
    first_invariant,
    kinematics,
    linearised_stress_defect,
    strain_energy_density,
)
from .mesh import SheetMesh
from .params import ParameterError, Sheet

__all__ = ["SheetProblem"]


@BilinearForm
def _pressure_mass(p, q, w):
    return p * q


@LinearForm
def _face_integral(v, w):
    return v


def _from_space(name):
    """A read-only attribute of the problem that is the space's ``name``."""
    return property(lambda self: getattr(self.space, name),
                    doc=f"``space.{name}`` (see :class:`TaylorHoodSpace`).")


@dataclass(frozen=True, eq=False, init=False)
class SheetProblem:
    """Taylor-Hood discretisation of one sheet on one mesh.

    Parameters
    ----------
    sheet : Sheet
    mesh : SheetMesh
    quadrature_order : int
        Order of the tetrahedral quadrature (2: 4 points, exact for the
        linearised stiffness of P2; 4: 11 points).
    space : TaylorHoodSpace, optional
        The space on ``mesh`` (default: built here,
        :meth:`~skfem_sheet.discretisation.TaylorHoodSpace.build`; a
        :class:`~skfem_sheet.build.BuildChain` gives the one it keeps); a
        stretched space for :meth:`with_length`.
    assembler : Assembler, optional
        The assembler of the space (default: built here); share one
        (pattern, work buffers and threads) between problems on one mesh:
        its lock serialises their assemblies.
    tip_force : float
        A dead vertical force on the tip face ``x = L`` (total, positive
        upward, units of ``rho g a^3``; default 0): see the module docstring
        and :meth:`with_tip_force`.

    Attributes
    ----------
    sheet : Sheet
    space : TaylorHoodSpace
    assembler : Assembler
    tip_force : float
    """

    sheet: Sheet
    space: TaylorHoodSpace
    assembler: Assembler
    tip_force: float
    _constants: dict = field(repr=False)  # constant summed blocks (tangent, mass), lazily

    def __init__(self, sheet: Sheet, mesh: SheetMesh, quadrature_order: int = 2, *,
                 space: TaylorHoodSpace | None = None, assembler: Assembler | None = None,
                 tip_force: float = 0.0):
        if space is None:
            space = TaylorHoodSpace.build(mesh, quadrature_order)
        elif space.mesh is not mesh or space.quadrature_order != quadrature_order:
            raise ValueError("space must be a space on mesh with the quadrature_order given")
        if assembler is None:
            assembler = Assembler.build(space if space.reference is None else space.reference)
        elif assembler.n_free != space.n_free or assembler.ndof != space.ndof:
            raise ValueError("assembler does not match the space's dof layout")
        object.__setattr__(self, "sheet", sheet)
        object.__setattr__(self, "space", space)
        object.__setattr__(self, "assembler", assembler)
        object.__setattr__(self, "tip_force", float(tip_force))
        object.__setattr__(self, "_constants", {})

    def with_length(self, length: float) -> SheetProblem:
        """The same problem for a sheet of another length, on the same mesh
        stretched in x (``x -> x length / mesh.length``).

        The mesh topology, dof numbering and sparsity pattern are kept, so the
        length is a continuous parameter of one discrete problem; only the
        x-derivatives, volume weights, node coordinates and loads change
        (:meth:`TaylorHoodSpace.stretched`), and the assembler is shared.
        Callers remesh beyond the remesh rule's stretch.
        """
        space = self.space.stretched(length)
        return SheetProblem(self.sheet.replace(length=space.length), self.space.mesh,
                            self.space.quadrature_order, space=space, assembler=self.assembler,
                            tip_force=self.tip_force)

    def with_tip_force(self, force: float) -> SheetProblem:
        """The same problem with the tip force ``force`` (total, positive
        upward, units of ``rho g a^3``) instead of :attr:`tip_force`.

        The copy shares the space, the assembler and the constant blocks; the
        residual gains ``-force f`` and the energy ``-force w_tip``.

        Examples
        --------
        >>> from skfem_sheet.mesh import sheet_mesh
        >>> p = SheetProblem(Sheet(length=0.5), sheet_mesh(Sheet(length=0.5), 0.25, half=True))
        >>> q = p.with_tip_force(-0.01)
        >>> w = np.zeros(p.ndof)
        >>> r0, r1 = p.residual(w, 1.0)[0], q.residual(w, 1.0)[0]
        >>> round(float(np.sum((r1 - r0)[2:p.nu_dof:3])), 12)   # the half model: F/2
        0.005
        """
        force = float(force)
        if not np.isfinite(force):
            raise ParameterError(f"tip_force must be finite, got {force!r}")
        if force != 0.0:
            _ = self.tip_load  # a sheet without a tip face is refused here
        new = SheetProblem(self.sheet, self.space.mesh, self.space.quadrature_order,
                           space=self.space, assembler=self.assembler, tip_force=force)
        object.__setattr__(new, "_constants", self._constants)  # load-independent: shared
        return new

    # -- the space's layout, by name ----------------------------------------
    sheet_mesh = _from_space("mesh")
    quadrature_order = _from_space("quadrature_order")
    length = _from_space("length")
    basis_u = _from_space("basis_u")
    basis_p = _from_space("basis_p")
    dphi = _from_space("dphi")
    phi1 = _from_space("phi1")
    phi2 = _from_space("phi2")
    dx = _from_space("dx")
    nodes = _from_space("nodes")
    n_nodes = _from_space("n_nodes")
    n_vertices = _from_space("n_vertices")
    ndof = _from_space("ndof")
    nu_dof = _from_space("nu_dof")
    n_free = _from_space("n_free")
    element_nodes = _from_space("element_nodes")
    element_vertices = _from_space("element_vertices")
    edofs = _from_space("edofs")
    clamp_nodes = _from_space("clamp_nodes")
    clamp_dofs = _from_space("clamp_dofs")
    fixed = _from_space("fixed")
    free = _from_space("free")
    gravity_load = _from_space("load_z")
    gravity_load.__doc__ = "d/dg of the residual: the weight vector (``space.load_z``)."
    volume0 = _from_space("volume")

    @property
    def tip_load(self) -> np.ndarray:
        """The tip face's traction at unit total force on the displacement
        dofs, ``f_(a,z) = int_face phi_a dA / A`` (``A`` the whole sheet's
        face area; a half model holds half of it): ``-d residual / d F``.
        Computed on first use on the mesh as built, where the face is the
        boundary facets at the largest x; a stretch in x or the map of the
        tip width scales the face uniformly, so ``f`` is theirs too.

        Raises
        ------
        ParameterError
            If the sheet has no tip face (a pointed tip, ``tip_width = 0``,
            or a planform whose bites take the whole cut ``x = L``).
        """
        if "tip_load" not in self._constants:
            mesh = self.basis_u.mesh
            x = mesh.p[0]
            tip = float(x.max())
            tol = 1e-9 * max(1.0, tip)
            on = np.all(np.abs(x[mesh.facets] - tip) <= tol, axis=0)
            facets = np.intersect1d(np.flatnonzero(on), mesh.boundary_facets())
            area = 0.0
            if len(facets):
                fb = FacetBasis(mesh, ElementTetP2(), facets=facets, intorder=4)
                phi = asm(_face_integral, fb)
                # the basis functions of nodes off the face vanish on it: their
                # round-off (1e-17) left out
                phi[np.abs(self.basis_u.doflocs[0] - tip) > tol] = 0.0
                area = float(phi.sum())
            if not area > 1e-12 * self.sheet.thickness:
                raise ParameterError(
                    "tip_force needs a tip face x = L to act on: this sheet has none (tip_width "
                    f"{self.sheet.tip_width:g}; a pointed tip or bites that take the whole cut)")
            full = 2.0 * area if self.sheet_mesh.half else area
            f = np.zeros(self.ndof)
            f[2:self.nu_dof:3] = phi / full
            f.setflags(write=False)
            self._constants["tip_load"] = f
        return self._constants["tip_load"]

    def tip_displacement(self, w) -> float:
        """``w_tip``: the mean vertical displacement of the tip face (units of
        a, upward), the tip force's work-conjugate (the energy holds ``-F
        w_tip``); a half model's face has the mean of the whole one."""
        f = self.tip_load
        scale = 2.0 if self.sheet_mesh.half else 1.0
        return float(scale * (f[:self.nu_dof] @ np.asarray(w)[:self.nu_dof]))

    @property
    def mu(self) -> float:
        """Shear modulus (the sheet's, dimensionless)."""
        return self.sheet.mu

    @property
    def clamp_elements(self):
        """Elements touching the clamp (``assembler.clamp_elements``)."""
        return self.assembler.clamp_elements

    # -- state helpers -------------------------------------------------------
    def split(self, w):
        """Nodal displacements (n_nodes, 3) and vertex pressures of ``w``."""
        return self.space.split(w)

    def displacements(self, w):
        """Nodal displacements (n_nodes, 3) of ``w``."""
        return self.space.split(w)[0]

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
        """``F`` and the pressure at the quadrature points of ``elements``."""
        sp_ = self.space
        U, pv = sp_.split(w)
        sel = slice(None) if elements is None else elements
        F = kinematics(U[sp_.element_nodes[sel]], sp_.dphi[sel])
        p = np.einsum("ec,eqc->eq", pv[sp_.element_vertices[sel]], sp_.phi1[sel])
        return F, p

    # -- residual, tangent, energy ------------------------------------------
    def _element_residuals(self, w, sel, R):
        """:func:`~skfem_sheet.kernels.element_residuals` of the elements ``sel``."""
        F, p = self._fields(w, sel)
        s = self.space
        return element_residuals(F, p, self.mu, s.dphi[sel], s.phi1[sel], s.dx[sel], R)

    def residual(self, w, g):
        """Full residual vector ``dPi/dw`` at gravity factor ``g`` (and the
        tip force :attr:`tip_force`, if any).

        Returns ``(r, Jmin)`` where ``Jmin`` is the smallest ``det F`` over
        quadrature points (``<= 0`` means an inverted element; then ``r`` is
        meaningless and filled with NaN).  The element residuals are computed
        on chunks of elements in threads, like the tangent.
        """
        asm_ = self.assembler
        with asm_.workspace.lock:
            R = asm_.residual_buffer()
            Jmin = float(np.min(asm_.on_element_chunks(self._element_residuals, w, R)))  # NaN propagates
            if not Jmin > 0:
                return np.full(self.ndof, np.nan), Jmin
            r = asm_.vector(R)
        r += g * self.gravity_load
        if self.tip_force:
            r -= self.tip_force * self.tip_load
        return r, Jmin

    def _element_blocks(self, w, sel, Kb, Kpu, w_ref=None):
        """:func:`~skfem_sheet.kernels.element_tangent_blocks` of the elements
        ``sel`` (a slice or an index array) into ``Kb``, ``Kpu``; with the
        stress defect of the step from ``w_ref`` to ``w`` if given."""
        F, p = self._fields(w, sel)
        dS = None
        if w_ref is not None:
            F0, p0 = self._fields(w_ref, sel)
            dS = linearised_stress_defect(F0, p0, F, p, self.mu)
        s = self.space
        element_tangent_blocks(F, p, self.mu, s.dphi[sel], s.phi1[sel], s.dx[sel], Kb, Kpu,
                               dS=dS)

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
        lap = self.mu * self.space.laplacian[sel]
        for i in range(3):
            Kb[:, :, :, i, i] += lap
        K = np.zeros((nel, 34, 34))
        K[:, :30, :30] = Kb.transpose(0, 1, 3, 2, 4).reshape(nel, 30, 30)
        K[:, 30:, :30] = Kpu.reshape(nel, 4, 30)
        K[:, :30, 30:] = K[:, 30:, :30].transpose(0, 2, 1)
        return K

    def _tangent_constant(self):
        """Summed blocks of the constant part ``mu d_ik int grad phi_a .
        grad phi_b`` of the tangent (computed once per problem)."""
        if "tangent" not in self._constants:
            self._constants["tangent"] = self.assembler.constant_blocks(
                self.mu * self.space.laplacian)
        return self._constants["tangent"]

    @property
    def mass_data(self):
        """Displacement mass matrix ``d_ik int phi_a phi_b`` as data on the
        tangent's pattern (the pseudo-transient shift; computed on first use)."""
        if "mass" not in self._constants:
            mass = np.einsum("eq,eqa,eqb->eab", self.dx, self.phi2, self.phi2)
            asm_ = self.assembler
            with asm_.workspace.lock:
                asm_.sum_blocks(asm_.constant_blocks(mass), None, None)
                self._constants["mass"] = asm_.gather()
        return self._constants["mass"]

    def tangent(self, w, w_ref=None):
        """Reduced tangent ``K_ff`` (free dofs) as a CSR matrix.

        With ``w_ref`` (the previous Newton iterate), the mixed-integration-point
        linearisation instead of the Hessian: the geometric stiffness carries
        the stress linearised from ``w_ref``, not the stress at ``w``
        (:func:`~skfem_sheet.kernels.linearised_stress_defect`).  Only for
        Newton corrections of a load path; inertia, folds and continuation
        need the Hessian (``w_ref=None``, the default).

        Its sparsity pattern is fixed for the problem's lifetime (the zero
        diagonal of the pressure block stored); see :mod:`skfem_sheet.assembly`.
        """
        asm_ = self.assembler
        constant = self._tangent_constant()
        with asm_.workspace.lock:
            Kb, Kpu = asm_.tangent_buffers()
            if w_ref is None:
                asm_.on_element_chunks(self._element_blocks, w, Kb, Kpu)
            else:
                asm_.on_element_chunks(
                    lambda ww, sel, kb, kpu: self._element_blocks(ww, sel, kb, kpu, w_ref),
                    w, Kb, Kpu)
            asm_.sum_blocks(constant, Kb, Kpu)
            data = asm_.gather()
        return asm_.matrix(data)

    def clamp_coupling(self, w):
        """``K_fc``: free rows, clamped columns (``clamp_dofs``; only the
        elements touching the clamp are computed)."""
        return self.assembler.clamp_matrix(self.element_matrices(w, self.clamp_elements))

    def energy(self, w, g):
        """Total potential energy Pi of the whole sheet (the constraint term
        vanishes at equilibrium; a half model counts twice), with the tip
        force's potential ``-F w_tip`` if it has one."""
        F, p = self._fields(w)
        dens = strain_energy_density(F, p, self.mu)
        U, _ = self.split(w)
        e = float(np.sum(self.dx * dens) + g * U[:, 2] @ (self.gravity_load[2:self.nu_dof:3]))
        e = 2.0 * e if self.sheet_mesh.half else e
        if self.tip_force:
            e -= self.tip_force * self.tip_displacement(w)
        return e

    def energy_density(self, w):
        """psi/mu = (I_C - 3)/2, averaged over each element (paper Fig. 3)."""
        F, _ = self._fields(w)
        IC = first_invariant(F)
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

    # -- for the linear solvers ---------------------------------------------
    def nodal_rotations(self, w):
        """Polar rotation factor of ``F`` at each node for state ``w``.

        ``F`` is averaged over each element's quadrature points, then over the
        elements around each node; ``R = U V^T`` from its SVD.  Returns
        ``(n_nodes, 3, 3)``.

        Examples
        --------
        >>> from skfem_sheet import Sheet
        >>> from skfem_sheet.mesh import sheet_mesh
        >>> p = SheetProblem(Sheet(length=0.5), sheet_mesh(Sheet(length=0.5), 0.15))
        >>> w = np.zeros(p.ndof)
        >>> w[: p.nu_dof] = (p.nodes @ (np.diag([-1.0, -1.0, 1.0]) - np.eye(3)).T).ravel()
        >>> R = p.nodal_rotations(w)      # the sheet turned by 180 degrees about z
        >>> np.allclose(R, np.diag([-1.0, -1.0, 1.0]))
        True
        """
        U, _ = self.split(np.asarray(w, dtype=float))
        en = self.element_nodes
        F = kinematics(U[en], self.dphi)
        dx = self.dx
        Fe = np.einsum("eq,eqij->eij", dx, F) / dx.sum(axis=1)[:, None, None]
        nodes = en.ravel()
        count = np.bincount(nodes, minlength=self.n_nodes)
        Fn = np.stack([np.bincount(nodes, np.repeat(Fe[:, i, j], en.shape[1]), self.n_nodes)
                       for i in range(3) for j in range(3)], axis=-1)
        Fn = Fn.reshape(-1, 3, 3) / np.maximum(count, 1)[:, None, None]
        u, _, vt = np.linalg.svd(Fn)
        R = u @ vt
        flip = np.linalg.det(R) < 0  # never for a valid state; keep R a rotation anyway
        if np.any(flip):
            u[flip, :, 2] *= -1
            R[flip] = u[flip] @ vt[flip]
        return R

    def saddle_point_layout(self) -> SaddlePointLayout:
        """The structure of the reduced tangent for the linear solvers.

        ``free`` is sorted, so the free displacement dofs (``3 node +
        component``) come first, then the free pressures.  The Schur
        complement stands in as ``M_p / mu``, the P1 pressure mass matrix of
        the free vertices over the shear modulus; the near-null space of the
        displacement block is built from the node coordinates, the nodal
        displacements and rotations of a state.
        """
        free = np.asarray(self.free)
        nu = int(np.count_nonzero(free < self.nu_dof))
        if not np.all(free[:nu] < self.nu_dof):
            raise ValueError("free dofs must be sorted: displacements first")
        node, comp = np.divmod(free[:nu], 3)
        vert = free[nu:] - self.nu_dof
        Mp = asm(_pressure_mass, self.basis_p).tocsr()[vert][:, vert] / self.mu
        return SaddlePointLayout(n_displacement=nu, n_pressure=len(free) - nu,
                                 displacement_nodes=node, displacement_components=comp,
                                 coordinates=self.nodes, pressure_schur=Mp,
                                 displacements=self.displacements,
                                 rotations=self.nodal_rotations)
