"""The analysis functions of the issue-3 benchmarks, on synthetic data of known order.

Only the pure helpers of ``benchmarks/_common.py`` (Richardson extrapolation,
power-law and log-log fits); the benchmarks themselves are heavy and run by hand.
"""
import doctest
import importlib.util
import math
import os

import numpy as np
import pytest

_PATH = os.path.join(os.path.dirname(__file__), os.pardir, "benchmarks", "_common.py")
_spec = importlib.util.spec_from_file_location("bench_common", _PATH)
bench = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(bench)

D0, C2 = 0.61234, 0.8          # "exact" value and error constant of the synthetic data
FAMILY = [0.12, 0.08, 0.06, 0.04, 0.03]   # the convergence benchmark's default family


def second_order(h, c3=0.0):
    return [D0 + C2 * x ** 2 + c3 * x ** 3 for x in h]


def test_richardson_constant_ratio_recovers_order_and_limit():
    h = [0.12, 0.06, 0.03]
    d_inf, p, C = bench.richardson(h, second_order(h))
    assert p == pytest.approx(2.0, abs=1e-10)
    assert d_inf == pytest.approx(D0, abs=1e-13)
    assert C == pytest.approx(C2, rel=1e-9)


def test_richardson_varying_ratio_recovers_order_and_limit():
    # ratios 1.43 and 1.4: the order comes from the nonlinear three-point equation
    h = [0.2, 0.14, 0.1]
    d_inf, p, C = bench.richardson(h, [1.5 - 0.3 * x ** 2.5 for x in h])
    assert p == pytest.approx(2.5, abs=1e-9)
    assert d_inf == pytest.approx(1.5, abs=1e-12)
    assert C == pytest.approx(-0.3, rel=1e-8)


def test_richardson_with_higher_order_term_is_close_to_two():
    # d = d0 + C h^2 + h^3 on the default family (ratios 1.5, 1.33): the h^3
    # term (4% of the h^2 term at the finest mesh) raises the three-point order
    # to 2.07 and leaves 1.6e-5 in the limit, 2% of the finest mesh's error (7.5e-4)
    d = second_order(FAMILY, c3=1.0)
    d_inf, p, C = bench.richardson(FAMILY[-3:], d[-3:])
    assert 2.0 < p < 2.15
    assert abs(d_inf - D0) < 0.05 * abs(d[-1] - D0)
    # the pure h^2 data on the same (not exactly constant-ratio) family are exact
    d_inf, p, _ = bench.richardson(FAMILY[-3:], second_order(FAMILY)[-3:])
    assert p == pytest.approx(2.0, abs=1e-9)
    assert d_inf == pytest.approx(D0, abs=1e-12)


@pytest.mark.parametrize("d", [[1.0, 1.1, 1.05],      # non-monotone
                               [1.0, 1.01, 1.03],     # differences grow: diverging
                               [1.0, 1.0, 1.01]])     # a zero difference
def test_richardson_refuses_non_converging_data(d):
    with pytest.raises(ValueError):
        bench.richardson([0.2, 0.1, 0.05], d)


def test_richardson_needs_decreasing_sizes():
    with pytest.raises(ValueError, match="decrease"):
        bench.richardson([0.05, 0.1, 0.2], [1.0, 1.1, 1.2])


def test_power_law_fit_through_four_points():
    d_inf, p, C, rms = bench.power_law_fit(FAMILY, second_order(FAMILY))
    assert p == pytest.approx(2.0, abs=1e-6)
    assert d_inf == pytest.approx(D0, abs=1e-10)
    assert rms < 1e-12


def test_power_law_fit_with_noise_stays_near_truth():
    rng = np.random.default_rng(0)
    h = [0.2, 0.14, 0.1, 0.07, 0.05]
    d = np.array(second_order(h)) + 1e-6 * rng.standard_normal(len(h))
    d_inf, p, C, rms = bench.power_law_fit(h, d)
    assert p == pytest.approx(2.0, abs=0.05)
    assert d_inf == pytest.approx(D0, abs=1e-5)
    assert 1e-8 < rms < 1e-5


def test_loglog_slope_exact_and_needs_nonzero_errors():
    h = np.array(FAMILY)
    slope, intercept = bench.loglog_slope(h, 3.0 * h ** 1.8)
    assert slope == pytest.approx(1.8, abs=1e-12)
    assert math.exp(intercept) == pytest.approx(3.0, rel=1e-10)
    with pytest.raises(ValueError, match="zero"):
        bench.loglog_slope(h, [1e-3, 1e-4, 0.0, 1e-6, 1e-7])


def test_analyse_sequence_second_order():
    d = second_order(FAMILY, c3=0.2)
    a = bench.analyse_sequence(FAMILY, d)
    assert a["warnings"] == []
    assert a["error_reference"] == "extrapolated"
    assert a["observed_order"] == pytest.approx(2.0, abs=0.03)
    assert a["observed_order_all"] == pytest.approx(2.0, abs=0.05)
    # the h^3 term leaves 0.5% of the finest mesh's error in the limit (3.4e-6 of 7.3e-4)
    assert abs(a["extrapolated"] - D0) < 0.02 * abs(d[-1] - D0)
    assert a["power_law"]["order"] == pytest.approx(2.0, abs=0.05)
    # relative errors shrink like h^2: a factor ~2 per sqrt(2) refinement
    e = np.abs(a["errors"])
    assert np.all(e[1:] < e[:-1])
    assert e[0] / e[2] == pytest.approx((FAMILY[0] / FAMILY[2]) ** 2, rel=0.05)


def test_analyse_sequence_is_honest_about_non_monotone_data():
    d = [0.60, 0.62, 0.61, 0.615, 0.612]
    a = bench.analyse_sequence(FAMILY, d)
    assert a["extrapolated"] is None and a["observed_order"] is None
    assert a["error_reference"] == "finest mesh"
    assert a["errors"][-1] == 0.0
    assert any("non-monotone" in w for w in a["warnings"])


def test_analyse_sequence_flags_non_monotone_first_mesh():
    # the last three converge at second order, the first mesh is off the trend
    d = [D0 - 0.01] + second_order(FAMILY[1:])
    a = bench.analyse_sequence(FAMILY, d)
    assert a["observed_order"] == pytest.approx(2.0, abs=1e-9)
    assert any("all meshes" in w for w in a["warnings"])


def test_parse_family():
    assert bench.parse_family("0.12:2,0.085:3, 0.06:auto") == [(0.12, 2), (0.085, 3),
                                                                 (0.06, None)]


def test_doctests_of_helpers():
    # the helpers' docstring examples (benchmarks/ is outside pytest's doctest paths)
    failed, attempted = doctest.testmod(bench, optionflags=doctest.ELLIPSIS)
    assert attempted >= 6 and failed == 0
