"""The benchmark scripts of ``benchmarks/``, on synthetic data and dry runs.

The helpers of ``benchmarks/harness.py`` (Richardson extrapolation, power-law and
log-log fits, journalled solves, the argument parser) on data of known order;
the scripts' own logic where it runs without a real solve (dry runs, fits of
synthetic families, journals); every script parses ``--help``.  The benchmarks
themselves are heavy and run by hand (``benchmarks/README.md``).
"""
import doctest
import importlib.util
import math
import os

import numpy as np
import pytest

_PATH = os.path.join(os.path.dirname(__file__), os.pardir, "benchmarks", "harness.py")
_spec = importlib.util.spec_from_file_location("bench_harness", _PATH)
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


# two nested families whose error terms have opposite signs (the shape the
# session-4 data of the convergence case have): d = D + A h^2 + B h^3
TWO_FAMILIES = [0.16, 0.08, 0.04, 0.12, 0.06, 0.03]
D_TURN, A_TURN, B_TURN = -0.0768, 0.07, -0.5


def turning(h, p=2.0):
    return [D_TURN + A_TURN * x ** p + B_TURN * x ** (p + 1) for x in h]


@pytest.mark.parametrize("p", [1.5, 2.0, 2.5])
def test_two_term_fit_recovers_the_order_where_richardson_sees_none(p):
    d = turning(TWO_FAMILIES, p)
    # each family alone turns (error maximal near h = 2A / 3|B| = 0.09): no order
    for fam in (slice(0, 3), slice(3, 6)):
        with pytest.raises(ValueError):
            bench.richardson(TWO_FAMILIES[fam], d[fam])
    f = bench.two_term_fit(TWO_FAMILIES, d)
    assert f["order"] == pytest.approx(p, abs=1e-6)
    assert f["extrapolated"] == pytest.approx(D_TURN, abs=1e-12)
    assert f["A"] == pytest.approx(A_TURN, rel=1e-5) and f["B"] == pytest.approx(B_TURN, rel=1e-5)
    assert f["rms"] < 1e-12


def test_two_term_fit_with_noise_brackets_the_truth():
    # noise of 5e-6 (Newton tolerance and round-off in the real data)
    rng = np.random.default_rng(7)
    d = np.array(turning(TWO_FAMILIES)) + 5e-6 * rng.standard_normal(6)
    f = bench.two_term_fit(TWO_FAMILIES, d)
    assert abs(f["order"] - 2.0) < 3 * f["order_se"] and f["order_se"] < 0.5
    assert abs(f["extrapolated"] - D_TURN) < 3 * f["extrapolated_se"]


def test_two_term_fit_needs_five_points():
    with pytest.raises(ValueError, match="five"):
        bench.two_term_fit(TWO_FAMILIES[:4], turning(TWO_FAMILIES[:4]))


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


# ---------------------------------------------------------------------------
# The sampled, journalled solves of benchmarks/stress.py and snap_sample.py
# ---------------------------------------------------------------------------
def test_random_sheets_in_range_and_thickness_modulus_drawn_after_the_shape():
    fixed = bench.random_sheets(40, 5)
    drawn = bench.random_sheets(40, 5, thickness=(0.02, 0.045), modulus=(400.0, 2000.0))
    assert fixed == bench.random_sheets(40, 5) and len(fixed) == 40
    for name, lo, hi in (("length", 0.2, 3.0), ("tip_width", 0.0, 1.0), ("curvature", 0.0, 6.0)):
        assert [p[name] for p in fixed] == [p[name] for p in drawn]
        xs = [p[name] for p in fixed]
        assert lo <= min(xs) and max(xs) <= hi and max(xs) - min(xs) > 0.5 * (hi - lo)
    assert {p["thickness"] for p in fixed} == {0.03} and {p["modulus"] for p in fixed} == {735.0}
    assert all(0.02 <= p["thickness"] <= 0.045 and 400 <= p["modulus"] <= 2000 for p in drawn)


def test_run_journalled_shards_resume_and_skip_a_cut_line(tmp_path):
    out = str(tmp_path / "j.jsonl")
    todo = [(p, path) for p in bench.random_sheets(3, 2) for path in ("a", "b")]
    calls = []

    def run(p, path):
        calls.append(bench.solve_key(p, path))
        return {"status": "converged", "n": len(calls)}

    seen = []
    bench.run_journalled(todo, out, run, shard=(1, 2), report=lambda *a: seen.append(a[:2]))
    assert calls == [bench.solve_key(*t) for t in todo[1::2]] and seen == [(0, 3), (1, 3), (2, 3)]
    with open(out, "a") as f:
        f.write('{"key": "cut by a ki')  # a kill in the middle of a line
    done = bench.run_journalled(todo, out, run, shard=(0, 2), reverse=True)
    assert calls[3:] == [bench.solve_key(*t) for t in todo[0::2]][::-1]
    assert list(done) == [bench.solve_key(*t) for t in todo[1::2] + todo[0::2][::-1]]
    rec = done[bench.solve_key(*todo[0])]
    assert rec["path"] == "a" and rec["length"] == todo[0][0]["length"] and rec["n"] == 6
    n = len(calls)
    assert bench.run_journalled(todo, out, run) == bench.read_jsonl(out) and len(calls) == n
    assert len(bench.read_jsonl(out)) == 6


def test_solve_or_crash_records_an_exception_as_a_crash():
    bad = dict(length=1.0, tip_width=1.0, curvature=0.0, thickness=-1.0, modulus=735.0)
    rec = bench.solve_or_crash(bad, "curvature-first", 0.2, fields=lambda r: {})
    assert rec["status"] == "crash" and "thickness" in rec["error"]
    assert "Traceback" in rec["traceback"] and rec["wall_time_s"] >= 0


# ---------------------------------------------------------------------------
# Nested refinement study (benchmarks/convergence.py --nested)
# ---------------------------------------------------------------------------
NESTED = [0.16, 0.08, 0.04, 0.02]   # base hmax 0.16 and three halvings


def test_nested_family_halves_hmax_and_doubles_layers():
    fam = bench.nested_family(0.16, 2, 3)
    assert [f[2] for f in fam] == [0, 1, 2, 3]
    assert [f[1] for f in fam] == [2, 4, 8, 16]
    assert [f[0] for f in fam] == NESTED          # exact: division by powers of two
    with pytest.raises(ValueError, match="refinements"):
        bench.nested_family(0.16, 2, -1)
    with pytest.raises(ValueError, match="layers"):
        bench.nested_family(0.16, 0, 2)
    with pytest.raises(ValueError, match="hmax"):
        bench.nested_family(0.0, 2, 2)


def test_local_orders_ratio_two_settle_to_the_leading_order():
    # d = d0 + C h^2 + h^3: the three-point order log2((d1-d2)/(d2-d3)) tends to 2
    # from above as h -> 0 (the h^3 term fades by a factor 2 per halving)
    d = second_order(NESTED, c3=3.0)
    orders = bench.local_orders(NESTED, d)
    assert len(orders) == 2
    assert 2.0 < orders[1] < orders[0]
    # the excess over 2 shrinks by a factor 2 per halving asymptotically; 1.66 here,
    # where the h^3 term is still 30-60% of the h^2 one
    assert orders[1] - 2.0 < 0.65 * (orders[0] - 2.0)
    # the formula for ratio 2, written out
    d1, d2, d3 = d[1:]
    assert orders[1] == pytest.approx(math.log2((d1 - d2) / (d2 - d3)), rel=1e-12)
    # and Richardson on the three finest recovers the limit to a fraction of the error
    d_inf, p, _ = bench.richardson(NESTED[1:], d[1:])
    assert abs(d_inf - D0) < 0.1 * abs(d[-1] - D0)


def test_local_orders_mark_non_converging_triples():
    h = NESTED
    assert bench.local_orders(h, [1.0, 1.1, 1.05, 1.06]) == [None, None]
    orders = bench.local_orders(h, [1.2, 1.1, 1.05, 1.06])   # last triple turns back
    assert orders[0] == pytest.approx(1.0, abs=1e-12) and orders[1] is None
    assert bench.local_orders(h[:2], [1.0, 1.1]) == []


def _bench_module(script):
    """A script of benchmarks/ as a module (benchmarks/ on the path for ``harness``, as
    when the script runs: Python puts a script's folder on the path)."""
    import sys

    bench_dir = os.path.dirname(_PATH)
    if bench_dir not in sys.path:
        sys.path.insert(0, bench_dir)
    spec = importlib.util.spec_from_file_location("bench_" + script[:-3],
                                                  os.path.join(bench_dir, script))
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod      # (dataclasses look their module up there)
    spec.loader.exec_module(mod)
    return mod


def _convergence_main(script="convergence.py"):
    return _bench_module(script).main


def test_convergence_dry_run_lists_the_nested_family(capsys):
    main = _convergence_main()
    assert main(["--dry-run"]) == 0
    lines = capsys.readouterr().out.splitlines()
    fam = [ln.split() for ln in lines if ln.startswith("family")]
    # h, base hmax, refine, layers of the default family: 0.16/0.08/0.04, 2/4/8
    assert [(f[2], f[4], f[6], f[8]) for f in fam] == [("0.16", "0.16", "0", "2"),
                                                       ("0.08", "0.16", "1", "4"),
                                                       ("0.04", "0.16", "2", "8")]
    check = [ln.split() for ln in lines if ln.startswith("check")]
    assert len(check) == 1 and check[0][2] == "0.03"


@pytest.mark.parametrize("argv, msg", [(["--refinements", "1"], "at least 2"),
                                       (["--family", "0.1:2,0.05:4,0.025:8"], "--remesh"),
                                       (["--remesh", "--base-hmax", "0.1"], "--nested"),
                                       (["--base-hmax", "0.01", "--refinements", "3"],
                                        "max-dofs")])
def test_convergence_refuses_bad_options(argv, msg, capsys):
    main = _convergence_main()
    with pytest.raises(SystemExit) as exc:
        main(argv + ["--dry-run"])
    assert exc.value.code == 2
    assert msg in capsys.readouterr().err


def _family_file(path, base, d_of_h, check=None):
    """A convergence.py --nested JSON file with the meshes base / 2^k."""
    import json

    runs = [dict(role="family", converged=True, layers=2 * 2 ** k, dofs=1000 * 8 ** k,
                 deflection=d_of_h(base / 2 ** k), wall_time_s=1.0,
                 spec=dict(hmax=base, refine=k)) for k in range(3)]
    case = dict(length=1.8, tip_width=1.0, curvature=5.0, path="curvature-first",
                solver="auto", mode="nested")
    with open(path, "w") as f:
        json.dump(dict(runs=runs, case=case, base_hmax=base, base_layers=2, check=check), f)
    return str(path)


def test_convergence_fit_of_two_turning_families(tmp_path, capsys):
    """The fit script on two synthetic nested families that each turn (no
    three-mesh order): it finds the order, the limit and the default's error."""
    import json

    def d_of_h(h):
        return D_TURN + A_TURN * h ** 2 + B_TURN * h ** 3

    check = dict(hmax=0.03, layers=2, deflection=D_TURN * 1.004)
    files = [_family_file(tmp_path / "a.json", 0.16, d_of_h, check),
             _family_file(tmp_path / "b.json", 0.12, d_of_h)]
    out = tmp_path / "fit.json"
    main = _convergence_main()
    assert main(["fit", *files, "--json", str(out)]) == 0
    fit = json.loads(out.read_text())
    assert fit["observed_order"] == pytest.approx(2.0, abs=1e-6)
    assert fit["extrapolated"] == pytest.approx(D_TURN, abs=1e-12)
    # d = 1.004 d_inf with d_inf < 0: 0.4% below the limit
    assert fit["check"]["error_vs_extrapolated"] == pytest.approx(-0.004, rel=1e-9)
    assert all(c["max_deviation"] < 1e-10 for c in fit["cross_validation"])
    text = capsys.readouterr().out
    assert "meets p >= 1.8" in text and "within 1%" in text


def test_convergence_fit_says_when_the_order_is_not_determined(tmp_path, capsys):
    # noise of 2e-5 on errors of 1e-4: the order's standard error is large
    rng = np.random.default_rng(1)
    noisy = {h: D_TURN + A_TURN * h ** 2 + B_TURN * h ** 3 + 2e-5 * rng.standard_normal()
             for h in (0.16, 0.08, 0.04, 0.12, 0.06, 0.03, 0.14, 0.07, 0.035)}
    files = [_family_file(tmp_path / f"{b}.json", b, noisy.__getitem__) for b in (0.16, 0.12, 0.14)]
    out = tmp_path / "fit.json"
    main = _convergence_main()
    assert main(["fit", *files, "--max-h", "0.12", "--json", str(out)]) == 0
    import json

    fit = json.loads(out.read_text())
    assert fit["observed_order_se"] > 0.2 and fit["order_determined"] is False
    assert max(fit["hmax"]) <= 0.12
    assert "not determined" in capsys.readouterr().out


def test_convergence_fit_refuses_too_few_meshes(tmp_path):
    main = _convergence_main()
    one = _family_file(tmp_path / "a.json", 0.16, lambda h: 1.0 + h ** 2)
    with pytest.raises(SystemExit, match="five or more"):
        main(["fit", one])


# ---------------------------------------------------------------------------
# The fold-curve map read from its journal only (benchmarks/fold_curves.py --partial)
# ---------------------------------------------------------------------------
def test_fold_curves_partial_reads_the_tables_journal(tmp_path, monkeypatch):
    """``_journalled`` finds the curves the fold-curve table journalled (written
    by :func:`skfem_sheet.studies.foldmap.fold_curves`, traces faked): the last
    line of a curve counts, a line cut short is skipped, the rest is missing."""
    import json
    from types import SimpleNamespace

    from skfem_sheet.figures.data import fold_curve_points
    from skfem_sheet.studies import foldmap as fm

    def fake(second):
        def trace(*args, **kw):
            return SimpleNamespace(
                second=second, cusp=None, standout_length=1.4, popup_length=1.2,
                cusp_located="", bistable=True, completed=True,
                points=({second: 1.0, "length": 1.4, "kind": "standout"},),
                factorizations=3, factorizations_per_point=3.0, remeshes=0, reason="",
                wall_time_s=0.1)
        return trace

    monkeypatch.setattr(fm, "trace_fold_curve", fake("tip_width"))
    monkeypatch.setattr(fm, "trace_curvature_fold_curve", fake("curvature"))
    pts = fold_curve_points("quick")
    done = [pts[0], pts[3], pts[-1]]          # two curves in (L, b/a), the rectangle's
    table = tmp_path / "foldcurves-quick.csv"
    fm.fold_curves(done, table=table, workers=1, progress=False)
    journal = str(table) + ".journal.jsonl"
    with open(journal) as f:
        lines = [json.loads(ln) for ln in f]
    again = dict(lines[0], standout_length=1.5)   # a later line of the same curve wins
    with open(journal, "a") as f:
        f.write(json.dumps(again) + "\n" + json.dumps(lines[1])[:40])   # and a cut line

    fc = _bench_module("fold_curves.py")
    df, missing = fc._journalled("quick", str(tmp_path))
    got = {(r.second, r.curvature): r for r in df.itertuples()}
    pair = {(p["second"], p["curvature"]) for p in done}
    assert set(got) == pair and len(df) == 3
    assert missing == sorted({(p["second"], p["curvature"]) for p in pts} - pair)
    assert got[(again["second"], again["curvature"])].standout_length == 1.5
    assert {r.key for r in df.itertuples()} == {ln["key"] for ln in lines}
    assert fc._journalled("quick", str(tmp_path / "none"))[1] == sorted(
        (p["second"], p["curvature"]) for p in pts)


# ---------------------------------------------------------------------------
# The suite's layout: scripts, their --help, the recorded outputs documents cite
# ---------------------------------------------------------------------------
BENCH = os.path.dirname(_PATH)
ROOT = os.path.dirname(BENCH)
SCRIPTS = sorted(f for f in os.listdir(BENCH) if f.endswith(".py"))
SUITES = ("accuracy", "speed", "robustness", "acceptance")


def test_the_suite_is_at_most_twenty_two_scripts_none_editing_the_path():
    # 22: issue 58's switching.py (the switching analysis's acceptance: its own
    # parts, not an extension of bistability.py's fold lengths) and issue 59's
    # speed_profile.py (where the time of a fold curve, a row, a solve goes, by
    # stage and operation), which no other script's part fits
    assert len(SCRIPTS) <= 22, SCRIPTS
    for name in SCRIPTS:
        text = open(os.path.join(BENCH, name)).read()
        assert "sys.path" not in text, f"{name} edits sys.path (import harness instead)"
        if name != "harness.py":
            assert "argparse.ArgumentParser(" not in text, f"{name}: use harness.parser"


def test_the_readme_describes_every_script_in_a_suite():
    readme = open(os.path.join(BENCH, "README.md")).read()
    for name in SCRIPTS:
        assert f"`{name}`" in readme or f"{name[:-3]}.py" in readme, name
    assert all(f"## {s.capitalize()}" in readme for s in SUITES)
    assert "asv" in readme       # what was chosen for tracking speed, and why


@pytest.mark.parametrize("name", [s for s in SCRIPTS if s != "harness.py"])
def test_every_script_says_how_it_is_run(name, capsys):
    """``--help`` exits 0 and prints the script's docstring, which names its command."""
    mod = _bench_module(name)
    with pytest.raises(SystemExit) as exc:
        mod.main(["--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    assert out.startswith("usage: ") and f"benchmarks/{name}" in out


def test_the_parser_helper_takes_the_docstring():
    ap = bench.parser("First line.\n\n    python benchmarks/x.py [--n N]\n\nMore.")
    ap.add_argument("--n", type=int, default=3)
    assert ap.description == "First line." and "python benchmarks/x.py" in ap.epilog
    assert ap.parse_args(["--n", "5"]).n == 5
    with pytest.raises(SystemExit):
        ap.parse_args(["--n", "five"])


def _cited_results():
    """``(file, cited path)`` of every ``benchmarks/results/...`` path cited in the
    README, docs/, the package, the tests and benchmarks/ (recorded outputs aside)."""
    import re
    import subprocess

    pattern = re.compile(r"benchmarks/results/([\w./-]*\.(?:txt|json|jsonl|csv|md))(?![\w{<*])")
    files = subprocess.run(["git", "ls-files", "README.md", "docs", "skfem_sheet", "tests",
                            "benchmarks", "notebooks"], cwd=ROOT, capture_output=True,
                           text=True, check=True).stdout.split()
    out = set()
    for f in files:
        if f.startswith("benchmarks/results/") and not f.endswith("README.md"):
            continue
        if not f.endswith((".py", ".md", ".ipynb", ".txt", ".cfg", ".toml", ".rst")):
            continue
        with open(os.path.join(ROOT, f)) as fh:
            for m in pattern.finditer(fh.read()):
                cited = m.group(1).rstrip(".")
                if "*" in cited or "<" in cited or "{" in cited:
                    continue
                out.add((f, cited))
    return out


#: Citations in modules whose owners rework them now, of results that moved into
#: the suite folders (to be updated there: benchmarks/README.md lists the new paths).
PENDING = {
    ("skfem_sheet/continuation.py", "stress_n100_seed1_hmax0.1_guard.txt"),
    ("skfem_sheet/continuation.py", "solve_cylinder_start_hmax0.1.txt"),
    ("skfem_sheet/newton.py", "snap_mip_issue17_hmax0.08.txt"),
    ("skfem_sheet/solve.py", "solve_sample_hmax0.03_coarse_vs_path.txt"),
    ("tests/test_fold_locate.py", "fold_curve_remesh_hmax0.2.txt"),
    ("tests/test_snap.py", "snap_mip_stress_silent_folds.txt"),
}


def test_every_cited_recorded_output_exists():
    results = os.path.join(BENCH, "results")
    missing = {(f, c) for f, c in _cited_results()
               if not os.path.exists(os.path.join(results, c))}
    assert missing - PENDING == set(), sorted(missing - PENDING)
    for _, c in PENDING:        # each one has moved to a suite folder, not gone
        assert sum(os.path.exists(os.path.join(results, s, c)) for s in SUITES) == 1, c
    assert set(os.listdir(results)) == {"README.md", "NOTES.md", *SUITES}
