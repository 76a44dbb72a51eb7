"""Sensitivities of a solved sheet, of a located fold, and the calibration on them.

Every derivative is checked against central finite differences of solves of
the perturbed discrete problem (Newton from the state, polished to 1e-13 a),
on coarse meshes (hmax 0.2-0.25), or against an exact identity of the model:
the deflection depends on the modulus and the load factor only through their
ratio (divide the energy by the load factor), so ``g dq/dg + E dq/dE = 0``
for the deflection and the tip angle, ``= Pi`` for the energy, and a fold
length obeys the same identity.
"""
import json
import math

import numpy as np
import pytest

from skfem_sheet import Sheet, solve
from skfem_sheet.analyses import sensitivity as S
from skfem_sheet.analyses.observables import tip_deflection
from skfem_sheet.calibration import (
    FOLD_TOLERANCES,
    CalibrationError,
    Measurement,
    calibrate,
    fold_point_sensitivities,
    read_measurements,
)
from skfem_sheet.cli import main
from skfem_sheet.engine import FoldCurvePoint, locate_fold, natural
from skfem_sheet.foldcurve import TOLERANCES, SheetFoldProblem
from skfem_sheet.linalg import make_linear_solver
from skfem_sheet.newton import NewtonOptions, Stats, newton, polish
from skfem_sheet.params import ParameterError, Planform

HMAX = 0.2
#: A bistable rectangle at hmax 0.2 (curvature-first: d 0.046, gravity-first: 0.499).
BISTABLE = Sheet(length=1.3, curvature=2.5)


def _fd_outputs(result, name, rel):
    """Central difference of the three outputs in ``name``: the perturbed problems
    (as the sensitivities see them) solved by Newton from the result's state."""
    problem, g0 = result.problem, result.gravity
    value = {"gravity": g0, "length": problem.length,
             "tip_width": problem.sheet_mesh.tip_width,
             "thickness": problem.sheet_mesh.thickness}.get(name)
    if value is None:
        value = getattr(problem.sheet, name)
    step = rel * abs(value) if value else rel
    out = []
    for s in (-1.0, 1.0):
        P, g, kappa = S.perturbed(problem, g0, name, value + s * step)
        w0 = result.w.copy()
        w0[P.clamp_dofs] = P.clamp_values(kappa)
        linear, stats = make_linear_solver(), Stats()
        res = newton(P, w0, g, linear, NewtonOptions(), stats)
        assert res.converged, res.reason
        w, _ = polish(P, res.w, g, linear, stats, utol=1e-13, max_iterations=10)
        out.append(np.array([tip_deflection(P, w), P.energy(w, g), S.tip_angle(P, w)]))
    return (out[1] - out[0]) / (2 * step)


@pytest.fixture(scope="module")
def branches():
    """Both branches of the bistable rectangle, with every sensitivity."""
    return {path: solve(BISTABLE, path=path, hmax=HMAX, sensitivities=S.PARAMETERS)
            for path in ("curvature-first", "gravity-first")}


@pytest.mark.parametrize("path", ["curvature-first", "gravity-first"])
@pytest.mark.parametrize("name", S.PARAMETERS)
def test_state_sensitivities_match_finite_differences_on_both_branches(branches, path, name):
    r = branches[path]
    assert r.branch == ("curvature-dominated" if path == "curvature-first"
                        else "gravity-dominated")
    # relative step 1e-4: the central difference's own error is about 1e-8 of
    # the derivative here (it falls 100x from the step 1e-3, measured), so the
    # 1e-4 bound is the sensitivity's error, with margin
    fd = _fd_outputs(r, name, 1e-4)
    got = np.array([r.sensitivities.of(out)[name] for out in S.OUTPUTS])
    assert np.all(np.abs(got - fd) <= 1e-4 * np.abs(fd) + 1e-12), (got, fd)


def test_the_solve_uses_its_own_factorisation(branches):
    r = branches["gravity-first"]
    s = r.sensitivities
    assert s.factorizations == 0 and s.tangent_assemblies == 1
    assert s.back_substitutions >= len(S.PARAMETERS) and s.relative_residual < 1e-7
    fresh = S.state_sensitivities(r.problem, r.w, r.gravity, S.PARAMETERS)
    assert fresh.factorizations == 1
    np.testing.assert_allclose(np.array(fresh.values), np.array(s.values), rtol=1e-7,
                               atol=1e-14)


@pytest.mark.parametrize("gravity", [1.0, 0.6])
def test_modulus_and_gravity_enter_through_their_ratio(gravity):
    r = solve(Sheet(length=0.8, tip_width=0.5, curvature=1.8, modulus=900.0), hmax=HMAX,
              gravity=gravity, sensitivities=("modulus", "gravity"))
    E, s = 900.0, r.sensitivities
    for out in ("deflection", "tip_angle"):
        v = s.of(out)
        assert abs(gravity * v["gravity"] + E * v["modulus"]) < 1e-6 * abs(E * v["modulus"])
    v = s.of("energy")
    assert gravity * v["gravity"] + E * v["modulus"] == pytest.approx(r.energy, rel=1e-6)


def test_without_gravity_the_modulus_does_nothing_and_the_load_a_lot():
    r = solve(Sheet(length=0.8, curvature=1.5), hmax=HMAX, gravity=0.0,
              sensitivities=("modulus", "gravity", "curvature"))
    s = r.sensitivities
    # the clamp alone: the state does not depend on the modulus (exactly, to round-off)
    assert abs(s["modulus"]) < 1e-12 and abs(s.of("tip_angle")["modulus"]) < 1e-12
    fd = _fd_outputs(r, "gravity", 1e-4)
    assert s["gravity"] > 0.01 and s["gravity"] == pytest.approx(fd[0], rel=1e-4)
    assert s["curvature"] == pytest.approx(_fd_outputs(r, "curvature", 1e-4)[0], rel=1e-4)


def test_a_flat_clamp_has_a_curvature_sensitivity():
    # a/R = 0 is the end of the range; the discrete problem extends to a/R < 0
    r = solve(Sheet(length=0.7, tip_width=0.8), hmax=HMAX, sensitivities=("curvature",))
    fd = _fd_outputs(r, "curvature", 1e-4)
    got = np.array([r.sensitivities.of(o)["curvature"] for o in S.OUTPUTS])
    assert np.all(np.abs(got - fd) <= 1e-4 * np.abs(fd) + 1e-12), (got, fd)


def test_the_mapped_mesh_is_the_stretched_one_for_the_length():
    r = solve(Sheet(length=0.9, tip_width=0.6, curvature=1.0), hmax=HMAX)
    a, b = S.mapped_problem(r.problem, length=1.05), r.problem.with_length(1.05)
    ra, rb = a.residual(r.w, 1.0)[0], b.residual(r.w, 1.0)[0]
    assert np.allclose(ra, rb, rtol=0, atol=1e-10 * np.abs(rb).max())
    # and the identity map gives the problem back
    same = S.mapped_problem(r.problem)
    assert np.allclose(same.residual(r.w, 1.0)[0], r.problem.residual(r.w, 1.0)[0],
                       rtol=0, atol=1e-12 * np.abs(rb).max())


def test_bad_requests_name_the_parameter():
    with pytest.raises(ParameterError, match="sensitivities must be names from"):
        solve(Sheet(length=0.5), hmax=0.25, sensitivities=("stiffness",))
    with pytest.raises(ParameterError, match="tip_width > 0"):
        solve(Sheet(length=0.5, tip_width=0.0), hmax=0.25, sensitivities="tip_width")
    planform = Sheet.from_planform(Planform.from_samples([0, 0.5], [1, 0.7]))
    with pytest.raises(ParameterError, match="trapezoid"):
        solve(planform, hmax=0.25, sensitivities="tip_width")
    with pytest.raises(ParameterError, match="outputs must be"):
        r = solve(Sheet(length=0.5), hmax=0.25)
        S.state_sensitivities(r.problem, r.w, 1.0, "modulus", outputs=("height",))


def test_result_json_and_record_carry_the_sensitivities(branches):
    r = branches["curvature-first"]
    summary = json.loads(json.dumps(r.summary()))
    assert summary["sensitivities"] == pytest.approx(r.sensitivities.of("deflection"))
    assert set(summary["sensitivity_report"]["values"]) == set(S.OUTPUTS)
    rec = r.to_record()
    assert json.loads(rec["deflection_sensitivities"]) == pytest.approx(summary["sensitivities"])
    plain = solve(Sheet(length=0.5), hmax=0.25)
    assert plain.sensitivities is None and "sensitivities" not in plain.summary()
    assert plain.to_record()["deflection_sensitivities"] == ""


def test_si_values_follow_from_the_scales(branches):
    s = branches["gravity-first"].sensitivities.with_si(0.05, 1250.0, 9.81)
    si = s.in_si()
    a, rho, g = 0.05, 1250.0, 9.81
    d = si["values"]["deflection"]
    assert d["youngs_modulus"] == pytest.approx(a * s["modulus"] / (rho * g * a), rel=1e-12)
    assert d["inverse_radius"] == pytest.approx(a * a * s["curvature"], rel=1e-12)
    # the acceleration enters through E/(rho g a) too: both routes agree (identity)
    assert d["gravity"] == pytest.approx(a * s["modulus"] * (-735.0 / g), rel=1e-6)
    assert si["units"]["deflection"]["youngs_modulus"] == "m/Pa"


# ------------------------------------------------------------------------------------------
# fold lengths
# ------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def standout():
    """The standout fold of the rectangle at a/R 2.5, hmax 0.25 (L1* about 1.33)."""
    P = SheetFoldProblem(2.5, 0.25, 1.35, 1.0)
    p0 = np.array([1.25, 1.0, 2.5])
    u0, _ = P.solve_state(p0, "curvature-first")
    branch = natural(P, u0, p0, "L", 2.0, step=0.03, min_step=5e-4, max_step=0.05,
                     tol=TOLERANCES, jump=0.1, keep_states=False)
    fold, _ = locate_fold(P, branch.fold.u, branch.fold.p, "L", v0=branch.fold.v,
                          tol=FOLD_TOLERANCES)
    return P, fold


def _relocated(P, fold, index, step):
    vals = []
    for s in (-1.0, 1.0):
        p = np.array(fold.p, dtype=float)
        p[index] += s * step
        g, res = locate_fold(P, fold.u, p, "L", v0=fold.v, tol=FOLD_TOLERANCES)
        assert g is not None, res.reason
        vals.append(g.value)
    return (vals[1] - vals[0]) / (2 * step)


def test_fold_length_sensitivities_match_relocated_folds(standout):
    P, fold = standout
    fs = fold_point_sensitivities(P, fold)
    assert fs.kind == "standout" and fs.parameter == "length"
    assert set(fs.sensitivities) == {"modulus", "thickness", "curvature", "gravity", "tip_width"}
    # the fold located again at b -+ 1e-3 and a/R -+ 2.5e-3 (tolerance of the
    # location 1e-10 in L, of the fold's move about 1e-4)
    assert fs["tip_width"] == pytest.approx(_relocated(P, fold, 1, 1e-3), rel=1e-4)
    assert fs["curvature"] == pytest.approx(_relocated(P, fold, 2, 2.5e-3), rel=1e-4)
    # a stiffer sheet stands out further; a heavier one less: L1*(E, g) = L1*(E/g, 1)
    assert fs["modulus"] > 0 and fs["gravity"] == pytest.approx(-735.0 * fs["modulus"],
                                                                 rel=1e-6)


def test_a_fold_has_no_sensitivity_to_its_own_parameter(standout):
    P, fold = standout
    with pytest.raises(ParameterError, match="own parameter"):
        fold_point_sensitivities(P, fold, ["length"])


def test_a_fold_curve_point_with_its_state_and_null_vector(standout):
    P, fold = standout
    point = FoldCurvePoint(p=fold.p, side=fold.side)       # as a fold curve keeps it
    with pytest.raises(ParameterError, match="null vector"):
        fold_point_sensitivities(P, point)
    a = fold_point_sensitivities(P, point, u=fold.u, v=fold.v)
    assert a.sensitivities == fold_point_sensitivities(P, fold).sensitivities


# ------------------------------------------------------------------------------------------
# calibration
# ------------------------------------------------------------------------------------------
CAL = Sheet(length=0.6, tip_width=0.8, curvature=1.2)
CAL_HMAX = 0.25


@pytest.fixture(scope="module")
def synthetic():
    """Deflections of the sheet at modulus 820 at three lengths."""
    return [(L, solve(CAL.replace(length=L, modulus=820.0), hmax=CAL_HMAX).deflection)
            for L in (0.5, 0.65, 0.8)]


def test_calibration_recovers_the_modulus_of_exact_data(synthetic, capsys):
    fit = calibrate(CAL, synthetic, hmax=CAL_HMAX, progress=True)
    # the bar on stderr counted every solve of the fit
    bar = capsys.readouterr().err
    assert "calibrate" in bar and f"{fit.solves}solve" in bar.replace(" ", "")
    assert fit.converged and fit["modulus"] == pytest.approx(820.0, rel=1e-6)
    assert fit.noise == "residuals" and fit.standard_error("modulus") < 1e-3
    assert fit.solves == 3 * fit.evaluations and fit.evaluations <= 6
    assert max(abs(r) for r in fit.residuals) < 1e-9


def test_calibration_with_noise_brackets_the_truth(synthetic):
    sigma = 0.001
    noise = [0.8, -1.1, 0.4]       # fixed draws: the test is deterministic
    ms = [Measurement(deflection=d + sigma * e, length=L, uncertainty=sigma)
          for (L, d), e in zip(synthetic, noise)]
    fit = calibrate(CAL, ms, hmax=CAL_HMAX)
    se = fit.standard_error("modulus")
    assert fit.noise == "uncertainties" and 0 < se < 100
    assert abs(fit["modulus"] - 820.0) < 3 * se
    # the standard error is that of the linearised model: sigma / |J| for weights 1/sigma
    J = np.array([solve(CAL.replace(length=L, modulus=fit["modulus"]), hmax=CAL_HMAX,
                        sensitivities="modulus").sensitivities["modulus"] for L, _ in synthetic])
    assert se == pytest.approx(sigma / np.linalg.norm(J), rel=1e-6)


def test_calibration_refuses_what_the_data_cannot_determine(synthetic):
    with pytest.raises(CalibrationError, match="only through their ratio"):
        calibrate(CAL, synthetic, free=("modulus", "gravity"), hmax=CAL_HMAX)
    with pytest.raises(CalibrationError, match="need at least 2 measurements"):
        calibrate(CAL, synthetic[:1], free=("modulus", "thickness"), hmax=CAL_HMAX)
    with pytest.raises(CalibrationError, match="do not depend on modulus"):
        calibrate(CAL, synthetic, gravity=0.0, hmax=CAL_HMAX)
    with pytest.raises(ParameterError, match="free must be"):
        calibrate(CAL, synthetic, free=("length",), hmax=CAL_HMAX)


def test_calibration_refuses_a_measurement_across_a_snap():
    # a drooped deflection on the curvature-first path: the fit lowers the
    # modulus until that path snaps to the gravity-dominated branch
    with pytest.raises(CalibrationError, match="lies across a snap"):
        calibrate(BISTABLE, [(1.3, 0.45)], hmax=0.25)


def test_measurements_from_csv(tmp_path):
    f = tmp_path / "m.csv"
    f.write_text("length,deflection,uncertainty\n0.5,0.01,0.001\n0.7,0.03,0.002\n")
    ms = read_measurements(f)
    assert [m.length for m in ms] == [0.5, 0.7] and ms[1].uncertainty == 0.002
    f.write_text("length,height\n0.5,0.01\n")
    with pytest.raises(ParameterError, match="deflection"):
        read_measurements(f)


def test_cli_calibrate_writes_the_modulus_and_the_deflection(synthetic, tmp_path, capsys):
    out = tmp_path / "fit.json"
    (L, d), = synthetic[:1]
    assert main(["calibrate", "--length", str(L), "--tip-width", "0.8", "--curvature", "1.2",
                 "--path", "curvature-first", "--hmax", str(CAL_HMAX), "--deflection", repr(d),
                 "--free", "modulus", "--json", str(out)]) == 0
    fit = json.loads(out.read_text())
    assert fit["modulus"] == pytest.approx(820.0, rel=1e-5)
    assert fit["deflection"] == pytest.approx(d, rel=1e-9)
    assert fit["modulus_standard_error"] is None     # one measurement: an exact fit
    assert main(["calibrate", "--length", "0.5", "--deflection", "0.01", "--deflection",
                 "0.02", "--hmax", "0.25"]) == 2
    assert "pairs" in capsys.readouterr().err


def test_cli_solve_writes_sensitivities(tmp_path, capsys):
    out = tmp_path / "r.json"
    assert main(["solve", "--length", "0.6", "--curvature", "1.0", "--hmax", "0.25", "--quiet",
                 "--sensitivities", "modulus,curvature", "--json", str(out)]) == 0
    s = json.loads(out.read_text())["sensitivities"]
    assert set(s) == {"modulus", "curvature"} and s["modulus"] < 0
    assert "d(d/a)/d(modulus)" in capsys.readouterr().out
    assert main(["solve", "--length", "0.6", "--hmax", "0.25", "--quiet",
                 "--sensitivities", "youngs"]) == 2
    si = tmp_path / "si.json"
    assert main(["solve", "--si", "base_width=0.05,length=0.03,tip_width=0.05,"
                 "thickness=1.5e-3,radius=0.05,youngs_modulus=4.5e5,density=1250", "--hmax",
                 "0.25", "--quiet", "--sensitivities", "modulus", "--json", str(si)]) == 0
    rep = json.loads(si.read_text())["sensitivity_report"]["si"]
    assert rep["units"]["deflection"]["youngs_modulus"] == "m/Pa"
    assert math.isfinite(rep["values"]["deflection"]["youngs_modulus"])
