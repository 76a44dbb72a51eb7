import numpy as np
import pytest

from skfem_sheet import Sheet
from skfem_sheet.bistability import fold_lengths, locate_on_mesh, stability, transfer
from skfem_sheet.cli import main
from skfem_sheet.foldcurve.options import MESH_LENGTH_GRID
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
    # coarse mesh: the folds move with hmax (at 0.1: L0* = 1.207, L1* = 1.349)
    return fold_lengths(Sheet(length=1.3, curvature=2.5), hmax=0.2, lengths=(1.0, 1.7),
                        step=0.15, keep_states=True)


def test_rectangle_is_bistable_and_its_folds_are_located(coarse_rectangle):
    r = coarse_rectangle
    assert r.bistable and r.popup_length < r.standout_length and r.in_window
    # one eigenvalue crosses zero at each fold: the aloft branch stable below
    # L1* (0 negative eigenvalues) and the middle branch beyond (1); the drooped
    # one stable above L0*
    assert r.standout.crossing == (0, 1) and r.popup.crossing == (1, 0)
    assert r.standout.confirmed and r.popup.confirmed
    for fold in (r.standout, r.popup):
        # located on a mesh made next to it, on the fold curves' grid of lengths
        assert abs(fold.mesh_length - fold.length) <= MESH_LENGTH_GRID + 1e-9
        assert abs(fold.mesh_length / MESH_LENGTH_GRID - round(fold.mesh_length
                                                               / MESH_LENGTH_GRID)) < 1e-9
    # each branch ends at its fold, located on the results' mesh (its points are the
    # trace's, on meshes made elsewhere: the fold moves by their difference, about
    # 0.02 a at hmax 0.2)
    for b, fold in ((r.increasing, r.standout), (r.decreasing, r.popup)):
        assert b.fold == fold.length and b.fold_deflection == fold.deflection
        lo, hi = sorted(b.bracket)
        assert lo - 0.05 <= b.fold <= hi + 0.05
        assert all(p.stable is not False for p in b.points)
    assert r.increasing.lengths.max() < r.standout.length + 0.02
    assert r.decreasing.lengths.min() > r.popup.length - 0.02
    # the aloft branch stays up, the drooped one stays down; the folds in between
    assert r.increasing.deflections.max() < 0.2 < r.decreasing.deflections.min()
    assert r.standout.deflection < r.popup.deflection
    assert r.position.where == "between" and r.position.states == 2


def test_a_branch_ends_at_the_fold_located_within_its_failed_step():
    """follow_length: the step past the standout fold fails, and the fold is
    located along the branch from the last equilibrium, inside that step; one
    eigenvalue crosses zero there."""
    from skfem_sheet.bistability import follow_length
    from skfem_sheet.engine.fold import inertia_crossing

    b = follow_length(Sheet(length=1.2, curvature=2.5), 1.6, hmax=0.2, step=0.1)
    assert b.fold is not None and b.fold_point is not None
    last, tried = b.bracket
    assert last == b.lengths.max() and last < b.fold <= tried + (tried - last)
    f = b.fold_point
    assert f.side == -1     # the branch lies below its end: a standout fold
    n_minus, n_plus = inertia_crossing(b.problem, f.u, f.p, f.v, 1e-4)
    assert abs(n_plus - n_minus) == 1


def test_s_curve_and_fold_lengths_locate_the_same_folds_on_one_mesh(coarse_rectangle,
                                                                     rectangle_s_curve):
    """The S-curve (pseudo-arclength through both folds, one mesh made at
    sqrt(1.2 x 1.45)) and fold_lengths (natural continuation both ways, each
    end followed along its branch) locate the same two folds when they are
    located on the same mesh: to the fold tolerance, not the bisection's
    +-0.005 of before."""
    r = coarse_rectangle
    sc, _ = rectangle_s_curve
    assert sc.points[0].length < r.popup_length and sc.points[-1].length > r.standout_length
    assert sc.converged and len(sc.folds) == 2 and all(sc.located)
    L1, L0 = sc.folds
    mid = float(np.sqrt(1.2 * 1.45))
    for kind, fold, ref in (("standout", r.standout, L1), ("popup", r.popup, L0)):
        again, _, why = locate_on_mesh(r.sheet, fold.point, fold.problem, kind, 0.2,
                                       mesh_length=mid)
        assert again is not None, why
        assert again.length == pytest.approx(ref, abs=1e-5)
        # and on another mesh of the same size, the fold moves by that mesh's own
        # discretisation (about 0.02 a at hmax 0.2), far more than the location's error
        assert abs(fold.length - ref) < 0.05
    # the ends are stable; the middle branch (between the folds in arclength
    # order) is unstable, and only it
    stable = [p.stable for p in sc.points]
    if stable[0] is None:
        pytest.skip("this linear solver does not report the inertia")
    assert stable[0] and stable[-1]
    i1 = int(np.argmax([p.stable is False for p in sc.points]))  # first unstable point
    unstable = [p for p in sc.points if p.stable is False]
    assert unstable, "no unstable point on the S-curve"
    assert all(L0 - 1e-6 <= p.length <= L1 + 1e-6 for p in unstable)
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
    (["bistability", "--min-step", "2"], "min_step"),
    (["bistability", "--length", "1.3", "--lengths", "1.5:2"], "lengths"),
])
def test_bad_cli_input_is_one_line(argv, name, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and name in err


def test_curvature_continuation_locates_both_critical_curvatures():
    from skfem_sheet.bistability import follow_curvature
    from skfem_sheet.engine.fold import inertia_crossing

    # rectangle, L/a = 1.3 (bistable at a/R = 2.5): the drooped state pops up
    # above a/R0*, the aloft one falls below a/R1*, with a/R1* < 2.5 < a/R0*
    up = follow_curvature(Sheet(length=1.3, curvature=1.0), 5.0, path="gravity-first",
                          hmax=0.2, step=0.5)
    down = follow_curvature(Sheet(length=1.3, curvature=5.0), 1.0, path="curvature-first",
                            hmax=0.2, step=0.5)
    assert up.fold is not None and down.fold is not None
    assert down.fold < 2.5 < up.fold
    for b in (up, down):
        # a fold of the curvature: one eigenvalue crosses zero along its null vector
        f = b.fold_point
        n_minus, n_plus = inertia_crossing(b.problem, f.u, f.p, f.v, 1e-4)
        assert abs(n_plus - n_minus) == 1
        assert min(b.bracket) - 1e-9 <= b.fold <= max(b.bracket) + abs(b.bracket[1]
                                                                      - b.bracket[0])
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
    """fold_lengths(coarse_hmax=..., branches=True): the branches traced on the
    coarse mesh first, their folds located again on the fine mesh, the fine
    branches started from the coarse mesh, each fine step predicted with the
    coarse branch's second-order part and followed up to the located fold:
    the same equilibria (Newton's tolerance) and the same folds as on the fine
    mesh alone (to the difference of the meshes each was located on, two
    meshes made a grid step apart: about 1e-4 at hmax 0.1), in fewer fine
    linearisations; a branch without folds at all is traced once (the
    gravity-first start checked to be the curvature-first end)."""
    sheet = Sheet(length=lengths[0], tip_width=tip_width, curvature=2.5)
    kw = dict(lengths=lengths, hmax=0.1, step=0.05 if bistable else 0.15, branches=True)
    fine = fold_lengths(sheet, coarse_hmax=0, **kw)
    c2f = fold_lengths(sheet, coarse_hmax=0.2, **kw)
    assert c2f.coarse_hmax == 0.2 and c2f.trace_factorizations > 0
    assert fine.coarse_hmax is None and fine.branch_hmax == c2f.branch_hmax == 0.1
    summary = c2f.summary()
    assert summary["trace_hmax"] == 0.2 and summary["one_branch"] == (not bistable)
    assert c2f.bistable == fine.bistable == bistable
    for name in ("popup_length", "standout_length"):
        a, b = getattr(fine, name), getattr(c2f, name)
        assert np.isnan(a) == np.isnan(b)
        if not np.isnan(a):
            assert abs(a - b) <= 2e-3
    up_f, up_c = _common_lengths(fine.increasing, c2f.increasing)
    assert len(up_f) >= 3
    np.testing.assert_allclose(up_c, up_f, atol=1e-5)
    assert c2f.factorizations < fine.factorizations
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
    sheet = Sheet(length=0.8, tip_width=0.0, curvature=2.5)
    once = fold_lengths(sheet, **kw)
    lengths = []
    twice = fold_lengths(sheet, on_point=(None, lambda P, w, L: lengths.append(L)), **kw)
    assert not once.bistable and once.decreasing is once.increasing
    assert twice.decreasing is not twice.increasing and twice.decreasing.fold is None
    assert len(lengths) == len(twice.decreasing.lengths) >= 4
    a, b = _common_lengths(twice.decreasing, once.increasing)
    assert len(a) >= 3 and np.abs(a - b).max() < 0.01
    assert (once.increasing.newton_iterations
            < twice.increasing.newton_iterations + twice.decreasing.newton_iterations)


def test_coarse_hmax_must_be_coarser():
    with pytest.raises(ParameterError, match="coarse_hmax"):
        fold_lengths(Sheet(length=1.0, curvature=2.5), lengths=(1.0, 1.2), hmax=0.2,
                     coarse_hmax=0.1)


def test_the_old_call_warns_and_gives_the_sheets_answer():
    """fold_lengths(tip_width, curvature, thickness=, modulus=) works one release
    more, with a DeprecationWarning, and answers for the material it was given
    (a planform's family at another modulus has other folds)."""
    sheet = Sheet(length=1.0, tip_width=0.0, curvature=2.5, modulus=400.0)
    new = fold_lengths(sheet, lengths=(1.0, 1.2), hmax=0.2, step=0.2)
    with pytest.warns(DeprecationWarning, match="pass the Sheet"):
        old = fold_lengths(0.0, 2.5, modulus=400.0, lengths=(1.0, 1.2), hmax=0.2, step=0.2)
    assert old.sheet == sheet and old.increasing.deflections.tolist() == \
        new.increasing.deflections.tolist()
