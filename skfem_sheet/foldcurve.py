"""Fold curves of the 3D sheet in (L, b) at a fixed clamp curvature, and the cusp.

The pop-up and standout lengths ``L0*(b)`` and ``L1*(b)`` (paper, Figs. 6
and 7) are the two halves of one *fold curve* in the plane of the length
``L`` and the tip width ``b``: from ``L1*`` at ``b = 1`` it runs down in
``b`` to the *cusp*, where the two folds meet and the bistable range closes,
and back up as ``L0*(b)``.  :func:`trace_fold_curve` traces it directly with
the continuation engine (:mod:`skfem_sheet.engine`): the fold is located once
at ``b = 1`` by natural continuation in L, then continued in ``(L, b)`` with
the minimally augmented system, each point a few factorisations of the
tangent; the cusp is located where the quadratic fold coefficient changes
sign, and every point is classified from the side on which the branch
exists: ``"standout"`` (the curvature-dominated branch exists below the
fold's length) or ``"popup"`` (the gravity-dominated one exists above).

Both parameters are continuous on one mesh (built at ``(L_m, b_m)``): the
length by stretching in x, ``x' = x L / L_m`` (as
:meth:`~skfem_sheet.problem.SheetProblem.with_length`), the tip width by
mapping in y, ``y' = y p_new(xi) / p_old(xi)`` with ``xi = x / L`` and the
width profile ``p(xi) = 1 + (b - 1) xi``; that map takes the trapezoid onto
the trapezoid exactly (``b > 0``), keeps the clamp (``xi = 0``) and the
symmetry plane (``y = 0``), and keeps the mesh topology and dof numbering,
so that a nodal state at one ``(L, b)`` is a valid state at the next.
``dR/dL`` and ``dR/db`` are central differences of residuals.

The map distorts the mesh: beyond a stretch of :data:`REMESH_STRETCH` in x
or a squeeze of :data:`REMESH_SQUEEZE` in y at the tip, the trace remeshes:
the sheet is meshed afresh at the current ``(L, b)``, the state (and the
null vector) are interpolated onto the new mesh
(:func:`skfem_sheet.analyses.transfer.transfer`, memory linear in the mesh),
the fold is located again there and the curve continues from it.  The
standout fold at ``b = 1`` is found the same way, by natural continuation in
L remeshed every :data:`REMESH_STRETCH`; a clamp curvature whose
curvature-dominated branch reaches the end of the length range without a
fold is *not bistable* there, and :attr:`FoldCurve.bistable` says so.

Coarse to fine (``coarse_hmax``, what the fold map does below hmax 0.1): the
curve is traced as above on a coarse mesh, and a few of its points (both
ends, points spaced evenly in the parameter plane, the neighbours of the
cusp) are carried onto the fine mesh (state and null vector) and corrected
there with the minimally augmented system -- the ends as folds in L at the
start value, the others on the hyperplane through the coarse point normal to
the coarse curve (transversal to the curve also at the cusp) -- level by
level (hmax 0.1, 0.06, then the fine mesh: a single jump from 0.1 to 0.03
leaves points outside Newton's basin).  A fine point costs a few
factorisations at the fine mesh; no load path or continuation runs there.
The cusp is then located on the fine mesh where the refined points' fold
coefficient changes sign: a few more fold points there, on sections of
fixed tip deflection, by the secant on the coefficient
(:func:`_cusp_by_coefficient`; ``cusp_located`` "fold coefficient on the
fine mesh", its cost in :attr:`FoldCurve.cusp_factorizations`); without a
sign change, the vertex of the parabola through the three refined points of
smallest ``b`` ("refined points").  An end that does not converge on the
finer mesh (at a/R = 1 the two folds at b = 1 lie 0.0013 apart in L/a and
0.01 below the coarse ones from hmax 0.1 to 0.06) is traced there instead:
the fold curve is continued on that mesh from the refined point next to it
to the start value (:func:`_continue_to_end`; used only where the
refinement of an end fails).

Everything this module needs from the rest of the package goes through the
adapter class :class:`_Sheet` at the top (the one place to change when those
interfaces move).
"""
from __future__ import annotations

import dataclasses
import sys
import time
from collections import OrderedDict
from dataclasses import dataclass, field

import numpy as np
from skfem import MeshTet
from tqdm.auto import tqdm

from .analyses.stability import stability
from .analyses.transfer import transfer
from .assembly import Assembler
from .continuation import follow_path
from .discretisation import TaylorHoodSpace, element_laplacian
from .engine import (
    EngineFailure,
    Problem,
    Tolerances,
    fold_curve,
    fold_on_section,
    locate_fold,
    natural,
)
from .engine import FoldCurve as EngineFoldCurve
from .engine.fold import FoldPoint, equilibrium_on_section, inertia_crossing
from .linalg import make_linear_solver
from .mesh import SheetMesh, sheet_mesh
from .newton import Stats
from .params import ParameterError, Sheet, check_range
from .problem import SheetProblem

__all__ = ["FINE_TOLERANCES", "MIN_SQUEEZE", "REMESH_SQUEEZE", "REMESH_STRETCH", "TOLERANCES", "FoldCurve",
           "SheetFoldProblem", "default_start_length", "trace_curvature_fold_curve",
           "trace_fold_curve"]

#: Smallest ratio of the tip width to the mesh's tip width (y squeeze at the tip).
MIN_SQUEEZE = 0.15

#: The trace remeshes where the mapped mesh is stretched in x by more than
#: this factor (or compressed by its inverse) ...
REMESH_STRETCH = 1.35
#: ... or its tip width is below this fraction of the mesh's (or above its inverse).
REMESH_SQUEEZE = 0.5
#: Predictor of the fold-curve continuation (see :func:`skfem_sheet.engine.fold_curve`).
#: Measured at hmax 0.1 (a/R 2.5): the quadratic predictor with step control
#: by the first correction halves the points (30 instead of 57) but not the
#: factorisations (335 instead of 362): Newton's basin for the thin sheet is
#: small (a first correction above about 0.005 a diverges, the membrane
#: stiffness turning small predictor errors into residuals of the order of
#: the weight), so longer steps fail and are halved.  Hence the tangent
#: predictor with the iteration-count rule.
PREDICTOR = "tangent"
#: Step control by the first correction (None: by the iteration count).
TARGET_CORRECTION = None
#: Largest number of remeshes of one trace.
MAX_REMESHES = 40

#: The corrector's stopping rule for the sheet.  The sharp test is on the
#: correction (displacements to 1e-6 of a; L and b to 1e-6): the residual of
#: a thin sheet is dominated by its membrane stiffness, so that a correction
#: of 1e-6 can still leave a residual of 1e-3 of the weight, which the next
#: (quadratic) step removes; the residual bound only guards against a small
#: correction far from equilibrium.
TOLERANCES = Tolerances(rtol=5e-3, utol=1e-6, max_iterations=10, max_correction=0.3)
#: The corrector's stopping rule for the points refined on a finer mesh (coarse
#: to fine): the returned point is the iterate plus a correction below
#: ``utol`` computed there, so that with Newton's quadratic convergence its
#: error is of the order of ``utol^2`` (L/a to about 1e-9); the residual at
#: that iterate may be larger than :data:`TOLERANCES` allows (a correction of
#: 1e-5 a leaves residuals of 1e-2 of the weight), which saves the last
#: linearisation of most points.
FINE_TOLERANCES = Tolerances(rtol=3e-2, utol=1e-5, max_iterations=10, max_correction=0.3)


def mapped_space(space, mesh):
    """``space`` (a Taylor-Hood space) carried onto ``mesh``: the same
    tetrahedra with moved vertices.

    Each tetrahedron of ``mesh`` is the image of the one of ``space.mesh``
    under an affine map ``x -> A_e x + c_e``, so the P2 gradients are
    ``grad phi A_e^{-1}`` (as rows), the volume weights ``dx |det A_e|``,
    the P2 nodes the images of the old ones (straight edges), and the values
    of the basis at the quadrature points the same: what
    :meth:`TaylorHoodSpace.build` computes on ``mesh``, without building
    scikit-fem bases (the topology, dof numbering and dof sets are kept).
    ``basis_u`` and ``basis_p`` stay those of ``space.mesh``: do not
    interpolate with the result (build a space for that).

    Examples
    --------
    >>> from skfem_sheet.mesh import sheet_mesh
    >>> m = sheet_mesh(Sheet(length=1.0, tip_width=1.0, curvature=1.0), 0.3, half=True)
    >>> s = TaylorHoodSpace.build(m)
    >>> P = m.mesh.p * np.array([[1.2], [0.9], [1.0]])
    >>> m2 = dataclasses.replace(m, mesh=MeshTet(P, m.mesh.t), length=1.2)
    >>> a, b = mapped_space(s, m2), TaylorHoodSpace.build(m2)
    >>> bool(np.allclose(a.dphi, b.dphi) and np.allclose(a.dx, b.dx)
    ...      and np.allclose(a.nodes, b.nodes) and np.allclose(a.load_z, b.load_z))
    True
    """
    t = space.mesh.mesh.t
    X0 = space.mesh.mesh.p[:, t]  # (3, 4, nel)
    X1 = mesh.mesh.p[:, t]
    E0 = np.transpose(X0[:, 1:] - X0[:, :1], (2, 0, 1))  # (nel, 3, 3): columns are edges
    E1 = np.transpose(X1[:, 1:] - X1[:, :1], (2, 0, 1))
    A = E1 @ np.linalg.inv(E0)  # x1 - x1_0 = A (x0 - x0_0)
    Ainv = np.linalg.inv(A)
    dphi = np.einsum("eqaj,ejk->eqak", space.dphi, Ainv)
    dx = space.dx * np.abs(np.linalg.det(A))[:, None]
    en = space.element_nodes
    rel = space.nodes[en] - X0[:, 0].T[:, None, :]  # (nel, 10, 3)
    nodes = np.empty_like(space.nodes)
    nodes[en] = np.einsum("eij,eaj->eai", A, rel) + X1[:, 0].T[:, None, :]
    load_z = np.zeros(space.ndof)
    load_z[:space.nu_dof] = np.bincount(
        (3 * en + 2).ravel(), np.einsum("eq,eqa->ea", dx, space.phi2).ravel(),
        minlength=space.nu_dof)
    return dataclasses.replace(space, mesh=mesh, length=mesh.length, dphi=dphi, dx=dx,
                               nodes=nodes, laplacian=element_laplacian(dx, dphi),
                               load_z=load_z, volume=float(dx.sum()), reference=None)


# ----------------------------------------------------------------------------
# the adapter: every use of the sheet's model, mesh and solver interfaces
# ----------------------------------------------------------------------------
class _Sheet:
    """The sheet's interfaces as this module uses them (model, mesh, linear
    solvers, load paths, stability), in one place."""

    def __init__(self, sheet, hmax, layers, solver):
        # the space and the assembler uncached (taylor_hood_space and
        # assembler_for keep the last eight alive, with their work buffers):
        # a trace's meshes are its own, freed with it
        mesh = sheet_mesh(sheet, hmax, layers, half=True)
        space = TaylorHoodSpace.build(mesh)
        self.base = SheetProblem(sheet, mesh, space=space, assembler=Assembler.build(space))
        self.solver_name = solver
        b = self.base
        self.free, self.nu_dof, self.ndof = b.free, b.nu_dof, b.ndof
        self.clamp_dofs = b.clamp_dofs
        self.n_pressure_free = int(np.count_nonzero(b.free >= b.nu_dof))
        self.force_scale = float(np.linalg.norm(b.gravity_load[b.free]))
        X = b.nodes
        tip = np.flatnonzero((np.abs(X[:, 0] - X[:, 0].max()) < 1e-9) & (np.abs(X[:, 1]) < 1e-9)
                             & (np.abs(X[:, 2]) < 1e-9))
        self.tip_dof = 3 * int(tip[0]) + 2 if len(tip) else None

    def fixed_values(self, curvature):
        """Full state vector with the clamp values set (free entries zero)."""
        w = np.zeros(self.ndof)
        w[self.clamp_dofs] = self.base.clamp_values(curvature)
        return w

    def at(self, length, tip_width, bases=False):
        """The base problem on its mesh mapped to ``(length, tip_width)``.

        The same construction as ``SheetProblem.with_length`` (a copy sharing
        the dof maps, the sparsity pattern and the work arrays, with the
        geometric data recomputed), for the map ``x' = x L / L_m``,
        ``y' = y p_b(xi) / p_{b_m}(xi)``: the mapped vertices give a mesh with
        the same tetrahedra, whose basis gradients, weights, nodes and loads
        replace the base's (:func:`mapped_space`).  ``bases=True``: also
        scikit-fem bases on the mapped mesh (needed to interpolate a state on
        it, :func:`~skfem_sheet.analyses.transfer.transfer`; slower).
        """
        b0 = self.base
        m0 = b0.sheet_mesh
        P = m0.mesh.p
        xi = P[0] / m0.length
        q = (1.0 + (tip_width - 1.0) * xi) / (1.0 + (m0.tip_width - 1.0) * xi)
        mesh = SheetMesh(mesh=MeshTet(np.vstack([xi * length, P[1] * q, P[2]]), m0.mesh.t),
                         length=length, tip_width=tip_width, thickness=m0.thickness,
                         hmax=m0.hmax, layers=m0.layers, half=m0.half, refine=m0.refine)
        # the same tetrahedra, so the same dof numbering and pattern: the base's
        # space mapped element by element (or, with bases, a fresh uncached
        # space on the mapped mesh), sharing the base's assembler
        space = (TaylorHoodSpace.build(mesh, b0.quadrature_order) if bases
                 else mapped_space(b0.space, mesh))
        # the Sheet only carries metadata here (b may exceed 1 by a difference step)
        sheet = b0.sheet.replace(length=length, tip_width=min(max(tip_width, 0.0), 1.0))
        return SheetProblem(sheet, mesh, b0.quadrature_order, space=space,
                            assembler=b0.assembler)

    @staticmethod
    def residual(problem, w):
        r, jmin = problem.residual(w, 1.0)
        return r, jmin

    @staticmethod
    def tangent(problem, w):
        return problem.tangent(w)

    def new_solver(self):
        return make_linear_solver(self.solver_name)

    @staticmethod
    def factorize(solver, K):
        solver.factorize(K, None)

    @staticmethod
    def negative_eigenvalues(problem, solver):
        """Negative eigenvalues of the constrained Hessian (None if unknown)."""
        return stability(problem, solver)[1]

    def solve_along_path(self, problem, curvature, path="curvature-first"):
        """Full state at ``problem`` by the load path (branch selection)."""
        solver = self.new_solver()
        stats = Stats()
        out = follow_path(problem, path, curvature, solver, stats=stats)
        return out.converged, out.w, stats.factorizations, out.reason


# ----------------------------------------------------------------------------
# the sheet as an engine problem in (L, b)
# ----------------------------------------------------------------------------
class _Factorization:
    """A factorised tangent on one of the adapter's solvers; solves stay valid
    if that solver has factorised something else since (it is refactorised)."""

    def __init__(self, owner, slot, K, problem):
        self.owner, self.slot, self.K, self.problem = owner, slot, K, problem
        self.generation = owner._generation[slot]
        self._negative = owner._sheet.negative_eigenvalues(problem, owner._solvers[slot])

    def _ready(self):
        o = self.owner
        if o._generation[self.slot] != self.generation:
            o._refactorize(self)

    def solve(self, b):
        self._ready()
        return self.owner._solvers[self.slot].solve(b)

    def inertia(self):
        return self._negative


class SheetFoldProblem(Problem):
    """The half sheet at full load as an engine problem in ``p = (L, b, a/R)``.

    The state ``u`` holds the free dofs; the clamp values are those of the
    curvature ``p[2]`` (a parameter vector ``(L, b)`` means ``curvature``).  Norms as in :mod:`skfem_sheet.newton`: the residual
    relative to the weight, corrections of the displacements; the arclength
    inner product weighs the mean square of the displacements plus the
    square of the tip's vertical displacement (pressures left out).

    Parameters
    ----------
    curvature : float
        a/R of the mesh's sheet, and of parameter vectors ``(L, b)``.
    hmax : float
    mesh_length, mesh_tip_width : float
        ``(L_m, b_m)`` of the mesh.
    thickness, modulus : float
    layers : int, optional
    solver : str
        Linear-solver back-end (see :func:`skfem_sheet.linalg.make_linear_solver`).
    solver_slots : int
        Factorisations held at once (1 bounds the memory to one factor; a
        solve with an older factorisation then refactorises it).
    cache : int
        Mapped problems kept (each holds the basis data of the mesh).

    Examples
    --------
    >>> P = SheetFoldProblem(2.5, hmax=0.25)
    >>> P.distortion([1.56, 0.5]), P.admissible_parameters([1.56, 0.1])
    ((1.2, 0.5), False)
    >>> u = np.zeros(len(P._sheet.free))
    >>> bool(np.all(np.isfinite(P.residual(u, [1.3, 0.8, 2.0]))))
    True
    """

    parameter_names = ("L", "b", "a/R")

    def __init__(self, curvature, hmax=0.1, mesh_length=1.3, mesh_tip_width=1.0,
                 thickness=0.03, modulus=735.0, layers=None, solver="auto", solver_slots=2,
                 cache=12):
        self.curvature = float(curvature)
        sheet = Sheet(length=mesh_length, tip_width=mesh_tip_width, curvature=curvature,
                      thickness=thickness, modulus=modulus)
        self._sheet = _Sheet(sheet, hmax, layers, solver)
        s = self._sheet
        self._fixed = (self.curvature, s.fixed_values(self.curvature))
        self._u_free = s.free < s.nu_dof
        self._theta = 1.0 / max(1, int(np.count_nonzero(self._u_free)))
        self._tip = (None if s.tip_dof is None
                     else int(np.searchsorted(s.free, s.tip_dof)))
        self._problems = OrderedDict()
        self._last_residuals = []  # (p, u, R) of the last few residuals
        # solver_slots factorisations held at once (a solve with an older one
        # refactorises it); cache mapped problems kept
        self._solvers = [s.new_solver() for _ in range(int(solver_slots))]
        self._generation = [0] * int(solver_slots)
        self._cache = int(cache)
        self._next = 0
        self.refactorizations = 0

    # -- geometry ------------------------------------------------------------
    def problem(self, p):
        """The mapped problem at ``p = (L, b)`` (a few are cached)."""
        key = (float(p[0]), float(p[1]))
        prob = self._problems.get(key)
        if prob is None:
            if not (key[0] > 0 and key[1] > 0):
                raise ParameterError(f"(L, b) must be positive, got {key}")
            prob = self._sheet.at(*key)
            self._problems[key] = prob
            if len(self._problems) > self._cache:
                self._problems.popitem(last=False)
        return prob

    def _kappa(self, p):
        return float(p[2]) if len(p) > 2 else self.curvature

    def full(self, u, p=()):
        """The full state: ``u`` on the free dofs, the clamp values of ``p``."""
        kappa = self._kappa(p)
        if kappa != self._fixed[0]:
            self._fixed = (kappa, self._sheet.fixed_values(kappa))
        w = self._fixed[1].copy()
        w[self._sheet.free] = u
        return w

    def distortion(self, p):
        """``(x stretch, y squeeze at the tip)`` of the mesh at ``p``."""
        m = self._sheet.base.sheet_mesh
        return p[0] / m.length, p[1] / m.tip_width

    @property
    def mesh_parameters(self):
        """``(L_m, b_m)`` of the mesh."""
        m = self._sheet.base.sheet_mesh
        return float(m.length), float(m.tip_width)

    def remesh_box(self, j, length_range, bounds_j):
        """The parameter box ``((L_lo, L_hi), (lo_j, hi_j))`` inside which this
        mesh is used: ``length_range`` and ``bounds_j`` cut to the remeshing
        limits (:data:`REMESH_STRETCH`, and for ``j = 1`` :data:`REMESH_SQUEEZE`)."""
        L_m, b_m = self.mesh_parameters
        L_box = (max(length_range[0], L_m / REMESH_STRETCH),
                 min(length_range[1], L_m * REMESH_STRETCH))
        j_box = tuple(bounds_j)
        if j == 1:
            j_box = (max(bounds_j[0], b_m * REMESH_SQUEEZE), min(bounds_j[1], b_m / REMESH_SQUEEZE))
        return L_box, j_box

    def transferred(self, other, u, p, state=True):
        """``u`` (free dofs of this problem at ``p``) interpolated onto ``other``
        at ``p``; ``state=False``: a vector with zero clamp values (a null vector)."""
        if state:
            w = self.full(u, p)
        else:
            w = np.zeros(self._sheet.ndof)
            w[self._sheet.free] = u
        # interpolation needs scikit-fem bases on the mapped mesh
        old = self._sheet.at(float(p[0]), float(p[1]), bases=True)
        return transfer(old, w, other.problem(p))[other._sheet.free]

    # -- protocol ------------------------------------------------------------
    def admissible_parameters(self, p) -> bool:
        """Within the mesh's distortion limits (stretch in [1/2, 2], tip
        width in (0, 1.5 b_m] and not squeezed below ``MIN_SQUEEZE``) and a
        curvature in (0, 2 pi)."""
        s, q = self.distortion(p)
        return bool(0.5 <= s <= 2.0 and MIN_SQUEEZE <= q <= 1.5 and p[1] > 0
                    and 0 < self._kappa(p) < 2 * np.pi)

    #: Differences of tangents in the fold system are one-sided (forward
    #: from the tangent at the iterate): one tangent assembly and one mapped
    #: mesh per parameter instead of two (:meth:`FoldSystem.sigma_derivatives`).
    fd_one_sided = True

    def residual(self, u, p):
        # the last residual is kept: the corrector evaluates it at a trial
        # point, and the linearisation there asks for it again
        key = tuple(float(x) for x in p)
        for k, uu, rr in self._last_residuals:
            if k == key and np.array_equal(uu, u):
                return rr.copy()
        if not self.admissible_parameters(p):
            return np.full(len(u), np.nan)  # inadmissible: the corrector halves the step
        r, jmin = self._sheet.residual(self.problem(p), self.full(u, p))
        r = r[self._sheet.free] if jmin > 0 else np.full(len(u), np.nan)
        self._last_residuals = [(key, np.array(u, dtype=float, copy=True), r),
                                *self._last_residuals[:3]]
        return r.copy()

    def dresidual(self, u, p, i):
        """``dR/dp_i`` by a forward difference from the residual at ``p``
        (one residual on one mapped mesh)."""
        p = np.asarray(p, dtype=float)
        h = self.fd_parameter_step * max(1.0, abs(p[i]))
        q = p.copy()
        q[i] += h
        r0 = self.residual(u, p)
        return (self.residual(u, q) - r0) / h

    def jacobian(self, u, p):
        return self._sheet.tangent(self.problem(p), self.full(u, p))

    def factorize(self, J):
        slot = self._next
        self._next = (slot + 1) % len(self._solvers)
        self._sheet.factorize(self._solvers[slot], J)
        self._generation[slot] += 1
        # (the inertia only needs the dof layout, the same for every (L, b))
        return _Factorization(self, slot, J, self._sheet.base)

    def release(self):
        """Drop the factorisations and the cached mapped problems (memory);
        the problem stays usable (they are made again when needed)."""
        s = self._sheet
        self._solvers = [s.new_solver() for _ in self._solvers]
        self._generation = [g + 1 for g in self._generation]
        self._problems.clear()
        self._last_residuals = []

    def _refactorize(self, fact):
        self._sheet.factorize(self._solvers[fact.slot], fact.K)
        self._generation[fact.slot] += 1
        fact.generation = self._generation[fact.slot]
        self.refactorizations += 1

    def dual(self, a):
        c = np.zeros_like(a)
        c[self._u_free] = self._theta * a[self._u_free]
        if self._tip is not None:
            c[self._tip] += a[self._tip]
        return c

    def residual_norm(self, r):
        return float(np.linalg.norm(r)) / self._sheet.force_scale

    def correction_norm(self, du):
        return float(np.abs(du[self._u_free]).max())

    # -- starting states -----------------------------------------------------
    def solve_state(self, p, path="curvature-first"):
        """State at ``p`` along a load path; raises ParameterError if it fails."""
        ok, w, nfact, why = self._sheet.solve_along_path(self.problem(p), self._kappa(p), path)
        if not ok:
            raise ParameterError(f"the sheet at (L, b, a/R) = {tuple(p)} could not be solved along "
                                 f"{path}: {why}")
        return w[self._sheet.free], nfact


# ----------------------------------------------------------------------------
# the study
# ----------------------------------------------------------------------------
@dataclass(frozen=True)
class FoldCurve:
    """The fold curve in (L, b) of one clamp curvature.

    Attributes
    ----------
    curvature : float
    points : tuple of dict
        ``{"tip_width", "length", "kind"}`` in the order traced (from the
        standout fold at ``b = 1`` through the cusp to the pop-up fold);
        ``kind`` is ``"standout"`` or ``"popup"``.
    cusp : dict or None
        ``{"tip_width", "length"}`` where the two folds meet.
    factorizations : int
        All factorisations (the starting solve and fold search included).
    factorizations_per_point : float
        Median over the points of the curve's continuation.
    wall_time_s : float
    hmax : float
    completed : bool
        The curve came back to ``b = 1``.
    reason : str
    negative_eigenvalues : tuple
        Per point, besides the critical one (None if unknown).
    crossing : tuple
        Per point, negative eigenvalue counts on both sides along the null
        vector (where checked; None elsewhere).
    """

    curvature: float
    points: tuple
    cusp: object
    factorizations: int
    factorizations_per_point: float
    wall_time_s: float
    hmax: float = 0.1
    completed: bool = False
    reason: str = ""
    negative_eigenvalues: tuple = ()
    crossing: tuple = ()
    curve: object = field(default=None, repr=False, compare=False)
    #: The second parameter of the curve ("tip_width", or "curvature" for
    #: :func:`trace_curvature_fold_curve`, whose points carry "curvature").
    second: str = "tip_width"
    #: The fixed tip width of a curve in (L, a/R).
    tip_width: float = 1.0
    #: False: the curvature-dominated branch at the start went through the
    #: whole length range without a fold (no bistable range; no points).
    bistable: bool = True
    #: Fresh meshes made on the way (state transferred each time).
    remeshes: int = 0
    #: ``(L_m, b_m)`` at which each mesh of the trace was made, in order (the
    #: first mesh, then one per remesh; coarse to fine: the coarse trace's,
    #: then the finest level's).  At a coarse mesh the folds depend on where
    #: the mesh was made (hmax 0.2, a/R 2.5: L0*(1) from 1.218 to 1.270 over
    #: meshes made at L_m from 0.95 to 1.37), so a comparison of two traces
    #: is made on the mesh they share (tests/test_foldcurve.py).
    meshes: tuple = ()
    #: How the cusp was found: "fold coefficient" (its sign change, located
    #: by regula falsi), "turning point" (where the second parameter turns
    #: back, if the sign change was not seen), for a curve refined coarse to
    #: fine "fold coefficient on the fine mesh" (the sign change of the
    #: refined points' coefficient, located there) or "refined points" (the
    #: turn of the refined points), or "" (no cusp).
    cusp_located: str = ""
    #: Factorisations spent locating the cusp on the fine mesh (coarse to
    #: fine; not counted in ``factorizations_per_point``, counted in
    #: ``factorizations``).
    cusp_factorizations: int = 0
    #: Coarse to fine (``coarse_hmax``): the mesh of the coarse trace, its
    #: points and factorisations (None: the curve was traced at ``hmax``).
    coarse_hmax: object = None
    coarse_points: object = None
    coarse_factorizations: object = None
    #: Per refinement level: ``{"hmax", "points", "failed", "factorizations",
    #: "factorizations_per_point"}`` (the last one is ``hmax``).
    stages: tuple = ()

    def _at_start_value(self, kind):
        end = 1.0 if self.second == "tip_width" else self.curvature
        for pt in self.points:
            if pt["kind"] == kind and abs(pt[self.second] - end) < 1e-9:
                return pt["length"]
        return None

    @property
    def standout_length(self):
        """``L1*`` where the curve starts (``b = 1``, or the start curvature;
        None if not on the curve)."""
        return self._at_start_value("standout")

    @property
    def popup_length(self):
        """``L0*`` where the curve ends (None if the curve did not come back)."""
        return self._at_start_value("popup")

    def record(self) -> dict:
        """:meth:`summary` plus the status: ``completed``, ``bistable``,
        ``reason``, ``remeshes``, ``hmax``, ``standout_length``, ``popup_length``."""
        out = self.summary()
        out.update(hmax=self.hmax, completed=bool(self.completed), bistable=bool(self.bistable),
                   reason=self.reason, remeshes=int(self.remeshes),
                   cusp_located=self.cusp_located,
                   standout_length=self.standout_length, popup_length=self.popup_length,
                   coarse_hmax=self.coarse_hmax, coarse_points=self.coarse_points,
                   coarse_factorizations=self.coarse_factorizations)
        return out

    def summary(self) -> dict:
        """JSON-ready: curvature, points, cusp, factorizations,
        factorizations_per_point, wall_time_s (and for a curve in (L, a/R):
        parameter = "curvature" and its tip_width)."""
        out = {"curvature": self.curvature, "points": [dict(p) for p in self.points],
               "cusp": None if self.cusp is None else dict(self.cusp),
               "factorizations": self.factorizations,
               "factorizations_per_point": self.factorizations_per_point,
               "wall_time_s": self.wall_time_s}
        if self.second != "tip_width":
            out.update(parameter=self.second, tip_width=self.tip_width)
        return out


def _kind(side):
    return "standout" if side < 0 else "popup" if side > 0 else "unknown"


class _Progress:
    def __init__(self, enabled, j=1, name="b"):
        self.j, self.name = j, name
        self.bar = None
        if enabled:
            self.bar = tqdm(desc="fold curve", unit="pt", file=sys.stderr)

    def __call__(self, pt):
        if self.bar is not None:
            self.bar.update(1)
            self.bar.set_postfix_str(f"{self.name}={pt.p[self.j]:.4f} L={pt.p[0]:.4f} "
                                     f"{_kind(pt.side)}", refresh=True)

    def close(self):
        if self.bar is not None:
            self.bar.close()


def default_start_length(curvature: float) -> float:
    """L/a of the first solve of a trace: below the pop-up length ``L0*(b = 1)``
    of the rectangle (hmax 0.1: 0.83, 0.97, 1.09, 1.21, 1.42, 1.72 at a/R = 1,
    1.5, 2, 2.5, 3.5, 5), so that the curvature-first solve is on the
    curvature-dominated branch; 1.2 at a/R = 2.5.

    Examples
    --------
    >>> [round(default_start_length(k), 3) for k in (1, 2.5, 5)]
    [0.6, 1.2, 1.6]
    """
    k = float(curvature)
    return float(min(1.2, 0.2 + 0.4 * k) if k <= 2.5 else 1.2 + 0.16 * (k - 2.5))


def trace_fold_curve(curvature: float, hmax: float = 0.1, *, start_length=None,
                     length_range=(0.6, 2.4), min_tip_width: float = 0.2,
                     thickness: float = 0.03, modulus: float = 735.0, layers=None,
                     solver: str = "auto", ds: float = 0.05, ds_max: float = 0.4,
                     check_inertia=10, mesh_length=None, max_points: int = 400,
                     progress: bool = False, coarse_hmax=None,
                     fine_points: int = 12, series=None) -> FoldCurve:
    """Trace the fold curve in (L, b) at clamp curvature ``curvature``.

    1. Solve the sheet at ``(start_length, b = 1)`` curvature-first, and follow
       the curvature-dominated branch in L (natural continuation) until its
       fold, located with the minimally augmented system: ``L1*(1)``.
    2. Continue that fold in ``(L, b)`` with decreasing ``b``
       (:func:`skfem_sheet.engine.fold_curve`) until the curve returns to
       ``b = 1`` (``L0*(1)``, the last point, put on ``b = 1``), locating the
       cusp on the way.

    Parameters
    ----------
    curvature : float
        a/R, in (0, 2 pi).
    hmax : float
        Mesh size (one mesh for the whole curve).
    start_length : float, optional
        Length of the first solve, below ``L0*`` (default
        :func:`default_start_length`).
    length_range : (float, float)
        The curve stops if L leaves this range (and a curvature whose
        curvature-dominated branch reaches its end without a fold is reported
        as not bistable).
    min_tip_width : float
        The curve stops below this tip width.
    ds, ds_max : float
        First and largest arclength step.
    check_inertia : bool or int
        Confirm on every (True) or every n-th point that exactly one
        eigenvalue crosses zero (two extra factorisations per checked point;
        at the fold itself the count of the near-zero pivot is not reliable
        with pivot perturbation, hence the check beside it).
    max_points : int
        Largest number of points of the curve.
    mesh_length : float, optional
        Length of the first mesh (default: ``1.08 start_length``); the trace
        remeshes beyond :data:`REMESH_STRETCH` / :data:`REMESH_SQUEEZE`.
    progress : bool
        tqdm bar on stderr.
    coarse_hmax : float or sequence of float, optional
        Coarse to fine: trace the curve at this (coarser) mesh size first
        (several: at the coarsest, then refined level by level),
        then correct ``fine_points`` of its points (and both ends, and the
        points around the cusp) on meshes of size ``hmax``, each from the
        coarse fold carried over, with the minimally augmented system: a few
        factorisations at ``hmax`` per point, no load path or continuation
        there.  The cusp is then located on the fine mesh where the
        refined points' fold coefficient changes sign (a few more fold
        points there).
    fine_points : int
        Points of the coarse curve refined (spaced evenly in the plane of
        the parameters), besides the ends and the cusp's neighbours.
    series : skfem_sheet.io.Series, optional
        Collects the state of every point of the curve (time: its index
        along the curve); write it with ``series.write(directory, name)``.

    Returns
    -------
    FoldCurve

    Examples
    --------
    >>> c = trace_fold_curve(2.5, hmax=0.1)  # doctest: +SKIP
    >>> c.standout_length, c.popup_length, c.cusp  # doctest: +SKIP
    """
    curvature = check_range("curvature", curvature, 0, 2 * np.pi, lo_open=True, hi_open=True)
    min_tip_width = check_range("min_tip_width", min_tip_width, 0, 1, lo_open=True, hi_open=True)
    return _run(curvature, 1.0, 1, (min_tip_width, 1.0), hmax=hmax, start_length=start_length,
                length_range=length_range, thickness=thickness, modulus=modulus,
                layers=layers, solver=solver, ds=ds, ds_max=ds_max,
                check_inertia=check_inertia, mesh_length=mesh_length,
                max_points=max_points, progress=progress, coarse_hmax=coarse_hmax,
                fine_points=fine_points, series=series)


def trace_curvature_fold_curve(tip_width: float = 1.0, curvature: float = 2.5,
                               hmax: float = 0.1, *, min_curvature: float = 0.3,
                               start_length=None, length_range=(0.6, 2.4),
                               thickness: float = 0.03, modulus: float = 735.0, layers=None,
                               solver: str = "auto", ds: float = 0.05, ds_max: float = 0.4,
                               check_inertia=10, mesh_length=None, max_points: int = 400,
                               progress: bool = False, coarse_hmax=None,
                               fine_points: int = 12, series=None) -> FoldCurve:
    """Trace the fold curve in (L, a/R) at tip width ``tip_width``.

    The same as :func:`trace_fold_curve` with the clamp curvature as the
    second parameter: from the standout fold at ``curvature`` the fold is
    continued to lower curvatures, through the cusp where bistability starts,
    and back to ``curvature`` as the pop-up fold.  The points carry
    ``curvature`` instead of ``tip_width``; the cusp is ``{"curvature",
    "length"}``.  Parameters as for :func:`trace_fold_curve`;
    ``min_curvature`` bounds the curve below.

    Examples
    --------
    >>> c = trace_curvature_fold_curve(1.0, 2.5, hmax=0.1)  # doctest: +SKIP
    >>> c.cusp["curvature"]  # doctest: +SKIP
    """
    tip_width = check_range("tip_width", tip_width, 0, 1, lo_open=True)
    curvature = check_range("curvature", curvature, 0, 2 * np.pi, lo_open=True, hi_open=True)
    min_curvature = check_range("min_curvature", min_curvature, 0, curvature, lo_open=True,
                                hi_open=True)
    return _run(curvature, tip_width, 2, (min_curvature, curvature), hmax=hmax,
                start_length=start_length, length_range=length_range, thickness=thickness,
                modulus=modulus, layers=layers, solver=solver, ds=ds, ds_max=ds_max,
                check_inertia=check_inertia, mesh_length=mesh_length,
                max_points=max_points, progress=progress, coarse_hmax=coarse_hmax,
                fine_points=fine_points, series=series)


_SECOND = {1: ("b", "tip_width"), 2: ("a/R", "curvature")}


class _Maker:
    """Fresh fold problems of one trace (same sheet and discretisation, another mesh)."""

    def __init__(self, curvature, hmax, thickness, modulus, layers, solver):
        self.args = (curvature, hmax)
        self.kw = dict(thickness=thickness, modulus=modulus, layers=layers, solver=solver)
        self.count = 0
        self.made = []  # (L_m, b_m) of each mesh made

    def __call__(self, mesh_length, mesh_tip_width):
        self.count += 1
        P = SheetFoldProblem(*self.args, mesh_length=mesh_length,
                             mesh_tip_width=min(1.0, mesh_tip_width), **self.kw)
        self.made.append(P.mesh_parameters)
        return P

    def remesh(self, P, u, p, v=None):
        """A problem on a fresh mesh at ``p``'s (L, b), with ``u`` (and ``v``) on it."""
        Q = self(float(p[0]), float(p[1]))
        return (Q, P.transferred(Q, u, p),
                None if v is None else P.transferred(Q, v, p, state=False))


def _standout_fold(make, P, u, p, hi, tol):
    """Natural continuation in L from ``(u, p)`` to the first fold, remeshing
    every :data:`REMESH_STRETCH`; where Newton fails short of the fold without
    locating it, the fold is located from the last point, or (twice at most)
    the continuation goes on from there on a fresh mesh.  Returns ``(P, fold or None, factorisations,
    reason)``; ``reason`` is ``""`` when the branch reached ``hi`` without a fold."""
    nfact, retries = 0, 0
    for _ in range(MAX_REMESHES + 1):
        stop = min(hi, P.mesh_parameters[0] * REMESH_STRETCH)
        branch = natural(P, u, p, "L", stop, step=0.05, min_step=1e-3, tol=tol, jump=0.1,
                         keep_states=False)
        nfact += branch.stats.factorizations
        if branch.fold is not None:
            return P, branch.fold, nfact, f"fold: {branch.reason}"
        if not branch.completed:
            if not branch.points or retries >= 2:
                return P, None, nfact, branch.reason or "natural continuation in L failed"
            # Newton failed short of the fold without locating it: locate it
            # from the last point directly, else go on from there on a fresh mesh
            last = branch.points[-1]
            fold, res = locate_fold(P, last.u, last.p, "L", tol=tol)
            nfact += res.iterations
            if (fold is not None and fold.side < 0
                    and -1e-3 <= fold.value - last.p[0] <= 0.1):
                return P, fold, nfact, f"fold located from the last point ({branch.reason})"
            retries += 1
            P, u, _ = make.remesh(P, last.u, last.p)
            p = last.p
            # on the fresh mesh the fold may lie just below the last point
            # (no equilibrium there to continue from): locate it directly
            # from the carried state, settled on the section of the branch
            # direction if the fold system does not converge from it
            fold, lost = _fold_near(P, u, p, tol)
            nfact += lost
            if (fold is not None and fold.side < 0
                    and -0.1 <= fold.value - last.p[0] <= 0.1):
                return P, fold, nfact, f"fold located on a fresh mesh ({branch.reason})"
            continue
        last = branch.points[-1]
        if stop >= hi - 1e-12:
            return P, None, nfact, ""
        P, u, _ = make.remesh(P, last.u, last.p)
        p = last.p
    return P, None, nfact, f"more than {MAX_REMESHES} remeshes"


def _fold_near(P, u, p, tol):
    """A fold in L near ``(u, p)``: from there, or from the equilibrium on
    the section of ``du/dL`` through it.  Returns ``(fold or None,
    factorisations)``."""
    fold, res = locate_fold(P, u, p, "L", tol=tol)
    lost = res.stats.factorizations
    if fold is not None:
        return fold, lost
    try:
        fact = P.factorize(P.jacobian(u, p))
        d = fact.solve(-P.dresidual(u, p, 0))
        lost += 1
    except EngineFailure:  # a singular tangent: no direction to settle along
        return None, lost
    settled = equilibrium_on_section(P, u, p, "L", (d, np.zeros_like(p), P.inner(d, u)),
                                     tol=tol)
    lost += settled.stats.factorizations
    if not settled.converged:
        return None, lost
    fold, res = locate_fold(P, settled.u, settled.p, "L", v0=d, tol=tol)
    return fold, lost + res.stats.factorizations


def _turning_point(points, key):
    """The cusp of a completed curve whose fold coefficient's sign change was
    not seen: where ``key`` turns back (its minimum over the points, refined
    by a parabola through the three points around it in the arclength)."""
    q = np.array([pt[key] for pt in points])
    L = np.array([pt["length"] for pt in points])
    k = int(np.argmin(q))
    if k == 0 or k == len(q) - 1:
        return None
    s = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(q), np.diff(L)))])
    idx = slice(k - 1, k + 2)
    cq, cL = np.polyfit(s[idx], q[idx], 2), np.polyfit(s[idx], L[idx], 2)
    s_min = -cq[1] / (2 * cq[0]) if cq[0] > 0 else s[k]
    s_min = float(np.clip(s_min, s[k - 1], s[k + 1]))
    return {key: float(np.polyval(cq, s_min)), "length": float(np.polyval(cL, s_min))}


def _as_fold_in_L(P, fold, tol):
    """A fold located in the second parameter, located again in L from there
    (fold_curve starts from a fold in L); None if that fails."""
    again, _ = locate_fold(P, fold.u, fold.p, "L", v0=fold.v, tol=tol)
    return again


def _strip(pt):
    return dataclasses.replace(pt, u=None)


def _trace(curvature, tip_width, j, bounds_j, *, hmax, start_length, length_range, thickness,
           modulus, layers, solver, ds, ds_max, check_inertia, mesh_length, max_points,
           progress, collect=None):
    """Standout fold at ``(tip_width, curvature)``, then its fold curve in
    ``(L, p_j)`` from the start value of ``p_j`` downward and back, remeshing
    on the way."""
    hmax = check_range("hmax", hmax, 0.02, 0.5)
    lo, hi = (check_range("length_range", float(x), 0.05, 20.0) for x in length_range)
    if start_length is None:
        start_length = min(max(default_start_length(curvature), lo + 0.02 * (hi - lo)),
                           0.5 * (lo + hi))
    if not lo < start_length < hi:
        raise ParameterError(f"start_length must be inside length_range {length_range!r}, "
                             f"got {start_length!r}")
    t0 = time.perf_counter()
    make = _Maker(curvature, hmax, thickness, modulus, layers, solver)
    P = make(mesh_length or 1.08 * start_length, tip_width)
    tol = TOLERANCES
    p0 = np.array([start_length, tip_width, curvature])
    u0, f_start = P.solve_state(p0, "curvature-first")
    P, fold, f_branch, why = _standout_fold(make, P, u0, p0, hi, tol)
    name, key = _SECOND[j]
    where = f"b/a = {tip_width:g}, a/R = {curvature:g}"
    if fold is None:
        total = f_start + f_branch
        if not why:
            return FoldCurve(curvature, (), None, int(total), float("nan"),
                             time.perf_counter() - t0, hmax, False,
                             f"not bistable at {where}: the curvature-dominated branch reached "
                             f"L/a = {hi:g} from {start_length:g} without a fold",
                             second=key, tip_width=tip_width, bistable=False,
                             remeshes=make.count - 1, meshes=tuple(make.made))
        raise ParameterError(f"no standout fold found in L from {start_length:g} to {hi:g} at "
                             f"{where}: {why}")
    bar = _Progress(progress, j, name)
    hi_j = bounds_j[1]
    points, cusps, per_point, stats = [], [], [], None
    engine_refact = 0
    direction, completed, reason = -1, False, ""
    try:
        while True:
            box = P.remesh_box(j, (lo, hi), bounds_j)
            seg = fold_curve(P, fold, ("L", name), box, ds=ds, ds_min=1e-4, ds_max=ds_max,
                             direction=direction, tol=tol, cusp_tol=1e-4,
                             check_inertia=check_inertia, easy_iterations=3,
                             predictor=PREDICTOR, target_correction=TARGET_CORRECTION,
                             max_points=max(2, max_points - len(points)), keep_states=True,
                             on_point=(None if collect is None else
                                       (lambda pt, u, v, P=P: collect(P, pt, u, v))),
                             progress=bar)
            stats = seg.stats if stats is None else stats + seg.stats
            engine_refact += P.refactorizations
            cusps += list(seg.cusps)
            pts = list(seg.points)
            per_point += [pt.factorizations for pt in pts[1:]]
            if not seg.completed or not pts:
                points += [_strip(pt) for pt in pts]
                reason = seg.reason or "the fold curve stopped"
                break
            last = pts[-1]
            Lc, qc = float(last.p[0]), float(last.p[j])
            real_end = (qc >= hi_j - 1e-9 or qc <= bounds_j[0] + 1e-9
                        or Lc <= lo + 1e-9 or Lc >= hi - 1e-9)
            if real_end:
                points += [_strip(pt) for pt in pts]
                completed = qc >= hi_j - 1e-9
                if not completed:
                    reason = (f"the curve left the box at L/a = {Lc:.4f}, {name} = {qc:.4f} "
                              f"before returning to {name} = {hi_j:g}")
                break
            if make.count > MAX_REMESHES:
                points += [_strip(pt) for pt in pts]
                reason = f"more than {MAX_REMESHES} remeshes"
                break
            points += [_strip(pt) for pt in pts[:-1]]
            if collect is not None and hasattr(collect, "drop_last"):
                collect.drop_last()  # the next segment starts at this point again
            prev = pts[-2].p if len(pts) > 1 else (points[-1].p if points else p0)
            step_j = float(last.p[j] - prev[j])
            direction = direction if step_j == 0 else (1 if step_j > 0 else -1)
            if len(points) >= max_points:
                reason = "max_points"
                break
            # a fresh mesh at the fold, the state and the null vector moved onto it
            P, u, _ = make.remesh(P, last.u, last.p)
            fold, res = locate_fold(P, u, last.p, "L", tol=tol)
            if fold is None:  # near the cusp the fold in L degenerates: in p_j at fixed L
                fold, res = locate_fold(P, u, last.p, name, tol=tol)
                if fold is not None:
                    fold = _as_fold_in_L(P, fold, tol)
            if fold is None:
                reason = (f"the fold was not found again after remeshing at L/a = {Lc:.4f}, "
                          f"{name} = {qc:.4f}: {res.reason}")
                break
            stats = stats + fold.stats
    finally:
        bar.close()
    out_points = tuple({key: float(pt.p[j]), "length": float(pt.p[0]), "kind": _kind(pt.side)}
                       for pt in points)
    cusp = None
    if cusps:
        c = cusps[0]
        cusp = {key: float(c.p[j]), "length": float(c.p[0])}
    elif completed:
        cusp = _turning_point(out_points, key)
    located = ("fold coefficient" if cusps else "turning point" if cusp is not None else "")
    total = f_start + f_branch + stats.factorizations + engine_refact
    curve = EngineFoldCurve(tuple(points), (0, j), tuple(cusps), completed, reason, stats)
    return FoldCurve(curvature, out_points, cusp, int(total),
                     float(np.median(per_point)) if per_point else float("nan"),
                     time.perf_counter() - t0, hmax, completed, reason,
                     tuple(pt.negative_eigenvalues for pt in points),
                     tuple(pt.crossing for pt in points), curve, key, tip_width,
                     remeshes=make.count - 1, meshes=tuple(make.made), cusp_located=located)



# ----------------------------------------------------------------------------
# coarse to fine
# ----------------------------------------------------------------------------
@dataclass(frozen=True)
class _Kept:
    """A fold-curve point of the coarse trace with what refining it needs."""

    problem: object = field(repr=False)
    p: np.ndarray
    u: np.ndarray = field(repr=False)
    v: np.ndarray = field(repr=False)
    a: float
    side: int
    tip: float


class _Collector:
    """Keeps every point of a coarse trace (states at the coarse mesh: small)."""

    def __init__(self):
        self.points = []

    def __call__(self, P, pt, u, v):
        self.points.append(_Kept(P, np.array(pt.p, dtype=float), np.array(u, dtype=float),
                                 np.array(v, dtype=float), float(pt.a), int(pt.side),
                                 float(u[P._tip])))


def _select(kept, n_points):
    """Indices of the coarse points to refine: both ends, ``n_points``
    spaced evenly in the plane of the two parameters (L/a and the second
    parameter, each relative to its range on the curve), and the two points
    around the sign change of the fold coefficient with their neighbours
    (the cusp: there the curve hardly moves in the plane)."""
    P = np.array([k.p for k in kept])
    q = (P - P.min(axis=0)) / np.maximum(np.ptp(P, axis=0), 1e-12)
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(q, axis=0), axis=1))])
    chosen = {0, len(kept) - 1}
    for target in np.linspace(0.0, s[-1], max(2, n_points)):
        chosen.add(int(np.argmin(np.abs(s - target))))
    a = np.array([k.a for k in kept])
    change = np.flatnonzero(np.sign(a[1:]) * np.sign(a[:-1]) < 0)
    if len(change):
        c = int(change[0])
        chosen.update(k for k in range(c - 1, c + 3) if 0 <= k < len(kept))
    # one point per tip deflection (a remesh repeats the point where it happens)
    out = []
    for k in sorted(chosen):
        if not out or abs(kept[k].tip - kept[out[-1]].tip) > 1e-9:
            out.append(k)
    return out


class _FineMeshes:
    """Fine problems of a refinement, one mesh per band of lengths (remeshed
    beyond :data:`REMESH_STRETCH`), each holding one factorisation."""

    def __init__(self, curvature, hmax, tip_width, kw):
        self.curvature, self.hmax, self.tip_width, self.kw = curvature, hmax, tip_width, kw
        self.meshes = []

    def for_length(self, L, band):
        for P in self.meshes:
            L_m = P.mesh_parameters[0]
            if L_m / REMESH_STRETCH <= L <= L_m * REMESH_STRETCH:
                return P
        L_m = float(np.clip(np.median(band), L / 1.2, L * 1.2))
        P = SheetFoldProblem(self.curvature, self.hmax, mesh_length=L_m,
                             mesh_tip_width=self.tip_width, solver_slots=1, cache=4, **self.kw)
        self.meshes.append(P)
        return P


def _refine(kept, chosen, j, make_fine, tol, check_inertia, last_is_end=True, ends=None):
    """The fold curve on the fine meshes from the coarse points ``kept[chosen]``.

    Each chosen coarse point is carried onto a fine mesh (state and null
    vector, :meth:`SheetFoldProblem.transferred`) and corrected there with
    the minimally augmented system: the two ends, at the start value of the
    second parameter, as folds in L (:func:`~skfem_sheet.engine.locate_fold`);
    the others on the hyperplane through the coarse point normal to the
    coarse curve's secant there (:func:`~skfem_sheet.engine.fold_on_section`,
    L and the second parameter free), which is transversal to the curve also
    at the cusp, where neither parameter parametrises it.  Returns
    ``(points, failures, spent)``: points as dicts with the fold, its
    factorisations and inertia, and the fine point as a :class:`_Kept`
    (``"kept"``, to refine further), in the order of the coarse curve;
    ``spent``: the factorisations of the points that failed.  ``ends``:
    the positions in ``chosen`` of the ends (default: the first, and the
    last if ``last_is_end``); an end that comes out as the other kind of
    fold (the pop-up fold found from a standout one) counts as failed."""
    name = _SECOND[j][0]
    band = [kept[k].p[0] for k in chosen]
    out, failures, spent = [], [], 0
    for n, k in enumerate(chosen):
        c = kept[k]
        Pf = make_fine.for_length(float(c.p[0]), band)
        f0 = Pf.refactorizations
        u = c.problem.transferred(Pf, c.u, c.p)
        v = c.problem.transferred(Pf, c.v, c.p, state=False)
        end = (n == 0 or (last_is_end and n == len(chosen) - 1)) if ends is None else n in ends
        section = None
        if not end:
            lo, hi = _neighbours(kept, k)
            t_u = c.problem.transferred(Pf, kept[hi].u - kept[lo].u, c.p, state=False)
            t_p = kept[hi].p - kept[lo].p
            section = (t_u, t_p, Pf.inner(t_u, u) + float(t_p @ c.p))
        fold, res = _fold_from(Pf, section, name, u, c.p, v, tol)
        lost = res.stats.factorizations if fold is None else 0
        if fold is None:
            # outside Newton's basin of the fold system: settle the carried
            # state first as an equilibrium on the section of its null
            # vector (L free), then locate the fold from there
            settled = equilibrium_on_section(Pf, u, c.p, "L",
                                             (v, np.zeros_like(c.p), Pf.inner(v, u)), tol=tol)
            lost += settled.stats.factorizations
            if settled.converged:
                fold, res = _fold_from(Pf, section, name, settled.u, settled.p, v, tol)
        if fold is not None and end and int(fold.side) != c.side:
            lost += fold.stats.factorizations
            fold, res = None, dataclasses.replace(res, reason="the other kind of fold")
        if fold is None:
            failures.append(f"{name} = {c.p[j]:.4f}, L/a = {c.p[0]:.4f}: {res.reason}")
            spent += lost + res.stats.factorizations + Pf.refactorizations - f0
            continue
        crossing, extra = None, 0
        if check_inertia and (end or n % int(check_inertia) == 0):
            crossing, extra = inertia_crossing(Pf, fold.u, fold.p, fold.v, 1e-4), 2
        tip = float(fold.u[Pf._tip])
        out.append(dict(p=np.array(fold.p), a=float(fold.a), side=int(fold.side), tip=tip,
                        negative=fold.negative_eigenvalues, crossing=crossing,
                        iterations=int(res.iterations),
                        factorizations=int(fold.stats.factorizations + extra + lost
                                           + Pf.refactorizations - f0), end=end,
                        refill=False,
                        kept=_Kept(Pf, np.array(fold.p), fold.u, fold.v, float(fold.a),
                                   int(fold.side), tip)))
    return out, failures, spent


#: First and largest arclength step of the continuation on a fine mesh
#: that replaces an end which could not be refined (:func:`_continue_to_end`).
REFILL_DS = (0.02, 0.2)


def _continue_to_end(pts, last, want, j, bounds_j, length_range, tol, check_inertia):
    """An end of a refined curve that could not be refined, traced on the fine
    mesh instead: the fold curve continued there
    (:func:`skfem_sheet.engine.fold_curve`) from the refined point next to
    it (``last``: the last end, else the first) to the start value of the
    second parameter, away from the cusp if that point is of the end's kind
    (``want``: its side) and through the cusp otherwise.

    A fallback for a curve whose coarse ends lie outside the fine fold
    system's basin (at a/R = 1 the two folds at b = 1 are 0.0013 apart in
    L/a while the fine folds lie 0.01 lower than the coarse ones).  Returns
    ``(points, lost, reason)``: the new points in the order of the curve
    (the end included, flagged ``"end"``; the start point left out), as the
    dicts of :func:`_refine`, and the factorisations not counted in their
    ``"factorizations"``; or ``([], factorisations, reason)``.
    """
    name = _SECOND[j][0]
    K = (pts[-1] if last else pts[0])["kept"]
    P = K.problem
    f0 = P.refactorizations
    start = FoldPoint(K.u, np.array(K.p), K.v, 0.0, K.a, K.side, 0)
    seen = []
    box = P.remesh_box(j, length_range, bounds_j)
    c = fold_curve(P, start, ("L", name), box, ds=REFILL_DS[0], ds_min=1e-4, ds_max=REFILL_DS[1],
                   direction=1 if K.side == want else -1, tol=tol, cusp_tol=1e-4,
                   check_inertia=0, easy_iterations=3, predictor=PREDICTOR,
                   target_correction=TARGET_CORRECTION, max_points=60, keep_states=True,
                   on_point=lambda pt, u, v: seen.append((np.array(u), np.array(v))))
    total = c.stats.factorizations + P.refactorizations - f0
    end = c.points[-1] if c.points else None
    if not (c.completed and end is not None and abs(end.p[j] - bounds_j[1]) < 1e-9
            and end.side == want):
        return [], total, (f"continued on the fine mesh to {name} = {bounds_j[1]:g}: "
                           f"{c.reason or 'ended elsewhere'}")
    out = []
    for n, (pt, (u, v)) in enumerate(zip(c.points[1:], seen[1:]), start=1):
        is_end = n == len(c.points) - 1
        crossing, extra = None, 0
        if check_inertia and is_end:
            f1 = P.refactorizations
            crossing = inertia_crossing(P, u, pt.p, v, 1e-4)
            extra = 2 + P.refactorizations - f1
        tip = float(u[P._tip])
        out.append(dict(p=np.array(pt.p), a=float(pt.a), side=int(pt.side), tip=tip,
                        negative=pt.negative_eigenvalues, crossing=crossing,
                        iterations=int(pt.iterations),
                        factorizations=int(pt.factorizations + extra), end=is_end,
                        refill=not is_end,
                        kept=_Kept(P, np.array(pt.p), u, v, float(pt.a), int(pt.side), tip)))
    lost = total - sum(pt.factorizations for pt in c.points[1:])
    if not last:
        out.reverse()
    return out, lost, ""


def _fold_from(P, section, name, u, p, v, tol):
    """The fold in L at fixed ``p`` (``section`` None), or on ``section``."""
    if section is None:
        return locate_fold(P, u, p, "L", v0=v, tol=tol)
    return fold_on_section(P, u, p, ("L", name), section, v0=v, tol=tol)


def _neighbours(kept, k):
    """The points around ``k`` on the same coarse mesh (for a secant)."""
    lo = k - 1 if k > 0 and kept[k - 1].problem is kept[k].problem else k
    hi = k + 1 if k + 1 < len(kept) and kept[k + 1].problem is kept[k].problem else k
    if lo == hi:
        raise ParameterError("a coarse fold-curve point without a neighbour on its mesh")
    return lo, hi


#: The cusp of a refined curve is located on the fine mesh until the second
#: parameter (b/a or a/R) changes by less than this between two corrections
#: and the fold coefficient's sign change is bracketed, in at most
#: :data:`CUSP_ITERATIONS` fold corrections, each at most
#: :data:`CUSP_STEP` (tip deflection / a) from a fold point already found.
CUSP_TOL = 2e-4
CUSP_ITERATIONS = 8
CUSP_STEP = 0.01


def _cusp_by_coefficient(points, j, tol):
    """The cusp of a refined curve, where the fold coefficient ``a`` vanishes.

    ``points``: the refined points (:class:`_Kept`, in the order of the
    curve); the cusp is looked for only if their ``a`` changes sign.  Along
    the curve the vertical deflection of the tip ``d`` is a regular
    parameter also through the cusp (neither L nor the second parameter is),
    so the fine fold points are computed on sections ``d = d_k``
    (:func:`~skfem_sheet.engine.fold_on_section`, L and the second parameter
    free), each predicted linearly in ``d`` from the two fold points nearest
    to ``d_k``, with ``d_k`` the secant zero of ``a(d)`` (inside the
    bracket of the sign change once two points close enough bracket it, and
    at most :data:`CUSP_STEP` from a point found).  The curve's points next
    to the cusp may all lie on one side of it (the coarse cusp is not the
    fine one), hence the steps rather than an interpolation across the
    sign change.  Stops when the second parameter changes by less than
    :data:`CUSP_TOL` between two corrections with the sign change bracketed
    (it is stationary at the cusp along the curve: its error is second order
    in that of ``d``).

    Returns ``(cusp or None, factorisations)``; the cusp is the fold point of
    smallest ``|a|``.
    """
    name, key = _SECOND[j]
    a = [q.a for q in points]
    change = [k for k in range(len(points) - 1) if a[k] * a[k + 1] < 0]
    if not change:
        return None, 0
    k = change[0]
    # the fold points near the cusp on one fine mesh (of the point of the
    # sign change with the smaller |a|), sorted by tip deflection
    home = points[k] if abs(a[k]) < abs(a[k + 1]) else points[k + 1]
    P = home.problem
    known = sorted(((q.tip, q.a, q.u, q.p, q.v) for q in points if q.problem is P),
                   key=lambda r: r[0])
    if len(known) < 2:
        return None, 0
    e = np.zeros_like(home.u)
    e[P._tip] = 1.0
    scale = P.inner(e, e)
    f0, spent = P.refactorizations, 0
    best, last_q, step = None, None, CUSP_STEP
    for _ in range(CUSP_ITERATIONS):
        d = np.array([r[0] for r in known])
        av = np.array([r[1] for r in known])
        # the secant zero of a(d): through the bracketing pair closest
        # together, else through the two points of smallest |a|
        pairs = [(i, i + 1) for i in range(len(known) - 1) if av[i] * av[i + 1] < 0]
        if pairs:
            lo, hi = min(pairs, key=lambda ij: d[ij[1]] - d[ij[0]])
        else:
            lo, hi = sorted(np.argsort(np.abs(av))[:2])
        if av[hi] == av[lo]:
            break
        target = d[lo] - av[lo] * (d[hi] - d[lo]) / (av[hi] - av[lo])
        if pairs:  # strictly inside the bracket
            target = float(np.clip(target, d[lo] + 0.05 * (d[hi] - d[lo]),
                                   d[hi] - 0.05 * (d[hi] - d[lo])))
        near = int(np.argmin(np.abs(d - target)))
        target = float(np.clip(target, d[near] - step, d[near] + step))
        # linear prediction in d from the two known points nearest to target
        i1, i2 = sorted(np.argsort(np.abs(d - target))[:2])
        w = (target - d[i1]) / (d[i2] - d[i1])
        r1, r2 = known[i1], known[i2]
        v2 = r2[4] if P.inner(r1[4], r2[4]) >= 0 else -r2[4]
        u = r1[2] + w * (r2[2] - r1[2])
        p = r1[3] + w * (r2[3] - r1[3])
        fold, res = fold_on_section(P, u, p, ("L", name),
                                    (e, np.zeros_like(p), scale * target),
                                    v0=r1[4] + w * (v2 - r1[4]), tol=tol)
        spent += res.stats.factorizations if fold is None else fold.stats.factorizations
        if fold is None:
            step = 0.5 * min(step, abs(target - d[near]) or step)
            if step < 1e-4:
                break
            continue
        if best is None or abs(fold.a) < abs(best.a):
            best = fold
        tip = float(fold.u[P._tip])
        known = sorted([*known, (tip, float(fold.a), fold.u, np.array(fold.p), fold.v)],
                       key=lambda r: r[0])
        q = float(fold.p[j])
        bracketed = any(r[1] * fold.a <= 0 for r in known)
        if fold.a == 0 or (bracketed and last_q is not None and abs(q - last_q) < CUSP_TOL):
            break
        last_q = q
    spent += P.refactorizations - f0
    if best is None:
        return None, spent
    return {key: float(best.p[j]), "length": float(best.p[0])}, spent


def _fine_cusp(points, j):
    """The cusp of refined points: the vertex of the parabola through the
    three points of the smallest second parameter, in the tip deflection
    (along the curve the second parameter has a regular minimum at the cusp,
    where its projection turns back); None if that minimum is at an end."""
    if len(points) < 3:
        return None
    d = np.array([q["tip"] for q in points])
    b = np.array([q["p"][j] for q in points])
    L = np.array([q["p"][0] for q in points])
    k = int(np.argmin(b))
    if k == 0 or k == len(points) - 1:
        return None
    sl = slice(k - 1, k + 2)
    cb, cL = np.polyfit(d[sl], b[sl], 2), np.polyfit(d[sl], L[sl], 2)
    d_star = -cb[1] / (2 * cb[0]) if cb[0] > 0 else d[k]
    d_star = float(np.clip(d_star, min(d[k - 1], d[k + 1]), max(d[k - 1], d[k + 1])))
    return {_SECOND[j][1]: float(np.polyval(cb, d_star)), "length": float(np.polyval(cL, d_star))}


class _Snapshot:
    """What :func:`skfem_sheet.io.state_fields` reads of a problem, for one
    state: a series frame then holds vertex fields, not the mapped problem's
    basis data."""

    def __init__(self, problem, w):
        self.sheet_mesh, self.length = problem.sheet_mesh, problem.length
        U, p = problem.split(w)
        self._split = (np.array(U), np.array(p))
        self._pressure = np.array(problem.paper_pressure(w))
        self._psi = np.array(problem.energy_density(w))

    def split(self, w):
        return self._split

    def paper_pressure(self, w):
        return self._pressure

    def energy_density(self, w):
        return self._psi


def _add_frame(series, P, u, p):
    """One fold-curve point into ``series`` (time: its index)."""
    w = P.full(u, p)
    series.add(len(series), _Snapshot(P.problem(p), w), w, length=float(p[0]),
               tip_width=float(p[1]), curvature=float(P._kappa(p)))


class _SeriesCollector:
    """The direct trace's points into a series (the point a remesh repeats
    is dropped, as the trace drops it)."""

    def __init__(self, series):
        self.series = series

    def __call__(self, P, pt, u, v):
        _add_frame(self.series, P, u, pt.p)

    def drop_last(self):
        if len(self.series):
            self.series.frames.pop()


def _run(curvature, tip_width, j, bounds_j, *, hmax, coarse_hmax, fine_points, series,
         check_inertia, progress, **kw):
    """A trace at ``hmax``, or coarse to fine (see :func:`trace_fold_curve`)."""
    hmax = check_range("hmax", hmax, 0.02, 0.5)
    coarse_levels = []
    if coarse_hmax is not None:
        values = np.atleast_1d(np.asarray(coarse_hmax, dtype=object))
        if not 1 <= len(values) <= 4:
            raise ParameterError(f"coarse_hmax must be a mesh size or up to four, got "
                                 f"{coarse_hmax!r}")
        coarse_levels = sorted((check_range("coarse_hmax", x, 0.02, 0.5) for x in values),
                               reverse=True)
        coarse_hmax = coarse_levels[0]
    if coarse_hmax is None or coarse_hmax <= hmax:
        collect = None if series is None else _SeriesCollector(series)
        return _trace(curvature, tip_width, j, bounds_j, hmax=hmax, check_inertia=check_inertia,
                      progress=progress, collect=collect, **kw)
    if isinstance(fine_points, bool) or not isinstance(fine_points, (int, np.integer)) \
            or not 2 <= fine_points <= 200:
        raise ParameterError(f"fine_points must be an integer in [2, 200], got {fine_points!r}")
    t0 = time.perf_counter()
    kept = _Collector()
    coarse = _trace(curvature, tip_width, j, bounds_j, hmax=coarse_hmax, check_inertia=0,
                    progress=progress, collect=kept, **kw)
    info = dict(hmax=hmax, coarse_hmax=coarse_hmax, coarse_points=len(coarse.points),
                coarse_factorizations=coarse.factorizations)
    if not coarse.bistable or len(kept.points) < 2:
        return dataclasses.replace(coarse, **info, wall_time_s=time.perf_counter() - t0,
                                   reason=f"{coarse.reason} (at the coarse mesh, "
                                          f"hmax {coarse_hmax:g})".strip())
    name, key = _SECOND[j]
    kw_mesh = {k: kw[k] for k in ("thickness", "modulus", "layers", "solver")}
    levels = [h for h in sorted(set(coarse_levels[1:]), reverse=True) if h > hmax] + [hmax]
    # the last point is a fold in L at the start value only if the coarse curve came back
    points, chosen = kept.points, _select(kept.points, fine_points)
    sides = (kept.points[0].side, kept.points[-1].side)  # the kinds of the two ends
    stages, failures, meshes, spent, ends = [], [], 0, 0, None
    for h in levels:
        fine = _FineMeshes(curvature, h, 1.0 if j == 1 else tip_width, kw_mesh)
        ci = check_inertia if h == hmax else 0
        pts, failed, lost = _refine(points, chosen, j, fine, FINE_TOLERANCES, ci,
                                    last_is_end=coarse.completed, ends=ends)
        # an end not refined (outside the fine fold system's basin): the curve
        # continued on this mesh from the refined point next to it instead
        refilled = 0
        for last in ((False, True) if coarse.completed else (False,)):
            if len(pts) < 2 or (pts[-1] if last else pts[0])["end"]:
                continue
            new, extra, why = _continue_to_end(pts, last, sides[int(last)], j, bounds_j,
                                               kw["length_range"], FINE_TOLERANCES, ci)
            lost += extra
            refilled += len(new)
            if new:
                pts = pts + new if last else new + pts
            else:
                failed.append(why)
        failures += [f"hmax {h:g}: {f}" for f in failed]
        spent += lost
        meshes += len(fine.meshes)
        per = [q["factorizations"] for q in pts]
        stages.append(dict(hmax=h, points=len(pts), failed=len(failed), refilled=refilled,
                           factorizations=int(sum(per)) + lost,
                           factorizations_per_point=float(np.median(per)) if per else None))
        for P in {id(q.problem): q.problem for q in points}.values():
            P.release()  # the coarser level's factorisations and mapped meshes
        # the next level refines this one's points except those of a
        # continuation (they serve as neighbours; its end is refined)
        points = [q.pop("kept") for q in pts]
        chosen = [k for k, q in enumerate(pts) if not q["refill"] or h == hmax]
        ends = {n for n, k in enumerate(chosen) if pts[k]["end"]}
        if len(points) < 2:
            break
    del kept
    if series is not None:
        for q in points:
            _add_frame(series, q.problem, q.u, q.p)
    cusp, located, cusp_cost = None, "", 0
    if stages[-1]["hmax"] == hmax and len(points) == len(pts):
        cusp, cusp_cost = _cusp_by_coefficient(points, j, FINE_TOLERANCES)
        located = "fold coefficient on the fine mesh" if cusp is not None else ""
    del points
    # complete: both ends refined at hmax (a point lost on the way only thins the curve)
    completed = coarse.completed and len(pts) >= 2 and pts[0]["end"] and pts[-1]["end"]
    reason = "; ".join(failures) if failures else coarse.reason
    if failures:
        reason = f"{len(failures)} point(s) not refined: {reason}"
    out_points = tuple({key: float(q["p"][j]), "length": float(q["p"][0]),
                        "kind": _kind(q["side"])} for q in pts)
    if pts and pts[0]["end"]:  # the ends lie on the start value exactly
        out_points[0][key] = float(bounds_j[1])
        if completed:
            out_points[-1][key] = float(bounds_j[1])
    if cusp is None:
        cusp = _fine_cusp(pts, j)
        located = "refined points" if cusp is not None else ""
    per_point = [q["factorizations"] for q in pts]
    total = (coarse.factorizations + int(sum(st["factorizations"] for st in stages))
             + cusp_cost)
    return FoldCurve(curvature, out_points, cusp, int(total),
                     float(np.median(per_point)) if per_point else float("nan"),
                     time.perf_counter() - t0, hmax, completed, reason,
                     tuple(q["negative"] for q in pts), tuple(q["crossing"] for q in pts),
                     None, key, tip_width, remeshes=coarse.remeshes + len(fine.meshes),
                     meshes=coarse.meshes + tuple(P.mesh_parameters for P in fine.meshes),
                     cusp_located=located, cusp_factorizations=cusp_cost,
                     coarse_hmax=coarse_hmax, coarse_points=len(coarse.points),
                     coarse_factorizations=coarse.factorizations, stages=tuple(stages))
