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
