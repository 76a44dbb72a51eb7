"""Every figure in one run (``python -m skfem_sheet figure all``): :func:`make_all`.

The figures are drawn one after the other into ``out_dir/<name>.png`` from
one data folder, so they share the fold-map table and the fold-curve table.
:func:`run_order` draws fig7 before fig6, so that all 18 fold curves are
traced in one batch over the workers, and fig2's and fig4's rows are
computed in one batch (:data:`SHARED_ROWS`).  fig3, figS1, figS3 and figS4
keep their own solves and run in one process beside the others where those
compute on two workers or more (:data:`ALONGSIDE`, :func:`plan`).  On a Dask
cluster (``scheduler``) the fold-map rows and fold curves are the cluster's
tasks, journalled here as a local run's are, the curves in the rows' batch
(:data:`CURVES_WITH_ROWS`); what writes files of its own stays on this
machine.

:func:`make_all` writes ``out_dir/summary.txt`` and ``summary.json``
(:mod:`skfem_sheet.figures.work`: per figure its wall time, solves,
factorisations, units computed and cached).  A figure that fails is recorded
there and the others are drawn; Ctrl-C writes the summary of the figures
finished and stops.

Examples
--------
>>> run_order(["fig2", "fig6", "fig7", "figS1"])
['fig2', 'fig7', 'fig6', 'figS1']
>>> plan(["fig2", "fig3", "fig7", "figS1"], workers=2)
(['fig2', 'fig7'], ['fig3', 'figS1'])
>>> plan(["fig2", "fig3", "fig7", "figS1"], workers=1)
(['fig2', 'fig3', 'fig7', 'figS1'], [])
>>> plan(["fig2", "fig3", "fig7", "figS1"], workers=Workers(scheduler="tcp://host:8786", local=1))
(['fig2', 'fig7'], ['fig3', 'figS1'])
"""
from __future__ import annotations

import contextlib
import os
import sys
import threading
import time

from tqdm.auto import tqdm

from .. import version
from ..io import atomic_write, dumps_json
from ..params import ParameterError
from .cache import data_folder
from .common import DEFAULT_DATA_DIR, quality_settings
from .data import (
    Workers,
    beside,
    dask_client,
    fold_curve_points,
    fold_curve_table,
    fold_map_table,
    foldmap,
)
from .figure2 import fig2_points
from .figure4 import fig4_points
from .registry import FIGURES, make_figure
from .work import FigureRun, summary_json, summary_text

__all__ = ["make_all", "run_order", "plan", "ALONGSIDE", "CURVES_WITH_ROWS", "SHARED_ROWS",
           "SUMMARY_FILES"]

#: The summary's files in the output folder: the text table and the JSON.
SUMMARY_FILES = ("summary.txt", "summary.json")

#: Figures whose fold-map rows are computed in one batch before the first of
#: them is drawn, where both are (fig5's rows are fig2's): one batch over the
#: workers, the most expensive rows first, instead of one per figure, each
#: ending with a worker idle while the other finishes its last row.  Its
#: entry in the summary is named after them (``"fig2+fig4-rows"``); the
#: figures then read their rows.
SHARED_ROWS = ("fig2", "fig4")
_POINTS = {"fig2": fig2_points, "fig4": fig4_points}

#: Figures with their own finite-element solves and no table shared with
#: another figure (fig3's surfaces, figS1's convergence solves, figS3's and
#: figS4's sheet).  Where the other figures compute on two workers or more,
#: these are drawn one after the other in one process of their own, beside
#: them (:func:`plan`): drawn in turn, their solves ran on one core while the
#: other waited (figS1's finest mesh alone 157 s of the 240 s the four took
#: at paper quality on main 3a969d2); beside the workers they fill the cores.
ALONGSIDE = ("fig3", "figS1", "figS3", "figS4")
#: Figures whose fold curves (:func:`~skfem_sheet.figures.data.fold_curve_points`)
#: are traced together with the rows of :data:`SHARED_ROWS` on a Dask cluster.
CURVES_WITH_ROWS = ("fig7", "fig6")
#: Figures whose data is computed on the workers (the fold map, the fold curves).
_ON_WORKERS = ("fig2", "fig4", "fig6", "fig7")


def run_order(names) -> list:
    """The order in which :func:`make_all` draws ``names``: as given, with fig7
    moved just before fig6 (its fold curves include fig6's; see the module)."""
    names = list(names)
    if "fig6" in names and "fig7" in names:
        names.remove("fig7")
        names.insert(names.index("fig6"), "fig7")
    return names


def plan(names, workers=None) -> tuple:
    """``(here, beside)``: the figures of ``names`` drawn one after the other
    in this process (in :func:`run_order`) and those of :data:`ALONGSIDE`
    drawn in a process beside it -- none unless a figure computed on the
    workers is drawn here and the workers are a Dask cluster's
    (:class:`~skfem_sheet.studies.runner.Workers` with a scheduler: this
    machine's cores are free while they compute) or at least 2 (default: one
    per CPU).  See the module's examples."""
    order = run_order(names)
    cluster = isinstance(workers, Workers) and workers.scheduler is not None
    n = (os.cpu_count() or 1) if workers is None else int(workers)
    side = [x for x in order if x in ALONGSIDE]
    if (n < 2 and not cluster) or not any(x in _ON_WORKERS for x in order):
        return order, []
    return [x for x in order if x not in side], side


def _draw_beside(names, quality, out_dir, data_dir) -> tuple:
    """The side process's task: ``names`` drawn one after the other into
    ``out_dir`` (their solves on this one core, no progress bars)."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    return tuple(_draw(n, quality, out_dir, data_dir, False, 1) for n in names)


def _out_folder(out_dir) -> str:
    out_dir = os.fspath(out_dir)
    try:
        os.makedirs(out_dir, exist_ok=True)
    except OSError as err:
        raise ParameterError(f"out_dir must be a writable folder, got {out_dir!r} ({err})") \
            from None
    if not os.access(out_dir, os.W_OK):
        raise ParameterError(f"out_dir must be a writable folder, got {out_dir!r}")
    return out_dir


def _on_cluster(workers) -> bool:
    return isinstance(workers, Workers) and workers.scheduler is not None


def _shared_rows(names, quality, data_dir, progress, workers):
    """The rows of :data:`SHARED_ROWS` in one fold-map batch, as a summary
    entry (None unless all of them are in ``names``); an exception becomes
    the entry's error (each figure then computes what it misses).

    On a Dask cluster the fold curves of fig7 (and fig6's, two of them) are
    traced at the same time (:data:`CURVES_WITH_ROWS`, ``-curves`` in the
    entry's name): the two studies are independent, and on many workers the
    rows' batch alone leaves workers idle while its longest rows finish."""
    if not all(n in names for n in SHARED_ROWS):
        return None
    points, seen = [], set()
    for name in SHARED_ROWS:
        for p in _POINTS[name](quality):
            key = foldmap.map_key(p)
            if key not in seen:
                seen.add(key)
                points.append(p)
    log, curve_log = [], []
    curves = _on_cluster(workers) and any(n in names for n in CURVES_WITH_ROWS)
    t0 = time.perf_counter()
    entry = "+".join(SHARED_ROWS) + "-rows" + ("+curves" if curves else "")
    errors, thread = [], None
    if curves:
        # the client is thread-safe and the curves' table their own; a daemon
        # thread, so that Ctrl-C here is not held up by it (the journal keeps
        # every curve it finished)
        def trace():
            try:
                fold_curve_table(fold_curve_points(quality), quality, data_dir, False, workers,
                                 curve_log)
            except Exception as err:  # fig7 and fig6 then trace what they miss
                errors.append(f"fold curves: {type(err).__name__}: {err}")

        thread = threading.Thread(target=trace, name="fold curves", daemon=True)
        thread.start()
    try:
        fold_map_table(points, quality, data_dir, progress, workers, log)
    except Exception as err:  # recorded in the summary; the figures go on
        errors.insert(0, f"{type(err).__name__}: {err}")
    if thread is not None:
        thread.join()
    return FigureRun(entry, "", time.perf_counter() - t0, tuple(log + curve_log),
                     "; ".join(errors))


def _draw(name, quality, out_dir, data_dir, progress, workers) -> FigureRun:
    """One figure into ``out_dir/<name>.png``; an exception (not Ctrl-C) becomes
    the run's error."""
    import matplotlib.pyplot as plt  # deferred: make_figure chose the file backend

    out = os.path.join(out_dir, f"{name}.png")
    log = []
    t0 = time.perf_counter()
    try:
        fig = make_figure(name, quality, out, data_dir, progress, workers, log=log)
        plt.close(fig)
    except Exception as err:  # recorded in the summary; the other figures go on
        return FigureRun(name, "", time.perf_counter() - t0, tuple(log),
                         f"{type(err).__name__}: {err}")
    return FigureRun(name, out, time.perf_counter() - t0, tuple(log))


def make_all(quality: str = "quick", out_dir=".", data_dir=DEFAULT_DATA_DIR,
             progress: bool = True, workers=None, names=None, scheduler=None) -> tuple:
    """Draw every figure (or ``names``) into ``out_dir``, with the summary beside them.

    Parameters
    ----------
    quality : {"quick", "paper"}
    out_dir : str
        Folder of the PNGs (``<name>.png``) and the summary
        (:data:`SUMMARY_FILES`); created if needed.
    data_dir : str
        Folder of the cached tables, shared by the figures (created if needed).
    progress : bool
        One progress bar on stderr (and the bar of the step under way).
    workers : int, optional
        Processes for the fold map and the fold curves (default: one per CPU);
        with ``scheduler``, the processes of this machine for the work that
        stays here (fig6's ribbon model; default: one per CPU).
    names : list of str, optional
        Keys of :data:`~skfem_sheet.figures.FIGURES` (default: all), drawn in
        :func:`run_order`.
    scheduler : str or distributed.Client, optional
        A Dask cluster (its address, ``tcp://host:8786``, or a client): the
        fold-map rows and the fold curves run there (see the module).

    Returns
    -------
    tuple of FigureRun
        One per figure, in the order drawn (a failed one has its ``error``),
        after the batch of :data:`SHARED_ROWS` where those figures are drawn.

    Raises
    ------
    ParameterError
        For a bad quality, figure name or folder, before anything is computed.

    Examples
    --------
    >>> runs = make_all("quick", "figures", "skfem_sheet_data")  # doctest: +SKIP
    >>> [r.name for r in runs][:3]  # doctest: +SKIP
    ['fig2', 'fig3', 'fig4']
    """
    quality_settings(quality)
    names = list(FIGURES) if names is None else list(names)
    unknown = [n for n in names if n not in FIGURES]
    if unknown or not names:
        raise ParameterError(f"names must be some of {', '.join(FIGURES)}, got {names!r}")
    out_dir = _out_folder(out_dir)
    data_folder(data_dir)
    import matplotlib  # deferred: import cost; the file backend before pyplot loads

    matplotlib.use("Agg", force=False)
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int)
                                or workers < 1):
        raise ParameterError(f"workers must be an integer >= 1, got {workers!r}")
    client, own = dask_client(scheduler) if scheduler is not None else (None, False)
    try:
        return _make_all(quality, out_dir, data_dir, progress, workers, names, client)
    finally:
        if own:
            client.close()


def _make_all(quality, out_dir, data_dir, progress, workers, names, client) -> tuple:
    about = {"quality": quality, "data_dir": os.fspath(data_dir), "out_dir": out_dir,
             "workers": workers, "version": version.__version__,
             "started_at": time.strftime("%Y-%m-%d %H:%M:%S %z")}
    where = f"workers: {workers or 'one per CPU'}"
    if client is not None:
        about["scheduler"] = str(client.scheduler.address)
        slots = sum(client.nthreads().values())
        about["cluster_threads"] = slots
        where = (f"Dask cluster {about['scheduler']} ({slots} threads); here: "
                 f"{workers or 'one per CPU'}")
        workers = Workers(scheduler=client, local=workers)
    here, side = plan(names, workers)
    about["beside"] = side
    title = (f"figure all, {quality} quality: data in {os.fspath(data_dir)}, figures in "
             f"{out_dir} ({where}"
             + (f"; {', '.join(side)} in a process beside them" if side else "") + ")")
    shared, done, t0 = None, {}, time.perf_counter()
    bar = tqdm(total=len(names), desc=f"figure all ({quality})", unit="fig", file=sys.stderr,
               disable=not progress, dynamic_ncols=True)
    try:
        with (beside(_draw_beside, side, quality, out_dir, os.fspath(data_dir)) if side
              else contextlib.nullcontext()) as fut:
            shared = _shared_rows(names, quality, data_dir, progress, workers)
            for name in here:
                bar.set_postfix_str(name)
                done[name] = _draw(name, quality, out_dir, data_dir, progress, workers)
                bar.update(1)
            if fut is not None:
                bar.set_postfix_str(", ".join(side))
                try:
                    side_runs = fut.result()
                except Exception:  # the process died (killed, out of memory): drawn here
                    side_runs = tuple(_draw(n, quality, out_dir, data_dir, progress, workers)
                                      for n in side)
                done.update((r.name, r) for r in side_runs)
                bar.update(len(side))
    finally:
        bar.close()
        runs = ([shared] if shared is not None else []) + [done[n] for n in run_order(names)
                                                           if n in done]
        _write_summary(runs, out_dir, title, {**about, "elapsed_s": time.perf_counter() - t0})
    return tuple(runs)


def _write_summary(runs, out_dir, title, about) -> None:
    text, data = SUMMARY_FILES
    table = summary_text(runs, title)
    if about["beside"]:  # the walls overlap: their sum is not the run's
        table += (f"\nelapsed {about['elapsed_s']:.1f} s ({', '.join(about['beside'])} drawn "
                  f"beside the others: the walls overlap)")
    atomic_write(os.path.join(out_dir, text), table + "\n")
    atomic_write(os.path.join(out_dir, data), dumps_json(summary_json(runs, **about)) + "\n")
