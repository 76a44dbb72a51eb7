import numpy as np
import pytest

from skfem_sheet import Sheet
from skfem_sheet.bistability import fold_lengths, stability, transfer
from skfem_sheet.cli import main
from skfem_sheet.linalg import make_linear_solver
from skfem_sheet.mesh import sheet_mesh
from skfem_sheet.params import ParameterError
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


def _common_lengths(a, b, atol=1e-9):
    """Deflections of branches ``a`` and ``b`` at the lengths both visited."""
    da, db = [], []
    for L, d in zip(a.lengths, a.deflections):
        k = np.flatnonzero(np.abs(b.lengths - L) <= atol)
        if k.size:
            da.append(d)
            db.append(b.deflections[k[0]])
    return np.array(da), np.array(db)


@pytest.mark.parametrize("tip_width, lengths, bistable", [(1.0, (1.15, 1.45), True),
                                                         (0.0, (0.8, 1.4), False)])
def test_coarse_to_fine_rows_agree_with_the_fine_mesh_alone(tip_width, lengths, bistable):
    """fold_lengths(coarse_hmax=...): the branches traced on the coarse mesh
    first, the fine starts reached from it and each fine step predicted with
    the coarse branch's second-order part: the same equilibria (Newton's
    tolerance), the same folds to the bisection's resolution, in fewer fine
    linearisations; a branch without folds at all is traced once (the
    gravity-first start checked to be the curvature-first end)."""
    kw = dict(lengths=lengths, hmax=0.1, step=0.1 if bistable else 0.15)
    fine = fold_lengths(tip_width, 2.5, **kw)
    c2f = fold_lengths(tip_width, 2.5, coarse_hmax=0.2, **kw)
    assert c2f.coarse_hmax == 0.2 and c2f.coarse_newton_iterations > 0
    summary = c2f.summary()
    assert summary["coarse_hmax"] == 0.2 and summary["one_branch"] == (not bistable)
    assert c2f.bistable == fine.bistable == bistable
    for name in ("popup_length", "standout_length"):
        a, b = getattr(fine, name), getattr(c2f, name)
        assert (a is None) == (b is None)
        if a is not None:
            assert abs(a - b) <= 2 * fine.tol + 1e-12
    up_f, up_c = _common_lengths(fine.increasing, c2f.increasing)
    assert len(up_f) >= 3
    np.testing.assert_allclose(up_c, up_f, atol=1e-5)
    def work(r):
        return r.increasing.newton_iterations + (
            0 if r.decreasing is r.increasing else r.decreasing.newton_iterations)
    assert work(c2f) < work(fine)
    if bistable:
        down_f, down_c = _common_lengths(fine.decreasing, c2f.decreasing)
        assert len(down_f) >= 3
        np.testing.assert_allclose(down_c, down_f, atol=1e-5)
    else:
        # one branch, traced once, coarse to fine and on the fine mesh alone
        assert c2f.decreasing is c2f.increasing and fine.decreasing is fine.increasing


def test_a_row_without_a_fold_is_one_branch_traced_back():
    """On one mesh too, a curvature-dominated branch that reaches the longest
    length without a fold is the gravity-dominated one: traced from the
    gravity-first start there (its states asked for by ``on_point``), it gives
    the same deflections up to the difference of the meshes the two
    continuations remesh onto (far less than 0.01); not asked for, it is not
    traced (``decreasing is increasing``), for the start and the check only."""
    kw = dict(lengths=(0.8, 1.4), hmax=0.15, step=0.15)
    once = fold_lengths(0.0, 2.5, **kw)
    lengths = []
    twice = fold_lengths(0.0, 2.5, on_point=(None, lambda P, w, L: lengths.append(L)), **kw)
    assert not once.bistable and once.decreasing is once.increasing
    assert twice.decreasing is not twice.increasing and twice.decreasing.fold is None
    assert len(lengths) == len(twice.decreasing.lengths) >= 4
    a, b = _common_lengths(twice.decreasing, once.increasing)
    assert len(a) >= 3 and np.abs(a - b).max() < 0.01
    assert (once.increasing.newton_iterations
            < twice.increasing.newton_iterations + twice.decreasing.newton_iterations)


def test_coarse_hmax_must_be_coarser():
    with pytest.raises(ParameterError, match="coarse_hmax"):
        fold_lengths(1.0, 2.5, lengths=(1.0, 1.2), hmax=0.2, coarse_hmax=0.1)
