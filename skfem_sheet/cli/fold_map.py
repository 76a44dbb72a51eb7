"""``skfem-sheet fold-map``: pop-up and standout lengths over a grid of (b/a, a/R).

See :mod:`skfem_sheet.studies.foldmap` for the table.
"""
from __future__ import annotations

import numpy as np

from ..studies.foldmap import critical_tip_width, fold_map, map_points
from .ranges import parse_range, parse_values
from .solve import solver_help

__all__ = ["register", "run"]


def register(subparsers) -> None:
    """Add the ``fold-map`` command."""
    p = subparsers.add_parser(
        "fold-map", help="pop-up and standout lengths over a grid of (b/a, a/R)",
        description="Fold lengths L0* (pop-up) and L1* (standout) for every (tip width, "
                    "curvature) of a grid, in parallel, into a resumable table; prints the "
                    "critical shape factor (b/a)* of each curvature.")
    p.add_argument("--tip-widths", default="0.5:1:0.1",
                   help="b/a values: a list '0.6,0.8,1' or a range 'start:stop:step'")
    p.add_argument("--curvatures", default="2.5", help="a/R values (list or range)")
    p.add_argument("--lengths", default="0.5:3", help="search range 'short:long' in L/a")
    p.add_argument("--hmax", type=float, default=0.1)
    p.add_argument("--layers", type=int, default=None)
    p.add_argument("--step", type=float, default=0.1, help="largest continuation step in L/a")
    p.add_argument("--tol", type=float, default=0.005, help="half-width of the fold brackets")
    p.add_argument("--solver", default="auto", help=solver_help())
    p.add_argument("--table", default=None, help="results .csv or .parquet (resumable)")
    p.add_argument("--workers", type=int, default=None)
    p.add_argument("--scheduler", default=None, help="Dask scheduler address tcp://host:port")
    p.add_argument("--retry-failed", action="store_true")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(run=run)


def run(args) -> int:
    """Compute the map, print the fold lengths and (b/a)*; 0 if every point converged."""
    tip_widths = parse_values(args.tip_widths, "tip-widths")
    curvatures = parse_values(args.curvatures, "curvatures")
    lengths = parse_range(args.lengths, "lengths", pair="short:long", example="0.6:2.4")
    points = map_points(tip_widths, curvatures, lengths=lengths, hmax=args.hmax,
                        layers=args.layers, step=args.step, tol=args.tol, solver=args.solver)
    df = fold_map(points, table=args.table, workers=args.workers, scheduler=args.scheduler,
                  progress=not args.quiet, retry_failed=args.retry_failed)

    def fmt(x):
        return "   none" if not np.isfinite(x) else f"{x:7.3f}"

    print(f"hmax = {args.hmax:g}, L/a searched in [{lengths[0]:g}, {lengths[1]:g}]")
    print("  a/R    b/a   L0* pop-up  L1* standout  bistable  converged")
    for _, r in df.iterrows():
        print(f"{r.curvature:5.2f}  {r.tip_width:5.2f}      {fmt(r.popup_length)}       "
              f"{fmt(r.standout_length)}  {str(bool(r.bistable)):>8}  {str(bool(r.converged)):>9}"
              + (f"  {r.message}" if r.message else ""))
    for c, (est, lo, hi) in critical_tip_width(df).items():
        if np.isfinite(est):
            print(f"a/R = {c:g}: (b/a)* ~ {est:.3f}, in [{lo:g}, {hi:g}]")
        elif np.isfinite(lo):
            print(f"a/R = {c:g}: no bistable shape factor up to b/a = {lo:g}")
        else:
            print(f"a/R = {c:g}: bistable down to b/a = {hi:g} (the smallest in the map)")
    if args.table:
        print(f"table: {df.attrs['fold_map']['table']}")
    return 0 if df["converged"].all() else 1
