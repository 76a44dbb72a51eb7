"""The reduced-order models: the free-c ribbon against the heavy elastica at zero clamp
curvature, with the evidence; and (``--speed``) the models' speed.

Run:  python benchmarks/ribbon_vs_elastica.py [--with-3d]
      (writes the tables to stdout; the recorded output is results/accuracy/ribbon_vs_elastica.txt)
      python benchmarks/ribbon_vs_elastica.py --speed [--workers 2] [--quick]
      (only the speed table: one ribbon solve at a new length by continuation, target
      <= 0.2 s; the Fig. 6 map, 50 lengths x 50 shape factors, both continuation
      directions, target <= 60 s on 2 cores; the other models)

Sections: (1) the table ribbon / elastica - 1 for rectangle and triangle, split into the
centre-of-mass drop -int sin phi and the tip term w(L,0) cos phi(L), and the same with
nu = 0; (2) convergence in the number of s-elements; (3) the energy term by term and
c(s) along the sheet at L = 0.5 and 1.5; (4) with --with-3d, the 3D solver's deflection at
hmax 0.03 (one solve at a time, ~20-60 s each on 2 free cores).
"""
from __future__ import annotations

import os
import statistics
import time

import numpy as np

from skfem_sheet.params import POISSON_RATIO, Sheet
from skfem_sheet.reduced import (
    cantilever_deflection,
    elastica,
    persistence_length,
    ribbon,
    ribbon_energy_terms,
    ribbon_map,
)
from skfem_sheet.reduced._ribbon_fem import make_mesh, make_operators, minimise
from skfem_sheet.reduced.ribbon import _deflection, _free_mask

from harness import parser

LENGTHS = (0.5, 0.6, 0.7, 0.8, 1.0, 1.4, 1.8)


def free_c_deflection(sheet, nu, n=24):
    """ribbon() at curvature 0 with a chosen Poisson ratio (same load ramp)."""
    mesh = make_mesh(n)
    x = np.zeros(4 * (n + 1))
    for lam in (0.25, 0.5, 0.75, 1.0):
        ops = make_operators(mesh, sheet.length, sheet.tip_width, sheet.thickness,
                             sheet.stretching_modulus, sheet.bending_modulus, nu, lam)
        x, _, _, _ = minimise(ops, x, _free_mask(n + 1, False))
    return _deflection(ops, x, mesh.S_nodes, sheet.length, sheet.tip_width)


def table():
    print("(1) ribbon (c free, a/R = 0) vs heavy elastica; rel = d_ribbon/d_elastica - 1")
    print(f"{'b':>4} {'L':>5} {'d_elastica':>11} {'d_ribbon':>11} {'rel':>9} "
          f"{'rel(cm)':>9} {'tip term':>9} {'max c':>7} {'rel(nu=0)':>10}")
    for b in (1.0, 0.0):
        for L in LENGTHS:
            s = Sheet(length=L, tip_width=b)
            el, r = elastica(s).deflection, ribbon(s)
            tip = r.c[-1] * b**2 / 24 * np.cos(r.phi[-1]) - r.c[0] / 24 * np.cos(r.phi[0])
            print(f"{b:4.1f} {L:5.2f} {el:11.6f} {r.deflection:11.6f} "
                  f"{r.deflection / el - 1:+9.4%} {(r.deflection - tip) / el - 1:+9.4%} "
                  f"{tip:+9.6f} {np.abs(r.c).max():7.4f} "
                  f"{free_c_deflection(s, 0.0) / el - 1:+10.5%}")
    print("rel(cm): centre-of-mass drop -int sin phi only; tip term: w(L,0) cos phi(L) - "
          "w(0,0) cos phi(0),\nthe t = 0 point's offset below the tip's centre of mass.\n")


def convergence():
    print("(2) convergence in the number of s-elements (cubic Hermite), a/R = 0")
    for b in (1.0, 0.0):
        for L in (0.5, 1.0):
            s = Sheet(length=L, tip_width=b)
            el = elastica(s).deflection
            row = [f"n={n}: {ribbon(s, n_elements=n).deflection / el - 1:+.6%}"
                   for n in (24, 48, 96, 192)]
            print(f"  b={b:.0f} L={L}: " + "  ".join(row))
    print()


def energies():
    print("(3) energy terms (units rho g a^4) and c(s), a/R = 0, rectangle")
    for L in (0.5, 1.5):
        s = Sheet(length=L)
        r, f = ribbon(s), ribbon(s, impose_flat=True)
        ef, e0 = ribbon_energy_terms(s, r), ribbon_energy_terms(s, f)
        print(f"  L = {L}: term, c free, c = 0, (c free)/bending_ss")
        for k in ef:
            print(f"    {k:11s} {ef[k]:+.6e} {e0[k]:+.6e} {ef[k] / ef['bending_ss']:+.4f}")
        idx = np.linspace(0, r.s.size - 1, 7).astype(int)
        dPhi = np.gradient(r.Phi, r.s)
        print("    s      " + " ".join(f"{v:8.3f}" for v in r.s[idx]))
        print("    c      " + " ".join(f"{v:8.5f}" for v in r.c[idx]))
        print("    Phi'   " + " ".join(f"{v:8.4f}" for v in dPhi[idx]))
        beta = np.abs(dPhi[idx]) / s.thickness
        print("    beta   " + " ".join(f"{v:8.2f}" for v in beta)
              + "   (Searle parameter p^2 |Phi'|/h)")
    print()


def three_d():
    from skfem_sheet import solve
    print("(4) 3D solver (hmax 0.03), a/R = 0: rel = d/d_elastica - 1")
    for b, Ls in ((1.0, (0.5, 0.7, 1.0)), (0.0, (0.5, 1.0))):
        for L in Ls:
            s = Sheet(length=L, tip_width=b)
            el, rib = elastica(s).deflection, ribbon(s).deflection
            r = solve(s, hmax=0.03, progress=True)
            print(f"  b={b:.0f} L={L}: d_3d={r.deflection:.6f} ({r.deflection / el - 1:+.3%})  "
                  f"ribbon {rib:.6f} ({rib / el - 1:+.3%})  elastica {el:.6f}  "
                  f"ribbon/3d - 1 = {rib / r.deflection - 1:+.3%}  "
                  f"elastica/3d - 1 = {el / r.deflection - 1:+.3%}  dofs={r.dofs}", flush=True)


def _timeit(fn, repeat=5):
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def continuation_step_time(curvature=2.5, tip_width=1.0, n=40):
    """Median time of one ribbon solve at L + 0.01 from the converged state at L."""
    state = ribbon(Sheet(length=1.0, tip_width=tip_width, curvature=curvature))
    times = []
    for L in 1.0 + 0.01 * np.arange(1, n + 1):
        sheet = Sheet(length=L, tip_width=tip_width, curvature=curvature)
        t0 = time.perf_counter()
        state = ribbon(sheet, initial=state)
        times.append(time.perf_counter() - t0)
        assert state.converged
    return statistics.median(times), max(times)


def speed(workers, quick):
    rows = []
    med, worst = continuation_step_time()
    rows.append(("ribbon solve by continuation (median / max)", f"{med:.4f} / {worst:.4f} s",
                 "<= 0.2 s", worst <= 0.2))
    t = _timeit(lambda: ribbon(Sheet(length=1.3, curvature=2.5)), 3)
    rows.append(("ribbon solve from scratch (load ramp)", f"{t:.4f} s", "", None))
    t = _timeit(lambda: persistence_length(Sheet(length=1.5, tip_width=0.0, curvature=2.5)), 3)
    rows.append(("persistence length (triangle)", f"{t:.4f} s", "", None))
    t = _timeit(lambda: cantilever_deflection(Sheet(length=1.5, tip_width=0.0, curvature=2.5)), 3)
    rows.append(("cantilever estimate", f"{t:.4f} s", "", None))
    t = _timeit(lambda: elastica(Sheet(length=1.0)), 3)
    rows.append(("heavy elastica L=1 (tol 1e-9)", f"{t:.4f} s", "", None))

    n = 20 if quick else 50
    t0 = time.perf_counter()
    table = ribbon_map(2.5, np.linspace(0.8, 2.2, n), np.linspace(0.0, 1.0, n),
                       workers=workers)
    t_map = time.perf_counter() - t0
    bad = sum(not r["converged"] for r in table)
    rows.append((f"Fig. 6 map {n}x{n}, both directions, {workers} workers",
                 f"{t_map:.1f} s ({len(table)} solves, {bad} not converged)",
                 "<= 60 s" if n == 50 else "", (t_map <= 60) if n == 50 else None))

    w = max(len(r[0]) for r in rows)
    print(f"{'benchmark':<{w}}  {'time':<40} {'target':<9} ok")
    for name, val, target, ok in rows:
        flag = "" if ok is None else ("yes" if ok else "NO")
        print(f"{name:<{w}}  {val:<40} {target:<9} {flag}")


def main(argv=None) -> int:
    ap = parser(__doc__)
    ap.add_argument("--with-3d", action="store_true", help="also run the 3D solver")
    ap.add_argument("--speed", action="store_true",
                    help="only the speed of the reduced models (was reduced_speed.py)")
    ap.add_argument("--workers", type=int, default=min(2, os.cpu_count() or 1),
                    help="processes of the --speed map")
    ap.add_argument("--quick", action="store_true", help="--speed: a 20 x 20 map, not 50 x 50")
    args = ap.parse_args(argv)
    if args.speed:
        speed(args.workers, args.quick)
        return 0
    print(f"nu = {POISSON_RATIO}, h = 0.03, E/(rho g a) = 735\n")
    table()
    convergence()
    energies()
    if args.with_3d:
        three_d()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
