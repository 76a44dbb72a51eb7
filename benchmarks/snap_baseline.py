"""The load-path regression set (issues 17 and 19): d, stability, Newton
iterations and factorisations of ~12 coarse solves, each in a fresh process
with reproducible arithmetic (one thread, ``MKL_CBWR=COMPATIBLE``).

Usage::

    python benchmarks/snap_baseline.py OUT.jsonl [CHECKOUT]  # run the set (on that checkout)
    python benchmarks/snap_baseline.py OUT.jsonl --options '{"newton": {"linearization": "mip"}}'
    python benchmarks/snap_baseline.py OUT.jsonl --options '{"solve": {"coarse_hmax": 0.2}}'
    python benchmarks/snap_baseline.py --compare A.jsonl B.jsonl

    python benchmarks/snap_baseline.py --trace '{"length": 3, "curvature": 2.5}' \\
        --path curvature-first --hmax 0.03 [--ds 0.01] [--txt out.txt]

``--compare`` prints both runs side by side, the relative change of d, the
totals of Newton iterations and factorisations, and how many cases are equal bit
for bit (exit status 1 if not all).

``--trace SHEET``: the independent check behind a snap, or its absence, that
does not use the load path's driver.  The first phase of ``--path`` (the
curvature ramp at no gravity, or the gravity ramp at a flat clamp from the
heavy elastica) is solved to full load, and the second phase is traced by
the engine's pseudo-arclength driver (steps ``ds`` to ``5 ds``) from its
start to past its full load, with the inertia of the Hessian factorised at
every point.  A turning point of the load is a sign change of the tangent's
load component, located by Newton on the fold system, with one eigenvalue
crossing zero there; a branch that is only steep has neither.  Printed: the
folds found, the negative-eigenvalue counts met, and the trace (load
fraction, d/a).  Used for the L 3 rectangle at a/R 2.5 curvature-first
(issue 26: whether its gravity ramp has a fold the load path should record
as a snap) at hmax 0.05 and 0.03
(``results/robustness/phase_trace_L3_aR2.5.txt``).
"""
import json
import os
import subprocess
import sys
import time

import numpy as np

from harness import parser

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

THIN = dict(thickness=0.02, modulus=400.0)
# (id, sheet, path, hmax, solve keywords)
CASES = [
    ("rect-L1-cf", dict(length=1.0, tip_width=1.0, curvature=2.5), "curvature-first", 0.1, {}),
    ("rect-L1-gf", dict(length=1.0, tip_width=1.0, curvature=2.5), "gravity-first", 0.1, {}),
    ("rect-L1.3-cf", dict(length=1.3, tip_width=1.0, curvature=2.5), "curvature-first", 0.1, {}),
    ("rect-L1.3-gf", dict(length=1.3, tip_width=1.0, curvature=2.5), "gravity-first", 0.1, {}),
    ("triangle-cf", dict(length=1.0, tip_width=0.0, curvature=2.5), "curvature-first", 0.1, {}),
    ("tapered-b0.8-gf", dict(length=1.2, tip_width=0.8, curvature=2.5), "gravity-first", 0.08, {}),
    ("issue17-gf", dict(length=1.299, tip_width=0.633, curvature=5.112, **THIN),
     "gravity-first", 0.08, {}),
    ("short-thin-popup-gf", dict(length=1.0, tip_width=0.8, curvature=5.5, **THIN),
     "gravity-first", 0.08, {}),
    ("rectangle-popup-gf", dict(length=1.3, tip_width=1.0, curvature=6.0), "gravity-first", 0.1, {}),
    ("long-thin-drop-cf", dict(length=1.63, tip_width=0.65, curvature=3.37, **THIN),
     "curvature-first", 0.1, {}),
    ("rect-L1-cf-full", dict(length=1.0, tip_width=1.0, curvature=2.5), "curvature-first", 0.1,
     dict(symmetric=False)),
    ("rect-L1.3-gf-superlu", dict(length=1.3, tip_width=1.0, curvature=2.5), "gravity-first", 0.1,
     dict(solver="superlu")),
]

CHILD = """
import json, os, sys, time
import skfem_sheet
from skfem_sheet import Sheet, solve
# the checkout asked for, not an installed copy (the child runs in it, and the
# working directory comes first on the import path, before an editable install's finder)
here = os.path.realpath(skfem_sheet.__file__)
if not here.startswith(os.path.join(os.path.realpath(sys.argv[2]), "")):
    sys.exit(f"skfem_sheet imported from {here}, not from the checkout {sys.argv[2]}")
from skfem_sheet.continuation import StepOptions
from skfem_sheet.newton import NewtonOptions
spec = json.loads(sys.argv[1])
opts = spec["options"]
kw = dict(spec["kw"])
if "newton" in opts:
    kw["newton_options"] = NewtonOptions(**opts["newton"])
if "step" in opts:
    kw["step_options"] = StepOptions(**opts["step"])
kw.update(opts.get("solve", {}))
t = time.perf_counter()
r = solve(Sheet(**spec["sheet"]), path=spec["path"], hmax=spec["hmax"], on_failure="return",
          **kw)
print(json.dumps(dict(d=r.deflection, converged=r.converged, stable=r.stable, branch=r.branch,
                      newton_iterations=r.newton_iterations, factorizations=r.factorizations,
                      snaps=[s.to_json() for s in r.snaps], wall_s=time.perf_counter() - t,
                      coarse_hmax=r.coarse_hmax, coarse_factorizations=r.coarse_factorizations,
                      coarse_newton_iterations=r.start_record.coarse_newton_iterations,
                      coarse_fallback=r.coarse_fallback)))
"""

ENV = dict(MKL_CBWR="COMPATIBLE", OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")


def run(out, root=ROOT, options=None):
    """Run every case in a fresh process; ``options`` (a dict with keys
    ``"newton"`` and/or ``"step"``) are passed to ``NewtonOptions`` /
    ``StepOptions`` of every solve."""
    env = dict(os.environ, PYTHONPATH=root, **ENV)
    with open(out, "w") as fh:
        for name, sheet, path, hmax, kw in CASES:
            spec = json.dumps(dict(sheet=sheet, path=path, hmax=hmax, kw=kw,
                                   options=options or {}))
            p = subprocess.run([sys.executable, "-c", CHILD, spec, root], cwd=root, env=env,
                               capture_output=True, text=True)
            if p.returncode:
                rec = dict(error=p.stderr[-500:])
            else:
                rec = json.loads(p.stdout.strip().splitlines()[-1])
            rec["case"] = name
            fh.write(json.dumps(rec) + "\n")
            fh.flush()
            print(name, rec.get("d"), rec.get("newton_iterations"), rec.get("factorizations"),
                  flush=True)


def compare(a, b):
    A = {r["case"]: r for r in map(json.loads, open(a))}
    B = {r["case"]: r for r in map(json.loads, open(b))}
    tot = [0, 0, 0, 0]
    print(f"{'case':22s} {'d before':>22s} {'d after':>22s} {'rel':>8s} stable  it  fac -> it  fac")
    for name in A:
        x, y = A[name], B.get(name, {})
        if "d" not in x or "d" not in y:
            print(name, "missing")
            continue
        rel = abs(y["d"] - x["d"]) / max(abs(x["d"]), 1e-300)
        print(f"{name:22s} {x['d']:22.15g} {y['d']:22.15g} {rel:8.1e} {x['stable']!s:>5}/"
              f"{y['stable']!s:<5} {x['newton_iterations']:3d} {x['factorizations']:4d} -> "
              f"{y['newton_iterations']:3d} {y['factorizations']:4d}")
        for i, k in enumerate(("newton_iterations", "factorizations")):
            tot[i] += x[k]
            tot[2 + i] += y[k]
    print(f"totals: Newton {tot[0]} -> {tot[2]}, factorisations {tot[1]} -> {tot[3]}")
    same = [name for name in A if name in B and "d" in A[name] and "d" in B[name]
            and A[name]["d"] == B[name]["d"] and A[name]["stable"] == B[name]["stable"]]
    print(f"bit for bit (d and stable): {len(same)} of {len(A)} cases")
    return 0 if len(same) == len(A) else 1


def trace_second_phase(sheet, path: str, hmax: float, ds: float = 0.01,
                       max_points: int = 400) -> dict:
    """The second phase of ``path`` traced through (see the module):
    ``{"dofs", "folds", "inertia", "completed", "reason", "points", "wall_time_s"}``
    with ``points`` the ``(load fraction, d/a, negative eigenvalues)`` of each
    point in arclength order."""
    # imported here: the regression set's children import the checkout under test themselves
    from skfem_sheet.analyses.observables import tip_deflection
    from skfem_sheet.continuation import elastica_state, load_phases, newton_tolerances
    from skfem_sheet.engine import arclength, ramp
    from skfem_sheet.engine.protocol import Counting
    from skfem_sheet.linalg import make_linear_solver
    from skfem_sheet.newton import NewtonOptions, Stats, newton
    from skfem_sheet.sheet_engine import LoadPhase, SheetLoadProblem
    from skfem_sheet.solve import build_problem

    t0 = time.perf_counter()
    problem = build_problem(sheet, hmax, None, 2, True, 0)
    solver = make_linear_solver()
    options = NewtonOptions()
    loads = SheetLoadProblem(problem, solver, Stats(), options)
    phases = load_phases(path, sheet.curvature)
    tol = newton_tolerances(options)
    first, start, end = phases[0]
    if first == "gravity":
        u = newton(problem, elastica_state(problem, 1.0), 1.0, solver, options,
                   Stats()).w[problem.free]
    else:
        b0 = ramp(Counting(LoadPhase(loads, start, end)), np.zeros(loads.n), [0.0], "lam", 1.0,
                  tol=newton_tolerances(options, 5e-3), end_tol=tol)
        if not b0.completed:
            raise RuntimeError(f"the first phase did not reach full load: {b0.reason}")
        u = b0.points[-1].u
    phase = LoadPhase(loads, *phases[1][1:])
    points = []

    def on_step(point, res):
        kappa, g = phase.loads(point.p)
        points.append((float(point.p[0]), tip_deflection(problem, loads.full(point.u, (kappa, g))),
                       point.negative_eigenvalues))

    branch = arclength(Counting(phase), u, np.array([0.0]), "lam", (-0.5, 1.2), ds=ds,
                       ds_max=5 * ds, tol=tol, max_points=max_points, check_inertia=True,
                       on_step=on_step)
    return {"dofs": int(problem.ndof), "folds": [float(f.value) for f in branch.folds],
            "inertia": sorted({-1 if k is None else int(k) for _, _, k in points}),
            "completed": bool(branch.completed), "reason": branch.reason, "points": points,
            "wall_time_s": time.perf_counter() - t0}


def trace_table(sheet, path, hmax, ds, out) -> str:
    """The trace of :func:`trace_second_phase` as text."""
    lam = [p[0] for p in out["points"]]
    monotone = bool(np.all(np.diff(lam) > 0))
    lines = [f"second phase of {path}: L/a {sheet.length:g}, b/a {sheet.tip_width:g}, "
             f"a/R {sheet.curvature:g}, h/a {sheet.thickness:g}, E/(rho g a) {sheet.modulus:g}, "
             f"hmax {hmax:g} ({out['dofs']} unknowns), ds {ds:g}",
             f"  {len(lam)} points, completed {out['completed']}{' (' + out['reason'] + ')' if out['reason'] else ''}, "
             f"load fraction monotone along the trace: {monotone}",
             f"  folds (turning points of the load): {out['folds'] or 'none'}",
             f"  negative eigenvalues met along the trace: {out['inertia']}",
             f"  wall {out['wall_time_s']:.1f} s",
             "",
             "   load fraction        d/a  negative eigenvalues"]
    lines += [f"  {q:14.6g} {d:10.6f}  {'?' if k is None else k}" for q, d, k in out["points"]]
    return "\n".join(lines)


def main(argv=None):
    ap = parser(__doc__)
    ap.add_argument("out", nargs="?", help="the JSON-lines file to write")
    ap.add_argument("root", nargs="?", default=ROOT,
                    help="the checkout whose skfem_sheet solves the cases (default: this one)")
    ap.add_argument("--options", type=json.loads, default=None,
                    help='JSON of NewtonOptions / StepOptions / solve keywords, e.g. '
                         '\'{"newton": {...}, "step": {...}, "solve": {"coarse_hmax": 0.2}}\'')
    ap.add_argument("--compare", nargs=2, metavar=("A.jsonl", "B.jsonl"),
                    help="compare two runs instead (exit 1 unless bit for bit)")
    ap.add_argument("--trace", type=json.loads, default=None, metavar="SHEET",
                    help='instead: trace the second phase of --path for this sheet (JSON of '
                         'Sheet keywords, e.g. \'{"length": 3, "curvature": 2.5}\')')
    ap.add_argument("--path", choices=("curvature-first", "gravity-first"),
                    default="curvature-first", help="with --trace")
    ap.add_argument("--hmax", type=float, default=0.1, help="with --trace")
    ap.add_argument("--ds", type=float, default=0.01,
                    help="with --trace: first arclength step (largest: 5 ds)")
    ap.add_argument("--txt", default=None, help="with --trace: write the table here too")
    args = ap.parse_args(argv)
    if args.compare:
        return compare(*args.compare)
    if args.trace is not None:
        from skfem_sheet import Sheet

        sheet = Sheet(**args.trace)
        text = trace_table(sheet, args.path, args.hmax, args.ds,
                           trace_second_phase(sheet, args.path, args.hmax, args.ds))
        print(text)
        if args.txt:
            from skfem_sheet.io import atomic_write

            atomic_write(args.txt, text + "\n")
        return 0
    if args.out is None:
        ap.error("give OUT.jsonl (or --compare A.jsonl B.jsonl)")
    run(args.out, args.root, args.options)
    return 0


if __name__ == "__main__":
    sys.exit(main())



