"""Parameter sweeps: a grid of sheets solved in parallel into one resumable table.

:func:`grid` expands parameter lists into points (their cartesian product);
:func:`run_sweep` solves them on local processes (default), in this process
(``workers=1``) or on a Dask cluster (``scheduler=``), and returns one tidy
:class:`pandas.DataFrame` (one row per point).  With ``table="results.csv"``
(or ``.parquet``) every finished point is journalled at once beside the
table, the table is rebuilt from the journal atomically, and a point whose
key is in the journal is not computed again, so an interrupted sweep resumes
where it stopped (:mod:`skfem_sheet.studies.runner`).

A point's ``key`` is a hash of its input parameters (:data:`PARAMETERS`) and
of the solve options :data:`OPTIONS` that differ from their frozen key
defaults (``refine`` 0, ``symmetric`` True, ``start`` "path", ``coarse_hmax``
0.1: an option at its key default is left out, so older journals keep their
keys), after normalisation: numbers rounded to 10 significant digits (``1.3``
and ``1.3000000000000003`` are one point; the rounded values are the ones
solved).  ``coarse_hmax`` enters as the coarse mesh the point is solved with.
The package version is a column, not part of the key.

A failed solve, a bad parameter and any other exception of one point are rows
with ``converged=False``, the reason in ``message`` and the exception class in
``error``; the sweep carries on (``retry_failed=True`` computes them again).
Ctrl-C stops the sweep within about a second, keeps the finished points and
raises :class:`~skfem_sheet.studies.runner.StudyInterrupted`.

Columns (:data:`COLUMNS`): the parameters, the options, the row of
:meth:`skfem_sheet.solve.Result.to_record` (the one definition of a result
row), ``version``, ``key``, ``error``, ``finished_at`` (UTC), and
``bistable`` (:func:`bistable_column`).  Work is grouped by mesh: the points
of one mesh go to one worker in chunks that share one
:class:`~skfem_sheet.build.BuildChain`.  Local workers are ``spawn``-ed,
each with ``cpu_count // workers`` BLAS threads unless the thread variables
are set; results do not depend on the executor.  Dask needs the ``cluster``
extra, Parquet the ``parquet`` extra.

Command line (:mod:`skfem_sheet.cli.sweep`)::

    python -m skfem_sheet sweep --lengths 0.5:1.5:0.25 --tip-widths 1,0 \\
        --curvatures 0,2.5 --paths both --hmax 0.1 --table out.csv \\
        [--refine 0,1] [--symmetric both] \\
        [--workers N] [--scheduler tcp://host:port] [--retry-failed] [--quiet]

Examples
--------
>>> from skfem_sheet.studies.sweep import grid, run_sweep
>>> points = grid(length=0.3, curvature=[0.0, 2.5], hmax=0.2)
>>> len(points), points[1]["curvature"], points[1]["path"]
(2, 2.5, 'curvature-first')
>>> df = run_sweep(points, workers=1, progress=False)
>>> df[["curvature", "converged", "branch"]].values.tolist()
[[0.0, True, 'gravity-dominated'], [2.5, True, 'curvature-dominated']]
"""
from __future__ import annotations

import functools
import inspect
import itertools
import math

import numpy as np

from ..build import BuildChain
from ..continuation import PATHS
from ..linalg import SOLVERS, available_solvers
from ..mesh import estimate_dofs
from ..params import DEFAULT_HMAX, ParameterError, Sheet
from ..solve import MAX_DOFS, STARTS, CoarseStart, Result, solve
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
    journal_path,
    key_value,
    normalize_int,
    normalize_number,
    normalize_params,
    study_points,
    typed_frame,
)
from .runner import read_journal as _read_journal

__all__ = ["grid", "run_sweep", "sweep", "point_key", "normalize_point", "read_journal",
           "journal_path", "check_point", "bistable_column", "PARAMETERS", "OPTIONS", "COLUMNS",
           "SAME_DEFLECTION"]

#: Input parameters of a point, with their defaults (those of Sheet and solve).
#: ``length`` has no default.
PARAMETERS = {"length": None, "tip_width": 1.0, "curvature": 0.0, "thickness": 0.03,
              "modulus": 735.0, "path": "curvature-first", "hmax": 0.03, "layers": None,
              "solver": "auto"}
_NUMERIC = ("length", "tip_width", "curvature", "thickness", "modulus", "hmax")
_SHEET = ("length", "tip_width", "curvature", "thickness", "modulus")

_SOLVE_DEFAULTS = {name: p.default for name, p in inspect.signature(solve).parameters.items()
                   if p.default is not inspect.Parameter.empty}
#: Solve options that can be swept, with their defaults: the keyword arguments
#: of :func:`~skfem_sheet.solve.solve` that :meth:`Result.to_record` reports
#: (a new one there is a new sweep parameter here).  In a point only when not
#: at the default.
OPTIONS = {name: _SOLVE_DEFAULTS[name] for name, _, _ in Result.RECORD_FIELDS
           if name in _SOLVE_DEFAULTS and name not in PARAMETERS}

#: The values of the solve options that a point's key leaves out, frozen: the
#: defaults ``solve`` had when each option became part of the key.  A journal
#: line without an option was solved with this value (it predates the option,
#: or the option was at this value), so a key never changes meaning when a
#: default of ``solve`` changes: since ``start="coarse"`` became the default,
#: a point at the default has ``start`` in its key and an old row (solved
#: along the load path on its own mesh, ``start="path"``) is never reused for
#: it.  A new option of ``solve`` must be added here with the default it has
#: when it is added (a test checks that every option is here).
_KEY_DEFAULTS = {"refine": 0, "symmetric": True, "start": "path", "coarse_hmax": 0.1,
                 "gravity": 1.0}

#: Kinds of the outputs of a row (``Result.to_record`` minus the parameters).
_OUTPUTS = {name: kind for name, kind, _ in Result.RECORD_FIELDS
            if name not in PARAMETERS and name not in OPTIONS}
_KINDS = {**{name: kind for name, kind, _ in Result.RECORD_FIELDS}, "layers": "int",
          "solver": "str", "version": "str", "key": "str", "error": "str",
          "finished_at": "str", "bistable": "bool?"}

#: Parameters that fix the mesh: points sharing them share a chunk's build chain.
_MESH = ("length", "tip_width", "thickness", "hmax", "layers", *OPTIONS)
_PATHS = ("curvature-first", "gravity-first")

#: Columns of the table, in order.
COLUMNS = (*PARAMETERS, *OPTIONS, *_OUTPUTS, "version", "key", "error", "finished_at",
           "bistable")

#: Two end states whose tip deflections differ by at most this (units of a) are
#: one state (the two paths' polished end states agree to about 1e-9 where they
#: reach one; the two states of a bistable sheet differ by tenths).
SAME_DEFLECTION = 1e-6


def _of_kind(kind):
    return tuple(c for c in COLUMNS if _KINDS[c] == kind)


# -- points, keys ----------------------------------------------------------------------
def _norm_option(v, default):
    """An option value normalised like its default (bool, whole number, float)."""
    if isinstance(default, bool):
        return bool(v) if isinstance(v, (bool, np.bool_)) else v
    if isinstance(default, int):
        return normalize_int(v)
    if isinstance(default, float):
        return normalize_number(v)
    return v


def normalize_point(point) -> dict:
    """A point with every parameter present, in order, and numbers normalised.

    Missing parameters get their defaults (:data:`PARAMETERS`); numbers are
    rounded to 10 significant digits; ``layers`` that are whole numbers become
    ``int``.  The solve options (:data:`OPTIONS`) follow, normalised the same
    way, only those that differ from ``solve``'s defaults (the key,
    :func:`point_key`, is made with the frozen key defaults instead).  Raises ``ParameterError``
    for an unknown parameter name or a missing ``length``.

    Examples
    --------
    >>> normalize_point({"length": 1.3000000000000003, "layers": 2.0})
    ... # doctest: +NORMALIZE_WHITESPACE
    {'length': 1.3, 'tip_width': 1.0, 'curvature': 0.0, 'thickness': 0.03,
     'modulus': 735.0, 'path': 'curvature-first', 'hmax': 0.03, 'layers': 2,
     'solver': 'auto'}
    >>> normalize_point({"length": 1.0, "refine": 1.0, "symmetric": True})["refine"]
    1
    """
    if not isinstance(point, dict):
        raise ParameterError(f"points must be dicts of parameters, got {type(point).__name__}")
    unknown = [k for k in point if k not in PARAMETERS and k not in OPTIONS]
    if unknown:
        raise ParameterError(f"point parameter {unknown[0]!r} is unknown; "
                             f"allowed: {', '.join([*PARAMETERS, *OPTIONS])}")
    out = normalize_params({k: v for k, v in point.items() if k in PARAMETERS}, PARAMETERS,
                           _NUMERIC, "point")
    if "length" not in point:
        raise ParameterError("every point needs a length")
    for name, default in OPTIONS.items():
        if name in point:
            v = _norm_option(point[name], default)
            if not (type(v) is type(default) and v == default):
                out[name] = v
    return out


def point_key(point) -> str:
    """Stable hash (16 hex digits) of a point's normalised input parameters.

    A solve option missing from ``point`` is ``solve``'s default; it is part
    of the key unless it is at its frozen key default (:data:`_KEY_DEFAULTS`,
    ``refine=0, symmetric=True, start="path", coarse_hmax=0.1``), so keys of
    old points stay valid and mean what they meant when they were made.

    Examples
    --------
    >>> point_key({"length": 1.3}) == point_key({"length": 1.30000000001, "curvature": -0.0})
    True
    >>> point_key({"length": 1.3}) == point_key({"length": 1.31})
    False
    >>> point_key({"length": 1.3}) == point_key({"length": 1.3, "refine": 0})
    True
    >>> point_key({"length": 1.3}) == point_key({"length": 1.3, "start": "path"})
    False
    """
    p = {**OPTIONS, **normalize_point(point)}
    p["coarse_hmax"] = _coarse_mesh(p)
    return hash_key([[k, key_value(p[k])] for k in PARAMETERS]
                    + [[k, key_value(p[k])] for k in OPTIONS
                       if not _at_key_default(k, p[k])])


def _coarse_mesh(p) -> float:
    """The coarse mesh a normalised point is solved with: ``coarse_hmax``, or
    (None, ``solve``'s default) the one the coarse start chooses for its
    ``hmax`` (:meth:`~skfem_sheet.starts.CoarseStart.coarse_mesh`: 0.1 for
    hmax up to 0.05, the value that was the default); a point on the path
    (``start="path"``) has none, and its key the key default."""
    if p["start"] != "coarse":
        return _KEY_DEFAULTS["coarse_hmax"]
    return normalize_number(CoarseStart(hmax=p["coarse_hmax"]).coarse_mesh(p["hmax"]))


def _at_key_default(name, value) -> bool:
    default = _KEY_DEFAULTS[name]
    v = _norm_option(value, default)
    return type(v) is type(default) and v == default


def grid(length, tip_width=1.0, curvature=0.0, thickness=0.03, modulus=735.0,
         path="curvature-first", hmax=0.03, layers=None, solver="auto", **options) -> list:
    """The cartesian product of parameter values, as a list of points (dicts).

    Every argument is a single value or a list (tuple, array, range) of values;
    ``path="both"`` means both load paths; ``options`` are solve options
    (:data:`OPTIONS`: ``refine``, ``symmetric``).  Points come in the order of
    nested loops over the arguments in signature order (``length`` outermost,
    then ``solver``, then the options innermost), normalised (see
    :func:`normalize_point`).  Values are not checked here: a bad one becomes a
    failed row in :func:`run_sweep`.

    Examples
    --------
    >>> pts = grid(length=[1.0, 1.3], tip_width=[1.0, 0.0], curvature=[0.0, 2.5],
    ...            path="both", hmax=0.1)
    >>> len(pts), pts[0]["path"], pts[1]["path"], pts[-1]["length"]
    (16, 'curvature-first', 'gravity-first', 1.3)
    >>> [p.get("refine", 0) for p in grid(length=1.0, refine=[0, 1])]
    [0, 1]
    """
    for name in options:
        if name not in OPTIONS:
            raise TypeError(f"grid() got an unexpected keyword argument {name!r}")
    args = dict(length=length, tip_width=tip_width, curvature=curvature, thickness=thickness,
                modulus=modulus, path=path, hmax=hmax, layers=layers, solver=solver,
                **{name: options[name] for name in OPTIONS if name in options})
    lists = {}
    for name, v in args.items():
        vals = as_values(name, v)
        if name == "path":
            vals = [q for p in vals for q in (_PATHS if p == "both" else (p,))]
        lists[name] = vals
    n = math.prod(len(v) for v in lists.values())
    if n > MAX_POINTS:
        raise ParameterError(f"grid must have at most {MAX_POINTS} points, got {n}")
    return [normalize_point(dict(zip(lists, combo)))
            for combo in itertools.product(*lists.values())]


def check_point(point) -> None:
    """Raise ParameterError for a point ``solve`` would refuse (the CLI checks up front).

    The checks are those of :func:`~skfem_sheet.solve.solve`, with the same
    size estimate (the symmetric half when ``symmetric``, refined ``refine``
    times): a point that ``solve`` accepts is accepted here.
    """
    p = {**OPTIONS, **normalize_point(point)}
    sheet = Sheet(**{k: p[k] for k in _SHEET})
    if p["path"] not in PATHS:
        raise ParameterError(f"path must be one of {', '.join(PATHS)}, got {p['path']!r}")
    if p["solver"] not in SOLVERS:
        raise ParameterError(f"solver must be one of {', '.join(SOLVERS)}, got {p['solver']!r}")
    if p["solver"] != "auto" and p["solver"] not in available_solvers():
        raise ParameterError(f"solver {p['solver']!r} is not installed here; available: "
                             f"{', '.join(available_solvers())} (pardiso: pip install "
                             "'skfem_sheet[fast]')")
    if not isinstance(p["symmetric"], (bool, np.bool_)):
        raise ParameterError(f"symmetric must be True or False, got {p['symmetric']!r}")
    if p["start"] not in STARTS:
        raise ParameterError(f"start must be one of {', '.join(STARTS)}, got {p['start']!r}")
    refine = p["refine"]
    n = estimate_dofs(sheet, p["hmax"], p["layers"], half=bool(p["symmetric"]), refine=refine)
    if n > MAX_DOFS:
        what = f"hmax={p['hmax']:g}" + (f" with refine={refine}" if refine else "")
        raise ParameterError(f"hmax must be larger{' or refine smaller' if refine else ''}: "
                             f"{what} gives about {n:,} unknowns, "
                             f"more than the {MAX_DOFS:,} that fit in memory here")


# -- one point (runs in the workers) -------------------------------------------------------
def _record(point, key):
    """The record of a point before (or without) its solve: outputs missing."""
    rec = dict(point)
    for name, default in OPTIONS.items():
        rec.setdefault(name, default)
    rec["coarse_hmax"] = _coarse_mesh(rec)
    rec.update({name: math.nan if kind == "float" else False if kind == "bool" else None
                for name, kind in _OUTPUTS.items()})
    rec.update(message="", version=__version__, key=key, error="")
    return rec


def _chain() -> BuildChain:
    """The build chain of one chunk: its points are on one mesh (and one
    coarse mesh of the coarse start), built once for all of them."""
    return BuildChain(max_meshes=2)


def _run_point(point, chain=None) -> dict:
    """Solve one normalised point (with the chunk's build ``chain``); every
    ``Exception`` becomes a failed record."""
    return computed_record(point, point_key, _record,
                           functools.partial(_fill_record, chain=chain))


def _fill_record(point, rec, chain=None) -> None:
    """Solve a sweep point and put the outputs of ``Result.to_record`` into its record."""
    sheet = Sheet(**{k: point[k] for k in _SHEET})
    r = solve(sheet, path=point["path"], hmax=point["hmax"], layers=point["layers"],
              solver=point["solver"], on_failure="return", progress=False, chain=chain,
              **{name: rec[name] for name in OPTIONS})
    rec.update({k: v for k, v in r.to_record().items() if k in _OUTPUTS})


#: Solve points in sequence (same mesh: one build chain for the chunk).
_run_chunk = EachPoint(__name__, "_run_point", "_chain")
#: The record of a point whose task failed outside the solve (e.g. its worker died).
_failed = functools.partial(failed_record, _record, point_key)


# -- journal and table ---------------------------------------------------------------------
def _sweep_key(rec):
    # an option missing from a journal line is its frozen key default (the line
    # predates the option), not today's default of solve
    return point_key({**_KEY_DEFAULTS,
                      **{k: rec[k] for k in (*PARAMETERS, *OPTIONS) if k in rec}})


def read_journal(path, *, key_of=None, required=("length", "deflection", "converged")) -> dict:
    """Finished points of a sweep's journal, ``{key: record}`` in order of first appearance.

    See :func:`skfem_sheet.studies.runner.read_journal`; keys are recomputed
    with ``key_of(record)``, by default :func:`point_key` of the sweep
    parameters.

    Examples
    --------
    >>> import os, tempfile
    >>> f = os.path.join(tempfile.mkdtemp(), "j.jsonl")
    >>> with open(f, "w") as fh:
    ...     _ = fh.write('{"length": 1.0, "deflection": 0.5, "converged": true}\\n{"len')
    >>> [r["deflection"] for r in read_journal(f).values()]
    [0.5]
    """
    return _read_journal(path, key_of=key_of or _sweep_key, required=required)


def bistable_column(records) -> list:
    """``bistable`` of each record: for a sheet (every parameter and option but
    the path) solved along both load paths, True where the two end states
    are two distinct stable states (their deflections differ by more than
    :data:`SAME_DEFLECTION`, both converged and stable), False where they
    are one state or a distinct one is unstable, None where a path is
    missing or failed or a stability is unknown.

    Examples
    --------
    >>> base = dict(length=1.3, curvature=2.5, converged=True, stable=True)
    >>> bistable_column([dict(base, path="curvature-first", deflection=0.05),
    ...                  dict(base, path="gravity-first", deflection=0.57),
    ...                  dict(base, length=0.5, path="curvature-first", deflection=0.01)])
    [True, True, None]
    """
    records = list(records)
    sheet = [k for k in (*PARAMETERS, *OPTIONS) if k != "path"]

    def ident(r):
        return tuple(key_value(r.get(k, OPTIONS.get(k, PARAMETERS.get(k)))) for k in sheet)

    groups = {}
    for r in records:
        groups.setdefault(ident(r), {})[r.get("path")] = r
    out = []
    for r in records:
        pair = groups[ident(r)]
        a, b = pair.get("curvature-first"), pair.get("gravity-first")
        if a is None or b is None or not (a.get("converged") and b.get("converged")):
            out.append(None)
            continue
        da, db = a.get("deflection"), b.get("deflection")
        if da is None or db is None or not (math.isfinite(da) and math.isfinite(db)):
            out.append(None)
        elif abs(da - db) <= SAME_DEFLECTION:
            out.append(False)
        else:
            st = [x.get("stable") for x in (a, b)]
            out.append(None if any(v is None or v != v for v in st)
                       else bool(all(bool(v) for v in st)))
    return out


def _frame(records):
    """A DataFrame with the table's columns and dtypes (options missing from
    older journal lines are their frozen key defaults: what they were solved with),
    and the ``bistable`` column of the pairs of paths among them."""
    records = [{**_KEY_DEFAULTS, **r} for r in records]
    for r, b in zip(records, bistable_column(records)):
        r["bistable"] = b
    return typed_frame(records, COLUMNS, floats=_of_kind("float"),
                       ints=_of_kind("int"), bools_or_na=_of_kind("bool?"),
                       bools=_of_kind("bool"), strings=_of_kind("str"))


def _chunks(points, n_workers, chunk_size=None):
    """Group points by mesh (sorted) and cut the groups into chunks."""
    def orderable(v):
        return (0, v, "") if isinstance(v, (int, float)) and not isinstance(v, bool) \
            else (1, 0.0, repr(v))

    def mesh_key(p):
        return tuple(orderable(p.get(k, OPTIONS.get(k))) for k in _MESH)

    rest = [k for k in PARAMETERS if k not in _MESH]
    pts = sorted(points, key=lambda p: (mesh_key(p), tuple(orderable(p[k]) for k in rest)))
    if chunk_size is None:
        chunk_size = max(1, min(8, math.ceil(len(pts) / (4 * max(1, n_workers)))))
    out = []
    for _, group in itertools.groupby(pts, key=mesh_key):
        group = list(group)
        out.extend(group[i:i + chunk_size] for i in range(0, len(group), chunk_size))
    return out


_JOB = Job(task=_run_chunk, failed=_failed, frame=_frame, key_of=_sweep_key,
           required=("length", "deflection", "converged"), desc="sweep")


# -- the sweep -----------------------------------------------------------------------------
def run_sweep(points, table=None, workers=None, scheduler=None, progress=True, *,
              retry_failed=False, chunk_size=None):
    """Solve every point and return the table (one row per point, in order).

    Parameters
    ----------
    points : list of dict
        Points from :func:`grid`, or dicts of :data:`PARAMETERS` and
        :data:`OPTIONS` (``length`` required, others default).  The same
        point given twice is solved once and gives two rows.
    table : str or path, optional
        ``.csv`` or ``.parquet`` file for the results, with its journal
        ``<table>.journal.jsonl`` (see the module docstring): points already in
        the journal are not computed again.  The table holds every point of
        the journal (this sweep's first, in order).  Without ``table`` nothing
        is written and nothing resumes.
    workers : int, optional
        Local processes (default ``os.cpu_count()``); 1 solves in this process.
    scheduler : str or distributed.Client, optional
        Solve on a Dask cluster instead: its address (``"tcp://host:8786"``)
        or a client.  Needs the ``cluster`` extra.
    progress : bool
        Progress bar on stderr (finished/total, failures).
    retry_failed : bool
        Compute again the points whose stored row is not converged.
    chunk_size : int, optional
        Points per task (default: up to 8, about four tasks per worker).

    Returns
    -------
    pandas.DataFrame
        Columns :data:`COLUMNS`; ``df.attrs["sweep"]`` holds the counts ``new``
        and ``cached`` and the ``table`` and ``journal`` paths.

    Raises
    ------
    ParameterError
        For a bad ``points``/``table``/``workers``/``scheduler`` argument (bad
        parameter values of a point give failed rows instead).
    StudyInterrupted
        On Ctrl-C (a ``KeyboardInterrupt``), after writing the table of the
        points finished so far; it says how many, and where.

    Examples
    --------
    >>> df = run_sweep([{"length": 0.3, "hmax": 0.2}], workers=1, progress=False)
    >>> len(df), bool(df.converged[0]), round(float(df.deflection[0]), 3)
    (1, True, 0.011)
    """
    points = study_points(points, normalize_point, "grid")
    if len(points) > MAX_POINTS:
        raise ParameterError(f"points must be at most {MAX_POINTS}, got {len(points)}")
    if chunk_size is not None and (not isinstance(chunk_size, int) or chunk_size < 1):
        raise ParameterError(f"chunk_size must be an integer >= 1, got {chunk_size!r}")
    path = check_run(table, workers, scheduler)
    keys = [point_key(p) for p in points]
    done, stats = execute(points, keys, _JOB, table=path, workers=workers, scheduler=scheduler,
                          progress=progress, retry_failed=retry_failed,
                          chunker=lambda todo, n: _chunks(todo, n, chunk_size))
    df = _frame(done[k] for k in keys)
    df.attrs["sweep"] = stats
    return df


def sweep(sheet: Sheet, table=None, *, path="curvature-first", hmax=DEFAULT_HMAX,
          workers=None, scheduler=None, progress=True, retry_failed=False, **grid_values):
    """Solve a family of sheets around ``sheet`` into one resumable table.

    The grid is ``sheet``'s parameters with those given in ``grid_values``
    replaced by lists of values (any of ``length``, ``tip_width``,
    ``curvature``, ``thickness``, ``modulus``, ``layers``, ``solver`` and the
    solve options :data:`OPTIONS`), along ``path`` (``"both"``: both load
    paths, and the ``bistable`` column says which sheets have two stable
    states); the rest is :func:`run_sweep` (``table``, ``workers``,
    ``scheduler``, ``retry_failed``: resumable, on local processes or Dask).

    Examples
    --------
    >>> df = sweep(Sheet(length=1.3, curvature=2.5), hmax=0.25, path="both",
    ...            length=[0.5, 1.3], workers=1, progress=False)
    >>> df.groupby("length").bistable.first().tolist()
    [False, True]
    """
    if not isinstance(sheet, Sheet):
        raise ParameterError(f"sheet must be a skfem_sheet.Sheet, got {type(sheet).__name__}")
    if sheet.planform is not None:
        raise ParameterError("sweep varies a trapezoid's parameters (length, tip_width, ...): "
                             "a sheet with a planform cannot be swept here; solve each with "
                             "solve(), or sweep its length with fold_lengths(..., "
                             "branches=True)")
    unknown = [k for k in grid_values if k not in PARAMETERS and k not in OPTIONS]
    if unknown or "path" in grid_values or "hmax" in grid_values:
        bad = unknown[0] if unknown else ("path" if "path" in grid_values else "hmax")
        raise ParameterError(f"{bad} is not a grid parameter of sweep (path and hmax are "
                             f"its own arguments); allowed: "
                             f"{', '.join(k for k in (*PARAMETERS, *OPTIONS) if k not in ('path', 'hmax'))}")
    base = {k: getattr(sheet, k) for k in _SHEET}
    points = grid(**{**base, **grid_values, "path": path, "hmax": hmax})
    return run_sweep(points, table, workers=workers, scheduler=scheduler, progress=progress,
                     retry_failed=retry_failed)
