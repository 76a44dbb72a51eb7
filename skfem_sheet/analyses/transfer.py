"""Transfer of a state between two meshes of one sheet, in memory linear in the mesh.

When a continuation remeshes, the state on the old (possibly stretched)
mesh is interpolated at the nodes of the new one (P2 displacements, P1
pressures), with the values of scikit-fem's ``CellBasis.probes`` but the
cells found differently: scikit-fem's element finder maps every point into
every candidate element at once (memory like the square of the mesh).  The
sheet meshes are extruded from a plan triangulation
(:func:`skfem_sheet.mesh.extrude`), so a point is located by a 2D point
location in the plan (triangles binned on a uniform grid; the candidate with
the largest smallest barycentric coordinate), the layer from ``z``, and the
tetrahedron among the three of that prism.  Every array is linear in the mesh (the grid, the prism table) or in the chunk
of points processed at once (``chunk``), so the working memory of a transfer
is bounded by a constant times the size of the state plus a fixed chunk.

Two meshes of a curved outline are two polygons inscribed in it
(:attr:`~skfem_sheet.mesh.SheetMesh.chord_error`), so a new node can lie
just outside the old plan, by at most the two chord errors: it is located in
the nearest boundary cell and the old field's polynomial there is continued
to it (:meth:`ExtrudedLocator.locate` with ``outside``).  A point farther out
cannot be carried: :class:`TransferError` names the two meshes and the
distance.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..params import ParameterError

__all__ = ["CHUNK", "ExtrudedLocator", "TransferError", "carry_distance", "interpolate",
           "transfer"]

#: Points located and interpolated at once (bounds the working memory: about
#: 0.75 kB per point, i.e. some 15 MB per chunk).
CHUNK = 20_000

#: Largest distance outside a cell, in barycentric coordinates, of a point
#: still taken to lie in it (round-off on the boundary; ``_clip_to_sheet``
#: moves the nodes of a new mesh inside the old one).
OUTSIDE_TOL = 1e-8


class TransferError(ParameterError):
    """A state that cannot be carried from one mesh to another: a node of the
    new mesh lies outside the old one by more than their outlines can differ
    (the message names both meshes and the distance)."""


@dataclass(frozen=True, eq=False)
class ExtrudedLocator:
    """Point location in a tetrahedral mesh extruded from a plan triangulation.

    Build it with :meth:`of`.  All arrays are linear in the mesh size.

    Attributes
    ----------
    origin : ndarray (2,)
        Lower-left corner of the grid of bins.
    cell : float
        Side of a (square) bin.
    shape : tuple of int
        Number of bins in x and y.
    bin_start : ndarray (nx * ny + 1,)
        CSR row pointer: the triangles whose bounding box meets bin ``c`` are
        ``bin_triangles[bin_start[c]:bin_start[c + 1]]``.
    bin_triangles : ndarray
        Triangle indices, grouped by bin.
    corner : ndarray (n_tri, 2)
        First vertex ``a`` of each plan triangle.
    inverse : ndarray (n_tri, 2, 2)
        Inverse of ``[b - a, c - a]``: the barycentric coordinates
        ``(l1, l2)`` of ``q`` are ``inverse @ (q - a)``.
    levels : ndarray (layers + 1,)
        Heights of the layer interfaces, increasing.
    prism_tets : ndarray (layers * n_tri, 3)
        The three tetrahedra of prism ``(triangle i, layer k)`` in row
        ``k * n_tri + i``.
    mapping : skfem MappingAffine
        The affine mapping of the mesh (reference coordinates of points).
    boundary : ndarray (k, 2, 2)
        The plan's boundary edges (their two vertices).
    boundary_triangle : ndarray (k,)
        The plan triangle of each boundary edge.
    """

    origin: np.ndarray
    cell: float
    shape: tuple
    bin_start: np.ndarray
    bin_triangles: np.ndarray
    corner: np.ndarray
    inverse: np.ndarray
    levels: np.ndarray
    prism_tets: np.ndarray
    mapping: object
    boundary: np.ndarray
    boundary_triangle: np.ndarray

    @classmethod
    def of(cls, sheet_mesh, mapping=None) -> ExtrudedLocator:
        """The locator of a :class:`skfem_sheet.mesh.SheetMesh`.

        Parameters
        ----------
        sheet_mesh : SheetMesh
            A mesh made by :func:`skfem_sheet.mesh.extrude` (vertices numbered
            layer by layer, ``sheet_mesh.layers`` layers).
        mapping : skfem MappingAffine, optional
            The mesh's mapping (default: a new one; pass a basis's
            ``mapping`` to share its cached inverse matrices).

        Raises
        ------
        ParameterError
            If the mesh is not extruded as :func:`~skfem_sheet.mesh.extrude`
            does.
        """
        m = sheet_mesh.mesh
        p, t = m.p, m.t
        layers = int(sheet_mesh.layers)
        nv_all, ntet = p.shape[1], t.shape[1]
        n_plan, ntri = nv_all // (layers + 1), ntet // (3 * layers)
        if n_plan * (layers + 1) != nv_all or 3 * layers * ntri != ntet:
            raise ParameterError(
                f"sheet_mesh must be extruded in its {layers} layers (vertices a multiple of "
                f"layers + 1, tetrahedra of 3 * layers), got {nv_all} vertices, {ntet} tetrahedra")
        xy = p[:2, :n_plan].T
        levels = p[2, ::n_plan].copy()
        if (np.any(np.diff(levels) <= 0)
                or not np.array_equal(p[2].reshape(layers + 1, n_plan),
                                      np.repeat(levels[:, None], n_plan, axis=1))
                or not np.array_equal(p[:2].reshape(2, layers + 1, n_plan),
                                      np.broadcast_to(xy.T[:, None, :], (2, layers + 1, n_plan)))):
            raise ParameterError("sheet_mesh must be extruded: the vertices of layer k "
                                 "are the plan's at one height, numbered k * n_plan + i")
        # every tetrahedron: its layer and its plan triangle (the three plan vertices)
        plan = t % n_plan
        layer = t.min(axis=0) // n_plan
        if np.any(t.max(axis=0) // n_plan != layer + 1):
            raise ParameterError("sheet_mesh must be extruded: every tetrahedron spans one layer")
        plan = np.sort(plan, axis=0)
        # the sorted plan indices of a tetrahedron in a prism (a, b, c) are
        # (a, a|b, b|c, c) with the middle two repeats: (a, b, c) = first, the
        # one of the middle two that differs from the first, last
        second = np.where(plan[1] != plan[0], plan[1], plan[2])
        triples = np.stack([plan[0], second, plan[3]], axis=1)
        if np.any((triples[:, 0] == triples[:, 1]) | (triples[:, 1] == triples[:, 2])):
            raise ParameterError("sheet_mesh must be extruded: a tetrahedron does not "
                                 "cover a plan triangle")
        tri, which = np.unique(triples, axis=0, return_inverse=True)
        which = which.ravel()
        if len(tri) != ntri:
            raise ParameterError(f"sheet_mesh must be extruded: {len(tri)} plan triangles "
                                 f"for {ntet} tetrahedra in {layers} layers")
        key = layer * ntri + which
        order = np.argsort(key, kind="stable")
        if not np.array_equal(np.bincount(key, minlength=layers * ntri),
                              np.full(layers * ntri, 3)):
            raise ParameterError("sheet_mesh must be extruded: every prism holds 3 tetrahedra")
        prism_tets = order.reshape(layers * ntri, 3)

        # plan triangles: barycentric coordinates
        a, b, c = xy[tri[:, 0]], xy[tri[:, 1]], xy[tri[:, 2]]
        M = np.stack([b - a, c - a], axis=2)  # columns b - a, c - a
        inverse = np.linalg.inv(M)

        # bins: square, about the size of a triangle
        lo = xy.min(axis=0)
        extent = np.maximum(xy.max(axis=0) - lo, 1e-300)
        tmin = np.minimum(np.minimum(a, b), c)
        tmax = np.maximum(np.maximum(a, b), c)
        cell = float(np.median(np.max(tmax - tmin, axis=1)))
        shape = tuple(int(s) for s in np.maximum(1, np.ceil(extent / cell)))
        pad = 1e-9 * float(extent.max())
        i0 = np.clip(np.floor((tmin - pad - lo) / cell).astype(np.int64), 0, np.array(shape) - 1)
        i1 = np.clip(np.floor((tmax + pad - lo) / cell).astype(np.int64), 0, np.array(shape) - 1)
        nx_t, ny_t = (i1 - i0 + 1).T
        count = nx_t * ny_t
        owner = np.repeat(np.arange(ntri), count)
        r = np.arange(len(owner)) - np.repeat(np.cumsum(count) - count, count)
        bins = (i0[owner, 0] + r % nx_t[owner]) * shape[1] + i0[owner, 1] + r // nx_t[owner]
        order = np.argsort(bins, kind="stable")
        per_bin = np.bincount(bins, minlength=shape[0] * shape[1])
        bin_start = np.concatenate([[0], np.cumsum(per_bin)])
        if mapping is None:
            mapping = m._mapping()
        # the plan's boundary: the edges of one triangle only
        edge_tri = np.tile(np.arange(ntri), 3)
        edges = np.sort(np.vstack([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]]), axis=1)
        _, first, count = np.unique(edges, axis=0, return_index=True, return_counts=True)
        once = first[count == 1]
        return cls(origin=lo, cell=cell, shape=shape, bin_start=bin_start,
                   bin_triangles=owner[order], corner=a, inverse=inverse, levels=levels,
                   prism_tets=prism_tets, mapping=mapping, boundary=xy[edges[once]],
                   boundary_triangle=edge_tri[once])

    def locate_plan(self, xy):
        """Plan triangle containing each point of ``xy`` (shape ``(n, 2)``).

        Returns
        -------
        triangle : ndarray (n,) of int
        score : ndarray (n,)
            Smallest barycentric coordinate in that triangle (``>= 0`` inside,
            the largest over the candidates; ``-inf`` where no triangle's
            bounding box is near the point).
        """
        xy = np.asarray(xy, dtype=float)
        n = len(xy)
        if n == 0:
            return np.zeros(0, dtype=np.int64), np.zeros(0)
        ij = np.floor((xy - self.origin) / self.cell).astype(np.int64)
        ij = np.clip(ij, 0, np.array(self.shape) - 1)
        bins = ij[:, 0] * self.shape[1] + ij[:, 1]
        start, stop = self.bin_start[bins], self.bin_start[bins + 1]
        count = stop - start
        if np.any(count == 0):  # no triangle near: outside, the nearest boundary cell
            tri, score = np.zeros(n, dtype=np.int64), np.full(n, -np.inf)
            some = count > 0
            if some.any():
                tri[some], score[some] = self.locate_plan(xy[some])
            return tri, score
        point = np.repeat(np.arange(n), count)
        first = np.cumsum(count) - count
        cand = self.bin_triangles[np.repeat(start - first, count) + np.arange(len(point))]
        d = xy[point] - self.corner[cand]
        lam = np.einsum("pij,pj->pi", self.inverse[cand], d)
        score = np.minimum(np.minimum(lam[:, 0], lam[:, 1]), 1.0 - lam[:, 0] - lam[:, 1])
        best = np.maximum.reduceat(score, first)
        # first candidate (in bin order) reaching the best score
        hit = np.flatnonzero(score == best[point])
        pick = hit[np.unique(point[hit], return_index=True)[1]]
        return cand[pick], best

    def nearest_boundary(self, xy):
        """The boundary edge of the plan nearest to each point of ``xy``
        (shape ``(n, 2)``): its triangle and the distance (exact, over all
        boundary edges, in chunks of points; for the few points outside)."""
        xy = np.asarray(xy, dtype=float)
        tri, dist = np.zeros(len(xy), dtype=np.int64), np.zeros(len(xy))
        a = self.boundary[:, 0]
        ab = self.boundary[:, 1] - a
        ab2 = np.maximum(np.einsum("kj,kj->k", ab, ab), 1e-300)
        step = max(1, 2_000_000 // max(1, len(a)))
        for lo in range(0, len(xy), step):
            q = xy[lo:lo + step, None, :] - a[None]
            t = np.clip(np.einsum("pkj,kj->pk", q, ab) / ab2, 0.0, 1.0)
            d = np.linalg.norm(q - t[..., None] * ab[None], axis=2)
            k = np.argmin(d, axis=1)
            tri[lo:lo + step] = self.boundary_triangle[k]
            dist[lo:lo + step] = d[np.arange(len(k)), k]
        return tri, dist

    def locate(self, X, outside: float = 0.0):
        """Tetrahedron containing each point of ``X`` (shape ``(n, 3)``).

        Parameters
        ----------
        X : ndarray (n, 3)
        outside : float
            Points outside the plan by at most this distance are located in
            the boundary cell nearest to them (whose polynomials continue the
            field there; see the module).

        Raises
        ------
        ParameterError
            If a point lies outside the mesh (by more than ``OUTSIDE_TOL`` in
            barycentric coordinates, or, in the plan, by more than
            ``outside``); the message gives its distance from the plan.
        """
        X = np.asarray(X, dtype=float)
        tri, score = self.locate_plan(X[:, :2])
        away = np.flatnonzero(score < -OUTSIDE_TOL)
        if len(away):
            near, dist = self.nearest_boundary(X[away, :2])
            if np.any(dist > outside):
                bad = int(np.argmax(dist))
                raise ParameterError(f"point {X[away[bad]].tolist()} is outside the plan of "
                                     f"the mesh by {dist[bad]:.3g} (more than {outside:.3g})")
            tri[away] = near
        nlay = len(self.levels) - 1
        k = np.clip(np.searchsorted(self.levels, X[:, 2], side="right") - 1, 0, nlay - 1)
        cand = self.prism_tets[k * (len(self.prism_tets) // nlay) + tri]  # (n, 3)
        best = np.full(len(X), -np.inf)
        cells = cand[:, 0].copy()
        x = X.T[:, :, None]
        for j in range(3):
            R = self.mapping.invF(x, tind=cand[:, j])[:, :, 0]
            s = np.minimum(R.min(axis=0), 1.0 - R.sum(axis=0))
            better = s > best
            best[better], cells[better] = s[better], cand[better, j]
        best[away] = 0.0  # outside the plan, allowed: the nearest cell's continuation
        if np.any(best < -OUTSIDE_TOL):
            bad = int(np.argmin(best))
            raise ParameterError(f"point {X[bad].tolist()} is outside the mesh "
                                 f"(barycentric coordinate {best[bad]:.3g})")
        return cells


def interpolate(basis, values, X, cells):
    """Values at the points ``X`` (shape ``(n, 3)``) of a field on ``basis``.

    The same arithmetic as scikit-fem's ``basis.probes(X.T) @ values``:
    reference coordinates by ``basis.mapping.invF`` and basis values by
    ``basis.elem.gbasis`` in the given cells, but for the located ``cells``
    only and without the sparse matrix.

    Parameters
    ----------
    basis : skfem CellBasis
        A scalar basis (P1 or P2 here).
    values : ndarray (basis.N,) or (basis.N, m)
        Nodal values (one column per component).
    X : ndarray (n, 3)
    cells : ndarray (n,)
        An element containing each point.

    Returns
    -------
    ndarray (n,) or (n, m)
    """
    values = np.asarray(values)
    pts = basis.mapping.invF(np.asarray(X, dtype=float).T[:, :, None], tind=cells)
    out = np.zeros((len(cells),) + values.shape[1:])
    for k in range(basis.Nbfun):
        phi = np.asarray(basis.elem.gbasis(basis.mapping, pts, k, tind=cells)[0])[:, 0]
        v = values[basis.element_dofs[k, cells]]
        out += phi.reshape((-1,) + (1,) * (values.ndim - 1)) * v
    return out


def transfer(old, w_old, new, *, chunk: int = CHUNK):
    """Interpolate a state from problem ``old`` onto problem ``new``.

    Both describe the same sheet at the same length (``old`` may be a
    stretched mesh): displacements (P2) and pressures (P1) are evaluated at
    the nodes of ``new``.  The clamped dofs are interpolated like the others;
    with one ``hmax`` the clamped edge ``x = 0`` of the plan is meshed alike
    at every length, so the clamp nodes of both meshes coincide and the
    clamped values are copied (to the ``1e-12`` relative shift of
    :func:`_clip_to_sheet`).  The values are those of scikit-fem's
    ``probes`` (to round-off); the working memory is linear in the meshes,
    plus ``chunk`` points at a time.

    Where the outline is curved, a node of ``new`` up to
    :func:`carry_distance` outside the plan of ``old`` takes the value of the
    old field continued from its nearest boundary cell (see the module).

    Parameters
    ----------
    old, new : SheetProblem
    w_old : ndarray (old.ndof,)
    chunk : int
        Points located and interpolated at once.

    Returns
    -------
    ndarray (new.ndof,)

    Raises
    ------
    TransferError
        A node of ``new`` lies outside ``old`` by more than
        :func:`carry_distance` (the two meshes do not describe one outline).
    """
    if isinstance(chunk, bool) or not float(chunk).is_integer() or chunk < 1:
        raise ParameterError(f"chunk must be an integer >= 1, got {chunk!r}")
    chunk = int(chunk)
    s_old = old.length / old.sheet_mesh.length
    X = new.nodes / np.array([s_old, 1.0, 1.0])  # in old's mesh coordinates
    X = _clip_to_sheet(X, old.sheet_mesh)
    allowed = carry_distance(old.sheet_mesh, new.sheet_mesh, s_old)
    U_old, p_old = old.split(w_old)
    locator = ExtrudedLocator.of(old.sheet_mesh, old.basis_u.mapping)
    n_v = new.sheet_mesh.n_vertices  # P2 vertex nodes come first (skfem numbering)
    w = np.zeros(new.ndof)
    U = w[: new.nu_dof].reshape(-1, 3)
    p = w[new.nu_dof:]
    for lo in range(0, len(X), chunk):
        hi = min(lo + chunk, len(X))
        Xc = X[lo:hi]
        try:
            cells = locator.locate(Xc, outside=allowed)
        except ParameterError as err:
            raise TransferError(
                f"a state on the mesh hmax {_mesh_name(old)} cannot be carried to the mesh "
                f"hmax {_mesh_name(new)}: {err}; a node may lie outside by at most the "
                f"two meshes' chord errors ({old.sheet_mesh.chord_error:.3g} and "
                f"{getattr(new.sheet_mesh, 'chord_error', 0.0):.3g}), farther the meshes do "
                f"not describe one outline") from None
        U[lo:hi] = interpolate(old.basis_u, U_old, Xc, cells)
        if lo < n_v:
            m = min(hi, n_v) - lo
            p[lo:lo + m] = interpolate(old.basis_p, p_old, Xc[:m], cells[:m])
    return w


def carry_distance(old_mesh, new_mesh, stretch: float = 1.0) -> float:
    """How far outside the plan of ``old_mesh`` a node of ``new_mesh`` may lie
    and still be carried (in ``old_mesh``'s coordinates; ``stretch`` the
    factor by which the old problem stretches its mesh in x): the sum of the
    two meshes' chord errors (:attr:`~skfem_sheet.mesh.SheetMesh.chord_error`;
    the new one's in the old coordinates, at most ``1 / stretch`` times as
    large), plus round-off.  Both polygons lie within their chord error of the
    one outline, so a point of one lies within the sum of the other.  0 for
    straight outlines (the trapezoid: its meshes' boundaries coincide)."""
    c_old = float(getattr(old_mesh, "chord_error", 0.0))
    c_new = float(getattr(new_mesh, "chord_error", 0.0)) * max(1.0, 1.0 / float(stretch))
    if c_old == 0.0 and c_new == 0.0:
        return 0.0
    return c_old + c_new + 1e-9 * max(1.0, float(old_mesh.length))


def _mesh_name(problem) -> str:
    m = problem.sheet_mesh
    return f"{m.hmax:g}" + (f" refined {m.refine}x" if m.refine else "") + \
        f" (L/a {problem.length:g})"


def _clip_to_sheet(X, mesh, eps=1e-12):
    """Move points that round-off put just outside the sheet back in: into
    ``0 <= x <= L``, the thickness and (a half mesh) ``y >= 0``, and for the
    trapezoid, whose edges are straight and meshed exactly, into its width.
    (A curved outline is not clipped to: its meshes' polygons differ by their
    chord errors, and :meth:`ExtrudedLocator.locate` carries a node just
    outside from its nearest cell.)"""
    X = X.copy()
    L, b, h = mesh.length, mesh.tip_width, mesh.thickness
    X[:, 0] = np.clip(X[:, 0], 0.0, L)
    lo = 0.0 if mesh.half else -1.0
    planform = getattr(mesh, "planform", None)
    if planform is None or (planform.is_linear and not planform.bites):
        half_width = 0.5 * (1.0 + (b - 1.0) * X[:, 0] / L)
        X[:, 1] = np.clip(X[:, 1], lo * half_width, half_width) * (1 - eps)
    elif mesh.half:
        X[:, 1] = np.maximum(X[:, 1], 0.0)
    X[:, 2] = np.clip(X[:, 2], -h / 2, h / 2)
    return X
