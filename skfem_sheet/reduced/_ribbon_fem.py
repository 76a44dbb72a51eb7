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

from skfem_sheet.engine import Problem, Tolerances, correct
from skfem_sheet.engine.protocol import Counting
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


class _ShiftedCholesky:
    """A (shifted) Cholesky factorisation of the reduced Hessian."""

    def __init__(self, H):
        self.factor, self.positive_definite = _factor(H)

    def solve(self, b):
        return cho_solve(self.factor, b)

    def inertia(self):
        return 0 if self.positive_definite else None


class EnergyProblem(Problem):
    """Minimising the ribbon's energy over the ``free`` dofs, as an engine problem.

    The state ``u`` is ``x[free]``; the other dofs keep the values of
    ``fixed(p)``.  The residual is the energy gradient of ``operators(p)``,
    the jacobian its Hessian, factorised by a Cholesky shifted until positive
    definite (a descent direction also where the Hessian is indefinite).
    Subclasses give the parameters a meaning (:class:`RibbonProblem` in
    :mod:`skfem_sheet.reduced.ribbon`: length, clamp curvature, gravity); on
    its own (``p`` empty) it is one minimisation (:func:`minimise`).
    """

    def __init__(self, free, ops: Operators = None, x_fixed=None, xtol=1e-10):
        self.free, self.xtol = np.asarray(free, bool), float(xtol)
        self._ops = ops
        self._x_fixed = None if x_fixed is None else np.array(x_fixed, dtype=float)
        self.scale = 1.0  # max(1, |x|_inf) at the iterate last linearised

    def operators(self, p) -> Operators:
        return self._ops

    def fixed(self, p):
        """Full dof vector carrying the fixed values at ``p``."""
        return self._x_fixed

    def full(self, u, p):
        x = self.fixed(p).copy()
        x[self.free] = u
        return x

    def energy(self, u, p):
        return total_energy(self.operators(p), self.full(u, p))

    def derivatives(self, u, p):
        """Energy, reduced gradient and reduced Hessian (one assembly)."""
        E, g, H = energy_gradient_hessian(self.operators(p), self.full(u, p))
        return E, g[self.free], H[np.ix_(self.free, self.free)]

    def residual(self, u, p):
        return self.derivatives(u, p)[1]

    def jacobian(self, u, p):
        return self.derivatives(u, p)[2]

    def factorize(self, J):
        return _ShiftedCholesky(J)

    def correction_norm(self, du):
        """``r / (r + xtol)``, ``r = |du|_inf / max(1, |x|_inf)`` (see :func:`energy_descent`)."""
        r = (float(np.max(np.abs(du))) if du.size else 0.0) / self.scale
        return r / (r + self.xtol)


def descent_tolerances(max_iter=100):
    """The corrector's limits for :func:`energy_descent` (its stopping rule is
    in the residual and correction measures; see there)."""
    return Tolerances(rtol=0.5, utol=0.5, max_iterations=max_iter, max_halvings=33)


def energy_descent(counter):
    """The linearisation and trial test of Newton's method with a line search
    on the energy, for :func:`skfem_sheet.engine.correct` on an
    :class:`EnergyProblem` (``counter`` the engine's counted view of it).

    At each iterate: the Newton direction with the shifted Cholesky of the
    Hessian; converged when the Hessian is positive definite and the
    correction is below ``xtol max(1, |x|_inf)``.  A trial point ``u + t du``
    (``t = 1, 1/2, ..., 2^-33``) is admissible when its energy is finite and
    meets the Armijo condition ``E(u + t du) <= E(u) + 1e-4 t g.du`` (or the
    correction is already below 1e-6 at a positive definite Hessian).  The
    corrector's residual and correction measures make its stopping rule
    exactly this one: the residual measure is 0 at a positive definite
    Hessian (1 otherwise; ``rtol = 1/2``), the correction measure is
    ``r / (r + xtol)`` with ``r = |du|_inf / max(1, |x|_inf)`` (below
    ``utol = 1/2`` iff ``r < xtol``, and bounded: a line-search Newton has no
    divergence test).  ``result.extra`` is whether the last Hessian was
    positive definite.

    Returns
    -------
    (linearize, admissible)
    """
    P = counter.problem
    state = {}

    def linearize(u, p):
        E, g, H = P.derivatives(u, p)  # one assembly for all three
        fact = counter.factorize(H)
        du = -fact.solve(g)
        pd = fact.inertia() == 0
        size = float(np.max(np.abs(du))) if du.size else 0.0
        P.scale = max(1.0, float(np.max(np.abs(P.full(u, p)))))
        state.update(E=E, slope=float(g @ du), pd=pd, size=size, k=0)
        return (0.0 if pd else 1.0), du, np.zeros_like(p), fact, pd

    def admissible(ut, pt):
        t = 0.5 ** state["k"]
        state["k"] += 1
        Et = P.energy(np.asarray(ut), pt)
        return bool(np.isfinite(Et) and (Et <= state["E"] + 1e-4 * t * state["slope"]
                                         or (state["pd"] and state["size"] < 1e-6)))
    return linearize, admissible


def outcome(P: EnergyProblem, res):
    """``(x, converged, stable, iterations)`` of a corrector result on ``P``."""
    x = P.full(res.u, res.p)
    if res.converged:
        return x, True, True, res.iterations
    return x, False, bool(res.extra) and res.reason != "max iterations", res.iterations


def minimise(ops: Operators, x0, free, max_iter=100, xtol=1e-10):
    """Newton's method with line search for a local minimum of E over ``free`` dofs.

    Runs on the engine's corrector (:func:`skfem_sheet.engine.correct`) with
    the problem :class:`EnergyProblem` and the linearisation of
    :func:`energy_descent`.  Returns ``(x, converged, stable, iterations)``;
    ``stable`` is True when the reduced Hessian at the solution is positive
    definite (a local minimum).
    """
    P = EnergyProblem(free, ops, x0, xtol)
    counter = Counting(P)
    linearize, admissible = energy_descent(counter)
    res = correct(counter, np.array(x0, dtype=float)[P.free], np.zeros(0), linearize,
                  descent_tolerances(max_iter), admissible)
    return outcome(P, res)
