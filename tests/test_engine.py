"""The continuation engine on cheap problems with known answers."""
import numpy as np
import pytest
import scipy.linalg as sla

from skfem_sheet.engine import (
    FoldPoint,
    FunctionProblem,
    Problem,
    Tolerances,
    arclength,
    fold_curve,
    locate_fold,
    natural,
    newton,
)
from skfem_sheet.params import ParameterError

LAM_STAR = 2.0 / (3.0 * np.sqrt(3.0))


def s_curve_problem():
    """u^3 - u + lam = 0: folds at lam = +-2/(3 sqrt 3), u = -+1/sqrt 3."""
    return FunctionProblem(lambda u, p: u**3 - u + p[0], lambda u, p: np.diag(3 * u**2 - 1),
                           ("lam",))


def cusp_problem():
    """u^3 - mu u - lam = 0: fold curve 27 lam^2 = 4 mu^3 (mu = 3u^2, lam = -2u^3)."""
    return FunctionProblem(lambda u, p: u**3 - p[1] * u - p[0],
                           lambda u, p: np.diag(3 * u**2 - p[1]), ("lam", "mu"))


class HeavyColumn(Problem):
    """A discrete heavy elastica standing up from a clamp tilted by ``alpha``.

    N rigid links of length ds = 1/N with rotational springs (bending
    stiffness 1), angles theta_i from the vertical, weight G per length::

        Pi = sum (theta_i - theta_{i-1})^2 / (2 ds) + G ds^2 sum c_i cos theta_i,
        theta_0 = alpha,  c_i = N - i + 1/2  (links above i, plus half of itself).

    The tangent is symmetric (an energy Hessian).  At alpha = 0 the upright
    column buckles (a pitchfork) at the smallest generalised eigenvalue G_c of
    ``(T / ds, ds^2 diag(c))``; a tilt unfolds it: the branch leaning against
    the tilt has a fold G*(alpha), and the fold curve in (G, alpha) has a cusp
    at (G_c, 0).  Parameters ``p = (G, alpha)``; dR/dp by the default
    central difference.
    """

    parameter_names = ("G", "alpha")

    def __init__(self, n=8):
        self.n, self.ds = n, 1.0 / n
        self.c = n - np.arange(1, n + 1) + 0.5
        T = 2 * np.eye(n) - np.eye(n, k=1) - np.eye(n, k=-1)
        T[-1, -1] = 1.0
        self.T = T / self.ds

    def residual(self, u, p):
        G, alpha = p
        th = np.concatenate([[alpha], u])
        d = np.diff(th) / self.ds
        r = d.copy()
        r[:-1] -= d[1:]
        return r - G * self.ds**2 * self.c * np.sin(u)

    def jacobian(self, u, p):
        return self.T - np.diag(p[0] * self.ds**2 * self.c * np.cos(u))

    def critical_load(self):
        w, V = sla.eigh(self.T, np.diag(self.ds**2 * self.c))
        return float(w[0]), V[:, 0]


# ---------------------------------------------------------------------------
# Newton
# ---------------------------------------------------------------------------
def test_newton_converges_and_counts_one_factorisation_per_iteration():
    P = FunctionProblem(lambda u, p: u**2 - p[0], lambda u, p: np.diag(2 * u))
    r = newton(P, np.array([3.0]), [2.0])
    assert r.converged and r.reason == ""
    assert r.u[0] == pytest.approx(np.sqrt(2.0), abs=1e-14)
    assert r.stats.factorizations == r.iterations == r.stats.newton_iterations
    rn, dn = r.history[-1]
    assert rn <= 1e-10 and dn <= 1e-10


def test_failed_newton_is_reported_as_failed():
    """u^2 + 1 = 0 has no real root: never returned as converged."""
    P = FunctionProblem(lambda u, p: u**2 + p[0], lambda u, p: np.diag(2 * u))
    r = newton(P, np.array([0.5]), [1.0], tol=Tolerances(max_iterations=30))
    assert not r.converged and r.reason
    assert abs(P.residual(r.u, [1.0])[0]) > 0.5
    # a guard on the first correction is a failure too
    g = newton(P, np.array([0.5]), [-4.0], tol=Tolerances(max_correction=0.1))
    assert not g.converged and "first correction" in g.reason


def test_inadmissible_states_are_halved_then_reported():
    """A residual that is NaN for u <= 0 (an inverted element): sqrt-like root."""
    def res(u, p):
        return np.where(u > 0, np.log(np.where(u > 0, u, 1.0)) - p[0], np.nan)

    P = FunctionProblem(res, lambda u, p: np.diag(1.0 / u))
    r = newton(P, np.array([3.0]), [0.0])  # the full first step lands at u < 0
    assert r.converged and r.u[0] == pytest.approx(1.0, abs=1e-12)


def test_bad_tolerances_raise_parameter_error():
    with pytest.raises(ParameterError, match="rtol"):
        Tolerances(rtol=-1.0)
    with pytest.raises(ParameterError, match="max_iterations"):
        Tolerances(max_iterations=0)


# ---------------------------------------------------------------------------
# folds in one parameter
# ---------------------------------------------------------------------------
def test_natural_continuation_locates_the_fold_to_1e_8():
    b = natural(s_curve_problem(), np.array([1.2]), np.array([-0.5]), "lam", 1.0, step=0.1,
                jump=0.3)
    assert not b.completed and b.fold is not None
    assert abs(b.fold.value - LAM_STAR) < 1e-8
    assert b.fold.u[0] == pytest.approx(1 / np.sqrt(3), abs=1e-6)
    lo, hi = b.bracket
    assert lo < b.fold.value <= hi
    # solutions exist below the fold; the branch points increase towards it
    assert b.fold.side == -1
    assert np.all(np.diff(b.values) > 0) and b.values[-1] < LAM_STAR


def test_natural_continuation_that_holds_completes():
    b = natural(s_curve_problem(), np.array([1.2]), np.array([-0.5]), 0, 0.2, step=0.1)
    assert b.completed and b.fold is None and b.values[-1] == pytest.approx(0.2)


def test_inertia_changes_by_exactly_one_across_a_fold():
    P = s_curve_problem()
    fold, _ = locate_fold(P, np.array([0.7]), np.array([0.3]), "lam", check_inertia=True)
    assert abs(fold.value - LAM_STAR) < 1e-10
    n_minus, n_plus = fold.crossing
    assert abs(n_plus - n_minus) == 1
    assert fold.negative_eigenvalues == min(n_minus, n_plus) == 0


def test_pseudo_arclength_passes_both_folds_of_an_s_curve():
    P = s_curve_problem()
    b = arclength(P, np.array([-1.5]), np.array([1.875]), "lam", (-2.0, 2.0), ds=0.2,
                  direction=-1)
    assert b.completed
    assert [f.value for f in b.folds] == pytest.approx([-LAM_STAR, LAM_STAR], abs=1e-10)
    # every point is an equilibrium; the u of the points decreases past both folds
    u = np.array([pt.u[0] for pt in b.points])
    assert np.all(np.diff(u) > 0)
    assert u[0] < -1 / np.sqrt(3) and u[-1] > 1 / np.sqrt(3)
    # stable, unstable (one negative eigenvalue), stable: changes of exactly one
    k = np.array([pt.negative_eigenvalues for pt in b.points])
    assert k[0] == 0 and k[-1] == 0 and k.max() == 1
    assert np.count_nonzero(np.diff(k)) == 2
    assert np.all((k == 1) == (np.abs(u) < 1 / np.sqrt(3)))


# ---------------------------------------------------------------------------
# fold curves and the cusp
# ---------------------------------------------------------------------------
def test_fold_curve_without_cusp_location_has_the_same_points():
    # max_cusp_iterations=0 (the coarse trace of a curve refined coarse to
    # fine): the cusp is not located, its sign change stays in the points'
    # fold coefficient, and the curve is the same point for point, with
    # fewer factorisations
    P = cusp_problem()
    start, _ = locate_fold(P, np.array([0.8]), np.array([-0.5, 1.0]), "lam")
    kw = dict(ds=0.1, direction=-1)
    located = fold_curve(P, start, ("lam", "mu"), ((-1.0, 1.0), (-0.5, 1.0)), **kw)
    seeds = fold_curve(P, start, ("lam", "mu"), ((-1.0, 1.0), (-0.5, 1.0)),
                       max_cusp_iterations=0, **kw)
    assert located.completed and seeds.completed
    assert len(located.cusps) == 1 and seeds.cusps == ()
    np.testing.assert_array_equal(seeds.params, located.params)
    a = np.array([pt.a for pt in seeds.points])
    assert np.count_nonzero(np.sign(a[1:]) != np.sign(a[:-1])) == 1
    assert seeds.stats.factorizations < located.stats.factorizations


def test_fold_curve_of_the_cusp_normal_form():
    P = cusp_problem()
    start, _ = locate_fold(P, np.array([0.8]), np.array([-0.5, 1.0]), "lam")
    assert isinstance(start, FoldPoint)
    c = fold_curve(P, start, ("lam", "mu"), ((-1.0, 1.0), (-0.5, 1.0)), ds=0.1, direction=-1,
                   check_inertia=True)
    assert c.completed, c.reason
    lam, mu = c.params.T
    # on the fold curve 27 lam^2 = 4 mu^3, from one branch of it to the other
    np.testing.assert_allclose(27 * lam**2, 4 * mu**3, atol=1e-8)
    assert lam[0] < 0 < lam[-1]
    assert mu[-1] == pytest.approx(1.0, abs=1e-12) and c.points[-1].clipped
    assert lam[-1] == pytest.approx(2 / (3 * np.sqrt(3)), abs=1e-10)
    # one cusp, at the origin
    assert len(c.cusps) == 1
    assert np.abs(c.cusps[0].p).max() < 1e-6
    # the curve's projection turns back there: mu = 3 u^2 has its minimum
    assert c.cusps[0].tangent_reversal == (False, True)
    # the fold kind flips at the cusp: a changes sign once, so does the side
    a = np.array([pt.a for pt in c.points])
    assert np.count_nonzero(np.diff(np.sign(a))) == 1
    sides = [pt.side for pt in c.points]
    assert sides[0] == -sides[-1] != 0
    assert np.count_nonzero(np.diff(sides)) == 1
    # exactly one eigenvalue crosses zero at every fold of the curve
    for pt in c.points[:-1]:
        n_minus, n_plus = pt.crossing
        assert abs(n_plus - n_minus) == 1
    # one factorisation per Newton step of the extended system (+ the first
    # linearisation at the start, + 2 per inertia check, every point here)
    assert c.stats.factorizations == c.stats.newton_iterations + 1 + 2 * len(c.points)
    # a few factorisations per point (+ 2 for the inertia check), not a bisection
    assert np.median([pt.iterations for pt in c.points]) <= 5
    assert np.all(c.factorizations_per_point[1:] >= np.array([pt.iterations + 2
                                                               for pt in c.points[1:]]))


def test_heavy_column_fold_curve_against_brute_force():
    col = HeavyColumn(8)
    G_c, mode = col.critical_load()
    alpha0 = 0.05
    # the branch leaning against the tilt: start on it at a large load, follow it
    # down in G to its fold
    guess = -0.6 * mode / np.abs(mode).max()
    b = natural(col, guess, np.array([1.3 * G_c, alpha0]), "G", 0.5 * G_c, step=0.05 * G_c,
                jump=0.5)
    assert b.fold is not None, b.reason
    G_fold = b.fold.value
    assert G_c < G_fold < 1.3 * G_c and b.fold.side == 1
    c = fold_curve(col, b.fold, ("G", "alpha"), ((0.5 * G_c, 2 * G_c), (-alpha0, alpha0)),
                   ds=0.05, ds_max=0.2, direction=-1, check_inertia=True, keep_states=True)
    assert c.completed, c.reason
    G, alpha = c.params.T
    # the cusp: the pitchfork of the upright column, at the eigenvalue load
    assert len(c.cusps) == 1
    cusp = c.cusps[0]
    assert abs(cusp.p[1]) < 1e-6 and cusp.p[0] == pytest.approx(G_c, abs=1e-6)
    assert cusp.tangent_reversal == (True, False)  # G*(alpha) has its minimum there
    assert np.abs(cusp.u).max() < 1e-3
    # symmetric in alpha (theta -> -theta): G*(alpha) = G*(-alpha)
    assert alpha[-1] == pytest.approx(-alpha0) and G[-1] == pytest.approx(G[0], abs=1e-8)
    # brute force: natural continuation in G with small steps at a few tilts
    checked = 0
    for k in (1, len(c.points) // 3, len(c.points) - 2):
        a_k = alpha[k]
        if abs(a_k) < 5e-3:
            continue
        brute = _brute_force_fold(col, c.points[k].u, G[k], a_k)
        assert G[k] == pytest.approx(brute, abs=2e-4 * G_c)
        checked += 1
    assert checked >= 2
    for pt in c.points[:-1]:
        assert abs(pt.crossing[1] - pt.crossing[0]) == 1


def _brute_force_fold(col, u_fold, G_fold, alpha, step=1e-4):
    """Last load where plain Newton from the previous state still finds the
    branch, walking down in G in fixed small steps from above the fold."""
    tol = Tolerances(max_iterations=30, max_correction=0.05)
    G = G_fold * 1.02
    r = newton(col, u_fold, [G, alpha], tol=Tolerances(max_iterations=50))
    assert r.converged
    u = r.u
    while True:
        G_try = G - step * G_fold
        r = newton(col, u, [G_try, alpha], tol=tol)
        if not r.converged:
            return G - 0.5 * step * G_fold
        u, G = r.u, G_try


def test_drivers_reject_bad_input():
    P = s_curve_problem()
    with pytest.raises(ParameterError, match="parameter"):
        natural(P, np.array([1.0]), np.array([0.0]), "mu", 1.0)
    with pytest.raises(ParameterError, match="bounds"):
        arclength(P, np.array([1.0]), np.array([0.0]), 0, (1.0, -1.0))
    with pytest.raises(ParameterError, match="start"):
        fold_curve(cusp_problem(), (np.zeros(1), np.zeros(2)), (0, 1), ((-1, 1), (-1, 1)))
