"""Stability of an equilibrium from the inertia of its constrained tangent.

:func:`stability` reads the inertia of the tangent a solver has factorised.
A symmetric half model (``U_y = 0`` on the symmetry plane ``y = 0``) sees only
perturbations that are mirror-symmetric like the state.  At a symmetric state
the whole sheet's Hessian splits into two blocks that do not couple (the
energy is mirror-invariant, so its second variation has no cross terms
between a mirror-symmetric and a mirror-antisymmetric perturbation): the
symmetric one, which the half model factorises, and the antisymmetric one,
the same half mesh's Hessian under the mirror's other condition -- ``U_x =
U_z = 0`` and the pressure zero on ``y = 0``, ``U_y`` free there
(:func:`antisymmetric_stability`).  The whole sheet's negative eigenvalues are
those of both blocks together, so the half model is stable against every
perturbation exactly when both counts are zero.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..linalg import LinearSolverError, make_linear_solver

__all__ = ["MODE_KINDS", "AntisymmetricStability", "antisymmetric_problem_dofs",
           "antisymmetric_stability", "antisymmetric_tangent", "mode_kind", "stability"]

#: Largest tangent checked with SuperLU when the solver cannot tell its inertia.
_SUPERLU_CHECK_DOFS = 100_000

#: The kinds an antisymmetric mode is named by (:func:`mode_kind`), by the
#: displacement component it moves most (in the reference frame): ``U_z``,
#: odd in ``y``, lifts one side of the sheet and lowers the other (a twist
#: about its axis); ``U_y``, even in ``y``, moves both sides the same way
#: across (a sideways sway); ``U_x``, odd in ``y``, shears the plan (one side
#: advances, the other retreats: bending in the sheet's own plane).
MODE_KINDS = {2: "twisting", 1: "lateral", 0: "in-plane bending"}


def stability(problem, solver):
    """``(stable, n_negative)`` from the inertia of the last factorised tangent.

    The reduced tangent ``[[A, B^T], [B, 0]]`` with ``m`` free pressure dofs
    (``B`` of full rank) has ``m + k`` negative eigenvalues, where ``k`` is the
    number of negative eigenvalues of ``A`` on the incompressible subspace
    ``ker B`` (Sylvester's law of inertia on the null-space decomposition).
    The equilibrium is stable iff ``k = 0`` and no eigenvalue vanishes.

    Returns ``(None, None)`` -- stability unknown -- if the back-end does not
    report the inertia, or if its last factorisation perturbed pivots
    (``solver.perturbed_pivots > 0``, PARDISO's ``iparm(14)``): the pivot
    counts are then those of a nearby matrix, and an eigenvalue at or near
    zero (a fold) may have been counted on either side.
    """
    m = int(np.count_nonzero(problem.free >= problem.nu_dof))
    return _verdict(solver, m)


def _verdict(solver, m):
    if getattr(solver, "perturbed_pivots", 0):
        return None, None
    inertia = getattr(solver, "inertia", None)
    inertia = inertia() if inertia is not None else None
    if inertia is None:
        return None, None
    _, n_neg, n_zero = inertia
    k = int(n_neg) - m
    return bool(k == 0 and n_zero == 0), k


def antisymmetric_problem_dofs(problem):
    """The free dofs of the antisymmetric problem on a half model's mesh:
    ``(free, keep, extra)``.

    ``free`` (sorted) are all dofs but the clamp's and, on the symmetry plane,
    ``U_x``, ``U_z`` and the pressure (a mirror-antisymmetric field vanishes
    there in its components that are odd in ``y``); ``keep`` are the
    positions in the half model's own free dofs (``problem.free``) of those
    free in both problems, and ``extra`` the dofs free here only: ``U_y`` on
    the symmetry plane off the clamp (the half model fixes it).
    """
    space = problem.space
    nodes = np.asarray(space.symmetry_nodes)
    fixed = np.zeros(problem.ndof, bool)
    fixed[problem.clamp_dofs] = True
    fixed[3 * nodes] = True
    fixed[3 * nodes + 2] = True
    fixed[problem.nu_dof + nodes[nodes < problem.n_vertices]] = True
    free = np.flatnonzero(~fixed)
    sym_free = np.zeros(problem.ndof, bool)
    sym_free[problem.free] = True
    position = np.full(problem.ndof, -1)
    position[problem.free] = np.arange(len(problem.free))
    keep = position[free[sym_free[free]]]
    extra = free[~sym_free[free]]
    return free, keep, extra


def antisymmetric_tangent(problem, w, K=None):
    """The Hessian at ``w`` of the half model's mesh under the antisymmetric
    condition (see the module), as a CSR matrix on the dofs ``keep`` then
    ``extra`` of :func:`antisymmetric_problem_dofs`.

    The entries among the dofs free in both problems are the half model's
    tangent ``K`` (assembled at ``w`` if not given); the rows of the extra
    dofs (``U_y`` on the symmetry plane) come from the element matrices of
    the elements that touch them, a strip along the plane.
    """
    free, keep, extra = antisymmetric_problem_dofs(problem)
    if K is None:
        K = problem.tangent(w)
    K11 = K[keep][:, keep]
    if not len(extra):
        return K11.tocsr()
    is_extra = np.zeros(problem.ndof, bool)
    is_extra[extra] = True
    edofs = problem.edofs
    elements = np.flatnonzero(is_extra[edofs].any(axis=1))
    Ke = problem.element_matrices(w, elements)
    d = edofs[elements]
    rows = np.broadcast_to(d[:, :, None], Ke.shape)
    cols = np.broadcast_to(d[:, None, :], Ke.shape)
    take = is_extra[rows]
    # the extra rows against every dof, in the numbering keep, then extra
    col_index = np.full(problem.ndof, -1)
    col_index[free[np.isin(free, extra, invert=True)]] = np.arange(len(keep))
    col_index[extra] = len(keep) + np.arange(len(extra))
    row_index = np.full(problem.ndof, -1)
    row_index[extra] = np.arange(len(extra))
    r, c, v = row_index[rows[take]], col_index[cols[take]], Ke[take]
    ok = c >= 0  # not against a fixed dof
    A = sp.csr_matrix((v[ok], (r[ok], c[ok])), shape=(len(extra), len(keep) + len(extra)))
    K21, K22 = A[:, :len(keep)], A[:, len(keep):]
    return sp.bmat([[K11, K21.T], [K21, K22]], format="csr")


@dataclass(frozen=True)
class AntisymmetricStability:
    """The antisymmetric half of a symmetric state's stability
    (:func:`antisymmetric_stability`).

    Attributes
    ----------
    stable : bool or None
        No negative and no zero eigenvalue of the constrained antisymmetric
        Hessian (None: the linear solver cannot tell).
    negative_eigenvalues : int or None
    mode : str
        The kind of the antisymmetric mode nearest zero where it is negative
        (:data:`MODE_KINDS`), "" otherwise.
    factorizations : int
        Factorisations made (one, or two with a SuperLU check).
    """

    stable: object
    negative_eigenvalues: object
    mode: str = ""
    factorizations: int = 0


def antisymmetric_stability(problem, w, solver="auto", K=None) -> AntisymmetricStability:
    """Stability of the symmetric state ``w`` of a half model against the
    mirror-antisymmetric perturbations, which the half model does not see.

    One factorisation of :func:`antisymmetric_tangent` on a fresh linear
    solver of the kind ``solver`` (the problem's own solver keeps its
    factorisation); its inertia, less the free pressures of the
    antisymmetric problem, is the number of negative eigenvalues on its
    incompressible subspace (as in :func:`stability`).  Where the back-end
    cannot tell (perturbed pivots, or no inertia at all), once more with
    SuperLU up to ``_SUPERLU_CHECK_DOFS`` unknowns.  A negative count is
    explained by the kind of mode (:func:`mode_kind`).

    Parameters
    ----------
    problem : SheetProblem
        A half model (``problem.sheet_mesh.half``).
    w : ndarray
        A mirror-symmetric equilibrium of it.
    solver : str
        The linear solver's name (:func:`~skfem_sheet.linalg.make_linear_solver`).
    K : sparse matrix, optional
        The half model's tangent at ``w`` if at hand.

    Examples
    --------
    >>> from skfem_sheet import Sheet
    >>> from skfem_sheet.solve import build_problem
    >>> p = build_problem(Sheet(length=0.6), 0.2, half=True)
    >>> antisymmetric_stability(p, np.zeros(p.ndof)).negative_eigenvalues   # the flat sheet
    0
    """
    if not problem.sheet_mesh.half:
        raise ValueError("the antisymmetric problem is the half model's other condition: "
                         "problem must be a half model")
    free, keep, extra = antisymmetric_problem_dofs(problem)
    Ka = antisymmetric_tangent(problem, w, K)
    m = int(np.count_nonzero(free >= problem.nu_dof))
    n = 0
    verdict = (None, None)
    linear = make_linear_solver(solver)
    # an iterative back-end (it needs the saddle-point layout) tells no inertia
    tries = [] if getattr(linear, "needs_layout", False) else [linear]
    if linear.name != "superlu" and Ka.shape[0] <= _SUPERLU_CHECK_DOFS:
        tries.append(None)  # SuperLU, made if needed
    for linear in tries:
        linear = linear if linear is not None else make_linear_solver("superlu")
        try:
            linear.factorize(Ka)
        except LinearSolverError:
            continue
        n += 1
        verdict = _verdict(linear, m)
        if verdict[0] is not None:
            break
    mode = ""
    if verdict[1] is not None and verdict[1] > 0:
        order = np.concatenate([free[np.isin(free, extra, invert=True)], extra])
        mode = mode_kind(linear, order < problem.nu_dof, order % 3)
    return AntisymmetricStability(verdict[0], verdict[1], mode, n)


def mode_kind(linear, is_u, components, iterations: int = 30) -> str:
    """The kind (:data:`MODE_KINDS`) of the mode of the factorised constrained
    Hessian nearest zero, if its eigenvalue is negative ("" otherwise).

    Inverse iteration on the pencil ``(K, M)``, ``M`` the identity on the
    displacement dofs ``is_u`` and zero on the pressures: ``x <- K^-1 M x``
    converges to the eigenvector of the eigenvalue of least magnitude (one
    back-substitution each, with the factorisation at hand); its Rayleigh
    quotient ``x.K x / x.M x`` says whether that eigenvalue is negative.  The
    kind is the displacement component that carries most of the mode.
    """
    rng = np.random.default_rng(0)
    x = np.where(is_u, rng.standard_normal(len(is_u)), 0.0)
    y = x
    for _ in range(iterations):
        y = np.asarray(linear.solve(np.where(is_u, x, 0.0)), dtype=float).ravel()
        norm = float(np.linalg.norm(y[is_u]))
        if not norm > 0:
            return ""
        x = y / norm
    # x.K x with K x = M x_prev: with x = K^-1 M x_prev / |.|, x.K x = x.(M x_prev) / |.|
    prev = np.where(is_u, x, 0.0)
    z = np.asarray(linear.solve(prev), dtype=float).ravel()
    rayleigh = float(prev @ prev) / float(z @ prev) if float(z @ prev) != 0 else 0.0
    if not rayleigh < 0:
        return ""
    share = [float(np.sum(x[is_u & (components == c)] ** 2)) for c in range(3)]
    return MODE_KINDS[int(np.argmax(share))]
