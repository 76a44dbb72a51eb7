"""Meshes of the trapezoidal prism: a gmsh triangulation of the plan, extruded.

The sheet occupies ``x in [0, L]``, ``|y| <= p(x)/2``, ``|z| <= h/2`` with
``p(x) = 1 + (b - 1) x / L`` (or the profile and bites of a
:class:`~skfem_sheet.params.Planform`: the outline is then lines, exact circle
arcs for the bites and a spline through the sampled profile, see
:func:`_planform_curves`).  We mesh the *upper half* of the plan view
(``y >= 0``) with gmsh, mirror it to ``y <= 0`` and extrude it through the
thickness in ``layers`` layers; each prism is cut into three tetrahedra.
With ``half=True`` the mirror is skipped: the mesh is then exactly the
``y >= 0`` half of the full one (same vertices, same cuts), for the symmetric
half-model of :func:`skfem_sheet.solve` (``U_y = 0`` on ``y = 0``).

Nested refinement (``refine=k``): the plan triangulation made at ``hmax`` is
split ``k`` times into four and extruded in ``layers * 2**k`` layers, so the
meshes ``refine = 0, 1, 2, ...`` of one base are nested (each prism lies in
one prism of the coarser mesh; the tetrahedra are not) and made of similar
prisms: a convergence study free of the noise of unrelated meshes.

Why extruded rather than a free 3D tetrahedral mesh:

- every tetrahedron is well shaped although the sheet is 30x thinner than it is
  wide (a free mesh with one element through the thickness has many slivers);
- the mesh is exactly mirror-symmetric under ``y -> -y`` (the cut of each prism
  follows a vertex order that the mirror preserves), so the symmetric solution
  is reproduced to round-off;
- the mid-plane ``z = 0`` carries quadratic nodes (vertices for an even number
  of layers, edge midpoints for an odd one), so the mid-line observables of the
  paper are read off nodes, and the axis ``y = 0`` carries nodes too (the tip of
  a triangle, the lowest point of the clamp arc).

Meshes are deterministic (gmsh runs single-threaded with fixed options): the
same :class:`MeshSpec` gives the same mesh.  Nothing is cached here; a solve
or a study that wants a mesh again keeps it in its
:class:`~skfem_sheet.build.BuildChain`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from skfem import MeshTet

from .params import ParameterError, Sheet, check_range

__all__ = ["MeshSpec", "SheetMesh", "sheet_mesh", "plan_triangulation", "refine_triangulation",
           "extrude", "default_layers", "estimate_dofs", "chord_error", "MAX_REFINE"]

MAX_REFINE = 4
"""Largest ``refine``: 4 halvings are 256x the tetrahedra of the base mesh."""


@dataclass(frozen=True, eq=False)
class SheetMesh:
    """A tetrahedral mesh of the sheet and the facts the solver needs about it.

    Attributes
    ----------
    mesh : skfem.MeshTet
        The tetrahedra (positively oriented).
    length : float
        The length it was built for (L/a).
    tip_width : float
        The tip width it was built for (b/a).
    thickness : float
        The thickness it was built for (h/a).
    hmax : float
        The target element size of the base triangulation (the edges are about
        ``hmax / 2**refine`` long).
    layers : int
        Number of element layers through the thickness (all of them: the base
        layers times ``2**refine``).
    half : bool
        Only the half ``y >= 0`` is meshed (symmetric half-model).
    refine : int
        Number of nested refinements of the base mesh (0: the base mesh).
    planform : Planform or None
        The plan view (None: the trapezoid of ``tip_width``).
    free_edge : ndarray (k, 2) or None
        Plan coordinates ``(x, y)`` of the plan's boundary points on the tip
        outline (the cut ``x = L`` and the bites), where the tip deflection
        is read (:func:`skfem_sheet.analyses.observables.free_edge_nodes`).
        None for meshes built by hand: the free edge is then ``x = length``.
    chord_error : float
        The largest distance of the plan's boundary from the outline it
        meshes (:func:`chord_error`; about ``h^2 k / 8`` for edges of length
        ``h`` on a curve of curvature ``k``, 0 where it is straight).
    """

    mesh: object
    length: float
    tip_width: float
    thickness: float
    hmax: float
    layers: int
    half: bool = False
    refine: int = 0
    planform: object = None
    free_edge: object = field(default=None, repr=False)
    chord_error: float = 0.0

    @property
    def n_elements(self) -> int:
        return self.mesh.t.shape[1]

    @property
    def n_vertices(self) -> int:
        return self.mesh.p.shape[1]

    def mirrored(self):
        """The whole sheet from a half mesh, for output.

        Returns
        -------
        p : ndarray (3, n)
            Vertices of the whole sheet.
        t : ndarray (4, m)
            Its tetrahedra (positively oriented).
        source : ndarray (n,)
            Half-mesh vertex of each vertex (a field ``f`` on the half mesh is
            ``f[source]`` on the whole, with its y component times ``sign``).
        sign : ndarray (n,)
            ``-1`` on the mirrored vertices, ``+1`` on the original ones.
        element_source : ndarray (m,)
            Half-mesh element of each tetrahedron.

        A full mesh is returned unchanged (``source`` the identity).
        """
        p, t = self.mesh.p, self.mesh.t
        nv, ne = p.shape[1], t.shape[1]
        if not self.half:
            return p, t, np.arange(nv), np.ones(nv), np.arange(ne)
        off = np.flatnonzero(np.abs(p[1]) > 1e-12 * max(1.0, self.length))
        index = np.arange(nv)
        index[off] = nv + np.arange(len(off))
        p_full = np.hstack([p, p[:, off] * np.array([[1.0], [-1.0], [1.0]])])
        t_mirror = index[t][[0, 2, 1, 3]]  # reflection flips orientation
        source = np.concatenate([np.arange(nv), off])
        sign = np.concatenate([np.ones(nv), -np.ones(len(off))])
        return (p_full, np.hstack([t, t_mirror]), source, sign,
                np.concatenate([np.arange(ne), np.arange(ne)]))


def default_layers(thickness: float, hmax: float) -> int:
    """Layers through the thickness: each at most ``hmax`` thick, and at least 2.

    With a single layer every vertex lies on the top or bottom surface, and
    Taylor-Hood (P2-P1) tetrahedra lose their inf-sup stability when no vertex
    of an element is interior: the pressure then enforces ``J = 1`` poorly
    (pointwise ``J - 1`` of 0.1) and Newton stalls or bounces at mesh-dependent
    loads (``docs/decisions.md``, "At least two layers").
    """
    return max(2, math.ceil(thickness / hmax - 1e-9))


def _check_refine(refine) -> int:
    if (isinstance(refine, (bool, np.bool_)) or not isinstance(refine, (int, np.integer, float))
            or not float(refine).is_integer() or not 0 <= refine <= MAX_REFINE):
        raise ParameterError(f"refine must be an integer in [0, {MAX_REFINE}], got {refine!r}")
    return int(refine)


def _check_mesh_args(sheet: Sheet, hmax: float, layers):
    hmax = check_range("hmax", hmax, 0, None, lo_open=True)
    top = min(0.5, sheet.length)
    if hmax > top:
        raise ParameterError(
            f"hmax must be in (0, {top:g}] (at most the sheet length and 0.5), got {hmax!r}")
    if hmax < 2e-3:
        raise ParameterError(f"hmax must be in [0.002, {top:g}]: smaller meshes do not "
                         f"fit in memory here, got {hmax!r}")
    if getattr(sheet, "planform", None) is not None:
        _check_narrow(sheet, hmax)
    if layers is None:
        layers = default_layers(sheet.thickness, hmax)
    if (isinstance(layers, bool) or not isinstance(layers, (int, float, np.integer, np.floating))
            or not float(layers).is_integer() or not 1 <= layers <= 16):
        raise ParameterError(f"layers must be an integer in [1, 16], got {layers!r}")
    return hmax, int(layers)


def _check_narrow(sheet: Sheet, hmax: float) -> None:
    """Refuse a planform narrower than ``2 hmax`` anywhere but a tip narrowing to its end.

    The width is that of the material at x (both horns of a bitten tip
    together).  Below two elements across, a neck cannot be meshed faithfully;
    a tip that narrows monotonically to the end (a triangle, a leaf, the horns
    a bite leaves) is fine: its elements just get smaller.
    """
    x = np.linspace(0.0, sheet.extent, 2001)
    w = np.asarray(sheet.width(x), dtype=float)
    narrow = w < 2.0 * hmax
    if not narrow.any():
        return
    k = int(np.argmax(narrow))
    tail = w[k:]
    rises = np.diff(tail) > 1e-9 * max(1.0, float(w.max()))
    if rises.any():
        j = k + int(np.argmax(rises))
        raise ParameterError(
            f"planform is too narrow for hmax = {hmax:g}: its width {w[j]:.3g} at x = {x[j]:.3g} "
            f"is below 2 hmax = {2 * hmax:g} and widens again (a neck; only a tip that narrows "
            "to its end may be narrower): use a smaller hmax or a wider planform")


def estimate_dofs(sheet: Sheet, hmax: float, layers=None, half: bool = False,
                  refine: int = 0) -> int:
    """Rough number of unknowns (P2 displacement + P1 pressure) before meshing.

    Used to refuse meshes that would not fit in memory with a clear message.
    The arguments are those of :func:`sheet_mesh`.

    Examples
    --------
    >>> s = Sheet(length=1.8)
    >>> n0, n1 = estimate_dofs(s, 0.16, 2, half=True), estimate_dofs(s, 0.16, 2, True, refine=1)
    >>> 7 < n1 / n0 < 9
    True
    """
    hmax, layers = _check_mesh_args(sheet, hmax, layers)
    refine = _check_refine(refine)
    layers *= 2**refine
    n_tri = (2.0 * sheet.area / (math.sqrt(3) / 4 * hmax**2) / (4 if half else 2)
             * 4**refine)
    n_v2 = 0.5 * n_tri  # plan vertices
    n_e2 = 1.5 * n_tri
    nv = n_v2 * (layers + 1)
    nedges = n_e2 * (layers + 1) + (n_v2 + n_e2) * layers
    return int(3 * (nv + nedges) + nv)


def plan_triangulation(length: float, tip_width: float, hmax: float, half: bool = False,
                       refine: int = 0, planform=None):
    """Triangulate the plan view, mirror-symmetric about ``y = 0``.

    With ``half=True`` only the part ``y >= 0`` (the same triangles, in the
    same relative vertex order).  With ``refine=k`` the triangulation made at
    ``hmax`` is split ``k`` times into four (:func:`refine_triangulation`);
    the result is still exactly mirror-symmetric, and its half is the half of
    the refined whole.

    Returns
    -------
    xy : ndarray, shape (n, 2)
        Vertex coordinates, sorted by the key ``(x, |y|, y)`` so that the vertex
        order commutes with the mirror ``y -> -y``.
    tri : ndarray, shape (m, 3)
        Triangles (counter-clockwise).

    With a ``planform`` (:class:`~skfem_sheet.params.Planform`) the outline
    follows its profile and bites (``tip_width`` is then ignored).
    """
    xy, tri, _ = _plan(length, tip_width, hmax, half, refine, planform)
    return xy, tri


def chord_error(xy, tri, length: float, planform=None) -> float:
    """The largest distance of a plan triangulation's boundary from the outline.

    The boundary vertices of a mesh of a curved outline lie on it, its edges
    are chords that leave the curve by up to their sagitta.  Evaluated at
    every boundary vertex and edge midpoint on a curved piece of the outline:
    the vertical gap to the profile ``y = p(x/L)/2`` or the radial gap to a
    bite's circle, whichever is smaller.  0 for the trapezoid.

    Parameters
    ----------
    xy : ndarray (n, 2)
        Plan vertices (the whole plan or its half ``y >= 0``).
    tri : ndarray (m, 3)
    length : float
        L/a.
    planform : Planform or None

    Examples
    --------
    >>> from skfem_sheet.params import Planform
    >>> P = Planform.from_function(lambda s: 1 + 0.2 * s * s)
    >>> xy, tri = plan_triangulation(1.6, P.tip_width, 0.2, half=True, planform=P)
    >>> 1e-4 < chord_error(xy, tri, 1.6, P) < 1e-3, chord_error(xy, tri, 1.6) == 0.0
    (True, True)
    """
    if planform is None or (planform.is_linear and not planform.bites):
        return 0.0
    xy = np.asarray(xy, dtype=float)
    edges = np.sort(np.vstack([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]]), axis=1)
    uniq, count = np.unique(edges, axis=0, return_counts=True)
    boundary = uniq[count == 1]
    a = np.column_stack([xy[boundary[:, 0], 0], np.abs(xy[boundary[:, 0], 1])])
    b = np.column_stack([xy[boundary[:, 1], 0], np.abs(xy[boundary[:, 1], 1])])
    eps = 1e-12 * max(1.0, float(length))

    def both(k, value):
        return (np.abs(a[:, k] - value) <= eps) & (np.abs(b[:, k] - value) <= eps)

    curved = ~(both(1, 0.0) | both(0, 0.0) | both(0, float(length)))
    if not curved.any():
        return 0.0
    pts = np.vstack([a[curved], b[curved], 0.5 * (a[curved] + b[curved])])
    gap = np.abs(pts[:, 1] - 0.5 * np.asarray(planform.profile(pts[:, 0] / length)))
    outline = planform.outline(length)
    for c, r in zip(outline.centres, outline.radii):
        gap = np.minimum(gap, np.abs(np.hypot(pts[:, 0] - c, pts[:, 1]) - r))
    return float(gap.max())


def _plan(length, tip_width, hmax, half=False, refine=0, planform=None):
    """:func:`plan_triangulation` and the free-edge points of the result."""
    half_xy, half_tri, segments, pointed = _half_plan(float(length), float(tip_width),
                                                      float(hmax), planform)
    n = len(half_xy)
    on_axis = np.abs(half_xy[:, 1]) < 1e-12 * max(1.0, length)
    half_xy = half_xy.copy()
    half_xy[on_axis, 1] = 0.0
    # mirror: axis vertices are shared, the others are duplicated with y -> -y
    mirror_index = np.arange(n)
    off = np.flatnonzero(~on_axis)
    mirror_index[off] = n + np.arange(len(off))
    xy = np.vstack([half_xy, half_xy[off] * [1.0, -1.0]])
    tri = np.vstack([half_tri, mirror_index[half_tri][:, ::-1]])
    # refine the whole (mirror-symmetric) plan: the midpoint of a mirrored edge
    # is the exact mirror of the midpoint (negation is exact in floating point),
    # midpoints of axis edges have y = 0 exactly, and every child triangle stays
    # on its parent's side of the axis
    xy, tri = refine_triangulation(xy, tri, _check_refine(refine))
    # vertex order (x, |y|, y): mirror-invariant for every edge that exists
    # (no triangle contains a vertex and its mirror image)
    order = np.lexsort((xy[:, 1], np.abs(xy[:, 1]), xy[:, 0]))
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    xy, tri = xy[order], rank[tri]
    if half:  # the y >= 0 part, vertex order kept
        keep = xy[:, 1] >= 0
        tri = tri[np.all(keep[tri], axis=1)]
        new = np.cumsum(keep) - 1
        xy, tri = xy[keep], new[tri]
    return xy, tri, _free_edge_points(xy, tri, segments, pointed, float(length))


def _free_edge_points(xy, tri, segments, pointed, length):
    """Vertices and midpoints of the boundary edges lying on the tip curves.

    ``segments`` (k, 2, 2) are the base mesh's edges on the tip curves (upper
    half); refined boundary edges lie on them too.  A pointed tip adds the
    point ``(length, 0)``.
    """
    edges = np.sort(np.vstack([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]]), axis=1)
    uniq, count = np.unique(edges, axis=0, return_counts=True)
    boundary = uniq[count == 1]
    points = []
    if len(segments) and len(boundary):
        mid = 0.5 * (xy[boundary[:, 0]] + xy[boundary[:, 1]])
        m = np.column_stack([mid[:, 0], np.abs(mid[:, 1])])
        a, b = segments[:, 0], segments[:, 1]
        ab = b - a
        t = np.einsum("mkj,kj->mk", m[:, None, :] - a[None], ab) / np.einsum("kj,kj->k", ab, ab)
        foot = a[None] + np.clip(t, 0.0, 1.0)[..., None] * ab[None]
        dist = np.linalg.norm(m[:, None, :] - foot, axis=2).min(axis=1)
        on = dist < 1e-9 * max(1.0, length)
        e = boundary[on]
        points += [xy[e[:, 0]], xy[e[:, 1]], mid[on]]
    if pointed:
        points.append(np.array([[length, 0.0]]))
    if not points:
        return np.zeros((0, 2))
    pts = np.unique(np.round(np.vstack(points), 13), axis=0)
    pts.setflags(write=False)
    return pts


def refine_triangulation(xy, tri, times: int = 1):
    """Split every triangle into four at its edge midpoints, ``times`` times.

    Parameters
    ----------
    xy : ndarray, shape (n, 2)
        Vertices.
    tri : ndarray, shape (m, 3)
        Triangles (their orientation is kept by the children).
    times : int
        Number of refinements (0 returns the input).

    Returns
    -------
    xy : ndarray, shape (n + n_edges, 2) for ``times=1``
        The old vertices first (same indices), then one midpoint per edge.
    tri : ndarray, shape (4**times m, 3)

    Examples
    --------
    >>> xy, tri = refine_triangulation(np.array([[0., 0.], [1., 0.], [0., 1.]]),
    ...                                np.array([[0, 1, 2]]))
    >>> xy.tolist()[3:], tri.shape
    ([[0.5, 0.0], [0.0, 0.5], [0.5, 0.5]], (4, 3))
    """
    xy = np.asarray(xy, dtype=float)
    tri = np.asarray(tri, dtype=np.int64)
    for _ in range(int(times)):
        n = len(xy)
        # edges (0,1), (1,2), (2,0) of every triangle, numbered once each
        pairs = np.sort(np.stack([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]], axis=1),
                        axis=2).reshape(-1, 2)
        edges, which = np.unique(pairs, axis=0, return_inverse=True)
        mid = n + which.reshape(-1, 3)   # midpoint vertex of edge (01, 12, 20)
        xy = np.vstack([xy, 0.5 * (xy[edges[:, 0]] + xy[edges[:, 1]])])
        a, b, c = tri.T
        m01, m12, m20 = mid.T
        tri = np.vstack([np.stack([a, m01, m20], axis=1), np.stack([m01, b, m12], axis=1),
                         np.stack([m20, m12, c], axis=1), np.stack([m01, m12, m20], axis=1)])
    return xy, tri


def _trapezoid_curves(geo, length, tip_width, hmax):
    """The trapezoid's outline: lines through its corners; returns (loop, tip curves)."""
    corners = [(0.0, 0.0), (length, 0.0)]
    if tip_width > 0:
        corners.append((length, tip_width / 2))
    corners.append((0.0, 0.5))
    pts = [geo.addPoint(x, y, 0.0, hmax) for x, y in corners]
    lines = [geo.addLine(pts[i], pts[(i + 1) % len(pts)]) for i in range(len(pts))]
    return lines, ([lines[1]] if tip_width > 0 else [])


def _planform_curves(geo, length, hmax, planform):
    """A planform's outline (upper half, counter-clockwise from the origin).

    Axis line, bite arcs (exact circle arcs), what remains of the tip cut,
    the side (one straight line for a linear profile, else a spline through
    the profile sampled every ``hmax / 4`` at least), the clamp line.
    Returns (loop curves, tip curves).
    """
    o = planform.outline(length)
    def pt(x, y):
        return geo.addPoint(x, y, 0.0, hmax)

    origin = pt(0.0, 0.0)
    start = pt(o.axis_end, 0.0)
    loop, tip = [geo.addLine(origin, start)], []
    for c, r, _xs, xe in o.arcs:
        ye = math.sqrt(max(r * r - (xe - c) ** 2, 0.0))
        end = pt(xe, ye)
        arc = geo.addCircleArc(start, geo.addPoint(c, 0.0, 0.0, hmax), end)
        loop.append(arc)
        tip.append(arc)
        start = end
    x_end = o.extent
    if o.cut is not None and o.cut[1] > o.cut[0]:
        top = pt(length, o.cut[1])
        line = geo.addLine(start, top)
        loop.append(line)
        tip.append(line)
        start = top
    clamp_top = pt(0.0, 0.5)
    if planform.is_linear:
        loop.append(geo.addLine(start, clamp_top))
    else:
        n = max(24, math.ceil(4.0 * x_end / hmax))
        xs = np.linspace(x_end, 0.0, n + 1)[1:-1]
        inner = [pt(float(x), float(0.5 * planform.profile(x / length))) for x in xs]
        loop.append(geo.addSpline([start] + inner + [clamp_top]))
    loop.append(geo.addLine(clamp_top, origin))
    return loop, tip


def _half_plan(length: float, tip_width: float, hmax: float, planform=None):
    """gmsh triangulation of ``0 <= y <= p(x)/2`` (deterministic).

    Returns ``(xy, tri, segments, pointed)``: vertices, triangles, the
    mesh edges on the tip curves (k, 2, 2) and whether the tip is a point.
    """
    # deferred: gmsh (a C library, ~0.1 s to import) is only needed for new meshes
    import gmsh

    initialized_here = not gmsh.isInitialized()
    if initialized_here:
        gmsh.initialize(readConfigFiles=False, interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.option.setNumber("General.Verbosity", 0)
        gmsh.option.setNumber("General.NumThreads", 1)
        gmsh.model.add("sheet_plan")
        geo = gmsh.model.geo
        if planform is None or (planform.is_linear and not planform.bites):
            b = tip_width if planform is None else planform.tip_width
            lines, tip_curves = _trapezoid_curves(geo, length, b, hmax)
            pointed = b <= 0
        else:
            lines, tip_curves = _planform_curves(geo, length, hmax, planform)
            pointed = not planform.bites and planform.tip_width <= 0
        geo.addPlaneSurface([geo.addCurveLoop(lines)])
        geo.synchronize()
        gmsh.option.setNumber("Mesh.MeshSizeMax", hmax)
        gmsh.option.setNumber("Mesh.MeshSizeMin", 0.0)
        gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 1)
        gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 1)
        gmsh.option.setNumber("Mesh.Algorithm", 6)  # Frontal-Delaunay: regular triangles
        gmsh.option.setNumber("Mesh.RandomFactor", 1e-9)
        gmsh.option.setNumber("Mesh.RandomSeed", 1)
        gmsh.model.mesh.generate(2)
        tags, coords, _ = gmsh.model.mesh.getNodes()
        etypes, _, enodes = gmsh.model.mesh.getElements(2)
        (k,) = [i for i, t in enumerate(etypes) if t == 2]
        tri_tags = np.asarray(enodes[k], dtype=np.int64).reshape(-1, 3)
        segments = []
        for curve in tip_curves:
            ltypes, _, lnodes = gmsh.model.mesh.getElements(1, curve)
            for lt, ln in zip(ltypes, lnodes):
                if lt == 1:
                    for a, b in np.asarray(ln, dtype=np.int64).reshape(-1, 2):
                        segments.append([gmsh.model.mesh.getNode(int(a))[0][:2],
                                         gmsh.model.mesh.getNode(int(b))[0][:2]])
    finally:
        gmsh.model.remove()
        if initialized_here:
            gmsh.finalize()
    xyz = np.asarray(coords).reshape(-1, 3)
    index = np.full(int(tags.max()) + 1, -1, dtype=np.int64)
    index[tags] = np.arange(len(tags))
    tri = index[tri_tags]
    used = np.unique(tri)
    remap = np.full(len(tags), -1, dtype=np.int64)
    remap[used] = np.arange(len(used))
    xy, tri = xyz[used, :2], remap[tri]
    # counter-clockwise
    a, b, c = (xy[tri[:, i]] for i in range(3))
    ab, ac = b - a, c - a
    neg = ab[:, 0] * ac[:, 1] - ab[:, 1] * ac[:, 0] < 0
    tri[neg] = tri[neg][:, ::-1]
    xy.setflags(write=False)
    tri.setflags(write=False)
    segments = np.asarray(segments, dtype=float).reshape(-1, 2, 2)
    segments.setflags(write=False)
    return xy, tri, segments, bool(pointed)


def extrude(xy, tri, thickness: float, layers: int):
    """Extrude a plan triangulation into tetrahedra, ``layers`` layers thick.

    Each prism ``(a, b, c) x (a', b', c')`` with ``a < b < c`` (global vertex
    order) is cut into ``(a, b, c, c')``, ``(a, b, b', c')``, ``(a, a', b', c')``:
    every quadrilateral face is cut along the diagonal from its lower-numbered
    bottom vertex to its higher-numbered top vertex, so neighbours agree and the
    mesh is conforming.

    Returns
    -------
    p : ndarray, shape (3, n_vertices)
    t : ndarray, shape (4, n_tets), positively oriented
    """
    nv = len(xy)
    z = np.linspace(-thickness / 2, thickness / 2, layers + 1)
    p = np.vstack([np.tile(xy.T, (1, layers + 1)), np.repeat(z, nv)[None, :]])
    s = np.sort(tri, axis=1)
    a, b, c = s[:, 0], s[:, 1], s[:, 2]
    tets = []
    for k in range(layers):
        lo, hi = k * nv, (k + 1) * nv
        tets += [np.stack([a + lo, b + lo, c + lo, c + hi]),
                 np.stack([a + lo, b + lo, b + hi, c + hi]),
                 np.stack([a + lo, a + hi, b + hi, c + hi])]
    t = np.hstack(tets)
    # orient positively
    v = p[:, t]
    vol = np.einsum("ij,ij->j", np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0], axis=0),
                    v[:, 3] - v[:, 0])
    neg = vol < 0
    t[1, neg], t[2, neg] = t[2, neg].copy(), t[1, neg].copy()
    return p, t


def sheet_mesh(sheet: Sheet, hmax: float = 0.03, layers=None, half: bool = False,
               refine: int = 0) -> SheetMesh:
    """The tetrahedral mesh of ``sheet`` (made afresh: see :class:`MeshSpec`).

    Parameters
    ----------
    sheet : Sheet
        Only ``length``, ``tip_width`` (or ``planform``) and ``thickness`` matter.
    hmax : float
        Target edge length in the plane; layers are at most ``hmax`` thick.
    layers : int, optional
        Element layers through the thickness (default ``max(2, ceil(h / hmax))``,
        see :func:`default_layers`).
    half : bool
        Mesh only the half ``y >= 0`` (the ``y >= 0`` part of the full mesh).
    refine : int
        Nested refinements, 0 to 4 (see the module; 8x the tetrahedra each).

    Examples
    --------
    >>> m = sheet_mesh(Sheet(length=1.0), hmax=0.25)
    >>> m.layers, m.mesh.p.shape[0]
    (2, 3)
    >>> r = sheet_mesh(Sheet(length=1.0), hmax=0.25, refine=1)
    >>> r.layers, r.n_elements // m.n_elements
    (4, 8)
    """
    return MeshSpec.of(sheet, hmax, layers, half, refine).build()


@dataclass(frozen=True)
class MeshSpec:
    """What a sheet mesh is made from: the checked arguments of :func:`sheet_mesh`.

    Equal specs give equal meshes, so a spec is the key under which a
    :class:`~skfem_sheet.build.BuildChain` keeps a mesh (curvature and
    modulus do not enter).

    Attributes
    ----------
    length : float
        L/a of the plan.
    tip_width : float
        b/a (ignored with a planform).
    thickness : float
        h/a.
    hmax : float
        Element size of the plan.
    layers : int
        All the layers (the base layers times ``2**refine``).
    half : bool
        The half ``y >= 0`` only.
    refine : int
        Nested refinements.
    planform : Planform or None
        The plan view (None: the trapezoid of ``tip_width``).

    Examples
    --------
    >>> spec = MeshSpec.of(Sheet(length=1.0), 0.25, refine=1)
    >>> spec.layers, spec == MeshSpec.of(Sheet(length=1.0, curvature=3.0), 0.25, refine=1)
    (4, True)
    >>> spec.build().n_elements == sheet_mesh(Sheet(length=1.0), 0.25, refine=1).n_elements
    True
    """

    length: float
    tip_width: float
    thickness: float
    hmax: float
    layers: int
    half: bool = False
    refine: int = 0
    planform: object = None

    @classmethod
    def of(cls, sheet: Sheet, hmax: float = 0.03, layers=None, half: bool = False,
           refine: int = 0) -> MeshSpec:
        """The spec of :func:`sheet_mesh` with these arguments (checked:
        bad ones raise :class:`~skfem_sheet.params.ParameterError`)."""
        hmax, layers = _check_mesh_args(sheet, hmax, layers)
        refine = _check_refine(refine)
        return cls(sheet.length, sheet.tip_width, sheet.thickness, hmax, layers * 2**refine,
                   bool(half), refine, getattr(sheet, "planform", None))

    def build(self) -> SheetMesh:
        """The mesh: the plan triangulated (gmsh), refined, extruded."""
        xy, tri, free_edge = _plan(self.length, self.tip_width, self.hmax, self.half,
                                   self.refine, self.planform)
        p, t = extrude(xy, tri, self.thickness, self.layers)
        return SheetMesh(mesh=MeshTet(p, t), length=self.length, tip_width=self.tip_width,
                         thickness=self.thickness, hmax=self.hmax, layers=self.layers,
                         half=self.half, refine=self.refine, planform=self.planform,
                         free_edge=free_edge,
                         chord_error=chord_error(xy, tri, self.length, self.planform))
