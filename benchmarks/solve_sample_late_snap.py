"""A late coarse snap in the wild: both starts on the snapping sheets of issue 17.

    python benchmarks/solve_sample_late_snap.py [--hmax 0.08] [--txt out.txt]

The two thin sheets of ``tests/test_snap.py`` that pop up late in the
curvature ramp of gravity-first, solved with ``start="path"`` and
``start="coarse"`` (reproducible PARDISO: ``MKL_CBWR=COMPATIBLE``, one
thread): fine and coarse factorisations, Newton iterations, the snap, the
label, d and how the coarse start went (``coarse_resume``).
"""
import argparse
import os
import sys
import time

os.environ.setdefault("MKL_CBWR", "COMPATIBLE")
for _var in ("OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

from skfem_sheet import Sheet, solve  # noqa: E402  (after the path fix)
from skfem_sheet.io import atomic_write  # noqa: E402

CASES = [dict(length=1.299, tip_width=0.633, curvature=5.112, thickness=0.02, modulus=400.0),
         dict(length=1.0, tip_width=0.8, curvature=5.5, thickness=0.02, modulus=400.0)]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--hmax", type=float, default=0.08)
    ap.add_argument("--txt", default=None)
    args = ap.parse_args(argv)
    lines = [f"# python benchmarks/solve_sample_late_snap.py {' '.join(argv or sys.argv[1:])}",
             f"# load average {', '.join(f'{x:.2f}' for x in os.getloadavg())}; gravity-first, "
             f"hmax {args.hmax:g}, coarse_hmax 0.1"]
    for params in CASES:
        d = {}
        for start in ("path", "coarse"):
            t = time.perf_counter()
            r = solve(Sheet(**params), path="gravity-first", hmax=args.hmax, start=start,
                      on_failure="return")
            d[start] = r.deflection
            snap = "-" if not r.snaps else f"{r.snaps[0][0]} {r.snaps[0][1]:.4f}"
            lines.append(
                f"L/a {params['length']:g} b/a {params['tip_width']:g} a/R {params['curvature']:g}"
                f" start={start:6s}: converged {r.converged}, d {r.deflection:.12f}, "
                f"{r.branch}, snap {snap}, fine factorisations {r.factorizations}, coarse "
                f"{r.coarse_factorizations}, Newton {r.newton_iterations}, wall "
                f"{time.perf_counter() - t:.1f} s"
                + (f"; {r.coarse_resume}" if r.coarse_resume else "")
                + (f"; fell back: {r.coarse_fallback}" if r.coarse_fallback else ""))
        lines.append(f"  relative difference in d: {abs(d['coarse'] / d['path'] - 1):.1e}")
    text = "\n".join(lines) + "\n"
    print(text)
    if args.txt:
        atomic_write(args.txt, text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
