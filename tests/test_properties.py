"""Property-based input tests (hypothesis) of the public API and the command line.

The property, for every generated input: either a ``ParameterError`` whose
message starts with the name of a parameter (for the CLI: exit code 2 and a
one-line message, no traceback), or a result whose own checks pass; never
another exception.  Values include NaN, +-inf, negatives, zero, huge numbers,
wrong types and strings.

Where the inputs are valid the heavy part is replaced by a sentinel that
raises :class:`Reached` (``solve``'s meshing; the bistability and sweep
computations), so the validation that runs is the real one and the test stays
cheap; a few real coarse solves check that valid inputs give results that
pass their own checks.  Inputs of known bugs in modules this test does not
own are kept out of the strategies and pinned by strict ``xfail`` tests below.

Budget: about 2,400 generated inputs in the default suite, well under a minute.
"""
import importlib
import math
import sys

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from skfem_sheet import Sheet, solve
from skfem_sheet.cli import main
from skfem_sheet.io import Series
from skfem_sheet.linalg import SOLVERS, available_solvers
from skfem_sheet.params import MAX_CURVATURE, ParameterError
from skfem_sheet.reduced.cantilever import cantilever_deflection
from skfem_sheet.reduced.elastica import elastica
from skfem_sheet.reduced.persistence import persistence_length
from skfem_sheet.reduced.ribbon import ribbon_continuation

SETTINGS = dict(deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture,
                                                      HealthCheck.too_slow],
                derandomize=True, database=None)


class Reached(Exception):
    """Raised in place of the heavy computation: the input passed validation."""


def _reached(*args, **kwargs):
    raise Reached


# -- strategies ----------------------------------------------------------------------------
special = st.sampled_from([0.0, -0.0, math.nan, math.inf, -math.inf, 1e308, -1e308, 5e-324,
                           1e-300, 2 * math.pi, -1.0])
numbers = st.one_of(st.floats(allow_nan=True, allow_infinity=True), special,
                    st.integers(-10**300, 10**300), st.floats(-5, 5), st.floats(0, 1))
junk = st.one_of(st.none(), st.booleans(), st.text(max_size=6),
                 st.sampled_from(["1.5", "nan", "-inf", "1e999", "abc", "", " 2 "]),
                 st.lists(st.floats(0, 2), max_size=2), st.just(1j), st.just({"a": 1}),
                 st.just(object()))
anything = st.one_of(numbers, junk)

SHEET_RANGES = {  # name: (lo, hi, lo_open, hi_open), in the order Sheet checks them
    "length": (0, 100, True, False),
    "tip_width": (0, 1, False, False),
    "curvature": (0, MAX_CURVATURE, False, True),
    "thickness": (0, 0.5, True, False),
    "modulus": (0, 1e9, True, False),
}


def _as_float(v):
    try:
        return float(v)
    except (TypeError, ValueError, OverflowError):
        return None


def _in_range(x, lo, hi, lo_open, hi_open):
    return (x is not None and math.isfinite(x) and (x > lo if lo_open else x >= lo)
            and (x < hi if hi_open else x <= hi))


def _first_bad(kwargs):
    for name, (lo, hi, lo_open, hi_open) in SHEET_RANGES.items():
        default = {"tip_width": 1.0, "curvature": 0.0, "thickness": 0.03, "modulus": 735.0}
        v = kwargs.get(name, default.get(name))
        if not _in_range(_as_float(v), lo, hi, lo_open, hi_open):
            return name
    return None


def _names_a_parameter(err, names):
    msg = str(err)
    assert "\n" not in msg.strip(), msg
    assert any(msg.startswith(n + " ") or msg.startswith(n + ":") for n in names), msg


# -- Sheet ---------------------------------------------------------------------------------
sheet_kwargs = st.fixed_dictionaries({"length": st.one_of(anything, st.floats(0.05, 5))},
                                     optional={k: st.one_of(anything, st.floats(0, 1))
                                               for k in list(SHEET_RANGES)[1:]})


@settings(max_examples=700, **SETTINGS)
@given(sheet_kwargs)
def test_sheet_accepts_exactly_the_valid_parameters(kwargs):
    """The first parameter out of range (or not a number) is named; valid ones give a
    Sheet whose fields are the numbers given, checked again by ``replace``."""
    bad = _first_bad(kwargs)
    try:
        s = Sheet(**kwargs)
    except ParameterError as err:
        if bad is None:  # every range met: only the thickness/length relation remains
            assert str(err).startswith("thickness must be at most half the length"), err
            assert _as_float(kwargs.get("thickness", 0.03)) > 0.5 * _as_float(kwargs["length"])
        else:
            assert str(err).startswith(bad + " must be"), (bad, err)
        return
    assert bad is None, (bad, kwargs)
    for name in SHEET_RANGES:
        v = getattr(s, name)
        assert type(v) is float and math.isfinite(v)
        if name in kwargs:
            assert v == _as_float(kwargs[name])
    assert s.thickness <= 0.5 * s.length
    assert s.replace() == s and Sheet(**s.to_dict()) == s
    assert s.mu > 0 and s.bending_modulus > 0 and s.area > 0


SI_RANGES = dict(base_width=st.floats(1e-3, 1), length=st.floats(1e-3, 1),
                 tip_width=st.floats(0, 1e-2), thickness=st.floats(1e-5, 1e-3),
                 radius=st.one_of(st.floats(1e-2, 10), st.just(math.inf)),
                 youngs_modulus=st.floats(1e3, 1e9), density=st.floats(100, 1e4),
                 gravity=st.floats(0.1, 30))
si_number = st.one_of(st.floats(allow_nan=True, allow_infinity=True), special,
                      st.integers(-10**300, 10**300))


@settings(max_examples=400, **SETTINGS)
@given(st.fixed_dictionaries({k: st.one_of(v, v, si_number) for k, v in SI_RANGES.items()}))
def test_from_si_maps_or_names_the_parameter(kwargs):
    """Numbers in SI give the dimensionless sheet (L/a, b/a, a/R, h/a, E/(rho g a)) or
    a ParameterError naming an SI quantity or the Sheet parameter it maps to."""
    try:
        s = Sheet.from_si(**kwargs)
    except ParameterError as err:
        _names_a_parameter(err, list(SI_RANGES) + list(SHEET_RANGES))
        return
    a = kwargs["base_width"]
    assert s.length == pytest.approx(kwargs["length"] / a, rel=1e-12)
    assert s.tip_width == pytest.approx(kwargs["tip_width"] / a, rel=1e-12)
    assert s.thickness == pytest.approx(kwargs["thickness"] / a, rel=1e-12)
    assert s.curvature == pytest.approx(a / kwargs["radius"], rel=1e-12)
    g = kwargs["gravity"]
    assert s.modulus == pytest.approx(kwargs["youngs_modulus"] / (kwargs["density"] * g * a),
                                      rel=1e-12)


# -- solve: validation before meshing --------------------------------------------------------
SOLVE_NAMES = ("sheet", "path", "hmax", "layers", "refine", "solver", "quadrature_order",
               "symmetric", "on_failure", "series", "newton_options", "step_options")


@pytest.fixture
def no_meshing(monkeypatch):
    monkeypatch.setattr(sys.modules["skfem_sheet.solve"], "build_problem", _reached)


small_sheets = st.builds(Sheet, length=st.floats(0.1, 3), tip_width=st.floats(0, 1),
                         curvature=st.floats(0, 6), thickness=st.sampled_from([0.01, 0.03]))
solve_args = st.fixed_dictionaries({
    "sheet": st.one_of(small_sheets, small_sheets, junk),
    "path": st.sampled_from(["curvature-first", "gravity-first", "sideways", "", None, 3]),
    "hmax": st.one_of(st.floats(0.05, 0.5), numbers, junk),
    "layers": st.one_of(st.none(), st.integers(-2, 20), st.sampled_from([2.0, 2.5, math.nan,
                                                                        math.inf, True])),
    "refine": st.one_of(st.integers(-1, 6), st.sampled_from([1.0, 1.5, math.nan, True, None])),
    "solver": st.sampled_from([*SOLVERS, "magic", "", None]),
    "quadrature_order": st.sampled_from([2, 3, 4, 1, 5, 2.0, 2.5, None, "2"]),
    "symmetric": st.sampled_from([True, False, np.bool_(True), 0, 1, "yes", None]),
    "on_failure": st.sampled_from(["raise", "return", "ignore", None]),
    "series": st.sampled_from([None, "out/", 3]) | st.builds(Series),
})


def _solve_args_valid(kw):
    s = kw["sheet"]
    if not isinstance(s, Sheet) or kw["path"] not in ("curvature-first", "gravity-first"):
        return False
    h = _as_float(kw["hmax"]) if not isinstance(kw["hmax"], (str, bool)) else None
    if not (h is not None and 2e-3 <= h <= min(0.5, s.length)):
        return False
    lay = kw["layers"]
    if lay is not None and (isinstance(lay, bool) or not (float(lay).is_integer()
                                                           and 1 <= lay <= 16)):
        return False
    r = kw["refine"]
    if isinstance(r, bool) or r is None or not (float(r).is_integer() and 0 <= r <= 4):
        return False
    return (kw["solver"] in SOLVERS and kw["quadrature_order"] in (2, 3, 4)
            and isinstance(kw["symmetric"], (bool, np.bool_))
            and kw["on_failure"] in ("raise", "return")
            and (kw["series"] is None or isinstance(kw["series"], Series)))


@settings(max_examples=500, **SETTINGS)
@given(solve_args)
def test_solve_validates_every_argument_before_meshing(no_meshing, kw):
    try:
        solve(**kw)
    except ParameterError as err:
        _names_a_parameter(err, SOLVE_NAMES)
        # a refusal for a valid-looking input must be the memory guard or a missing back-end
        if _solve_args_valid(kw):
            msg = str(err)
            assert ("unknowns" in msg or "needs" in msg
                    or kw["solver"] not in available_solvers() + ["auto"]), msg
        return
    except Reached:
        assert _solve_args_valid(kw), kw
        return
    pytest.fail("solve returned without meshing")


@settings(max_examples=6, **SETTINGS)
@given(st.builds(Sheet, length=st.floats(0.3, 0.8), tip_width=st.floats(0, 1),
                 curvature=st.floats(0, 2.5)),
       st.sampled_from(["curvature-first", "gravity-first"]))
def test_valid_solves_pass_their_own_checks(sheet, path):
    """Real coarse solves of valid sheets: a converged result is a consistent one."""
    r = solve(sheet, path=path, hmax=0.3, on_failure="return")
    rec = r.to_record()
    assert rec["length"] == sheet.length and rec["path"] == path
    if r.converged:
        assert math.isfinite(r.deflection) and abs(r.deflection) < sheet.length
        assert r.kappa == pytest.approx(sheet.curvature) and r.gravity == 1.0
        assert abs(r.volume_change) < 0.05 and math.isfinite(r.energy)
        assert r.load_steps == len(r.steps) >= 1
    else:
        assert r.message


# -- the reduced models --------------------------------------------------------------------
def _check_reduced(name, sheet, r):
    L = sheet.length
    if name == "elastica":
        if r.converged:
            assert math.isfinite(r.deflection) and -1e-9 <= r.deflection <= L * (1 + 1e-9)
    elif name == "persistence":  # 0 for a flat clamp
        assert r.persistence_length >= 0 and not math.isnan(r.persistence_length)
    elif name == "cantilever":
        assert r.deflection >= 0 and not math.isnan(r.deflection)
    elif name == "ribbon":
        ok = np.asarray(r.converged, bool)
        assert np.all(np.isfinite(r.deflection[ok]))
        assert np.all(np.abs(r.deflection[ok]) <= r.lengths[ok] * (1 + 1e-6))


REDUCED = {
    "elastica": lambda s, extra: elastica(s, **extra),
    "persistence": lambda s, extra: persistence_length(s, **extra),
    "cantilever": lambda s, extra: cantilever_deflection(s, **extra),
    "ribbon": lambda s, extra: ribbon_continuation(s, **extra),
}
ribbon_lengths = st.one_of(st.lists(st.floats(0.2, 1.5), min_size=1, max_size=2),
                           st.lists(numbers, max_size=2), numbers)
reduced_extra = {
    "elastica": st.just({}),
    "persistence": st.just({}),
    "cantilever": st.fixed_dictionaries({}, optional={"include_curved_part": st.booleans()}),
    "ribbon": st.fixed_dictionaries(
        {"lengths": ribbon_lengths},
        optional={"direction": st.sampled_from(["increasing", "decreasing", "up", None]),
                  "n_elements": st.one_of(st.integers(-2, 500),
                                          st.sampled_from([8.5, math.nan, None, 8.0])),
                  "impose_flat": st.booleans(),
                  "refine_tol": st.one_of(st.floats(0.01, 0.1), numbers),
                  "jump_tol": st.one_of(st.floats(0.01, 0.1), numbers)}),
}
# a length below twice the template's thickness is refused by Sheet, naming the thickness
REDUCED_NAMES = ("sheet", "sheet_template", "lengths", "direction", "n_elements",
                 "include_curved_part", "refine_tol", "jump_tol", "thickness")
any_sheet = st.builds(Sheet, length=st.floats(0.2, 3), tip_width=st.floats(0, 1),
                      curvature=st.floats(0, 6), thickness=st.floats(0.005, 0.05),
                      modulus=st.floats(10, 1e4))


@pytest.fixture
def no_reduced_solves(monkeypatch):
    monkeypatch.setattr(sys.modules["skfem_sheet.reduced.elastica"], "solve_bvp", _reached)
    monkeypatch.setattr(sys.modules["skfem_sheet.reduced.ribbon"], "ribbon", _reached)
    monkeypatch.setattr(sys.modules["skfem_sheet.reduced.persistence"], "solve_ivp", _reached)


def _ribbon_args_valid(extra):
    try:
        L = np.asarray(extra["lengths"], dtype=float).ravel()
    except (TypeError, ValueError, OverflowError):
        return False
    n = extra.get("n_elements", 24)
    return (L.size > 0 and bool(np.all((L > 0) & (L <= 100)))
            and extra.get("direction", "increasing") in ("increasing", "decreasing")
            and not isinstance(n, bool) and n is not None and np.isfinite(n)
            and float(n).is_integer() and 4 <= n <= 400
            and all(_in_range(_as_float(extra.get(k, 0.02)), 0, math.inf, True, False)
                    for k in ("refine_tol", "jump_tol")))


@settings(max_examples=450, **SETTINGS)
@given(st.sampled_from(sorted(REDUCED)).flatmap(
    lambda m: st.tuples(st.just(m), st.one_of(junk, any_sheet), reduced_extra[m])))
def test_reduced_models_validate_their_arguments(no_reduced_solves, case):
    """Bad arguments of the reduced models are named; their ODE/BVP and ribbon solvers
    are replaced by the sentinel (what is computed without them runs for real)."""
    name, sheet, extra = case
    try:
        r = REDUCED[name](sheet, extra)
    except ParameterError as err:
        _names_a_parameter(err, REDUCED_NAMES)
        return
    except Reached:
        assert isinstance(sheet, Sheet)
        assert name != "ribbon" or _ribbon_args_valid(extra), extra
        return
    assert isinstance(sheet, Sheet)
    _check_reduced(name, sheet, r)


@settings(max_examples=12, **SETTINGS)
@given(st.sampled_from(sorted(REDUCED)),
       st.builds(Sheet, length=st.floats(0.3, 2), tip_width=st.floats(0, 1),
                 curvature=st.floats(0, 4)))
def test_reduced_models_on_valid_sheets_pass_their_checks(name, sheet):
    extra = {"lengths": [sheet.length, sheet.length + 0.1]} if name == "ribbon" else {}
    _check_reduced(name, sheet, REDUCED[name](sheet, extra))


# -- the command line ----------------------------------------------------------------------
@pytest.fixture
def no_heavy_work(monkeypatch):
    monkeypatch.setattr(importlib.import_module("skfem_sheet.solve"), "build_problem", _reached)
    monkeypatch.setattr(importlib.import_module("skfem_sheet.bistability.follow"),
                        "SheetShapeProblem",
                        _reached)
    monkeypatch.setattr(importlib.import_module("skfem_sheet.studies.sweep"), "execute", _reached)
    monkeypatch.setattr(importlib.import_module("skfem_sheet.reduced.elastica"), "solve_bvp", _reached)
    monkeypatch.setattr(importlib.import_module("skfem_sheet.reduced.ribbon"), "ribbon", _reached)


texts = st.one_of(st.sampled_from(["1", "0.5", "1.3", "2.5", "0", "-0", "-1", "nan", "inf",
                                   "-inf", "1e308", "1e999", "abc", "", " ", "0.03", "735",
                                   "1:2", "0.6:2.4", "1,2", "0.5:1:0.25", "3", "a:b", "both"]),
                  st.floats(allow_nan=True).map(repr), st.text(max_size=5))
OPTIONS = {
    "solve": ["--length", "--tip-width", "--curvature", "--thickness", "--modulus", "--hmax",
              "--layers", "--refine", "--path", "--solver", "--si", "--series", "--folds"],
    "rom elastica": ["--length", "--tip-width", "--thickness", "--modulus"],
    "rom persistence": ["--length", "--tip-width", "--curvature", "--thickness", "--modulus"],
    "rom cantilever": ["--length", "--tip-width", "--curvature", "--thickness", "--modulus"],
    "rom ribbon": ["--lengths", "--tip-width", "--curvature", "--direction", "--elements"],
    "bistability": ["--tip-width", "--curvature", "--lengths", "--hmax", "--step", "--tol",
                    "--at-length", "--curvatures", "--solver", "--length", "--si"],
    "sweep": ["--lengths", "--tip-widths", "--curvatures", "--hmax", "--refine", "--workers",
              "--paths", "--symmetric", "--solver"],
}


@st.composite
def argv(draw):
    command = draw(st.sampled_from(sorted(OPTIONS)))
    opts = draw(st.lists(st.sampled_from(OPTIONS[command]), max_size=4, unique=True))
    args = command.split()
    if command in ("solve", "rom elastica", "rom persistence", "rom cantilever") and \
            draw(st.booleans()):
        args += ["--length", draw(st.sampled_from(["0.5", "1.3"]))]
    if command == "rom persistence" and draw(st.booleans()):
        args += ["--curvature", "2.5"]
    if command in ("rom ribbon", "sweep") and draw(st.booleans()):
        args += ["--lengths", draw(st.sampled_from(["1:1.2:0.1", "1,1.2"]))]
    for o in opts:
        args += [o, draw(texts)]
    if command in ("sweep", "bistability"):
        args += ["--quiet"]
    return args


@settings(max_examples=400, **SETTINGS)
@given(argv())
def test_cli_one_line_error_or_runs(no_heavy_work, tmp_path_factory, capsys, monkeypatch, args):
    monkeypatch.chdir(tmp_path_factory.getbasetemp())
    capsys.readouterr()
    if args[0] == "sweep":
        args = args + ["--table", "fuzz.csv"]
    try:
        code = main(args)
    except SystemExit as e:  # argparse
        code = e.code
        out = capsys.readouterr()
        assert code == 2, (args, out)
        assert "Traceback" not in out.err and len(out.err.strip().splitlines()) == 1, out.err
        return
    except Reached:  # validated, the heavy part would run now
        capsys.readouterr()
        return
    out = capsys.readouterr()
    assert "Traceback" not in out.err, out.err
    if code == 2:
        assert len(out.err.strip().splitlines()) == 1 and "error:" in out.err, out.err
    else:
        assert code in (0, 1), (args, code, out)


# -- known bugs in modules this file does not own (found by the searches above) -------------
# Each raises another exception than ParameterError.  Strict: when one is fixed its xfail
# fails, and the case moves into the strategies above.
def _si(**change):
    return {**dict(base_width=0.05, length=0.065, tip_width=0.05, thickness=1.5875e-3,
                   radius=0.02, youngs_modulus=4.5e5, density=1250.0), **change}


#: Found by the properties above and fixed (session 5): each must now raise a
#: ParameterError naming its parameter.
FIXED_BUGS = {
    "solve: solve(newton_options='x')":
        (lambda: solve(Sheet(0.5), hmax=0.3, newton_options="x"), "newton_options"),
    "solve: solve(step_options=1)":
        (lambda: solve(Sheet(0.5), hmax=0.3, step_options=1), "step_options"),
    "params: Sheet(length=10**400)": (lambda: Sheet(length=10**400), "length"),
    "params: Sheet.from_si(base_width=10**400)":
        (lambda: Sheet.from_si(**_si(base_width=10**400)), "base_width"),
    "params: Sheet.from_si(length='0.065')": (lambda: Sheet.from_si(**_si(length="x")), "length"),
    "params: Sheet.from_si(radius='abc')": (lambda: Sheet.from_si(**_si(radius="abc")), "radius"),
    "params: Sheet.from_si(radius=None)": (lambda: Sheet.from_si(**_si(radius=None)), "radius"),
    "mesh: solve(layers='2')": (lambda: solve(Sheet(0.5), hmax=0.3, layers="2"), "layers"),
    "mesh: solve(layers='abc')": (lambda: solve(Sheet(0.5), hmax=0.3, layers="abc"), "layers"),
    "elastica: elastica(tol=None)": (lambda: elastica(Sheet(1.0), tol=None), "tol"),
    "elastica: elastica(n_nodes=None)": (lambda: elastica(Sheet(1.0), n_nodes=None), "n_nodes"),
    "persistence: persistence_length(n_profile=nan)":
        (lambda: persistence_length(Sheet(1.0, curvature=2.5), n_profile=math.nan), "n_profile"),
    "persistence: persistence_length(rtol=None)":
        (lambda: persistence_length(Sheet(1.0, curvature=2.5), rtol=None), "rtol"),
    "ribbon: ribbon_continuation(lengths='abc')":
        (lambda: ribbon_continuation(Sheet(1.0, curvature=2.5), "abc"), "lengths"),
    "cantilever: cantilever_deflection(persistence='x')":
        (lambda: cantilever_deflection(Sheet(1.0, curvature=2.5), persistence="x"), "persistence"),
}


@pytest.mark.parametrize("case", sorted(FIXED_BUGS))
def test_fixed_bug_raises_parameter_error_naming_the_parameter(no_meshing, case):
    fn, name = FIXED_BUGS[case]
    with pytest.raises(ParameterError, match=name):
        fn()

