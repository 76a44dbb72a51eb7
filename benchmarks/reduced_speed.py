"""Speed of the reduced-order models (issue 7 targets).

Run:  python benchmarks/reduced_speed.py [--workers 2] [--quick]

Prints a table: time of one ribbon solve at a new length by continuation
(target <= 0.2 s) and of the Fig. 6 map, 50 lengths x 50 shape factors, both
continuation directions (target <= 60 s on 2 cores), plus the other models.
"""
from __future__ import annotations

import os
import statistics
import time

import numpy as np

from skfem_sheet.params import Sheet
from skfem_sheet.reduced import (
    cantilever_deflection,
    elastica,
    persistence_length,
    ribbon,
    ribbon_map,
)

from harness import parser


def _timeit(fn, repeat=5):
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def continuation_step_time(curvature=2.5, tip_width=1.0, n=40):
    """Median time of one ribbon solve at L + 0.01 from the converged state at L."""
    state = ribbon(Sheet(length=1.0, tip_width=tip_width, curvature=curvature))
    times = []
    for L in 1.0 + 0.01 * np.arange(1, n + 1):
        sheet = Sheet(length=L, tip_width=tip_width, curvature=curvature)
        t0 = time.perf_counter()
        state = ribbon(sheet, initial=state)
        times.append(time.perf_counter() - t0)
        assert state.converged
    return statistics.median(times), max(times)


def main(argv=None) -> int:
    ap = parser(__doc__)
    ap.add_argument("--workers", type=int, default=min(2, os.cpu_count() or 1))
    ap.add_argument("--quick", action="store_true", help="20 x 20 map instead of 50 x 50")
    args = ap.parse_args(argv)

    rows = []
    med, worst = continuation_step_time()
    rows.append(("ribbon solve by continuation (median / max)", f"{med:.4f} / {worst:.4f} s",
                 "<= 0.2 s", worst <= 0.2))
    t = _timeit(lambda: ribbon(Sheet(length=1.3, curvature=2.5)), 3)
    rows.append(("ribbon solve from scratch (load ramp)", f"{t:.4f} s", "", None))
    t = _timeit(lambda: persistence_length(Sheet(length=1.5, tip_width=0.0, curvature=2.5)), 3)
    rows.append(("persistence length (triangle)", f"{t:.4f} s", "", None))
    t = _timeit(lambda: cantilever_deflection(Sheet(length=1.5, tip_width=0.0, curvature=2.5)), 3)
    rows.append(("cantilever estimate", f"{t:.4f} s", "", None))
    t = _timeit(lambda: elastica(Sheet(length=1.0)), 3)
    rows.append(("heavy elastica L=1 (tol 1e-9)", f"{t:.4f} s", "", None))

    n = 20 if args.quick else 50
    t0 = time.perf_counter()
    table = ribbon_map(2.5, np.linspace(0.8, 2.2, n), np.linspace(0.0, 1.0, n),
                       workers=args.workers)
    t_map = time.perf_counter() - t0
    bad = sum(not r["converged"] for r in table)
    rows.append((f"Fig. 6 map {n}x{n}, both directions, {args.workers} workers",
                 f"{t_map:.1f} s ({len(table)} solves, {bad} not converged)",
                 "<= 60 s" if n == 50 else "", (t_map <= 60) if n == 50 else None))

    w = max(len(r[0]) for r in rows)
    print(f"{'benchmark':<{w}}  {'time':<40} {'target':<9} ok")
    for name, val, target, ok in rows:
        flag = "" if ok is None else ("yes" if ok else "NO")
        print(f"{name:<{w}}  {val:<40} {target:<9} {flag}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
