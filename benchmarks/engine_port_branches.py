"""Before/after numbers of the port of the branch-following loops onto the engine (issue 19).

Run:  OMP_NUM_THREADS=1 python benchmarks/engine_port_branches.py run OUT.json [--quick]
      python benchmarks/engine_port_branches.py compare BEFORE.json AFTER.json
      (the compare table is benchmarks/results/engine_port_branches.txt)

Cases: fold_lengths(1, 2.5, hmax 0.1) (both follow_length directions, L1*, L0*);
follow_curvature at L 1.3, hmax 0.2 (both directions, the test's case);
s_curve at hmax 0.2 (the test's case) and at hmax 0.1 (1.1 -> 1.45);
ribbon_continuation on its tests' cases.
"""
from __future__ import annotations

import json
import sys
import time

import numpy as np

from skfem_sheet import Sheet
from skfem_sheet.bistability import fold_lengths, follow_curvature, s_curve
from skfem_sheet.reduced import ribbon_continuation


def branch(b):
    return {"values": [float(x) for x in b.lengths], "d": [float(x) for x in b.deflections],
            "stable": list(b.stable), "fold": b.fold, "bracket": [float(x) for x in b.bracket],
            "reason": b.reason, "wall_time_s": b.wall_time_s}


def curve(sc):
    return {"values": [float(x) for x in sc.lengths], "d": [float(x) for x in sc.deflections],
            "stable": list(sc.stable), "folds": list(sc.folds), "converged": sc.converged,
            "wall_time_s": sc.wall_time_s}


def ribbon_case(c):
    return {"values": [float(x) for x in c.lengths], "d": [float(x) for x in c.deflection],
            "jumped": [bool(x) for x in c.jumped], "jumps": [float(x) for x in c.jump_lengths],
            "stable": [bool(x) for x in c.stable]}


def run(out, quick=False):
    res = {}
    t = time.perf_counter()
    r = fold_lengths(1.0, 2.5, lengths=(1.0, 1.7) if quick else (0.6, 2.4), hmax=0.1)
    res["fold_lengths_h0.1"] = {"L0": r.popup_length, "L1": r.standout_length,
                                "up": branch(r.increasing), "down": branch(r.decreasing),
                                "wall_time_s": time.perf_counter() - t}
    print("fold_lengths", r.popup_length, r.standout_length, flush=True)
    up = follow_curvature(Sheet(length=1.3, curvature=1.0), 5.0, path="gravity-first",
                          hmax=0.2, step=0.5)
    down = follow_curvature(Sheet(length=1.3, curvature=5.0), 1.0, path="curvature-first",
                            hmax=0.2, step=0.5)
    res["follow_curvature_h0.2"] = {"up": branch(up), "down": branch(down)}
    print("follow_curvature", up.fold, down.fold, flush=True)
    sc = s_curve(Sheet(length=1.1, curvature=2.5), 1.45, hmax=0.2)
    res["s_curve_h0.2"] = curve(sc)
    sc = s_curve(Sheet(length=1.1, curvature=2.5), 1.45, hmax=0.1)
    res["s_curve_h0.1"] = curve(sc)
    print("s_curve", sc.folds, flush=True)
    lengths = np.arange(1.2, 1.56, 0.02)
    res["ribbon_rect_up"] = ribbon_case(ribbon_continuation(Sheet(1.0, curvature=2.5), lengths,
                                                            "increasing"))
    res["ribbon_rect_down"] = ribbon_case(ribbon_continuation(Sheet(1.0, curvature=2.5), lengths,
                                                              "decreasing"))
    tri = np.linspace(0.8, 2.0, 31)
    res["ribbon_tri_up"] = ribbon_case(ribbon_continuation(
        Sheet(1.0, tip_width=0.0, curvature=2.5), tri, "increasing"))
    res["ribbon_tri_down"] = ribbon_case(ribbon_continuation(
        Sheet(1.0, tip_width=0.0, curvature=2.5), tri, "decreasing"))
    with open(out, "w") as f:
        json.dump(res, f, indent=1)


def _rel(a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    return float(np.max(np.abs(a - b) / np.maximum(np.abs(b), 1e-300))) if len(a) else 0.0


def compare(before, after):
    A, B = (json.load(open(p)) for p in (before, after))
    print("engine port of the branch-following loops: before (main) / after (engine drivers)")
    print(f"{'case':28s} {'points':>8s} {'same values':>11s} {'max rel d':>10s} "
          f"{'stable same':>11s}  folds/jumps before -> after")
    for key in A:
        for sub in (("up", "down") if "up" in A[key] else (None,)):
            a = A[key][sub] if sub else A[key]
            b = B[key][sub] if sub else B[key]
            name = key + (f".{sub}" if sub else "")
            same = len(a["values"]) == len(b["values"]) and np.allclose(
                a["values"], b["values"], rtol=0, atol=1e-6)
            rel = _rel(b["d"], a["d"]) if same else float("nan")
            st = a["stable"] == b["stable"]
            fa = [a.get(k) for k in ("fold", "folds", "jumps") if k in a]
            fb = [b.get(k) for k in ("fold", "folds", "jumps") if k in b]
            print(f"{name:28s} {len(a['values']):4d}/{len(b['values']):<3d} {str(same):>11s} "
                  f"{rel:10.2e} {str(st):>11s}  {fa} -> {fb}")
            if not same:  # the common prefix of equal parameter values
                va, vb = np.asarray(a["values"]), np.asarray(b["values"])
                n = min(len(va), len(vb))
                k = int(np.argmax(np.abs(va[:n] - vb[:n]) > 1e-6)) if np.any(
                    np.abs(va[:n] - vb[:n]) > 1e-6) else n
                print(f"{'':28s} the first {k} points agree: max |dL| "
                      f"{np.abs(va[:k] - vb[:k]).max():.1e}, max rel d "
                      f"{_rel(b['d'][:k], a['d'][:k]):.1e}; then a step-size decision "
                      f"differs (points further along the same curve)")
            elif key.startswith("s_curve"):
                print(f"{'':28s} max |dL| {np.abs(np.subtract(a['values'], b['values'])).max():.1e}"
                      " (L is an unknown of the arclength system)")
        if "L0" in A[key]:
            print(f"{'':28s} L0* {A[key]['L0']} -> {B[key]['L0']}; L1* {A[key]['L1']} -> "
                  f"{B[key]['L1']}; wall {A[key]['wall_time_s']:.0f} s -> "
                  f"{B[key]['wall_time_s']:.0f} s")


if __name__ == "__main__":
    if sys.argv[1] == "run":
        run(sys.argv[2], quick="--quick" in sys.argv)
    else:
        compare(sys.argv[2], sys.argv[3])
