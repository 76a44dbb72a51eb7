"""Stability of an equilibrium from the inertia of its constrained tangent."""
from __future__ import annotations

import numpy as np

__all__ = ["stability"]


def stability(problem, solver):
    """``(stable, n_negative)`` from the inertia of the last factorised tangent.

    The reduced tangent ``[[A, B^T], [B, 0]]`` with ``m`` free pressure dofs
    (``B`` of full rank) has ``m + k`` negative eigenvalues, where ``k`` is the
    number of negative eigenvalues of ``A`` on the incompressible subspace
    ``ker B`` (Sylvester's law of inertia on the null-space decomposition).
    The equilibrium is stable iff ``k = 0`` and no eigenvalue vanishes.

    Returns ``(None, None)`` -- stability unknown -- if the back-end does not
    report the inertia, or if its last factorisation perturbed pivots
    (``solver.perturbed_pivots > 0``, PARDISO's ``iparm(14)``): the pivot
    counts are then those of a nearby matrix, and an eigenvalue at or near
    zero (a fold) may have been counted on either side.
    """
    if getattr(solver, "perturbed_pivots", 0):
        return None, None
    inertia = getattr(solver, "inertia", None)
    inertia = inertia() if inertia is not None else None
    if inertia is None:
        return None, None
    _, n_neg, n_zero = inertia
    m = int(np.count_nonzero(problem.free >= problem.nu_dof))
    k = int(n_neg) - m
    return bool(k == 0 and n_zero == 0), k
