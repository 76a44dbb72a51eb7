"""The study runner: many independent points as one resumable, parallel job.

A *study* (the sweep, :mod:`skfem_sheet.studies.sweep`; the fold map,
:mod:`skfem_sheet.studies.foldmap`) is a list of points, each computed on its
own into one flat *record*.  The runner does everything else, the same way
for every study: the points' **keys** (:func:`normalize_params`,
:func:`hash_key`: numbers rounded to 10 significant digits); the **journal**
beside the table (:func:`journal_path`, :class:`Journal`: one JSON line per
finished record, one ``os.write`` on an ``O_APPEND`` descriptor, then
``os.fsync``; :func:`read_journal` ignores a line cut short and keeps the
last of equal keys); the **table**, rebuilt from the journal and replaced
atomically (:func:`write_table`); **resume** (a journalled key is not
computed again, unless ``retry_failed`` and not converged); the
**executors** (this process, ``spawn``-ed local processes, :func:`pool`, or
a Dask cluster, :func:`dask`); **Ctrl-C** (:class:`StudyInterrupted`: the
points in flight abandoned within about a second, the table written); and
**failures** (:func:`record_failure`, :func:`finish_record`).

A study describes its kind of point with a :class:`Job` (usually an
:class:`EachPoint` task and a :func:`failed_record`), checks its arguments
(:func:`study_points`, :func:`check_run`) and calls :func:`execute`.
"""
from __future__ import annotations

import contextlib
import hashlib
import importlib
import io
import json
import math
import multiprocessing
import os
import signal
import socket
import sys
import threading
import time
import traceback
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from datetime import datetime, timezone
from typing import Callable

import pandas as pd
from tqdm.auto import tqdm

from ..io import atomic_write, check_writable, dumps_json
from ..params import ParameterError

__all__ = ["Job", "EachPoint", "StudyInterrupted", "computed_record", "failed_record", "execute", "check_run", "study_points",
           "Journal", "journal_path", "read_journal", "write_table",
           "check_table", "typed_frame", "table_records", "record_failure", "finish_record",
           "utc_now", "normalize_number", "normalize_int", "normalize_params", "key_value",
           "hash_key", "as_values", "pool", "beside", "dask", "dask_client", "Workers",
           "study_executor", "on_executor", "MAX_POINTS"]

SIGNIFICANT = 10          # digits kept when normalising numbers (the key and the computation)
MAX_POINTS = 100_000      # largest study accepted
TABLE_EVERY_S = 30.0      # rewrite the table at most this often while running
_THREAD_VARS = ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS")


# -- points and keys -----------------------------------------------------------------------
def normalize_number(x):
    """A float rounded to 10 significant digits (non-numbers returned unchanged).

    Examples
    --------
    >>> normalize_number(1.3000000000000003), normalize_number(-0.0), normalize_number("a")
    (1.3, 0.0, 'a')
    """
    if isinstance(x, bool) or x is None or isinstance(x, str):
        return x
    try:
        v = float(x)
    except (TypeError, ValueError):
        return x
    if not math.isfinite(v):
        return v
    return float(f"{v:.{SIGNIFICANT}g}") + 0.0  # + 0.0 turns -0.0 into 0.0


def normalize_int(x):
    """A whole number as ``int`` (``2.0`` -> ``2``); anything else unchanged."""
    if x is None or isinstance(x, (bool, str)):
        return x
    try:
        v = float(x)
    except (TypeError, ValueError):
        return x
    return int(v) if math.isfinite(v) and v.is_integer() else v


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
            v = normalize_number(v)
        elif name == "layers":
            v = normalize_int(v)
        out[name] = v
    return out


def key_value(v):
    """A parameter value as it enters a key (JSON-able; non-finite floats as text)."""
    if isinstance(v, float) and not math.isfinite(v):
        return repr(v)
    if isinstance(v, (bool, int, float, str)) or v is None:
        return v
    return repr(v)


def hash_key(items) -> str:
    """16 hex digits of the SHA-256 of ``items`` as compact JSON (the journal keys)."""
    text = json.dumps(items, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def as_values(name, v) -> list:
    """``v`` as a list of values: a single value (number, string, None) is one value."""
    if isinstance(v, (str, bytes, dict)) or v is None or not hasattr(v, "__iter__"):
        return [v]
    vals = list(v)
    if not vals:
        raise ParameterError(f"{name} must have at least one value, got an empty list")
    return vals


# -- records -------------------------------------------------------------------------------
def utc_now() -> str:
    """The current UTC time as ISO text (milliseconds), the ``finished_at`` stamp."""
    return datetime.now(timezone.utc).isoformat(timespec="milliseconds")


def _pyval(x):
    """numpy scalars to Python (for JSON)."""
    return x.item() if hasattr(x, "item") and not isinstance(x, (list, tuple, str)) else x


def record_failure(rec, err, t0) -> None:
    """Put an exception raised while computing a point into its record.

    ``message`` (the exception's text), ``error`` (its class), ``wall_time_s``
    since ``t0`` (``time.perf_counter()``), and the ``traceback`` unless it
    is a ``ParameterError`` (bad input, not a bug).
    """
    rec.update(message=str(err) or type(err).__name__, error=type(err).__name__,
               wall_time_s=time.perf_counter() - t0)
    if not isinstance(err, ParameterError):
        rec["traceback"] = traceback.format_exc()


def finish_record(rec) -> dict:
    """Stamp a finished record (time, host, process) and make it JSON-ready."""
    rec["finished_at"] = utc_now()
    rec["host"] = socket.gethostname()
    rec["pid"] = os.getpid()
    return {k: _pyval(v) for k, v in rec.items()}


def computed_record(point, key_of, empty_record, fill) -> dict:
    """The finished record of one point, computed in this process.

    ``empty_record(point, key_of(point))`` (the outputs missing), filled in
    place by ``fill(point, rec)``; an ``Exception`` raised by ``fill`` goes
    into the record (:func:`record_failure`, with the wall time since the
    record was made) instead of stopping the study.  Stamped and JSON-ready
    (:func:`finish_record`).
    """
    rec = empty_record(point, key_of(point))
    t0 = time.perf_counter()
    try:
        fill(point, rec)
    except Exception as err:  # noqa: BLE001 - one bad point must not stop the study
        record_failure(rec, err, t0)
    return finish_record(rec)


# -- journal and table ---------------------------------------------------------------------
def journal_path(table) -> str:
    """The journal of ``table``: ``<table>.journal.jsonl``."""
    return os.fspath(table) + ".journal.jsonl"


def read_journal(path, *, key_of, required) -> dict:
    """Finished points of a journal, ``{key: record}`` in order of first appearance.

    Lines that are not complete JSON records (a write cut short by a crash,
    garbage) are skipped; for lines with the same key the last one wins.  Keys
    are recomputed from the parameters stored in each line (``key_of(record)``;
    lines it refuses with ``ParameterError`` are skipped); lines without the
    ``required`` fields are skipped.  A missing file is an empty journal.
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
            key = key_of(rec)
        except ParameterError:
            continue
        rec["key"] = key
        out[key] = rec  # keeps the first position, the last line's values
    return out


class Journal:
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

    def append(self, rec) -> None:
        data = (dumps_json(rec, compact=True) + "\n").encode()
        n = os.write(self.fd, data)
        while n < len(data):  # short writes are rare on files; finish the line
            n += os.write(self.fd, data[n:])
        os.fsync(self.fd)

    def close(self) -> None:
        if self.fd is not None:
            os.close(self.fd)
            self.fd = None


def typed_frame(records, columns, *, floats=(), ints=(), bools_or_na=(), bools=(),
                strings=()):
    """Records as a DataFrame with fixed columns and dtypes (missing values stay
    missing: NaN floats, nullable ``Int64``/``boolean``, None strings; ``bools``
    count a missing value as False)."""
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


def check_table(table) -> str:
    """Check a study's ``table`` argument up front; returns its path.

    ``.csv`` or ``.parquet`` (which needs pyarrow), in a writable folder, and
    not an existing file without its journal (which this study would replace).
    """
    path = check_writable("table", table, [".csv", ".parquet"])
    if path.lower().endswith(".parquet"):
        try:
            import pyarrow  # noqa: F401  (optional dependency: only to check it is there)
        except ImportError:
            raise ParameterError("table: writing .parquet needs pyarrow: pip install "
                                 "'skfem_sheet[parquet]' (or use a .csv table)") from None
    if os.path.exists(path) and not os.path.exists(journal_path(path)):
        raise ParameterError(
            f"table {path!r} exists without its journal {journal_path(path)!r} (the record of "
            "finished points): move the table away or choose another name")
    return path


def write_table(df, path) -> None:
    """Replace ``path`` atomically by ``df`` (CSV or Parquet by suffix)."""
    if os.fspath(path).lower().endswith(".parquet"):
        buf = io.BytesIO()
        df.to_parquet(buf, index=False)
        atomic_write(path, buf.getvalue())
    else:
        atomic_write(path, df.to_csv(index=False))


def table_records(done, order) -> list:
    """This study's points in request order, then older points of the journal."""
    seen = set(order)
    return [done[k] for k in order if k in done] + [r for k, r in done.items() if k not in seen]


class StudyInterrupted(KeyboardInterrupt):
    """Ctrl-C during a study: what was kept, and where.

    A ``KeyboardInterrupt``; its text says how many of the study's points are
    finished and kept, in which table, and how to go on.

    Attributes
    ----------
    desc : str
        The study (the progress bar's label, e.g. ``"sweep"``).
    finished, points : int
        Distinct points finished (this run and earlier ones), of all asked for.
    new : int
        Of those, finished in this run.
    table : str or None
        Where they are kept (with its journal), or None: nothing was written.
    records : dict
        Key -> record of every finished point (also without a table).

    Examples
    --------
    >>> print(StudyInterrupted("sweep", finished=3, points=8, new=2, table="s.csv", records={}))
    sweep interrupted: 3 of 8 points are finished (2 in this run) and kept in s.csv and its \
journal; the 5 others were abandoned or not started: run it again to compute them
    """

    def __init__(self, desc, *, finished, points, new, table, records):
        self.desc, self.finished, self.points, self.new = desc, finished, points, new
        self.table, self.records = table, records
        rest = points - finished
        if table:
            where = (f"kept in {table} and its journal; the {rest} others were abandoned or "
                     f"not started: run it again to compute them")
        else:
            where = ("not kept (no table was given: pass table= to keep them); "
                     f"the {rest} others were abandoned or not started")
        super().__init__(f"{desc} interrupted: {finished} of {points} points are finished "
                         f"({new} in this run) and {where}")


# -- the job -------------------------------------------------------------------------------
@dataclass(frozen=True)
class Job:
    """How one kind of point is computed, failed, keyed and tabulated.

    Attributes
    ----------
    task : callable
        ``task(points) -> list of records``, a module-level function (so that
        worker processes can unpickle it); each record holds its ``key`` and
        ``converged``, and is JSON-ready (:func:`finish_record`).
    failed : callable
        ``failed(point, message, error) -> record`` of a point whose task died
        outside the computation (e.g. its worker process was killed).
    frame : callable
        ``frame(records) -> pandas.DataFrame``, the table.
    key_of : callable
        ``key_of(record) -> key``, recomputed from a journal line's parameters.
    required : tuple of str
        Fields a journal line must have to count.
    desc : str
        Label of the progress bar.
    """

    task: Callable
    failed: Callable
    frame: Callable
    key_of: Callable
    required: tuple
    desc: str


@dataclass(frozen=True)
class EachPoint:
    """A study's chunk task: its points computed in sequence, one record each, in order.

    ``EachPoint(module, name)(points)`` is ``[run(p) for p in points]`` with
    ``run = module.name`` (catching its computation's exceptions,
    :func:`record_failure`); with ``shared``, ``run(p, context)`` with
    ``context = module.shared()`` made once for the chunk.  The functions are
    looked up by name when the task runs, so the task pickles as strings.

    Attributes
    ----------
    module : str
        The module's import name (``__name__`` of the study).
    name : str
        The function's name in it.
    shared : str
        The name of a module-level factory of the chunk's shared context, or
        ``""`` for none.
    """

    module: str
    name: str
    shared: str = ""

    def __call__(self, points) -> list:
        module = importlib.import_module(self.module)
        run = getattr(module, self.name)
        if not self.shared:
            return [run(p) for p in points]
        context = getattr(module, self.shared)()
        return [run(p, context) for p in points]


def failed_record(empty_record, key_of, point, message, error) -> dict:
    """The record of a point whose task failed outside its computation (e.g. its worker died).

    ``empty_record(point, key_of(point))`` (the study's record with the
    outputs missing) with ``message`` (the reason), ``error`` (its class, e.g.
    ``"WorkerDied"``) and the ``finished_at`` stamp.  A study binds the first
    two arguments (``functools.partial``) to make its :attr:`Job.failed`.
    """
    rec = empty_record(point, key_of(point))
    rec.update(message=message, error=error, finished_at=utc_now())
    return rec


def execute(points, keys, job, *, table, workers, scheduler, progress, retry_failed, chunker):
    """Run the points not yet in ``table``'s journal; journal, table and progress bar.

    Parameters
    ----------
    points, keys : list
        Normalised points and their keys (same order; a key may repeat).
    job : Job
    table : str or None
        Checked table path (:func:`check_table`), or None: nothing written,
        nothing resumed.
    workers : int or None
        Local processes (default ``os.cpu_count()``); 1: in this process.
    scheduler : str, distributed.Client or None
        A Dask cluster instead (:func:`dask_client`).
    progress : bool
    retry_failed : bool
        Compute again the points whose stored record is not converged.
    chunker : callable
        ``chunker(points, n_slots) -> list of lists``: the tasks.

    Returns
    -------
    done : dict
        Every key of the journal (and of this run) -> its record.
    stats : dict
        ``new``, ``cached``, ``points`` (distinct), ``table``, ``journal``, and
        ``new_keys``: the keys of the ``new`` records (computed in this run,
        failed ones included), in the order they finished.

    Raises
    ------
    StudyInterrupted
        On Ctrl-C (``KeyboardInterrupt``): the points in flight abandoned, the
        table written; it says what was kept.
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
    before = {k: done[k].get("finished_at") for k in todo_keys if k in done}

    client, own_client = (None, False)
    if scheduler is not None:
        client, own_client = dask_client(scheduler)

    # leave=None: kept on screen unless nested under another bar (``figure all``'s)
    bar = tqdm(total=len(order), initial=n_cached, desc=job.desc, unit="pt", file=sys.stderr,
               disable=not progress, dynamic_ncols=True, leave=None)
    failed = sum(1 for k in order if k in done and k not in todo_keys
                 and not done[k].get("converged"))
    bar.set_postfix(failed=failed, refresh=False)
    journal = Journal(jpath) if jpath else None
    last_table = time.monotonic()
    new_keys = []
    interrupted = False
    try:
        if todo:
            if client is not None:
                slots = sum(client.nthreads().values()) or 1
                results = dask(chunker(todo, slots), client, job.task, job.failed)
            elif n_workers == 1:
                results = ([rec] for chunk in chunker(todo, 1) for p in chunk
                           for rec in job.task([p]))
            else:
                results = pool(chunker(todo, n_workers), n_workers, job.task, job.failed)
            try:
                for recs in results:
                    for rec in recs:
                        if journal is not None:
                            journal.append(rec)
                        done[rec["key"]] = rec
                        new_keys.append(rec["key"])
                        failed += not rec["converged"]
                        bar.set_postfix(failed=failed, refresh=False)
                        bar.update(1)
                    if table and time.monotonic() - last_table > TABLE_EVERY_S:
                        write_table(job.frame(table_records(done, order)), table)
                        last_table = time.monotonic()
            finally:
                close = getattr(results, "close", None)
                if close is not None:
                    close()  # stops the workers now (also on Ctrl-C)
    except KeyboardInterrupt:
        interrupted = True
    finally:
        bar.close()
        if journal is not None:
            journal.close()
        if own_client:
            client.close()
        disk = None
        if table:
            # rebuilt from the journal file: also keeps lines appended by others
            disk = read_journal(jpath, key_of=job.key_of, required=job.required)
            write_table(job.frame(table_records(disk, order)), table)
    if interrupted:
        # what is kept is what the journal holds (Ctrl-C may land between a line's
        # write and its count here)
        kept = done if disk is None else disk
        raise StudyInterrupted(
            job.desc, finished=sum(1 for k in order if k in kept), points=len(order),
            new=sum(1 for k in todo_keys if k in kept
                    and (k not in before or kept[k].get("finished_at") != before[k])),
            table=table, records=kept) from None
    return done, {"new": len(new_keys), "cached": n_cached, "points": len(order),
                  "table": table, "journal": jpath, "new_keys": tuple(new_keys)}


def study_points(points, normalize, maker) -> list:
    """A study's ``points`` argument normalised (``normalize(point)`` each).

    ``ParameterError`` for a single dict given instead of a list (``maker``
    names the function that makes the list, e.g. ``"grid"``).
    """
    if isinstance(points, dict):
        raise ParameterError(f"points must be a list of dicts (use {maker}(...)), got one dict")
    return [normalize(p) for p in points]


def check_run(table, workers, scheduler):
    """Check a study's ``table``, ``workers`` and ``scheduler`` arguments; the table's path.

    ``ParameterError`` for ``workers`` with ``scheduler``, ``workers`` not an
    integer >= 1, or a bad ``table`` (:func:`check_table`); None for no table.
    """
    if scheduler is not None and workers is not None:
        raise ParameterError("workers must not be given with scheduler (Dask decides)")
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int)
                                or workers < 1):
        raise ParameterError(f"workers must be an integer >= 1, got {workers!r}")
    return check_table(table) if table is not None else None


# -- local processes -----------------------------------------------------------------------
def _watch_parent(parent_pid):
    while True:
        time.sleep(0.5)
        if os.getppid() != parent_pid:
            os._exit(1)  # the study was killed: do not go on computing for nobody


def _init_pool_worker(parent_pid):
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's business
    # A worker holds both ends of the pool's pipes, so it would wait forever for
    # work from a parent killed with SIGKILL: it exits when its parent changes.
    threading.Thread(target=_watch_parent, args=(parent_pid,), daemon=True).start()


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
    """Shut the pool down: after its work (``kill=False``), or at once
    (``kill=True``: the points in flight are abandoned, their workers killed).

    The workers are taken before ``shutdown``, which forgets them: killed
    after it, they would go on with their points, and the interpreter's exit
    would wait for those.
    """
    if not kill:
        ex.shutdown(wait=True)
        return
    procs = list((getattr(ex, "_processes", None) or {}).values())
    terminate = getattr(ex, "terminate_workers", None)  # Python >= 3.14
    if terminate is not None:
        terminate()
    else:
        for proc in procs:
            if proc.is_alive():
                proc.terminate()
    ex.shutdown(wait=False, cancel_futures=True)
    for proc in procs:
        proc.join(5)
        if proc.is_alive():     # SIGTERM not heeded within 5 s
            proc.kill()
            proc.join(1)


def _new_pool(n):
    """A pool of ``n`` spawned workers that ignore Ctrl-C and exit with their parent."""
    return ProcessPoolExecutor(max_workers=n, mp_context=multiprocessing.get_context("spawn"),
                               initializer=_init_pool_worker, initargs=(os.getpid(),))


def pool(chunks, n_workers, task, failed):
    """Chunks on ``n_workers`` spawned processes; yields lists of records.

    At most ``n_workers`` chunks are in flight.  If a worker process dies (the
    pool breaks), the points of the chunks in flight are computed again one at
    a time in a fresh single-process pool, so that only a point that kills its
    worker on its own is recorded as failed (``failed(point, message,
    error)``).  Each worker is limited to ``cpu_count // n_workers`` BLAS/MKL
    threads unless ``OMP_NUM_THREADS``/``MKL_NUM_THREADS``/``OPENBLAS_NUM_THREADS``
    are set.
    """
    threads = max(1, (os.cpu_count() or 1) // n_workers)
    queue = list(reversed(chunks))
    ex = None
    with _thread_env(threads):
        try:
            ex = _new_pool(n_workers)
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
                        else:  # not from a computation (those are caught): e.g. pickling
                            yield [failed(p, f"the worker failed: {type(err).__name__}: {err}",
                                          type(err).__name__) for p in chunk]
                if broken:
                    _stop_pool(ex, kill=True)
                    ex = None
                    yield from _isolated(suspects, _new_pool, task, failed)
                    ex = _new_pool(n_workers)
        except BaseException:
            if ex is not None:
                _stop_pool(ex, kill=True)
                ex = None
            raise
        finally:
            if ex is not None:
                _stop_pool(ex, kill=False)


@contextlib.contextmanager
def beside(task, *args):
    """Run ``task(*args)`` on one spawned process while the caller goes on.

    Yields the task's :class:`concurrent.futures.Future`, on a worker of
    :func:`pool`'s kind (one BLAS thread unless set).  Leaving the block
    normally waits for the task; leaving it by an exception (Ctrl-C
    included) kills the process.  ``task`` must be a module-level function.

    Examples
    --------
    >>> with beside(os.getpid) as fut:  # doctest: +SKIP
    ...     fut.result() != os.getpid()
    True
    """
    ex = _new_pool(1)
    finished = False
    try:
        with _thread_env(1):  # the process starts on the first submit
            fut = ex.submit(task, *args)
        yield fut
        finished = True
    finally:
        _stop_pool(ex, kill=not finished)


def _ping():
    return os.getpid()


def _isolated(points, new_pool, task, failed):
    """Compute points one at a time, each in a fresh worker if the previous one died."""
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
                yield [failed(p, "the worker process died while solving this point "
                                 "(killed, out of memory or crashed)", "WorkerDied")]
                _stop_pool(ex, kill=True)
                ex = new_pool(1)
    except BaseException:
        _stop_pool(ex, kill=True)
        raise
    _stop_pool(ex, kill=False)


# -- where a batch runs ---------------------------------------------------------------------
@dataclass(frozen=True)
class Workers:
    """Where the tasks of a batch run: the Dask cluster of ``scheduler``, or
    ``local`` processes of this machine.

    Passed where a number of workers is (the figures' ``workers``), so that
    the studies under it (:func:`execute`, :func:`on_executor`) run their
    tasks on the cluster, journalled here; work that stays on this machine
    takes ``int(workers)``: ``local``, or one per CPU if None.

    Attributes
    ----------
    scheduler : str, distributed.Client or None
        The cluster (an address like ``tcp://host:8786``, or a client); None:
        ``local`` processes.
    local : int or None
        Processes of this machine.

    Examples
    --------
    >>> w = Workers(scheduler="tcp://127.0.0.1:8786", local=3)
    >>> int(w), study_executor(w)
    (3, {'workers': None, 'scheduler': 'tcp://127.0.0.1:8786'})
    >>> study_executor(4), study_executor(Workers(local=2))
    ({'workers': 4, 'scheduler': None}, {'workers': 2, 'scheduler': None})
    """

    scheduler: object = None
    local: int | None = None

    def __post_init__(self):
        if self.local is not None and (isinstance(self.local, bool)
                                       or not isinstance(self.local, int) or self.local < 1):
            raise ParameterError(f"local must be an integer >= 1, got {self.local!r}")

    def __int__(self) -> int:
        return int(self.local) if self.local is not None else (os.cpu_count() or 1)

    __index__ = __int__

    def __float__(self) -> float:
        return float(int(self))


def study_executor(workers) -> dict:
    """``workers`` (None, a number, or :class:`Workers`) as the ``workers`` and
    ``scheduler`` arguments of a study (:func:`execute`, :func:`check_run`).
    See :class:`Workers` for examples."""
    if isinstance(workers, Workers):
        if workers.scheduler is not None:
            return {"workers": None, "scheduler": workers.scheduler}
        return {"workers": workers.local, "scheduler": None}
    return {"workers": workers, "scheduler": None}


def on_executor(chunks, workers, task, failed):
    """``task(chunk)`` for each of ``chunks`` on the Dask cluster of ``workers``
    (a :class:`Workers` with a scheduler: :func:`dask`) or on ``int(workers)``
    spawned local processes (:func:`pool`); yields each chunk's list of
    records as it finishes (``failed(point, message, error)`` for a point
    whose task died)."""
    ex = study_executor(workers)
    if ex["scheduler"] is None:
        yield from pool(chunks, int(workers), task, failed)
        return
    client, own = dask_client(ex["scheduler"])
    try:
        yield from dask(chunks, client, task, failed)
    finally:
        if own:
            client.close()


# -- Dask ----------------------------------------------------------------------------------
def dask_client(scheduler):
    """``(client, own)`` for a scheduler address (a new client, ``own``) or a client."""
    if not isinstance(scheduler, str):
        if not hasattr(scheduler, "submit"):
            raise ParameterError("scheduler must be an address like 'tcp://host:8786' or a "
                                 f"distributed.Client, got {type(scheduler).__name__}")
        return scheduler, False
    try:
        from distributed import Client  # optional dependency (the 'cluster' extra)
    except ImportError:
        raise ParameterError("scheduler needs dask and distributed: "
                             "pip install 'skfem_sheet[cluster]'") from None
    try:
        return Client(scheduler, timeout="20s", set_as_default=False), True
    except (OSError, TimeoutError, ValueError) as err:
        raise ParameterError(f"scheduler: cannot connect to {scheduler!r}: {err}") from None


def dask(chunks, client, task, failed):
    """Chunks as Dask tasks; yields lists of records.  A chunk whose task fails
    is retried point by point; a single point whose task fails is a failed record."""
    from distributed import as_completed  # optional dependency (the 'cluster' extra)

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
            except Exception as err:  # noqa: BLE001 - e.g. KilledWorker: not the study's end
                if len(chunk) > 1:
                    for p in chunk:
                        todo.add(submit([p]))
                else:
                    yield [failed(chunk[0], f"the Dask task failed: {type(err).__name__}: "
                                            f"{err}", type(err).__name__)]
    except BaseException:
        client.cancel(list(futures))
        raise
