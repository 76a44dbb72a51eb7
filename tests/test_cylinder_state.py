"""The clamp's cylinder as a state (``continuation.cylinder_state``)."""
import numpy as np
import pytest

from skfem_sheet import Sheet
from skfem_sheet.analyses.observables import tip_deflection
from skfem_sheet.analyses.stability import stability
from skfem_sheet.continuation import _cylinder_displacement, cylinder_state, follow_path
from skfem_sheet.kernels import clamp_displacement
from skfem_sheet.linalg import make_linear_solver
from skfem_sheet.newton import NewtonOptions, Stats, newton
from skfem_sheet.params import ParameterError
from skfem_sheet.solve import build_problem

TIGHT = NewtonOptions(rtol=1e-9, utol=1e-10, max_iterations=30)


def _jacobian(kappa, y, z, eps=1e-6):
    """det of the map (y, z) -> (y, z) + U by central differences (U_x = 0, no x-dependence)."""
    def pos(yy, zz):
        U = _cylinder_displacement(yy, zz, kappa)
        return np.stack([yy + U[..., 1], zz + U[..., 2]], -1)

    dy = (pos(y + eps, z) - pos(y - eps, z)) / (2 * eps)
    dz = (pos(y, z + eps) - pos(y, z - eps)) / (2 * eps)
    return dy[..., 0] * dz[..., 1] - dy[..., 1] * dz[..., 0]


@pytest.mark.parametrize("kappa", [0.5, 2.5, 6.0])
def test_the_cylinder_is_isochoric_and_the_clamp_s_arc(kappa):
    rng = np.random.default_rng(3)
    y, z = rng.uniform(-0.5, 0.5, 200), rng.uniform(-0.05, 0.05, 200)
    # J = 1 to the difference error (the clamp's own map has J = 1 - kappa z)
    assert np.abs(_jacobian(kappa, y, z) - 1.0).max() < 1e-8
    # the mid-plane on the clamp's arc exactly, the fibres along its normal:
    # off it, the radius R sqrt(1 - 2 kappa z) against the clamp's R - z
    U, C = _cylinder_displacement(y, 0 * z, kappa), clamp_displacement(y, 0 * z, kappa)
    assert np.abs(U - C).max() < 1e-15
    gap = np.linalg.norm(_cylinder_displacement(y, z, kappa) - clamp_displacement(y, z, kappa),
                         axis=-1)
    rho = 1 / kappa - np.sqrt(1 / kappa**2 - 2 * z / kappa)
    assert gap == pytest.approx(np.abs(rho - z), rel=1e-6, abs=1e-15)


def test_cylinder_state_holds_the_clamp_and_is_nearly_incompressible():
    problem = build_problem(Sheet(length=0.8, curvature=3.0), 0.15, None, 2, True, 0)
    w = cylinder_state(problem, 3.0)
    assert np.array_equal(w[problem.clamp_dofs], problem.clamp_values(3.0))
    U, p = problem.split(w)
    assert np.all(U[:, 0] == 0) and np.all(p == 0)
    # the P2 interpolant of the isochoric map: away from the clamp's elements
    # (where the clamp's own map takes over) |J - 1| is interpolation error,
    # O(h^2), while the clamp's map extended along x has J = 1 - kappa z
    ext = w.copy()
    ext[: problem.nu_dof] = clamp_displacement(problem.nodes[:, 1], problem.nodes[:, 2],
                                               3.0).ravel()
    assert np.abs(problem.jacobians(ext) - 1).max() > 0.04
    errors = []
    for h in (0.15, 0.075):
        pr = build_problem(Sheet(length=0.8, curvature=3.0), h, 2, 2, True, 0)
        far = np.ones(len(pr.dx), bool)
        far[pr.clamp_elements] = False
        errors.append(np.abs(pr.jacobians(cylinder_state(pr, 3.0))[far] - 1).max())
    assert errors[0] < 0.02 and errors[1] < errors[0] / 3
    # the plate pressure frees the faces: p = mu (R^2 / rho^2 - 1), odd in z
    pp = problem.split(cylinder_state(problem, 3.0, "plate"))[1]
    z = problem.nodes[: problem.n_vertices, 2]
    assert np.allclose(pp, problem.mu * 6 * z / (1 - 6 * z))
    assert np.array_equal(cylinder_state(problem, 0.0), np.zeros(problem.ndof))


def test_newton_from_the_cylinder_reaches_the_ramp_s_state():
    # the triangle of solve_speed at a/R = 2.5: Newton from the cylinder at zero
    # gravity converges, to the state the curvature ramp reaches (same d to
    # 1e-8 after tight solves of both, same inertia)
    sheet = Sheet(1.3, 0.0, 2.5)
    problem = build_problem(sheet, 0.15, None, 2, True, 0)
    ramp = {}

    def on_step(pr, w, k, g):
        if g == 0.0 and k == 2.5:
            ramp.setdefault("w", w.copy())

    follow_path(problem, "curvature-first", 2.5, make_linear_solver("auto"), on_step=on_step)
    lin = make_linear_solver("auto")
    ref = newton(problem, ramp["w"], 0.0, lin, TIGHT, Stats())
    ref_inertia = stability(problem, lin)
    res = newton(problem, cylinder_state(problem, 2.5), 0.0, lin,
                 NewtonOptions(rtol=1.0, utol=1e-3), Stats())
    assert res.converged and ref.converged
    pol = newton(problem, res.w, 0.0, lin, TIGHT, Stats())
    assert pol.converged and stability(problem, lin) == ref_inertia
    assert tip_deflection(problem, pol.w) == pytest.approx(tip_deflection(problem, ref.w),
                                                           rel=1e-8)
    assert np.abs(pol.w[: problem.nu_dof] - ref.w[: problem.nu_dof]).max() < 1e-7


def test_cylinder_state_bad_arguments():
    problem = build_problem(Sheet(length=0.5), 0.2, None, 2, True, 0)
    with pytest.raises(ParameterError, match="pressure"):
        cylinder_state(problem, 1.0, "paper")
    with pytest.raises(ParameterError, match="kappa"):
        cylinder_state(problem, 1.0 / problem.sheet.thickness)
