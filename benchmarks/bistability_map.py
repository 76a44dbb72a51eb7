"""Bistability map (issue 4, item 5; data of the paper's Figs. 6 and 7).

Runs the fold map of :data:`skfem_sheet.figures.QUICK_GRID` (or the paper grid)
into a resumable table and prints L0*, L1*, the bistable flag per (b/a, a/R)
and the critical shape factor (b/a)* of each curvature.  Re-running with the
same table computes nothing again.

    python benchmarks/bistability_map.py --table skfem_sheet_data/foldmap-quick.csv
"""
import argparse
import math

from skfem_sheet import figures
from skfem_sheet.studies.foldmap import critical_tip_width, fold_map


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quality", choices=figures.QUALITIES, default="quick")
    ap.add_argument("--table", default="skfem_sheet_data/foldmap-quick.csv")
    ap.add_argument("--workers", type=int, default=None)
    args = ap.parse_args(argv)
    points = figures.map_grid_points(args.quality)
    df = fold_map(points, table=args.table, workers=args.workers)
    p0 = points[0]
    print(f"fold map, quality {args.quality}: hmax = {p0['hmax']:g}, L/a in "
          f"[{p0['length_min']:g}, {p0['length_max']:g}], step {p0['step']:g}, folds to "
          f"+-{p0['tol']:g}; {len(df)} points, {int(df.converged.sum())} converged, "
          f"{df.wall_time_s.sum() / 60:.0f} CPU-min")

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
