"""Observables of a deformed sheet: tip deflection, mid-line profiles.

Deflection (paper, caption of Fig. 1): the signed vertical distance from the
lowest point of the clamped edge to that of the free edge, positive downward::

    d = min_{clamp} z  -  min_{free edge} z

on the deformed mid-surface ``z = 0``.  The clamped edge is the mid-line of
the face ``x = 0``.  The free edge is the tip outline, the boundary opposite
the clamp: for a trapezoid the mid-line of the face ``x = L`` (for a triangle
its tip point), for a :class:`~skfem_sheet.params.Planform` what remains of
the cut ``x = L`` together with the bite arcs (the sides ``|y| = p(x)/2`` are
not part of it).  Its points are recorded by the mesh
(:attr:`skfem_sheet.mesh.SheetMesh.free_edge`: the vertices and edge
midpoints of the plan's boundary edges on the tip curves), and their
mid-plane nodes are :func:`free_edge_nodes`; for a trapezoid these are
exactly the nodes of the mid-line ``x = L``, so d is the value it always was.
Both edges carry quadratic nodes of the mesh (see :mod:`skfem_sheet.mesh`).
"""
from __future__ import annotations

import weakref

import numpy as np
from scipy.spatial import cKDTree

__all__ = ["free_edge_nodes", "midline_heights", "midline_nodes", "tip_deflection"]

#: free-edge node indices per mesh (they do not change when a space is stretched)
_FREE_EDGE = weakref.WeakKeyDictionary()


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


def free_edge_nodes(problem):
    """Indices of the mid-plane nodes on the free edge (the tip outline), sorted by y.

    A mesh without a recorded free edge (built by hand) uses the mid-line
    ``x = length``.  A stretched problem (``with_length``) has the same nodes.
    """
    sm = problem.sheet_mesh
    edge = getattr(sm, "free_edge", None)
    if edge is None:
        return midline_nodes(problem, problem.length)
    idx = _FREE_EDGE.get(sm)
    if idx is None:
        X = problem.nodes
        tol = 1e-9 * max(1.0, sm.length)
        cand = np.flatnonzero(np.abs(X[:, 2]) < tol)
        ref = np.column_stack([X[cand, 0] * (sm.length / problem.length), X[cand, 1]])
        dist, _ = cKDTree(np.asarray(edge)).query(ref)
        idx = cand[dist < tol]
        if len(idx) == 0:
            raise RuntimeError("no mesh node on the free edge")
        idx = idx[np.argsort(X[idx, 1], kind="stable")]
        idx.setflags(write=False)
        _FREE_EDGE[sm] = idx
    return idx


def tip_deflection(problem, w):
    """Signed tip deflection d (positive downward): lowest clamp point minus lowest
    free-edge point, on the deformed mid-surface (see the module docstring)."""
    _, zc = midline_heights(problem, w, 0.0)
    idx = free_edge_nodes(problem)
    U, _ = problem.split(w)
    zf = problem.nodes[idx, 2] + U[idx, 2]
    return float(zc.min() - zf.min())
