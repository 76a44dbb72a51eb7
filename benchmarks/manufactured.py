"""Method of manufactured solutions for the sheet's discretisation (issue 13, item 1).

    python benchmarks/manufactured.py [--base-hmax 0.25] [--refinements 2]
        [--json benchmarks/results/accuracy/manufactured.json]
        [--txt benchmarks/results/accuracy/manufactured.txt] [--png benchmarks/results/accuracy/manufactured.png]

The package's own discrete problem (Taylor-Hood P2-P1 tetrahedra, its residual,
tangent, gravity load and clamp) is solved with extra data that make smooth
exact fields ``U*``, ``p*`` the solution of the continuous problem, on nested
meshes of a rectangular sheet; the errors are measured against the exact fields.

Continuous problem as the package assembles it (``skfem_sheet/problem.py``, ``skfem_sheet/kernels.py``)::

    R_u(v) = int P(F, p) : grad v dV + g int v_z dV          (weight density 1, load factor g)
    R_p(q) = - int (J - 1) q dV
    P = mu F - (mu + p J) F^{-T}                              (p: the package's pressure,
                                                               p_paper - mu)

with the clamp ``U = U0(y, z; kappa)`` (``clamp_displacement``) on ``x = 0`` and
all other faces free.  For exact fields ``U*``, ``p*`` the manufactured data are
(sympy, :func:`manufactured_fields`)::

    body force  b = - Div P* + g e_z                          in the sheet
    traction    t = P* N                                      on x = L, y = +-w/2, z = +-h/2
    source      s = J* - 1                                    in the constraint J - 1 = s

and the discrete problem solved is ``R_pkg(w) - [int b.v + int_free t.v ; - int s q] = 0``
(the extra terms do not depend on ``w``: Newton with the package's tangent).

Exact fields: the mid-line is bent into a circular arc of curvature ``k_b``
(rotation ``k_b L`` at the tip), the cross-section is twisted by ``tau x`` and, as
at the clamp, wrapped onto the cylinder of radius ``R = 1 / kappa``::

    phi*(X) = c(x) + R_y(k_b x) R_x(tau x) (0, (R - z) sin(y/R), R - (R - z) cos(y/R))
    c(x) = (sin(k_b x) / k_b, 0, -(1 - cos(k_b x)) / k_b),   U* = phi* - X

which equals the clamp's ``U0`` at ``x = 0`` for the clamp curvature ``kappa``.  The
rotations are large (69 degrees of bending and 46 degrees of twist at the tip by
default).  The pressure (the package's variable) is
``p* = mu (0.2 (sin(2x + 1/2) cos 3y + 2 z cos x) - 0.2)``.  With larger
pressures, or without the negative offset, the exact state is an unstable
equilibrium under the dead manufactured loads (the tangent has more negative
eigenvalues than there are pressure dofs) and Newton stalls on the coarse meshes.

Measured: ``||U_h - U*||`` in L2 and H1, ``||p_h - p*||`` in L2 (quadrature of order
6 on every tetrahedron), and the tip value ``U_z`` at the centre of the free edge
``(L, 0, 0)`` (a vertex of every mesh).  Expected orders for P2-P1: 3, 2, 2 and at
least 2.

Meshes: ``sheet_mesh(..., half=False, refine=k)``, nested refinements of one base
mesh (every edge halved k times in all three directions, ratio exactly 2); the
abscissa ``h`` is the nominal size ``base_hmax / 2**k``.  Default: base hmax 0.25,
k = 0, 1, 2 (1668, 10920 and 78588 unknowns, about 2.2 GB and 40 s); the default-suite
test ``tests/test_manufactured.py`` runs base hmax 0.5 (654 .. 29100 unknowns).
Refining the default once more (about 580k unknowns) does not fit in the memory
budget of the shared machine.

All use of the package's internals is in :class:`PackageAdapter` below.
"""
from __future__ import annotations

import math
import os
import sys
import time

import numpy as np
import scipy.sparse.linalg as spla
import skfem
import sympy
from skfem import Basis, FacetBasis

from skfem_sheet import Sheet
from skfem_sheet.io import atomic_write, dumps_json
from skfem_sheet.mesh import sheet_mesh
from skfem_sheet.params import ParameterError
from skfem_sheet.problem import SheetProblem

from harness import parser

HERE = os.path.dirname(os.path.abspath(__file__))
RESULTS = os.path.join(HERE, "results", "accuracy")

#: The case: a thick rectangle, moderate modulus, curved clamp, full gravity.
CASE = dict(length=1.0, tip_width=1.0, curvature=2.5, thickness=0.2, modulus=30.0)
#: Exact-field parameters: bending curvature of the mid-line, twist rate, pressure amplitude / mu.
FIELD = dict(bend=1.2, twist=0.8, pressure=0.2, offset=-0.2)
GRAVITY = 1.0
DATA_ORDER = 6      # quadrature order of the manufactured data and of the error norms
TARGETS = dict(u_l2=2.7, u_h1=1.8, p_l2=1.8, tip=1.8)
CHUNK = 20000       # points per evaluation of the exact fields


# ----------------------------------------------------------------------------
# the one place that knows the package's internals (names change with the
# model.py split: update here only)
# ----------------------------------------------------------------------------
class PackageAdapter:
    """The package's discrete problem of one sheet on one mesh, seen through
    the few operations the manufactured-solution study needs.

    Parameters
    ----------
    sheet : skfem_sheet.Sheet
    mesh : skfem_sheet.mesh.SheetMesh
        A full (not half) mesh.
    quadrature_order : int
        The package's quadrature order (its default is 2).
    """

    def __init__(self, sheet, mesh, quadrature_order=2):
        self._pb = SheetProblem(sheet, mesh, quadrature_order)
        pb = self._pb
        self.mesh = mesh.mesh                  # skfem.MeshTet
        self.element_u = pb.basis_u.elem       # skfem ElementTetP2 (displacement, per component)
        self.element_p = pb.basis_p.elem       # skfem ElementTetP1 (pressure)
        self.nodes = pb.nodes                  # (n_nodes, 3) P2 node coordinates
        self.n_nodes = pb.n_nodes
        self.n_vertices = pb.n_vertices
        self.ndof = pb.ndof
        self.free = pb.free                    # free dofs (the tangent's rows and columns)
        self.clamp_dofs = pb.clamp_dofs        # fixed dofs (x = 0); a full mesh has no others
        if len(pb.fixed) != len(pb.clamp_dofs):
            raise ValueError("PackageAdapter needs a full mesh (no symmetry plane)")

    def join(self, U, p):
        """State vector from nodal displacements (n_nodes, 3) and vertex pressures.

        Layout: displacement dofs node by node (``3 node + component``), then
        the vertex pressures (``p`` in the package's convention).
        """
        return np.concatenate([np.asarray(U, float).ravel(), np.asarray(p, float)])

    def split(self, w):
        """Nodal displacements (n_nodes, 3) and vertex pressures of ``w``."""
        return self._pb.split(w)

    def clamp_values(self, kappa):
        """Values of the clamped dofs for clamp curvature ``kappa``."""
        return self._pb.clamp_values(kappa)

    def residual(self, w, g):
        """The package's full residual vector at gravity factor ``g``."""
        r, jmin = self._pb.residual(w, g)
        if not jmin > 0:
            raise FloatingPointError(f"inverted element (min det F = {jmin:g})")
        return r

    def tangent(self, w):
        """The package's tangent on the free dofs (CSR)."""
        return self._pb.tangent(w)


# ----------------------------------------------------------------------------
# exact fields and manufactured data (sympy)
# ----------------------------------------------------------------------------
def manufactured_fields(kappa, mu, gravity=GRAVITY, bend=FIELD["bend"], twist=FIELD["twist"],
                        pressure=FIELD["pressure"], offset=FIELD["offset"]):
    """Exact fields and manufactured data as numpy functions of ``X`` (3, ...).

    Returns
    -------
    dict of callables
        ``U`` (3, ...), ``gradU`` (3, 3, ...), ``p`` (...), ``P`` (3, 3, ...)
        (first Piola stress), ``body`` (3, ...) ``= -Div P + g e_z``,
        ``source`` (...) ``= J - 1``.
    """
    if not kappa > 0:
        raise ParameterError(f"kappa must be in (0, 2 pi) (the clamp wraps the section on a "
                             f"cylinder of radius 1/kappa), got {kappa!r}")
    if not bend > 0:
        raise ParameterError(f"bend must be positive (curvature of the bent mid-line), "
                             f"got {bend!r}")
    x, y, z = sympy.symbols("x y z", real=True)
    X = sympy.Matrix([x, y, z])
    R = 1 / sympy.nsimplify(kappa)
    kb, tw = sympy.nsimplify(bend), sympy.nsimplify(twist)
    section = sympy.Matrix([0, (R - z) * sympy.sin(y / R), R - (R - z) * sympy.cos(y / R)])
    th, al = kb * x, tw * x
    Ry = sympy.Matrix([[sympy.cos(th), 0, sympy.sin(th)], [0, 1, 0],
                       [-sympy.sin(th), 0, sympy.cos(th)]])
    Rx = sympy.Matrix([[1, 0, 0], [0, sympy.cos(al), -sympy.sin(al)],
                       [0, sympy.sin(al), sympy.cos(al)]])
    c = sympy.Matrix([sympy.sin(th) / kb, 0, -(1 - sympy.cos(th)) / kb])
    phi = c + Ry * Rx * section
    U = phi - X
    mu_s = sympy.nsimplify(mu)
    amp = sympy.nsimplify(pressure) * mu_s
    p = amp * (sympy.sin(2 * x + sympy.Rational(1, 2)) * sympy.cos(3 * y) + 2 * z * sympy.cos(x)) \
        + sympy.nsimplify(offset) * mu_s
    F = phi.jacobian(X)
    J = F.det(method="berkowitz")
    cof = F.adjugate().T          # cof F = J F^{-T}
    P = mu_s * F - (mu_s / J + p) * cof
    div = sympy.Matrix([sum(sympy.diff(P[i, j], X[j]) for j in range(3)) for i in range(3)])
    body = -div + sympy.Matrix([0, 0, sympy.nsimplify(gravity)])
    gradU = U.jacobian(X)

    def lam(expr, shape):
        f = sympy.lambdify((x, y, z), expr, modules="numpy", cse=True)

        def call(Xq):
            # in chunks of points: the common subexpressions of the stress are
            # hundreds of temporaries of the size of the input
            Xq = np.asarray(Xq, float)
            pts = Xq.reshape(3, -1)
            full = np.empty(shape + (pts.shape[1],))
            for lo in range(0, pts.shape[1], CHUNK):
                sl = slice(lo, lo + CHUNK)
                out = f(pts[0, sl], pts[1, sl], pts[2, sl])
                if not shape:
                    full[sl] = out
                    continue
                out = np.asarray(out, dtype=object)
                for idx in np.ndindex(*shape):
                    full[idx + (sl,)] = out[idx]
            return full.reshape(shape + Xq.shape[1:])
        return call

    return dict(U=lam(list(U), (3,)), gradU=lam(gradU.tolist(), (3, 3)), p=lam(p, ()),
                P=lam(P.tolist(), (3, 3)), body=lam(list(body), (3,)), source=lam(J - 1, ()))


# ----------------------------------------------------------------------------
# one mesh
# ----------------------------------------------------------------------------
def _scalar_load(basis, values, n):
    """``int values * phi_a`` for every scalar basis function ``a`` of ``basis``
    (values at its quadrature points, shape (n_elements, n_points)), length ``n``."""
    dx = np.asarray(basis.dx)
    local = np.stack([np.sum(dx * values * np.asarray(basis.basis[a][0]), axis=1)
                      for a in range(basis.Nbfun)])                 # (Nbfun, n_elements)
    return np.bincount(basis.element_dofs.ravel(), weights=local.ravel(), minlength=n)


def manufactured_load(ad: PackageAdapter, fields, length, order=DATA_ORDER):
    """The manufactured terms ``[int b.v + int_free t.v ; - int s q]`` on the
    problem's own dofs (quadrature of order ``order``)."""
    bu = Basis(ad.mesh, ad.element_u, intorder=order)
    bp = Basis(ad.mesh, ad.element_p, intorder=order)
    if not np.allclose(bu.doflocs.T, ad.nodes):
        raise AssertionError("the data basis does not number the nodes like the problem")
    tol = 1e-9 * max(1.0, length)
    free_faces = ad.mesh.facets_satisfying(lambda x: x[0] > tol, boundaries_only=True)
    fb = FacetBasis(ad.mesh, ad.element_u, facets=free_faces, intorder=order)
    body = fields["body"](np.asarray(bu.global_coordinates()))              # (3, nel, nq)
    trac = np.einsum("ijfq,jfq->ifq", fields["P"](np.asarray(fb.global_coordinates())),
                     np.asarray(fb.normals))                                # P N, (3, nf, nq)
    fu = np.zeros((ad.n_nodes, 3))
    for i in range(3):
        fu[:, i] = (_scalar_load(bu, body[i], ad.n_nodes)
                    + _scalar_load(fb, trac[i], ad.n_nodes))
    fp = -_scalar_load(bp, fields["source"](np.asarray(bp.global_coordinates())), ad.n_vertices)
    return np.concatenate([fu.ravel(), fp])


def _linear_solve(K, rhs):
    try:
        import pypardiso  # optional: faster than SuperLU on the larger meshes
    except ImportError:
        return spla.spsolve(K.tocsc(), rhs)
    return pypardiso.spsolve(K, rhs)


def solve_manufactured(ad: PackageAdapter, fields, kappa, load, gravity=GRAVITY, rtol=1e-10,
                       max_iter=30, max_halvings=12):
    """Newton on ``R_pkg(w) - load = 0`` from the interpolant of the exact fields.

    Returns ``(w, iterations, residual norms)``.
    """
    X = ad.nodes.T
    U0 = fields["U"](X).T
    p0 = fields["p"](ad.mesh.p)
    w = ad.join(U0, p0)
    w[ad.clamp_dofs] = ad.clamp_values(kappa)
    norms = []
    r = (ad.residual(w, gravity) - load)[ad.free]
    ref = max(float(np.linalg.norm(r)), float(np.linalg.norm(load[ad.free])))
    for it in range(max_iter + 1):
        norms.append(float(np.linalg.norm(r)))
        if norms[-1] <= rtol * ref:
            return w, it, norms
        delta = _linear_solve(ad.tangent(w), r)
        # backtracking: halve the step while it inverts an element or raises the residual
        for _ in range(max_halvings):
            trial = w.copy()
            trial[ad.free] -= delta
            try:
                r_trial = (ad.residual(trial, gravity) - load)[ad.free]
            except FloatingPointError:
                delta *= 0.5
                continue
            if np.linalg.norm(r_trial) < norms[-1] or np.linalg.norm(r_trial) <= rtol * ref:
                break
            delta *= 0.5
        else:
            raise RuntimeError(f"Newton step rejected {max_halvings} times: norms {norms}")
        w, r = trial, r_trial
    raise RuntimeError(f"Newton did not converge: residual norms {norms}")


def errors(ad: PackageAdapter, fields, w, length):
    """L2 and H1 errors of U, L2 error of p, and the tip value against the exact fields."""
    U, p = ad.split(w)
    bu = Basis(ad.mesh, ad.element_u, intorder=DATA_ORDER)
    bp = Basis(ad.mesh, ad.element_p, intorder=DATA_ORDER)
    Xq = np.asarray(bu.global_coordinates())           # (3, nel, nq)
    dx = np.asarray(bu.dx)
    Ue, Ge = fields["U"](Xq), fields["gradU"](Xq)
    l2 = h1s = 0.0
    for i in range(3):
        f = bu.interpolate(U[:, i])
        l2 += float(np.sum(dx * (np.asarray(f) - Ue[i]) ** 2))
        h1s += float(np.sum(dx * np.sum((f.grad - Ge[i]) ** 2, axis=0)))
    fp = bp.interpolate(p)
    pe = fields["p"](np.asarray(bp.global_coordinates()))
    pl2 = float(np.sum(np.asarray(bp.dx) * (np.asarray(fp) - pe) ** 2))
    tol = 1e-9 * max(1.0, length)
    tip = np.flatnonzero((np.abs(ad.nodes[:, 0] - length) < tol) & (np.abs(ad.nodes[:, 1]) < tol)
                         & (np.abs(ad.nodes[:, 2]) < tol))
    if len(tip) != 1:
        raise RuntimeError("no node at the centre of the free edge (L, 0, 0)")
    tip_exact = float(fields["U"](np.array([[length], [0.0], [0.0]]))[2, 0])
    tip_h = float(U[tip[0], 2])
    # norms of the exact fields, for relative errors
    u_norm = math.sqrt(float(np.sum(dx * np.sum(Ue ** 2, axis=0))))
    p_norm = math.sqrt(float(np.sum(np.asarray(bp.dx) * pe ** 2)))
    return dict(u_l2=math.sqrt(l2), u_h1=math.sqrt(l2 + h1s), p_l2=math.sqrt(pl2),
                tip=abs(tip_h - tip_exact), tip_value=tip_h, tip_exact=tip_exact,
                u_l2_norm=u_norm, p_l2_norm=p_norm)


def run_mesh(base_hmax, refine, case=CASE, quadrature_order=2, fields=None):
    """Solve the manufactured problem on ``sheet_mesh(..., refine=refine)``; one record."""
    sheet = Sheet(**case)
    if fields is None:
        fields = manufactured_fields(sheet.curvature, sheet.mu)
    t0 = time.perf_counter()
    mesh = sheet_mesh(sheet, base_hmax, half=False, refine=refine)
    ad = PackageAdapter(sheet, mesh, quadrature_order)
    load = manufactured_load(ad, fields, sheet.length)
    w, its, norms = solve_manufactured(ad, fields, sheet.curvature, load)
    err = errors(ad, fields, w, sheet.length)
    return dict(h=base_hmax / 2 ** refine, base_hmax=base_hmax, refine=refine,
                layers=mesh.layers, elements=mesh.n_elements, dofs=int(ad.ndof),
                newton_iterations=its, residual_norms=norms,
                wall_time_s=time.perf_counter() - t0, peak_rss_gb=_peak_rss_gb(), **err)


def _peak_rss_gb():
    """High-water mark of this process's resident memory (GB; cumulative over the meshes)."""
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0 ** 2


def fitted_rates(runs, last=3):
    """Least-squares slopes of log(error) against log(h) over the ``last`` finest meshes."""
    runs = sorted(runs, key=lambda r: -r["h"])[-last:]
    h = np.log([r["h"] for r in runs])
    out = {}
    for key in TARGETS:
        e = np.array([r[key] for r in runs])
        out[key] = float(np.polyfit(h, np.log(e), 1)[0]) if np.all(e > 0) else None
    return out


def study(base_hmax=0.5, refinements=3, case=CASE, quadrature_order=2, fit_last=3, log=None):
    """All meshes ``refine = 0 .. refinements`` and the fitted rates (a JSON-ready dict)."""
    sheet = Sheet(**case)
    fields = manufactured_fields(sheet.curvature, sheet.mu)
    runs = []
    for k in range(refinements + 1):
        runs.append(run_mesh(base_hmax, k, case, quadrature_order, fields))
        if log:
            r = runs[-1]
            log(f"h {r['h']:.4f}: {r['dofs']} dofs, {r['newton_iterations']} Newton, "
                f"{r['wall_time_s']:.1f} s")
    rates = fitted_rates(runs, fit_last)
    passed = {k: rates[k] is not None and rates[k] >= t for k, t in TARGETS.items()}
    return dict(case=dict(case, gravity=GRAVITY, clamp="clamp_displacement(kappa=curvature)",
                          quadrature_order=quadrature_order, data_quadrature_order=DATA_ORDER),
                field=dict(FIELD), base_hmax=base_hmax, refinements=refinements,
                fit_last=min(fit_last, len(runs)), meshes=runs, rates=rates,
                local_rates=[fitted_rates(runs[k:k + 2], 2) for k in range(len(runs) - 1)],
                targets=dict(TARGETS), passed=passed, all_passed=all(passed.values()),
                versions=dict(skfem=skfem.__version__, sympy=sympy.__version__))


def table(res):
    c = res["case"]
    lines = [f"manufactured solution: L/a={c['length']:g}, w/a={c['tip_width']:g}, "
             f"h/a={c['thickness']:g}, mu={c['modulus'] / 3:g}, clamp a/R={c['curvature']:g}, "
             f"g={c['gravity']:g}; U* bent (k_b={res['field']['bend']:g}) and twisted "
             f"(tau={res['field']['twist']:g}); nested refinements of hmax {res['base_hmax']:g}",
             f"{'h':>7s} {'layers':>6s} {'dofs':>7s} {'newton':>6s} {'|U|L2':>10s} "
             f"{'|U|H1':>10s} {'|p|L2':>10s} {'tip err':>10s} {'wall s':>7s}"]
    lines.append("-" * len(lines[-1]))
    for r in res["meshes"]:
        lines.append(f"{r['h']:7.4f} {r['layers']:6d} {r['dofs']:7d} {r['newton_iterations']:6d} "
                     f"{r['u_l2']:10.3e} {r['u_h1']:10.3e} {r['p_l2']:10.3e} {r['tip']:10.3e} "
                     f"{r['wall_time_s']:7.1f}")
    lines.append("")
    lines.append("rates between consecutive meshes: " + "; ".join(
        ", ".join(f"{k} {v:.2f}" for k, v in lr.items() if v is not None)
        for lr in res["local_rates"]))
    lines.append(f"fitted rates over the {res['fit_last']} finest meshes:")
    for k, t in res["targets"].items():
        v = res["rates"][k]
        lines.append(f"  {k:5s} {v:6.3f}  target >= {t:g}  "
                     f"{'PASS' if res['passed'][k] else 'FAIL'}")
    return "\n".join(lines) + "\n"


def plot(res, png):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    h = np.array([r["h"] for r in res["meshes"]])
    fig, ax = plt.subplots(figsize=(5.5, 4.2))
    labels = dict(u_l2="U, L2", u_h1="U, H1", p_l2="p, L2", tip="tip U_z")
    for key, lab in labels.items():
        e = np.array([r[key] for r in res["meshes"]])
        ax.loglog(h, e, "o-", label=f"{lab}: slope {res['rates'][key]:.2f}")
    for order, ls in ((2, ":"), (3, "--")):
        ax.loglog(h, res["meshes"][-1]["u_h1"] * (h / h[-1]) ** order, "k", ls=ls, lw=0.8,
                  label=f"h^{order}")
    ax.set_xlabel("h / a (hmax / 2^refine)")
    ax.set_ylabel("error")
    ax.set_title("manufactured solution, Taylor-Hood P2-P1", fontsize=9)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(png, dpi=130)
    plt.close(fig)


def main(argv=None):
    ap = parser(__doc__)
    ap.add_argument("--base-hmax", type=float, default=0.25,
                    help="hmax of the base mesh (default 0.25)")
    ap.add_argument("--refinements", type=int, default=2, help="refine = 0 .. K (default 2)")
    ap.add_argument("--fit-last", type=int, default=3, help="meshes in the fitted slope")
    ap.add_argument("--quadrature-order", type=int, default=2,
                    help="the package's quadrature order (its default 2)")
    ap.add_argument("--json", default=os.path.join(RESULTS, "manufactured.json"))
    ap.add_argument("--txt", default=os.path.join(RESULTS, "manufactured.txt"))
    ap.add_argument("--png", default=os.path.join(RESULTS, "manufactured.png"))
    args = ap.parse_args(argv)
    if args.refinements < 2:
        ap.error("--refinements must be at least 2")
    res = study(args.base_hmax, args.refinements, quadrature_order=args.quadrature_order,
                fit_last=args.fit_last, log=lambda s: print(s, file=sys.stderr, flush=True))
    text = table(res)
    print(text, end="")
    if args.json:
        atomic_write(args.json, dumps_json(res, indent=1))
    if args.txt:
        atomic_write(args.txt, text)
    if args.png:
        plot(res, args.png)
    return 0 if res["all_passed"] else 1


if __name__ == "__main__":
    sys.exit(main())
