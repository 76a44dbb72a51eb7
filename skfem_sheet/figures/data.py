"""The fold-map data of the figures: which points, their table, and what a row holds.

The one module of :mod:`skfem_sheet.figures` that imports the studies: every
finite-element curve of fig2 and fig4-fig7 comes from one fold-map table per
quality (:func:`skfem_sheet.studies.foldmap.fold_map`), read here; the figure
modules take :func:`map_grid_points`, :func:`fold_map_table`,
:func:`row_branches` and :data:`foldmap` from this module.

Examples
--------
>>> len(map_grid_points("quick"))
49
"""
from __future__ import annotations

import math
import os
import time

import numpy as np
import pandas as pd

from ..params import ParameterError
from ..studies import foldmap
from ..studies.runner import Workers, beside, dask_client, on_executor, study_executor
from .cache import data_folder
from .common import DEFAULT_DATA_DIR, quality_settings
from .work import DataStep, note

__all__ = ["foldmap", "map_grid_points", "fold_map_table", "row_branches", "branch_snapped",
           "usable", "select_rows", "as_bool", "fold_lines", "CURVE_CURVATURES",
           "RECTANGLE_CURVE_FROM", "fold_curve_points", "fold_curve_table", "curve_fold_lines",
           "curve_region", "curve_modes", "FIGURE_METHOD", "figure_method", "study_step",
           "on_workers", "beside", "Workers", "dask_client", "TRANSITION_WINDOW",
           "transition_window", "transition_rows"]

#: Where fig6 and fig7 take the bistable region from by default: ``"curves"``
#: (traced fold curves) or ``"grid"`` (the point-by-point fold map, the reference).
FIGURE_METHOD = "curves"

#: The clamp curvatures of the fold curves of a quality (every 0.25 from 1 to 5).
CURVE_CURVATURES = {q: tuple(float(x) for x in np.round(np.arange(1.0, 5.0001, 0.25), 6))
                    for q in ("quick", "paper")}
#: The curve in (L, a/R) at b/a = 1 starts here and turns at the rectangle's critical a/R.
RECTANGLE_CURVE_FROM = 2.5

_MODES = ("curvature_dominated", "gravity_dominated")

#: Half-width (L/a) of the lengths a point's transition is traced over on its
#: own mesh, around the transition on the coarse mesh (:func:`transition_rows`).
#: It sets only the cost: a windowed row whose steepest interval is not inside
#: its window is replaced by the whole row (``docs/decisions.md``, "The
#: transition window").
TRANSITION_WINDOW = 0.2


# -- points and the table ------------------------------------------------------------------
def map_grid_points(quality: str = "quick", select=None) -> list:
    """Fold-map points of the quality's grid, optionally only the ``(a/R, b/a)`` ``select``-ed.

    ``select(curvature, tip_width) -> bool`` picks grid points; the points are
    those of :func:`skfem_sheet.studies.foldmap.map_points` with the quality's
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
    out = []
    for c, tips in s["grid"].items():
        tips = [b for b in tips if select is None or select(c, b)]
        if tips:
            out += foldmap.map_points(tips, [c], lengths=s["lengths"], hmax=s["hmax"],
                                      step=s["step"], tol=s["tol"])
    return out


def fold_map_table(points, quality: str = "quick", data_dir=DEFAULT_DATA_DIR, progress=True,
                   workers=None, log=None):
    """Rows of the quality's fold-map table for ``points`` (computing the missing ones).

    The table is ``data_dir/foldmap-<quality>.csv`` with its journal; points
    already journalled are read, not recomputed.  ``workers``: a number of
    local processes, or a :class:`~skfem_sheet.studies.runner.Workers` (a
    Dask cluster: the rows are its tasks, journalled here).  ``log``: a list
    to append this step's :class:`~skfem_sheet.figures.work.DataStep` to
    (factorisations: the computed rows' ``newton_iterations``).

    Returns
    -------
    pandas.DataFrame
        One row per point, in order (:data:`skfem_sheet.studies.foldmap.MAP_COLUMNS`).

    Examples
    --------
    >>> df = fold_map_table(fig2_points("quick"), "quick", "skfem_sheet_data")  # doctest: +SKIP
    """
    table = os.path.join(data_folder(data_dir), f"foldmap-{quality}.csv")
    t0 = time.perf_counter()
    df = foldmap.fold_map(points, table=table, progress=progress, **study_executor(workers))
    note(log, study_step("fold map", df, df.attrs["fold_map"], "newton_iterations",
                         time.perf_counter() - t0))
    return df


def transition_window(point, transition: float, half_width: float = TRANSITION_WINDOW):
    """The lengths ``(lo, hi)`` within ``half_width`` of ``transition`` on the
    point's grid of lengths (``length_min + k step``), cut to its range.

    Examples
    --------
    >>> transition_window({"length_min": 0.5, "length_max": 3.0, "step": 0.05}, 1.7125)
    (1.5, 1.95)
    >>> transition_window({"length_min": 0.5, "length_max": 3.0, "step": 0.05}, 0.6)
    (0.5, 0.8)
    """
    L0, L1, h = float(point["length_min"]), float(point["length_max"]), float(point["step"])
    lo = L0 + h * math.floor((transition - half_width - L0) / h + 1e-9)
    hi = L0 + h * math.ceil((transition + half_width - L0) / h - 1e-9)
    return round(max(L0, lo), 9), round(min(L1, hi), 9)


def _has_fold(row) -> bool:
    return any(np.isfinite(_float(row[k])) for k in ("standout_length", "popup_length"))


def _inside_window(row, point) -> bool:
    """Whether a windowed row gives its point's transition: usable, without a
    fold, and the names of its points changing inside the window (rows
    without names: its steepest interval of d(L) inside it), or at an end of
    the point's whole range: then the whole branch has it there too."""
    if not usable(row) or as_bool([row["bistable"]])[0] or _has_fold(row):
        return False
    L, d, _ = foldmap.branch_curve(row)
    names = foldmap.branch_names(row)
    if len(names) == len(L) and len(L) >= 2:
        # the names change inside the window (or at an end of the whole range)
        gd = [k for k, n in enumerate(names) if n == "gravity-dominated"]
        if not gd:
            return L[-1] >= float(point["length_max"]) - 1e-9
        return gd[0] > 0 or L[0] <= float(point["length_min"]) + 1e-9
    if len(L) < 3:
        return False
    i = foldmap.steepest_interval(L, d)
    return ((i > 0 or L[0] <= float(point["length_min"]) + 1e-9)
            and (i < len(L) - 2 or L[-1] >= float(point["length_max"]) - 1e-9))


def transition_rows(points, quality: str = "quick", data_dir=DEFAULT_DATA_DIR, progress=True,
                    workers=None, log=None, full=()):
    """Fold-map rows that give the transition length of each of ``points``
    (Fig. 6's markers where the transition is continuous).

    The transition needs the branch on the fine mesh only around it: each
    point is computed on its coarse mesh
    (:func:`~skfem_sheet.studies.foldmap.row_coarse_hmax`), then on its own
    mesh within :data:`TRANSITION_WINDOW` of the coarse transition
    (:func:`transition_window`).  A windowed row serves where its steepest
    interval lies inside its window and it has no fold; otherwise (and for
    points with a coarse fold, in ``full``, or without a coarser mesh) the
    whole row is used.  Every row is a point of the fold-map table.

    Returns
    -------
    pandas.DataFrame
        One row per point, in order (the windowed ones with their window
        as ``length_min``, ``length_max``).
    """
    points = list(points)
    if not points:
        return pd.DataFrame(columns=list(foldmap.MAP_COLUMNS))
    keep = {foldmap.map_key(p) for p in full}
    coarse_hmax = [foldmap.row_coarse_hmax(p["hmax"]) for p in points]
    whole = [h is None or foldmap.map_key(p) in keep for p, h in zip(points, coarse_hmax)]
    coarse_at = [k for k, w in enumerate(whole) if not w]
    chosen = [None] * len(points)
    if coarse_at:
        coarse = fold_map_table([{**points[k], "hmax": coarse_hmax[k]} for k in coarse_at],
                                quality, data_dir, progress, workers, log)
        windowed = []
        for k, (_, row) in zip(coarse_at, coarse.iterrows()):
            t = foldmap.transition_length(row) if usable(row) else None
            if t is None or _has_fold(row):
                whole[k] = True
            else:
                lo, hi = transition_window(points[k], t)
                windowed.append((k, {**points[k], "length_min": lo, "length_max": hi}))
        if windowed:
            fine = fold_map_table([p for _, p in windowed], quality, data_dir, progress, workers,
                                  log)
            for (k, _), (_, row) in zip(windowed, fine.iterrows()):
                if _inside_window(row, points[k]):
                    chosen[k] = row
                else:
                    whole[k] = True
    rest = [k for k, w in enumerate(whole) if w]
    if rest:
        df = fold_map_table([points[k] for k in rest], quality, data_dir, progress, workers, log)
        for k, (_, row) in zip(rest, df.iterrows()):
            chosen[k] = row
    return pd.DataFrame([r.to_dict() for r in chosen]).reset_index(drop=True)


def figure_method(method=None) -> str:
    """``method``, or :data:`FIGURE_METHOD` if None; checked.

    Examples
    --------
    >>> figure_method(), figure_method("grid")
    ('curves', 'grid')
    """
    method = FIGURE_METHOD if method is None else method
    if method not in ("curves", "grid"):
        raise ParameterError(f"method must be 'curves' or 'grid', got {method!r}")
    return method


def fold_curve_points(quality: str = "quick", curvatures=None, rectangle: bool = True) -> list:
    """The fold curves of a quality: one in (L, b/a) per a/R of
    :data:`CURVE_CURVATURES` (or ``curvatures``), and the rectangle's curve
    in (L, a/R) (unless ``rectangle`` is False), all at the quality's mesh.

    Examples
    --------
    >>> pts = fold_curve_points("quick")
    >>> len(pts), pts[0]["hmax"], pts[-1]["second"]
    (18, 0.1, 'curvature')
    """
    s = quality_settings(quality)
    cs = CURVE_CURVATURES[quality] if curvatures is None else curvatures
    return foldmap.curve_points(cs, hmax=s["hmax"],
                                rectangle_from=RECTANGLE_CURVE_FROM if rectangle else None)


def fold_curve_table(points, quality: str = "quick", data_dir=DEFAULT_DATA_DIR, progress=True,
                     workers=None, log=None):
    """Rows of the quality's fold-curve table ``data_dir/foldcurves-<quality>.csv``
    for ``points`` (tracing the curves not yet journalled), one per curve;
    ``workers`` and ``log`` as in :func:`fold_map_table` (factorisations: the
    rows' own)."""
    table = os.path.join(data_folder(data_dir), f"foldcurves-{quality}.csv")
    t0 = time.perf_counter()
    df = foldmap.fold_curves(points, table=table, progress=progress,
                             **study_executor(workers))
    note(log, study_step("fold curves", df, df.attrs["fold_curves"], "factorizations",
                         time.perf_counter() - t0))
    return df


def _unit_name(row) -> str:
    """A map point or fold curve in words: ``b/a 1, a/R 5``, ``a/R 5``, ``b/a 1 in a/R``."""
    if "second" not in row:
        return f"b/a {float(row['tip_width']):g}, a/R {float(row['curvature']):g}"
    if row["second"] == "curvature":
        return f"b/a {float(row['tip_width']):g} in a/R"
    return f"a/R {float(row['curvature']):g}"


def on_workers(chunks, workers, task):
    """``task(chunk)`` for each of ``chunks`` on ``workers`` spawned processes
    (the studies' pool, :func:`~skfem_sheet.studies.runner.pool`), or on the
    Dask cluster of a :class:`~skfem_sheet.studies.runner.Workers`
    (:func:`~skfem_sheet.studies.runner.on_executor`), yielding each chunk's
    results as it finishes (None for a point whose worker failed: the caller
    computes it again).  The figures' one door to the worker pool."""
    yield from on_executor(chunks, workers, task, lambda point, message, error: None)


def study_step(what, df, stats, counter, wall_time_s) -> DataStep:
    """The :class:`~skfem_sheet.figures.work.DataStep` of a study's table ``df``:
    its rows computed in this run (``stats["new_keys"]``, the runner's), their
    ``counter`` column summed as the factorisations, their ``wall_time_s``
    summed and the longest of them.

    Examples
    --------
    >>> import pandas as pd
    >>> df = pd.DataFrame({"key": ["a", "b"], "tip_width": [1.0, 0.0], "curvature": [5.0, 5.0],
    ...                    "newton_iterations": [40, 10], "wall_time_s": [30.0, 5.0]})
    >>> s = study_step("fold map", df, {"new_keys": ("a",), "cached": 1}, "newton_iterations",
    ...                31.0)
    >>> s.computed, s.cached, s.factorizations, s.longest
    (1, 1, 40, 'b/a 1, a/R 5 (30 s)')
    """
    new = set(stats.get("new_keys", ()))
    rows = df[df["key"].isin(new)].drop_duplicates("key") if len(df) and new else df.iloc[:0]
    counts = pd.to_numeric(rows[counter], errors="coerce").astype(float)
    times = pd.to_numeric(rows["wall_time_s"], errors="coerce").astype(float)
    longest = ""
    if len(rows) and times.notna().any():
        i = int(np.nanargmax(times.to_numpy(float)))
        longest = f"{_unit_name(rows.iloc[i])} ({times.iloc[i]:.0f} s)"
    return DataStep(what, computed=len(new), cached=int(stats.get("cached", 0)),
                    solves=len(new), factorizations=int(counts.fillna(0).sum()),
                    wall_time_s=float(wall_time_s),
                    compute_s=float(times.sum()) if times.notna().any() else math.nan,
                    longest=longest)


# -- reading rows --------------------------------------------------------------------------
def as_bool(values):
    """Booleans from a column that may hold bools, 0/1, NA or the strings True/False.

    Examples
    --------
    >>> as_bool([True, 0, None, float("nan"), "True", "false"]).tolist()
    [True, False, False, False, True, False]
    """
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


def usable(row) -> bool:
    """The row holds branch curves (its computation did not fail).

    Examples
    --------
    >>> usable({"error": "", "curvature_dominated": "{}", "gravity_dominated": ""})
    True
    >>> usable({"error": "RuntimeError", "curvature_dominated": "{}", "gravity_dominated": ""})
    False
    """
    return not _text(row, "error") and bool(_text(row, "curvature_dominated")
                                           or _text(row, "gravity_dominated"))


def select_rows(df, curvature=None, tip_width=None):
    """The rows of ``df`` at ``curvature`` and/or ``tip_width`` (compared with ``isclose``)."""
    sel = np.ones(len(df), dtype=bool)
    if curvature is not None:
        sel &= np.isclose(df["curvature"].astype(float), curvature)
    if tip_width is not None:
        sel &= np.isclose(df["tip_width"].astype(float), tip_width)
    return df[sel]


def _snapped_from_message(row, which) -> bool:
    """Compatibility only: whether an OLD fold-map row says ``which`` branch did not exist.

    Tables (and journals) written before the ``curvature_dominated_snapped`` /
    ``gravity_dominated_snapped`` columns record it only in prose, in
    ``message``, as the sentence the fold map wrote then ("the
    curvature-dominated branch does not exist at L/a = ..."); the finished
    quick map on disk is such a table, so it is read this way rather than
    recomputed.  New rows carry the boolean columns: see :func:`branch_snapped`.
    """
    label = {"curvature_dominated": "curvature-dominated",
             "gravity_dominated": "gravity-dominated"}[which]
    return f"the {label} branch does not exist" in _text(row, "message")


def branch_snapped(row, which: str) -> bool:
    """Whether ``which`` branch of a fold-map row did not exist where its continuation started.

    Read from the row's column ``<which>_snapped`` (the branch's
    ``start_snapped``), or, in rows without it, from the message
    (:func:`_snapped_from_message`).

    Examples
    --------
    >>> branch_snapped({"gravity_dominated_snapped": True, "message": ""}, "gravity_dominated")
    True
    >>> branch_snapped({"curvature_dominated_snapped": False, "message": ""},
    ...                "curvature_dominated")
    False
    >>> old = {"message": "the gravity-dominated branch does not exist at L/a = 3"}
    >>> branch_snapped(old, "gravity_dominated"), branch_snapped(old, "curvature_dominated")
    (True, False)
    """
    column = f"{which}_snapped"
    v = row[column] if column in row else None
    if v is None or (not isinstance(v, str) and pd.isna(v)):
        return _snapped_from_message(row, which)
    return bool(as_bool([v])[0])


def row_branches(row) -> dict:
    """What to draw of one fold-map row: the stable branches and where they part.

    Returns
    -------
    dict
        ``curvature_dominated`` and ``gravity_dominated``: ``(L, d)`` of each
        branch's stable points, sorted by L (empty where the branch did not
        exist at its start, :func:`branch_snapped`); ``bistable``;
        ``popup_length``, ``standout_length``; ``transition_length``;
        ``usable`` (False for a failed point).

    Examples
    --------
    >>> import json
    >>> curve = json.dumps({"lengths": [1.0, 1.1, 1.2], "deflection": [0.1, 0.2, 0.3],
    ...                     "stable": [True, None, False]})
    >>> row = {"bistable": False, "curvature": 2.5, "popup_length": float("nan"),
    ...        "standout_length": float("nan"), "transition_length": 1.1,
    ...        "curvature_dominated": curve, "gravity_dominated": curve,
    ...        "curvature_dominated_snapped": False, "gravity_dominated_snapped": False,
    ...        "message": "", "error": ""}
    >>> out = row_branches(row)
    >>> out["curvature_dominated"][0].tolist(), out["transition_length"]  # unstable dropped
    ([1.0, 1.1], 1.1)
    >>> row_branches(dict(row, gravity_dominated_snapped=True))["gravity_dominated"][0].size
    0
    """
    ok = usable(row)
    out = {"usable": ok, "bistable": bool(row["bistable"]) and ok,
           "popup_length": _float(row["popup_length"]),
           "standout_length": _float(row["standout_length"])}
    for which in _MODES:
        L, d, st = foldmap.branch_curve(row, which) if ok else (np.empty(0), np.empty(0), [])
        keep = np.array([s is not False for s in st], dtype=bool)
        if branch_snapped(row, which):
            keep[:] = False  # its continuation started on the other branch
        out[which] = (L[keep], d[keep])
    t = None
    if ok and not out["bistable"]:
        t = _float(row["transition_length"]) if "transition_length" in row else None
        if t is None or not np.isfinite(t):
            t = foldmap.transition_length(row)
        t = None if t is None else float(t)
    out["transition_length"] = t
    return out


# -- the bistable region ---------------------------------------------------------------------
def fold_lines(rows, critical):
    """The bistable region of one curvature's rows in the (b/a, L/a) plane.

    ``critical`` is this curvature's ``(estimate, low, high)`` from
    :func:`skfem_sheet.studies.foldmap.critical_tip_width`.  Returns ``None``
    (no bistable row) or a dict: ``b``, ``L0``, ``L1`` of the bistable rows
    from ``high`` up, ascending in b, and ``tip`` = ``(b*, L*)`` where the
    two meet (L0* and L1* of the two smallest bistable shape factors
    extrapolated linearly to b*), None if the map does not bracket b*.
    """
    est, lo, hi = critical
    if not np.isfinite(hi):
        return None
    ok = rows[np.array([usable(r) for _, r in rows.iterrows()], dtype=bool)] \
        if len(rows) else rows
    ok = ok[as_bool(ok["bistable"]) & (ok["tip_width"].astype(float) >= hi - 1e-9)]
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


# -- the bistable region from fold curves ------------------------------------------------------
def curve_fold_lines(row, tip_widths=None):
    """The bistable region of one fold curve in (L, b/a), as :func:`fold_lines` gives it.

    Returns None (no bistable curve, or a failed one) or a dict: ``b``,
    ``L0``, ``L1`` at ``tip_widths`` (default: the b/a of the curve's points)
    above the cusp, ascending, and ``tip`` = the cusp ``(b*, L*)`` (None if
    the curve did not turn back); ``curve`` = the traced polyline ``(L, b)``
    from L1*(1) through the cusp to L0*(1); ``halves`` = the standout and
    pop-up folds ``(b, L)`` (:func:`skfem_sheet.studies.foldmap.curve_halves`).
    """
    if _text(row, "error") or not bool(row["bistable"]):
        return None
    halves = foldmap.curve_halves(row)
    if halves is None or halves["cusp"] is None:
        return None
    (bs, Ls), (bp, Lp) = halves["standout"], halves["popup"]
    b_star, L_star = halves["cusp"]
    if tip_widths is None:
        b = np.unique(np.concatenate([bs[1:], bp[1:]]))
    else:
        b = np.asarray(tip_widths, float)
        b = b[(b > b_star) & (b <= min(bs.max(), bp.max()) + 1e-12)]
    L1 = np.interp(b, bs, Ls)
    L0 = np.interp(b, bp, Lp)
    curve = (np.concatenate([Ls[::-1], Lp[1:]]), np.concatenate([bs[::-1], bp[1:]]))
    return {"b": b, "L0": L0, "L1": L1, "tip": (float(b_star), float(L_star)), "curve": curve,
            "halves": ((bs, Ls), (bp, Lp))}


def curve_region(df, tip_widths=None) -> dict:
    """The bistable region of a fold-curve table, in the form of
    ``figure7.bistable_region``: ``chains`` per a/R of nodes ``(b, L0*, L1*)``
    from the cusp ``(b*, L*, L*)`` up (at ``tip_widths``, default every 0.05),
    ``critical`` (:func:`skfem_sheet.studies.foldmap.critical_curve`: the
    cusps, and the rectangle's critical a/R), ``edge`` (that last one if it is
    not a traced a/R)."""
    tips = np.round(np.arange(0.05, 1.0001, 0.05), 6) if tip_widths is None else tip_widths
    chains, edge = {}, None
    rows = df[df["second"] == "tip_width"] if len(df) else df
    for _, row in rows.iterrows():
        lines = curve_fold_lines(row, tips)
        if lines is None:
            continue
        bs, Ls = lines["tip"]
        nodes = [(bs, Ls, Ls)] + [(float(b), float(l0), float(l1))
                                  for b, l0, l1 in zip(lines["b"], lines["L0"], lines["L1"])]
        chains[float(row["curvature"])] = nodes
    critical = foldmap.critical_curve(df) if len(df) else []
    for b, c, L in critical:
        if b == 1.0 and all(abs(c - k) > 1e-9 for k in chains):
            chains[float(c)] = [(1.0, L, L)]
            edge = (1.0, float(c), float(L))
    return {"chains": dict(sorted(chains.items())), "critical": critical, "edge": edge}


def curve_modes(lines, tip_widths, lengths):
    """Mode markers from a fold curve: at each ``b`` of ``tip_widths`` above
    the cusp, the curvature-dominated mode exists for ``L <= L1*(b)`` and the
    gravity-dominated one for ``L >= L0*(b)``.  Returns ``(cd, gd)``, lists of
    ``(L, b)``; the tip widths at or below the cusp are left out (they need
    a map point each: there the transition is continuous)."""
    cd, gd = [], []
    if lines is None:
        return cd, gd
    (bs, Ls), (bp, Lp) = lines["halves"]
    b_star = lines["tip"][0]
    L = np.asarray(lengths, float)
    for b in tip_widths:
        if b <= b_star or b > min(bs.max(), bp.max()) + 1e-12:
            continue
        l1, l0 = np.interp(b, bs, Ls), np.interp(b, bp, Lp)
        cd += [(x, float(b)) for x in L[L <= l1]]
        gd += [(x, float(b)) for x in L[L >= l0]]
    return cd, gd
