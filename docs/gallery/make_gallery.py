"""Regenerate the gallery (``docs/gallery/*.png``) from the best recorded or computable runs.

    python docs/gallery/make_gallery.py --data-dir DIR [PART ...]

Parts (default: all, in this order), each writing ``docs/gallery/<part>.png``:

- ``figS1``: ``python -m skfem_sheet figure figS1 --quality paper --data-dir DIR`` after
  :func:`skfem_sheet.figures.figureS1.seed_from_benchmarks` filled DIR with the recorded
  runs of ``benchmarks/convergence.py`` (``benchmarks/results/accuracy/convergence*_L1.8_aR5.json``:
  three nested families and the default mesh; no solve) and
  ``benchmarks/results/accuracy/manufactured.json`` was copied to DIR (panel b);
- ``figS3``, ``figS4``: ``python -m skfem_sheet figure figS3|figS4 --quality paper
  --data-dir DIR`` (one solve each at hmax 0.03);
- ``fig2``, ``fig4``, ``fig5``, ``fig6``: ``python -m skfem_sheet figure figN --quality paper
  --data-dir DIR`` after DIR was seeded with the recorded journals of ``figure all --quality
  paper`` (``benchmarks/results/speed/foldmap-paper_hmax0.03_e992b48.jsonl``: the 26 fold-map
  rows at hmax 0.03, and ``foldcurves-paper_hmax0.03_e992b48.jsonl``: the 18 fold curves;
  ``figure_all_paper_e992b48.txt``): no finite-element solve, the ribbon model's curves and
  map computed (fig6's paper map, 126 x 51 per curvature: about 2 min);
- ``fig7``: :func:`skfem_sheet.figures.draw_fig7` of the recorded paper-quality fold
  curves (``benchmarks/results/speed/foldcurves-paper_hmax0.03.csv``: 18 curves at hmax 0.03,
  ``fold_map_paper_hmax0.03.txt``), what ``figure fig7 --quality paper`` draws from its
  table;
- ``fig3``: ``python -m skfem_sheet figure fig3 --quality paper --data-dir DIR`` (six
  solves at hmax 0.03, smooth shading);
- ``demo``: ``python -m skfem_sheet demo --png docs/gallery/demo.png`` (hmax 0.04, the
  aloft rectangle) and ``demo_drooped``: the same sheet ``--path gravity-first``;
- ``demo_pyvista``: :func:`skfem_sheet.plot.render_sheet` of the drooped demo sheet
  (PyVista off screen; the ``render`` extra);
- ``planform_bites``: the triangle at L/a 1.3, a/R 2.5 with no, one and two bites of
  radius 0.25 (curvature-first, ``start="path"``) at hmax 0.03, one colour scale (the
  hmax 0.03 runs of ``benchmarks/results/acceptance/planform_bites_h0.03.txt``).
"""
from __future__ import annotations

import argparse
import os
import shutil
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
RESULTS = os.path.join(ROOT, "benchmarks", "results")

try:
    import skfem_sheet  # noqa: F401
except ImportError:  # run from a checkout without installing
    sys.path.insert(0, ROOT)


def _out(name):
    return os.path.join(HERE, f"{name}.png")


def _save(fig, name):
    from skfem_sheet.figures.style import DPI

    fig.savefig(_out(name), dpi=DPI, bbox_inches="tight", pad_inches=0.02)
    import matplotlib.pyplot as plt

    plt.close(fig)


def part_figS1(data_dir):
    from skfem_sheet.cli import main
    from skfem_sheet.figures.figureS1 import seed_from_benchmarks

    seed_from_benchmarks(data_dir, os.path.join(RESULTS, "accuracy"))
    shutil.copyfile(os.path.join(RESULTS, "accuracy", "manufactured.json"),
                    os.path.join(data_dir, "manufactured.json"))
    return main(["figure", "figS1", "--quality", "paper", "--data-dir", data_dir,
                 "--out", _out("figS1"), "--quiet"])


def part_figS3(data_dir):
    from skfem_sheet.cli import main

    return main(["figure", "figS3", "--quality", "paper", "--data-dir", data_dir,
                 "--out", _out("figS3"), "--quiet"])


def part_figS4(data_dir):
    from skfem_sheet.cli import main

    return main(["figure", "figS4", "--quality", "paper", "--data-dir", data_dir,
                 "--out", _out("figS4"), "--quiet"])


def recorded_curves():
    """The recorded paper-quality fold-curve table, with the table's string columns."""
    import pandas as pd

    df = pd.read_csv(os.path.join(RESULTS, "speed", "foldcurves-paper_hmax0.03.csv"))
    for c in ("error", "message", "cusp_located", "second", "points"):
        df[c] = df[c].astype(object).where(df[c].notna(), "").astype(str)
    return df


def part_fig7(data_dir):
    import matplotlib

    matplotlib.use("Agg")
    from skfem_sheet.figures import draw_fig7
    from skfem_sheet.figures.data import curve_region

    df = recorded_curves()
    _save(draw_fig7(df, "paper", region=curve_region(df)), "fig7")
    return 0


def _seed_paper_journals(data_dir):
    """DIR with the recorded paper-quality journals of ``figure all`` (the fold map's rows and
    the fold curves), so that ``figure figN --quality paper`` computes no finite elements."""
    for recorded, table in (("foldmap-paper_hmax0.03_e992b48.jsonl", "foldmap-paper.csv"),
                            ("foldcurves-paper_hmax0.03_e992b48.jsonl", "foldcurves-paper.csv")):
        target = os.path.join(data_dir, table + ".journal.jsonl")
        if not os.path.exists(target):
            shutil.copyfile(os.path.join(RESULTS, "speed", recorded), target)


def _paper_figure(name):
    def part(data_dir):
        from skfem_sheet.cli import main

        _seed_paper_journals(data_dir)
        return main(["figure", name, "--quality", "paper", "--data-dir", data_dir,
                     "--out", _out(name), "--quiet"])
    part.__name__ = f"part_{name}"
    return part


part_fig2, part_fig4, part_fig5, part_fig6 = (_paper_figure(n) for n in ("fig2", "fig4", "fig5",
                                                                          "fig6"))


def part_fig3(data_dir):
    from skfem_sheet.cli import main

    return main(["figure", "fig3", "--quality", "paper", "--data-dir", data_dir,
                 "--out", _out("fig3"), "--quiet"])


def part_demo(data_dir):
    from skfem_sheet.cli import main

    vtu = os.path.join(data_dir, "demo.vtu")
    code = main(["demo", "--png", _out("demo"), "--vtu", vtu, "--quiet"])
    return code or main(["demo", "--path", "gravity-first", "--png", _out("demo_drooped"),
                         "--vtu", os.path.join(data_dir, "demo_drooped.vtu"), "--quiet"])


def part_demo_pyvista(data_dir):
    from skfem_sheet import Sheet, solve
    from skfem_sheet.plot import pyvista_available, render_sheet

    if not pyvista_available():
        print("demo_pyvista: PyVista is not installed (pip install skfem_sheet[render])")
        return 0
    r = solve(Sheet(length=1.3, curvature=2.5), path="gravity-first", hmax=0.04)
    render_sheet(r, _out("demo_pyvista"))
    return 0


def part_planform_bites(data_dir):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib import cm

    from skfem_sheet import Sheet, solve
    from skfem_sheet.params import Planform
    from skfem_sheet.plot import colour_scale, plot_sheet, top_surface

    cases = {"triangle": (), "one bite": (0.25,), "two bites": (0.25, 0.25)}
    results = {}
    for name, bites in cases.items():
        s = Sheet.from_planform(Planform.trapezoid(0.0, bites=bites), length=1.3, curvature=2.5)
        # start="path": the default coarse start cannot transfer a bitten sheet (fine
        # nodes on a bite's arc lie outside the coarse mesh's chords: transfer raises)
        results[name] = solve(s, path="curvature-first", hmax=0.03, start="path")
    import numpy as np

    psi = np.concatenate([top_surface(r)[2] for r in results.values()])
    norm, label = colour_scale(psi, None, "robust")
    fig = plt.figure(figsize=(13.5, 4.4))
    for i, (name, r) in enumerate(results.items()):
        ax = fig.add_subplot(1, 3, i + 1, projection="3d")
        plot_sheet(r, ax=ax, vmax=norm.vmax, colorbar=False,
                   title=f"{name}: d/a = {r.deflection:.3f}")
        ax.set_xlim(0, 1.3)
        ax.set_ylim(-0.65, 0.65)
        ax.set_zlim(-0.65, 0.65)
    fig.colorbar(cm.ScalarMappable(norm=norm, cmap="viridis"), ax=fig.axes, shrink=0.6,
                 pad=0.02, label=label, extend="max")
    fig.suptitle("A slice of pizza, L/a = 1.3, a/R = 2.5 (hmax 0.03, curvature-first): "
                 "bites of radius 0.25a lift the tip", fontsize=10)
    fig.savefig(_out("planform_bites"), dpi=130, bbox_inches="tight")
    plt.close(fig)
    for name, r in results.items():
        print(f"planform_bites {name}: d/a = {r.deflection:.5f}")
    return 0


PARTS = {"figS1": part_figS1, "figS3": part_figS3, "figS4": part_figS4, "fig7": part_fig7,
         "fig2": part_fig2, "fig4": part_fig4, "fig5": part_fig5, "fig6": part_fig6,
         "fig3": part_fig3, "demo": part_demo,
         "demo_pyvista": part_demo_pyvista, "planform_bites": part_planform_bites}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data-dir", required=True, help="cache folder of the figures")
    ap.add_argument("parts", nargs="*", default=[],
                    help=f"parts to make (default: all): {', '.join(PARTS)}")
    args = ap.parse_args(argv)
    unknown = [p for p in args.parts if p not in PARTS]
    if unknown:
        ap.error(f"parts must be among {', '.join(PARTS)}, got {', '.join(unknown)}")
    os.makedirs(args.data_dir, exist_ok=True)
    for name in args.parts or list(PARTS):
        t0 = time.perf_counter()
        code = PARTS[name](args.data_dir)
        print(f"{name}: {'ok' if not code else f'exit {code}'} "
              f"({time.perf_counter() - t0:.0f} s)", flush=True)
        if code:
            return code
    return 0


if __name__ == "__main__":
    sys.exit(main())
