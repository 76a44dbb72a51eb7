"""Persistence length without gravity (supplement eqs. code2-code3)."""
import math

import numpy as np
import pytest

from skfem_sheet.params import Sheet
from skfem_sheet.reduced import persistence_length, persistence_length_asymptotic
from skfem_sheet.reduced.persistence import lhat_of_delta


@pytest.mark.parametrize("h,kappa,L", [(0.03, 2.5, 3.0), (0.01, 1.0, 10.0), (0.05, 5.0, 0.9)])
def test_rectangle_matches_closed_form(h, kappa, L):
    r = persistence_length(Sheet(length=L, curvature=kappa, thickness=h))
    exact = 1.0 / math.sqrt(70.0 * h / kappa)          # a^2 / sqrt(70 h R)
    assert r.persistence_length == pytest.approx(exact, rel=1e-6)
    assert r.lhat == pytest.approx(1.0, rel=1e-9)
    # C(S) = (1 - S)^2 for the rectangle
    np.testing.assert_allclose(r.C, (1.0 - r.S) ** 2, atol=1e-9)


@pytest.mark.parametrize("delta", [0.02, 0.005])
def test_small_width_change_first_order_correction(delta):
    lhat, S, C = lhat_of_delta(delta)
    assert (lhat - 1.0) / delta == pytest.approx(-0.9, abs=0.03)
    C1 = (C - (1.0 - S) ** 2) / delta
    expected = 11.0 / 5.0 * S * (1.0 - S) ** 2
    assert np.max(np.abs(C1 - expected)) < 0.03 * np.max(expected)


def test_long_trapezoid_consistent_and_asymptotic():
    sheet = Sheet(length=20.0, tip_width=0.9, curvature=2.5)
    r = persistence_length(sheet)
    # Dhat is consistent with L_p itself
    assert r.delta_hat == pytest.approx((1 - 0.9) * r.persistence_length / 20.0, rel=1e-9)
    assert (r.lhat - 1.0) / r.delta_hat == pytest.approx(-0.9, abs=0.03)
    C1 = (r.C - (1 - r.S) ** 2) / r.delta_hat
    np.testing.assert_allclose(C1, 2.2 * r.S * (1 - r.S) ** 2, atol=0.02)
    assert r.persistence_length == pytest.approx(persistence_length_asymptotic(sheet), rel=1e-4)
    assert r.persistence_length < r.rectangle_length


def test_triangle_profile_solves_the_ode():
    """Residual of [P^3 C']^2 [P^3 C']' = 8 Lhat^4 P C on the returned profile."""
    r = persistence_length(Sheet(length=1.5, tip_width=0.0, curvature=2.5), n_profile=4001)
    S, C = r.S, r.C
    P = 1.0 - r.delta_hat * S
    Q = P**3 * np.gradient(C, S, edge_order=2)
    lhs = Q**2 * np.gradient(Q, S, edge_order=2)
    rhs = 8.0 * r.lhat**4 * P * C
    inner = (S > 0.05) & (S < 0.9)
    assert np.max(np.abs(lhs - rhs)[inner]) < 1e-3 * np.max(np.abs(rhs))
    assert C[0] == pytest.approx(1.0) and C[-1] == pytest.approx(0.0, abs=1e-12)
    # tapering shortens the persistence length markedly (Dhat not small here)
    assert 0.5 < r.persistence_length / r.rectangle_length < 0.7


def test_decreasing_in_taper_and_physical_profile():
    Lps = [persistence_length(Sheet(length=2.0, tip_width=b, curvature=2.5)).persistence_length
           for b in (1.0, 0.75, 0.5, 0.25, 0.0)]
    assert np.all(np.diff(Lps) < 0)
    r = persistence_length(Sheet(length=2.0, tip_width=0.5, curvature=2.5))
    assert np.all(np.diff(r.c) <= 1e-12) and r.c[0] == pytest.approx(2.5)
    assert r.s[-1] == pytest.approx(r.persistence_length)


def test_flat_clamp_and_short_sheet():
    r = persistence_length(Sheet(length=1.0, curvature=0.0))
    assert r.persistence_length == 0.0
    short = persistence_length(Sheet(length=0.3, tip_width=0.5, curvature=5.0))
    assert short.reaches_tip and math.isinf(short.persistence_length)
    rect = persistence_length(Sheet(length=0.3, curvature=5.0))
    assert rect.reaches_tip and rect.persistence_length == pytest.approx(rect.rectangle_length)
    # a triangle's L_p stays inside the sheet even when it is short
    tri = persistence_length(Sheet(length=0.3, tip_width=0.0, curvature=5.0))
    assert not tri.reaches_tip and tri.persistence_length < 0.3


def test_validation():
    with pytest.raises(ValueError, match="sheet"):
        persistence_length({"length": 1.0})
    with pytest.raises(ValueError, match="delta"):
        lhat_of_delta(1.5)
