"""Fig. 6: ribbon-model d/a over (L/a, b/a) at a/R = 2.5 (a) and 5 (b), with the FE modes.

Background: the ribbon model continued in L
(:func:`skfem_sheet.reduced.maps.ribbon_map`), cached in
``data_dir/fig6-<quality>-ribbon.csv``; its jumps; markers where the
finite-element modes exist and the FE bistable region.  By default
(``method="curves"``) the bistable region is the traced fold curve of each
a/R (L1*, the cusp, L0*) and the markers above the cusp come from it; only
the shape factors below the cusp, where the transition is continuous, take a
fold-map point each -- traced on the fine mesh only around its transition
where fig2 and fig4 do not draw that row whole
(:func:`~skfem_sheet.figures.data.transition_rows`).  ``method="grid"``:
everything from the fold map (the reference).

Examples
--------
>>> sorted({p["curvature"] for p in fig6_points("quick")})
[2.5, 5.0]
"""
from __future__ import annotations

import os
import time

import numpy as np
import pandas as pd
from tqdm.auto import tqdm

from ..reduced import maps
from .cache import data_folder, load_or_compute
from .common import DEFAULT_DATA_DIR, QUALITIES, arange, quality_settings
from .data import (
    curve_fold_lines,
    curve_modes,
    figure_method,
    fold_curve_points,
    fold_curve_table,
    fold_lines,
    fold_map_table,
    foldmap,
    map_grid_points,
    select_rows,
    transition_rows,
    usable,
)
from .figure2 import fig2_points
from .figure4 import fig4_points
from .style import (
    COLUMN_WIDTH,
    FOLD_ACCURACY,
    fmt,
    footnote,
    halo,
    hmax_of,
    styled_figure,
)
from .work import DataStep, note

__all__ = ["fig6_points", "fig6_ribbon", "draw_fig6", "fig6"]

#: The clamp curvatures of the two panels.
_FIG6_CURVATURES = (2.5, 5.0)


def fig6_points(quality: str = "quick") -> list:
    """Fold-map points of Fig. 6: every shape factor of the grid at a/R = 2.5 and 5.

    Examples
    --------
    >>> sorted({p["curvature"] for p in fig6_points()}), len(fig6_points())
    ([2.5, 5.0], 18)
    """
    return map_grid_points(quality, lambda c, b: c in (2.5, 5.0))


def _fig6_ribbon_grid(quality):
    s = quality_settings(quality)
    lengths = arange(*s["fig6_ribbon_lengths"])
    tips = np.round(np.linspace(0.0, 1.0, s["fig6_ribbon_tips"]), 6)
    return lengths, tips


def fig6_ribbon(quality="quick", data_dir=DEFAULT_DATA_DIR, progress=True, workers=None,
                log=None):
    """Ribbon-model map of Fig. 6 at a/R = 2.5 and 5 (cached ``fig6-<quality>-ribbon.csv``).

    Every shape factor of the grid is continued in L in both directions
    (:func:`skfem_sheet.reduced.maps.ribbon_map`); quick: 26 x 26 (L/a, b/a)
    per curvature, about a minute in all on 2 cores, once.  ``log``: a list
    to append the step's :class:`~skfem_sheet.figures.work.DataStep` to (its
    units: the shapes, one per b/a and a/R; no finite-element solves).

    Returns
    -------
    pandas.DataFrame
        Columns :data:`skfem_sheet.reduced.maps.MAP_FIELDS`.

    Examples
    --------
    >>> df = fig6_ribbon("quick")  # doctest: +SKIP
    >>> sorted(set(df.curvature)), sorted(set(df.direction))  # doctest: +SKIP
    ([2.5, 5.0], ['decreasing', 'increasing'])
    """
    lengths, tips = _fig6_ribbon_grid(quality)
    fn = os.path.join(data_folder(data_dir), f"fig6-{quality}-ribbon.csv")
    want = {(c, b, L, dr) for c in _FIG6_CURVATURES for b in tips for L in lengths
            for dr in ("increasing", "decreasing")}

    def on_grid(df):
        have = {(round(c, 6), round(b, 6), round(L, 6), dr) for c, b, L, dr in
                df[["curvature", "tip_width", "length", "direction"]].itertuples(index=False)}
        return have == want and len(df) == len(want)

    def compute():
        # one pool per curvature, the bar moved by each shape
        n = workers if workers is not None else 1
        rows = []
        with tqdm(total=len(_FIG6_CURVATURES) * tips.size, desc="fig6 ribbon map",
                  unit="shape", disable=not progress, leave=None) as bar:
            for c in _FIG6_CURVATURES:
                rows += maps.ribbon_map(c, lengths, tips, workers=n,
                                        on_shape=lambda: bar.update(1))
        df = pd.DataFrame(rows, columns=list(maps.MAP_FIELDS))
        for col in ("curvature", "tip_width", "length"):
            df[col] = df[col].astype(float).round(6)
        return df

    t0 = time.perf_counter()
    df, computed = load_or_compute(fn, compute, accept=on_grid)
    t, n = time.perf_counter() - t0, len(_FIG6_CURVATURES) * tips.size
    note(log, DataStep("ribbon model", computed=n if computed else 0,
                       cached=0 if computed else n, wall_time_s=t,
                       compute_s=t if computed else 0.0, finite_elements=False))
    return df


def _fold_polyline(lines):
    """(L, b) of the boundary: down along L0*, through the tip (b*, L*), up along L1*."""
    L = list(lines["L0"][::-1])
    b = list(lines["b"][::-1])
    if lines["tip"] is not None:
        L.append(lines["tip"][1])
        b.append(lines["tip"][0])
    else:  # the map does not close the region: two separate curves
        L.append(np.nan)
        b.append(np.nan)
    return np.array(L + list(lines["L1"])), np.array(b + list(lines["b"]))

def _curve_rows(curves):
    """``{a/R: row}`` of the curves in (L, b/a) of a fold-curve table."""
    if curves is None or not len(curves):
        return {}
    rows = curves[curves["second"] == "tip_width"]
    return {float(r["curvature"]): r for _, r in rows.iterrows()}


def draw_fig6(fe, rom, quality: str = "paper", mode_lengths=None, curves=None):
    """Draw Fig. 6: ribbon-model d/a over (L/a, b/a) at (a) a/R = 2.5 and (b) a/R = 5,
    with the FE modes and bistable region.

    Background colour: d/a of the ribbon model continued with increasing L
    (the curvature-dominated branch while it lasts); dashed black: its jumps;
    filled diamonds / open squares: a curvature- / gravity-dominated FE mode
    exists there (both: bistable; :func:`skfem_sheet.studies.foldmap.modes`); solid
    black: the FE folds L0* (left) and L1* (right) of the bistable rows,
    closed where they meet at the critical shape factor (b/a)*.

    Parameters
    ----------
    fe : pandas.DataFrame
        Fold-map rows at a/R = 2.5 and 5.
    rom : pandas.DataFrame
        From :func:`fig6_ribbon`.
    curves : pandas.DataFrame, optional
        Fold-curve rows (:func:`skfem_sheet.studies.foldmap.fold_curves`): the
        bistable region of an a/R with a bistable curve is drawn from it, and
        its markers above the cusp (at the quality's grid of b/a, or at the
        b/a of ``fe``); ``fe`` rows of that a/R above the cusp are then not
        used.
    mode_lengths : array_like, optional
        L/a of the mode markers (default 0.6, 0.7, ..., 2.8).

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> import pandas as pd
    >>> fe = pd.DataFrame([dict(tip_width=b, curvature=k, hmax=0.1, bistable=b > 0.5,
    ...                         popup_length=1.2 + 0.2 * b, standout_length=1.0 + 0.6 * b,
    ...                         bistable_width=0.4 * b - 0.2, transition_length=1.3,
    ...                         converged=True, curvature_dominated="[]",
    ...                         gravity_dominated="[]", curvature_dominated_snapped=False,
    ...                         gravity_dominated_snapped=False, message="", error="")
    ...                    for b in (0.0, 0.5, 1.0) for k in (2.5, 5.0)])
    >>> rom = pd.DataFrame([dict(curvature=k, tip_width=b, length=L, direction=dr,
    ...                          deflection=L - 1, converged=True, stable=True, jumped=False)
    ...                     for k in (2.5, 5.0) for b in (0.0, 1.0) for L in (1.0, 2.0)
    ...                     for dr in ("increasing", "decreasing")])
    >>> fig = draw_fig6(fe, rom)
    >>> fig.axes[1].get_xlabel(), fig.axes[0].get_ylabel(), fig.axes[2].get_ylabel()
    ('$L/a$', '$b/a$', '$d/a$ (ribbon model)')
    """
    # deferred: import cost (see figures.style)
    import matplotlib
    from matplotlib import cm, colors
    from matplotlib.lines import Line2D

    Lm = (arange(0.6, 2.8, 0.1) if mode_lengths is None
          else np.asarray(mode_lengths, float))
    # marker sizes for the spacing of the L grid (the open square encloses the diamond)
    dL = float(np.min(np.diff(np.unique(Lm)))) if np.unique(Lm).size > 1 else 0.2
    msq, mdi = (4.6, 2.6) if dL >= 0.15 else (3.4, 2.0)
    crit = foldmap.critical_tip_width(fe) if len(fe) else {}
    by_curve = _curve_rows(curves)
    records = {c: select_rows(rom, curvature=c).to_dict("records") for c in _FIG6_CURVATURES}
    grids = {c: maps.map_grid(r, "increasing") for c, r in records.items() if r}
    finite = [g[2][g[4]] for g in grids.values()]
    vals = np.concatenate(finite) if finite else np.array([0.0, 1.0])
    vmin, vmax = min(0.0, float(np.nanmin(vals))), float(np.nanmax(vals))
    cmap = matplotlib.colormaps["viridis"]
    n_failed = 0
    with styled_figure(COLUMN_WIDTH, 5.6) as fig:
        axes = fig.subplots(2, 1, sharex=True)
        im = None
        for ax, c, lab in zip(axes, _FIG6_CURVATURES, ("(a)", "(b)")):
            if c in grids:
                Ls, bs, D, _, ok = grids[c]
                im = ax.pcolormesh(Ls, bs, np.where(ok, D, np.nan), shading="nearest",
                                   cmap=cmap, vmin=vmin, vmax=vmax, rasterized=True)
                jb, jl = maps.jump_curve(records[c], "increasing")
                (ln,) = ax.plot(jl, jb, color="black", linestyle="--", linewidth=1.1,
                                path_effects=halo(2.4), zorder=4)
                ln.set_gid(f"ribbon-jump|k={fmt(c)}")
                ax.set_xlim(Ls[0] - 0.5 * (Ls[1] - Ls[0]) if Ls.size > 1 else Ls[0],
                            Ls[-1] + 0.5 * (Ls[1] - Ls[0]) if Ls.size > 1 else Ls[-1])
                ax.set_ylim(-0.02, 1.02)
            rows = select_rows(fe, curvature=c) if len(fe) else fe
            cd_pts, gd_pts = [], []
            clines = (curve_fold_lines(by_curve[float(c)]) if float(c) in by_curve else None)
            b_star = clines["tip"][0] if clines is not None else np.inf
            if clines is not None:
                grid = quality_settings(quality)["grid"] if quality in QUALITIES else {}
                tips = grid.get(float(c), sorted({float(b) for b in rows["tip_width"]})
                                if len(rows) else [])
                cd_pts, gd_pts = curve_modes(clines, tips, Lm)
            for _, row in rows.iterrows():
                if float(row["tip_width"]) > b_star:
                    continue  # from the fold curve
                if not usable(row):
                    n_failed += 1
                    continue
                cd, gd = foldmap.modes(row, Lm)
                b = float(row["tip_width"])
                cd_pts += [(L, b) for L in Lm[cd]]
                gd_pts += [(L, b) for L in Lm[gd]]
            for pts, kw, gid in ((gd_pts, dict(marker="s", markersize=msq,
                                                markerfacecolor="none"), "fe-gravity"),
                                 (cd_pts, dict(marker="D", markersize=mdi,
                                               markerfacecolor="black"), "fe-curvature")):
                xy = np.array(pts, float).reshape(-1, 2)
                (ln,) = ax.plot(xy[:, 0], xy[:, 1], linestyle="none", markeredgecolor="black",
                                markeredgewidth=0.7, path_effects=halo(1.5), **kw)
                ln.set_gid(f"{gid}|k={fmt(c)}")
            lines = (None if clines is not None or not len(rows)
                     else fold_lines(rows, crit.get(float(c), (np.nan, np.nan, np.nan))))
            if clines is not None:
                L, b = clines["curve"]
                (ln,) = ax.plot(L, b, color="black", linewidth=1.3, path_effects=halo(2.6))
                ln.set_gid(f"fe-folds|k={fmt(c)}")
                (cu,) = ax.plot([clines["tip"][1]], [clines["tip"][0]], marker="o",
                                markersize=3.2, color="black", linestyle="none", zorder=6)
                cu.set_gid(f"fe-cusp|k={fmt(c)}")
            elif lines is not None:
                L, b = _fold_polyline(lines)
                (ln,) = ax.plot(L, b, color="black", linewidth=1.3, path_effects=halo(2.6))
                ln.set_gid(f"fe-folds|k={fmt(c)}")
            ax.set_ylabel("$b/a$")
            ax.text(0.98, 0.04, f"{lab} $a/R={fmt(c)}$", transform=ax.transAxes,
                    ha="right", va="bottom", fontweight="bold",
                    bbox=dict(boxstyle="round,pad=0.2", facecolor="white", edgecolor="none",
                              alpha=0.85))
        axes[-1].set_xlabel("$L/a$")
        handles = [
            Line2D([], [], linestyle="none", marker="D", markersize=mdi, color="black",
                   label="FE: curvature-dominated mode"),
            Line2D([], [], linestyle="none", marker="s", markersize=msq,
                   markerfacecolor="none", markeredgecolor="black",
                   label="FE: gravity-dominated mode"),
            Line2D([], [], color="black", linewidth=1.3,
                   label="FE: bistable region $L_0^*\\leq L\\leq L_1^*$"),
            Line2D([], [], color="black", linestyle="--", label="ribbon: jump ($L$ increasing)"),
        ]
        if n_failed:
            handles.append(Line2D([], [], color="none",
                                  label=f"{n_failed} map points failed, omitted"))
        fig.legend(handles=handles, loc="upper center", ncol=2, frameon=False,
                   bbox_to_anchor=(0.5, 1.0), columnspacing=0.8, handletextpad=0.4)
        top = 1.0 - (0.16 * ((len(handles) + 1) // 2) + 0.05) / fig.get_figheight()
        fig.tight_layout(rect=(0, 0, 0.86, top), h_pad=0.4)
        pos = [ax.get_position() for ax in axes]
        cax = fig.add_axes([0.88, pos[-1].y0, 0.025, pos[0].y1 - pos[-1].y0])
        if im is None:
            im = cm.ScalarMappable(norm=colors.Normalize(vmin, vmax), cmap=cmap)
        fig.colorbar(im, cax=cax)
        cax.set_ylabel("$d/a$ (ribbon model)")
        cax.tick_params(labelsize=6)
        s = quality_settings(quality) if quality in QUALITIES else {}
        src = (f"FE fold curves hmax={hmax_of(curves)}, map points hmax={hmax_of(fe)}"
               if by_curve else f"FE fold map hmax={hmax_of(fe)}")
        footnote(fig, quality, f"{src}; ribbon map "
                                f"{len(set(rom['length'])) if len(rom) else 0} x "
                                f"{len(set(rom['tip_width'])) if len(rom) else 0}"
                                + (f", markers every {fmt(s['fig6_lengths'][2])} in L/a"
                                   if s else "") + f"; {FOLD_ACCURACY}")
    return fig


def fig6(quality="quick", data_dir=DEFAULT_DATA_DIR, progress=True, workers=None,
         method=None, log=None):
    """Fig. 6: ribbon-model map of d/a over (L/a, b/a) with the FE modes and bistable region.

    ``method=None``: :data:`skfem_sheet.figures.data.FIGURE_METHOD`.
    ``method="curves"`` (the default there): the fold curves at a/R = 2.5 and 5 (the
    quality's fold-curve table), and fold-map points only at the shape
    factors of the grid at or below each cusp; ``"grid"``: every point of
    :func:`fig6_points` from the fold map.  ``log``: a list to append the
    data steps to (:class:`~skfem_sheet.figures.work.DataStep`).

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> fig6("quick").savefig("fig6.png", dpi=200)  # doctest: +SKIP
    """
    method = figure_method(method)
    Lm = arange(*quality_settings(quality)["fig6_lengths"])
    rom = fig6_ribbon(quality, data_dir, progress, workers, log)
    if method == "grid":
        fe = fold_map_table(fig6_points(quality), quality, data_dir, progress, workers, log)
        return draw_fig6(fe, rom, quality, mode_lengths=Lm)
    curves = fold_curve_table(fold_curve_points(quality, _FIG6_CURVATURES, rectangle=False),
                              quality, data_dir, progress, workers, log)
    cusp = {}
    for c, row in _curve_rows(curves).items():
        lines = curve_fold_lines(row)
        cusp[c] = lines["tip"][0] if lines is not None else np.inf
    pts = map_grid_points(quality, lambda c, b: c in _FIG6_CURVATURES
                          and b <= cusp.get(float(c), np.inf))
    # below the cusps only the transition length of each row is drawn: the
    # rows that fig2 and fig4 draw whole are taken whole, the others traced
    # on the fine mesh only around their transition
    fe = transition_rows(pts, quality, data_dir, progress, workers, log,
                         full=fig2_points(quality) + fig4_points(quality))
    return draw_fig6(fe, rom, quality, mode_lengths=Lm, curves=curves)
