"""The paper's figures, one command each: ``python -m skfem_sheet figure NAME``.

====  ==================================================================  =====================
name  what it shows (paper caption)                                       data
====  ==================================================================  =====================
fig2  d/a against L/a, rectangles (a) and triangles (b),                 fold map
      a/R in {0, 1, 2.5, 5}; both stable branches where bistable
fig3  deformed sheets coloured by psi/mu at a/R = 2.5, L/a = 1.3:         six full FE solves
      rectangle (both modes), triangle, trapezoids b/a = 0.8, 0.6, 0.4
fig4  d/a against L/a for b/a in {0, 0.2, ..., 1} at a/R = 0 (a) and      fold map
      2.5 (b); insets against the area A/a^2
fig5  finite elements against the ribbon model, rectangle and triangle,  fold map + ribbon
      a/R = 1 and 2.5
fig6  ribbon-model d/a over (L/a, b/a) at a/R = 2.5 (a) and 5 (b), its   ribbon map + fold map
      jumps, FE modes (markers) and the FE bistable region
fig7  the bistable region in (L/a, b/a, a/R): standout L1* (upper) and    fold map
      pop-up L0* (lower) surfaces meeting on the critical curve
====  ==================================================================  =====================

Data: every finite-element curve of fig2, fig4-fig7 comes from one fold-map
table per quality, ``data_dir/foldmap-<quality>.csv``
(:func:`skfem_sheet.foldmap.fold_map`): for each (b/a, a/R) both stable
branches as curves d(L) -- the curvature-dominated one followed up from
``L/a = 0.5`` to its fold ``L1*``, the gravity-dominated one down from
``L/a = 3`` to its fold ``L0*`` -- with the stability of every point.
Each figure asks the map for the (b/a, a/R) points it needs; points already
in the table (its journal) are not recomputed, so drawing twice computes
nothing twice, and the figures share their points (fig5's are fig2's).
fig3 keeps its deformed surfaces in ``fig3-<quality>/*.npz``, fig5 its ribbon
curves in ``fig5-<quality>-ribbon.csv``, fig6 its ribbon map in
``fig6-<quality>-ribbon.csv``.

Quality: ``"quick"`` is the fold map at hmax 0.1 with continuation steps of
at most 0.1 in L/a and folds located to +-0.005 (:data:`QUICK_GRID`; 10 s
to 4.5 min per (b/a, a/R) point on one core, longest for wide, strongly
curved sheets; the 49 points took 44 min on 2 cores, once; then each figure
draws in about 5 s from the table, and fig6 adds about 1.5 min for its
ribbon map the first time).  ``"paper"`` uses hmax
0.03, steps of 0.05 and finer grids (:data:`PAPER_GRID`; hours on a
cluster).  Quick figures carry a footnote saying so.

Drawing convention (fig2, fig4, fig5): solid lines and filled markers are
the curvature-dominated mode, dashed lines and open markers the
gravity-dominated one, only stable points (stability unknown counts as
stable).  Where a row is bistable both branches are drawn, each up to its
fold, with a dotted arrow at each fold for the jump to the other branch;
elsewhere the two branches coincide and one curve is drawn, solid below the
transition length and dashed above (:func:`skfem_sheet.foldmap.modes`; at
a/R = 0 there is no curvature-dominated mode).  Map points that failed are
left out and counted in the legend.

Adding a figure: :data:`FIGURES` maps a name to a function
``(quality, data_dir, progress, workers) -> matplotlib Figure``; the CLI's
choices are its keys.

Examples
--------
>>> {"fig2", "fig3", "fig4", "fig5", "fig6", "fig7"} <= set(FIGURES)
True
>>> quality_settings("quick")["hmax"]
0.1
>>> sorted(QUICK_GRID)
[0.0, 1.0, 1.5, 2.0, 2.5, 3.5, 5.0]
"""
from __future__ import annotations

import importlib
import itertools
import math
import os

import numpy as np

from .params import ParameterError

__all__ = ["FIGURES", "QUALITIES", "DEFAULT_DATA_DIR", "QUICK_GRID", "PAPER_GRID",
           "quality_settings", "make_figure", "map_grid_points", "fold_map_table",
           "fig2", "fig3", "fig4", "fig5", "fig6", "fig7",
           "fig2_points", "fig4_points", "fig5_points", "fig6_points", "fig7_points",
           "draw_fig2", "draw_fig3", "draw_fig4", "draw_fig5", "draw_fig6", "draw_fig7",
           "fig3_sheets", "fig3_data", "fig5_ribbon", "fig6_ribbon", "row_branches",
           "bistable_region",
           "add_figure_subparser"]

QUALITIES = ("quick", "paper")
DEFAULT_DATA_DIR = "skfem_sheet_data"

#: Column width of a two-column journal (inches), full width, output resolution.
COLUMN_WIDTH = 3.4
FULL_WIDTH = 7.0
DPI = 200

_STYLE = {"font.size": 8, "axes.labelsize": 8, "axes.titlesize": 8, "legend.fontsize": 7,
          "xtick.labelsize": 7, "ytick.labelsize": 7, "lines.linewidth": 1.0,
          "lines.markersize": 3.5, "legend.handlelength": 1.8, "legend.borderaxespad": 0.3,
          "axes.linewidth": 0.6, "savefig.dpi": DPI}

#: The fold map of quick quality, ``{a/R: [b/a, ...]}``: every figure's points are in it.
QUICK_GRID = {0.0: [0.0, 0.2, 0.4, 0.6, 0.8, 1.0],
              1.0: [0.0, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0],
              1.5: [0.5, 0.6, 0.7, 0.8, 0.9, 1.0],
              2.0: [0.5, 0.6, 0.7, 0.8, 0.9, 1.0],
              2.5: [0.0, 0.2, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0],
              3.5: [0.5, 0.6, 0.7, 0.8, 0.9, 1.0],
              5.0: [0.0, 0.2, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0]}

_FINE_TIPS = [round(0.5 + 0.05 * i, 6) for i in range(11)]       # 0.5, 0.55, ..., 1
_TAPERED = [0.0, 0.1, 0.2, 0.3, 0.4]
#: The fold map of paper quality: b/a in steps of 0.05 where bistability can
#: appear (b/a >= 0.5), a/R in steps of 0.25 up to 2.5 and 0.5 beyond.
PAPER_GRID = {0.0: [0.0, 0.2, 0.4, 0.6, 0.8, 1.0],
              **{c: (_TAPERED + _FINE_TIPS if c in (1.0, 2.5, 5.0) else list(_FINE_TIPS))
                 for c in (1.0, 1.25, 1.5, 1.75, 2.0, 2.25, 2.5, 3.0, 3.5, 4.0, 4.5, 5.0)}}

_SETTINGS = {
    "quick": {
        "hmax": 0.1, "hmax_fig3": 0.08, "lengths": (0.5, 3.0), "step": 0.1, "tol": 0.005,
        "grid": QUICK_GRID,
        "fig6_lengths": (0.6, 2.8, 0.1),        # FE mode markers
        "fig6_ribbon_lengths": (0.5, 3.0, 0.1),  # ribbon background (26 x 26)
        "fig6_ribbon_tips": 26,
        "fig7_curvatures": (1.0, 1.5, 2.0, 2.5, 3.5, 5.0),
        "ribbon_step": 0.05,                     # fig5's ribbon curves
        "marker_gap": 0.06,                      # least L/a between two markers of a curve
    },
    "paper": {
        "hmax": 0.03, "hmax_fig3": 0.03, "lengths": (0.5, 3.0), "step": 0.05, "tol": 0.005,
        "grid": PAPER_GRID,
        "fig6_lengths": (0.6, 2.8, 0.1),
        "fig6_ribbon_lengths": (0.5, 3.0, 0.02),
        "fig6_ribbon_tips": 51,
        "fig7_curvatures": (1.0, 1.25, 1.5, 1.75, 2.0, 2.25, 2.5, 3.0, 3.5, 4.0, 4.5, 5.0),
        "ribbon_step": 0.01,
        "marker_gap": 0.1,
    },
}

_CURVATURE_COLOURS = {0.0: "#444444", 1.0: "#1f77b4", 2.5: "#d62728", 5.0: "#2ca02c"}
#: Line style of the two modes: solid + filled (curvature-dominated), dashed + open.
_MODE_STYLE = {"curvature_dominated": dict(linestyle="-", filled=True, marker="o"),
               "gravity_dominated": dict(linestyle="--", filled=False, marker="o")}
_MODE_LABEL = {"curvature_dominated": "curvature-dominated",
               "gravity_dominated": "gravity-dominated"}


def quality_settings(quality: str) -> dict:
    """Mesh size and grids of a quality level (``"quick"`` or ``"paper"``).

    Examples
    --------
    >>> s = quality_settings("paper")
    >>> s["hmax"], s["step"], len(s["grid"])
    (0.03, 0.05, 13)
    >>> quality_settings("draft")
    Traceback (most recent call last):
    ...
    skfem_sheet.params.ParameterError: quality must be one of quick, paper, got 'draft'
    """
    if quality not in _SETTINGS:
        raise ParameterError(f"quality must be one of {', '.join(QUALITIES)}, got {quality!r}")
    return dict(_SETTINGS[quality])


# -- data --------------------------------------------------------------------------------
def _foldmap():
    """The fold-map module (looked up at call time so tests can substitute it)."""
    return importlib.import_module("skfem_sheet.studies.foldmap")


def _arange(lo, hi, step):
    return np.round(np.arange(lo, hi + 1e-9, step), 6)


def map_grid_points(quality: str = "quick", select=None) -> list:
    """Fold-map points of the quality's grid, optionally only the ``(a/R, b/a)`` ``select``-ed.

    ``select(curvature, tip_width) -> bool`` picks grid points; the points are
    those of :func:`skfem_sheet.foldmap.map_points` with the quality's
    lengths, mesh, step and tolerance, so every figure asks for the very
    same points (same journal keys) as a run over the whole grid.

    Examples
    --------
    >>> pts = map_grid_points("quick")
    >>> len(pts), pts[0]["hmax"], pts[0]["length_min"], pts[0]["length_max"]
    (49, 0.1, 0.5, 3.0)
    >>> len(map_grid_points("quick", lambda c, b: c == 2.5))
    9
    """
    s = quality_settings(quality)
    fm = _foldmap()
    out = []
    for c, tips in s["grid"].items():
        tips = [b for b in tips if select is None or select(c, b)]
        if tips:
            out += fm.map_points(tips, [c], lengths=s["lengths"], hmax=s["hmax"],
                                 step=s["step"], tol=s["tol"])
    return out


def fig2_points(quality: str = "quick") -> list:
    """Fold-map points of Fig. 2: rectangles and triangles, a/R in {0, 1, 2.5, 5}.

    Examples
    --------
    >>> sorted((p["curvature"], p["tip_width"]) for p in fig2_points())[:3]
    [(0.0, 0.0), (0.0, 1.0), (1.0, 0.0)]
    """
    return map_grid_points(quality, lambda c, b: c in (0.0, 1.0, 2.5, 5.0) and b in (0.0, 1.0))


def fig4_points(quality: str = "quick") -> list:
    """Fold-map points of Fig. 4: b/a in {0, 0.2, ..., 1} at a/R = 0 and 2.5.

    Examples
    --------
    >>> len(fig4_points())
    12
    """
    tips = (0.0, 0.2, 0.4, 0.6, 0.8, 1.0)
    return map_grid_points(quality, lambda c, b: c in (0.0, 2.5) and b in tips)


def fig5_points(quality: str = "quick") -> list:
    """Fold-map points of Fig. 5: fig2's at a/R = 1 and 2.5.

    Examples
    --------
    >>> all(p in fig2_points("paper") for p in fig5_points("paper"))
    True
    """
    return [p for p in fig2_points(quality) if p["curvature"] in (1.0, 2.5)]


def fig6_points(quality: str = "quick") -> list:
    """Fold-map points of Fig. 6: every shape factor of the grid at a/R = 2.5 and 5.

    Examples
    --------
    >>> sorted({p["curvature"] for p in fig6_points()}), len(fig6_points())
    ([2.5, 5.0], 18)
    """
    return map_grid_points(quality, lambda c, b: c in (2.5, 5.0))


def fig7_points(quality: str = "quick") -> list:
    """Fold-map points of Fig. 7: b/a >= 0.5 at the quality's a/R > 0.

    Examples
    --------
    >>> len(fig7_points()), min(p["tip_width"] for p in fig7_points())
    (36, 0.5)
    """
    cs = quality_settings(quality)["fig7_curvatures"]
    return map_grid_points(quality, lambda c, b: c in cs and b >= 0.5)


def _table(data_dir, name: str, quality: str) -> str:
    data_dir = os.fspath(data_dir)
    try:
        os.makedirs(data_dir, exist_ok=True)
    except OSError as err:
        raise ParameterError(f"data_dir must be a writable folder, got {data_dir!r} ({err})") \
            from None
    return os.path.join(data_dir, f"{name}-{quality}.csv")


def fold_map_table(points, quality: str = "quick", data_dir=DEFAULT_DATA_DIR, progress=True,
                   workers=None):
    """Rows of the quality's fold-map table for ``points`` (computing the missing ones).

    The table is ``data_dir/foldmap-<quality>.csv`` with its journal; points
    already journalled are read, not recomputed.

    Returns
    -------
    pandas.DataFrame
        One row per point, in order (:data:`skfem_sheet.foldmap.MAP_COLUMNS`).

    Examples
    --------
    >>> df = fold_map_table(fig2_points("quick"), "quick", "skfem_sheet_data")  # doctest: +SKIP
    """
    table = _table(data_dir, "foldmap", quality)
    return _foldmap().fold_map(points, table=table, workers=workers, progress=progress)


def _as_bool(values):
    """Booleans from a column that may hold bools, 0/1, NA or the strings True/False."""
    import pandas as pd

    out = []
    for v in values:
        if isinstance(v, str):
            out.append(v.strip().lower() in ("true", "1", "yes"))
        elif v is None or pd.isna(v):
            out.append(False)
        else:
            out.append(bool(v))
    return np.array(out, dtype=bool)


def _text(row, name) -> str:
    v = row[name] if name in row else ""
    return v if isinstance(v, str) else ""


def _float(v) -> float:
    return math.nan if v is None else float(v)


def _usable(row) -> bool:
    """The row holds branch curves (its computation did not fail)."""
    return not _text(row, "error") and bool(_text(row, "curvature_dominated")
                                           or _text(row, "gravity_dominated"))


def row_branches(row) -> dict:
    """What to draw of one fold-map row: the stable branches and where they part.

    Returns
    -------
    dict
        ``curvature_dominated`` and ``gravity_dominated``: ``(L, d)`` arrays
        of the stable points (stability unknown counts as stable) of each
        branch, sorted by L, empty if the branch did not exist where its
        continuation started (its points would lie on the other branch);
        ``bistable``; ``popup_length`` (L0*), ``standout_length`` (L1*);
        ``transition_length`` (non-bistable rows: where the single curve
        passes from the curvature- to the gravity-dominated mode; None for
        a flat clamp or no curve); ``usable`` (False for a failed point).

    Examples
    --------
    >>> import json
    >>> curve = json.dumps({"lengths": [1.0, 1.1, 1.2], "deflection": [0.1, 0.2, 0.3],
    ...                     "stable": [True, None, False]})
    >>> row = {"bistable": False, "curvature": 2.5, "popup_length": float("nan"),
    ...        "standout_length": float("nan"), "transition_length": 1.1,
    ...        "curvature_dominated": curve, "gravity_dominated": curve, "message": "",
    ...        "error": ""}
    >>> out = row_branches(row)
    >>> out["curvature_dominated"][0].tolist(), out["transition_length"]  # unstable dropped
    ([1.0, 1.1], 1.1)
    """
    fm = _foldmap()
    usable = _usable(row)
    out = {"usable": usable, "bistable": bool(row["bistable"]) and usable,
           "popup_length": _float(row["popup_length"]),
           "standout_length": _float(row["standout_length"])}
    message = _text(row, "message")
    for which in ("curvature_dominated", "gravity_dominated"):
        L, d, st = fm.branch_curve(row, which) if usable else (np.empty(0), np.empty(0), [])
        keep = np.array([s is not False for s in st], dtype=bool)
        if f"the {_MODE_LABEL[which]} branch does not exist" in message:
            keep[:] = False  # its continuation started on the other branch
        out[which] = (L[keep], d[keep])
    t = None
    if usable and not out["bistable"]:
        t = _float(row["transition_length"]) if "transition_length" in row else None
        if t is None or not np.isfinite(t):
            t = fm.transition_length(row)
        t = None if t is None else float(t)
    out["transition_length"] = t
    return out


# -- drawing helpers ---------------------------------------------------------------------
def _new_figure(width, height):
    import matplotlib.pyplot as plt

    return plt.figure(figsize=(width, height))


def _footnote(fig, quality, text, top=False):
    if quality == "quick":
        fig.text(0.995, 0.998 if top else 0.002, f"quick quality: {text}", ha="right",
                 va="top" if top else "bottom", fontsize=5.5, color="0.45")


def _panel_label(ax, text, loc=(0.02, 0.97)):
    ax.text(*loc, text, transform=ax.transAxes, ha="left", va="top", fontweight="bold")


def _fmt(x):
    return f"{x:g}"


def _thin(L, gap):
    """Indices of the points to mark: at least ``gap`` apart in L, always both ends."""
    if len(L) == 0:
        return []
    keep = [0]
    for i in range(1, len(L)):
        if L[i] - L[keep[-1]] >= gap:
            keep.append(i)
    if keep[-1] != len(L) - 1:
        if len(keep) > 1 and L[-1] - L[keep[-1]] < 0.5 * gap:
            keep[-1] = len(L) - 1
        else:
            keep.append(len(L) - 1)
    return keep


def _segment(ax, L, d, colour, mode, gid, x=None, markers=True, gap=0.06, label=None):
    """One piece of a branch in the style of its mode; returns the Line2D (or None)."""
    if len(L) == 0:
        return None
    st = _MODE_STYLE[mode]
    xs = L if x is None else x(L)
    kw = {}
    if markers:
        kw = dict(marker=st["marker"], markevery=_thin(L, gap), markeredgewidth=0.7,
                  markerfacecolor=colour if st["filled"] else "white",
                  markeredgecolor=colour)
    (line,) = ax.plot(xs, d, color=colour, linestyle=st["linestyle"], label=label, **kw)
    line.set_gid(gid)
    return line


def _jump(ax, L, d_from, d_to, colour, gid):
    ann = ax.annotate("", xy=(L, d_to), xytext=(L, d_from),
                      arrowprops=dict(arrowstyle="-|>", color=colour, lw=0.7,
                                      linestyle=(0, (1.2, 1.2)), shrinkA=0, shrinkB=1.5,
                                      mutation_scale=6))
    ann.set_gid(gid)
    return ann


def _draw_row(ax, row, colour, *, x=None, markers=True, jumps=True, gap=0.06, label=None):
    """Draw one fold-map row (see the module docstring); returns what was drawn.

    Returns a dict: ``drawn`` (False for a failed row), ``bistable``,
    ``lines`` {mode: [Line2D]}.
    """
    br = row_branches(row)
    lines = {"curvature_dominated": [], "gravity_dominated": []}
    if not br["usable"]:
        return {"drawn": False, "bistable": False, "lines": lines, "colour": colour}
    tag = f"b={_fmt(float(row['tip_width']))}|k={_fmt(float(row['curvature']))}"
    (Lc, dc), (Lg, dg) = br["curvature_dominated"], br["gravity_dominated"]

    def seg(L, d, mode, lab):
        ln = _segment(ax, L, d, colour, mode, f"{mode}|{tag}", x=x, markers=markers, gap=gap,
                      label=lab)
        if ln is not None:
            lines[mode].append(ln)
        return ln

    if br["bistable"]:
        seg(Lc, dc, "curvature_dominated", label)
        seg(Lg, dg, "gravity_dominated", None)
        if jumps and len(Lc) and len(Lg):
            # L1*: the curvature-dominated branch ends and the sheet drops; L0*: it pops up
            _jump(ax, Lc[-1] if x is None else x(Lc[-1]), dc[-1], np.interp(Lc[-1], Lg, dg),
                  colour, f"jump-L1|{tag}")
            _jump(ax, Lg[0] if x is None else x(Lg[0]), dg[0], np.interp(Lg[0], Lc, dc),
                  colour, f"jump-L0|{tag}")
        return {"drawn": True, "bistable": True, "lines": lines, "colour": colour}
    t = br["transition_length"]
    if not len(Lg):
        seg(Lc, dc, "curvature_dominated", label)
    elif not len(Lc) or t is None:
        seg(Lg, dg, "gravity_dominated", label)
    else:
        below = Lc < t
        above = Lg >= t
        first = seg(Lc[below], dc[below], "curvature_dominated", label)
        # the dashed part starts where the solid one ends: one curve
        Lb, db = Lg[above], dg[above]
        if below.any() and above.any():
            Lb, db = np.r_[Lc[below][-1], Lb], np.r_[dc[below][-1], db]
        seg(Lb, db, "gravity_dominated", None if first is not None else label)
    return {"drawn": True, "bistable": False, "lines": lines, "colour": colour}


def _style_handles(colour="0.3", jumps=True, n_failed=0):
    """Legend handles for the two modes, the jumps at the folds and failed map points."""
    from matplotlib.lines import Line2D

    hs = []
    for mode in ("curvature_dominated", "gravity_dominated"):
        st = _MODE_STYLE[mode]
        hs.append(Line2D([], [], color=colour, linestyle=st["linestyle"], marker=st["marker"],
                         markerfacecolor=colour if st["filled"] else "white",
                         markeredgecolor=colour, label=_MODE_LABEL[mode]))
    if jumps:
        hs.append(Line2D([], [], color=colour, linestyle=(0, (1.2, 1.2)), marker="v",
                         markersize=3, label="jump at a fold ($L_1^*$, $L_0^*$)"))
    if n_failed:
        hs.append(Line2D([], [], color="none", linestyle="none",
                         label=f"{n_failed} map point{'s' if n_failed > 1 else ''} failed, "
                               "omitted"))
    return hs


def _top_legends(fig, groups, row=0.16):
    """Legends stacked above the panels, ``groups = [(handles, ncol), ...]``, each filled
    row by row; returns the top of the room left for the panels (figure fraction)."""
    y = 1.0
    for handles, ncol in groups:
        if not handles:
            continue
        nrow = -(-len(handles) // ncol)
        # a legend fills columns first: reorder so that it reads row by row
        pad = handles + [None] * (nrow * ncol - len(handles))
        order = [pad[r * ncol + c] for c in range(ncol) for r in range(nrow)]
        from matplotlib.lines import Line2D

        order = [Line2D([], [], color="none", label=" ") if h is None else h for h in order]
        fig.legend(handles=order, loc="upper center", ncol=ncol, frameon=False,
                   bbox_to_anchor=(0.5, y), columnspacing=1.0, borderaxespad=0.0)
        y -= (row * nrow + 0.03) / fig.get_figheight()
    return y - 0.03 / fig.get_figheight()


def _colour_handles(key):
    """Legend handles ``{label: colour}`` (plain lines: the mode styles have their own key)."""
    from matplotlib.lines import Line2D

    return [Line2D([], [], color=c, linewidth=1.6, label=lab) for lab, c in key.items()]


def _rows(df, curvature=None, tip_width=None):
    sel = np.ones(len(df), dtype=bool)
    if curvature is not None:
        sel &= np.isclose(df["curvature"].astype(float), curvature)
    if tip_width is not None:
        sel &= np.isclose(df["tip_width"].astype(float), tip_width)
    return df[sel]


def _hmax_of(df):
    hs = sorted({float(h) for h in df["hmax"]}) if "hmax" in df and len(df) else []
    return "/".join(_fmt(h) for h in hs) or "?"


# -- Fig. 2 ------------------------------------------------------------------------------
def draw_fig2(df, quality: str = "paper"):
    """Draw Fig. 2 from fold-map rows: d/a against L/a, (a) rectangles, (b) triangles.

    Parameters
    ----------
    df : pandas.DataFrame
        Fold-map rows (:data:`skfem_sheet.foldmap.MAP_COLUMNS`) of b/a = 1
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
    ...              gravity_dominated=c, message="", error="") for b in (0.0, 1.0)]
    >>> fig = draw_fig2(pd.DataFrame(rows))
    >>> fig.axes[1].get_xlabel(), fig.axes[0].get_ylabel()
    ('$L/a$', '$d/a$')
    """
    import matplotlib

    with matplotlib.rc_context(_STYLE):
        fig = _new_figure(COLUMN_WIDTH, 4.6)
        axes = fig.subplots(2, 1, sharex=True)
        n_failed, any_bistable, key = 0, False, {}
        for ax, tip, name, lab in zip(axes, (1.0, 0.0), ("rectangles", "triangles"),
                                      ("(a)", "(b)")):
            sub = _rows(df, tip_width=tip)
            for k in sorted(set(sub["curvature"].astype(float))):
                colour = _CURVATURE_COLOURS.get(k, None)
                for _, row in _rows(sub, curvature=k).iterrows():
                    res = _draw_row(ax, row, colour)
                    n_failed += not res["drawn"]
                    any_bistable |= res["bistable"]
                    if res["drawn"]:
                        key[f"$a/R={_fmt(k)}$"] = res["colour"]
            ax.axhline(0.0, color="0.75", linewidth=0.5, zorder=0)
            ax.set_ylabel("$d/a$")
            _panel_label(ax, f"{lab} {name} ($b/a={_fmt(tip)}$)")
        # the a/R colours in (a); modes, jumps, failures on top
        if key:
            axes[0].legend(handles=_colour_handles(key), loc="upper left",
                           bbox_to_anchor=(0.0, 0.9), frameon=False)
        top = _top_legends(fig, [(_style_handles(jumps=any_bistable, n_failed=n_failed), 2)])
        axes[-1].set_xlabel("$L/a$")
        fig.tight_layout(h_pad=0.4, rect=(0, 0, 1, top))
        _footnote(fig, quality, f"FE fold map hmax={_hmax_of(df)}")
    return fig


def fig2(quality="quick", data_dir=DEFAULT_DATA_DIR, progress=True, workers=None):
    """Fig. 2: tip deflection d/a against L/a from simulations (rectangles, triangles).

    Reads (computing what is missing) the fold map ``data_dir/foldmap-<quality>.csv``.

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> fig = fig2("quick", data_dir="skfem_sheet_data")  # doctest: +SKIP
    >>> fig.savefig("fig2.png", dpi=200)  # doctest: +SKIP
    """
    df = fold_map_table(fig2_points(quality), quality, data_dir, progress, workers)
    return draw_fig2(df, quality)


# -- Fig. 3 ------------------------------------------------------------------------------
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
    from .params import Sheet

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
    from .plot import top_surface
    from .solve import solve

    r = solve(sheet, path=path, hmax=hmax, on_failure="return")
    X, tri, psi = top_surface(r)
    return {"X": np.asarray(X, float), "tri": np.asarray(tri, np.int64),
            "psi": np.asarray(psi, float), "deflection": float(r.deflection),
            "converged": bool(r.converged), "message": str(r.message),
            "snapped": bool(len(r.snaps)), "hmax": float(hmax)}


def _fig3_file(folder, sheet, path, hmax):
    return os.path.join(folder, f"L{sheet.length:g}_b{sheet.tip_width:g}_k{sheet.curvature:g}_"
                                f"h{sheet.thickness:g}_E{sheet.modulus:g}_{path}_hmax{hmax:g}.npz")


def fig3_data(quality="quick", data_dir=DEFAULT_DATA_DIR, progress=True):
    """Deformed top surfaces of the Fig. 3 sheets, cached in ``data_dir/fig3-<quality>/``.

    Returns
    -------
    list of (panel, title, Sheet, path, dict)
        The dict holds ``X`` (vertices), ``tri``, ``psi`` (psi/mu per triangle),
        ``deflection``, ``converged``, ``message``, ``snapped``, ``hmax``.

    Examples
    --------
    >>> [item[0] for item in fig3_data("quick")]  # doctest: +SKIP
    ['d', 'e', 'f', 'g', 'h', 'i']
    """
    hmax = quality_settings(quality)["hmax_fig3"]
    folder = os.path.join(os.fspath(data_dir), f"fig3-{quality}")
    _table(data_dir, "fig3", quality)  # checks the folder
    os.makedirs(folder, exist_ok=True)
    from tqdm.auto import tqdm

    out = []
    sheets = fig3_sheets()
    for panel, title, sheet, path in tqdm(sheets, desc="fig3 solves", disable=not progress):
        fn = _fig3_file(folder, sheet, path, hmax)
        if os.path.exists(fn):
            with np.load(fn, allow_pickle=False) as z:
                data = {k: z[k] for k in z.files}
            for k in ("deflection", "hmax"):
                data[k] = float(data[k])
            for k in ("converged", "snapped"):
                data[k] = bool(data[k])
            data["message"] = str(data["message"])
        else:
            data = _solve_surface(sheet, path, hmax)
            tmp = fn + ".tmp.npz"
            np.savez_compressed(tmp, **data)
            os.replace(tmp, fn)
        out.append((panel, title, sheet, path, data))
    return out


def _surface_limits(items):
    lo = np.min([d["X"].min(axis=0) for *_, d in items], axis=0)
    hi = np.max([d["X"].max(axis=0) for *_, d in items], axis=0)
    return lo, hi


def draw_fig3(items, quality: str = "paper"):
    """Draw Fig. 3 (d-i): shaded deformed sheets coloured by psi/mu, one colour scale.

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
    import matplotlib
    from matplotlib import cm, colors
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    from .plot import _shaded

    with matplotlib.rc_context(_STYLE):
        n = len(items)
        ncol = min(3, n)
        nrow = -(-n // ncol)
        fig = _new_figure(FULL_WIDTH, 2.45 * nrow + 0.3)
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
        for i, (panel, title, sheet, path, d) in enumerate(items):
            ax = fig.add_subplot(nrow, ncol, i + 1, projection="3d")
            faces = d["X"][d["tri"]]
            ax.add_collection3d(Poly3DCollection(
                faces, facecolors=_shaded(cmap(norm(np.maximum(d["psi"], 0.0))), faces),
                linewidths=0))
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
        from matplotlib.ticker import MaxNLocator

        ticks = [t for t in MaxNLocator(7).tick_values(0.0, vmax) if 0 <= t <= vmax]
        cb = fig.colorbar(cm.ScalarMappable(norm=norm, cmap=cmap), cax=cax, extend="max",
                          ticks=ticks)
        cb.ax.tick_params(labelsize=6)
        cax.set_ylabel(r"$\psi/\mu$ (square-root scale)")
        k = items[0][2]
        fig.text(0.45, 0.995, f"$a/R={_fmt(k.curvature)}$, $L/a={_fmt(k.length)}$, "
                              f"$h/a={_fmt(k.thickness)}$", ha="center", va="top", fontsize=8)
        _footnote(fig, quality, f"FE hmax={_fmt(items[0][4]['hmax'])}", top=True)
    return fig


def fig3(quality="quick", data_dir=DEFAULT_DATA_DIR, progress=True, workers=None):
    """Fig. 3 (d-i): simulated sheets at a/R = 2.5, L/a = 1.3 coloured by psi/mu.

    ``workers`` is accepted for a uniform signature; the six solves run in turn.

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> fig3("quick").savefig("fig3.png", dpi=200)  # doctest: +SKIP
    """
    return draw_fig3(fig3_data(quality, data_dir, progress), quality)


# -- Fig. 4 ------------------------------------------------------------------------------
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
    ...              message="", error="") for b in (0.0, 1.0) for k in (0.0, 2.5)]
    >>> fig = draw_fig4(pd.DataFrame(rows))
    >>> [ax.get_xlabel() for ax in fig.axes], fig.axes[0].child_axes[0].get_xlabel()
    (['', '$L/a$'], '$A/a^2$')
    """
    import matplotlib

    tips = sorted(set(df["tip_width"].astype(float)))
    cmap = matplotlib.colormaps["viridis"]

    def colour(b):
        return cmap(0.85 * b)

    with matplotlib.rc_context(_STYLE):
        fig = _new_figure(COLUMN_WIDTH, 5.6)
        main = fig.subplots(2, 1, sharex=True)
        n_failed, any_bistable, key = 0, False, {}
        for ax, k, lab in zip(main, (0.0, 2.5), ("(a)", "(b)")):
            sub = _rows(df, curvature=k)
            inset = ax.inset_axes([0.11, 0.55, 0.33, 0.33])
            for b in tips:
                for _, row in _rows(sub, tip_width=b).iterrows():
                    res = _draw_row(ax, row, colour(b), gap=0.1)
                    n_failed += not res["drawn"]
                    any_bistable |= res["bistable"]
                    if res["drawn"]:
                        key[f"$b/a={_fmt(b)}$"] = res["colour"]
                    with matplotlib.rc_context({"lines.linewidth": 0.7}):
                        _draw_row(inset, row, colour(b), x=lambda L, b=b: 0.5 * (1 + b) * L,
                                  markers=False, jumps=False)
            for a in (ax, inset):
                a.axhline(0.0, color="0.75", linewidth=0.5, zorder=0)
            inset.set_xlabel("$A/a^2$", fontsize=6, labelpad=1)
            inset.set_ylabel("$d/a$", fontsize=6, labelpad=1)
            inset.tick_params(labelsize=5.5, pad=1.5, length=2)
            ax.set_ylabel("$d/a$")
            _panel_label(ax, f"{lab} $a/R={_fmt(k)}$")
        # above the panels, where no curve can hide under them: the shapes (colours),
        # then the modes, the jumps and failures (both panels)
        top = _top_legends(fig, [(_colour_handles(key), 3),
                                 (_style_handles(jumps=any_bistable, n_failed=n_failed), 2)])
        main[-1].set_xlabel("$L/a$")
        fig.tight_layout(h_pad=0.4, rect=(0, 0, 1, top))
        _footnote(fig, quality, f"FE fold map hmax={_hmax_of(df)}")
    return fig


def fig4(quality="quick", data_dir=DEFAULT_DATA_DIR, progress=True, workers=None):
    """Fig. 4: d/a against L/a for b/a in {0, 0.2, ..., 1}, a/R = 0 and 2.5 (fold map).

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> fig4("quick").savefig("fig4.png", dpi=200)  # doctest: +SKIP
    """
    df = fold_map_table(fig4_points(quality), quality, data_dir, progress, workers)
    return draw_fig4(df, quality)


# -- Fig. 5 ------------------------------------------------------------------------------
_RIBBON_FIELDS = ("tip_width", "curvature", "direction", "length", "deflection", "converged",
                  "jumped")


def fig5_ribbon(quality="quick", data_dir=DEFAULT_DATA_DIR, progress=True):
    """Ribbon-model curves of Fig. 5, both continuation directions (cached CSV).

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
    import pandas as pd
    from tqdm.auto import tqdm

    from .params import Sheet
    from .reduced import ribbon_continuation

    s = quality_settings(quality)
    fn = os.path.join(os.path.dirname(_table(data_dir, "fig5", quality)),
                      f"fig5-{quality}-ribbon.csv")
    lengths = _arange(*s["lengths"], s["ribbon_step"])
    if os.path.exists(fn):
        df = pd.read_csv(fn)
        have = np.unique(df["length"].to_numpy(float)) if len(df) else np.empty(0)
        if len(df) == 4 * 2 * lengths.size and have.shape == lengths.shape \
                and np.allclose(have, lengths):
            return df
    rows = []
    cases = list(itertools.product((1.0, 0.0), (1.0, 2.5), ("increasing", "decreasing")))
    for b, k, direction in tqdm(cases, desc="fig5 ribbon model", disable=not progress):
        br = ribbon_continuation(Sheet(1.0, tip_width=b, curvature=k), lengths, direction)
        for L, d, c, j in zip(br.lengths, br.deflection, br.converged, br.jumped):
            rows.append({"tip_width": b, "curvature": k, "direction": direction,
                         "length": float(L), "deflection": float(d), "converged": bool(c),
                         "jumped": bool(j)})
    df = pd.DataFrame(rows, columns=list(_RIBBON_FIELDS))
    tmp = fn + ".tmp"
    df.to_csv(tmp, index=False)
    os.replace(tmp, fn)
    return df


def _ribbon_line(ax, sub, colour, linestyle, label):
    """A ribbon branch in continuation order, broken at its jumps; returns failures."""
    ok = _as_bool(sub["converged"])
    jumped = _as_bool(sub["jumped"])
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
    ...                         gravity_dominated=c, message="", error="")
    ...                    for b in (0.0, 1.0) for k in (1.0, 2.5)])
    >>> rom = pd.DataFrame([dict(length=L, tip_width=b, curvature=k, direction=dr,
    ...                          deflection=0.3 * L, converged=True, jumped=False)
    ...                     for L in (1.0, 2.0) for b in (0.0, 1.0) for k in (1.0, 2.5)
    ...                     for dr in ("increasing", "decreasing")])
    >>> fig = draw_fig5(fe, rom)
    >>> len(fig.axes), fig.axes[2].get_xlabel(), fig.axes[0].get_ylabel()
    (4, '$L/a$', '$d/a$')
    """
    import matplotlib

    fe_colour, rom_colour = "#1f4e9c", "#e07b00"
    with matplotlib.rc_context(_STYLE):
        fig = _new_figure(COLUMN_WIDTH, 3.9)
        axes = fig.subplots(2, 2, sharex=True, sharey=True)
        panels = [((0, 0), 1.0, 1.0, "(a)"), ((0, 1), 0.0, 1.0, "(b)"),
                  ((1, 0), 1.0, 2.5, "(c)"), ((1, 1), 0.0, 2.5, "(d)")]
        n_failed = n_rom_failed = 0
        any_bistable = False
        for (i, j), b, k, lab in panels:
            ax = axes[i, j]
            ax.axhline(0.0, color="0.75", linewidth=0.5, zorder=0)
            r = rom[np.isclose(rom["tip_width"].astype(float), b)
                    & np.isclose(rom["curvature"].astype(float), k)]
            for direction, ls in (("increasing", "--"), ("decreasing", ":")):
                n_rom_failed += _ribbon_line(ax, r[r["direction"] == direction], rom_colour,
                                             ls, None)
            for _, row in _rows(fe, curvature=k, tip_width=b).iterrows():
                with matplotlib.rc_context({"lines.markersize": 2.5}):
                    res = _draw_row(ax, row, fe_colour, gap=0.1)
                n_failed += not res["drawn"]
                any_bistable |= res["bistable"]
            shape = "rectangle" if b == 1.0 else "triangle"
            _panel_label(ax, f"{lab} {shape}\n$a/R={_fmt(k)}$")
            if i == 1:
                ax.set_xlabel("$L/a$")
            if j == 0:
                ax.set_ylabel("$d/a$")
        from matplotlib.lines import Line2D

        handles = _style_handles(colour=fe_colour, jumps=any_bistable, n_failed=n_failed)
        for h in handles[:2]:
            h.set_label("FE, " + h.get_label())
        handles += [Line2D([], [], color=rom_colour, linestyle=ls, label=f"ribbon, $L$ {d}")
                    for ls, d in (("--", "increasing"), (":", "decreasing"))]
        if n_rom_failed:
            handles.append(Line2D([], [], color="none",
                                  label=f"ribbon: {n_rom_failed} not converged, omitted"))
        top = _top_legends(fig, [(handles, 2)])
        fig.tight_layout(rect=(0, 0, 1, top), h_pad=0.3, w_pad=0.3)
        _footnote(fig, quality, f"FE fold map hmax={_hmax_of(fe)}")
    return fig


def fig5(quality="quick", data_dir=DEFAULT_DATA_DIR, progress=True, workers=None):
    """Fig. 5: finite elements against the ribbon model (rectangle, triangle; a/R = 1, 2.5).

    The finite-element curves are fold-map rows (fig2's); the ribbon curves
    are cached in ``data_dir/fig5-<quality>-ribbon.csv``.

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> fig5("quick").savefig("fig5.png", dpi=200)  # doctest: +SKIP
    """
    fe = fold_map_table(fig5_points(quality), quality, data_dir, progress, workers)
    rom = fig5_ribbon(quality, data_dir, progress)
    return draw_fig5(fe, rom, quality)


# -- Fig. 6 ------------------------------------------------------------------------------
_FIG6_CURVATURES = (2.5, 5.0)


def _fig6_ribbon_grid(quality):
    s = quality_settings(quality)
    lengths = _arange(*s["fig6_ribbon_lengths"])
    tips = np.round(np.linspace(0.0, 1.0, s["fig6_ribbon_tips"]), 6)
    return lengths, tips


def fig6_ribbon(quality="quick", data_dir=DEFAULT_DATA_DIR, progress=True, workers=None):
    """Ribbon-model map of Fig. 6 at a/R = 2.5 and 5 (cached ``fig6-<quality>-ribbon.csv``).

    Every shape factor of the grid is continued in L in both directions
    (:func:`skfem_sheet.reduced.maps.ribbon_map`); quick: 26 x 26 (L/a, b/a)
    per curvature, about a minute in all on 2 cores, once.

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
    import pandas as pd
    from tqdm.auto import tqdm

    from .reduced.maps import MAP_FIELDS, ribbon_map

    lengths, tips = _fig6_ribbon_grid(quality)
    fn = os.path.join(os.path.dirname(_table(data_dir, "fig6", quality)),
                      f"fig6-{quality}-ribbon.csv")
    want = {(c, b, L, dr) for c in _FIG6_CURVATURES for b in tips for L in lengths
            for dr in ("increasing", "decreasing")}
    if os.path.exists(fn):
        df = pd.read_csv(fn)
        have = {(round(c, 6), round(b, 6), round(L, 6), dr) for c, b, L, dr in
                df[["curvature", "tip_width", "length", "direction"]].itertuples(index=False)}
        if have == want and len(df) == len(want):
            return df
    n = workers if workers is not None else 1
    cases = [(c, tips[i:i + 2 * n]) for c in _FIG6_CURVATURES
             for i in range(0, tips.size, 2 * n)]
    rows = []
    with tqdm(total=2 * tips.size, desc="fig6 ribbon map", unit="shape",
              disable=not progress) as bar:
        for c, chunk in cases:
            rows += ribbon_map(c, lengths, chunk, workers=min(n, chunk.size))
            bar.update(chunk.size)
    df = pd.DataFrame(rows, columns=list(MAP_FIELDS))
    for col in ("curvature", "tip_width", "length"):
        df[col] = df[col].astype(float).round(6)
    tmp = fn + ".tmp"
    df.to_csv(tmp, index=False)
    os.replace(tmp, fn)
    return df


def _fold_lines(rows, critical):
    """The bistable region of one curvature's rows in the (b/a, L/a) plane.

    ``critical`` is this curvature's ``(estimate, low, high)`` from
    :func:`skfem_sheet.foldmap.critical_tip_width`.  Returns ``None`` (no
    bistable row) or a dict: ``b``, ``L0``, ``L1`` of the bistable rows from
    ``high`` up, ascending in b, and ``tip`` = ``(b*, L*)`` where the two
    meet (L0* and L1* of the two smallest bistable shape factors extrapolated
    linearly to b*), None if the map does not bracket b*.
    """
    est, lo, hi = critical
    if not np.isfinite(hi):
        return None
    ok = rows[np.array([_usable(r) for _, r in rows.iterrows()], dtype=bool)] \
        if len(rows) else rows
    ok = ok[_as_bool(ok["bistable"]) & (ok["tip_width"].astype(float) >= hi - 1e-9)]
    ok = ok.sort_values("tip_width")
    if not len(ok):
        return None
    b = ok["tip_width"].to_numpy(float)
    L0 = ok["popup_length"].to_numpy(float)
    L1 = ok["standout_length"].to_numpy(float)
    tip = None
    if np.isfinite(est):
        if b.size >= 2:
            s = (est - b[0]) / (b[1] - b[0])
            Lstar = 0.5 * (L0[0] + s * (L0[1] - L0[0]) + L1[0] + s * (L1[1] - L1[0]))
        else:
            Lstar = 0.5 * (L0[0] + L1[0])
        tip = (float(est), float(Lstar))
    return {"b": b, "L0": L0, "L1": L1, "tip": tip}


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


def _halo(width=1.6):
    from matplotlib import patheffects

    return [patheffects.withStroke(linewidth=width, foreground="white")]


def draw_fig6(fe, rom, quality: str = "paper", mode_lengths=None):
    """Draw Fig. 6: ribbon-model d/a over (L/a, b/a) at (a) a/R = 2.5 and (b) a/R = 5,
    with the FE modes and bistable region.

    Background colour: d/a of the ribbon model continued with increasing L
    (the curvature-dominated branch while it lasts); dashed black: its jumps;
    filled diamonds / open squares: a curvature- / gravity-dominated FE mode
    exists there (both: bistable; :func:`skfem_sheet.foldmap.modes`); solid
    black: the FE folds L0* (left) and L1* (right) of the bistable rows,
    closed where they meet at the critical shape factor (b/a)*.

    Parameters
    ----------
    fe : pandas.DataFrame
        Fold-map rows at a/R = 2.5 and 5.
    rom : pandas.DataFrame
        From :func:`fig6_ribbon`.
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
    ...                         gravity_dominated="[]", message="", error="")
    ...                    for b in (0.0, 0.5, 1.0) for k in (2.5, 5.0)])
    >>> rom = pd.DataFrame([dict(curvature=k, tip_width=b, length=L, direction=dr,
    ...                          deflection=L - 1, converged=True, stable=True, jumped=False)
    ...                     for k in (2.5, 5.0) for b in (0.0, 1.0) for L in (1.0, 2.0)
    ...                     for dr in ("increasing", "decreasing")])
    >>> fig = draw_fig6(fe, rom)
    >>> fig.axes[1].get_xlabel(), fig.axes[0].get_ylabel(), fig.axes[2].get_ylabel()
    ('$L/a$', '$b/a$', '$d/a$ (ribbon model)')
    """
    import matplotlib
    from matplotlib.lines import Line2D

    from .reduced.maps import jump_curve, map_grid

    fm = _foldmap()
    Lm = (_arange(0.6, 2.8, 0.1) if mode_lengths is None
          else np.asarray(mode_lengths, float))
    # marker sizes for the spacing of the L grid (the open square encloses the diamond)
    dL = float(np.min(np.diff(np.unique(Lm)))) if np.unique(Lm).size > 1 else 0.2
    msq, mdi = (4.6, 2.6) if dL >= 0.15 else (3.4, 2.0)
    crit = fm.critical_tip_width(fe) if len(fe) else {}
    records = {c: _rows(rom, curvature=c).to_dict("records") for c in _FIG6_CURVATURES}
    grids = {c: map_grid(r, "increasing") for c, r in records.items() if r}
    finite = [g[2][g[4]] for g in grids.values()]
    vals = np.concatenate(finite) if finite else np.array([0.0, 1.0])
    vmin, vmax = min(0.0, float(np.nanmin(vals))), float(np.nanmax(vals))
    cmap = matplotlib.colormaps["viridis"]
    n_failed = 0
    with matplotlib.rc_context(_STYLE):
        fig = _new_figure(COLUMN_WIDTH, 5.6)
        axes = fig.subplots(2, 1, sharex=True)
        im = None
        for ax, c, lab in zip(axes, _FIG6_CURVATURES, ("(a)", "(b)")):
            if c in grids:
                Ls, bs, D, _, ok = grids[c]
                im = ax.pcolormesh(Ls, bs, np.where(ok, D, np.nan), shading="nearest",
                                   cmap=cmap, vmin=vmin, vmax=vmax, rasterized=True)
                jb, jl = jump_curve(records[c], "increasing")
                (ln,) = ax.plot(jl, jb, color="black", linestyle="--", linewidth=1.1,
                                path_effects=_halo(2.4), zorder=4)
                ln.set_gid(f"ribbon-jump|k={_fmt(c)}")
                ax.set_xlim(Ls[0] - 0.5 * (Ls[1] - Ls[0]) if Ls.size > 1 else Ls[0],
                            Ls[-1] + 0.5 * (Ls[1] - Ls[0]) if Ls.size > 1 else Ls[-1])
                ax.set_ylim(-0.02, 1.02)
            rows = _rows(fe, curvature=c)
            cd_pts, gd_pts = [], []
            for _, row in rows.iterrows():
                if not _usable(row):
                    n_failed += 1
                    continue
                cd, gd = fm.modes(row, Lm)
                b = float(row["tip_width"])
                cd_pts += [(L, b) for L in Lm[cd]]
                gd_pts += [(L, b) for L in Lm[gd]]
            for pts, kw, gid in ((gd_pts, dict(marker="s", markersize=msq,
                                                markerfacecolor="none"), "fe-gravity"),
                                 (cd_pts, dict(marker="D", markersize=mdi,
                                               markerfacecolor="black"), "fe-curvature")):
                xy = np.array(pts, float).reshape(-1, 2)
                (ln,) = ax.plot(xy[:, 0], xy[:, 1], linestyle="none", markeredgecolor="black",
                                markeredgewidth=0.7, path_effects=_halo(1.5), **kw)
                ln.set_gid(f"{gid}|k={_fmt(c)}")
            lines = _fold_lines(rows, crit.get(float(c), (np.nan, np.nan, np.nan)))
            if lines is not None:
                L, b = _fold_polyline(lines)
                (ln,) = ax.plot(L, b, color="black", linewidth=1.3, path_effects=_halo(2.6))
                ln.set_gid(f"fe-folds|k={_fmt(c)}")
            ax.set_ylabel("$b/a$")
            ax.text(0.98, 0.04, f"{lab} $a/R={_fmt(c)}$", transform=ax.transAxes,
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
            from matplotlib import cm, colors

            im = cm.ScalarMappable(norm=colors.Normalize(vmin, vmax), cmap=cmap)
        fig.colorbar(im, cax=cax)
        cax.set_ylabel("$d/a$ (ribbon model)")
        cax.tick_params(labelsize=6)
        s = quality_settings(quality) if quality in _SETTINGS else {}
        _footnote(fig, quality, f"FE fold map hmax={_hmax_of(fe)}; ribbon map "
                                f"{len(set(rom['length'])) if len(rom) else 0} x "
                                f"{len(set(rom['tip_width'])) if len(rom) else 0}"
                                + (f", markers every {_fmt(s['fig6_lengths'][2])} in L/a"
                                   if s else ""))
    return fig


def fig6(quality="quick", data_dir=DEFAULT_DATA_DIR, progress=True, workers=None):
    """Fig. 6: ribbon-model map of d/a over (L/a, b/a) with the FE modes and bistable region.

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> fig6("quick").savefig("fig6.png", dpi=200)  # doctest: +SKIP
    """
    fe = fold_map_table(fig6_points(quality), quality, data_dir, progress, workers)
    rom = fig6_ribbon(quality, data_dir, progress, workers)
    return draw_fig6(fe, rom, quality,
                     mode_lengths=_arange(*quality_settings(quality)["fig6_lengths"]))


# -- Fig. 7 ------------------------------------------------------------------------------
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
    ...                         message="", error="")
    ...                    for b in (0.6, 0.8, 1.0) for k in (1.0, 2.0, 3.0)])
    >>> reg = bistable_region(df)
    >>> [round(c[1], 3) for c in reg["critical"]]  # a/R along the critical curve
    [1.0, 2.0, 3.0]
    >>> [len(reg["chains"][k]) for k in sorted(reg["chains"])]
    [1, 3, 3]
    """
    fm = _foldmap()
    ok = df[np.array([_usable(r) for _, r in df.iterrows()], dtype=bool)] if len(df) else df
    crit = fm.critical_tip_width(ok) if len(ok) else {}
    chains, critical, edge = {}, [], None
    for c, (est, lo, hi) in sorted(crit.items()):
        lines = _fold_lines(_rows(ok, curvature=c), (est, lo, hi))
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
    rect = _rows(ok, tip_width=1.0)
    if len(rect):
        ccrit = fm.critical_tip_width(_swap(rect)).get(1.0)
        if ccrit is not None and np.isfinite(ccrit[0]):
            lines = _fold_lines(_swap(rect), ccrit)
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


def _region_mesh(region):
    """Nodes ``(b, a/R, L0, L1)`` and triangles of the two fold surfaces."""
    nodes, idx = [], []
    for c, chain in region["chains"].items():
        idx.append(list(range(len(nodes), len(nodes) + len(chain))))
        nodes += [(b, c, l0, l1) for b, l0, l1 in chain]
    chains = list(region["chains"].values())
    tris = []
    for k in range(len(chains) - 1):
        tris += _zip_chains(chains[k], chains[k + 1], idx[k], idx[k + 1])
    return np.array(nodes, float).reshape(-1, 4), np.array(tris, int).reshape(-1, 3)


def draw_fig7(df, quality: str = "paper"):
    """Draw Fig. 7: the bistable region in (L/a, b/a, a/R), (a) in 3D and (b) its sections.

    (a) the standout lengths L1* (green, upper surface) and pop-up lengths
    L0* (blue, lower) over the (b/a, a/R) of the bistable rows, meeting on
    the critical curve (black) where L0* = L1*; rows that are not bistable
    are left out.  (b) the same folds against b/a, one closed curve per a/R
    (L1* solid, L0* dashed).

    Parameters
    ----------
    df : pandas.DataFrame
        Fold-map rows over a grid of (b/a, a/R).

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
    ...                         message="", error="")
    ...                    for b in (0.6, 0.8, 1.0) for k in (1.0, 2.0, 3.0)])
    >>> fig = draw_fig7(df)
    >>> ax = fig.axes[0]
    >>> ax.get_xlabel(), ax.get_ylabel(), ax.get_zlabel()
    ('$b/a$', '$a/R$', '$L/a$')
    """
    import matplotlib
    from matplotlib.tri import Triangulation

    region = bistable_region(df)
    nodes, tris = _region_mesh(region)
    green, blue = "#2ca02c", "#1f5fbf"
    n_failed = int(sum(not _usable(r) for _, r in df.iterrows()))
    with matplotlib.rc_context(_STYLE):
        fig = _new_figure(COLUMN_WIDTH, 5.9)
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
                             markersize=2, label=f"$a/R={_fmt(c)}$")
            l1.set_gid(f"L1|k={_fmt(c)}")
            (l0,) = ax2.plot(chain[:, 0], chain[:, 1], color=colour, linestyle="--",
                             marker="o", markersize=2, markerfacecolor="white")
            l0.set_gid(f"L0|k={_fmt(c)}")
        ax2.set_xlabel("$b/a$")
        ax2.set_ylabel("$L/a$")
        ax2.text(0.02, 0.96, "(b)", transform=ax2.transAxes, fontweight="bold", va="top")
        handles = ax2.get_legend_handles_labels()[0]
        if handles:
            ax2.legend(loc="center left", bbox_to_anchor=(1.01, 0.5), frameon=False,
                       handlelength=1.2)
        if n_failed:
            fig.text(0.5, 0.005, f"{n_failed} map points failed, omitted", ha="center",
                     va="bottom", fontsize=6)
        fig.suptitle("Bistable region (FE): standout $L_1^*$ (green, upper) and pop-up "
                     "$L_0^*$ (blue, lower)\nsurfaces meet on the critical curve "
                     "(black, $L_0^*=L_1^*$); (b) $L_1^*$ solid, $L_0^*$ dashed",
                     fontsize=7, y=0.995)
        _footnote(fig, quality, f"FE fold map hmax={_hmax_of(df)}")
    return fig


def fig7(quality="quick", data_dir=DEFAULT_DATA_DIR, progress=True, workers=None):
    """Fig. 7: the bistable region in (L/a, b/a, a/R) from the fold map.

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> fig7("quick").savefig("fig7.png", dpi=200)  # doctest: +SKIP
    """
    df = fold_map_table(fig7_points(quality), quality, data_dir, progress, workers)
    return draw_fig7(df, quality)


# -- registry and command line -----------------------------------------------------------
#: Figure name -> function ``(quality, data_dir, progress, workers) -> Figure``.
#: The CLI offers exactly these names.
FIGURES = {"fig2": fig2, "fig3": fig3, "fig4": fig4, "fig5": fig5, "fig6": fig6,
           "fig7": fig7}


def make_figure(name: str, quality: str = "quick", out=None, data_dir=DEFAULT_DATA_DIR,
                progress: bool = True, workers=None):
    """Compute (or read from the cache) and draw one figure; write it to ``out``.

    Parameters
    ----------
    name : str
        A key of :data:`FIGURES`.
    quality : {"quick", "paper"}
    out : str, optional
        PNG (or PDF/SVG) file to write, at 200 dpi.
    data_dir : str
        Folder of the cached tables (created if needed).
    progress : bool
        Progress bars on stderr.
    workers : int, optional
        Processes for the sweep (default: the sweep's own choice).

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> make_figure("fig9")
    Traceback (most recent call last):
    ...
    skfem_sheet.params.ParameterError: name must be one of fig2, ..., fig7, got 'fig9'
    """
    if name not in FIGURES:
        raise ParameterError(f"name must be one of {', '.join(FIGURES)}, got {name!r}")
    quality_settings(quality)
    if out is not None:
        from .io import check_writable

        check_writable("out", out, [".png", ".pdf", ".svg"])
    import matplotlib

    if out is not None:
        matplotlib.use("Agg", force=False)
    fig = FIGURES[name](quality=quality, data_dir=data_dir, progress=progress, workers=workers)
    if out is not None:
        fig.savefig(out, dpi=DPI, bbox_inches="tight", pad_inches=0.02)
    return fig


def _cmd_figure(args) -> int:
    from .io import check_writable

    out = args.out or f"{args.name}.png"
    check_writable("--out", out, [".png", ".pdf", ".svg"])
    if args.workers is not None and args.workers < 1:
        raise ParameterError(f"--workers must be in [1, inf), got {args.workers}")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig = make_figure(args.name, args.quality, out, args.data_dir, progress=not args.quiet,
                      workers=args.workers)
    plt.close(fig)
    print(f"{args.name} ({args.quality}): wrote {out} (data cached in {args.data_dir})")
    return 0


def add_figure_subparser(sub) -> None:
    """Register the ``figure`` command on an argparse subparsers object.

    Examples
    --------
    >>> import argparse
    >>> p = argparse.ArgumentParser(); sub = p.add_subparsers(dest="command")
    >>> add_figure_subparser(sub)
    >>> args = p.parse_args(["figure", "fig2", "--quality", "paper"])
    >>> args.name, args.quality, args.out, args.data_dir
    ('fig2', 'paper', None, 'skfem_sheet_data')
    """
    p = sub.add_parser("figure", help="draw one of the paper's figures",
                       description="Draw one of the paper's figures (data cached in --data-dir).")
    p.add_argument("name", choices=list(FIGURES), metavar="NAME",
                   help=f"one of {', '.join(FIGURES)}")
    p.add_argument("--quality", choices=QUALITIES, default="quick",
                   help="quick (fold map at hmax 0.1) or paper (hmax 0.03, finer grids)")
    p.add_argument("--out", default=None, help="output PNG (default NAME.png)")
    p.add_argument("--data-dir", default=DEFAULT_DATA_DIR,
                   help=f"folder of the cached tables (default ./{DEFAULT_DATA_DIR}/)")
    p.add_argument("--workers", type=int, default=None,
                   help="processes for the fold map (default: one per CPU)")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    p.set_defaults(func=_cmd_figure)
