"""Stress test of the 3D solver over the whole parameter space (issue 5).

    python benchmarks/stress.py [--n 100] [--seed 1] [--hmax 0.1] [--out stress.jsonl]
        [--start coarse|path] [--coarse-hmax H] [--shard K:N]
    python benchmarks/stress.py --compare BEFORE.jsonl AFTER.jsonl

A seeded random sample of ``--n`` points over L/a in [0.2, 3], b/a in [0, 1],
a/R in [0, 6], plus the corners (sharp tip, a/R = 6, very short and very long
sheets, thickness 0.01 and 0.06, modulus 100 and 1e4), each solved along both
load paths at a coarse mesh.  Every solve ends as

- ``converged``  full load reached;
- ``failed``     cleanly reported failure (``converged=False`` with the last
                 converged load and the reason);
- ``crash``      any exception escaping ``solve`` (a bug).

Each record also holds ``stable`` and ``snaps`` (issue 17): a converged
result must be verified stable.

Results are appended to a JSON-lines file as they finish, so an interrupted
run resumes where it stopped (finished points are skipped).  A table and a
summary line are printed at the end.
"""
import sys

from harness import (
    add_shard_option,
    add_start_option,
    both_paths,
    coarse_fields,
    compare_journals,
    parse_shard,
    parser,
    random_sheets,
    read_jsonl,
    run_journalled,
    solve_key,
    solve_or_crash,
    start_options,
)


def sample(n, seed):
    pts = [dict(p, kind="random") for p in random_sheets(n, seed)]
    corners = [
        dict(length=1.3, tip_width=0.0, curvature=6.0),
        dict(length=1.3, tip_width=1.0, curvature=6.0),
        dict(length=0.2, tip_width=1.0, curvature=2.5),
        dict(length=0.2, tip_width=0.0, curvature=6.0),
        dict(length=3.0, tip_width=1.0, curvature=2.5),
        dict(length=3.0, tip_width=0.0, curvature=6.0),
        dict(length=3.0, tip_width=1.0, curvature=0.0),
        dict(length=1.3, tip_width=1.0, curvature=2.5, thickness=0.01),
        dict(length=1.3, tip_width=1.0, curvature=2.5, thickness=0.06),
        dict(length=1.3, tip_width=1.0, curvature=2.5, modulus=100.0),
        dict(length=1.3, tip_width=1.0, curvature=2.5, modulus=1e4),
        dict(length=1.3, tip_width=0.0, curvature=0.0, modulus=100.0),
    ]
    for c in corners:
        pts.append(dict(dict(thickness=0.03, modulus=735.0), **c, kind="corner"))
    return pts


def _fields(r):
    return dict(deflection=r.deflection, message=r.message, kappa_reached=r.kappa,
                gravity_reached=r.gravity, newton_iterations=r.newton_iterations,
                load_steps=r.load_steps, rejected_steps=r.rejected_steps,
                factorizations=r.factorizations,
                wall_time_s=r.wall_time_s, dofs=r.dofs, stable=r.stable,
                snaps=[s.to_json() for s in r.snaps], **coarse_fields(r))


def run_point(p, path, hmax, options=None):
    return solve_or_crash(p, path, hmax, _fields, options)


def main(argv=None):
    ap = parser(__doc__)
    ap.add_argument("--n", type=int, default=100)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--hmax", type=float, default=0.1)
    ap.add_argument("--out", default="stress.jsonl")
    add_shard_option(ap)
    add_start_option(ap)
    ap.add_argument("--reverse", action="store_true",
                    help="work through the shard from its end (a second worker on a shard)")
    ap.add_argument("--compare", nargs=2, metavar=("BEFORE.jsonl", "AFTER.jsonl"),
                    help="pair two journals solve by solve instead (exit 1 if any differs)")
    args = ap.parse_args(argv)
    if args.compare:
        return compare_journals(*args.compare)
    shard = parse_shard(args.shard)
    todo = both_paths(sample(args.n, args.seed))
    options = start_options(args)
    run_journalled(todo, args.out, lambda p, path: run_point(p, path, args.hmax, options),
                   shard=shard, reverse=args.reverse, progress="stress")
    if shard[1] > 1:
        return 0
    done = read_jsonl(args.out)  # with the solves of other workers on the same file
    recs = [done[solve_key(p, path)] for p, path in todo]
    print(f"{'kind':7s} {'L/a':>5s} {'b/a':>5s} {'a/R':>5s} {'h/a':>5s} {'E':>6s} {'path':16s} "
          f"{'status':9s} {'d/a':>8s} {'newton':>6s} {'s':>6s}  reason")
    for r in recs:
        d = f"{r['deflection']:8.4f}" if "deflection" in r else " " * 8
        print(f"{r['kind']:7s} {r['length']:5.2f} {r['tip_width']:5.2f} {r['curvature']:5.2f} "
              f"{r['thickness']:5.3f} {r['modulus']:6.0f} {r['path']:16s} {r['status']:9s} {d} "
              f"{r.get('newton_iterations', 0):6d} {r['wall_time_s']:6.1f}  "
              f"{r.get('message') or r.get('error', '')}")
    rand = [r for r in recs if r["kind"] == "random"]
    count = {s: sum(r["status"] == s for r in recs) for s in ("converged", "failed", "crash")}
    rate = sum(r["status"] == "converged" for r in rand) / max(1, len(rand))
    print(f"\nsummary: {len(recs)} solves, {count['converged']} converged, {count['failed']} "
          f"failed cleanly, {count['crash']} crashed; random points converged: "
          f"{100 * rate:.1f}% of {len(rand)}")
    # records made before issue 17 have no "stable"/"snaps" fields
    verified = [r for r in recs if r["status"] == "converged" and "stable" in r]
    print(f"converged with stable False/None: {sum(r['stable'] is not True for r in verified)} "
          f"of {len(verified)} recorded; solves that snapped: "
          f"{sum(bool(r['snaps']) for r in verified)}")
    return 1 if count["crash"] else 0


if __name__ == "__main__":
    sys.exit(main())
