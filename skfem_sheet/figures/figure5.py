"""Fig. 5: finite elements against the ribbon model (rectangle, triangle; a/R = 1, 2.5).

The finite-element curves are fold-map rows (fig2's); the ribbon-model
curves (:func:`skfem_sheet.reduced.ribbon_continuation`, both directions)
are cached in ``data_dir/fig5-<quality>-ribbon.csv``.

Examples
--------
>>> sorted({(p["curvature"], p["tip_width"]) for p in fig5_points("quick")})
[(1.0, 0.0), (1.0, 1.0), (2.5, 0.0), (2.5, 1.0)]
"""
from __future__ import annotations

import itertools
import os
import time

import numpy as np
import pandas as pd
from tqdm.auto import tqdm

from .. import reduced
from ..params import Sheet
from .cache import data_folder, load_or_compute
from .common import DEFAULT_DATA_DIR, arange, quality_settings
from .data import as_bool, fold_map_table, select_rows
from .figure2 import fig2_points
from .style import (
    COLUMN_WIDTH,
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
from .work import DataStep, note

__all__ = ["fig5_points", "fig5_ribbon", "draw_fig5", "fig5"]

#: Columns of the ribbon-curve cache.
_RIBBON_FIELDS = ("tip_width", "curvature", "direction", "length", "deflection", "converged",
                  "jumped")


def fig5_points(quality: str = "quick") -> list:
    """Fold-map points of Fig. 5: fig2's at a/R = 1 and 2.5.

    Examples
    --------
    >>> all(p in fig2_points("paper") for p in fig5_points("paper"))
    True
    """
    return [p for p in fig2_points(quality) if p["curvature"] in (1.0, 2.5)]


def fig5_ribbon(quality="quick", data_dir=DEFAULT_DATA_DIR, progress=True, log=None):
    """Ribbon-model curves of Fig. 5, both continuation directions (cached CSV).

    ``log``: a list to append the step's :class:`~skfem_sheet.figures.work.DataStep`
    to (the 8 continuations, computed or cached; the ribbon model is not
    finite elements: no solves counted).

    Returns
    -------
    pandas.DataFrame
        Columns tip_width, curvature, direction, length, deflection, converged,
        jumped (a jump lies between this length and the previous one).

    Examples
    --------
    >>> sorted(set(fig5_ribbon("quick").direction))  # about 10 s  # doctest: +SKIP
    ['decreasing', 'increasing']
    """
    s = quality_settings(quality)
    fn = os.path.join(data_folder(data_dir), f"fig5-{quality}-ribbon.csv")
    lengths = arange(*s["lengths"], s["ribbon_step"])

    def on_grid(df):
        have = np.unique(df["length"].to_numpy(float)) if len(df) else np.empty(0)
        return len(df) == 4 * 2 * lengths.size and have.shape == lengths.shape \
            and np.allclose(have, lengths)

    cases = list(itertools.product((1.0, 0.0), (1.0, 2.5), ("increasing", "decreasing")))

    def compute():
        rows = []
        for b, k, direction in tqdm(cases, desc="fig5 ribbon model", disable=not progress,
                                    leave=None):
            br = reduced.ribbon_continuation(Sheet(1.0, tip_width=b, curvature=k), lengths,
                                             direction)
            for L, d, c, j in zip(br.lengths, br.deflection, br.converged, br.jumped):
                rows.append({"tip_width": b, "curvature": k, "direction": direction,
                             "length": float(L), "deflection": float(d), "converged": bool(c),
                             "jumped": bool(j)})
        return pd.DataFrame(rows, columns=list(_RIBBON_FIELDS))

    t0 = time.perf_counter()
    df, computed = load_or_compute(fn, compute, accept=on_grid)
    t = time.perf_counter() - t0
    note(log, DataStep("ribbon model", computed=len(cases) if computed else 0,
                       cached=0 if computed else len(cases), wall_time_s=t,
                       compute_s=t if computed else 0.0, finite_elements=False))
    return df


def _ribbon_line(ax, sub, colour, linestyle, label):
    """A ribbon branch in continuation order, broken at its jumps; returns failures."""
    ok = as_bool(sub["converged"])
    jumped = as_bool(sub["jumped"])
    L = sub["length"].to_numpy(float)
    d = sub["deflection"].to_numpy(float)
    xs, ys = [], []
    for i in range(L.size):
        if not ok[i]:
            continue
        if jumped[i] and xs:
            xs.append(np.nan)
            ys.append(np.nan)
        xs.append(L[i])
        ys.append(d[i])
    ax.plot(xs, ys, color=colour, linestyle=linestyle, label=label, linewidth=0.9)
    return int((~ok).sum())


def draw_fig5(fe, rom, quality: str = "paper"):
    """Draw Fig. 5: finite elements (blue; solid + filled: curvature-dominated, dashed +
    open: gravity-dominated) against the ribbon model (orange; dashed: increasing L,
    dotted: decreasing L), (a, b) a/R = 1, (c, d) a/R = 2.5.

    Parameters
    ----------
    fe : pandas.DataFrame
        Fold-map rows of b/a = 1 and 0 at a/R = 1 and 2.5.
    rom : pandas.DataFrame
        From :func:`fig5_ribbon`.

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> import json, pandas as pd
    >>> c = json.dumps({"lengths": [1.0, 2.0], "deflection": [0.3, 0.6],
    ...                 "stable": [True, True]})
    >>> fe = pd.DataFrame([dict(tip_width=b, curvature=k, hmax=0.1, bistable=False,
    ...                         popup_length=float("nan"), standout_length=float("nan"),
    ...                         transition_length=1.5, curvature_dominated=c,
    ...                         gravity_dominated=c, curvature_dominated_snapped=False,
    ...                         gravity_dominated_snapped=False, message="", error="")
    ...                    for b in (0.0, 1.0) for k in (1.0, 2.5)])
    >>> rom = pd.DataFrame([dict(length=L, tip_width=b, curvature=k, direction=dr,
    ...                          deflection=0.3 * L, converged=True, jumped=False)
    ...                     for L in (1.0, 2.0) for b in (0.0, 1.0) for k in (1.0, 2.5)
    ...                     for dr in ("increasing", "decreasing")])
    >>> fig = draw_fig5(fe, rom)
    >>> len(fig.axes), fig.axes[2].get_xlabel(), fig.axes[0].get_ylabel()
    (4, '$L/a$', '$d/a$')
    """
    # deferred: import cost (see figures.style)
    import matplotlib
    from matplotlib.lines import Line2D

    fe_colour, rom_colour = "#1f4e9c", "#e07b00"
    with styled_figure(COLUMN_WIDTH, 3.9) as fig:
        axes = fig.subplots(2, 2, sharex=True, sharey=True)
        panels = [((0, 0), 1.0, 1.0, "(a)"), ((0, 1), 0.0, 1.0, "(b)"),
                  ((1, 0), 1.0, 2.5, "(c)"), ((1, 1), 0.0, 2.5, "(d)")]
        n_rom_failed = 0
        drawn = []
        for (i, j), b, k, lab in panels:
            ax = axes[i, j]
            ax.axhline(0.0, color="0.75", linewidth=0.5, zorder=0)
            r = rom[np.isclose(rom["tip_width"].astype(float), b)
                    & np.isclose(rom["curvature"].astype(float), k)]
            for direction, ls in (("increasing", "--"), ("decreasing", ":")):
                n_rom_failed += _ribbon_line(ax, r[r["direction"] == direction], rom_colour,
                                             ls, None)
            for _, row in select_rows(fe, curvature=k, tip_width=b).iterrows():
                with matplotlib.rc_context({"lines.markersize": 2.5}):
                    drawn.append((None, draw_row(ax, row, fe_colour, gap=0.1)))
            shape = "rectangle" if b == 1.0 else "triangle"
            panel_label(ax, f"{lab} {shape}\n$a/R={fmt(k)}$")
            if i == 1:
                ax.set_xlabel("$L/a$")
            if j == 0:
                ax.set_ylabel("$d/a$")
        n_failed, any_bistable, _ = tally(drawn)
        handles = style_handles(colour=fe_colour, jumps=any_bistable, n_failed=n_failed)
        for h in handles[:2]:
            h.set_label("FE, " + h.get_label())
        handles += [Line2D([], [], color=rom_colour, linestyle=ls, label=f"ribbon, $L$ {d}")
                    for ls, d in (("--", "increasing"), (":", "decreasing"))]
        if n_rom_failed:
            handles.append(Line2D([], [], color="none",
                                  label=f"ribbon: {n_rom_failed} not converged, omitted"))
        top = top_legends(fig, [(handles, 2)])
        fig.tight_layout(rect=(0, 0, 1, top), h_pad=0.3, w_pad=0.3)
        footnote(fig, quality, f"FE fold map hmax={hmax_of(fe)}")
    return fig


def fig5(quality="quick", data_dir=DEFAULT_DATA_DIR, progress=True, workers=None, log=None):
    """Fig. 5: finite elements against the ribbon model (rectangle, triangle; a/R = 1, 2.5).

    The finite-element curves are fold-map rows (fig2's); the ribbon curves
    are cached in ``data_dir/fig5-<quality>-ribbon.csv``.  ``log``: a list to
    append the data steps to (:class:`~skfem_sheet.figures.work.DataStep`).

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> fig5("quick").savefig("fig5.png", dpi=200)  # doctest: +SKIP
    """
    fe = fold_map_table(fig5_points(quality), quality, data_dir, progress, workers, log)
    rom = fig5_ribbon(quality, data_dir, progress, log)
    return draw_fig5(fe, rom, quality)
