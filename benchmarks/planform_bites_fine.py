"""The bitten triangle (no, one, two bites of radius 0.25) at hmax 0.03 on both load paths
(issue 14 acceptance); prints the table recorded in results/planform_bites_h0.03.txt."""
import time

from skfem_sheet import Sheet, solve
from skfem_sheet.params import Planform

print("triangle L/a 1.3, a/R 2.5, bites of radius 0.25, 3D at hmax 0.03 (half model, PARDISO)")
print(f"{'case':10s} {'path':16s} {'d':>9s} conv  stable newton fact wall_s")
for name, bt in {"triangle": (), "one bite": (0.25,), "two bites": (0.25, 0.25)}.items():
    s = Sheet.from_planform(Planform.trapezoid(0.0, bites=bt), length=1.3, curvature=2.5)
    for path in ("curvature-first", "gravity-first"):
        t = time.perf_counter()
        r = solve(s, path=path, hmax=0.03, on_failure="return", progress=False)
        print(f"{name:10s} {path:16s} {r.deflection:+9.5f} {r.converged!s:5s} {r.stable!s:6s} "
              f"{r.newton_iterations:6d} {r.factorizations:4d} {time.perf_counter() - t:6.1f}",
              flush=True)
