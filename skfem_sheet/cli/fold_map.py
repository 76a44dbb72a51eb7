"""``skfem-sheet fold-map``: pop-up and standout lengths over (b/a, a/R).

``--method curves`` (default): one traced fold curve per a/R (L1*, the cusp
(b/a)*, L0*; and with ``--rectangle`` the curve in (L, a/R) at b/a = 1,
whose cusp is the curvature where the rectangle becomes bistable).
``--method grid``: the fold lengths of each point of a grid, its branches
followed in L and their ends located (the reference).  The tables are
those of skfem_sheet.studies.foldmap.
"""
from __future__ import annotations

import numpy as np

from ..params import DEFAULT_HMAX, ParameterError
from ..studies.foldmap import (
    critical_curve,
    critical_tip_width,
    curve_halves,
    curve_points,
    fold_curves,
    fold_map,
    map_points,
)
from .ranges import parse_range, parse_values
from .solve import solver_help

__all__ = ["register", "run", "add_method_arguments", "print_curve_table", "METHODS"]

#: The ways of computing the map (``--method``): fold curves (the default) or a grid.
METHODS = ("curves", "grid")


def add_method_arguments(p, table_help="results .csv or .parquet (resumable)") -> None:
    """Add ``--method``, ``--table`` and ``--workers``: how and where the map is computed.

    The options of the ``fold-map`` command (``table_help`` says where the table goes).
    """
    p.add_argument("--method", choices=METHODS, default=METHODS[0],
                   help="curves: one fold curve per a/R (default); grid: point by point")
    p.add_argument("--table", default=None, help=table_help)
    p.add_argument("--workers", type=int, default=None)


def register(subparsers) -> None:
    """Add the ``fold-map`` command."""
    p = subparsers.add_parser(
        "fold-map",
        help="pop-up and standout lengths over (b/a, a/R), from fold curves or a grid",
        description="Fold lengths L0* (pop-up) and L1* (standout) and the critical shape "
                    "factor (b/a)* of each curvature, in parallel, into a resumable table: "
                    "from one traced fold curve per curvature (--method curves, default) or "
                    "for every (tip width, curvature) of a grid (--method grid).")
    add_method_arguments(p)
    p.add_argument("--rectangle", type=float, default=None, metavar="A_R",
                   help="curves: also trace the curve in (L, a/R) at b/a = 1 from this a/R "
                        "(its cusp: where the rectangle becomes bistable)")
    p.add_argument("--tip-widths", default="0.5:1:0.1",
                   help="b/a values: a list '0.6,0.8,1' or a range 'start:stop:step'")
    p.add_argument("--curvatures", default="2.5", help="a/R values (list or range)")
    p.add_argument("--lengths", default="0.5:3", help="search range 'short:long' in L/a")
    p.add_argument("--hmax", type=float, default=DEFAULT_HMAX,
                   help=f"mesh size (default {DEFAULT_HMAX:g}, the paper's; 0.1 for a quick "
                        f"look)")
    p.add_argument("--layers", type=int, default=None)
    p.add_argument("--step", type=float, default=0.1, help="largest continuation step in L/a")
    p.add_argument("--tol", type=float, default=0.005,
                   help="grid: the shortest continuation step before a branch is given up "
                        "where no fold is located (default 0.005; the folds are located to "
                        "1e-6)")
    p.add_argument("--solver", default="auto", help=solver_help())
    p.add_argument("--scheduler", default=None, help="Dask scheduler address tcp://host:port")
    p.add_argument("--retry-failed", action="store_true")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(run=run)


def _fmt4(x):
    return "   none" if not np.isfinite(x) else f"{x:7.4f}"


def print_curve_table(df) -> None:
    """Print a fold-curve table (:func:`~skfem_sheet.studies.foldmap.fold_curves`), a line a curve.

    a/R, the curve's plane, L1*, L0*, the cusp, the points, factorisations
    per point, wall time, and the message of a curve not completed.
    """
    print("  a/R   curve       L1*      L0*   cusp b/a  cusp a/R  cusp L   points  fact/pt"
          "  wall s")
    for _, r in df.iterrows():
        which = "(L, b/a)" if r.second == "tip_width" else "(L, a/R)"
        print(f"{r.curvature:5.2f}  {which}  {_fmt4(r.standout_length)}  "
              f"{_fmt4(r.popup_length)}  {_fmt4(r.cusp_tip_width)}   "
              f"{_fmt4(r.cusp_curvature)}  {_fmt4(r.cusp_length)}  {int(r.n_points):6d}  "
              f"{r.factorizations_per_point:7.1f}  {r.wall_time_s:6.0f}"
              + ("" if r.completed else f"  {r.message}"))


def _run_curves(args, tip_widths) -> int:
    curvatures = parse_values(args.curvatures, "curvatures")
    points = curve_points(curvatures, hmax=args.hmax, layers=args.layers, solver=args.solver,
                          rectangle_from=args.rectangle)
    df = fold_curves(points, table=args.table, workers=args.workers, scheduler=args.scheduler,
                     progress=not args.quiet, retry_failed=args.retry_failed)

    print(f"hmax = {args.hmax:g}, h/a = {points[0]['thickness']:g}, E/(rho g a) = "
          f"{points[0]['modulus']:g}, fold curves")
    print_curve_table(df)
    print("  a/R    b/a   L0* pop-up  L1* standout  (interpolated on the fold curves)")
    for _, r in df[df["second"] == "tip_width"].iterrows():
        halves = curve_halves(r)
        if halves is None or halves["cusp"] is None:
            continue
        (bs, Ls), (bp, Lp) = halves["standout"], halves["popup"]
        for b in tip_widths:
            if halves["cusp"][0] < b <= min(bs.max(), bp.max()) + 1e-12:
                print(f"{r.curvature:5.2f}  {b:5.2f}      {_fmt4(np.interp(b, bp, Lp))}       "
                      f"{_fmt4(np.interp(b, bs, Ls))}")
    crit = critical_curve(df)
    if crit:
        print("critical curve (b/a)*, a/R, L*: "
              + "; ".join(f"({b:.3f}, {c:.3f}, {L:.3f})" for b, c, L in crit))
    if args.table:
        print(f"table: {df.attrs['fold_curves']['table']}")
    return 0 if df["converged"].all() else 1


def run(args) -> int:
    """Compute the map, print the fold lengths and (b/a)*; 0 if every point converged."""
    tip_widths = parse_values(args.tip_widths, "tip-widths")
    if args.method == "curves":
        return _run_curves(args, tip_widths)
    if args.rectangle is not None:
        raise ParameterError("--rectangle is for --method curves")
    curvatures = parse_values(args.curvatures, "curvatures")
    lengths = parse_range(args.lengths, "lengths", pair="short:long", example="0.6:2.4")
    points = map_points(tip_widths, curvatures, lengths=lengths, hmax=args.hmax,
                        layers=args.layers, step=args.step, tol=args.tol, solver=args.solver)
    df = fold_map(points, table=args.table, workers=args.workers, scheduler=args.scheduler,
                  progress=not args.quiet, retry_failed=args.retry_failed)

    def fmt(x):
        return "   none" if not np.isfinite(x) else f"{x:7.5f}"

    print(f"hmax = {args.hmax:g}, h/a = {points[0]['thickness']:g}, E/(rho g a) = "
          f"{points[0]['modulus']:g}, L/a searched in [{lengths[0]:g}, {lengths[1]:g}]")
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
