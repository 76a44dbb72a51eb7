import numpy as np
import pytest

from skfem_sheet import Sheet
from skfem_sheet.mesh import default_layers, estimate_dofs, plan_triangulation, sheet_mesh


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
    from skfem_sheet import mesh as mesh_module

    mesh_module._half_plan.cache_clear()
    mesh_module._cached_mesh.cache_clear()
    m2 = sheet_mesh(s, 0.1)
    assert m1 is not m2
    np.testing.assert_array_equal(m1.mesh.p, m2.mesh.p)
    np.testing.assert_array_equal(m1.mesh.t, m2.mesh.t)
    assert sheet_mesh(s, 0.1) is m2  # cached


def test_triangle_tip_and_midline_nodes():
    from skfem_sheet.model import SheetProblem
    from skfem_sheet.observables import midline_nodes

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
    from skfem_sheet.model import SheetProblem

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
