"""The free-c ribbon model against the heavy elastica at zero clamp curvature, with the evidence.

Run:  python benchmarks/ribbon_vs_elastica.py [--with-3d]
      (writes the tables to stdout; the recorded output is results/accuracy/ribbon_vs_elastica.txt)

Sections: (1) the table ribbon / elastica - 1 for rectangle and triangle, split into the
centre-of-mass drop -int sin phi and the tip term w(L,0) cos phi(L), and the same with
nu = 0; (2) convergence in the number of s-elements; (3) the energy term by term and
c(s) along the sheet at L = 0.5 and 1.5; (4) with --with-3d, the 3D solver's deflection at
hmax 0.03 (one solve at a time, ~20-60 s each on 2 free cores).
"""
from __future__ import annotations

import numpy as np

from skfem_sheet.params import POISSON_RATIO, Sheet
from skfem_sheet.reduced import elastica, ribbon, ribbon_energy_terms
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


def main(argv=None) -> int:
    ap = parser(__doc__)
    ap.add_argument("--with-3d", action="store_true", help="also run the 3D solver")
    args = ap.parse_args(argv)
    print(f"nu = {POISSON_RATIO}, h = 0.03, E/(rho g a) = 735\n")
    table()
    convergence()
    energies()
    if args.with_3d:
        three_d()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
