"""The tip force of SheetProblem (issue 58): a dead vertical load on the face x = L.

What is checked: the load vector carries the total force F (half of it on a half
model); its work-conjugate is the face's mean vertical displacement; the residual is
the gradient of the energy with the load's potential; the clamp's reaction balances
the weight and the tip force (global equilibrium); a small force bends a flat plate
by the compliance of plate and beam theory; the engine adapter's load derivative is
exact.
"""
import numpy as np
import pytest

from skfem_sheet import Sheet
from skfem_sheet.engine import newton as engine_newton
from skfem_sheet.linalg import make_linear_solver
from skfem_sheet.newton import NewtonOptions, Stats, newton
from skfem_sheet.params import ParameterError
from skfem_sheet.sheet_engine import SheetForceProblem
from skfem_sheet.solve import build_problem, solve
from skfem_sheet.switch import TOLERANCES


@pytest.fixture(scope="module")
def trapezoid():
    return build_problem(Sheet(length=1.1, tip_width=0.7, curvature=2.0), 0.25, half=True)


@pytest.mark.parametrize("half", [True, False])
def test_the_load_vector_carries_the_total_force(half):
    p = build_problem(Sheet(length=1.1, tip_width=0.7, curvature=2.0), 0.25, half=half)
    f = p.tip_load
    assert np.all(f[np.arange(p.ndof) % 3 != 2][: 2 * p.n_nodes] == 0)  # vertical only
    assert f[p.nu_dof:].sum() == 0  # no pressure dofs
    assert np.isclose(f[2:p.nu_dof:3].sum(), 0.5 if half else 1.0, rtol=0, atol=1e-13)
    # only the nodes of the tip face x = L carry it
    loaded = np.flatnonzero(f[2:p.nu_dof:3])
    assert np.allclose(p.nodes[loaded, 0], 1.1)


def test_tip_displacement_is_the_mean_vertical_displacement(trapezoid):
    p = trapezoid
    w = np.zeros(p.ndof)
    w[2:p.nu_dof:3] = -0.37  # a translation: every point of the face moves by it
    assert p.tip_displacement(w) == pytest.approx(-0.37, abs=1e-14)
    # a rotation about the face's mid-line y = 0 (U_z = theta y) averages out
    w[2:p.nu_dof:3] = 0.2 * p.nodes[:, 1]
    full = build_problem(Sheet(length=1.1, tip_width=0.7, curvature=2.0), 0.25, half=False)
    wf = np.zeros(full.ndof)
    wf[2:full.nu_dof:3] = 0.2 * full.nodes[:, 1]
    assert full.tip_displacement(wf) == pytest.approx(0.0, abs=1e-14)


def test_the_residual_is_the_gradient_of_the_energy_with_the_load(trapezoid):
    p = trapezoid
    rng = np.random.default_rng(5)
    w = np.zeros(p.ndof)
    w[p.clamp_dofs] = p.clamp_values(2.0)
    w[p.free] = 1e-3 * rng.standard_normal(p.n_free)
    F, g = -0.013, 0.7
    q = p.with_tip_force(F)
    # the energy: -F w_tip more than without the force (a half model counts twice)
    assert q.energy(w, g) - p.energy(w, g) == pytest.approx(-F * p.tip_displacement(w),
                                                            rel=1e-12)
    # the residual (of the half model) is the gradient of half the energy
    d = np.zeros(p.ndof)
    d[p.free] = rng.standard_normal(p.n_free)
    e = 1e-6
    dE = (q.energy(w + e * d, g) - q.energy(w - e * d, g)) / (2 * e)
    r, _ = q.residual(w, g)
    assert 2 * float(r @ d) == pytest.approx(dE, rel=1e-6)
    # the tangent does not depend on F
    assert abs(q.tangent(w) - p.tangent(w)).max() == 0


def test_copies_share_the_constants_and_keep_the_force(trapezoid):
    q = trapezoid.with_tip_force(0.02)
    assert q.tip_force == 0.02 and q.with_length(1.2).tip_force == 0.02
    assert np.array_equal(q.with_length(1.2).tip_load, q.tip_load)   # a stretch scales the face
    assert q.with_tip_force(0.0).residual(np.zeros(q.ndof), 1.0)[0] == pytest.approx(
        trapezoid.residual(np.zeros(q.ndof), 1.0)[0], abs=0)
    with pytest.raises(ParameterError, match="tip_force must be finite"):
        trapezoid.with_tip_force(float("nan"))


def test_a_pointed_sheet_has_no_tip_face():
    p = build_problem(Sheet(length=1.0, tip_width=0.0), 0.25, half=True)
    with pytest.raises(ParameterError, match="tip face"):
        p.with_tip_force(0.01)


def test_small_force_bends_a_flat_plate_like_plate_and_beam_theory():
    """No gravity, a flat clamp: the tip compliance ``w_tip / F`` of a clamped
    square plate lies between the plate's ``L^3 (1 - nu^2) / (3 E I)`` (the
    anticlastic curvature suppressed) and the beam's ``L^3 / (3 E I)`` (free),
    ``I = b h^3 / 12`` (measured: 149 at hmax 0.25, 161 at 0.1, against 151
    and 202: the coarse mesh 1.3% stiffer than the plate, hence the 3%)."""
    s = Sheet(length=1.0)
    p = build_problem(s, 0.25, half=True)
    F = -1e-5
    q = p.with_tip_force(F)
    res = newton(q, np.zeros(q.ndof), 0.0, make_linear_solver(), NewtonOptions(), Stats())
    assert res.converged
    beam = s.length**3 / (3 * s.modulus * s.thickness**3 / 12)
    plate = beam * (1 - 0.5**2)
    compliance = q.tip_displacement(res.w) / F
    assert 0.97 * plate < compliance < beam
    # global equilibrium: the clamp carries the tip force (half of it on the half)
    r, _ = q.residual(res.w, 0.0)
    clamp_z = q.clamp_dofs[q.clamp_dofs % 3 == 2]
    assert r[clamp_z].sum() == pytest.approx(-0.5 * F, rel=1e-6)


def test_force_adapter_has_the_exact_load_derivative():
    r = solve(Sheet(length=1.1, tip_width=0.7, curvature=2.0), hmax=0.25)
    P = SheetForceProblem(r.problem, make_linear_solver(), curvature=2.0, force_unit=0.01)
    u = r.w[P.free]
    h = 0.3
    fd = (P.residual(u, [h]) - P.residual(u, [-h])) / (2 * h)   # linear in F: exact
    assert np.allclose(P.dresidual(u, [0.0], 0), fd, rtol=0, atol=1e-12)
    assert P.force([2.0]) == pytest.approx(0.02)
    # the clamp reaction at an equilibrium with gravity: the weight less the pull
    res = engine_newton(P, u, [0.1], tol=TOLERANCES)
    assert res.converged
    w = P.full(res.u, [0.1])
    res_full, _ = P.problem_at([0.1]).residual(w, 1.0)
    clamp_z = r.problem.clamp_dofs[r.problem.clamp_dofs % 3 == 2]
    assert res_full[clamp_z].sum() == pytest.approx(r.problem.volume0 - 0.5 * 0.001, rel=1e-6)
