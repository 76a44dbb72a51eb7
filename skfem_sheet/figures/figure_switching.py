"""Switching: how hard the bistable rectangle is to switch, across its bistable window.

(a) The switching forces -- the push down ``F_down`` that snaps the aloft state and
the pull up ``F_up`` that snaps the drooped one, over the sheet's weight -- against
L/a for the rectangle at a/R 2.5 and 5, each vanishing linearly at its fold length
(the normal form; dotted: the lines through the two lengths nearest each fold,
extrapolated to zero); inset: the force-deflection curve of L/a 1.3 at a/R 2.5 (F
against d, stable solid, unstable dashed, the folds and the saddle marked).  (b) The
energy barriers ``Pi(saddle) - Pi(state)`` over ``W a`` (the work of lifting the
whole sheet by one base width), vanishing like ``(L* - L)^{3/2}`` at the fold of
their state.

Data: the window ``L0* < L < L1*`` from the fold map's rows of the rectangle (the
rows fig2 draws; :mod:`skfem_sheet.figures.data`), the switching analysis
(:func:`skfem_sheet.switch.switching`) at lengths spread across it, each cached
in ``data_dir/switching-<quality>/`` (one file per length: an interrupted run keeps
what it finished), and the inset's curve (at paper quality traced on hmax 0.03
itself).

Examples
--------
>>> switching_lengths(1.2, 1.4, 4).tolist()
[1.225, 1.275, 1.325, 1.375]
"""
from __future__ import annotations

import math
import os
import time

import numpy as np
import pandas as pd
from tqdm.auto import tqdm

from ..params import ParameterError, Sheet
from ..result import SolveError
from ..switch import switching
from .cache import data_folder, load_or_compute
from .common import DEFAULT_DATA_DIR, quality_settings
from .data import fold_map_table, map_grid_points, row_branches, select_rows
from .style import CURVATURE_COLOURS, FULL_WIDTH, fmt, mesh_footnote, panel_label, styled_figure
from .work import DataStep, note

__all__ = ["CURVATURES", "INSET", "LENGTHS_PER_WINDOW", "switching_points", "switching_lengths",
           "switching_table", "switching_curve", "draw_switching", "fig_switching"]

#: The clamp curvatures of the figure (the rectangle, b/a = 1).
CURVATURES = (2.5, 5.0)
#: The inset's sheet: ``(L/a, a/R)``.
INSET = (1.3, 2.5)
#: Lengths analysed across each bistable window, by quality.
LENGTHS_PER_WINDOW = {"quick": 5, "paper": 9}

#: The columns of the table (one row per analysed length).
COLUMNS = ("curvature", "length", "hmax", "bistable", "force_down", "force_up",
           "barrier_down", "barrier_up", "saddle_deflection", "fold_down_deflection",
           "fold_up_deflection", "aloft_deflection", "drooped_deflection", "weight", "shape",
           "factorizations", "wall_time_s", "error")


def switching_points(quality: str = "quick") -> list:
    """The fold-map points whose rows give the windows: the rectangle at :data:`CURVATURES`.

    Examples
    --------
    >>> sorted(p["curvature"] for p in switching_points())
    [2.5, 5.0]
    """
    return map_grid_points(quality, lambda c, b: c in CURVATURES and b == 1.0)


def switching_lengths(popup, standout, n):
    """``n`` lengths spread evenly inside the window ``(popup, standout)``
    (the middles of ``n`` equal parts), rounded to 6 decimals."""
    if not (np.isfinite(popup) and np.isfinite(standout) and popup < standout):
        return np.empty(0)
    return np.round(popup + (standout - popup) * (np.arange(n) + 0.5) / n, 6)


def _row(sheet, hmax):
    """One analysed length as a table row (a failure recorded, not raised)."""
    out = dict.fromkeys(COLUMNS, math.nan)
    out.update(curvature=sheet.curvature, length=sheet.length, hmax=hmax, bistable=False,
               shape="", error="")
    try:
        s = switching(sheet, hmax=hmax)
    except (SolveError, ParameterError) as err:
        out["error"] = f"{type(err).__name__}: {err}"
        return pd.DataFrame([out], columns=COLUMNS)
    for k in COLUMNS:
        if k not in ("curvature", "length", "hmax", "error"):
            out[k] = getattr(s, k)
    return pd.DataFrame([out], columns=COLUMNS)


def _windows(quality, data_dir, progress, workers, log):
    """``{a/R: (L0*, L1*)}`` from the fold map's rows (NaN where not bistable)."""
    rows = fold_map_table(switching_points(quality), quality, data_dir, progress=progress,
                          workers=workers, log=log)
    out = {}
    for c in CURVATURES:
        sel = select_rows(rows, curvature=c, tip_width=1.0)
        b = row_branches(sel.iloc[0]) if len(sel) else {"bistable": False}
        out[c] = ((b["popup_length"], b["standout_length"]) if b["bistable"]
                  else (math.nan, math.nan))
    return out


def switching_table(quality: str = "quick", data_dir=DEFAULT_DATA_DIR, progress=True,
                    workers=None, log=None):
    """The switching analysis across the windows: one row per length (:data:`COLUMNS`).

    The lengths are :func:`switching_lengths` of each row's window; each is
    analysed on the quality's mesh and cached in
    ``data_dir/switching-<quality>/`` (computed only where missing).
    ``log``: a list to append the step's
    :class:`~skfem_sheet.figures.work.DataStep` to (after the fold map's).

    Returns
    -------
    pandas.DataFrame
    """
    hmax = quality_settings(quality)["hmax"]
    windows = _windows(quality, data_dir, progress, workers, log)
    folder = data_folder(data_dir, f"switching-{quality}")
    jobs = [(c, float(L)) for c in CURVATURES
            for L in switching_lengths(*windows[c], LENGTHS_PER_WINDOW[quality])]
    t0 = time.perf_counter()
    frames, computed = [], []
    for c, L in tqdm(jobs, desc="switching", disable=not progress, leave=None):
        fn = os.path.join(folder, f"L{L:g}_k{c:g}_hmax{hmax:g}.csv")
        df, new = load_or_compute(fn, lambda c=c, L=L: _row(Sheet(length=L, curvature=c),
                                                                 hmax))
        df = df.copy()
        for k in ("shape", "error"):  # an empty text reads back as NaN
            df[k] = df[k].astype(object).where(df[k].notna(), "").astype(str)
        df["bistable"] = df["bistable"].astype(bool)
        frames.append(df)
        if new:
            computed.append(df.iloc[0])
    table = (pd.concat(frames, ignore_index=True) if frames
             else pd.DataFrame(columns=COLUMNS))
    table.attrs["windows"] = windows
    times = [(float(r["wall_time_s"]), f"L/a {fmt(r['length'])}, a/R {fmt(r['curvature'])}")
             for r in computed if np.isfinite(float(r["wall_time_s"]))]
    longest = max(times) if times else None
    note(log, DataStep("switching", computed=len(computed), cached=len(jobs) - len(computed),
                       solves=len(computed),
                       factorizations=int(sum(np.nan_to_num(float(r["factorizations"]))
                                              for r in computed)),
                       wall_time_s=time.perf_counter() - t0,
                       compute_s=float(sum(t for t, _ in times)) if times else math.nan,
                       longest=f"{longest[1]} ({longest[0]:.0f} s)" if longest else ""))
    return table


def switching_curve(quality: str = "quick", data_dir=DEFAULT_DATA_DIR, progress=True, log=None):
    """The inset's force-deflection curve (:data:`INSET`), traced on the
    quality's mesh itself, cached as CSV (the columns of
    :meth:`~skfem_sheet.switch.ForceCurve.to_csv`)."""
    hmax = quality_settings(quality)["hmax"]
    L, c = INSET
    fn = os.path.join(data_folder(data_dir, f"switching-{quality}"),
                      f"curve_L{L:g}_k{c:g}_hmax{hmax:g}.csv")
    t0 = time.perf_counter()

    def compute():
        s = switching(Sheet(length=L, curvature=c), hmax=hmax, curve_hmax=hmax,
                      progress=progress)
        from io import StringIO

        df = pd.read_csv(StringIO(s.curve.to_csv()))
        df["factorizations"] = s.curve.factorizations
        df["wall_time_s"] = s.curve.wall_time_s
        return df

    df, computed = load_or_compute(fn, compute)
    note(log, DataStep("switching curve", computed=int(computed), cached=int(not computed),
                       solves=int(computed),
                       factorizations=int(df["factorizations"].iloc[0]) if computed else 0,
                       wall_time_s=time.perf_counter() - t0,
                       compute_s=float(df["wall_time_s"].iloc[0]) if computed else math.nan,
                       longest=f"the inset's curve ({df['wall_time_s'].iloc[0]:.0f} s)"
                       if computed else ""))
    return df


def _normal_form_line(ax, L, y, end, colour):
    """The line through the two points nearest the fold ``end``, extrapolated to
    zero (dotted); returns the extrapolated zero (NaN if not drawn)."""
    ok = np.isfinite(y)
    L, y = np.asarray(L)[ok], np.asarray(y)[ok]
    if len(L) < 2:
        return math.nan
    i = np.argsort(np.abs(L - end))[:2]
    (La, Lb), (ya, yb) = L[i], y[i]
    if La == Lb or ya == yb:
        return math.nan
    zero = La - ya * (Lb - La) / (yb - ya)
    near = La if abs(La - zero) < abs(Lb - zero) else Lb
    ax.plot([near, zero], [ya if near == La else yb, 0.0], ":", color=colour, linewidth=0.9)
    return float(zero)


def draw_switching(table, curve=None, quality: str = "paper"):
    """Draw the figure from the table of :func:`switching_table` (and the inset's curve).

    Examples
    --------
    >>> import matplotlib
    >>> matplotlib.use("Agg")
    >>> t = pd.DataFrame({"curvature": [2.5] * 3, "length": [1.22, 1.27, 1.32],
    ...                   "hmax": [0.1] * 3, "bistable": [True] * 3,
    ...                   "force_down": [-0.004, -0.0025, -0.0008], "force_up": [0.0006, 0.002, 0.003],
    ...                   "barrier_down": [4e-4, 2e-4, 2e-5], "barrier_up": [2e-5, 3e-4, 8e-4],
    ...                   "weight": [0.0366, 0.0381, 0.0396]})
    >>> fig = draw_switching(t, quality="quick")
    >>> [ax.get_ylabel()[:9] for ax in fig.axes[:2]]
    ['$F^*/W$ (', 'barrier /']
    """
    with styled_figure(FULL_WIDTH, 2.7) as fig:
        ax_f, ax_b = fig.subplots(1, 2)
        for c in CURVATURES:
            rows = table[np.isclose(table["curvature"].astype(float), c)]
            rows = rows[rows["bistable"].astype(bool)].sort_values("length")
            if not len(rows):
                continue
            colour = CURVATURE_COLOURS.get(c, "k")
            L = rows["length"].to_numpy(float)
            W = rows["weight"].to_numpy(float)
            up = rows["force_up"].to_numpy(float) / W
            down = rows["force_down"].to_numpy(float) / W
            ax_f.plot(L, up, "-o", color=colour, markersize=3, gid=f"force_up|k={c:g}",
                      label=f"a/R = {fmt(c)}")
            ax_f.plot(L, down, "--o", color=colour, markersize=3, markerfacecolor="white",
                      gid=f"force_down|k={c:g}")
            windows = table.attrs.get("windows", {})
            L0, L1 = windows.get(c, (L.min(), L.max()))
            _normal_form_line(ax_f, L, up, L0, colour)
            _normal_form_line(ax_f, L, down, L1, colour)
            bu = rows["barrier_up"].to_numpy(float) / W
            bd = rows["barrier_down"].to_numpy(float) / W
            ax_b.semilogy(L, bu, "-o", color=colour, markersize=3, gid=f"barrier_up|k={c:g}")
            ax_b.semilogy(L, bd, "--o", color=colour, markersize=3, markerfacecolor="white",
                          gid=f"barrier_down|k={c:g}")
        ax_f.axhline(0.0, color="0.6", linewidth=0.6)
        ax_f.set_xlabel("$L/a$")
        ax_f.set_ylabel("$F^*/W$ (pull up > 0, push down < 0)")
        ax_b.set_xlabel("$L/a$")
        ax_b.set_ylabel("barrier / $(W a)$")
        panel_label(ax_f, "(a) switching force")
        panel_label(ax_b, "(b) energy barrier", loc=(0.02, 0.97))
        from matplotlib.lines import Line2D  # deferred: import cost

        handles = [Line2D([], [], color="0.3", marker="o", markersize=3,
                          label="drooped state (pull up)"),
                   Line2D([], [], color="0.3", linestyle="--", marker="o", markersize=3,
                          markerfacecolor="white", label="aloft state (push down)")]
        handles += [Line2D([], [], color=CURVATURE_COLOURS.get(c, "k"), label=f"a/R = {fmt(c)}")
                    for c in CURVATURES]
        ax_b.legend(handles=handles, loc="lower center", frameon=False)
        if curve is not None and len(curve):
            _draw_inset(ax_f, curve, _gap(ax_f, table))
        hs = sorted({float(h) for h in table["hmax"]}) if len(table) else []
        mesh_footnote(fig, quality, "FE hmax " + ("/".join(fmt(h) for h in hs) or "?")
                      + "; dotted: the normal form's lines to the folds")
        fig.tight_layout(pad=0.4)
    return fig


def _gap(ax, table):
    """``(x0, width)`` in axes fraction of the widest stretch of L between the
    windows' points (where the inset goes), or the right half if none."""
    L = np.sort(table.loc[table["bistable"].astype(bool), "length"].to_numpy(float))
    lo, hi = ax.get_xlim()
    edges = np.concatenate([[lo], L, [hi]])
    i = int(np.argmax(np.diff(edges)))
    a, b = (edges[i] - lo) / (hi - lo), (edges[i + 1] - lo) / (hi - lo)
    if b - a < 0.25:
        return 0.55, 0.42
    pad = 0.06 * (b - a) + 0.03
    return a + pad, min(0.45, b - a - 2 * pad)


def _draw_inset(ax, curve, where=(0.55, 0.42)):
    """The force-deflection curve of :data:`INSET` in ``ax``, low in it at
    ``where = (x0, width)`` (axes fraction)."""
    ins = ax.inset_axes([where[0], 0.14, where[1], 0.42])
    F = curve["force"].to_numpy(float)
    d = curve["deflection"].to_numpy(float)
    k = curve["negative_eigenvalues"].to_numpy(float)
    kind = curve["kind"].astype(str).to_numpy()
    sheet = Sheet(length=INSET[0], curvature=INSET[1])
    W = sheet.area * sheet.thickness
    stable = (k == 0) | (kind == "fold")
    unstable = (k > 0) | (kind == "fold")
    for mask, style in ((stable, "-"), (unstable, "--")):
        y = np.where(mask, F / W, np.nan)
        ins.plot(d, y, style, color=CURVATURE_COLOURS.get(INSET[1], "k"), linewidth=1.0)
    for name, marker in (("fold", "x"), ("saddle", "o")):
        sel = kind == name
        ins.plot(d[sel], F[sel] / W, marker, color="k", markersize=3,
                 markerfacecolor="white" if name == "saddle" else None)
    ins.axhline(0.0, color="0.6", linewidth=0.5)
    ins.set_xlabel("$d/a$", fontsize=6, labelpad=1)
    ins.set_ylabel("$F/W$", fontsize=6, labelpad=1)
    ins.tick_params(labelsize=5.5, pad=1)
    ins.text(0.97, 0.06, f"L/a {fmt(INSET[0])}, a/R {fmt(INSET[1])}", transform=ins.transAxes,
             ha="right", va="bottom", fontsize=6)


def fig_switching(quality: str = "quick", data_dir=DEFAULT_DATA_DIR, progress=True, workers=None,
                  log=None):
    """The switching figure: compute or read its tables, then draw it."""
    table = switching_table(quality, data_dir, progress, workers, log)
    curve = switching_curve(quality, data_dir, progress, log)
    return draw_switching(table, curve, quality)
