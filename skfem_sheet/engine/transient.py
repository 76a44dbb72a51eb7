"""Pseudo-transient continuation: the engine's way to a stable equilibrium.

Where a branch ends at a fold the state must move to another branch, which
the Newton corrector (:func:`~skfem_sheet.engine.corrector.correct`) cannot
reach; and an unstable equilibrium must be left.  This iterates (Kelley &
Keyes, SIAM J. Numer. Anal. 35, 1998)::

    (K(u) + sigma M) du = -R(u)

with a mass (or any positive definite) matrix ``M``: a damped,
gradient-flow-like path that is drawn to stable equilibria and turns into
Newton as ``sigma -> 0``.  The shift is controlled by the inertia of the
shifted tangent and by the step length, never by ratios of residual norms
(which near convergence are ratios of round-off and would make the iteration
count and the end state depend on it).

The system is given by a small protocol (:class:`TransientSystem`), so that
the iteration knows nothing of the problem behind it.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..params import check_range
from .protocol import EngineFailure

__all__ = ["SHIFT_MEMORY_FADE", "TransientResult", "TransientSystem", "pseudo_transient"]

#: Per step, the remembered shift that left a negative direction (see
#: :func:`pseudo_transient`) is divided by this: the memory must outlast the
#: step or two in which the step-length rule would bring the shift below it
#: again, and be gone once the state is past the saddle (the shift can then
#: fall by ``max_decrease``, 64, per step); ``docs/decisions.md``, "The
#: shift's memory".
SHIFT_MEMORY_FADE = 16.0


class TransientSystem:
    """What :func:`pseudo_transient` needs of a problem (a protocol).

    ``u`` is the state, ``du`` a correction of the same shape.
    """

    def residual(self, u):  # pragma: no cover - protocol
        """``R(u)``, or ``None`` if ``u`` is inadmissible (e.g. an inverted
        element, a non-finite residual)."""
        raise NotImplementedError

    def tangent(self, u):  # pragma: no cover - protocol
        """The tangent at ``u`` (assembled once per step)."""
        raise NotImplementedError

    def factorize(self, K, u, sigma):  # pragma: no cover - protocol
        """Factorise ``K + sigma M``; return the number of its negative
        directions that matter (``None``: unknown).  Raise
        :class:`~skfem_sheet.engine.protocol.EngineFailure` if singular."""
        raise NotImplementedError

    def correction(self, r):  # pragma: no cover - protocol
        """``du = -(K + sigma M)^{-1} r`` with the last factorisation."""
        raise NotImplementedError

    def residual_norm(self, r) -> float:
        return float(np.linalg.norm(r))

    def correction_norm(self, du) -> float:
        return float(np.abs(du).max()) if np.size(du) else 0.0


@dataclass(frozen=True)
class TransientResult:
    """Outcome of :func:`pseudo_transient`.

    Attributes
    ----------
    u : ndarray
        The settled state if converged, else the last iterate.
    converged : bool
    iterations : int
        Steps (one linear solve each).
    reason : str
        Why not converged ("" if converged).
    residuals : tuple
        Residual norm at each iterate.
    corrections : tuple
        Correction norm of each step.
    """

    u: np.ndarray
    converged: bool
    iterations: int
    reason: str = ""
    residuals: tuple = ()
    corrections: tuple = ()


def pseudo_transient(system, u, *, utol: float, shift: float = 100.0,
                     max_iterations: int = 80, radius: float = 0.1,
                     sigma_floor: float = 1e-2, max_halvings: int = 6,
                     max_decrease: float = 4.0) -> TransientResult:
    """Pseudo-transient continuation from ``u`` to a stable equilibrium.

    Shift control:

    - a shifted tangent with a negative direction (``system.factorize``
      returns more than 0) or a singular one is refactorised with a larger
      ``sigma`` (``sigma_floor`` if it was 0): every step is a descent step
      of a convex model, which repels from saddles.  The first
      refactorisation of a step quadruples ``sigma``, each further one
      multiplies the last factor by four (x4, x16, x64, ...): the shift
      needed is not known (the inertia counts the eigenvalues below
      ``-sigma``, not how far below), a shift too large only shortens a step
      (the step-length rule below lowers it again by up to ``max_decrease``
      at the next), while each one too small costs a factorisation (after a
      snap the shift needed grows by 10-100 from one state to the next);
    - the largest shift found to leave a negative direction is remembered:
      the tangent changes little over one step, so the next steps do not
      lower ``sigma`` below four times it, and the memory fades by
      :data:`SHIFT_MEMORY_FADE` per step (without it, the step-length rule
      below divides ``sigma`` by up to ``max_decrease`` back into the range
      just found too small at a nearby state, and each such step costs
      several refactorisations again);
    - a step whose correction norm exceeds ``radius`` is cut to it, and a cut
      (or halved) step doubles ``sigma``; a full step divides it by four, and
      below ``sigma_floor`` it becomes exactly 0 (plain Newton); while full
      steps are much shorter than ``radius`` (the shift dominates the
      tangent, so the step length scales like ``1/sigma``) it is divided by
      up to ``max_decrease`` instead, aiming at a step of half the radius
      (after a snap the shift can be 1e6 times larger than at the end, and
      four at a time that is ten steps of crawling);
    - steps to inadmissible states are halved (``max_halvings`` times).

    Stopping rule: a plain Newton step (``sigma = 0``) whose tangent has no
    negative direction (or an unknown inertia) and whose correction norm is at
    most ``utol``; the state at which it was computed is returned.  This is a
    settle, to be followed by a tight Newton solve that defines the end state.

    Parameters
    ----------
    system : TransientSystem
    u : ndarray
        Start.
    utol : float
        Bound on the last plain Newton correction.
    shift : float
        Initial ``sigma``.
    max_iterations : int
        Steps (refactorisations for a larger ``sigma`` are not steps).
    radius : float
        Largest correction norm of one step.
    sigma_floor : float
        Smallest non-zero shift.
    max_halvings : int
    max_decrease : float
        Largest division of ``sigma`` after a full step (at least 4; 4 gives
        the fixed quartering).

    Returns
    -------
    TransientResult

    Examples
    --------
    A double well ``E = u^4/4 - u^2/2`` from its saddle's neighbourhood: the
    settle goes down to a minimum (``u = 1``), where plain Newton from the
    same start would converge to the saddle ``u = 0``.

    >>> class Well(TransientSystem):
    ...     def residual(self, u): return u**3 - u
    ...     def tangent(self, u): return 3 * u**2 - 1
    ...     def factorize(self, K, u, sigma):
    ...         self.a = K + sigma
    ...         return int(np.sum(self.a < 0))
    ...     def correction(self, r): return -r / self.a
    >>> res = pseudo_transient(Well(), np.array([0.01]), utol=1e-10, shift=1.0)
    >>> res.converged, round(float(res.u[0]), 8)
    (True, 1.0)
    """
    check_range("utol", utol, 0, None, lo_open=True)
    check_range("radius", radius, 0, None, lo_open=True)
    check_range("max_iterations", max_iterations, 1, 100000)
    check_range("max_decrease", max_decrease, 4, 1e6)
    u = np.array(u, dtype=float)
    r = system.residual(u)
    if r is None:
        return TransientResult(u, False, 0, "inadmissible initial state")
    history, corrections = [system.residual_norm(r)], []

    def result(ok, it, reason=""):
        return TransientResult(u, ok, it, reason, tuple(history), tuple(corrections))

    sigma = float(shift)
    sigma_max = 1e6 * max(float(shift), sigma_floor)
    too_small = 0.0  # the largest shift found to leave a negative direction, fading
    for it in range(max_iterations):
        K = system.tangent(u)
        grow = 4.0
        while True:
            try:
                k = system.factorize(K, u, sigma)
            except EngineFailure:
                k = -1  # singular: more damping
            if k is None or k == 0:
                break
            too_small = max(too_small, sigma)
            if sigma >= sigma_max:
                return result(False, it, "no shift makes the tangent positive definite")
            sigma = min(max(grow * sigma, sigma_floor), sigma_max)
            grow *= 4.0
        du = system.correction(r)
        if not np.all(np.isfinite(du)):
            return result(False, it + 1, "NaN in the increment")
        dn = system.correction_norm(du)
        corrections.append(dn)
        if sigma == 0.0 and dn <= utol:
            return result(True, it + 1)
        cut = min(1.0, radius / dn) if dn > 0 else 1.0
        d = cut * du
        alpha = 1.0
        for _ in range(max_halvings + 1):
            ut = u + alpha * d
            rt = system.residual(ut)
            if rt is not None:
                break
            alpha *= 0.5
        else:
            return result(False, it + 1, "inadmissible trial states")
        u, r = ut, rt
        history.append(system.residual_norm(r))
        if cut < 1.0 or alpha < 1.0:
            sigma = max(2.0 * sigma, sigma_floor)
        else:
            # a full step: divide by 4, or while the step is much shorter
            # than the radius (the shift dominates: dn ~ 1/sigma) by up to
            # max_decrease, aiming at a step of half the radius
            aim = 0.5 * radius / dn if dn > 0 else max_decrease
            f = min(max_decrease, max(4.0, aim))
            sigma = max(sigma / f, 4.0 * too_small)
            sigma = sigma if sigma >= sigma_floor else 0.0
        too_small /= SHIFT_MEMORY_FADE
    return result(False, max_iterations, "pseudo-transient iteration did not settle")
