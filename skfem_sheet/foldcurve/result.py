"""The result of a fold-curve trace: :class:`FoldCurve`."""
from __future__ import annotations

from dataclasses import dataclass, field

__all__ = ["FoldCurve"]


@dataclass(frozen=True)
class FoldCurve:
    """The fold curve in (L, b) of one clamp curvature.

    Attributes
    ----------
    curvature : float
    points : tuple of dict
        ``{"tip_width", "length", "kind"}`` in the order traced (from the
        standout fold at ``b = 1`` through the cusp to the pop-up fold);
        ``kind`` is ``"standout"`` or ``"popup"``.
    cusp : dict or None
        ``{"tip_width", "length"}`` where the two folds meet.
    factorizations : int
        All factorisations (the starting solve and fold search included).
    factorizations_per_point : float
        Median over the points of the curve's continuation.
    wall_time_s : float
    hmax : float
    completed : bool
        The curve came back to ``b = 1``.
    reason : str
    negative_eigenvalues : tuple
        Per point, besides the critical one (None if unknown).
    crossing : tuple
        Per point, negative eigenvalue counts on both sides along the null
        vector (where checked; None elsewhere).

    Examples
    --------
    >>> c = FoldCurve(2.5, ({"tip_width": 1.0, "length": 1.35, "kind": "standout"},
    ...                     {"tip_width": 0.63, "length": 1.24, "kind": "standout"},
    ...                     {"tip_width": 1.0, "length": 1.21, "kind": "popup"}),
    ...               {"tip_width": 0.63, "length": 1.24}, 120, 4.0, 10.0, completed=True)
    >>> c.standout_length, c.popup_length
    (1.35, 1.21)
    """

    curvature: float
    points: tuple
    cusp: object
    factorizations: int
    factorizations_per_point: float
    wall_time_s: float
    hmax: float = 0.1
    completed: bool = False
    reason: str = ""
    negative_eigenvalues: tuple = ()
    crossing: tuple = ()
    curve: object = field(default=None, repr=False, compare=False)
    #: The second parameter of the curve ("tip_width", or "curvature" for
    #: :func:`trace_curvature_fold_curve`, whose points carry "curvature").
    second: str = "tip_width"
    #: The fixed tip width of a curve in (L, a/R).
    tip_width: float = 1.0
    #: False: the curvature-dominated branch at the start went through the
    #: whole length range without a fold (no bistable range; no points).
    bistable: bool = True
    #: Fresh meshes made on the way (state transferred each time).
    remeshes: int = 0
    #: ``(L_m, b_m)`` at which each mesh of the trace was made, in order (the
    #: first mesh, then one per remesh; coarse to fine: the coarse trace's,
    #: then the finest level's).  At a coarse mesh the folds depend on where
    #: the mesh was made (hmax 0.2, a/R 2.5: L0*(1) from 1.218 to 1.270 over
    #: meshes made at L_m from 0.95 to 1.37), so a comparison of two traces
    #: is made on the mesh they share (tests/test_foldcurve.py).
    meshes: tuple = ()
    #: How the cusp was found: "fold coefficient" (its sign change, located
    #: by regula falsi), "turning point" (where the second parameter turns
    #: back, if the sign change was not seen), for a curve refined coarse to
    #: fine "fold coefficient on the fine mesh" (the sign change of the
    #: refined points' coefficient, located there) or "refined points" (the
    #: turn of the refined points), or "" (no cusp).
    cusp_located: str = ""
    #: Factorisations spent locating the cusp on the fine mesh (coarse to
    #: fine; not counted in ``factorizations_per_point``, counted in
    #: ``factorizations``).
    cusp_factorizations: int = 0
    #: Coarse to fine (``coarse_hmax``): the mesh of the coarse trace, its
    #: points and factorisations (None: the curve was traced at ``hmax``).
    coarse_hmax: object = None
    coarse_points: object = None
    coarse_factorizations: object = None
    #: Per refinement level: ``{"hmax", "points", "failed", "refilled",
    #: "settled", "factorizations", "factorizations_per_point"}`` (the last
    #: one is ``hmax``; ``refilled``: points traced on that mesh,
    #: ``settled``: points located from their carried state settled first,
    #: :func:`~skfem_sheet.foldcurve.refine.settled_fold`).
    stages: tuple = ()

    def _at_start_value(self, kind):
        end = 1.0 if self.second == "tip_width" else self.curvature
        for pt in self.points:
            if pt["kind"] == kind and abs(pt[self.second] - end) < 1e-9:
                return pt["length"]
        return None

    @property
    def standout_length(self):
        """``L1*`` where the curve starts (``b = 1``, or the start curvature;
        None if not on the curve)."""
        return self._at_start_value("standout")

    @property
    def popup_length(self):
        """``L0*`` where the curve ends (None if the curve did not come back)."""
        return self._at_start_value("popup")

    def record(self) -> dict:
        """:meth:`summary` plus the status: ``completed``, ``bistable``,
        ``reason``, ``remeshes``, ``hmax``, ``standout_length``, ``popup_length``."""
        out = self.summary()
        out.update(hmax=self.hmax, completed=bool(self.completed), bistable=bool(self.bistable),
                   reason=self.reason, remeshes=int(self.remeshes),
                   cusp_located=self.cusp_located,
                   standout_length=self.standout_length, popup_length=self.popup_length,
                   coarse_hmax=self.coarse_hmax, coarse_points=self.coarse_points,
                   coarse_factorizations=self.coarse_factorizations)
        return out

    def summary(self) -> dict:
        """JSON-ready: curvature, points, cusp, factorizations,
        factorizations_per_point, wall_time_s (and for a curve in (L, a/R):
        parameter = "curvature" and its tip_width)."""
        out = {"curvature": self.curvature, "points": [dict(p) for p in self.points],
               "cusp": None if self.cusp is None else dict(self.cusp),
               "factorizations": self.factorizations,
               "factorizations_per_point": self.factorizations_per_point,
               "wall_time_s": self.wall_time_s}
        if self.second != "tip_width":
            out.update(parameter=self.second, tip_width=self.tip_width)
        return out
