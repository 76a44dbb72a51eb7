"""What a state is (skfem_sheet.analyses.mode): curvature- or gravity-dominated, read from
the state; one state one name whichever path reached it, a bistable pair two names."""
import numpy as np
import pytest

from skfem_sheet import Sheet, solve
from skfem_sheet.analyses.mode import (
    CURVATURE_DOMINATED,
    GRAVITY_DOMINATED,
    mode_of,
    name_of,
)
from skfem_sheet.engine import newton
from skfem_sheet.sheet_shape import TOLERANCES, SheetShapeProblem

H = 0.2


@pytest.fixture(scope="module")
def pair():
    """The paper's rectangle at L/a 1.3, a/R 2.5: aloft and drooped."""
    sheet = Sheet(length=1.3, curvature=2.5)
    return [solve(sheet, path=p, hmax=H, sensitivities=("length",))
            for p in ("curvature-first", "gravity-first")]


def test_a_bistable_pair_has_two_names_and_each_its_signs(pair):
    up, down = pair
    assert abs(up.deflection - down.deflection) > 0.3
    assert (up.branch, down.branch) == (CURVATURE_DOMINATED, GRAVITY_DOMINATED)
    # aloft: the sag accelerates with L and the curvature persists to the tip;
    # drooped: the sag decelerates and the curvature relaxes inside the sheet
    assert up.mode.bend > 0 and not up.mode.relaxed and up.mode.curvature_min > 0
    assert down.mode.slope > 0 > down.mode.bend and down.mode.relaxed
    assert down.mode.curvature_min < 0


def test_the_slope_is_the_length_sensitivity(pair):
    """d' = dd/dL of the mode and the solve's sensitivity to the length are one
    derivative (both K w' = -R_L on the stretched mesh)."""
    for r in pair:
        assert r.mode.slope == pytest.approx(r.sensitivities["length"], rel=1e-5)


def test_the_bend_is_the_second_derivative_along_the_branch():
    """d'' of the mode equals the second difference of d over three equilibria
    on one mesh stretched to L - h, L, L + h (O(h^2) apart)."""
    L, h = 1.3, 0.004
    P = SheetShapeProblem(Sheet(length=L, curvature=2.5), H, parameters=("L",),
                          geometry="stretch")
    out = P.along_path(np.array([L]), "gravity-first")
    u0 = out.w[P.free]
    d = []
    for x in (L - h, L, L + h):
        res = newton(P, u0, np.array([x]), tol=TOLERANCES)
        assert res.converged
        d.append(P.deflection(res.u, np.array([x])))
    mid = newton(P, u0, np.array([L]), tol=TOLERANCES)
    m = mode_of(P.problem(np.array([L])), P.full(mid.u, np.array([L])), 1.0)
    fd2 = (d[2] - 2 * d[1] + d[0]) / h**2
    # the second difference's own error is O(h^2): a quarter of it per halving of h
    # (0.85% at h 0.008, 0.21% at 0.004 here); below 0.004 Newton's tolerance (1e-6 in
    # the state) over h^2 takes over
    assert m.bend == pytest.approx(fd2, rel=5e-3)
    assert m.slope == pytest.approx((d[2] - d[0]) / (2 * h), rel=1e-3)


@pytest.mark.parametrize("length, curvature, name", [
    (0.5, 2.5, CURVATURE_DOMINATED),   # short: held aloft (the tip even rises)
    (2.9, 0.8, GRAVITY_DOMINATED),     # long, hanging 2.7 a below the clamp
    (3.0, 2.5, GRAVITY_DOMINATED),     # long on a strong clamp, hanging too
])
def test_one_state_one_name_whichever_path(length, curvature, name):
    sheet = Sheet(length=length, curvature=curvature)
    a, b = (solve(sheet, path=p, hmax=H) for p in ("curvature-first", "gravity-first"))
    assert abs(a.deflection - b.deflection) < 1e-6
    assert a.branch == b.branch == name


def test_the_limits_are_named_by_what_is_missing():
    flat = solve(Sheet(length=0.5), hmax=H)
    weightless = solve(Sheet(length=0.5, curvature=2.5), hmax=H, gravity=0.0)
    assert flat.branch == GRAVITY_DOMINATED and "flat clamp" in flat.mode.reason
    assert weightless.branch == CURVATURE_DOMINATED and weightless.mode.reason == "no gravity"


def test_either_sign_makes_a_state_gravity_dominated():
    assert name_of(1.1, 0.2, relaxed=True) == GRAVITY_DOMINATED      # hanging, accelerating
    assert name_of(1.5, -0.4, relaxed=False) == GRAVITY_DOMINATED    # weak clamp, sagging
    assert name_of(0.5, 4.0, relaxed=False) == CURVATURE_DOMINATED
    assert name_of(-0.1, -0.2, relaxed=False) == CURVATURE_DOMINATED  # the tip rises
