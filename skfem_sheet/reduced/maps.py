"""Deflection map of the ribbon model over (L/a, b/a) -- the paper's Fig. 6.

For every shape factor b/a the ribbon model is continued in L in both
directions (:func:`~skfem_sheet.reduced.ribbon.ribbon_continuation`); the
result is a tidy table (one row per shape factor, length and direction) and a
colour map with the jumps of the increasing-L continuation (Fig. 6, dashed
curves) and of the decreasing-L one marked.
"""
from __future__ import annotations

import csv
from concurrent.futures import ProcessPoolExecutor
from contextlib import ExitStack

import numpy as np

from skfem_sheet.params import ParameterError, Sheet, check_range
from skfem_sheet.reduced._common import as_sheet
from skfem_sheet.reduced.ribbon import DEFAULT_ELEMENTS, ribbon_continuation

__all__ = ["ribbon_map", "write_map_csv", "plot_map", "map_grid", "jump_curve", "MAP_FIELDS"]

#: Column order of the tidy table.
MAP_FIELDS = ("curvature", "tip_width", "length", "direction", "deflection",
              "converged", "stable", "jumped")


def _one_shape(args):
    """Both continuations for one shape factor -> list of row dicts (picklable task)."""
    template, lengths, n_elements = args
    rows = []
    for direction in ("increasing", "decreasing"):
        br = ribbon_continuation(template, lengths, direction, n_elements=n_elements)
        for L, d, c, s, j in zip(br.lengths, br.deflection, br.converged, br.stable, br.jumped):
            rows.append({"curvature": template.curvature, "tip_width": template.tip_width,
                         "length": float(L), "direction": direction, "deflection": float(d),
                         "converged": bool(c), "stable": bool(s), "jumped": bool(j)})
    return rows


def ribbon_map(curvature: float, lengths, tip_widths, thickness: float = 0.03,
               modulus: float = 735.0, n_elements: int = DEFAULT_ELEMENTS,
               workers: int = 1, on_shape=None):
    """Tip deflection of the ribbon model over a grid of lengths and shape factors.

    Parameters
    ----------
    curvature : float
        a/R of the clamp (the map is at fixed curvature, Fig. 6a: 2.5, 6b: 5).
    lengths, tip_widths : array_like
        L/a and b/a grid values.
    thickness, modulus : float
        h/a and E/(rho g a).
    n_elements : int
        Elements of each ribbon solve.
    workers : int
        Processes over shape factors (1 = serial; else one pool of ``workers``
        processes for all of them).
    on_shape : callable() or None
        Called as each shape factor's two continuations are in (e.g. a
        progress bar's ``update``).

    Returns
    -------
    list of dict
        Rows with keys :data:`MAP_FIELDS`, ordered by shape factor, direction
        and continuation order; deflection positive downward.

    Examples
    --------
    >>> rows = ribbon_map(2.5, [1.2, 1.3], [1.0])
    >>> len(rows), sorted({r["direction"] for r in rows})
    (4, ['decreasing', 'increasing'])
    """
    lengths = np.unique(np.asarray(lengths, dtype=float).ravel())
    widths = np.asarray(tip_widths, dtype=float).ravel()
    if lengths.size == 0 or widths.size == 0:
        raise ParameterError("lengths and tip_widths must be non-empty")
    workers = int(check_range("workers", workers, 1, 64))
    templates = [as_sheet(Sheet(length=float(lengths[0]), tip_width=float(b),
                                curvature=curvature, thickness=thickness, modulus=modulus))
                 for b in widths]
    tasks = [(t, lengths, n_elements) for t in templates]
    chunks = []
    with ExitStack() as stack:
        if workers == 1:
            done = map(_one_shape, tasks)
        else:
            pool = stack.enter_context(ProcessPoolExecutor(max_workers=min(workers, len(tasks))))
            done = pool.map(_one_shape, tasks)
        for chunk in done:  # in the order of the shape factors
            chunks.append(chunk)
            if on_shape is not None:
                on_shape()
    return [row for chunk in chunks for row in chunk]


def write_map_csv(rows, path) -> None:
    """Write the tidy table of :func:`ribbon_map` with the :mod:`csv` module."""
    with open(path, "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=MAP_FIELDS)
        writer.writeheader()
        for row in rows:
            writer.writerow({k: row[k] for k in MAP_FIELDS})


def map_grid(rows, direction: str):
    """Arrange rows of one direction as (lengths, tip_widths, D[width, length], J, ok)."""
    sel = [r for r in rows if r["direction"] == direction]
    if not sel:
        raise ParameterError(f"direction must be present in the rows, got {direction!r}")
    Ls = np.unique([r["length"] for r in sel])
    bs = np.unique([r["tip_width"] for r in sel])
    D = np.full((bs.size, Ls.size), np.nan)
    J = np.zeros_like(D, dtype=bool)
    ok = np.zeros_like(D, dtype=bool)
    for r in sel:
        i, j = np.searchsorted(bs, r["tip_width"]), np.searchsorted(Ls, r["length"])
        D[i, j], J[i, j], ok[i, j] = r["deflection"], r["jumped"], r["converged"]
    return Ls, bs, D, J, ok


def jump_curve(rows, direction: str):
    """Per shape factor, the midpoint length of the (first) jump, or NaN."""
    Ls, bs, _, J, _ = map_grid(rows, direction)
    out = np.full(bs.size, np.nan)
    for i in range(bs.size):
        k = np.flatnonzero(J[i])
        if k.size:
            j = k[0] if direction == "increasing" else k[-1]
            out[i] = 0.5 * (Ls[j] + Ls[j - 1]) if j > 0 else Ls[j]
    return bs, out


def plot_map(rows, path, title: str = "") -> None:
    """Colour map of d/a over (L/a, b/a), both directions side by side, jumps marked."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(10, 4), sharey=True, constrained_layout=True)
    vmax = np.nanmax([r["deflection"] for r in rows])
    vmin = min(0.0, np.nanmin([r["deflection"] for r in rows]))
    for ax, direction in zip(axes, ("increasing", "decreasing")):
        Ls, bs, D, _, ok = map_grid(rows, direction)
        im = ax.pcolormesh(Ls, bs, np.where(ok, D, np.nan), shading="nearest",
                           vmin=vmin, vmax=vmax, cmap="viridis")
        for d2, style in (("increasing", "k--"), ("decreasing", "w:")):
            jb, jl = jump_curve(rows, d2)
            ax.plot(jl, jb, style, lw=2, label=f"jump ({d2} L)")
        ax.set_xlabel("L/a")
        ax.set_title(f"{direction} L" + (f" - {title}" if title else ""))
    axes[0].set_ylabel("b/a")
    axes[1].legend(loc="lower right", fontsize=8)
    fig.colorbar(im, ax=axes, label="d/a (downward)")
    fig.savefig(path, dpi=120)
    plt.close(fig)
