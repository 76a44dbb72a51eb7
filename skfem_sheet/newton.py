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
                     shift=100.0, max_iterations=150) -> NewtonResult:
    """Pseudo-transient continuation to a stable equilibrium at gravity ``g``.

    Used where a branch ends at a fold and the sheet must snap to the other
    branch, which plain Newton cannot reach.  Iterates (Kelley & Keyes, SIAM
    J. Numer. Anal. 35, 1998)::

        (K(w) + sigma M) dw = -r(w),      sigma_{k+1} = sigma_k |r_k| / |r_{k-1}|

    with the displacement mass matrix ``M``: a damped, gradient-flow-like path
    that is drawn to stable equilibria, turning into Newton (``sigma -> 0``)
    as the residual falls.  Steps that invert an element are halved.
    Converged on the same test as :func:`newton` once ``sigma`` is negligible.

    ``max_iterations`` is generous because a symmetric half model can only
    snap along mirror-symmetric shapes, a slower route than the whole sheet's
    (pop-up of L/a = 1.3, a/R = 6 at hmax 0.1: 92 iterations against 39).
    """
    free = problem.free
    nu_free = free < problem.nu_dof
    rref = float(np.linalg.norm(problem.gravity_load[free]))
    M = problem.mass_data
    w = w.copy()
    r, Jmin = timed(stats, "assembly_s", problem.residual, w, g)
    if not Jmin > 0:
        return NewtonResult(w, False, 0, "inverted element in the initial guess")
    rn = float(np.linalg.norm(r[free]))
    history, corrections = [rn], []
    sigma = shift
    for it in range(max_iterations):
        K = timed(stats, "assembly_s", problem.tangent, w)
        A = sp.csr_matrix((K.data + sigma * M, K.indices, K.indptr), shape=K.shape)
        try:
            timed(stats, "linear_solve_s", solver.factorize, A, w)
            delta = timed(stats, "linear_solve_s", solver.solve, -r[free])
        except LinearSolverError:
            sigma *= 10.0  # singular: more damping
            continue
        stats.factorizations += 1
        stats.newton_iterations += 1
        corrections.append(float(np.abs(delta[nu_free]).max()))
        step = _admissible_step(problem, w, delta, g, options.max_halvings, stats)
        if step is None:
            return NewtonResult(w, False, it + 1, "inverted element", history, 0.0, corrections)
        wt, rt, alpha = step
        rnt = float(np.linalg.norm(rt[free]))
        # switched evolution relaxation, bounded to stay well conditioned
        sigma = float(np.clip(sigma * rnt / max(rn, 1e-300), 1e-12, 1e6))
        w, r, rn = wt, rt, rnt
        history.append(rn)
        if sigma < 1e-6 and rn <= options.rtol * rref and corrections[-1] * alpha <= options.utol:
            return NewtonResult(w, True, it + 1, "", history, 0.0, corrections)
    return NewtonResult(w, False, max_iterations, "pseudo-transient iteration did not settle",
                        history, 0.0, corrections)
