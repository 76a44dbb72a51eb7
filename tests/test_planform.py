"""Any planform (issue 14): Planform validation, outline geometry, meshes, free edge,
reduced models and the 3D solver on sampled, flaring and bitten sheets."""
import math
import pickle

import numpy as np
import pytest

from skfem_sheet.analyses.observables import (
    free_edge_nodes,
    midline_nodes,
    tip_deflection,
)
from skfem_sheet.mesh import sheet_mesh
from skfem_sheet.params import ParameterError, Planform, Sheet, read_planform_csv
from skfem_sheet.problem import SheetProblem
from skfem_sheet.reduced import (
    cantilever_deflection,
    elastica,
    persistence_length,
    persistence_length_asymptotic,
    ribbon,
)
from skfem_sheet.reduced.cantilever import flat_cantilever_drop


def sampled_trapezoid(L, b, k=0.0, x_mid=None):
    x = [0.0, L / 3 if x_mid is None else x_mid, L]
    return Sheet.from_planform(Planform.from_samples(x, [1 + (b - 1) * v / L for v in x]),
                               curvature=k)


# -- the Planform and the Sheet --------------------------------------------------------------
def test_trapezoid_sheet_unchanged():
    s = Sheet(1.3, 0.6, 2.5)
    assert s.planform is None and s.extent == 1.3
    assert s.to_dict() == {"length": 1.3, "tip_width": 0.6, "curvature": 2.5, "thickness": 0.03,
                               "modulus": 735.0}
    assert s.width(0.65) == 1.0 + (0.6 - 1.0) * 0.65 / 1.3
    assert s.replace(length=2.0) == Sheet(2.0, 0.6, 2.5)


def test_sampled_trapezoid_is_the_trapezoid():
    s, t = sampled_trapezoid(1.3, 0.6), Sheet(1.3, 0.6)
    x = np.linspace(0, 1.3, 53)
    np.testing.assert_allclose(s.width(x), t.width(x), rtol=0, atol=1e-15)
    np.testing.assert_allclose(s.width_integral(x), t.width_integral(x), rtol=0, atol=1e-14)
    assert s.tip_width == 0.6 and s.area == pytest.approx(t.area, abs=1e-14)
    assert s.planform.is_linear and s.planform.length is None   # the sheet's length rules


def test_sheet_with_planform_is_hashable_picklable_and_round_trips():
    s = Sheet.from_planform(Planform.trapezoid(0.0, bites=(0.3, 0.2)), length=1.3, curvature=2.5)
    assert Sheet(**s.to_dict()) == s and hash(Sheet(**s.to_dict())) == hash(s)
    assert pickle.loads(pickle.dumps(s)) == s
    assert s.to_dict()["planform"] == {"xi": [0.0, 1.0], "width": [1.0, 0.0], "bites": [0.3, 0.2]}
    assert s.replace(curvature=1.0).planform == s.planform


def test_callable_profile_is_sampled_in_x():
    s = Sheet(2.0, planform=lambda x: 1 + 0.25 * x)       # a flare to b/a = 1.5 at L = 2
    assert isinstance(s.planform, Planform) and s.tip_width == pytest.approx(1.5)
    assert s.width(1.0) == pytest.approx(1.25, abs=1e-14)
    assert s.planform.is_linear and s == Sheet.from_planform(s.planform, length=2.0)
    with pytest.raises(ParameterError, match="must return a number"):
        Sheet(1.0, planform=lambda x: "wide")


def test_continuation_in_length_stretches_the_profile():
    leaf = Planform.from_function(lambda u: 1 + 1.2 * u - 2.2 * u**2)
    s = Sheet.from_planform(leaf, length=1.0)
    t = s.replace(length=1.6)
    x = np.linspace(0, 1, 11)
    np.testing.assert_allclose(t.width(1.6 * x), s.width(x), rtol=0, atol=1e-15)
    assert t.area == pytest.approx(1.6 * s.area, rel=1e-12)
    # the stretched problem keeps the planform
    p = SheetProblem(s, sheet_mesh(s, 0.2, half=True)).with_length(1.3)
    assert p.sheet.planform == leaf and p.sheet.length == 1.3


def test_flaring_trapezoid_and_its_cross_sections():
    s = Sheet.from_planform(Planform.trapezoid(1.5), length=2.0)
    assert s.tip_width == 1.5 and s.area == pytest.approx(2.5, rel=1e-14)
    assert s.width(1.0) == pytest.approx(1.25, abs=1e-15)
    np.testing.assert_allclose(s.width_slope(np.array([0.1, 1.9])), 0.25, atol=1e-14)


def test_bite_geometry_closed_forms():
    L, r = 1.3, 0.3
    tri = Sheet.from_planform(Planform.trapezoid(0.0, bites=(r,)), length=L)
    # the disc cuts a sector of angle 2 atan(a / 2L) out of the triangle
    assert tri.area == pytest.approx(L / 2 - r * r * math.atan(0.5 / L), rel=1e-12)
    assert tri.outline.axis_end == pytest.approx(L - r)
    assert tri.extent == pytest.approx(L - r * math.cos(math.atan(0.5 / L)), rel=1e-9)
    rect = Sheet.from_planform(Planform.trapezoid(1.0, bites=(r,)), length=1.0)
    assert rect.area == pytest.approx(1.0 - math.pi * r * r / 2, rel=1e-12)
    assert rect.outline.cut == pytest.approx((r, 0.5)) and rect.extent == 1.0
    # two bites: the second centred where the first left the axis
    two = Sheet.from_planform(Planform.trapezoid(1.0, bites=(0.3, 0.25)), length=1.0)
    assert two.outline.centres == (1.0, 0.7) and two.outline.axis_end == pytest.approx(0.45)
    # width_integral is the integral of width, width_slope its derivative
    for s in (tri, two):
        x = np.linspace(0, s.extent, 400001)
        w = s.width(x)
        area = np.sum(0.5 * (w[1:] + w[:-1]) * np.diff(x))
        assert area == pytest.approx(s.area, rel=2e-6)
        xm = np.array([0.2, 0.5, 0.8]) * s.extent
        fd = (s.width(xm + 1e-7) - s.width(xm - 1e-7)) / 2e-7
        np.testing.assert_allclose(s.width_slope(xm), fd, rtol=1e-5, atol=1e-7)


BAD = [
    (lambda: Planform.from_samples([0, 0.5, 1], [1, -0.2, 0.5]), "width must be >= 0"),
    (lambda: Planform.from_samples([0, 0.5, 1], [1, float("nan"), 0.5]), "finite"),
    (lambda: Planform.from_samples([0, 1], [1, float("inf")]), "finite"),
    (lambda: Planform.from_samples([0, 1], [0.8, 0.5]), "width at x = 0 must be 1"),
    (lambda: Planform.from_samples([0, 0.6, 0.4, 1], [1, 1, 1, 1]), "strictly increasing"),
    (lambda: Planform.from_samples([0, 0.5, 0.5, 1], [1, 1, 1, 1]), "strictly increasing"),
    (lambda: Planform.from_samples([0.1, 1], [1, 1]), "start at the clamp"),
    (lambda: Planform.from_samples([0], [1]), "at least 2 samples"),
    (lambda: Planform.from_samples([0, 0.5, 1], [1, 1]), "same number of samples"),
    (lambda: Planform.from_samples([0, 0.5, 1], [1, 0, 1]), "pinches the sheet"),
    (lambda: Planform.trapezoid(0.5, bites=(-0.1,)), "bites must be radii"),
    (lambda: Sheet.from_planform(Planform.trapezoid(0.0, bites=(0.8, 0.6)), length=1.3),
     "stay clear of the clamp"),
    (lambda: Sheet.from_planform(Planform.from_samples([0, 0.5, 1], [1, 0.3, 1.6], bites=(0.6,))),
     "cut the outline into pieces"),
    (lambda: Sheet(1.0, tip_width=0.5, planform=Planform.trapezoid(0.7)), "tip_width must be"),
    (lambda: Sheet.from_planform(Planform.trapezoid(1.0)), "length must be given"),
]


@pytest.mark.parametrize("make, message", BAD)
def test_bad_planforms_are_refused_with_a_clear_message(make, message):
    with pytest.raises(ParameterError, match=message):
        make()


def test_too_narrow_for_the_mesh():
    neck = Sheet.from_planform(Planform.from_samples([0, 0.5, 1], [1, 0.15, 1]))
    with pytest.raises(ParameterError, match=r"too narrow for hmax = 0.1.*neck"):
        sheet_mesh(neck, 0.1)
    sheet_mesh(neck, 0.05, half=True)          # fine on a finer mesh
    # a tip narrowing to its end (triangle, leaf, bite horns) is allowed
    leaf = Sheet.from_planform(Planform.from_function(lambda u: 1 + 1.2 * u - 2.2 * u**2), length=1)
    bitten = Sheet.from_planform(Planform.trapezoid(0.0, bites=(0.3,)), length=1.3)
    for s in (leaf, bitten):
        assert sheet_mesh(s, 0.2, half=True).n_elements > 0


def test_read_planform_csv(tmp_path):
    f = tmp_path / "leaf.csv"
    f.write_text("x,width\n0,1\n0.6,1.3\n1.2,0\n")
    P = read_planform_csv(f)
    assert P.length == 1.2 and P.xi == (0.0, 0.5, 1.0) and P.width == (1.0, 1.3, 0.0)
    s = Sheet.from_planform(P, curvature=2.5)
    assert s.length == 1.2 and s.tip_width == 0.0
    (tmp_path / "bad.csv").write_text("x,w\n0,1\n1,1\n")
    with pytest.raises(ParameterError, match="columns x,width"):
        read_planform_csv(tmp_path / "bad.csv")
    (tmp_path / "neg.csv").write_text("x,width\n0,1\n1,-1\n")
    with pytest.raises(ParameterError, match=">= 0"):
        read_planform_csv(tmp_path / "neg.csv")


# -- meshes and the free edge ------------------------------------------------------------------
def test_sampled_trapezoid_mesh_is_the_trapezoid_mesh():
    for half in (False, True):
        a = sheet_mesh(Sheet(1.3, 0.6), 0.15, half=half)
        b = sheet_mesh(sampled_trapezoid(1.3, 0.6), 0.15, half=half)
        np.testing.assert_array_equal(a.mesh.p, b.mesh.p)
        np.testing.assert_array_equal(a.mesh.t, b.mesh.t)
        np.testing.assert_array_equal(a.free_edge, b.free_edge)


@pytest.mark.parametrize("b", [1.0, 0.6, 0.0])
def test_free_edge_of_a_trapezoid_is_the_midline_at_L(b):
    s = Sheet(1.1, b)
    for half in (False, True):
        for layers, refine in ((2, 0), (3, 0), (2, 1)):
            p = SheetProblem(s, sheet_mesh(s, 0.25, layers, half=half, refine=refine))
            ref = np.sort(midline_nodes(p, s.length))
            np.testing.assert_array_equal(np.sort(free_edge_nodes(p)), ref)
            np.testing.assert_array_equal(np.sort(free_edge_nodes(p.with_length(1.4))), ref)


@pytest.mark.parametrize("bites", [(0.3,), (0.3, 0.25)])
def test_bitten_mesh_follows_the_outline(bites):
    s = Sheet.from_planform(Planform.trapezoid(1.0, bites=bites), length=1.0)
    m = sheet_mesh(s, 0.1)
    v = m.mesh.p[:, m.mesh.t]
    vol = np.einsum("ij,ij->j", np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0], axis=0),
                    v[:, 3] - v[:, 0]) / 6
    assert vol.min() > 0
    # inscribed polygon of the arcs: a little more material than the exact outline
    assert 0 < vol.sum() / s.thickness - s.area < 0.01 * s.area
    xy = m.mesh.p[:2, m.mesh.p[2] == m.mesh.p[2].min()]
    np.testing.assert_allclose(np.sort(xy[1]), np.sort(-xy[1]), atol=1e-14)  # mirror symmetric
    o = s.outline
    inside = np.zeros(xy.shape[1], dtype=bool)
    for c, r in zip(o.centres, o.radii):
        inside |= np.hypot(xy[0] - c, xy[1]) < r * (1 - 1e-9)
    assert not inside.any()                            # no vertex inside a bite
    # free edge: arcs and what is left of the cut x = L, nodes on the circles or on x = L
    p = SheetProblem(s, m)
    X = p.nodes[free_edge_nodes(p)]
    assert np.all(np.abs(X[:, 2]) < 1e-12)
    on_arc = np.zeros(len(X), dtype=bool)
    for c, r in zip(o.centres, o.radii):
        on_arc |= np.abs(np.hypot(X[:, 0] - c, X[:, 1]) - r) < 0.1**2 / r  # chord sag h^2/8r
    assert np.all(on_arc | np.isclose(X[:, 0], 1.0))
    assert np.any(np.isclose(X[:, 0], o.axis_end) & (X[:, 1] == 0))
    assert np.any(np.isclose(X[:, 1], 0.5) & np.isclose(X[:, 0], 1.0))


# -- reduced models --------------------------------------------------------------------------------
@pytest.mark.parametrize("b, k", [(1.0, 2.5), (0.6, 2.5), (0.0, 0.0)])
def test_reduced_models_of_a_sampled_trapezoid(b, k):
    s, t = sampled_trapezoid(1.3, b, k, x_mid=0.4), Sheet(1.3, b, k)
    assert elastica(s).deflection == pytest.approx(elastica(t).deflection, abs=1e-9)
    assert cantilever_deflection(s, include_curved_part=True).deflection == pytest.approx(
        cantilever_deflection(t, include_curved_part=True).deflection, abs=1e-9)
    assert persistence_length(s).persistence_length == pytest.approx(
        persistence_length(t).persistence_length, abs=1e-9)
    assert ribbon(s).deflection == pytest.approx(ribbon(t).deflection, abs=1e-9)


def test_flaring_cantilever_closed_form():
    # p = 1 + k x: J(s) = (1 + k s) u^2/2 + k u^3/3, u = L - s (any k, here flaring)
    L, b = 1.2, 1.5
    s = Sheet.from_planform(Planform.trapezoid(b), length=L)
    k = (b - 1) / L
    x, w = np.polynomial.legendre.leggauss(200)
    ss, ww = 0.5 * L * (x + 1), 0.5 * L * w
    u = L - ss
    J = (1 + k * ss) * u**2 / 2 + k * u**3 / 3
    exact = s.thickness / s.bending_modulus * np.sum(ww * (L - ss) * J / (1 + k * ss))
    assert flat_cantilever_drop(s, 0.0) == pytest.approx(exact, rel=1e-12)
    # a wider tip is a heavier lever: it droops more than the rectangle, in the elastica too
    rect = Sheet(L)
    assert flat_cantilever_drop(s, 0.0) > flat_cantilever_drop(rect, 0.0)
    assert elastica(s).deflection > elastica(rect).deflection


def test_persistence_length_of_a_slight_flare_follows_the_asymptote():
    s = Sheet.from_planform(Planform.trapezoid(1.05), length=20.0, curvature=2.5)
    r = persistence_length(s)
    alpha = r.rectangle_length
    assert r.persistence_length > alpha        # widening: the curvature persists further
    # L_p ~ alpha (1 - 9/10 alpha (1 - b)/L) + O(Delta^2)
    assert r.persistence_length == pytest.approx(alpha * (1 + 0.9 * alpha * 0.05 / 20), rel=1e-4)
    assert persistence_length_asymptotic(s) == pytest.approx(r.persistence_length, rel=1e-4)


def test_reduced_models_with_bites_use_the_material_width():
    s = Sheet.from_planform(Planform.trapezoid(1.0, bites=(0.3,)), length=1.0)
    rect = Sheet(1.0)
    # the bite takes weight off the tip: less droop than the rectangle
    assert 0 < elastica(s).deflection < elastica(rect).deflection
    assert 0 < cantilever_deflection(s).deflection < cantilever_deflection(rect).deflection
    tri = Sheet.from_planform(Planform.trapezoid(0.0, bites=(0.3,)), length=1.3)
    e = elastica(tri)
    assert e.converged and e.s[-1] == pytest.approx(tri.extent)
    # two independent discretisations of the same bitten heavy elastica agree:
    # collocation (elastica) and the ribbon model's Hermite energy with c = 0
    for sheet in (s, tri):
        assert ribbon(sheet, impose_flat=True).deflection == pytest.approx(
            elastica(sheet).deflection, rel=1e-5)


# -- 3D ----------------------------------------------------------------------------------------------
def test_3d_sampled_trapezoid_gives_the_trapezoids_deflection():
    from skfem_sheet.solve import solve
    a = solve(Sheet(0.8, 0.6, 1.5), hmax=0.2)
    b = solve(sampled_trapezoid(0.8, 0.6, 1.5), hmax=0.2)
    assert a.converged and b.converged
    assert abs(a.deflection - b.deflection) < 1e-6


def test_3d_bitten_sheet_solves_and_its_tip_is_on_the_bite():
    from skfem_sheet.solve import solve
    s = Sheet.from_planform(Planform.trapezoid(1.0, bites=(0.3,)), length=0.8)
    r = solve(s, hmax=0.2)
    assert r.converged
    d = tip_deflection(r.problem, r.w)
    assert d == r.deflection and 0 < d < solve(Sheet(0.8), hmax=0.2).deflection


def test_curved_outlines_converge_at_second_order():
    # spline side (leaf) and circle arcs (bite): the meshed area error falls like h^2
    leaf = Sheet(1.2, planform=lambda x: 1 + x - 2.2 / 1.44 * x**2)
    bitten = Sheet.from_planform(Planform.trapezoid(1.0, bites=(0.3,)), length=1.0)
    for s in (leaf, bitten):
        err = []
        for h in (0.1, 0.05):
            m = sheet_mesh(s, h, half=True).mesh
            v = m.p[:, m.t]
            vol = np.einsum("ij,ij->j", np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0], axis=0),
                            v[:, 3] - v[:, 0]).sum() / 6
            err.append(abs(2 * vol / s.thickness - s.area))
        assert err[1] < err[0] / 3 and err[1] < 1e-3 * s.area
