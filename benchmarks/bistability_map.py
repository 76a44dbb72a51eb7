"""Bistability map (issue 4, item 5; issue 19, item 4; data of the paper's Figs. 6 and 7).

``--method curves`` (default): the fold curves of the figures' quality (one
per a/R from 1 to 5 every 0.25, and the rectangle's curve in (L, a/R)) into a
resumable table; prints L1*(1), L0*(1), the cusp (b/a)* per a/R and the
rectangle's critical a/R.  ``--method grid``: the point-by-point fold map of
:data:`skfem_sheet.figures.QUICK_GRID` (or the paper grid), L0*, L1*, the
bistable flag per (b/a, a/R) and the bracketed (b/a)* (the reference).
Re-running with the same table computes nothing again.  The summary line's
"sum of curve walls" (or "point walls") adds up each curve's (point's) own wall
time: the work, not the elapsed time of a parallel run, and not CPU time.

    python benchmarks/bistability_map.py --table skfem_sheet_data/foldcurves-quick.csv
    python benchmarks/bistability_map.py --method grid --table skfem_sheet_data/foldmap-quick.csv
"""
import argparse
import math

from skfem_sheet import figures
from skfem_sheet.cli.fold_map import add_method_arguments, print_curve_table
from skfem_sheet.figures.data import fold_curve_points
from skfem_sheet.studies.foldmap import critical_curve, critical_tip_width, fold_curves, fold_map


def curves(args):
    points = fold_curve_points(args.quality)
    df = fold_curves(points, table=args.table, workers=args.workers)
    print(f"fold curves, quality {args.quality}: hmax = {points[0]['hmax']:g}; {len(df)} "
          f"curves, {int(df.completed.sum())} completed, "
          f"{int((~df.bistable & df.converged).sum())} not bistable, "
          f"{int((~df.converged).sum())} failed; sum of curve walls "
          f"{df.wall_time_s.sum() / 60:.0f} min")

    print_curve_table(df)
    print("critical curve (b/a)*, a/R, L*:")
    for b, c, L in critical_curve(df):
        print(f"  ({b:.4f}, {c:.3f}, {L:.4f})")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quality", choices=figures.QUALITIES, default="quick")
    add_method_arguments(ap, table_help="default skfem_sheet_data/foldcurves-QUALITY.csv "
                                        "(curves) or skfem_sheet_data/foldmap-QUALITY.csv (grid)")
    args = ap.parse_args(argv)
    if args.table is None:
        name = "foldcurves" if args.method == "curves" else "foldmap"
        args.table = f"skfem_sheet_data/{name}-{args.quality}.csv"
    if args.method == "curves":
        return curves(args)
    points = figures.map_grid_points(args.quality)
    df = fold_map(points, table=args.table, workers=args.workers)
    p0 = points[0]
    print(f"fold map, quality {args.quality}: hmax = {p0['hmax']:g}, L/a in "
          f"[{p0['length_min']:g}, {p0['length_max']:g}], step {p0['step']:g}, folds to "
          f"+-{p0['tol']:g}; {len(df)} points, {int(df.converged.sum())} converged, "
          f"sum of point walls {df.wall_time_s.sum() / 60:.0f} min")

    def f(x):
        return "   none" if not math.isfinite(x) else f"{x:7.3f}"

    print("  a/R    b/a      L0*      L1*   width  bistable  wall s")
    for _, r in df.sort_values(["curvature", "tip_width"]).iterrows():
        print(f"{r.curvature:5.2f}  {r.tip_width:5.2f}  {f(r.popup_length)}  "
              f"{f(r.standout_length)}  {f(r.standout_length - r.popup_length)}  "
              f"{str(bool(r.bistable)):>8}  {r.wall_time_s:6.0f}")
    print("critical shape factor (b/a)* (bistable from 'high' up, not at 'low'):")
    for c, (est, lo, hi) in critical_tip_width(df).items():
        print(f"  a/R = {c:4g}: estimate {f(est)}, bracket [{f(lo)}, {f(hi)}]")


if __name__ == "__main__":
    main()
