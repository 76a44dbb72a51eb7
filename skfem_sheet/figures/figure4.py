"""Fig. 4: d/a against L/a for b/a in {0, 0.2, ..., 1} at a/R = 0 (a) and 2.5 (b).

Insets against the plan area A/a^2 = (1 + b/a) L/(2a); fold map (see
:mod:`skfem_sheet.figures`).

Examples
--------
>>> len(fig4_points("quick"))
12
"""
from __future__ import annotations

from .common import DEFAULT_DATA_DIR
from .data import fold_map_table, map_grid_points, select_rows
from .style import (
    COLUMN_WIDTH,
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

__all__ = ["fig4_points", "draw_fig4", "fig4"]


def fig4_points(quality: str = "quick") -> list:
    """Fold-map points of Fig. 4: b/a in {0, 0.2, ..., 1} at a/R = 0 and 2.5.

    Examples
    --------
    >>> len(fig4_points())
    12
    """
    tips = (0.0, 0.2, 0.4, 0.6, 0.8, 1.0)
    return map_grid_points(quality, lambda c, b: c in (0.0, 2.5) and b in tips)


def draw_fig4(df, quality: str = "paper"):
    """Draw Fig. 4: d/a against L/a for several b/a at a/R = 0 (a) and 2.5 (b),
    insets against the plan area A/a^2 = (1 + b/a) L/(2a).

    Parameters
    ----------
    df : pandas.DataFrame
        Fold-map rows at a/R = 0 and 2.5.

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> import json, pandas as pd
    >>> c = json.dumps({"lengths": [1.0, 2.0], "deflection": [0.4, 1.5],
    ...                 "stable": [True, True]})
    >>> rows = [dict(tip_width=b, curvature=k, hmax=0.1, bistable=False,
    ...              popup_length=float("nan"), standout_length=float("nan"),
    ...              transition_length=1.5, curvature_dominated=c, gravity_dominated=c,
    ...              curvature_dominated_snapped=False, gravity_dominated_snapped=False,
    ...              message="", error="") for b in (0.0, 1.0) for k in (0.0, 2.5)]
    >>> fig = draw_fig4(pd.DataFrame(rows))
    >>> [ax.get_xlabel() for ax in fig.axes], fig.axes[0].child_axes[0].get_xlabel()
    (['', '$L/a$'], '$A/a^2$')
    """
    import matplotlib  # deferred: import cost (see figures.style)

    tips = sorted(set(df["tip_width"].astype(float)))
    cmap = matplotlib.colormaps["viridis"]

    def colour(b):
        return cmap(0.85 * b)

    with styled_figure(COLUMN_WIDTH, 5.6) as fig:
        main = fig.subplots(2, 1, sharex=True)
        drawn = []
        for ax, k, lab in zip(main, (0.0, 2.5), ("(a)", "(b)")):
            sub = select_rows(df, curvature=k)
            inset = ax.inset_axes([0.11, 0.55, 0.33, 0.33])
            for b in tips:
                for _, row in select_rows(sub, tip_width=b).iterrows():
                    drawn.append((f"$b/a={fmt(b)}$", draw_row(ax, row, colour(b), gap=0.1)))
                    with matplotlib.rc_context({"lines.linewidth": 0.7}):
                        draw_row(inset, row, colour(b), x=lambda L, b=b: 0.5 * (1 + b) * L,
                                  markers=False, jumps=False)
            for a in (ax, inset):
                a.axhline(0.0, color="0.75", linewidth=0.5, zorder=0)
            inset.set_xlabel("$A/a^2$", fontsize=6, labelpad=1)
            inset.set_ylabel("$d/a$", fontsize=6, labelpad=1)
            inset.tick_params(labelsize=5.5, pad=1.5, length=2)
            ax.set_ylabel("$d/a$")
            panel_label(ax, f"{lab} $a/R={fmt(k)}$")
        # above the panels, where no curve can hide under them: the shapes (colours),
        # then the modes, the jumps and failures (both panels)
        n_failed, any_bistable, key = tally(drawn)
        top = top_legends(fig, [(colour_handles(key), 3),
                                 (style_handles(jumps=any_bistable, n_failed=n_failed), 2)])
        main[-1].set_xlabel("$L/a$")
        fig.tight_layout(h_pad=0.4, rect=(0, 0, 1, top))
        footnote(fig, quality, f"FE fold map hmax={hmax_of(df)}")
    return fig


def fig4(quality="quick", data_dir=DEFAULT_DATA_DIR, progress=True, workers=None, log=None):
    """Fig. 4: d/a against L/a for b/a in {0, 0.2, ..., 1}, a/R = 0 and 2.5 (fold map).

    ``log``: a list to append the data steps to
    (:class:`~skfem_sheet.figures.work.DataStep`; ``figure all`` reads them).

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> fig4("quick").savefig("fig4.png", dpi=200)  # doctest: +SKIP
    """
    df = fold_map_table(fig4_points(quality), quality, data_dir, progress, workers, log)
    return draw_fig4(df, quality)
