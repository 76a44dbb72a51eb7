"""Observables of a deformed sheet: tip deflection, mid-line profiles.

Deflection (paper, caption of Fig. 1): the signed vertical distance from the
lowest point of the clamped edge to that of the free edge, positive downward::

    d = min_y z(0, y, 0) - min_y z(L, y, 0)

evaluated on the deformed mid-lines ``z = 0`` of the clamped face ``x = 0`` and
of the free edge ``x = L`` (for a triangle the free edge is the tip point).
Both mid-lines carry quadratic nodes of the mesh (see :mod:`skfem_sheet.mesh`).
"""
from __future__ import annotations

import numpy as np

__all__ = ["midline_nodes", "midline_heights", "tip_deflection"]


def midline_nodes(problem, x):
    """Indices of the quadratic nodes on the mid-line ``(x, y, 0)``, sorted by y."""
    X = problem.nodes
    tol = 1e-9 * max(1.0, problem.length)
    idx = np.flatnonzero((np.abs(X[:, 0] - x) < tol) & (np.abs(X[:, 2]) < tol))
    if len(idx) == 0:
        raise RuntimeError(f"no mesh node on the mid-line x = {x}")
    return idx[np.argsort(X[idx, 1])]


def midline_heights(problem, w, x):
    """Reference ``y`` and deformed height ``z + U_z`` along the mid-line at ``x``."""
    idx = midline_nodes(problem, x)
    U, _ = problem.split(w)
    X = problem.nodes[idx]
    return X[:, 1], X[:, 2] + U[idx, 2]


def tip_deflection(problem, w):
    """Signed tip deflection d (positive downward)."""
    _, zc = midline_heights(problem, w, 0.0)
    _, zf = midline_heights(problem, w, problem.length)
    return float(zc.min() - zf.min())
