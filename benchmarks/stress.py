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

``--planforms`` (issue 56): the planforms instead, ``--n`` seeded sheets in
turn of five kinds -- trapezoids (b/a 0.5-1), leaves (``p = 1 + c1 xi - c2
xi^2``, tip 0.6-0.95), flares (``p = 1 + c xi^2``, tip 1.05-1.3), sampled
outlines (five samples, a random walk of the width) and bitten slices (a
trapezoid or triangle with one or two tip bites) -- seven in ten near the
bistable region (L/a 1.2-2.4, a/R 2-6), the others anywhere (L/a 0.4-3, a/R
0-6); any prefix of the sample (``--limit K``) has every kind.  Each is solved
along both paths; the summary gives, per kind: solves, converged and stable,
refused (a clean failure, with its message), crashed, coarse-start fallbacks,
fine factorisations (median and largest), and checks that every recorded
snap is a located fold (one eigenvalue crossing) and that no fold is
snapped from twice.  ``--full-check K``: the first ``K`` converged sheets also
solved as the whole sheet (``symmetric=False``): the whole sheet's negative
eigenvalue counts of ``K - s M`` (``M`` the identity on the displacements; at
``s = 0`` the stability count) against the half model's symmetric and
antisymmetric counts added, and the antisymmetric check's time against the
solve's.

    python benchmarks/stress.py --planforms --n 100 --seed 56 --hmax 0.1 --out P.jsonl
    python benchmarks/stress.py --planforms --n 100 --seed 56 --hmax 0.05 --limit 20 --out Q.jsonl
    python benchmarks/stress.py --planforms --n 100 --seed 56 --full-check 12 --out F.jsonl

``--starts``: the default start against the load path (``start="path"``) on
given planform sheets, each solve in a fresh process (its peak resident
memory, ``VmHWM``, its own; threads as given to this script): the same end
states and snaps (d to 1e-6, phase and load to 1e-4), the fine mesh's
factorisations, the coarse work, wall, peak memory and the antisymmetric
stability check's share of the wall (timed once more after the solve).  ``--sheet SPEC``
(repeated) is the JSON of a sample point of ``--planforms`` (``length``,
``curvature`` and a ``planform`` description such as ``{"kind": "leaf", "c1":
0.3, "c2": 0.35}``), solved along ``--paths``; ``--issue-sheets`` adds the three
sheets of issue 56 (the flare p = 1 + 0.2 xi^2, L 1.6, a/R 3; the leaf p = 1 +
0.5 xi - 0.9 xi^2, L 2, a/R 4; the flare of tip 1.114, L 2.186, a/R 5.476; all
curvature-first) and issue 55's rectangle (L 1.5702, a/R 5, gravity-first).

    python benchmarks/stress.py --starts --issue-sheets --hmax 0.1 --json S.json
    python benchmarks/stress.py --starts --hmax 0.03 --sheet '{"length": 1.5, ...}'
"""
import json
import os
import statistics
import subprocess
import sys
import time
import traceback

import numpy as np

from skfem_sheet import Sheet, solve
from skfem_sheet.params import Planform

HERE = os.path.dirname(os.path.abspath(__file__))

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


# -- planforms (issue 56) -------------------------------------------------------------
PLANFORM_KINDS = ("trapezoid", "leaf", "flare", "sampled", "bitten")
CURVED = ("leaf", "flare", "sampled", "bitten")


def planform_sample(n, seed):
    """``n`` seeded sheets of the five kinds in turn (see the module), each a
    dict of the Sheet's numbers, ``kind``, ``region`` and ``planform`` (the
    planform's description, from which :func:`planform_sheet` makes it)."""
    rng = np.random.default_rng(seed)
    out = []
    while len(out) < n:
        kind = PLANFORM_KINDS[len(out) % len(PLANFORM_KINDS)]
        near = rng.uniform() < 0.7
        length = rng.uniform(1.2, 2.4) if near else rng.uniform(0.4, 3.0)
        curvature = rng.uniform(2.0, 6.0) if near else rng.uniform(0.0, 6.0)
        if kind == "trapezoid":
            desc = {"tip_width": rng.uniform(0.5, 1.0)}
        elif kind == "leaf":
            tip, c1 = rng.uniform(0.6, 0.95), rng.uniform(0.2, 1.0)
            desc = {"c1": c1, "c2": 1.0 + c1 - tip}
        elif kind == "flare":
            desc = {"c": rng.uniform(0.05, 0.3)}
        elif kind == "sampled":
            w = [1.0]
            for _ in range(4):
                w.append(float(np.clip(w[-1] + rng.uniform(-0.2, 0.2), 0.5, 1.3)))
            desc = {"xi": [0.0, 0.25, 0.5, 0.75, 1.0], "width": w}
        else:
            bites = [rng.uniform(0.1, 0.35)]
            if rng.uniform() < 0.3:
                bites.append(rng.uniform(0.05, 0.2))
            desc = {"tip_width": rng.uniform(0.0, 0.9), "bites": bites}
        p = dict(length=float(length), curvature=float(curvature), thickness=0.03,
                 modulus=735.0, kind=kind, region="near" if near else "far",
                 planform=dict(kind=kind, **{k: (float(v) if not isinstance(v, list)
                                                 else [float(x) for x in v])
                                             for k, v in desc.items()}))
        try:
            sheet = planform_sheet(p)
        except ValueError:  # a bite that eats the sheet, a neck: drawn again
            continue
        p["tip_width"] = float(sheet.tip_width)
        out.append(p)
    return out


def planform_sheet(p):
    """The Sheet of a sample point of :func:`planform_sample`."""
    d = p["planform"]
    base = dict(curvature=p["curvature"], thickness=p["thickness"], modulus=p["modulus"])
    kind = d["kind"]
    if kind == "trapezoid":
        return Sheet(length=p["length"], tip_width=d["tip_width"], **base)
    if kind == "leaf":
        c1, c2 = d["c1"], d["c2"]
        planform = Planform.from_function(lambda s: 1.0 + c1 * s - c2 * s * s)
    elif kind == "flare":
        c = d["c"]
        planform = Planform.from_function(lambda s: 1.0 + c * s * s)
    elif kind == "sampled":
        planform = Planform(tuple(d["xi"]), tuple(d["width"]))
    else:
        planform = Planform.trapezoid(d["tip_width"], bites=tuple(d["bites"]))
    return Sheet.from_planform(planform, length=p["length"], **base)


def _planform_fields(r):
    return dict(_fields(r), negative_eigenvalues=list(r.negative_eigenvalues or ()),
                start_folds=[dict(f) for f in r.start_record.folds])


def run_planform_point(p, path, hmax, options=None):
    """One solve of a planform sample point (a crash is recorded, not raised)."""
    t0 = time.perf_counter()
    try:
        sheet = planform_sheet(p)
        r = solve(sheet, path=path, hmax=min(hmax, p["length"] / 2), on_failure="return",
                  **(options or {}))
    except Exception as err:  # noqa: BLE001 - a crash is what this benchmark counts
        if type(err).__name__ == "ParameterError":  # refused before solving: not a crash
            return dict(status="failed", message=str(err), wall_time_s=time.perf_counter() - t0)
        return dict(status="crash", error=f"{type(err).__name__}: {err}",
                    traceback=traceback.format_exc(), wall_time_s=time.perf_counter() - t0)
    return dict(status="converged" if r.converged else "failed", **_planform_fields(r))


#: The shifts ``s`` of the full check: counts of the eigenvalues of the pencil
#: ``(K, M)`` below ``s`` (``M`` the identity on the whole sheet's displacement
#: dofs; on the half model's, 1/2 on the symmetry plane, whose nodes the two
#: halves share).
FULL_CHECK_SHIFTS = (0.0, 1e-3, 3e-3, 1e-2)


def _shifted_counts(problem, w, kind):
    """Negative eigenvalue counts of ``K - s M`` on the incompressible
    subspace for :data:`FULL_CHECK_SHIFTS`: the whole sheet's (``kind`` "full")
    or the half model's symmetric or antisymmetric problem."""
    import scipy.sparse as sp

    from skfem_sheet.analyses.stability import antisymmetric_problem_dofs, antisymmetric_tangent
    from skfem_sheet.linalg import make_linear_solver

    plane = np.zeros(problem.ndof, bool)
    if problem.sheet_mesh.half:
        plane[3 * problem.space.symmetry_nodes[:, None] + np.arange(3)] = True
    if kind == "antisymmetric":
        free, keep, extra = antisymmetric_problem_dofs(problem)
        dofs = np.concatenate([free[np.isin(free, extra, invert=True)], extra])
        K = antisymmetric_tangent(problem, w)
    else:
        dofs = problem.free
        K = problem.tangent(w)
    M = sp.diags(np.where(dofs < problem.nu_dof, np.where(plane[dofs], 0.5, 1.0), 0.0))
    m = int(np.count_nonzero(dofs >= problem.nu_dof))
    out = []
    for s in FULL_CHECK_SHIFTS:
        linear = make_linear_solver("auto")
        linear.factorize((K - s * M).tocsr())
        inertia = linear.inertia()
        out.append(None if inertia is None else int(inertia[1]) - m)
    return out


def run_full_check(p, path, hmax, options=None):
    """The half model (default) and the whole sheet of one sample point: both
    d, both counts at every shift, the antisymmetric check's time."""
    from skfem_sheet.analyses.stability import antisymmetric_stability

    sheet = planform_sheet(p)
    h = min(hmax, p["length"] / 2)
    half = solve(sheet, path=path, hmax=h, on_failure="return", **(options or {}))
    full = solve(sheet, path=path, hmax=h, on_failure="return", symmetric=False,
                 **(options or {}))
    rec = dict(status="converged" if half.converged and full.converged else "failed",
               deflection=half.deflection, full_deflection=full.deflection,
               message=half.message or full.message,
               negative_eigenvalues=list(half.negative_eigenvalues or ()),
               full_negative_eigenvalues=list(full.negative_eigenvalues or ()),
               wall_time_s=half.wall_time_s, full_wall_time_s=full.wall_time_s,
               factorizations=half.factorizations)
    if half.problem is not None and full.problem is not None and rec["status"] == "converged":
        t = time.perf_counter()
        antisymmetric_stability(half.problem, half.w, K=half.problem.tangent(half.w))
        rec["antisymmetric_s"] = time.perf_counter() - t
        rec["symmetric_counts"] = _shifted_counts(half.problem, half.w, "symmetric")
        rec["antisymmetric_counts"] = _shifted_counts(half.problem, half.w, "antisymmetric")
        rec["full_counts"] = _shifted_counts(full.problem, full.w, "full")
    return rec


def _median(xs):
    return statistics.median(xs) if xs else float("nan")


def planform_report(recs, full_check=False):
    """The planform table and summary (see the module); returns the exit status
    (1 if any solve crashed or a check fails)."""
    bad = 0
    print(f"{'kind':9s} {'reg':4s} {'L/a':>5s} {'b/a':>5s} {'a/R':>5s} {'path':16s} {'status':9s} "
          f"{'d/a':>9s} {'fine':>5s} {'coarse':>6s} {'s':>6s}  note")
    for r in recs:
        d = f"{r['deflection']:9.5f}" if "deflection" in r else " " * 9
        note = r.get("coarse_fallback") or r.get("message") or r.get("error", "")
        print(f"{r['kind']:9s} {r['region']:4s} {r['length']:5.2f} {r['tip_width']:5.2f} "
              f"{r['curvature']:5.2f} {r['path']:16s} {r['status']:9s} {d} "
              f"{r.get('factorizations', 0):5d} {r.get('coarse_factorizations', 0):6d} "
              f"{r['wall_time_s']:6.1f}  {note}")
    if full_check:
        done = [r for r in recs if "full_counts" in r]
        same = [r for r in done if [a + b for a, b in zip(r["symmetric_counts"],
                                                         r["antisymmetric_counts"])]
                == r["full_counts"]]
        print(f"\nfull check: {len(done)} sheets; the whole sheet's counts at the shifts "
              f"{FULL_CHECK_SHIFTS} equal the half model's symmetric + antisymmetric counts "
              f"in {len(same)}")
        for r in done:
            print(f"  {r['kind']:9s} L {r['length']:.3f} a/R {r['curvature']:.3f} {r['path']:16s}"
                  f" d {r['deflection']:.6f} / {r['full_deflection']:.6f}: sym "
                  f"{r['symmetric_counts']} + anti {r['antisymmetric_counts']} vs full "
                  f"{r['full_counts']}; antisymmetric check {r['antisymmetric_s']:.2f} s of a "
                  f"{r['wall_time_s']:.1f} s solve ({r['antisymmetric_s'] / r['wall_time_s']:.2f})")
        return 0 if len(same) == len(done) else 1
    print("\nkind       solves conv+stable refused crashed fallbacks fine fact. median/max")
    for kind in PLANFORM_KINDS + ("curved", "all"):
        sel = [r for r in recs if r["kind"] == kind or kind == "all"
               or (kind == "curved" and r["kind"] in CURVED)]
        if not sel:
            continue
        ok = [r for r in sel if r["status"] == "converged" and r.get("stable") is True]
        ref = [r for r in sel if r["status"] == "failed"]
        crash = [r for r in sel if r["status"] == "crash"]
        fb = [r for r in sel if r.get("coarse_fallback")]
        fact = [r["factorizations"] for r in sel if "factorizations" in r]
        print(f"{kind:10s} {len(sel):6d} {len(ok):11d} {len(ref):7d} {len(crash):7d} "
              f"{len(fb):9d} {_median(fact):8.1f} / {max(fact) if fact else 0}")
    crash = [r for r in recs if r["status"] == "crash"]
    unverified = [r for r in recs if r["status"] == "converged" and r.get("stable") is not True]
    refused = [r for r in recs if r["status"] == "failed"]
    bad += len(crash) + len(unverified)
    # every snap a located fold (one eigenvalue crossing), each fold once
    not_located, twice = [], []
    for r in recs:
        snaps = r.get("snaps") or []
        for s in snaps:
            k = s.get("negative_eigenvalues") or [None, None]
            if None in k or k[1] - k[0] != 1:
                not_located.append((r["key"], s))
        for a, b in zip(snaps, snaps[1:]):
            if a["phase"] == b["phase"] and abs(a["load"] - b["load"]) <= 1e-4:
                twice.append((r["key"], a["load"], b["load"]))
    bad += len(not_located) + len(twice)
    n_fb = sum(1 for r in recs if r.get("coarse_fallback"))
    print(f"\n{len(recs)} solves: {len(crash)} crashed, {len(unverified)} converged but not "
          f"verified stable, {len(refused)} refused; coarse-start fallbacks {n_fb} "
          f"({100 * n_fb / max(1, len(recs)):.1f}%); snaps {sum(len(r.get('snaps') or []) for r in recs)}"
          f", not a located fold {len(not_located)}, a fold snapped from twice {len(twice)}")
    for r in refused:
        print(f"  refused: {r['key']}: {r.get('message')}")
    for r in crash:
        print(f"  crashed: {r['key']}: {r.get('error')}")
    for key, a, b in twice:
        print(f"  twice: {key}: {a} and {b}")
    return 1 if bad else 0


# -- the default start against the path, in fresh processes (issue 56) ------------------
#: Issue 56's three sheets and issue 55's rectangle, each on its path.
ISSUE_SHEETS = [
    (dict(length=1.6, curvature=3.0, planform={"kind": "flare", "c": 0.2}), "curvature-first"),
    (dict(length=2.0, curvature=4.0, planform={"kind": "leaf", "c1": 0.5, "c2": 0.9}),
     "curvature-first"),
    (dict(length=2.186, curvature=5.476, planform={"kind": "flare", "c": 0.114}),
     "curvature-first"),
    (dict(length=1.5702, curvature=5.0, planform={"kind": "trapezoid", "tip_width": 1.0}),
     "gravity-first"),
]

CHILD = """
import json, sys, time
from harness import peak_rss_bytes
from stress import planform_sheet
from skfem_sheet import solve
spec = json.loads(sys.argv[1])
t = time.perf_counter()
r = solve(planform_sheet(spec["sheet"]), path=spec["path"], hmax=spec["hmax"],
          start=spec["start"], on_failure="return")
call = time.perf_counter() - t
peak = peak_rss_bytes() / 1024**3
anti = None
if r.converged:  # the antisymmetric check once more, timed on its own (in the solve's wall)
    from skfem_sheet.analyses.stability import antisymmetric_stability
    t = time.perf_counter()
    antisymmetric_stability(r.problem, r.w, K=r.problem.tangent(r.w))
    anti = time.perf_counter() - t
print(json.dumps(dict(converged=r.converged, message=r.message, deflection=r.deflection,
                      stable=r.stable, negative_eigenvalues=list(r.negative_eigenvalues or ()),
                      snaps=[s.to_json() for s in r.snaps], factorizations=r.factorizations,
                      newton_iterations=r.newton_iterations,
                      coarse_factorizations=r.coarse_factorizations,
                      fallback=r.coarse_fallback, wall_s=r.wall_time_s, call_s=call,
                      antisymmetric_s=anti, dofs=r.dofs, peak_gb=peak), default=float))
"""


def run_start(sheet, path, hmax, start):
    """One solve of ``--starts`` in a fresh process (in this folder, so that
    the child imports this script's modules): its record."""
    spec = dict(sheet=dict(dict(thickness=0.03, modulus=735.0), **sheet), path=path, hmax=hmax,
                start=start)
    out = subprocess.run([sys.executable, "-c", CHILD, json.dumps(spec)], cwd=HERE,
                         capture_output=True, text=True, check=False)
    if out.returncode:
        return dict(converged=False, message=f"crash: {out.stderr.strip().splitlines()[-1:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def same_states(a, b):
    """Both converged to one end state with the same snaps."""
    if not (a.get("converged") and b.get("converged")):
        return False
    sa = [(s["phase"], s["load"]) for s in a["snaps"]]
    sb = [(s["phase"], s["load"]) for s in b["snaps"]]
    return (abs(a["deflection"] - b["deflection"]) <= 1e-6 and len(sa) == len(sb)
            and all(x[0] == y[0] and abs(x[1] - y[1]) <= 1e-4 for x, y in zip(sa, sb)))


def compare_starts(args):
    """``--starts`` (see the module)."""
    todo = [(json.loads(s), p) for s in args.sheet for p in args.paths.split(",")]
    if args.issue_sheets:
        todo += ISSUE_SHEETS
    recs, agree = [], 0
    print(f"{'sheet':58s} {'path':16s} {'start':6s} {'d/a':>11s} {'fine':>5s} {'coarse':>6s} "
          f"{'wall s':>7s} {'peak GB':>7s} {'anti':>5s}  snaps (phase, load)   ('anti': the "
          f"antisymmetric check's time over the solve's wall)")
    for sheet, path in todo:
        pair = {start: run_start(sheet, path, args.hmax, start) for start in ("coarse", "path")}
        ok = same_states(pair["coarse"], pair["path"])
        agree += ok
        name = json.dumps(dict(sheet), separators=(",", ":"))[:58]
        for start, r in pair.items():
            d = f"{r['deflection']:11.7f}" if r.get("converged") else "     failed"
            snaps = [(s["phase"][:4], round(s["load"], 6)) for s in r.get("snaps", [])]
            anti = r.get("antisymmetric_s")
            share = f"{anti / r['wall_s']:5.2f}" if anti and r.get("wall_s") else "    -"
            print(f"{name:58s} {path:16s} {start:6s} {d} {r.get('factorizations', 0):5d} "
                  f"{r.get('coarse_factorizations', 0):6d} {r.get('wall_s', 0):7.1f} "
                  f"{r.get('peak_gb', 0):7.3f} {share}  {snaps} "
                  f"{r.get('fallback') or r.get('message')}")
        print(f"{'':58s} {'':16s} {'same end state and snaps' if ok else 'DIFFER'}")
        recs.append(dict(sheet=sheet, path=path, hmax=args.hmax, starts=pair, agree=ok))
    print(f"\n{agree} of {len(todo)} pairs agree (d to 1e-6, the same snaps to 1e-4 in load)")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(recs, f, indent=1, default=float)
    return 0 if agree == len(todo) else 1


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
    ap.add_argument("--planforms", action="store_true",
                    help="the planform sample instead (issue 56; see below)")
    ap.add_argument("--limit", type=int, default=None,
                    help="with --planforms: only the first LIMIT sheets of the sample")
    ap.add_argument("--full-check", type=int, default=0, metavar="K",
                    help="with --planforms: the first K sheets also as the whole sheet")
    ap.add_argument("--starts", action="store_true",
                    help="the default start against the path on --sheet / --issue-sheets")
    ap.add_argument("--sheet", action="append", default=[],
                    help="with --starts: a planform sample point's JSON (repeat)")
    ap.add_argument("--paths", default="curvature-first,gravity-first",
                    help="with --starts: the paths of the --sheet sheets")
    ap.add_argument("--issue-sheets", action="store_true",
                    help="with --starts: issue 56's three sheets and issue 55's rectangle")
    ap.add_argument("--json", default=None, help="with --starts: write the records here")
    ap.add_argument("--compare", nargs=2, metavar=("BEFORE.jsonl", "AFTER.jsonl"),
                    help="pair two journals solve by solve instead (exit 1 if any differs)")
    args = ap.parse_args(argv)
    if args.starts:
        return compare_starts(args)
    if args.compare:
        return compare_journals(*args.compare)
    shard = parse_shard(args.shard)
    options = start_options(args)
    if args.planforms:
        points = planform_sample(args.n, args.seed)[:args.limit]
        if args.full_check:
            points = points[:args.full_check]
            run = run_full_check
        else:
            run = run_planform_point
        todo = both_paths(points)
        run_journalled(todo, args.out, lambda p, path: run(p, path, args.hmax, options),
                       shard=shard, reverse=args.reverse, progress="planforms")
        if shard[1] > 1:
            return 0
        done = read_jsonl(args.out)
        return planform_report([done[solve_key(p, path)] for p, path in todo],
                               full_check=bool(args.full_check))
    todo = both_paths(sample(args.n, args.seed))
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
