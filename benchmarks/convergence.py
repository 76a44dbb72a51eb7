"""Mesh convergence of the tip deflection (issue 3; the paper's supplement Fig. S1).

    python benchmarks/convergence.py [--family 0.12:2,0.08:3,0.06:4,0.04:6,0.03:8]
        [--check-hmax 0.03] [--solver auto] [--json convergence.json]
        [--png convergence.png] [--quick] [--force]

Case (selectable): rectangle, L/a = 1.8, a/R = 5, curvature-first.  The
family of meshes is refined in all three directions by the same factor: the
default keeps hmax / (layer thickness) = 8, so the meshes are geometrically
similar (hmax = 0.24 h / layers ... in units of a: hmax 0.12, 0.08, 0.06,
0.04, 0.03 with 2, 3, 4, 6, 8 layers; ratios 1.5 and 1.33 alternate, which the
Richardson formula for varying ratios handles).  The finest mesh is about 250k
unknowns with the default mirror-symmetric half (twice that for the whole
sheet).  ``--family 0.12:2,0.06:4,0.03:8`` is a constant-ratio (r = 2)
alternative.  Reported:

- d/a per mesh, unknowns, wall time, Newton iterations, peak memory;
- the Richardson extrapolated value from the last three meshes and the
  observed order, the log-log least-squares slope of |d - d_inf| against hmax
  over the last three meshes (= the Richardson order) and over all of them;
- the error of every mesh against the extrapolated value, and of the default
  setting (``--check-hmax``, default layers) - the paper's claim is that
  hmax = 0.03 is within 1% and that the order is about 2.

Each solve runs in a fresh process (peak memory per solve).  The JSON file is
rewritten after every solve; a rerun skips finished solves (``--force`` redoes
them).  A PNG plot shows d against hmax and the log-log error with the fitted
slope.
"""
import argparse
import math
import sys

from tqdm.auto import tqdm

from _common import (add_run_options, analyse_sequence, estimate_unknowns, fmt,
                     interrupted, machine_info, open_store, parse_family, run_isolated,
                     warn_if_busy)

DEFAULT_FAMILY = "0.12:2,0.08:3,0.06:4,0.04:6,0.03:8"
QUICK_FAMILY = "0.2:2,0.14:2,0.1:2"
TARGET_ORDER = 1.8
TARGET_ERROR = 0.01


def plot(png, family_runs, check_run, analysis, case_label):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    h = np.array([r["spec"]["hmax"] for r in family_runs])
    d = np.array([r["deflection"] for r in family_runs])
    d_inf = analysis["extrapolated"]
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 4))
    ax1.plot(h, d, "o-", label="refined in 3 directions")
    for r in family_runs:
        ax1.annotate(f"{r['layers']} layers", (r["spec"]["hmax"], r["deflection"]),
                     textcoords="offset points", xytext=(4, 4), fontsize=7)
    if check_run is not None:
        ax1.plot([check_run["spec"]["hmax"]], [check_run["deflection"]], "s",
                 label=f"default ({check_run['layers']} layers)")
    if d_inf is not None:
        ax1.axhline(d_inf, color="k", ls="--", lw=1, label=f"extrapolated {d_inf:.5f}")
        ax1.axhspan(d_inf * (1 - TARGET_ERROR), d_inf * (1 + TARGET_ERROR), color="0.9",
                    label="±1%")
    ax1.set_xlabel("hmax / a")
    ax1.set_ylabel("d / a")
    ax1.set_xlim(left=0)
    ax1.set_title(case_label, fontsize=9)
    ax1.legend(fontsize=7)
    if d_inf is not None:
        err = np.abs(d - d_inf) / abs(d_inf)
        ok = err > 0
        ax2.loglog(h[ok], err[ok], "o", label="|d - d_inf| / d_inf")
        p = analysis["observed_order"]
        hh = np.array([h.min() * 0.9, h.max() * 1.1])
        last = -1
        ax2.loglog(hh, err[last] * (hh / h[last]) ** p, "k--", lw=1,
                   label=f"slope {p:.2f} (last three)")
        if check_run is not None and check_run["deflection"] != d_inf:
            ax2.loglog([check_run["spec"]["hmax"]],
                       [abs(check_run["deflection"] / d_inf - 1)], "s", label="default")
        ax2.axhline(TARGET_ERROR, color="r", lw=0.8, ls=":", label="1%")
        ax2.set_xlabel("hmax / a")
        ax2.set_ylabel("relative error")
        ax2.legend(fontsize=7)
    else:
        ax2.text(0.5, 0.5, "no extrapolation\n(non-monotone or too few meshes)",
                 ha="center", va="center", transform=ax2.transAxes)
    fig.tight_layout()
    fig.savefig(png, dpi=130)
    plt.close(fig)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--length", type=float, default=1.8, help="L/a (default 1.8)")
    ap.add_argument("--tip-width", type=float, default=1.0, help="b/a (default 1)")
    ap.add_argument("--curvature", type=float, default=5.0, help="a/R (default 5)")
    ap.add_argument("--path", default="curvature-first",
                    choices=("curvature-first", "gravity-first"))
    ap.add_argument("--family", default=None,
                    help=f"meshes as hmax:layers,... coarse to fine (default {DEFAULT_FAMILY})")
    ap.add_argument("--check-hmax", type=float, default=None,
                    help="the default setting compared with the extrapolated value "
                         "(default 0.03, default layers; 'nan' to skip)")
    ap.add_argument("--solver", default="auto")
    ap.add_argument("--quadrature-order", type=int, default=None)
    ap.add_argument("--max-dofs", type=int, default=300_000,
                    help="refuse meshes estimated above this many unknowns (default 300k)")
    ap.add_argument("--quick", action="store_true",
                    help=f"coarse validation run: family {QUICK_FAMILY}, check hmax 0.14")
    add_run_options(ap, "convergence")
    ap.add_argument("--dry-run", action="store_true",
                    help="list the solves and their estimated sizes, run nothing")
    args = ap.parse_args(argv)

    family = parse_family(args.family or (QUICK_FAMILY if args.quick else DEFAULT_FAMILY))
    if len(family) < 3:
        ap.error("--family needs at least three meshes")
    if any(l is None for _, l in family):
        ap.error("--family: give the layers of every mesh (hmax:layers)")
    if any(a[0] <= b[0] for a, b in zip(family, family[1:])):
        ap.error("--family must go from coarse to fine (hmax decreasing)")
    check_hmax = args.check_hmax if args.check_hmax is not None else (0.14 if args.quick
                                                                     else 0.03)
    sheet = dict(length=args.length, tip_width=args.tip_width, curvature=args.curvature)
    case_label = (f"L/a={args.length:g}, b/a={args.tip_width:g}, a/R={args.curvature:g}, "
                  f"{args.path}")

    def spec(hmax, layers):
        s = dict(sheet=sheet, path=args.path, hmax=hmax, layers=layers, solver=args.solver)
        if args.quadrature_order is not None:
            s["quadrature_order"] = args.quadrature_order
        return s

    specs = [("family", spec(h, l)) for h, l in family]
    if not math.isnan(check_hmax):
        specs.append(("check", spec(check_hmax, None)))
    for role, s in specs:
        try:
            n = estimate_unknowns(sheet, s["hmax"], s["layers"])
        except ValueError as err:   # skfem_sheet's ParameterError: a bad mesh option
            ap.error(str(err))
        if n is not None and n > args.max_dofs:
            ap.error(f"hmax={s['hmax']:g} with {s['layers'] or 'default'} layers is about "
                     f"{n:,} unknowns, above --max-dofs {args.max_dofs:,}")
        if args.dry_run:
            print(f"{role:6s} hmax {s['hmax']:<7g} layers {s['layers'] or 'default':<7} "
                  f"about {fmt(n, ',d', '?')} unknowns")
    if args.dry_run:
        return 0

    store = open_store(args, "convergence")
    store.save(case=dict(sheet, path=args.path, solver=args.solver), machine=machine_info())
    todo = [(role, s) for role, s in specs if store.get(s) is None]
    if todo:
        warn_if_busy()
    runs = {}
    for role, s in specs:
        if store.get(s) is not None:
            runs[role, s["hmax"], s["layers"]] = store.get(s)
    bar = tqdm(todo, desc="convergence", unit="solve", file=sys.stderr)
    try:
        for role, s in bar:
            bar.set_postfix(hmax=s["hmax"], layers=s["layers"] or "default")
            rec = run_isolated(s, timeout=args.timeout, threads=args.threads,
                               verbose=args.verbose)
            rec["role"] = role
            store.add(rec)
            runs[role, s["hmax"], s["layers"]] = rec
    except KeyboardInterrupt:
        return interrupted(args)
    finally:
        bar.close()

    fam = [runs["family", h, l] for h, l in family]
    check = runs.get(("check", check_hmax, None))
    good = [r for r in fam if r["status"] == "converged"]
    bad = [r for r in fam if r["status"] != "converged"]
    analysis = analyse_sequence([r["spec"]["hmax"] for r in good],
                                [r["deflection"] for r in good])
    if bad:
        analysis["warnings"].insert(0, f"{len(bad)} mesh(es) of the family did not converge "
                                    "and are left out of the analysis")
    d_ref = analysis["extrapolated"] if analysis["extrapolated"] is not None else (
        good[-1]["deflection"] if good else None)

    print(f"convergence of the tip deflection: {case_label}, solver {args.solver}")
    head = (f"{'hmax':>7s} {'layers':>6s} {'dofs':>8s} {'d/a':>10s} {'error %':>8s} "
            f"{'newton':>6s} {'wall s':>7s} {'peak GB':>7s}  status")
    print(head)
    print("-" * len(head))
    rows = fam + ([check] if check is not None else [])
    for r in rows:
        d = r.get("deflection")
        err = (100 * (d / d_ref - 1)) if (d is not None and d_ref) else None
        tag = "" if r["status"] == "converged" else \
            f"{r['status']}: {r.get('message') or r.get('error', '')}"
        if r is check:
            tag = ("default setting " + tag).strip()
        print(f"{r['spec']['hmax']:7.4f} {fmt(r.get('layers', r['spec']['layers']), '6d'):>6s} "
              f"{fmt(r.get('dofs'), '8d'):>8s} {fmt(d, '10.6f'):>10s} {fmt(err, '+8.3f'):>8s} "
              f"{fmt(r.get('newton_iterations'), '6d'):>6s} "
              f"{fmt(r.get('wall_time_s'), '7.1f'):>7s} "
              f"{fmt(r.get('peak_rss_gb'), '7.2f'):>7s}  {tag}")
    print()
    a = analysis
    if a["extrapolated"] is not None:
        print(f"Richardson (last three meshes): d_inf = {a['extrapolated']:.6f}, "
              f"observed order {a['observed_order']:.2f} (log-log fit of |d - d_inf| over the "
              f"last three), {fmt(a['observed_order_all'], '.2f')} over all "
              f"{len(good)} meshes")
        if a["power_law"]:
            pl = a["power_law"]
            print(f"least-squares d_inf + C h^p through all {len(good)} meshes: "
                  f"d_inf = {pl['extrapolated']:.6f}, p = {pl['order']:.2f}, "
                  f"rms residual {pl['rms']:.1e}")
    else:
        print("no extrapolated value; errors above are relative to the finest converged mesh")
    for w in a["warnings"]:
        print(f"WARNING: {w}")

    targets = {}
    if a["observed_order"] is not None:
        targets["observed_order>=1.8"] = a["observed_order"] >= TARGET_ORDER
    check_error = None
    if check is not None and check["status"] == "converged" and a["extrapolated"] is not None:
        check_error = check["deflection"] / a["extrapolated"] - 1
        targets[f"hmax={check_hmax:g} within 1%"] = abs(check_error) <= TARGET_ERROR
    if targets:
        print("targets: " + ", ".join(f"{k}: {'PASS' if v else 'FAIL'}"
                                      for k, v in targets.items()))

    store.save(
        case=dict(sheet, path=args.path, solver=args.solver),
        hmax=[r["spec"]["hmax"] for r in good], layers=[r["layers"] for r in good],
        deflection=[r["deflection"] for r in good], dofs=[r["dofs"] for r in good],
        wall_time_s=[r["wall_time_s"] for r in good],
        observed_order=a["observed_order"], observed_order_all=a["observed_order_all"],
        extrapolated=a["extrapolated"], power_law=a["power_law"], errors=a["errors"],
        error_reference=a["error_reference"], warnings=a["warnings"],
        check=None if check is None else dict(
            hmax=check_hmax, layers=check.get("layers"), deflection=check.get("deflection"),
            dofs=check.get("dofs"), wall_time_s=check.get("wall_time_s"),
            status=check["status"], error=check_error),
        targets={k: bool(v) for k, v in targets.items()})
    if args.json:
        print(f"wrote {args.json}")
    if args.png and good:
        plot(args.png, good, check if check is not None and check["status"] == "converged"
             else None, a, case_label)
        print(f"wrote {args.png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
