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
from .continuation import follow_path
from .discretisation import TaylorHoodSpace
from .engine import FoldCurve as EngineFoldCurve
from .engine import Problem, Tolerances, fold_curve, locate_fold, natural
from .linalg import make_linear_solver
from .mesh import SheetMesh, sheet_mesh
from .newton import Stats
from .params import ParameterError, Sheet, check_range
from .problem import SheetProblem

__all__ = ["MIN_SQUEEZE", "REMESH_SQUEEZE", "REMESH_STRETCH", "TOLERANCES", "FoldCurve",
           "SheetFoldProblem", "default_start_length", "trace_curvature_fold_curve",
           "trace_fold_curve"]

#: Smallest ratio of the tip width to the mesh's tip width (y squeeze at the tip).
MIN_SQUEEZE = 0.15

#: The trace remeshes where the mapped mesh is stretched in x by more than
#: this factor (or compressed by its inverse) ...
REMESH_STRETCH = 1.35
#: ... or its tip width is below this fraction of the mesh's (or above its inverse).
REMESH_SQUEEZE = 0.5
#: Largest number of remeshes of one trace.
MAX_REMESHES = 40

#: The corrector's stopping rule for the sheet.  The sharp test is on the
#: correction (displacements to 1e-6 of a; L and b to 1e-6): the residual of
#: a thin sheet is dominated by its membrane stiffness, so that a correction
#: of 1e-6 can still leave a residual of 1e-3 of the weight, which the next
#: (quadratic) step removes; the residual bound only guards against a small
#: correction far from equilibrium.
TOLERANCES = Tolerances(rtol=5e-3, utol=1e-6, max_iterations=10, max_correction=0.3)


# ----------------------------------------------------------------------------
# the adapter: every use of the sheet's model, mesh and solver interfaces
# ----------------------------------------------------------------------------
class _Sheet:
    """The sheet's interfaces as this module uses them (model, mesh, linear
    solvers, load paths, stability), in one place."""

    def __init__(self, sheet, hmax, layers, solver):
        self.base = SheetProblem(sheet, sheet_mesh(sheet, hmax, layers, half=True))
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

    def at(self, length, tip_width):
        """The base problem on its mesh mapped to ``(length, tip_width)``.

        The same construction as ``SheetProblem.with_length`` (a copy sharing
        the dof maps, the sparsity pattern and the work arrays, with the
        geometric data recomputed), for the map ``x' = x L / L_m``,
        ``y' = y p_b(xi) / p_{b_m}(xi)``: the mapped vertices give a mesh with
        the same tetrahedra, whose basis gradients, weights, nodes and loads
        replace the base's.
        """
        b0 = self.base
        m0 = b0.sheet_mesh
        P = m0.mesh.p
        xi = P[0] / m0.length
        q = (1.0 + (tip_width - 1.0) * xi) / (1.0 + (m0.tip_width - 1.0) * xi)
        mesh = SheetMesh(mesh=MeshTet(np.vstack([xi * length, P[1] * q, P[2]]), m0.mesh.t),
                         length=length, tip_width=tip_width, thickness=m0.thickness,
                         hmax=m0.hmax, layers=m0.layers, half=m0.half, refine=m0.refine)
        # the same tetrahedra, so the same dof numbering and pattern: a fresh
        # (uncached) space on the mapped mesh, sharing the base's assembler
        space = TaylorHoodSpace.build(mesh, b0.quadrature_order)
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
                 thickness=0.03, modulus=735.0, layers=None, solver="auto"):
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
        self._solvers = [s.new_solver(), s.new_solver()]
        self._generation = [0, 0]
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
            if len(self._problems) > 12:
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
        return transfer(self.problem(p), w, other.problem(p))[other._sheet.free]

    # -- protocol ------------------------------------------------------------
    def admissible_parameters(self, p) -> bool:
        """Within the mesh's distortion limits (stretch in [1/2, 2], tip
        width in (0, 1.5 b_m] and not squeezed below ``MIN_SQUEEZE``) and a
        curvature in (0, 2 pi)."""
        s, q = self.distortion(p)
        return bool(0.5 <= s <= 2.0 and MIN_SQUEEZE <= q <= 1.5 and p[1] > 0
                    and 0 < self._kappa(p) < 2 * np.pi)

    def residual(self, u, p):
        if not self.admissible_parameters(p):
            return np.full(len(u), np.nan)  # inadmissible: the corrector halves the step
        r, jmin = self._sheet.residual(self.problem(p), self.full(u, p))
        if not jmin > 0:
            return np.full(len(u), np.nan)
        return r[self._sheet.free]

    def jacobian(self, u, p):
        return self._sheet.tangent(self.problem(p), self.full(u, p))

    def factorize(self, J):
        slot = self._next
        self._next = 1 - slot
        self._sheet.factorize(self._solvers[slot], J)
        self._generation[slot] += 1
        # (the inertia only needs the dof layout, the same for every (L, b))
        return _Factorization(self, slot, J, self._sheet.base)

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
    #: How the cusp was found: "fold coefficient" (its sign change, located
    #: by regula falsi), "turning point" (where the second parameter turns
    #: back, if the sign change was not seen), or "" (no cusp).
    cusp_located: str = ""

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
                   standout_length=self.standout_length, popup_length=self.popup_length)
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
                     progress: bool = False) -> FoldCurve:
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
    return _trace(curvature, 1.0, 1, (min_tip_width, 1.0), hmax=hmax, start_length=start_length,
                  length_range=length_range, thickness=thickness, modulus=modulus,
                  layers=layers, solver=solver, ds=ds, ds_max=ds_max,
                  check_inertia=check_inertia, mesh_length=mesh_length,
                  max_points=max_points, progress=progress)


def trace_curvature_fold_curve(tip_width: float = 1.0, curvature: float = 2.5,
                               hmax: float = 0.1, *, min_curvature: float = 0.3,
                               start_length=None, length_range=(0.6, 2.4),
                               thickness: float = 0.03, modulus: float = 735.0, layers=None,
                               solver: str = "auto", ds: float = 0.05, ds_max: float = 0.4,
                               check_inertia=10, mesh_length=None, max_points: int = 400,
                               progress: bool = False) -> FoldCurve:
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
    return _trace(curvature, tip_width, 2, (min_curvature, curvature), hmax=hmax,
                  start_length=start_length, length_range=length_range, thickness=thickness,
                  modulus=modulus, layers=layers, solver=solver, ds=ds, ds_max=ds_max,
                  check_inertia=check_inertia, mesh_length=mesh_length,
                  max_points=max_points, progress=progress)


_SECOND = {1: ("b", "tip_width"), 2: ("a/R", "curvature")}


class _Maker:
    """Fresh fold problems of one trace (same sheet and discretisation, another mesh)."""

    def __init__(self, curvature, hmax, thickness, modulus, layers, solver):
        self.args = (curvature, hmax)
        self.kw = dict(thickness=thickness, modulus=modulus, layers=layers, solver=solver)
        self.count = 0

    def __call__(self, mesh_length, mesh_tip_width):
        self.count += 1
        return SheetFoldProblem(*self.args, mesh_length=mesh_length,
                                mesh_tip_width=min(1.0, mesh_tip_width), **self.kw)

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
            continue
        last = branch.points[-1]
        if stop >= hi - 1e-12:
            return P, None, nfact, ""
        P, u, _ = make.remesh(P, last.u, last.p)
        p = last.p
    return P, None, nfact, f"more than {MAX_REMESHES} remeshes"


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
           progress):
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
                             remeshes=make.count - 1)
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
                             max_points=max(2, max_points - len(points)), keep_states=True,
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
                     remeshes=make.count - 1, cusp_located=located)

