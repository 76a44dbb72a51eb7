"""Work-precision of the 3D solver: wall time against error (issue 3).

    python benchmarks/work_precision.py [--hmax 0.12,0.08,0.06,0.04,0.03]
        [--solvers pardiso,superlu] [--layers auto,scaled] [--symmetric both]
        [--quadrature 2] [--reference-json convergence.json]
        [--json work_precision.json] [--png work_precision.png] [--quick] [--all]

Every combination of mesh size x linear-solver back-end x mesh/element choice
is solved once, in a fresh process (so that the peak memory is that solve's):

- ``--layers``: ``auto`` is the solver's default number of element layers
  through the thickness (2 for hmax >= 0.015), ``scaled`` refines the
  thickness with hmax like the convergence benchmark's family
  (``max(2, round(8 h / hmax))`` layers: 2, 3, 4, 6, 8 for hmax 0.12, 0.08,
  0.06, 0.04, 0.03 - the meshes of the convergence benchmark's family),
  an integer fixes it;
- ``--symmetric``: solve the mirror-symmetric half (``symmetric=True``) or the
  whole sheet, when ``solve`` has that option;
- ``--quadrature``: quadrature orders.

The error is relative to a reference value: the Richardson extrapolated value
of ``benchmarks/convergence.py``'s JSON (``--reference-json``, same case), else
this benchmark's own finest run (the table says which); solves already done
by the convergence benchmark (same mesh, back-end, symmetry and skfem_sheet
sources) are taken from that file instead of being repeated.  Printed: the table of
runs, the cheapest run reaching each target accuracy, and the sentence for the
README (which hmax gives 1% with the default settings and what it costs).
The PNG plots error against wall time, one line per choice, points labelled
with hmax.  superlu is skipped below hmax 0.05 unless ``--all`` (it takes many
minutes there); meshes above ``--max-dofs`` unknowns are skipped.
"""
import json
import sys

from tqdm.auto import tqdm

from harness import (
    add_run_options,
    available_backends,
    estimate_unknowns,
    fmt,
    interrupted,
    machine_info,
    open_store,
    parser,
    run_isolated,
    solve_supports,
    warn_if_busy,
)

DEFAULT_HMAX = "0.12,0.08,0.06,0.04,0.03"
QUICK_HMAX = "0.2,0.14"
TARGETS = (0.05, 0.02, 0.01, 0.005, 0.001)
SUPERLU_MIN_HMAX = 0.05
SCALED_ASPECT = 8.0   # hmax / layer thickness of the "scaled" layers (convergence family)


def scaled_layers(thickness, hmax):
    """Layers keeping hmax / (thickness / layers) about 8, at least 2."""
    return max(2, int(round(SCALED_ASPECT * thickness / hmax)))


def choice_label(rec_or_choice):
    c = rec_or_choice
    parts = [c["solver"], f"layers {c['layers_mode']}"]
    if c.get("symmetric") is not None:
        parts.append("half" if c["symmetric"] else "full")
    if c.get("quadrature_order") is not None:
        parts.append(f"q{c['quadrature_order']}")
    return ", ".join(parts)


def read_reference(path, case):
    with open(path) as f:
        doc = json.load(f)
    ref = doc.get("extrapolated")
    if ref is None:
        raise SystemExit(f"{path} has no extrapolated value (see its warnings: "
                         f"{doc.get('warnings')})")
    other = doc.get("case", {})
    for k in ("length", "tip_width", "curvature", "path"):
        if k in other and other[k] != case[k]:
            raise SystemExit(f"{path} is for {k} = {other[k]!r}, this run for {case[k]!r}")
    return float(ref), doc.get("runs", [])


def same_solve(spec, rec, code):
    """Whether a converged run of another benchmark is this solve (same sources too,
    unless ``code`` is None)."""
    s = rec.get("spec", {})
    return (rec.get("status") == "converged" and (code is None or rec.get("code") == code)
            and s.get("sheet") == spec["sheet"] and s.get("path") == spec["path"]
            and s.get("hmax") == spec["hmax"] and rec.get("layers") == spec["layers"]
            and rec.get("solver") == spec["solver"]
            and s.get("quadrature_order") == spec.get("quadrature_order")
            and rec.get("symmetric") == spec.get("symmetric"))


def plot(png, runs, ref, ref_label, case_label):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 5))
    groups = {}
    for r in runs:
        groups.setdefault(choice_label(r["choice"]), []).append(r)
    markers = "os^vD<>ph*"
    for i, (label, rs) in enumerate(sorted(groups.items())):
        rs = sorted(rs, key=lambda r: -r["spec"]["hmax"])
        pts = [(r["wall_time_s"], abs(r["error"])) for r in rs if r["error"]]
        if not pts:
            continue
        ax.loglog(*zip(*pts), marker=markers[i % len(markers)], label=label)
        for r in rs:
            if r["error"]:
                ax.annotate(f"{r['spec']['hmax']:g}", (r["wall_time_s"], abs(r["error"])),
                            textcoords="offset points", xytext=(3, 3), fontsize=6)
    ax.axhline(0.01, color="r", lw=0.8, ls=":", label="1%")
    ax.set_xlabel("wall time of the solve [s]")
    ax.set_ylabel("|d - d_ref| / |d_ref|")
    ax.set_title(f"{case_label}\nreference: {ref_label} d = {ref:.6f}", fontsize=9)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(png, dpi=130)
    plt.close(fig)


def main(argv=None):
    ap = parser(__doc__)
    ap.add_argument("--length", type=float, default=1.8, help="L/a (default 1.8)")
    ap.add_argument("--tip-width", type=float, default=1.0, help="b/a (default 1)")
    ap.add_argument("--curvature", type=float, default=5.0, help="a/R (default 5)")
    ap.add_argument("--path", default="curvature-first",
                    choices=("curvature-first", "gravity-first"))
    ap.add_argument("--hmax", default=None, help=f"mesh sizes (default {DEFAULT_HMAX})")
    ap.add_argument("--solvers", default=None,
                    help="back-ends (default: all available, " + ",".join(available_backends())
                    + ")")
    ap.add_argument("--layers", default="auto,scaled",
                    help="layer choices: auto, scaled, or integers (default auto,scaled)")
    ap.add_argument("--symmetric", default="both", choices=("both", "true", "false"),
                    help="half / whole sheet, if solve supports symmetric= (default both)")
    ap.add_argument("--quadrature", default=None,
                    help="quadrature orders, e.g. 2,3 (default: the solver's)")
    ap.add_argument("--reference-json", default=None,
                    help="convergence.py's JSON: its extrapolated value is the reference")
    ap.add_argument("--max-dofs", type=int, default=300_000,
                    help="skip meshes estimated above this many unknowns (default 300k)")
    ap.add_argument("--all", action="store_true",
                    help=f"also run superlu below hmax {SUPERLU_MIN_HMAX:g}")
    ap.add_argument("--quick", action="store_true",
                    help=f"coarse validation run: hmax {QUICK_HMAX}, layers auto")
    add_run_options(ap, "work_precision")
    ap.add_argument("--dry-run", action="store_true",
                    help="list the solves and their estimated sizes, run nothing")
    args = ap.parse_args(argv)

    hmaxs = sorted((float(x) for x in (args.hmax or (QUICK_HMAX if args.quick
                                                       else DEFAULT_HMAX)).split(",")),
                   reverse=True)
    have = available_backends()
    solvers = args.solvers.split(",") if args.solvers else have
    for s in solvers:
        if s not in have:
            ap.error(f"--solvers: {s!r} is not available here (available: {', '.join(have)})")
    layer_modes = ["auto"] if (args.quick and args.layers == "auto,scaled") else \
        [x.strip() for x in args.layers.split(",")]
    for m in layer_modes:
        if m not in ("auto", "scaled") and not m.isdigit():
            ap.error(f"--layers: {m!r} is not auto, scaled or an integer")
    if solve_supports("symmetric"):
        sym_modes = {"both": [True, False], "true": [True], "false": [False]}[args.symmetric]
    else:
        sym_modes = [None]
        if args.symmetric != "both":
            print("note: this skfem_sheet's solve has no symmetric= option; ignored",
                  file=sys.stderr)
    quads = [int(q) for q in args.quadrature.split(",")] if args.quadrature else [None]

    sheet = dict(length=args.length, tip_width=args.tip_width, curvature=args.curvature)
    case = dict(sheet, path=args.path)
    case_label = (f"L/a={args.length:g}, b/a={args.tip_width:g}, a/R={args.curvature:g}, "
                  f"{args.path}")
    thickness = 0.03

    plan, skipped = [], []
    for hmax in hmaxs:
        for solver in solvers:
            for lm in layer_modes:
                layers = (None if lm == "auto" else scaled_layers(thickness, hmax)
                          if lm == "scaled" else int(lm))
                for sym in sym_modes:
                    for q in quads:
                        choice = dict(solver=solver, layers_mode=lm, symmetric=sym,
                                      quadrature_order=q)
                        spec = dict(sheet=sheet, path=args.path, hmax=hmax, layers=layers,
                                    solver=solver)
                        if sym is not None:
                            spec["symmetric"] = sym
                        if q is not None:
                            spec["quadrature_order"] = q
                        label = f"hmax {hmax:g}, {choice_label(choice)}"
                        if solver == "superlu" and hmax < SUPERLU_MIN_HMAX and not args.all:
                            skipped.append(f"{label}: superlu below hmax "
                                           f"{SUPERLU_MIN_HMAX:g} takes many minutes (--all)")
                            continue
                        try:
                            n = estimate_unknowns(sheet, hmax, layers, sym)
                        except ValueError as err:   # skfem_sheet's ParameterError
                            ap.error(str(err))
                        if n is not None and n > args.max_dofs:
                            skipped.append(f"{label}: about {n:,} unknowns > --max-dofs")
                            continue
                        plan.append((choice, spec))
                        if args.dry_run:
                            print(f"{label}: about {fmt(n, ',d', '?')} unknowns")
    if args.dry_run:
        for s in skipped:
            print(f"skipped: {s}")
        return 0
    if not plan:
        ap.error("nothing to run")

    ref = ref_label = None
    foreign = []
    if args.reference_json:
        ref, foreign = read_reference(args.reference_json, case)
        ref_label = f"extrapolated value of {args.reference_json}"

    store = open_store(args, "work_precision")
    store.save(case=case, machine=machine_info())
    todo = [(c, s) for c, s in plan if store.get(s) is None]
    if todo:
        warn_if_busy()
    runs = []
    bar = tqdm(total=len(plan), desc="work-precision", unit="solve", file=sys.stderr)
    try:
        for choice, spec in plan:
            rec = store.get(spec)
            if rec is None and not args.force and spec["layers"] is not None:
                # the same solve done by convergence.py (its explicit-layer family)
                same = [r for r in foreign if same_solve(
                    spec, r, None if args.reuse_stale else store.code)]
                if same:
                    rec = dict(same[-1], spec=spec, choice=choice,
                               reused_from=args.reference_json)
                    store.add(rec)
            if rec is None:
                bar.set_postfix(hmax=spec["hmax"], solver=spec["solver"])
                rec = run_isolated(spec, timeout=args.timeout, threads=args.threads,
                                   verbose=args.verbose)
                rec["choice"] = choice
                store.add(rec)
            runs.append(rec)
            bar.update()
    except KeyboardInterrupt:
        return interrupted(args)
    finally:
        bar.close()

    good = [r for r in runs if r["status"] == "converged"]
    ref_run = None
    if ref is None:
        if not good:
            print("no run converged: no reference, no errors")
            return 1
        ref_run = min(good, key=lambda r: (r["spec"]["hmax"], -r["layers"], -r["dofs"]))
        ref = ref_run["deflection"]
        ref_label = (f"own finest run (hmax {ref_run['spec']['hmax']:g}, {ref_run['layers']} "
                     f"layers, {choice_label(ref_run['choice'])}); pass --reference-json "
                     "for the extrapolated value")
    def mesh_of(r):
        return (r["spec"]["hmax"], r.get("layers"), r["choice"]["quadrature_order"])

    for r in runs:
        r["error"] = (r["deflection"] / ref - 1) if r["status"] == "converged" else None
        r["on_reference_mesh"] = ref_run is not None and r["status"] == "converged" \
            and mesh_of(r) == mesh_of(ref_run)
        if r["on_reference_mesh"]:
            r["error"] = None   # its own discretisation: no error measured
    # invariant: back-ends and half/whole sheet solve the same discrete problem
    by_mesh = {}
    for r in good:
        by_mesh.setdefault(mesh_of(r), []).append(r["deflection"])
    spread = max((abs(max(ds) - min(ds)) / abs(ref) for ds in by_mesh.values() if len(ds) > 1),
                 default=None)

    print(f"work-precision: {case_label}")
    print(f"reference d = {ref:.6f}: {ref_label}")
    head = (f"{'solver':8s} {'layers':>6s} {'sym':4s} {'q':>2s} {'hmax':>7s} {'dofs':>8s} "
            f"{'d/a':>10s} {'error %':>8s} {'newton':>6s} {'wall s':>7s} {'linear s':>8s} "
            f"{'peak GB':>7s}  status")
    print(head)
    print("-" * len(head))
    for r in sorted(runs, key=lambda r: (choice_label(r["choice"]), -r["spec"]["hmax"])):
        c = r["choice"]
        sym = "-" if c["symmetric"] is None else ("half" if c["symmetric"] else "full")
        tag = "" if r["status"] == "converged" else \
            f"{r['status']}: {r.get('message') or r.get('error', '')}"
        if r is ref_run:
            tag = "(reference)"
        elif r.get("on_reference_mesh"):
            tag = "(reference mesh: no error)"
        if r.get("reused_from"):
            tag = (tag + f" (solve from {r['reused_from']})").strip()
        print(f"{c['solver']:8s} {fmt(r.get('layers', r['spec']['layers']), '6d'):>6s} "
              f"{sym:4s} {fmt(c['quadrature_order'], '2d'):>2s} {r['spec']['hmax']:7.4f} "
              f"{fmt(r.get('dofs'), '8d'):>8s} {fmt(r.get('deflection'), '10.6f'):>10s} "
              f"{fmt(None if r['error'] is None else 100 * r['error'], '+8.3f'):>8s} "
              f"{fmt(r.get('newton_iterations'), '6d'):>6s} "
              f"{fmt(r.get('wall_time_s'), '7.1f'):>7s} {fmt(r.get('linear_solve_s'), '8.1f'):>8s} "
              f"{fmt(r.get('peak_rss_gb'), '7.2f'):>7s}  {tag}")
    for s in skipped:
        print(f"skipped: {s}")
    if spread is not None:
        print(f"largest relative spread of d between choices on the same mesh (back-ends, "
              f"half/whole): {spread:.1e}")

    print("\ncheapest run per target accuracy:")
    best = {}
    for tol in TARGETS:
        ok = [r for r in good if r["error"] is not None and abs(r["error"]) <= tol]
        if not ok:
            print(f"  {100 * tol:5.1f}%: none of the runs")
            best[str(tol)] = None
            continue
        r = min(ok, key=lambda r: r["wall_time_s"])
        best[str(tol)] = dict(hmax=r["spec"]["hmax"], layers=r["layers"], choice=r["choice"],
                              wall_time_s=r["wall_time_s"], peak_rss_gb=r["peak_rss_gb"],
                              error=r["error"], dofs=r["dofs"])
        print(f"  {100 * tol:5.1f}%: hmax {r['spec']['hmax']:g}, {r['layers']} layers, "
              f"{choice_label(r['choice'])}: {r['wall_time_s']:.1f} s, "
              f"{r['peak_rss_gb']:.2f} GB, {r['dofs']:,} unknowns "
              f"(error {100 * r['error']:+.2f}%)")

    # the README sentence: default settings (best back-end, default layers and symmetry)
    default = [r for r in good if r["choice"]["solver"] == have[0]
               and r["choice"]["layers_mode"] == "auto"
               and r["choice"]["symmetric"] in (None, True)
               and r["choice"]["quadrature_order"] is None]
    default.sort(key=lambda r: -r["spec"]["hmax"])
    sentence = None
    default = [r for r in default if r["error"] is not None]
    for k, r in enumerate(default):
        if all(abs(x["error"]) <= 0.01 for x in default[k:]):
            sentence = (f"With the default settings ({have[0]}, {r['layers']} layers"
                        + (", symmetric half" if r["choice"]["symmetric"] else "")
                        + f") hmax = {r['spec']['hmax']:g} is within 1% of the reference "
                        f"({100 * r['error']:+.2f}%, reference: {ref_label.split(';')[0]}); "
                        f"it takes {r['wall_time_s']:.0f} s and {r['peak_rss_gb']:.1f} GB "
                        f"for {r['dofs']:,} unknowns on this machine.")
            break
    if sentence is None and default:
        sentence = (f"With the default settings ({have[0]}) no hmax down to "
                    f"{default[-1]['spec']['hmax']:g} stays within 1% of the reference.")
    if sentence:
        print("\nREADME: " + sentence)

    store.save(case=case, reference=dict(value=ref, source=ref_label),
               cheapest=best, readme_sentence=sentence, skipped=skipped,
               same_mesh_spread=spread)
    if args.json:
        print(f"wrote {args.json}")
    if args.png and good:
        plot(args.png, good, ref, ref_label.split(";")[0], case_label)
        print(f"wrote {args.png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
