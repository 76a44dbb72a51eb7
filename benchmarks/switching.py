"""Acceptance of the switching analysis (issue 58): forces, barriers, saddle, scaling, cost.

    python benchmarks/switching.py [--parts scaling,saddle,force,cost,sheets]
                                   [--json out.json]

Parts (each printed as a table; with ``--json`` the records are written after
every part, and a rerun skips the parts already there):

``saddle``
    The rectangle at a/R 2.5, L/a 1.3 on hmax 0.1 and 0.05: the S-curve in L
    (``s_curve`` from L/a 1.1 to 1.3^2/1.1, so that its one mesh is made at
    1.3), its unstable middle state at L/a 1.3 (Newton from the two unstable
    points around it, polished) against the saddle of the curve in the tip
    force: (a) traced from the aloft state on the S-curve's own mesh, (b) of
    ``switching(sheet, hmax, curve_hmax=hmax)`` on the mesh made at 1.3; d and
    the negative eigenvalues of both, and the work identity ``Pi(saddle) -
    Pi(aloft) = int F dw_tip`` (and from the drooped state) on (b).
``scaling``
    On hmax 0.1, one mesh made at each fold and stretched: the fold lengths
    L1* (the aloft state's) and L0* (the drooped state's) located in L on the
    branch (``fold_on_branch``), then the switching force and the barrier of
    that state at L1* - delta and L0* + delta, delta = 0.002 ... 0.064: the
    exponents of the log-log fits (the normal form: 1 and 3/2) and the zeros
    of F*(L) and barrier^(2/3)(L) extrapolated by quadratics in L, against
    the located fold lengths.
``force``
    The force-controlled solve on hmax 0.1 (``apply_tip_force``): the aloft
    state pushed to 0.99 and 1.01 of F_down, the drooped state pulled to 0.99
    and 1.01 of F_up: whether it snaps, where, and where it lands.
``cost`` (also ``si``)
    The paper's silicone sheet in SI (a 5 cm, h 1.5875 mm, rho 1250, E 4.5e5
    Pa, L/a 1.3, a/R 2.5) at hmax 0.03: ``solve``, ``switching``, ``solve``
    again in one process (run with OMP_NUM_THREADS=1 MKL_NUM_THREADS=1): the
    ratio of the analysis to the mean solve, and the forces in mN, the
    barriers in microjoules, the sheet's weight.
``sheets``
    Two sheets no test uses on hmax 0.1: a trapezoid near the cusp of its
    bistable range (b/a 0.8, a/R 1.5, L/a 0.996) and a sheet that is not
    bistable (b/a 0.6, a/R 2.5, L/a 1.25).
"""
import json
import math
import os
import time

import numpy as np

from skfem_sheet import Sheet, solve
from skfem_sheet.analyses.observables import tip_deflection
from skfem_sheet.analyses.stability import stability
from skfem_sheet.bistability import s_curve
from skfem_sheet.engine.fold import fold_on_branch
from skfem_sheet.engine.protocol import Counting
from skfem_sheet.io import Series, atomic_write, dumps_json
from skfem_sheet.linalg import make_linear_solver
from skfem_sheet.newton import NewtonOptions, Stats, newton, polish
from skfem_sheet.sheet_shape import TOLERANCES, SheetShapeProblem
from skfem_sheet.switch import SIScale, apply_tip_force, force_curve, switching

from harness import machine_info, parser

PARTS = ("saddle", "scaling", "force", "cost", "sheets")
RECTANGLE = Sheet(length=1.3, curvature=2.5)
DELTAS = (0.002, 0.004, 0.008, 0.016, 0.032, 0.064)


def _save(path, data):
    if path:
        atomic_write(path, dumps_json(data, indent=1) + "\n")


def _equilibrium(problem, w):
    """``w`` solved on ``problem`` at full load (the sheet's Newton, polished to
    1e-10): the state and its negative eigenvalues."""
    solver, stats = make_linear_solver(), Stats()
    res = newton(problem, w, 1.0, solver, NewtonOptions(linearization="exact"), stats)
    if not res.converged:
        raise RuntimeError(f"Newton did not converge: {res.reason}")
    w, _ = polish(problem, res.w, 1.0, solver, stats, utol=1e-10, max_iterations=6)
    return w, stability(problem, solver)[1]


def _interpolated(frames, points, length, stable, first_half=False):
    """The S-curve's state at ``length`` interpolated between two consecutive
    points of that stability (on the first half of the curve if asked)."""
    n = len(frames) // 2 if first_half else len(frames)
    for i in range(n - 1):
        a, b = frames[i], frames[i + 1]
        if (points[i].stable, points[i + 1].stable) == (stable, stable) and \
                (a.time - length) * (b.time - length) <= 0:
            t = (length - a.time) / (b.time - a.time)
            return a.w + t * (b.w - a.w), a.problem
    raise RuntimeError(f"no pair of {'stable' if stable else 'unstable'} points around {length}")


def _work(curve):
    s, z, e = curve.points[0], curve.point("saddle"), curve.point("end")
    out = {"work_down": curve.work("start", "saddle"), "barrier_down": z.energy - s.energy}
    if e is not None:
        out.update(work_up=curve.work("end", "saddle"), barrier_up=z.energy - e.energy)
    for k in ("down", "up"):
        if f"barrier_{k}" in out:
            out[f"work_rel_error_{k}"] = (out[f"work_{k}"] - out[f"barrier_{k}"]) \
                / out[f"barrier_{k}"]
    return out


def part_saddle(hmaxes=(0.1, 0.05)):
    rows = []
    for h in hmaxes:
        t0 = time.perf_counter()
        series = Series()
        sc = s_curve(RECTANGLE.replace(length=1.1), 1.3**2 / 1.1, hmax=h,
                     on_point=series.on_point)
        frames = series.frames
        w_mid, prob = _interpolated(frames, sc.points, 1.3, False)
        prob = prob.with_length(1.3)
        middle, k_mid = _equilibrium(prob, w_mid)
        d_mid = tip_deflection(prob, middle)
        w_aloft, _ = _interpolated(frames, sc.points, 1.3, True, first_half=True)
        aloft, _ = _equilibrium(prob, w_aloft)
        curve = force_curve(prob, aloft, 2.5)
        za = curve.point("saddle")
        sw = switching(RECTANGLE, hmax=h, curve_hmax=h)
        rows.append({"hmax": h, "s_curve_mesh_length": float(prob.sheet_mesh.length),
                     "s_curve_points": len(sc.points), "middle_deflection": d_mid,
                     "middle_negative_eigenvalues": k_mid,
                     "saddle_on_s_curve_mesh": za.deflection,
                     "saddle_on_s_curve_mesh_negative_eigenvalues": za.negative_eigenvalues,
                     "saddle_switching": sw.saddle_deflection,
                     "saddle_switching_negative_eigenvalues": sw.saddle_negative_eigenvalues,
                     "diff_s_curve_mesh": za.deflection - d_mid,
                     "diff_switching": sw.saddle_deflection - d_mid,
                     "shape": sw.shape, "curve_points": len(sw.curve.points),
                     "force_down": sw.force_down, "force_up": sw.force_up,
                     **{f"curve_{k}": v for k, v in _work(curve).items()},
                     **_work(sw.curve), "wall_s": time.perf_counter() - t0})
    print("saddle against the S-curve's unstable middle state (rectangle a/R 2.5, L/a 1.3):")
    print(f"  {'hmax':>5} {'middle d':>12} {'k':>2} {'saddle (a)':>12} {'k':>2} {'(a)-mid':>9} "
          f"{'saddle (b)':>12} {'k':>2} {'(b)-mid':>9} {'work rel down':>13} {'up':>10}")
    for r in rows:
        print(f"  {r['hmax']:5.2f} {r['middle_deflection']:12.8f} "
              f"{r['middle_negative_eigenvalues']:>2} {r['saddle_on_s_curve_mesh']:12.8f} "
              f"{r['saddle_on_s_curve_mesh_negative_eigenvalues']:>2} "
              f"{r['diff_s_curve_mesh']:+9.1e} {r['saddle_switching']:12.8f} "
              f"{r['saddle_switching_negative_eigenvalues']:>2} {r['diff_switching']:+9.1e} "
              f"{r['work_rel_error_down']:+13.2e} {r['work_rel_error_up']:+10.2e}")
    print("  (a) the curve in F on the S-curve's mesh stretched to 1.3; (b) switching(sheet, "
          "hmax, curve_hmax=hmax) on the mesh made at 1.3; work: (int F dw - barrier) / "
          "barrier on (b)")
    return rows


def _fold_in_length(L_mesh, L_start, path, h):
    """The fold in L of the branch of ``path`` at ``L_start`` on one mesh made
    at ``L_mesh`` and stretched: ``(L*, problem, d*)``."""
    P = SheetShapeProblem(RECTANGLE.replace(length=L_mesh), h, parameters=("L",),
                          geometry="stretch")
    out = P.along_path([L_start], path)
    if not out.converged:
        raise RuntimeError(f"{path} at L/a {L_start}: {out.reason}")
    C = Counting(P)
    u, p = out.w[P.free], np.array([L_start])
    fact = C.factorize(C.jacobian(u, p))
    v = fact.solve(-C.dresidual(u, p, 0))
    fold, res = fold_on_branch(C, u, p, 0, v, tol=TOLERANCES, ptol=1e-9)
    if fold is None:
        raise RuntimeError(f"the fold from L/a {L_start} was not located: {res.reason}")
    return float(fold.value), P, P.deflection(fold.u, fold.p)


def _fit(L, y, L_fold, power):
    """Exponent of ``|y| ~ |L* - L|^power`` (log-log least squares) and the zero of
    ``|y|^(1/power)`` extrapolated by a quadratic in L."""
    delta = np.abs(L_fold - np.asarray(L))
    y = np.abs(np.asarray(y))
    slope = float(np.polyfit(np.log(delta), np.log(y), 1)[0])
    local = [float(np.log(y[i + 1] / y[i]) / np.log(delta[i + 1] / delta[i]))
             for i in range(len(y) - 1)]
    c = np.polyfit(L, y ** (1.0 / power), 2)
    roots = np.roots(c)
    roots = roots[np.isreal(roots)].real
    zero = float(roots[np.argmin(np.abs(roots - L_fold))]) if len(roots) else math.nan
    return slope, local, zero


def part_scaling(h=0.1):
    out = {}
    for kind, path, direction, side in (("standout", "curvature-first", -1, -1),
                                        ("popup", "gravity-first", 1, 1)):
        guess = 1.35 if kind == "standout" else 1.205  # where the quick fold map has them
        start = guess + side * 0.01  # inside the window
        L_fold, P, d_fold = _fold_in_length(guess, start, path, h)
        # mesh made at the located fold: the lengths approach it on one stretched mesh
        L_fold, P, d_fold = _fold_in_length(L_fold, L_fold + side * 0.01, path, h)
        rows = []
        for delta in DELTAS:
            L = L_fold + side * delta
            t0 = time.perf_counter()
            st = P.along_path([L], path)
            if not st.converged:
                rows.append({"delta": delta, "length": L, "error": st.reason})
                continue
            curve = force_curve(P.problem([L]), st.w, 2.5, direction=direction)
            fold, saddle = (curve.folds[0] if curve.folds else None), curve.point("saddle")
            rows.append({"delta": delta, "length": L, "shape": curve.shape,
                         "force": fold.force if fold else math.nan,
                         "barrier": (saddle.energy - curve.points[0].energy) if saddle
                         else math.nan,
                         "saddle_negative_eigenvalues": saddle.negative_eigenvalues
                         if saddle else None,
                         "points": len(curve.points), "factorizations": curve.factorizations,
                         "wall_s": time.perf_counter() - t0})
            print(f"  {kind} delta {delta:.3f}: {rows[-1]}", flush=True)
        good = [r for r in rows if np.isfinite(r.get("force", math.nan))
                and np.isfinite(r.get("barrier", math.nan))]
        Ls = [r["length"] for r in good]
        fs, fl, fz = _fit(Ls, [r["force"] for r in good], L_fold, 1.0)
        bs, bl, bz = _fit(Ls, [r["barrier"] for r in good], L_fold, 1.5)
        out[kind] = {"fold_length": L_fold, "fold_deflection": d_fold,
                     "mesh_length": float(P.mesh_parameters[0]), "rows": rows,
                     "force_exponent": fs, "force_local_exponents": fl, "force_zero": fz,
                     "barrier_exponent": bs, "barrier_local_exponents": bl,
                     "barrier_zero": bz}
    print(f"scaling near the folds of the rectangle at a/R 2.5, hmax {h:g} (one mesh made at "
          f"each fold, stretched):")
    for kind, r in out.items():
        what = "F_down, barrier_down" if kind == "standout" else "F_up, barrier_up"
        print(f"  {kind} L* = {r['fold_length']:.6f} ({what}):")
        print(f"    {'delta':>6} {'L/a':>9} {'F*':>12} {'barrier':>12} {'k':>2} {'pts':>4}")
        for row in r["rows"]:
            if "error" in row:
                print(f"    {row['delta']:6.3f} {row['length']:9.5f}  failed: {row['error']}")
                continue
            print(f"    {row['delta']:6.3f} {row['length']:9.5f} {row['force']:+12.5e} "
                  f"{row['barrier']:12.5e} {row['saddle_negative_eigenvalues']!s:>2} "
                  f"{row['points']:4d}")
        print(f"    exponent of F*: {r['force_exponent']:.4f} (local "
              + ", ".join(f"{x:.3f}" for x in r["force_local_exponents"]) + ")")
        print(f"    exponent of the barrier: {r['barrier_exponent']:.4f} (local "
              + ", ".join(f"{x:.3f}" for x in r["barrier_local_exponents"]) + ")")
        print(f"    zeros extrapolated: F* {r['force_zero']:.6f} "
              f"({r['force_zero'] - r['fold_length']:+.2e}), barrier "
              f"{r['barrier_zero']:.6f} ({r['barrier_zero'] - r['fold_length']:+.2e})")
    return out


def part_force(h=0.1):
    sw = switching(RECTANGLE, hmax=h)
    aloft = solve(RECTANGLE, hmax=h)
    drooped = solve(RECTANGLE, "gravity-first", hmax=h)
    rows = []
    for name, start, F in (("aloft pushed", aloft, sw.force_down),
                           ("drooped pulled", drooped, sw.force_up)):
        for factor in (0.99, 1.01):
            t0 = time.perf_counter()
            out = apply_tip_force(start, factor * F)
            rows.append({"state": name, "factor": factor, "force": out.force,
                         "converged": out.converged, "snaps": len(out.snaps),
                         "snap_force": out.snaps[0].load if out.snaps else math.nan,
                         "located_fold": F, "start_deflection": out.start_deflection,
                         "deflection": out.deflection, "stable": out.stable,
                         "factorizations": out.factorizations,
                         "wall_s": time.perf_counter() - t0})
    print(f"force-controlled solve, rectangle a/R 2.5, L/a 1.3, hmax {h:g} "
          f"(F_down {sw.force_down:+.8e}, F_up {sw.force_up:+.8e}; aloft d/a "
          f"{aloft.deflection:.5f}, drooped {drooped.deflection:.5f}):")
    for r in rows:
        snap = (f"snapped at F = {r['snap_force']:+.10e} (located fold "
                f"{r['located_fold']:+.10e})" if r["snaps"] else "no snap")
        print(f"  {r['state']:15s} to {r['factor']:.2f} F*: {snap}; d/a "
              f"{r['start_deflection']:.5f} -> {r['deflection']:.5f}, stable {r['stable']}, "
              f"{r['factorizations']} factorisations")
    return {"switching": sw.summary() | {"curve": None}, "rows": rows}


def part_cost(h=0.03):
    sheet = Sheet.from_si(0.05, 0.065, 0.05, 1.5875e-3, 0.02, 4.5e5, 1250)
    si = SIScale(0.05, 1250.0)
    t0 = time.perf_counter()
    r1 = solve(sheet, hmax=h)
    t1 = time.perf_counter()
    sw = switching(sheet, hmax=h, si=si)
    t2 = time.perf_counter()
    r2 = solve(sheet, hmax=h)
    t3 = time.perf_counter()
    solve_s = 0.5 * ((t1 - t0) + (t3 - t2))
    out = {"sheet": sheet.to_dict(), "solve_s": [t1 - t0, t3 - t2], "switching_s": t2 - t1,
           "solve_deflections": [r1.deflection, r2.deflection],
           "aloft_deflection_switching": sw.aloft_deflection,
           "ratio": (t2 - t1) / solve_s, "solve_factorizations": r1.factorizations,
           "switching_factorizations": sw.factorizations,
           "curve_factorizations": sw.curve.factorizations, "curve_hmax": sw.curve.hmax,
           "switching_solve_s": sw.solve_wall_time_s, "si": sw.in_si(),
           "switching": sw.summary() | {"curve": None}}
    si_v = out["si"]
    print(f"the paper's silicone sheet (a 5 cm, h 1.5875 mm, rho 1250, E 4.5e5 Pa, L/a 1.3, "
          f"a/R 2.5; h/a {sheet.thickness:g}, E/(rho g a) {sheet.modulus:.4g}) at hmax {h:g}:")
    print(f"  {sw.states}")
    print(f"  force_down {1e3 * si_v['force_down_N']:+.4f} mN, force_up "
          f"{1e3 * si_v['force_up_N']:+.4f} mN; the sheet's weight "
          f"{1e3 * si_v['weight_N']:.4f} mN")
    print(f"  barrier_down {1e6 * si_v['barrier_down_J']:.4f} microjoules, barrier_up "
          f"{1e6 * si_v['barrier_up_J']:.4f} microjoules")
    print(f"  saddle d {1e3 * si_v['saddle_deflection_m']:.3f} mm, aloft "
          f"{1e3 * si_v['aloft_deflection_m']:.3f} mm, drooped "
          f"{1e3 * si_v['drooped_deflection_m']:.3f} mm")
    print(f"  cost: solve {t1 - t0:.1f} s and {t3 - t2:.1f} s ({r1.factorizations} "
          f"factorisations on hmax {h:g}), switching {t2 - t1:.1f} s ({sw.factorizations} on "
          f"hmax {h:g}, the curve {sw.curve.factorizations} on hmax {sw.curve.hmax:g}): "
          f"{out['ratio']:.2f} x the mean solve")
    return out


def part_sheets(h=0.1):
    rows = []
    for name, sheet in (("near the cusp", Sheet(length=0.996, tip_width=0.8, curvature=1.5)),
                        ("not bistable", Sheet(length=1.25, tip_width=0.6, curvature=2.5))):
        t0 = time.perf_counter()
        sw = switching(sheet, hmax=h)
        rows.append({"name": name, "sheet": sheet.to_dict(),
                     "summary": sw.summary() | {"curve": {k: v for k, v in
                                                          sw.curve.summary().items()
                                                          if k in ("shape", "notes",
                                                                   "reason")}},
                     "wall_s": time.perf_counter() - t0})
        print(f"{name}: {sheet.length:g}, b/a {sheet.tip_width:g}, a/R {sheet.curvature:g}, "
              f"hmax {h:g} ({rows[-1]['wall_s']:.0f} s):")
        print("\n".join("  " + line for line in sw.lines()))
        folds = [p for p in sw.curve.points if p.kind == "fold"]
        for p in folds:
            print(f"    fold at F = {p.force:+.6e} ({100 * p.force / sw.weight:+.3g}% of the "
                  f"weight), d/a {p.deflection:.5f}")
    return rows


def main(argv=None):
    ap = parser(__doc__)
    ap.add_argument("--parts", default=",".join(PARTS),
                    help=f"comma list from {', '.join(PARTS)} (default: all)")
    ap.add_argument("--json", default=None, help="records, written after every part")
    args = ap.parse_args(argv)
    parts = [p.strip() for p in args.parts.split(",") if p.strip()]
    parts = ["cost" if p == "si" else p for p in parts]
    bad = [p for p in parts if p not in PARTS]
    if bad:
        ap.error(f"--parts must be from {', '.join(PARTS)}, got {', '.join(bad)}")
    data = {}
    if args.json and os.path.exists(args.json):
        with open(args.json) as f:
            data = json.load(f)
    data.setdefault("machine", machine_info())
    for part in parts:
        if part in data:
            print(f"{part}: recorded in {args.json}")
            continue
        data[part] = globals()[f"part_{part}"]()
        _save(args.json, data)


if __name__ == "__main__":
    main()
