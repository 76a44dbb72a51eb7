"""The force-deflection curve of a sheet in its tip force: its points
(:class:`CurvePoint`: force, tip deflection, energy, inertia) and the curve
(:class:`ForceCurve`: its folds, the switching forces, the work identity
``dPi = F dw_tip`` integrated with Hermite cubics, its files).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..io import atomic_write, check_writable
from ..params import ParameterError


# -----------------------------------------------------------------------------
# the curve
# -----------------------------------------------------------------------------
@dataclass(frozen=True)
class CurvePoint:
    """One equilibrium of the force-deflection curve.

    Attributes
    ----------
    force : float
        The tip force F (``rho g a^3``, positive upward).
    tip_displacement : float
        ``w_tip``: the tip face's mean vertical displacement (a, upward).
    deflection : float
        d/a (positive downward; :func:`~skfem_sheet.analyses.observables.tip_deflection`).
    energy : float
        The sheet's own energy Pi (elastic and gravitational, without the
        tip force's potential; ``rho g a^4``).
    stiffness : float
        ``dF/dw_tip`` along the curve (``rho g a^2``): positive on a stable
        branch, 0 at a fold, negative on the unstable branch.
    negative_eigenvalues : int or None
        Of the constrained Hessian (None: unknown).
    kind : str
        ``"point"``, ``"fold"``, or the states at ``F = 0``: ``"start"``,
        ``"saddle"`` (the first crossing of F = 0 after the start), ``"end"``.
    """

    force: float
    tip_displacement: float
    deflection: float
    energy: float
    stiffness: float
    negative_eigenvalues: object
    kind: str = "point"

    @property
    def stable(self):
        """No negative eigenvalue (None: unknown; a fold: False)."""
        if self.kind == "fold":
            return False
        k = self.negative_eigenvalues
        return None if k is None else k == 0


def _hermite(w0, F0, k0, w1, F1, k1) -> float:
    """``int F dw`` over ``[w0, w1]`` of the cubic Hermite interpolant of F(w)
    with the slopes ``k = dF/dw`` at both ends (exact for cubics)."""
    h = w1 - w0
    return 0.5 * h * (F0 + F1) + h * h * (k0 - k1) / 12.0


@dataclass(frozen=True)
class ForceCurve:
    """The curve of equilibria in the tip force F, traced from a state at F = 0.

    Attributes
    ----------
    points : tuple of CurvePoint
        In the order traced: the start state, the points, the folds where
        they lie, the crossings of F = 0 (``kind`` says which).
    hmax : float
        The mesh it was traced on.
    direction : int
        ``-1``: traced pushing down from the start (the aloft state), ``+1``:
        pulling up.
    completed : bool
        It came back to F = 0 twice (saddle and end state), or ended where
        ``|F|`` left the range traced (``reason`` says which).
    reason : str
        Why the trace ended ("" for an S traced to its other end).
    shape : str
        ``"one S"`` (two folds, one negative eigenvalue between them and none
        outside), or what it is instead (the notes say more).
    notes : tuple of str
        More folds than an S has, an inertia change without a turn (a branch
        point), a fold not confirmed by the inertia, a tip that turns.
    factorizations : int
    wall_time_s : float
    problem : SheetProblem
        The discrete sheet (at F = 0) the states belong to.
    states : dict
        Full dof vectors of the start, ``fold 1``, ``fold 2`` ..., the
        ``saddle`` and the ``end`` state, by kind.
    null_vectors : dict
        The null vectors (free dofs) of the folds, ``fold 1`` ...
    """

    points: tuple
    hmax: float
    direction: int
    completed: bool
    reason: str
    shape: str
    notes: tuple = ()
    factorizations: int = 0
    wall_time_s: float = 0.0
    problem: object = field(default=None, repr=False)
    states: dict = field(default_factory=dict, repr=False)
    null_vectors: dict = field(default_factory=dict, repr=False)

    # -- arrays ----------------------------------------------------------------
    @property
    def forces(self):
        return np.array([p.force for p in self.points])

    @property
    def tip_displacements(self):
        return np.array([p.tip_displacement for p in self.points])

    @property
    def deflections(self):
        return np.array([p.deflection for p in self.points])

    @property
    def energies(self):
        return np.array([p.energy for p in self.points])

    @property
    def stable(self):
        return [p.stable for p in self.points]

    def names(self) -> list:
        """The name of every point: its kind, the folds numbered in the order
        traced (``"start"``, ``"point"``, ``"fold 1"``, ..., ``"saddle"``,
        ``"fold 2"``, ..., ``"end"``)."""
        out, n = [], 0
        for p in self.points:
            if p.kind == "fold":
                n += 1
                out.append(f"fold {n}")
            else:
                out.append(p.kind)
        return out

    def index(self, name: str) -> int:
        """The position of the point named ``name`` (:meth:`names`)."""
        names = self.names()
        if name == "point" or name not in names:
            allowed = ", ".join(n for n in names if n != "point")
            raise ParameterError(f"name must be one of the curve's points ({allowed}), got "
                                 f"{name!r}")
        return names.index(name)

    @property
    def folds(self) -> tuple:
        """The fold points, in the order traced."""
        return tuple(p for p in self.points if p.kind == "fold")

    def point(self, name: str):
        """The point named ``name`` (``"saddle"``, ``"end"``, ``"fold 1"`` ...), or None."""
        try:
            return self.points[self.index(name)]
        except ParameterError:
            return None

    def work(self, start: str = "start", end: str = "saddle") -> float:
        """``int F dw_tip`` along the curve from the point ``start`` to ``end``
        (names as :meth:`names`; Hermite cubics in ``w_tip`` with the slopes at
        the points; trapezoids where the tip turns, ``w_tip`` not monotone): by
        the work identity ``Pi(end) - Pi(start)``.

        Examples
        --------
        On ``F = w^2`` from ``w = 0`` to 1 (slope ``2 w``; exact: 1/3):

        >>> pts = [CurvePoint(w * w, w, 0.0, 0.0, 2 * w, 0, k)
        ...        for w, k in ((0.0, "start"), (0.5, "point"), (1.0, "saddle"))]
        >>> round(ForceCurve(tuple(pts), 0.1, -1, True, "", "one S").work(), 12)
        0.333333333333
        """
        i, j = self.index(start), self.index(end)
        sign = 1.0
        if j < i:
            i, j, sign = j, i, -1.0
        total = 0.0
        pts = self.points[i:j + 1]
        w = np.array([p.tip_displacement for p in pts])
        monotone = bool(np.all(np.diff(w) <= 0) or np.all(np.diff(w) >= 0))
        for a, b in zip(pts[:-1], pts[1:]):
            if monotone and np.isfinite(a.stiffness) and np.isfinite(b.stiffness):
                total += _hermite(a.tip_displacement, a.force, a.stiffness,
                                  b.tip_displacement, b.force, b.stiffness)
            else:
                total += 0.5 * (b.tip_displacement - a.tip_displacement) * (a.force + b.force)
        return sign * total

    def to_csv(self) -> str:
        """The points as CSV text: ``force, tip_displacement, deflection, energy,
        stiffness, negative_eigenvalues, kind`` (units of ``rho g a^3``, a,
        ``rho g a^4``, ``rho g a^2``; an unknown inertia empty)."""
        lines = ["force,tip_displacement,deflection,energy,stiffness,negative_eigenvalues,kind"]
        for p in self.points:
            k = "" if p.negative_eigenvalues is None else str(p.negative_eigenvalues)
            lines.append(f"{p.force!r},{p.tip_displacement!r},{p.deflection!r},{p.energy!r},"
                         f"{p.stiffness!r},{k},{p.kind}")
        return "\n".join(lines) + "\n"

    def write(self, filename) -> None:
        """Write :meth:`to_csv` to ``filename`` (atomically)."""
        check_writable("filename", filename, [".csv"])
        atomic_write(filename, self.to_csv())

    def summary(self) -> dict:
        """JSON-ready: the arrays, the folds, the shape."""
        return {"hmax": self.hmax, "direction": self.direction, "completed": self.completed,
                "reason": self.reason, "shape": self.shape, "notes": list(self.notes),
                "force": self.forces.tolist(), "tip_displacement": self.tip_displacements.tolist(),
                "deflection": self.deflections.tolist(), "energy": self.energies.tolist(),
                "stiffness": [p.stiffness for p in self.points],
                "negative_eigenvalues": [p.negative_eigenvalues for p in self.points],
                "kind": [p.kind for p in self.points],
                "factorizations": self.factorizations, "wall_time_s": self.wall_time_s}
