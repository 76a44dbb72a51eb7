"""Time of the final polish of solve (FINAL_UTOL, back-substitutions only) on three cases.

    python benchmarks/solve_sample_polish_cost.py [HMAX]

One process, ``solve``'s default start; prints per case the wall, the time
and share of the polish, the corrections applied, the fine factorisations and
back-substitutions (the polish's ratio to the wall is measured in one run).
"""
import os
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

from skfem_sheet import Sheet, solve  # noqa: E402  (after the path fix)

CASES = [((1.3, 1.0, 2.5), "curvature-first"), ((2.182, 0.8653, 2.0726), "curvature-first"),
         ((1.9623, 0.6596, 4.9107), "gravity-first")]


def main(hmax):
    solve_module = sys.modules["skfem_sheet.solve"]
    real, spent = solve_module.polish, []

    def timed_polish(*args, **kwargs):
        t = time.perf_counter()
        out = real(*args, **kwargs)
        spent.append(time.perf_counter() - t)
        return out

    solve_module.polish = timed_polish
    print(f"# python benchmarks/solve_sample_polish_cost.py {hmax:g}; load average "
          f"{', '.join(f'{x:.2f}' for x in os.getloadavg())}")
    for params, path in CASES:
        spent.clear()
        r = solve(Sheet(*params), path=path, hmax=hmax)
        print(params, path, f"wall {r.wall_time_s:.2f} s, polish {spent[0]:.2f} s "
              f"({100 * spent[0] / r.wall_time_s:.1f}%), {r.polish_iterations} corrections, "
              f"fine fact {r.factorizations}, back-subs {r.back_substitutions}, dofs {r.dofs}",
              flush=True)


if __name__ == "__main__":
    main(float(sys.argv[1]) if len(sys.argv) > 1 else 0.03)
