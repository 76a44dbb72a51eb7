"""Fig. 7: the bistable region in (L/a, b/a, a/R) from fold curves (or the fold map).

The standout lengths L1* (upper surface) and pop-up lengths L0* (lower) over
the bistable (b/a, a/R), meeting on the critical curve where L0* = L1*.  By
default (``method="curves"``) they come from traced fold curves, one per a/R
(:func:`skfem_sheet.figures.data.curve_region`), the critical curve being
their cusps and the rectangle's critical a/R; ``method="grid"`` reads them
from the point-by-point fold map (:func:`bistable_region`, the reference).

Examples
--------
>>> min(p["tip_width"] for p in fig7_points("quick"))
0.5
"""
from __future__ import annotations

import numpy as np

from .common import DEFAULT_DATA_DIR, quality_settings
from .data import (
    curve_region,
    figure_method,
    fold_curve_points,
    fold_curve_table,
    fold_lines,
    fold_map_table,
    foldmap,
    map_grid_points,
    select_rows,
    usable,
)
from .style import COLUMN_WIDTH, FOLD_ACCURACY, fmt, footnote, hmax_of, styled_figure

__all__ = ["fig7_points", "bistable_region", "region_mesh", "draw_fig7", "fig7"]


def fig7_points(quality: str = "quick") -> list:
    """Fold-map points of Fig. 7: b/a >= 0.5 at the quality's a/R > 0.

    Examples
    --------
    >>> len(fig7_points()), min(p["tip_width"] for p in fig7_points())
    (36, 0.5)
    """
    cs = quality_settings(quality)["fig7_curvatures"]
    return map_grid_points(quality, lambda c, b: c in cs and b >= 0.5)


def _swap(df):
    """The map with the roles of b/a and a/R exchanged (for critical curvatures)."""
    return df.rename(columns={"tip_width": "curvature", "curvature": "tip_width"})


def bistable_region(df) -> dict:
    """The bistable region of fold-map rows in (b/a, a/R, L/a), for Fig. 7.

    Returns
    -------
    dict
        ``chains``: per curvature (ascending) the list of nodes
        ``(b, L0*, L1*)`` along b: the critical point ``(b*, L*, L*)`` where
        the folds meet (if the map brackets it), then the bistable rows;
        ``critical``: ``[(b*, a/R, L*)]``, the curve where L0* = L1*, ending
        on the rectangle's edge at the critical curvature of b/a = 1 if the
        map brackets it (its bistable width extrapolated to zero in a/R);
        ``edge``: that end point ``(1, a/R*, L*)`` if it is not on a grid
        curvature (it then also makes a chain of one node), else None.

    Examples
    --------
    >>> import pandas as pd
    >>> df = pd.DataFrame([dict(tip_width=b, curvature=k, bistable=b > 0.6 and k > 1,
    ...                         popup_length=1 + 0.1 * k, standout_length=1 + 0.2 * k * b,
    ...                         bistable_width=0.2 * k * b - 0.1 * k, converged=True,
    ...                         curvature_dominated="[]", gravity_dominated="[]",
    ...                         curvature_dominated_snapped=False,
    ...                         gravity_dominated_snapped=False, message="", error="")
    ...                    for b in (0.6, 0.8, 1.0) for k in (1.0, 2.0, 3.0)])
    >>> reg = bistable_region(df)
    >>> [round(c[1], 3) for c in reg["critical"]]  # a/R along the critical curve
    [1.0, 2.0, 3.0]
    >>> [len(reg["chains"][k]) for k in sorted(reg["chains"])]
    [1, 3, 3]
    """
    ok = df[np.array([usable(r) for _, r in df.iterrows()], dtype=bool)] if len(df) else df
    crit = foldmap.critical_tip_width(ok) if len(ok) else {}
    chains, critical, edge = {}, [], None
    for c, (est, lo, hi) in sorted(crit.items()):
        lines = fold_lines(select_rows(ok, curvature=c), (est, lo, hi))
        if lines is None:
            continue
        nodes = [(float(b), float(l0), float(l1))
                 for b, l0, l1 in zip(lines["b"], lines["L0"], lines["L1"])]
        if lines["tip"] is not None:
            bs, Ls = lines["tip"]
            nodes.insert(0, (bs, Ls, Ls))
            critical.append((bs, float(c), Ls))
        chains[float(c)] = nodes
    # the rectangle's edge: where bistability of b/a = 1 begins in a/R
    rect = select_rows(ok, tip_width=1.0)
    if len(rect):
        ccrit = foldmap.critical_tip_width(_swap(rect)).get(1.0)
        if ccrit is not None and np.isfinite(ccrit[0]):
            lines = fold_lines(_swap(rect), ccrit)
            if lines is not None and lines["tip"] is not None:
                cs, Ls = lines["tip"]
                if all(abs(cs - k) > 1e-9 for k in chains):
                    chains[float(cs)] = [(1.0, Ls, Ls)]
                    edge = (1.0, float(cs), Ls)
                critical.append((1.0, float(cs), Ls))
    chains = dict(sorted(chains.items()))
    critical.sort(key=lambda p: p[1])
    return {"chains": chains, "critical": critical, "edge": edge}


def _zip_chains(a, b, ia, ib):
    """Triangles between two chains of nodes sorted by b/a (indices ``ia``, ``ib``)."""
    tris, i, j = [], 0, 0
    while i < len(a) - 1 or j < len(b) - 1:
        if i == len(a) - 1 or (j < len(b) - 1 and b[j + 1][0] <= a[i + 1][0]):
            tris.append((ia[i], ib[j], ib[j + 1]))
            j += 1
        else:
            tris.append((ia[i], ib[j], ia[i + 1]))
            i += 1
    return tris


def region_mesh(region):
    """Nodes ``(b, a/R, L0, L1)`` and triangles of the two fold surfaces of a
    :func:`bistable_region`."""
    nodes, idx = [], []
    for c, chain in region["chains"].items():
        idx.append(list(range(len(nodes), len(nodes) + len(chain))))
        nodes += [(b, c, l0, l1) for b, l0, l1 in chain]
    chains = list(region["chains"].values())
    tris = []
    for k in range(len(chains) - 1):
        tris += _zip_chains(chains[k], chains[k + 1], idx[k], idx[k + 1])
    return np.array(nodes, float).reshape(-1, 4), np.array(tris, int).reshape(-1, 3)


def draw_fig7(df, quality: str = "paper", region=None):
    """Draw Fig. 7: the bistable region in (L/a, b/a, a/R), (a) in 3D and (b) its sections.

    (a) the standout lengths L1* (green, upper surface) and pop-up lengths
    L0* (blue, lower) over the (b/a, a/R) of the bistable rows, meeting on
    the critical curve (black) where L0* = L1*; rows that are not bistable
    are left out.  (b) the same folds against b/a, one closed curve per a/R
    (L1* solid, L0* dashed).

    Parameters
    ----------
    df : pandas.DataFrame
        Fold-map rows over a grid of (b/a, a/R), or the fold-curve rows of
        ``region``.
    region : dict, optional
        The region to draw (:func:`skfem_sheet.figures.data.curve_region`);
        default :func:`bistable_region` of ``df``.

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> import pandas as pd
    >>> df = pd.DataFrame([dict(tip_width=b, curvature=k, hmax=0.1, bistable=b > 0.6 and k > 1,
    ...                         popup_length=1 + 0.1 * k, standout_length=1 + 0.2 * k * b,
    ...                         bistable_width=0.2 * k * b - 0.1 * k, converged=True,
    ...                         curvature_dominated="[]", gravity_dominated="[]",
    ...                         curvature_dominated_snapped=False,
    ...                         gravity_dominated_snapped=False, message="", error="")
    ...                    for b in (0.6, 0.8, 1.0) for k in (1.0, 2.0, 3.0)])
    >>> fig = draw_fig7(df)
    >>> ax = fig.axes[0]
    >>> ax.get_xlabel(), ax.get_ylabel(), ax.get_zlabel()
    ('$b/a$', '$a/R$', '$L/a$')
    """
    # deferred: import cost (see figures.style)
    import matplotlib
    from matplotlib.tri import Triangulation

    from_curves = region is not None
    region = bistable_region(df) if region is None else region
    nodes, tris = region_mesh(region)
    green, blue = "#2ca02c", "#1f5fbf"
    if from_curves:
        n_failed = int(sum(bool(r["error"]) or not bool(r["converged"]) for _, r in df.iterrows()))
    else:
        n_failed = int(sum(not usable(r) for _, r in df.iterrows()))
    with styled_figure(COLUMN_WIDTH, 5.9) as fig:
        ax = fig.add_axes([0.02, 0.38, 0.93, 0.56], projection="3d")
        # seen from above the upper surface is in front: draw in a fixed order
        ax.computed_zorder = False
        if len(tris):
            tri = Triangulation(nodes[:, 0], nodes[:, 1], tris)
            for z, colour, gid, order in ((nodes[:, 2], blue, "surface-L0", 1),
                                          (nodes[:, 3], green, "surface-L1", 3)):
                surf = ax.plot_trisurf(tri, z, color=colour, alpha=0.5, shade=True,
                                       linewidth=0.2, edgecolor=colour, zorder=order)
                surf.set_gid(gid)
        if nodes.size:
            for col, colour, order in ((2, blue, 2), (3, green, 4)):
                ax.scatter(nodes[:, 0], nodes[:, 1], nodes[:, col], color=colour, s=3,
                           depthshade=False, zorder=order)
        if region["critical"]:
            cr = np.array(region["critical"], float)
            (ln,) = ax.plot(cr[:, 0], cr[:, 1], cr[:, 2], color="black", linewidth=1.4,
                            zorder=5)
            ln.set_gid("critical")
        ax.set_xlabel("$b/a$", labelpad=-6)
        ax.set_ylabel("$a/R$", labelpad=-6)
        ax.zaxis.set_rotate_label(False)
        ax.set_zlabel("$L/a$", labelpad=-7, rotation=90)
        ax.tick_params(labelsize=5.5, pad=-2)
        ax.view_init(elev=22, azim=-128)
        ax.set_box_aspect((1, 1.15, 0.9), zoom=0.95)
        for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
            axis.pane.set_facecolor((0.97, 0.97, 0.97, 1.0))
            axis._axinfo["grid"]["linewidth"] = 0.3
        ax.text2D(0.0, 0.98, "(a)", transform=ax.transAxes, fontweight="bold", va="top")
        # (b) sections at each a/R
        ax2 = fig.add_axes([0.15, 0.07, 0.62, 0.29])
        edge = region["edge"]
        cs = [c for c in sorted(region["chains"]) if edge is None or c != edge[1]]
        cmap = matplotlib.colormaps["plasma"]
        cmax = max(cs) if cs else 1.0
        for c in cs:
            chain = np.array(region["chains"][c], float)
            colour = cmap(0.85 * c / cmax)
            (l1,) = ax2.plot(chain[:, 0], chain[:, 2], color=colour, linestyle="-", marker="o",
                             markersize=2, label=f"$a/R={fmt(c)}$")
            l1.set_gid(f"L1|k={fmt(c)}")
            (l0,) = ax2.plot(chain[:, 0], chain[:, 1], color=colour, linestyle="--",
                             marker="o", markersize=2, markerfacecolor="white")
            l0.set_gid(f"L0|k={fmt(c)}")
        ax2.set_xlabel("$b/a$")
        ax2.set_ylabel("$L/a$")
        ax2.text(0.02, 0.96, "(b)", transform=ax2.transAxes, fontweight="bold", va="top")
        handles = ax2.get_legend_handles_labels()[0]
        if handles:
            ax2.legend(loc="center left", bbox_to_anchor=(1.01, 0.5), frameon=False,
                       handlelength=1.2)
        if n_failed:
            what = "fold curves did not complete" if from_curves else "map points failed"
            fig.text(0.5, 0.005, f"{n_failed} {what}, omitted", ha="center",
                     va="bottom", fontsize=6)
        fig.suptitle("Bistable region (FE): standout $L_1^*$ (green, upper) and pop-up "
                     "$L_0^*$ (blue, lower)\nsurfaces meet on the critical curve "
                     "(black, $L_0^*=L_1^*$); (b) $L_1^*$ solid, $L_0^*$ dashed",
                     fontsize=7, y=0.995)
        source = (f"FE fold curves ({len(df)}) hmax={hmax_of(df)}" if from_curves
                  else f"FE fold map hmax={hmax_of(df)}")
        footnote(fig, quality, f"{source}; {FOLD_ACCURACY}")
    return fig


def fig7(quality="quick", data_dir=DEFAULT_DATA_DIR, progress=True, workers=None,
         method=None, log=None):
    """Fig. 7: the bistable region in (L/a, b/a, a/R).

    ``method=None``: :data:`skfem_sheet.figures.data.FIGURE_METHOD`.
    ``method="curves"`` (the default there): from the quality's fold curves
    (:func:`skfem_sheet.figures.data.fold_curve_points`, cached in
    ``data_dir/foldcurves-<quality>.csv``; the curves not yet traced are
    traced, in parallel and resumably); ``"grid"``: from the fold-map points
    of :func:`fig7_points`.  ``log``: a list to append the data step to
    (:class:`~skfem_sheet.figures.work.DataStep`).

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> fig7("quick").savefig("fig7.png", dpi=200)  # doctest: +SKIP
    """
    method = figure_method(method)
    if method == "curves":
        df = fold_curve_table(fold_curve_points(quality), quality, data_dir, progress, workers,
                              log)
        return draw_fig7(df, quality, region=curve_region(df))
    df = fold_map_table(fig7_points(quality), quality, data_dir, progress, workers, log)
    return draw_fig7(df, quality)
