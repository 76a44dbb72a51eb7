"""The supplement's ansatz check (issue 27): mid-surface observables, gravity 0, the ansatz.

- :mod:`skfem_sheet.analyses.midsurface` on states with known answers (rigid
  motions and stretches of the flat sheet, the clamped arc), its symmetry and
  the half model against the whole sheet;
- ``solve(..., gravity=0.0)`` on both load paths against the persistence-length
  model's no-gravity limit (the integrated lateral curvature L_p/(3R), reached as
  stretching comes to dominate);
- the claims of Figs. S3 and S4 at a coarse mesh (hmax 0.1) through
  ``benchmarks/ansatz.py``'s own functions, with the numbers measured at hmax
  0.1 and 0.03 (``benchmarks/results/accuracy/ansatz_hmax0.03.txt``) written beside
  each tolerance.
"""
import importlib.util
import math
import os

import numpy as np
import pytest

from skfem_sheet import Sheet, solve
from skfem_sheet.analyses.midsurface import (
    clamp_layer_width,
    midsurface,
    midsurface_at,
    quadratic_fit,
)
from skfem_sheet.params import ParameterError
from skfem_sheet.reduced.persistence import persistence_length
from skfem_sheet.solve import build_problem

_PATH = os.path.join(os.path.dirname(__file__), os.pardir, "benchmarks", "ansatz.py")
_spec = importlib.util.spec_from_file_location("bench_ansatz", _PATH)
ansatz = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(ansatz)

COARSE = 0.1
S4_SECTIONS = (0.4, 0.8, 1.2)


def _state(problem, U):
    return problem.space.join(U, np.zeros(problem.space.n_vertices))


# -- kinematics on states with known answers ------------------------------------------------
@pytest.fixture(scope="module")
def flat_problem():
    return build_problem(Sheet(length=1.2, curvature=0.0), 0.25, None, 2, half=True)


def test_rigid_rotation_and_translation_leave_no_relative_displacement(flat_problem):
    # X -> Q X + c with Q a rotation about e2 by alpha: linear in X, so exact in P2;
    # the section frame must carry it all: phi = alpha, u = v = w = 0, E = 0 (round-off)
    alpha = 0.3
    Q = np.array([[math.cos(alpha), 0, -math.sin(alpha)], [0, 1, 0],
                  [math.sin(alpha), 0, math.cos(alpha)]])
    X = flat_problem.nodes
    U = X @ Q.T - X + np.array([0.1, 0.0, -0.2])
    m = midsurface(flat_problem, _state(flat_problem, U), [0.0, 0.6, 1.2], n_across=21)
    assert np.allclose(m.frame.angle, alpha, atol=1e-12)
    assert np.allclose(m.frame.strain, 0.0, atol=1e-12)
    for a in (m.u, m.v, m.w, m.E_ss, m.E_st, m.E_tt):
        assert np.abs(a).max() < 1e-12
    # centre of mass: the rotated centre line
    expected = np.outer(m.s, Q[:, 0]) + np.array([0.1, 0.0, -0.2])
    assert np.allclose(m.frame.centre, expected, atol=1e-12)


def test_uniform_stretch_gives_the_green_lagrange_strain(flat_problem):
    # x = (1 + e) X e1 + (1 + f) Y e2: E_ss = e + e^2/2, E_tt = f + f^2/2, E_st = 0,
    # eps = e, v = f t, u = w = 0; plate stresses T/Y = E + nu E_other
    e, f = 0.01, -0.004
    U = flat_problem.nodes * np.array([e, f, 0.0])
    m = midsurface(flat_problem, _state(flat_problem, U), [0.3, 0.9], n_across=11)
    assert np.allclose(m.E_ss, e + e**2 / 2, atol=1e-14)
    assert np.allclose(m.E_tt, f + f**2 / 2, atol=1e-14)
    assert np.abs(m.E_st).max() < 1e-14
    assert np.allclose(m.frame.strain, e, atol=1e-14)
    assert np.allclose(m.v, f * m.t, atol=1e-14)
    assert np.allclose(m.T_ss, m.E_ss + 0.5 * m.E_tt)
    assert np.allclose(m.T_tt, m.E_tt + 0.5 * m.E_ss)


def test_quadratic_fit_is_exact_on_quadratics_and_measures_a_quartic():
    t = np.linspace(-0.5, 0.5, 41)
    c, r = quadratic_fit(t, 0.2 - 0.1 * t + 3 * t**2)
    assert np.allclose(c, [0.2, -0.1, 3.0]) and r < 1e-12
    _, r4 = quadratic_fit(t, t**4 - np.mean(t**4))
    assert 0.05 < r4 < 0.5   # a quartic is not a quadratic (measured 0.12)


# -- on a solved sheet ----------------------------------------------------------------------
@pytest.fixture(scope="module")
def s4_coarse():
    sheet = Sheet(length=2.0, curvature=0.5, thickness=0.03175)
    return sheet, solve(sheet, hmax=COARSE, gravity=0.0)


def test_the_clamped_section_is_the_arc(s4_coarse):
    # s = 0: x(0, t) = (0, R sin(t/R), R (1 - cos(t/R))), so relative to its centre
    # v = R sin(t/R) - t, w = R [(2R/a) sin(a/(2R)) - cos(t/R)] (a = 1, phi(0) ~ 0);
    # the P2 interpolation of the arc at hmax 0.1 is measured to 2e-6 in v, w
    sheet, r = s4_coarse
    R = 1.0 / sheet.curvature
    m = midsurface(r.problem, r.w, [0.0], n_across=41)
    t = m.t[0]
    assert np.abs(m.v[0] - (R * np.sin(t / R) - t)).max() < 2e-5
    assert np.abs(m.w[0] - R * (2 * R * np.sin(1 / (2 * R)) - np.cos(t / R))).max() < 2e-5
    # the clamp keeps the arc's length: E_tt(0, t) vanishes to the interpolation error
    # of the arc's tangent (measured 2e-4 at hmax 0.1, against E ~ 3e-3 nearby)
    assert np.abs(m.E_tt[0]).max() < 5e-4
    assert abs(m.frame.angle[0]) < 0.01   # horizontal clamp (3D: -0.002, a layer of size h)


def test_mirror_symmetry_of_the_fields(s4_coarse):
    # the symmetric state: u, w, E_ss, E_tt even in t; v, E_st odd
    _, r = s4_coarse
    m = midsurface(r.problem, r.w, [0.3, 1.0], n_across=21)
    for a in (m.u, m.w, m.E_ss, m.E_tt):
        assert np.abs(a - a[:, ::-1]).max() < 1e-12
    for a in (m.v, m.E_st):
        assert np.abs(a + a[:, ::-1]).max() < 1e-12
    # zero cross-sectional means (Simpson on the grid; u, v, w by construction)
    w = np.ones(21)
    w[1:-1:2], w[2:-1:2] = 4, 2
    for a in (m.u, m.v, m.w):
        assert np.abs(a @ (w / w.sum())).max() < 1e-12


def test_half_model_and_whole_sheet_agree():
    # the mirrored half (the default) against the whole sheet on the same cut: the
    # same state to the solver's tolerance (measured 3e-9 in w at hmax 0.2)
    sheet = Sheet(length=1.0, curvature=0.5, thickness=0.03175)
    half = solve(sheet, hmax=0.2, gravity=0.0)
    whole = solve(sheet, hmax=0.2, gravity=0.0, symmetric=False)
    s = [0.25, 0.75]
    a = midsurface(half.problem, half.w, s, n_across=21)
    b = midsurface(whole.problem, whole.w, s, n_across=21)
    for name in ("u", "v", "w"):
        assert np.abs(getattr(a, name) - getattr(b, name)).max() < 1e-7, name
    # strains off the plane t = 0: there the whole sheet's gradient is one element's
    # (it jumps across the plane's element faces), the half model's the mean of both
    # sides (odd parts cancel: E_st(s, 0) = 0; one side's is 1.5e-5 here)
    off = np.r_[0:10, 11:21]
    for name in ("E_ss", "E_st", "E_tt"):
        assert np.abs(getattr(a, name)[:, off] - getattr(b, name)[:, off]).max() < 1e-7, name
    assert np.abs(a.E_st[:, 10]).max() < 1e-15


def test_vtu_carries_the_midsurface_fields(s4_coarse, tmp_path):
    meshio = pytest.importorskip("meshio")
    _, r = s4_coarse
    fn = tmp_path / "s4.vtu"
    r.write(str(fn))
    out = meshio.read(fn)
    for name in ("midsurface_u", "midsurface_v", "midsurface_w", "E_ss", "E_st", "E_tt",
                 "T_ss_over_Y", "T_tt_over_Y"):
        assert name in out.point_data, name
    # the vertex values are the grid's at the same (s, t)
    P = out.points
    i = int(np.argmin(np.abs(P[:, 0] - 0.8) + np.abs(P[:, 1] - 0.3)))
    f = midsurface_at(r.problem, r.w, P[i:i + 1, :2])
    assert out.point_data["midsurface_w"][i] == pytest.approx(f["w"][0], abs=1e-12)
    # and constant through the thickness (one value per plan point)
    same = np.flatnonzero((np.abs(P[:, 0] - P[i, 0]) < 1e-12) & (np.abs(P[:, 1] - P[i, 1]) < 1e-12))
    assert len(same) >= 2
    assert np.ptp(out.point_data["E_ss"][same]) == 0.0


def test_bad_input_names_the_parameter(s4_coarse):
    _, r = s4_coarse
    with pytest.raises(ParameterError, match="s must lie"):
        midsurface(r.problem, r.w, [2.5])
    with pytest.raises(ParameterError, match="n_across"):
        midsurface(r.problem, r.w, [0.5], n_across=20)
    with pytest.raises(ParameterError, match="points"):
        midsurface_at(r.problem, r.w, [0.5, 0.1, 0.0])
    with pytest.raises(ParameterError, match="n_sections"):
        midsurface_at(r.problem, r.w, [[0.5, 0.1]], n_sections=1)
    with pytest.raises(ParameterError, match="t and w"):
        quadratic_fit([0, 1], [0, 1])


# -- gravity 0 on both paths against the persistence-length model ---------------------------
@pytest.mark.parametrize("path", ["curvature-first", "gravity-first"])
def test_gravity_free_curvature_approaches_the_persistence_model(path):
    # Without gravity the persistence-length model (supplement, "Persistence length in
    # the absence of gravity") has R c(s) = (1 - s/L_p)^2 up to L_p = a^2/sqrt(70 h R),
    # so int_0^L R c ds = L_p / 3.  It holds where stretching dominates the lateral
    # bending, i.e. for L_p large against the width's own decay length.  The 3D
    # ratio int R c ds / (L_p/3), measured at hmax 0.15 (0.1) on both paths:
    # 1.551 (1.54) at a/R 2.5, h/a 0.03 (L_p 1.09); 1.172 (1.17) at a/R 5, h/a 0.03
    # (L_p 1.54); 1.064 (1.069) at a/R 5, h/a 0.015 (L_p 2.18): it falls to 1 as L_p
    # grows.  Asserted: decreasing, the last within 10% of 1 and the first not.
    # (At the paper's S3/S4 sheet, a/R 0.5 and L_p 0.47, the 3D curvature does not
    # follow the model's L_p: R c(s) is nearly the same at a/R 1.)
    ratios = []
    for H, kappa in ((0.03, 2.5), (0.03, 5.0), (0.015, 5.0)):
        sheet = Sheet(length=2.5, curvature=kappa, thickness=H)
        r = solve(sheet, path=path, hmax=0.15, gravity=0.0)
        assert r.converged and r.target_gravity == 0.0 and r.gravity == 0.0
        s = np.linspace(0.0, 2.5, 51)
        C = midsurface(r.problem, r.w, s).lateral_curvature() / kappa
        integral = float(np.sum((C[1:] + C[:-1]) / 2 * np.diff(s)))
        ratios.append(integral / (persistence_length(sheet).persistence_length / 3))
    assert np.all(np.diff(ratios) < 0)
    assert ratios[-1] == pytest.approx(1.0, abs=0.1)
    assert ratios[0] > 1.3


def test_gravity_free_paths_reach_one_midsurface():
    # gravity 0 leaves one curvature phase on either path: the same state
    sheet = Sheet(length=1.5, curvature=0.5, thickness=0.03175)
    ms = []
    for path in ("curvature-first", "gravity-first"):
        r = solve(sheet, path=path, hmax=COARSE, gravity=0.0)
        ms.append(midsurface(r.problem, r.w, [0.5, 1.0]))
    for name in ("u", "v", "w", "E_ss"):
        assert np.abs(getattr(ms[0], name) - getattr(ms[1], name)).max() < 1e-9, name


# -- the claims of Figs. S3 and S4 (coarse mesh) ------------------------------------------
@pytest.fixture(scope="module")
def ansatz_coarse():
    return ansatz.run(hmax=COARSE)


def test_w_is_quadratic_in_t_at_leading_order(ansatz_coarse):
    # Fig. S4: "w is quadratic in t at leading order".  Relative residual of the
    # least-squares quadratic over the full width, measured (hmax 0.1 / 0.03):
    # 0.067 / 0.069, 0.073 / 0.074, 0.068 / 0.069 at s/a = 0.4, 0.8, 1.2 -- above the
    # issue's 0.05, mesh-converged; what remains is an even quartic (residual of
    # c0 + c2 t^2 + c4 t^4: 0.0009 / 0.0010, 0.0025, 0.0020 / 0.0019).
    rows = ansatz_coarse["sections"]
    assert [r["s"] for r in rows] == list(S4_SECTIONS)
    for r in rows:
        assert r["w_quadratic_residual"] < 0.09
        assert r["w_quartic_residual"] < 0.005
        assert r["w_quartic_residual"] < 0.1 * r["w_quadratic_residual"]


def test_inplane_displacements_are_of_order_thickness_squared(ansatz_coarse):
    # Fig. S4: u/(h/a)^2 and v/(h/a)^2 are O(1).  Measured maxima (hmax 0.1 / 0.03):
    # u 0.432/0.431, 0.150/0.147, 0.026/0.025; v 1.131/1.078, 0.092/0.083, 0.025/0.025.
    # w/(h/a) 0.59, 0.20, 0.065 (it decays with the curvature c(s)).
    rows = ansatz_coarse["sections"]
    for r in rows:
        assert r["u_scaled_max"] < 3 and r["v_scaled_max"] < 3
    assert 0.1 < max(r["u_scaled_max"] for r in rows) < 3
    assert 0.1 < max(r["v_scaled_max"] for r in rows) < 3
    assert 0.1 < rows[0]["w_scaled_max"] < 3


def test_inplane_exponent(ansatz_coarse):
    # With a/R in proportion to h/a (the ansatz's w ~ a (h/a)), u and v scale like
    # (h/a)^p with p = 1.929 +- 0.026 (hmax 0.1; 1.960 +- 0.019 at hmax 0.03): 2.
    # At the paper's fixed a/R = 0.5 the clamp sets them (v(0, t) = -t^3/(6 R^2)):
    # p = 0.140 +- 0.220 (0.146 +- 0.215 at hmax 0.03), not 2.
    out = ansatz_coarse
    assert out["inplane_exponent_similar"] == pytest.approx(2.0, abs=0.15)
    assert out["inplane_exponent_similar_uncertainty"] < 0.1
    assert abs(out["inplane_exponent"]) < 1.0


def test_strains_outside_the_clamp_layer_are_small(ansatz_coarse):
    # Fig. S3: "save for a small boundary layer near the clamped edge, strains and
    # stresses are all small".  Layer width ln(20) sqrt(Rh)/(3(1-nu^2))^(1/4) = 0.616;
    # largest |E| beyond it, measured 1.31e-3 (hmax 0.1) / 1.30e-3 (0.03), i.e. 1.3 (h/a)^2,
    # at the layer's edge on the free side; inside it 3.6e-3 / 3.2e-3, near the corners.
    out = ansatz_coarse
    H = out["case"]["thickness"]
    assert out["layer_width"] == pytest.approx(clamp_layer_width(Sheet(length=1.5,
                                               curvature=0.5, thickness=H)))
    assert out["strain_max_outside_layer"] < 2 * H**2
    assert out["strain_max_outside_layer"] < 0.5 * out["strain_max_in_layer"]
    # and small against the bending strain at the surfaces, h/(2R) = 7.9e-3
    assert out["strain_max_outside_layer"] < 0.25 * out["bending_strain_scale"]


def test_ansatz_json_interface(ansatz_coarse, tmp_path):
    fn = tmp_path / "a.json"
    assert ansatz.main(["--hmax", "0.2", "--second-thickness", "0", "--json", str(fn)]) == 0
    import json

    out = json.loads(fn.read_text())
    assert [r["s"] for r in out["sections"]] == list(S4_SECTIONS)
    for r in out["sections"]:
        assert {"s", "w_quadratic_residual", "u_scaled_max", "v_scaled_max"} <= set(r)
    assert {"strain_max_outside_layer", "layer_width"} <= set(out)
    assert "inplane_exponent" not in out   # no second thickness ran
    assert "inplane_exponent" in ansatz_coarse
