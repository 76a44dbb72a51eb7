"""Cubic-Hermite finite elements for the ribbon model's reduced energy E[c, Phi].

The unknowns c(S) and Phi(S) live on a fixed uniform grid in S = s/L in [0, 1]
(so a solution at one length is a good initial guess at the next), each with
nodal values and S-derivatives (C^1 cubic Hermite elements, four Gauss points
per element).  All local variables q = (c, c', c'', Phi', phi) are linear in
the unknowns, phi = Phi + (c' p^2 + 2 c p p')/4! included, so the energy's
gradient and Hessian follow exactly from the pointwise derivatives in
:mod:`._ribbon_kernels` by the chain rule.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import LinAlgError, cho_factor, cho_solve

from skfem_sheet.reduced._ribbon_kernels import energy_density, energy_derivatives

__all__ = ["Mesh", "make_mesh", "Operators", "make_operators", "total_energy",
           "energy_gradient_hessian", "minimise"]

N_GAUSS = 4


def _hermite(xi):
    """Cubic Hermite shape functions on [0, 1] and their first two xi-derivatives."""
    N = np.stack([1 - 3 * xi**2 + 2 * xi**3, xi - 2 * xi**2 + xi**3,
                  3 * xi**2 - 2 * xi**3, -xi**2 + xi**3], axis=-1)
    dN = np.stack([-6 * xi + 6 * xi**2, 1 - 4 * xi + 3 * xi**2,
                   6 * xi - 6 * xi**2, -2 * xi + 3 * xi**2], axis=-1)
    d2N = np.stack([-6 + 12 * xi, -4 + 6 * xi, 6 - 12 * xi, -2 + 6 * xi], axis=-1)
    return N, dN, d2N


@dataclass(frozen=True)
class Mesh:
    """Length-independent part of the discretisation (uniform grid in S)."""

    n_elements: int
    S_nodes: np.ndarray      # (Ne + 1,)
    S_gauss: np.ndarray      # (Ne, Q)
    w_gauss: np.ndarray      # (Q,) weights on [0, 1]
    N: np.ndarray            # (Q, 4) shape functions, slope dofs scaled by hS
    dN: np.ndarray           # (Q, 4) d/dS
    d2N: np.ndarray          # (Q, 4) d2/dS2
    dofs: np.ndarray         # (Ne, 8) global indices: c dofs then Phi dofs


def make_mesh(n_elements: int) -> Mesh:
    """Build a :class:`Mesh` with ``n_elements`` cubic Hermite elements."""
    ne = int(n_elements)
    hS = 1.0 / ne
    x, w = np.polynomial.legendre.leggauss(N_GAUSS)
    xi, w = 0.5 * (x + 1.0), 0.5 * w
    N, dN, d2N = _hermite(xi)
    scale = np.array([1.0, hS, 1.0, hS])
    N, dN, d2N = N * scale, dN * scale / hS, d2N * scale / hS**2
    S_nodes = np.linspace(0.0, 1.0, ne + 1)
    S_gauss = S_nodes[:-1, None] + hS * xi[None, :]
    e = np.arange(ne)[:, None]
    # node-major layout: [c, c_S, Phi, Phi_S] per node
    c_dofs = np.hstack([4 * e, 4 * e + 1, 4 * e + 4, 4 * e + 5])
    dofs = np.hstack([c_dofs, c_dofs + 2])
    return Mesh(ne, S_nodes, S_gauss, w, N, dN, d2N, dofs)


@dataclass(frozen=True)
class Operators:
    """Length-dependent linear maps from element dofs to q, plus weights."""

    B: np.ndarray        # (Ne, Q, 5, 8)
    weight: np.ndarray   # (Ne, Q) quadrature weights in s
    p: np.ndarray        # (Ne, Q)
    grav: np.ndarray     # (Ne, Q) rho g h I(s)
    dofs: np.ndarray
    Y: float
    D: float
    nu: float


def make_operators(mesh: Mesh, length, tip_width, weight_per_area, Y, D, nu,
                   gravity_scale=1.0, profile=None) -> Operators:
    """Assemble B with q = B x_e for a sheet of the given length and tip width.

    ``profile`` (optional) replaces the linear width: a function of s returning
    ``(p, dp/ds, I)`` with I(s) = int_s^L p (``length`` is then the end of the
    material, ``tip_width`` unused).
    """
    L, b = float(length), float(tip_width)
    S = mesh.S_gauss
    if profile is None:
        p = 1.0 + (b - 1.0) * S
        dp = (b - 1.0) / L
    else:
        p, dp, I_planform = profile(L * S)
    ne, nq = S.shape
    B = np.zeros((ne, nq, 5, 8))
    B[:, :, 0, :4] = mesh.N
    B[:, :, 1, :4] = mesh.dN / L
    B[:, :, 2, :4] = mesh.d2N / L**2
    B[:, :, 3, 4:] = mesh.dN / L
    B[:, :, 4, 4:] = mesh.N
    B[:, :, 4, :4] = (p**2 / 24.0)[..., None] * mesh.dN / L + (p * dp / 12.0)[..., None] * mesh.N
    weight = np.broadcast_to(mesh.w_gauss * L / ne, S.shape)
    I = L * ((1.0 - S) + 0.5 * (b - 1.0) * (1.0 - S**2)) if profile is None else I_planform
    return Operators(B, weight, p, gravity_scale * weight_per_area * I, mesh.dofs, Y, D, nu)


def _local(ops: Operators, x):
    return np.einsum("eqjk,ek->eqj", ops.B, x[ops.dofs])


def total_energy(ops: Operators, x) -> float:
    """Discrete reduced energy E[c, Phi]."""
    e = energy_density(_local(ops, x), ops.p, ops.grav, ops.Y, ops.D, ops.nu)
    return float(np.sum(ops.weight * e))


def energy_gradient_hessian(ops: Operators, x):
    """Energy, gradient (n,) and dense Hessian (n, n) in all dofs."""
    e, g, H = energy_derivatives(_local(ops, x), ops.p, ops.grav, ops.Y, ops.D, ops.nu)
    w = ops.weight
    ge = np.einsum("eq,eqja,eqj->ea", w, ops.B, g)
    He = np.einsum("eq,eqja,eqjk,eqkb->eab", w, ops.B, H, ops.B, optimize=True)
    n = x.size
    grad = np.bincount(ops.dofs.ravel(), ge.ravel(), minlength=n)
    rows = np.repeat(ops.dofs, 8, axis=1).ravel()
    cols = np.tile(ops.dofs, (1, 8)).ravel()
    hess = np.bincount(rows * n + cols, He.ravel(), minlength=n * n).reshape(n, n)
    return float(np.sum(w * e)), grad, hess


def _factor(H):
    """Cholesky of H, shifted until positive definite; returns (factor, was_pd)."""
    try:
        return cho_factor(H), True
    except LinAlgError:
        pass
    scale = np.max(np.abs(np.diag(H)))
    tau = 1e-8 * scale
    while True:
        try:
            return cho_factor(H + tau * np.eye(H.shape[0])), False
        except LinAlgError:
            tau *= 10.0


def minimise(ops: Operators, x0, free, max_iter=100, xtol=1e-10):
    """Newton's method with line search for a local minimum of E over ``free`` dofs.

    Returns ``(x, converged, stable, iterations)``; ``stable`` is True when the
    reduced Hessian at the solution is positive definite (a local minimum).
    """
    x = np.array(x0, dtype=float)
    for it in range(1, max_iter + 1):
        E, g, H = energy_gradient_hessian(ops, x)
        gf, Hf = g[free], H[np.ix_(free, free)]
        fac, pd = _factor(Hf)
        dx = -cho_solve(fac, gf)
        size = np.max(np.abs(dx))
        if pd and size < xtol * max(1.0, np.max(np.abs(x))):
            x[free] += dx
            return x, True, True, it
        t, slope = 1.0, float(gf @ dx)
        while t > 1e-10:
            trial = x.copy()
            trial[free] += t * dx
            Et = total_energy(ops, trial)
            if np.isfinite(Et) and (Et <= E + 1e-4 * t * slope or (pd and size < 1e-6)):
                break
            t *= 0.5
        else:
            return x, False, pd, it
        x = trial
    return x, False, False, max_iter
