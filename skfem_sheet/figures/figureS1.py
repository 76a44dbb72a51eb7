"""Fig. S1: convergence test, d/a against the largest mesh diameter (L/a 1.8, a/R 5).

The case of ``benchmarks/convergence.py`` (rectangle, L/a = 1.8, a/R = 5,
curvature-first, the symmetric half): nested mesh families, each a base mesh
(hmax, 2 layers) with every edge halved ``refine`` times (``solve(...,
refine=k)``; h = hmax / 2^k), plus the default mesh (hmax 0.03, 2 layers).
The "projected exact value" is the least-squares
``d = d_inf + A h^2 + B h^3`` (paper quality; quick: ``d_inf + A h^2``, its
meshes are too coarse for two terms) over the family meshes with ``h <=
figS1_fit_max_h`` (the paper's order 2 fixed; the recorded free-order fit,
``benchmarks/results/accuracy/convergence_fit_L1.8_aR5.txt``, finds p = 1.72 +- 0.41 and
d_inf within 3e-5 of it), drawn with a +-1% band (the caption's claim).  The
quick meshes (h >= 0.08) are before the asymptotic range (the recorded error
changes sign near h = 0.07-0.09), so the quick projection is only indicative.

Quick: bases 0.24, 0.2, 0.16 with refine 0, 1 (minutes).  Paper: bases 0.16,
0.14, 0.12 with refine 0 to 2 (the recorded study: hours, 7 GB at the finest);
:func:`seed_from_benchmarks` fills the paper cache from the recorded runs
(``benchmarks/results/accuracy/convergence_nested*_L1.8_aR5.json``) instead.

Panel (b), if ``data_dir/manufactured.json`` exists (the JSON written by
``benchmarks/manufactured.py --json``, e.g. the recorded
``benchmarks/results/accuracy/manufactured.json``): the manufactured-solution errors
against h with their fitted rates.

Each solve is cached in ``data_dir/figS1-<quality>/*.csv``.

Examples
--------
>>> [(m["hmax"], m["refine"]) for m in figS1_meshes("quick")][:3]
[(0.24, 0), (0.24, 1), (0.2, 0)]
"""
from __future__ import annotations

import glob
import json
import os
import time

import numpy as np
import pandas as pd

from ..io import atomic_write
from ..params import ParameterError, Sheet
from ..solve import solve
from .cache import data_folder, load_or_compute
from .common import DEFAULT_DATA_DIR, quality_settings
from .data import on_workers
from .style import COLUMN_WIDTH, FULL_WIDTH, fmt, mesh_footnote, panel_label, styled_figure
from .work import note, solves_step

__all__ = ["FIGS1_SHEET", "DEFAULT_MESH", "figS1_meshes", "figS1_data", "projected_value",
           "seed_from_benchmarks", "draw_figS1", "figS1"]

#: The convergence case (paper, supplement Fig. S1).
FIGS1_SHEET = Sheet(length=1.8, curvature=5.0)
#: The package's default mesh (and the paper's): hmax 0.03 with 2 layers.
DEFAULT_MESH = {"hmax": 0.03, "layers": 2, "refine": 0, "role": "default"}
_COLUMNS = ["hmax", "layers", "refine", "h", "role", "dofs", "deflection", "converged",
            "wall_time_s", "factorizations"]


def figS1_meshes(quality: str = "quick") -> list:
    """The meshes of Fig. S1: the quality's nested families, then the default mesh."""
    out = []
    for base, layers, k in quality_settings(quality)["figS1_families"]:
        out += [{"hmax": base, "layers": layers, "refine": r, "role": "family"}
                for r in range(k + 1)]
    return out + [dict(DEFAULT_MESH)]


def _file(folder, m):
    return os.path.join(folder, f"hmax{m['hmax']:g}_layers{m['layers']}_refine{m['refine']}"
                                f"_{m['role']}.csv")


def _solve_row(m):
    r = solve(FIGS1_SHEET, hmax=m["hmax"], layers=m["layers"], refine=m["refine"],
              on_failure="return")
    return pd.DataFrame([{**m, "h": m["hmax"] / 2 ** m["refine"], "dofs": r.dofs,
                          "deflection": r.deflection, "converged": bool(r.converged),
                          "wall_time_s": r.wall_time_s,
                          "factorizations": r.factorizations + r.coarse_factorizations}])[_COLUMNS]


def _solve_chunk(chunk):
    """The solves of ``chunk`` (``(path, mesh)`` pairs), each written to its
    cache file as :func:`figS1_data` would: a task of the worker pool."""
    out = []
    for path, m in chunk:
        load_or_compute(path, lambda m=m: _solve_row(m))
        out.append(path)
    return out


def _on_workers(todo, workers, progress):
    """Solve the meshes ``todo`` (``(path, mesh)`` pairs, none cached) on
    ``workers`` processes, the finest first (the longest: the finest family
    mesh takes half of the paper quality's solve time), each into its cache
    file.  A solve whose worker fails is left to the caller (solved again in
    this process, where its error is raised)."""
    from tqdm.auto import tqdm

    order = sorted(todo, key=lambda pm: pm[1]["hmax"] / 2 ** pm[1]["refine"])
    with tqdm(total=len(order), desc="figS1 solves", disable=not progress, leave=None) as bar:
        for done in on_workers([[pm] for pm in order], min(int(workers), len(order)),
                               _solve_chunk):
            bar.update(len(done))


def figS1_data(quality="quick", data_dir=DEFAULT_DATA_DIR, progress=True,
               log=None, workers=None) -> pd.DataFrame:
    """One row per mesh of :func:`figS1_meshes` (solved, or read from the cache).

    ``workers`` (more than one): the solves not cached run on that many
    processes, the finest first (:func:`~skfem_sheet.figures.data.on_workers`);
    None: one per CPU, at most two (at paper quality the finest solve alone
    peaks at 6.1 GB, and the two finest at once about 10 GB, estimated from
    their unknowns); 1: one after the other in this
    process.
    ``log``: a list to append the step's
    :class:`~skfem_sheet.figures.work.DataStep` to (the solves run now, their
    factorisations; rows cached before the column was recorded, and the
    seeded ones, have none).
    """
    from tqdm.auto import tqdm

    folder = data_folder(data_dir, f"figS1-{quality}")
    meshes = figS1_meshes(quality)
    t0 = time.perf_counter()
    files = [_file(folder, m) for m in meshes]
    cached = [os.path.exists(f) for f in files]
    todo = [(f, m) for f, m, c in zip(files, meshes, cached) if not c]
    if workers is None:  # two at most unless asked (memory: see above)
        workers = min(2, os.cpu_count() or 1)
    if int(workers) > 1 and len(todo) > 1:
        _on_workers(todo, workers, progress)
    rows, solved = [], []
    for f, m, c in tqdm(list(zip(files, meshes, cached)), desc="figS1 solves",
                        disable=not progress, leave=None):
        row, _ = load_or_compute(f, lambda m=m: _solve_row(m))
        rows.append(row)
        if not c:
            solved.append((f"hmax {m['hmax']:g} refine {m['refine']}",
                           {k: row[k].iloc[0] for k in ("factorizations", "wall_time_s")
                            if k in row and pd.notna(row[k].iloc[0])}))
    note(log, solves_step(solved, len(meshes), time.perf_counter() - t0))
    return pd.concat(rows, ignore_index=True)


def seed_from_benchmarks(data_dir, results_dir, quality: str = "paper") -> int:
    """Fill the quality's cache with the recorded runs of ``benchmarks/convergence.py``.

    Reads every ``convergence*_L1.8_aR5.json`` in ``results_dir``; a run
    whose mesh (hmax, layers, refine) is one of :func:`figS1_meshes` and
    that converged is written as that mesh's cached row (existing rows are
    kept).  Returns the number of rows written.

    Examples
    --------
    >>> import tempfile
    >>> seed_from_benchmarks(tempfile.mkdtemp(), tempfile.mkdtemp())
    0
    """
    folder = data_folder(data_dir, f"figS1-{quality}")
    wanted = {(m["hmax"], m["layers"], m["refine"]): m for m in figS1_meshes(quality)}
    written = 0
    for fn in sorted(glob.glob(os.path.join(os.fspath(results_dir),
                                            "convergence*_L1.8_aR5.json"))):
        with open(fn) as f:
            runs = json.load(f).get("runs", [])
        for run in runs:
            spec = run.get("spec", {})
            sheet = spec.get("sheet", {})
            if (sheet.get("length"), sheet.get("curvature"), sheet.get("tip_width", 1.0)) \
                    != (1.8, 5.0, 1.0) or spec.get("path", "curvature-first") != \
                    "curvature-first" or not run.get("converged"):
                continue
            layers = spec.get("layers") or run.get("layers")
            key = (spec.get("hmax"), layers, spec.get("refine", 0) or 0)
            m = wanted.get(key)
            if m is None or os.path.exists(_file(folder, m)):
                continue
            row = pd.DataFrame([{**m, "h": m["hmax"] / 2 ** m["refine"], "dofs": run["dofs"],
                                 "deflection": run["deflection"], "converged": True,
                                 "wall_time_s": run.get("wall_time_s", np.nan),
                                 "factorizations": run.get("factorizations", np.nan)}]
                               )[_COLUMNS]
            atomic_write(_file(folder, m), row.to_csv(index=False))
            written += 1
    return written


def projected_value(h, d, max_h, powers=(2, 3)):
    """``d_inf`` of the least-squares ``d = d_inf + sum_k A_k h^k`` over ``h <= max_h``.

    Examples
    --------
    >>> h = np.array([0.2, 0.1, 0.05, 0.025])
    >>> round(projected_value(h, -0.07 + 0.3 * h**2 - h**3, 0.2), 12)
    -0.07
    """
    h, d = np.asarray(h, float), np.asarray(d, float)
    use = h <= max_h * (1 + 1e-9)
    if use.sum() < len(powers) + 1:
        raise ParameterError(f"max_h must leave at least {len(powers) + 1} meshes for the "
                             f"fit, got {max_h}")
    A = np.column_stack([np.ones(use.sum())] + [h[use] ** k for k in powers])
    c, *_ = np.linalg.lstsq(A, d[use], rcond=None)
    return float(c[0])


def _manufactured(data_dir):
    fn = os.path.join(os.fspath(data_dir), "manufactured.json")
    if not os.path.exists(fn):
        return None
    with open(fn) as f:
        return json.load(f)


def draw_figS1(df, quality: str = "paper", manufactured=None):
    """Draw Fig. S1 from :func:`figS1_data` rows (and the manufactured-solution JSON).

    Examples
    --------
    >>> df = pd.DataFrame({"hmax": [.2, .2, .2, .03], "layers": 2, "refine": [0, 1, 2, 0],
    ...     "h": [.2, .1, .05, .03], "role": ["family"] * 3 + ["default"],
    ...     "dofs": 1, "deflection": [-.078, -.0772, -.0770, -.0771], "converged": True,
    ...     "wall_time_s": 1.0})
    >>> len(draw_figS1(df, "quick").axes)
    1
    """
    fam = df[(df["role"] == "family") & df["converged"].astype(bool)]
    settings = quality_settings(quality)
    max_h, powers = settings["figS1_fit_max_h"], settings["figS1_fit_powers"]
    d_inf = projected_value(fam["h"], fam["deflection"], max_h, powers)
    width = FULL_WIDTH if manufactured else COLUMN_WIDTH
    with styled_figure(width, 3.6) as fig:
        axes = fig.subplots(1, 2 if manufactured else 1, squeeze=False,
                            gridspec_kw=dict(left=0.17 if not manufactured else 0.09,
                                             right=0.98, bottom=0.42, top=0.93,
                                             wspace=0.3))[0]
        ax = axes[0]
        hh = np.geomspace(float(df["h"].min()) * 0.8, float(df["h"].max()) * 1.25, 50)
        ax.fill_between(hh, d_inf * 0.99, d_inf * 1.01, color="0.88", lw=0,
                        label=r"$\pm 1\%$ of the projected value")
        ax.axhline(d_inf, color="k", lw=0.8, ls="--",
                   label=f"projected exact value {d_inf:.5f}")
        markers = "osD^v"
        for i, ((base, layers), g) in enumerate(fam.groupby(["hmax", "layers"])):
            g = g.sort_values("h")
            ax.plot(g["h"], g["deflection"], marker=markers[i % 5], ms=3.5,
                    label=f"nested: base hmax {fmt(base)}, {layers} layers, refined")
        dflt = df[df["role"] == "default"]
        if len(dflt):
            r = dflt.iloc[0]
            err = 100 * (r["deflection"] - d_inf) / abs(d_inf)
            ax.plot([r["h"]], [r["deflection"]], "k*", ms=7,
                    label=f"default hmax {fmt(r['hmax'])}, {int(r['layers'])} layers "
                          f"({err:+.2f}%)")
        ax.set_xscale("log")
        ticks = [x for x in (0.03, 0.04, 0.06, 0.08, 0.12, 0.16, 0.24)
                 if hh.min() <= x <= hh.max()]
        ax.set_xticks(ticks, [fmt(x) for x in ticks])
        ax.minorticks_off()
        ax.set_xlabel("largest mesh diameter $h/a$ (after refinement)")
        ax.set_ylabel("$d/a$")
        ax.legend(fontsize=5.5, loc="upper left", bbox_to_anchor=(-0.2, -0.17),
                  frameon=False)
        ax.set_title(f"rectangle, $L/a={fmt(FIGS1_SHEET.length)}$, "
                     f"$a/R={fmt(FIGS1_SHEET.curvature)}$, $h/a={fmt(FIGS1_SHEET.thickness)}$",
                     fontsize=7)
        if manufactured:
            panel_label(ax, "(a)")
            bx = axes[1]
            meshes = manufactured["meshes"]
            h = np.array([m["h"] for m in meshes])
            names = {"u_l2": r"$\|U-U^*\|_{L^2}$", "u_h1": r"$\|U-U^*\|_{H^1}$",
                     "p_l2": r"$\|p-p^*\|_{L^2}$", "tip": "tip $U_z$ error"}
            for key, lab in names.items():
                e = np.array([abs(m[key]) for m in meshes])
                rate = manufactured.get("rates", {}).get(key)
                bx.loglog(h, e, marker="o", ms=3, label=f"{lab}: rate {rate:.2f}"
                          if rate is not None else lab)
            bx.set_xticks(h, [fmt(x) for x in h])
            bx.minorticks_off()
            bx.set_xlabel("$h$ (nested refinements)")
            bx.set_ylabel("error")
            bx.set_title("manufactured solution (P2/P1, bent and twisted)", fontsize=7)
            bx.legend(fontsize=6, frameon=False)
            panel_label(bx, "(b)")
        n = int(fam["dofs"].max()) if len(fam) else 0
        mesh_footnote(fig, quality, f"FE: {len(fam)} family meshes (largest {n} unknowns, "
                                    f"symmetric half); fit over h <= {fmt(max_h)}: "
                                    + r"$d_\infty$" + "".join(f" + A{k} h^{k}"
                                                               for k in powers))
    return fig


def figS1(quality="quick", data_dir=DEFAULT_DATA_DIR, progress=True, workers=None, log=None):
    """Fig. S1: the convergence test (d/a against hmax; MMS rates beside it if recorded).

    ``log``: a list to append the data step to (:func:`figS1_data`);
    ``workers``: its solves on that many processes (see :func:`figS1_data`).

    Examples
    --------
    >>> figS1("quick").savefig("figS1.png", dpi=200)  # doctest: +SKIP
    """
    return draw_figS1(figS1_data(quality, data_dir, progress, log, workers), quality,
                      _manufactured(data_dir))
