"""Acceptance numbers of issue 14 (any planform), at coarse meshes.

Run from the repository root: ``PYTHONPATH=. python benchmarks/planform_acceptance.py [part ...]``
with parts ``sampled``, ``flare``, ``elastica``, ``bites`` (default: all).  Each part
writes ``benchmarks/results/planform_<part>.json`` (one record per solve, the
table rewritten after every solve) and prints a short table.  The bitten-triangle
part also saves pictures under ``benchmarks/results/``.

- sampled: a trapezoid given as sampled points (3 samples, PCHIP) against the
  trapezoid itself, 3D (hmax 0.1) on both load paths and every reduced model;
  plus the same samples perturbed by 1e-9 (which forces the spline outline and an
  unrelated mesh) to show the size of the mesh-to-mesh noise the exact match avoids.
- flare: b/a = 1.5 against b/a = 1, 3D (hmax 0.1, curvature-first) against the
  ribbon model at L/a = 1.0 and 1.3, a/R = 0 and 2.5.
- elastica: the heavy elastica at a/R = 0, L/a = 1 against the 3D flat sheet at
  hmax 0.06 for b/a = 1.5 and 1.
- bites: the triangle at L/a = 1.3, a/R = 2.5 with no, one and two bites
  (radius 0.25 each), both load paths at hmax 0.1, with the ribbon model.
"""
from __future__ import annotations

import os
import sys
import time

from skfem_sheet.io import atomic_write, dumps_json
from skfem_sheet.params import Planform, Sheet
from skfem_sheet.reduced import (cantilever_deflection, elastica, persistence_length,
                                 ribbon)
from skfem_sheet.solve import solve

HERE = os.path.dirname(os.path.abspath(__file__))
RESULTS = os.path.join(HERE, "results")
PATHS = ("curvature-first", "gravity-first")


def _save(part, rows):
    atomic_write(os.path.join(RESULTS, f"planform_{part}.json"), dumps_json(rows, indent=2))


def _solve(sheet, path, hmax):
    t = time.perf_counter()
    r = solve(sheet, path=path, hmax=hmax, on_failure="return")
    return r, {"path": path, "hmax": hmax, "deflection": r.deflection,
               "converged": bool(r.converged), "seconds": round(time.perf_counter() - t, 1)}


def _reduced(sheet):
    return {"elastica": elastica(sheet).deflection,
            "ribbon_curvature": ribbon(sheet, "curvature").deflection,
            "ribbon_gravity": ribbon(sheet, "gravity").deflection,
            "persistence_length": persistence_length(sheet).persistence_length,
            "cantilever": cantilever_deflection(sheet, include_curved_part=True).deflection}


def sampled():
    rows = []
    L, b, k = 1.3, 0.6, 2.5
    x = [0.0, 0.5, L]
    w = [1.0 + (b - 1.0) * xi / L for xi in x]
    cases = {"trapezoid": Sheet(L, b, k),
             "sampled": Sheet.from_planform(Planform.from_samples(x, w), curvature=k),
             "sampled_perturbed_1e-9": Sheet.from_planform(
                 Planform.from_samples(x, [w[0], w[1] + 1e-9, w[2]]), curvature=k)}
    red = {}
    for name, s in cases.items():
        red[name] = _reduced(s)
        for path in PATHS:
            _, rec = _solve(s, path, 0.1)
            rows.append({"case": name, **rec, **red[name]})
            _save("sampled", rows)
    base = {(r["path"]): r for r in rows if r["case"] == "trapezoid"}
    print("case                     path              d_3D           |d - d_trapezoid|")
    for r in rows:
        print(f"{r['case']:24s} {r['path']:16s} {r['deflection']:.10f}  "
              f"{abs(r['deflection'] - base[r['path']]['deflection']):.2e}")
    for key in red["trapezoid"]:
        print(f"reduced {key:20s} |sampled - trapezoid| = "
              f"{abs(red['sampled'][key] - red['trapezoid'][key]):.2e}")


def flare():
    rows = []
    for L in (1.0, 1.3):
        for k in (0.0, 2.5):
            for b in (1.0, 1.5):
                s = Sheet.from_planform(Planform.trapezoid(b), length=L, curvature=k)
                _, rec = _solve(s, "curvature-first", 0.1)
                rb = ribbon(s, "curvature")
                rows.append({"length": L, "curvature": k, "tip_width": b, **rec,
                             "ribbon": rb.deflection, "ribbon_converged": rb.converged,
                             "relative_difference": (rb.deflection - rec["deflection"])
                             / abs(rec["deflection"])})
                _save("flare", rows)
    print(" L    a/R   b/a   d_3D(h0.1)  d_ribbon   (ribbon-3D)/|3D|")
    for r in rows:
        print(f"{r['length']:.1f}  {r['curvature']:.1f}  {r['tip_width']:.1f}  "
              f"{r['deflection']:.5f}   {r['ribbon']:.5f}   {100 * r['relative_difference']:+.2f}%")


def elastica_part():
    rows = []
    for b in (1.5, 1.0):
        s = Sheet.from_planform(Planform.trapezoid(b), length=1.0)
        _, rec = _solve(s, "curvature-first", 0.06)
        e = elastica(s).deflection
        rows.append({"tip_width": b, **rec, "elastica": e,
                     "relative_difference": (rec["deflection"] - e) / e})
        _save("elastica", rows)
    for r in rows:
        print(f"b/a {r['tip_width']:.1f}: d_3D(h0.06) {r['deflection']:.5f}, elastica "
              f"{r['elastica']:.5f}, 3D above elastica by {100 * r['relative_difference']:.2f}%")


def bites():
    from skfem_sheet.plot import plot_sheet
    rows = []
    cases = {"triangle": (), "one bite": (0.25,), "two bites": (0.25, 0.25)}
    for name, bt in cases.items():
        s = Sheet.from_planform(Planform.trapezoid(0.0, bites=bt), length=1.3, curvature=2.5)
        red = {"ribbon_curvature": ribbon(s, "curvature").deflection,
               "ribbon_gravity": ribbon(s, "gravity").deflection, "elastica": elastica(s).deflection}
        for path in PATHS:
            r, rec = _solve(s, path, 0.1)
            rows.append({"case": name, "bites": list(bt), "extent": s.extent, "area": s.area,
                         **rec, **red})
            _save("bites", rows)
            if r.converged:
                tag = name.replace(" ", "_")
                plot_sheet(r, os.path.join(RESULTS, f"planform_{tag}_{path}.png"),
                           title=f"{name}, L/a = 1.3, a/R = 2.5, {path}, d = {r.deflection:.3f}")
    print("case        path              d_3D(h0.1)  conv  ribbon(c/g)          extent  area")
    for r in rows:
        print(f"{r['case']:10s}  {r['path']:16s}  {r['deflection']:.5f}   {r['converged']!s:5s} "
              f"{r['ribbon_curvature']:.4f}/{r['ribbon_gravity']:.4f}  {r['extent']:.3f}  {r['area']:.3f}")


PARTS = {"sampled": sampled, "flare": flare, "elastica": elastica_part, "bites": bites}

if __name__ == "__main__":
    for part in sys.argv[1:] or list(PARTS):
        PARTS[part]()
