"""Parameter sweeps: a grid of sheets solved in parallel into one resumable table.

:func:`grid` expands parameter lists into points (their cartesian product);
:func:`run_sweep` solves them on local processes (default), in this process
(``workers=1``) or on a Dask cluster (``scheduler=``), and returns one tidy
:class:`pandas.DataFrame` (one row per point).  With ``table="results.csv"``
(or ``.parquet``) the results survive interruption:

- every finished point is appended at once to a journal beside the table,
  ``results.csv.journal.jsonl``: one JSON line per point, written by the parent
  process with a single ``os.write`` on an ``O_APPEND`` descriptor, then
  ``os.fsync``.  A line cut short by a crash is ignored when reading, and lines
  with the same key are collapsed (the last wins);
- the table is rebuilt from the journal and replaced atomically (temporary file
  + ``os.replace``) every 30 s and at the end, so it is never half written;
- a point whose key is already in the journal is not computed again, so a sweep
  killed in any way (Ctrl-C, ``kill -9``, a lost machine) resumes where it
  stopped, and re-running a finished sweep computes nothing.

A point is identified by ``key``, a hash of its input parameters (``length,
tip_width, curvature, thickness, modulus, path, hmax, layers, solver``) after
normalisation: numbers are rounded to 10 significant digits (and ``-0.0`` is
``0.0``, ``2.0`` layers is ``2``), so ``1.3``, ``1.30000000001`` and
``np.arange(...)``'s ``1.3000000000000003`` are the same point.  The rounded
values are the ones solved and stored in the table.  The package version is a
column, not part of the key: re-running after an upgrade reuses old results
(start a new table to recompute them).

A failed solve (full load not reached), a bad parameter (``ParameterError``)
and any other exception raised while solving one point are rows with
``converged=False`` and the reason in ``message`` (the exception class in
``error``); the sweep carries on.  They are finished points too: pass
``retry_failed=True`` to compute them again.  Ctrl-C stops the sweep at once
(finished points are kept; the table is written) and re-raises
``KeyboardInterrupt``.

Columns of the table (:data:`COLUMNS`): the parameters, then ``deflection``
(d/a, positive down), ``converged``, ``message``, ``branch``
("curvature-dominated" or "gravity-dominated": ``Result.branch`` when the solver
provides it, else the load path's own branch, switched when the path snapped --
a label of the load path, not a classification of the shape: a long sheet whose
curvature-first path droops gradually, without a detected snap, keeps the label
"curvature-dominated"; for the physical modes use the fold map,
:func:`skfem_sheet.foldmap.modes`),
``stable`` (``Result.stable``, empty when unknown), ``snapped``,
``newton_iterations``, ``load_steps``, ``wall_time_s``, ``assembly_s``,
``linear_solve_s``, ``dofs``, ``energy``, ``volume_change``, ``version``,
``key``, ``error``, ``kappa_reached``, ``gravity_reached``, ``factorizations``,
``rejected_steps``, ``linear_solver`` (back-end used), ``layers_used``,
``finished_at`` (UTC).  The journal lines also hold ``host``, ``pid`` and, for
exceptions, ``traceback``.

Work is grouped by mesh (``length, tip_width, thickness, hmax, layers``): the
points of one mesh go to the same worker in sequence, in chunks, and reuse its
cached mesh.  Local workers are ``spawn``-ed processes (safe with MKL and
gmsh), each limited to ``cpu_count // workers`` BLAS/MKL threads unless
``OMP_NUM_THREADS``/``MKL_NUM_THREADS``/``OPENBLAS_NUM_THREADS`` are set (Dask
workers get one thread from their nanny).  Results do not depend on the
executor.  Dask needs the ``cluster`` extra: ``pip install 'skfem_sheet[cluster]'``;
Parquet tables need ``pip install 'skfem_sheet[parquet]'``.

Command line::

    python -m skfem_sheet sweep --lengths 0.5:1.5:0.25 --tip-widths 1,0 \\
        --curvatures 0,2.5 --paths both --hmax 0.1 --table out.csv \\
        [--workers N] [--scheduler tcp://host:port] [--retry-failed] [--quiet]

Examples
--------
>>> from skfem_sheet.sweep import grid, run_sweep
>>> points = grid(length=0.3, curvature=[0.0, 2.5], hmax=0.2)
>>> len(points), points[1]["curvature"], points[1]["path"]
(2, 2.5, 'curvature-first')
>>> df = run_sweep(points, workers=1, progress=False)
>>> df[["curvature", "converged", "branch"]].values.tolist()
[[0.0, True, 'curvature-dominated'], [2.5, True, 'curvature-dominated']]
"""
from __future__ import annotations

import contextlib
import hashlib
import itertools
import json
import math
import os
import signal
import socket
import sys
import tempfile
import time
import traceback
from datetime import datetime, timezone

from .params import ParameterError, Sheet
from .solve import solve

__all__ = ["grid", "run_sweep", "point_key", "normalize_point", "read_journal",
           "journal_path", "parse_values", "add_sweep_subparser", "PARAMETERS", "COLUMNS"]

#: Input parameters of a point, with their defaults (those of Sheet and solve).
#: ``length`` has no default.
PARAMETERS = {"length": None, "tip_width": 1.0, "curvature": 0.0, "thickness": 0.03,
              "modulus": 735.0, "path": "curvature-first", "hmax": 0.03, "layers": None,
              "solver": "auto"}
_NUMERIC = ("length", "tip_width", "curvature", "thickness", "modulus", "hmax")
#: Parameters that fix the mesh: points sharing them reuse a worker's cached mesh.
_MESH = ("length", "tip_width", "thickness", "hmax", "layers")
_PATHS = ("curvature-first", "gravity-first")
_BRANCH = {"curvature-first": "curvature-dominated", "gravity-first": "gravity-dominated"}
_OTHER_BRANCH = {"curvature-dominated": "gravity-dominated",
                 "gravity-dominated": "curvature-dominated"}

#: Columns of the table, in order.
COLUMNS = (*PARAMETERS, "deflection", "converged", "message", "branch", "stable", "snapped",
           "newton_iterations", "load_steps", "wall_time_s", "assembly_s", "linear_solve_s",
           "dofs", "energy", "volume_change", "version", "key", "error", "kappa_reached",
           "gravity_reached", "factorizations", "rejected_steps", "linear_solver",
           "layers_used", "finished_at")
_FLOAT = ("length", "tip_width", "curvature", "thickness", "modulus", "hmax", "deflection",
          "wall_time_s", "assembly_s", "linear_solve_s", "energy", "volume_change",
          "kappa_reached", "gravity_reached")
_INT = ("layers", "newton_iterations", "load_steps", "dofs", "factorizations",
        "rejected_steps", "layers_used")
_BOOL_OR_NA = ("stable", "snapped")
_STR = ("path", "solver", "message", "branch", "version", "key", "error", "linear_solver",
        "finished_at")

_SIGNIFICANT = 10          # digits kept when normalising numbers (the key and the solve)
_MAX_POINTS = 100_000      # largest grid accepted
_TABLE_EVERY_S = 30.0      # rewrite the table at most this often while running
_THREAD_VARS = ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS")


# -- points, keys ----------------------------------------------------------------------
def _norm_number(x):
    """A float rounded to 10 significant digits (non-numbers returned unchanged)."""
    if isinstance(x, bool) or x is None or isinstance(x, str):
        return x
    try:
        v = float(x)
    except (TypeError, ValueError):
        return x
    if not math.isfinite(v):
        return v
    return float(f"{v:.{_SIGNIFICANT}g}") + 0.0  # + 0.0 turns -0.0 into 0.0


def _norm_layers(x):
    if x is None or isinstance(x, (bool, str)):
        return x
    try:
        v = float(x)
    except (TypeError, ValueError):
        return x
    return int(v) if math.isfinite(v) and v.is_integer() else v


def normalize_point(point) -> dict:
    """A point with every parameter present, in order, and numbers normalised.

    Missing parameters get their defaults (:data:`PARAMETERS`); numbers are
    rounded to 10 significant digits; ``layers`` that are whole numbers become
    ``int``.  Raises ``ParameterError`` for an unknown parameter name or a
    missing ``length``.

    Examples
    --------
    >>> normalize_point({"length": 1.3000000000000003, "layers": 2.0})
    ... # doctest: +NORMALIZE_WHITESPACE
    {'length': 1.3, 'tip_width': 1.0, 'curvature': 0.0, 'thickness': 0.03,
     'modulus': 735.0, 'path': 'curvature-first', 'hmax': 0.03, 'layers': 2,
     'solver': 'auto'}
    """
    out = normalize_params(point, PARAMETERS, _NUMERIC, "point")
    if "length" not in point:
        raise ParameterError("every point needs a length")
    return out


def normalize_params(point, parameters, numeric, what) -> dict:
    """``point`` with every name of ``parameters`` (defaults filled in), in
    their order; the ``numeric`` ones rounded to 10 significant digits,
    ``layers`` a whole number made ``int``.  ``ParameterError`` for a
    non-dict or an unknown name (``what`` names the kind of point)."""
    if not isinstance(point, dict):
        raise ParameterError(f"points must be dicts of parameters, got {type(point).__name__}")
    unknown = [k for k in point if k not in parameters]
    if unknown:
        raise ParameterError(f"{what} parameter {unknown[0]!r} is unknown; "
                             f"allowed: {', '.join(parameters)}")
    out = {}
    for name, default in parameters.items():
        v = point.get(name, default)
        if name in numeric:
            v = _norm_number(v)
        elif name == "layers":
            v = _norm_layers(v)
        out[name] = v
    return out


def _key_value(v):
    if isinstance(v, float) and not math.isfinite(v):
        return repr(v)
    if isinstance(v, (bool, int, float, str)) or v is None:
        return v
    return repr(v)


def point_key(point) -> str:
    """Stable hash (16 hex digits) of a point's normalised input parameters.

    Examples
    --------
    >>> point_key({"length": 1.3}) == point_key({"length": 1.30000000001, "curvature": -0.0})
    True
    >>> point_key({"length": 1.3}) == point_key({"length": 1.31})
    False
    """
    p = normalize_point(point)
    return hash_key([[k, _key_value(p[k])] for k in PARAMETERS])


def hash_key(items) -> str:
    """16 hex digits of the SHA-256 of ``items`` as compact JSON (the journal keys)."""
    text = json.dumps(items, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _values(name, v):
    if isinstance(v, (str, bytes, dict)) or v is None or not hasattr(v, "__iter__"):
        return [v]
    vals = list(v)
    if not vals:
        raise ParameterError(f"{name} must have at least one value, got an empty list")
    return vals


def grid(length, tip_width=1.0, curvature=0.0, thickness=0.03, modulus=735.0,
         path="curvature-first", hmax=0.03, layers=None, solver="auto") -> list:
    """The cartesian product of parameter values, as a list of points (dicts).

    Every argument is a single value or a list (tuple, array, range) of values;
    ``path="both"`` means both load paths.  Points come in the order of nested
    loops over the arguments in signature order (``length`` outermost,
    ``solver`` innermost), normalised (see :func:`normalize_point`).  Values are
    not checked here: a bad one becomes a failed row in :func:`run_sweep`.

    Examples
    --------
    >>> pts = grid(length=[1.0, 1.3], tip_width=[1.0, 0.0], curvature=[0.0, 2.5],
    ...            path="both", hmax=0.1)
    >>> len(pts), pts[0]["path"], pts[1]["path"], pts[-1]["length"]
    (16, 'curvature-first', 'gravity-first', 1.3)
    """
    args = dict(length=length, tip_width=tip_width, curvature=curvature, thickness=thickness,
                modulus=modulus, path=path, hmax=hmax, layers=layers, solver=solver)
    lists = {}
    for name, v in args.items():
        vals = _values(name, v)
        if name == "path":
            vals = [q for p in vals for q in (_PATHS if p == "both" else (p,))]
        lists[name] = vals
    n = math.prod(len(v) for v in lists.values())
    if n > _MAX_POINTS:
        raise ParameterError(f"grid must have at most {_MAX_POINTS} points, got {n}")
    return [normalize_point(dict(zip(lists, combo)))
            for combo in itertools.product(*lists.values())]


# -- one point (runs in the workers) -------------------------------------------------------
def _pyval(x):
    """numpy scalars to Python (for JSON)."""
    return x.item() if hasattr(x, "item") and not isinstance(x, (list, tuple, str)) else x


def _derived_branch(result, path):
    branch = getattr(result, "branch", None)
    if branch is not None:
        return str(branch)
    own = _BRANCH.get(path)
    if own is not None and len(result.snaps) > 0:
        own = _OTHER_BRANCH[own]
    return own


def _record(point, key):
    from . import __version__

    rec = dict(point)
    rec.update(deflection=math.nan, converged=False, message="", branch=None, stable=None,
               snapped=None, newton_iterations=None, load_steps=None, wall_time_s=math.nan,
               assembly_s=math.nan, linear_solve_s=math.nan, dofs=None, energy=math.nan,
               volume_change=math.nan, version=__version__, key=key, error="",
               kappa_reached=math.nan, gravity_reached=math.nan, factorizations=None,
               rejected_steps=None, linear_solver=None, layers_used=None)
    return rec


def _run_point(point) -> dict:
    """Solve one normalised point; every ``Exception`` becomes a failed record."""
    key = point_key(point)
    rec = _record(point, key)
    t0 = time.perf_counter()
    try:
        sheet = Sheet(length=point["length"], tip_width=point["tip_width"],
                      curvature=point["curvature"], thickness=point["thickness"],
                      modulus=point["modulus"])
        r = solve(sheet, path=point["path"], hmax=point["hmax"], layers=point["layers"],
                  solver=point["solver"], on_failure="return", progress=False)
        stable = getattr(r, "stable", None)
        rec.update(
            deflection=float(r.deflection), converged=bool(r.converged),
            message=str(r.message or ""), branch=_derived_branch(r, point["path"]),
            stable=None if stable is None else bool(stable), snapped=len(r.snaps) > 0,
            newton_iterations=int(r.newton_iterations), load_steps=int(r.load_steps),
            wall_time_s=float(r.wall_time_s), assembly_s=float(r.assembly_s),
            linear_solve_s=float(r.linear_solve_s), dofs=int(r.dofs),
            energy=float(r.energy), volume_change=float(r.volume_change),
            kappa_reached=float(r.kappa), gravity_reached=float(r.gravity),
            factorizations=int(r.factorizations), rejected_steps=int(r.rejected_steps),
            linear_solver=str(r.solver), layers_used=int(r.layers))
    except Exception as err:  # noqa: BLE001 - one bad point must not stop the sweep
        _record_failure(rec, err, t0)
    return _finish(rec)


def _record_failure(rec, err, t0):
    """Put an exception raised while computing a point into its record."""
    rec.update(message=str(err) or type(err).__name__, error=type(err).__name__,
               wall_time_s=time.perf_counter() - t0)
    if not isinstance(err, ParameterError):
        rec["traceback"] = traceback.format_exc()


def _finish(rec) -> dict:
    """Stamp a finished record (time, host, process) and make it JSON-ready."""
    rec["finished_at"] = datetime.now(timezone.utc).isoformat(timespec="milliseconds")
    rec["host"] = socket.gethostname()
    rec["pid"] = os.getpid()
    return {k: _pyval(v) for k, v in rec.items()}


def _run_chunk(points) -> list:
    """Solve points in sequence (same mesh: the worker's mesh cache is reused)."""
    return [_run_point(p) for p in points]


def _watch_parent(parent_pid):
    while True:
        time.sleep(0.5)
        if os.getppid() != parent_pid:
            os._exit(1)  # the sweep was killed: do not go on computing for nobody


def _init_pool_worker(parent_pid):
    import threading

    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's business
    # A worker holds both ends of the pool's pipes, so it would wait forever for
    # work from a parent killed with SIGKILL: it exits when its parent changes.
    threading.Thread(target=_watch_parent, args=(parent_pid,), daemon=True).start()


# -- journal and table ---------------------------------------------------------------------
def journal_path(table) -> str:
    """The journal of ``table``: ``<table>.journal.jsonl``."""
    return os.fspath(table) + ".journal.jsonl"


def _sweep_key(rec):
    return point_key({k: rec[k] for k in PARAMETERS if k in rec})


def read_journal(path, *, key_of=None, required=("length", "deflection", "converged")) -> dict:
    """Finished points of a journal, ``{key: record}`` in order of first appearance.

    Lines that are not complete JSON records (a write cut short by a crash,
    garbage) are skipped; for lines with the same key the last one wins.  Keys
    are recomputed from the parameters stored in each line (``key_of(record)``,
    by default :func:`point_key` of the sweep parameters); lines without the
    ``required`` fields are skipped.  A missing file is an empty journal.

    Examples
    --------
    >>> import os, tempfile
    >>> f = os.path.join(tempfile.mkdtemp(), "j.jsonl")
    >>> with open(f, "w") as fh:
    ...     _ = fh.write('{"length": 1.0, "deflection": 0.5, "converged": true}\\n{"len')
    >>> [r["deflection"] for r in read_journal(f).values()]
    [0.5]
    """
    path = os.fspath(path)
    try:
        with open(path, "rb") as fh:
            data = fh.read()
    except FileNotFoundError:
        return {}
    out = {}
    for line in data.split(b"\n"):
        if not line.strip():
            continue
        try:
            rec = json.loads(line)
        except (UnicodeDecodeError, json.JSONDecodeError):
            continue  # a line cut short by a crash, or garbage
        if not isinstance(rec, dict) or not set(required) <= set(rec):
            continue
        try:
            key = (key_of or _sweep_key)(rec)
        except ParameterError:
            continue
        rec["key"] = key
        out[key] = rec  # keeps the first position, the last line's values
    return out


class _Journal:
    """Append-only JSON-lines file: one ``os.write`` + ``os.fsync`` per record."""

    def __init__(self, path):
        self.path = path
        self.fd = os.open(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
        size = os.fstat(self.fd).st_size
        if size:
            with open(path, "rb") as fh:
                fh.seek(size - 1)
                last = fh.read(1)
            if last != b"\n":  # a line cut short by a crash: end it, never extend it
                os.write(self.fd, b"\n")

    def append(self, rec):
        data = (json.dumps(rec, separators=(",", ":")) + "\n").encode()
        n = os.write(self.fd, data)
        while n < len(data):  # short writes are rare on files; finish the line
            n += os.write(self.fd, data[n:])
        os.fsync(self.fd)

    def close(self):
        if self.fd is not None:
            os.close(self.fd)
            self.fd = None


def _frame(records):
    """A DataFrame with the table's columns and dtypes."""
    return typed_frame(records, COLUMNS, floats=_FLOAT, ints=_INT, bools_or_na=_BOOL_OR_NA,
                       bools=("converged",), strings=_STR)


def typed_frame(records, columns, *, floats=(), ints=(), bools_or_na=(), bools=(),
                strings=()):
    """Records as a DataFrame with fixed columns and dtypes (missing values stay
    missing: NaN floats, nullable ``Int64``/``boolean``, None strings; ``bools``
    count a missing value as False)."""
    import pandas as pd

    df = pd.DataFrame.from_records(list(records), columns=list(columns))
    for c in floats:
        df[c] = pd.to_numeric(df[c], errors="coerce").astype("float64")
    for c in ints:
        df[c] = pd.to_numeric(df[c], errors="coerce").astype("Int64")
    for c in bools_or_na:
        df[c] = df[c].astype("boolean")
    for c in bools:
        df[c] = df[c].fillna(False).astype(bool)
    string = "str" if int(pd.__version__.split(".")[0]) >= 3 else object  # pandas' default
    for c in strings:
        df[c] = df[c].astype(object).where(df[c].notna(), None).astype(string)
    return df


def _check_table(table):
    from .io import check_writable

    path = check_writable("table", table, [".csv", ".parquet"])
    if path.lower().endswith(".parquet"):
        try:
            import pyarrow  # noqa: F401
        except ImportError:
            raise ParameterError("table: writing .parquet needs pyarrow: pip install "
                                 "'skfem_sheet[parquet]' (or use a .csv table)") from None
    if os.path.exists(path) and not os.path.exists(journal_path(path)):
        raise ParameterError(
            f"table {path!r} exists without its journal {journal_path(path)!r} (the record of "
            "finished points): move the table away or choose another name")
    return path


def _write_table(df, path):
    """Replace ``path`` atomically by ``df`` (CSV or Parquet by suffix)."""
    folder = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(prefix="." + os.path.basename(path) + ".", suffix=".tmp",
                               dir=folder)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes it 0600; a table is an ordinary file
    try:
        with os.fdopen(fd, "wb") as fh:
            if path.lower().endswith(".parquet"):
                df.to_parquet(fh, index=False)
            else:
                df.to_csv(fh, index=False)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise
    with contextlib.suppress(OSError):  # make the rename durable too
        dfd = os.open(folder, os.O_RDONLY)
        try:
            os.fsync(dfd)
        finally:
            os.close(dfd)


def _table_records(done, order):
    """This sweep's points in request order, then older points of the journal."""
    seen = set(order)
    return [done[k] for k in order if k in done] + [r for k, r in done.items() if k not in seen]


# -- executors -----------------------------------------------------------------------------
def _chunks(points, n_workers, chunk_size=None):
    """Group points by mesh (sorted) and cut the groups into chunks."""
    def orderable(v):
        return (0, v, "") if isinstance(v, (int, float)) and not isinstance(v, bool) \
            else (1, 0.0, repr(v))

    def mesh_key(p):
        return tuple(orderable(p[k]) for k in _MESH)

    rest = [k for k in PARAMETERS if k not in _MESH]
    pts = sorted(points, key=lambda p: (mesh_key(p), tuple(orderable(p[k]) for k in rest)))
    if chunk_size is None:
        chunk_size = max(1, min(8, math.ceil(len(pts) / (4 * max(1, n_workers)))))
    out = []
    for _, group in itertools.groupby(pts, key=mesh_key):
        group = list(group)
        out.extend(group[i:i + chunk_size] for i in range(0, len(group), chunk_size))
    return out


def _failed(point, message, error):
    """The record of a point whose task failed outside the solve (e.g. its worker died)."""
    rec = _record(point, point_key(point))
    rec.update(message=message, error=error,
               finished_at=datetime.now(timezone.utc).isoformat(timespec="milliseconds"))
    return rec


@contextlib.contextmanager
def _thread_env(n):
    """Set the BLAS/MKL thread counts inherited by spawned workers (unless set)."""
    saved = {v: os.environ.get(v) for v in _THREAD_VARS}
    try:
        for v in _THREAD_VARS:
            if saved[v] is None:
                os.environ[v] = str(n)
        yield
    finally:
        for v, old in saved.items():
            if old is None:
                os.environ.pop(v, None)
            else:
                os.environ[v] = old


def _stop_pool(ex, kill):
    if kill:
        ex.shutdown(wait=False, cancel_futures=True)
        terminate = getattr(ex, "terminate_workers", None)  # Python >= 3.14
        if terminate is not None:
            terminate()
        else:
            for proc in list((getattr(ex, "_processes", None) or {}).values()):
                proc.terminate()
            for proc in list((getattr(ex, "_processes", None) or {}).values()):
                proc.join(5)
    else:
        ex.shutdown(wait=True)


def _pool(chunks, n_workers, task=None, failed=None):
    """Chunks on ``n_workers`` spawned processes; yields lists of records.

    At most ``n_workers`` chunks are in flight.  If a worker process dies (the
    pool breaks), the points of the chunks in flight are solved again one at a
    time in a fresh single-process pool, so that only a point that kills its
    worker on its own is recorded as failed.  ``task`` replaces
    :func:`_run_chunk` (other kinds of points; tests), ``failed`` replaces
    :func:`_failed`.
    """
    import multiprocessing
    from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
    from concurrent.futures.process import BrokenProcessPool

    task = task or _run_chunk
    failed = failed or _failed
    ctx = multiprocessing.get_context("spawn")

    def new_pool(n):
        return ProcessPoolExecutor(max_workers=n, mp_context=ctx, initializer=_init_pool_worker,
                                   initargs=(os.getpid(),))

    threads = max(1, (os.cpu_count() or 1) // n_workers)
    queue = list(reversed(chunks))
    ex = None
    with _thread_env(threads):
        try:
            ex = new_pool(n_workers)
            running = {}
            while queue or running:
                broken = False
                while queue and len(running) < n_workers:
                    try:
                        fut = ex.submit(task, queue[-1])
                    except BrokenProcessPool:
                        broken = True
                        break
                    running[fut] = queue.pop()
                if not broken:
                    finished, _ = wait(running, return_when=FIRST_COMPLETED)
                    broken = any(isinstance(f.exception(), BrokenProcessPool) for f in finished)
                if broken:  # a broken pool ends every future in flight
                    wait(running, timeout=60)
                suspects = []
                for fut in list(running):
                    if broken and not fut.done():
                        fut.cancel()
                        suspects.extend(running.pop(fut))
                    elif fut.done():
                        chunk = running.pop(fut)
                        err = fut.exception()
                        if err is None:
                            yield fut.result()
                        elif isinstance(err, BrokenProcessPool):
                            suspects.extend(chunk)
                        else:  # not from a solve (those are caught): e.g. pickling
                            yield [failed(p, f"the worker failed: {type(err).__name__}: {err}",
                                          type(err).__name__) for p in chunk]
                if broken:
                    _stop_pool(ex, kill=True)
                    ex = None
                    yield from _isolated(suspects, new_pool, task, failed)
                    ex = new_pool(n_workers)
        except BaseException:
            if ex is not None:
                _stop_pool(ex, kill=True)
                ex = None
            raise
        finally:
            if ex is not None:
                _stop_pool(ex, kill=False)


def _ping():
    return os.getpid()


def _isolated(points, new_pool, task, failed=None):
    """Solve points one at a time, each in a fresh worker if the previous one died."""
    from concurrent.futures.process import BrokenProcessPool

    ex = new_pool(1)
    try:
        try:
            ex.submit(_ping).result()
        except BrokenProcessPool:
            raise RuntimeError(
                "sweep worker processes die on start-up; in a script, call run_sweep under "
                "`if __name__ == '__main__':` (workers are spawned and import the main "
                "module), or pass workers=1") from None
        for p in points:
            try:
                yield ex.submit(task, [p]).result()
            except BrokenProcessPool:
                yield [(failed or _failed)(p, "the worker process died while solving this point "
                                              "(killed, out of memory or crashed)", "WorkerDied")]
                _stop_pool(ex, kill=True)
                ex = new_pool(1)
    except BaseException:
        _stop_pool(ex, kill=True)
        raise
    _stop_pool(ex, kill=False)


def _dask_client(scheduler):
    if not isinstance(scheduler, str):
        if not hasattr(scheduler, "submit"):
            raise ParameterError("scheduler must be an address like 'tcp://host:8786' or a "
                                 f"distributed.Client, got {type(scheduler).__name__}")
        return scheduler, False
    try:
        from distributed import Client
    except ImportError:
        raise ParameterError("scheduler needs dask and distributed: "
                             "pip install 'skfem_sheet[cluster]'") from None
    try:
        return Client(scheduler, timeout="20s", set_as_default=False), True
    except (OSError, TimeoutError, ValueError) as err:
        raise ParameterError(f"scheduler: cannot connect to {scheduler!r}: {err}") from None


def _dask(chunks, client, task=None, failed=None):
    """Chunks as Dask tasks; a chunk whose task fails is retried point by point."""
    from distributed import as_completed

    task, failed = task or _run_chunk, failed or _failed
    futures = {}

    def submit(chunk):
        fut = client.submit(task, chunk, pure=False)
        futures[fut] = chunk
        return fut

    todo = as_completed([submit(c) for c in chunks], loop=client.loop)
    try:
        for fut in todo:
            chunk = futures.pop(fut)
            try:
                yield fut.result()
            except Exception as err:  # noqa: BLE001 - e.g. KilledWorker: not the sweep's end
                if len(chunk) > 1:
                    for p in chunk:
                        todo.add(submit([p]))
                else:
                    yield [failed(chunk[0], f"the Dask task failed: {type(err).__name__}: "
                                            f"{err}", type(err).__name__)]
    except BaseException:
        client.cancel(list(futures))
        raise


# -- the sweep -----------------------------------------------------------------------------
def run_sweep(points, table=None, workers=None, scheduler=None, progress=True, *,
              retry_failed=False, chunk_size=None):
    """Solve every point and return the table (one row per point, in order).

    Parameters
    ----------
    points : list of dict
        Points from :func:`grid`, or dicts of :data:`PARAMETERS` (``length``
        required, others default).  The same point given twice is solved once
        and gives two rows.
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
    KeyboardInterrupt
        On Ctrl-C, after writing the table of the points finished so far.

    Examples
    --------
    >>> df = run_sweep([{"length": 0.3, "hmax": 0.2}], workers=1, progress=False)
    >>> len(df), bool(df.converged[0]), round(float(df.deflection[0]), 3)
    (1, True, 0.011)
    """
    if isinstance(points, dict):
        raise ParameterError("points must be a list of dicts (use grid(...)), got one dict")
    points = [normalize_point(p) for p in points]
    if len(points) > _MAX_POINTS:
        raise ParameterError(f"points must be at most {_MAX_POINTS}, got {len(points)}")
    if scheduler is not None and workers is not None:
        raise ParameterError("workers must not be given with scheduler (Dask decides)")
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int)
                                or workers < 1):
        raise ParameterError(f"workers must be an integer >= 1, got {workers!r}")
    if chunk_size is not None and (not isinstance(chunk_size, int) or chunk_size < 1):
        raise ParameterError(f"chunk_size must be an integer >= 1, got {chunk_size!r}")
    path = _check_table(table) if table is not None else None

    keys = [point_key(p) for p in points]
    done, stats = _execute(points, keys, _SWEEP_JOB, table=path, workers=workers,
                           scheduler=scheduler, progress=progress, retry_failed=retry_failed,
                           chunker=lambda todo, n: _chunks(todo, n, chunk_size))
    df = _frame(done[k] for k in keys)
    df.attrs["sweep"] = stats
    return df


class _Job:
    """How one kind of point is keyed, computed, failed and tabulated.

    ``task`` (a module-level function, so that workers can unpickle it) maps a
    chunk of points to their records; ``failed(point, message, error)`` is the
    record of a point whose task died; ``frame(records)`` makes the table;
    ``key_of(record)`` and ``required`` read the journal back.
    """

    def __init__(self, task, failed, frame, key_of, required, desc):
        self.task, self.failed, self.frame = task, failed, frame
        self.key_of, self.required, self.desc = key_of, required, desc


def _execute(points, keys, job, *, table, workers, scheduler, progress, retry_failed, chunker):
    """Run the points not yet in ``table``'s journal; journal, table and progress bar.

    Returns ``(done, stats)``: ``done`` maps every key of the journal (and of
    this run) to its record.  Used by :func:`run_sweep` and by the fold map
    (:func:`skfem_sheet.foldmap.fold_map`).
    """
    jpath = journal_path(table) if table else None
    order = list(dict.fromkeys(keys))
    by_key = dict(zip(keys, points))
    done = read_journal(jpath, key_of=job.key_of, required=job.required) if jpath else {}
    todo_keys = [k for k in order if k not in done
                 or (retry_failed and not done[k].get("converged"))]
    todo = [by_key[k] for k in todo_keys]
    n_cached = len(order) - len(todo)
    n_workers = workers if workers is not None else (os.cpu_count() or 1)

    client, own_client = (None, False)
    if scheduler is not None:
        client, own_client = _dask_client(scheduler)

    from tqdm.auto import tqdm

    bar = tqdm(total=len(order), initial=n_cached, desc=job.desc, unit="pt", file=sys.stderr,
               disable=not progress, dynamic_ncols=True)
    failed = sum(1 for k in order if k in done and k not in todo_keys
                 and not done[k].get("converged"))
    bar.set_postfix(failed=failed, refresh=False)
    journal = _Journal(jpath) if jpath else None
    last_table = time.monotonic()
    new = 0
    try:
        if todo:
            if client is not None:
                slots = sum(client.nthreads().values()) or 1
                results = _dask(chunker(todo, slots), client, job.task, job.failed)
            elif n_workers == 1:
                results = ([rec] for chunk in chunker(todo, 1) for p in chunk
                           for rec in job.task([p]))
            else:
                results = _pool(chunker(todo, n_workers), n_workers, job.task, job.failed)
            try:
                for recs in results:
                    for rec in recs:
                        if journal is not None:
                            journal.append(rec)
                        done[rec["key"]] = rec
                        new += 1
                        failed += not rec["converged"]
                        bar.set_postfix(failed=failed, refresh=False)
                        bar.update(1)
                    if table and time.monotonic() - last_table > _TABLE_EVERY_S:
                        _write_table(job.frame(_table_records(done, order)), table)
                        last_table = time.monotonic()
            finally:
                close = getattr(results, "close", None)
                if close is not None:
                    close()  # stops the workers now (also on Ctrl-C)
    finally:
        bar.close()
        if journal is not None:
            journal.close()
        if own_client:
            client.close()
        if table:
            # rebuilt from the journal file: also keeps lines appended by others
            disk = read_journal(jpath, key_of=job.key_of, required=job.required)
            _write_table(job.frame(_table_records(disk, order)), table)
    return done, {"new": new, "cached": n_cached, "points": len(order), "table": table,
                  "journal": jpath}


_SWEEP_JOB = _Job(_run_chunk, _failed, _frame, _sweep_key, ("length", "deflection", "converged"),
                  "sweep")


# -- command line --------------------------------------------------------------------------
def parse_values(text, name, kind=float) -> list:
    """Parse ``"a:b:step"`` (a, a + step, ..., b inclusive within step/1e6) or ``"x,y,z"``.

    Raises ``ParameterError`` naming ``name`` on malformed input.

    Examples
    --------
    >>> parse_values("0.5:1.5:0.25", "--lengths")
    [0.5, 0.75, 1.0, 1.25, 1.5]
    >>> parse_values("1,0", "--tip-widths")
    [1.0, 0.0]
    """
    text = str(text).strip()
    if ":" in text:
        if kind is not float:
            raise ParameterError(f"{name} must be a comma list, got {text!r}")
        from .reduced.cli import parse_range

        return [_norm_number(v) for v in parse_range(text, name, _MAX_POINTS, slack=1e-6)]
    items = [t.strip() for t in text.split(",")]
    if not text or any(not t for t in items):
        raise ParameterError(f"{name} must be 'start:stop:step' or 'x,y,...', got {text!r}")
    out = []
    for t in items:
        try:
            v = kind(t)
        except ValueError:
            raise ParameterError(f"{name} must be numbers, got {t!r}") from None
        if kind is float and not math.isfinite(v):
            raise ParameterError(f"{name} values must be finite, got {t!r}")
        out.append(v)
    return out


def _check_point(p):
    """Raise ParameterError for a point ``solve`` would refuse (CLI checks up front)."""
    from .continuation import PATHS
    from .linalg import SOLVERS, available_solvers
    from .mesh import estimate_dofs
    from .solve import MAX_DOFS

    sheet = Sheet(length=p["length"], tip_width=p["tip_width"], curvature=p["curvature"],
                  thickness=p["thickness"], modulus=p["modulus"])
    if p["path"] not in PATHS:
        raise ParameterError(f"path must be one of {', '.join(PATHS)}, got {p['path']!r}")
    if p["solver"] not in SOLVERS:
        raise ParameterError(f"solver must be one of {', '.join(SOLVERS)}, got {p['solver']!r}")
    if p["solver"] != "auto" and p["solver"] not in available_solvers():
        raise ParameterError(f"solver {p['solver']!r} is not installed here; available: "
                             f"{', '.join(available_solvers())} (pardiso: pip install "
                             "'skfem_sheet[fast]')")
    n = estimate_dofs(sheet, p["hmax"], p["layers"])
    if n > MAX_DOFS:
        raise ParameterError(f"hmax must be larger: hmax={p['hmax']:g} gives about {n:,} "
                             f"unknowns, more than {MAX_DOFS:,}")


def _cmd_sweep(args) -> int:
    if args.workers is not None and args.workers < 1:
        raise ParameterError(f"--workers must be an integer >= 1, got {args.workers}")
    paths = _PATHS if args.paths.strip() == "both" else \
        tuple(s.strip() for s in args.paths.split(","))
    for q in paths:
        if q not in _PATHS:
            raise ParameterError(f"--paths must be 'both' or a comma list of "
                                 f"{', '.join(_PATHS)}, got {q!r}")
    solvers = [s.strip() for s in args.solver.split(",")]
    points = grid(length=parse_values(args.lengths, "--lengths"),
                  tip_width=parse_values(args.tip_widths, "--tip-widths"),
                  curvature=parse_values(args.curvatures, "--curvatures"),
                  thickness=parse_values(args.thicknesses, "--thicknesses"),
                  modulus=parse_values(args.moduli, "--moduli"),
                  path=list(paths), hmax=parse_values(args.hmax, "--hmax"),
                  layers=[None] if args.layers is None else parse_values(args.layers, "--layers",
                                                                           int),
                  solver=solvers)
    for p in points:
        _check_point(p)
    from .io import check_writable

    check_writable("--table", args.table, [".csv", ".parquet"])
    try:
        df = run_sweep(points, table=args.table, workers=args.workers,
                       scheduler=args.scheduler, progress=not args.quiet,
                       retry_failed=args.retry_failed)
    except KeyboardInterrupt:
        done = read_journal(journal_path(args.table))
        keys = set(point_key(p) for p in points)
        print(f"skfem-sheet sweep: interrupted; {len(keys & set(done))} of {len(keys)} points "
              f"are finished and kept in {args.table}; run the same command again to resume",
              file=sys.stderr)
        return 130
    info = df.attrs["sweep"]
    rows = df.drop_duplicates("key")
    n_conv = int(rows.converged.sum())
    print(f"sweep: {info['points']} points, {n_conv} converged, {info['points'] - n_conv} "
          f"failed ({info['new']} computed now, {info['cached']} from earlier runs) "
          f"-> {info['table']}")
    for _, r in rows[~rows.converged].head(5).iterrows():
        print(f"  failed: L/a={r.length:g} b/a={r.tip_width:g} a/R={r.curvature:g} "
              f"{r.path} hmax={r.hmax:g}: {r.message}")
    return 0


def add_sweep_subparser(subparsers) -> None:
    """Register ``sweep`` on an argparse subparsers object (``func(args)`` -> exit code).

    Examples
    --------
    >>> import argparse
    >>> p = argparse.ArgumentParser(); sub = p.add_subparsers(dest="command")
    >>> add_sweep_subparser(sub)
    >>> args = p.parse_args(["sweep", "--lengths", "1,2", "--table", "x.csv"])
    >>> args.lengths, args.paths, args.workers
    ('1,2', 'curvature-first', None)
    """
    p = subparsers.add_parser(
        "sweep", help="solve a grid of sheets in parallel into one table (resumable)",
        description="Solve the cartesian product of the given values (each 'a:b:step', b "
                    "included, or 'x,y,...') on local processes or a Dask cluster.  Results "
                    "go to --table (.csv or .parquet) and its journal <table>.journal.jsonl; "
                    "running the same command again resumes (finished points are kept).")
    p.add_argument("--lengths", required=True, help="L/a values, e.g. 0.5:1.5:0.25 or 1,1.3")
    p.add_argument("--tip-widths", default="1", help="b/a values (default 1)")
    p.add_argument("--curvatures", default="0", help="a/R values (default 0)")
    p.add_argument("--thicknesses", default="0.03", help="h/a values (default 0.03)")
    p.add_argument("--moduli", default="735", help="E/(rho g a) values (default 735)")
    p.add_argument("--paths", default="curvature-first",
                   help="both, or a comma list of curvature-first, gravity-first")
    p.add_argument("--hmax", default="0.03", help="mesh sizes (default 0.03)")
    p.add_argument("--layers", default=None, help="element layers through the thickness")
    p.add_argument("--solver", default="auto", help="linear solvers: auto, pardiso, superlu")
    p.add_argument("--table", required=True, help="results table, .csv or .parquet")
    p.add_argument("--workers", type=int, default=None,
                   help="local worker processes (default: number of CPUs; 1: no pool)")
    p.add_argument("--scheduler", default=None,
                   help="Dask scheduler address tcp://host:port (needs skfem_sheet[cluster])")
    p.add_argument("--retry-failed", action="store_true",
                   help="compute again the points stored as not converged")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=_cmd_sweep)
