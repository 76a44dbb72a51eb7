"""TaylorHoodSpace: dof layout and dof sets."""
import numpy as np
import pytest

from skfem_sheet import Sheet
from skfem_sheet.build import BuildChain
from skfem_sheet.discretisation import TaylorHoodSpace
from skfem_sheet.mesh import sheet_mesh
from skfem_sheet.params import ParameterError
from skfem_sheet.problem import SheetProblem


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


def test_dof_sets_partition_and_displacements_come_first():
    s = Sheet(length=0.8, tip_width=0.5, curvature=2.0)
    for half in (False, True):
        V = TaylorHoodSpace.build(sheet_mesh(s, 0.2, layers=2, half=half))
        assert V.ndof == 3 * V.n_nodes + V.n_vertices == V.nu_dof + V.n_vertices
        assert np.array_equal(np.sort(np.concatenate([V.free, V.fixed])), np.arange(V.ndof))
        assert np.all(np.diff(V.free) > 0)
        nu = np.count_nonzero(V.free < V.nu_dof)
        assert np.all(V.free[:nu] < V.nu_dof) and np.all(V.free[nu:] >= V.nu_dof)
        assert np.isin(V.clamp_dofs, V.fixed).all()
        assert np.allclose(V.nodes[V.clamp_nodes, 0], 0.0)
        assert (len(V.symmetry_nodes) > 0) == half
        # every pressure dof is free, and the P1 vertices are the first P2 nodes
        assert np.all(V.free[nu:] == V.nu_dof + np.arange(V.n_vertices))
        np.testing.assert_array_equal(V.nodes[: V.n_vertices], V.mesh.mesh.p.T)


def test_split_and_join_are_inverse():
    s = Sheet(length=0.8, tip_width=0.5, curvature=2.0)
    V = TaylorHoodSpace.build(sheet_mesh(s, 0.2, layers=2))
    w = np.random.default_rng(0).normal(size=V.ndof)
    U, p = V.split(w)
    assert U.shape == (V.n_nodes, 3) and p.shape == (V.n_vertices,)
    assert np.array_equal(V.join(U, p), w)
    assert U[5, 2] == w[3 * 5 + 2] and p[3] == w[V.nu_dof + 3]
    with pytest.raises(ValueError, match="join"):
        V.join(U[1:], p)


def test_stretched_space_is_always_one_stretch_of_the_reference():
    s = Sheet(length=1.0, tip_width=0.6, curvature=1.5)
    V = TaylorHoodSpace.build(sheet_mesh(s, 0.2, layers=2, half=True))
    assert V.reference is None and V.length == V.mesh.length
    W = V.stretched(1.2).stretched(1.3)
    direct = V.stretched(1.3)
    assert W.reference is V and W.length == 1.3
    for name in ("dphi", "dx", "nodes", "laplacian", "load_z"):
        assert np.array_equal(getattr(W, name), getattr(direct, name)), name
    assert W.volume == pytest.approx(1.3 * V.volume)
    # topology and dof sets are shared, not copied
    assert W.free is V.free and W.edofs is V.edofs and W.basis_u is V.basis_u
    # the stretch is exact in x: volume weights scale, x-derivatives shrink
    np.testing.assert_allclose(W.dx, 1.3 * V.dx, rtol=1e-15)
    np.testing.assert_allclose(W.dphi[..., 0] * 1.3, V.dphi[..., 0], rtol=1e-14)
    assert np.array_equal(W.dphi[..., 1:], V.dphi[..., 1:])


@pytest.mark.parametrize("length", [0.0, -1.0, float("nan")])
def test_bad_stretch_length(length):
    s = Sheet(length=1.0)
    V = TaylorHoodSpace.build(sheet_mesh(s, 0.2, layers=2, half=True))
    with pytest.raises(ParameterError, match="length"):
        V.stretched(length)


def test_space_is_kept_per_mesh_and_order_by_a_chain():
    s = Sheet(length=1.0)
    chain = BuildChain()
    m = chain.mesh(s, 0.2, layers=2, half=True)
    assert chain.space(m) is chain.space(m, 2)
    assert chain.space(m, 4) is not chain.space(m)
    assert chain.space(m, 4).dx.shape[1] > chain.space(m).dx.shape[1]
    # a mesh the chain does not keep: a space built afresh every time
    other = sheet_mesh(s, 0.2, layers=2, half=True)
    assert chain.space(other) is not chain.space(other)
