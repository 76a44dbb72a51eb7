import numpy as np
import pytest

from skfem_sheet import Sheet
from skfem_sheet.analyses.observables import midline_nodes
from skfem_sheet.mesh import default_layers, estimate_dofs, plan_triangulation, sheet_mesh
from skfem_sheet.problem import SheetProblem


@pytest.mark.parametrize("b", [1.0, 0.5, 0.0])
@pytest.mark.parametrize("layers", [1, 2])
def test_volume_orientation_and_conformity(b, layers):
    s = Sheet(length=1.2, tip_width=b)
    m = sheet_mesh(s, hmax=0.15, layers=layers).mesh
    v = m.p[:, m.t]
    vol = np.einsum("ij,ij->j", np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0], axis=0),
                    v[:, 3] - v[:, 0]) / 6
    assert vol.min() > 0
    assert vol.sum() == pytest.approx(s.area * s.thickness, rel=1e-12)
    # conforming: the boundary facets are exactly the surface of the prism
    f = m.facets[:, m.boundary_facets()]
    a, b_, c = (m.p[:, f[i]] for i in range(3))
    area = 0.5 * np.linalg.norm(np.cross(b_ - a, c - a, axis=0), axis=0)
    perimeter = 1.0 + s.tip_width + 2 * np.hypot(s.length, (1 - s.tip_width) / 2)
    assert area.sum() == pytest.approx(2 * s.area + perimeter * s.thickness, rel=1e-12)


def test_mirror_symmetry_and_determinism():
    s = Sheet(length=1.3, tip_width=0.6)
    xy, tri = plan_triangulation(s.length, s.tip_width, 0.1)
    mirrored = {(round(x, 12), round(-y, 12)) for x, y in xy}
    assert mirrored == {(round(x, 12), round(y, 12)) for x, y in xy}
    # triangles map to triangles under the mirror
    key = {(round(x, 12), round(y, 12)): i for i, (x, y) in enumerate(xy)}
    tris = {tuple(sorted(t)) for t in tri}
    for t in tri:
        image = tuple(sorted(key[(round(xy[i, 0], 12), round(-xy[i, 1], 12))] for i in t))
        assert image in tris
    m1 = sheet_mesh(s, 0.1)
    m2 = sheet_mesh(s, 0.1)  # made afresh (nothing is cached), the same mesh
    assert m1 is not m2
    np.testing.assert_array_equal(m1.mesh.p, m2.mesh.p)
    np.testing.assert_array_equal(m1.mesh.t, m2.mesh.t)
    from skfem_sheet.build import BuildChain

    chain = BuildChain()
    assert chain.mesh(s, 0.1) is chain.mesh(s, 0.1)  # a chain keeps it
    np.testing.assert_array_equal(chain.mesh(s, 0.1).mesh.p, m2.mesh.p)


def test_triangle_tip_and_midline_nodes():
    s = Sheet(length=1.0, tip_width=0.0)
    for layers in (1, 2, 3):
        prob = SheetProblem(s, sheet_mesh(s, 0.2, layers))
        tip = midline_nodes(prob, 1.0)
        assert len(tip) == 1 and np.allclose(prob.nodes[tip[0]], [1.0, 0.0, 0.0])
        clamp = midline_nodes(prob, 0.0)
        assert np.isclose(prob.nodes[clamp, 1].min(), -0.5)
        assert np.any(np.isclose(prob.nodes[clamp, 1], 0.0))


def test_layers_and_estimate():
    assert default_layers(0.03, 0.03) == 2
    assert default_layers(0.03, 0.01) == 3
    s = Sheet(length=1.0)
    m = sheet_mesh(s, 0.1)
    n = SheetProblem(s, m).ndof
    assert 0.5 * n < estimate_dofs(s, 0.1) < 2 * n


@pytest.mark.parametrize("hmax, msg", [(0, "hmax"), (-0.1, "hmax"), (2.0, "hmax"),
                                      (1e-4, "hmax"), (float("nan"), "hmax")])
def test_bad_mesh_size(hmax, msg):
    with pytest.raises(ValueError, match=msg):
        sheet_mesh(Sheet(length=1.0), hmax)


def test_bad_layers():
    with pytest.raises(ValueError, match="layers"):
        sheet_mesh(Sheet(length=1.0), 0.1, layers=0)
    with pytest.raises(ValueError, match="layers"):
        sheet_mesh(Sheet(length=1.0), 0.1, layers=1.5)


# ---------------------------------------------------------------------------
# Nested refinement (refine=k: every edge halved k times in all three directions)
# ---------------------------------------------------------------------------
def _tet_volumes(m):
    v = m.p[:, m.t]
    return np.einsum("ij,ij->j", np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0], axis=0),
                     v[:, 3] - v[:, 0]) / 6


def _point_set(p):
    return {tuple(np.round(x, 12)) for x in p.T}


@pytest.mark.parametrize("b", [1.0, 0.5, 0.0])
@pytest.mark.parametrize("half", [False, True])
def test_refine_once_is_nested_and_exact(b, half):
    s = Sheet(length=1.2, tip_width=b)
    base = sheet_mesh(s, hmax=0.2, layers=2, half=half)
    fine = sheet_mesh(s, hmax=0.2, layers=2, half=half, refine=1)
    assert fine.refine == 1 and fine.layers == 4 and fine.hmax == base.hmax
    assert fine.n_elements == 8 * base.n_elements
    assert _point_set(base.mesh.p) <= _point_set(fine.mesh.p)   # nested vertex sets
    # every fine vertex is a base vertex or the midpoint of a base edge (of the
    # plan, of a vertical edge, or of a face diagonal): nothing else is added
    e = base.mesh.edges
    mids = 0.5 * (base.mesh.p[:, e[0]] + base.mesh.p[:, e[1]])
    assert _point_set(fine.mesh.p) <= _point_set(base.mesh.p) | _point_set(mids)
    vol = _tet_volumes(fine.mesh)
    assert vol.min() > 0
    assert vol.sum() == pytest.approx(s.area * s.thickness / (2 if half else 1), rel=1e-12)
    # edges halved: the longest edge is half the base mesh's longest edge
    def longest(m):
        return np.linalg.norm(m.p[:, m.edges[0]] - m.p[:, m.edges[1]], axis=0).max()
    assert longest(fine.mesh) == pytest.approx(longest(base.mesh) / 2, rel=1e-12)
    # conforming: the boundary facets make up exactly the surface of the (half) prism
    m = fine.mesh
    f = m.facets[:, m.boundary_facets()]
    a, b_, c = (m.p[:, f[i]] for i in range(3))
    area = 0.5 * np.linalg.norm(np.cross(b_ - a, c - a, axis=0), axis=0).sum()
    side = np.hypot(s.length, (1 - s.tip_width) / 2)
    if half:
        surface = s.area + (0.5 + s.tip_width / 2 + side + s.length) * s.thickness
    else:
        surface = 2 * s.area + (1.0 + s.tip_width + 2 * side) * s.thickness
    assert area == pytest.approx(surface, rel=1e-12)


@pytest.mark.parametrize("refine", [1, 2])
def test_refined_half_is_the_mirror_half_of_the_whole(refine):
    s = Sheet(length=1.3, tip_width=0.6)
    full = sheet_mesh(s, 0.2, layers=2, refine=refine)
    half = sheet_mesh(s, 0.2, layers=2, half=True, refine=refine)
    p, t = full.mesh.p, full.mesh.t
    # the whole mesh is mirror-symmetric: its tets map to tets under y -> -y
    key = {x: i for i, x in enumerate(map(tuple, np.round(p.T, 12)))}
    image = np.array([key[(x, -y if y else y, z)] for x, y, z in np.round(p.T, 12)])
    tets = {tuple(sorted(x)) for x in t.T}
    assert {tuple(sorted(image[x])) for x in t.T} == tets
    # the half is the y >= 0 part of the whole: same vertices in the same order,
    # same tetrahedra
    keep = p[1] >= 0
    np.testing.assert_array_equal(half.mesh.p, p[:, keep])
    new = np.cumsum(keep) - 1
    upper = t[:, np.all(keep[t], axis=0)]
    assert {tuple(sorted(x)) for x in new[upper].T} == {tuple(sorted(x)) for x in half.mesh.t.T}
    assert 2 * half.n_elements == full.n_elements
    # and mirrored() rebuilds the whole
    pf, tf, *_ = half.mirrored()
    assert ({tuple(sorted(map(tuple, np.round(pf[:, x].T, 12)))) for x in tf.T}
            == {tuple(sorted(map(tuple, np.round(p[:, x].T, 12)))) for x in t.T})


def test_refined_plan_matches_skfem_refinement():
    from skfem import MeshTri

    xy, tri = plan_triangulation(1.1, 0.3, 0.25)
    fine_xy, fine_tri = plan_triangulation(1.1, 0.3, 0.25, refine=2)
    ref = MeshTri(xy.T.copy(), tri.T.copy()).refined(2)
    assert _point_set(fine_xy.T) == _point_set(ref.p)
    assert len(fine_tri) == ref.t.shape[1] == 16 * len(tri)
    # counter-clockwise children, total area exact
    a, b, c = (fine_xy[fine_tri[:, i]] for i in range(3))
    cross = (b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0]
    assert cross.min() > 0
    assert 0.5 * cross.sum() == pytest.approx(1.1 * (1 + 0.3) / 2, rel=1e-12)


def test_refine_layers_cache_and_estimate():
    s = Sheet(length=1.0)
    assert sheet_mesh(s, 0.1, refine=1).layers == 2 * default_layers(s.thickness, 0.1)
    assert sheet_mesh(s, 0.2, layers=3, refine=2).layers == 12
    from skfem_sheet.build import BuildChain
    from skfem_sheet.mesh import MeshSpec

    chain = BuildChain()
    m0, m1 = chain.mesh(s, 0.2, refine=0), chain.mesh(s, 0.2, refine=1)
    assert m0 is not m1 and chain.mesh(s, 0.2, refine=1) is m1   # refine is in the key
    assert chain.mesh(s, 0.2) is m0
    assert MeshSpec.of(s, 0.2, refine=1) != MeshSpec.of(s, 0.2)
    n0, n1 = (estimate_dofs(s, 0.2, 2, half=True, refine=k) for k in (0, 1))
    assert 7.0 < n1 / n0 < 8.5   # P2 unknowns grow a little less than 8x (boundary)
    n = SheetProblem(s, sheet_mesh(s, 0.1, refine=1)).ndof
    assert 0.5 * n < estimate_dofs(s, 0.1, refine=1) < 2 * n


@pytest.mark.parametrize("refine", [-1, 5, 1.5, True, "1", None])
def test_bad_refine(refine):
    from skfem_sheet.params import ParameterError

    with pytest.raises(ParameterError, match=r"refine must be an integer in \[0, 4\]"):
        sheet_mesh(Sheet(length=1.0), 0.2, refine=refine)
    with pytest.raises(ParameterError, match="refine"):
        estimate_dofs(Sheet(length=1.0), 0.2, refine=refine)


def test_solve_passes_refine_to_the_mesh():
    from skfem_sheet import solve
    from skfem_sheet.params import ParameterError

    s = Sheet(length=0.5)
    half = solve(s, hmax=0.2, refine=1)
    assert half.layers == 4
    assert half.problem.sheet_mesh.refine == 1
    # the refined half mesh is the mirror half of the refined whole: same answer
    whole = solve(s, hmax=0.2, refine=1, symmetric=False)
    assert half.deflection == pytest.approx(whole.deflection, rel=1e-9, abs=1e-12)
    assert whole.dofs > 1.9 * half.dofs
    with pytest.raises(ParameterError, match="refine"):
        solve(s, hmax=0.2, refine=5)
    with pytest.raises(ParameterError, match="refine smaller"):
        solve(s, hmax=0.01, refine=3)
