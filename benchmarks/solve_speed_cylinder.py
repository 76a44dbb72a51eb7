"""Does the clamp's cylinder pay as the start of the curvature ramp? (issue 16)

    python benchmarks/solve_speed_cylinder.py [--hmax 0.1] [--n 12] [--seed 16]
        [--no-sample] [--max-iterations 8] [--json out.json] [--txt out.txt]

For every sheet of the seeded sample of ``benchmarks/solve_sample.py`` (and
its four cases' two sheets, rectangle and triangle), on the mesh ``hmax``:

- the ``curvature-first`` load path as it runs (``follow_path``): the
  factorisations and Newton iterations of its curvature ramp at zero gravity
  (up to the first state at full curvature) and of the whole path;
- Newton at zero gravity and full curvature from
  :func:`skfem_sheet.continuation.cylinder_state` (pressure ``zero`` and
  ``plate``) with the ramp's intermediate tolerance (``rtol = 1``,
  ``utol = intermediate_utol``) and ``--max-iterations``: converged or not,
  its factorisations, and, if converged, whether it is the ramp's state:
  both solved once more by Newton to ``rtol 1e-9, utol 1e-10`` (not counted),
  then the relative difference of the tip deflection d and the largest
  nodal difference, and the inertia of both (stable, negative eigenvalues).

A cylinder start would replace the ramp's factorisations by its own where it
converges to the same state, and add them to the ramp's where it fails (the
fall-back): the summary gives both sums.
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys
import time

import numpy as np

from _common import fmt, machine_info

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

from solve_sample import CASES, sample_sheets  # noqa: E402

from skfem_sheet import Sheet  # noqa: E402
from skfem_sheet.analyses.observables import tip_deflection  # noqa: E402
from skfem_sheet.analyses.stability import stability  # noqa: E402
from skfem_sheet.continuation import StepOptions, cylinder_state, follow_path  # noqa: E402
from skfem_sheet.io import atomic_write, dumps_json  # noqa: E402
from skfem_sheet.linalg import make_linear_solver  # noqa: E402
from skfem_sheet.newton import NewtonOptions, Stats, newton  # noqa: E402
from skfem_sheet.solve import build_problem  # noqa: E402

TIGHT = NewtonOptions(rtol=1e-9, utol=1e-10, max_iterations=30)


def _tight(problem, w):
    """``w`` solved by Newton at zero gravity to :data:`TIGHT`, and its inertia."""
    lin = make_linear_solver("auto")
    res = newton(problem, w, 0.0, lin, TIGHT, Stats())
    return res, stability(problem, lin)


def one(params, hmax, max_iterations):
    """The measurements of one sheet (a JSON-ready dict)."""
    sheet = Sheet(**params)
    kappa = sheet.curvature
    problem = build_problem(sheet, hmax, None, 2, True, 0)
    stats, ramp = Stats(), {}

    def on_step(pr, w, k, g):
        if g == 0.0 and k == kappa and "w" not in ramp:
            ramp.update(w=w.copy(), factorizations=stats.factorizations,
                        newton_iterations=stats.newton_iterations)

    t0 = time.perf_counter()
    out = follow_path(problem, "curvature-first", kappa, make_linear_solver("auto"),
                      stats=stats, on_step=on_step)
    row = dict(parameters=params, hmax=hmax, dofs=int(problem.ndof), converged=out.converged,
               ramp_factorizations=ramp.get("factorizations"),
               ramp_newton_iterations=ramp.get("newton_iterations"),
               ramp_steps=sum(1 for s in out.steps if s[0] == "curvature"),
               path_factorizations=stats.factorizations,
               path_newton_iterations=stats.newton_iterations,
               path_wall_s=time.perf_counter() - t0)
    ref, ref_inertia = _tight(problem, ramp["w"])
    d_ref = tip_deflection(problem, ref.w)
    row.update(ramp_d_polished=d_ref, ramp_stable=ref_inertia[0],
               ramp_negative_eigenvalues=ref_inertia[1])
    loose = NewtonOptions(rtol=1.0, utol=StepOptions().intermediate_utol,
                          max_iterations=max_iterations)
    nu = problem.nu_dof
    for pressure in ("zero", "plate"):
        st = Stats()
        res = newton(problem, cylinder_state(problem, kappa, pressure), 0.0,
                     make_linear_solver("auto"), loose, st)
        rec = dict(converged=bool(res.converged), reason=res.reason,
                   factorizations=st.factorizations, newton_iterations=st.newton_iterations)
        if res.converged:
            pol, inertia = _tight(problem, res.w)
            d = tip_deflection(problem, pol.w)
            rec.update(d_polished=d, d_relative_difference=abs(d - d_ref) / abs(d_ref),
                       max_node_difference=float(np.abs(pol.w[:nu] - ref.w[:nu]).max()),
                       stable=inertia[0], negative_eigenvalues=inertia[1],
                       same_state=bool(abs(d - d_ref) <= 1e-6 * abs(d_ref)
                                       and inertia == ref_inertia))
        row[f"cylinder_{pressure}"] = rec
    return row


def summarise(rows):
    """Sums over the sheets: the ramp's factorisations, and a cylinder start's
    (its own where it reached the ramp's state, its own plus the ramp's where not)."""
    out = dict(n=len(rows), ramp_factorizations=sum(r["ramp_factorizations"] for r in rows),
               path_factorizations=sum(r["path_factorizations"] for r in rows),
               median_ramp_factorizations=statistics.median(r["ramp_factorizations"]
                                                            for r in rows),
               median_path_factorizations=statistics.median(r["path_factorizations"]
                                                            for r in rows))
    for pressure in ("zero", "plate"):
        total, same, conv = 0, 0, 0
        for r in rows:
            c = r[f"cylinder_{pressure}"]
            conv += c["converged"]
            if c.get("same_state"):
                total += c["factorizations"]
                same += 1
            else:
                total += c["factorizations"] + r["ramp_factorizations"]
        out[f"cylinder_{pressure}"] = dict(converged=conv, same_state=same,
                                           start_factorizations=total)
    return out


def table(rows, summary):
    lines = [f"{'L':>6} {'b':>6} {'a/R':>6} {'ramp f':>6} {'path f':>6} {'d0 ramp':>9} "
             f"{'cyl0 f':>6} {'cyl0':>22} {'cylp f':>6} {'cylp':>22}"]
    for r in rows:
        p = r["parameters"]
        cells = []
        for pressure in ("zero", "plate"):
            c = r[f"cylinder_{pressure}"]
            what = (f"same, dd {c['d_relative_difference']:.1e}" if c.get("same_state")
                    else ("OTHER state" if c["converged"] else c["reason"]))
            cells.append(f"{c['factorizations']:>6} {what:>22}")
        lines.append(f"{p['length']:>6.4g} {p['tip_width']:>6.4g} {p['curvature']:>6.4g} "
                     f"{r['ramp_factorizations']:>6} {r['path_factorizations']:>6} "
                     f"{fmt(r['ramp_d_polished'], '9.5f')} " + " ".join(cells))
    s = summary
    lines.append("")
    lines.append(f"sum over {s['n']} sheets: ramp factorisations {s['ramp_factorizations']} "
                 f"(median {s['median_ramp_factorizations']}), whole curvature-first path "
                 f"{s['path_factorizations']} (median {s['median_path_factorizations']})")
    for pressure in ("zero", "plate"):
        c = s[f"cylinder_{pressure}"]
        lines.append(f"cylinder start, pressure {pressure}: converged {c['converged']}, the "
                     f"ramp's state {c['same_state']} of {s['n']}; factorisations to full "
                     f"curvature with fall-back to the ramp {c['start_factorizations']} "
                     f"(ramp alone {s['ramp_factorizations']})")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--hmax", type=float, default=0.1)
    ap.add_argument("--n", type=int, default=12)
    ap.add_argument("--seed", type=int, default=16)
    ap.add_argument("--no-sample", action="store_true", help="only the two case sheets")
    ap.add_argument("--max-iterations", type=int, default=NewtonOptions().max_iterations)
    ap.add_argument("--json")
    ap.add_argument("--txt")
    args = ap.parse_args(argv)
    sheets = [] if args.no_sample else sample_sheets(args.n, args.seed)
    sheets += [dict(kw) for _, kw in CASES]
    rows = []
    for params in sheets:
        rows.append(one(params, args.hmax, args.max_iterations))
        print(table(rows[-1:], summarise(rows[-1:])).splitlines()[1], flush=True)
    summary = summarise(rows)
    text = (f"python benchmarks/solve_speed_cylinder.py {' '.join(argv or sys.argv[1:])}\n"
            f"{machine_info()}\n\n" + table(rows, summary))
    print(text)
    if args.txt:
        atomic_write(args.txt, text + "\n")
    if args.json:
        atomic_write(args.json, dumps_json(dict(command=text.splitlines()[0], settings=vars(args),
                                                rows=rows, summary=summary)))


if __name__ == "__main__":
    main()
