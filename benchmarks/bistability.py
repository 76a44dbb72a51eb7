"""Acceptance measurements of bistability (issue 4), printed as a table.

    python benchmarks/bistability.py [--hmax 0.1] [--json out.json] [--skip-critical]

1. Pop-up and standout lengths (continuation in L, folds by bisection to
   +-0.005) for the rectangle, b/a = 0.5 and the triangle at a/R = 2.5, and
   the rectangle at a/R = 1.
2. The S-curve of the rectangle at a/R = 2.5 by pseudo-arclength
   continuation: its fold points against the bisection, and the stability
   of its middle branch.
3. The critical shape factor (b/a)* at a/R = 2.5: bisection on b/a between
   a non-bistable and a bistable tip width.

Results are appended to the JSON after every case (a rerun skips finished
cases), so an interrupted run loses at most the case in progress.
"""
import json
import os
import sys
import time

from skfem_sheet import Sheet
from skfem_sheet.bistability import fold_lengths, s_curve

from harness import parser

CASES = [("rectangle", 1.0, 2.5), ("b/a = 0.5", 0.5, 2.5), ("triangle", 0.0, 2.5),
         ("rectangle", 1.0, 1.0)]


def _load(path):
    if path and os.path.exists(path):
        with open(path) as f:
            return json.load(f)
    return {}


def _save(path, data):
    if path:
        tmp = path + ".tmp"
        with open(tmp, "w") as f:
            json.dump(data, f, indent=1)
        os.replace(tmp, path)


def _bistable(s, tol=0.005):
    """Both folds found and their brackets disjoint (L1* - L0* > 2 tol)."""
    L0, L1 = s["popup_length"], s["standout_length"]
    return bool(L0 is not None and L1 is not None and L1 - L0 > 2 * tol)


def _fmt(x):
    return "   none" if x is None else f"{x:7.3f}"


def main(argv=None):
    ap = parser(__doc__)
    ap.add_argument("--hmax", type=float, default=0.1)
    ap.add_argument("--lengths", default="0.6:2.0", help="L/a range searched (short:long)")
    ap.add_argument("--json", default=None)
    ap.add_argument("--skip-critical", action="store_true")
    ap.add_argument("--critical-steps", type=int, default=3,
                    help="bisection steps on b/a between 0.5 and 1 (default 3: +-0.03)")
    args = ap.parse_args(argv)
    lo, hi = (float(x) for x in args.lengths.split(":"))
    data = _load(args.json)
    data.setdefault("hmax", args.hmax)
    folds = data.setdefault("folds", {})

    def run(b, k):
        key = f"b={b:g},k={k:g}"
        if key not in folds:
            r = fold_lengths(Sheet(length=lo, tip_width=b, curvature=k), hmax=args.hmax,
                             lengths=(lo, hi), progress=True)
            folds[key] = {k2: v for k2, v in r.summary().items()}
            _save(args.json, data)
        return folds[key]

    print(f"hmax = {args.hmax:g}, L/a searched in [{lo:g}, {hi:g}], folds located to 1e-6")
    head = f"{'case':12s} {'a/R':>5s} {'L0* (pop-up)':>13s} {'L1* (standout)':>15s} {'bistable':>8s} {'newton':>7s} {'wall s':>7s}"
    print(head)
    print("-" * len(head))
    for name, b, k in CASES:
        s = run(b, k)
        its = (s["curvature_dominated"]["newton_iterations"]
               + s["gravity_dominated"]["newton_iterations"])
        L0, L1 = s["popup_length"], s["standout_length"]
        print(f"{name:12s} {k:5.2g} {_fmt(L0):>13s} {_fmt(L1):>15s} "
              f"{str(_bistable(s)):>8s} {its:7d} {s['wall_time_s']:7.0f}", flush=True)
    rect = folds["b=1,k=2.5"]
    inside = (_bistable(rect) and rect["popup_length"] < 1.3 < rect["standout_length"])
    print(f"rectangle a/R = 2.5: L0* < 1.3 < L1*: {inside}")

    # the S-curve
    if "s_curve" not in data and _bistable(rect):
        L0, L1 = rect["popup_length"], rect["standout_length"]
        t = time.perf_counter()
        sc = s_curve(Sheet(length=max(lo, L0 - 0.15), curvature=2.5), min(hi, L1 + 0.15),
                     hmax=args.hmax)
        data["s_curve"] = sc.summary()
        data["s_curve"]["wall_time_s"] = time.perf_counter() - t
        _save(args.json, data)
    if "s_curve" in data:
        sc = data["s_curve"]
        f = sc["folds"]
        print(f"S-curve: {len(sc['lengths'])} points, converged {sc['converged']}, "
              f"folds at L/a = {', '.join(f'{x:.4f}' for x in f)} "
              f"({sc['newton_iterations']} Newton iterations, {sc['wall_time_s']:.0f} s)")
        if len(f) == 2:
            print(f"  |L1*(arclength) - L1*(bisection)| = {abs(f[0] - rect['standout_length']):.4f}, "
                  f"|L0*(arclength) - L0*(bisection)| = {abs(f[1] - rect['popup_length']):.4f}")
        unstable = [L for L, st in zip(sc["lengths"], sc["stable"]) if st is False]
        print(f"  unstable points: {len(unstable)} of {len(sc['lengths'])}, all with L/a in "
              f"[{min(unstable):.3f}, {max(unstable):.3f}]" if unstable else "  no unstable point")

    # critical shape factor
    if not args.skip_critical:
        b_no, b_yes = 0.5, 1.0
        if _bistable(folds["b=0.5,k=2.5"]) or not _bistable(rect):
            print("critical shape factor: b/a = 0.5 and 1 do not bracket it")
        else:
            for _ in range(args.critical_steps):
                b = round(0.5 * (b_no + b_yes), 4)
                s = run(b, 2.5)
                print(f"  b/a = {b:.4f}: L0* = {_fmt(s['popup_length'])}, L1* = "
                      f"{_fmt(s['standout_length'])}, bistable {_bistable(s)}", flush=True)
                if _bistable(s):
                    b_yes = b
                else:
                    b_no = b
            data["critical_shape_factor"] = [b_no, b_yes]
            _save(args.json, data)
            print(f"critical shape factor at a/R = 2.5: (b/a)* in [{b_no:.4f}, {b_yes:.4f}]")
    return 0


if __name__ == "__main__":
    sys.exit(main())
