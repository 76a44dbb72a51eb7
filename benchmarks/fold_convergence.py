"""Fold lengths L0* (pop-up) and L1* (standout) of the rectangle under mesh refinement (issue 13, item 3).

    python benchmarks/fold_convergence.py [--json out.json] [--txt out.txt]
        [--curvatures 2.5 5] [--hmax 0.1 0.06 0.045 0.03] [--refine 0.1] [--solver auto]

(default record and table: ``benchmarks/results/accuracy/fold_convergence.{json,txt}``;
delete them to recompute from scratch).

For every clamp curvature a/R and mesh size hmax, the two folds of the
rectangle (b/a = 1) are located directly at b = 1 with the continuation
engine (:mod:`skfem_sheet.engine`) on the sheet of
:class:`skfem_sheet.foldcurve.SheetFoldProblem` (the same problem, adapter
and corrector tolerances as :func:`skfem_sheet.foldcurve.trace_fold_curve`):

- standout ``L1*``: a curvature-first solve at a length below ``L1*``, then
  natural continuation in L upward; the step that fails at the fold triggers
  its location with the minimally augmented system (Newton on ``R = 0,
  sigma = 0`` in ``(u, L)``), so the fold length is converged to the
  corrector's tolerance (not bracketed);
- pop-up ``L0*``: a gravity-first solve at a length above ``L0*`` (inside the
  bistable range), then natural continuation in L downward, located the same way.

Each fold is computed on its own mesh built at a length near the fold (the
start length, 0.02 toward the fold), so the stretch ``L / L_m`` of the mesh
at the fold is within a few per cent and hmax is the mesh's in-plane size
there.  Finer meshes start from the coarser mesh's fold (0.02 behind it),
which saves most of the continuation steps.

The record is rewritten after every fold (a rerun with the same ``--json``
skips the folds already there), so an interrupted run loses at most the fold
in progress.  ``curvatures[*].meshes`` lists the meshes coarse to fine with
``popup_length`` and ``standout_length`` (the format that
``benchmarks/verification_report.py`` reads); ``change`` compares the two
finest meshes against the fold tolerance ``TOLERANCE``.
"""
from __future__ import annotations

import json
import os
import resource
import time

import numpy as np

from skfem_sheet.engine import natural
from skfem_sheet.foldcurve import TOLERANCES, SheetFoldProblem
from skfem_sheet.io import atomic_write, dumps_json
from skfem_sheet.params import ParameterError

import harness
from harness import parser

#: Where the recorded outputs live.
RESULTS = os.path.join(harness.RESULTS, "accuracy")
#: Fold tolerance of the paper's fold lengths (the bisection's bracket, +-0.005).
TOLERANCE = 0.005
#: First standout search (length of the curvature-first solve) per curvature.
STANDOUT_START = {2.5: 1.2, 5.0: 1.2}
#: Largest length searched.
LENGTH_RANGE = (0.5, 3.0)


def _peak_mb():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def locate(curvature, hmax, kind, start, *, solver="auto", layers=None, step=0.02,
           min_step=5e-4, refine=0):
    """One fold at b = 1: ``kind`` "standout" (curvature-first, L upward) or
    "popup" (gravity-first, L downward), from the length ``start``.

    ``refine`` > 0: the mesh of ``hmax`` refined uniformly ``refine`` times
    (nested; ``SheetFoldProblem(..., refine=refine)``).

    Returns a JSON-ready dict (``length`` None if no fold was found).
    """
    t0 = time.perf_counter()
    up = kind == "standout"
    mesh_length = start + (0.02 if up else -0.02)
    P = SheetFoldProblem(curvature, hmax, mesh_length, 1.0, layers=layers, solver=solver,
                         refine=refine)
    p0 = np.array([start, 1.0, curvature])
    path = "curvature-first" if up else "gravity-first"
    out = {"kind": kind, "start_length": start, "mesh_length": mesh_length, "path": path,
           "length": None}
    try:
        u0, f_start = P.solve_state(p0, path)
    except ParameterError as err:
        out.update(reason=str(err), wall_time_s=time.perf_counter() - t0)
        return out
    stop = LENGTH_RANGE[1] if up else LENGTH_RANGE[0]
    branch = natural(P, u0, p0, "L", stop, step=step, min_step=min_step, max_step=0.05,
                     tol=TOLERANCES, jump=0.1, keep_states=False)
    fold = branch.fold
    length, located, bracket = None, None, None
    if fold is not None:
        length, located = fold.value, "minimally augmented system"
    elif branch.bracket and branch.reason.startswith("step below min_step"):
        # the fold's location from the failed step's start did not converge, but the
        # branch was followed to within min_step of its end: the fold lies in the
        # bracket (the branch exists at its first value), good to min_step
        bracket = [float(x) for x in branch.bracket]
        length, located = bracket[0], f"bracket of natural continuation (min_step {min_step:g})"
    out.update(
        length=length, located=located, bracket=bracket,
        side=None if fold is None else int(fold.side),
        fold_coefficient=None if fold is None else float(fold.a),
        negative_eigenvalues=None if fold is None else fold.negative_eigenvalues,
        steps=len(branch.points),
        last_length=float(branch.values[-1]) if len(branch.points) else None,
        reason=branch.reason,
        factorizations=int(f_start + branch.stats.factorizations + P.refactorizations),
        ndof=int(P.ndof),
        wall_time_s=time.perf_counter() - t0,
        peak_rss_mb=_peak_mb())
    return out


def _load(path):
    if path and os.path.exists(path):
        with open(path) as f:
            return json.load(f)
    return {}


def _case(doc, curvature):
    for c in doc.setdefault("curvatures", []):
        if abs(c["curvature"] - curvature) < 1e-12:
            return c
    c = {"curvature": curvature, "tip_width": 1.0, "meshes": []}
    doc["curvatures"].append(c)
    doc["curvatures"].sort(key=lambda c: c["curvature"])
    return c


def _h(m):
    """The mesh size of a record (hmax / 2^refine)."""
    return m["hmax"] / 2 ** m.get("refine", 0)


def _mesh(case, hmax, refine=0):
    for m in case["meshes"]:
        if abs(m["hmax"] - hmax) < 1e-12 and m.get("refine", 0) == refine:
            return m
    m = {"hmax": hmax, "refine": refine, "h": hmax / 2 ** refine, "popup_length": None,
         "standout_length": None}
    case["meshes"].append(m)
    case["meshes"].sort(key=lambda m: (-_h(m), m.get("refine", 0)))
    return m


def summarize(case):
    """Totals per mesh and the change between the two finest meshes."""
    for m in case["meshes"]:
        runs = [m[k] for k in ("popup", "standout") if isinstance(m.get(k), dict)]
        m["factorizations"] = sum(r.get("factorizations", 0) for r in runs)
        m["wall_time_s"] = sum(r.get("wall_time_s", 0.0) for r in runs)
    change = {}
    for key in ("popup_length", "standout_length"):
        vals = [m for m in case["meshes"] if m.get(key) is not None]
        if len(vals) >= 2:
            a, b = vals[-2], vals[-1]
            d = abs(b[key] - a[key])
            change[key] = {"coarse_hmax": a["hmax"], "coarse_refine": a.get("refine", 0),
                           "fine_hmax": b["hmax"], "fine_refine": b.get("refine", 0), "change": d,
                           "tolerance": TOLERANCE, "within": bool(d <= TOLERANCE)}
    case["change"] = change
    return case


def table(doc) -> str:
    lines = [f"Fold lengths of the rectangle (b/a = 1) under mesh refinement; fold tolerance "
             f"+-{TOLERANCE}",
             "folds at b = 1 by natural continuation in L (skfem_sheet.engine), located with the "
             "minimally augmented system;",
             "  * = that system did not converge: the end of the branch to min_step 5e-4 "
             "(the branch exists there)",
             "  refine r: the mesh of hmax refined uniformly r times (nested, h = hmax / 2^r)",
             f"{'a/R':>5} {'hmax':>6} {'r':>2} {'ndof':>8} {'L0* pop-up':>11} {'dL0*':>8} "
             f"{'L1* standout':>13} {'dL1*':>8} {'fact':>6} {'wall s':>8} {'peak MB':>8}",
             "-" * 95]
    for case in doc.get("curvatures", []):
        prev = {}
        for m in case["meshes"]:
            cells = []
            for key in ("popup_length", "standout_length"):
                v = m.get(key)
                d = "" if v is None or prev.get(key) is None else f"{v - prev[key]:+.4f}"
                run = m.get(key.split("_")[0])
                star = ("*" if isinstance(run, dict) and run.get("bracket") is not None
                        else "")
                cells += ["none" if v is None else f"{v:.4f}{star}", d]
                if v is not None:
                    prev[key] = v
            runs = [m[k] for k in ("popup", "standout") if isinstance(m.get(k), dict)]
            ndof = max((r.get("ndof", 0) for r in runs), default=0)
            peak = max((r.get("peak_rss_mb", 0) for r in runs), default=0)
            lines.append(f"{case['curvature']:>5g} {m['hmax']:>6g} {m.get('refine', 0):>2d} "
                         f"{ndof:>8d} {cells[0]:>11} "
                         f"{cells[1]:>8} {cells[2]:>13} {cells[3]:>8} "
                         f"{m.get('factorizations', 0):>6d} {m.get('wall_time_s', 0):>8.0f} "
                         f"{peak:>8.0f}")
        for key, label in (("popup_length", "L0*"), ("standout_length", "L1*")):
            c = case.get("change", {}).get(key)
            if c:
                fine = f"hmax {c['fine_hmax']:g}" + (f" r{c['fine_refine']}"
                                                     if c.get("fine_refine") else "")
                coarse = f"hmax {c['coarse_hmax']:g}" + (f" r{c['coarse_refine']}"
                                                         if c.get("coarse_refine") else "")
                lines.append(f"  a/R = {case['curvature']:g}: |{label}({fine}) - "
                             f"{label}({coarse})| = {c['change']:.4f} "
                             f"{'<=' if c['within'] else '>'} {TOLERANCE}: "
                             f"{'within' if c['within'] else 'NOT within'} the fold tolerance")
    return "\n".join(lines) + "\n"


def main(argv=None):
    ap = parser(__doc__)
    ap.add_argument("--json", default=os.path.join(RESULTS, "fold_convergence.json"),
                    help="record (rewritten after every fold; reruns skip the folds already "
                         "there)")
    ap.add_argument("--txt", default=os.path.join(RESULTS, "fold_convergence.txt"),
                    help="table (also printed)")
    ap.add_argument("--curvatures", type=float, nargs="+", default=[2.5, 5.0])
    ap.add_argument("--hmax", type=float, nargs="+", default=[0.1, 0.06, 0.045, 0.03])
    ap.add_argument("--refine", type=float, nargs="*", default=[],
                    help="hmax values whose mesh is also refined once (nested)")
    ap.add_argument("--solver", default="auto")
    ap.add_argument("--layers", type=int, default=None)
    args = ap.parse_args(argv)
    doc = _load(args.json)
    doc.update(benchmark="fold_convergence", tolerance=TOLERANCE, tip_width=1.0,
               method="natural continuation in L at b = 1, folds located with the minimally "
                      "augmented system (skfem_sheet.engine, foldcurve.TOLERANCES)")

    def save():
        for c in doc["curvatures"]:
            summarize(c)
        if args.json:
            atomic_write(args.json, dumps_json(doc, indent=2) + "\n")
        if args.txt:
            atomic_write(args.txt, table(doc))

    for kappa in args.curvatures:
        case = _case(doc, kappa)
        plan = sorted([(h, 0) for h in args.hmax] + [(h, 1) for h in args.refine],
                      key=lambda hr: (-hr[0] / 2 ** hr[1], hr[1]))
        for hmax, refine in plan:
            m = _mesh(case, hmax, refine)
            coarser = [c for c in case["meshes"] if _h(c) > _h(m) + 1e-12]
            for kind in ("standout", "popup"):
                key = f"{kind}_length"
                if m.get(key) is not None:
                    continue
                prev = next((c[key] for c in reversed(coarser) if c.get(key) is not None), None)
                if kind == "standout":
                    starts = ([prev - 0.015, prev - 0.1] if prev is not None
                              else [STANDOUT_START.get(kappa, 1.2)])
                else:
                    L1 = m.get("standout_length")
                    starts = [prev + 0.015] if prev is not None else []
                    if L1 is not None:
                        starts = [s for s in starts if s < L1 - 0.005] + [L1 - 0.01]
                for start in starts:
                    print(f"a/R {kappa:g} hmax {hmax:g} refine {refine}: {kind} from "
                          f"L = {start:.4f} ...",
                          flush=True)
                    run = locate(kappa, hmax, kind, start, solver=args.solver,
                                 layers=args.layers, step=0.02 if prev is None else 0.005,
                                 refine=refine)
                    print(f"  -> L = {run['length']}  ({run.get('factorizations')} "
                          f"factorizations, {run['wall_time_s']:.0f} s; {run.get('reason')})",
                          flush=True)
                    m[kind] = run
                    m[key] = run["length"]
                    if run["length"] is not None:
                        break
                save()
    save()
    print(table(doc), end="")


if __name__ == "__main__":
    main()
