"""``skfem-sheet figure``: draw one of the paper's figures (see :mod:`skfem_sheet.figures`).

Examples
--------
>>> import argparse
>>> p = argparse.ArgumentParser(); sub = p.add_subparsers(dest="command")
>>> register(sub)
>>> args = p.parse_args(["figure", "fig2", "--quality", "paper"])
>>> args.name, args.quality, args.out, args.data_dir
('fig2', 'paper', None, 'skfem_sheet_data')
"""
from __future__ import annotations

import matplotlib

from ..figures import DEFAULT_DATA_DIR, FIGURES, QUALITIES, make_figure
from ..io import check_writable
from ..params import ParameterError

__all__ = ["register", "run"]


def register(subparsers) -> None:
    """Add the ``figure`` command."""
    p = subparsers.add_parser("figure", help="draw one of the paper's figures",
                              description="Draw one of the paper's figures (data cached in "
                                          "--data-dir).")
    p.add_argument("name", choices=list(FIGURES), metavar="NAME",
                   help=f"one of {', '.join(FIGURES)}")
    p.add_argument("--quality", choices=QUALITIES, default="quick",
                   help="quick (fold map at hmax 0.1) or paper (hmax 0.03, finer grids)")
    p.add_argument("--out", default=None, help="output PNG (default NAME.png)")
    p.add_argument("--data-dir", default=DEFAULT_DATA_DIR,
                   help=f"folder of the cached tables (default ./{DEFAULT_DATA_DIR}/)")
    p.add_argument("--workers", type=int, default=None,
                   help="processes for the fold map (default: one per CPU)")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    p.set_defaults(run=run)


def run(args) -> int:
    """Compute (or read from the cache) and draw the figure into ``--out``."""
    out = args.out or f"{args.name}.png"
    check_writable("--out", out, [".png", ".pdf", ".svg"])
    if args.workers is not None and args.workers < 1:
        raise ParameterError(f"--workers must be in [1, inf), got {args.workers}")
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # deferred: after choosing the file backend (Agg)

    fig = make_figure(args.name, args.quality, out, args.data_dir, progress=not args.quiet,
                      workers=args.workers)
    plt.close(fig)
    print(f"{args.name} ({args.quality}): wrote {out} (data cached in {args.data_dir})")
    return 0
