"""The verification report (``docs/verification.md``) is generated from the recorded
benchmark outputs and kept in sync with them (issue 13, item 4)."""
import importlib.util
import json
import os
import shutil
import sys

import pytest

_PATH = os.path.join(os.path.dirname(__file__), os.pardir, "benchmarks", "verification_report.py")
_spec = importlib.util.spec_from_file_location("verification_report", _PATH)
report = importlib.util.module_from_spec(_spec)
sys.modules[_spec.name] = report       # its dataclass looks its module up
_spec.loader.exec_module(report)


def test_committed_report_is_the_report_of_the_recorded_outputs():
    assert report.main(["--check"]) == 0


def test_every_check_has_a_value_a_tolerance_a_command_and_a_verdict():
    checks = report.collect()
    assert len(checks) >= 15
    sections = {c.section for c in checks}
    assert len(sections) == len(report.SECTIONS)
    for c in checks:
        assert c.status in report.STATUSES
        assert c.command.startswith(("python ", "cd benchmarks && python "))
        assert c.tolerance and c.value
    text = report.render(checks)
    for c in checks:
        assert f"**{c.status}**" in text


@pytest.fixture
def results_copy(tmp_path):
    dst = tmp_path / "results"
    shutil.copytree(report.RESULTS, dst)
    return dst


def test_check_fails_when_a_recorded_output_changes(results_copy, tmp_path):
    out = tmp_path / "verification.md"
    assert report.main(["--results", str(results_copy), "--output", str(out)]) == 0
    assert report.main(["--results", str(results_copy), "--output", str(out), "--check"]) == 0
    path = results_copy / "accuracy" / "manufactured.json"
    doc = json.loads(path.read_text())
    doc["rates"]["u_l2"] = 2.0          # below the P2 target: the check must turn to FAIL
    path.write_text(json.dumps(doc))
    assert report.main(["--results", str(results_copy), "--output", str(out), "--check"]) == 1
    failed = [c for c in report.collect(str(results_copy)) if c.status == report.FAIL]
    assert [c.source for c in failed] == ["accuracy/manufactured.json"]
    assert "2.000" in failed[0].value


def test_missing_outputs_are_reported_missing_not_passed(results_copy):
    os.remove(results_copy / "accuracy" / "thick_L1_aR2.5_h0.1.json")
    os.remove(results_copy / "acceptance" / "solver_acceptance_hmax0.03.txt")
    checks = report.collect(str(results_copy))
    missing = {c.source for c in checks if c.status == report.MISSING}
    assert {"accuracy/thick_L1_aR2.5_h0.1.json", "acceptance/solver_acceptance_hmax0.03.txt"} <= missing


def test_fold_convergence_records_are_read_when_present(results_copy):
    doc = {"curvatures": [{"curvature": 2.5, "meshes": [
        {"hmax": 0.06, "popup_length": 0.812, "standout_length": 1.403},
        {"hmax": 0.045, "popup_length": 0.809, "standout_length": 1.395}]}]}
    (results_copy / "accuracy" / "fold_convergence.json").write_text(json.dumps(doc))
    folds = [c for c in report.collect(str(results_copy)) if c.source == "accuracy/fold_convergence.json"]
    assert [(c.value, c.status) for c in folds] == [("0.0030", report.PASS),
                                                     ("0.0080", report.FAIL)]
