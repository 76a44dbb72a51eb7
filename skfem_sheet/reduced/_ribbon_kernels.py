"""Vectorised kernels of the ribbon model: reduced energy density and its derivatives.

Local variables at a quadrature point are ``q = (c, c', c'', Phi', phi)``
(derivatives in s).  Inserting the ansatz strains (supplement eqs.
strainansatz, bendstrainansatz; E_tt = E_st = 0 so T_ss = Y E_ss) into the
plate energy (eq. asymenergy) and integrating over t in [-p/2, p/2] exactly
gives the energy per unit length

    e = Y/2 [ c^2 Phi'^2 p^5/6! - 2 c Phi' k p^7/8! + k^2 p^9/2073600 ]
      + D/2 [ Phi'^2 p + Phi' c'' p^3/12 + c''^2 p^5/320 + c^2 p
              + 2 nu c (Phi' p + c'' p^3/24) + (1 - nu) c'^2 p^3/6 ]
      + rho g h I(s) sin(phi),

with k = 2 c'^2 - c c''.  The t-moments p^5/720 = int q2^2, p^7/40320 =
int q2 q4 and p^9/2073600 = 7 p^9/(4 10!) = int q4^2 (q2 = t^2/2 - p^2/4!,
q4 = t^4/4! - p^4/(16 5!)) are those of T^2_ss and T^4_ss in the supplement.
The gravity term is rho g h int p e_3.r ds = rho g h int I(s) sin(phi) ds.
"""
from __future__ import annotations

import numpy as np

__all__ = ["stretch_coefficients", "energy_density", "energy_derivatives", "energy_terms"]


def stretch_coefficients(p):
    """t-moments (int q2^2, int q2 q4, int q4^2) over [-p/2, p/2]."""
    return p**5 / 720.0, p**7 / 40320.0, p**9 / 2073600.0


def _bending_matrix(p, D, nu):
    """Constant Hessian K of the bending energy in x = (c, c', c'', Phi'), shape (..., 4, 4)."""
    K = np.zeros(p.shape + (4, 4))
    K[..., 0, 0] = D * p
    K[..., 1, 1] = D * (1.0 - nu) * p**3 / 6.0
    K[..., 2, 2] = D * p**5 / 320.0
    K[..., 3, 3] = D * p
    K[..., 3, 2] = K[..., 2, 3] = D * p**3 / 24.0
    K[..., 0, 3] = K[..., 3, 0] = D * nu * p
    K[..., 0, 2] = K[..., 2, 0] = D * nu * p**3 / 24.0
    return K


def energy_density(q, p, grav, Y, D, nu):
    """Energy per unit length e(q) at points; ``q`` has shape (..., 5)."""
    c, c1, c2, P, phi = np.moveaxis(q, -1, 0)
    A, B, C = stretch_coefficients(p)
    k = 2.0 * c1**2 - c * c2
    F = A * c * c * P * P - 2.0 * B * c * P * k + C * k * k
    bend = (P * P * p + P * c2 * p**3 / 12.0 + c2 * c2 * p**5 / 320.0 + c * c * p
            + 2.0 * nu * c * (P * p + c2 * p**3 / 24.0) + (1.0 - nu) * c1 * c1 * p**3 / 6.0)
    return 0.5 * Y * F + 0.5 * D * bend + grav * np.sin(phi)


def energy_terms(q, p, grav, Y, D, nu):
    """The energy density split into its physical terms (they sum to :func:`energy_density`).

    Keys: ``stretching`` (Y/2 int E_ss^2), ``bending_ss`` (D/2 int B_ss^2),
    ``bending_tt`` (D/2 int B_tt^2), ``poisson`` (D nu int B_ss B_tt, the only
    term linear in c at fixed Phi: it drives the anticlastic curvature),
    ``twisting`` (D (1 - nu) int B_st^2) and ``gravity``; each an array of
    shape ``q.shape[:-1]``.
    """
    c, c1, c2, P, phi = np.moveaxis(q, -1, 0)
    A, B, C = stretch_coefficients(p)
    k = 2.0 * c1**2 - c * c2
    return {
        "stretching": 0.5 * Y * (A * c * c * P * P - 2.0 * B * c * P * k + C * k * k),
        "bending_ss": 0.5 * D * (P * P * p + P * c2 * p**3 / 12.0 + c2 * c2 * p**5 / 320.0),
        "bending_tt": 0.5 * D * c * c * p,
        "poisson": D * nu * c * (P * p + c2 * p**3 / 24.0),
        "twisting": 0.5 * D * (1.0 - nu) * c1 * c1 * p**3 / 6.0,
        "gravity": grav * np.sin(phi),
    }


def energy_derivatives(q, p, grav, Y, D, nu):
    """Energy density, gradient (..., 5) and Hessian (..., 5, 5) in q."""
    c, c1, c2, P, phi = np.moveaxis(q, -1, 0)
    A, B, C = stretch_coefficients(p)
    k = 2.0 * c1**2 - c * c2
    F = A * c * c * P * P - 2.0 * B * c * P * k + C * k * k
    # F as a function of (c, P, k)
    Fc = 2.0 * A * c * P * P - 2.0 * B * P * k
    FP = 2.0 * A * c * c * P - 2.0 * B * c * k
    Fk = -2.0 * B * c * P + 2.0 * C * k
    Fh = np.empty(p.shape + (3, 3))
    Fh[..., 0, 0] = 2.0 * A * P * P
    Fh[..., 0, 1] = Fh[..., 1, 0] = 4.0 * A * c * P - 2.0 * B * k
    Fh[..., 0, 2] = Fh[..., 2, 0] = -2.0 * B * P
    Fh[..., 1, 1] = 2.0 * A * c * c
    Fh[..., 1, 2] = Fh[..., 2, 1] = -2.0 * B * c
    Fh[..., 2, 2] = 2.0 * C
    # Jacobian of (c, P, k) with respect to x = (c, c1, c2, P)
    J = np.zeros(p.shape + (3, 4))
    J[..., 0, 0] = 1.0
    J[..., 1, 3] = 1.0
    J[..., 2, 0] = -c2
    J[..., 2, 1] = 4.0 * c1
    J[..., 2, 2] = -c
    K = _bending_matrix(p, D, nu)
    x = np.stack([c, c1, c2, P], axis=-1)
    Kx = np.einsum("...ij,...j->...i", K, x)

    e = 0.5 * Y * F + 0.5 * np.einsum("...i,...i->...", x, Kx) + grav * np.sin(phi)
    g = np.zeros(p.shape + (5,))
    g[..., :4] = 0.5 * Y * np.einsum("...a,...ai->...i",
                                     np.stack([Fc, FP, Fk], axis=-1), J) + Kx
    g[..., 4] = grav * np.cos(phi)
    H = np.zeros(p.shape + (5, 5))
    Hx = np.einsum("...ai,...ab,...bj->...ij", J, Fh, J)
    Hx[..., 1, 1] += 4.0 * Fk
    Hx[..., 0, 2] -= Fk
    Hx[..., 2, 0] -= Fk
    H[..., :4, :4] = 0.5 * Y * Hx + K
    H[..., 4, 4] = -grav * np.sin(phi)
    return e, g, H
