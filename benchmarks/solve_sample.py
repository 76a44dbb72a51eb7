"""Speed of solves over a seeded random sample of sheets (issue 16, item 1).

The lead's re-run (``solve``'s default start, ``"coarse"``; one command)::

    flock /work/heavy.lock python benchmarks/solve_sample.py --hmax 0.03 --n 12 --seed 16 \
        --json benchmarks/results/speed/solve_sample_hmax0.03_coarse.json \
        --txt benchmarks/results/speed/solve_sample_hmax0.03_coarse.txt
    python benchmarks/solve_sample.py compare benchmarks/results/speed/solve_sample_hmax0.03_path.json \
        benchmarks/results/speed/solve_sample_hmax0.03_coarse.json --by-run --base path \
        --other coarse --txt benchmarks/results/speed/solve_sample_hmax0.03_coarse_vs_path.txt

    python benchmarks/solve_sample.py [--hmax 0.03] [--n 12] [--seed 16]
        [--json out.json] [--txt out.txt] [--no-cases] [--cases-only]
        [--case rectangle] [--sheet L,B,K ...] [--paths curvature-first,gravity-first]
        [--variant NAME=JSON ...] [--start path|coarse] [--coarse-hmax H]
        [--polish] [--threads N] [--timeout S]
    python benchmarks/solve_sample.py compare RUN.json [RUN.json ...] [--by-run] ...
        (no solve: two variants or two runs paired sheet by sheet; ``compare --help``)

A benchmark that cannot be tuned to: ``--n`` sheets drawn uniformly (seeded)
from L/a in [1, 2.2], b/a in [0.6, 1], a/R in [1.5, 5] -- inside and near the
bistable region, where load paths are hardest -- each solved along both load
paths, plus the four cases of ``benchmarks/solve_speed.py`` (rectangle and
triangle, L/a = 1.3, a/R = 2.5).  Every solve runs in a fresh Python process,
so its peak resident memory (VmHWM) is its own and no state carries over.

Per solve: factorisations, back-substitutions, Newton iterations, wall time
(the Result's), the share of it in the linear solver, peak memory, the tip
deflection d/a, the branch, stability, snaps.  Summary (top-level keys of the
JSON, over the random sample): ``median_factorizations``,
``max_factorizations``, ``median_wall_s``; the same over the four cases and
over all solves under ``summary_cases`` and ``summary_all``.

``--variant NAME=JSON`` (repeatable) runs every solve once per variant, in
turn (old, new, old, new, ...: the machine load is shared fairly), with
``JSON`` passed as options to the linear solver, e.g.
``--variant new={} --variant old='{"reproducible": false}'``, except the keys
``start`` and ``coarse_hmax``, which are passed to ``solve`` (e.g.
``--variant path='{"start": "path"}' --variant coarse='{"start": "coarse"}'``);
the summary then gives, per variant, the median ratio of its wall and
linear-solver time to the first variant's over the paired solves, and
whether the branch and d agree.  ``--start``/``--coarse-hmax`` set those
``solve`` options for every solve.  With ``start="coarse"``
``factorizations`` counts the fine mesh's only and ``coarse_factorizations``
the coarse path's (the summary gives both and their sum); the wall time
includes the coarse path.  ``equivalent_factorizations`` counts both in
factorisations of the fine mesh: the fine count plus the coarse solvers'
factorisation time divided by the fine solver's mean time per factorisation,
both measured in that solve (a coarse factorisation at hmax 0.1 costs a small
fraction of one at hmax 0.03).  ``--polish`` solves every end state once more by
Newton to ``rtol = 1e-9``, ``utol = 1e-10`` (not timed, not counted) and
records its d as ``deflection_polished``: two solves on one branch then
agree to round-off, whatever the tolerance they stopped at.

Timings are only meaningful on an otherwise idle machine: the load average
at the start is recorded and a warning printed if it is high.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

from harness import GB, fmt, machine_info, parser, peak_rss_bytes, warn_if_busy

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

from skfem_sheet.io import atomic_write, dumps_json

#: The sampled box (issue 16): L/a, b/a, a/R.
BOX = dict(length=(1.0, 2.2), tip_width=(0.6, 1.0), curvature=(1.5, 5.0))
PATHS = ("curvature-first", "gravity-first")
#: The four cases of benchmarks/solve_speed.py.
CASES = [("rectangle", dict(length=1.3, tip_width=1.0, curvature=2.5)),
         ("triangle", dict(length=1.3, tip_width=0.0, curvature=2.5))]


def sample_sheets(n, seed):
    """``n`` sheets (keyword dicts of ``Sheet``) drawn uniformly from :data:`BOX`.

    Examples
    --------
    >>> a = sample_sheets(3, 16)
    >>> a == sample_sheets(3, 16), all(1.0 <= s["length"] <= 2.2 for s in a)
    (True, True)
    """
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        out.append({k: round(float(rng.uniform(lo, hi)), 4) for k, (lo, hi) in BOX.items()})
    return out


# ---------------------------------------------------------------------------
# one solve, in a fresh process
# ---------------------------------------------------------------------------
def _child(spec_json, out_path):
    """Body of the child process: one solve, its record written to ``out_path``."""
    spec = json.loads(spec_json)
    rec = dict(spec=spec)
    try:
        from skfem_sheet import Sheet, solve
        from skfem_sheet.linalg import make_linear_solver

        solve_module = sys.modules["skfem_sheet.solve"]
        made = []
        options = spec.get("linear_options") or {}

        def recording(name="auto", **kw):
            # keep the solver object to read its counts (back-substitutions,
            # perturbed pivots), and pass the variant's options to it
            s = make_linear_solver(name, **{**options, **kw})
            made.append(s)
            return s

        solve_module.make_linear_solver = recording
        sys.modules["skfem_sheet.starts"].make_linear_solver = recording  # the coarse mesh's
        rss0 = peak_rss_bytes()
        r = solve(Sheet(**spec["parameters"]), path=spec["path"], hmax=spec["hmax"],
                  on_failure="return", **(spec.get("solve_options") or {}))
    except Exception as err:  # noqa: BLE001 - recorded as a crash of this solve
        import traceback

        rec.update(status="crash", error=f"{type(err).__name__}: {err}",
                   traceback=traceback.format_exc(), peak_rss_gb=peak_rss_bytes() / GB)
    else:
        # the first solver made is the one of the mesh hmax (a coarse path makes its own)
        counts = made[0].counts.as_dict() if made and hasattr(made[0], "counts") else {}
        back = getattr(r, "back_substitutions", None)
        if back is None:
            back = counts.get("back_substitutions")
        wall, lin = float(r.wall_time_s), float(r.linear_solve_s)
        # the coarse path's factorisations in units of the fine mesh's, by the
        # factorisation time each solver measured in this solve
        fine_s = float(getattr(made[0], "factor_time", 0.0)) if made else 0.0
        coarse_s = float(sum(getattr(m, "factor_time", 0.0) for m in made[1:]))
        per_fine = fine_s / r.factorizations if r.factorizations and fine_s > 0 else None
        rec.update(
            status="converged" if r.converged else "failed", converged=bool(r.converged),
            message=r.message, dofs=int(r.dofs), solver=r.solver,
            factorizations=int(r.factorizations), back_substitutions=back,
            perturbed_factorizations=counts.get("perturbed_factorizations"),
            newton_iterations=int(r.newton_iterations), load_steps=int(r.load_steps),
            wall_time_s=wall, linear_solve_s=lin,
            linear_share=lin / wall if wall > 0 else None,
            peak_rss_gb=peak_rss_bytes() / GB, rss_before_solve_gb=rss0 / GB,
            deflection=float(r.deflection), branch=r.branch, stable=r.stable,
            snaps=len(r.snaps), snap_at=[[s.phase, s.load] for s in r.snaps],
            start=getattr(r, "start", "path"),
            coarse_factorizations=int(getattr(r, "coarse_factorizations", 0)),
            coarse_newton_iterations=int(getattr(r, "coarse_newton_iterations", 0)),
            coarse_fallback=getattr(r, "coarse_fallback", ""),
            coarse_folds=[dict(f) for f in r.start_record.folds],
            polish_iterations=int(getattr(r, "polish_iterations", 0)),
            factor_time_s=fine_s, coarse_factor_time_s=coarse_s,
            equivalent_factorizations=(None if per_fine is None
                                       else r.factorizations + coarse_s / per_fine))
        if spec.get("polish") and r.converged:
            rec["deflection_polished"] = _polished_deflection(r)
    atomic_write(out_path, dumps_json(rec))


def _polished_deflection(r):
    """d of ``r``'s end state solved once more by Newton to a tight tolerance."""
    from skfem_sheet.analyses.observables import tip_deflection
    from skfem_sheet.linalg import make_linear_solver
    from skfem_sheet.newton import NewtonOptions, Stats, newton

    res = newton(r.problem, r.w, r.gravity, make_linear_solver(r.solver),
                 NewtonOptions(rtol=1e-9, utol=1e-10, max_iterations=6), Stats())
    return float(tip_deflection(r.problem, res.w)) if res.converged else None


def run_one(spec, threads=None, timeout=None):
    """Solve ``spec`` in a fresh Python process and return its record."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(x for x in (ROOT, env.get("PYTHONPATH")) if x)
    if threads:
        for var in ("MKL_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
            env[var] = str(threads)
    fd, out = tempfile.mkstemp(prefix="solve_sample_", suffix=".json")
    os.close(fd)
    os.unlink(out)
    t0 = time.perf_counter()
    try:
        proc = subprocess.run([sys.executable, os.path.abspath(__file__), "--child",
                               json.dumps(spec), out], env=env, timeout=timeout,
                              stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    except subprocess.TimeoutExpired:
        return dict(spec=spec, status="timeout", error=f"killed after {timeout:g} s",
                    process_s=time.perf_counter() - t0)
    if not os.path.exists(out):
        tail = " | ".join((proc.stderr or "").strip().splitlines()[-3:])
        return dict(spec=spec, status="crash", process_s=time.perf_counter() - t0,
                    error=f"child exited with code {proc.returncode}: {tail}")
    with open(out) as f:
        rec = json.load(f)
    os.unlink(out)
    rec["process_s"] = time.perf_counter() - t0
    return rec


# ---------------------------------------------------------------------------
# summary and table
# ---------------------------------------------------------------------------
def summarise(rows):
    """Median / worst factorisations, median wall over ``rows`` (all statuses
    count: a failed solve's work is work; ``n_failed`` says how many)."""
    done = [r for r in rows if r.get("factorizations") is not None]
    fact = [r["factorizations"] for r in done]
    wall = [r["wall_time_s"] for r in done]
    back = [r["back_substitutions"] for r in done if r.get("back_substitutions") is not None]
    newton = [r["newton_iterations"] for r in done]
    mem = [r["peak_rss_gb"] for r in done if r.get("peak_rss_gb") is not None]
    share = [r["linear_share"] for r in done if r.get("linear_share") is not None]
    med = (lambda v: float(statistics.median(v)) if v else None)
    coarse = [r.get("coarse_factorizations") or 0 for r in done]
    total = [f + c for f, c in zip(fact, coarse)]
    equiv = [r["equivalent_factorizations"] for r in done
             if r.get("equivalent_factorizations") is not None]
    return dict(
        median_equivalent_factorizations=med(equiv),
        max_equivalent_factorizations=max(equiv) if equiv else None,
        median_coarse_factorizations=med(coarse), max_coarse_factorizations=max(coarse)
        if coarse else None, median_total_factorizations=med(total),
        max_total_factorizations=max(total) if total else None,
        n_coarse_fallback=sum(bool(r.get("coarse_fallback")) for r in done
                              if r.get("start") == "coarse"),
        n_coarse_folds=sum(len(r.get("coarse_folds") or ()) for r in done),
        n=len(rows), n_failed=sum(r.get("status") != "converged" for r in rows),
        n_stable_unknown=sum(r.get("status") == "converged" and r.get("stable") is None
                             for r in rows),
        median_factorizations=med(fact), max_factorizations=max(fact) if fact else None,
        median_back_substitutions=med(back), max_back_substitutions=max(back) if back else None,
        median_newton_iterations=med(newton),
        max_newton_iterations=max(newton) if newton else None,
        median_wall_s=med(wall), max_wall_s=max(wall) if wall else None,
        median_linear_share=med(share), max_peak_rss_gb=max(mem) if mem else None,
        perturbed_factorizations=sum(r.get("perturbed_factorizations") or 0 for r in done))


def _ratios(rows, variants):
    """Median ratio of each variant's wall / linear time to the first one's."""
    if len(variants) < 2:
        return None
    base = variants[0]
    by = {}
    for r in rows:
        key = (r["group"], json.dumps(r["parameters"], sort_keys=True), r["path"])
        by.setdefault(key, {})[r["variant"]] = r
    out = {}
    for v in variants[1:]:
        pairs = [(d[v], d[base]) for d in by.values() if v in d and base in d
                 and d[v].get("wall_time_s") and d[base].get("wall_time_s")]
        out[v] = dict(
            pairs=len(pairs),
            median_wall_ratio=(float(statistics.median(a["wall_time_s"] / b["wall_time_s"]
                                                       for a, b in pairs)) if pairs else None),
            median_linear_ratio=(float(statistics.median(
                a["linear_solve_s"] / b["linear_solve_s"] for a, b in pairs)) if pairs else None),
            same_iterations=all(a["newton_iterations"] == b["newton_iterations"]
                                for a, b in pairs),
            max_rel_deflection_difference=max(
                (abs(a["deflection"] - b["deflection"]) / max(abs(b["deflection"]), 1e-300)
                 for a, b in pairs), default=None),
            both_converged=sum(a.get("converged") and b.get("converged") for a, b in pairs),
            same_branch=sum(a.get("branch") == b.get("branch") for a, b in pairs
                            if a.get("converged") and b.get("converged")),
            different_branch=[dict(parameters=a["parameters"], path=a["path"],
                                   branches={v: a.get("branch"), base: b.get("branch")},
                                   deflections={v: a.get("deflection"),
                                                base: b.get("deflection")})
                              for a, b in pairs if a.get("converged") and b.get("converged")
                              and a.get("branch") != b.get("branch")],
            max_rel_polished_deflection_difference=max(
                (abs(a["deflection_polished"] - b["deflection_polished"])
                 / max(abs(b["deflection_polished"]), 1e-300) for a, b in pairs
                 if a.get("deflection_polished") is not None
                 and b.get("deflection_polished") is not None), default=None))
    return {"baseline": base, **out}


def table(rows, variants):
    wv = max(8, *(len(v) for v in variants))
    head = (f"{'group':9s} {'L/a':>6s} {'b/a':>6s} {'a/R':>6s} {'path':15s} "
            + (f"{'variant':{wv}s} " if len(variants) > 1 else "")
            + f"{'dofs':>6s} {'d/a':>9s} {'branch':>9s} {'stable':>6s} {'newton':>6s} "
            f"{'fact':>5s} {'cfact':>5s} {'backsub':>7s} {'wall s':>7s} {'lin %':>5s} {'peak GB':>7s}  status")
    lines = [head, "-" * len(head)]
    for r in rows:
        p = r["parameters"]
        branch = {"curvature-dominated": "curvature", "gravity-dominated": "gravity"}.get(
            r.get("branch"), r.get("branch"))
        share = r.get("linear_share")
        lines.append(
            f"{r['group']:9s} {p['length']:6.3f} {p['tip_width']:6.3f} {p['curvature']:6.3f} "
            f"{r['path']:15s} " + (f"{r['variant']:{wv}s} " if len(variants) > 1 else "")
            + f"{fmt(r.get('dofs'), '6d'):>6s} {fmt(r.get('deflection'), '9.5f'):>9s} "
            f"{fmt(branch, 's'):>9s} {fmt(r.get('stable'), '', 'unknown'):>6s} "
            f"{fmt(r.get('newton_iterations'), '6d'):>6s} {fmt(r.get('factorizations'), '5d'):>5s} "
            f"{fmt(r.get('coarse_factorizations'), '5d'):>5s} "
            f"{fmt(r.get('back_substitutions'), '7d'):>7s} {fmt(r.get('wall_time_s'), '7.1f'):>7s} "
            f"{fmt(None if share is None else 100 * share, '5.1f'):>5s} "
            f"{fmt(r.get('peak_rss_gb'), '7.3f'):>7s}  {r.get('status')}"
            + ("" if r.get("status") == "converged" else f" {r.get('message') or r.get('error')}")
            + (f" [fell back: {r['coarse_fallback']}]" if r.get("coarse_fallback") else ""))
    return lines


def _summary_lines(name, s):
    share = None if s["median_linear_share"] is None else 100 * s["median_linear_share"]
    return [f"{name}: {s['n']} solves ({s['n_failed']} not converged, {s['n_stable_unknown']} "
            f"converged with stability unknown); factorisations on the mesh hmax (fine) median "
            f"{fmt(s['median_factorizations'], 'g')}, max {fmt(s['max_factorizations'], 'g')}; "
            f"coarse median {fmt(s['median_coarse_factorizations'], 'g')}, max "
            f"{fmt(s['max_coarse_factorizations'], 'g')}; fine + coarse median "
            f"{fmt(s['median_total_factorizations'], 'g')}, max "
            f"{fmt(s['max_total_factorizations'], 'g')}; fell back to the fine path "
            f"{s['n_coarse_fallback']}; fine + coarse in fine factorisations (by the "
            f"factorisation times measured in each solve) median "
            f"{fmt(s.get('median_equivalent_factorizations'), '.1f')}, max "
            f"{fmt(s.get('max_equivalent_factorizations'), '.1f')}; coarse folds located on the "
            f"fine mesh {s.get('n_coarse_folds', 0)}; wall median {fmt(s['median_wall_s'], '.1f')} "
            f"s, max {fmt(s['max_wall_s'], '.1f')} s; back-substitutions median "
            f"{fmt(s['median_back_substitutions'], 'g')}; Newton "
            f"median {fmt(s['median_newton_iterations'], 'g')}, max "
            f"{fmt(s['max_newton_iterations'], 'g')}; linear-solver share median "
            f"{fmt(share, '.0f')}"
            f"%; peak memory max {fmt(s['max_peak_rss_gb'], '.3f')} GB; factorisations with "
            f"perturbed pivots {s['perturbed_factorizations']}"]


def _parse_variant(text):
    name, sep, js = text.partition("=")
    if not sep or not name:
        raise argparse.ArgumentTypeError(f"--variant must be NAME=JSON, got {text!r}")
    try:
        opts = json.loads(js)
    except json.JSONDecodeError as err:
        raise argparse.ArgumentTypeError(f"--variant {name}: bad JSON ({err})") from None
    if not isinstance(opts, dict):
        raise argparse.ArgumentTypeError(f"--variant {name}: JSON must be an object")
    return name, opts


#: Keys of a ``--variant`` passed to ``solve`` (the others go to the linear solver).
SOLVE_KEYS = ("start", "coarse_hmax")


def main(argv=None):
    if argv is None:
        argv = sys.argv[1:]
    if argv[:1] == ["compare"]:
        return compare_main(argv[1:])
    ap = parser(__doc__)
    ap.add_argument("--hmax", type=float, default=0.03, help="mesh size (default 0.03)")
    ap.add_argument("--n", type=int, default=12, help="random sheets (default 12, at least 12 "
                    "for the issue's sample)")
    ap.add_argument("--seed", type=int, default=16, help="seed of the sample (default 16)")
    ap.add_argument("--paths", default=",".join(PATHS), help="load paths (default both)")
    ap.add_argument("--no-cases", action="store_true", help="skip the four solve_speed cases")
    ap.add_argument("--cases-only", action="store_true", help="only the solve_speed cases")
    ap.add_argument("--sheet", action="append", default=None, metavar="L,B,K",
                    help="only this sheet (L/a, b/a, a/R; repeatable; group 'sheet'), "
                         "e.g. to re-run a few rows of the sample")
    ap.add_argument("--case", choices=[c for c, _ in CASES], action="append",
                    help="only these solve_speed cases (repeatable)")
    ap.add_argument("--variant", type=_parse_variant, action="append",
                    help="NAME=JSON linear-solver options; several: run alternately")
    ap.add_argument("--start", choices=("path", "coarse"), default=None,
                    help="solve's start for every solve (default: solve's own)")
    ap.add_argument("--coarse-hmax", type=float, default=None,
                    help="solve's coarse_hmax for every solve (default: solve's own)")
    ap.add_argument("--polish", action="store_true",
                    help="also record d after a tight Newton solve from the end state")
    ap.add_argument("--threads", type=int, default=None,
                    help="MKL/OpenMP/OpenBLAS threads per solve (default: the libraries' own)")
    ap.add_argument("--timeout", type=float, default=None, help="seconds per solve")
    ap.add_argument("--json", default=None, help="write the rows and summary here")
    ap.add_argument("--resume", action="store_true",
                    help="keep the rows already in --json and run only the missing solves")
    ap.add_argument("--txt", default=None, help="write the printed table here")
    args = ap.parse_args(argv)
    if args.hmax <= 0:
        ap.error("--hmax must be positive")
    if args.n < 0:
        ap.error("--n must be >= 0")
    paths = [p for p in args.paths.split(",") if p]
    for p in paths:
        if p not in PATHS:
            ap.error(f"--paths: {p!r} is not one of {', '.join(PATHS)}")
    variants = args.variant or [("default", {})]
    names = [v for v, _ in variants]
    if len(set(names)) != len(names):
        ap.error("--variant names must differ")

    plan = []
    if args.sheet:
        for text in args.sheet:
            try:
                L, b, k = (float(x) for x in text.split(","))
            except ValueError:
                ap.error(f"--sheet must be L,B,K (three numbers), got {text!r}")
            plan.append(("sheet", dict(length=L, tip_width=b, curvature=k)))
    elif not args.cases_only:
        plan += [("sample", s) for s in sample_sheets(args.n, args.seed)]
    if not args.no_cases and not args.sheet:
        plan += [(c, s) for c, s in CASES if not args.case or c in args.case]
    plan = [(g, s, p) for g, s in plan for p in paths]
    if not plan:
        ap.error("nothing to run")

    warn_if_busy()
    info = machine_info()
    cmd = "python benchmarks/solve_sample.py " + " ".join(
        a if " " not in a and "{" not in a else repr(a) for a in (argv or sys.argv[1:]))
    rows = []
    if args.resume and args.json and os.path.exists(args.json):
        with open(args.json) as f:
            rows = json.load(f)["rows"]
    done = {(r["group"], json.dumps(r["parameters"], sort_keys=True), r["path"], r["variant"])
            for r in rows}
    t_start = time.perf_counter()

    def save():
        sample = [r for r in rows if r["group"] in ("sample", "sheet")]
        cases = [r for r in rows if r["group"] not in ("sample", "sheet")]
        doc = dict(benchmark="solve_sample", command=cmd, machine=info,
                   settings=dict(hmax=args.hmax, n=args.n, seed=args.seed, paths=paths,
                                 box=BOX, variants=dict(variants), threads=args.threads,
                                 start=args.start, coarse_hmax=args.coarse_hmax,
                                 polish=args.polish),
                   rows=rows)
        first = [r for r in sample if r["variant"] == names[0]]
        doc.update(summarise(first))
        doc["summary_cases"] = summarise([r for r in cases if r["variant"] == names[0]])
        doc["summary_all"] = summarise([r for r in rows if r["variant"] == names[0]])
        if len(names) > 1:
            doc["summary_by_variant"] = {v: summarise([r for r in rows if r["variant"] == v])
                                         for v in names}
            doc["variant_ratios"] = _ratios(rows, names)
        doc["elapsed_s"] = time.perf_counter() - t_start
        if args.json:
            atomic_write(args.json, dumps_json(doc))
        return doc

    try:
        for group, params, path in plan:
            for name, opts in variants:
                if (group, json.dumps(params, sort_keys=True), path, name) in done:
                    continue
                solve_options = {k: v for k, v in (("start", args.start),
                                                   ("coarse_hmax", args.coarse_hmax))
                                 if v is not None}
                solve_options.update({k: v for k, v in opts.items() if k in SOLVE_KEYS})
                spec = dict(parameters=params, path=path, hmax=args.hmax,
                            linear_options={k: v for k, v in opts.items()
                                            if k not in SOLVE_KEYS},
                            solve_options=solve_options, polish=args.polish)
                rec = run_one(spec, threads=args.threads, timeout=args.timeout)
                rec.pop("spec", None)
                rows.append(dict(group=group, parameters=params, path=path, variant=name,
                                 hmax=args.hmax, **rec))
                print(f"[{len(rows)}/{len(plan) * len(variants)}] {group} "
                      f"{params} {path} {name}: {rec.get('status')} "
                      f"fact={rec.get('factorizations')} wall={fmt(rec.get('wall_time_s'), '.1f')}",
                      file=sys.stderr)
                save()
    except KeyboardInterrupt:
        print("interrupted: the finished solves are in --json", file=sys.stderr)
        return 130
    doc = save()
    lines = [f"# {cmd}",
             f"# {info['date']}, {info['cpus']} cpus, load average at start "
             f"{', '.join(f'{x:.2f}' for x in info.get('load_average_at_start', []))}; "
             f"{len(rows)} solves in {doc['elapsed_s']:.0f} s; each solve in a fresh process",
             f"solves (start {args.start or 'solve default'}) at hmax = {args.hmax:g}: a seeded sample of {args.n} sheets "
             f"(seed {args.seed}; L/a in {BOX['length']}, b/a in {BOX['tip_width']}, a/R in "
             f"{BOX['curvature']}) on {' and '.join(paths)}, and the solve_speed cases"]
    lines += table(rows, names)
    lines += _summary_lines("random sample", {k: doc[k] for k in summarise([]).keys()})
    lines += _summary_lines("solve_speed cases", doc["summary_cases"])
    lines += _summary_lines("all", doc["summary_all"])
    if len(names) > 1:
        for v, s in doc["summary_by_variant"].items():
            lines += _summary_lines(f"variant {v} ({json.dumps(dict(variants)[v])})", s)
        for v, q in doc["variant_ratios"].items():
            if v == "baseline":
                continue
            lines.append(f"variant {v} / {names[0]} over {q['pairs']} paired solves: median "
                         f"wall ratio {fmt(q['median_wall_ratio'], '.3f')}, median linear-solver"
                         f" time ratio {fmt(q['median_linear_ratio'], '.3f')}, same Newton "
                         f"iterations: {q['same_iterations']}, largest relative difference in "
                         f"d: {fmt(q['max_rel_deflection_difference'], '.2e')} (after polishing: "
                         f"{fmt(q['max_rel_polished_deflection_difference'], '.2e')}); same "
                         f"branch in {q['same_branch']} of {q['both_converged']} pairs where "
                         f"both converged")
            for x in q["different_branch"]:
                lines.append(f"  different branch: {x}")
    text = "\n".join(lines) + "\n"
    print(text)
    if args.txt:
        atomic_write(args.txt, text)
    return 0


# -- compare: runs paired sheet by sheet --------------------------------------------------
COMPARE_DOC = """Two variants (or two runs) of solve_sample paired sheet by sheet; nothing is solved.

    python benchmarks/solve_sample.py compare RUN.json [RUN.json ...] [--base path]
        [--other coarse] [--txt out.txt] [--json out.json]
    python benchmarks/solve_sample.py compare OLD.json NEW.json --by-run [--txt ...]

Reads ``benchmarks/solve_sample.py`` outputs run with two variants, e.g.
``--variant path='{"start": "path"}' --variant coarse='{"start": "coarse"}'
--polish``, pairs the solves of one sheet and path, and reports per pair and
over all: the branch of each (same?), the relative difference in d as solved
and after the tight polish (``deflection_polished``: the same equilibrium
gives round-off), the fine-mesh factorisations of each and the coarse path's,
the walls, where each snapped (the load parameter of its last phase: how far
a fold moves between the meshes), and whether and why the coarse start fell
back to the fine path.  Nothing is solved here.

``--by-run``: exactly two runs of one variant each (e.g. the same command
before and after a change); the first run's solves are the base (named
``--base``, default ``old``), the second's the other (``--other``, default
``new``), whatever their variants.
"""


def pairs_of(docs, base, other, base_hmax=None, other_hmax=None):
    """``(base_row, other_row)`` per (sheet, path) over the runs ``docs``; with
    ``base_hmax``/``other_hmax`` the two come from those meshes (branches
    compared across meshes: d then differs by the discretisation error)."""
    by = {}
    across = base_hmax is not None or other_hmax is not None
    for doc in docs:
        for r in doc["rows"]:
            key = (json.dumps(r["parameters"], sort_keys=True), r["path"],
                   None if across else r["hmax"])
            for name, h in ((base, base_hmax), (other, other_hmax)):
                if r["variant"] == name and (h is None or r["hmax"] == h):
                    by.setdefault(key, {})[name] = r
    return [(d[base], d[other]) for d in by.values() if base in d and other in d]


def _rel(a, b):
    if a is None or b is None:
        return None
    return abs(a - b) / max(abs(b), 1e-300)


#: Two end states are the same equilibrium when their d agree to this after the
#: tight polish (round-off: 1e-14 seen), or, unpolished, to ``STATE_TOL_RAW``
#: (the stopping tolerance utol 1e-6 of each).
STATE_TOL_POLISHED = 1e-9
STATE_TOL_RAW = 1e-5


#: Across meshes (``--base-hmax``/``--other-hmax``) d differs by the
#: discretisation error (about 1% between hmax 0.06 and 0.03): the end states
#: are taken to be one branch within this relative difference (the branches of
#: one sheet differ by tens of per cent: 0.04 against 0.45 at L/a 1.36).
STATE_TOL_ACROSS = 0.05


def _same_state(rel_raw, rel_pol, across=False):
    if across:
        return rel_raw is not None and rel_raw <= STATE_TOL_ACROSS
    if rel_pol is not None:
        return rel_pol <= STATE_TOL_POLISHED
    return rel_raw is not None and rel_raw <= STATE_TOL_RAW


def compare_pairs(pairs, across=False):
    rows = []
    for b, o in pairs:
        both = bool(b.get("converged")) and bool(o.get("converged"))
        rel_raw = _rel(o.get("deflection"), b.get("deflection")) if both else None
        rel_pol = (_rel(o.get("deflection_polished"), b.get("deflection_polished"))
                   if both else None)
        rows.append(dict(
            same_state=both and _same_state(rel_raw, rel_pol, across),
            parameters=b["parameters"], path=b["path"], group=b["group"],
            both_converged=both, base_status=b.get("status"), other_status=o.get("status"),
            base_branch=b.get("branch"), other_branch=o.get("branch"),
            same_branch=both and b.get("branch") == o.get("branch"),
            base_d=b.get("deflection"), other_d=o.get("deflection"),
            rel_d=_rel(o.get("deflection"), b.get("deflection")) if both else None,
            rel_d_polished=_rel(o.get("deflection_polished"), b.get("deflection_polished"))
            if both else None,
            base_fact=b.get("factorizations"), other_fact=o.get("factorizations"),
            other_coarse_fact=o.get("coarse_factorizations"),
            base_wall=b.get("wall_time_s"), other_wall=o.get("wall_time_s"),
            base_snaps=b.get("snap_at"), other_snaps=o.get("snap_at"),
            fallback=o.get("coarse_fallback") or ""))
    return rows


def _median(v):
    v = [x for x in v if x is not None]
    return float(statistics.median(v)) if v else None


def compare_summary(rows):
    conv = [r for r in rows if r["both_converged"]]
    used = [r for r in conv if not r["fallback"]]
    return dict(
        pairs=len(rows), sheets=len({json.dumps(r["parameters"], sort_keys=True) for r in rows}),
        both_converged=len(conv), same_branch=sum(r["same_branch"] for r in conv),
        same_state=sum(r["same_state"] for r in conv),
        label_only=sum(r["same_state"] and not r["same_branch"] for r in conv),
        different_branch=[r for r in conv if not r["same_branch"]],
        coarse_used=len(used), fell_back=sum(bool(r["fallback"]) for r in rows),
        fallback_reasons=sorted({r["fallback"].split(" (")[0].split(":")[0] for r in rows
                                 if r["fallback"]}),
        max_rel_d_coarse_used=max((r["rel_d"] for r in used if r["rel_d"] is not None),
                                  default=None),
        max_rel_d_polished_coarse_used=max(
            (r["rel_d_polished"] for r in used if r["rel_d_polished"] is not None), default=None),
        pairs_polished=sum(r["rel_d_polished"] is not None for r in used),
        median_base_fact=_median([r["base_fact"] for r in rows]),
        max_base_fact=max((r["base_fact"] or 0 for r in rows), default=None),
        median_other_fact=_median([r["other_fact"] for r in rows]),
        max_other_fact=max((r["other_fact"] or 0 for r in rows), default=None),
        median_other_coarse_fact=_median([r["other_coarse_fact"] for r in rows]),
        median_base_wall=_median([r["base_wall"] for r in rows]),
        median_other_wall=_median([r["other_wall"] for r in rows]),
        median_wall_ratio=_median([r["other_wall"] / r["base_wall"] for r in rows
                                if r["other_wall"] and r["base_wall"]]))


def _snap(s):
    return ",".join(f"{p[0][0]}{p[1]:.3f}" for p in s) if s else "-"


def compare_lines(rows, s, base, other):
    head = (f"{'L/a':>6s} {'b/a':>6s} {'a/R':>6s} {'path':15s} {'d ' + base:>10s} "
            f"{'d ' + other:>10s} {'rel d':>8s} {'rel pol':>8s} {'branch':>9s} "
            f"{'f ' + base:>7s} {'f ' + other:>8s} {'coarse':>6s} {'snap ' + base:>12s} "
            f"{'snap ' + other:>13s}  fallback")
    out = [head, "-" * len(head)]
    for r in rows:
        p = r["parameters"]
        br = ("same " if r["same_branch"] else "DIFF ") + (r["base_branch"] or "?")[:4]
        if r["same_state"] and not r["same_branch"]:
            br = "label " + (r["base_branch"] or "?")[:3]
        elif not r["same_state"] and r["both_converged"]:
            br = "STATE " + (r["base_branch"] or "?")[:3]
        if not r["both_converged"]:
            br = f"{r['base_status']}/{r['other_status']}"
        out.append(
            f"{p['length']:6.3f} {p['tip_width']:6.3f} {p['curvature']:6.3f} {r['path']:15s} "
            f"{r['base_d'] if r['base_d'] is not None else float('nan'):10.5f} "
            f"{r['other_d'] if r['other_d'] is not None else float('nan'):10.5f} "
            f"{r['rel_d'] if r['rel_d'] is not None else float('nan'):8.1e} "
            f"{r['rel_d_polished'] if r['rel_d_polished'] is not None else float('nan'):8.1e} "
            f"{br:>9s} {r['base_fact'] or 0:7d} {r['other_fact'] or 0:8d} "
            f"{r['other_coarse_fact'] or 0:6d} {_snap(r['base_snaps']):>12s} "
            f"{_snap(r['other_snaps']):>13s}  {r['fallback']}")
    out.append(
        f"{s['pairs']} pairs ({s['sheets']} sheets), both converged {s['both_converged']}; "
        f"same branch label {s['same_branch']} of {s['both_converged']}, same end state (d "
        f"equal to {STATE_TOL_POLISHED:g} after polishing, else {STATE_TOL_RAW:g}; across "
        f"meshes to {STATE_TOL_ACROSS:g}) "
        f"{s['same_state']} ({s['label_only']} with the same state under the other label: "
        f"'label' below); the coarse state used in "
        f"{s['coarse_used']}, fell back to the fine path in {s['fell_back']} "
        f"({'; '.join(s['fallback_reasons']) or '-'})")
    out.append(
        f"where the coarse state was used: largest relative difference in d "
        f"{s['max_rel_d_coarse_used']:.2e} as solved (tolerance utol 1e-6 of each), "
        f"{s['max_rel_d_polished_coarse_used'] if s['max_rel_d_polished_coarse_used'] is not None else float('nan'):.2e}"
        f" after a tight Newton solve of both end states ({s['pairs_polished']} pairs)")
    out.append(
        f"fine-mesh factorisations: {base} median {s['median_base_fact']:g}, max "
        f"{s['max_base_fact']}; {other} median {s['median_other_fact']:g}, max "
        f"{s['max_other_fact']} (plus its coarse path: median "
        f"{s['median_other_coarse_fact']:g}); wall median {base} {s['median_base_wall']:.1f} s, "
        f"{other} {s['median_other_wall']:.1f} s (median ratio {s['median_wall_ratio']:.2f})")
    for r in s["different_branch"]:
        what = "same state, other label" if r["same_state"] else "DIFFERENT STATE"
        out.append(f"  {what}: {r['parameters']} {r['path']}: {base} {r['base_branch']} d "
                   f"{r['base_d']:.6f}, {other} {r['other_branch']} d {r['other_d']:.6f} "
                   f"(fallback: {r['fallback'] or 'none'})")
    diff = [r for r in rows if r["both_converged"] and not r["same_state"]]
    out.append(f"end states that differ: {len(diff)}")
    return out


def compare_main(argv=None):
    ap = parser(COMPARE_DOC, prog="solve_sample.py compare")
    ap.add_argument("runs", nargs="+", help="solve_sample.py --json outputs")
    ap.add_argument("--base", default=None, help="variant of reference (default path; "
                    "with --by-run the name of the first run, default old)")
    ap.add_argument("--other", default=None, help="variant compared (default coarse; "
                    "with --by-run the name of the second run, default new)")
    ap.add_argument("--by-run", action="store_true",
                    help="compare two runs: the first's solves against the second's")
    ap.add_argument("--base-hmax", type=float, default=None,
                    help="take the base variant at this hmax (pairs across meshes)")
    ap.add_argument("--other-hmax", type=float, default=None,
                    help="take the other variant at this hmax (pairs across meshes)")
    ap.add_argument("--txt", default=None)
    ap.add_argument("--json", default=None)
    args = ap.parse_args(argv)
    docs = []
    for f in args.runs:
        with open(f) as fh:
            docs.append(json.load(fh))
    if args.by_run:
        if len(docs) != 2:
            ap.error("--by-run compares exactly two runs")
        args.base, args.other = args.base or "old", args.other or "new"
        for doc, name in zip(docs, (args.base, args.other)):
            for r in doc["rows"]:
                r["variant"] = name
    args.base, args.other = args.base or "path", args.other or "coarse"
    across = args.base_hmax is not None or args.other_hmax is not None
    rows = compare_pairs(pairs_of(docs, args.base, args.other, args.base_hmax, args.other_hmax), across)
    if not rows:
        ap.error(f"no pairs of variants {args.base!r} and {args.other!r} in {args.runs}")
    s = compare_summary(rows)
    loads = [d["machine"].get("load_average_at_start") for d in docs]
    head = [f"# python benchmarks/solve_sample.py compare {' '.join(argv or sys.argv[1:])}",
            f"# from: {'; '.join(d['command'] for d in docs)}",
            f"# load average at the start of each run: {loads}",
            f"hmax {sorted({r['hmax'] for d in docs for r in d['rows']})}: variant "
            f"{args.other!r} against {args.base!r}, per sheet and path "
            "(snap: phase initial and the load parameter of the snap in it)"]
    text = "\n".join(head + compare_lines(rows, s, args.base, args.other)) + "\n"
    print(text)
    if args.txt:
        atomic_write(args.txt, text)
    if args.json:
        atomic_write(args.json, dumps_json(dict(rows=rows, summary=s)))
    return 0


if __name__ == "__main__":
    if len(sys.argv) == 4 and sys.argv[1] == "--child":
        _child(sys.argv[2], sys.argv[3])
    else:
        sys.exit(main())
