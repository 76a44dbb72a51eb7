"""The sheet as an engine problem in its shape: length, tip width and clamp curvature.

:class:`SheetShapeProblem` is the one adapter of the sheet at full load to
the continuation engine in the parameters ``(L, b, a/R)`` (length, tip width
and clamp curvature, any of them): the continuations in L and a/R of
:mod:`skfem_sheet.bistability`, the fold curves of :mod:`skfem_sheet.foldcurve`
and the paths of :mod:`skfem_sheet.paths` run on it.  It is a
:class:`~skfem_sheet.sheet_engine.SheetEngineProblem` (state, norms, the one
lazy refactorisation); what it adds is the shape:

- **One mesh, carried to nearby shapes**, with the same tetrahedra, dof
  numbering and sparsity pattern, so that a nodal state at one shape is
  valid at the next: ``geometry="stretch"`` (the length only,
  :meth:`~skfem_sheet.problem.SheetProblem.with_length`; ``dR/dL`` a central
  difference) or ``"map"`` (length and tip width, ``y' = y p_b(xi) /
  p_{b_m}(xi)``, :meth:`~skfem_sheet.discretisation.TaylorHoodSpace.mapped`;
  forward differences, ``fd_one_sided``).  The two agree to round-off where
  both apply.
- **One remesh rule**: beyond a stretch of :data:`REMESH_STRETCH` in x (or
  its inverse) or a tip squeezed below :data:`REMESH_SQUEEZE` (or widened
  beyond its inverse), the sheet is meshed afresh at the current shape and
  the state transferred (:func:`~skfem_sheet.analyses.transfer.transfer`), in
  place (:meth:`SheetShapeProblem.remesh`) or as a new problem
  (:meth:`SheetShapeProblem.remeshed`).

The limits (1.35, 0.5): a stretched mesh carries a discretisation error of
its own that grows with the stretch, kept at about the fold resolution of
:func:`~skfem_sheet.bistability.fold_lengths`, while each remesh costs a
mesh, a space, an assembler and a state that must converge again
(``docs/decisions.md``, "The remesh limits"); the map is admissible
(:meth:`SheetShapeProblem.admissible_parameters`) down to :data:`MIN_SQUEEZE`.
"""
from __future__ import annotations

from collections import OrderedDict

import numpy as np
from skfem import MeshTet

from .analyses.transfer import transfer
from .continuation import follow_path
from .discretisation import TaylorHoodSpace
from .engine import Tolerances
from .linalg import make_linear_solver
from .mesh import SheetMesh, sheet_mesh
from .newton import Stats
from .params import ParameterError, Sheet
from .problem import SheetProblem
from .sheet_engine import SheetEngineProblem, SolverSlot

__all__ = ["MIN_SQUEEZE", "PARAMETERS", "REMESH_SQUEEZE", "REMESH_STRETCH", "TOLERANCES",
           "SheetFoldProblem", "SheetShapeProblem", "needs_remesh", "remesh_pieces"]

#: The shape parameters, in the order of a full parameter vector.
PARAMETERS = ("L", "b", "a/R")

#: Remesh where the mesh is stretched in x by more than this factor (or
#: compressed by its inverse); see the module docstring for the reason.
REMESH_STRETCH = 1.35
#: ... or its tip width is below this fraction of the mesh's (or above its inverse).
REMESH_SQUEEZE = 0.5
#: Smallest ratio of the tip width to the mesh's tip width the map admits.
MIN_SQUEEZE = 0.15

#: The corrector's stopping rule for the sheet in its shape (fold curves and
#: paths).  The sharp test is on the correction (displacements to 1e-6 of a;
#: L and b to 1e-6): the residual of a thin sheet is dominated by its membrane
#: stiffness, so that a correction of 1e-6 can still leave a residual of 1e-3
#: of the weight, which the next (quadratic) step removes; the residual bound
#: only guards against a small correction far from equilibrium.
TOLERANCES = Tolerances(rtol=5e-3, utol=1e-6, max_iterations=10, max_correction=0.3)


def needs_remesh(mesh_parameters, length: float, tip_width=None) -> bool:
    """Whether the mesh made at ``mesh_parameters = (L_m, b_m)`` must be
    remeshed to serve ``(length, tip_width)`` (the remesh rule; without a
    tip width, the stretch alone).

    Examples
    --------
    >>> needs_remesh((1.0, 1.0), 1.3, 1.0), needs_remesh((1.0, 1.0), 1.4, 1.0)
    (False, True)
    >>> needs_remesh((1.0, 1.0), 1.0, 0.45), needs_remesh((1.0, 0.0), 1.3)
    (True, False)
    """
    s = length / mesh_parameters[0]
    if tip_width is None:
        return not 1 / REMESH_STRETCH <= s <= REMESH_STRETCH
    q = tip_width / mesh_parameters[1]
    return not (1 / REMESH_STRETCH <= s <= REMESH_STRETCH
                and REMESH_SQUEEZE <= q <= 1 / REMESH_SQUEEZE)


def remesh_pieces(a, b) -> int:
    """Pieces of the straight segment ``a -> b`` in ``(L, b, ...)`` small
    enough for one mesh each under the remesh rule (a mesh made in the middle
    of a piece serves all of it).

    Examples
    --------
    >>> remesh_pieces((1.0, 1.0), (1.3, 1.0)), remesh_pieces((1.0, 1.0), (2.0, 0.5))
    (1, 3)
    """
    n = 1
    for i, limit in ((0, REMESH_STRETCH), (1, 1 / REMESH_SQUEEZE)):
        ratio = max(a[i], b[i]) / min(a[i], b[i])
        n = max(n, int(np.ceil(np.log(ratio) / np.log(limit) - 1e-9)))
    return n


class SheetShapeProblem(SheetEngineProblem):
    """The sheet at full load as an engine problem in some of ``(L, b, a/R)``.

    Parameters
    ----------
    sheet : Sheet
        The sheet the mesh is made for (its length and tip width are
        ``(L_m, b_m)``), and the values of the parameters not in
        ``parameters`` (its thickness and modulus throughout).
    hmax : float
    parameters : tuple of str
        The names of the entries of ``p``, in the order of
        :data:`PARAMETERS`: ``("L",)``, ``("a/R",)``, or ``("L", "b",
        "a/R")`` (then a vector ``(L, b)`` means the sheet's curvature).
    geometry : {"map", "stretch"}
        How the mesh is carried to ``(L, b)`` (module docstring); "stretch"
        carries the length only.
    layers, half, refine
        Of the mesh (:func:`~skfem_sheet.mesh.sheet_mesh`).
    solver : str
        Linear-solver back-end (:func:`~skfem_sheet.linalg.make_linear_solver`).
    solver_slots : int
        Factorisations held at once (1 bounds the memory to one factor; a
        solve with an older factorisation then refactorises it).
    cache : int
        Problems at other shapes kept (each holds the basis data of the mesh).
    residual_memory : int
        Residuals kept.

    Examples
    --------
    >>> P = SheetShapeProblem(Sheet(length=0.8, curvature=2.0), 0.25, parameters=("L",),
    ...                       geometry="stretch")
    >>> u, _ = P.solve_state([0.8])
    >>> round(P.deflection(u, [0.8]), 4)
    -0.0066
    >>> P.needs_remesh([1.05]), P.needs_remesh([1.1])
    (False, True)
    """

    def __init__(self, sheet: Sheet, hmax: float = 0.1, *, parameters=PARAMETERS,
                 geometry: str = "map", layers=None, half: bool = True, refine: int = 0,
                 solver: str = "auto", solver_slots: int = 1, cache: int = 12,
                 residual_memory: int = 1):
        parameters = tuple(parameters)
        if parameters not in (("L",), ("a/R",), PARAMETERS):
            raise ParameterError(f"parameters must be ('L',), ('a/R',) or {PARAMETERS}, got "
                                 f"{parameters!r}")
        if geometry not in ("map", "stretch"):
            raise ParameterError(f"geometry must be 'map' or 'stretch', got {geometry!r}")
        if geometry == "stretch" and "b" in parameters:
            raise ParameterError("the stretch carries the length only: use geometry='map' for b")
        if geometry == "map" and getattr(sheet, "planform", None) is not None:
            raise ParameterError("the map in y is that of a trapezoid: a sheet with a "
                                 "planform can only be stretched (geometry='stretch')")
        self.parameter_names = parameters
        self.geometry = geometry
        #: Forward differences in the parameters (the fold system's, on the map).
        self.fd_one_sided = geometry == "map"
        self.hmax, self.layers, self.half, self.refine = hmax, layers, bool(half), int(refine)
        self.solver_name = solver
        self.length, self.tip_width = float(sheet.length), float(sheet.tip_width)
        self.curvature = float(sheet.curvature)
        self._cache = int(cache)
        self._problems = OrderedDict()
        base = self._build(sheet)
        super().__init__(base, [self.new_solver(base) for _ in range(int(solver_slots))],
                         residual_memory=residual_memory)
        self.base = base

    def _build(self, sheet):
        # the mesh, its space and its assembler this problem's own (freed
        # with it): a continuation's meshes are not needed by anyone else
        return SheetProblem(sheet, sheet_mesh(sheet, self.hmax, self.layers, half=self.half,
                                              refine=self.refine))

    def new_solver(self, base=None):
        """A fresh linear solver for this problem's systems."""
        solver = make_linear_solver(self.solver_name)
        if getattr(solver, "needs_layout", False):
            solver.attach((base or self.base).saddle_point_layout())
        return solver

    # -- the shape at p --------------------------------------------------------
    def values(self, p):
        """``(L, b, a/R)`` at ``p`` (the sheet's values where ``p`` has none)."""
        out = {"L": self.length, "b": self.tip_width, "a/R": self.curvature}
        for name, x in zip(self.parameter_names, p):
            out[name] = float(x)
        return out["L"], out["b"], out["a/R"]

    def kappa(self, p) -> float:
        return self.values(p)[2]

    @property
    def mesh_parameters(self):
        """``(L_m, b_m)`` of the mesh."""
        m = self.base.sheet_mesh
        return float(m.length), float(m.tip_width)

    def distortion(self, p):
        """``(x stretch, y squeeze at the tip)`` of the mesh at ``p``."""
        L, b, _ = self.values(p)
        m = self.base.sheet_mesh
        return L / m.length, b / m.tip_width

    def needs_remesh(self, p) -> bool:
        """Whether ``p`` lies beyond the remesh rule's limits for this mesh."""
        L, b, _ = self.values(p)
        return needs_remesh(self.mesh_parameters, L, None if self.geometry == "stretch" else b)

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

    def admissible_parameters(self, p) -> bool:
        """Where the map is valid: stretch in [1/2, 2], tip width in (0, 1.5
        b_m] and not squeezed below :data:`MIN_SQUEEZE`, a curvature in (0, 2
        pi).  The stretch: a stretch in [1/2, 2] and a curvature in [0, 2 pi)
        (a trial step of a fold system far off, e.g. to a negative length,
        gets a NaN residual and is halved, instead of an error from the
        mesh)."""
        if self.geometry == "stretch":
            s = self.values(p)[0] / self.base.sheet_mesh.length
            kappa = self.values(p)[2]
            return bool(0.5 <= s <= 2.0 and 0 <= kappa < 2 * np.pi)
        s, q = self.distortion(p)
        L, b, kappa = self.values(p)
        return bool(0.5 <= s <= 2.0 and MIN_SQUEEZE <= q <= 1.5 and b > 0
                    and 0 < kappa < 2 * np.pi)

    def at(self, length: float, tip_width: float, bases: bool = False):
        """The base problem on its mesh carried to ``(length, tip_width)``: a
        copy sharing the dof maps, the sparsity pattern and the work arrays,
        with the geometric data of the stretched (``geometry="stretch"``:
        :meth:`~skfem_sheet.problem.SheetProblem.with_length`) or mapped mesh
        (:meth:`~skfem_sheet.discretisation.TaylorHoodSpace.mapped`).
        ``bases=True`` (the map): a space built afresh on the mapped mesh,
        with scikit-fem bases (needed to interpolate a state on it,
        :func:`~skfem_sheet.analyses.transfer.transfer`; slower)."""
        b0 = self.base
        if self.geometry == "stretch":
            return b0.with_length(length)
        m0 = b0.sheet_mesh
        P = m0.mesh.p
        xi = P[0] / m0.length
        q = (1.0 + (tip_width - 1.0) * xi) / (1.0 + (m0.tip_width - 1.0) * xi)
        mesh = SheetMesh(mesh=MeshTet(np.vstack([xi * length, P[1] * q, P[2]]), m0.mesh.t),
                         length=length, tip_width=tip_width, thickness=m0.thickness,
                         hmax=m0.hmax, layers=m0.layers, half=m0.half, refine=m0.refine)
        # the same tetrahedra, so the same dof numbering and pattern: the base's
        # space mapped element by element (or, with bases, a fresh space on the
        # mapped mesh), sharing the base's assembler
        space = (TaylorHoodSpace.build(mesh, b0.quadrature_order) if bases
                 else b0.space.mapped(mesh))
        # the Sheet only carries metadata here (b may exceed 1 by a difference step)
        sheet = b0.sheet.replace(length=length, tip_width=min(max(tip_width, 0.0), 1.0))
        return SheetProblem(sheet, mesh, b0.quadrature_order, space=space,
                            assembler=b0.assembler)

    def problem(self, p):
        """The problem at ``p`` (the last :attr:`cache` are kept)."""
        L, b, _ = self.values(p)
        key = (L, b)
        prob = self._problems.get(key)
        if prob is None:
            if self.geometry == "map" and not (L > 0 and b > 0):
                raise ParameterError(f"(L, b) must be positive, got {key}")
            prob = self.at(L, b)
            self._problems[key] = prob
            if len(self._problems) > self._cache:
                self._problems.popitem(last=False)
        return prob

    def problem_at(self, p):
        return self.problem(p)

    # -- protocol ------------------------------------------------------------
    def evaluate_residual(self, u, p):
        if not self.admissible_parameters(p):
            return np.full(len(u), np.nan)  # inadmissible: the corrector halves the step
        return super().evaluate_residual(u, p)

    def dresidual(self, u, p, i):
        """``dR/dp_i``: on the map a forward difference from the residual at
        ``p`` (one residual on one mapped mesh); on the stretch a central
        difference in L on the stretch, exact in a/R."""
        if self.geometry == "map":
            p = np.asarray(p, dtype=float)
            h = self.fd_parameter_step * max(1.0, abs(p[i]))
            q = p.copy()
            q[i] += h
            r0 = self.residual(u, p)
            return (self.residual(u, q) - r0) / h
        if self.parameter_names[i] == "a/R":
            return self.clamp_rate_residual(u, p)
        prob, w = self.problem(p), self.full(u, p)
        eps = 1e-6 * prob.length
        rp, _ = prob.with_length(prob.length + eps).residual(w, 1.0)
        rm, _ = prob.with_length(prob.length - eps).residual(w, 1.0)
        return ((rp - rm) / (2 * eps))[self.free]

    # -- meshes ----------------------------------------------------------------
    def remesh(self, u, p):
        """Mesh afresh at ``p``'s shape, in place (with a fresh solver); ``u``
        interpolated onto the new mesh is returned."""
        old = self.problem(p)
        w = self.full(u, p)
        base = self._build(old.sheet)
        self.base = base
        self._slots = [SolverSlot(self.new_solver(base)) for _ in self._slots]
        self._next = 0
        self._problems.clear()
        self.set_layout(base)
        return transfer(old, w, base)[self.free]

    def transferred(self, other, u, p, state=True):
        """``u`` (free dofs of this problem at ``p``) interpolated onto ``other``
        at ``p``; ``state=False``: a vector with zero clamp values (a null vector)."""
        if state:
            w = self.full(u, p)
        else:
            w = np.zeros(self.ndof)
            w[self.free] = u
        L, b, _ = self.values(p)
        # interpolation on the map needs scikit-fem bases on the mapped mesh
        old = self.at(L, b, bases=True) if self.geometry == "map" else self.problem(p)
        return transfer(old, w, other.problem(p))[other.free]

    def release(self):
        """Drop the factorisations and the problems at other shapes (memory);
        the problem stays usable (they are made again when needed)."""
        for slot in self._slots:
            slot.solver = self.new_solver()
            slot.generation += 1
        self._problems.clear()
        self._residuals = []

    # -- states on a load path -------------------------------------------------
    def solve_state(self, p, path="curvature-first"):
        """State at ``p`` along a load path, on a fresh solver (the held
        factorisations stay): ``(u, factorisations)``; raises ParameterError
        if it fails."""
        stats = Stats()
        out = follow_path(self.problem(p), path, self.kappa(p), self.new_solver(), stats=stats)
        if not out.converged:
            raise ParameterError(f"the sheet at (L, b, a/R) = {tuple(p)} could not be solved "
                                 f"along {path}: {out.reason}")
        return out.w[self.free], stats.factorizations

    def along_path(self, p, path, stats=None):
        """The load path at ``p`` on :attr:`solver`: the result of
        :func:`~skfem_sheet.continuation.follow_path` (check ``converged``);
        the solver then holds the tangent at its end state, which
        :meth:`held` takes."""
        out = follow_path(self.problem(p), path, self.kappa(p), self.solver,
                          stats=stats if stats is not None else Stats())
        self.solver_used()
        return out


class SheetFoldProblem(SheetShapeProblem):
    """The half sheet at full load on the map, in ``p = (L, b, a/R)``: the
    problem of fold curves and paths.

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
    solver_slots : int
        Factorisations held at once.
    cache : int
        Mapped problems kept.
    refine : int
        Nested refinements of the mesh (:func:`~skfem_sheet.mesh.sheet_mesh`).

    Examples
    --------
    >>> P = SheetFoldProblem(2.5, hmax=0.25)
    >>> P.distortion([1.56, 0.5]), P.admissible_parameters([1.56, 0.1])
    ((1.2, 0.5), False)
    >>> u = np.zeros(P.n)
    >>> bool(np.all(np.isfinite(P.residual(u, [1.3, 0.8, 2.0]))))
    True
    """

    def __init__(self, curvature, hmax=0.1, mesh_length=1.3, mesh_tip_width=1.0,
                 thickness=0.03, modulus=735.0, layers=None, solver="auto", solver_slots=2,
                 cache=12, refine=0):
        sheet = Sheet(length=mesh_length, tip_width=mesh_tip_width, curvature=curvature,
                      thickness=thickness, modulus=modulus)
        super().__init__(sheet, hmax, parameters=PARAMETERS, geometry="map", layers=layers,
                         half=True, refine=refine, solver=solver, solver_slots=solver_slots,
                         cache=cache, residual_memory=4)
