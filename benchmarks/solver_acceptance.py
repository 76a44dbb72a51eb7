"""Acceptance measurements of the 3D solver (issue 2), printed as a table.

    python benchmarks/solver_acceptance.py [--hmax 0.03] [--solver auto] [--json out.json]

Cases: the flat rectangle (L/a = 1, a/R = 0) against the heavy elastica with
plate modulus; the rectangle and the triangle at a/R = 2.5, L/a = 1.3 along
both load paths.  Reported per solve: d/a, Newton iterations, load steps,
wall time, linear-solver and assembly time, relative volume change and the
largest asymmetry of U_z along the free edge.
"""
import json
import sys

import numpy as np

from skfem_sheet import Sheet, solve
from skfem_sheet.analyses.observables import midline_heights
from skfem_sheet.reduced import elastica

from harness import parser

CASES = [
    ("flat rectangle", Sheet(1.0), "curvature-first"),
    ("rectangle", Sheet(1.3, 1.0, 2.5), "curvature-first"),
    ("rectangle", Sheet(1.3, 1.0, 2.5), "gravity-first"),
    ("triangle", Sheet(1.3, 0.0, 2.5), "curvature-first"),
    ("triangle", Sheet(1.3, 0.0, 2.5), "gravity-first"),
]


def main(argv=None):
    ap = parser(__doc__)
    ap.add_argument("--hmax", type=float, default=0.03)
    ap.add_argument("--solver", default="auto")
    ap.add_argument("--json", default=None)
    args = ap.parse_args(argv)
    rows = []
    head = (f"{'case':15s} {'path':16s} {'d/a':>9s} {'newton':>6s} {'steps':>5s} {'wall s':>7s} "
            f"{'linear s':>8s} {'asm s':>6s} {'dofs':>7s} {'dV/V':>9s} {'asym':>8s}")
    print(head)
    print("-" * len(head))
    for name, sheet, path in CASES:
        r = solve(sheet, path=path, hmax=args.hmax, solver=args.solver, on_failure="return")
        y, z = midline_heights(r.problem, r.w, sheet.length)
        asym = float(np.abs(z - z[::-1]).max())
        row = dict(r.summary(), case=name, free_edge_asymmetry=asym)
        rows.append(row)
        print(f"{name:15s} {path:16s} {r.deflection:9.5f} {r.newton_iterations:6d} "
              f"{r.load_steps:5d} {r.wall_time_s:7.1f} {r.linear_solve_s:8.1f} "
              f"{r.assembly_s:6.1f} {r.dofs:7d} {r.volume_change:9.1e} {asym:8.1e}"
              + ("" if r.converged else f"  NOT CONVERGED: {r.message}"), flush=True)
    ref = elastica(Sheet(1.0)).deflection
    flat = rows[0]["deflection"]
    print(f"\nflat rectangle: d = {flat:.5f}, heavy elastica (plate modulus) {ref:.5f}, "
          f"difference {100 * (flat / ref - 1):+.2f}%")
    up, down = rows[1]["deflection"], rows[2]["deflection"]
    print(f"rectangle a/R=2.5 L/a=1.3: curvature-first d = {up:.4f} (|d| < 0.1: {abs(up) < 0.1}),"
          f" gravity-first d = {down:.4f} (d > 0.5: {down > 0.5})")
    t1, t2 = rows[3]["deflection"], rows[4]["deflection"]
    print(f"triangle a/R=2.5 L/a=1.3: {t1:.5f} vs {t2:.5f}, difference "
          f"{100 * abs(t1 / t2 - 1):.3f}%")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
