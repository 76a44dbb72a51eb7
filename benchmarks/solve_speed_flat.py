"""The flat rectangle L/a = 1 against the heavy elastica, on both starts of ``solve``.

    python benchmarks/solve_speed_flat.py [--hmax 0.03] [--txt out.txt]

Solves the flat clamp (a/R = 0, b/a = 1, L/a = 1) with ``start="path"`` and
``start="coarse"`` and compares d with the heavy elastica of the plate
modulus (:func:`skfem_sheet.reduced.elastica`); the acceptance of issue 16 is
0.5%.  Prints the fine and coarse factorisations and the wall of each.
"""
from __future__ import annotations

import argparse
import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

from skfem_sheet import Sheet, solve  # noqa: E402  (after the path fix)
from skfem_sheet.io import atomic_write  # noqa: E402
from skfem_sheet.reduced import elastica  # noqa: E402

from _common import machine_info  # noqa: E402

#: Largest relative difference from the heavy elastica accepted (issue 16).
TOLERANCE = 5e-3


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--hmax", type=float, default=0.03)
    ap.add_argument("--txt", default=None)
    args = ap.parse_args(argv)
    info = machine_info()
    ref = elastica(Sheet(1.0)).deflection
    lines = [f"# python benchmarks/solve_speed_flat.py {' '.join(argv or sys.argv[1:])}",
             f"# {info['date']}, load average at start "
             f"{', '.join(f'{x:.2f}' for x in info.get('load_average_at_start', []))}",
             f"flat rectangle L/a = 1, hmax {args.hmax:g}: heavy elastica d = {ref:.6f}"]
    ok = True
    for start in ("path", "coarse"):
        r = solve(Sheet(1.0), hmax=args.hmax, start=start)
        rel = r.deflection / ref - 1
        ok &= abs(rel) <= TOLERANCE
        lines.append(f"  start={start:6s} d = {r.deflection:.6f} ({100 * rel:+.3f}% from the "
                     f"elastica, limit {100 * TOLERANCE:.1f}%): {r.factorizations} "
                     f"factorisations (+{r.coarse_factorizations} coarse), {r.newton_iterations} "
                     f"Newton (+{r.coarse_newton_iterations} coarse), wall {r.wall_time_s:.1f} s"
                     f"{'' if not r.coarse_fallback else ', fell back: ' + r.coarse_fallback}")
    lines.append("PASS" if ok else "FAIL")
    text = "\n".join(lines) + "\n"
    print(text)
    if args.txt:
        atomic_write(args.txt, text)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
