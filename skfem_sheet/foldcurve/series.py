"""A fold curve's states as a ParaView series (:class:`skfem_sheet.io.Series`)."""
from __future__ import annotations

import numpy as np

__all__ = ["SeriesCollector", "Snapshot", "add_frame"]


class Snapshot:
    """What :func:`skfem_sheet.io.state_fields` and :func:`skfem_sheet.io.in_units`
    read of a problem, for one state: a series frame then holds vertex fields
    (and the sheet, for its SI scales), not the mapped problem's basis data."""

    def __init__(self, problem, w):
        self.sheet, self.sheet_mesh, self.length = (problem.sheet, problem.sheet_mesh,
                                                    problem.length)
        U, p = problem.split(w)
        self._split = (np.array(U), np.array(p))
        self._pressure = np.array(problem.paper_pressure(w))
        self._psi = np.array(problem.energy_density(w))

    def split(self, w):
        return self._split

    def paper_pressure(self, w):
        return self._pressure

    def energy_density(self, w):
        return self._psi


def add_frame(series, P, u, p):
    """One fold-curve point into ``series`` (time: its index)."""
    w = P.full(u, p)
    series.add(len(series), Snapshot(P.problem(p), w), w, length=float(p[0]),
               tip_width=float(p[1]), curvature=float(P.kappa(p)))


class SeriesCollector:
    """The direct trace's points into a series (the point a remesh repeats
    is dropped, as the trace drops it)."""

    def __init__(self, series):
        self.series = series

    def __call__(self, P, pt, u, v):
        add_frame(self.series, P, u, pt.p)

    def drop_last(self):
        if len(self.series):
            self.series.frames.pop()
