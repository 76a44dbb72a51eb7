"""Pictures of deformed sheets (matplotlib, no screen needed).

Matplotlib is imported inside :func:`plot_sheet`, deliberately: its import
cost is paid only when a picture is drawn, after the backend is chosen.
"""
from __future__ import annotations

import numpy as np
from skfem import MeshTet

from .io import check_writable, whole_sheet_fields

__all__ = ["top_surface", "shaded", "plot_sheet"]


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


def shaded(rgba, faces, light=(-0.4, -0.5, 0.77)):
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
    lam = 0.45 + 0.55 * np.abs(n @ (np.asarray(light) / np.linalg.norm(light)))
    out = rgba.copy()
    out[:, :3] *= lam[:, None]
    return out


def plot_sheet(result, filename=None, ax=None, title=None, vmax=None, colorbar=True):
    """Shaded 3D view of the deformed sheet coloured by psi/mu (paper Fig. 3).

    Parameters
    ----------
    result : Result
    filename : str, optional
        Write a PNG there.
    ax : matplotlib 3D axes, optional
    vmax : float, optional
        Upper end of the colour scale (default: 99th percentile).

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib  # deferred: import cost (see the module docstring)

    if filename is not None:
        check_writable("filename", filename, [".png", ".pdf", ".svg"])
    if filename is not None and ax is None:
        matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt  # deferred: after the backend is chosen
    from matplotlib import cm, colors
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    X, tri, psi = top_surface(result)
    if ax is None:
        fig = plt.figure(figsize=(6.0, 4.6))
        ax = fig.add_subplot(projection="3d")
    else:
        fig = ax.figure
    vmax = vmax or float(np.percentile(psi, 99)) or 1.0
    norm = colors.Normalize(0.0, vmax)
    cmap = matplotlib.colormaps["viridis"]
    faces = X[tri]
    poly = Poly3DCollection(faces, facecolors=shaded(cmap(norm(psi)), faces), linewidths=0)
    ax.add_collection3d(poly)
    lo, hi = X.min(axis=0), X.max(axis=0)
    span = max(hi - lo)
    mid = 0.5 * (lo + hi)
    for set_lim, c in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), mid):
        set_lim(c - span / 2, c + span / 2)
    ax.set_box_aspect((1, 1, 1))
    ax.set_xlabel("x/a")
    ax.set_ylabel("y/a")
    ax.set_zlabel("z/a")
    ax.view_init(elev=18, azim=-125)
    s = result.sheet
    ax.set_title(title or (f"L/a={s.length:g}, b/a={s.tip_width:g}, a/R={s.curvature:g}, "
                           f"{result.path}\nd/a = {result.deflection:.4f}"), fontsize=9)
    if colorbar:
        sm = cm.ScalarMappable(norm=norm, cmap=cmap)
        fig.colorbar(sm, ax=ax, shrink=0.6, pad=0.1, label=r"$\psi/\mu$")
    if filename is not None:
        fig.savefig(filename, dpi=150, bbox_inches="tight")
        plt.close(fig)
    return fig
