"""Drawing shared by the figures: sizes, style, the two modes' lines, legends, footnotes.

:func:`draw_row` draws one fold-map row in the convention of fig2, fig4 and
fig5 (solid + filled markers: curvature-dominated; dashed + open:
gravity-dominated; both branches up to their folds, with jump arrows, where
the row is bistable).  Matplotlib is imported inside the functions that draw,
deliberately: the command line imports this package, and matplotlib's import
cost is then paid only when a figure is drawn (and after ``make_figure`` has
chosen the backend).
"""
from __future__ import annotations

import contextlib

import numpy as np

from .data import row_branches

__all__ = ["COLUMN_WIDTH", "FULL_WIDTH", "DPI", "STYLE", "CURVATURE_COLOURS", "MODE_STYLE",
           "MODE_LABEL", "new_figure", "styled_figure", "footnote", "mesh_footnote", "panel_label", "fmt", "thin", "segment",
           "jump", "draw_row", "tally", "style_handles", "top_legends", "colour_handles", "hmax_of",
           "halo"]

#: Column width of a two-column journal (inches), full width, output resolution.
COLUMN_WIDTH = 3.4
FULL_WIDTH = 7.0
DPI = 200

#: Matplotlib settings of every figure.
STYLE = {"font.size": 8, "axes.labelsize": 8, "axes.titlesize": 8, "legend.fontsize": 7,
         "xtick.labelsize": 7, "ytick.labelsize": 7, "lines.linewidth": 1.0,
         "lines.markersize": 3.5, "legend.handlelength": 1.8, "legend.borderaxespad": 0.3,
         "axes.linewidth": 0.6, "savefig.dpi": DPI}

#: Line colour of each clamp curvature a/R (fig2).
CURVATURE_COLOURS = {0.0: "#444444", 1.0: "#1f77b4", 2.5: "#d62728", 5.0: "#2ca02c"}
#: Line style of the two modes: solid + filled (curvature-dominated), dashed + open.
MODE_STYLE = {"curvature_dominated": dict(linestyle="-", filled=True, marker="o"),
              "gravity_dominated": dict(linestyle="--", filled=False, marker="o")}
MODE_LABEL = {"curvature_dominated": "curvature-dominated",
              "gravity_dominated": "gravity-dominated"}


def new_figure(width, height):
    """A new matplotlib figure of ``width`` x ``height`` inches."""
    import matplotlib.pyplot as plt  # deferred: import cost (and make_figure picks the backend)

    return plt.figure(figsize=(width, height))


@contextlib.contextmanager
def styled_figure(width, height):
    """``with styled_figure(width, height) as fig:`` a new figure drawn in :data:`STYLE`.

    The settings hold inside the block (where the figure is drawn), as in
    ``with matplotlib.rc_context(STYLE): fig = new_figure(width, height)``.
    """
    import matplotlib  # deferred: import cost (see the module docstring)

    with matplotlib.rc_context(STYLE):
        yield new_figure(width, height)


#: How well a mesh resolves the fold lengths (benchmarks/fold_convergence.py,
#: docs/verification.md): quoted in the footnotes of the figures showing L0*, L1*.
FOLD_ACCURACY = ("hmax 0.1 puts L0*, L1* 0.004-0.0065 long; "
                 "hmax <= 0.06 resolves them to +-0.005")


def footnote(fig, quality, text, top=False):
    """The grey "quick quality: ..." note in a corner of quick figures (none for paper)."""
    if quality == "quick":
        fig.text(0.995, 0.998 if top else 0.002, f"quick quality: {text}", ha="right",
                 va="top" if top else "bottom", fontsize=5.5, color="0.45")


def mesh_footnote(fig, quality, text):
    """The mesh in the lower right corner, at every quality (quick ones say so).

    Examples
    --------
    >>> import matplotlib
    >>> matplotlib.use("Agg")
    >>> fig = new_figure(2, 2)
    >>> mesh_footnote(fig, "paper", "FE hmax 0.03").get_text()
    'FE hmax 0.03'
    """
    prefix = "quick quality: " if quality == "quick" else ""
    return fig.text(0.995, 0.002, prefix + text, ha="right", va="bottom", fontsize=5.5,
                    color="0.45")


def panel_label(ax, text, loc=(0.02, 0.97)):
    """A bold panel label such as "(a) rectangles" in the axes' upper left corner."""
    ax.text(*loc, text, transform=ax.transAxes, ha="left", va="top", fontweight="bold")


def fmt(x):
    """A number as the figures print it (``%g``).

    Examples
    --------
    >>> fmt(2.50), fmt(1.0)
    ('2.5', '1')
    """
    return f"{x:g}"


def thin(L, gap):
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


def segment(ax, L, d, colour, mode, gid, x=None, markers=True, gap=0.06, label=None):
    """One piece of a branch in the style of its mode; returns the Line2D (or None)."""
    if len(L) == 0:
        return None
    st = MODE_STYLE[mode]
    xs = L if x is None else x(L)
    kw = {}
    if markers:
        kw = dict(marker=st["marker"], markevery=thin(L, gap), markeredgewidth=0.7,
                  markerfacecolor=colour if st["filled"] else "white",
                  markeredgecolor=colour)
    (line,) = ax.plot(xs, d, color=colour, linestyle=st["linestyle"], label=label, **kw)
    line.set_gid(gid)
    return line


def jump(ax, L, d_from, d_to, colour, gid):
    """A dotted arrow at ``L`` from ``d_from`` to ``d_to`` (the jump at a fold)."""
    ann = ax.annotate("", xy=(L, d_to), xytext=(L, d_from),
                      arrowprops=dict(arrowstyle="-|>", color=colour, lw=0.7,
                                      linestyle=(0, (1.2, 1.2)), shrinkA=0, shrinkB=1.5,
                                      mutation_scale=6))
    ann.set_gid(gid)
    return ann


def draw_row(ax, row, colour, *, x=None, markers=True, jumps=True, gap=0.06, label=None):
    """Draw one fold-map row (see the module docstring); returns what was drawn.

    Returns a dict: ``drawn`` (False for a failed row), ``bistable``,
    ``lines`` {mode: [Line2D]}.
    """
    br = row_branches(row)
    lines = {"curvature_dominated": [], "gravity_dominated": []}
    if not br["usable"]:
        return {"drawn": False, "bistable": False, "lines": lines, "colour": colour}
    tag = f"b={fmt(float(row['tip_width']))}|k={fmt(float(row['curvature']))}"
    (Lc, dc), (Lg, dg) = br["curvature_dominated"], br["gravity_dominated"]

    def seg(L, d, mode, lab):
        ln = segment(ax, L, d, colour, mode, f"{mode}|{tag}", x=x, markers=markers, gap=gap,
                     label=lab)
        if ln is not None:
            lines[mode].append(ln)
        return ln

    if br["bistable"]:
        seg(Lc, dc, "curvature_dominated", label)
        seg(Lg, dg, "gravity_dominated", None)
        if jumps and len(Lc) and len(Lg):
            # L1*: the curvature-dominated branch ends and the sheet drops; L0*: it pops up
            jump(ax, Lc[-1] if x is None else x(Lc[-1]), dc[-1], np.interp(Lc[-1], Lg, dg),
                 colour, f"jump-L1|{tag}")
            jump(ax, Lg[0] if x is None else x(Lg[0]), dg[0], np.interp(Lg[0], Lc, dc),
                 colour, f"jump-L0|{tag}")
        return {"drawn": True, "bistable": True, "lines": lines, "colour": colour}
    t = br["transition_length"]
    if not len(Lg):
        seg(Lc, dc, "curvature_dominated", label)
    elif not len(Lc) or t is None:
        seg(Lg, dg, "gravity_dominated", label)
    else:
        # t at the curvature-dominated branch's last point: its points are all
        # curvature-dominated (foldmap.transition_length), drawn whole
        whole = t >= Lc[-1]
        below = np.ones(len(Lc), bool) if whole else Lc < t
        above = np.zeros(len(Lg), bool) if whole else Lg >= t
        first = seg(Lc[below], dc[below], "curvature_dominated", label)
        # the dashed part starts where the solid one ends: one curve
        Lb, db = Lg[above], dg[above]
        if below.any() and above.any():
            Lb, db = np.r_[Lc[below][-1], Lb], np.r_[dc[below][-1], db]
        seg(Lb, db, "gravity_dominated", None if first is not None else label)
    return {"drawn": True, "bistable": False, "lines": lines, "colour": colour}


def tally(drawn):
    """What the rows drawn by :func:`draw_row` add up to, for the legends.

    ``drawn`` is a list of ``(label, result)``: a row's legend label (or None)
    and what :func:`draw_row` returned for it, in drawing order.  Returns
    ``(n_failed, any_bistable, key)``: the rows not drawn, whether any row
    was bistable, and ``{label: colour}`` of the labelled rows drawn (in order
    of first appearance, the last colour of a label).

    Examples
    --------
    >>> tally([("a", {"drawn": True, "bistable": False, "colour": "r"}),
    ...        ("b", {"drawn": False, "bistable": False, "colour": "g"}),
    ...        ("a", {"drawn": True, "bistable": True, "colour": "k"})])
    (1, True, {'a': 'k'})
    """
    n_failed = sum(not res["drawn"] for _, res in drawn)
    any_bistable = any(res["bistable"] for _, res in drawn)
    key = {}
    for label, res in drawn:
        if label is not None and res["drawn"]:
            key[label] = res["colour"]
    return n_failed, any_bistable, key


def style_handles(colour="0.3", jumps=True, n_failed=0):
    """Legend handles for the two modes, the jumps at the folds and failed map points."""
    from matplotlib.lines import Line2D  # deferred: import cost

    hs = []
    for mode in ("curvature_dominated", "gravity_dominated"):
        st = MODE_STYLE[mode]
        hs.append(Line2D([], [], color=colour, linestyle=st["linestyle"], marker=st["marker"],
                         markerfacecolor=colour if st["filled"] else "white",
                         markeredgecolor=colour, label=MODE_LABEL[mode]))
    if jumps:
        hs.append(Line2D([], [], color=colour, linestyle=(0, (1.2, 1.2)), marker="v",
                         markersize=3, label="jump at a fold ($L_1^*$, $L_0^*$)"))
    if n_failed:
        hs.append(Line2D([], [], color="none", linestyle="none",
                         label=f"{n_failed} map point{'s' if n_failed > 1 else ''} failed, "
                               "omitted"))
    return hs


def top_legends(fig, groups, row=0.16):
    """Legends stacked above the panels, ``groups = [(handles, ncol), ...]``, each filled
    row by row; returns the top of the room left for the panels (figure fraction)."""
    from matplotlib.lines import Line2D  # deferred: import cost

    y = 1.0
    for handles, ncol in groups:
        if not handles:
            continue
        nrow = -(-len(handles) // ncol)
        # a legend fills columns first: reorder so that it reads row by row
        pad = handles + [None] * (nrow * ncol - len(handles))
        order = [pad[r * ncol + c] for c in range(ncol) for r in range(nrow)]
        order = [Line2D([], [], color="none", label=" ") if h is None else h for h in order]
        fig.legend(handles=order, loc="upper center", ncol=ncol, frameon=False,
                   bbox_to_anchor=(0.5, y), columnspacing=1.0, borderaxespad=0.0)
        y -= (row * nrow + 0.03) / fig.get_figheight()
    return y - 0.03 / fig.get_figheight()


def colour_handles(key):
    """Legend handles ``{label: colour}`` (plain lines: the mode styles have their own key)."""
    from matplotlib.lines import Line2D  # deferred: import cost

    return [Line2D([], [], color=c, linewidth=1.6, label=lab) for lab, c in key.items()]


def hmax_of(df):
    """The mesh sizes of the rows, for a footnote (``"0.1"``, ``"0.03/0.1"`` or ``"?"``)."""
    hs = sorted({float(h) for h in df["hmax"]}) if "hmax" in df and len(df) else []
    return "/".join(fmt(h) for h in hs) or "?"


def halo(width=1.6):
    """A white outline (path effect) that keeps black lines readable on a colour map."""
    from matplotlib import patheffects  # deferred: import cost

    return [patheffects.withStroke(linewidth=width, foreground="white")]

