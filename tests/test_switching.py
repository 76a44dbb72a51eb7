"""Switching forces and energy barriers of a bistable sheet (issue 58).

On the paper's rectangle (L/a 1.3, a/R 2.5) on a coarse mesh (hmax 0.2, where it is
bistable), what is checked against the mathematics: the curve in the tip force is one
S (inertia 0, 1, 0 between its folds, the tip stiffness positive on the stable
branches and negative on the unstable one); the work identity Pi(saddle) - Pi(aloft) =
int F dw_tip; the saddle is the S-curve's unstable middle state at the same length; the
drooped end of the curve is the gravity-first solve's state; a force-controlled solve
1% below the switching force stays, 1% above it snaps at the located fold.  The
acceptance numbers (hmax 0.1, 0.05, 0.03, the scaling near the folds) are recorded by
``benchmarks/switching.py``.
"""
import json
import math

import numpy as np
import pytest

from skfem_sheet import Sheet, solve
from skfem_sheet.analyses.observables import tip_deflection
from skfem_sheet.linalg import make_linear_solver
from skfem_sheet.newton import NewtonOptions, Stats, newton, polish
from skfem_sheet.params import ParameterError
from skfem_sheet.switch import (
    CurvePoint,
    ForceCurve,
    SIScale,
    apply_tip_force,
    force_curve,
    switching,
)

SHEET = Sheet(length=1.3, curvature=2.5)
HMAX = 0.2


@pytest.fixture(scope="module")
def sw():
    return switching(SHEET, hmax=HMAX)


@pytest.fixture(scope="module")
def drooped():
    return solve(SHEET, "gravity-first", hmax=HMAX)


def test_the_rectangle_is_bistable_with_one_s(sw):
    assert sw.bistable and sw.shape == "one S" and not sw.notes
    assert sw.force_down < 0 < sw.force_up
    assert sw.barrier_down > 0 and sw.barrier_up > 0
    assert sw.saddle_negative_eigenvalues == 1
    # along the curve, top to bottom: aloft, its fold, the saddle, the other fold, drooped
    assert (sw.aloft_deflection < sw.fold_down_deflection < sw.saddle_deflection
            < sw.fold_up_deflection < sw.drooped_deflection)
    assert sw.curve.hmax == HMAX  # hmax 0.2 >= 0.1: traced on the mesh of the answer


def test_inertia_and_stiffness_along_the_curve(sw):
    pts = sw.curve.points
    folds = [i for i, p in enumerate(pts) if p.kind == "fold"]
    assert len(folds) == 2 and [p.kind for p in pts].count("saddle") == 1
    for i, p in enumerate(pts):
        if p.kind == "fold":
            assert p.stiffness == 0
            continue
        unstable = folds[0] < i < folds[1]
        assert p.negative_eigenvalues == (1 if unstable else 0)
        # dF/dw_tip: positive on the stable branches, negative on the unstable one
        assert (p.stiffness < 0) == unstable
    # the folds are the extremes of F
    assert sw.force_down == pytest.approx(sw.curve.forces.min(), abs=0)
    assert sw.force_up == pytest.approx(sw.curve.forces.max(), abs=0)


def test_work_identity(sw):
    """Pi(saddle) - Pi(aloft) = int F dw_tip from the aloft state to the saddle
    (and from the drooped state): measured to 2e-5 at hmax 0.1."""
    assert sw.curve_barrier_down == sw.barrier_down  # one mesh
    assert sw.work_down == pytest.approx(sw.barrier_down, rel=1e-3)
    assert sw.work_up == pytest.approx(sw.barrier_up, rel=1e-3)


def test_the_curve_ends_on_the_gravity_first_state(sw, drooped):
    assert drooped.converged and drooped.stable
    assert sw.drooped_deflection == pytest.approx(drooped.deflection, abs=1e-6)
    assert sw.drooped_energy == pytest.approx(drooped.energy, rel=1e-9)


def _equilibrium(problem, w):
    """``w`` solved at L = problem's length (the sheet's Newton, polished)."""
    solver, stats = make_linear_solver(), Stats()
    res = newton(problem, w, 1.0, solver, NewtonOptions(), stats)
    assert res.converged
    w, _ = polish(problem, res.w, 1.0, solver, stats, utol=1e-10, max_iterations=4)
    return w


def _bracket(frames, length, stable):
    """The state interpolated at ``length`` between two consecutive frames of
    the S-curve on the branch of that stability."""
    for a, b in zip(frames[:-1], frames[1:]):
        if (a.stable, b.stable) == (stable, stable) and (a.time - length) * (b.time - length) <= 0:
            t = (length - a.time) / (b.time - a.time)
            return a.w + t * (b.w - a.w), a.problem
    raise AssertionError(f"no {'stable' if stable else 'unstable'} pair around {length}")


def test_the_saddle_is_the_s_curves_unstable_middle_state(rectangle_s_curve):
    """On the S-curve's own mesh, stretched to L/a 1.3: the saddle of the curve in F
    (from the aloft state) and the unstable middle state of the curve in L are
    one equilibrium (d to 1e-6, one negative eigenvalue each)."""
    sc, series = rectangle_s_curve

    class Frame:
        def __init__(self, f, pt):
            self.time, self.w, self.problem, self.stable = f.time, f.w, f.problem, pt.stable

    frames = [Frame(f, pt) for f, pt in zip(series.frames, sc.points)]
    w_mid, prob = _bracket(frames, 1.3, False)
    w_aloft, _ = _bracket(frames[:len(frames) // 2], 1.3, True)
    prob = prob.with_length(1.3)
    middle = _equilibrium(prob, w_mid)
    curve = force_curve(prob, _equilibrium(prob, w_aloft), 2.5)
    saddle = curve.point("saddle")
    assert curve.shape == "one S" and saddle.negative_eigenvalues == 1
    d_middle = tip_deflection(prob, middle)
    assert saddle.deflection == pytest.approx(d_middle, abs=1e-6)
    assert np.abs(curve.states["saddle"] - middle)[:prob.nu_dof].max() < 1e-5


def test_force_controlled_solve_either_side_of_the_switching_force(sw, drooped):
    aloft = solve(SHEET, hmax=HMAX)
    below = apply_tip_force(aloft, 0.99 * sw.force_down)
    assert below.converged and not below.snapped and below.stable
    assert aloft.deflection < below.deflection < sw.fold_down_deflection  # still aloft
    above = apply_tip_force(aloft, 1.01 * sw.force_down)
    assert above.converged and len(above.snaps) == 1 and above.stable
    snap = above.snaps[0]
    assert snap.phase == "tip force"
    assert snap.load == pytest.approx(sw.force_down, rel=1e-6)  # at the located fold
    assert above.deflection > sw.fold_up_deflection  # landed drooped
    # and the drooped state pulled up
    below = apply_tip_force(drooped, 0.99 * sw.force_up)
    assert below.converged and not below.snapped
    assert below.deflection > sw.fold_up_deflection
    above = apply_tip_force(drooped, 1.01 * sw.force_up)
    assert above.converged and len(above.snaps) == 1
    assert above.snaps[0].load == pytest.approx(sw.force_up, rel=1e-6)
    assert above.deflection < sw.fold_down_deflection  # landed aloft


def test_a_sheet_that_is_not_bistable_gets_one_state():
    """Far below the pop-up length (L/a 0.6, a/R 1): one state, aloft."""
    s = switching(Sheet(length=0.6, curvature=1.0), hmax=0.25, max_force=0.3)
    assert s.bistable is False
    assert s.states.startswith("one state at F = 0: curvature-dominated (aloft)")
    assert math.isnan(s.barrier_down) and math.isnan(s.barrier_up)
    assert math.isnan(s.force_up) and math.isnan(s.saddle_deflection)
    assert s.curve.point("saddle") is None
    summary = json.loads(s.to_json())
    assert summary["bistable"] is False and summary["barrier_down"] is None
    assert "one state" in repr(s)


def test_summary_si_and_repr(sw):
    out = sw.summary()
    for key in ("force_down", "force_up", "barrier_down", "barrier_up", "saddle_deflection",
                "bistable", "fold_down_deflection", "fold_up_deflection", "curve", "weight"):
        assert key in out
    assert out["force_down"] == sw.force_down and out["bistable"] is True
    assert len(out["curve"]["force"]) == len(sw.curve.points)
    si = sw.with_si(SIScale(0.05, 1250.0)).in_si()
    assert si["force_down_N"] == pytest.approx(sw.force_down * 1250 * 9.81 * 0.05**3, rel=1e-12)
    assert si["barrier_up_J"] == pytest.approx(sw.barrier_up * 1250 * 9.81 * 0.05**4, rel=1e-12)
    text = str(sw.with_si(SIScale(0.05, 1250.0)))
    assert "mN" in text and "microjoules" in text
    assert len(repr(sw)) < 300 and "bistable" in repr(sw)
    with pytest.raises(ParameterError, match="SI scales"):
        sw.in_si()


def test_bad_input():
    with pytest.raises(ParameterError, match="sheet must be"):
        switching("sheet")
    with pytest.raises(ParameterError, match="tip face"):
        switching(Sheet(length=1.0, tip_width=0.0, curvature=2.0), hmax=0.25)
    with pytest.raises(ParameterError, match="max_force"):
        switching(SHEET, hmax=0.25, max_force=-1)
    with pytest.raises(ParameterError, match="curve_hmax"):
        switching(SHEET, hmax=0.2, curve_hmax=0.1)
    with pytest.raises(ParameterError, match="result must be"):
        apply_tip_force("r", 0.01)


def test_work_of_hermite_cubics_is_exact_for_a_cubic():
    """The work along the curve: Hermite cubics in w_tip, exact where F(w) is cubic."""
    w = np.linspace(0.0, -0.3, 4)
    F = w**3 - 0.2 * w
    k = 3 * w**2 - 0.2
    kinds = ["start", "point", "point", "saddle"]
    pts = tuple(CurvePoint(f, x, 0.0, 0.0, s, 0, kind) for f, x, s, kind in zip(F, w, k, kinds))
    c = ForceCurve(pts, 0.1, -1, True, "", "one S")
    exact = (w[-1]**4 / 4 - 0.1 * w[-1]**2) - 0.0
    assert c.work("start", "saddle") == pytest.approx(exact, rel=1e-12)
    assert c.work("saddle", "start") == pytest.approx(-exact, rel=1e-12)


def test_the_benchmarks_fit_recovers_the_normal_form():
    """benchmarks/switching.py's scaling fit on exact normal-form data plus the next
    order: exponents near 1 and 3/2, the zeros of F and barrier^(2/3) at the fold."""
    import importlib.util
    import os

    path = os.path.join(os.path.dirname(__file__), os.pardir, "benchmarks", "switching.py")
    spec = importlib.util.spec_from_file_location("bench_switching", path)
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    L_fold = 1.3494
    L = L_fold - np.array(bench.DELTAS[:5])
    d = L_fold - L
    F = -0.03 * d * (1 + 0.3 * d)
    B = 0.01 * d**1.5 * (1 + 0.4 * d)
    fs, local, fz = bench._fit(L, F, L_fold, 1.0)
    bs, _, bz = bench._fit(L, B, L_fold, 1.5)
    assert fs == pytest.approx(1.0, abs=0.01) and bs == pytest.approx(1.5, abs=0.01)
    assert local[0] == pytest.approx(1.0, abs=1e-3)   # the next order fades near the fold
    assert fz == pytest.approx(L_fold, abs=1e-6) and bz == pytest.approx(L_fold, abs=1e-5)


def test_the_switch_command_writes_the_interfaces_keys(tmp_path, capsys):
    """The paper's silicone sheet given in SI on the command line (one analysis on hmax
    0.25): the interface's keys, the SI values beside them, the curve as CSV."""
    from skfem_sheet.cli import main

    out, curve = tmp_path / "s.json", tmp_path / "c.csv"
    si = ("base_width=0.05,length=0.065,tip_width=0.05,thickness=1.5875e-3,radius=0.02,"
          "youngs_modulus=4.5e5,density=1250")
    assert main(["switch", "--si", si, "--hmax", "0.25", "--json", str(out), "--curve",
                 str(curve), "--quiet"]) == 0
    text = capsys.readouterr().out
    assert "two states at F = 0 (bistable)" in text and " mN" in text
    data = json.loads(out.read_text())
    assert data["bistable"] is True and data["force_down"] < 0 < data["force_up"]
    for key in ("barrier_down", "barrier_up", "saddle_deflection", "fold_down_deflection",
                "fold_up_deflection", "weight", "shape", "curve"):
        assert key in data
    unit = 1250 * 9.81 * 0.05**3  # rho g a^3 in newtons
    assert data["si"]["force_down_N"] == pytest.approx(data["force_down"] * unit, rel=1e-12)
    assert data["si"]["barrier_up_J"] == pytest.approx(data["barrier_up"] * unit * 0.05,
                                                       rel=1e-12)
    rows = curve.read_text().splitlines()
    assert rows[0].startswith("force,tip_displacement,deflection") and len(rows) > 20
    # bad input: one line naming the problem, exit code 2
    assert main(["switch", "--length", "1", "--tip-width", "0", "--curvature", "2",
                 "--hmax", "0.25", "--quiet"]) == 2
    assert "tip face" in capsys.readouterr().err


@pytest.mark.slow
def test_the_whole_sheet_has_the_same_s_and_no_asymmetric_branch_point():
    """The mirror symmetry y -> -y: the whole sheet (asymmetric states admitted) has
    the half model's S to round-off (measured 3e-15 in the forces, 2e-13 in the
    barriers on hmax 0.25), and no eigenvalue of an asymmetric mode turns negative
    along it: no twisting branch point, one S (a minute and a half)."""
    half = switching(SHEET, hmax=0.25)
    whole = switching(SHEET, hmax=0.25, symmetric=False)
    assert whole.shape == "one S" and not whole.notes
    for key in ("force_down", "force_up", "barrier_down", "barrier_up", "saddle_deflection"):
        assert getattr(whole, key) == pytest.approx(getattr(half, key), rel=1e-8), key
    assert whole.saddle_negative_eigenvalues == 1
