"""Fold curves against the point-by-point fold search (issue 19, item 4).

    python benchmarks/fold_curves.py --curvatures 2.5,5 --hmax 0.1 [--compare 2.5]
        [--map quick --data-dir DIR --workers 2] [--json out.json]

1. For each a/R: trace the fold curve in (L, b/a)
   (:func:`skfem_sheet.foldcurve.trace_fold_curve`) and print its points,
   factorisations per point (median), wall time, L1*(1), L0*(1), the cusp
   (b/a)* and the remeshes.
2. ``--compare A_R``: the same fold lengths at b/a = 1 by today's
   point-by-point search (:func:`skfem_sheet.bistability.fold_lengths`:
   continuation in L from both ends, folds bracketed to +-0.005).
3. ``--map QUALITY``: the whole map of fold curves of that figure quality
   (one per a/R of ``figures.data.CURVE_CURVATURES`` plus the rectangle's
   curve in (L, a/R)), through the resumable fold-curve table in
   ``--data-dir``: its elapsed time, the sum of the curves' own wall times
   (``sum_curve_walls_s``; the work, not CPU time: ``cpu_s``, the same number,
   is its old name, kept for the recorded results), and every curve.

Coarse to fine (issue 19 at hmax 0.03):

    python benchmarks/fold_curves.py --curvatures 2.5,5 --hmax 0.03 --isolated \
        [--coarse-hmax 0.1,0.06 --fine-points 6] [--compare 2.5 --compare-hmax 0.06]

traces each curve coarse to fine (the fold map's levels,
``studies.foldmap.COARSE_HMAX``, by default below hmax 0.1) in a fresh
process (``--isolated``) and prints its peak RSS beside that of the largest
single solve it contains (``solve`` at ``L1*(1)``, ``b/a = 1``, in a fresh
process too).  The paper-quality map of Fig. 7 is
``--map paper --workers 2 --data-dir DIR`` (then
``python -m skfem_sheet figure fig7 --quality paper --data-dir DIR`` draws
it from the table without computing).

Measured wall times depend on the load of the machine (the load average at
the start is recorded).
"""
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np
import pandas as pd

from skfem_sheet import Sheet
from skfem_sheet.bistability import fold_lengths
from skfem_sheet.figures.data import fold_curve_points, fold_curve_table
from skfem_sheet.foldcurve import trace_fold_curve
from skfem_sheet.io import atomic_write, dumps_json
from skfem_sheet.studies.foldmap import COARSE_HMAX, FINE_POINTS
from skfem_sheet.studies.runner import journal_path, read_journal

from harness import machine_info, parser, run_isolated


def _fmt(x, spec="7.4f"):
    return "   none" if x is None or x != x else format(x, spec)


def _peak_rss_gb():
    """VmHWM of this process (GB)."""
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1e6
    return float("nan")


def curve_case(curvature, hmax, coarse_hmax=None, fine_points=FINE_POINTS):
    t0 = time.perf_counter()
    fine = coarse_hmax is not None
    c = trace_fold_curve(curvature, hmax=hmax, check_inertia=5 if fine else 0,
                         coarse_hmax=coarse_hmax, fine_points=fine_points)
    wall = time.perf_counter() - t0
    return dict(curvature=curvature, hmax=hmax, points=len(c.points),
                factorizations=c.factorizations,
                factorizations_per_point=c.factorizations_per_point, wall_time_s=wall,
                standout_length=c.standout_length, popup_length=c.popup_length,
                cusp=c.cusp, cusp_located=c.cusp_located,
                cusp_factorizations=c.cusp_factorizations, remeshes=c.remeshes,
                completed=c.completed, bistable=c.bistable, reason=c.reason,
                coarse_hmax=c.coarse_hmax, coarse_points=c.coarse_points,
                coarse_factorizations=c.coarse_factorizations, stages=list(c.stages),
                crossing=[list(x) if x is not None else None for x in c.crossing],
                peak_rss_gb=_peak_rss_gb())


def isolated_curve_case(curvature, hmax, coarse_hmax, fine_points):
    """:func:`curve_case` in a fresh process (its peak RSS is the curve's
    alone), then the largest single solve it contains (``solve`` at L1*(1),
    b/a = 1, curvature-first) in another."""
    fd, out = tempfile.mkstemp(suffix=".json")
    os.close(fd)
    spec = dict(curvature=curvature, hmax=hmax, coarse_hmax=coarse_hmax,
                fine_points=fine_points)
    subprocess.run([sys.executable, os.path.abspath(__file__), "--child-curve",
                    json.dumps(spec), out], check=True)
    with open(out) as fh:
        r = json.load(fh)
    os.unlink(out)
    if r["standout_length"] is not None:
        single = run_isolated(dict(sheet=dict(length=r["standout_length"], tip_width=1.0,
                                              curvature=curvature),
                                   path="curvature-first", hmax=hmax))
        r["single_solve"] = {k: single.get(k) for k in ("status", "peak_rss_gb", "wall_time_s")}
    return r


def pointwise_case(curvature, hmax):
    t0 = time.perf_counter()
    r = fold_lengths(Sheet(length=0.5, curvature=curvature), hmax=hmax, lengths=(0.5, 3.0),
                     step=0.1)
    wall = time.perf_counter() - t0
    its = r.increasing.newton_iterations + (r.decreasing.newton_iterations
                                            if r.decreasing is not r.increasing else 0)
    return dict(curvature=curvature, hmax=hmax, standout_length=r.standout_length,
                popup_length=r.popup_length, newton_iterations=int(its), wall_time_s=wall)


def _journalled(quality, data_dir):
    """The curves of the quality already in the table's journal (nothing computed).

    The journal the fold-curve table keeps (:func:`skfem_sheet.studies.foldmap.fold_curves`:
    one line per traced curve, its point's fields and its ``key``), read by the
    package's reader on the stored keys; a curve is one of the quality's
    (``second``, ``curvature``), the last line of each counting.  Returns the
    records and the sorted (second, curvature) pairs not yet journalled.
    """
    journal = journal_path(os.path.join(data_dir, f"foldcurves-{quality}.csv"))
    want = {(p["second"], p["curvature"]) for p in fold_curve_points(quality)}
    recs = {}
    for r in read_journal(journal, key_of=lambda rec: rec["key"],
                          required=("key", "second", "curvature")).values():
        if (r["second"], r["curvature"]) in want:
            recs[(r["second"], r["curvature"])] = r
    return pd.DataFrame(list(recs.values())), sorted(want - set(recs))


def map_case(quality, data_dir, workers, partial=False):
    t0 = time.perf_counter()
    missing = []
    if partial:
        df, missing = _journalled(quality, data_dir)
    else:
        df = fold_curve_table(fold_curve_points(quality), quality, data_dir, progress=False,
                              workers=workers)
    wall = time.perf_counter() - t0
    rows = []
    for _, r in df.iterrows():
        rows.append({k: (None if (isinstance(v, float) and v != v) else v) for k, v in dict(
            second=r.second, curvature=float(r.curvature), standout_length=r.standout_length,
            popup_length=r.popup_length, cusp_tip_width=r.cusp_tip_width,
            cusp_curvature=r.cusp_curvature, cusp_length=r.cusp_length,
            cusp_located=r.cusp_located, bistable=bool(r.bistable), completed=bool(r.completed),
            points=int(r.n_points), factorizations_per_point=r.factorizations_per_point,
            remeshes=None if r.remeshes != r.remeshes else int(r.remeshes),
            wall_time_s=r.wall_time_s, message=r.message, error=r.error).items()})
    walls = float(df.wall_time_s.sum())
    return dict(quality=quality, elapsed_s=wall, sum_curve_walls_s=walls, cpu_s=walls,
                curves=len(df), completed=int(df.completed.sum()),
                not_bistable=int((~df.bistable & df.converged).sum()),
                failed=int((~df.converged).sum()), rows=rows,
                missing=[list(m) for m in missing])


def _levels(text, hmax):
    if text == "auto":
        return tuple(COARSE_HMAX) if hmax < COARSE_HMAX[0] else None
    if text in ("", "none"):
        return None
    return tuple(float(x) for x in text.split(","))


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    if argv and argv[0] == "--child-curve":
        spec = json.loads(argv[1])
        r = curve_case(spec["curvature"], spec["hmax"], spec["coarse_hmax"],
                       spec["fine_points"])
        atomic_write(argv[2], dumps_json(r))
        return
    ap = parser(__doc__)
    ap.add_argument("--curvatures", default="2.5,5")
    ap.add_argument("--hmax", type=float, default=0.1)
    ap.add_argument("--compare", type=float, default=None, metavar="A_R",
                    help="also the point-by-point search at b/a = 1 and this a/R")
    ap.add_argument("--map", default=None, choices=("quick", "paper"))
    ap.add_argument("--data-dir", default="skfem_sheet_data")
    ap.add_argument("--partial", action="store_true",
                    help="--map: report the curves already in the table, compute nothing")
    ap.add_argument("--workers", type=int, default=None)
    ap.add_argument("--json", default=None)
    ap.add_argument("--coarse-hmax", default="auto",
                    help="coarse to fine levels, e.g. 0.1,0.06 (default auto: the fold map's "
                         "below hmax 0.1; none: trace at --hmax)")
    ap.add_argument("--fine-points", type=int, default=FINE_POINTS)
    ap.add_argument("--isolated", action="store_true",
                    help="each curve in a fresh process, with its peak RSS and that of the "
                         "largest single solve it contains")
    ap.add_argument("--compare-hmax", type=float, default=None,
                    help="mesh of the point-by-point comparison (default --hmax)")
    args = ap.parse_args(argv)
    levels = _levels(args.coarse_hmax, args.hmax)
    out = dict(machine=machine_info(), curves=[], pointwise=None, map=None)
    curvatures = [float(x) for x in args.curvatures.split(",") if x]
    print(" ".join(["python benchmarks/fold_curves.py", *argv]))
    if levels:
        print(f"coarse to fine: traced at hmax {levels[0]:g}, refined at "
              + ", ".join(f"{h:g}" for h in [*levels[1:], args.hmax] if h >= args.hmax)
              + f" ({args.fine_points} points besides the ends and the cusp)")
    print(f"fold curves at hmax {args.hmax:g} (load average at start "
          f"{os.getloadavg()[0]:.1f} on {os.cpu_count()} cores)")
    print("  a/R  points  fact/pt  wall s      L1*(1)   L0*(1)   cusp b/a  cusp L  remeshes")
    t_all = time.perf_counter()
    for c in curvatures:
        if args.isolated:
            r = isolated_curve_case(c, args.hmax, levels, args.fine_points)
        else:
            r = curve_case(c, args.hmax, levels, args.fine_points)
        out["curves"].append(r)
        cusp = r["cusp"] or {}
        print(f"{c:5.2f}  {r['points']:6d}  {_fmt(r['factorizations_per_point'], '7.1f')}  "
              f"{r['wall_time_s']:6.0f}   {_fmt(r['standout_length'])}  "
              f"{_fmt(r['popup_length'])}   {_fmt(cusp.get('tip_width'))}  "
              f"{_fmt(cusp.get('length'))}  {r['remeshes']:8d}"
              + ("" if r["completed"] else f"  ({r['reason']})"), flush=True)
        for st in r.get("stages") or []:
            print(f"       hmax {st['hmax']:g}: {st['points']} points ({st['failed']} failed"
                  + (f", {st['refilled']} continued on that mesh" if st.get("refilled") else "")
                  + f"), {st['factorizations']} factorisations, "
                  f"{_fmt(st['factorizations_per_point'], '.1f')} per point (median)")
        if r.get("cusp_located"):
            print(f"       cusp located by the {r['cusp_located']} "
                  f"({r.get('cusp_factorizations') or 0} factorisations)")
        if r.get("coarse_hmax") is not None:
            print(f"       coarse trace at hmax {r['coarse_hmax']:g}: {r['coarse_points']} "
                  f"points, {r['coarse_factorizations']} factorisations")
        single = r.get("single_solve")
        if single:
            ratio = r["peak_rss_gb"] / single["peak_rss_gb"] if single.get("peak_rss_gb") else None
            print(f"       peak RSS {r['peak_rss_gb']:.2f} GB; single solve at L1*(1): "
                  f"{_fmt(single.get('peak_rss_gb'), '.2f')} GB ({single['status']}, "
                  f"{_fmt(single.get('wall_time_s'), '.0f')} s); ratio {_fmt(ratio, '.2f')}",
                  flush=True)
        elif r.get("peak_rss_gb") is not None:
            print(f"       peak RSS of this process so far {r['peak_rss_gb']:.2f} GB")
    if curvatures:
        print(f"curves: {time.perf_counter() - t_all:.0f} s wall in all (load average now "
              f"{os.getloadavg()[0]:.1f})", flush=True)
    if args.compare is not None:
        r = pointwise_case(args.compare, args.compare_hmax or args.hmax)
        out["pointwise"] = r
        print(f"point by point (fold_lengths, +-0.005) at a/R {args.compare:g}, b/a 1, "
              f"hmax {r['hmax']:g}: "
              f"L1* {_fmt(r['standout_length'])}, L0* {_fmt(r['popup_length'])}, "
              f"{r['newton_iterations']} Newton iterations, {r['wall_time_s']:.0f} s", flush=True)
    if args.map:
        m = map_case(args.map, args.data_dir, args.workers, args.partial)
        out["map"] = m
        print(f"map of fold curves, quality {args.map}: {m['curves']} curves, "
              f"{m['completed']} completed, {m['not_bistable']} not bistable, "
              f"{m['failed']} failed; elapsed {m['elapsed_s']:.0f} s (this run; 0 if all "
              f"were in the table), sum of curve walls {m['sum_curve_walls_s']:.0f} s")
        print("  curve        a/R      L1*      L0*   cusp b/a  cusp a/R  cusp L  points  "
              "fact/pt  remeshes  wall s")
        for r in m["rows"]:
            which = "(L, b/a)" if r["second"] == "tip_width" else "(L, a/R)"
            print(f"  {which}  {r['curvature']:5.2f}  {_fmt(r['standout_length'])}  "
                  f"{_fmt(r['popup_length'])}   {_fmt(r['cusp_tip_width'])}   "
                  f"{_fmt(r['cusp_curvature'])}  {_fmt(r['cusp_length'])}  {r['points']:6d}  "
                  f"{_fmt(r['factorizations_per_point'], '7.1f')}  "
                  f"{r['remeshes'] if r['remeshes'] is not None else '-':>8}  "
                  f"{_fmt(r['wall_time_s'], '6.0f')}"
                  + ("" if r["completed"] else f"  {r['message'] or r['error']}"))
        fpp = [r["factorizations_per_point"] for r in m["rows"]
               if r["factorizations_per_point"] is not None]
        if fpp:
            print(f"map: median over the curves of the factorisations per point "
                  f"{np.median(fpp):.1f} (max {max(fpp):.1f}); elapsed {m['elapsed_s']:.0f} s "
                  f"with {args.workers or 1} workers; load average now "
                  f"{os.getloadavg()[0]:.1f}")
        if m["missing"]:
            print("not yet in the table: " + ", ".join(f"{s} a/R {c:g}" for s, c in m["missing"]))
    if args.json:
        atomic_write(args.json, dumps_json(out, indent=2))


if __name__ == "__main__":
    main()
