"""The sheet as an engine problem in one parameter (bistability's adapter)."""
import numpy as np
import pytest

from skfem_sheet import Sheet
from skfem_sheet.bistability.follow import _chord_linearization, _tolerances
from skfem_sheet.engine import correct
from skfem_sheet.engine.protocol import Counting
from skfem_sheet.sheet_shape import SheetShapeProblem


def _branch_problem(sheet, name):
    return SheetShapeProblem(sheet, 0.25, parameters=(name,), geometry="stretch")


@pytest.fixture(scope="module")
def solved():
    sheet = Sheet(length=0.8, curvature=2.0)
    out = _branch_problem(sheet, "L").along_path([0.8], "curvature-first")
    assert out.converged
    return sheet, out.w


@pytest.mark.parametrize("name, p", [("a/R", 2.0), ("L", 0.8)])
def test_parameter_derivative_of_the_residual_is_a_difference_quotient(solved, name, p):
    """dR/dp at fixed free dofs: the clamp rate coupled into the free rows
    (a/R, exact) and a central difference on the stretch (L) agree with a
    wide central difference of the residual."""
    sheet, w = solved
    P = _branch_problem(sheet, name)
    u = w[P.free]
    h = 1e-4
    fd = (P.residual(u, np.array([p + h])) - P.residual(u, np.array([p - h]))) / (2 * h)
    rate = P.dresidual(u, np.array([p]), 0)
    assert np.linalg.norm(rate - fd) <= 1e-5 * np.linalg.norm(fd)


def test_chord_rule_returns_a_converged_state_as_it_is(solved):
    """From a converged state the corrector spends one factorisation (the
    first linearisation) and, at the confirming back-substitution, stops and
    returns the iterate it reached; from a perturbed one it converges back,
    the residual left after a correction below utol removed by a chord step
    (the last factorisation reused) instead of a third factorisation."""
    sheet, w = solved
    P = _branch_problem(sheet, "L")
    C = Counting(P)
    p = np.array([sheet.length])
    u = w[P.free]
    res = correct(C, u, p, _chord_linearization(C), _tolerances())
    assert res.converged and res.stats.factorizations == 1
    assert P.correction_norm(res.u - u) <= 1e-6
    bumped = u + 1e-3 * np.where(P._u_free, 1.0, 0.0)
    res2 = correct(C, bumped, p, _chord_linearization(C), _tolerances())
    assert res2.converged and P.correction_norm(res2.u - u) <= 1e-8
    # two factorisations, one chord step (its correction below utol 1e-6, its
    # residual above rtol), and the last linearisation only confirmed
    rn, dn = zip(*res2.history)
    assert res2.stats.factorizations == 2 and res2.iterations == 4
    assert dn[2] <= 1e-6 and rn[2] > 1e-4 and rn[3] <= 1e-4
