"""The points and branches of a continuation in L or a/R.

:class:`BranchPoint` (one equilibrium on a branch), :class:`Branch` (a
branch followed by :func:`~skfem_sheet.bistability.follow_length` or
:func:`~skfem_sheet.bistability.follow_curvature`, to its fold or to why it
ends) and the base they share with the S-curve
(:class:`~skfem_sheet.bistability.SCurve`): the lengths, deflections,
stability and names of the points, and their series written to files.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from ..params import ParameterError


@dataclass(frozen=True)
class BranchPoint:
    """One equilibrium at full load: length, tip deflection, stability, and (where
    asked for, ``names=True``) its name (:func:`skfem_sheet.analyses.mode.mode_of`:
    "curvature-dominated" or "gravity-dominated", as ``solve`` names it)."""

    length: float
    deflection: float
    stable: object  # bool or None (solver cannot tell)
    negative_eigenvalues: object = None
    newton_iterations: int = 0
    name: str = ""


class Curve:
    """Arrays over the ``points`` (BranchPoint) of a continuation result."""

    @property
    def lengths(self):
        """Parameter values (lengths; curvatures for :func:`follow_curvature`)."""
        return np.array([p.length for p in self.points])

    @property
    def deflections(self):
        return np.array([p.deflection for p in self.points])

    @property
    def stable(self):
        return [p.stable for p in self.points]

    @property
    def names(self):
        """Each point's name ("" where not asked for)."""
        return [p.name for p in self.points]

    def write_series(self, directory, name, series) -> str:
        """Write the states of this curve as a ParaView series, ``directory/name.pvd``.

        ``series`` is the :class:`skfem_sheet.io.Series` passed as ``on_point``
        (its :meth:`~skfem_sheet.io.Series.on_point`) to the continuation that
        made this curve: one state per point.  Each VTU also holds the
        point's ``deflection`` and ``stable`` (1, 0, or -1 unknown) as field data.
        """
        if len(series) != len(self.points) or not np.allclose(
                [f.time for f in series.frames], self.lengths, rtol=0, atol=1e-12):
            raise ParameterError(f"series must hold one state per point of this curve "
                                 f"({len(self.points)}), got {len(series)} that do not match")
        data = [{"deflection": p.deflection, "stable": -1 if p.stable is None else int(p.stable)}
                for p in self.points]
        return series.write(directory, name, data=data)


@dataclass(frozen=True)
class Branch(Curve):
    """Result of :func:`follow_length` (and :func:`follow_curvature`).

    Attributes
    ----------
    points : tuple of BranchPoint
        The converged equilibria, in the order of the continuation.
    fold : float or None
        The parameter value (length, or curvature) of the fold where the
        branch ends, located with the minimally augmented system; None if
        the branch held over the whole range, or ended without a located
        fold (``reason`` says why).
    bracket : tuple
        ``(last value on the branch, the value of the step that failed)``
        where the branch ended short of its range (a fold or not).
    reason : str
        Why the continuation ended short of its range ("" if it did not).
    start_snapped : bool
        The starting solve (along its load path) snapped to the other
        branch: the branch the path selects does not exist at the start
        length, and the points are on the other one.
    fold_deflection : float
        d/a at the fold (NaN without one).
    fold_point : FoldPoint or None
        The located fold (:class:`skfem_sheet.engine.FoldPoint`: state,
        parameter, null vector) on ``problem``, the continuation's problem
        (its mesh at the fold); dropped from the branches :func:`fold_lengths`
        returns.
    """

    points: tuple
    fold: object = None
    bracket: tuple = ()
    reason: str = ""
    newton_iterations: int = 0
    wall_time_s: float = 0.0
    start_snapped: bool = False
    fold_deflection: float = math.nan
    fold_point: object = field(default=None, repr=False, compare=False)
    problem: object = field(default=None, repr=False, compare=False)

    def without_states(self) -> Branch:
        """The branch without its fold's state and problem (memory)."""
        return replace(self, fold_point=None, problem=None)

    def summary(self) -> dict:
        """JSON-ready: the points, the fold and why the branch ended."""
        return {"lengths": self.lengths.tolist(), "deflection": self.deflections.tolist(),
                "stable": self.stable, "fold": self.fold,
                "fold_deflection": self.fold_deflection, "bracket": list(self.bracket),
                "reason": self.reason, "start_snapped": self.start_snapped,
                "newton_iterations": self.newton_iterations, "wall_time_s": self.wall_time_s}
