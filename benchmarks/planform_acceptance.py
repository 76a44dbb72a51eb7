"""Acceptance numbers of issue 14 (any planform), at coarse meshes.

Run: ``python benchmarks/planform_acceptance.py [part ...]``
with parts ``sampled``, ``flare``, ``elastica``, ``bites`` (default: all).  Each part
writes ``benchmarks/results/acceptance/planform_<part>.json`` (one record per solve, the
table rewritten after every solve) and its table to ``planform_<part>.txt``
(``--report`` rewrites the tables from the JSON without solving).  The
bitten-triangle part also saves pictures under ``benchmarks/results/acceptance/``, the
part ``gallery`` the figure ``docs/gallery/planform_bites.png``.

- sampled: a trapezoid given as sampled points (3 samples, PCHIP) against the
  trapezoid itself, 3D (hmax 0.1) on both load paths and every reduced model;
  plus the same samples perturbed by 1e-9 (which forces the spline outline and an
  unrelated mesh) to show the size of the mesh-to-mesh noise the exact match avoids.
- flare (and flare_h0.06): b/a = 1.5 against b/a = 1, 3D (hmax 0.1, and 0.06)
  curvature-first, against the ribbon model at L/a = 1.0 and 1.3, a/R = 0 and 2.5.
- elastica: the heavy elastica at a/R = 0, L/a = 1 against the 3D flat sheet at
  hmax 0.06 for b/a = 1.5 and 1.
- leaf: a pointed leaf (spline outline), a/R = 0 and 2.5, both paths at hmax 0.1
  and 0.06, with the heavy elastica and the ribbon model.
- bites (and bites_h0.06, bites_h0.03): the triangle at L/a = 1.3, a/R = 2.5 with no, one and
  two bites (radius 0.25 each), and the trapezoids cut straight where each bite
  leaves the axis, both load paths at hmax 0.1 (0.06), with the reduced models.
"""
from __future__ import annotations

import json
import os
import sys
import time

import numpy as np

from skfem_sheet.io import atomic_write, dumps_json
from skfem_sheet.params import Planform, Sheet
from skfem_sheet.plot import plot_sheet, top_surface
from skfem_sheet.reduced import (
    cantilever_deflection,
    elastica,
    persistence_length,
    ribbon,
)
from skfem_sheet.solve import solve

from harness import parser

HERE = os.path.dirname(os.path.abspath(__file__))
RESULTS = os.path.join(HERE, "results", "acceptance")
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
    return rows


def report_sampled(rows):
    base = {r["path"]: r for r in rows if r["case"] == "trapezoid"}
    out = ["3D (hmax 0.1, L/a 1.3, b/a 0.6, a/R 2.5) and reduced models: sampled trapezoid",
           "case                     path              d_3D           |d - d_trapezoid|"]
    for r in rows:
        out.append(f"{r['case']:24s} {r['path']:16s} {r['deflection']:.10f}  "
                   f"{abs(r['deflection'] - base[r['path']]['deflection']):.2e}")
    by = {r["case"]: r for r in rows}
    for key in ("elastica", "ribbon_curvature", "ribbon_gravity", "persistence_length",
                "cantilever"):
        out.append(f"reduced {key:20s} |sampled - trapezoid| = "
                   f"{abs(by['sampled'][key] - by['trapezoid'][key]):.2e}")
    return out


def flare(hmax=0.1):
    rows = []
    for L in (1.0, 1.3):
        for k in (0.0, 2.5):
            for b in (1.0, 1.5):
                s = Sheet.from_planform(Planform.trapezoid(b), length=L, curvature=k)
                _, rec = _solve(s, "curvature-first", hmax)
                rb = ribbon(s, "curvature")
                rows.append({"length": L, "curvature": k, "tip_width": b, **rec,
                             "ribbon": rb.deflection, "ribbon_converged": rb.converged,
                             "relative_difference": (rb.deflection - rec["deflection"])
                             / abs(rec["deflection"])})
                _save("flare" if hmax == 0.1 else f"flare_h{hmax:g}", rows)
    return rows


def report_flare(rows):
    out = [f"3D (hmax {rows[0]['hmax']:g}, curvature-first) against the ribbon model (curvature branch)",
           " L    a/R   b/a   d_3D       d_ribbon   ribbon-3D   (ribbon-3D)/|3D|"]
    for r in rows:
        out.append(f"{r['length']:.1f}  {r['curvature']:.1f}  {r['tip_width']:.1f}  "
                   f"{r['deflection']:+.5f}  {r['ribbon']:+.5f}  {r['ribbon'] - r['deflection']:+.5f}"
                   f"    {100 * r['relative_difference']:+.2f}%")
    return out


def elastica_part():
    rows = []
    for b in (1.5, 1.0):
        s = Sheet.from_planform(Planform.trapezoid(b), length=1.0)
        _, rec = _solve(s, "curvature-first", 0.06)
        e = elastica(s).deflection
        rows.append({"tip_width": b, **rec, "elastica": e,
                     "relative_difference": (rec["deflection"] - e) / e})
        _save("elastica", rows)
    return rows


def report_elastica(rows):
    return [f"b/a {r['tip_width']:.1f}, a/R 0, L/a 1: d_3D(hmax {r['hmax']:g}) {r['deflection']:.5f}, "
            f"heavy elastica {r['elastica']:.5f}, (3D - elastica)/elastica = "
            f"{100 * r['relative_difference']:+.2f}%" for r in rows]


def bites(hmax=0.1):
    """The triangle with no, one and two bites, and the trapezoids cut straight where
    each bite leaves the axis (the trapezoid the paper says a bitten slice approximates)."""
    rows = []
    cases = {"triangle": (), "one bite": (0.25,), "two bites": (0.25, 0.25)}
    sheets = {}
    for name, bt in cases.items():
        s = Sheet.from_planform(Planform.trapezoid(0.0, bites=bt), length=1.3, curvature=2.5)
        sheets[name] = s
        if bt:
            x0 = s.outline.axis_end
            sheets[f"cut at {x0:g}"] = Sheet(x0, 1.0 - x0 / 1.3, 2.5)
    for name, s in sheets.items():
        red = {"ribbon_curvature": ribbon(s, "curvature").deflection,
               "ribbon_gravity": ribbon(s, "gravity").deflection, "elastica": elastica(s).deflection}
        for path in PATHS:
            r, rec = _solve(s, path, hmax)
            rows.append({"case": name, "bites": list(s.planform.bites) if s.planform else [],
                         "length": s.length, "tip_width": s.tip_width, "extent": s.extent,
                         "area": s.area, **rec, **red})
            _save("bites" if hmax == 0.1 else f"bites_h{hmax:g}", rows)
            if r.converged and s.planform is not None and hmax == 0.1:
                tag = name.replace(" ", "_")
                plot_sheet(r, os.path.join(RESULTS, f"planform_{tag}_{path}.png"),
                           title=f"{name}, L/a = 1.3, a/R = 2.5, {path}, d = {r.deflection:.3f}")
    return rows


def report_bites(rows):
    out = [(f"triangle L/a 1.3, a/R 2.5, bites of radius 0.25 (3D hmax {rows[0]['hmax']:g}; "
           "ribbon curvature/gravity branch); 'cut at x0': the trapezoid cut straight at "
           "the bite's innermost point"),
           ("case         path              d_3D      conv   ribbon(c/g)        elastica  "
           "L      b/a    extent  area")]
    for r in rows:
        out.append(f"{r['case']:11s}  {r['path']:16s}  {r['deflection']:+.5f}  {r['converged']!s:5s}  "
                   f"{r['ribbon_curvature']:+.4f}/{r['ribbon_gravity']:+.4f}  {r['elastica']:.4f}  "
                   f"{r['length']:.3f}  {r['tip_width']:.3f}  {r['extent']:.3f}   {r['area']:.3f}")
    return out


def leaf():
    """A pointed leaf p = 1 + x - (2.2/1.44) x^2 (L = 1.2): the spline outline in 3D."""
    rows = []
    for k in (0.0, 2.5):
        s = Sheet(1.2, planform=lambda x: 1 + x - 2.2 / 1.44 * x**2, curvature=k)
        red = {"elastica": elastica(s).deflection,
               "ribbon_curvature": ribbon(s, "curvature").deflection,
               "ribbon_gravity": ribbon(s, "gravity").deflection}
        for path in PATHS:
            for hmax in (0.1, 0.06):
                _, rec = _solve(s, path, hmax)
                rows.append({"curvature": k, "area": s.area, **rec, **red})
                _save("leaf", rows)
    return rows


def report_leaf(rows):
    out = ["leaf p = 1 + x - (2.2/1.44) x^2, L/a = 1.2 (pointed tip), 3D against reduced models",
           "a/R   path              hmax  d_3D      conv   elastica  ribbon(c/g)"]
    for r in rows:
        out.append(f"{r['curvature']:.1f}   {r['path']:16s}  {r['hmax']:.2f}  {r['deflection']:+.5f}  "
                   f"{r['converged']!s:5s}  {r['elastica']:.5f}   "
                   f"{r['ribbon_curvature']:+.5f}/{r['ribbon_gravity']:+.5f}")
    return out


def gallery():
    """The triangle, once and twice bitten, side by side on one colour scale."""
    # deferred: the backend must be chosen before pyplot is imported
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib import cm, colors

    cases = {"triangle": (), "one bite": (0.25,), "two bites": (0.25, 0.25)}
    results = {}
    for name, bt in cases.items():
        s = Sheet.from_planform(Planform.trapezoid(0.0, bites=bt), length=1.3, curvature=2.5)
        results[name] = solve(s, path="curvature-first", hmax=0.1)
    vmax = max(float(np.percentile(top_surface(r)[2], 99)) for r in results.values())
    fig = plt.figure(figsize=(13.5, 4.4))
    for i, (name, r) in enumerate(results.items()):
        ax = fig.add_subplot(1, 3, i + 1, projection="3d")
        plot_sheet(r, ax=ax, vmax=vmax, colorbar=False,
                   title=f"{name}: d/a = {r.deflection:.3f}")
        ax.set_xlim(0, 1.3)
        ax.set_ylim(-0.65, 0.65)
        ax.set_zlim(-0.65, 0.65)
    fig.colorbar(cm.ScalarMappable(norm=colors.Normalize(0.0, vmax), cmap="viridis"),
                 ax=fig.axes, shrink=0.6, pad=0.02, label=r"$\psi/\mu$")
    fig.suptitle("A slice of pizza, L/a = 1.3, a/R = 2.5 (hmax 0.1, curvature-first): "
                 "bites of radius 0.25a lift the tip", fontsize=10)
    path = os.path.join(HERE, os.pardir, "docs", "gallery", "planform_bites.png")
    fig.savefig(path, dpi=130, bbox_inches="tight")
    plt.close(fig)
    return [f"{name}: d/a = {r.deflection:.5f}" for name, r in results.items()]


PARTS = {"sampled": (sampled, report_sampled), "flare": (flare, report_flare),
         "flare_h0.06": (lambda: flare(0.06), report_flare),
         "elastica": (elastica_part, report_elastica), "bites": (bites, report_bites),
         "bites_h0.06": (lambda: bites(0.06), report_bites),
         "bites_h0.03": (lambda: bites(0.03), report_bites), "leaf": (leaf, report_leaf)}


def main(argv=None):
    """``[--report] [part ...]``: run (or, with --report, re-read) the parts and
    write their tables to ``benchmarks/results/acceptance/planform_<part>.txt``."""
    ap = parser(__doc__)
    ap.add_argument("parts", nargs="*", metavar="part",
                    help=f"default: all but bites_h0.03 ({', '.join([*PARTS, 'gallery'])})")
    ap.add_argument("--report", action="store_true",
                    help="rewrite the tables from the recorded JSON, without solving")
    args = ap.parse_args(argv)
    unknown = [p for p in args.parts if p not in (*PARTS, "gallery")]
    if unknown:
        ap.error(f"unknown part {unknown[0]!r}: choose from {', '.join([*PARTS, 'gallery'])}")
    report_only = args.report
    parts = args.parts or [p for p in (*PARTS, "gallery") if p != "bites_h0.03"]
    for part in parts:
        if part == "gallery":
            lines = gallery()
        else:
            run, report = PARTS[part]
            if report_only:
                with open(os.path.join(RESULTS, f"planform_{part}.json")) as fh:
                    rows = json.load(fh)
            else:
                rows = run()
            lines = report(rows)
        text = "\n".join(lines) + "\n"
        atomic_write(os.path.join(RESULTS, f"planform_{part}.txt"), text)
        print(text)


if __name__ == "__main__":
    sys.exit(main())
