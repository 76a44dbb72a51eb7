"""Bistability measured: fold lengths, their cost and agreement, the names of states.

    python benchmarks/bistability.py [--hmax 0.1] [--json out.json] [--skip-critical]
    python benchmarks/bistability.py --fold-lengths [--curvatures 2.5,5] [--hmax 0.03]
        [--curve] [--json out.json]
    python benchmarks/bistability.py --si-sheet [--hmax 0.05]
    python benchmarks/bistability.py --names [--n 100] [--seed 1] [--hmax 0.1]
        [--out labels.jsonl] [--start coarse|path] [--shard K:N]
    python benchmarks/bistability.py --windows [--hmax 0.1] [--out windows.jsonl]

The table (no mode flag):

1. Pop-up and standout lengths (``fold_lengths``: the branches in L, their
   ends located) for the rectangle, b/a = 0.5 and the triangle at a/R = 2.5,
   and the rectangle at a/R = 1.
2. The S-curve of the rectangle at a/R = 2.5 by pseudo-arclength
   continuation: its fold points against fold_lengths', and the stability
   of its middle branch.
3. The critical shape factor (b/a)* at a/R = 2.5: bisection on b/a between
   a non-bistable and a bistable tip width.

Results are appended to the JSON after every case (a rerun skips finished
cases), so an interrupted run loses at most the case in progress.

``--fold-lengths``: the rectangle at each a/R, ``fold_lengths(Sheet(length=1.3,
curvature=a/R), hmax)`` timed (wall, peak memory of the process so far,
factorisations on each mesh, and in solves: one solve of the same sheet on
hmax, timed before and after it, for a machine whose load changes); with
``--curve`` also the fold curve in (L, b/a) at that a/R (``fold_curve``,
coarse to fine as the fold map traces it), its ends at b/a 1 the reference:
compared as each code gives them, and with fold_lengths' folds located once
more on the fold curve's fine mesh (``locate_on_mesh(..., mesh_length=...)``):
the same mesh, the same fold.

``--si-sheet``: the issue's SI sheet (base 4 cm, length 5.5 cm, tip 3.6 cm,
thickness 1.2 mm, clamp radius 1.6 cm, E 6.0e5 Pa, density 1150 kg/m^3) three
ways: ``fold_lengths``, ``python -m skfem_sheet bistability --si ...``,
``solve_both(sheet, folds=True)``; the same L0*, L1*, in metres too.

``--names``: the solves of ``benchmarks/stress.py`` (the same seeded sample and
corners, both load paths, at ``min(hmax, L/2)``), each with its name
(``Result.branch``, read from the state: :mod:`skfem_sheet.analyses.mode`),
what it was read from, the name the load path's history gave before (its own
branch, switched at each snap), and the paper's picture beside it: whether the
transverse curvature ``c(s)`` of the mid-surface (at 19 sections over
``0 <= s <= 0.9 L``) changes sign along the sheet ("relaxed") or keeps the
clamp's sign ("persists").  Then, per sheet: one state (both converged, d
within 1e-6) must carry one name, two stable states two, and every hanging
state (d > L/2) must be gravity-dominated; the violations are printed (exit 1
if any).

``--windows``: the stress set holds few bistable sheets, so these are sought
out: for each of :data:`FAMILIES` the fold lengths on the mesh, then both
paths at lengths 10%, 50% and 90% across its window; every pair must be two
states with two names.
"""
import json
import os
import resource
import subprocess
import sys
import tempfile
import time

import numpy as np
from stress import sample

from skfem_sheet import Sheet, fold_curve, solve, solve_both
from skfem_sheet.analyses.midsurface import midsurface
from skfem_sheet.bistability import fold_lengths, locate_on_mesh, s_curve

from harness import (
    add_shard_option,
    add_start_option,
    both_paths,
    parse_shard,
    parser,
    read_jsonl,
    run_journalled,
    solve_key,
    solve_or_crash,
    start_options,
)

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


def _bistable(s):
    """Both folds found with L0* < L1*."""
    L0, L1 = s["popup_length"], s["standout_length"]
    return bool(L0 is not None and L1 is not None and L0 < L1)


def _fmt(x):
    return "   none" if x is None else f"{x:7.3f}"


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


#: Two end states whose deflections differ by at most this are one state.
SAME = 1e-6


def _history(r):
    names = ("curvature-dominated", "gravity-dominated")
    own = 0 if r.path == "curvature-first" else 1
    return names[(own + len(r.snaps)) % 2]


def _persistence(r):
    """"relaxed" if the transverse curvature changes sign over 0 <= s <= 0.9 L,
    "persists" if it keeps the clamp's, None for a flat clamp or no state."""
    if not r.converged or r.sheet.curvature == 0:
        return None
    s = np.linspace(0.0, 0.9 * r.sheet.length, 19)
    c = midsurface(r.problem, r.w, s, n_across=21).lateral_curvature()
    return "relaxed" if np.any(c < 0) else "persists"


def _fields(r):
    m = r.mode
    return dict(deflection=r.deflection, message=r.message, stable=r.stable,
                branch=r.branch, history=_history(r),
                slope=None if m is None else m.slope, bend=None if m is None else m.bend,
                reason=None if m is None else m.reason, persistence=_persistence(r),
                snaps=[s.to_json() for s in r.snaps], newton_iterations=r.newton_iterations,
                wall_time_s=r.wall_time_s)


def report(recs) -> int:
    """Check the names pair by pair; print the violations and the counts."""
    by_sheet = {}
    for r in recs:
        key = tuple(round(r[k], 10) for k in ("length", "tip_width", "curvature", "thickness",
                                              "modulus"))
        by_sheet.setdefault(key, {})[r["path"]] = r
    bad, counts = [], dict(one=0, two=0, hanging=0, other=0)
    agree = total = 0
    for key, pair in by_sheet.items():
        a, b = pair.get("curvature-first"), pair.get("gravity-first")
        for r in (a, b):
            if r and r["status"] == "converged" and r.get("persistence"):
                total += 1
                agree += (r["persistence"] == "relaxed") == (r["branch"] == "gravity-dominated")
            if r and r["status"] == "converged" and r["deflection"] > 0.5 * r["length"]:
                counts["hanging"] += 1
                if r["branch"] != "gravity-dominated":
                    bad.append(f"hanging but {r['branch']}: {key} {r['path']} d {r['deflection']:.4f}")
        if not (a and b and a["status"] == b["status"] == "converged"):
            counts["other"] += 1
            continue
        if abs(a["deflection"] - b["deflection"]) <= SAME:
            counts["one"] += 1
            if a["branch"] != b["branch"]:
                bad.append(f"one state, two names: {key} d {a['deflection']:.6f} "
                           f"{a['branch']} / {b['branch']}")
        elif a["stable"] and b["stable"]:
            counts["two"] += 1
            if a["branch"] == b["branch"]:
                bad.append(f"a bistable pair with one name: {key} d {a['deflection']:.4f} / "
                           f"{b['deflection']:.4f} both {a['branch']}")
        else:
            counts["other"] += 1
    hist = [r for r in recs if r["status"] == "converged" and r["branch"] != r["history"]]
    print(f"{len(by_sheet)} sheets, {len(recs)} solves: {counts['one']} ending in one state, "
          f"{counts['two']} bistable pairs, {counts['hanging']} hanging states (d > L/2), "
          f"{counts['other']} pairs with a failed or unstable solve")
    print(f"names that differ from the load path's history: {len(hist)}")
    for r in hist:
        print(f"  L {r['length']:.3f} b {r['tip_width']:.3f} a/R {r['curvature']:.3f} "
              f"{r['path']:16s} d {r['deflection']:8.4f}: {r['history']} -> {r['branch']} "
              f"(d' {r['slope']:.3g}, d'' {r['bend']:.3g}; c(s) {r['persistence']})")
    print(f"the names against the transverse curvature (relaxed = gravity-dominated): "
          f"{agree} of {total} agree")
    for r in recs:
        if (r["status"] == "converged" and r.get("persistence")
                and (r["persistence"] == "relaxed") != (r["branch"] == "gravity-dominated")):
            print(f"  differs: L {r['length']:.3f} b {r['tip_width']:.3f} a/R "
                  f"{r['curvature']:.3f} {r['path']:16s} d {r['deflection']:8.4f} "
                  f"{r['branch']} (d' {r['slope']:.3g}, d'' {r['bend']:.3g}), c(s) "
                  f"{r['persistence']}")
    print(f"violations: {len(bad)}")
    for line in bad:
        print(f"  {line}")
    return 1 if bad else 0


#: Families with a bistable window: (tip width, curvature, thickness, modulus), the
#: rectangle at the paper's curvatures, tapered towards the cusp, a weak clamp near
#: the rectangle's cusp, a thinner and a softer sheet.
FAMILIES = [(1.0, 2.5, 0.03, 735.0), (1.0, 5.0, 0.03, 735.0), (0.8, 2.5, 0.03, 735.0),
            (0.7, 2.5, 0.03, 735.0), (1.0, 1.2, 0.03, 735.0), (0.9, 4.0, 0.03, 735.0),
            (1.0, 2.5, 0.02, 735.0), (1.0, 2.5, 0.03, 400.0)]


def windows(hmax, out):
    """Both paths across the bistable window of each family: two states, two names."""
    done = {}
    try:
        with open(out) as fh:
            for line in fh:
                rec = json.loads(line)
                done[rec["key"]] = rec
    except FileNotFoundError:
        pass
    bad, n = [], 0
    for b, k, h, E in FAMILIES:
        sheet = Sheet(length=1.0, tip_width=b, curvature=k, thickness=h, modulus=E)
        key = json.dumps([b, k, h, E])
        if key not in done:
            f = fold_lengths(sheet, hmax=hmax)
            rec = dict(key=key, L0=f.popup_length, L1=f.standout_length, bistable=f.bistable,
                       pairs=[])
            if f.bistable:
                for x in (0.1, 0.5, 0.9):
                    L = f.popup_length + x * f.width
                    rs = [solve(sheet.replace(length=L), path=p, hmax=hmax)
                          for p in ("curvature-first", "gravity-first")]
                    rec["pairs"].append(dict(length=L, deflection=[r.deflection for r in rs],
                                             stable=[r.stable for r in rs],
                                             branch=[r.branch for r in rs]))
            done[key] = rec
            with open(out, "a") as fh:
                fh.write(json.dumps(rec) + "\n")
        rec = done[key]
        print(f"b/a {b:g}, a/R {k:g}, h/a {h:g}, E {E:g}: L0* {rec['L0']:.5f}, "
              f"L1* {rec['L1']:.5f}", flush=True)
        for q in rec["pairs"]:
            n += 1
            (d1, d2), names = q["deflection"], q["branch"]
            two = abs(d1 - d2) > SAME and all(q["stable"])
            ok = two and names[0] != names[1]
            print(f"  L/a {q['length']:.5f}: d/a {d1:.4f} / {d2:.4f}, {names[0]} / {names[1]}"
                  + ("" if ok else "   <-- VIOLATION"))
            if not ok:
                bad.append((b, k, h, E, q["length"]))
    print(f"{n} pairs inside bistable windows, violations: {len(bad)}")
    return 1 if bad else 0


def si_sheet(H):
    """The issue's SI sheet, three ways: the same fold lengths."""
    SI = dict(base_width=0.04, length=0.055, tip_width=0.036, thickness=1.2e-3, radius=0.016,
              youngs_modulus=6.0e5, density=1150)
    JSON = os.path.join(tempfile.mkdtemp(), "bistability.json")
    sheet = Sheet.from_si(**SI)
    print(repr(sheet))
    t = time.perf_counter()
    f = fold_lengths(sheet, hmax=H)
    print(f"python fold_lengths ({time.perf_counter() - t:.0f} s):")
    print(f)
    arg = ",".join(f"{k}={v:g}" for k, v in SI.items())
    t = time.perf_counter()
    out = subprocess.run([sys.executable, "-m", "skfem_sheet", "bistability", "--si", arg,
                          "--hmax", str(H), "--json", JSON, "--quiet"], capture_output=True,
                         text=True)
    print(f"bistability --si ({time.perf_counter() - t:.0f} s), exit {out.returncode}:")
    print(out.stdout)
    cli = json.load(open(JSON))
    t = time.perf_counter()
    both = solve_both(sheet, hmax=H, folds=True)
    print(f"solve_both(folds=True) ({time.perf_counter() - t:.0f} s):")
    print(both)
    rows = [("fold_lengths", f.popup_length, f.standout_length),
            ("bistability --si", cli["popup_length"], cli["standout_length"]),
            ("solve_both(folds=True)", both.folds.popup_length, both.folds.standout_length)]
    print("\nL0*, L1* (L/a) and in mm:")
    for name, a, b in rows:
        print(f"  {name:24s} {a:.7f} {b:.7f}   {40 * a:.4f} mm {40 * b:.4f} mm")
    print("largest difference:", max(abs(r[1] - rows[0][1]) for r in rows),
          max(abs(r[2] - rows[0][2]) for r in rows))
    print("CLI JSON si:", json.dumps(cli["si"]))
    return 0


def main(argv=None):
    ap = parser(__doc__)
    ap.add_argument("--fold-lengths", action="store_true", help="fold_lengths' cost and agreement")
    ap.add_argument("--si-sheet", action="store_true", help="the SI sheet three ways")
    ap.add_argument("--names", action="store_true", help="the names of the stress set's states")
    ap.add_argument("--windows", action="store_true",
                    help="both paths across the bistable windows of FAMILIES")
    ap.add_argument("--curvatures", default="2.5,5", help="--fold-lengths: a/R values")
    ap.add_argument("--curve", action="store_true", help="--fold-lengths: the fold curve too")
    ap.add_argument("--n", type=int, default=100)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--out", default="labels.jsonl", help="--names, --windows: the journal")
    add_shard_option(ap)
    add_start_option(ap)
    ap.add_argument("--hmax", type=float, default=None,
                    help="mesh size (default 0.1; --fold-lengths 0.03, --si-sheet 0.05)")
    ap.add_argument("--lengths", default="0.6:2.0", help="L/a range searched (short:long)")
    ap.add_argument("--json", default=None)
    ap.add_argument("--skip-critical", action="store_true")
    ap.add_argument("--critical-steps", type=int, default=3,
                    help="bisection steps on b/a between 0.5 and 1 (default 3: +-0.03)")
    args = ap.parse_args(argv)
    if args.fold_lengths:
        hmax = 0.03 if args.hmax is None else args.hmax
        rows = [one(float(k), hmax, args.curve) for k in args.curvatures.split(",")]
        if args.json:
            with open(args.json, "w") as fh:
                json.dump(rows, fh, indent=1)
        return 0
    if args.si_sheet:
        return si_sheet(0.05 if args.hmax is None else args.hmax)
    if args.windows:
        return windows(0.1 if args.hmax is None else args.hmax, args.out)
    if args.names:
        hmax = 0.1 if args.hmax is None else args.hmax
        shard = parse_shard(args.shard)
        todo = both_paths(sample(args.n, args.seed))
        options = start_options(args)
        run_journalled(todo, args.out,
                       lambda p, path: solve_or_crash(p, path, hmax, _fields, options),
                       shard=shard, progress="names")
        if shard[1] > 1:
            return 0
        done = read_jsonl(args.out)
        return report([done[solve_key(p, path)] for p, path in todo])
    args.hmax = 0.1 if args.hmax is None else args.hmax
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
            print(f"  |L1*(arclength) - L1*(fold_lengths)| = "
                  f"{abs(f[0] - rect['standout_length']):.4f}, |L0*(arclength) - "
                  f"L0*(fold_lengths)| = {abs(f[1] - rect['popup_length']):.4f} (two meshes)")
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
