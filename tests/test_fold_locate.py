"""Fold location from an equilibrium outside Newton's basin for the fold system.

Near a fold that is flat in the parameter on a branch that curves strongly
in the state (a thin sheet: bending soft, membrane stiff), the first Newton
step on ``R = 0, sigma = 0`` from a point of the branch goes straight to the
fold's state and overshoots the fold in the parameter; off the curved branch
the residual and the test function are far from their linearisation and
Newton diverges.  ``locate_fold(..., approach=n)`` then approaches the fold
along the branch by pseudo-arclength steps (regular at the fold) and locates
it from the nearer point of the bracket; :func:`skfem_sheet.engine.natural`
does so at its last failed step.  ``approach=0`` (locate_fold's default) is
the old behaviour: Newton on the fold system only.
"""
import numpy as np
import pytest

from skfem_sheet import engine, foldcurve
from skfem_sheet.engine import FunctionProblem, locate_fold, natural
from skfem_sheet.engine.fold import FoldSystem, fold_test
from skfem_sheet.engine.protocol import Counting

# the toy: energy k (y - beta x^2)^2 / 2 + c x^3 / 3 - lam x.  Equilibria
# y = beta x^2, lam = c x^2: one fold at x = y = lam = 0, solutions for
# lam >= 0; the stiffness k along y makes the branch stiff off its curve.
K_STIFF, BETA, C = 1e5, 10.0, 1.0


def _toy():
    def residual(u, p):
        x, y = u
        m = y - BETA * x**2
        return np.array([-2 * K_STIFF * BETA * x * m + C * x**2 - p[0], K_STIFF * m])

    def jacobian(u, p):
        x, y = u
        m = y - BETA * x**2
        return np.array([[-2 * K_STIFF * BETA * m + 4 * K_STIFF * BETA**2 * x**2 + 2 * C * x,
                          -2 * K_STIFF * BETA * x],
                         [-2 * K_STIFF * BETA * x, K_STIFF]])

    return FunctionProblem(residual, jacobian, ("lam",))


def _on_branch(x):
    return np.array([x, BETA * x**2]), np.array([C * x**2])


def _check_toy_fold(P, fold):
    assert abs(fold.value) < 1e-12  # the fold of the normal form: lam = 0
    assert np.max(np.abs(fold.u)) < 1e-6
    assert fold.side == 1  # equilibria only for lam >= 0
    # the fold coefficient v . D^2 R[v, v] with v = (1, 0): 2 c (differences of tangents)
    assert abs(abs(fold.a) - 2 * C) < 1e-5
    assert np.linalg.norm(P.residual(fold.u, fold.p)) < 1e-10
    K = P.jacobian(fold.u, fold.p)
    assert np.linalg.norm(K @ fold.v) < 1e-8 * np.linalg.norm(K) * np.linalg.norm(fold.v)


def test_toy_fold_located_from_outside_the_fold_systems_basin():
    P = _toy()
    u, p = _on_branch(0.01)  # 2 beta x = 0.2: the test function still ~ linear in x
    # Newton on the fold system: its first step lands near the fold's state
    # (x to 8 % of the start), 2 lam away in lam; from there it diverges
    old, res = locate_fold(P, u, p, "lam")
    assert old is None and res.reason == "diverging"
    fold, res = locate_fold(P, u, p, "lam", approach=8)
    assert fold is not None and res.converged
    _check_toy_fold(P, fold)
    # the approach's work is counted in the result and the fold
    assert res.iterations == res.stats.newton_iterations == fold.stats.newton_iterations
    assert res.stats.factorizations >= res.iterations > 3


def test_toy_natural_continuation_ends_at_the_fold():
    """natural used to end with "step below min_step" and no fold: the fold
    system did not converge from its last point (the test asserts that this is
    still so for the plain fold system)."""
    P = _toy()
    u, p = _on_branch(0.1)
    b = natural(P, u, p, "lam", -0.01, step=0.002, min_step=3e-4, jump=0.1)
    last = b.points[-1]
    old, _ = locate_fold(P, last.u, last.p, "lam", approach=0)
    assert old is None
    assert b.fold is not None and not b.completed
    # the fold lies within the last failed step, which bracketed it
    lo, hi = sorted(b.bracket)
    assert lo <= b.fold.value <= hi
    _check_toy_fold(P, b.fold)


def test_approach_needs_an_equilibrium():
    """From a point off the branch (no equilibrium) nothing is approached:
    the result is Newton on the fold system's."""
    P = _toy()
    u, p = _on_branch(0.01)
    off = u + np.array([0.0, 1e-3])
    a, ra = locate_fold(P, off, p, "lam", approach=8)
    b, rb = locate_fold(P, off, p, "lam")
    assert (a is None) == (b is None)
    assert ra.iterations == rb.iterations and ra.stats == rb.stats


# the sheet: a/R 2.5 at hmax 0.2 on the mesh made at L 1.2825, pop-up fold at b/a 1
# (benchmarks/results/fold_curve_remesh_hmax0.2.txt, section 2): the fold-curve
# trace (continued in b) puts L0* at 1.236464 on this mesh
TRACE_POPUP = 1.236464


@pytest.fixture(scope="module")
def sheet_popup():
    P = foldcurve.SheetFoldProblem(2.5, hmax=0.2, mesh_length=1.2825)
    p0 = np.array([1.30, 1.0, 2.5])
    u0, _ = P.solve_state(p0, "gravity-first")
    b = natural(P, u0, p0, "L", 1.0, step=0.02, min_step=1e-4, tol=foldcurve.TOLERANCES,
                jump=0.1, check_inertia=True)
    return P, b


def test_sheet_popup_fold_located_by_natural_continuation(sheet_popup):
    P, b = sheet_popup
    tol = foldcurve.TOLERANCES
    last = b.points[-1]
    # the case of the record: Newton at fixed L fails within 1e-4 of the fold
    # and the fold system does not converge from the last point
    old, res = locate_fold(P, last.u, last.p, "L", tol=tol, approach=0)
    assert old is None, "the fold system converges now: this test no longer tests the approach"
    fold = b.fold
    assert fold is not None and fold.parameter == 0 and fold.side == 1  # pop-up: L >= L0*
    assert abs(fold.value - TRACE_POPUP) < 1e-5
    lo, hi = sorted(b.bracket)
    assert fold.value <= hi and fold.value < last.p[0]
    # an equilibrium at a fold: the residual within the stopping rule, and
    # Newton's correction on R = 0, sigma = 0 from there below its bound
    # (K is singular there: the correction at fixed L is not defined)
    r = P.residual(fold.u, fold.p)
    assert P.residual_norm(r) <= tol.rtol
    _, du, dp, _, _ = FoldSystem(Counting(P), fold.v, [0])(fold.u, fold.p)
    assert max(P.correction_norm(du), abs(dp[0])) <= tol.utol
    K = P.jacobian(fold.u, fold.p)
    fact = P.factorize(K)
    # with a null vector: the test function there is 1 % of its value at the
    # last point of the branch (1e-4 away in L), and exactly one eigenvalue
    # of the tangent crosses zero along v
    sigma, _ = fold_test(fact, lambda x: K @ x, fold.v)
    K_last = P.jacobian(last.u, last.p)
    sigma_last, _ = fold_test(P.factorize(K_last), lambda x: K_last @ x, fold.v)
    assert abs(sigma) < 1e-2 * abs(sigma_last)
    assert fold.crossing is not None and abs(fold.crossing[1] - fold.crossing[0]) == 1
    # locate_fold called directly from the last point, with the approach
    direct, res = locate_fold(P, last.u, last.p, "L", tol=tol, approach=8)
    assert direct is not None and res.converged
    assert abs(direct.value - fold.value) < 1e-7


def test_sheet_popup_fold_agrees_with_pseudo_arclength(sheet_popup):
    """Another route from the same last point: pseudo-arclength continuation
    through the fold, which brackets it by the sign change of the tangent's
    L component (L0* is the smallest L of the branch)."""
    P, b = sheet_popup
    last = b.points[-1]
    a = engine.arclength(P, last.u, last.p, "L", (1.2, float(last.p[0]) + 1e-3), ds=0.005,
                         direction=-1, tol=foldcurve.TOLERANCES, max_points=10)
    assert a.completed and len(a.folds) == 1
    t_p = np.array([pt.tangent_p for pt in a.points])
    assert t_p[0] < 0 < t_p[-1] and np.sum(np.diff(np.sign(t_p)) != 0) == 1
    assert np.all(a.values >= b.fold.value - 1e-9)
    assert abs(a.folds[0].value - b.fold.value) < 1e-7


# -- fold_on_branch: Newton on dp/dc along the branch ----------------------------------------
def test_toy_fold_on_branch_converges_quadratically_on_the_stiff_curved_branch():
    """From an equilibrium of the toy's stiff, curved branch (where the fold
    system diverges), Newton on ``g = dp/dc`` with the branch's curvature from
    residual differences: each section lands on the branch, and the load's
    distance to the fold falls quadratically (a secant's order would be 1.6)."""
    P = _toy()
    u, p = _on_branch(0.01)
    fold, res = engine.fold.fold_on_branch(Counting(P), u, p, "lam", np.array([1.0, 0.0]),
                                           ptol=1e-14)
    assert fold is not None and res.converged
    _check_toy_fold(P, fold)
    # lam = c x^2 on sections x = const: dp/dc = 2 c x, exactly linear, so one
    # Newton step lands on the fold; with the first section that is two
    # section solves and a couple of Newton iterations each
    assert res.stats.newton_iterations <= 8


def test_fold_on_branch_stops_at_the_stated_load_tolerance():
    """The iteration stops when the load would move less than ``ptol`` on the
    way to the fold, and then reports the fold the last step predicts: on the
    softening spring ``u - u^3/3 = lam`` (fold at lam = 2/3, u = 1) the loose
    tolerance takes fewer sections and the fold is still within ``ptol``."""
    P = FunctionProblem(lambda u, p: u - u**3 / 3 - p[0],
                        lambda u, p: np.diag(1 - u**2), ("lam",))
    counts = {}
    for ptol in (1e-3, 1e-12):
        c = Counting(P)
        f, res = engine.fold.fold_on_branch(c, np.array([0.9]), np.array([0.64]), "lam",
                                            np.ones(1), ptol=ptol)
        assert f is not None
        assert abs(f.value - 2.0 / 3.0) <= ptol
        assert abs(float(f.u[0]) - 1.0) <= 10 * np.sqrt(ptol)
        # v . D^2 R [v, v] = -2 u: -2 at the fold, read at the last section
        # (within 10 sqrt(ptol) of u = 1, like the state)
        assert f.side == -1 and abs(f.a - (-2.0)) <= 20 * np.sqrt(ptol) + 1e-6
        counts[ptol] = c.stats().factorizations
    assert counts[1e-3] < counts[1e-12]


def test_fold_on_branch_gives_up_at_a_minimum_of_the_load_rate_and_follows_an_overshoot():
    """Newton on ``g = dp/dc = 0`` along a branch whose rate has a positive
    minimum and no zero, ``lam = u^3/3 + u/5`` (``g = u^2 + 1/5``): the
    sections straddle the minimum, ``g'`` alternating, ``g`` not shrinking;
    the search stops there instead of running to ``max_iterations``.  On the
    softening spring ``u - u^3/3 = lam`` from ``u = 0.3`` the first step
    overshoots the fold at ``u = 1`` (``|g|`` grows, its sign changes) and
    Newton still converges to it."""
    P = FunctionProblem(lambda u, p: p[0] - u**3 / 3 - u / 5,
                        lambda u, p: np.diag(-(u**2 + 0.2)), ("lam",))
    for u0 in (0.3, 1.0, -0.5):
        c = Counting(P)
        f, res = engine.fold.fold_on_branch(c, np.array([u0]), np.array([u0**3 / 3 + u0 / 5]),
                                            "lam", np.ones(1))
        assert f is None and "does not contract" in res.reason
        # at most four section solves (of two or three Newton steps each),
        # where max_iterations (12) would have spent thirteen
        assert c.stats().factorizations <= 12
    S = FunctionProblem(lambda u, p: u - u**3 / 3 - p[0],
                        lambda u, p: np.diag(1 - u**2), ("lam",))
    f, res = engine.fold.fold_on_branch(Counting(S), np.array([0.3]),
                                        np.array([0.3 - 0.3**3 / 3]), "lam", np.ones(1))
    assert f is not None and abs(f.value - 2.0 / 3.0) <= 1e-9


@pytest.mark.parametrize("start", [1.05, 0.97])
def test_fold_on_branch_reads_the_fold_s_side_from_the_branch_s_curvature_in_the_load(start):
    """The side of a fold (where its branch's solutions lie) from the last
    section's curvature of the load, ``p - p* = g' (c - c*)^2 / 2``.  The
    spring ``x - x^3/3 = eps lam`` (fold at x = 1, lam* = 2/(3 eps),
    solutions below) with a second unknown that the load moves hard and the
    mode not at all, ``y = B lam``: at a section off the fold (here past it)
    ``v . R_lam`` of the branch's direction there is ``-eps - B^2 g`` with
    ``g = dlam/dx < 0``, so ``-sign(a v . R_lam)`` gives the wrong side
    (+1) once ``B^2 |g| > eps``; ``g'`` does not."""
    eps, B = 1e-2, 10.0
    P = FunctionProblem(lambda u, p: np.array([u[0] - u[0]**3 / 3 - eps * p[0],
                                               u[1] - B * p[0]]),
                        lambda u, p: np.diag([1 - u[0]**2, 1.0]), ("lam",))
    lam0 = (start - start**3 / 3) / eps
    c = Counting(P)
    f, res = engine.fold.fold_on_branch(c, np.array([start, B * lam0]), np.array([lam0]),
                                        "lam", np.array([1.0, 0.0]), ptol=1e-3)
    assert f is not None
    assert abs(f.value - 2 / (3 * eps)) <= 1e-3 * 2 / (3 * eps)
    assert f.side == -1


@pytest.mark.parametrize("one_sided", [False, True])
def test_sigma_derivatives_from_residuals_are_the_exact_third_derivatives(one_sided):
    # E = u1^4/4 + p0 u1 u2^2 + p1 u2^3/3: R = grad E is cubic in u and linear
    # in p, so the residual differences are exact (to round-off) for any step:
    # d sigma/du = -D^2 R[v, v] and d sigma/dp = -v.(dK/dp)v, worked by hand
    def R(u, p):
        return np.array([u[0]**3 + p[0] * u[1]**2, 2 * p[0] * u[0] * u[1] + p[1] * u[1]**2])

    def K(u, p):
        return np.array([[3 * u[0]**2, 2 * p[0] * u[1]],
                         [2 * p[0] * u[1], 2 * p[0] * u[0] + 2 * p[1] * u[1]]])

    P = FunctionProblem(R, K, ("p0", "p1"))
    P.fd_one_sided = one_sided
    u, p, v = np.array([0.7, -1.3]), np.array([0.4, 1.1]), np.array([0.6, 0.8])
    g_u, g_p = FoldSystem(Counting(P), v, (0, 1)).sigma_derivatives(u, p, v)
    D2R = np.array([6 * u[0] * v[0]**2 + 2 * p[0] * v[1]**2,
                    4 * p[0] * v[0] * v[1] + 2 * p[1] * v[1]**2])
    vKv_p = np.array([4 * u[1] * v[0] * v[1] + 2 * u[0] * v[1]**2, 2 * u[1] * v[1]**2])
    np.testing.assert_allclose(g_u, -D2R, rtol=1e-7)
    np.testing.assert_allclose(g_p, -vKv_p, rtol=1e-6)
