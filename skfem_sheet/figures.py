"""The paper's figures, one command each: ``python -m skfem_sheet figure NAME``.

====  ==================================================================  ====================
name  what it shows (paper caption)                                       data
====  ==================================================================  ====================
fig2  d/a against L/a, rectangles (a) and triangles (b),                 FE sweep table
      a/R in {0, 1, 2.5, 5}; both load paths where bistable
fig3  deformed sheets coloured by psi/mu at a/R = 2.5, L/a = 1.3:         six full FE solves
      rectangle (both modes), triangle, trapezoids b/a = 0.8, 0.6, 0.4
fig4  d/a against L/a for b/a in {0, 0.2, ..., 1} at a/R = 0 (a) and      FE sweep table
      2.5 (b); insets against the area A/a^2
fig5  finite elements against the ribbon model, rectangle and triangle,  fig2's table + ribbon
      a/R = 1 and 2.5
====  ==================================================================  ====================

``quality="quick"`` uses coarse meshes (hmax 0.1, 0.08 for fig3) and a few
lengths per curve (minutes on 2 cores); ``"paper"`` uses the paper's mesh
(hmax 0.03) and length grids with step 0.05.  Quick figures carry a footnote
saying so.

Caching: every finite-element point goes through :func:`skfem_sheet.sweep.run_sweep`
with one table per figure and quality in ``data_dir`` (``fig2-quick.csv``, ...);
points already in a table are not recomputed, so drawing twice computes nothing
twice.  fig5's finite-element curves are fig2's points: it reads (and, if
needed, completes) fig2's table.  fig3 stores the deformed top surfaces in
``fig3-<quality>/*.npz``, fig5 the ribbon curves in ``fig5-<quality>-ribbon.csv``.

Failed points are never dropped silently: a point whose solve did not reach
full load is left out of its curve and counted in the legend ("n not
converged, omitted"); a solve that snapped to the other branch at the end of
its own is drawn where it landed, with a cross.

Adding a figure: :data:`FIGURES` maps a name to a function
``(quality, data_dir, progress, workers) -> matplotlib Figure``; the CLI's
choices are its keys.

Examples
--------
>>> {"fig2", "fig3", "fig4", "fig5"} <= set(FIGURES)
True
>>> quality_settings("quick")["hmax"]
0.1
"""
from __future__ import annotations

import importlib
import itertools
import os

import numpy as np

from .params import ParameterError

__all__ = ["FIGURES", "QUALITIES", "DEFAULT_DATA_DIR", "quality_settings", "make_figure",
           "fig2", "fig3", "fig4", "fig5", "fig2_points", "fig4_points", "fig5_points",
           "draw_fig2", "draw_fig3", "draw_fig4", "draw_fig5", "fig3_sheets", "fig3_data",
           "fig5_ribbon",
           "add_figure_subparser"]

QUALITIES = ("quick", "paper")
DEFAULT_DATA_DIR = "skfem_sheet_data"
PATHS = ("curvature-first", "gravity-first")

#: Column width of a two-column journal (inches), full width, output resolution.
COLUMN_WIDTH = 3.4
FULL_WIDTH = 7.0
DPI = 200

_STYLE = {"font.size": 8, "axes.labelsize": 8, "axes.titlesize": 8, "legend.fontsize": 7,
          "xtick.labelsize": 7, "ytick.labelsize": 7, "lines.linewidth": 1.0,
          "lines.markersize": 3.5, "legend.handlelength": 1.8, "legend.borderaxespad": 0.3,
          "axes.linewidth": 0.6, "savefig.dpi": DPI}

_PAPER_LENGTHS = tuple(np.round(np.arange(0.5, 2.8 + 1e-9, 0.05), 6).tolist())

_SETTINGS = {
    "quick": {
        "hmax": 0.1, "hmax_fig3": 0.08,
        # a few lengths per curve, denser where the branches of a/R = 2.5 and 5 part
        # (both branches of the rectangle at a/R = 2.5, L/a = 1.3 exist at hmax 0.1)
        "lengths": (0.6, 0.9, 1.2, 1.3, 1.5, 1.8, 2.2, 2.6),
        "fig4_lengths": (0.6, 0.9, 1.2, 1.3, 1.6, 2.2),
        # gravity-first (the second branch) only where bistability is possible:
        # triangles are not bistable (paper Fig. 2b), tapered sheets only for
        # b/a >~ 0.6 (paper Fig. 7); "paper" runs both paths everywhere.
        "fig2_triangle_paths": ("curvature-first",),
        "fig4_min_bistable_tip": 0.6,
        "ribbon_step": 0.05,
    },
    "paper": {
        "hmax": 0.03, "hmax_fig3": 0.03,
        "lengths": _PAPER_LENGTHS,
        "fig4_lengths": _PAPER_LENGTHS,
        "fig2_triangle_paths": PATHS,
        "fig4_min_bistable_tip": 0.0,
        "ribbon_step": 0.01,
    },
}

_CURVATURE_COLOURS = {0.0: "#444444", 1.0: "#1f77b4", 2.5: "#d62728", 5.0: "#2ca02c"}
_PATH_STYLE = {"curvature-first": dict(marker="o", linestyle="-", filled=True),
               "gravity-first": dict(marker="s", linestyle="--", filled=False)}


def quality_settings(quality: str) -> dict:
    """Mesh size and grids of a quality level (``"quick"`` or ``"paper"``).

    Examples
    --------
    >>> quality_settings("paper")["hmax"]
    0.03
    >>> quality_settings("draft")
    Traceback (most recent call last):
    ...
    skfem_sheet.params.ParameterError: quality must be one of quick, paper, got 'draft'
    """
    if quality not in _SETTINGS:
        raise ParameterError(f"quality must be one of {', '.join(QUALITIES)}, got {quality!r}")
    return dict(_SETTINGS[quality])


# -- data --------------------------------------------------------------------------------
def _sweep():
    """The sweep module (looked up at call time so tests can substitute it)."""
    return importlib.import_module("skfem_sheet.sweep")


def _grid(**axes):
    return _sweep().grid(**axes)


def fig2_points(quality: str = "quick") -> list:
    """Sweep points of Fig. 2: rectangles and triangles, a/R in {0, 1, 2.5, 5}.

    At a/R = 0 both load paths are the same problem, so only curvature-first is
    run there.

    Examples
    --------
    >>> pts = fig2_points("quick")
    >>> len(pts), pts[0]["hmax"], sorted({p["curvature"] for p in pts})
    (88, 0.1, [0.0, 1.0, 2.5, 5.0])
    """
    s = quality_settings(quality)
    L, h = list(s["lengths"]), s["hmax"]
    return (_grid(length=L, tip_width=[1.0, 0.0], curvature=[0.0], path=["curvature-first"],
                  hmax=h)
            + _grid(length=L, tip_width=[1.0], curvature=[1.0, 2.5, 5.0], path=list(PATHS),
                    hmax=h)
            + _grid(length=L, tip_width=[0.0], curvature=[1.0, 2.5, 5.0],
                    path=list(s["fig2_triangle_paths"]), hmax=h))


def fig4_points(quality: str = "quick") -> list:
    """Sweep points of Fig. 4: b/a in {0, 0.2, ..., 1} at a/R = 0 and 2.5.

    Examples
    --------
    >>> pts = fig4_points("quick")
    >>> len(pts), sorted({p["tip_width"] for p in pts if p["path"] == "gravity-first"})
    (90, [0.6, 0.8, 1.0])
    """
    s = quality_settings(quality)
    L, h = list(s["fig4_lengths"]), s["hmax"]
    tips = [0.0, 0.2, 0.4, 0.6, 0.8, 1.0]
    both = [b for b in tips if b >= s["fig4_min_bistable_tip"]]
    single = [b for b in tips if b < s["fig4_min_bistable_tip"]]
    pts = (_grid(length=L, tip_width=tips, curvature=[0.0], path=["curvature-first"], hmax=h)
           + _grid(length=L, tip_width=both, curvature=[2.5], path=list(PATHS), hmax=h))
    if single:
        pts += _grid(length=L, tip_width=single, curvature=[2.5], path=["curvature-first"],
                     hmax=h)
    return pts


def fig5_points(quality: str = "quick") -> list:
    """Finite-element points of Fig. 5: fig2's points at a/R = 1 and 2.5.

    Examples
    --------
    >>> all(p in fig2_points("paper") for p in fig5_points("paper"))
    True
    """
    return [p for p in fig2_points(quality) if p["curvature"] in (1.0, 2.5)]


def _table(data_dir, name: str, quality: str) -> str:
    data_dir = os.fspath(data_dir)
    try:
        os.makedirs(data_dir, exist_ok=True)
    except OSError as err:
        raise ParameterError(f"data_dir must be a writable folder, got {data_dir!r} ({err})") \
            from None
    return os.path.join(data_dir, f"{name}-{quality}.csv")


def _key(length, tip_width, curvature, path, hmax):
    return (round(float(length), 9), round(float(tip_width), 9), round(float(curvature), 9),
            str(path), round(float(hmax), 9))


def _as_bool(values):
    """Booleans from a column that may hold bools, 0/1, NA or the strings True/False."""
    import pandas as pd

    out = []
    for v in values:
        if isinstance(v, str):
            out.append(v.strip().lower() in ("true", "1", "yes"))
        elif v is None or pd.isna(v):  # unknown (e.g. snapped of a failed solve)
            out.append(False)
        else:
            out.append(bool(v))
    return np.array(out, dtype=bool)


def _select(df, points):
    """Rows of ``df`` that are ``points`` (the table may hold more), one per point."""
    import pandas as pd

    wanted = {_key(p["length"], p["tip_width"], p["curvature"], p["path"], p["hmax"])
              for p in points}
    if len(df) == 0:
        return df
    keys = [_key(*r) for r in df[["length", "tip_width", "curvature", "path", "hmax"]]
            .itertuples(index=False, name=None)]
    mask = np.array([k in wanted for k in keys], dtype=bool)
    out = df.loc[mask].copy()
    out["_key"] = [k for k, m in zip(keys, mask) if m]
    out = out.drop_duplicates("_key", keep="last").drop(columns="_key")
    return pd.DataFrame(out).reset_index(drop=True)


def _sweep_table(points, table, progress, workers):
    df = _sweep().run_sweep(points, table=table, workers=workers, progress=progress)
    return _select(df, points)


# -- drawing helpers ---------------------------------------------------------------------
def _new_figure(width, height):
    import matplotlib.pyplot as plt

    return plt.figure(figsize=(width, height))


def _footnote(fig, quality, text, top=False):
    if quality == "quick":
        fig.text(0.995, 0.998 if top else 0.002, f"quick quality: {text}", ha="right",
                 va="top" if top else "bottom", fontsize=5.5, color="0.45")


def _curve(ax, sub, colour, path, label=None, x="length"):
    """One sweep curve: converged points joined in x order; returns (n failed, n snapped)."""
    st = _PATH_STYLE[path]
    sub = sub.sort_values(x)
    ok = _as_bool(sub["converged"])
    snapped = _as_bool(sub["snapped"]) if "snapped" in sub else np.zeros(len(sub), bool)
    xs = sub[x].to_numpy(float)
    ds = sub["deflection"].to_numpy(float)
    ax.plot(xs[ok], ds[ok], color=colour, linestyle=st["linestyle"], marker=st["marker"],
            markerfacecolor=colour if st["filled"] else "none", markeredgecolor=colour,
            markeredgewidth=0.8, label=label)
    sel = ok & snapped
    if sel.any():
        import matplotlib

        size = 1.4 * float(matplotlib.rcParams["lines.markersize"])
        ax.plot(xs[sel], ds[sel], linestyle="none", marker="x", color="black",
                markersize=size, markeredgewidth=0.25 * size, zorder=5)
    return int((~ok).sum()), int(sel.sum())


def _marker_handles(paths=PATHS, n_failed=0, n_snapped=0, colour="0.3"):
    """Legend handles for the load-path markers, snaps and omitted points."""
    from matplotlib.lines import Line2D

    hs = []
    for p in paths:
        st = _PATH_STYLE[p]
        hs.append(Line2D([], [], color=colour, linestyle=st["linestyle"], marker=st["marker"],
                         markerfacecolor=colour if st["filled"] else "none",
                         markeredgecolor=colour, label=p))
    if n_snapped:
        hs.append(Line2D([], [], color="black", linestyle="none", marker="x", markersize=5,
                         label=f"snapped ({n_snapped})"))
    if n_failed:
        hs.append(Line2D([], [], color="none", linestyle="none",
                         label=f"{n_failed} not converged, omitted"))
    return hs


def _panel_label(ax, text, loc=(0.02, 0.97)):
    ax.text(*loc, text, transform=ax.transAxes, ha="left", va="top", fontweight="bold")


def _fmt(x):
    return f"{x:g}"


# -- Fig. 2 ------------------------------------------------------------------------------
def draw_fig2(df, quality: str = "paper", hmax=None):
    """Draw Fig. 2 from a sweep table: d/a against L/a, (a) rectangles, (b) triangles.

    Parameters
    ----------
    df : pandas.DataFrame
        Sweep rows (columns length, tip_width, curvature, path, deflection,
        converged, snapped).
    quality : str
        ``"quick"`` adds a footnote saying so.
    hmax : float, optional
        Mesh size, for the footnote.

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> import pandas as pd
    >>> rows = [dict(length=L, tip_width=b, curvature=0.0, path="curvature-first",
    ...              deflection=0.4 * L, converged=True, snapped=False)
    ...         for L in (1.0, 2.0) for b in (0.0, 1.0)]
    >>> fig = draw_fig2(pd.DataFrame(rows))
    >>> fig.axes[1].get_xlabel(), fig.axes[0].get_ylabel()
    ('$L/a$', '$d/a$')
    """
    import matplotlib

    with matplotlib.rc_context(_STYLE):
        fig = _new_figure(COLUMN_WIDTH, 4.6)
        axes = fig.subplots(2, 1, sharex=True)
        counts, paths_all = {}, set()
        for ax, tip, name, lab in zip(axes, (1.0, 0.0), ("rectangles", "triangles"),
                                      ("(a)", "(b)")):
            sub = df[np.isclose(df["tip_width"].astype(float), tip)]
            n_failed = n_snapped = 0
            paths_seen = []
            for k in sorted(set(sub["curvature"].astype(float))):
                colour = _CURVATURE_COLOURS.get(k, None)
                first = True
                for path in PATHS:
                    cur = sub[np.isclose(sub["curvature"].astype(float), k)
                              & (sub["path"] == path)]
                    if len(cur) == 0:
                        continue
                    paths_seen.append(path)
                    f, s = _curve(ax, cur, colour, path,
                                  label=f"$a/R={_fmt(k)}$" if first else None)
                    first = False
                    n_failed += f
                    n_snapped += s
            ax.axhline(0.0, color="0.75", linewidth=0.5, zorder=0)
            ax.set_ylabel("$d/a$")
            _panel_label(ax, f"{lab} {name} ($b/a={_fmt(tip)}$)")
            counts[lab] = (n_failed, n_snapped)
            paths_all.update(paths_seen)
        # colours and markers are shared by both panels: the a/R key in the first
        # panel with curves, the load paths, snaps and omitted points in (b)
        for ax in axes:
            if any(not ln.get_label().startswith("_") for ln in ax.get_lines()):
                ax.legend(loc="upper left", bbox_to_anchor=(0.0, 0.9), frameon=False)
                break
        handles = _marker_handles([p for p in PATHS if p in paths_all])
        for lab, (n_failed, n_snapped) in counts.items():
            if n_snapped:
                handles += _marker_handles([], 0, n_snapped)
                handles[-1].set_label(f"{lab} snapped ({n_snapped})")
            if n_failed:
                handles += _marker_handles([], n_failed, 0)
                handles[-1].set_label(f"{lab} {n_failed} not converged, omitted")
        axes[-1].set_xlabel("$L/a$")
        top = 1.0
        if handles:  # above the panels, where no curve can hide under it
            fig.legend(handles=handles, loc="upper center", ncol=2, frameon=False,
                       bbox_to_anchor=(0.5, 1.0), columnspacing=1.0)
            top = 1.0 - (0.16 * ((len(handles) + 1) // 2) + 0.05) / fig.get_figheight()
        fig.tight_layout(h_pad=0.4, rect=(0, 0, 1, top))
        _footnote(fig, quality, f"FE hmax={_fmt(hmax) if hmax else '?'}, few lengths")
    return fig


def fig2(quality="quick", data_dir=DEFAULT_DATA_DIR, progress=True, workers=None):
    """Fig. 2: tip deflection d/a against L/a from simulations (rectangles, triangles).

    Computes (or reads from ``data_dir/fig2-<quality>.csv``) the sweep and draws it.

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> fig = fig2("quick", data_dir="skfem_sheet_data")  # doctest: +SKIP
    >>> fig.savefig("fig2.png", dpi=200)  # doctest: +SKIP
    """
    pts = fig2_points(quality)
    df = _sweep_table(pts, _table(data_dir, "fig2", quality), progress, workers)
    return draw_fig2(df, quality, hmax=quality_settings(quality)["hmax"])


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
def draw_fig4(df, quality: str = "paper", hmax=None):
    """Draw Fig. 4: d/a against L/a for several b/a at a/R = 0 (a) and 2.5 (b),
    insets against the plan area A/a^2 = (1 + b/a) L/(2a).

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> import pandas as pd
    >>> rows = [dict(length=L, tip_width=b, curvature=k, path="curvature-first",
    ...              deflection=0.4 * L * (1 + b), converged=True, snapped=False)
    ...         for L in (1.0, 2.0) for b in (0.0, 1.0) for k in (0.0, 2.5)]
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
        fig = _new_figure(COLUMN_WIDTH, 5.0)
        main = fig.subplots(2, 1, sharex=True)
        n_failed_all = n_snapped_all = 0
        paths_all = set()
        for ax, k, lab in zip(main, (0.0, 2.5), ("(a)", "(b)")):
            sub = df[np.isclose(df["curvature"].astype(float), k)].copy()
            sub["area"] = (0.5 * (1.0 + sub["tip_width"].astype(float))
                           * sub["length"].astype(float))
            inset = ax.inset_axes([0.11, 0.55, 0.33, 0.33])
            n_failed = n_snapped = 0
            paths_seen = set()
            for b in tips:
                cur_b = sub[np.isclose(sub["tip_width"].astype(float), b)]
                first = True
                for path in PATHS:
                    cur = cur_b[cur_b["path"] == path]
                    if len(cur) == 0:
                        continue
                    paths_seen.add(path)
                    f, s = _curve(ax, cur, colour(b), path,
                                  label=f"$b/a={_fmt(b)}$" if first else None)
                    first = False
                    n_failed += f
                    n_snapped += s
                    with matplotlib.rc_context({"lines.markersize": 2.0,
                                                "lines.linewidth": 0.7}):
                        _curve(inset, cur, colour(b), path, x="area")
            for a in (ax, inset):
                a.axhline(0.0, color="0.75", linewidth=0.5, zorder=0)
            inset.set_xlabel("$A/a^2$", fontsize=6, labelpad=1)
            inset.set_ylabel("$d/a$", fontsize=6, labelpad=1)
            inset.tick_params(labelsize=5.5, pad=1.5, length=2)
            ax.set_ylabel("$d/a$")
            _panel_label(ax, f"{lab} $a/R={_fmt(k)}$")
            n_failed_all += n_failed
            n_snapped_all += n_snapped
            paths_all |= paths_seen
        # colours and markers are shared by both panels: the shape key in (a), the
        # load paths, snaps and omitted points (counted over both panels) in (b)
        if any(not ln.get_label().startswith("_") for ln in main[0].get_lines()):
            main[0].legend(loc="lower right", frameon=False, ncol=2, columnspacing=0.8)
        handles = _marker_handles([p for p in PATHS if p in paths_all], n_failed_all,
                                  n_snapped_all)
        if handles:
            main[-1].legend(handles=handles, loc="lower right", frameon=False)
        main[-1].set_xlabel("$L/a$")
        fig.tight_layout(h_pad=0.4)
        _footnote(fig, quality, f"FE hmax={_fmt(hmax) if hmax else '?'}, few lengths")
    return fig


def fig4(quality="quick", data_dir=DEFAULT_DATA_DIR, progress=True, workers=None):
    """Fig. 4: d/a against L/a for b/a in {0, 0.2, ..., 1}, a/R = 0 and 2.5.

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> fig4("quick").savefig("fig4.png", dpi=200)  # doctest: +SKIP
    """
    df = _sweep_table(fig4_points(quality), _table(data_dir, "fig4", quality), progress,
                      workers)
    return draw_fig4(df, quality, hmax=quality_settings(quality)["hmax"])


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
    lengths = np.round(np.arange(0.5, 2.8 + 1e-9, s["ribbon_step"]), 6)
    if os.path.exists(fn):
        df = pd.read_csv(fn)
        if len(df) == 4 * 2 * lengths.size:
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


def draw_fig5(fe, rom, quality: str = "paper", hmax=None):
    """Draw Fig. 5: finite elements (solid, markers) against the ribbon model (dashed:
    increasing L, dotted: decreasing L), (a, b) a/R = 1, (c, d) a/R = 2.5.

    Parameters
    ----------
    fe : pandas.DataFrame
        Sweep rows (length, tip_width, curvature, path, deflection, converged, snapped).
    rom : pandas.DataFrame
        From :func:`fig5_ribbon`.

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> import pandas as pd
    >>> fe = pd.DataFrame([dict(length=L, tip_width=b, curvature=k, path="curvature-first",
    ...                         deflection=0.3 * L, converged=True, snapped=False)
    ...                    for L in (1.0, 2.0) for b in (0.0, 1.0) for k in (1.0, 2.5)])
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
        fig = _new_figure(COLUMN_WIDTH, 3.7)
        axes = fig.subplots(2, 2, sharex=True, sharey=True)
        panels = [((0, 0), 1.0, 1.0, "(a)"), ((0, 1), 0.0, 1.0, "(b)"),
                  ((1, 0), 1.0, 2.5, "(c)"), ((1, 1), 0.0, 2.5, "(d)")]
        n_failed = n_snapped = n_rom_failed = 0
        for (i, j), b, k, lab in panels:
            ax = axes[i, j]
            ax.axhline(0.0, color="0.75", linewidth=0.5, zorder=0)
            r = rom[np.isclose(rom["tip_width"].astype(float), b)
                    & np.isclose(rom["curvature"].astype(float), k)]
            for direction, ls in (("increasing", "--"), ("decreasing", ":")):
                n_rom_failed += _ribbon_line(ax, r[r["direction"] == direction], rom_colour,
                                             ls, None)
            f_ = fe[np.isclose(fe["tip_width"].astype(float), b)
                    & np.isclose(fe["curvature"].astype(float), k)]
            for path in PATHS:
                cur = f_[f_["path"] == path]
                if len(cur):
                    f, s = _curve(ax, cur, fe_colour, path)
                    n_failed += f
                    n_snapped += s
            shape = "rectangle" if b == 1.0 else "triangle"
            _panel_label(ax, f"{lab} {shape}\n$a/R={_fmt(k)}$")
            if i == 1:
                ax.set_xlabel("$L/a$")
            if j == 0:
                ax.set_ylabel("$d/a$")
        from matplotlib.lines import Line2D

        handles = _marker_handles(PATHS, n_failed, n_snapped, colour=fe_colour)
        handles[0].set_label("FE, curvature-first")
        handles[1].set_label("FE, gravity-first")
        handles += [Line2D([], [], color=rom_colour, linestyle=ls, label=f"ribbon, $L$ {d}")
                    for ls, d in (("--", "increasing"), (":", "decreasing"))]
        if n_rom_failed:
            handles.append(Line2D([], [], color="none",
                                  label=f"ribbon: {n_rom_failed} not converged, omitted"))
        fig.legend(handles=handles, loc="upper center", ncol=2, frameon=False,
                   bbox_to_anchor=(0.5, 1.0), columnspacing=1.0)
        fig.tight_layout(rect=(0, 0, 1, 0.9), h_pad=0.3, w_pad=0.3)
        _footnote(fig, quality, f"FE hmax={_fmt(hmax) if hmax else '?'}, few lengths")
    return fig


def fig5(quality="quick", data_dir=DEFAULT_DATA_DIR, progress=True, workers=None):
    """Fig. 5: finite elements against the ribbon model (rectangle, triangle; a/R = 1, 2.5).

    The finite-element points are fig2's (same table); the ribbon curves are
    cached in ``data_dir/fig5-<quality>-ribbon.csv``.

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> fig5("quick").savefig("fig5.png", dpi=200)  # doctest: +SKIP
    """
    fe = _sweep_table(fig5_points(quality), _table(data_dir, "fig2", quality), progress,
                      workers)
    rom = fig5_ribbon(quality, data_dir, progress)
    return draw_fig5(fe, rom, quality, hmax=quality_settings(quality)["hmax"])


# -- registry and command line -----------------------------------------------------------
#: Figure name -> function ``(quality, data_dir, progress, workers) -> Figure``.
#: The CLI offers exactly these names (fig6/fig7 join when the bistability module has them).
FIGURES = {"fig2": fig2, "fig3": fig3, "fig4": fig4, "fig5": fig5}


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
    skfem_sheet.params.ParameterError: name must be one of fig2, fig3, fig4, fig5, got 'fig9'
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
                   help="quick (coarse mesh, few lengths; minutes) or paper (hmax 0.03)")
    p.add_argument("--out", default=None, help="output PNG (default NAME.png)")
    p.add_argument("--data-dir", default=DEFAULT_DATA_DIR,
                   help=f"folder of the cached sweep tables (default ./{DEFAULT_DATA_DIR}/)")
    p.add_argument("--workers", type=int, default=None,
                   help="processes for the sweep (default: the sweep's choice)")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    p.set_defaults(func=_cmd_figure)
