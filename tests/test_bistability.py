import numpy as np
import pytest

from skfem_sheet import Sheet
from skfem_sheet.bistability import fold_lengths, stability, transfer
from skfem_sheet.cli import main
from skfem_sheet.linalg import make_linear_solver
from skfem_sheet.mesh import sheet_mesh
from skfem_sheet.problem import SheetProblem


def test_transfer_is_exact_for_quadratic_fields():
    """Interpolating from a stretched mesh to a fresh one keeps a field that
    both meshes represent exactly (quadratic displacement, linear pressure)."""
    s0 = Sheet(length=1.0, tip_width=0.5)
    old = SheetProblem(s0, sheet_mesh(s0, 0.2, half=True)).with_length(1.3)
    new = SheetProblem(s0.replace(length=1.3), sheet_mesh(s0.replace(length=1.3), 0.2, half=True))

    def field(p):
        X = p.nodes
        w = np.zeros(p.ndof)
        w[: p.nu_dof] = np.stack([X[:, 0] * X[:, 1], X[:, 0] ** 2 - X[:, 2], X[:, 1] ** 2], 1).ravel()
        V = p.sheet_mesh.mesh.p.T * [p.length / p.sheet_mesh.length, 1, 1]
        w[p.nu_dof:] = 3 * V[:, 0] - V[:, 2]
        return w

    np.testing.assert_allclose(transfer(old, field(old), new), field(new), atol=1e-9)


def test_unloaded_sheet_is_stable():
    p = SheetProblem(Sheet(length=0.6), sheet_mesh(Sheet(length=0.6), 0.2, half=True))
    solver = make_linear_solver("auto")
    solver.factorize(p.tangent(np.zeros(p.ndof)))
    stable, k = stability(p, solver)
    if stable is None:
        pytest.skip("this linear solver does not report the inertia")
    assert stable and k == 0


@pytest.fixture(scope="module")
def coarse_rectangle():
    # coarse mesh: the folds move with hmax (at 0.1: L0* = 1.205, L1* = 1.347)
    return fold_lengths(1.0, 2.5, lengths=(1.0, 1.7), hmax=0.2, step=0.15)


def test_rectangle_is_bistable_and_folds_are_bracketed(coarse_rectangle):
    r = coarse_rectangle
    assert r.bistable and r.popup_length < r.standout_length
    for b, fold in ((r.increasing, r.standout_length), (r.decreasing, r.popup_length)):
        lo, hi = b.bracket
        assert abs(hi - lo) <= 2 * r.tol + 1e-12 and min(lo, hi) < fold < max(lo, hi)
        assert all(p.stable is not False for p in b.points)
    # the aloft branch stays up, the drooped one stays down
    assert r.increasing.deflections.max() < 0.2 < r.decreasing.deflections.min()


def test_s_curve_passes_both_folds_with_an_unstable_middle(coarse_rectangle, rectangle_s_curve):
    r = coarse_rectangle
    # the S-curve from L/a 1.2 to 1.45 on the same mesh size (hmax 0.2), shared with
    # test_series (conftest.py); it spans both bisected folds (1.215 and 1.368 at
    # hmax 0.2), as the run from popup - 0.1 to standout + 0.1 did
    sc, _ = rectangle_s_curve
    assert sc.points[0].length < r.popup_length and sc.points[-1].length > r.standout_length
    assert sc.converged
    assert len(sc.folds) == 2
    L1, L0 = sc.folds
    assert L1 == pytest.approx(r.standout_length, abs=0.01)
    assert L0 == pytest.approx(r.popup_length, abs=0.01)
    # the ends are stable; the middle branch (between the folds in arclength
    # order) is unstable, and only it
    stable = [p.stable for p in sc.points]
    if stable[0] is None:
        pytest.skip("this linear solver does not report the inertia")
    assert stable[0] and stable[-1]
    i1 = int(np.argmax([p.stable is False for p in sc.points]))  # first unstable point
    unstable = [p for p in sc.points if p.stable is False]
    assert unstable, "no unstable point on the S-curve"
    assert all(L0 - 0.01 <= p.length <= L1 + 0.01 for p in unstable)
    # unstable points are contiguous: one middle branch
    flags = np.array([p.stable is False for p in sc.points])
    assert flags[i1:i1 + len(unstable)].all()
    # the deflection increases monotonically along the S (no jumps)
    assert np.all(np.diff(sc.deflections) > 0)


@pytest.mark.parametrize("argv, name", [
    (["bistability", "--lengths", "2:1"], "lengths"),
    (["bistability", "--lengths", "x"], "lengths"),
    (["bistability", "--tip-width", "2"], "tip_width"),
    (["bistability", "--hmax", "-1"], "hmax"),
    (["bistability", "--tol", "0.5"], "tol"),
])
def test_bad_cli_input_is_one_line(argv, name, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and name in err


def test_curvature_continuation_brackets_both_critical_curvatures():
    from skfem_sheet.bistability import follow_curvature

    # rectangle, L/a = 1.3 (bistable at a/R = 2.5): the drooped state pops up
    # above a/R0*, the aloft one falls below a/R1*, with a/R1* < 2.5 < a/R0*
    up = follow_curvature(Sheet(length=1.3, curvature=1.0), 5.0, path="gravity-first",
                          hmax=0.2, step=0.5)
    down = follow_curvature(Sheet(length=1.3, curvature=5.0), 1.0, path="curvature-first",
                            hmax=0.2, step=0.5)
    assert up.fold is not None and down.fold is not None
    assert down.fold < 2.5 < up.fold
    assert abs(up.bracket[1] - up.bracket[0]) <= 0.01 + 1e-12
    assert np.all(np.diff(up.deflections) < 0)  # curvature lifts the drooped sheet
