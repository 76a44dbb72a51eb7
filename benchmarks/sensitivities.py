"""Sensitivities by one back-substitution against finite differences of solves, and calibration (issue 30).

    python benchmarks/sensitivities.py [--hmax 0.1] [--parts state,cost,folds,calibration]
        [--cost-hmax 0.05] [--json out.json] [--txt out.txt]

(default record and table: ``benchmarks/results/accuracy/sensitivities_hmax<H>.{json,txt}``).

Four parts, each on sheets that no test uses:

- ``state``: three sheets (a bistable trapezoid, b/a 0.9, a/R 2.8, on both
  branches; a narrow, thin, stiff trapezoid whose tip rises; a trapezoid whose
  curvature-first path snaps), both load paths.  Each solve is made with
  ``sensitivities`` = all six parameters; every derivative of the deflection,
  the energy and the tip angle is compared with the central difference of
  two extra solves at ``p (1 -+ 1e-3)`` (``--step``; absolute 1e-3 where p = 0):
  full solves along the same load path for the modulus, the thickness, the
  curvature and the gravity (the mesh of ``h (1 -+ 1e-3)`` is the mapped one,
  same plan and layers), and, for the length and the tip width, Newton from
  the state on the mapped mesh (a new mesh at another length or tip width
  would be another triangulation, whose difference is discretisation noise,
  not the derivative), polished to 1e-13 a.  The relative difference is
  reported with the central difference's own truncation error in mind: it
  falls like the step squared: where the difference exceeds 1e-3, the
  central difference at a quarter of the step (two more solves) and the
  Richardson extrapolation of the two are reported too.  The cost: the
  solve's wall time against the sensitivities', their back-substitutions
  and factorisations.
- ``cost``: the same on a finer mesh (``--cost-hmax``, default 0.05), sheet
  A on both paths: the solve with the six sensitivities, and another with
  the modulus alone.
- ``folds``: the standout and pop-up lengths of one trapezoid (b/a 0.9,
  a/R 2.6), located with the minimally augmented system
  (:func:`skfem_sheet.calibration.locate_folds`), their sensitivities
  ``dL*/dp = -(phi . R_p)/(phi . R_L)`` against the fold located again at
  ``p -+ dp`` (relative 1e-3) from the fold: the tip width and the curvature
  on the same fold problem, the modulus and the thickness on the fold problem
  of the perturbed sheet (same mesh topology); the gravity through the exact
  identity ``L*(E, g) = L*(E/g, 1)``, i.e. against ``-E`` times the modulus's
  central difference.
- ``calibration``: synthetic measurements (five lengths of one trapezoid at
  E/(rho g a) = 700, noise of standard deviation 0.002 a, three seeds), the
  modulus fitted from 735 with :func:`skfem_sheet.calibrate`: the recovered
  value, its standard error, the error in standard errors, the number of
  solves (and seed 0: the same data without noise, an exact fit); and the
  refusals (modulus and gravity together; a measurement
  across a snap), with their messages.
"""
from __future__ import annotations

import dataclasses
import json
import os
import sys
import time

import numpy as np

from skfem_sheet import Sheet, calibrate, solve
from skfem_sheet.analyses import sensitivity as S
from skfem_sheet.analyses.observables import tip_deflection
from skfem_sheet.calibration import (
    FOLD_TOLERANCES,
    CalibrationError,
    Measurement,
    locate_folds,
)
from skfem_sheet.engine import locate_fold
from skfem_sheet.engine import newton as engine_newton
from skfem_sheet.foldcurve import TOLERANCES, SheetFoldProblem
from skfem_sheet.io import atomic_write, dumps_json
from skfem_sheet.linalg import make_linear_solver
from skfem_sheet.newton import NewtonOptions, Stats, newton, polish

import harness
from harness import fmt, machine_info, parser, warn_if_busy

RESULTS = os.path.join(harness.RESULTS, "accuracy")

#: The sheets of the state part (none of them in a test).
SHEETS = {
    "A": Sheet(length=1.35, tip_width=0.9, curvature=2.8),
    "B": Sheet(length=0.9, tip_width=0.45, curvature=3.2, thickness=0.025, modulus=900.0),
    "C": Sheet(length=1.15, tip_width=0.8, curvature=2.0, thickness=0.035, modulus=600.0),
}
PATHS = ("curvature-first", "gravity-first")
#: Parameters differenced by full solves (the same mesh); the others by Newton on the mapped mesh.
BY_SOLVE = ("modulus", "thickness", "curvature", "gravity")
#: The fold part's sheet.
FOLD_SHEET = dict(tip_width=0.9, curvature=2.6)
#: The calibration part's sheet, truth, lengths and noise.
CAL_SHEET = Sheet(length=0.8, tip_width=0.8, curvature=1.5)
CAL_TRUTH, CAL_LENGTHS, CAL_SIGMA, CAL_SEEDS = 700.0, (0.6, 0.7, 0.8, 0.9, 1.0), 0.002, (1, 2, 3)


def _value(result, name):
    p, sheet = result.problem, result.sheet
    return {"gravity": result.gravity, "length": p.length, "tip_width": sheet.tip_width,
            "thickness": sheet.thickness, "modulus": sheet.modulus,
            "curvature": sheet.curvature}[name]


def _outputs(problem, w, g):
    return np.array([tip_deflection(problem, w), problem.energy(w, g), S.tip_angle(problem, w)])


def _rel(a, b):
    return abs(a - b) / abs(b) if b else float("nan")


def _fd(result, name, rel, hmax):
    """Central difference of the outputs in ``name`` by two extra solves."""
    p0 = _value(result, name)
    step = rel * abs(p0) if p0 else rel
    out, branches = [], []
    for s in (-1.0, 1.0):
        value = p0 + s * step
        if name in BY_SOLVE:
            kw = {"gravity": value} if name == "gravity" else {}
            sheet = result.sheet if name == "gravity" else result.sheet.replace(**{name: value})
            r = solve(sheet, path=result.path, hmax=hmax, gravity=kw.get("gravity", 1.0))
            out.append(_outputs(r.problem, r.w, r.gravity))
            branches.append(r.branch)
        else:
            P, g, kappa = S.perturbed(result.problem, result.gravity, name, value)
            w0 = result.w.copy()
            w0[P.clamp_dofs] = P.clamp_values(kappa)
            linear, stats = make_linear_solver(), Stats()
            res = newton(P, w0, g, linear, NewtonOptions(), stats)
            w, _ = polish(P, res.w, g, linear, stats, utol=1e-13, max_iterations=10)
            out.append(_outputs(P, w, g))
            branches.append(result.branch if res.converged else "not converged")
    return (out[1] - out[0]) / (2 * step), branches


def state_part(hmax, rel):
    rows, costs = [], []
    for key, sheet in SHEETS.items():
        for path in PATHS:
            r = solve(sheet, path=path, hmax=hmax, sensitivities=S.PARAMETERS)
            s = r.sensitivities
            costs.append(dict(sheet=key, path=path, branch=r.branch, snaps=len(r.snaps),
                              dofs=r.dofs, solve_s=r.wall_time_s,
                              factorizations=r.factorizations, sensitivities_s=s.time_s,
                              back_substitutions=s.back_substitutions,
                              sens_factorizations=s.factorizations,
                              refinement_steps=s.refinement_steps,
                              relative_residual=s.relative_residual))
            for name in S.PARAMETERS:
                fd, branches = _fd(r, name, rel, hmax)
                got = np.array([s.of(out)[name] for out in S.OUTPUTS])
                finer = rich = None
                if np.any(np.abs(got - fd) > 1e-3 * np.abs(fd)):
                    # the difference's own truncation error: a quarter of the step
                    # (two more solves) and Richardson's extrapolation of the two
                    finer, _ = _fd(r, name, rel / 4, hmax)
                    rich = (16 * finer - fd) / 15
                for i, out in enumerate(S.OUTPUTS):
                    v = float(got[i])
                    row = dict(sheet=key, path=path, branch=r.branch, parameter=name,
                               output=out, sensitivity=v, finite_difference=float(fd[i]),
                               relative_difference=_rel(v, fd[i]),
                               fd_by="solve" if name in BY_SOLVE else "Newton, mapped mesh",
                               fd_branches=branches, deflection=r.deflection)
                    if finer is not None:
                        row.update(fd_quarter_step=float(finer[i]),
                                   relative_difference_quarter=_rel(v, finer[i]),
                                   richardson=float(rich[i]),
                                   relative_difference_richardson=_rel(v, rich[i]))
                    rows.append(row)
            print(f"  state {key} {path}: d = {r.deflection:.5f} ({r.branch}), max rel. diff "
                  f"{max(x['relative_difference'] for x in rows[-18:]):.2e}", flush=True)
    return rows, costs


def cost_part(hmax):
    """Sheet A on both paths at ``hmax``: the solve with all six sensitivities,
    and another with the modulus alone (each in the solve, with its factorisation)."""
    rows = []
    for path in PATHS:
        r = solve(SHEETS["A"], path=path, hmax=hmax, sensitivities=S.PARAMETERS)
        one = solve(SHEETS["A"], path=path, hmax=hmax, sensitivities=("modulus",))
        rows.append(dict(path=path, dofs=r.dofs, solve_s=r.wall_time_s,
                         factorizations=r.factorizations, six_s=r.sensitivities.time_s,
                         modulus_solve_s=one.wall_time_s, modulus_s=one.sensitivities.time_s,
                         back_substitutions=r.sensitivities.back_substitutions,
                         sens_factorizations=r.sensitivities.factorizations,
                         deflection=r.deflection))
        print(f"  cost {path}: solve {r.wall_time_s:.1f} s, six {r.sensitivities.time_s:.2f} s",
              flush=True)
    return rows


def _relocate(P, fold, p):
    """The fold located again at ``p`` from ``fold`` (from an equilibrium on its
    side of the fold if the fold system does not converge from the fold itself)."""
    g, res = locate_fold(P, fold.u, p, "L", v0=fold.v, tol=FOLD_TOLERANCES)
    if g is None:
        q = np.array(p, dtype=float)
        q[0] += 0.01 * fold.side
        eq = engine_newton(P, fold.u, q, tol=TOLERANCES)
        g, res = locate_fold(P, eq.u, q, "L", tol=FOLD_TOLERANCES, approach=8)
    return None if g is None else float(g.value)


def folds_part(hmax, rel):
    t0 = time.perf_counter()
    folds = locate_folds(Sheet(length=1.3, **FOLD_SHEET), hmax=hmax)
    located_s = time.perf_counter() - t0
    rows = []
    for kind, fs in folds.items():
        # the fold was located in L on its mesh; the same mesh mapped in (L, b, a/R)
        # (a SheetFoldProblem made at the same length: the same mesh, the same dofs)
        # moves it in the tip width and the curvature
        Lm, bm = fs.problem.mesh_parameters
        P = SheetFoldProblem(FOLD_SHEET["curvature"], hmax, Lm, bm)
        fold = dataclasses.replace(fs.fold, p=np.array([fs.value, FOLD_SHEET["tip_width"],
                                                        FOLD_SHEET["curvature"]]))
        fd = {}
        for name, index in (("tip_width", 1), ("curvature", 2)):
            step = rel * float(fold.p[index])
            vals = []
            for s in (-1.0, 1.0):
                p = np.array(fold.p, dtype=float)
                p[index] += s * step
                vals.append(_relocate(P, fold, p))
            fd[name] = (vals[1] - vals[0]) / (2 * step) if None not in vals else float("nan")
        for name, base in (("modulus", 735.0), ("thickness", 0.03)):
            step = rel * base
            vals = []
            for s in (-1.0, 1.0):
                Q = SheetFoldProblem(FOLD_SHEET["curvature"], hmax, Lm, bm,
                                     **{"modulus": 735.0, "thickness": 0.03,
                                        name: base + s * step})
                vals.append(_relocate(Q, fold, np.array(fold.p, dtype=float)))
            fd[name] = (vals[1] - vals[0]) / (2 * step) if None not in vals else float("nan")
        fd["gravity"] = -735.0 * fd["modulus"]
        for name, v in fs.sensitivities.items():
            rows.append(dict(kind=kind, fold_length=fs.value, parameter=name, sensitivity=v,
                             relocated=fd[name],
                             relative_difference=abs(v - fd[name]) / abs(fd[name]),
                             by=("identity L*(E, g) = L*(E/g, 1)" if name == "gravity"
                                 else "fold located again"),
                             mesh_length=Lm, factorizations=fs.factorizations))
        print(f"  fold {kind}: L* = {fs.value:.5f}", flush=True)
    window = {name: folds["standout"][name] - folds["popup"][name]
              for name in folds["standout"].sensitivities} if len(folds) == 2 else {}
    return rows, dict(located_s=located_s, window_sensitivities=window,
                      window=(folds["standout"].value - folds["popup"].value
                              if len(folds) == 2 else None))


def calibration_part(hmax):
    truth = {L: solve(CAL_SHEET.replace(length=L, modulus=CAL_TRUTH), hmax=hmax).deflection
             for L in CAL_LENGTHS}
    fits = []
    for seed in (0, *CAL_SEEDS):       # seed 0: no noise (an exact fit)
        rng = np.random.default_rng(seed)
        sigma = CAL_SIGMA if seed else 0.0
        ms = [Measurement(deflection=d + sigma * rng.standard_normal(), length=L,
                          uncertainty=CAL_SIGMA) for L, d in truth.items()]
        fit = calibrate(CAL_SHEET, ms, hmax=hmax)
        se = fit.standard_error("modulus")
        fits.append(dict(seed=seed, modulus=fit["modulus"], standard_error=se,
                         error_in_se=(fit["modulus"] - CAL_TRUTH) / se, solves=fit.solves,
                         evaluations=fit.evaluations, wall_time_s=fit.wall_time_s,
                         converged=fit.converged, max_abs_residual=max(map(abs, fit.residuals))))
        print(f"  calibration seed {seed}: E = {fit['modulus']:.2f} +- {se:.2f} "
              f"({fit.solves} solves)", flush=True)
    refusals = {}
    ms = [Measurement(deflection=d, length=L) for L, d in truth.items()]
    for case, call in (("modulus and gravity", lambda: calibrate(
            CAL_SHEET, ms, free=("modulus", "gravity"), hmax=hmax)),
            ("across a snap", lambda: calibrate(SHEETS["A"], [(1.35, 0.5)], hmax=hmax))):
        try:
            call()
            refusals[case] = "NOT refused"
        except CalibrationError as err:
            refusals[case] = str(err)
    return fits, refusals


def table(out) -> str:
    m = out["meta"]
    lines = [f"Sensitivities against finite differences (hmax {m['hmax']}, relative step "
             f"{m['step']:g}); {m['machine']['date']}, load {m['machine'].get('load_average_at_start')}"]
    if "state" in out:
        rows = out["state"]["rows"]
        lines += ["", "State sensitivities: d (deflection), Pi (energy), phi (tip angle); "
                  "rel = |adjoint - FD| / |FD|",
                  f"{'sheet':5} {'path':16} {'branch':20} {'parameter':10} {'dd/dp':>13} "
                  f"{'rel d':>8} {'dPi/dp':>13} {'rel Pi':>8} {'dphi/dp':>13} {'rel phi':>8}  FD by"]
        for i in range(0, len(rows), 3):
            d, e, a = rows[i:i + 3]
            lines.append(f"{d['sheet']:5} {d['path']:16} {d['branch']:20} {d['parameter']:10} "
                         f"{d['sensitivity']:+13.6e} {fmt(d['relative_difference'], '8.1e')} "
                         f"{e['sensitivity']:+13.6e} {fmt(e['relative_difference'], '8.1e')} "
                         f"{a['sensitivity']:+13.6e} {fmt(a['relative_difference'], '8.1e')}  "
                         f"{d['fd_by']}")
            if "richardson" in d:
                for label, k in (("step/4", "relative_difference_quarter"),
                                 ("Richardson", "relative_difference_richardson")):
                    lines.append(f"{'':44}{label:>10} {'':13} {fmt(d[k], '8.1e')} {'':13} "
                                 f"{fmt(e[k], '8.1e')} {'':13} {fmt(a[k], '8.1e')}")
        rel = [r["relative_difference"] for r in rows if np.isfinite(r["relative_difference"])]
        best = [min(r["relative_difference"], r.get("relative_difference_richardson", np.inf))
                for r in rows if np.isfinite(r["relative_difference"])]
        lines += [f"largest relative difference: {max(rel):.2e} over {len(rel)} derivatives "
                  f"({sum(x <= 1e-3 for x in rel)} within 1e-3); against the Richardson "
                  f"extrapolation where the step's own error shows: largest {max(best):.2e} "
                  f"({sum(x <= 1e-3 for x in best)} within 1e-3)", "",
                  "Cost (wall s): the solve and its six sensitivities",
                  f"{'sheet':5} {'path':16} {'dofs':>6} {'solve':>7} {'fact':>5} {'six':>7} "
                  f"{'ratio':>6} {'backsub':>8} {'refact':>6} {'refine':>6}"]
        for c in out["state"]["costs"]:
            lines.append(f"{c['sheet']:5} {c['path']:16} {c['dofs']:6d} {c['solve_s']:7.2f} "
                         f"{c['factorizations']:5d} {c['sensitivities_s']:7.3f} "
                         f"{c['sensitivities_s'] / c['solve_s']:6.3f} "
                         f"{c['back_substitutions']:8d} {c['sens_factorizations']:6d} "
                         f"{c['refinement_steps']:6d}")
    if "cost" in out:
        lines += ["", f"Cost on a finer mesh (hmax {out['cost']['hmax']}): sheet A, the solve "
                  "with the six sensitivities and with the modulus alone (wall s)",
                  f"{'path':16} {'dofs':>7} {'solve':>8} {'fact':>5} {'six':>7} {'ratio':>6} "
                  f"{'modulus':>8} {'ratio':>6} {'backsub':>8} {'refact':>6}"]
        for c in out["cost"]["rows"]:
            lines.append(f"{c['path']:16} {c['dofs']:7d} {c['solve_s']:8.2f} "
                         f"{c['factorizations']:5d} {c['six_s']:7.3f} "
                         f"{c['six_s'] / c['solve_s']:6.3f} {c['modulus_s']:8.3f} "
                         f"{c['modulus_s'] / c['modulus_solve_s']:6.3f} "
                         f"{c['back_substitutions']:8d} {c['sens_factorizations']:6d}")
    if "folds" in out:
        f = out["folds"]
        lines += ["", f"Fold lengths of b/a {FOLD_SHEET['tip_width']}, a/R "
                  f"{FOLD_SHEET['curvature']}: dL*/dp = -(phi . R_p)/(phi . R_L) against the "
                  f"fold located again at p -+ dp (located in {f['meta']['located_s']:.0f} s)",
                  f"{'fold':9} {'L*':>8} {'parameter':10} {'dL*/dp':>13} {'relocated':>13} "
                  f"{'rel':>8}  by"]
        for r in f["rows"]:
            lines.append(f"{r['kind']:9} {r['fold_length']:8.5f} {r['parameter']:10} "
                         f"{r['sensitivity']:+13.6e} {r['relocated']:+13.6e} "
                         f"{fmt(r['relative_difference'], '8.1e')}  {r['by']}")
        w = f["meta"]["window_sensitivities"]
        if w:
            lines.append(f"bistable window L1* - L0* = {f['meta']['window']:.5f}: "
                         + ", ".join(f"d/d{k} {v:+.4g}" for k, v in w.items()))
    if "calibration" in out:
        c = out["calibration"]
        lines += ["", f"Calibration: E/(rho g a) = {CAL_TRUTH:g} at L/a {CAL_LENGTHS}, b/a "
                  f"{CAL_SHEET.tip_width}, a/R {CAL_SHEET.curvature}, noise sigma {CAL_SIGMA} a; "
                  "fit from 735",
                  f"{'seed':>4} {'E fitted':>10} {'SE':>8} {'(E-E*)/SE':>10} {'solves':>6} "
                  f"{'evals':>5} {'wall s':>7}"]
        for r in c["fits"]:
            lines.append(f"{r['seed']:4d} {r['modulus']:10.3f} {r['standard_error']:8.3f} "
                         f"{r['error_in_se']:+10.2f} {r['solves']:6d} {r['evaluations']:5d} "
                         f"{r['wall_time_s']:7.1f}")
        for case, msg in c["refusals"].items():
            lines.append(f"refused ({case}): {msg}")
    return "\n".join(lines)


def main(argv=None):
    ap = parser(__doc__)
    ap.add_argument("--hmax", type=float, default=0.1)
    ap.add_argument("--step", type=float, default=1e-3,
                    help="relative step of the finite differences (default 1e-3)")
    ap.add_argument("--parts", default="state,cost,folds,calibration",
                    help="comma list of state, cost, folds, calibration (a record's other "
                         "parts are kept)")
    ap.add_argument("--cost-hmax", type=float, default=0.05,
                    help="mesh size of the cost part (default 0.05)")
    ap.add_argument("--json", default=None)
    ap.add_argument("--txt", default=None)
    args = ap.parse_args(argv)
    parts = [p.strip() for p in args.parts.split(",") if p.strip()]
    bad = [p for p in parts if p not in ("state", "cost", "folds", "calibration")]
    if bad:
        ap.error(f"--parts must be from state, cost, folds, calibration, got {', '.join(bad)}")
    warn_if_busy()
    base = os.path.join(RESULTS, f"sensitivities_hmax{args.hmax:g}")
    json_path, txt_path = args.json or base + ".json", args.txt or base + ".txt"
    out = {}
    if os.path.exists(json_path):          # keep the parts not run now
        with open(json_path) as fh:
            out = json.load(fh)
    out["meta"] = dict(hmax=args.hmax, step=args.step, machine=machine_info(), parts=parts)
    if "cost" in parts:
        out["cost"] = dict(hmax=args.cost_hmax, rows=cost_part(args.cost_hmax))
    if "state" in parts:
        rows, costs = state_part(args.hmax, args.step)
        out["state"] = dict(rows=rows, costs=costs)
    if "folds" in parts:
        rows, meta = folds_part(args.hmax, args.step)
        out["folds"] = dict(rows=rows, meta=meta)
    if "calibration" in parts:
        fits, refusals = calibration_part(args.hmax)
        out["calibration"] = dict(fits=fits, refusals=refusals)
    text = table(out)
    print(text)
    atomic_write(json_path, dumps_json(out) + "\n")
    atomic_write(txt_path, text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
