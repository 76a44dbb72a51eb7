"""Ribbon model (supplement, large plate rotations), continuation and the Fig. 6 map."""
import numpy as np
import pytest

from skfem_sheet.params import Sheet
from skfem_sheet.reduced import (
    detect_jumps,
    elastica,
    plot_map,
    ribbon,
    ribbon_continuation,
    ribbon_energy_terms,
    ribbon_map,
    write_map_csv,
)
from skfem_sheet.reduced._ribbon_fem import (
    energy_gradient_hessian,
    make_mesh,
    make_operators,
    minimise,
    total_energy,
)
from skfem_sheet.reduced._ribbon_kernels import energy_density, energy_derivatives, energy_terms
from skfem_sheet.reduced.ribbon import DEFAULT_ELEMENTS, _deflection, _free_mask

NU = 0.5


# -- the energy -------------------------------------------------------------------
def _direct_density(q, p, grav, Y, D, nu, n_t=12):
    """Energy per length by Gauss quadrature in t of the ansatz strains (eqs. strainansatz,
    bendstrainansatz) and the plate energy T_ij E_ij/2 + M_ij B_ij/2."""
    c, c1, c2, P, phi = q
    x, w = np.polynomial.legendre.leggauss(n_t)
    t, w = 0.5 * p * x, 0.5 * p * w
    q2 = t**2 / 2 - p**2 / 24
    q4 = t**4 / 24 - p**4 / (16 * 120)
    Ess = -c * P * q2 + (2 * c1**2 - c * c2) * q4
    Bss, Btt, Bst = P + c2 * t**2 / 2, c, c1 * t
    stretch = 0.5 * Y * Ess**2                       # E_tt = E_st = 0: T_ss = Y E_ss
    Mss, Mtt, Mst = D * (Bss + nu * Btt), D * (Btt + nu * Bss), D * (1 - nu) * Bst
    bend = 0.5 * (Mss * Bss + Mtt * Btt + 2 * Mst * Bst)
    return np.sum(w * (stretch + bend)) + grav * np.sin(phi)


def test_energy_density_matches_t_quadrature():
    rng = np.random.default_rng(1)
    for _ in range(5):
        q = rng.normal(size=5)
        p, grav = rng.uniform(0.1, 1.0), rng.uniform(0, 1)
        e = energy_density(q[None], np.array([p]), np.array([grav]), 29.4, 0.0022, NU)[0]
        assert e == pytest.approx(_direct_density(q, p, grav, 29.4, 0.0022, NU), rel=1e-12)
        terms = energy_terms(q[None], np.array([p]), np.array([grav]), 29.4, 0.0022, NU)
        assert sum(v[0] for v in terms.values()) == pytest.approx(e, rel=1e-12)


def test_pointwise_derivatives_match_finite_differences():
    rng = np.random.default_rng(2)
    q, p, g = rng.normal(size=(6, 5)), rng.uniform(0.2, 1, 6), rng.uniform(0, 1, 6)
    _, grad, hess = energy_derivatives(q, p, g, 3.0, 0.1, NU)
    h = 1e-6
    for i in range(5):
        dq = np.zeros(5)
        dq[i] = h
        ep, gp, _ = energy_derivatives(q + dq, p, g, 3.0, 0.1, NU)
        em, gm, _ = energy_derivatives(q - dq, p, g, 3.0, 0.1, NU)
        np.testing.assert_allclose((ep - em) / (2 * h), grad[:, i], atol=1e-8)
        np.testing.assert_allclose((gp - gm) / (2 * h), hess[:, :, i], atol=1e-8)


def test_assembled_gradient_matches_finite_differences():
    mesh = make_mesh(6)
    s = Sheet(length=1.3, tip_width=0.4, curvature=2.5)
    ops = make_operators(mesh, 1.3, 0.4, 0.03, s.stretching_modulus, s.bending_modulus, NU)
    x = np.random.default_rng(3).normal(scale=0.3, size=4 * 7)
    E, g, H = energy_gradient_hessian(ops, x)
    assert E == pytest.approx(total_energy(ops, x))
    h = 1e-6
    for k in range(0, x.size, 3):
        e = np.zeros_like(x)
        e[k] = h
        assert (total_energy(ops, x + e) - total_energy(ops, x - e)) / (2 * h) == \
            pytest.approx(g[k], rel=1e-5, abs=1e-9)
        _, gp, _ = energy_gradient_hessian(ops, x + e)
        _, gm, _ = energy_gradient_hessian(ops, x - e)
        np.testing.assert_allclose((gp - gm) / (2 * h), H[:, k], rtol=1e-5, atol=1e-8)


# -- limits -----------------------------------------------------------------------
@pytest.mark.parametrize("b", [1.0, 0.0])
@pytest.mark.parametrize("L", [0.5, 1.0, 1.8])
def test_flat_ribbon_is_heavy_elastica(b, L):
    ref = elastica(Sheet(length=L, tip_width=b)).deflection
    r = ribbon(Sheet(length=L, tip_width=b, curvature=2.5), impose_flat=True)
    assert r.converged and r.stable
    assert r.deflection == pytest.approx(ref, rel=5e-3)
    assert r.deflection == pytest.approx(ref, rel=1e-6)     # what we actually get
    assert np.all(r.c == 0.0)


@pytest.mark.parametrize("L", [0.8, 1.0, 1.3, 1.8])
def test_free_c_rectangle_at_zero_curvature_close_to_elastica(L):
    ref = elastica(Sheet(length=L)).deflection
    r = ribbon(Sheet(length=L))
    assert r.deflection == pytest.approx(ref, rel=5e-3)
    assert 0 < np.max(np.abs(r.c)) < 0.1          # Poisson coupling: small c


# Issue 7 asked for the free-c rectangle within 0.5 % of the elastica on L = 0.5...1.8.  That
# holds from L = 0.75 on only, and it should not hold below: the elastica (plate modulus) is
# the wide-plate limit, the anticlastic curvature makes short and tapered sheets softer, and
# the 3D solver is softer still (see ribbon.py, "Flat clamp: why c free is softer ..." and
# test_free_c_softening_agrees_with_3d).  These tests assert that behaviour instead.
FLAT_LENGTHS = np.array([0.5, 0.6, 0.7, 0.8, 1.0, 1.4, 1.8])


def _free_c_vs_elastica(b):
    return np.array([ribbon(Sheet(length=L, tip_width=b)).deflection
                     / elastica(Sheet(length=L, tip_width=b)).deflection - 1
                     for L in FLAT_LENGTHS])


def test_free_c_rectangle_softening_decreases_with_length():
    rel = _free_c_vs_elastica(1.0)       # +1.92 % at L = 0.5 ... -0.004 % at L = 1.8
    assert np.all(np.diff(np.abs(rel)) < 0)
    assert 0.01 < rel[0] < 0.03                              # short sheet: measurably softer
    assert np.all(np.abs(rel[FLAT_LENGTHS >= 0.75]) < 5e-3)   # issue 7's 0.5 % from 0.75 on
    assert abs(rel[FLAT_LENGTHS == 0.7][0]) > 5e-3 > abs(rel[FLAT_LENGTHS == 0.8][0])


def test_free_c_triangle_softening_decreases_with_length():
    rel = _free_c_vs_elastica(0.0)       # +35.6 % at L = 0.5, +4.1 % at 1.0, +0.12 % at 1.8
    assert np.all(rel > 0) and np.all(np.diff(rel) < 0)
    # 3D gives +37 % at L = 0.5; the beam-modulus limit 1/(1 - nu^2) - 1 is 33 %
    assert 0.30 < rel[0] < 0.42
    assert 0.02 < rel[FLAT_LENGTHS == 1.0][0] < 0.06
    assert rel[-1] < 5e-3


def _free_c_deflection(sheet, nu, n=24):
    """ribbon() at curvature 0 with a chosen Poisson ratio (load ramped as in ribbon())."""
    mesh = make_mesh(n)
    x = np.zeros(4 * (n + 1))
    for lam in (0.25, 0.5, 0.75, 1.0):
        ops = make_operators(mesh, sheet.length, sheet.tip_width, sheet.thickness,
                             sheet.stretching_modulus, sheet.bending_modulus, nu, lam)
        x, conv, _, _ = minimise(ops, x, _free_mask(n + 1, False))
        assert conv
    return _deflection(ops, x, mesh.S_nodes, sheet.length, sheet.tip_width), x[0::4]


def test_free_c_difference_is_poisson_coupling_for_rectangle_taper_for_triangle():
    for L in (0.5, 1.0):
        s = Sheet(length=L)
        d, c = _free_c_deflection(s, 0.0)
        assert d == pytest.approx(elastica(s).deflection, rel=1e-6)
        assert np.max(np.abs(c)) < 1e-8
        assert _free_c_deflection(s, 0.5)[0] == pytest.approx(ribbon(s).deflection, rel=1e-9)
    tri = Sheet(length=0.5, tip_width=0.0)
    d_tri = _free_c_deflection(tri, 0.0)[0]       # +14.5 %: taper couples c to phi' at nu = 0
    assert d_tri > 1.1 * elastica(tri).deflection


def test_energy_terms_and_their_trend():
    short, long_ = Sheet(length=0.5), Sheet(length=1.5)
    rs, rl = ribbon(short), ribbon(long_)
    es, el = ribbon_energy_terms(short, rs), ribbon_energy_terms(long_, rl)
    mesh = make_mesh(DEFAULT_ELEMENTS)
    ops = make_operators(mesh, 0.5, 1.0, 0.03, short.stretching_modulus,
                         short.bending_modulus, NU)
    assert es["total"] == pytest.approx(total_energy(ops, rs.state), rel=1e-12)
    for e in (es, el):
        assert e["poisson"] < 0 < min(e["bending_tt"], e["twisting"], e["stretching"])
    # the anticlastic (Poisson) energy matters less for the longer, more strongly bent sheet
    assert abs(es["poisson"]) / es["bending_ss"] > 2 * abs(el["poisson"]) / el["bending_ss"]
    flat = ribbon_energy_terms(short, ribbon(short, impose_flat=True))
    assert flat["poisson"] == flat["bending_tt"] == flat["twisting"] == flat["stretching"] == 0
    with pytest.raises(ValueError, match="result"):
        ribbon_energy_terms(long_, rs)


@pytest.mark.slow
@pytest.mark.parametrize("b", [1.0, 0.0])
def test_free_c_softening_agrees_with_3d(b):
    """At L = 0.5 the 3D solver is softer than the elastica, and softer than the ribbon model:
    rectangle +2.4 %, triangle +37 % (hmax 0.03; both rise under refinement)."""
    from skfem_sheet import solve
    s = Sheet(length=0.5, tip_width=b)
    d_el, d_rib = elastica(s).deflection, ribbon(s).deflection
    d_3d = solve(s, hmax=0.03).deflection
    assert d_3d > d_rib > 1.005 * d_el
    assert abs(d_rib - d_3d) < abs(d_el - d_3d)


def test_tapered_clamp_slope_and_clamp_conditions():
    s = Sheet(length=1.2, tip_width=0.0, curvature=2.5)
    r = ribbon(s)
    assert r.Phi[0] == 0.0 and r.c[0] == 2.5
    assert r.phi[0] == pytest.approx(1.0 * (-1 / 1.2) * 2.5 / 12, rel=1e-12)   # p p'/(12 R)


def test_mesh_convergence():
    s = Sheet(length=1.2, tip_width=0.5, curvature=2.5)
    d16, d32 = ribbon(s, n_elements=16).deflection, ribbon(s, n_elements=32).deflection
    assert abs(d16 - d32) < 1e-4


# -- continuation and bistability ---------------------------------------------------
def test_rectangle_jump_and_hysteresis():
    lengths = np.arange(1.2, 1.56, 0.02)
    up = ribbon_continuation(Sheet(1.0, curvature=2.5), lengths, "increasing")
    down = ribbon_continuation(Sheet(1.0, curvature=2.5), lengths, "decreasing")
    assert up.converged.all() and down.converged.all()
    assert up.stable.all() and down.stable.all()
    assert up.jumped.sum() == 1 and down.jumped.sum() == 1
    L_up, L_down = up.jump_lengths[0], down.jump_lengths[0]
    assert L_up == pytest.approx(1.38, abs=0.03)               # paper, Fig. 5c
    assert L_down < L_up - 0.01                                # hysteresis
    # orders: increasing list starts short, decreasing starts long
    assert up.lengths[0] < up.lengths[-1] and down.lengths[0] > down.lengths[-1]
    # the two branches overlap in the bistable range: two states at one length
    jump_up = up.deflection[np.flatnonzero(up.jumped)[0]] - up.deflection[np.flatnonzero(up.jumped)[0] - 1]
    assert jump_up > 0.2
    fine = np.arange(1.360, 1.400, 0.005)
    fu = ribbon_continuation(Sheet(1.0, curvature=2.5), fine, "increasing",
                             start=up.results[int(np.searchsorted(up.lengths, 1.35)) - 1])
    fd = ribbon_continuation(Sheet(1.0, curvature=2.5), fine, "decreasing",
                             start=down.results[int(np.flatnonzero(down.lengths > 1.40)[-1])])
    both = np.abs(fu.deflection - fd.deflection[::-1]) > 0.1
    assert both.any()


def test_triangle_is_smooth_without_jump():
    lengths = np.linspace(0.8, 2.0, 31)
    up = ribbon_continuation(Sheet(1.0, tip_width=0.0, curvature=2.5), lengths, "increasing")
    down = ribbon_continuation(Sheet(1.0, tip_width=0.0, curvature=2.5), lengths, "decreasing")
    assert not up.jumped.any() and not down.jumped.any()
    np.testing.assert_allclose(up.deflection, down.deflection[::-1], atol=1e-6)
    assert np.all(np.diff(up.deflection) > 0)


def test_detect_jumps_and_validation():
    assert detect_jumps([0, 0.02, 0.04, 0.3, 0.32]).tolist() == [False, False, False, True, False]
    assert not detect_jumps(np.linspace(0, 1, 20) ** 2).any()
    with pytest.raises(ValueError, match="direction"):
        ribbon_continuation(Sheet(1.0), [1.0], "sideways")
    with pytest.raises(ValueError, match="branch"):
        ribbon(Sheet(1.0), branch="up")
    with pytest.raises(ValueError, match="n_elements"):
        ribbon(Sheet(1.0), n_elements=2)
    with pytest.raises(ValueError, match="lengths"):
        ribbon_continuation(Sheet(1.0), [])
    with pytest.raises(ValueError, match="lengths"):
        ribbon_continuation(Sheet(1.0), [1.0, -2.0])


def test_map_table_and_png(tmp_path):
    rows = ribbon_map(2.5, [1.3, 1.36, 1.42, 1.5], [0.0, 1.0])
    assert len(rows) == 2 * 4 * 2
    rect_up = [r for r in rows if r["tip_width"] == 1.0 and r["direction"] == "increasing"]
    assert [r["length"] for r in rect_up] == [1.3, 1.36, 1.42, 1.5]
    assert sum(r["jumped"] for r in rect_up) == 1
    write_map_csv(rows, tmp_path / "m.csv")
    plot_map(rows, tmp_path / "m.png")
    assert (tmp_path / "m.png").stat().st_size > 1000
    assert (tmp_path / "m.csv").read_text().splitlines()[0].startswith("curvature,tip_width")


def test_map_calls_on_shape_once_per_shape_factor():
    seen = []
    rows = ribbon_map(2.5, [1.3, 1.4], [0.0, 0.5, 1.0], on_shape=lambda: seen.append(len(seen)))
    assert seen == [0, 1, 2]
    assert len(rows) == 3 * 2 * 2  # shape factors x directions x lengths


@pytest.mark.slow
def test_map_parallel_matches_serial():
    kw = dict(curvature=2.5, lengths=np.linspace(1.0, 1.6, 7), tip_widths=[0.0, 0.9])
    a, b = ribbon_map(**kw), ribbon_map(**kw, workers=2)
    assert [r["deflection"] for r in a] == pytest.approx([r["deflection"] for r in b])


def test_two_stable_states_at_one_length():
    """Curvature-first vs gravity-first loading paths (the paper's FE protocol)."""
    s = Sheet(length=1.38, curvature=2.5)
    cur, grav = ribbon(s, branch="curvature"), ribbon(s, branch="gravity")
    assert cur.stable and grav.stable and cur.converged and grav.converged
    assert cur.deflection < 0.05 < 0.2 < grav.deflection
    # outside the bistable range both paths agree
    a, b = ribbon(s.replace(length=1.5)), ribbon(s.replace(length=1.5), branch="gravity")
    assert a.deflection == pytest.approx(b.deflection, abs=1e-9)
