"""Heavy elastica with varying width (supplement eq. phODE2)."""
import numpy as np
import pytest

from skfem_sheet.params import Sheet
from skfem_sheet.reduced import elastica, elastica_linear_deflection

#: Reference value, converged to ~1e-12 (tol 1e-11 and an independent
#: cubic-Hermite energy minimisation agree to 1e-11).
D_RECT_L1 = 0.768087485994


def test_rectangle_reference_value_and_convergence():
    r = elastica(Sheet(length=1.0))
    assert r.converged
    assert r.deflection == pytest.approx(D_RECT_L1, rel=1e-8)
    fine = elastica(Sheet(length=1.0), tol=1e-11)
    assert abs(fine.deflection - r.deflection) < 1e-7
    assert r.deflection == pytest.approx(0.77, abs=0.005)       # the sanity value


@pytest.mark.parametrize("b,C", [(1.0, 1 / 8), (0.0, 1 / 24), (0.5, None)])
def test_small_load_linear_limit(b, C):
    sheet = Sheet(length=1.0, tip_width=b, modulus=735.0e5)
    lin = elastica_linear_deflection(sheet)
    if C is not None:
        assert lin == pytest.approx(C * sheet.thickness / sheet.bending_modulus, rel=1e-12)
    assert elastica(sheet).deflection == pytest.approx(lin, rel=1e-5)


def test_large_deflection_physics():
    d = [elastica(Sheet(length=L, tip_width=0.0)).deflection for L in (0.5, 1.0, 1.5, 1.8)]
    assert np.all(np.diff(d) > 0) and d[0] > 0
    r = elastica(Sheet(length=1.8))
    assert r.converged and r.deflection < 1.8
    assert np.all(np.diff(r.phi) <= 1e-12)               # hangs monotonically
    assert r.phi[0] == 0.0 and abs(r.moment[-1]) < 1e-9   # phi(0) = 0, phi'(L) = 0
    # heavier than linear theory allows? no: large rotations reduce the drop
    assert r.deflection < elastica_linear_deflection(Sheet(length=1.8))


def test_validation():
    with pytest.raises(ValueError, match="tol"):
        elastica(Sheet(length=1.0), tol=0.5)
