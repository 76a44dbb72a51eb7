"""Fig. 3 (d-i): simulated sheets at a/R = 2.5, L/a = 1.3, coloured by psi/mu.

Six full finite-element solves (rectangle in both modes, triangle,
trapezoids b/a = 0.8, 0.6, 0.4); their deformed top surfaces are cached in
``data_dir/fig3-<quality>/*.npz`` (:func:`skfem_sheet.figures.cache.cached`).

Examples
--------
>>> [p for p, *_ in fig3_sheets()]
['d', 'e', 'f', 'g', 'h', 'i']
"""
from __future__ import annotations

import os
import time

import numpy as np
from tqdm.auto import tqdm

from ..params import Sheet
from ..plot import draw_surface, top_surface
from ..solve import solve
from .cache import data_folder, load_or_compute
from .common import DEFAULT_DATA_DIR, quality_settings
from .style import FULL_WIDTH, fmt, footnote, styled_figure
from .work import note, solves_step

__all__ = ["fig3_sheets", "fig3_data", "draw_fig3", "fig3"]


def fig3_sheets():
    """The six sheets of Fig. 3 (panels d-i): ``(panel, title, Sheet, path)``.

    All at a/R = 2.5, L/a = 1.3.  The rectangle is drawn in both modes; the
    triangle and trapezoids in their gravity-dominated mode (the triangle's
    only one; paper Fig. 3c, g-i).

    Examples
    --------
    >>> [(p, s.tip_width, path) for p, _, s, path in fig3_sheets()][:2]
    [('d', 1.0, 'gravity-first'), ('e', 1.0, 'curvature-first')]
    """
    base = Sheet(length=1.3, tip_width=1.0, curvature=2.5)
    return [
        ("d", "rectangle, gravity-dominated", base, "gravity-first"),
        ("e", "rectangle, curvature-dominated", base, "curvature-first"),
        ("f", "triangle", base.replace(tip_width=0.0), "gravity-first"),
        ("g", "trapezoid $b/a=0.8$", base.replace(tip_width=0.8), "gravity-first"),
        ("h", "trapezoid $b/a=0.6$", base.replace(tip_width=0.6), "gravity-first"),
        ("i", "trapezoid $b/a=0.4$", base.replace(tip_width=0.4), "gravity-first"),
    ]


def _solve_surface(sheet, path, hmax):
    """Solve one sheet and return its deformed top surface and summary (a dict of arrays)."""
    r = solve(sheet, path=path, hmax=hmax, on_failure="return")
    X, tri, psi = top_surface(r)
    return {"X": np.asarray(X, float), "tri": np.asarray(tri, np.int64),
            "psi": np.asarray(psi, float), "deflection": float(r.deflection),
            "converged": bool(r.converged), "message": str(r.message),
            "snapped": bool(len(r.snaps)), "hmax": float(hmax),
            "factorizations": int(r.factorizations + r.coarse_factorizations),
            "wall_time_s": float(r.wall_time_s)}


def _fig3_file(folder, sheet, path, hmax):
    return os.path.join(folder, f"L{sheet.length:g}_b{sheet.tip_width:g}_k{sheet.curvature:g}_"
                                f"h{sheet.thickness:g}_E{sheet.modulus:g}_{path}_hmax{hmax:g}.npz")


def fig3_data(quality="quick", data_dir=DEFAULT_DATA_DIR, progress=True, log=None):
    """Deformed top surfaces of the Fig. 3 sheets, cached in ``data_dir/fig3-<quality>/``.

    ``log``: a list to append the step's
    :class:`~skfem_sheet.figures.work.DataStep` to (the solves run now, their
    factorisations).

    Returns
    -------
    list of (panel, title, Sheet, path, dict)
        The dict holds ``X`` (vertices), ``tri``, ``psi`` (psi/mu per triangle),
        ``deflection``, ``converged``, ``message``, ``snapped``, ``hmax``
        (and, for surfaces cached since they were recorded, the solve's
        ``factorizations`` and ``wall_time_s``).

    Examples
    --------
    >>> [item[0] for item in fig3_data("quick")]  # doctest: +SKIP
    ['d', 'e', 'f', 'g', 'h', 'i']
    """
    hmax = quality_settings(quality)["hmax_fig3"]
    folder = data_folder(data_dir, f"fig3-{quality}")
    out = []
    sheets = fig3_sheets()
    t0 = time.perf_counter()
    solved = []
    for panel, title, sheet, path in tqdm(sheets, desc="fig3 solves", disable=not progress,
                                          leave=None):
        data, computed = load_or_compute(
            _fig3_file(folder, sheet, path, hmax),
            lambda sheet=sheet, path=path: _solve_surface(sheet, path, hmax))
        for k in ("deflection", "hmax"):
            data[k] = float(data[k])
        for k in ("converged", "snapped"):
            data[k] = bool(data[k])
        data["message"] = str(data["message"])
        if "factorizations" in data:
            data["factorizations"] = int(data["factorizations"])
        if "wall_time_s" in data:
            data["wall_time_s"] = float(data["wall_time_s"])
        if computed:
            solved.append((f"panel {panel}", data))
        out.append((panel, title, sheet, path, data))
    note(log, solves_step(solved, len(sheets), time.perf_counter() - t0))
    return out


def _surface_limits(items):
    lo = np.min([d["X"].min(axis=0) for *_, d in items], axis=0)
    hi = np.max([d["X"].max(axis=0) for *_, d in items], axis=0)
    return lo, hi


def draw_fig3(items, quality: str = "paper"):
    """Draw Fig. 3 (d-i): smoothly shaded deformed sheets coloured by psi/mu, one colour scale.

    Parameters
    ----------
    items : list
        From :func:`fig3_data`: ``(panel, title, sheet, path, surface dict)``.

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> import numpy as np
    >>> from skfem_sheet.params import Sheet
    >>> X = np.array([[0, -.5, 0], [1, -.5, -.2], [1, .5, -.2], [0, .5, 0.]])
    >>> d = dict(X=X, tri=np.array([[0, 1, 2], [0, 2, 3]]), psi=np.array([0.01, 0.02]),
    ...          deflection=0.2, converged=True, snapped=False, message="", hmax=0.1)
    >>> fig = draw_fig3([("d", "rectangle", Sheet(1.0), "gravity-first", d)])
    >>> fig.axes[-1].get_ylabel()
    '$\\\\psi/\\\\mu$ (square-root scale)'
    """
    # deferred: import cost (see figures.style)
    import matplotlib
    from matplotlib import cm, colors
    from matplotlib.ticker import MaxNLocator

    n = len(items)
    ncol = min(3, n)
    nrow = -(-n // ncol)
    with styled_figure(FULL_WIDTH, 2.45 * nrow + 0.3) as fig:
        # psi/mu = (I_C - 3)/2 dips slightly below 0 where the discrete volume
        # change is not zero (coarse meshes): those show in the lowest colour.
        allpsi = np.concatenate([d["psi"] for *_, d in items])
        vmax = float(np.percentile(allpsi, 99)) or 1.0
        # a square-root scale: the clamp's corner boundary layers would otherwise
        # hide the interior stretching of the buckled sheets (paper Fig. 3d, g)
        norm = colors.PowerNorm(0.5, vmin=0.0, vmax=vmax, clip=True)
        cmap = matplotlib.colormaps["viridis"]
        lo, hi = _surface_limits(items)
        span = float(max(hi - lo))
        mid = 0.5 * (lo + hi)
        for i, (panel, title, _sheet, path, d) in enumerate(items):
            ax = fig.add_subplot(nrow, ncol, i + 1, projection="3d")
            # smooth shading: psi/mu averaged to the vertices, interpolated with the
            # normals on sub-triangles (skfem_sheet.plot.draw_surface)
            draw_surface(ax, d["X"], d["tri"], d["psi"], norm, cmap, subdivisions=2)
            for set_lim, c in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), mid):
                set_lim(c - span / 2, c + span / 2)
            ax.set_box_aspect((1, 1, 1), zoom=1.08)
            ax.view_init(elev=18, azim=-125)
            for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
                axis.pane.set_facecolor((0.96, 0.96, 0.96, 1.0))
                axis._axinfo["grid"]["linewidth"] = 0.3
            ax.set_xlabel("$x/a$", labelpad=-9)
            ax.set_ylabel("$y/a$", labelpad=-9)
            ax.zaxis.set_rotate_label(False)
            ax.set_zlabel("$z/a$", labelpad=-9, rotation=90)
            ax.tick_params(labelsize=5.5, pad=-3)
            status = "" if d["converged"] else " NOT converged"
            if d["snapped"]:
                status += ", snapped"
            ax.set_title(f"({panel}) {title}\n{path}: $d/a={d['deflection']:.3f}${status}",
                         fontsize=7, pad=0)
        top = 1.0 - 0.3 / fig.get_figheight()
        fig.subplots_adjust(left=0.0, right=0.9, bottom=0.0, top=top, wspace=0.02, hspace=0.12)
        cax = fig.add_axes([0.915, 0.22, 0.012, 0.56])
        ticks = [t for t in MaxNLocator(7).tick_values(0.0, vmax) if 0 <= t <= vmax]
        cb = fig.colorbar(cm.ScalarMappable(norm=norm, cmap=cmap), cax=cax, extend="max",
                          ticks=ticks)
        cb.ax.tick_params(labelsize=6)
        cax.set_ylabel(r"$\psi/\mu$ (square-root scale)")
        k = items[0][2]
        fig.text(0.45, 0.995, f"$a/R={fmt(k.curvature)}$, $L/a={fmt(k.length)}$, "
                              f"$h/a={fmt(k.thickness)}$", ha="center", va="top", fontsize=8)
        footnote(fig, quality, f"FE hmax={fmt(items[0][4]['hmax'])}", top=True)
    return fig


def fig3(quality="quick", data_dir=DEFAULT_DATA_DIR, progress=True, workers=None, log=None):
    """Fig. 3 (d-i): simulated sheets at a/R = 2.5, L/a = 1.3 coloured by psi/mu.

    ``workers`` is accepted for a uniform signature; the six solves run in turn.
    ``log``: a list to append the data step to (:func:`fig3_data`).

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> fig3("quick").savefig("fig3.png", dpi=200)  # doctest: +SKIP
    """
    return draw_fig3(fig3_data(quality, data_dir, progress, log), quality)
