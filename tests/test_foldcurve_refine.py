"""Fold curves coarse to fine, the mapped space, the quadratic predictor, the series."""
import json

import numpy as np
import pytest

from skfem_sheet.cli import main
from skfem_sheet.engine import (
    FunctionProblem,
    Tolerances,
    fold_curve,
    fold_on_section,
    locate_fold,
)
from skfem_sheet.engine.fold import equilibrium_on_section
from skfem_sheet.foldcurve import CUSP_TOL, KeptPoint, SheetFoldProblem, trace_fold_curve
from skfem_sheet.foldcurve.cusp import cusp_by_coefficient
from skfem_sheet.io import Series, read_pvd
from skfem_sheet.params import ParameterError

COARSE = 0.2


def cusp_problem():
    return FunctionProblem(lambda u, p: u**3 - p[1] * u - p[0],
                           lambda u, p: np.diag(3 * u**2 - p[1]), ("lam", "mu"))


class _ToyCusp(FunctionProblem):
    """The cusp normal form with a second state ``y`` read as the tip
    deflection: equilibria ``y = x``, ``x^3 - b x - L = 0``, folds at ``(L, b) = (-2 c^3, 3 c^2)``,
    ``x = y = c``, the cusp at the origin."""

    tip_index = 1
    refactorizations = 0

    def __init__(self):
        # the gradient of x^4/4 - b x^2/2 - L x + (y - x)^2/2 (a symmetric tangent)
        super().__init__(lambda u, p: np.array([u[0]**3 - p[1] * u[0] - p[0] - (u[1] - u[0]),
                                                u[1] - u[0]]),
                         lambda u, p: np.array([[3 * u[0]**2 - p[1] + 1, -1.0], [-1.0, 1.0]]),
                         ("L", "b"))


def _toy_points(P, cs):
    out = []
    for c in cs:
        f, res = fold_on_section(P, np.array([c, c]) * 1.02, np.array([-2 * c**3, 3 * c**2]),
                                 ("L", "b"), (np.array([0.0, 1.0]), np.zeros(2), c),
                                 v0=np.ones(2))
        assert f is not None, res.reason
        out.append(KeptPoint(P, f.p, f.u, f.v, f.a, f.side, float(f.u[1])))
    return out


def test_cusp_of_refined_points_is_located_where_the_fold_coefficient_vanishes():
    """The refined points next to the cusp all on one side of it (as when the
    coarse cusp is not the fine one): the cusp is found by stepping on to the
    sign change of the fold coefficient; b* to the stopping tolerance (b =
    3 c^2 is stationary there), a few corrections; no sign change: none."""
    P = _ToyCusp()
    points = _toy_points(P, [0.045, 0.04, 0.035, -0.3])
    cusp, spent = cusp_by_coefficient(points, 1, Tolerances(rtol=1e-10, utol=1e-10))
    assert cusp is not None
    assert abs(cusp["tip_width"]) < CUSP_TOL
    assert abs(cusp["length"]) < 1e-5
    assert 0 < spent <= 40
    assert cusp_by_coefficient(points[:3], 1, Tolerances()) == (None, 0)


def test_mapped_space_gives_the_residual_and_tangent_of_a_built_space():
    """The space carried element by element onto the mapped mesh is the space
    scikit-fem builds there: same residual and tangent (a squeezed, stretched
    trapezoid)."""
    P = SheetFoldProblem(2.5, hmax=COARSE, mesh_length=1.3)
    fast, built = P.at(1.4, 0.7), P.at(1.4, 0.7, bases=True)
    w = P.full(np.random.default_rng(1).normal(size=P.n) * 1e-3, [1.4, 0.7])
    r1, r2 = fast.residual(w, 1.0)[0], built.residual(w, 1.0)[0]
    np.testing.assert_allclose(r1, r2, rtol=1e-10, atol=1e-12 * np.abs(r2).max())
    K1, K2 = fast.tangent(w), built.tangent(w)
    assert abs(K1 - K2).max() <= 1e-10 * abs(K2).max()
    assert fast.volume0 == pytest.approx(built.volume0, rel=1e-12)


def test_fold_on_section_passes_the_cusp_of_the_normal_form():
    """On the sections u = c the fold of u^3 - mu u - lam is (lam, mu) =
    (-2 c^3, 3 c^2), also at the cusp c = 0, where neither parameter
    parametrises the fold curve."""
    P = cusp_problem()
    for c in (-0.5, -1e-3, 0.0, 0.3):
        f, res = fold_on_section(P, np.array([c + 0.05]), np.array([-2 * c**3 + 0.01,
                                                                    3 * c**2 + 0.02]),
                                 ("lam", "mu"), (np.ones(1), np.zeros(2), c), v0=np.ones(1))
        assert f is not None, res.reason
        np.testing.assert_allclose(f.p, [-2 * c**3, 3 * c**2], atol=1e-10)


def test_equilibrium_on_section_settles_near_a_fold():
    """u^3 - u + lam = 0 near its fold (u = 1/sqrt 3): on the section
    u = 0.6 the equilibrium is lam = u - u^3 (the bordered matrix is regular
    although K nearly vanishes)."""
    P = FunctionProblem(lambda u, p: u**3 - u + p[0], lambda u, p: np.diag(3 * u**2 - 1),
                        ("lam",))
    r = equilibrium_on_section(P, np.array([0.58]), np.array([0.3]), "lam",
                               (np.ones(1), np.zeros(1), 0.6))
    assert r.converged
    assert r.p[0] == pytest.approx(0.6 - 0.6**3, abs=1e-12)


def test_quadratic_predictor_with_step_control_traces_the_cusp_curve():
    """The quadratic predictor and the step control by the first correction
    give the same curve and cusp (27 lam^2 = 4 mu^3, cusp at 0 to 1e-6)."""
    P = cusp_problem()
    start, _ = locate_fold(P, np.array([0.8]), np.array([-0.5, 1.0]), "lam")
    c = fold_curve(P, start, ("lam", "mu"), ((-1.0, 1.0), (-0.5, 1.0)), ds=0.1, direction=-1,
                   predictor="quadratic", target_correction=1e-3, ds_max=0.5)
    assert c.completed, c.reason
    lam, mu = c.params.T
    np.testing.assert_allclose(27 * lam**2, 4 * mu**3, atol=1e-8)
    assert len(c.cusps) == 1 and np.abs(c.cusps[0].p).max() < 1e-6
    with pytest.raises(ParameterError, match="predictor"):
        fold_curve(P, start, ("lam", "mu"), ((-1.0, 1.0), (-0.5, 1.0)), predictor="cubic")


def test_on_point_sees_every_point_with_its_state_and_null_vector():
    P = cusp_problem()
    start, _ = locate_fold(P, np.array([0.8]), np.array([-0.5, 1.0]), "lam")
    seen = []
    c = fold_curve(P, start, ("lam", "mu"), ((-1.0, 1.0), (-0.5, 1.0)), ds=0.1, direction=-1,
                   on_point=lambda pt, u, v: seen.append((pt.p.copy(), u.copy(), v.copy())))
    assert len(seen) == len(c.points)
    for (p, u, v), pt in zip(seen, c.points):
        np.testing.assert_allclose(p, pt.p)
        assert abs(3 * u[0] ** 2 - p[1]) < 1e-8  # u is the fold's state: K(u) = 0
        assert abs(v[0]) == pytest.approx(1.0)


def test_fold_curve_series_reads_back_with_meshio(tmp_path):
    """Issue 15 item 1 for fold curves: one state per point of the curve, the
    point index as time, the whole sheet mirrored (as Result.write)."""
    meshio = pytest.importorskip("meshio")
    s = Series()
    c = trace_fold_curve(2.5, hmax=COARSE, max_points=3, check_inertia=0, series=s)
    assert len(s) == len(c.points) == 3
    pvd = s.write(tmp_path, "fold-curve")
    steps = read_pvd(pvd)
    assert len(steps) == len(c.points)
    times = [t for t, _ in steps]
    assert np.all(np.diff(times) > 0)
    P = SheetFoldProblem(2.5, hmax=COARSE, mesh_length=1.3)
    n_half = P.base.sheet_mesh.n_vertices
    for (_t, path), pt in zip(steps, c.points):
        m = meshio.read(path)
        assert n_half < len(m.points) < 2 * n_half  # mirrored: the whole sheet
        assert np.isfinite(m.point_data["displacement"]).all()
        assert m.points[:, 0].max() == pytest.approx(pt["length"], rel=1e-9)


def test_coarse_hmax_is_checked():
    with pytest.raises(ParameterError, match="coarse_hmax"):
        trace_fold_curve(2.5, hmax=0.1, coarse_hmax=0.01)
    with pytest.raises(ParameterError, match="fine_points"):
        trace_fold_curve(2.5, hmax=0.1, coarse_hmax=0.2, fine_points=1)


@pytest.mark.slow
def test_refined_curve_agrees_with_the_curve_traced_at_the_fine_mesh():
    """Coarse to fine (0.2 -> 0.15): the folds at b = 1 and the cusp as the
    curve traced directly at hmax 0.15 (to the tolerance of a fold location
    on another mesh of the same size: 0.003), a few factorisations per point."""
    direct = trace_fold_curve(2.5, hmax=0.15, check_inertia=0)
    fine = trace_fold_curve(2.5, hmax=0.15, coarse_hmax=0.2, fine_points=6, check_inertia=3)
    assert fine.completed, fine.reason
    assert fine.standout_length == pytest.approx(direct.standout_length, abs=3e-3)
    assert fine.popup_length == pytest.approx(direct.popup_length, abs=3e-3)
    assert fine.cusp["tip_width"] == pytest.approx(direct.cusp["tip_width"], abs=5e-3)
    assert fine.coarse_hmax == 0.2 and fine.stages[-1]["hmax"] == 0.15
    kinds = [p["kind"] for p in fine.points]
    n = kinds.count("standout")
    assert kinds == ["standout"] * n + ["popup"] * (len(kinds) - n)
    for cross in fine.crossing[:1] + fine.crossing[-1:]:
        assert cross is not None and abs(cross[1] - cross[0]) == 1


@pytest.mark.slow
def test_an_end_outside_the_fine_basin_is_traced_on_the_fine_mesh():
    """a/R = 1 from hmax 0.1 to 0.06: the two folds at b = 1 are 0.0013 apart
    in L/a and 0.012 below the coarse ones, the standout end and its
    neighbours do not converge on the fine mesh; the end is traced there
    instead.  The curve is complete, a standout half then a pop-up half,
    L1* > L0*, one eigenvalue crossing at both ends, and the bistable window
    and the cusp as the curve traced directly at hmax 0.06 (another mesh of
    that size: L/a itself to 3e-3, as above)."""
    fine = trace_fold_curve(1.0, hmax=0.06, coarse_hmax=0.1, fine_points=6, check_inertia=5)
    direct = trace_fold_curve(1.0, hmax=0.06, check_inertia=0)
    assert fine.completed and direct.completed, (fine.reason, direct.reason)
    assert fine.stages[-1]["refilled"] > 0
    kinds = [p["kind"] for p in fine.points]
    n = kinds.count("standout")
    assert 0 < n < len(kinds) and kinds == ["standout"] * n + ["popup"] * (len(kinds) - n)
    assert fine.standout_length > fine.popup_length
    assert fine.standout_length == pytest.approx(direct.standout_length, abs=3e-3)
    assert fine.popup_length == pytest.approx(direct.popup_length, abs=3e-3)
    window = fine.standout_length - fine.popup_length
    assert window == pytest.approx(direct.standout_length - direct.popup_length, abs=2e-4)
    assert fine.cusp["tip_width"] == pytest.approx(direct.cusp["tip_width"], abs=2e-3)
    for cross in fine.crossing[:1] + fine.crossing[-1:]:
        assert cross is not None and abs(cross[1] - cross[0]) == 1


@pytest.mark.slow
def test_cli_fold_curve_writes_its_series(tmp_path):
    """``fold-curve --series DIR`` writes DIR/<name>.pvd with one step per point."""
    out = tmp_path / "c.json"
    assert main(["fold-curve", "--curvature", "2.5", "--hmax", str(COARSE), "--series",
                 str(tmp_path / "s"), "--json", str(out), "--quiet"]) == 0
    data = json.loads(out.read_text())
    steps = read_pvd(tmp_path / "s" / "fold-curve_aR2.5.pvd")
    assert len(steps) == len(data["points"]) > 3
    assert np.all(np.diff([t for t, _ in steps]) > 0)


def test_fine_meshes_do_not_follow_round_off_in_the_carried_lengths():
    # the fine mesh of a band is made at its median length rounded to the
    # grid: lengths that differ by round-off (1e-5) give the same mesh, so the
    # fine folds do not move with them (another unstructured mesh moved them
    # by 1e-4 at hmax 0.03); a band elsewhere gets its own grid length
    from skfem_sheet.foldcurve.options import MESH_LENGTH_GRID
    from skfem_sheet.foldcurve.refine import FineMeshes
    band = [1.13, 1.2171, 1.26, 1.31]
    lengths = []
    for shift in (0.0, 1e-5, -1e-5):
        fine = FineMeshes(2.5, 0.3, 1.0, {})
        P = fine.for_length(1.2 + shift, [x + shift for x in band])
        lengths.append(P.mesh_parameters[0])
    assert lengths[0] == lengths[1] == lengths[2] == pytest.approx(1.25)
    assert abs(lengths[0] / MESH_LENGTH_GRID - round(lengths[0] / MESH_LENGTH_GRID)) < 1e-12
    assert FineMeshes(2.5, 0.3, 1.0, {}).for_length(1.6, [1.6, 1.62]).mesh_parameters[0] \
        == pytest.approx(1.6)


@pytest.mark.slow
def test_a_point_settled_on_one_level_is_settled_first_on_the_next(monkeypatch):
    """a/R 2.5, hmax 0.1 from 0.2 and 0.15: points whose carried states
    lay outside Newton's basin of the fold system at hmax 0.15 (they were
    settled as equilibria first) are settled first at hmax 0.1, before
    their direct try.  The order of the two tries does not change the
    curve: the same folds and cusp as with the direct try first, to the
    corrector's ``utol`` (where the direct try converges too, it is
    another Newton path to the same fold), and the failed direct tries are
    not made again."""
    from skfem_sheet.foldcurve import refine as R
    from skfem_sheet.foldcurve.options import FINE_TOLERANCES

    tol = 2 * FINE_TOLERANCES.utol  # each within utol of the one fold

    def run():
        return trace_fold_curve(2.5, hmax=0.1, coarse_hmax=[0.2, 0.15], fine_points=6,
                                check_inertia=0)

    hinted = run()
    direct_first = R.settled_fold
    monkeypatch.setattr(R, "settled_fold", lambda *a: direct_first(*a[:7]))  # no hint
    plain = run()
    assert hinted.completed and plain.completed, (hinted.reason, plain.reason)
    assert hinted.stages[0]["settled"] >= 1 and hinted.stages[1]["settled"] >= 1
    assert hinted.standout_length == pytest.approx(plain.standout_length, abs=tol)
    assert hinted.popup_length == pytest.approx(plain.popup_length, abs=tol)
    assert hinted.cusp["tip_width"] == pytest.approx(plain.cusp["tip_width"], abs=tol)
    assert [p["length"] for p in hinted.points] == pytest.approx(
        [p["length"] for p in plain.points], abs=tol)
    # the failed direct tries are not made again (measured: 45 factorisations
    # at hmax 0.1 against 54; hmax 0.15, where nothing is known yet, 67 both)
    assert hinted.stages[1]["factorizations"] < plain.stages[1]["factorizations"]
    assert hinted.stages[0]["factorizations"] == plain.stages[0]["factorizations"]


def test_a_carried_state_is_settled_by_one_newton_step(monkeypatch):
    """A fold flat in the parameter on a branch curved in a stiff direction
    (energy ``1e5 (y - 10 x^2)^2 / 2 + x^3 / 3 - L x``: the fold at L = 0): from
    states a little off the branch in the stiff direction (a carried state's
    membrane error) the fold system diverges; one Newton step of the
    equilibrium on the section of the null vector (``SETTLE_STEP``) is enough
    for it to converge, to the fold the converged settling leads to, with one
    factorisation of settling instead of three."""
    from skfem_sheet.engine import Tolerances, locate_fold
    from skfem_sheet.foldcurve import refine as R
    from skfem_sheet.foldcurve.options import SETTLE_STEP

    def res(u, p):
        m = u[1] - 10 * u[0]**2
        return np.array([-2e6 * u[0] * m + u[0]**2 - p[0], 1e5 * m])

    def jac(u, p):
        m = u[1] - 10 * u[0]**2
        return np.array([[-2e6 * m + 4e7 * u[0]**2 + 2 * u[0], -2e6 * u[0]],
                         [-2e6 * u[0], 1e5]])

    P = FunctionProblem(res, jac, ("L",))
    tol = Tolerances(rtol=np.inf, utol=1e-10, max_iterations=20, max_correction=1.0)
    assert R.SETTLE_STEP is SETTLE_STEP and SETTLE_STEP.max_iterations == 1
    cases = [(np.array([x, 10 * x**2 + dy]), np.array([x**2]), np.array([1.0, 20 * x]))
             for x, dy in ((0.003, 3e-6), (0.005, 5e-6))]
    one = []
    for u0, p0, v in cases:
        direct, _ = locate_fold(P, u0, p0, "L", v0=v, tol=tol)
        assert direct is None  # outside the fold system's basin
        fold, _, lost, settled = R.settled_fold(P, None, "L", u0, p0, v, tol, True)
        assert settled and lost == 1 and abs(fold.value) < 1e-12 and abs(fold.u[0]) < 1e-6
        one.append(fold.value)
    monkeypatch.setattr(R, "SETTLE_STEP", tol)  # the settling converged, as before
    for (u0, p0, v), value in zip(cases, one):
        fold, _, lost, settled = R.settled_fold(P, None, "L", u0, p0, v, tol, True)
        assert settled and lost >= 3 and abs(fold.value - value) < 1e-12
