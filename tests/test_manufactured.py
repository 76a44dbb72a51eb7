"""Manufactured-solution convergence of the package's discretisation (issue 13, item 1).

The package's own residual and tangent (Taylor-Hood P2-P1, gravity, the curved
clamp) are solved with manufactured body force, traction and constraint source
that make a bent-and-twisted exact field the solution (``benchmarks/manufactured.py``);
on three nested meshes the fitted error slopes must be those of P2-P1.
"""
import importlib.util
import json
import os

import numpy as np
import pytest

pytest.importorskip("sympy")

_PATH = os.path.join(os.path.dirname(__file__), os.pardir, "benchmarks", "manufactured.py")
_spec = importlib.util.spec_from_file_location("bench_manufactured", _PATH)
mms = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(mms)

from skfem_sheet import Sheet
from skfem_sheet.kernels import clamp_displacement


@pytest.fixture(scope="module")
def fields():
    s = Sheet(**mms.CASE)
    return mms.manufactured_fields(s.curvature, s.mu)


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    """The benchmark's JSON on base hmax 0.5, refine 0, 1, 2 (654, 4120 and 29100
    unknowns, about 10 s), through its command line."""
    out = tmp_path_factory.mktemp("mms") / "out.json"
    code = mms.main(["--base-hmax", "0.5", "--refinements", "2", "--json", str(out),
                     "--txt", "", "--png", ""])
    doc = json.loads(out.read_text())
    doc["exit_code"] = code
    return doc


def test_exact_field_takes_the_clamp_values(fields):
    rng = np.random.default_rng(3)
    y = rng.uniform(-0.5, 0.5, 20)
    z = rng.uniform(-0.1, 0.1, 20)
    X = np.stack([np.zeros_like(y), y, z])
    U = fields["U"](X)
    np.testing.assert_allclose(U.T, clamp_displacement(y, z, mms.CASE["curvature"]),
                               atol=1e-14)


def test_exact_field_has_large_rotations(fields):
    # the tip cross-section is rotated by k_b L about y and tau L about x
    eps = 1e-6
    X = np.array([[1.0 - eps, 1.0 + eps], [0.0, 0.0], [0.0, 0.0]])
    U = fields["U"](X)
    tangent = (X[:, 1] + U[:, 1] - X[:, 0] - U[:, 0]) / (2 * eps)
    angle = np.degrees(np.arccos(tangent[0] / np.linalg.norm(tangent)))
    assert angle == pytest.approx(np.degrees(mms.FIELD["bend"]), abs=1e-4)
    assert angle > 60


def test_manufactured_data_satisfy_the_equations_pointwise(fields):
    # the body force is - Div P + g e_z: check one component against a central
    # difference of the stress, and the source is J - 1 of the exact gradient
    X = np.array([[0.37], [0.21], [-0.04]])
    h = 1e-5
    div = np.zeros(3)
    for j in range(3):
        e = np.zeros((3, 1))
        e[j] = h
        div += (fields["P"](X + e)[:, j, 0] - fields["P"](X - e)[:, j, 0]) / (2 * h)
    np.testing.assert_allclose(fields["body"](X)[:, 0], -div + [0, 0, mms.GRAVITY],
                               rtol=1e-6, atol=1e-6)
    F = np.eye(3) + fields["gradU"](X)[:, :, 0]
    assert fields["source"](X)[0] == pytest.approx(np.linalg.det(F) - 1, abs=1e-12)
    # and the stress is the package's P = mu F - (mu + p J) F^-T
    mu = Sheet(**mms.CASE).mu
    p = fields["p"](X)[0]
    J = np.linalg.det(F)
    P = mu * F - (mu + p * J) * np.linalg.inv(F).T
    np.testing.assert_allclose(fields["P"](X)[:, :, 0], P, rtol=1e-12, atol=1e-12)


def test_newton_converges_quadratically(study):
    for run in study["meshes"]:
        n = run["residual_norms"]
        assert run["newton_iterations"] <= 6
        assert n[-1] < 1e-8 * n[0]
        assert n[-1] < 1e-2 * n[-2]      # the last step contracts by orders of magnitude


def test_errors_decrease_on_every_refinement(study):
    for key in ("u_l2", "u_h1", "p_l2", "tip"):
        e = [r[key] for r in study["meshes"]]
        assert all(a > b for a, b in zip(e, e[1:])), (key, e)


def test_fitted_rates_are_those_of_taylor_hood(study):
    rates = study["rates"]
    assert rates["u_l2"] >= 2.7
    assert rates["u_h1"] >= 1.8
    assert rates["p_l2"] >= 1.8
    assert rates["tip"] >= 1.8
    # and not implausibly high (P2 displacement cannot beat h^3 in L2 for long)
    assert rates["u_l2"] <= 3.6
    assert rates["u_h1"] <= 2.4
    assert study["all_passed"]


def test_relative_error_is_small_on_the_finest_mesh(study):
    r = study["meshes"][-1]
    assert r["u_l2"] / r["u_l2_norm"] < 1e-3
    assert r["p_l2"] / r["p_l2_norm"] < 1e-2


def test_json_interface(study):
    assert study["exit_code"] == 0
    assert set(study["rates"]) == {"u_l2", "u_h1", "p_l2", "tip"}
    assert [m["h"] for m in study["meshes"]] == [0.5, 0.25, 0.125]
    for m in study["meshes"]:
        assert {"u_l2", "u_h1", "p_l2", "tip", "tip_exact", "dofs"} <= set(m)


def test_bad_field_parameters_raise():
    from skfem_sheet.params import ParameterError

    with pytest.raises(ParameterError, match="kappa"):
        mms.manufactured_fields(0.0, 10.0)
    with pytest.raises(ParameterError, match="bend"):
        mms.manufactured_fields(2.5, 10.0, bend=0.0)
