"""analyses/: stability from the inertia, the tip deflection."""
import numpy as np
import pytest
from _states import small_problem

from skfem_sheet.analyses.observables import midline_nodes, tip_deflection
from skfem_sheet.analyses.stability import stability


class _Inertia:
    def __init__(self, inertia):
        self._inertia = inertia

    def inertia(self):
        return self._inertia


@pytest.fixture(scope="module")
def problem():
    return small_problem(True)


def test_stability_counts_negative_eigenvalues_beyond_the_pressures(problem):
    m = int(np.count_nonzero(problem.free >= problem.nu_dof))
    n = problem.n_free
    assert stability(problem, _Inertia((n - m, m, 0))) == (True, 0)
    assert stability(problem, _Inertia((n - m - 2, m + 2, 0))) == (False, 2)
    assert stability(problem, _Inertia((n - m - 1, m, 1))) == (False, 0)   # singular
    assert stability(problem, _Inertia(None)) == (None, None)
    assert stability(problem, object()) == (None, None)


def test_tip_deflection_of_a_rigid_drop(problem):
    # the free edge moved down by 0.25, the clamp kept: d = 0.25
    w = np.zeros(problem.ndof)
    U, _ = problem.split(w)
    U[:, 2] = -0.25 * problem.nodes[:, 0] / problem.length
    assert tip_deflection(problem, w) == pytest.approx(0.25, rel=1e-12)
    tip = midline_nodes(problem, problem.length)
    assert np.all(np.diff(problem.nodes[tip, 1]) > 0)


class _Perturbed(_Inertia):
    perturbed_pivots = 2


def test_stability_is_unknown_when_pivots_were_perturbed(problem):
    # a factorisation that perturbed pivots counts those of a nearby matrix:
    # even counts that would say "stable" are not trusted
    m = int(np.count_nonzero(problem.free >= problem.nu_dof))
    assert stability(problem, _Perturbed((problem.n_free - m, m, 0))) == (None, None)


def test_stability_unknown_from_a_real_perturbed_factorisation(problem):
    pytest.importorskip("pypardiso")
    from skfem_sheet.linalg import make_linear_solver

    K = problem.tangent(np.zeros(problem.ndof))
    exact = make_linear_solver("pardiso")
    exact.factorize(K)
    assert exact.perturbed_pivots == 0 and stability(problem, exact) == (True, 0)
    # a pivot threshold of 10^-1 (iparm 10 = 1) perturbs the small pivots of
    # the thin sheet's bending: same matrix, the inertia is no longer trusted
    coarse = make_linear_solver("pardiso", pivot_perturbation=1)
    coarse.factorize(K)
    assert coarse.perturbed_pivots > 0 and coarse.inertia() is None
    assert stability(problem, coarse) == (None, None)


def test_tip_deflection_is_the_old_midline_formula_for_a_trapezoid(problem):
    # the free edge of a trapezoid is the mid-line x = L, so d is what it always was
    from _states import random_state
    w = random_state(problem, seed=3, amp=1e-2)
    U, _ = problem.split(w)
    z = problem.nodes[:, 2] + U[:, 2]
    old = z[midline_nodes(problem, 0.0)].min() - z[midline_nodes(problem, problem.length)].min()
    assert tip_deflection(problem, w) == old


def test_tip_deflection_on_a_bitten_edge_is_its_lowest_point():
    from skfem_sheet.mesh import sheet_mesh
    from skfem_sheet.params import Planform, Sheet
    from skfem_sheet.problem import SheetProblem
    s = Sheet.from_planform(Planform.trapezoid(1.0, bites=(0.3,)), length=0.8)
    p = SheetProblem(s, sheet_mesh(s, 0.2, layers=2, half=True))
    x = p.nodes[:, 0]
    w = np.zeros(p.ndof)
    # drooping as x^2: the lowest free-edge points are on what is left of the cut x = L
    w[2: p.nu_dof: 3] = -x**2
    assert tip_deflection(p, w) == pytest.approx(0.8**2, rel=1e-12)
    # rising as x^2: the lowest one is where the bite leaves the axis, x = L - r
    w[2: p.nu_dof: 3] = x**2
    assert tip_deflection(p, w) == pytest.approx(-0.5**2, rel=1e-12)
