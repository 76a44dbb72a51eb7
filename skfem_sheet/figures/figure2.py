"""Fig. 2: d/a against L/a, (a) rectangles and (b) triangles, a/R in {0, 1, 2.5, 5}.

Both stable branches where a row is bistable (fold map, see
:mod:`skfem_sheet.figures`).

Examples
--------
>>> len(fig2_points("quick"))
8
"""
from __future__ import annotations

from .common import DEFAULT_DATA_DIR
from .data import fold_map_table, map_grid_points, select_rows
from .style import (
    COLUMN_WIDTH,
    CURVATURE_COLOURS,
    colour_handles,
    draw_row,
    fmt,
    footnote,
    hmax_of,
    panel_label,
    style_handles,
    styled_figure,
    tally,
    top_legends,
)

__all__ = ["fig2_points", "draw_fig2", "fig2"]


def fig2_points(quality: str = "quick") -> list:
    """Fold-map points of Fig. 2: rectangles and triangles, a/R in {0, 1, 2.5, 5}.

    Examples
    --------
    >>> sorted((p["curvature"], p["tip_width"]) for p in fig2_points())[:3]
    [(0.0, 0.0), (0.0, 1.0), (1.0, 0.0)]
    """
    return map_grid_points(quality, lambda c, b: c in (0.0, 1.0, 2.5, 5.0) and b in (0.0, 1.0))


def draw_fig2(df, quality: str = "paper"):
    """Draw Fig. 2 from fold-map rows: d/a against L/a, (a) rectangles, (b) triangles.

    Parameters
    ----------
    df : pandas.DataFrame
        Fold-map rows (:data:`skfem_sheet.studies.foldmap.MAP_COLUMNS`) of b/a = 1
        and 0 at any curvatures.
    quality : str
        ``"quick"`` adds a footnote saying so.

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> import json, pandas as pd
    >>> c = json.dumps({"lengths": [1.0, 2.0], "deflection": [0.4, 1.5],
    ...                 "stable": [True, True]})
    >>> rows = [dict(tip_width=b, curvature=0.0, hmax=0.1, bistable=False,
    ...              popup_length=float("nan"), standout_length=float("nan"),
    ...              transition_length=float("nan"), curvature_dominated=c,
    ...              gravity_dominated=c, curvature_dominated_snapped=False,
    ...              gravity_dominated_snapped=False, message="", error="")
    ...         for b in (0.0, 1.0)]
    >>> fig = draw_fig2(pd.DataFrame(rows))
    >>> fig.axes[1].get_xlabel(), fig.axes[0].get_ylabel()
    ('$L/a$', '$d/a$')
    """
    with styled_figure(COLUMN_WIDTH, 4.6) as fig:
        axes = fig.subplots(2, 1, sharex=True)
        drawn = []
        for ax, tip, name, lab in zip(axes, (1.0, 0.0), ("rectangles", "triangles"),
                                      ("(a)", "(b)")):
            sub = select_rows(df, tip_width=tip)
            for k in sorted(set(sub["curvature"].astype(float))):
                colour = CURVATURE_COLOURS.get(k, None)
                for _, row in select_rows(sub, curvature=k).iterrows():
                    drawn.append((f"$a/R={fmt(k)}$", draw_row(ax, row, colour)))
            ax.axhline(0.0, color="0.75", linewidth=0.5, zorder=0)
            ax.set_ylabel("$d/a$")
            panel_label(ax, f"{lab} {name} ($b/a={fmt(tip)}$)")
        # the a/R colours in (a); modes, jumps, failures on top
        n_failed, any_bistable, key = tally(drawn)
        if key:
            axes[0].legend(handles=colour_handles(key), loc="upper left",
                           bbox_to_anchor=(0.0, 0.9), frameon=False)
        top = top_legends(fig, [(style_handles(jumps=any_bistable, n_failed=n_failed), 2)])
        axes[-1].set_xlabel("$L/a$")
        fig.tight_layout(h_pad=0.4, rect=(0, 0, 1, top))
        footnote(fig, quality, f"FE fold map hmax={hmax_of(df)}")
    return fig


def fig2(quality="quick", data_dir=DEFAULT_DATA_DIR, progress=True, workers=None, log=None):
    """Fig. 2: tip deflection d/a against L/a from simulations (rectangles, triangles).

    Reads (computing what is missing) the fold map ``data_dir/foldmap-<quality>.csv``.
    ``log``: a list to append the data steps to
    (:class:`~skfem_sheet.figures.work.DataStep`; ``figure all`` reads them).

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> fig = fig2("quick", data_dir="skfem_sheet_data")  # doctest: +SKIP
    >>> fig.savefig("fig2.png", dpi=200)  # doctest: +SKIP
    """
    df = fold_map_table(fig2_points(quality), quality, data_dir, progress, workers, log)
    return draw_fig2(df, quality)
