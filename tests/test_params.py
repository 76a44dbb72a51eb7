import math

import pytest

from skfem_sheet import Sheet


def test_defaults_are_the_papers():
    s = Sheet(length=1.3)
    assert (s.tip_width, s.curvature, s.thickness, s.modulus) == (1.0, 0.0, 0.03, 735.0)
    assert s.mu == pytest.approx(245.0)
    assert s.bending_modulus == pytest.approx(735 * 0.03**3 / 9)
    assert s.radius == math.inf
    assert Sheet(1.0, curvature=2.5).radius == pytest.approx(0.4)


def test_from_si_papers_silicone():
    # rho 1250 kg/m^3, h 1.5875 mm, a 5 cm, E 4.5e5 Pa: E/(rho g a) = 733.9 (paper rounds to 735)
    s = Sheet.from_si(base_width=0.05, length=0.065, tip_width=0.0, thickness=1.5875e-3,
                      radius=0.02, youngs_modulus=4.5e5, density=1250)
    assert s.modulus == pytest.approx(4.5e5 / (1250 * 9.81 * 0.05))
    assert s.length == pytest.approx(1.3) and s.tip_width == 0.0
    assert s.curvature == pytest.approx(2.5) and s.thickness == pytest.approx(0.03175)
    flat = Sheet.from_si(0.05, 0.05, 0.05, 1.5e-3, math.inf, 4.5e5, 1250)
    assert flat.curvature == 0.0


@pytest.mark.parametrize("kwargs, name", [
    (dict(length=0), "length"), (dict(length=-1), "length"), (dict(length=float("nan")), "length"),
    (dict(length=1, tip_width=1.5), "tip_width"), (dict(length=1, tip_width=-0.1), "tip_width"),
    (dict(length=1, curvature=-1), "curvature"), (dict(length=1, curvature=6.3), "curvature"),
    (dict(length=1, thickness=0), "thickness"), (dict(length=1, thickness=float("inf")), "thickness"),
    (dict(length=1, modulus=-5), "modulus"), (dict(length="abc"), "length"),
    (dict(length=0.04, thickness=0.03), "thickness"),
])
def test_bad_parameters_name_the_parameter_and_range(kwargs, name):
    with pytest.raises(ValueError) as err:
        Sheet(**kwargs)
    msg = str(err.value)
    assert msg.startswith(name)
    assert "must" in msg


def test_width_profile_and_replace():
    s = Sheet(length=2.0, tip_width=0.5)
    assert s.width(0.0) == 1.0 and s.width(2.0) == 0.5 and s.width(1.0) == 0.75
    assert s.area == pytest.approx(1.5)
    t = s.replace(curvature=1.0)
    assert t.curvature == 1.0 and t.length == 2.0 and s.curvature == 0.0
    with pytest.raises(ValueError, match="curvature"):
        s.replace(curvature=-1)


def test_from_si_refuses_an_underflowing_weight():
    # every factor is valid, but rho g a underflows to 0: a ParameterError, not a ZeroDivisionError
    with pytest.raises(ValueError, match="^gravity must"):
        Sheet.from_si(0.004, 1.0, 0.0, 1e-5, math.inf, 1e3, 100.0, gravity=5e-324)
