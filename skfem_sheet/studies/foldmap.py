"""Bistability map: pop-up and standout lengths over a grid of (tip width, curvature).

For every point ``(b/a, a/R)`` of a grid, :func:`~skfem_sheet.bistability.fold_lengths`
locates the standout length ``L1*`` and the pop-up length ``L0*`` (paper,
Figs. 6 and 7) on the point's own mesh; a row that finds no fold says why
(``curvature_dominated_reason`` / ``gravity_dominated_reason``).
:func:`fold_map` runs the points in parallel into one resumable table with
both branch curves ``d(L)`` (:mod:`skfem_sheet.studies.runner`).  From the
table: :func:`critical_tip_width` (the shape factor ``(b/a)*`` below which no
length is bistable), :func:`modes` (which modes exist at given lengths, the
markers of Fig. 6), :func:`branch_curve` (a row's ``(L, d, stable)``).

Command line (:mod:`skfem_sheet.cli.fold_map`)::

    python -m skfem_sheet fold-map --tip-widths 0.5:1:0.1 --curvatures 1,2.5,5 \\
        --hmax 0.1 --table foldmap.csv [--workers N] [--scheduler tcp://host:port]

Examples
--------
>>> from skfem_sheet.studies.foldmap import map_points, fold_map
>>> pts = map_points(tip_widths=[0.0], curvatures=[2.5], lengths=(0.8, 1.0), hmax=0.15,
...                  step=0.2)
>>> df = fold_map(pts, workers=1, progress=False)
>>> bool(df.converged[0]), bool(df.bistable[0])
(True, False)
"""
from __future__ import annotations

import functools
import itertools
import json
import math

import numpy as np

from ..bistability import FOLD_CURVE_LEVELS, FOLD_CURVE_POINTS, fold_lengths
from ..foldcurve import trace_curvature_fold_curve, trace_fold_curve
from ..io import dumps_json
from ..params import DEFAULT_HMAX, ParameterError, Sheet
from ..version import __version__
from .runner import (
    MAX_POINTS,
    EachPoint,
    Job,
    as_values,
    check_run,
    computed_record,
    execute,
    failed_record,
    hash_key,
    key_value,
    normalize_params,
    study_points,
    typed_frame,
)

__all__ = ["MAP_PARAMETERS", "MAP_COLUMNS", "map_points", "map_key", "map_sheet", "fold_map",
           "row_coarse_hmax",
           "branch_curve", "branch_names", "transition_length", "steepest_interval", "modes",
           "critical_tip_width",
           "CURVE_PARAMETERS", "CURVE_COLUMNS", "curve_points", "fold_curves", "curve_halves",
           "critical_curve"]

#: Input parameters of a map point and their defaults.  ``tol``: the
#: shortest step of the continuations (``min_step`` of
#: :func:`~skfem_sheet.bistability.fold_lengths`; it was the half-width of
#: the fold's bisection bracket before the folds were located, hence its name).
MAP_PARAMETERS = {"tip_width": 1.0, "curvature": 2.5, "length_min": 0.5, "length_max": 3.0,
                  "hmax": DEFAULT_HMAX, "layers": None, "step": 0.1, "tol": 0.005, "thickness": 0.03,
                  "modulus": 735.0, "solver": "auto"}
#: The journal keys' tag: rows whose folds were bracketed by failed solves
#: (before the folds were located) carry ``"fold-map"`` and are not served for
#: the same point now (their fold lengths are bisection points, +- ``tol``).
_KEY_TAG = "fold-map/located"
_NUMERIC = ("tip_width", "curvature", "length_min", "length_max", "hmax", "step", "tol",
            "thickness", "modulus")

#: Columns of the table, in order.  ``curvature_dominated`` and
#: ``gravity_dominated`` hold the branch curves as JSON
#: (``{"lengths": [...], "deflection": [...], "stable": [...]}``, see
#: :func:`branch_curve`).  ``curvature_dominated_snapped`` and
#: ``gravity_dominated_snapped`` say whether that branch did not exist at its
#: start (``length_min``, resp. ``length_max``): the sheet snapped to the other
#: branch at once (``Branch.start_snapped``; empty when the point failed).
MAP_COLUMNS = (*MAP_PARAMETERS, "popup_length", "standout_length", "bistable",
               "bistable_width", "transition_length", "converged", "message",
               "curvature_dominated_reason", "gravity_dominated_reason",
               "curvature_dominated_snapped", "gravity_dominated_snapped",
               "curvature_dominated", "gravity_dominated", "newton_iterations", "wall_time_s",
               "version", "key", "error", "finished_at")
_FLOAT = (*_NUMERIC, "popup_length", "standout_length", "bistable_width", "transition_length",
          "wall_time_s")
_INT = ("layers", "newton_iterations")
_STR = ("solver", "message", "curvature_dominated_reason", "gravity_dominated_reason",
        "curvature_dominated", "gravity_dominated", "version", "key", "error", "finished_at")


# -- points and keys -------------------------------------------------------------------------
_SNAPPED = ("curvature_dominated_snapped", "gravity_dominated_snapped")
#: The sentences of ``message`` that said the same before the flags were columns.
_NOT_EXISTING = {"curvature_dominated_snapped": "the curvature-dominated branch does not exist",
                 "gravity_dominated_snapped": "the gravity-dominated branch does not exist"}


def _normalize(point) -> dict:
    return normalize_params(point, MAP_PARAMETERS, _NUMERIC, "map point")


def map_key(point) -> str:
    """The journal key of a map point: its parameters, normalised, hashed (two
    points with the same key are the same computation, one row of a table).

    Examples
    --------
    >>> map_key(map_points([1.0], [2.5])[0]) == map_key(dict(tip_width=1, curvature=2.5))
    True
    """
    p = _normalize({k: point[k] for k in MAP_PARAMETERS if k in point})
    return hash_key([_KEY_TAG, *[[k, key_value(p[k])] for k in MAP_PARAMETERS]])


def map_points(tip_widths, curvatures, *, lengths=(0.5, 3.0), hmax: float = DEFAULT_HMAX,
               layers=None,
               step: float = 0.1, tol: float = 0.005, thickness: float = 0.03,
               modulus: float = 735.0, solver: str = "auto") -> list:
    """The grid ``tip_widths x curvatures`` as map points (dicts), curvature outermost.

    ``lengths = (short, long)`` is the search range of every point: the
    curvature-dominated branch is followed up from ``short``, the
    gravity-dominated one down from ``long`` (see
    :func:`~skfem_sheet.bistability.fold_lengths`).

    Examples
    --------
    >>> pts = map_points([0.5, 1.0], [1.0, 2.5])
    >>> len(pts), pts[1]["tip_width"], pts[1]["curvature"], pts[0]["length_max"]
    (4, 1.0, 1.0, 3.0)
    """
    tw = as_values("tip_widths", tip_widths)
    cv = as_values("curvatures", curvatures)
    if not (isinstance(lengths, (tuple, list)) and len(lengths) == 2):
        raise ParameterError(f"lengths must be (short, long), got {lengths!r}")
    n = len(tw) * len(cv)
    if n > MAX_POINTS:
        raise ParameterError(f"the map must have at most {MAX_POINTS} points, got {n}")
    return [_normalize(dict(tip_width=b, curvature=c, length_min=lengths[0],
                            length_max=lengths[1], hmax=hmax, layers=layers, step=step, tol=tol,
                            thickness=thickness, modulus=modulus, solver=solver))
            for c, b in itertools.product(cv, tw)]


# -- one point (runs in the workers) ---------------------------------------------------------
def _empty_record(point, key):
    rec = dict(point)
    rec.update(popup_length=math.nan, standout_length=math.nan, bistable=False,
               bistable_width=math.nan, transition_length=math.nan, converged=False,
               message="", curvature_dominated_reason="", gravity_dominated_reason="",
               curvature_dominated_snapped=None, gravity_dominated_snapped=None,
               curvature_dominated="", gravity_dominated="", newton_iterations=None,
               wall_time_s=math.nan, version=__version__, key=key, error="")
    return rec


def _curve_json(branch) -> str:
    """A branch curve as JSON: its points (each with its name, as ``solve``
    names a state), and its located fold last (stability ``null``: the
    marginal state where the branch ends; name ``""``)."""
    L = [round(float(x), 10) for x in branch.lengths]
    d = [float(x) for x in branch.deflections]
    st = [None if s is None else bool(s) for s in branch.stable]
    names = list(branch.names)
    if branch.fold is not None and math.isfinite(branch.fold_deflection):
        L.append(round(float(branch.fold), 10))
        d.append(float(branch.fold_deflection))
        st.append(None)
        names.append("")
    return dumps_json({"lengths": L, "deflection": d, "stable": st, "names": names},
                      compact=True)


def _nan(x):
    return math.nan if x is None else float(x)


def _run_map_point(point) -> dict:
    """Fold lengths of one normalised map point; every exception becomes a failed record."""
    return computed_record(point, map_key, _empty_record, _fill_map_record)


def row_coarse_hmax(hmax: float):
    """The mesh a map point's branches are first traced on (coarse to fine):
    :data:`COARSE_HMAX`'s first for meshes at most half as large, else None
    (the branches on the point's own mesh alone).

    Examples
    --------
    >>> row_coarse_hmax(0.03), row_coarse_hmax(0.06), row_coarse_hmax(0.1)
    (0.1, None, None)
    """
    return COARSE_HMAX[0] if 2 * float(hmax) <= COARSE_HMAX[0] * (1 + 1e-12) else None


def map_sheet(point) -> Sheet:
    """The sheet of a map point: its planform and material at ``length_min``.

    Examples
    --------
    >>> map_sheet(map_points([0.5], [2.5])[0])
    Sheet(L/a = 0.5, b/a = 0.5, a/R = 2.5, h/a = 0.03, E/(rho g a) = 735)
    """
    return Sheet(length=point["length_min"], tip_width=point["tip_width"],
                 curvature=point["curvature"], thickness=point["thickness"],
                 modulus=point["modulus"])


def _fill_map_record(point, rec) -> None:
    """Put the fold lengths and branch curves of a map point into its record:
    :func:`~skfem_sheet.bistability.fold_lengths` with the branches on the
    point's own mesh (traced first on the coarse mesh of
    :func:`row_coarse_hmax` where there is one), the folds located there; the
    record's ``newton_iterations`` counts the factorisations of both meshes."""
    coarse = row_coarse_hmax(point["hmax"])
    r = fold_lengths(map_sheet(point), hmax=point["hmax"],
                     lengths=(point["length_min"], point["length_max"]), branches=True,
                     coarse_hmax=coarse if coarse is not None else 0,
                     layers=point["layers"], solver=point["solver"], step=point["step"],
                     min_step=min(point["tol"], point["step"]), names=True)
    up, down = r.increasing, r.decreasing
    notes = []
    if up.start_snapped:
        notes.append(f"the curvature-dominated branch does not exist at L/a = "
                     f"{point['length_min']:g} (lower length_min)")
    if down.start_snapped:
        notes.append(f"the gravity-dominated branch does not exist at L/a = "
                     f"{point['length_max']:g} (raise length_max)")
    rec.update(popup_length=_nan(r.popup.length if r.popup else None),
               standout_length=_nan(r.standout.length if r.standout else None),
               bistable=bool(r.bistable), bistable_width=float(r.width),
               converged=not notes, message="; ".join(notes) if notes else r.message,
               curvature_dominated_reason=up.reason,
               gravity_dominated_reason=down.reason,
               curvature_dominated_snapped=bool(up.start_snapped),
               gravity_dominated_snapped=bool(down.start_snapped),
               curvature_dominated=_curve_json(up), gravity_dominated=_curve_json(down),
               newton_iterations=int(r.factorizations + r.trace_factorizations),
               wall_time_s=float(r.wall_time_s))
    rec["transition_length"] = _nan(transition_length(rec))


def _with_flags(rec):
    """A record with the ``*_snapped`` flags: journal lines written before they
    were columns say it in ``message`` (the sentences :func:`_fill_map_record`
    writes); a failed point (``error``) leaves them unknown."""
    if all(k in rec for k in _SNAPPED):
        return rec
    rec = dict(rec)
    for name, sentence in _NOT_EXISTING.items():
        if name not in rec:
            rec[name] = None if rec.get("error") else sentence in str(rec.get("message") or "")
    return rec


def _frame(records):
    return typed_frame((_with_flags(r) for r in records), MAP_COLUMNS, floats=_FLOAT, ints=_INT,
                       bools_or_na=_SNAPPED, bools=("bistable", "converged"), strings=_STR)


_MAP_JOB = Job(task=EachPoint(__name__, "_run_map_point"),
               failed=functools.partial(failed_record, _empty_record, map_key), frame=_frame,
               key_of=map_key, required=("tip_width", "curvature", "converged", "popup_length"), desc="fold map")


def _chunks(points, n_workers):
    """One point per task, the most expensive (long, strongly curved) first."""
    return [[p] for p in sorted(points, key=lambda p: (-p["curvature"], -p["tip_width"]))]


def fold_map(points, table=None, workers=None, scheduler=None, progress=True, *,
             retry_failed=False):
    """Fold lengths of every map point, in parallel, into one resumable table.

    Parameters
    ----------
    points : list of dict
        From :func:`map_points` (or dicts of :data:`MAP_PARAMETERS`).
    table : str or path, optional
        ``.csv`` or ``.parquet`` file, with a journal beside it: points
        already in the journal are not computed again (as in
        :func:`skfem_sheet.studies.sweep.run_sweep`; the journal is described
        in :mod:`skfem_sheet.studies.runner`).
    workers, scheduler, progress, retry_failed
        As in :func:`skfem_sheet.studies.sweep.run_sweep`.

    Returns
    -------
    pandas.DataFrame
        One row per point (:data:`MAP_COLUMNS`): ``popup_length`` (``L0*``,
        NaN if the gravity-dominated branch held down to ``length_min``),
        ``standout_length`` (``L1*``, NaN if the curvature-dominated one held
        up to ``length_max``), ``bistable``, ``bistable_width``
        (``L1* - L0*``), ``transition_length`` (:func:`transition_length`),
        ``converged`` (both branches started where they should; otherwise
        ``message`` says which range end to move) and the branch curves.

    Examples
    --------
    >>> df = fold_map(map_points([0.0], [2.5], lengths=(0.8, 1.0), hmax=0.15, step=0.2),
    ...               workers=1, progress=False)
    >>> float(df.popup_length[0]) != float(df.popup_length[0])  # NaN: no fold in range
    True
    """
    points = study_points(points, _normalize, "map_points")
    path = check_run(table, workers, scheduler)
    keys = [map_key(p) for p in points]
    done, stats = execute(points, keys, _MAP_JOB, table=path, workers=workers,
                          scheduler=scheduler, progress=progress, retry_failed=retry_failed,
                          chunker=_chunks)
    df = _frame(done[k] for k in keys)
    df.attrs["fold_map"] = stats
    return df


# -- reading the table -----------------------------------------------------------------------
def branch_curve(row, which: str = "curvature_dominated"):
    """``(lengths, deflections, stable)`` arrays of one branch of a table row.

    ``which`` is ``"curvature_dominated"`` (followed with increasing L from
    ``length_min``) or ``"gravity_dominated"`` (decreasing L from
    ``length_max``); points are sorted by length.

    Examples
    --------
    >>> row = {"curvature_dominated": '{"lengths": [0.6, 0.5], "deflection": [0.2, 0.1], '
    ...                               '"stable": [true, true]}'}
    >>> [a.tolist() for a in branch_curve(row)]
    [[0.5, 0.6], [0.1, 0.2], [True, True]]
    """
    if which not in ("curvature_dominated", "gravity_dominated"):
        raise ParameterError("which must be 'curvature_dominated' or 'gravity_dominated', "
                             f"got {which!r}")
    text = row[which]
    if not isinstance(text, str) or not text:
        return np.empty(0), np.empty(0), np.empty(0, dtype=object)
    data = json.loads(text)
    L = np.asarray(data["lengths"], float)
    order = np.argsort(L, kind="stable")
    return (L[order], np.asarray(data["deflection"], float)[order],
            np.asarray(data["stable"], dtype=object)[order])


def transition_length(row) -> float | None:
    """Where the curvature-dominated mode gives way to the gravity-dominated one.

    None for a bistable row (two: ``L0*`` and ``L1*``).  Otherwise the single
    fold found; else the middle of the interval where the names of the
    curvature-dominated branch's points (:mod:`skfem_sheet.analyses.mode`)
    change; for a row without names the middle of the steepest interval of
    ``d(L)``; None for a flat clamp.

    Examples
    --------
    >>> transition_length({"bistable": False, "standout_length": float("nan"),
    ...                    "popup_length": 1.24, "curvature": 2.5})
    1.24
    >>> curve = ('{"lengths": [1.2, 1.3, 1.4], "deflection": [0.1, 0.3, 0.6], '
    ...          '"stable": [true, true, true], "names": ["curvature-dominated", '
    ...          '"gravity-dominated", "gravity-dominated"]}')
    >>> transition_length({"bistable": False, "standout_length": float("nan"),
    ...                    "popup_length": float("nan"), "curvature": 2.5,
    ...                    "curvature_dominated": curve})
    1.25
    """
    if bool(row["bistable"]):
        return None
    folds = [f for f in (row["standout_length"], row["popup_length"])
             if f is not None and np.isfinite(f)]
    if folds:
        return float(np.mean(folds))
    if float(row["curvature"]) == 0.0:
        return None
    L, d, _ = branch_curve(row)
    names = branch_names(row)
    if len(names) == len(L) and len(L) >= 2 and all(names):
        gd = [k for k, n in enumerate(names) if n == "gravity-dominated"]
        if not gd:
            return float(L[-1])          # curvature-dominated to its end
        k = gd[0]
        return float(L[0]) if k == 0 else float(0.5 * (L[k - 1] + L[k]))
    if len(L) < 3:
        return None
    i = steepest_interval(L, d)
    return float(0.5 * (L[i] + L[i + 1]))


def branch_names(row, which: str = "curvature_dominated") -> list:
    """The names of the points of a row's branch (sorted by length as
    :func:`branch_curve`; the located fold's, unnamed, left out), or ``[]``
    for a row without them.

    Examples
    --------
    >>> branch_names({"curvature_dominated": '{"lengths": [0.6, 0.5, 0.7], "deflection": '
    ...               '[0, 0, 0], "stable": [true, true, null], "names": ["a", "b", ""]}'})
    ['b', 'a']
    """
    text = row[which] if which in row else ""
    if not isinstance(text, str) or not text:
        return []
    data = json.loads(text)
    names = data.get("names")
    if not names:
        return []
    L = np.asarray(data["lengths"], float)
    order = np.argsort(L, kind="stable")
    return [names[k] for k in order if names[k]]


def steepest_interval(L, d) -> int:
    """Index ``i`` of the interval ``[L[i], L[i + 1]]`` where ``d`` rises
    fastest (the one :func:`transition_length` takes the middle of).

    Examples
    --------
    >>> steepest_interval([1.0, 1.1, 1.15, 1.3], [0.0, 0.1, 0.2, 0.3])
    1
    """
    return int(np.argmax(np.diff(d) / np.diff(L)))


def modes(row, lengths):
    """Which modes exist at ``lengths`` (the markers of the paper's Fig. 6).

    Returns two boolean arrays, ``(curvature_dominated, gravity_dominated)``.
    Bistable row: the curvature-dominated mode exists up to ``L1*``, the
    gravity-dominated one from ``L0*``, both in between.  Otherwise the sheet
    has one mode at each length, on either side of :func:`transition_length`
    (a flat clamp, ``a/R = 0``: gravity-dominated everywhere).

    Examples
    --------
    >>> row = {"bistable": True, "popup_length": 1.2, "standout_length": 1.35,
    ...        "curvature": 2.5}
    >>> [m.tolist() for m in modes(row, [1.0, 1.3, 1.5])]
    [[True, True, False], [False, True, True]]
    """
    L = np.asarray(lengths, float)
    if bool(row["bistable"]):
        return L <= row["standout_length"], L >= row["popup_length"]
    t = row.get("transition_length") if hasattr(row, "get") else None
    if t is None or not np.isfinite(t):
        t = transition_length(row)
    if t is None:
        return np.zeros(L.shape, bool), np.ones(L.shape, bool)
    return L < t, L >= t


def critical_tip_width(df) -> dict:
    """For each curvature: the critical shape factor ``(b/a)*`` of the map rows.

    Returns ``{curvature: (estimate, low, high)}``: the shape factors of the
    map are bistable from ``high`` up and not at ``low`` (the largest
    non-bistable one below ``high``), so ``(b/a)*`` is in ``[low, high]``;
    ``estimate`` extrapolates the width ``L1* - L0*`` of the two smallest
    bistable shape factors linearly to zero, clipped to the bracket.  A
    curvature with no bistable shape factor gives ``(nan, max b, nan)``; one
    bistable at every shape factor of the map gives ``(nan, nan, min b)``.

    Examples
    --------
    >>> import pandas as pd
    >>> df = pd.DataFrame({"curvature": [2.5] * 3, "tip_width": [0.6, 0.8, 1.0],
    ...                    "bistable": [False, True, True], "converged": [True] * 3,
    ...                    "bistable_width": [float("nan"), 0.05, 0.15]})
    >>> critical_tip_width(df)[2.5]
    (0.7, 0.6, 0.8)
    """
    out = {}
    for c, g in df[df["converged"]].groupby("curvature"):
        g = g.sort_values("tip_width")
        b = g["tip_width"].to_numpy(float)
        bi = g["bistable"].to_numpy(bool)
        w = g["bistable_width"].to_numpy(float)
        if not bi.any():
            out[float(c)] = (math.nan, float(b.max()), math.nan)
            continue
        # the bistable shape factors from the top down, until the first that is not
        first = len(b) - 1
        while first > 0 and bi[first - 1]:
            first -= 1
        if first == 0:
            out[float(c)] = (math.nan, math.nan, float(b[0]))
            continue
        lo, hi = float(b[first - 1]), float(b[first])
        est = 0.5 * (lo + hi)
        if first + 1 < len(b) and w[first + 1] > w[first] > 0:
            est = hi - w[first] * (b[first + 1] - hi) / (w[first + 1] - w[first])
            est = float(np.clip(est, lo, hi))
        out[float(c)] = (round(float(est), 10), lo, hi)
    return out


# -- the map from fold curves ----------------------------------------------------------------
#: Fold curves on meshes finer than the first of these are traced coarse to
#: fine (:data:`~skfem_sheet.bistability.FOLD_CURVE_LEVELS`, the one rule of
#: :func:`~skfem_sheet.bistability.fold_curve` too).
COARSE_HMAX = FOLD_CURVE_LEVELS
#: Points of the coarse curve refined (besides its ends and the cusp's neighbours).
FINE_POINTS = FOLD_CURVE_POINTS

#: Input parameters of one fold curve of the map and their defaults: ``second``
#: is the curve's second parameter, ``"tip_width"`` (the curve in (L, b/a)
#: at a/R = ``curvature``) or ``"curvature"`` (the curve in (L, a/R) at
#: b/a = ``tip_width``, from a/R = ``curvature`` down round the cusp where
#: bistability starts).
CURVE_PARAMETERS = {"curvature": 2.5, "second": "tip_width", "tip_width": 1.0, "hmax": 0.1,
                    "layers": None, "thickness": 0.03, "modulus": 735.0, "solver": "auto"}
_CURVE_NUMERIC = ("curvature", "tip_width", "hmax", "thickness", "modulus")
#: Columns of the fold-curve table: the folds at the start value (``L1*``,
#: ``L0*``), the cusp, the curve's points (JSON ``[[p_j, L, kind], ...]`` in
#: the order traced), the cost.  ``bistable`` is False (and the curve empty)
#: where the curvature-dominated branch at the start has no fold in the
#: length range; ``converged``: the curve came back to its start value, or
#: the sheet is not bistable there.
CURVE_COLUMNS = (*CURVE_PARAMETERS, "standout_length", "popup_length", "cusp_tip_width",
                 "cusp_curvature", "cusp_length", "cusp_located", "bistable", "completed",
                 "converged", "n_points", "factorizations", "factorizations_per_point",
                 "remeshes", "points", "message", "wall_time_s", "version", "key", "error",
                 "finished_at")
_CURVE_FLOAT = (*_CURVE_NUMERIC, "standout_length", "popup_length", "cusp_tip_width",
                "cusp_curvature", "cusp_length", "factorizations_per_point", "wall_time_s")
_CURVE_INT = ("layers", "n_points", "factorizations", "remeshes")
_CURVE_STR = ("second", "solver", "cusp_located", "points", "message", "version", "key",
              "error", "finished_at")


def _normalize_curve(point) -> dict:
    p = normalize_params(point, CURVE_PARAMETERS, _CURVE_NUMERIC, "fold-curve point")
    if p["second"] not in ("tip_width", "curvature"):
        raise ParameterError(f"second must be 'tip_width' or 'curvature', got {p['second']!r}")
    return p


def _curve_key(point) -> str:
    p = _normalize_curve({k: point[k] for k in CURVE_PARAMETERS if k in point})
    return hash_key(["fold-curve", *[[k, key_value(p[k])] for k in CURVE_PARAMETERS]])


def curve_points(curvatures, *, hmax: float = DEFAULT_HMAX, layers=None,
                 thickness: float = 0.03,
                 modulus: float = 735.0, solver: str = "auto", rectangle_from=None) -> list:
    """The fold curves of a map: one in (L, b/a) per curvature, and with
    ``rectangle_from = a/R`` one in (L, a/R) at b/a = 1 from that curvature
    down (its cusp: the curvature where the rectangle becomes bistable).

    Examples
    --------
    >>> pts = curve_points([1.0, 2.5], rectangle_from=2.5)
    >>> [(p["second"], p["curvature"]) for p in pts]
    [('tip_width', 1.0), ('tip_width', 2.5), ('curvature', 2.5)]
    """
    common = dict(hmax=hmax, layers=layers, thickness=thickness, modulus=modulus, solver=solver)
    pts = [_normalize_curve(dict(curvature=c, second="tip_width", tip_width=1.0, **common))
           for c in as_values("curvatures", curvatures)]
    if rectangle_from is not None:
        pts.append(_normalize_curve(dict(curvature=rectangle_from, second="curvature",
                                         tip_width=1.0, **common)))
    if len(pts) > MAX_POINTS:
        raise ParameterError(f"at most {MAX_POINTS} curves, got {len(pts)}")
    return pts


def _empty_curve_record(point, key):
    rec = dict(point)
    rec.update(standout_length=math.nan, popup_length=math.nan, cusp_tip_width=math.nan,
               cusp_curvature=math.nan, cusp_length=math.nan, cusp_located="", bistable=False,
               completed=False, converged=False, n_points=0, factorizations=None,
               factorizations_per_point=math.nan, remeshes=None, points="[]", message="",
               wall_time_s=math.nan, version=__version__, key=key, error="")
    return rec


def _run_curve_point(point) -> dict:
    """One fold curve; every exception becomes a failed record."""
    return computed_record(point, _curve_key, _empty_curve_record, _fill_curve_record)


def _fill_curve_record(point, rec) -> None:
    """Trace the fold curve of a point and put it into its record."""
    fine = point["hmax"] < COARSE_HMAX[0]
    common = dict(hmax=point["hmax"], layers=point["layers"], thickness=point["thickness"],
                  modulus=point["modulus"], solver=point["solver"],
                  check_inertia=5 if fine else 0,
                  coarse_hmax=COARSE_HMAX if fine else None, fine_points=FINE_POINTS)
    if point["second"] == "tip_width":
        c = trace_fold_curve(point["curvature"], **common)
    else:
        c = trace_curvature_fold_curve(point["tip_width"], point["curvature"], **common)
    j = c.second
    cusp = c.cusp or {}
    rec.update(standout_length=_nan(c.standout_length), popup_length=_nan(c.popup_length),
               cusp_tip_width=_nan(cusp.get("tip_width", point["tip_width"]
                                            if cusp and j == "curvature" else None)),
               cusp_curvature=_nan(cusp.get("curvature", point["curvature"]
                                            if cusp and j == "tip_width" else None)),
               cusp_length=_nan(cusp.get("length")), cusp_located=c.cusp_located,
               bistable=bool(c.bistable), completed=bool(c.completed),
               converged=bool(c.completed or not c.bistable), n_points=len(c.points),
               factorizations=int(c.factorizations),
               factorizations_per_point=float(c.factorizations_per_point),
               remeshes=int(c.remeshes), message=_curve_message(c),
               points=dumps_json([[round(p[j], 8), round(p["length"], 8), p["kind"]]
                                  for p in c.points], compact=True),
               wall_time_s=float(c.wall_time_s))


def _curve_message(c) -> str:
    """The curve's reason, and for a curve traced coarse to fine its levels."""
    if getattr(c, "coarse_hmax", None) is None:
        return c.reason
    levels = "; ".join(f"hmax {st['hmax']:g}: {st['points']} points, {st['failed']} failed, "
                       f"{st['factorizations']} factorisations"
                       + (f" ({st['factorizations_per_point']:g} per point)"
                          if st["factorizations_per_point"] is not None else "")
                       for st in c.stages)
    text = (f"coarse to fine: traced at hmax {c.coarse_hmax:g} ({c.coarse_points} points, "
            f"{c.coarse_factorizations} factorisations); {levels}")
    return f"{c.reason} [{text}]" if c.reason else text


def _curve_frame(records):
    return typed_frame(records, CURVE_COLUMNS, floats=_CURVE_FLOAT, ints=_CURVE_INT,
                       bools=("bistable", "completed", "converged"), strings=_CURVE_STR)


_CURVE_JOB = Job(task=EachPoint(__name__, "_run_curve_point"),
                 failed=functools.partial(failed_record, _empty_curve_record, _curve_key),
                 frame=_curve_frame, key_of=_curve_key, required=("curvature", "second", "converged"),
                 desc="fold curves")


def _curve_chunks(points, n_workers):
    """One curve per task, the strongest curvature (the longest curve) first."""
    return [[p] for p in sorted(points, key=lambda p: -p["curvature"])]


def fold_curves(points, table=None, workers=None, scheduler=None, progress=True, *,
                retry_failed=False):
    """Trace the fold curves ``points`` (:func:`curve_points`) in parallel, resumably.

    The same runner as :func:`fold_map` (journal beside ``table``, local
    processes or Dask): a curve already journalled is not traced again.

    Returns
    -------
    pandas.DataFrame
        One row per curve (:data:`CURVE_COLUMNS`); read it with
        :func:`curve_halves` and :func:`critical_curve`.
    """
    points = study_points(points, _normalize_curve, "curve_points")
    path = check_run(table, workers, scheduler)
    keys = [_curve_key(p) for p in points]
    done, stats = execute(points, keys, _CURVE_JOB, table=path, workers=workers,
                          scheduler=scheduler, progress=progress, retry_failed=retry_failed,
                          chunker=_curve_chunks)
    df = _curve_frame(done[k] for k in keys)
    df.attrs["fold_curves"] = stats
    return df


def curve_halves(row):
    """The two folds of a fold-curve row, split at the cusp.

    Returns ``None`` (no points) or a dict: ``standout`` and ``popup``, each
    ``(q, L)`` arrays sorted by the second parameter ``q`` (b/a, or a/R for a
    curve in (L, a/R)), both starting at the turning point of ``q`` (the
    cusp), and ``cusp`` = ``(q*, L*)`` (None if the curve did not turn).
    The points before the turning point (in the order traced, from the start
    value) are the standout fold ``L1*``, those after it the pop-up fold; the
    point at the turn goes with its ``kind`` (with both if the kinds do not
    change along the curve).

    Examples
    --------
    >>> row = {"points": "[[1,1.35,\\"standout\\"],[0.6,1.25,\\"standout\\"],"
    ...                  "[1,1.2,\\"popup\\"]]", "cusp_tip_width": 0.6, "cusp_length": 1.25,
    ...        "second": "tip_width"}
    >>> h = curve_halves(row)
    >>> h["standout"][0].tolist(), h["popup"][1].tolist(), h["cusp"]
    ([0.6, 1.0], [1.25, 1.2], (0.6, 1.25))
    """
    text = row["points"]
    data = json.loads(text) if isinstance(text, str) and text else []
    if not data:
        return None
    q = np.array([d[0] for d in data], float)
    L = np.array([d[1] for d in data], float)
    k = int(np.argmin(q))
    name = "cusp_tip_width" if row["second"] == "tip_width" else "cusp_curvature"
    cq, cL = float(row[name]), float(row["cusp_length"])
    turned = 0 < k < len(q) - 1 and np.isfinite(cq) and np.isfinite(cL)
    if not turned:
        order = np.argsort(q)
        return {"standout": (q[order], L[order]), "popup": (np.empty(0), np.empty(0)),
                "cusp": None}
    kinds = [d[2] if len(d) > 2 else "" for d in data]
    up, down = slice(0, k + 1), slice(k, len(q))
    if kinds[0] == "standout" and kinds[-1] == "popup":  # the kinds say where the point at k is
        up, down = (slice(0, k + 1), slice(k + 1, len(q))) if kinds[k] == "standout" else \
            (slice(0, k), slice(k, len(q)))
    halves = {}
    for name, sl in (("standout", up), ("popup", down)):
        qq, LL = q[sl], L[sl]
        keep = qq > cq  # the cusp itself first, then the points beyond it
        qq, LL = np.concatenate([[cq], qq[keep]]), np.concatenate([[cL], LL[keep]])
        order = np.argsort(qq, kind="stable")
        halves[name] = (qq[order], LL[order])
    halves["cusp"] = (cq, cL)
    return halves


def critical_curve(df) -> list:
    """The critical curve ``[(b*, a/R, L*)]`` of a fold-curve table, ascending in a/R.

    One point per bistable curve in (L, b/a) with a cusp, and the cusp
    ``(1, a/R*, L*)`` of a curve in (L, a/R) at b/a = 1 (where the rectangle
    becomes bistable).

    Examples
    --------
    >>> import pandas as pd
    >>> df = pd.DataFrame([dict(second="tip_width", curvature=2.5, tip_width=1.0,
    ...                         cusp_tip_width=0.63, cusp_curvature=2.5, cusp_length=1.25,
    ...                         bistable=True, error=""),
    ...                    dict(second="curvature", curvature=2.5, tip_width=1.0,
    ...                         cusp_tip_width=1.0, cusp_curvature=1.1, cusp_length=0.9,
    ...                         bistable=True, error="")])
    >>> critical_curve(df)
    [(1.0, 1.1, 0.9), (0.63, 2.5, 1.25)]
    """
    out = []
    for _, r in df.iterrows():
        if r.get("error") or not bool(r["bistable"]):
            continue
        b, c, L = (float(r[k]) for k in ("cusp_tip_width", "cusp_curvature", "cusp_length"))
        if np.isfinite(b) and np.isfinite(c) and np.isfinite(L):
            out.append((b, c, L))
    return sorted(out, key=lambda p: (p[1], -p[0]))
