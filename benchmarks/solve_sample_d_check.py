"""d of the coarse start against the load path at hmax 0.03, with polished references.

    python benchmarks/solve_sample_d_check.py [COARSE.json [OUT.txt]]

Reads ``COARSE.json`` in ``benchmarks/results/`` (default
``solve_sample_hmax0.03_coarse.json``: ``solve``'s default start, every end
state polished to ``FINAL_UTOL``) and the full-path
reference ``solve_sample_hmax0.03_path.json`` (made before the polish: its d
is off by up to its Newton tolerance, ``utol = 1e-6``), with the rows it
differs most in re-run polished (``solve_sample_hmax0.03_path_polished_rows.json``,
by ``python benchmarks/solve_sample.py --hmax 0.03 --sheet 1.4963,0.8717,3.5365
--sheet 1.3,1.0,2.5 --paths curvature-first --start path --json ...``), and
writes the relative differences in d to ``OUT.txt`` there (default
``solve_sample_hmax0.03_coarse_vs_path_d.txt``).  Nothing is solved here.
"""
import json
import os
import sys

RESULTS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "results")


def _key(r):
    return json.dumps(r["parameters"], sort_keys=True), r["path"]


def _load(name):
    with open(os.path.join(RESULTS, name)) as f:
        return json.load(f)


def main(coarse="solve_sample_hmax0.03_coarse.json",
         out="solve_sample_hmax0.03_coarse_vs_path_d.txt"):
    pol = _load("solve_sample_hmax0.03_path_polished_rows.json")
    co = _load(coarse)
    old = _load("solve_sample_hmax0.03_path.json")
    ref = {_key(r): (r["deflection"], "path, unpolished (solve_sample_hmax0.03_path.json)")
           for r in old["rows"]}
    ref.update({_key(r): (r["deflection"],
                          "path, polished (solve_sample_hmax0.03_path_polished_rows.json)")
                for r in pol["rows"]})
    lines = [f"# python benchmarks/solve_sample_d_check.py {coarse} {out}",
             f"# d of start='coarse' (polished; {coarse}) against "
             "start='path' at hmax 0.03: the reference",
             "# solve_sample_hmax0.03_path.json (unpolished: d off by up to utol 1e-6), the "
             "rows it differs most in re-run polished",
             f"{'L/a':>7s} {'b/a':>7s} {'a/R':>7s} {'path':16s} {'d path':>18s} "
             f"{'d coarse':>18s} {'rel d':>8s}  reference"]
    worst = 0.0
    for r in co["rows"]:
        d_ref, what = ref[_key(r)]
        rel = abs(r["deflection"] - d_ref) / abs(d_ref)
        worst = max(worst, rel)
        p = r["parameters"]
        lines.append(f"{p['length']:7.4f} {p['tip_width']:7.4f} {p['curvature']:7.4f} "
                     f"{r['path']:16s} {d_ref:18.12f} {r['deflection']:18.12f} {rel:8.1e}  {what}")
    lines.append(f"largest relative difference in d over {len(co['rows'])} solves: {worst:.2e} "
                 f"(acceptance 1e-6)")
    text = "\n".join(lines) + "\n"
    with open(os.path.join(RESULTS, out), "w") as f:
        f.write(text)
    print(text)


if __name__ == "__main__":
    main(*sys.argv[1:3])
