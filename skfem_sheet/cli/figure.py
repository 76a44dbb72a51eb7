"""``skfem-sheet figure``: draw one of the paper's figures, or ``all`` of them
(see :mod:`skfem_sheet.figures`).

Examples
--------
>>> import argparse
>>> p = argparse.ArgumentParser(); sub = p.add_subparsers(dest="command")
>>> register(sub)
>>> args = p.parse_args(["figure", "fig2", "--quality", "paper"])
>>> args.name, args.quality, args.out, args.data_dir
('fig2', 'paper', None, 'skfem_sheet_data')
>>> p.parse_args(["figure", "all", "--out-dir", "figs"]).out_dir
'figs'
>>> p.parse_args(["figure", "all", "--scheduler", "tcp://host:8786"]).scheduler
'tcp://host:8786'
"""
from __future__ import annotations

import os
import sys

import matplotlib

from ..figures import DEFAULT_DATA_DIR, FIGURES, QUALITIES, make_all, make_figure, summary_text
from ..figures.batch import SUMMARY_FILES
from ..io import check_writable
from ..params import ParameterError
from ..studies.runner import Workers, dask_client

__all__ = ["register", "run", "ALL"]

#: The name that draws every figure of :data:`~skfem_sheet.figures.FIGURES`.
ALL = "all"


def register(subparsers) -> None:
    """Add the ``figure`` command."""
    p = subparsers.add_parser("figure", help="draw one of the paper's figures (or all)",
                              description="Draw one of the paper's figures, or all of them "
                                          "(data cached in --data-dir).")
    p.add_argument("name", choices=[*FIGURES, ALL], metavar="NAME",
                   help=f"one of {', '.join(FIGURES)}, or {ALL} (every figure into --out-dir)")
    p.add_argument("--quality", choices=QUALITIES, default="quick",
                   help="quick (fold map at hmax 0.1) or paper (hmax 0.03, finer grids)")
    p.add_argument("--out", default=None, help="output PNG (default NAME.png; not with all)")
    p.add_argument("--out-dir", default=None,
                   help="folder of the PNGs (NAME.png) and, with all, the summary "
                        f"({', '.join(SUMMARY_FILES)}); default: the current folder")
    p.add_argument("--data-dir", default=DEFAULT_DATA_DIR,
                   help=f"folder of the cached tables (default ./{DEFAULT_DATA_DIR}/)")
    p.add_argument("--workers", type=int, default=None,
                   help="processes for the fold map, the fold curves and figS1's solves "
                        "(default: one per CPU; figS1 two at most); with --scheduler, the "
                        "processes of this machine for what stays here")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="a Dask scheduler, tcp://host:port: the fold-map rows and the fold "
                        "curves run on its cluster, journalled in --data-dir as on local "
                        "processes (resumable with or without it)")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    p.set_defaults(run=run)


def run(args) -> int:
    """Compute (or read from the cache) and draw the figure into ``--out``; with
    ``all``, every figure into ``--out-dir`` and print the summary table.

    Returns 0, or 1 if a figure of ``all`` failed (the summary says which)."""
    if args.workers is not None and args.workers < 1:
        raise ParameterError(f"--workers must be in [1, inf), got {args.workers}")
    out_dir = getattr(args, "out_dir", None)
    if args.name == ALL:
        if args.out is not None:
            raise ParameterError(f"--out names one file; with NAME {ALL} give --out-dir "
                                 f"(got --out {args.out!r})")
        return _run_all(args, out_dir or ".")
    if args.out is not None and out_dir is not None:
        raise ParameterError("give --out or --out-dir, not both")
    out = args.out or os.path.join(out_dir or "", f"{args.name}.png")
    check_writable("--out", out, [".png", ".pdf", ".svg"])
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # deferred: after choosing the file backend (Agg)

    client, own = dask_client(args.scheduler) if args.scheduler else (None, False)
    try:
        workers = args.workers if client is None else Workers(scheduler=client,
                                                               local=args.workers)
        fig = make_figure(args.name, args.quality, out, args.data_dir,
                          progress=not args.quiet, workers=workers)
    finally:
        if own:
            client.close()
    plt.close(fig)
    print(f"{args.name} ({args.quality}): wrote {out} (data cached in {args.data_dir})")
    return 0


def _run_all(args, out_dir) -> int:
    matplotlib.use("Agg")
    runs = make_all(args.quality, out_dir, args.data_dir, progress=not args.quiet,
                    workers=args.workers, scheduler=args.scheduler)
    print(summary_text(runs, f"figure all ({args.quality}): data in {args.data_dir}"))
    wrote = [r.out for r in runs if r.out]
    print(f"wrote {len(wrote)} figures and "
          f"{' and '.join(os.path.join(out_dir, f) for f in SUMMARY_FILES)}")
    failed = [r for r in runs if r.error]
    for r in failed:
        print(f"{r.name} failed: {r.error}", file=sys.stderr)
    return 1 if failed else 0
