"""Material kernels: clamp displacement, 3x3 determinants and inverses."""
import numpy as np

from skfem_sheet.kernels import clamp_displacement, det_inv


def test_clamp_maps_midline_to_arc_with_normals_unstretched():
    kappa = 2.5
    R = 1 / kappa
    y = np.linspace(-0.5, 0.5, 11)
    for z in (-0.015, 0.0, 0.015):
        X = np.stack([np.zeros_like(y), y, np.full_like(y, z)], -1)
        x = X + clamp_displacement(y, z, kappa)
        # centre of the arc at (0, 0, R): distance R - z, angle y/R
        r = np.hypot(x[:, 1], x[:, 2] - R)
        np.testing.assert_allclose(r, R - z, rtol=1e-12)
        np.testing.assert_allclose(np.arctan2(x[:, 1], R - x[:, 2]), y / R, rtol=1e-12)
    # flat clamp and the smooth small-curvature limit
    assert np.all(clamp_displacement(y, 0.01, 0.0) == 0)
    small = clamp_displacement(y, 0.01, 1e-7)
    assert np.abs(small).max() < 1e-7


def test_det_inv_matches_numpy():
    F = np.eye(3) + 0.3 * np.random.default_rng(1).normal(size=(50, 3, 3))
    J, Finv = det_inv(F)
    np.testing.assert_allclose(J, np.linalg.det(F), rtol=1e-12)
    np.testing.assert_allclose(Finv, np.linalg.inv(F), rtol=1e-10, atol=1e-12)


# --------------------------------------------------------------------------------------
# mixed-integration-point (MIP) linearisation: second Piola stress and its increment
# --------------------------------------------------------------------------------------
def _stack(seed=5):
    rng = np.random.default_rng(seed)
    F = np.eye(3) + 0.2 * rng.normal(size=(6, 4, 3, 3))
    return rng, F, rng.normal(size=(6, 4))


def test_second_piola_is_the_pull_back_of_the_first():
    from skfem_sheet.kernels import first_piola, second_piola

    _, F, p = _stack()
    P, _, _ = first_piola(F, p, 1.7)
    S = second_piola(F, p, 1.7)
    np.testing.assert_allclose(np.matmul(F, S), P, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(S, np.swapaxes(S, -1, -2), atol=1e-12)  # symmetric
    assert np.abs(second_piola(np.broadcast_to(np.eye(3), F.shape).copy(), 0 * p, 1.7)).max() < 1e-14


def test_second_piola_increment_is_its_directional_derivative():
    from skfem_sheet.kernels import second_piola, second_piola_increment

    rng, F, p = _stack(6)
    dF, dp = rng.normal(size=F.shape), rng.normal(size=p.shape)
    eps = 1e-6
    fd = (second_piola(F + eps * dF, p + eps * dp, 2.0)
          - second_piola(F - eps * dF, p - eps * dp, 2.0)) / (2 * eps)
    np.testing.assert_allclose(second_piola_increment(F, p, 2.0, dF, dp), fd, atol=1e-7)


def test_stress_defect_is_second_order_and_zero_for_a_linearised_rotation():
    """The MIP defect ``S0 + dS - S(F)`` vanishes at ``F = F0`` and shrinks like the
    square of the step; for an infinitesimal rotation ``F = (I + t W) F0`` of a
    stress-free state the linearised stress stays 0, so the defect is minus the
    spurious stress of the linear update (which is O(t^2), not 0)."""
    from skfem_sheet.kernels import linearised_stress_defect, second_piola

    rng, F0, p0 = _stack(7)
    assert np.abs(linearised_stress_defect(F0, p0, F0, p0, 1.0)).max() == 0.0
    dF, dp = rng.normal(size=F0.shape), rng.normal(size=p0.shape)
    d1 = np.abs(linearised_stress_defect(F0, p0, F0 + 1e-2 * dF, p0 + 1e-2 * dp, 1.0)).max()
    d2 = np.abs(linearised_stress_defect(F0, p0, F0 + 5e-3 * dF, p0 + 5e-3 * dp, 1.0)).max()
    assert 3.5 < d1 / d2 < 4.5
    Id = np.broadcast_to(np.eye(3), F0.shape).copy()
    W = np.array([[0.0, -1.0, 0.3], [1.0, 0.0, -0.5], [-0.3, 0.5, 0.0]])
    F = Id + 0.1 * W
    zero = np.zeros_like(p0)
    S = second_piola(F, zero, 1.0)
    assert np.abs(S).max() > 1e-3  # the linear update of a rotation stretches
    np.testing.assert_allclose(linearised_stress_defect(Id, zero, F, zero, 1.0), -S,
                               atol=1e-14)
