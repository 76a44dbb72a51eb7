"""The four cases of benchmarks/solve_speed.py in one process (hmax from argv, default 0.03):
prints d, Newton iterations, factorisations and wall per solve, and the total.

Used to compare two checkouts as whole processes, alternating (PYTHONPATH=...)."""
import sys
import time

from skfem_sheet import Sheet, solve

hmax = float(sys.argv[1]) if len(sys.argv) > 1 else 0.03
CASES = [(dict(length=1.3, tip_width=1.0, curvature=2.5), "curvature-first"),
         (dict(length=1.3, tip_width=1.0, curvature=2.5), "gravity-first"),
         (dict(length=1.3, tip_width=0.0, curvature=2.5), "curvature-first"),
         (dict(length=1.3, tip_width=0.0, curvature=2.5), "gravity-first")]
t0 = time.perf_counter()
for p, path in CASES:
    r = solve(Sheet(**p), path=path, hmax=hmax, progress=False)
    print(f"{p['tip_width']} {path} d={r.deflection!r} newton={r.newton_iterations} "
          f"fact={r.factorizations} wall={r.wall_time_s:.2f}", flush=True)
print(f"total {time.perf_counter() - t0:.2f}")
