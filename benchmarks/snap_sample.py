"""Verified end states and snap cost over thin and soft sheets (issue 17).

    python benchmarks/snap_sample.py [--n 50] [--seed 17] [--hmax 0.1] [--out snap_sample.jsonl]
        [--start coarse|path] [--coarse-hmax H] [--shard K:N]
    python benchmarks/snap_sample.py --compare BEFORE.jsonl AFTER.jsonl

A seeded random sample of ``--n`` sheets with L/a in [0.2, 3], b/a in [0, 1],
a/R in [0, 6] (spread as in ``benchmarks/stress.py``), thickness h/a in
[0.02, 0.045] and modulus E/(rho g a) in [400, 2000], each solved along both
load paths at ``min(hmax, L/2)`` with ``on_failure="return"``.  Per solve it
records the status (``converged``, ``failed`` or ``crash``), d, the Newton
iterations, the verdict ``stable`` and every snap ``(phase, lam, kappa, g)``.

The summary counts

- ``converged=True`` with ``stable`` False or None: must be zero (a load
  path verifies its end state; only a linear solver that cannot report the
  inertia may leave ``stable=None``);
- the solves that snapped, and the iteration statistics of snapping and
  non-snapping solves (median, 90th percentile, max).

Results are appended to a JSON-lines file as they finish (an interrupted run
resumes; ``--shard k:n`` lets several processes share one file, and a last run
without it prints the table).  Exit status 1 if a solve crashed or a
converged result is not verified stable.
"""
import sys

import numpy as np

from harness import (
    add_shard_option,
    add_start_option,
    both_paths,
    coarse_fields,
    compare_journals,
    parse_shard,
    parser,
    random_sheets,
    run_journalled,
    solve_key,
    solve_or_crash,
    start_options,
)


def _snap_text(s):
    """One snap of a record: a dict (located fold) or, in records made before
    the located-fold rule, ``[phase, lam, a/R, g]``."""
    if isinstance(s, dict):
        return (f"{s['phase']} fold at {s['load']:.6g} (a/R={s['curvature']:.4g} "
                f"g={s['gravity']:.3g}) d {s['fold_deflection']:.4f}->{s['landing_deflection']:.4f}")
    return f"{s[0]} lam={s[1]:.4g} a/R={s[2]:.4g} g={s[3]:.3g}"

def sample(n, seed):
    """``n`` seeded random sheets (dicts of Sheet arguments)."""
    return random_sheets(n, seed, thickness=(0.02, 0.045), modulus=(400.0, 2000.0))


def _fields(r):
    return dict(deflection=r.deflection, message=r.message, stable=r.stable,
                negative_eigenvalues=r.negative_eigenvalues, snaps=[s.to_json() for s in r.snaps],
                branch=r.branch, newton_iterations=r.newton_iterations,
                factorizations=r.factorizations, load_steps=r.load_steps,
                rejected_steps=r.rejected_steps, wall_time_s=r.wall_time_s, dofs=r.dofs,
                **coarse_fields(r))


def run_point(p, path, hmax, options=None):
    """One solve as a JSON-ready record."""
    return solve_or_crash(p, path, hmax, _fields, options)


def _stats(xs):
    if not xs:
        return "-"
    xs = np.asarray(xs)
    return (f"n={len(xs)} median {np.median(xs):.0f}, p90 {np.percentile(xs, 90):.0f}, "
            f"max {xs.max():.0f}")


def report(recs):
    """The table and the summary lines; returns the exit status."""
    header = (f"{'L/a':>5s} {'b/a':>5s} {'a/R':>5s} {'h/a':>6s} {'E':>6s} {'path':16s} "
              f"{'status':9s} {'d/a':>9s} {'stable':>6s} {'newton':>6s} {'s':>6s}  snaps / reason")
    lines = [header]
    for r in recs:
        d = f"{r['deflection']:9.5f}" if "deflection" in r else " " * 9
        snaps = "; ".join(_snap_text(s) for s in r.get("snaps", []))
        lines.append(f"{r['length']:5.2f} {r['tip_width']:5.2f} {r['curvature']:5.2f} "
                     f"{r['thickness']:6.4f} {r['modulus']:6.0f} {r['path']:16s} {r['status']:9s} "
                     f"{d} {r.get('stable')!s:>6s} {r.get('newton_iterations', 0):6d} "
                     f"{r['wall_time_s']:6.1f}  {snaps} {r.get('message') or r.get('error', '')}")
    count = {s: sum(r["status"] == s for r in recs) for s in ("converged", "failed", "crash")}
    unverified = [r for r in recs if r["status"] == "converged" and r.get("stable") is not True]
    snapped = [r for r in recs if r.get("snaps")]
    conv = [r for r in recs if r["status"] == "converged"]
    summary = (f"summary: {len(recs)} solves, {count['converged']} converged, "
               f"{count['failed']} failed cleanly, {count['crash']} crashed")
    lines += ["", summary,
              f"converged with stable False/None: {len(unverified)}",
              f"solves that snapped: {len(snapped)} ({sum(len(r['snaps']) for r in snapped)} snaps)",
              "newton iterations, snapping solves: "
              + _stats([r["newton_iterations"] for r in conv if r.get("snaps")]),
              "newton iterations, other solves:    "
              + _stats([r["newton_iterations"] for r in conv if not r.get("snaps")]),
              f"total wall time of the solves: {sum(r['wall_time_s'] for r in recs):.0f} s"]
    for r in unverified:
        lines.append(f"UNVERIFIED: {r['key']} stable={r.get('stable')}")
    print("\n".join(lines))
    return 1 if count["crash"] or unverified else 0


def main(argv=None):
    ap = parser(__doc__)
    ap.add_argument("--n", type=int, default=50)
    ap.add_argument("--seed", type=int, default=17)
    ap.add_argument("--hmax", type=float, default=0.1)
    ap.add_argument("--out", default="snap_sample.jsonl")
    add_shard_option(ap)
    add_start_option(ap)
    ap.add_argument("--compare", nargs=2, metavar=("BEFORE.jsonl", "AFTER.jsonl"),
                    help="pair two journals solve by solve instead (exit 1 if any differs)")
    args = ap.parse_args(argv)
    if args.compare:
        return compare_journals(*args.compare)
    shard = parse_shard(args.shard)
    todo = both_paths(sample(args.n, args.seed))

    def report_one(i, n, p, path, rec):
        print(f"[{i + 1}/{n}] {path} L={p['length']:.2f} a/R={p['curvature']:.2f}: "
              f"{rec['status']} {rec.get('newton_iterations')} it, stable={rec.get('stable')}, "
              f"{len(rec.get('snaps', []))} snap(s), {rec['wall_time_s']:.1f} s",
              file=sys.stderr, flush=True)

    options = start_options(args)
    done = run_journalled(todo, args.out, lambda p, path: run_point(p, path, args.hmax, options),
                          shard=shard, report=report_one)
    if shard[1] > 1:
        return 0
    return report([done[solve_key(p, path)] for p, path in todo])


if __name__ == "__main__":
    sys.exit(main())
