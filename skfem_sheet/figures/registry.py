"""The figures' registry: :data:`FIGURES` (name -> function) and :func:`make_figure`.

Examples
--------
>>> sorted(FIGURES)
['fig2', 'fig3', 'fig4', 'fig5', 'fig6', 'fig7', 'figS1', 'figS3', 'figS4', 'switching']
"""
from __future__ import annotations

from ..io import check_writable
from ..params import ParameterError
from .common import DEFAULT_DATA_DIR, quality_settings
from .figure2 import fig2
from .figure3 import fig3
from .figure4 import fig4
from .figure5 import fig5
from .figure6 import fig6
from .figure7 import fig7
from .figure_switching import fig_switching
from .figureS1 import figS1
from .figureS3 import figS3
from .figureS4 import figS4
from .style import DPI

__all__ = ["FIGURES", "make_figure"]

#: Figure name -> function ``(quality, data_dir, progress, workers, log) -> Figure``
#: (``log``: a list for the data steps, :mod:`skfem_sheet.figures.work`).
#: The command line (``skfem_sheet.cli``) offers exactly these names (and ``all``).
FIGURES = {"fig2": fig2, "fig3": fig3, "fig4": fig4, "fig5": fig5, "fig6": fig6,
           "fig7": fig7, "figS1": figS1, "figS3": figS3, "figS4": figS4,
           "switching": fig_switching}


def make_figure(name: str, quality: str = "quick", out=None, data_dir=DEFAULT_DATA_DIR,
                progress: bool = True, workers=None, log=None):
    """Compute (or read from the cache) and draw one figure; write it to ``out``.

    Parameters
    ----------
    name : str
        A key of :data:`FIGURES`.
    quality : {"quick", "paper"}
    out : str, optional
        PNG (or PDF/SVG) file to write, at 200 dpi.
    data_dir : str
        Folder of the cached tables (created if needed).
    progress : bool
        Progress bars on stderr.
    workers : int, optional
        Processes for the fold map (default: the fold map's own choice).
    log : list, optional
        Receives one :class:`~skfem_sheet.figures.work.DataStep` per table
        the figure read or computed.

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> make_figure("fig9")
    Traceback (most recent call last):
    ...
    skfem_sheet.params.ParameterError: name must be one of fig2, ..., switching, got 'fig9'
    """
    if name not in FIGURES:
        raise ParameterError(f"name must be one of {', '.join(FIGURES)}, got {name!r}")
    quality_settings(quality)
    if out is not None:
        check_writable("out", out, [".png", ".pdf", ".svg"])
    import matplotlib  # deferred: import cost; the backend is chosen before pyplot loads

    if out is not None:
        matplotlib.use("Agg", force=False)
    fig = FIGURES[name](quality=quality, data_dir=data_dir, progress=progress, workers=workers,
                        log=log)
    if out is not None:
        fig.savefig(out, dpi=DPI, bbox_inches="tight", pad_inches=0.02)
    return fig
