"""One verification report, generated from the recorded benchmark outputs (issue 13, item 4).

    python benchmarks/verification_report.py            # writes docs/verification.md
    python benchmarks/verification_report.py --check    # exit 1 if docs/verification.md differs
    python benchmarks/verification_report.py --results DIR --output FILE

Nothing is solved here: every check reads a file in ``benchmarks/results/``
(the outputs recorded by the benchmarks, see ``benchmarks/results/README.md``)
and states its value, its tolerance, the command that reproduces the recorded
output, and the verdict:

- ``PASS`` / ``FAIL``: the value meets / misses the tolerance;
- ``UNDETERMINED``: the recorded study cannot decide (an order with a standard
  error too large to say whether it meets the target);
- ``MISSING``: the recorded output is absent (not yet run, or renamed).

The report is deterministic (no dates, no machine state), so ``--check``
regenerates it and compares it with the committed ``docs/verification.md``:
a change of a recorded output, of a tolerance or of this script without
regenerating the report is caught (``tests/test_verification_report.py``).
"""
from __future__ import annotations

import glob
import json
import os
import re
import sys
from dataclasses import dataclass

from harness import parser

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
RESULTS = os.path.join(HERE, "results")
OUTPUT = os.path.join(ROOT, "docs", "verification.md")

PASS, FAIL, UNDETERMINED, MISSING = "PASS", "FAIL", "UNDETERMINED", "MISSING"
STATUSES = (PASS, FAIL, UNDETERMINED, MISSING)


@dataclass(frozen=True)
class Check:
    """One line of the report."""

    section: str
    name: str
    value: str
    tolerance: str
    status: str
    source: str
    command: str


def _verdict(ok):
    return PASS if ok else FAIL


def _load_json(results, name):
    path = os.path.join(results, name)
    if not os.path.exists(path):
        return None
    with open(path) as f:
        return json.load(f)


def _read_text(results, name):
    path = os.path.join(results, name)
    if not os.path.exists(path):
        return None
    with open(path) as f:
        return f.read()


def _missing(section, name, tolerance, source, command):
    return Check(section, name, "-", tolerance, MISSING, source, command)


# ----------------------------------------------------------------------------
# the sections
# ----------------------------------------------------------------------------
def manufactured_checks(results):
    section = "Manufactured solution (Taylor-Hood P2-P1 order)"
    src, cmd = "accuracy/manufactured.json", "python benchmarks/manufactured.py"
    labels = {"u_l2": "rate of the U error in L2", "u_h1": "rate of the U error in H1",
              "p_l2": "rate of the p error in L2",
              "tip": "rate of the tip U_z error at (L, 0, 0)"}
    doc = _load_json(results, src)
    out = []
    for key, label in labels.items():
        if doc is None:
            out.append(_missing(section, label, "-", src, cmd))
            continue
        rate, target = doc["rates"][key], doc["targets"][key]
        h = [m["h"] for m in doc["meshes"]][-doc["fit_last"]:]
        out.append(Check(section, f"{label} (fitted over h = {', '.join(f'{x:g}' for x in h)})",
                         "-" if rate is None else f"{rate:.3f}", f">= {target:g}",
                         _verdict(rate is not None and rate >= target), src, cmd))
    if doc is not None:
        fin = doc["meshes"][-1]
        out.append(Check(section, f"relative L2 error of U on the finest mesh (h = {fin['h']:g})",
                         f"{fin['u_l2'] / fin['u_l2_norm']:.2e}", "< 1e-3",
                         _verdict(fin["u_l2"] / fin["u_l2_norm"] < 1e-3), src, cmd))
    return out


def thick_checks(results):
    section = "Tip deflection on a thick sheet in the asymptotic range (h/a 0.1, a/R 2.5, L/a 1)"
    src, cmd = "accuracy/thick_L1_aR2.5_h0.1.json", "python benchmarks/thick_convergence.py"
    doc = _load_json(results, src)
    if doc is None or "families" not in doc:
        return [_missing(section, "observed order of d, nested family 1", ">= 1.8", src, cmd)]
    out = []
    for k, fam in enumerate(doc["families"], 1):
        hs = ", ".join(f"{m['h']:g}" for m in fam["meshes"])
        p = fam["richardson_order"]
        out.append(Check(section, f"observed order of d, nested family {k} (h = {hs})",
                         "-" if p is None else f"{p:.3f}", f">= {doc['target_order']:g}",
                         _verdict(p is not None and p >= doc["target_order"]), src, cmd))
    lims = [f["extrapolated"] for f in doc["families"] if f["extrapolated"] is not None]
    joint = doc.get("joint_fit")
    if joint and len(lims) > 1:
        spread = (max(lims) - min(lims)) / abs(joint["extrapolated"])
        out.append(Check(section, "spread of the families' Richardson values, relative "
                         f"(d_inf = {', '.join(f'{x:.5f}' for x in lims)})",
                         f"{100 * spread:.2f}%", "<= 1%", _verdict(spread <= 0.01), src, cmd))
        fin = min(joint["errors"], key=lambda e: e["h"])
        out.append(Check(section, f"error of the finest mesh (h = {fin['h']:g}) against the "
                         f"joint limit {joint['extrapolated']:.5f}",
                         f"{100 * fin['relative_error']:+.2f}%", "within 1%",
                         _verdict(abs(fin["relative_error"]) <= 0.01), src, cmd))
    return out


def paper_case_checks(results):
    section = "Tip deflection on the paper's case (L/a 1.8, a/R 5, h/a 0.03)"
    src = "accuracy/convergence_fit_L1.8_aR5.json"
    r = "benchmarks/results/accuracy/"
    cmd = (f"python benchmarks/convergence.py fit {r}convergence_nested_L1.8_aR5.json "
           f"{r}convergence_nested_base0.14_L1.8_aR5.json "
           f"{r}convergence_nested_base0.12_L1.8_aR5.json --max-h 0.12 "
           f"--json {r}convergence_fit_L1.8_aR5.json")
    doc = _load_json(results, src)
    if doc is None:
        return [_missing(section, "observed order of d (three nested families)", ">= 1.8",
                         src, cmd)]
    p, se = doc["observed_order"], doc["observed_order_se"]
    status = (UNDETERMINED if not doc.get("order_determined", se <= 0.2)
              else _verdict(p >= 1.8))
    out = [Check(section, f"observed order of d, two-term fit of three nested families "
                 f"(h <= {doc['max_h']:g})", f"{p:.2f} +- {se:.2f}", ">= 1.8 (se <= 0.2)",
                 status, src, cmd)]
    chk = doc.get("check") or {}
    err = chk.get("error_vs_extrapolated")
    if err is not None:
        out.append(Check(section, f"default mesh hmax {chk['hmax']:g} ({chk['layers']} layers) "
                         f"against the extrapolated d_inf = {doc['extrapolated']:.5f}",
                         f"{100 * err:+.3f}%", "within 1%", _verdict(abs(err) <= 0.01), src,
                         cmd))
    return out


_RIBBON_ROW = re.compile(r"^\s*(\d\.\d)\s+(\d\.\d\d)\s+([\d.]+)\s+([\d.]+)\s+([+-][\d.]+)%\s+"
                         r"([+-][\d.]+)%\s+\S+\s+\S+\s+([+-][\d.]+)%\s*$")
_S_CONV = re.compile(r"^\s*b=(\d) L=([\d.]+): (.*)$")


def reduced_checks(results):
    section = "Reduced-model limits (ribbon and heavy elastica)"
    src = "accuracy/ribbon_vs_elastica.txt"
    cmd = "python benchmarks/ribbon_vs_elastica.py --with-3d"
    text = _read_text(results, src)
    if text is None:
        return [_missing(section, "ribbon with nu = 0 equals the heavy elastica", "-", src, cmd)]
    rows = []
    for line in text.splitlines():
        m = _RIBBON_ROW.match(line)
        if m:
            b, L, _, _, rel, _, rel0 = (float(x) for x in m.groups())
            rows.append((b, L, rel / 100, rel0 / 100))
    out = []
    rect = [r for r in rows if r[0] == 1.0]
    if rect:
        worst0 = max(abs(r[3]) for r in rect)
        out.append(Check(section, "rectangle, a/R = 0: ribbon with nu = 0 against the heavy "
                         f"elastica, largest |relative difference| over L = "
                         f"{rect[0][1]:g}..{rect[-1][1]:g}", f"{worst0:.1e} (printed to 1e-7)", "<= 1e-6",
                         _verdict(worst0 <= 1e-6), src, cmd))
        long = [r for r in rect if r[1] >= 0.75]
        worst = max(abs(r[2]) for r in long)
        out.append(Check(section, "rectangle, a/R = 0: ribbon (free c, nu = 1/2) against the "
                         "heavy elastica, largest |relative difference| for L >= 0.75",
                         f"{100 * worst:.3f}%", "<= 0.5%", _verdict(worst <= 5e-3), src, cmd))
    tri = [r for r in rows if r[0] == 0.0]
    if tri:
        last = tri[-1]
        out.append(Check(section, f"triangle, a/R = 0: ribbon against the heavy elastica at the "
                         f"longest L = {last[1]:g}", f"{100 * last[2]:+.3f}%", "< 0.5%",
                         _verdict(last[2] < 5e-3), src, cmd))
    changes = []
    for line in text.splitlines():
        m = _S_CONV.match(line)
        if m:
            vals = [float(v) for v in re.findall(r"n=\d+: ([+-][\d.]+)%", m.group(3))]
            if len(vals) >= 2:
                changes.append(abs(vals[-1] - vals[-2]) / 100)
    if changes:
        out.append(Check(section, "ribbon discretisation: change of d / d_elastica between the "
                         "two finest s-meshes (n = 96, 192), largest over the cases",
                         f"{max(changes):.1e}", "<= 1e-6", _verdict(max(changes) <= 1e-6),
                         src, cmd))
    if not out:
        out.append(Check(section, "ribbon against the heavy elastica", "-", "-", MISSING, src,
                         cmd + " (format not understood)"))
    return out


_ACCEPT_ROW = re.compile(r"^(flat rectangle|rectangle|triangle)\s+(curvature-first|gravity-first)"
                         r"\s+(\S+)\s+\d+\s+\d+\s+\S+\s+\S+\s+\S+\s+(\d+)\s+(\S+)\s+(\S+)\s*$")
_FLAT = re.compile(r"flat rectangle: d = ([\d.]+), heavy elastica \(plate modulus\) ([\d.]+)")


def solver_checks(results):
    section = "3D solver: analytic limit, branches and invariants (hmax 0.03)"
    src, cmd = "acceptance/solver_acceptance_hmax0.03.txt", "python benchmarks/solver_acceptance.py"
    text = _read_text(results, src)
    if text is None:
        return [_missing(section, "flat rectangle against the heavy elastica", "-", src, cmd)]
    rows = [m.groups() for m in map(_ACCEPT_ROW.match, text.splitlines()) if m]
    out = []
    m = _FLAT.search(text)
    if m:
        d, ref = float(m.group(1)), float(m.group(2))
        rel = d / ref - 1
        out.append(Check(section, "flat rectangle L/a = 1 against the heavy elastica with plate "
                         "modulus", f"{100 * rel:+.2f}%", "within 0.5%",
                         _verdict(abs(rel) <= 5e-3), src, cmd))
    by = {(r[0], r[1]): float(r[2]) for r in rows}
    up, down = by.get(("rectangle", "curvature-first")), by.get(("rectangle", "gravity-first"))
    if up is not None and down is not None:
        out.append(Check(section, "rectangle a/R = 2.5, L/a = 1.3: the two load paths end on two "
                         "branches (curvature-first |d|, gravity-first d)",
                         f"{abs(up):.4f}, {down:.4f}", "|d| < 0.1 and d > 0.5",
                         _verdict(abs(up) < 0.1 and down > 0.5), src, cmd))
    t1, t2 = by.get(("triangle", "curvature-first")), by.get(("triangle", "gravity-first"))
    if t1 is not None and t2 is not None:
        rel = abs(t1 / t2 - 1)
        out.append(Check(section, "triangle a/R = 2.5, L/a = 1.3 (not bistable): both load paths "
                         "agree", f"{100 * rel:.3f}%", "<= 0.01%", _verdict(rel <= 1e-4), src,
                         cmd))
    if rows:
        dv = max(abs(float(r[4])) for r in rows)
        out.append(Check(section, f"volume change |dV/V| (incompressibility), largest over the "
                         f"{len(rows)} solves", f"{dv:.1e}", "< 1e-6", _verdict(dv < 1e-6), src,
                         cmd))
        asym = max(abs(float(r[5])) for r in rows)
        out.append(Check(section, f"mirror symmetry: largest |U_z(y) - U_z(-y)| on the free edge "
                         f"over the {len(rows)} solves", f"{asym:.1e}", "< 1e-12",
                         _verdict(asym < 1e-12), src, cmd))
    if not out:
        out.append(Check(section, "solver acceptance", "-", "-", MISSING, src,
                         cmd + " (format not understood)"))
    return out


def _fold_cases(doc):
    """``(curvature, meshes)`` pairs of a fold-convergence record, whatever the nesting
    (``cases`` / ``curvatures`` lists, or a mapping keyed by curvature)."""
    found = []
    if isinstance(doc, dict):
        if "meshes" in doc and "curvature" in doc:
            return [(doc["curvature"], doc["meshes"])]
        for key, val in doc.items():
            sub = _fold_cases(val)
            if not sub and isinstance(val, dict) and "meshes" in val:
                try:
                    sub = [(float(key), val["meshes"])]
                except ValueError:
                    sub = []
            found += sub
    elif isinstance(doc, list):
        for item in doc:
            found += _fold_cases(item)
    return found


def fold_checks(results):
    section = "Fold lengths (pop-up L0*, standout L1*) under mesh refinement"
    cmd = "python benchmarks/fold_convergence.py"
    files = sorted(os.path.relpath(p, results) for p in glob.glob(
        os.path.join(results, "accuracy", "fold_convergence*.json")))
    out = []
    for src in files:
        doc = _load_json(results, src)
        for kappa, meshes in _fold_cases(doc):
            meshes = [m for m in meshes if isinstance(m, dict)]
            for key, label in (("popup_length", "L0*"), ("standout_length", "L1*")):
                vals = [m for m in meshes if m.get(key) is not None]
                if len(vals) < 2:
                    continue
                a, b = vals[-2], vals[-1]
                diff = abs(b[key] - a[key])
                out.append(Check(section, f"a/R = {float(kappa):g}: change of {label} between "
                                 "the two finest meshes", f"{diff:.4f}", "<= 0.005",
                                 _verdict(diff <= 0.005), src, cmd))
    if not out:
        out.append(_missing(section, "change of L0*, L1* between the two finest meshes "
                            "(a/R = 2.5, 5)", "<= 0.005", "fold_convergence*.json", cmd))
    return out


SECTIONS = (manufactured_checks, thick_checks, paper_case_checks, fold_checks, reduced_checks,
            solver_checks)


def collect(results=RESULTS):
    """All checks, in report order."""
    return [c for section in SECTIONS for c in section(results)]


def _cell(text):
    return str(text).replace("|", "\\|")


def render(checks):
    """The Markdown report."""
    counts = {s: sum(c.status == s for c in checks) for s in STATUSES}
    lines = [
        "# Verification report",
        "",
        "Generated by `python benchmarks/verification_report.py` from the outputs recorded in",
        "`benchmarks/results/`; do not edit by hand. `python benchmarks/verification_report.py "
        "--check`",
        "(run by `tests/test_verification_report.py`) fails when this file is not what the recorded",
        "outputs give. Each check names the recorded file it reads and the command that",
        "reproduces that file. UNDETERMINED: the recorded study cannot decide; MISSING: the",
        "output has not been recorded.",
        "",
        f"**{len(checks)} checks: " + ", ".join(f"{counts[s]} {s}" for s in STATUSES) + "**",
        "",
    ]
    section = None
    for c in checks:
        if c.section != section:
            section = c.section
            lines += ["", f"## {section}", "",
                      "| check | value | tolerance | status | recorded in | command |",
                      "|---|---|---|---|---|---|"]
        lines.append(f"| {_cell(c.name)} | {_cell(c.value)} | {_cell(c.tolerance)} | "
                     f"**{c.status}** | `{_cell(c.source)}` | `{_cell(c.command)}` |")
    return "\n".join(lines) + "\n"


def main(argv=None):
    ap = parser(__doc__)
    ap.add_argument("--results", default=RESULTS, help="folder of the recorded outputs")
    ap.add_argument("--output", default=OUTPUT, help="the report (default docs/verification.md)")
    ap.add_argument("--check", action="store_true",
                    help="write nothing; exit 1 if the report differs from --output")
    args = ap.parse_args(argv)
    text = render(collect(args.results))
    if args.check:
        old = None
        if os.path.exists(args.output):
            with open(args.output) as f:
                old = f.read()
        if old != text:
            print(f"{args.output} is not the report of the recorded outputs: regenerate it with "
                  "python benchmarks/verification_report.py", file=sys.stderr)
            return 1
        print(f"{args.output} is up to date")
        return 0
    from skfem_sheet.io import atomic_write

    atomic_write(args.output, text)
    print(f"wrote {args.output}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
