"""Newton-Raphson for one load ``(kappa, g)``, and pseudo-transient continuation.

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

from .linalg import LinearSolverError
from .params import check_range

__all__ = ["NewtonOptions", "NewtonResult", "Stats", "newton", "pseudo_transient", "timed"]


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
    """

    rtol: float = 1e-4
    utol: float = 1e-6
    max_iterations: int = 8
    max_halvings: int = 6

    def __post_init__(self):
        check_range("rtol", self.rtol, 0, 1, lo_open=True)
        check_range("utol", self.utol, 0, 1, lo_open=True)
        check_range("max_iterations", self.max_iterations, 1, 1000)
        check_range("max_halvings", self.max_halvings, 0, 60)


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


def _admissible_step(problem, w, delta, g, max_halvings, stats):
    """``w + alpha delta`` on the free dofs with the largest ``alpha = 2^-k``
    (``k <= max_halvings``) whose residual is finite and whose elements are not
    inverted.  Returns ``(w_new, r_new, alpha)``, or ``None`` if there is none."""
    alpha = 1.0
    for _ in range(max_halvings + 1):
        wt = w.copy()
        wt[problem.free] += alpha * delta
        rt, Jmin = timed(stats, "assembly_s", problem.residual, wt, g)
        stats.residual_evaluations += 1
        if Jmin > 0 and np.all(np.isfinite(rt)):
            return wt, rt, alpha
        alpha *= 0.5
    return None


def newton(problem, w, g, solver, options: NewtonOptions, stats: Stats,
           max_first_increment=np.inf) -> NewtonResult:
    """Solve ``r(w; g) = 0`` for the free dofs of ``w`` (fixed dofs are kept).

    Full Newton steps, halved only where a trial point has an inverted element
    (``det F <= 0``) or NaN.  A residual-norm (or Deuflhard natural-monotonicity)
    line search was tried and rejected: a bending step of a thin sheet leaves a
    large membrane residual that the *next* full Newton step removes, so those
    tests cut good steps and doubled the iteration counts.  Globalisation is
    the job of the load stepping (:mod:`skfem_sheet.continuation`), which cuts
    the load step when Newton fails here; an iteration whose correction grows
    far beyond the first one is stopped early as "diverging".

    Convergence: ``||r_free|| <= rtol ||f_gravity||`` and the next correction
    is below ``utol``.  The next correction is estimated by a simplified Newton
    step ``-K^{-1} r`` with the factorisation at hand (a back-substitution), so
    no factorisation is spent only to confirm convergence.

    Parameters
    ----------
    problem : SheetProblem
    w : ndarray
        Initial guess; its clamped entries are the boundary values.
    g : float
        Gravity load factor.
    solver : linear-solver back-end (see :mod:`skfem_sheet.linalg`)
    options : NewtonOptions
    stats : Stats
        Updated in place (iterations, factorizations, timings).
    max_first_increment : float
        Reject the attempt if the first correction moves a node further than
        this: a guard against jumping to another branch after a large step.

    Returns
    -------
    NewtonResult
        ``w`` is the last iterate; ``converged`` is False with a ``reason``
        ("inverted element", "NaN ...", "diverging", "max iterations",
        "singular tangent", "first correction too large") otherwise.
    """
    free = problem.free
    nu_free = free < problem.nu_dof  # displacement part of the free dofs
    rref = float(np.linalg.norm(problem.gravity_load[free]))
    w = w.copy()
    r, Jmin = timed(stats, "assembly_s", problem.residual, w, g)
    stats.residual_evaluations += 1
    if not Jmin > 0:
        return NewtonResult(w, False, 0, "inverted element in the initial guess")
    rn = float(np.linalg.norm(r[free]))
    history = [rn]
    first = 0.0
    corrections = []

    def back_solve(rhs):
        return timed(stats, "linear_solve_s", solver.solve, rhs)

    for it in range(options.max_iterations):
        if not np.isfinite(rn):
            return NewtonResult(w, False, it, "NaN in the residual", history, first, corrections)
        K = timed(stats, "assembly_s", problem.tangent, w)
        try:
            timed(stats, "linear_solve_s", solver.factorize, K, w)
            delta = back_solve(-r[free])
        except LinearSolverError as err:
            return NewtonResult(w, False, it, f"singular tangent ({err})", history, first, corrections)
        stats.factorizations += 1
        stats.newton_iterations += 1
        if not np.all(np.isfinite(delta)):
            return NewtonResult(w, False, it + 1, "NaN in the Newton increment", history, first, corrections)
        corrections.append(float(np.abs(delta[nu_free]).max()))
        if it == 0:
            first = corrections[0]
            if first > max_first_increment:
                return NewtonResult(w, False, 1, "first correction too large "
                                    f"({first:.3g} > {max_first_increment:.3g})", history, first, corrections)
        # Corrections of a thin sheet are often non-monotone for a few
        # iterations (a bending step leaves a membrane residual for the next
        # one): only a correction far beyond the first one counts as divergence.
        if it >= 2 and corrections[-1] > max(10.0 * first, 0.1):
            return NewtonResult(w, False, it + 1, "diverging", history, first, corrections)
        step = _admissible_step(problem, w, delta, g, options.max_halvings, stats)
        if step is None:
            return NewtonResult(w, False, it + 1, "inverted element", history, first, corrections)
        w, r, _ = step
        rn = float(np.linalg.norm(r[free]))
        history.append(rn)
        if rn <= options.rtol * rref:
            dbar = back_solve(-r[free])
            if float(np.abs(dbar[nu_free]).max()) <= options.utol:
                return NewtonResult(w, True, it + 1, "", history, first, corrections)
    return NewtonResult(w, False, options.max_iterations, "max iterations", history, first, corrections)


def pseudo_transient(problem, w, g, solver, options: NewtonOptions, stats: Stats,
                     shift=100.0, max_iterations=80, radius=0.1, negatives=None,
                     sigma_floor=1e-2) -> NewtonResult:
    """Pseudo-transient continuation to a stable equilibrium at gravity ``g``.

    Used where a branch ends at a fold and the sheet must snap to the other
    branch, which plain Newton cannot reach, and to leave an unstable
    equilibrium.  Iterates (Kelley & Keyes, SIAM J. Numer. Anal. 35, 1998)::

        (K(w) + sigma M) dw = -r(w)

    with the displacement mass matrix ``M``: a damped, gradient-flow-like path
    that is drawn to stable equilibria, turning into Newton as ``sigma -> 0``.

    The shift is controlled by the inertia of the shifted tangent and by the
    step length, never by ratios of residual norms (which near convergence are
    ratios of round-off and made the old schedule, and so the iteration count
    and the end state, depend on it):

    - a shifted tangent with a negative direction on the incompressible
      subspace (``negatives(problem, solver) > 0``) is refactorised with
      ``sigma`` four times larger (``sigma_floor`` if it was 0): every step is
      a descent step of a convex model, which repels from saddles;
    - a step whose largest displacement exceeds ``radius`` is cut to it, and a
      cut (or halved) step doubles ``sigma``; a full step divides it by four,
      and below ``sigma_floor`` it becomes exactly 0 (plain Newton);
    - steps that invert an element are halved.

    Stopping rule: a plain Newton step (``sigma = 0``) whose tangent has no
    negative direction (or whose inertia the back-end cannot report) and
    whose largest displacement is at most ``options.utol``.  This is meant as
    a loose settle (e.g. ``utol = 1e-3``) to be followed by a tight
    :func:`newton` solve from ``w``, which defines the end state.

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

    Returns
    -------
    NewtonResult
        ``converged`` False with a ``reason`` if it did not settle in
        ``max_iterations`` steps, or a step could not avoid inverted elements.
    """
    free = problem.free
    nu_free = free < problem.nu_dof
    M = problem.mass_data
    w = w.copy()
    r, Jmin = timed(stats, "assembly_s", problem.residual, w, g)
    stats.residual_evaluations += 1
    if not Jmin > 0:
        return NewtonResult(w, False, 0, "inverted element in the initial guess")
    history, corrections = [float(np.linalg.norm(r[free]))], []
    sigma = float(shift)
    sigma_max = 1e6 * max(float(shift), sigma_floor)
    for it in range(max_iterations):
        K = timed(stats, "assembly_s", problem.tangent, w)
        while True:
            A = K if sigma == 0.0 else sp.csr_matrix((K.data + sigma * M, K.indices, K.indptr),
                                                     shape=K.shape)
            try:
                timed(stats, "linear_solve_s", solver.factorize, A, w)
                stats.factorizations += 1
                k = negatives(problem, solver) if negatives is not None else None
            except LinearSolverError:
                k = -1  # singular: more damping
            if k is None or k == 0:
                break
            sigma = max(4.0 * sigma, sigma_floor)
            if sigma > sigma_max:
                return NewtonResult(w, False, it, "no shift makes the tangent positive definite",
                                    history, 0.0, corrections)
        delta = timed(stats, "linear_solve_s", solver.solve, -r[free])
        stats.newton_iterations += 1
        if not np.all(np.isfinite(delta)):
            return NewtonResult(w, False, it + 1, "NaN in the increment", history, 0.0, corrections)
        du = float(np.abs(delta[nu_free]).max())
        corrections.append(du)
        if sigma == 0.0 and du <= options.utol:
            return NewtonResult(w, True, it + 1, "", history, 0.0, corrections)
        cut = min(1.0, radius / du) if du > 0 else 1.0
        step = _admissible_step(problem, w, cut * delta, g, options.max_halvings, stats)
        if step is None:
            return NewtonResult(w, False, it + 1, "inverted element", history, 0.0, corrections)
        w, r, alpha = step
        history.append(float(np.linalg.norm(r[free])))
        if cut < 1.0 or alpha < 1.0:
            sigma = max(2.0 * sigma, sigma_floor)
        else:
            sigma = sigma / 4.0 if sigma / 4.0 >= sigma_floor else 0.0
    return NewtonResult(w, False, max_iterations, "pseudo-transient iteration did not settle",
                        history, 0.0, corrections)
