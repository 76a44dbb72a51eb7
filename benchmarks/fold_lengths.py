"""Fold lengths located (``fold_lengths``) against the fold curve at b/a 1, and their cost.

    python benchmarks/fold_lengths.py [--curvatures 2.5,5] [--hmax 0.03] [--curve]
        [--json out.json]

For the rectangle at each a/R: ``fold_lengths(Sheet(length=1.3, curvature=a/R), hmax)``
(the branches traced on hmax 0.1, each end located on a mesh of size hmax made next
to it), timed (wall, peak memory of the process so far, factorisations on each
mesh; and in solves: the wall of one solve of the same sheet on hmax, timed
before and after it, for a machine whose load changes); with ``--curve`` also the fold curve in (L, b/a) at that a/R
(``fold_curve``, coarse to fine as the fold map traces it), its ends at b/a 1 the
reference.  The two codes make their fine meshes at different lengths (the fold
curve one mesh for all the points it refines, at their median length), so the
folds are compared twice: as each code gives them, and with fold_lengths' folds
located once more on the fold curve's fine mesh (``locate_on_mesh(...,
mesh_length=...)``): the same mesh, the same fold, to the location's tolerance.
"""
import json
import resource
import sys
import time

from skfem_sheet import Sheet, fold_curve, fold_lengths, solve
from skfem_sheet.bistability import locate_on_mesh

from harness import parser


def _peak_mb():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _reference_solve(sheet, hmax):
    """The wall time of one solve of ``sheet`` on ``hmax`` (curvature-first, default
    start): the yardstick of a loaded machine, timed beside each fold_lengths."""
    t0 = time.perf_counter()
    solve(sheet, hmax=hmax)
    return time.perf_counter() - t0


def one(curvature, hmax, curve):
    sheet = Sheet(length=1.3, curvature=curvature)
    before = _reference_solve(sheet, hmax)
    t0 = time.perf_counter()
    f = fold_lengths(sheet, hmax=hmax, keep_states=True)
    wall = time.perf_counter() - t0
    after = _reference_solve(sheet, hmax)
    solve_s = 0.5 * (before + after)
    row = dict(curvature=curvature, hmax=hmax, wall_s=wall, peak_mb=_peak_mb(),
               reference_solve_s=solve_s, in_solves=wall / solve_s,
               popup_length=f.popup_length, standout_length=f.standout_length,
               popup_mesh=f.popup.mesh_length if f.popup else None,
               standout_mesh=f.standout.mesh_length if f.standout else None,
               crossings=[None if x is None else list(x.crossing) for x in (f.popup, f.standout)],
               fine_factorizations=f.factorizations, trace_factorizations=f.trace_factorizations,
               trace_hmax=f.trace_hmax)
    print(f"a/R {curvature:g}: L0* {f.popup_length:.6f} (mesh {row['popup_mesh']}), L1* "
          f"{f.standout_length:.6f} (mesh {row['standout_mesh']}), {wall:.1f} s, "
          f"{f.factorizations} factorisations on hmax {hmax:g} + {f.trace_factorizations} on "
          f"{f.trace_hmax:g}, crossings {row['crossings']}; one solve {solve_s:.1f} s "
          f"beside it: {wall / solve_s:.1f} solves", flush=True)
    if curve:
        t0 = time.perf_counter()
        c = fold_curve(sheet, hmax=hmax)
        row.update(curve_wall_s=time.perf_counter() - t0, curve_popup=c.popup_length,
                   curve_standout=c.standout_length, curve_meshes=[list(m) for m in c.meshes])
        L_m = float(c.meshes[-1][0])       # the last level's mesh: the fine points' own
        same = {}
        for kind, fold in (("popup", f.popup), ("standout", f.standout)):
            g, _, why = locate_on_mesh(sheet, fold.point, fold.problem, kind, hmax,
                                       mesh_length=L_m)
            same[kind] = g.length if g is not None else float("nan")
        row.update(curve_mesh_length=L_m, popup_on_curve_mesh=same["popup"],
                   standout_on_curve_mesh=same["standout"])
        print(f"  fold curve ({row['curve_wall_s']:.0f} s, its fine mesh made at L {L_m:g}): "
              f"L0* {c.popup_length:.6f}, L1* {c.standout_length:.6f}; fold_lengths - curve: "
              f"{f.popup_length - c.popup_length:+.2e}, {f.standout_length - c.standout_length:+.2e}"
              f"; on the curve's mesh: {same['popup'] - c.popup_length:+.2e}, "
              f"{same['standout'] - c.standout_length:+.2e}", flush=True)
    return row


def main(argv=None):
    ap = parser(__doc__)
    ap.add_argument("--curvatures", default="2.5,5")
    ap.add_argument("--hmax", type=float, default=0.03)
    ap.add_argument("--curve", action="store_true", help="also trace the fold curve")
    ap.add_argument("--json", default=None)
    args = ap.parse_args(argv)
    rows = [one(float(k), args.hmax, args.curve) for k in args.curvatures.split(",")]
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(rows, fh, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
