"""Paths through parameter space: one equilibrium carried along a polyline in (L, b, a/R).

The paper's conclusion: bistability "may be avoided ... by reducing the shape
factor, increasing the length, and then increasing the shape factor".
:func:`follow` carries one equilibrium of the half sheet along a polyline
through ``(L/a, b/a, a/R)``: natural continuation with the engine
(:func:`skfem_sheet.engine.natural`) on the mapped mesh of
:class:`skfem_sheet.sheet_shape.SheetFoldProblem` (the length by stretching in
x, the tip width by mapping in y, the curvature through the clamp), one
segment after the other, each parametrised by ``t`` in [0, 1].  Where the
branch is lost -- at a located fold, or where the continuation cannot go on
-- the sheet *jumps*: it is solved just beyond that point along both load
paths (curvature-first and gravity-first) and the solution farthest from the
lost state is taken (beyond a fold the old branch does not exist, so both
land on the other branch); the jump is recorded (where, the deflection
before and after) and the continuation goes on from there.  The mesh is made
afresh at a vertex of the polyline where the map would distort it beyond the
remesh rule of :mod:`skfem_sheet.sheet_shape` (segments are cut into pieces
that one mesh, made in the middle of the piece, serves; the state is
transferred).

Examples
--------
>>> from skfem_sheet import Sheet
>>> r = follow(Sheet(length=1.2, curvature=2.5), [(1.45, 1.0, 2.5)],
...            hmax=0.1)  # doctest: +SKIP
>>> r.jumped, r.jumps[0]["at"][0]  # doctest: +SKIP
(True, 1.35)
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from .analyses.observables import tip_deflection
from .engine import Problem, natural
from .params import ParameterError, Sheet, check_range
from .sheet_shape import TOLERANCES, SheetFoldProblem, remesh_pieces

__all__ = ["PathResult", "follow"]

#: A step of the continuation whose state moved further than this (correction
#: norm, displacement / a) from its prediction landed on another branch.
JUMP = 0.1
#: Largest number of jumps on one segment.
MAX_JUMPS = 5


class _Segment(Problem):
    """The fold problem along the segment ``p(t) = a + t (b - a)``."""

    parameter_names = ("t",)

    def __init__(self, P, a, b):
        self.P, self.a, self.d = P, np.asarray(a, float), np.asarray(b, float) - a

    def at(self, t):
        return self.a + float(np.asarray(t).ravel()[0]) * self.d

    def residual(self, u, t):
        return self.P.residual(u, self.at(t))

    def jacobian(self, u, t):
        return self.P.jacobian(u, self.at(t))

    def factorize(self, J):
        return self.P.factorize(J)

    def dual(self, a):
        return self.P.dual(a)

    def residual_norm(self, r):
        return self.P.residual_norm(r)

    def correction_norm(self, du):
        return self.P.correction_norm(du)


@dataclass(frozen=True)
class PathResult:
    """An equilibrium carried along a polyline.

    Attributes
    ----------
    points : tuple of dict
        ``{"length", "tip_width", "curvature", "deflection", "segment"}`` in
        the order followed (d/a positive downward); after a jump the first
        point is the state it landed in.
    jumps : tuple of dict
        ``{"segment", "at", "deflection_before", "deflection_after", "jump",
        "fold", "path"}``: ``at`` = ``(L, b, a/R)`` where the branch was lost
        (the located fold if ``fold``), ``jump`` = after - before, ``path``
        the load path that found the landing state.
    through : tuple
        The vertices of the polyline (the start included).
    factorizations : int
    remeshes : int
    wall_time_s : float
    hmax : float
    """

    points: tuple
    jumps: tuple
    through: tuple
    factorizations: int
    remeshes: int
    wall_time_s: float
    hmax: float

    @property
    def jumped(self) -> bool:
        """Whether the equilibrium jumped anywhere on the path."""
        return bool(self.jumps)

    @property
    def start_deflection(self) -> float:
        return self.points[0]["deflection"]

    @property
    def end_deflection(self) -> float:
        return self.points[-1]["deflection"]

    def summary(self) -> dict:
        """JSON-ready."""
        return {"through": [list(p) for p in self.through], "hmax": self.hmax,
                "jumped": self.jumped, "jumps": [dict(j) for j in self.jumps],
                "points": [dict(p) for p in self.points],
                "start_deflection": self.start_deflection,
                "end_deflection": self.end_deflection,
                "factorizations": self.factorizations, "remeshes": self.remeshes,
                "wall_time_s": self.wall_time_s}


def _vertex(v, what):
    try:
        L, b, k = (float(x) for x in v)
    except (TypeError, ValueError):
        raise ParameterError(f"{what} must be (L, b, a/R), got {v!r}") from None
    check_range(f"{what} length", L, 0.05, 20.0)
    check_range(f"{what} tip width", b, 0.0, 1.0, lo_open=True)
    check_range(f"{what} curvature", k, 0.0, 2 * np.pi, lo_open=True, hi_open=True)
    return np.array([L, b, k])


def follow(sheet: Sheet, through, hmax: float = 0.1, *, step: float = 0.05, layers=None,
           solver: str = "auto", start_path: str = "curvature-first",
           snap_step: float = 0.01) -> PathResult:
    """Carry one equilibrium of ``sheet`` along the polyline ``through``.

    Parameters
    ----------
    sheet : Sheet
        The start: its length, tip width and curvature (and its thickness
        and modulus, kept along the path).
    through : sequence of (L, b, a/R)
        The vertices after the start.
    hmax : float
        Mesh size.
    step : float
        First and largest continuation step, in the parameter ``t`` of a
        segment (scaled so that ``t`` in [0, 1] spans the segment).
    start_path : {"curvature-first", "gravity-first"}
        Load path of the first solve: which equilibrium to start from.
    snap_step : float
        Where the branch is lost, the landing state is solved this far
        beyond it (in parameter-space distance).

    Returns
    -------
    PathResult

    Examples
    --------
    >>> follow(Sheet(length=1.2), [(1.3, 1.0)])
    Traceback (most recent call last):
    ...
    skfem_sheet.params.ParameterError: through[0] must be (L, b, a/R), got (1.3, 1.0)
    """
    if not isinstance(sheet, Sheet):
        raise ParameterError(f"sheet must be a Sheet, got {type(sheet).__name__}")
    if start_path not in ("curvature-first", "gravity-first"):
        raise ParameterError(f"start_path must be 'curvature-first' or 'gravity-first', got "
                             f"{start_path!r}")
    if isinstance(through, (str, bytes)) or not hasattr(through, "__len__") or not through:
        raise ParameterError(f"through must be a non-empty list of (L, b, a/R), got {through!r}")
    hmax = check_range("hmax", hmax, 0.02, 0.5)
    step = check_range("step", step, 0.0, 1.0, lo_open=True)
    snap_step = check_range("snap_step", snap_step, 0.0, 0.5, lo_open=True)
    verts = [_vertex(v, f"through[{i}]") for i, v in enumerate(through)]
    p0 = _vertex((sheet.length, sheet.tip_width, sheet.curvature), "the sheet's")
    t0 = time.perf_counter()

    def make(L, b, k):
        return SheetFoldProblem(k, hmax, mesh_length=L, mesh_tip_width=b,
                                thickness=sheet.thickness, modulus=sheet.modulus,
                                layers=layers, solver=solver)

    P = make(*p0)
    remeshes, nfact = 0, 0
    u, f = P.solve_state(p0, start_path)
    nfact += f

    def deflection(P, u, p):
        return tip_deflection(P.problem(p), P.full(u, p))

    points = [dict(length=p0[0], tip_width=p0[1], curvature=p0[2],
                   deflection=deflection(P, u, p0), segment=-1)]
    jumps = []
    pieces = []  # (segment index, start, end): segments cut so that one mesh serves a piece
    a = p0
    for k, b in enumerate(verts):
        n = remesh_pieces(a, b)
        for m in range(n):
            pieces.append((k, a + (b - a) * m / n, a + (b - a) * (m + 1) / n))
        a = b
    for k, a, b in pieces:
        if P.needs_remesh(a) or P.needs_remesh(b):
            Q = make(*np.sqrt(a * b))  # a mesh in the geometric middle of the piece
            u = P.transferred(Q, u, a)
            P, remeshes = Q, remeshes + 1
        length = float(np.linalg.norm(b - a))
        if length == 0:
            continue
        seg = _Segment(P, a, b)
        t = 0.0
        n_jumps = 0
        while t < 1.0 - 1e-12:
            br = natural(seg, u, np.array([t]), 0, 1.0, step=step, min_step=1e-3 * step,
                         tol=TOLERANCES, jump=JUMP, keep_states=True)
            nfact += br.stats.factorizations
            for pt in br.points[1:] if br.points else ():
                p = seg.at(pt.p)
                points.append(dict(length=p[0], tip_width=p[1], curvature=p[2],
                                   deflection=deflection(P, pt.u, p), segment=k))
            if br.completed:
                u = br.points[-1].u
                t = 1.0
                break
            if not br.points:
                raise ParameterError(f"segment {k}: the continuation could not start at "
                                     f"{seg.at([t]).tolist()}: {br.reason}")
            # the branch is lost: at the located fold, or where it could not go on
            last = br.points[-1]
            if br.fold is not None:
                t_lost, u_lost = float(br.fold.p[0]), br.fold.u
            else:
                t_lost, u_lost = float(last.p[0]), last.u
            p_lost = seg.at([t_lost])
            d_before = deflection(P, u_lost, p_lost)
            t_land = min(1.0, t_lost + snap_step / length)
            p_land = seg.at([t_land])
            best = None
            for path in ("gravity-first", "curvature-first"):
                try:
                    w, f = P.solve_state(p_land, path)
                except ParameterError:
                    continue
                nfact += f
                d = deflection(P, w, p_land)
                if best is None or abs(d - d_before) > abs(best[1] - d_before):
                    best = (w, d, path)
            if best is None:
                raise ParameterError(f"segment {k}: the branch was lost at "
                                     f"{p_lost.tolist()} and no state was found beyond it "
                                     f"({br.reason})")
            u, d_after, path = best
            jumps.append(dict(segment=k, at=[float(x) for x in p_lost],
                              deflection_before=d_before, deflection_after=d_after,
                              jump=d_after - d_before, fold=br.fold is not None, path=path))
            points.append(dict(length=p_land[0], tip_width=p_land[1], curvature=p_land[2],
                               deflection=d_after, segment=k))
            t = t_land
            n_jumps += 1
            if n_jumps > MAX_JUMPS:
                raise ParameterError(f"segment {k}: more than {MAX_JUMPS} jumps")
    points = tuple({key: (float(v) if key != "segment" else int(v)) for key, v in pt.items()}
                   for pt in points)
    return PathResult(points, tuple(jumps), (tuple(p0.tolist()),) + tuple(
        tuple(v.tolist()) for v in verts), int(nfact), remeshes, time.perf_counter() - t0, hmax)
