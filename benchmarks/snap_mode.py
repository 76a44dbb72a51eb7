"""What the Newton corrections of the issue-17 sheet's curvature ramp are
(issue 17, item 3: why every accepted step costs 3-8 iterations).

Usage::

    OMP_NUM_THREADS=1 MKL_CBWR=COMPATIBLE python benchmarks/snap_mode.py [HMAX] [QUADRATURE_ORDER]

Solves ``Sheet(length=1.299, tip_width=0.633, curvature=5.112, thickness=0.02,
modulus=400)`` gravity-first (default hmax 0.08, quadrature order 2) and prints

1. every Newton correction of the curvature phase: its largest nodal
   displacement, the median of the nodal maxima, the mean correction of the
   tip edge ``X = L`` and the residual norm at the iterate;
2. at the accepted states up to the fold, the four lowest eigenvalues of
   ``K v = lambda M v`` on the incompressible subspace (``M`` the
   displacement mass matrix, as in the pseudo-transient shift), how spread
   the lowest mode is, and (at two states) how its eigenvalue grows when the
   state is moved along the mode by the size of a Newton correction;
3. the error of the tangent predictor (from the exact tangent at each
   accepted state) against the next accepted state;
4. for each converged Newton solve, the distance of every iterate from the
   state it converged to (largest nodal value and the tip-edge mean of
   ``x``), and where the first iterate (the predictor) is furthest from it;
5. the energy density along the centre line (elements with ``Y < 0.08``,
   bins of 0.04 in ``X``, relative to the peak) at the accepted states: the
   localised ridge and how it moves.

A diagnosis script: nothing is asserted; the numbers are recorded in
benchmarks/results/snap_issue17_sheet_hmax0.08.txt.
"""
import sys

import numpy as np
import scipy.sparse.linalg as spla

from skfem_sheet import Sheet, solve
from skfem_sheet import continuation as cont
from skfem_sheet import newton as nw
from skfem_sheet.linalg import make_linear_solver
from skfem_sheet.newton import Stats

SHEET = Sheet(length=1.299, tip_width=0.633, curvature=5.112, thickness=0.02, modulus=400)


def main(hmax=0.08, quadrature_order=2):
    log, states, held, calls = [], {}, {}, []
    linearize = nw._SheetNewton.linearize
    newton = cont.newton

    def recorded_newton(problem, w, g, solver, opts, stats, **kw):
        calls.append([])
        res = newton(problem, w, g, solver, opts, stats, **kw)
        calls[-1] = (calls[-1], res)
        return res

    def logged_linearize(self, w, p):
        calls[-1].append(w.copy())
        out = linearize(self, w, p)
        pr = self.problem
        U = out[1][: pr.nu_dof].reshape(-1, 3)
        tip = np.isclose(pr.nodes[:, 0], pr.nodes[:, 0].max())
        nodal = np.abs(U).max(axis=1)
        j = int(np.argmax(nodal))
        log.append(f"   |du| {nodal.max():.2e} at X={np.round(pr.nodes[j], 3).tolist()}  "
                   f"median {np.median(nodal):.2e}  tip-edge mean (x, z) "
                   f"({U[tip, 0].mean():+.2e}, {U[tip, 2].mean():+.2e})  |r| {out[0]:.2e}  "
                   f"max |dp| {np.abs(out[1][pr.nu_dof:]).max():.2e}")
        return out

    follow = cont.follow_path

    def recorded_follow(problem, path, kappa, solver, **kw):
        held.update(problem=problem, kappa=kappa)

        def on_step(pr, w, k, g):
            states[k / kappa if kappa else 0.0] = w.copy()
            log.append(f"accepted kappa={k:.5g} (lam {k / kappa:.4f}), g={g:g}")
        kw["on_step"] = on_step
        return follow(problem, path, kappa, solver, **kw)

    solve_module = sys.modules["skfem_sheet.solve"]
    nw._SheetNewton.linearize = logged_linearize
    solve_module.follow_path = recorded_follow
    cont.newton = recorded_newton
    try:
        r = solve(SHEET, path="gravity-first", hmax=hmax, quadrature_order=quadrature_order)
    finally:
        nw._SheetNewton.linearize = linearize
        solve_module.follow_path = follow
        cont.newton = newton
    print(f"d = {r.deflection!r}, {r.newton_iterations} Newton iterations, "
          f"{r.factorizations} factorisations, stable={r.stable}, snaps={r.snaps}")
    print("\n## 1. Newton corrections (each line one linearisation)")
    print("\n".join(log))

    pr, kappa = held["problem"], held["kappa"]
    free = pr.free
    nuf = free < pr.nu_dof
    M = pr.assembler.matrix(pr.mass_data)
    tip = np.isclose(pr.nodes[:, 0], pr.nodes[:, 0].max())

    def lowest(w, k=4):
        solver = make_linear_solver("superlu")
        solver.factorize(pr.tangent(w), w)
        n = len(free)
        op = spla.LinearOperator((n, n), matvec=lambda x: solver.solve(M @ x), dtype=float)
        mu, V = spla.eigs(op, k=k, which="LM", v0=solver.solve(M @ np.ones(n)), tol=1e-8)
        lam = 1.0 / mu.real
        order = np.argsort(lam)
        return lam[order], V[:, order].real

    lams = sorted(lam for lam in states if 0.0 < lam)
    print("\n## 2. Lowest eigenvalues of K v = lambda M v at accepted states")
    for i, lam in enumerate(lams):
        if lam < 0.6 or lam > 0.9:
            continue
        w = states[lam]
        ev, V = lowest(w)
        v = np.zeros(pr.ndof)
        v[free] = V[:, 0] / np.abs(V[nuf, 0]).max()
        U = v[: pr.nu_dof].reshape(-1, 3)
        nodal = np.abs(U).max(axis=1)
        print(f"lam {lam:.4f}: eigenvalues {np.round(ev, 4).tolist()}; lowest mode: "
              f"{np.mean(nodal > 0.5):.0%} of the nodes above half its maximum, tip-edge mean "
              f"(x, z) = ({U[tip, 0].mean():+.3f}, {U[tip, 2].mean():+.3f})")
        if i in (len(lams) // 3, 2 * len(lams) // 3):
            for amp in (0.01, 0.03, 0.05):
                lb, _ = lowest(w + amp * v, 2)
                rb, _ = pr.residual(w + amp * v, 1.0)
                print(f"   moved by {amp} along the mode: lowest eigenvalue {lb[0]:.4g} "
                      f"(at the state {ev[0]:.4g}), |r| {np.linalg.norm(rb[free]):.2e}")

    print("\n## 3. Tangent predictor (exact tangent at the accepted state) vs the next state")
    load = cont.load_phases("gravity-first", kappa)[1][1]
    solver, stats = make_linear_solver("superlu"), Stats()
    nu = pr.nu_dof
    for lam0, lam1 in zip(lams[:-1], lams[1:]):
        if lam0 >= 0.89:
            break
        w0, w1 = states[lam0], states[lam1]
        solver.factorize(pr.tangent(w0), w0)
        dk, dg = cont._load_rate(load, lam0)
        dw = cont._tangent_predictor(pr, w0, dk, dg, load(lam0)[0], solver, stats)
        wp = w0 + (lam1 - lam0) * dw
        wp[pr.clamp_dofs] = pr.clamp_values(load(lam1)[0])
        print(f"lam {lam0:.4f} -> {lam1:.4f}: step max|dw| {np.abs((w1 - w0)[:nu]).max():.3e}, "
              f"predictor error max {np.abs((wp - w1)[:nu]).max():.3e}")

    print("\n## 4. Distance of the Newton iterates from the converged state")
    for iterates, res in (c for c in calls if isinstance(c, tuple)):
        if not res.converged or len(iterates) < 3:
            continue
        err = [(w - res.w)[:nu] for w in iterates]
        first = np.abs(err[0]).reshape(-1, 3).max(axis=1)
        j = int(np.argmax(first))
        print("max " + " ".join(f"{np.abs(e).max():.1e}" for e in err)
              + " | tip x " + " ".join(f"{e.reshape(-1, 3)[tip, 0].mean():+.1e}" for e in err)
              + f" | predictor furthest at X={np.round(pr.nodes[j], 3).tolist()}")

    print("\n## 5. Energy density along the centre line (bins of 0.04 in X from 0.32)")
    centre = pr.nodes[pr.space.element_nodes[:, :4]].mean(axis=1)
    line = centre[:, 1] < 0.08
    bins = np.round(centre[line, 0] / 0.04).astype(int)
    for lam in lams:
        if lam < 0.6 or lam > 0.9:
            continue
        e = pr.energy_density(states[lam])[line]
        prof = np.array([e[bins == b].mean() if np.any(bins == b) else 0.0 for b in range(34)])
        print(f"lam {lam:.3f}: peak beyond X = 0.32 at X = {0.04 * (8 + int(np.argmax(prof[8:]))):.2f}; "
              f"{np.round(prof[8:26] / prof[8:].max(), 2).tolist()}")


if __name__ == "__main__":
    args = sys.argv[1:]
    main(float(args[0]) if args else 0.08, int(args[1]) if len(args) > 1 else 2)
