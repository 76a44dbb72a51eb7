"""SheetProblem: residual, tangent and energy agree; loads; with_length."""
import numpy as np
import pytest
from _states import random_state, small_problem

from skfem_sheet import Sheet
from skfem_sheet.mesh import sheet_mesh
from skfem_sheet.problem import SheetProblem


@pytest.fixture(scope="module", params=[False, True], ids=["full", "half"])
def problem(request):
    return small_problem(request.param)


def test_reference_state_is_stress_free(problem):
    r, Jmin = problem.residual(np.zeros(problem.ndof), 0.0)
    assert Jmin == pytest.approx(1.0)
    assert np.abs(r).max() < 1e-12


def test_residual_is_the_energy_gradient(problem):
    w = random_state(problem)
    v = np.random.default_rng(2).normal(size=problem.ndof)
    # fourth-order difference: the random state is strongly curved (pressures ~20)
    E = lambda t: problem.energy(w + t * v, 0.7)  # noqa: E731
    eps = 1e-5
    dE = (8 * (E(eps) - E(-eps)) - (E(2 * eps) - E(-2 * eps))) / (12 * eps)
    r, _ = problem.residual(w, 0.7)
    halves = 2.0 if problem.sheet_mesh.half else 1.0  # energy() is of the whole sheet
    assert dE == pytest.approx(halves * (r @ v), rel=1e-6)


def test_tangent_matches_finite_differences_and_is_symmetric(problem):
    w = random_state(problem, seed=3)
    rng = np.random.default_rng(4)
    free = problem.free
    K = problem.tangent(w)
    assert abs(K - K.T).max() <= 1e-10 * abs(K).max()
    for _ in range(3):
        v = np.zeros(problem.ndof)
        v[free] = rng.normal(size=len(free))
        eps = 1e-6
        fd = (problem.residual(w + eps * v, 0.3)[0] - problem.residual(w - eps * v, 0.3)[0]) / (2 * eps)
        np.testing.assert_allclose(K @ v[free], fd[free], atol=1e-6 * np.abs(fd).max())
    # the clamp coupling block too
    v = np.zeros(problem.ndof)
    v[problem.clamp_dofs] = rng.normal(size=len(problem.clamp_dofs))
    fd = (problem.residual(w + eps * v, 0.3)[0] - problem.residual(w - eps * v, 0.3)[0]) / (2 * eps)
    np.testing.assert_allclose(problem.clamp_coupling(w) @ v[problem.clamp_dofs], fd[free],
                               atol=1e-6 * np.abs(fd).max())


def test_gravity_load_is_the_weight(problem):
    # sum of the vertical nodal forces = volume (rho g = 1)
    assert problem.gravity_load[2:problem.nu_dof:3].sum() == pytest.approx(problem.volume0)
    assert np.abs(problem.gravity_load[0:problem.nu_dof:3]).max() == 0


def test_inverted_element_is_reported(problem):
    w = np.zeros(problem.ndof)
    U = w[: problem.nu_dof].reshape(-1, 3)
    U[:, 2] = -2 * problem.nodes[:, 2]  # mirror through the mid-plane: J = -1
    r, Jmin = problem.residual(w, 1.0)
    assert Jmin < 0 and np.all(np.isnan(r))


def test_stretched_problem_equals_a_fresh_mesh_of_that_length():
    """with_length(L) on a mesh built for L0 is the problem on the mesh built
    for L0 and stretched: it must give the same energy as a direct mapping of
    the nodes (an exact affine change of variables)."""
    s0 = Sheet(length=1.0, tip_width=0.6, curvature=1.5)
    p0 = SheetProblem(s0, sheet_mesh(s0, 0.2, layers=2, half=True))
    p1 = p0.with_length(1.3)
    assert p1.sheet.length == 1.3 and p1.length == 1.3
    assert p1.nodes[:, 0].max() == pytest.approx(1.3)
    assert p1.volume0 == pytest.approx(1.3 * p0.volume0)
    # a state that is a function of the physical position: U = f(X)
    def state(p):
        X = p.nodes
        w = np.zeros(p.ndof)
        U = np.stack([0.01 * X[:, 0] * X[:, 1], 0.02 * X[:, 0] ** 2, -0.1 * X[:, 0] ** 2], 1)
        w[: p.nu_dof] = U.ravel()
        return w
    # the same physical configuration on a mesh built directly at L = 1.3: a
    # quadratic field is exact on both meshes, so the energies differ only by
    # quadrature of the nonlinear density on different tetrahedra (3e-10 here)
    s1 = s0.replace(length=1.3)
    direct = SheetProblem(s1, sheet_mesh(s1, 0.2, layers=2, half=True))
    e1, ed = p1.energy(state(p1), 1.0), direct.energy(state(direct), 1.0)
    assert e1 == pytest.approx(ed, rel=1e-8)
    # stretching back is the identity
    back = p1.with_length(1.0)
    np.testing.assert_allclose(back.dphi, p0.dphi)
    np.testing.assert_allclose(back.gravity_load, p0.gravity_load)


def test_problem_fields_are_declared_and_frozen():
    import dataclasses

    p = small_problem(True)
    assert [f.name for f in dataclasses.fields(p)] == ["sheet", "space", "assembler",
                                                        "tip_force", "_constants"]
    assert p.tip_force == 0.0  # the dead tip load (issue 58), none by default
    with pytest.raises(dataclasses.FrozenInstanceError):
        p.sheet = p.sheet.replace(length=2.0)
    # the layout is the space's, by name
    assert p.free is p.space.free and p.nu_dof == p.space.nu_dof
    assert p.gravity_load is p.space.load_z and p.volume0 == p.space.volume


def test_with_length_is_a_fresh_problem_on_the_stretched_space():
    p = small_problem(True)
    w = random_state(p, seed=9)
    K0 = p.tangent(w).toarray()
    q = p.with_length(1.0)
    assert isinstance(q, SheetProblem) and q.sheet.length == 1.0 == q.length
    assert q.space.reference is p.space and q.sheet_mesh is p.sheet_mesh
    assert q._constants is not p._constants
    q.tangent(w), q.mass_data
    assert np.array_equal(p.tangent(w).toarray(), K0)   # p is unchanged by q
    # back at the mesh's own length: the same problem, to the last bit
    r = q.with_length(p.length)
    assert np.array_equal(r.tangent(w).toarray(), K0)


def test_mismatched_space_or_assembler_is_refused():
    p = small_problem(True)
    other = small_problem(False)
    with pytest.raises(ValueError, match="space"):
        SheetProblem(p.sheet, other.sheet_mesh, space=p.space)
    with pytest.raises(ValueError, match="assembler"):
        SheetProblem(p.sheet, p.sheet_mesh, assembler=other.assembler)


def test_saddle_point_layout_of_the_problem():
    p = small_problem(True)
    lay = p.saddle_point_layout()
    free = p.free
    assert lay.n_displacement == np.count_nonzero(free < p.nu_dof)
    assert lay.n_unknowns == p.n_free and lay.n_pressure == p.n_vertices
    np.testing.assert_array_equal(3 * lay.displacement_nodes + lay.displacement_components,
                                  free[: lay.n_displacement])
    # M_p / mu: symmetric positive definite, its sum the volume over mu
    M = lay.pressure_schur.toarray()
    assert np.allclose(M, M.T) and np.linalg.eigvalsh(M).min() > 0
    assert M.sum() == pytest.approx(p.volume0 / p.mu, rel=1e-12)
    w = random_state(p)
    assert np.array_equal(lay.displacements(w), p.split(w)[0])
    assert lay.rotations(w).shape == (p.n_nodes, 3, 3)


def test_mip_tangent_is_the_hessian_at_its_reference_and_symmetric(problem):
    """``tangent(w, w_ref)``: the exact tangent when ``w_ref = w``; otherwise a
    symmetric matrix that differs from it by a term second order in ``w - w_ref``."""
    w = random_state(problem, seed=8)
    K = problem.tangent(w)
    assert abs(problem.tangent(w, w_ref=w) - K).max() == 0.0
    rng = np.random.default_rng(9)
    v = np.zeros(problem.ndof)
    v[problem.free] = rng.normal(size=len(problem.free))
    v[problem.nu_dof:] = 0.0
    diffs = []
    for t in (1e-5, 5e-6):  # random v: gradients ~ v / (element thickness)
        Km = problem.tangent(w + t * v, w_ref=w)
        assert abs(Km - Km.T).max() <= 1e-10 * abs(Km).max()
        diffs.append(abs(Km - problem.tangent(w + t * v)).max())
    assert diffs[1] > 0 and 3.5 < diffs[0] / diffs[1] < 4.5
