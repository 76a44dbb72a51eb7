"""The sheet as a problem of the continuation engine, in its loads.

:class:`SheetLoadProblem` says what one discrete sheet (a
:class:`~skfem_sheet.problem.SheetProblem` on one mesh) is to the engine's
drivers (:mod:`skfem_sheet.engine`): the state ``u`` is the vector of free
dofs, the parameters are the loads ``p = (curvature, gravity)`` (the clamp's
curvature a/R, which sets the clamped values, and the gravity factor), and

- ``residual(u, p)``: the free rows of ``dPi/dw`` (NaN where an element
  inverts, so that the corrector halves the step);
- ``jacobian(u, p)``: the tangent (the Hessian of the energy), and
  ``newton_jacobian(u, p, previous)`` the matrix of Newton corrections
  (the mixed-integration-point linearisation from the previous iterate,
  :class:`~skfem_sheet.newton.NewtonOptions`);
- ``factorize(J)``: on the sheet's linear solver, with a lazy
  refactorisation when the solver has factorised something else since; the
  inertia is the number of negative eigenvalues of the constrained Hessian
  (:func:`~skfem_sheet.analyses.stability.stability`), unknown (None) for a
  factorisation of a MIP matrix or when PARDISO perturbed pivots;
- ``dresidual``: exact in both loads (``dR/dg`` is the weight vector,
  ``dR/dkappa`` the clamp coupling times the rate of the clamp values);
- the norms of :mod:`skfem_sheet.newton` (residual relative to the full
  weight, corrections as the largest displacement) and the arclength inner
  product: the mean square of the displacements plus the square of the tip's
  vertical displacement (pressures left out).

Every factorisation, assembly and linear solve is counted in the sheet's
:class:`~skfem_sheet.newton.Stats`.
"""
from __future__ import annotations

import numpy as np

from .analyses.observables import free_edge_nodes, tip_deflection
from .analyses.stability import stability
from .engine.protocol import EngineFailure, Problem
from .linalg import LinearSolverError
from .newton import NewtonOptions, Stats, timed

__all__ = ["LoadPhase", "SheetLoadProblem"]


class _Factorization:
    """A factorised matrix on the sheet's solver (refactorised if the solver
    has factorised another matrix since); its inertia read once."""

    def __init__(self, owner, K, w, exact):
        self.owner, self.K, self.w, self.exact = owner, K, w, exact
        self.generation = owner.generation
        k = stability(owner.problem, owner.solver)[1] if exact else None
        self._negative = k

    def _ready(self):
        o = self.owner
        if o.generation != self.generation:
            if self.K is None:  # the solver's matrix at the time: the tangent at w
                self.K = timed(o.stats, "assembly_s", o.problem.tangent, self.w)
            o._factorize(self.K, self.w)  # counted with the factorisations
            self.generation = o.generation

    def solve(self, b):
        self._ready()
        return timed(self.owner.stats, "linear_solve_s", self.owner.solver.solve, b)

    def inertia(self):
        """Negative eigenvalues of the constrained Hessian (None: unknown, or
        the matrix was not the Hessian)."""
        return self._negative


class SheetLoadProblem(Problem):
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
        self.problem, self.solver = problem, solver
        self.stats = stats if stats is not None else Stats()
        self.options = newton_options or NewtonOptions()
        self.free = problem.free
        self.n = len(self.free)
        self.nu_dof = problem.nu_dof
        self._u_free = self.free < problem.nu_dof
        self._theta = 1.0 / max(1, int(np.count_nonzero(self._u_free)))
        self._rref = float(np.linalg.norm(problem.gravity_load[self.free]))
        self._weight = problem.gravity_load[self.free]
        tip_nodes = free_edge_nodes(problem)
        tip = 3 * tip_nodes[np.argmin(np.abs(problem.nodes[tip_nodes, 1]))] + 2
        self._tip = int(np.searchsorted(self.free, tip))
        self._fixed = None
        self._last = None  # (key, residual) of the last residual
        self._matrix = None  # (state, exact) of the last matrix assembled
        self.generation = 0  # factorisations made on the solver

    # -- states --------------------------------------------------------------
    def full(self, u, p):
        """The full dof vector: ``u`` on the free dofs, the clamp values of
        the curvature ``p[0]``."""
        kappa = float(p[0])
        if self._fixed is None or self._fixed[0] != kappa:
            w = np.zeros(self.problem.ndof)
            w[self.problem.clamp_dofs] = self.problem.clamp_values(kappa)
            self._fixed = (kappa, w)
        w = self._fixed[1].copy()
        w[self.free] = u
        return w

    def deflection(self, u, p):
        """Tip deflection d/a (positive downward) of the state ``u`` at ``p``."""
        return tip_deflection(self.problem, self.full(u, p))

    def energy(self, u, p):
        """Total potential energy at ``(u, p)``."""
        return self.problem.energy(self.full(u, p), float(p[1]))

    # -- protocol ------------------------------------------------------------
    def residual(self, u, p):
        key = (float(p[0]), float(p[1]))
        if self._last is not None and self._last[0] == key and np.array_equal(self._last[1], u):
            return self._last[2]
        r, jmin = timed(self.stats, "assembly_s", self.problem.residual, self.full(u, p), key[1])
        self.stats.residual_evaluations += 1
        r = r[self.free] if jmin > 0 else np.full(self.n, np.nan)
        self._last = (key, np.array(u, dtype=float), r)
        return r

    def jacobian(self, u, p):
        w = self.full(u, p)
        self._matrix = (w, True)
        return timed(self.stats, "assembly_s", self.problem.tangent, w)

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
        self._matrix = (w, ref is None)
        return timed(self.stats, "assembly_s", self.problem.tangent, w, ref)

    def _factorize(self, K, w):
        try:
            timed(self.stats, "linear_solve_s", self.solver.factorize, K, w)
        except LinearSolverError as err:
            raise EngineFailure(f"singular tangent ({err})") from None
        self.stats.factorizations += 1
        self.generation += 1

    def factorize(self, J):
        w, exact = self._matrix if self._matrix is not None else (None, True)
        self._factorize(J, w)
        return _Factorization(self, J, w, exact)

    def held(self, u, p):
        """The factorisation the solver holds now, taken as the tangent at
        ``(u, p)`` (e.g. left by :func:`skfem_sheet.newton.newton` at its
        converged state); refactorised from the tangent there if the solver
        factorises something else before it is used."""
        return _Factorization(self, None, self.full(u, p), True)

    def dresidual(self, u, p, i):
        if i == 1:
            return self._weight
        prob = self.problem
        w = self.full(u, p)
        return timed(self.stats, "assembly_s", prob.clamp_coupling, w) @ prob.clamp_rate(
            float(p[0]))

    def dual(self, a):
        c = np.zeros_like(a)
        c[self._u_free] = self._theta * a[self._u_free]
        c[self._tip] += a[self._tip]
        return c

    def residual_norm(self, r):
        return float(np.linalg.norm(r)) / self._rref

    def correction_norm(self, du):
        du = np.asarray(du)[self._u_free]
        return float(np.abs(du).max()) if du.size else 0.0


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
