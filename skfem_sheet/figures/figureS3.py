"""Fig. S3: in-plane strains E_ss, E_st, E_tt and stresses T_ss, T_tt of a gravity-free rectangle.

Supplement, "Motivation/validation of reduced-order ansatzes": a rectangle of
L/a = 1.5, a/R = 0.5, h/a = 0.03175 without gravity (``solve(...,
gravity=0.0)``).  The fields are those of
:mod:`skfem_sheet.analyses.midsurface` on the reference plan (s, t): the
mid-surface's Green--Lagrange strains and the paper's plate stresses
``T_ij = Y [(1 - nu) E_ij + nu E_kk delta_ij]`` shown as ``T/Y`` (``Y = E h /
(1 - nu^2)``).  Each panel has its own symmetric colour range, the field's
largest magnitude (so the clamp layer shows as it is), in units of
``(h/a)^2``, the reduced model's order of the in-plane strains.  The dashed
line is the clamp layer's edge, ``ln(20) sqrt(R h)/(3 (1 - nu^2))^(1/4)``
(:func:`~skfem_sheet.analyses.midsurface.clamp_layer_width`).

The grid is cached in ``data_dir/figS3-<quality>/*.npz``.

Examples
--------
>>> figS3_sheet().length, figS3_sheet().curvature, figS3_sheet().thickness
(1.5, 0.5, 0.03175)
"""
from __future__ import annotations

import os
import time

import numpy as np

from ..analyses.midsurface import clamp_layer_width, midsurface
from ..params import Sheet
from ..solve import solve
from .cache import data_folder, load_or_compute
from .common import DEFAULT_DATA_DIR, quality_settings
from .style import FULL_WIDTH, fmt, mesh_footnote, styled_figure
from .work import note, solves_step

__all__ = ["figS3_sheet", "figS3_data", "draw_figS3", "figS3", "FIELDS_S3",
           "supplement_solve"]

#: Panels: (key of the cached grid, label).
FIELDS_S3 = (("E_ss", "$E_{ss}$"), ("E_st", "$E_{st}$"), ("E_tt", "$E_{tt}$"),
             ("T_ss", "$T_{ss}/Y$"), ("T_tt", "$T_{tt}/Y$"))


def figS3_sheet() -> Sheet:
    """The sheet of Fig. S3: rectangle, L/a 1.5, a/R 0.5, h/a 0.03175 (E/(rho g a) 735)."""
    return Sheet(length=1.5, curvature=0.5, thickness=0.03175)


def supplement_solve(sheet, hmax):
    """``solve(sheet, hmax=hmax, gravity=0.0)`` (curvature-first, the symmetric half)."""
    return solve(sheet, hmax=hmax, gravity=0.0)


def _grid_data(sheet, hmax, n_s, n_t):
    r = supplement_solve(sheet, hmax)
    m = midsurface(r.problem, r.w, np.linspace(0.0, sheet.length, n_s), n_across=n_t)
    return {"s": m.s, "t": m.t, "E_ss": m.E_ss, "E_st": m.E_st, "E_tt": m.E_tt,
            "T_ss": m.T_ss, "T_tt": m.T_tt, "u": m.u, "v": m.v, "w": m.w,
            "hmax": float(hmax), "dofs": int(r.dofs), "layers": int(r.layers),
            "converged": bool(r.converged), "deflection": float(r.deflection),
            "factorizations": int(r.factorizations + r.coarse_factorizations),
            "wall_time_s": float(r.wall_time_s)}


def figS3_data(quality="quick", data_dir=DEFAULT_DATA_DIR, progress=True, log=None):
    """The mid-surface grid of the Fig. S3 sheet (a dict of arrays), cached.

    ``log``: a list to append the step's
    :class:`~skfem_sheet.figures.work.DataStep` to (one solve, or none).

    Returns
    -------
    dict
        ``s`` (n_s,), ``t`` (n_s, n_t), the fields of :data:`FIELDS_S3` and
        ``u, v, w`` (n_s, n_t), ``hmax``, ``dofs``, ``layers``, ``converged``
        (and, cached since they were recorded, the solve's ``factorizations``
        and ``wall_time_s``).
    """
    s = quality_settings(quality)
    hmax, (n_s, n_t) = s["hmax_supplement"], s["supplement_grid"]
    sheet = figS3_sheet()
    folder = data_folder(data_dir, f"figS3-{quality}")
    fn = os.path.join(folder, f"L{sheet.length:g}_k{sheet.curvature:g}_h{sheet.thickness:g}_"
                              f"g0_hmax{hmax:g}_{n_s}x{n_t}.npz")
    t0 = time.perf_counter()
    data, computed = load_or_compute(fn, lambda: _grid_data(sheet, hmax, n_s, n_t))
    note(log, solves_step([("the rectangle", data)] if computed else [], 1,
                          time.perf_counter() - t0))
    return data


def draw_figS3(data, quality: str = "paper", sheet=None):
    """Draw Fig. S3 from :func:`figS3_data`: five colour maps over the plan (s, t).

    Examples
    --------
    >>> import numpy as np
    >>> s = np.linspace(0, 1.5, 4); t = np.tile(np.linspace(-.5, .5, 5), (4, 1))
    >>> d = {k: np.outer(s, np.ones(5)) * 1e-3 for k, _ in FIELDS_S3}
    >>> d.update(s=s, t=t, hmax=0.1, dofs=10, layers=2, converged=True)
    >>> fig = draw_figS3(d, "quick")
    >>> len(fig.axes)   # five maps, their colour bars, the notes
    11
    """
    from matplotlib import colors  # deferred: import cost (see figures.style)

    sheet = sheet or figS3_sheet()
    H = sheet.thickness
    layer = clamp_layer_width(sheet)
    s, t = np.asarray(data["s"]), np.asarray(data["t"])
    S = np.repeat(s[:, None], t.shape[1], axis=1)
    with styled_figure(FULL_WIDTH, 3.9) as fig:
        gs = fig.add_gridspec(2, 3, left=0.06, right=0.97, bottom=0.11, top=0.9,
                              wspace=0.38, hspace=0.42)
        places = [gs[0, 0], gs[0, 1], gs[0, 2], gs[1, 0], gs[1, 1]]
        for i, ((key, label), place) in enumerate(zip(FIELDS_S3, places)):
            ax = fig.add_subplot(place)
            field = np.asarray(data[key]) / H**2
            vmax = float(np.abs(field).max()) or 1.0
            mesh = ax.pcolormesh(S, t, field, shading="gouraud", cmap="RdBu_r",
                                 norm=colors.Normalize(-vmax, vmax), rasterized=True)
            ax.axvline(layer, color="k", lw=0.7, ls="--")
            ax.set_aspect("equal")
            ax.set_xlim(0, sheet.length)
            ax.set_ylim(-0.5, 0.5)
            ax.set_xlabel("$s/a$")
            if i % 3 == 0:
                ax.set_ylabel("$t/a$")
            ax.set_title(label + " $/(h/a)^2$", pad=3)
            cb = fig.colorbar(mesh, ax=ax, shrink=0.85, pad=0.03)
            cb.ax.tick_params(labelsize=6)
        ax = fig.add_subplot(gs[1, 2])
        ax.axis("off")
        ax.text(0.0, 0.95,
                f"rectangle, $L/a={fmt(sheet.length)}$, $a/R={fmt(sheet.curvature)}$,\n"
                f"$h/a={fmt(H)}$, no gravity\n\n"
                "Green–Lagrange strains of the mid-surface;\n"
                r"plate stresses $T_{ij}=Y[(1-\nu)E_{ij}+\nu E_{kk}\delta_{ij}]$," + "\n"
                r"$Y=Eh/(1-\nu^2)$, $\nu=1/2$" + "\n\n"
                "colour ranges: $\\pm$ each field's largest $|.|$,\n"
                "in units of $(h/a)^2$\n\n"
                f"dashed: clamp layer, $s/a < {layer:.2f}$\n"
                r"($\ln 20\,\sqrt{Rh}/[3(1-\nu^2)]^{1/4}$)" + "\n"
                f"$(h/a)^2 = {H**2:.2e}$",
                va="top", ha="left", fontsize=6.5, transform=ax.transAxes)
        status = "" if data.get("converged", True) else ", NOT converged"
        mesh_footnote(fig, quality, f"FE hmax {fmt(float(data['hmax']))}, "
                                    f"{int(data['layers'])} layers, {int(data['dofs'])} "
                                    f"unknowns (symmetric half){status}")
    return fig


def figS3(quality="quick", data_dir=DEFAULT_DATA_DIR, progress=True, workers=None, log=None):
    """Fig. S3: strains and stresses of the gravity-free rectangle (one FE solve).

    ``workers`` is accepted for a uniform signature; ``log`` as in :func:`figS3_data`.

    Examples
    --------
    >>> figS3("quick").savefig("figS3.png", dpi=200)  # doctest: +SKIP
    """
    return draw_figS3(figS3_data(quality, data_dir, progress, log), quality)
