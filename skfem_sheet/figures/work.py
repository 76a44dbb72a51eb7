"""What drawing a figure cost: one :class:`DataStep` per table a figure read or computed.

Every data function of the figures (the fold map, the fold curves, fig3's
solves, fig5's and fig6's ribbon curves, the supplement's solves) takes
``log=None``, a list; when given, it appends one :class:`DataStep` saying
what it computed in this run and what it read from the data folder, with the
counters the computations already keep: the fold-curve rows' and the
solves' ``factorizations`` (:attr:`skfem_sheet.result.Result.factorizations`
plus the coarse start's), the fold-map rows' ``newton_iterations`` (the
continuation's factorisations and the start solves' Newton linearisations,
one factorisation each; the few extra factorisations at converged start
states are not recorded there).  :class:`FigureRun` is one figure of
``figure all`` (:func:`skfem_sheet.figures.batch.make_all`): its wall time,
its steps, and what dominated; :func:`summary_text` and :func:`summary_json`
are its table.

Examples
--------
>>> log = []
>>> note(log, DataStep("FE solves", computed=2, solves=2, factorizations=30, wall_time_s=4.0))
>>> run = FigureRun("fig3", "fig3.png", 5.0, tuple(log))
>>> run.solves, run.factorizations, run.dominated
(2, 30, 'FE solves: 2 computed (80%)')
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

__all__ = ["DataStep", "FigureRun", "note", "solves_step", "summary_rows", "summary_text", "summary_json",
           "SUMMARY_HEADER"]


@dataclass(frozen=True)
class DataStep:
    """One table a figure read or computed in one run.

    Attributes
    ----------
    what : str
        The kind of data: ``"fold map"``, ``"fold curves"``, ``"FE solves"``,
        ``"ribbon model"``.
    computed, cached : int
        Units computed in this run and units read from the data folder (map
        points, curves, solves, ribbon continuations or shapes).
    solves : int
        Finite-element computations run in this run: one per solve, fold-map
        point (its two continuations in L) or fold curve (0 for the ribbon
        model, which is not finite elements).
    factorizations : int
        Tangent factorisations of those, as their records count them (see
        the module's text); units whose record has no count add nothing.
    wall_time_s : float
        Wall time of the step in this process (reading and computing).
    compute_s : float
        The computed units' own wall times summed (over the workers: it can
        exceed ``wall_time_s``); ``nan`` where the records keep none.
    longest : str
        The longest unit computed and its time, e.g. ``"a/R 5 (782 s)"``
        (``""`` if none was computed or the records do not tell).
    finite_elements : bool
        Its units are finite-element computations (False: the ribbon model).
    """

    what: str
    computed: int = 0
    cached: int = 0
    solves: int = 0
    factorizations: int = 0
    wall_time_s: float = 0.0
    compute_s: float = math.nan
    longest: str = ""
    finite_elements: bool = True

    def to_json(self) -> dict:
        return {"what": self.what, "computed": self.computed, "cached": self.cached,
                "solves": self.solves, "factorizations": self.factorizations,
                "wall_time_s": self.wall_time_s, "compute_s": self.compute_s,
                "longest": self.longest, "finite_elements": self.finite_elements}


def note(log, step: DataStep) -> None:
    """Append ``step`` to ``log`` (a list), if there is one."""
    if log is not None:
        log.append(step)


def solves_step(solved, n, wall_time_s) -> DataStep:
    """The :class:`DataStep` of ``n`` cached solves of which ``solved``,
    ``[(name, data)]``, ran now (``data``: the cached table, with the solve's
    ``factorizations`` and ``wall_time_s`` where it records them).

    Examples
    --------
    >>> s = solves_step([("d", {"factorizations": 30, "wall_time_s": 2.0})], 6, 2.5)
    >>> s.computed, s.cached, s.factorizations, s.longest
    (1, 5, 30, 'd (2 s)')
    """
    times = [(float(d["wall_time_s"]), name) for name, d in solved if "wall_time_s" in d]
    longest = max(times) if times else None
    return DataStep("FE solves", computed=len(solved), cached=n - len(solved),
                    solves=len(solved),
                    factorizations=int(sum(int(d.get("factorizations", 0)) for _, d in solved)),
                    wall_time_s=float(wall_time_s),
                    compute_s=float(sum(t for t, _ in times)) if times else math.nan,
                    longest=f"{longest[1]} ({longest[0]:.0f} s)" if longest else "")


@dataclass(frozen=True)
class FigureRun:
    """One figure of ``figure all``: where it went, what it cost, what failed.

    Attributes
    ----------
    name : str
        The figure (a key of :data:`skfem_sheet.figures.FIGURES`).
    out : str
        The file written (``""`` if the figure failed).
    wall_time_s : float
        From the figure's first data step to its file written.
    steps : tuple of DataStep
        Its data steps, in the order they ran.
    error : str
        ``"ExceptionType: message"`` if the figure failed, else ``""``.
    """

    name: str
    out: str
    wall_time_s: float
    steps: tuple = field(default_factory=tuple)
    error: str = ""

    @property
    def solves(self) -> int:
        return int(sum(s.solves for s in self.steps))

    @property
    def factorizations(self) -> int:
        return int(sum(s.factorizations for s in self.steps))

    @property
    def cached(self) -> int:
        """Finite-element computations read from the data folder instead of run."""
        return int(sum(s.cached for s in self.steps if s.finite_elements))

    @property
    def draw_s(self) -> float:
        """The wall time outside the data steps: drawing and writing the file."""
        return max(0.0, self.wall_time_s - sum(s.wall_time_s for s in self.steps))

    @property
    def dominated(self) -> str:
        """The step (or the drawing) that took most of the wall time, with its share.

        Examples
        --------
        >>> FigureRun("fig2", "f.png", 2.0, (DataStep("fold map", cached=8, wall_time_s=0.5),)
        ...           ).dominated
        'drawing (75%)'
        """
        if self.error:
            return f"failed: {self.error}"
        parts = [(s.wall_time_s, s) for s in self.steps] + [(self.draw_s, None)]
        t, step = max(parts, key=lambda p: p[0])
        share = f"{100 * t / self.wall_time_s:.0f}%" if self.wall_time_s > 0 else "-"
        if step is None:
            return f"drawing ({share})"
        done = f"{step.computed} computed" if step.computed else f"{step.cached} cached"
        text = f"{step.what}: {done} ({share})"
        return f"{text}, longest {step.longest}" if step.longest else text

    def to_json(self) -> dict:
        return {"name": self.name, "out": self.out, "wall_time_s": self.wall_time_s,
                "draw_s": self.draw_s, "solves": self.solves,
                "factorizations": self.factorizations, "cached": self.cached, "dominated": self.dominated, "error": self.error,
                "steps": [s.to_json() for s in self.steps]}


#: Columns of :func:`summary_text`.
SUMMARY_HEADER = ("figure", "wall s", "draw s", "solves", "factorisations", "cached",
                  "dominated by")


def summary_rows(runs) -> list:
    """One row of :data:`SUMMARY_HEADER` per run, then the total (strings)."""
    rows = [(r.name, f"{r.wall_time_s:.1f}", f"{r.draw_s:.1f}", str(r.solves),
             str(r.factorizations), str(r.cached), r.dominated)
            for r in runs]
    runs = list(runs)
    failed = sum(bool(r.error) for r in runs)
    rows.append(("total", f"{sum(r.wall_time_s for r in runs):.1f}",
                 f"{sum(r.draw_s for r in runs):.1f}", str(sum(r.solves for r in runs)),
                 str(sum(r.factorizations for r in runs)), str(sum(r.cached for r in runs)),
                 f"{failed} failed" if failed else ""))
    return rows


def summary_text(runs, title: str = "") -> str:
    """The summary as a fixed-width text table (``title`` on the first line, if given).

    Examples
    --------
    >>> run = FigureRun("fig3", "fig3.png", 5.0, (DataStep("FE solves", computed=6,
    ...                 solves=6, factorizations=120, wall_time_s=4.0),))
    >>> print(summary_text([run]))  # doctest: +NORMALIZE_WHITESPACE
    figure  wall s  draw s  solves  factorisations  cached  dominated by
    fig3       5.0     1.0       6             120       0  FE solves: 6 computed (80%)
    total      5.0     1.0       6             120       0
    """
    rows = [SUMMARY_HEADER, *summary_rows(runs)]
    widths = [max(len(r[i]) for r in rows) for i in range(len(SUMMARY_HEADER) - 1)]
    lines = [title] if title else []
    for r in rows:
        cells = [r[0].ljust(widths[0])] + [c.rjust(w) for c, w in zip(r[1:-1], widths[1:])]
        lines.append("  ".join(cells + [r[-1]]).rstrip())
    return "\n".join(lines)


def summary_json(runs, **about) -> dict:
    """The summary as JSON-ready data: ``about`` (e.g. quality, folders), the
    figures (:meth:`FigureRun.to_json`) and the totals."""
    runs = list(runs)
    return {**about, "figures": [r.to_json() for r in runs],
            "total": {"wall_time_s": sum(r.wall_time_s for r in runs),
                      "solves": sum(r.solves for r in runs),
                      "factorizations": sum(r.factorizations for r in runs),
                      "cached": sum(r.cached for r in runs),
                      "failed": [r.name for r in runs if r.error]}}
