"""Speed of a solve with solve's defaults (issue 3, item 6), per linear-solver back-end.

    python benchmarks/solve_speed.py [--hmax 0.03] [--solvers pardiso,superlu] [--all]
        [--repeat 1] [--threads N] [--json solve_speed.json] [--png solve_speed.png]
        [--quick]

Cases: the rectangle (b/a = 1) and the triangle (b/a = 0) at a/R = 2.5,
L/a = 1.3, each along both load paths (curvature-first: the aloft branch of
the bistable rectangle; gravity-first: the drooped one), at hmax = 0.03 with
the solver's default layers, symmetry and start (``start="coarse"`` since
issue 16: the load path on hmax 0.1, finished on hmax; before it, the whole
load path on hmax).  Each solve runs in a fresh process;
columns: d/a, branch, unknowns, Newton iterations, factorisations, wall time
(the ``Result``'s, meshing included), assembly and linear-solve time, the
share of the wall time spent outside the linear solver, peak resident memory
(VmHWM of the process) and PASS/FAIL against the targets of issue 3:

    converged, wall <= 60 s, <= 30 Newton iterations, <= 30% outside the
    linear solver, peak memory <= 3 GB (and, for the rectangle, the branch the
    path selects: curvature-first |d| < 0.1, gravity-first d > 0.5).

The targets apply to the best installed back-end; the summary line says
whether it meets them on every case.  superlu is skipped below hmax 0.05
unless ``--all`` (it takes many minutes there).  Timings are only meaningful
on an otherwise idle machine (a warning is printed if the load average says
otherwise).
"""
import argparse
import sys

from tqdm.auto import tqdm

from _common import (
    add_run_options,
    available_backends,
    fmt,
    interrupted,
    machine_info,
    open_store,
    run_isolated,
    warn_if_busy,
)

CASES = [
    ("rectangle", dict(length=1.3, tip_width=1.0, curvature=2.5), "curvature-first"),
    ("rectangle", dict(length=1.3, tip_width=1.0, curvature=2.5), "gravity-first"),
    ("triangle", dict(length=1.3, tip_width=0.0, curvature=2.5), "curvature-first"),
    ("triangle", dict(length=1.3, tip_width=0.0, curvature=2.5), "gravity-first"),
]
LIMITS = dict(wall_time_s=60.0, newton_iterations=30, outside_linear_share=0.30,
              peak_rss_gb=3.0)
SUPERLU_MIN_HMAX = 0.05


def verdict(rec, case):
    """List of the targets a run misses (empty: PASS)."""
    if rec["status"] != "converged":
        return [rec["status"]]
    miss = []
    if rec["wall_time_s"] > LIMITS["wall_time_s"]:
        miss.append(f"wall>{LIMITS['wall_time_s']:g}s")
    if rec["newton_iterations"] > LIMITS["newton_iterations"]:
        miss.append(f"newton>{LIMITS['newton_iterations']}")
    if rec["outside_linear_share"] > LIMITS["outside_linear_share"]:
        miss.append(f"outside-linear>{100 * LIMITS['outside_linear_share']:.0f}%")
    if rec["peak_rss_gb"] > LIMITS["peak_rss_gb"]:
        miss.append(f"memory>{LIMITS['peak_rss_gb']:g}GB")
    if case == "rectangle":
        path = rec["spec"]["path"]
        if path == "curvature-first" and not abs(rec["deflection"]) < 0.1:
            miss.append("branch: not aloft")
        if path == "gravity-first" and not rec["deflection"] > 0.5:
            miss.append("branch: not drooped")
    return miss


def plot(png, rows):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = [r for r in rows if r["status"] == "converged"]
    if not rows:
        return False
    labels = [f"{r['case'][:4]} {r['spec']['path'].split('-')[0][:4]}\n{r['spec']['solver']}"
              for r in rows]
    lin = [r["linear_solve_s"] for r in rows]
    asm = [r["assembly_s"] for r in rows]
    other = [max(r["wall_time_s"] - a - l, 0.0) for r, a, l in zip(rows, asm, lin)]
    x = range(len(rows))
    fig, ax = plt.subplots(figsize=(max(6, 1.1 * len(rows)), 4))
    ax.bar(x, lin, label="linear solve")
    ax.bar(x, asm, bottom=lin, label="assembly")
    ax.bar(x, other, bottom=[a + b for a, b in zip(lin, asm)], label="other")
    ax.axhline(LIMITS["wall_time_s"], color="r", ls=":", lw=1, label="60 s target")
    ax.set_xticks(list(x))
    ax.set_xticklabels(labels, fontsize=7)
    ax.set_ylabel("wall time [s]")
    ax.set_title(f"solves (solve's defaults), hmax = {rows[0]['spec']['hmax']:g}", fontsize=9)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(png, dpi=130)
    plt.close(fig)
    return True


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--hmax", type=float, default=None, help="mesh size (default 0.03)")
    ap.add_argument("--solvers", default=None,
                    help="back-ends (default: all available, " + ",".join(available_backends())
                    + ")")
    ap.add_argument("--all", action="store_true",
                    help=f"also run superlu below hmax {SUPERLU_MIN_HMAX:g}")
    ap.add_argument("--repeat", type=int, default=1,
                    help="solves per case and back-end; the fastest is reported (default 1)")
    ap.add_argument("--quick", action="store_true", help="coarse validation run: hmax 0.12")
    add_run_options(ap, "solve_speed")
    args = ap.parse_args(argv)
    hmax = args.hmax if args.hmax is not None else (0.12 if args.quick else 0.03)
    have = available_backends()
    solvers = args.solvers.split(",") if args.solvers else have
    for s in solvers:
        if s not in have:
            ap.error(f"--solvers: {s!r} is not available here (available: {', '.join(have)})")
    if args.repeat < 1:
        ap.error("--repeat must be at least 1")

    notes, plan = [], []
    for solver in solvers:
        if solver == "superlu" and hmax < SUPERLU_MIN_HMAX and not args.all:
            notes.append(f"superlu skipped: below hmax {SUPERLU_MIN_HMAX:g} it takes many "
                         "minutes per solve (--all runs it)")
            continue
        for case, sheet, path in CASES:
            for k in range(args.repeat):
                spec = dict(sheet=sheet, path=path, hmax=hmax, layers=None, solver=solver)
                if k:
                    spec["repeat"] = k
                plan.append((case, spec))
    if not plan:
        ap.error("nothing to run")

    store = open_store(args, "solve_speed")
    store.save(machine=machine_info(), limits=LIMITS)
    if any(store.get(s) is None for _, s in plan):
        warn_if_busy()
    bar = tqdm(total=len(plan), desc="solve speed", unit="solve", file=sys.stderr)
    recs = []
    try:
        for case, spec in plan:
            rec = store.get(spec)
            if rec is None:
                bar.set_postfix(case=case, path=spec["path"], solver=spec["solver"])
                rec = run_isolated(spec, timeout=args.timeout, threads=args.threads,
                                   verbose=args.verbose)
                rec["case"] = case
                store.add(rec)
            recs.append(rec)
            bar.update()
    except KeyboardInterrupt:
        return interrupted(args)
    finally:
        bar.close()

    # fastest of the repeats per (case, path, solver)
    rows = {}
    for rec in recs:
        k = (rec["case"], rec["spec"]["path"], rec["spec"]["solver"])
        old = rows.get(k)
        if old is None or (rec["status"] == "converged" and (
                old["status"] != "converged" or rec["wall_time_s"] < old["wall_time_s"])):
            rows[k] = rec
    rows = list(rows.values())

    print(f"solves (solve's defaults) at hmax = {hmax:g} (a/R = 2.5, L/a = 1.3); targets: wall <= "
          f"{LIMITS['wall_time_s']:g} s, <= {LIMITS['newton_iterations']} Newton iterations, "
          f"<= {100 * LIMITS['outside_linear_share']:.0f}% outside the linear solver, "
          f"<= {LIMITS['peak_rss_gb']:g} GB"
          + (f"; fastest of {args.repeat}" if args.repeat > 1 else ""))
    head = (f"{'case':9s} {'path':15s} {'solver':8s} {'dofs':>8s} {'d/a':>8s} {'branch':>9s} "
            f"{'newton':>6s} {'fact':>5s} {'wall s':>7s} {'asm s':>6s} {'linear s':>8s} "
            f"{'outside':>7s} {'peak GB':>7s}  verdict")
    print(head)
    print("-" * len(head))
    summary = []
    for r in rows:
        miss = verdict(r, r["case"])
        r["verdict"] = "PASS" if not miss else "FAIL"
        r["misses"] = miss
        branch = r.get("branch")
        branch = {"curvature-dominated": "curvature", "gravity-dominated": "gravity"}.get(
            branch, branch)
        share = r.get("outside_linear_share")
        print(f"{r['case']:9s} {r['spec']['path']:15s} {r['spec']['solver']:8s} "
              f"{fmt(r.get('dofs'), '8d'):>8s} {fmt(r.get('deflection'), '8.4f'):>8s} "
              f"{fmt(branch, 's'):>9s} {fmt(r.get('newton_iterations'), '6d'):>6s} "
              f"{fmt(r.get('factorizations'), '5d'):>5s} {fmt(r.get('wall_time_s'), '7.1f'):>7s} "
              f"{fmt(r.get('assembly_s'), '6.1f'):>6s} {fmt(r.get('linear_solve_s'), '8.1f'):>8s} "
              f"{fmt(None if share is None else 100 * share, '6.1f'):>6s}% "
              f"{fmt(r.get('peak_rss_gb'), '7.2f'):>7s}  {r['verdict']}"
              + (f" ({', '.join(miss)})" if miss else "")
              + ("" if r["status"] == "converged" else f" {r.get('message') or r.get('error')}"))
        summary.append(dict(case=r["case"], path=r["spec"]["path"], solver=r["spec"]["solver"],
                            verdict=r["verdict"], misses=miss))
    for n in notes:
        print(f"note: {n}")
    best = have[0]
    best_rows = [r for r in rows if r["spec"]["solver"] == best]
    overall = None
    if best_rows:
        overall = all(r["verdict"] == "PASS" for r in best_rows) and len(best_rows) == len(CASES)
        slowest = max((r for r in best_rows if r["status"] == "converged"),
                      key=lambda r: r["wall_time_s"], default=None)
        print(f"\nbest installed back-end ({best}): {'PASS' if overall else 'FAIL'} on "
              f"{sum(r['verdict'] == 'PASS' for r in best_rows)} of {len(CASES)} cases"
              + (f"; slowest {slowest['case']} {slowest['spec']['path']} "
                 f"{slowest['wall_time_s']:.1f} s, {slowest['newton_iterations']} Newton "
                 f"iterations, {100 * slowest['outside_linear_share']:.0f}% outside the "
                 f"linear solver, {slowest['peak_rss_gb']:.2f} GB" if slowest else ""))
        if hmax != 0.03:
            print(f"(the targets are for hmax = 0.03; this run used hmax = {hmax:g})")
    store.save(limits=LIMITS, hmax=hmax, table=summary,
               best_backend=best, best_backend_pass=overall, notes=notes)
    if args.json:
        print(f"wrote {args.json}")
    if args.png and plot(args.png, rows):
        print(f"wrote {args.png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
