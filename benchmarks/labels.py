"""The names of the states of the stress set: one state, one name; a bistable pair, two.

    python benchmarks/labels.py [--n 100] [--seed 1] [--hmax 0.1] [--out labels.jsonl]
        [--start coarse|path] [--shard K:N]
    python benchmarks/labels.py --windows [--hmax 0.1] [--out windows.jsonl]

The solves of ``benchmarks/stress.py`` (the same seeded sample and corners,
both load paths, at ``min(hmax, L/2)``), each recorded with its name
(``Result.branch``, read from the state: :mod:`skfem_sheet.analyses.mode`),
the S-curve's slope and bend it was read from, the name the load path's
history gave before (its own branch, switched at each snap), and the
paper's picture of the two modes as a check beside it: whether the
transverse curvature ``c(s)`` of the mid-surface (the quadratic fit across
each section, :meth:`~skfem_sheet.analyses.midsurface.Midsurface.lateral_curvature`,
at 19 sections over ``0 <= s <= 0.9 L``) changes sign along the sheet
(relaxed near the base, the sheet flat beyond: "relaxed") or keeps the
clamp's sign ("persists").

Then, per sheet (both paths):

- **one state** (both converged, d within 1e-6): the two names must be one;
- **two states, both stable**: the two names must differ (a bistable pair);
- **hanging** (a converged state with d > L/2, the tip below the clamp by more
  than half the length): it must be gravity-dominated.

The report prints every violation and the counts (exit 1 if any), and the
agreement of the names with the transverse-curvature picture.

``--windows``: the stress set holds few bistable sheets, so these are sought
out: for each of :data:`FAMILIES` (planform, curvature, material) the fold
lengths on the mesh (``fold_lengths``), then both paths at lengths 10%, 50%
and 90% across its window ``L0* < L < L1*``; every such pair must be two
states with two names.
"""
import sys

import numpy as np
from stress import sample

from skfem_sheet.analyses.midsurface import midsurface

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
    import json

    from skfem_sheet import Sheet, fold_lengths, solve

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


def main(argv=None):
    ap = parser(__doc__)
    ap.add_argument("--n", type=int, default=100)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--hmax", type=float, default=0.1)
    ap.add_argument("--out", default="labels.jsonl")
    ap.add_argument("--windows", action="store_true",
                    help="instead: both paths across the bistable windows of FAMILIES")
    add_shard_option(ap)
    add_start_option(ap)
    args = ap.parse_args(argv)
    if args.windows:
        return windows(args.hmax, args.out)
    shard = parse_shard(args.shard)
    todo = both_paths(sample(args.n, args.seed))
    options = start_options(args)
    run_journalled(todo, args.out,
                   lambda p, path: solve_or_crash(p, path, args.hmax, _fields, options),
                   shard=shard, progress="labels")
    if shard[1] > 1:
        return 0
    done = read_jsonl(args.out)
    return report([done[solve_key(p, path)] for p, path in todo])


if __name__ == "__main__":
    sys.exit(main())
