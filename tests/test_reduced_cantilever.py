"""Cantilever estimate beyond the persistence length (supplement, Euler-Bernoulli)."""
import numpy as np
import pytest
from scipy.integrate import solve_bvp

from skfem_sheet.params import Sheet
from skfem_sheet.reduced import cantilever_coefficient, cantilever_deflection
from skfem_sheet.reduced.cantilever import flat_cantilever_drop


@pytest.mark.parametrize("b,C", [(1.0, 1 / 8), (0.0, 1 / 24)])
def test_closed_forms(b, C):
    sheet = Sheet(length=2.0, tip_width=b, curvature=2.5)
    r = cantilever_deflection(sheet)
    Lp = r.persistence_length
    exact = C * sheet.thickness * (2.0 - Lp) ** 4 / sheet.bending_modulus
    assert r.deflection == pytest.approx(exact, rel=1e-10)
    assert r.coefficient == pytest.approx(C, rel=1e-10)
    assert cantilever_coefficient(b, 3.0, 0.7) == pytest.approx(C, rel=1e-10)


def test_general_width_against_direct_bvp():
    """D [p W'']'' = -rho g h p, W(Lp)=W'(Lp)=0, pW''(L)=(pW'')'(L)=0 by collocation."""
    sheet = Sheet(length=2.0, tip_width=0.4)
    D, q, L, Lp = sheet.bending_modulus, sheet.thickness, 2.0, 0.6
    p = sheet.width

    def fun(s, y):  # y = (W, W', m = D p W'', m')
        return np.vstack([y[1], y[2] / (D * p(s)), y[3], -q * p(s)])

    def bc(ya, yb):
        return np.array([ya[0], ya[1], yb[2], yb[3]])

    s = np.linspace(Lp, L, 50)
    sol = solve_bvp(fun, bc, s, np.zeros((4, s.size)), tol=1e-8, max_nodes=100000)
    assert sol.status == 0
    assert flat_cantilever_drop(sheet, Lp) == pytest.approx(-sol.y[0, -1], rel=1e-6)
    c = cantilever_coefficient(0.4, 2.0, 0.6)
    assert 1 / 24 < c < 1 / 8


def test_curved_part_and_limits():
    r = cantilever_deflection(Sheet(length=1.5, curvature=2.5), include_curved_part=True)
    # rectangle: W0(Lp) = -3/56 int c' ds = 3 kappa / 56
    assert r.curved_rise == pytest.approx(3 * 2.5 / 56, rel=1e-4)
    assert r.deflection == pytest.approx(r.flat_drop - r.curved_rise)
    short = cantilever_deflection(Sheet(length=0.8, curvature=2.5))
    assert short.deflection == 0.0 and short.persistence_length == pytest.approx(0.8)
    flat = cantilever_deflection(Sheet(length=1.0))
    assert flat.deflection == pytest.approx(0.03 / (8 * Sheet(1.0).bending_modulus))
