import numpy as np
import pytest

from skfem_sheet import Sheet
from skfem_sheet.mesh import sheet_mesh
from skfem_sheet.model import SheetProblem, clamp_displacement, det_inv


@pytest.fixture(scope="module", params=[False, True], ids=["full", "half"])
def problem(request):
    s = Sheet(length=0.8, tip_width=0.5, curvature=2.0)
    return SheetProblem(s, sheet_mesh(s, 0.2, layers=2, half=request.param))


def random_state(problem, seed=0, amp=1e-4):
    """A smooth, clamp-compatible state (the whole sheet bent into the clamp's
    cylinder, plus a drop) with small random noise and random pressures."""
    rng = np.random.default_rng(seed)
    X = problem.nodes
    U = clamp_displacement(X[:, 1], X[:, 2], problem.sheet.curvature)
    U[:, 2] -= 0.1 * X[:, 0] ** 2
    w = amp * rng.normal(size=problem.ndof)
    w[: problem.nu_dof] += U.ravel()
    w[problem.nu_dof:] = 20 * rng.normal(size=problem.n_vertices)
    w[problem.clamp_dofs] = problem.clamp_values(problem.sheet.curvature)
    w[problem.fixed[~np.isin(problem.fixed, problem.clamp_dofs)]] = 0.0  # symmetry plane
    return w


def test_clamp_maps_midline_to_arc_with_normals_unstretched():
    kappa = 2.5
    R = 1 / kappa
    y = np.linspace(-0.5, 0.5, 11)
    for z in (-0.015, 0.0, 0.015):
        X = np.stack([np.zeros_like(y), y, np.full_like(y, z)], -1)
        x = X + clamp_displacement(y, z, kappa)
        # centre of the arc at (0, 0, R): distance R - z, angle y/R
        r = np.hypot(x[:, 1], x[:, 2] - R)
        np.testing.assert_allclose(r, R - z, rtol=1e-12)
        np.testing.assert_allclose(np.arctan2(x[:, 1], R - x[:, 2]), y / R, rtol=1e-12)
    # flat clamp and the smooth small-curvature limit
    assert np.all(clamp_displacement(y, 0.01, 0.0) == 0)
    small = clamp_displacement(y, 0.01, 1e-7)
    assert np.abs(small).max() < 1e-7


def test_det_inv_matches_numpy():
    F = np.eye(3) + 0.3 * np.random.default_rng(1).normal(size=(50, 3, 3))
    J, Finv = det_inv(F)
    np.testing.assert_allclose(J, np.linalg.det(F), rtol=1e-12)
    np.testing.assert_allclose(Finv, np.linalg.inv(F), rtol=1e-10, atol=1e-12)


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


def test_pressure_block_has_explicit_zero_diagonal(problem):
    K = problem.tangent(random_state(problem))
    d = K.diagonal()
    npres = problem.n_vertices
    assert np.all(d[-npres:] == 0)
    # every diagonal entry is stored
    rows = np.repeat(np.arange(K.shape[0]), np.diff(K.indptr))
    assert np.count_nonzero(rows == K.indices) == K.shape[0]


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


def test_pattern_matches_a_dof_level_assembly(problem):
    """The block-level sparsity pattern and scatter give the same matrix as a
    plain COO assembly of the element matrices over the free dofs."""
    import scipy.sparse as sp

    w = random_state(problem, seed=5)
    Ke = problem.element_matrices(w)
    n = problem.ndof
    rows = np.repeat(problem.edofs, 34, axis=1).ravel()
    cols = np.tile(problem.edofs, (1, 34)).ravel()
    full = sp.csr_matrix((Ke.ravel(), (rows, cols)), shape=(n, n))
    ref = full[problem.free][:, problem.free]
    K = problem.tangent(w)
    assert K.has_sorted_indices
    assert abs(K - ref).max() <= 1e-12 * abs(ref).max()
    # every structural entry of the reference is in the pattern
    pat = sp.csr_matrix((np.ones(K.nnz), K.indices, K.indptr), shape=K.shape)
    refpat = (abs(ref) > 0).astype(float)
    assert (refpat - refpat.multiply(pat)).nnz == 0


def test_half_problem_has_symmetry_plane_fixed():
    s = Sheet(length=0.8, tip_width=0.5, curvature=2.0)
    half = SheetProblem(s, sheet_mesh(s, 0.2, layers=2, half=True))
    on_plane = np.abs(half.nodes[:, 1]) < 1e-12
    fixed_y = np.isin(3 * np.flatnonzero(on_plane) + 1, half.fixed)
    assert on_plane.any() and fixed_y.all()
    # x and z on the plane stay free away from the clamp
    away = on_plane & (half.nodes[:, 0] > 1e-9)
    assert np.isin(3 * np.flatnonzero(away), half.free).all()
    assert np.isin(3 * np.flatnonzero(away) + 2, half.free).all()


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


@pytest.mark.slow
def test_pattern_of_a_large_mesh():
    """More than 46341 blocks: the block-pair keys need 64-bit integers
    (skfem's element dofs are int32; this crashed at hmax 0.03 with 8 layers)."""
    from skfem_sheet.solve import _problem

    p = _problem(Sheet(length=1.8, curvature=5.0), 0.03, 8, 2, True)
    assert p.n_nodes + p.n_vertices > 46341
    K = p.tangent(np.zeros(p.ndof))
    assert K.shape == (p.n_free, p.n_free) and K.has_sorted_indices


def test_threaded_tangent_equals_serial(monkeypatch):
    """The element kernels run on chunks of elements in threads; the assembled
    tangent must be the serial one exactly (disjoint slices, same arithmetic)."""
    from skfem_sheet import model
    from skfem_sheet.params import Sheet
    from skfem_sheet.solve import _problem

    pb = _problem(Sheet(length=1.0, curvature=2.5), 0.15, None, 2, half=True)
    rng = np.random.default_rng(3)
    w = np.zeros(pb.ndof)
    w[:pb.nu_dof] = 1e-3 * rng.standard_normal(pb.nu_dof)
    w[pb.nu_dof:] = 0.1 * rng.standard_normal(pb.ndof - pb.nu_dof)
    monkeypatch.setattr(model, "_THREAD_MIN_ELEMENTS", 10**9)
    serial = pb.tangent(w).toarray()
    r_serial, j_serial = pb.residual(w, 0.7)
    monkeypatch.setattr(model, "_THREAD_MIN_ELEMENTS", 1)
    monkeypatch.setattr(model, "_threads", lambda: 3)
    assert len(model._element_chunks(len(pb.dx))) == 3
    assert np.array_equal(pb.tangent(w).toarray(), serial)
    r, j = pb.residual(w, 0.7)
    assert np.array_equal(r, r_serial) and j == j_serial
    # a NaN in the last chunk only is not hidden by the other chunks' Jmin
    last = model._element_chunks(len(pb.dx))[-1]
    others = np.unique(pb.element_nodes[: last.start])
    node = np.setdiff1d(pb.element_nodes[last], others)[0]
    w_bad = w.copy()
    w_bad[3 * node] = np.nan
    r, j = pb.residual(w_bad, 0.7)
    assert not j > 0 and np.isnan(r).all()
