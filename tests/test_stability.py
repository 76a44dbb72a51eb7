"""Stability against every perturbation (analyses/stability.py, issue 56): the
half model's symmetric problem and the antisymmetric problem on the same half
mesh together are the whole sheet."""
import numpy as np
import pytest
import scipy.sparse as sp

from skfem_sheet import Sheet, solve
from skfem_sheet.analyses.stability import (
    antisymmetric_problem_dofs,
    antisymmetric_stability,
    antisymmetric_tangent,
    mode_kind,
)
from skfem_sheet.linalg import available_solvers, make_linear_solver
from skfem_sheet.solve import build_problem

pytestmark = pytest.mark.skipif("pardiso" not in available_solvers(),
                                reason="the counts are read off PARDISO's inertia")


def _pencil(problem, kind):
    """``(K, M, m)`` of the half model's symmetric or antisymmetric problem or
    the whole sheet's (``kind`` "full"): the constrained Hessian's pencil with
    ``M`` the identity on the displacement dofs (on a half mesh 1/2 on the
    symmetry plane, whose nodes the two halves share), ``m`` free pressures."""
    plane = np.zeros(problem.ndof, bool)
    if problem.sheet_mesh.half:
        plane[3 * problem.space.symmetry_nodes[:, None] + np.arange(3)] = True
    if kind == "antisymmetric":
        free, _, extra = antisymmetric_problem_dofs(problem)
        dofs = np.concatenate([free[np.isin(free, extra, invert=True)], extra])
    else:
        dofs = problem.free
    M = sp.diags(np.where(dofs < problem.nu_dof, np.where(plane[dofs], 0.5, 1.0), 0.0))
    return dofs, M, int(np.count_nonzero(dofs >= problem.nu_dof))


def _factorized(A):
    """``A`` factorised by PARDISO, or by SuperLU where PARDISO perturbed
    pivots (its inertia is then unknown: near an eigenvalue of the pencil)."""
    for name in ("pardiso", "superlu"):
        linear = make_linear_solver(name)
        linear.factorize(A.tocsr())
        if linear.inertia() is not None:
            return linear
    raise AssertionError("no inertia")


def _below(K, M, m, shift):
    """Eigenvalues of the constrained pencil below ``shift`` (Sylvester)."""
    return _factorized(K - shift * M).inertia()[1] - m


def test_the_whole_sheets_spectrum_is_the_symmetric_and_antisymmetric_problems_together():
    """At a mirror-symmetric equilibrium the whole sheet's Hessian splits into
    a symmetric and an antisymmetric block (the half model's two problems, up
    to a congruence that scales the symmetry plane's rows): the number of the
    whole sheet's eigenvalues below any shift is the sum of the two problems'
    counts.  Checked at the end state of a curved sheet under its weight at
    shifts that put 0 to about 30 eigenvalues below (measured 0, 4, 11, 16,
    28), so that the antisymmetric problem is tested well beyond its
    stability count."""
    sheet = Sheet(length=0.8, tip_width=0.7, curvature=2.5)
    half = solve(sheet, hmax=0.2, start="path")
    full = solve(sheet, hmax=0.2, start="path", symmetric=False)
    assert half.deflection == pytest.approx(full.deflection, abs=1e-9)
    ph, pf = half.problem, full.problem
    Ks, Ka, Kf = ph.tangent(half.w), antisymmetric_tangent(ph, half.w), pf.tangent(full.w)
    (_, Ms, ms), (_, Ma, ma), (_, Mf, mf) = (_pencil(ph, "symmetric"),
                                             _pencil(ph, "antisymmetric"), _pencil(pf, "full"))
    counts = []
    for shift in (0.0, 0.01, 0.05, 0.1, 0.3):
        s, a, f = _below(Ks, Ms, ms, shift), _below(Ka, Ma, ma, shift), _below(Kf, Mf, mf, shift)
        assert s + a == f, (shift, s, a, f)
        counts.append(f)
    assert counts[0] == 0 and counts[-1] >= 20 and counts == sorted(counts)
    assert half.negative_eigenvalues == (0, 0) and half.stable is True
    assert full.negative_eigenvalues == (0, None) and full.stable is True


def test_the_first_antisymmetric_mode_of_a_flat_cantilever_is_a_twist():
    """A thin flat cantilever's softest antisymmetric deformation is torsion
    (its stiffness goes like h^3, in-plane bending's like a^2 h): shifted just
    past the antisymmetric problem's first eigenvalue (found by bisection on
    the inertia), one eigenvalue is negative and its mode is named a twist;
    below it none is, and no mode is named."""
    p = build_problem(Sheet(length=0.8), 0.2, half=True)
    w = np.zeros(p.ndof)
    K = antisymmetric_tangent(p, w)
    dofs, M, m = _pencil(p, "antisymmetric")
    lo, hi = 0.0, 1.0
    assert _below(K, M, m, lo) == 0 and _below(K, M, m, hi) >= 1
    for _ in range(30):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if _below(K, M, m, mid) == 0 else (lo, mid)
    is_u, components = dofs < p.nu_dof, dofs % 3
    for shift, kind in ((hi * (1 + 1e-3), "twisting"), (lo * (1 - 1e-3), "")):
        assert mode_kind(_factorized(K - shift * M), is_u, components) == kind
    assert antisymmetric_stability(p, w).negative_eigenvalues == 0
