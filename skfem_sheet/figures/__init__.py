"""The paper's figures, one command each: ``python -m skfem_sheet figure NAME``.

=====  ==================================================================  =====================
name   what it shows (paper caption)                                       data
=====  ==================================================================  =====================
fig2   d/a against L/a, rectangles (a) and triangles (b),                  fold map
       a/R in {0, 1, 2.5, 5}; both stable branches where bistable
fig3   deformed sheets coloured by psi/mu at a/R = 2.5, L/a = 1.3:         six full FE solves
       rectangle (both modes), triangle, trapezoids b/a = 0.8, 0.6, 0.4
fig4   d/a against L/a for b/a in {0, 0.2, ..., 1} at a/R = 0 (a) and      fold map
       2.5 (b); insets against the area A/a^2
fig5   finite elements against the ribbon model, rectangle and triangle,   fold map + ribbon
       a/R = 1 and 2.5
fig6   ribbon-model d/a over (L/a, b/a) at a/R = 2.5 (a) and 5 (b), its    ribbon map + fold map
       jumps, FE modes (markers) and the FE bistable region
fig7   the bistable region in (L/a, b/a, a/R): standout L1* (upper) and    fold map
       pop-up L0* (lower) surfaces meeting on the critical curve
figS1  convergence test: d/a against the largest mesh diameter, L/a 1.8,   nested FE meshes
       a/R 5, with the projected exact value (+ MMS rates if recorded)
figS3  in-plane strains E_ss, E_st, E_tt and stresses T_ss, T_tt of a      one FE solve
       gravity-free rectangle, L/a 1.5, a/R 0.5, h/a 0.03175
figS4  u/(h/a)^2, v/(h/a)^2, w/(h/a) at s/a = 0.4, 0.8, 1.2, gravity-free  one FE solve
       rectangle L/a 2, a/R 0.5, h/a 0.03175
=====  ==================================================================  =====================

One figure more, not in the paper: ``switching``, the switching forces and energy barriers
of the rectangle across its bistable window (:mod:`skfem_sheet.switch`).

The supplement's figures keep their solves in ``figS<n>-<quality>/``.

Data: every finite-element curve of fig2, fig4-fig7 comes from one fold-map
table per quality, ``data_dir/foldmap-<quality>.csv``
(:func:`skfem_sheet.studies.foldmap.fold_map`): for each (b/a, a/R) both stable
branches as curves d(L) with the stability of every point.  Points already in
the table (its journal) are not recomputed, and the figures share them.

Quality: ``"quick"`` is the fold map at hmax 0.1 (:data:`QUICK_GRID`);
``"paper"`` hmax 0.03 and finer grids (:data:`PAPER_GRID`).  Quick figures
carry a footnote saying so.

Drawing convention (fig2, fig4, fig5): solid lines and filled markers the
curvature-dominated mode, dashed lines and open markers the gravity-dominated
one, stable points only; a bistable row has both branches, each to its fold
with a dotted arrow for the jump; elsewhere one curve, solid below the
transition length and dashed above (:func:`skfem_sheet.studies.foldmap.modes`).

Modules: one per figure (``figureN``: its points, data and drawing; named so
that ``skfem_sheet.figures.figN`` stays the function); ``common``, ``data``
(the one module that imports the studies), ``cache``, ``style``,
``registry`` (:data:`FIGURES`, :func:`make_figure`), ``work`` and ``batch``
(:func:`make_all`, ``figure all``).  A new figure is a module ``figureN.py``
with ``figN(quality, data_dir, progress, workers, log)`` added to
:data:`FIGURES`.

Examples
--------
>>> {"fig2", "fig3", "fig4", "fig5", "fig6", "fig7"} <= set(FIGURES)
True
>>> quality_settings("quick")["hmax"]
0.1
>>> sorted(QUICK_GRID)
[0.0, 1.0, 1.5, 2.0, 2.5, 3.5, 5.0]
"""
from __future__ import annotations

from .batch import make_all, run_order
from .common import DEFAULT_DATA_DIR, PAPER_GRID, QUALITIES, QUICK_GRID, quality_settings
from .data import fold_map_table, map_grid_points, row_branches
from .figure2 import draw_fig2, fig2, fig2_points
from .figure3 import draw_fig3, fig3, fig3_data, fig3_sheets
from .figure4 import draw_fig4, fig4, fig4_points
from .figure5 import draw_fig5, fig5, fig5_points, fig5_ribbon
from .figure6 import draw_fig6, fig6, fig6_points, fig6_ribbon
from .figure7 import bistable_region, draw_fig7, fig7, fig7_points
from .figure_switching import draw_switching, fig_switching, switching_curve, switching_table
from .figureS1 import draw_figS1, figS1, figS1_data, seed_from_benchmarks
from .figureS3 import draw_figS3, figS3, figS3_data
from .figureS4 import draw_figS4, figS4, figS4_data
from .registry import FIGURES, make_figure
from .style import COLUMN_WIDTH, DPI, FULL_WIDTH
from .work import DataStep, FigureRun, summary_json, summary_text

__all__ = ["FIGURES", "QUALITIES", "DEFAULT_DATA_DIR", "QUICK_GRID", "PAPER_GRID",
           "quality_settings", "make_figure", "map_grid_points", "fold_map_table",
           "fig2", "fig3", "fig4", "fig5", "fig6", "fig7", "figS1", "figS3", "figS4",
           "figS1_data", "figS3_data", "figS4_data", "draw_figS1", "draw_figS3", "draw_figS4",
           "seed_from_benchmarks",
           "fig2_points", "fig4_points", "fig5_points", "fig6_points", "fig7_points",
           "draw_fig2", "draw_fig3", "draw_fig4", "draw_fig5", "draw_fig6", "draw_fig7",
           "fig3_sheets", "fig3_data", "fig5_ribbon", "fig6_ribbon", "row_branches",
           "bistable_region", "COLUMN_WIDTH", "FULL_WIDTH", "DPI", "make_all", "run_order",
           "DataStep", "FigureRun", "summary_text", "summary_json",
           "fig_switching", "draw_switching", "switching_table", "switching_curve"]
