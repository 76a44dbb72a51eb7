"""Coarse-to-fine starts against the load path on the fine mesh, from solve_sample runs.

    python benchmarks/solve_sample_compare.py RUN.json [RUN.json ...] [--base path]
        [--other coarse] [--txt out.txt] [--json out.json]
    python benchmarks/solve_sample_compare.py OLD.json NEW.json --by-run [--txt ...]

Reads ``benchmarks/solve_sample.py`` outputs run with two variants, e.g.
``--variant path='{"start": "path"}' --variant coarse='{"start": "coarse"}'
--polish``, pairs the solves of one sheet and path, and reports per pair and
over all: the branch of each (same?), the relative difference in d as solved
and after the tight polish (``deflection_polished``: the same equilibrium
gives round-off), the fine-mesh factorisations of each and the coarse path's,
the walls, where each snapped (the load parameter of its last phase: how far
a fold moves between the meshes), and whether and why the coarse start fell
back to the fine path.  Nothing is solved here.

``--by-run``: exactly two runs of one variant each (e.g. the same command
before and after a change); the first run's solves are the base (named
``--base``, default ``old``), the second's the other (``--other``, default
``new``), whatever their variants.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

from skfem_sheet.io import atomic_write, dumps_json  # noqa: E402  (after the path fix)


def pairs_of(docs, base, other, base_hmax=None, other_hmax=None):
    """``(base_row, other_row)`` per (sheet, path) over the runs ``docs``; with
    ``base_hmax``/``other_hmax`` the two come from those meshes (branches
    compared across meshes: d then differs by the discretisation error)."""
    by = {}
    across = base_hmax is not None or other_hmax is not None
    for doc in docs:
        for r in doc["rows"]:
            key = (json.dumps(r["parameters"], sort_keys=True), r["path"],
                   None if across else r["hmax"])
            for name, h in ((base, base_hmax), (other, other_hmax)):
                if r["variant"] == name and (h is None or r["hmax"] == h):
                    by.setdefault(key, {})[name] = r
    return [(d[base], d[other]) for d in by.values() if base in d and other in d]


def _rel(a, b):
    if a is None or b is None:
        return None
    return abs(a - b) / max(abs(b), 1e-300)


#: Two end states are the same equilibrium when their d agree to this after the
#: tight polish (round-off: 1e-14 seen), or, unpolished, to ``STATE_TOL_RAW``
#: (the stopping tolerance utol 1e-6 of each).
STATE_TOL_POLISHED = 1e-9
STATE_TOL_RAW = 1e-5


#: Across meshes (``--base-hmax``/``--other-hmax``) d differs by the
#: discretisation error (about 1% between hmax 0.06 and 0.03): the end states
#: are taken to be one branch within this relative difference (the branches of
#: one sheet differ by tens of per cent: 0.04 against 0.45 at L/a 1.36).
STATE_TOL_ACROSS = 0.05


def _same_state(rel_raw, rel_pol, across=False):
    if across:
        return rel_raw is not None and rel_raw <= STATE_TOL_ACROSS
    if rel_pol is not None:
        return rel_pol <= STATE_TOL_POLISHED
    return rel_raw is not None and rel_raw <= STATE_TOL_RAW


def compare(pairs, across=False):
    rows = []
    for b, o in pairs:
        both = bool(b.get("converged")) and bool(o.get("converged"))
        rel_raw = _rel(o.get("deflection"), b.get("deflection")) if both else None
        rel_pol = (_rel(o.get("deflection_polished"), b.get("deflection_polished"))
                   if both else None)
        rows.append(dict(
            same_state=both and _same_state(rel_raw, rel_pol, across),
            parameters=b["parameters"], path=b["path"], group=b["group"],
            both_converged=both, base_status=b.get("status"), other_status=o.get("status"),
            base_branch=b.get("branch"), other_branch=o.get("branch"),
            same_branch=both and b.get("branch") == o.get("branch"),
            base_d=b.get("deflection"), other_d=o.get("deflection"),
            rel_d=_rel(o.get("deflection"), b.get("deflection")) if both else None,
            rel_d_polished=_rel(o.get("deflection_polished"), b.get("deflection_polished"))
            if both else None,
            base_fact=b.get("factorizations"), other_fact=o.get("factorizations"),
            other_coarse_fact=o.get("coarse_factorizations"),
            base_wall=b.get("wall_time_s"), other_wall=o.get("wall_time_s"),
            base_snaps=b.get("snap_at"), other_snaps=o.get("snap_at"),
            fallback=o.get("coarse_fallback") or ""))
    return rows


def _med(v):
    v = [x for x in v if x is not None]
    return float(statistics.median(v)) if v else None


def summary(rows):
    conv = [r for r in rows if r["both_converged"]]
    used = [r for r in conv if not r["fallback"]]
    return dict(
        pairs=len(rows), sheets=len({json.dumps(r["parameters"], sort_keys=True) for r in rows}),
        both_converged=len(conv), same_branch=sum(r["same_branch"] for r in conv),
        same_state=sum(r["same_state"] for r in conv),
        label_only=sum(r["same_state"] and not r["same_branch"] for r in conv),
        different_branch=[r for r in conv if not r["same_branch"]],
        coarse_used=len(used), fell_back=sum(bool(r["fallback"]) for r in rows),
        fallback_reasons=sorted({r["fallback"].split(" (")[0].split(":")[0] for r in rows
                                 if r["fallback"]}),
        max_rel_d_coarse_used=max((r["rel_d"] for r in used if r["rel_d"] is not None),
                                  default=None),
        max_rel_d_polished_coarse_used=max(
            (r["rel_d_polished"] for r in used if r["rel_d_polished"] is not None), default=None),
        pairs_polished=sum(r["rel_d_polished"] is not None for r in used),
        median_base_fact=_med([r["base_fact"] for r in rows]),
        max_base_fact=max((r["base_fact"] or 0 for r in rows), default=None),
        median_other_fact=_med([r["other_fact"] for r in rows]),
        max_other_fact=max((r["other_fact"] or 0 for r in rows), default=None),
        median_other_coarse_fact=_med([r["other_coarse_fact"] for r in rows]),
        median_base_wall=_med([r["base_wall"] for r in rows]),
        median_other_wall=_med([r["other_wall"] for r in rows]),
        median_wall_ratio=_med([r["other_wall"] / r["base_wall"] for r in rows
                                if r["other_wall"] and r["base_wall"]]))


def _snap(s):
    return ",".join(f"{p[0][0]}{p[1]:.3f}" for p in s) if s else "-"


def lines_of(rows, s, base, other):
    head = (f"{'L/a':>6s} {'b/a':>6s} {'a/R':>6s} {'path':15s} {'d ' + base:>10s} "
            f"{'d ' + other:>10s} {'rel d':>8s} {'rel pol':>8s} {'branch':>9s} "
            f"{'f ' + base:>7s} {'f ' + other:>8s} {'coarse':>6s} {'snap ' + base:>12s} "
            f"{'snap ' + other:>13s}  fallback")
    out = [head, "-" * len(head)]
    for r in rows:
        p = r["parameters"]
        br = ("same " if r["same_branch"] else "DIFF ") + (r["base_branch"] or "?")[:4]
        if r["same_state"] and not r["same_branch"]:
            br = "label " + (r["base_branch"] or "?")[:3]
        elif not r["same_state"] and r["both_converged"]:
            br = "STATE " + (r["base_branch"] or "?")[:3]
        if not r["both_converged"]:
            br = f"{r['base_status']}/{r['other_status']}"
        out.append(
            f"{p['length']:6.3f} {p['tip_width']:6.3f} {p['curvature']:6.3f} {r['path']:15s} "
            f"{r['base_d'] if r['base_d'] is not None else float('nan'):10.5f} "
            f"{r['other_d'] if r['other_d'] is not None else float('nan'):10.5f} "
            f"{r['rel_d'] if r['rel_d'] is not None else float('nan'):8.1e} "
            f"{r['rel_d_polished'] if r['rel_d_polished'] is not None else float('nan'):8.1e} "
            f"{br:>9s} {r['base_fact'] or 0:7d} {r['other_fact'] or 0:8d} "
            f"{r['other_coarse_fact'] or 0:6d} {_snap(r['base_snaps']):>12s} "
            f"{_snap(r['other_snaps']):>13s}  {r['fallback']}")
    out.append(
        f"{s['pairs']} pairs ({s['sheets']} sheets), both converged {s['both_converged']}; "
        f"same branch label {s['same_branch']} of {s['both_converged']}, same end state (d "
        f"equal to {STATE_TOL_POLISHED:g} after polishing, else {STATE_TOL_RAW:g}; across "
        f"meshes to {STATE_TOL_ACROSS:g}) "
        f"{s['same_state']} ({s['label_only']} with the same state under the other label: "
        f"'label' below); the coarse state used in "
        f"{s['coarse_used']}, fell back to the fine path in {s['fell_back']} "
        f"({'; '.join(s['fallback_reasons']) or '-'})")
    out.append(
        f"where the coarse state was used: largest relative difference in d "
        f"{s['max_rel_d_coarse_used']:.2e} as solved (tolerance utol 1e-6 of each), "
        f"{s['max_rel_d_polished_coarse_used'] if s['max_rel_d_polished_coarse_used'] is not None else float('nan'):.2e}"
        f" after a tight Newton solve of both end states ({s['pairs_polished']} pairs)")
    out.append(
        f"fine-mesh factorisations: {base} median {s['median_base_fact']:g}, max "
        f"{s['max_base_fact']}; {other} median {s['median_other_fact']:g}, max "
        f"{s['max_other_fact']} (plus its coarse path: median "
        f"{s['median_other_coarse_fact']:g}); wall median {base} {s['median_base_wall']:.1f} s, "
        f"{other} {s['median_other_wall']:.1f} s (median ratio {s['median_wall_ratio']:.2f})")
    for r in s["different_branch"]:
        what = "same state, other label" if r["same_state"] else "DIFFERENT STATE"
        out.append(f"  {what}: {r['parameters']} {r['path']}: {base} {r['base_branch']} d "
                   f"{r['base_d']:.6f}, {other} {r['other_branch']} d {r['other_d']:.6f} "
                   f"(fallback: {r['fallback'] or 'none'})")
    diff = [r for r in rows if r["both_converged"] and not r["same_state"]]
    out.append(f"end states that differ: {len(diff)}")
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("runs", nargs="+", help="solve_sample.py --json outputs")
    ap.add_argument("--base", default=None, help="variant of reference (default path; "
                    "with --by-run the name of the first run, default old)")
    ap.add_argument("--other", default=None, help="variant compared (default coarse; "
                    "with --by-run the name of the second run, default new)")
    ap.add_argument("--by-run", action="store_true",
                    help="compare two runs: the first's solves against the second's")
    ap.add_argument("--base-hmax", type=float, default=None,
                    help="take the base variant at this hmax (pairs across meshes)")
    ap.add_argument("--other-hmax", type=float, default=None,
                    help="take the other variant at this hmax (pairs across meshes)")
    ap.add_argument("--txt", default=None)
    ap.add_argument("--json", default=None)
    args = ap.parse_args(argv)
    docs = []
    for f in args.runs:
        with open(f) as fh:
            docs.append(json.load(fh))
    if args.by_run:
        if len(docs) != 2:
            ap.error("--by-run compares exactly two runs")
        args.base, args.other = args.base or "old", args.other or "new"
        for doc, name in zip(docs, (args.base, args.other)):
            for r in doc["rows"]:
                r["variant"] = name
    args.base, args.other = args.base or "path", args.other or "coarse"
    across = args.base_hmax is not None or args.other_hmax is not None
    rows = compare(pairs_of(docs, args.base, args.other, args.base_hmax, args.other_hmax), across)
    if not rows:
        ap.error(f"no pairs of variants {args.base!r} and {args.other!r} in {args.runs}")
    s = summary(rows)
    loads = [d["machine"].get("load_average_at_start") for d in docs]
    head = [f"# python benchmarks/solve_sample_compare.py {' '.join(argv or sys.argv[1:])}",
            f"# from: {'; '.join(d['command'] for d in docs)}",
            f"# load average at the start of each run: {loads}",
            f"hmax {sorted({r['hmax'] for d in docs for r in d['rows']})}: variant "
            f"{args.other!r} against {args.base!r}, per sheet and path "
            "(snap: phase initial and the load parameter of the snap in it)"]
    text = "\n".join(head + lines_of(rows, s, args.base, args.other)) + "\n"
    print(text)
    if args.txt:
        atomic_write(args.txt, text)
    if args.json:
        atomic_write(args.json, dumps_json(dict(rows=rows, summary=s)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
