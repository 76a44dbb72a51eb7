"""Shared test data: a small tapered sheet problem and random admissible states."""
import numpy as np

from skfem_sheet import Sheet
from skfem_sheet.kernels import clamp_displacement
from skfem_sheet.mesh import sheet_mesh
from skfem_sheet.problem import SheetProblem


def small_problem(half):
    s = Sheet(length=0.8, tip_width=0.5, curvature=2.0)
    return SheetProblem(s, sheet_mesh(s, 0.2, layers=2, half=half))


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
