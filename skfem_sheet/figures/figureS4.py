"""Fig. S4: scaled mid-surface deformations u/(h/a)^2, v/(h/a)^2, w/(h/a) at three sections.

Supplement, "Motivation/validation of reduced-order ansatzes": a rectangle of
L/a = 2, a/R = 0.5, h/a = 0.03175 without gravity, at the cross-sections
s/a = 0.4, 0.8, 1.2.  ``u, v, w`` are the displacements along d1, d2, d3
relative to the cross-section's rigid motion (centre of mass r(s), angle
phi(s); :mod:`skfem_sheet.analyses.midsurface`).  The w panel also shows the
least-squares quadratic in t of each section (thin dashed) and its relative
residual ``||w - q|| / ||w||``.

The sections are cached in ``data_dir/figS4-<quality>/*.npz``.

Examples
--------
>>> figS4_sheet().length, FIGS4_SECTIONS
(2.0, (0.4, 0.8, 1.2))
"""
from __future__ import annotations

import os
import time

import numpy as np

from ..analyses.midsurface import midsurface, quadratic_fit
from ..params import Sheet
from .cache import data_folder, load_or_compute
from .common import DEFAULT_DATA_DIR, quality_settings
from .figureS3 import supplement_solve
from .style import FULL_WIDTH, fmt, mesh_footnote, panel_label, styled_figure
from .work import note, solves_step

__all__ = ["FIGS4_SECTIONS", "figS4_sheet", "figS4_data", "draw_figS4", "figS4"]

#: The cross-sections s/a of Fig. S4.
FIGS4_SECTIONS = (0.4, 0.8, 1.2)
_COLOURS = ("#1f77b4", "#d62728", "#2ca02c")


def figS4_sheet() -> Sheet:
    """The sheet of Fig. S4: rectangle, L/a 2, a/R 0.5, h/a 0.03175 (E/(rho g a) 735)."""
    return Sheet(length=2.0, curvature=0.5, thickness=0.03175)


def _sections_data(sheet, hmax, n_t):
    r = supplement_solve(sheet, hmax)
    m = midsurface(r.problem, r.w, list(FIGS4_SECTIONS), n_across=n_t)
    return {"s": m.s, "t": m.t, "u": m.u, "v": m.v, "w": m.w, "angle": m.frame.angle,
            "hmax": float(hmax), "dofs": int(r.dofs), "layers": int(r.layers),
            "converged": bool(r.converged),
            "factorizations": int(r.factorizations + r.coarse_factorizations),
            "wall_time_s": float(r.wall_time_s)}


def figS4_data(quality="quick", data_dir=DEFAULT_DATA_DIR, progress=True, log=None):
    """u, v, w at the Fig. S4 sections (a dict of arrays ``[section, point]``), cached.

    ``log``: a list to append the step's
    :class:`~skfem_sheet.figures.work.DataStep` to (one solve, or none).
    """
    s = quality_settings(quality)
    hmax, n_t = s["hmax_supplement"], s["supplement_grid"][1]
    sheet = figS4_sheet()
    folder = data_folder(data_dir, f"figS4-{quality}")
    fn = os.path.join(folder, f"L{sheet.length:g}_k{sheet.curvature:g}_h{sheet.thickness:g}_"
                              f"g0_hmax{hmax:g}_{n_t}.npz")
    t0 = time.perf_counter()
    data, computed = load_or_compute(fn, lambda: _sections_data(sheet, hmax, n_t))
    note(log, solves_step([("the rectangle", data)] if computed else [], 1,
                          time.perf_counter() - t0))
    return data


def draw_figS4(data, quality: str = "paper", sheet=None):
    """Draw Fig. S4 from :func:`figS4_data`: three panels against t/a, one line per section.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.tile(np.linspace(-.5, .5, 9), (3, 1))
    >>> d = dict(s=np.array([.4, .8, 1.2]), t=t, u=t**4 * 1e-3, v=t**3 * 1e-3, w=t**2 * 1e-2,
    ...          hmax=0.1, dofs=10, layers=2, converged=True)
    >>> len(draw_figS4(d, "quick").axes)
    3
    """
    sheet = sheet or figS4_sheet()
    H = sheet.thickness
    t = np.asarray(data["t"])
    with styled_figure(FULL_WIDTH, 2.5) as fig:
        axes = fig.subplots(1, 3, gridspec_kw=dict(left=0.07, right=0.99, bottom=0.19,
                                                   top=0.86, wspace=0.34))
        scaled = (("u", H**2, "$u/(h/a)^2$"), ("v", H**2, "$v/(h/a)^2$"),
                  ("w", H, "$w/(h/a)$"))
        for ax, (key, scale, label), letter in zip(axes, scaled, "abc"):
            for i, s in enumerate(np.asarray(data["s"])):
                y = np.asarray(data[key])[i]
                lab = f"$s/a={fmt(round(float(s), 6))}$"
                if key == "w":
                    c, res = quadratic_fit(t[i], y)
                    ax.plot(t[i], (c[0] + c[1] * t[i] + c[2] * t[i] ** 2) / scale, color="k",
                            lw=0.6, ls="--", zorder=3)
                    lab += f" (quadratic: resid. {res:.3f})"
                ax.plot(t[i], y / scale, color=_COLOURS[i % 3], label=lab)
            ax.axhline(0, color="0.7", lw=0.5, zorder=0)
            ax.set_xlabel("$t/a$")
            ax.set_ylabel(label)
            ax.set_xlim(-0.5, 0.5)
            panel_label(ax, f"({letter})", loc=(0.02, 0.1) if key == "w" else (0.02, 0.97))
        axes[2].legend(loc="upper center", fontsize=5.5, frameon=False)
        axes[0].legend(loc="lower center", fontsize=6, frameon=False)
        fig.text(0.5, 0.995, f"rectangle, $L/a={fmt(sheet.length)}$, "
                             f"$a/R={fmt(sheet.curvature)}$, $h/a={fmt(H)}$, no gravity; "
                             "displacements relative to the cross-section's rigid motion "
                             "(dashed: least-squares quadratics)",
                 ha="center", va="top", fontsize=7)
        status = "" if data.get("converged", True) else ", NOT converged"
        mesh_footnote(fig, quality, f"FE hmax {fmt(float(data['hmax']))}, "
                                    f"{int(data['layers'])} layers, {int(data['dofs'])} "
                                    f"unknowns (symmetric half){status}")
    return fig


def figS4(quality="quick", data_dir=DEFAULT_DATA_DIR, progress=True, workers=None, log=None):
    """Fig. S4: scaled u, v, w of the gravity-free rectangle at s/a = 0.4, 0.8, 1.2.

    ``workers`` is accepted for a uniform signature; ``log`` as in :func:`figS4_data`.

    Examples
    --------
    >>> figS4("quick").savefig("figS4.png", dpi=200)  # doctest: +SKIP
    """
    return draw_figS4(figS4_data(quality, data_dir, progress, log), quality)
