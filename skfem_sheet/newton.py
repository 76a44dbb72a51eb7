"""Newton-Raphson for one load ``(kappa, g)``, and pseudo-transient continuation,
on the sheet: the engine's corrector and transient iteration, with the sheet's
stopping rule and admissibility.

There is one Newton loop in the package, :func:`skfem_sheet.engine.corrector.correct`,
and one pseudo-transient iteration, :func:`skfem_sheet.engine.transient.pseudo_transient`;
:func:`newton` and :func:`pseudo_transient` here only say what a sheet is to them
(state = the whole dof vector, corrections on the free dofs, norms, counters).

Convergence needs both a small residual and a small next increment::

    ||r_free||_2 <= rtol * ||f_gravity||_2   and   max |du| <= utol

(``f_gravity`` is the discrete weight vector at full gravity, the natural force
scale).  Every trial point is checked for inverted elements (``det F <= 0``)
and NaN, and the step is halved on those.  The result says honestly whether it
converged and why not.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from .engine import transient
from .engine.corrector import Tolerances, correct
from .engine.protocol import Counting, EngineFailure, Problem
from .linalg import LinearSolverError
from .params import ParameterError, check_range

__all__ = ["NewtonOptions", "NewtonResult", "Stats", "newton", "polish", "pseudo_transient",
           "timed"]


@dataclass(frozen=True)
class NewtonOptions:
    """Tolerances and limits of the Newton iteration.

    Attributes
    ----------
    rtol : float
        Residual tolerance relative to the norm of the full weight vector.
    utol : float
        Tolerance on the largest displacement increment (units of a).
    max_iterations : int
        Give up (and let the load stepping cut the step) after this many.
    max_halvings : int
        Step halvings on trial points with an inverted element (or NaN)
        before the iteration fails.
    linearization : {"mip", "exact"}
        The matrix of the Newton corrections: from the second iteration on,
        the mixed-integration-point linearisation (default;
        :meth:`SheetProblem.tangent` with ``w_ref``, the previous iterate),
        whose geometric stiffness carries the stress linearised from the
        previous iterate (Magisano, Leonetti & Garcea, CMAME 2017), or the
        exact tangent (the Hessian of the energy) at every iteration.  The
        residual, hence the converged state, is the same; on thin sheets MIP
        needs fewer iterations
        (``benchmarks/results/robustness/snap_mip_issue17_hmax0.08.txt``).  A
        converged solve always leaves the exact tangent factorised, so that
        inertia checks and tangent predictors see the Hessian.
    mip_threshold : float
        With ``"mip"``: the MIP matrix is used only after a step longer than
        this (largest nodal displacement, units of a); after shorter steps
        the stress defect (second order in the step) is negligible and the
        exact tangent is used, so a solve that converges quickly ends on an
        exact factorisation and needs no refactorisation for its inertia.
    final_utol : float
        The end state of a solve is polished by simplified-Newton corrections
        with the factorisation at hand (back-substitutions only,
        :func:`polish`) until the last one is at most this (units of a):
        Newton stops when the next correction is below ``utol`` without
        applying it, so two solves of one equilibrium (e.g. the two starts of
        :func:`skfem_sheet.solve.solve`) then agree in d to about
        ``final_utol`` instead of ``utol``.
    polish_iterations : int
        Most corrections of that polish (it stops early, keeping the state it
        has, if a correction does not shrink to at most half the previous one).
    """

    rtol: float = 1e-4
    utol: float = 1e-6
    max_iterations: int = 8
    max_halvings: int = 6
    linearization: str = "mip"
    mip_threshold: float = 2e-3
    final_utol: float = 1e-9
    polish_iterations: int = 4

    def __post_init__(self):
        check_range("rtol", self.rtol, 0, 1, lo_open=True)
        check_range("utol", self.utol, 0, 1, lo_open=True)
        check_range("max_iterations", self.max_iterations, 1, 1000)
        check_range("max_halvings", self.max_halvings, 0, 60)
        if self.linearization not in ("exact", "mip"):
            raise ParameterError("linearization must be 'exact' or 'mip', got "
                                 f"{self.linearization!r}")
        check_range("mip_threshold", self.mip_threshold, 0, 1)
        check_range("final_utol", self.final_utol, 0, 1, lo_open=True)
        check_range("polish_iterations", self.polish_iterations, 0, 100)


@dataclass
class Stats:
    """Counters and timers accumulated over a whole solve."""

    newton_iterations: int = 0
    factorizations: int = 0
    residual_evaluations: int = 0
    assembly_s: float = 0.0
    linear_solve_s: float = 0.0


@dataclass
class NewtonResult:
    w: np.ndarray
    converged: bool
    iterations: int
    reason: str = ""
    residuals: list = field(default_factory=list)
    first_increment: float = 0.0
    corrections: list = field(default_factory=list)  # max |du| of each iteration


def timed(stats, attr, fn, *args):
    """``fn(*args)``, its wall time added to the counter ``stats.<attr>``
    (e.g. ``"assembly_s"``, ``"linear_solve_s"`` of :class:`Stats`), also
    when it raises."""
    t = time.perf_counter()
    try:
        return fn(*args)
    finally:
        setattr(stats, attr, getattr(stats, attr) + time.perf_counter() - t)




class _SheetNewton(Problem):
    """The sheet at gravity ``g`` as the engine's corrector sees it: the state is
    the whole dof vector (clamped entries kept), a correction is zero on the
    fixed dofs, its norm is the largest displacement on the free dofs.  The
    residual of an accepted trial point is kept for the next linearisation (one
    residual evaluation per iteration, as the stopping test needs it anyway)."""

    def __init__(self, problem, g, solver, options, stats):
        self.problem, self.g, self.solver, self.options, self.stats = (
            problem, g, solver, options, stats)
        self.free = problem.free
        self.nu_free = self.free < problem.nu_dof
        self.rref = float(np.linalg.norm(problem.gravity_load[self.free]))
        self.last = (None, None)  # (state, residual) of the last admissible point
        self.residuals = []
        self.previous = None  # the previous linearisation point (MIP reference)
        self.exact = True  # whether the last factorisation is the exact tangent's
        self.last_correction = np.inf  # the last correction's norm
        self.chord = None  # (state, correction): a chord step at that state

    def evaluate(self, w):
        """The residual at ``w`` if ``w`` is admissible (no inverted element,
        finite), else None; kept for the linearisation at ``w``."""
        r, Jmin = timed(self.stats, "assembly_s", self.problem.residual, w, self.g)
        self.stats.residual_evaluations += 1
        ok = Jmin > 0 and bool(np.all(np.isfinite(r)))
        self.last = (w, r) if ok else (None, None)
        return r if ok else None

    def admissible(self, w, p):
        return self.evaluate(w) is not None

    def correction_norm(self, du):
        return float(np.abs(du[: self.problem.nu_dof]).max())

    def back_solve(self, r):
        return timed(self.stats, "linear_solve_s", self.solver.solve, -r[self.free])

    def linearize(self, w, p):
        kept, r = self.last
        if kept is not w and not np.array_equal(kept, w):
            r = self.evaluate(w)
            if r is None:
                raise EngineFailure("inverted element")
        rn = float(np.linalg.norm(r[self.free]))
        if not np.isfinite(rn):
            raise EngineFailure("NaN in the residual")
        if self.chord is not None and self.chord[0] is w:
            # a chord step (see converged): the last factorisation's correction
            du = self.chord[1]
            self.chord = None
            self.last_correction = self.correction_norm(du)
            self.stats.newton_iterations += 1
            return rn, du, np.zeros(1), self.solver, None
        self.chord = None
        ref = self.previous if self.options.linearization == "mip" else None
        if ref is not None and not (np.abs(w[: self.problem.nu_dof] - ref[: self.problem.nu_dof]).max()
                                    > self.options.mip_threshold):
            ref = None
        K = timed(self.stats, "assembly_s", self.problem.tangent, w, ref)
        self.exact = ref is None
        self.previous = w
        try:
            timed(self.stats, "linear_solve_s", self.solver.factorize, K, w)
            delta = self.back_solve(r)
        except LinearSolverError as err:
            raise EngineFailure(f"singular tangent ({err})") from None
        self.stats.factorizations += 1
        self.stats.newton_iterations += 1
        if not np.all(np.isfinite(delta)):
            raise EngineFailure("NaN in the Newton increment")
        du = np.zeros_like(w)
        du[self.free] = delta
        self.last_correction = self.correction_norm(du)
        return rn, du, np.zeros(1), self.solver, None

    def converged(self, w, p, fact, extra):
        """Small residual at ``w`` and a small simplified-Newton correction
        there (a back-substitution with the factorisation at hand).

        Where the residual is still above ``rtol`` but that correction is
        below ``utol`` and at most half the last one, the next iteration
        takes it as it is (a chord step), instead of factorising the tangent
        at ``w``: the rule of
        :func:`skfem_sheet.bistability.follow._chord_linearization` (the record:
        ``benchmarks/results/speed/solve_sample_hmax0.03_chord.txt``)."""
        r = self.last[1]
        rn = float(np.linalg.norm(r[self.free]))
        self.residuals.append(rn)
        delta = self.back_solve(r)
        dn = float(np.abs(delta[self.nu_free]).max())
        if rn <= self.options.rtol * self.rref:
            return dn <= self.options.utol
        if (np.all(np.isfinite(delta)) and dn <= self.options.utol
                and dn <= 0.5 * self.last_correction):
            du = np.zeros_like(w)
            du[self.free] = delta
            self.chord = (w, du)
        return False


def newton(problem, w, g, solver, options: NewtonOptions, stats: Stats,
           max_first_increment=np.inf, reference=None, exact_on_return=True) -> NewtonResult:
    """Solve ``r(w; g) = 0`` for the free dofs of ``w`` (fixed dofs are kept).

    The engine's corrector (:func:`skfem_sheet.engine.corrector.correct`) on
    the sheet.  The first correction is made with the exact tangent, the
    later ones with ``options.linearization`` (by default the
    mixed-integration-point matrix, whose geometric stiffness carries the
    stress linearised from the previous iterate, so that a bending step of a
    thin sheet leaves no spurious membrane stress of its linearised rotation
    in the next tangent).  Full Newton steps, halved only where a trial point
    has an inverted element (``det F <= 0``) or NaN; no line search (a
    bending step of a thin sheet leaves a large membrane residual that the
    *next* full step removes: ``docs/decisions.md``, "No line search").
    Globalisation is the load stepping's (:mod:`skfem_sheet.continuation`);
    an iteration whose correction (from the third on) exceeds
    ``max(10 first, 0.1)`` is stopped early as "diverging".

    Convergence: ``||r_free|| <= rtol ||f_gravity||`` and the next correction
    is below ``utol``.  The next correction is estimated by a simplified Newton
    step ``-K^{-1} r`` with the factorisation at hand (a back-substitution), so
    no factorisation is spent only to confirm convergence; where that
    correction is below ``utol`` and at most half the last one but the
    residual is still above ``rtol``, it is applied as it is (a chord step,
    counted as an iteration, not a factorisation).

    Parameters
    ----------
    problem : SheetProblem
    w : ndarray
        Initial guess; its clamped entries are the boundary values.
    g : float
        Gravity load factor.
    solver : linear-solver back-end (see :mod:`skfem_sheet.linalg`)
    options : NewtonOptions
    stats : ~skfem_sheet.newton.Stats
        Updated in place (iterations, factorizations, timings).
    max_first_increment : float
        Reject the attempt if the first correction moves a node further than
        this: a guard against jumping to another branch after a large step.
    reference : ndarray, optional
        With ``options.linearization == "mip"``: the state that ``w`` was
        predicted from (the accepted state of a load step), the reference of
        the first linearisation (default: the exact tangent at ``w`` first).
    exact_on_return : bool
        With ``options.linearization == "mip"``: if the last linearisation of
        a converged solve was a MIP one, factorise the exact tangent at the
        converged state before returning (one more factorisation), so that
        the solver holds the Hessian for an inertia check.  ``False`` where
        no inertia is read before the next solve (an intermediate load step,
        whose tangent predictor may use the MIP factorisation).

    Returns
    -------
    NewtonResult
        ``w`` is the last iterate; ``converged`` is False with a ``reason``
        ("inverted element", "NaN ...", "diverging", "max iterations",
        "singular tangent", "first correction too large") otherwise.
    """
    sheet = _SheetNewton(problem, g, solver, options, stats)
    sheet.previous = reference
    w = np.array(w, dtype=float)
    r, Jmin = timed(stats, "assembly_s", problem.residual, w, g)
    stats.residual_evaluations += 1
    if not Jmin > 0:
        return NewtonResult(w, False, 0, "inverted element in the initial guess")
    sheet.last = (w, r)  # a NaN in it ends the first linearisation
    sheet.residuals.append(float(np.linalg.norm(r[problem.free])))
    tol = Tolerances(rtol=options.rtol, utol=options.utol, max_iterations=options.max_iterations,
                     max_halvings=options.max_halvings, max_correction=max_first_increment,
                     divergence_floor=0.1)
    start = stats.newton_iterations
    res = correct(Counting(sheet), w, np.array([float(g)]), sheet.linearize, tol,
                  sheet.admissible, converged=sheet.converged)
    if res.converged and not sheet.exact and exact_on_return:
        # leave the Hessian factorised: the callers read inertia and predict with it
        K = timed(stats, "assembly_s", problem.tangent, res.u)
        try:
            timed(stats, "linear_solve_s", solver.factorize, K, res.u)
        except LinearSolverError as err:
            return NewtonResult(res.u, False, stats.newton_iterations - start,
                                f"singular tangent at the converged state ({err})",
                                sheet.residuals)
        stats.factorizations += 1
    corrections = [dn for _, dn in res.history]
    reason = "inverted element" if res.reason.startswith("inadmissible") else res.reason
    return NewtonResult(res.u, res.converged, stats.newton_iterations - start, reason,
                        sheet.residuals, corrections[0] if corrections else 0.0, corrections)


class _SheetTransient(transient.TransientSystem):
    """The sheet at gravity ``g`` as the pseudo-transient iteration sees it
    (state: the whole dof vector; ``M``: the displacement mass matrix)."""

    def __init__(self, problem, g, solver, stats, negatives):
        self.problem, self.g, self.solver, self.stats, self.negatives = (
            problem, g, solver, stats, negatives)

    def residual(self, w):
        r, Jmin = timed(self.stats, "assembly_s", self.problem.residual, w, self.g)
        self.stats.residual_evaluations += 1
        return r if Jmin > 0 and np.all(np.isfinite(r)) else None

    def residual_norm(self, r):
        return float(np.linalg.norm(r[self.problem.free]))

    def correction_norm(self, du):
        return float(np.abs(du[: self.problem.nu_dof]).max())

    def tangent(self, w):
        return timed(self.stats, "assembly_s", self.problem.tangent, w)

    def factorize(self, K, w, sigma):
        A = K if sigma == 0.0 else sp.csr_matrix((K.data + sigma * self.problem.mass_data,
                                                  K.indices, K.indptr), shape=K.shape)
        try:
            timed(self.stats, "linear_solve_s", self.solver.factorize, A, w)
            self.stats.factorizations += 1
            return (self.negatives(self.problem, self.solver) if self.negatives is not None
                    else None)
        except LinearSolverError:
            raise EngineFailure("singular shifted tangent") from None

    def correction(self, r):
        free = self.problem.free
        du = np.zeros_like(r)
        du[free] = timed(self.stats, "linear_solve_s", self.solver.solve, -r[free])
        self.stats.newton_iterations += 1
        return du


def polish(problem, w, g, solver, stats: Stats, *, utol: float, max_iterations: int,
           first: float = np.inf):
    """Simplified-Newton corrections of the equilibrium ``w`` at gravity ``g``
    with the factorisation ``solver`` holds (back-substitutions only, no new
    factorisation), applied until one is at most ``utol`` (units of a, largest
    nodal displacement), at most ``max_iterations``.

    Stops early, keeping the state it has, where a correction is not finite,
    inverts an element, exceeds ``first`` or does not shrink to at most half
    the previous one.  :func:`skfem_sheet.solve.solve` brings every converged
    end state to ``NewtonOptions.final_utol`` with it.

    Returns
    -------
    (w, n) : the polished state and the number of corrections applied.

    Examples
    --------
    >>> from skfem_sheet import Sheet
    >>> from skfem_sheet.linalg import make_linear_solver
    >>> from skfem_sheet.solve import build_problem
    >>> problem = build_problem(Sheet(length=0.5), 0.2)
    >>> solver, stats = make_linear_solver(), Stats()
    >>> res = newton(problem, np.zeros(problem.ndof), 1.0, solver, NewtonOptions(), stats)
    >>> w, n = polish(problem, res.w, 1.0, solver, stats, utol=1e-12, max_iterations=4)
    >>> n >= 1 and stats.factorizations == res.iterations
    True
    """
    free = problem.free
    nu_free = free < problem.nu_dof
    w = np.array(w, dtype=float)
    previous, n = first, 0
    for _ in range(max_iterations):
        r, Jmin = timed(stats, "assembly_s", problem.residual, w, g)
        stats.residual_evaluations += 1
        if not (Jmin > 0 and np.all(np.isfinite(r))):
            break
        try:
            du = timed(stats, "linear_solve_s", solver.solve, -r[free])
        except LinearSolverError:
            break
        size = float(np.abs(du[nu_free]).max()) if np.any(nu_free) else 0.0
        if not (np.isfinite(size) and size <= (previous if n == 0 else 0.5 * previous)):
            break
        w[free] += du
        n, previous = n + 1, size
        if size <= utol:
            break
    return w, n


def pseudo_transient(problem, w, g, solver, options: NewtonOptions, stats: Stats,
                     shift=100.0, max_iterations=80, radius=0.1, negatives=None,
                     sigma_floor=1e-2, max_decrease=64.0) -> NewtonResult:
    """Pseudo-transient continuation to a stable equilibrium at gravity ``g``.

    The engine's iteration (:func:`skfem_sheet.engine.transient.pseudo_transient`,
    Kelley & Keyes 1998) on the sheet::

        (K(w) + sigma M) dw = -r(w)

    with the displacement mass matrix ``M``: a damped path drawn to stable
    equilibria, turning into Newton as ``sigma -> 0`` (the snap onto another
    branch, which plain Newton cannot reach).  The shift is controlled by the
    inertia of the shifted tangent (``negatives``) and the step length.  It
    stops at a plain Newton step with no negative direction and a largest
    displacement at most ``options.utol``: a loose settle, to be followed by
    a tight :func:`newton` solve.

    Parameters
    ----------
    shift : float
        Initial ``sigma`` (units of the tangent over the mass matrix).
    max_iterations : int
        Steps (each one linear solve; refactorisations for a larger ``sigma``
        count as factorisations, not steps).
    radius : float
        Largest displacement of one step (units of a).
    negatives : callable(problem, solver) -> int or None, optional
        Number of negative directions of the factorised matrix on the
        incompressible subspace (``None``: unknown); without it the inertia
        is not checked.
    sigma_floor : float
        Smallest non-zero shift.
    max_decrease : float
        Largest division of the shift after a full step much shorter than
        ``radius`` (64 lets the large shift of a snap fall in a few steps).

    Returns
    -------
    NewtonResult
        ``converged`` False with a ``reason`` if it did not settle in
        ``max_iterations`` steps, or a step could not avoid inverted elements.
    """
    system = _SheetTransient(problem, g, solver, stats, negatives)
    res = transient.pseudo_transient(system, w, utol=options.utol, shift=shift,
                                     max_iterations=max_iterations, radius=radius,
                                     sigma_floor=sigma_floor,
                                     max_halvings=options.max_halvings,
                                     max_decrease=max_decrease)
    reason = {"inadmissible initial state": "inverted element in the initial guess",
              "inadmissible trial states": "inverted element"}.get(res.reason, res.reason)
    return NewtonResult(res.u, res.converged, res.iterations, reason, list(res.residuals),
                        0.0, list(res.corrections))
