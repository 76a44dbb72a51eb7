"""The cusp of a fold curve: where its two folds meet and the bistable range closes.

Three ways, by what is known: :func:`turning_point` (a traced curve whose
fold coefficient's sign change was not seen: where the second parameter turns
back), :func:`cusp_by_coefficient` (refined points whose fold coefficient
changes sign: located on the fine mesh) and :func:`fine_cusp` (refined points
without that sign change: the turn of the second parameter).
"""
from __future__ import annotations

import numpy as np

from ..engine import fold_on_section
from .options import SECOND

__all__ = ["CUSP_ITERATIONS", "CUSP_STEP", "CUSP_TOL", "cusp_by_coefficient", "fine_cusp",
           "turning_point"]

#: The cusp of a refined curve is located on the fine mesh until the second
#: parameter (b/a or a/R) changes by less than this between two corrections
#: and the fold coefficient's sign change is bracketed, in at most
#: :data:`CUSP_ITERATIONS` fold corrections, each at most
#: :data:`CUSP_STEP` (tip deflection / a) from a fold point already found.
CUSP_TOL = 2e-4
CUSP_ITERATIONS = 8
CUSP_STEP = 0.01


def cusp_by_coefficient(points, j, tol):
    """The cusp of a refined curve, where the fold coefficient ``a`` vanishes.

    ``points``: the refined points (:class:`~skfem_sheet.foldcurve.refine.KeptPoint`,
    in the order of the curve); the cusp is looked for only if their ``a``
    changes sign.  Along the curve the vertical deflection of the tip ``d`` is a regular
    parameter also through the cusp (neither L nor the second parameter is),
    so the fine fold points are computed on sections ``d = d_k``
    (:func:`~skfem_sheet.engine.fold_on_section`, L and the second parameter
    free), each predicted linearly in ``d`` from the two fold points nearest
    to ``d_k``, with ``d_k`` the secant zero of ``a(d)`` (inside the
    bracket of the sign change once two points close enough bracket it, and
    at most :data:`CUSP_STEP` from a point found).  The curve's points next
    to the cusp may all lie on one side of it (the coarse cusp is not the
    fine one), hence the steps rather than an interpolation across the
    sign change.  Stops when the second parameter changes by less than
    :data:`CUSP_TOL` between two corrections with the sign change bracketed
    (it is stationary at the cusp along the curve: its error is second order
    in that of ``d``).

    Returns ``(cusp or None, factorisations)``; the cusp is the fold point of
    smallest ``|a|``.
    """
    name, key = SECOND[j]
    a = [q.a for q in points]
    change = [k for k in range(len(points) - 1) if a[k] * a[k + 1] < 0]
    if not change:
        return None, 0
    k = change[0]
    # the fold points near the cusp on one fine mesh (of the point of the
    # sign change with the smaller |a|), sorted by tip deflection
    home = points[k] if abs(a[k]) < abs(a[k + 1]) else points[k + 1]
    P = home.problem
    known = sorted(((q.tip, q.a, q.u, q.p, q.v) for q in points if q.problem is P),
                   key=lambda r: r[0])
    if len(known) < 2:
        return None, 0
    e = np.zeros_like(home.u)
    e[P.tip_index] = 1.0
    scale = P.inner(e, e)
    f0, spent = P.refactorizations, 0
    best, last_q, step = None, None, CUSP_STEP
    for _ in range(CUSP_ITERATIONS):
        d = np.array([r[0] for r in known])
        av = np.array([r[1] for r in known])
        # the secant zero of a(d): through the bracketing pair closest
        # together, else through the two points of smallest |a|
        pairs = [(i, i + 1) for i in range(len(known) - 1) if av[i] * av[i + 1] < 0]
        if pairs:
            lo, hi = min(pairs, key=lambda ij: d[ij[1]] - d[ij[0]])
        else:
            lo, hi = sorted(np.argsort(np.abs(av))[:2])
        if av[hi] == av[lo]:
            break
        target = d[lo] - av[lo] * (d[hi] - d[lo]) / (av[hi] - av[lo])
        if pairs:  # strictly inside the bracket
            target = float(np.clip(target, d[lo] + 0.05 * (d[hi] - d[lo]),
                                   d[hi] - 0.05 * (d[hi] - d[lo])))
        near = int(np.argmin(np.abs(d - target)))
        target = float(np.clip(target, d[near] - step, d[near] + step))
        # linear prediction in d from the two known points nearest to target
        i1, i2 = sorted(np.argsort(np.abs(d - target))[:2])
        w = (target - d[i1]) / (d[i2] - d[i1])
        r1, r2 = known[i1], known[i2]
        v2 = r2[4] if P.inner(r1[4], r2[4]) >= 0 else -r2[4]
        u = r1[2] + w * (r2[2] - r1[2])
        p = r1[3] + w * (r2[3] - r1[3])
        fold, res = fold_on_section(P, u, p, ("L", name),
                                    (e, np.zeros_like(p), scale * target),
                                    v0=r1[4] + w * (v2 - r1[4]), tol=tol)
        spent += res.stats.factorizations if fold is None else fold.stats.factorizations
        if fold is None:
            step = 0.5 * min(step, abs(target - d[near]) or step)
            if step < 1e-4:
                break
            continue
        if best is None or abs(fold.a) < abs(best.a):
            best = fold
        tip = float(fold.u[P.tip_index])
        known = sorted([*known, (tip, float(fold.a), fold.u, np.array(fold.p), fold.v)],
                       key=lambda r: r[0])
        q = float(fold.p[j])
        bracketed = any(r[1] * fold.a <= 0 for r in known)
        if fold.a == 0 or (bracketed and last_q is not None and abs(q - last_q) < CUSP_TOL):
            break
        last_q = q
    spent += P.refactorizations - f0
    if best is None:
        return None, spent
    return {key: float(best.p[j]), "length": float(best.p[0])}, spent


def fine_cusp(points, j):
    """The cusp of refined points: the vertex of the parabola through the
    three points of the smallest second parameter, in the tip deflection
    (along the curve the second parameter has a regular minimum at the cusp,
    where its projection turns back); None if that minimum is at an end.

    ``points`` have ``tip`` and ``p`` (:class:`~skfem_sheet.foldcurve.refine.RefinedPoint`).

    Examples
    --------
    >>> from types import SimpleNamespace as Point
    >>> pts = [Point(tip=d, p=np.array([L, b]))
    ...        for d, b, L in ((0.1, 0.7, 1.3), (0.2, 0.64, 1.25), (0.3, 0.7, 1.22))]
    >>> {k: round(v, 4) for k, v in fine_cusp(pts, 1).items()}
    {'tip_width': 0.64, 'length': 1.25}
    """
    if len(points) < 3:
        return None
    d = np.array([q.tip for q in points])
    b = np.array([q.p[j] for q in points])
    L = np.array([q.p[0] for q in points])
    k = int(np.argmin(b))
    if k == 0 or k == len(points) - 1:
        return None
    sl = slice(k - 1, k + 2)
    cb, cL = np.polyfit(d[sl], b[sl], 2), np.polyfit(d[sl], L[sl], 2)
    d_star = -cb[1] / (2 * cb[0]) if cb[0] > 0 else d[k]
    d_star = float(np.clip(d_star, min(d[k - 1], d[k + 1]), max(d[k - 1], d[k + 1])))
    return {SECOND[j][1]: float(np.polyval(cb, d_star)), "length": float(np.polyval(cL, d_star))}


def turning_point(points, key):
    """The cusp of a completed curve whose fold coefficient's sign change was
    not seen: where ``key`` turns back (its minimum over the points, refined
    by a parabola through the three points around it in the arclength).

    Examples
    --------
    >>> pts = [{"tip_width": b, "length": L} for b, L in
    ...        ((1.0, 1.35), (0.7, 1.3), (0.64, 1.25), (0.7, 1.22), (1.0, 1.21))]
    >>> {k: round(v, 4) for k, v in turning_point(pts, "tip_width").items()}
    {'tip_width': 0.6397, 'length': 1.253}
    """
    q = np.array([pt[key] for pt in points])
    L = np.array([pt["length"] for pt in points])
    k = int(np.argmin(q))
    if k == 0 or k == len(q) - 1:
        return None
    s = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(q), np.diff(L)))])
    idx = slice(k - 1, k + 2)
    cq, cL = np.polyfit(s[idx], q[idx], 2), np.polyfit(s[idx], L[idx], 2)
    s_min = -cq[1] / (2 * cq[0]) if cq[0] > 0 else s[k]
    s_min = float(np.clip(s_min, s[k - 1], s[k + 1]))
    return {key: float(np.polyval(cq, s_min)), "length": float(np.polyval(cL, s_min))}
