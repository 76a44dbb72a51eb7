"""End-to-end solves on coarse meshes (fast); the paper-resolution checks are
marked slow and repeated by benchmarks/solver_acceptance.py."""
import numpy as np
import pytest
from scipy.integrate import quad, solve_bvp

from skfem_sheet import Sheet, SolveError, solve
from skfem_sheet.analyses.observables import midline_heights


def heavy_elastica(L, thickness=0.03, modulus=735.0):
    """d of the inextensible heavy elastica with plate modulus D = E h^3 / (12 (1 - nu^2)),
    D phi'' = rho g h (L - s) cos phi, phi(0) = phi'(L) = 0 (computed here independently)."""
    D = modulus * thickness**3 / (12 * (1 - 0.25))
    s = np.linspace(0, L, 201)
    sol = solve_bvp(lambda s, y: np.vstack([y[1], thickness * (L - s) * np.cos(y[0]) / D]),
                    lambda a, b: np.array([a[0], b[1]]), s, np.zeros((2, s.size)), tol=1e-10,
                    max_nodes=100000)
    assert sol.status == 0
    return -quad(lambda x: np.sin(sol.sol(x)[0]), 0, L, epsabs=1e-13)[0]


@pytest.fixture(scope="module")
def flat():
    return solve(Sheet(length=0.6), hmax=0.1)


def test_flat_sheet_converges_towards_the_heavy_elastica():
    # the error against the plate elastica must shrink under refinement
    ref = heavy_elastica(0.6)
    errs = [abs(solve(Sheet(length=0.6), hmax=h).deflection / ref - 1) for h in (0.2, 0.1, 0.05)]
    assert errs[0] > errs[1] > errs[2]
    assert errs[2] < 0.01


def test_volume_is_conserved_and_converged_result_is_honest(flat):
    assert flat.converged and flat.message == ""
    assert abs(flat.volume_change) < 1e-6
    assert flat.deflection > 0  # gravity pulls down
    assert flat.newton_iterations >= flat.load_steps


def test_free_edge_is_symmetric_and_the_half_model_agrees():
    sheet = Sheet(length=0.8, tip_width=0.6, curvature=2.0)
    r = solve(sheet, hmax=0.1, symmetric=False)
    y, z = midline_heights(r.problem, r.w, 0.8)
    np.testing.assert_allclose(y, -y[::-1], atol=1e-12)
    np.testing.assert_allclose(z, z[::-1], atol=1e-3 * np.ptp(z) + 1e-9)
    # the half model's mesh is the y >= 0 half of the full one: same answer
    half = solve(sheet, hmax=0.1)
    assert half.symmetric and not r.symmetric
    assert half.dofs < 0.6 * r.dofs
    assert half.deflection == pytest.approx(r.deflection, rel=1e-9)
    assert half.energy == pytest.approx(r.energy, rel=1e-9)
    yh, zh = midline_heights(half.problem, half.w, 0.8)
    np.testing.assert_allclose(zh, z[y >= -1e-12], atol=1e-10)


def test_curvature_stiffens_a_short_sheet():
    flat = solve(Sheet(length=0.6), hmax=0.1).deflection
    curved = solve(Sheet(length=0.6, curvature=2.5), hmax=0.1).deflection
    assert abs(curved) < 0.2 * flat


def test_deterministic(flat):
    again = solve(Sheet(length=0.6), hmax=0.1)
    assert again.deflection == pytest.approx(flat.deflection, abs=1e-10)


def test_superlu_and_default_backend_agree(flat):
    r = solve(Sheet(length=0.6), hmax=0.1, solver="superlu")
    assert r.solver == "superlu"
    assert r.deflection == pytest.approx(flat.deflection, rel=1e-7)


def test_failure_is_reported_not_returned_as_an_answer():
    from skfem_sheet.continuation import StepOptions
    from skfem_sheet.newton import NewtonOptions

    # one Newton iteration per step and no room to cut the step: cannot converge
    kw = dict(newton_options=NewtonOptions(max_iterations=1, utol=1e-12, rtol=1e-12),
              step_options=StepOptions(initial_step=0.5, min_step=0.25, max_step=0.5))
    with pytest.raises(SolveError) as err:
        solve(Sheet(length=1.0, curvature=2.0), hmax=0.15, **kw)
    res = err.value.result
    assert not res.converged and "phase stopped" in res.message
    r = solve(Sheet(length=1.0, curvature=2.0), hmax=0.15, on_failure="return", **kw)
    assert not r.converged and r.message


@pytest.mark.parametrize("kwargs, name", [
    (dict(path="sideways"), "path"), (dict(hmax=-1), "hmax"), (dict(hmax=1e-4), "hmax"),
    (dict(solver="magic"), "solver"), (dict(on_failure="ignore"), "on_failure"),
    (dict(quadrature_order=7), "quadrature_order"), (dict(layers=0), "layers"),
    (dict(gravity=-0.5), "gravity"), (dict(gravity=11.0), "gravity"),
])
def test_bad_arguments(kwargs, name):
    with pytest.raises(ValueError, match=name):
        solve(Sheet(length=1.0), **kwargs)


def test_write_vtu_and_json(tmp_path, flat):
    import json

    import meshio

    flat.write(tmp_path / "out.vtu")
    m = meshio.read(tmp_path / "out.vtu")
    assert set(m.point_data) >= {"displacement", "pressure"}
    assert "psi_over_mu" in m.cell_data
    # the whole sheet is written (a symmetric half solve is mirrored)
    assert len(m.points) > flat.problem.sheet_mesh.n_vertices
    assert np.ptp(m.points[:, 1]) == pytest.approx(1.0)
    U = m.point_data["displacement"]
    left, right = m.points[:, 1] < -1e-9, m.points[:, 1] > 1e-9
    # mirror symmetry of the written field: U_z(y) = U_z(-y), U_y(y) = -U_y(-y)
    key = np.lexsort((m.points[:, 2], m.points[:, 0], np.abs(m.points[:, 1])))
    order_l = [i for i in key if left[i]]
    order_r = [i for i in key if right[i]]
    np.testing.assert_allclose(U[order_l, 2], U[order_r, 2], atol=1e-12)
    np.testing.assert_allclose(U[order_l, 1], -U[order_r, 1], atol=1e-12)
    flat.write(tmp_path / "out.json")
    data = json.loads((tmp_path / "out.json").read_text())
    for key in ("deflection", "converged", "path", "dofs", "newton_iterations", "load_steps",
                "wall_time_s", "linear_solve_s", "assembly_s", "params"):
        assert key in data
    assert data["params"]["hmax"] == 0.1 and data["deflection"] == flat.deflection
    for bad in (tmp_path / "out.txt", tmp_path / "missing" / "out.vtu"):
        with pytest.raises(ValueError, match="filename"):
            flat.write(bad)


# --------------------------------------------------------------------------------------
# the paper's resolution (slow)
# --------------------------------------------------------------------------------------
@pytest.mark.slow
def test_flat_rectangle_matches_heavy_elastica_at_paper_resolution():
    r = solve(Sheet(length=1.0), hmax=0.03)
    assert r.deflection == pytest.approx(heavy_elastica(1.0), rel=5e-3)


@pytest.mark.slow
def test_bistable_rectangle_and_monostable_triangle():
    up = solve(Sheet(1.3, 1.0, 2.5), path="curvature-first", hmax=0.03)
    down = solve(Sheet(1.3, 1.0, 2.5), path="gravity-first", hmax=0.03)
    assert abs(up.deflection) < 0.1 and down.deflection > 0.5
    t1 = solve(Sheet(1.3, 0.0, 2.5), path="curvature-first", hmax=0.03)
    t2 = solve(Sheet(1.3, 0.0, 2.5), path="gravity-first", hmax=0.03)
    assert t1.deflection == pytest.approx(t2.deflection, rel=5e-3)
    for r in (up, down, t1, t2):
        assert r.newton_iterations <= 40
        assert abs(r.volume_change) < 1e-6


def test_lost_branch_snaps_and_says_so():
    # a/R = 6, L/a = 1.3 is below the pop-up length: the drooped branch followed by
    # gravity-first ends at a fold during the curvature ramp and the sheet pops up
    # to the only (aloft) equilibrium, the one curvature-first finds directly
    sheet = Sheet(1.3, 1.0, 6.0)
    # the whole sheet: the symmetric half can only snap along mirror-symmetric
    # shapes, a slower route whose count of recorded snaps depends on round-off
    up = solve(sheet, path="curvature-first", hmax=0.1, symmetric=False)
    popped = solve(sheet, path="gravity-first", hmax=0.1, symmetric=False)
    assert up.snaps == () and up.branch == "curvature-dominated"
    assert len(popped.snaps) == 1 and popped.snaps[0].phase == "curvature"
    assert popped.branch == "curvature-dominated"
    assert popped.deflection == pytest.approx(up.deflection, abs=1e-4)


@pytest.mark.slow
def test_half_model_snaps_to_the_same_state():
    # slow (historically: the residual-ratio pseudo-transient took 250-450 Newton
    # iterations for the half model's symmetric snap; the inertia-controlled one, ~100)
    sheet = Sheet(1.3, 1.0, 6.0)
    up = solve(sheet, path="curvature-first", hmax=0.1)
    half = solve(sheet, path="gravity-first", hmax=0.1)
    assert half.deflection == pytest.approx(up.deflection, abs=1e-4)


def test_both_branches_are_reported_stable():
    sheet = Sheet(1.3, 1.0, 2.5)
    for path in ("curvature-first", "gravity-first"):
        r = solve(sheet, path=path, hmax=0.15)
        if r.stable is None:
            pytest.skip("this linear solver does not report the inertia")
        assert r.stable and r.negative_eigenvalues == (0, 0)
        assert r.summary()["stable"] is True


def test_timings_count_every_factorisation_and_solve():
    """The Newton statistics must account for all the linear-solver work of a
    path, including the factorisation at the start of each phase (it was once
    left out, which made 10% of a solve look like time outside the solver)."""
    from skfem_sheet.continuation import follow_path
    from skfem_sheet.linalg import make_linear_solver
    from skfem_sheet.newton import Stats
    from skfem_sheet.solve import build_problem

    sheet = Sheet(length=0.8, curvature=2.5)
    problem = build_problem(sheet, 0.2, None, 2, half=True)
    solver = make_linear_solver("superlu")
    stats = Stats()
    out = follow_path(problem, "curvature-first", sheet.curvature, solver, stats=stats)
    assert out.converged
    assert stats.factorizations == solver.n_factorizations
    assert stats.linear_solve_s >= solver.factor_time + solver.solve_time
    assert stats.linear_solve_s <= 1.5 * (solver.factor_time + solver.solve_time) + 0.05


def test_without_gravity_both_paths_reach_one_state_and_small_loads_are_linear():
    """``gravity=0``: the clamp's curvature alone, one phase on either path,
    hence the same state (an invariant); a flat sheet without gravity stays
    in its reference state; and in the small-load limit d is linear in the
    load (doubling g doubles d to 1e-4, the quadratic term is O(g^2))."""
    sheet = Sheet(length=1.5, curvature=0.5)
    up = solve(sheet, path="curvature-first", hmax=0.15, gravity=0.0)
    down = solve(sheet, path="gravity-first", hmax=0.15, gravity=0.0)
    assert up.converged and up.stable and up.gravity == 0.0 and up.target_gravity == 0.0
    assert [s[0] for s in up.steps] == ["curvature"] * len(up.steps)
    assert abs(up.deflection - down.deflection) < 1e-12
    assert up.to_record()["gravity"] == 0.0
    flat = solve(Sheet(length=1.0), hmax=0.15, gravity=0.0)
    assert flat.converged and flat.deflection == 0.0 and flat.steps == ()
    d1, d2 = (solve(Sheet(length=1.0), hmax=0.15, gravity=g).deflection for g in (1e-3, 2e-3))
    assert d1 > 0 and abs(d2 / d1 - 2.0) < 1e-4
