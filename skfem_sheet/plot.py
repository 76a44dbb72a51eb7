"""Pictures of deformed sheets (matplotlib, no screen needed; PyVista optional).

:func:`plot_sheet` draws the deformed top surface ``z = h/2`` coloured by the
elastic energy density psi/mu (paper Fig. 3) with smooth shading: the
per-tetrahedron psi/mu is averaged to the surface's vertices (area-weighted),
every triangle is split into ``subdivisions**2`` sub-triangles whose colours
and lighting normals are interpolated from the vertices (Gouraud-like; a 3D
matplotlib collection has no shading of its own).  The colour scale is
logarithmic by default, from the 1st percentile (by area) of psi/mu to its
maximum, so the clamp's two corners (where psi/mu peaks) do not saturate the
interior stretching (the saddle of a drooped sheet); the bar says which
scale it is.  :func:`render_sheet` draws the same with PyVista off screen
(the ``render`` extra), where it is installed.

Matplotlib is imported inside the drawing functions, deliberately: its import
cost is paid only when a picture is drawn, after the backend is chosen.
"""
from __future__ import annotations

import numpy as np
from skfem import MeshTet

from .io import check_writable, whole_sheet_fields
from .params import ParameterError

__all__ = ["top_surface", "shaded", "vertex_values", "vertex_normals", "smooth_faces",
           "colour_scale", "COLOUR_SCALES", "draw_surface", "plot_sheet", "render_sheet",
           "pyvista_available"]

#: The colour scales of :func:`colour_scale`.
COLOUR_SCALES = ("log", "robust", "linear")

_LIGHT = (-0.4, -0.5, 0.77)


def top_surface(result):
    """Deformed top surface ``z = h/2``: vertices (n, 3), triangles (m, 3) and
    psi/mu of the tetrahedron under each triangle."""
    h = result.problem.sheet_mesh.thickness
    p, t, U, _, psi = whole_sheet_fields(result)
    mesh = MeshTet(p, t) if result.problem.sheet_mesh.half else result.problem.sheet_mesh.mesh
    f = mesh.boundary_facets()
    tri = mesh.facets[:, f]
    top = np.all(np.abs(mesh.p[2, tri] - h / 2) < 1e-9, axis=0)
    tri = tri[:, top].T
    elem = mesh.f2t[0, f[top]]
    return mesh.p.T + U, tri, psi[elem]


def _lambert(normals, light=_LIGHT):
    light = np.asarray(light, dtype=float)
    return 0.45 + 0.55 * np.abs(normals @ (light / np.linalg.norm(light)))


def shaded(rgba, faces, light=_LIGHT):
    """Lambert shading of face colours (both sides lit).

    Parameters
    ----------
    rgba : ndarray (m, 4)
        Colours of the faces.
    faces : ndarray (m, 3, 3)
        Vertices of each triangle.
    light : 3-sequence
        Direction of the light.

    Returns
    -------
    ndarray (m, 4)
        The colours darkened by ``0.45 + 0.55 |n . l|`` (``n`` the unit normal).

    Examples
    --------
    >>> faces = np.array([[[0, 0, 0], [1, 0, 0], [0, 1, 0]]], float)
    >>> shaded(np.ones((1, 4)), faces, light=(0, 0, 1)).tolist()
    [[1.0, 1.0, 1.0, 1.0]]
    """
    n = np.cross(faces[:, 1] - faces[:, 0], faces[:, 2] - faces[:, 0])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    out = rgba.copy()
    out[:, :3] *= _lambert(n, light)[:, None]
    return out


def _areas_normals(X, tri):
    n = np.cross(X[tri[:, 1]] - X[tri[:, 0]], X[tri[:, 2]] - X[tri[:, 0]])
    area = 0.5 * np.linalg.norm(n, axis=1)
    return area, n


def vertex_values(X, tri, values):
    """Area-weighted mean of per-triangle ``values`` at the vertices.

    Examples
    --------
    >>> X = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], float)
    >>> vertex_values(X, np.array([[0, 1, 2], [1, 3, 2]]), np.array([1.0, 3.0])).tolist()
    [1.0, 2.0, 2.0, 3.0]
    """
    area, _ = _areas_normals(X, tri)
    num = np.zeros(len(X))
    den = np.zeros(len(X))
    for k in range(3):
        np.add.at(num, tri[:, k], area * values)
        np.add.at(den, tri[:, k], area)
    return num / np.where(den > 0, den, 1.0)


def vertex_normals(X, tri):
    """Unit normals at the vertices (area-weighted mean of the triangles' normals)."""
    _, n = _areas_normals(X, tri)  # |n| = 2 area: area-weighted
    out = np.zeros_like(X, dtype=float)
    for k in range(3):
        np.add.at(out, tri[:, k], n)
    norm = np.linalg.norm(out, axis=1, keepdims=True)
    return out / np.where(norm > 0, norm, 1.0)


def smooth_faces(X, tri, vertex_field, subdivisions: int = 2):
    """Sub-triangles of every triangle with interpolated values and normals.

    Each triangle is split into ``subdivisions**2`` (barycentric grid); the
    field and the vertex normals are interpolated linearly to every
    sub-triangle's centroid.

    Returns
    -------
    faces : ndarray (m n^2, 3, 3)
    values : ndarray (m n^2,)
    normals : ndarray (m n^2, 3)
        Unit normals (the interpolated vertex normals) for lighting.

    Examples
    --------
    >>> X = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float)
    >>> f, v, n = smooth_faces(X, np.array([[0, 1, 2]]), np.array([0.0, 1.0, 2.0]), 2)
    >>> f.shape, round(float(v.mean()), 12)
    ((4, 3, 3), 1.0)
    """
    n = int(subdivisions)
    if n < 1:
        raise ParameterError(f"subdivisions must be an integer >= 1, got {subdivisions!r}")
    N = vertex_normals(X, tri)
    bary = []  # barycentric corners of the sub-triangles
    for i in range(n):
        for j in range(n - i):
            a, b, c = (i, j), (i + 1, j), (i, j + 1)
            bary.append([a, b, c])
            if i + j < n - 1:
                bary.append([(i + 1, j), (i + 1, j + 1), (i, j + 1)])
    B = np.array(bary, dtype=float) / n  # (k, 3 corners, 2): weights of vertices 1, 2
    W = np.concatenate([1.0 - B.sum(axis=2, keepdims=True), B], axis=2)  # (k, 3, 3)
    Xt = X[tri]  # (m, 3, 3)
    faces = np.einsum("kcv,mvd->mkcd", W, Xt).reshape(-1, 3, 3)
    Wc = W.mean(axis=1)  # centroids (k, 3)
    values = np.einsum("kv,mv->mk", Wc, np.asarray(vertex_field)[tri]).ravel()
    normals = np.einsum("kv,mvd->mkd", Wc, N[tri]).reshape(-1, 3)
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    return faces, values, normals


def _weighted_percentile(values, weights, q):
    order = np.argsort(values)
    c = np.cumsum(weights[order])
    return float(values[order][np.searchsorted(c, q / 100.0 * c[-1])])


def colour_scale(values, weights=None, scale: str = "log", vmax=None):
    """A matplotlib norm for psi/mu and the colour bar's label that states it.

    ``"log"``: logarithmic from the 1st percentile (by ``weights``) of the
    positive values to the maximum; ``"robust"``: linear from 0 to the 95th
    percentile (larger values saturate, the bar is extended); ``"linear"``:
    0 to the maximum.  ``vmax`` overrides the upper end.

    Examples
    --------
    >>> norm, label = colour_scale(np.array([1e-4, 1e-3, 1e-2, 1.0]))
    >>> label
    '$\\\\psi/\\\\mu$ (log scale, 1st percentile to max)'
    """
    # deferred: import cost (see the module docstring)
    from matplotlib import colors

    if scale not in COLOUR_SCALES:
        raise ParameterError(f"scale must be one of {', '.join(COLOUR_SCALES)}, got {scale!r}")
    values = np.asarray(values, dtype=float)
    weights = np.ones_like(values) if weights is None else np.asarray(weights, dtype=float)
    top = float(vmax) if vmax else float(values.max())
    if top <= 0:
        top = 1.0
    if scale == "log":
        pos = values > 0
        lo = _weighted_percentile(values[pos], weights[pos], 1.0) if pos.any() else top * 1e-3
        lo = min(lo, top / 10)
        return (colors.LogNorm(lo, top, clip=True),
                r"$\psi/\mu$ (log scale, 1st percentile to max)")
    if scale == "robust":
        hi = float(vmax) if vmax else _weighted_percentile(values, weights, 95.0)
        return colors.Normalize(0.0, hi or 1.0, clip=True), \
            r"$\psi/\mu$ (linear, 0 to the 95th percentile)"
    return colors.Normalize(0.0, top), r"$\psi/\mu$ (linear, 0 to max)"


def draw_surface(ax, X, tri, face_values, norm, cmap, subdivisions: int = 2, light=_LIGHT):
    """Add the smoothly shaded surface to a 3D axes (see the module docstring)."""
    # deferred: import cost (see the module docstring)
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    v = vertex_values(X, tri, face_values)
    faces, values, normals = smooth_faces(X, tri, v, subdivisions)
    rgba = cmap(norm(np.maximum(values, norm.vmin if norm.vmin > 0 else 0.0)))
    rgba[:, :3] *= _lambert(normals, light)[:, None]
    poly = Poly3DCollection(faces, facecolors=rgba, linewidths=0, antialiased=False)
    ax.add_collection3d(poly)
    return poly


def plot_sheet(result, filename=None, ax=None, title=None, vmax=None, colorbar=True,
               scale: str = "robust", subdivisions: int = 3):
    """Smoothly shaded 3D view of the deformed sheet coloured by psi/mu (paper Fig. 3).

    Parameters
    ----------
    result : Result
        Drawn in units of a, or in millimetres for a sheet made from SI
        quantities (``result.sheet.si``).
    filename : str, optional
        Write a PNG there.
    ax : matplotlib 3D axes, optional
    vmax : float, optional
        Upper end of the colour scale (default: see ``scale``).
    scale : {"log", "robust", "linear"}
        Colour scale (:func:`colour_scale`; stated on the colour bar).
    subdivisions : int
        Sub-triangles per edge of each surface triangle (smooth shading).

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> from skfem_sheet import Sheet, solve
    >>> r = solve(Sheet(length=0.6, curvature=1.0), hmax=0.2)
    >>> fig = plot_sheet(r)
    >>> fig.axes[-1].get_ylabel()
    '$\\\\psi/\\\\mu$ (linear, 0 to the 95th percentile)'
    """
    import matplotlib  # deferred: import cost (see the module docstring)

    if filename is not None:
        check_writable("filename", filename, [".png", ".pdf", ".svg"])
    if filename is not None and ax is None:
        matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt  # deferred: after the backend is chosen
    from matplotlib import cm

    X, tri, psi = top_surface(result)
    area, _ = _areas_normals(X, tri)
    norm, label = colour_scale(psi, area, scale, vmax)
    si = getattr(result.sheet, "si", None)
    if si is not None:  # a sheet made from SI quantities: its axes in millimetres
        X = X * (1e3 * si.base_width)
    if ax is None:
        fig = plt.figure(figsize=(6.0, 4.6))
        ax = fig.add_subplot(projection="3d")
    else:
        fig = ax.figure
    cmap = matplotlib.colormaps["viridis"]
    draw_surface(ax, X, tri, psi, norm, cmap, subdivisions)
    lo, hi = X.min(axis=0), X.max(axis=0)
    span = max(hi - lo)
    mid = 0.5 * (lo + hi)
    for set_lim, c in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), mid):
        set_lim(c - span / 2, c + span / 2)
    ax.set_box_aspect((1, 1, 1))
    unit = "/a" if si is None else " [mm]"
    ax.set_xlabel(f"x{unit}")
    ax.set_ylabel(f"y{unit}")
    ax.set_zlabel(f"z{unit}")
    ax.view_init(elev=18, azim=-125)
    s = result.sheet
    d = (f"d/a = {result.deflection:.4f}" if si is None else
         f"d = {1e3 * si.metres(result.deflection):.4g} mm (d/a = {result.deflection:.4f})")
    ax.set_title(title or (f"L/a={s.length:g}, b/a={s.tip_width:g}, a/R={s.curvature:g}, "
                           f"{result.path}\n{d}, hmax {result.hmax:g}"), fontsize=9)
    if colorbar:
        sm = cm.ScalarMappable(norm=norm, cmap=cmap)
        extend = "max" if scale == "robust" else "neither"
        fig.colorbar(sm, ax=ax, shrink=0.6, pad=0.1, label=label, extend=extend)
    if filename is not None:
        fig.savefig(filename, dpi=150, bbox_inches="tight")
        plt.close(fig)
    return fig


def pyvista_available() -> bool:
    """Whether PyVista (the ``render`` extra) can be imported."""
    try:
        import pyvista  # noqa: F401  (deferred: optional)
    except ImportError:
        return False
    return True


def render_sheet(result, filename, scale: str = "robust", window_size=(1200, 900)):
    """Render the deformed sheet with PyVista off screen (smooth shading) into a PNG.

    The whole deformed solid's outer surface, coloured by psi/mu averaged to
    the vertices, on the colour scale of :func:`colour_scale` (stated on the
    bar).  Needs the ``render`` extra (``pip install skfem_sheet[render]``)
    and an off-screen OpenGL (the VTK wheels' OSMesa/EGL, or a virtual screen).

    Raises
    ------
    ParameterError
        If PyVista is not installed.

    Examples
    --------
    >>> from skfem_sheet import Sheet, solve
    >>> r = solve(Sheet(length=0.6, curvature=1.0), hmax=0.2)
    >>> render_sheet(r, "sheet.png")  # doctest: +SKIP
    'sheet.png'
    """
    path = check_writable("filename", filename, [".png"])
    try:
        import pyvista as pv  # deferred: optional
    except ImportError:
        raise ParameterError("render_sheet needs PyVista: pip install skfem_sheet[render]") \
            from None
    p, t, U, _, psi = whole_sheet_fields(result)
    cells = np.column_stack([np.full(t.shape[1], 4), t.T]).ravel()
    grid = pv.UnstructuredGrid(cells, np.full(t.shape[1], pv.CellType.TETRA, dtype=np.uint8),
                               p.T + U)
    grid.cell_data["psi_over_mu"] = psi
    try:
        surf = grid.extract_surface(algorithm="dataset_surface")
    except TypeError:  # PyVista before the algorithm keyword
        surf = grid.extract_surface()
    surf = surf.cell_data_to_point_data()
    values = np.asarray(surf.point_data["psi_over_mu"])
    norm, label = colour_scale(values, None, scale)
    plotter = pv.Plotter(off_screen=True, window_size=list(window_size))
    plotter.add_mesh(surf, scalars="psi_over_mu", cmap="viridis", smooth_shading=True,
                     clim=[norm.vmin, norm.vmax], log_scale=(scale == "log"),
                     scalar_bar_args={"title": label.replace("$", "").replace("\\", "")})
    plotter.view_vector((-0.55, -0.8, 0.35), viewup=(0, 0, 1))
    plotter.screenshot(path)
    plotter.close()
    return path
