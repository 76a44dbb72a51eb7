"""Material kernels of the incompressible neo-Hookean sheet: pure numpy.

Continuum model (paper, supplement, "Numerical Method", first display)::

    Pi(U, p) = int  mu/2 (I_C - 3) - mu ln J + g U_z - p (J - 1)  dV

with ``F = I + grad U``, ``J = det F``, ``I_C = tr(F^T F)``, dimensionless
units (lengths / a, energy densities / (rho g a), so the weight density is 1
and ``g`` is the gravity *load factor*, 1 at full gravity).

About ``- mu ln J``: it vanishes wherever ``J = 1``, so the continuum problem is
the paper's; it only shifts the Lagrange multiplier, ``p_paper = p + mu`` (the
paper's pressure is ``mu`` in the stress-free state, ours is 0).  Without it
the displacement block of the tangent carries ``-mu D^2 J``, which with one
element through the thickness (where P1 pressure enforces ``J = 1`` only
weakly) makes Newton stall at mesh-dependent, unphysical loads
(``docs/decisions.md``, "The shifted pressure").  Outputs report ``p_paper``.

Everything here works on stacks of quadrature-point values (leading axes
``(nel, nq)``) and knows nothing of meshes or dof numbering: the element
arrays come from :class:`skfem_sheet.discretisation.TaylorHoodSpace`, the
assembly into global matrices is :mod:`skfem_sheet.assembly`.
Names follow the mathematics: ``F`` deformation gradient, ``J = det F``,
``p`` pressure (Lagrange multiplier), ``mu`` shear modulus, ``dphi`` the
reference gradients of the P2 basis, ``psi`` (``phi1``) the P1 basis, ``wq``
the quadrature weights times the volume element.
"""
from __future__ import annotations

import numpy as np

from .discretisation import det_inv

__all__ = ["clamp_displacement", "clamp_displacement_rate", "kinematics", "det_inv",
           "first_piola", "element_residuals", "element_tangent_blocks",
           "strain_energy_density", "first_invariant", "second_piola",
           "second_piola_increment", "linearised_stress_defect"]


def clamp_displacement(y, z, kappa):
    """Clamp displacement ``U0(y, z)`` for clamp curvature ``kappa = a/R``.

    Supplement, "Numerical Method", second display::

        U0 = [(R - z) sin(y/R) - y] e_y + (R - z) [1 - cos(y/R)] e_z,  U0_x = 0,

    written in a form that is exact and smooth as ``kappa -> 0`` (``U0 = 0``):
    ``R sin(y/R) = y sinc(kappa y / pi)`` and
    ``R (1 - cos(y/R)) = y sin(kappa y / 2) sinc(kappa y / (2 pi))``.

    Returns an array of shape ``y.shape + (3,)``.
    """
    y = np.asarray(y, dtype=float)
    z = np.asarray(z, dtype=float)
    s = np.sin(kappa * y)
    r_sin = y * np.sinc(kappa * y / np.pi)  # R sin(y/R)
    r_vers = y * np.sin(0.5 * kappa * y) * np.sinc(kappa * y / (2 * np.pi))  # R (1 - cos)
    out = np.zeros(y.shape + (3,))
    out[..., 1] = r_sin - z * s - y
    out[..., 2] = r_vers - z * (1.0 - np.cos(kappa * y))
    return out


def clamp_displacement_rate(y, z, kappa, dk=1e-6):
    """``d U0 / d kappa`` (central difference of :func:`clamp_displacement`)."""
    return (clamp_displacement(y, z, kappa + dk)
            - clamp_displacement(y, z, kappa - dk)) / (2 * dk)


def kinematics(Ue, dphi):
    """Deformation gradient at quadrature points.

    Parameters
    ----------
    Ue : ndarray (nel, 10, 3)
        Nodal displacements of each element.
    dphi : ndarray (nel, nq, 10, 3)
        Reference gradients of the P2 basis.

    Returns
    -------
    F : ndarray (nel, nq, 3, 3), ``F_iJ = delta_iJ + dU_i/dX_J``.
    """
    # F_ij = sum_a U_ai dphi_aj as a batched matmul (3-5x faster than einsum)
    F = np.matmul(Ue.transpose(0, 2, 1)[:, None], dphi)
    F[..., 0, 0] += 1.0
    F[..., 1, 1] += 1.0
    F[..., 2, 2] += 1.0
    return F


def first_piola(F, p, mu):
    """First Piola stress of ``psi = mu/2 (I_C - 3) - mu ln J - p (J - 1)``.

    ``P = mu F - (mu + p J) F^{-T}``.  Returns ``(P, J, Finv)``.
    """
    J, Finv = det_inv(F)
    P = mu * F - (mu + p * J)[..., None, None] * np.swapaxes(Finv, -1, -2)
    return P, J, Finv


def element_residuals(F, p, mu, dphi, psi, wq, R):
    """Element residuals, the first variation of ``Pi`` without the load,
    written into ``R`` (nel, 34): ``int P_ij dphi_aj`` for the 30 displacement
    dofs (node-major, ``3 a + i``) and ``-int (J - 1) psi_c`` for the 4
    pressure dofs.  Returns the smallest ``J`` (NaN propagates).

    Parameters
    ----------
    F : ndarray (nel, nq, 3, 3)
    p : ndarray (nel, nq)
        Pressure at the quadrature points.
    mu : float
    dphi : ndarray (nel, nq, 10, 3)
    psi : ndarray (nel, nq, 4)
        P1 basis values.
    wq : ndarray (nel, nq)
        Quadrature weights times the volume element.
    R : ndarray (nel, 34)
    """
    P, J, _ = first_piola(F, p, mu)
    # ru_ai = sum_q w_q dphi_aj P_ij (batched matmul, then the sum over q)
    ru = np.matmul(dphi, (wq[..., None, None] * P).transpose(0, 1, 3, 2)).sum(1)
    R[:, :30] = ru.reshape(len(wq), 30)
    R[:, 30:] = -np.einsum("eq,eqc->ec", wq * (J - 1.0), psi)
    return float(J.min())


def element_tangent_blocks(F, p, mu, dphi, psi, wq, Kb, Kpu, chunk=256, dS=None):
    """The state-dependent part of the element tangents (the Hessian of
    ``Pi``), written in place.

    ``Kb`` (nel, 10, 10, 3, 3) receives the 3 x 3 node-node blocks
    ``Kb[a, b, i, k] = int (mu + p J) b_ak b_bi - p J b_ai b_bk``
    (the constant ``mu d_ik grad phi_a . grad phi_b`` is left out: it is
    ``mu`` times ``TaylorHoodSpace.laplacian``), ``Kpu`` (nel, 4, 10, 3) receives
    ``Kpu[c, a, i] = -int J b_ai psi_c``, with the spatial gradients
    ``b_a = F^{-T} grad phi_a``.  The two 30 x 30 products and their
    rearrangement into blocks run on ``chunk`` elements at a time, in cache.

    ``dS`` (nel, nq, 3, 3), optional: a symmetric stress defect added to the
    stress of the geometric stiffness, ``Kb[a, b, i, i] += int grad phi_a . dS
    grad phi_b`` (the mixed-integration-point linearisation, see
    :func:`linearised_stress_defect`); ``None`` gives the exact Hessian.
    """
    J, Finv = det_inv(F)
    nel, nq = J.shape
    bs = np.matmul(dphi, Finv).reshape(nel, nq, 30)  # b_ai = dphi_am Finv_mi
    wpJ = wq * p * J
    c3 = -wpJ[..., None] * bs  # - p J b_ai b_bk
    c2 = (mu * wq + wpJ)[..., None] * bs  # (mu + p J) b_ak b_bi
    m = min(chunk, nel)
    Y2, Y3 = np.empty((m, 30, 30)), np.empty((m, 30, 30))
    for lo in range(0, nel, m):
        hi = min(lo + m, nel)
        y2, y3 = Y2[: hi - lo], Y3[: hi - lo]
        bt = bs[lo:hi]
        np.matmul(c3[lo:hi].transpose(0, 2, 1), bt, out=y3)  # (a, i, b, k)
        np.matmul(c2[lo:hi].transpose(0, 2, 1), bt, out=y2)  # (a, k, b, i)
        np.add(y3.reshape(-1, 10, 3, 10, 3).transpose(0, 1, 3, 2, 4),
               y2.reshape(-1, 10, 3, 10, 3).transpose(0, 1, 3, 4, 2), out=Kb[lo:hi])
    np.matmul(psi.transpose(0, 2, 1), -(wq * J)[..., None] * bs,
              out=Kpu.reshape(nel, 4, 30))
    if dS is not None:
        # G_ab = sum_q w_q dphi_aJ dS_JL dphi_bL, on the diagonal i = k
        G = np.matmul(np.matmul(dphi, wq[..., None, None] * dS),
                      dphi.transpose(0, 1, 3, 2)).sum(1)
        for i in range(3):
            Kb[:, :, :, i, i] += G


def second_piola(F, p, mu):
    """Second Piola-Kirchhoff stress ``S = F^{-1} P = mu I - (mu + p J) C^{-1}``
    (``C = F^T F``) of the energy density of :func:`first_piola`."""
    J, Finv = det_inv(F)
    Cinv = np.matmul(Finv, np.swapaxes(Finv, -1, -2))
    S = -(mu + p * J)[..., None, None] * Cinv
    S[..., 0, 0] += mu
    S[..., 1, 1] += mu
    S[..., 2, 2] += mu
    return S


def second_piola_increment(F, p, mu, dF, dp):
    """Directional derivative of :func:`second_piola` at ``(F, p)`` along
    ``(dF, dp)``::

        dS = -(dp J + p dJ) C^{-1} + (mu + p J) C^{-1} dC C^{-1},
        dJ = J tr(F^{-1} dF),  dC = dF^T F + F^T dF.
    """
    J, Finv = det_inv(F)
    Cinv = np.matmul(Finv, np.swapaxes(Finv, -1, -2))
    dJ = J * np.einsum("...ij,...ji->...", Finv, dF)
    FtdF = np.matmul(np.swapaxes(F, -1, -2), dF)
    dC = FtdF + np.swapaxes(FtdF, -1, -2)
    return (-(dp * J + p * dJ)[..., None, None] * Cinv
            + (mu + p * J)[..., None, None] * np.matmul(np.matmul(Cinv, dC), Cinv))


def linearised_stress_defect(F0, p0, F, p, mu):
    """Stress defect of a mixed-integration-point (MIP) Newton step.

    Magisano, Leonetti & Garcea (CMAME 2017) treat the stress at the
    quadrature points as an independent variable of the linearisation: after
    a Newton correction from ``(F0, p0)`` to ``(F, p)`` the stress is the
    *linearised* one, ``S0 + dS(F0, p0)[F - F0, p - p0]``, not ``S(F, p)``.
    The difference is second order in the correction; for a thin sheet it is
    the spurious membrane stress of a finite rotation of a linearised
    bending step, which makes the exact tangent at the new iterate far too
    stiff along that rotation.  Returns ``S0 + dS - S(F, p)``, to be passed
    as ``dS`` to :func:`element_tangent_blocks` (the residual is unchanged,
    so the converged state is that of exact Newton).
    """
    return (second_piola(F0, p0, mu) + second_piola_increment(F0, p0, mu, F - F0, p - p0)
            - second_piola(F, p, mu))


def strain_energy_density(F, p, mu):
    """``psi = mu/2 (I_C - 3) - mu ln J - p (J - 1)`` at the quadrature points
    (``J`` from ``np.linalg.det``)."""
    J = np.linalg.det(F)
    IC = first_invariant(F)
    return 0.5 * mu * (IC - 3) - mu * np.log(J) - p * (J - 1)


def first_invariant(F):
    """``I_C = tr(F^T F)`` at the quadrature points."""
    return np.einsum("eqij,eqij->eq", F, F)
