"""The sheet as a problem of the continuation engine.

The engine's drivers (:mod:`skfem_sheet.engine`) see a problem through its
protocol (:mod:`skfem_sheet.engine.protocol`).  :class:`SheetEngineProblem`
is what every adapter of the discrete sheet to it shares: the state ``u`` is
the vector of free dofs (:meth:`~SheetEngineProblem.full` adds the clamp
values); ``residual`` the free rows of ``dPi/dw`` (NaN where an element
inverts); ``jacobian`` the Hessian; ``factorize`` **the one lazy
refactorisation** (a factorisation used after its solver has factorised
something else is factorised again first, counted), its inertia the negative
eigenvalues of the constrained Hessian where known; the norms of
:mod:`skfem_sheet.newton` and the arclength inner product (the mean square
of the displacements plus the tip's vertical displacement squared).

:class:`SheetLoadProblem` has the loads ``p = (curvature, gravity)`` (the load
paths), :class:`SheetForceProblem` the tip force (:mod:`skfem_sheet.switch`),
:class:`skfem_sheet.sheet_shape.SheetShapeProblem` the shape ``(L, b, a/R)``.
Every factorisation, assembly and linear solve is counted in the adapter's
:class:`~skfem_sheet.newton.Stats`.
"""
from __future__ import annotations

from collections import OrderedDict

import numpy as np

from .analyses.observables import free_edge_nodes, tip_deflection
from .analyses.stability import stability
from .engine.protocol import EngineFailure, Problem
from .linalg import LinearSolverError
from .newton import NewtonOptions, Stats, timed
from .params import ParameterError

__all__ = ["Factorization", "LoadPhase", "SheetEngineProblem", "SheetForceProblem",
           "SheetLoadProblem", "SolverSlot"]


class SolverSlot:
    """One linear solver of an adapter and its *generation*: the number of
    factorisations it has made (a :class:`Factorization` made at an older
    generation is no longer the solver's)."""

    __slots__ = ("solver", "generation")

    def __init__(self, solver):
        self.solver, self.generation = solver, 0


class Factorization:
    """A matrix factorised on one of an adapter's solvers.

    The solver holds one factorisation at a time: :meth:`solve` first
    factorises the matrix again if the solver has factorised something else
    since (the lazy refactorisation; counted in the adapter's ``stats`` and
    ``refactorizations``).  A factorisation *held* (:meth:`SheetEngineProblem.held`)
    has no matrix: it is assembled from the state when needed.

    Attributes
    ----------
    exact : bool
        The matrix is the Hessian (not a Newton matrix linearised elsewhere):
        its inertia says whether the state is stable.
    generation : int
        The generation of its solver when it was (last) factorised.
    """

    def __init__(self, owner, slot: SolverSlot, K, w, p, exact: bool = True):
        self.owner, self.slot, self.K, self.w, self.p = owner, slot, K, w, p
        self.exact = bool(exact)
        self.generation = slot.generation
        self._stability = (stability(owner.layout, slot.solver) if exact else (None, None))

    def _ready(self):
        o, slot = self.owner, self.slot
        if slot.generation != self.generation:
            if self.K is None:  # the solver's matrix at the time: the tangent at w
                self.K = timed(o.stats, "assembly_s", o.problem_at(self.p).tangent, self.w)
            o.factorize_on(slot, self.K, self.w)
            o.refactorizations += 1
            self.generation = slot.generation

    def solve(self, b):
        self._ready()
        return timed(self.owner.stats, "linear_solve_s", self.slot.solver.solve, b)

    def stability(self):
        """``(stable, negative eigenvalues)`` (None, None if unknown)."""
        return self._stability

    def inertia(self):
        """Negative eigenvalues of the constrained Hessian (None: unknown, or
        the matrix was not the Hessian)."""
        return self._stability[1]


class SheetEngineProblem(Problem):
    """What every adapter of the sheet to the engine shares (see the module
    docstring).  Subclasses say what the parameters are: :meth:`problem_at`
    (the discrete sheet at ``p``), :meth:`kappa` (its clamp curvature) and
    :meth:`gravity`.

    Parameters
    ----------
    layout : SheetProblem
        The discrete sheet whose dof layout (free dofs, clamp, tip) the
        states use; every problem at a ``p`` shares it.
    solvers : sequence of linear-solver back-ends
        The solver slots: factorisations are made on them in turn, so that
        ``len(solvers)`` of them are held at once.
    stats : ~skfem_sheet.newton.Stats, optional
    residual_memory : int
        Residuals kept (the latest first).
    """

    def __init__(self, layout, solvers, stats: Stats | None = None, residual_memory: int = 1):
        self.stats = stats if stats is not None else Stats()
        self.refactorizations = 0  # factorisations made again by Factorization.solve
        self._slots = [SolverSlot(s) for s in solvers]
        self._next = 0
        self._memory = max(1, int(residual_memory))
        self.set_layout(layout)

    def set_layout(self, layout):
        """Take the dof layout of ``layout`` (a new mesh); kept residuals are dropped."""
        self.layout = layout
        self.free = layout.free
        self.n = len(self.free)
        self.nu_dof, self.ndof = layout.nu_dof, layout.ndof
        self._u_free = self.free < layout.nu_dof
        self._theta = 1.0 / max(1, int(np.count_nonzero(self._u_free)))
        self._rref = float(np.linalg.norm(layout.gravity_load[self.free]))
        tip_nodes = free_edge_nodes(layout)
        tip = 3 * tip_nodes[np.argmin(np.abs(layout.nodes[tip_nodes, 1]))] + 2
        #: Index in ``u`` of the vertical displacement of the tip's centre.
        self.tip_index = int(np.searchsorted(self.free, tip))
        self._fixed = None
        self._residuals = []  # (p, u, residual), the latest first
        self._matrix = None  # (state, p, exact) of the last matrix assembled

    # -- the parameters (subclasses) -------------------------------------------
    def problem_at(self, p):  # pragma: no cover - protocol of the subclasses
        """The discrete sheet (a SheetProblem) at ``p``."""
        raise NotImplementedError

    def kappa(self, p) -> float:  # pragma: no cover - protocol of the subclasses
        """The clamp curvature a/R at ``p``."""
        raise NotImplementedError

    def gravity(self, p) -> float:
        """The gravity factor at ``p`` (full load: 1)."""
        return 1.0

    # -- states --------------------------------------------------------------
    @property
    def solver(self):
        """The solver of the first slot (the only one of a one-slot adapter)."""
        return self._slots[0].solver

    @property
    def generation(self) -> int:
        """Factorisations made on :attr:`solver`."""
        return self._slots[0].generation

    def full(self, u, p):
        """The full dof vector: ``u`` on the free dofs, the clamp values of
        the curvature at ``p``."""
        kappa = self.kappa(p)
        if self._fixed is None or self._fixed[0] != kappa:
            w = np.zeros(self.layout.ndof)
            w[self.layout.clamp_dofs] = self.layout.clamp_values(kappa)
            self._fixed = (kappa, w)
        w = self._fixed[1].copy()
        w[self.free] = u
        return w

    def deflection(self, u, p):
        """Tip deflection d/a (positive downward) of the state ``u`` at ``p``."""
        return tip_deflection(self.problem_at(p), self.full(u, p))

    # -- protocol ------------------------------------------------------------
    def residual(self, u, p):
        key = tuple(float(x) for x in p)
        for k, uu, r in self._residuals:
            if k == key and np.array_equal(uu, u):
                return r.copy()
        r = self.evaluate_residual(u, p)
        self._residuals = [(key, np.array(u, dtype=float, copy=True), r),
                           *self._residuals[:self._memory - 1]]
        return r.copy()

    def evaluate_residual(self, u, p):
        """The residual at ``(u, p)``, assembled (NaN where an element inverts)."""
        r, jmin = timed(self.stats, "assembly_s", self.problem_at(p).residual, self.full(u, p),
                        self.gravity(p))
        self.stats.residual_evaluations += 1
        return r[self.free] if jmin > 0 else np.full(self.n, np.nan)

    def jacobian(self, u, p):
        w = self.full(u, p)
        self._matrix = (w, p, True)
        return timed(self.stats, "assembly_s", self.problem_at(p).tangent, w)

    def factorize_on(self, slot: SolverSlot, K, w):
        """Factorise ``K`` (formed at the state ``w``) on ``slot``'s solver."""
        try:
            timed(self.stats, "linear_solve_s", slot.solver.factorize, K, w)
        except LinearSolverError as err:
            raise EngineFailure(f"singular tangent ({err})") from None
        self.stats.factorizations += 1
        slot.generation += 1

    def factorize(self, J):
        w, p, exact = self._matrix if self._matrix is not None else (None, None, True)
        slot = self._slots[self._next]
        self._next = (self._next + 1) % len(self._slots)
        self.factorize_on(slot, J, w)
        return Factorization(self, slot, J, w, p, exact)

    def held(self, u, p):
        """The factorisation the first solver holds now, taken as the tangent
        at ``(u, p)`` (e.g. left by a load path or by
        :func:`skfem_sheet.newton.newton` at its converged state);
        refactorised from the tangent there if the solver factorises
        something else before it is used."""
        return Factorization(self, self._slots[0], None, self.full(u, p), p, True)

    def solver_used(self):
        """Say that :attr:`solver` was used from outside (a load path
        factorised on it): factorisations made before are no longer held."""
        self._slots[0].generation += 1

    def dual(self, a):
        c = np.zeros_like(a)
        c[self._u_free] = self._theta * a[self._u_free]
        c[self.tip_index] += a[self.tip_index]
        return c

    def residual_norm(self, r):
        return float(np.linalg.norm(r)) / self._rref

    def correction_norm(self, du):
        du = np.asarray(du)[self._u_free]
        return float(np.abs(du).max()) if du.size else 0.0

    def clamp_rate_residual(self, u, p):
        """``dR/d(a/R)`` at fixed free dofs: the clamp coupling times the rate
        of the clamp values (exact)."""
        prob = self.problem_at(p)
        w = self.full(u, p)
        return timed(self.stats, "assembly_s", prob.clamp_coupling, w) @ prob.clamp_rate(
            self.kappa(p))


class SheetLoadProblem(SheetEngineProblem):
    """One discrete sheet as an engine problem in ``p = (curvature, gravity)``.

    Parameters
    ----------
    problem : SheetProblem
    solver : linear-solver back-end (:func:`skfem_sheet.linalg.make_linear_solver`)
    stats : ~skfem_sheet.newton.Stats, optional
        Counts factorisations, assemblies and solves (a new one by default).
    newton_options : NewtonOptions, optional
        Their ``linearization`` and ``mip_threshold`` set the Newton matrix
        (:meth:`newton_jacobian`); default :class:`NewtonOptions`.

    Examples
    --------
    >>> from skfem_sheet import Sheet
    >>> from skfem_sheet.engine import newton
    >>> from skfem_sheet.linalg import make_linear_solver
    >>> from skfem_sheet.solve import build_problem
    >>> P = SheetLoadProblem(build_problem(Sheet(length=0.5), 0.2), make_linear_solver())
    >>> res = newton(P, np.zeros(P.n), [0.0, 1.0])
    >>> res.converged, round(P.deflection(res.u, res.p), 3)
    (True, 0.09)
    """

    parameter_names = ("curvature", "gravity")

    def __init__(self, problem, solver, stats: Stats | None = None,
                 newton_options: NewtonOptions | None = None):
        self.problem = problem
        self.options = newton_options or NewtonOptions()
        super().__init__(problem, [solver], stats)
        self._weight = problem.gravity_load[self.free]

    def problem_at(self, p):
        return self.problem

    def kappa(self, p) -> float:
        return float(p[0])

    def gravity(self, p) -> float:
        return float(p[1])

    def energy(self, u, p):
        """Total potential energy at ``(u, p)``."""
        return self.problem.energy(self.full(u, p), float(p[1]))

    def newton_jacobian(self, u, p, previous):
        """The matrix of a Newton correction at ``u`` whose previous iterate
        (in the same correction) was ``previous`` (None at the first one): the
        Hessian, or with ``NewtonOptions.linearization == "mip"`` after a move
        longer than ``mip_threshold`` the mixed-integration-point matrix
        linearised from ``previous``."""
        w = self.full(u, p)
        ref = None
        if self.options.linearization == "mip" and previous is not None:
            du = np.asarray(u)[self._u_free] - np.asarray(previous)[self._u_free]
            if du.size and float(np.abs(du).max()) > self.options.mip_threshold:
                ref = self.full(previous, p)
        self._matrix = (w, p, ref is None)
        return timed(self.stats, "assembly_s", self.problem.tangent, w, ref)

    def dresidual(self, u, p, i):
        if i == 1:
            return self._weight
        return self.clamp_rate_residual(u, p)


class SheetForceProblem(SheetEngineProblem):
    """One discrete sheet at fixed loads as an engine problem in its tip
    force, ``p = (F / force_unit,)``.

    The tip force ``F`` (total, positive upward, units of ``rho g a^3``) is a
    dead load over the tip face
    (:meth:`~skfem_sheet.problem.SheetProblem.with_tip_force`): the residual
    is ``R(u) - F f``, so ``dR/dF = -f`` exactly and the tangent does not
    depend on ``F``.

    Parameters
    ----------
    problem : SheetProblem
        The sheet on its mesh (its own tip force, if any, is replaced by ``p``).
    solver : linear-solver back-end
    curvature : float
        The clamp curvature a/R (fixed).
    gravity : float
        The gravity factor (fixed; 1: the sheet's own weight).
    stats : ~skfem_sheet.newton.Stats, optional
    force_unit : float
        The unit of the parameter (``rho g a^3``; default 1): ``p[0] = F /
        force_unit`` (an attribute, changeable between continuations); the
        arclength norm weighs the parameter against the displacements by it.
    tip_norm : bool
        The arclength inner product on the tip centre's vertical displacement
        alone (default False: :meth:`SheetEngineProblem.dual`), so that steps
        and the bending control follow the plotted curve of ``p`` against
        the tip.

    Examples
    --------
    >>> from skfem_sheet import Sheet
    >>> from skfem_sheet.engine import newton
    >>> from skfem_sheet.linalg import make_linear_solver
    >>> from skfem_sheet.solve import build_problem
    >>> prob = build_problem(Sheet(length=0.5), 0.2, half=True)
    >>> P = SheetForceProblem(prob, make_linear_solver(), curvature=0.0)
    >>> a = newton(P, np.zeros(P.n), [0.0]).u
    >>> b = newton(P, a, [-0.002]).u          # a push down adds to the sag
    >>> bool(P.deflection(b, [-0.002]) > P.deflection(a, [0.0]))
    True
    >>> round(float(P.dresidual(a, [0.0], 0).sum()), 12)   # -f: half of the unit force
    -0.5
    """

    parameter_names = ("tip_force",)

    def __init__(self, problem, solver, curvature: float, gravity: float = 1.0,
                 stats: Stats | None = None, force_unit: float = 1.0, tip_norm: bool = False):
        self.problem = problem.with_tip_force(0.0) if problem.tip_force else problem
        self.curvature, self.g = float(curvature), float(gravity)
        self.force_unit = float(force_unit)
        self.tip_norm = bool(tip_norm)
        if not (self.force_unit > 0 and np.isfinite(self.force_unit)):
            raise ParameterError(f"force_unit must be positive and finite, got {force_unit!r}")
        super().__init__(self.problem, [solver], stats)
        self._f = np.asarray(self.problem.tip_load)[self.free]  # -dR/dF (no tip face: raises)
        self._forces = OrderedDict()  # F -> the problem with that tip force (shares everything)

    def force(self, p) -> float:
        """The tip force F at ``p`` (``rho g a^3``)."""
        return float(p[0]) * self.force_unit

    def problem_at(self, p):
        F = self.force(p)
        if F == 0.0:
            return self.problem
        prob = self._forces.get(F)
        if prob is None:
            prob = self._forces[F] = self.problem.with_tip_force(F)
            if len(self._forces) > 8:
                self._forces.popitem(last=False)
        return prob

    def kappa(self, p) -> float:
        return self.curvature

    def gravity(self, p) -> float:
        return self.g

    def dresidual(self, u, p, i):
        return -self.force_unit * self._f

    def dual(self, a):
        if not self.tip_norm:
            return super().dual(a)
        c = np.zeros_like(a)
        c[self.tip_index] = a[self.tip_index]
        return c

    def tip_displacement(self, u, p) -> float:
        """``w_tip`` of ``u``: the tip face's mean vertical displacement (up)."""
        return self.problem.tip_displacement(self.full(u, p))

    def energy(self, u, p, load_potential: bool = True) -> float:
        """The total potential energy at ``(u, p)`` (``rho g a^4``); without
        the tip force's potential ``-F w_tip`` if ``load_potential`` is False
        (the sheet's own energy: elastic and gravitational)."""
        w = self.full(u, p)
        e = self.problem.energy(w, self.g)
        return e - self.force(p) * self.problem.tip_displacement(w) if load_potential else e


class LoadPhase(Problem):
    """One phase of a load path as an engine problem in one parameter
    ``lam``, the fraction of the phase: ``loads(lam) = start + lam (end -
    start)`` in ``(curvature, gravity)`` (the loads are linear in ``lam``).

    Parameters
    ----------
    sheet : SheetLoadProblem
    start, end : (float, float)
        The loads ``(curvature, gravity)`` at ``lam = 0`` and ``lam = 1``.

    Examples
    --------
    >>> from skfem_sheet import Sheet
    >>> from skfem_sheet.linalg import make_linear_solver
    >>> from skfem_sheet.solve import build_problem
    >>> P = SheetLoadProblem(build_problem(Sheet(length=0.5), 0.2), make_linear_solver())
    >>> phase = LoadPhase(P, (2.0, 0.0), (2.0, 1.0))
    >>> phase.loads([0.25])
    (2.0, 0.25)
    """

    parameter_names = ("lam",)

    def __init__(self, sheet: SheetLoadProblem, start, end):
        self.sheet = sheet
        self.start = np.array(start, dtype=float)
        self.rate = np.array(end, dtype=float) - self.start

    def loads(self, p):
        """``(curvature, gravity)`` at ``p = (lam,)``."""
        q = self.start + float(p[0]) * self.rate
        return float(q[0]), float(q[1])

    def residual(self, u, p):
        return self.sheet.residual(u, self.loads(p))

    def jacobian(self, u, p):
        return self.sheet.jacobian(u, self.loads(p))

    def newton_jacobian(self, u, p, previous):
        return self.sheet.newton_jacobian(u, self.loads(p), previous)

    def factorize(self, J):
        return self.sheet.factorize(J)

    def dresidual(self, u, p, i):
        q = self.loads(p)
        out = np.zeros(self.sheet.n)
        for j in (0, 1):
            if self.rate[j]:
                out = out + self.rate[j] * self.sheet.dresidual(u, q, j)
        return out

    def dual(self, a):
        return self.sheet.dual(a)

    def residual_norm(self, r):
        return self.sheet.residual_norm(r)

    def correction_norm(self, du):
        return self.sheet.correction_norm(du)
