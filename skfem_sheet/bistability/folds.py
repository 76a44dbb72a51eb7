"""The fold lengths of a sheet as results: :class:`Fold` (one fold located on
one mesh), :class:`FoldLengths` (both folds of a Sheet, its two branches, the
bistable window) and :class:`FoldPosition` (where a length sits against the
folds, :func:`fold_position`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

from ..params import Sheet
from ..version import __version__
from .branch import Branch
from .follow import FOLD_TOL

#: The kind of fold at the end of each branch, and the side its branch lies on
#: (:attr:`skfem_sheet.engine.FoldPoint.side`: the curvature-dominated branch
#: exists below ``L1*``, the gravity-dominated one above ``L0*``).
KINDS = {"standout": ("curvature-dominated", -1), "popup": ("gravity-dominated", +1)}


@dataclass(frozen=True)
class Fold:
    """A fold length located on one mesh: the end of one stable branch.

    Attributes
    ----------
    kind : str
        ``"standout"`` (``L1*``: the curvature-dominated branch ends there,
        longer sheets have none) or ``"popup"`` (``L0*``: the
        gravity-dominated one ends there, shorter sheets have none).
    length : float
        ``L*/a``, located to :data:`FOLD_TOL`.
    deflection : float
        d/a at the fold.
    crossing : tuple or None
        ``(n-, n+)``: the negative eigenvalue counts of the tangent on both
        sides of the fold along its null vector.
    negative_eigenvalues : int or None
        Besides the critical one: 0 for a fold at the end of a stable branch.
    hmax : float
        The mesh it was located on ...
    mesh_length : float
        ... made at this length (on the grid
        :data:`~skfem_sheet.foldcurve.options.MESH_LENGTH_GRID`, next to the
        fold).
    factorizations : int
        Work of locating it on that mesh (the crossing's two included).
    point, problem
        The located fold (:class:`skfem_sheet.engine.FoldPoint`: state, null
        vector) and its :class:`~skfem_sheet.sheet_shape.SheetShapeProblem`,
        kept only with ``fold_lengths(..., keep_states=True)`` (the fold's
        sensitivities, :func:`skfem_sheet.calibration.fold_length_sensitivities`).

    Examples
    --------
    >>> f = Fold("standout", 1.3472, 0.105, (0, 1), 0, 0.1, 1.35, 5)
    >>> f.confirmed, f.branch
    (True, 'curvature-dominated')
    """

    kind: str
    length: float
    deflection: float
    crossing: object
    negative_eigenvalues: object
    hmax: float
    mesh_length: float
    factorizations: int = 0
    point: object = field(default=None, repr=False, compare=False)
    problem: object = field(default=None, repr=False, compare=False)

    @property
    def branch(self) -> str:
        """The branch that ends at this fold."""
        return KINDS[self.kind][0]

    @property
    def confirmed(self):
        """Exactly one eigenvalue crosses zero at the fold (True), not (False),
        or unknown (None: the linear solver gives no inertia)."""
        if self.crossing is None:
            return None
        return abs(int(self.crossing[1]) - int(self.crossing[0])) == 1

    def to_json(self) -> dict:
        return {"kind": self.kind, "length": self.length, "deflection": self.deflection,
                "crossing": None if self.crossing is None else list(self.crossing),
                "confirmed": self.confirmed, "negative_eigenvalues": self.negative_eigenvalues,
                "hmax": self.hmax, "mesh_length": self.mesh_length,
                "factorizations": self.factorizations}


@dataclass(frozen=True)
class FoldPosition:
    """Where a length sits against the fold lengths of its planform and curvature.

    Attributes
    ----------
    length : float
        L/a.
    where : str
        ``"between"`` (both branches exist: two states), ``"below"`` (shorter
        than the pop-up length ``L0*``: only the curvature-dominated state),
        ``"above"`` (longer than the standout length ``L1*``: only the
        gravity-dominated state), ``"at a fold"`` (within :data:`FOLD_TOL`
        of one), ``"one branch"`` (a flat clamp: both paths are one problem;
        or no fold at all: one state at every length) or ``"unknown"``
        (outside what the continuations covered).
    states : int or None
        Number of stable states at this length (2, 1, or None if unknown).
    text : str
        The verdict in words.
    """

    length: float
    where: str
    states: object
    text: str

    def to_json(self) -> dict:
        return {"length": self.length, "where": self.where, "states": self.states,
                "text": self.text}


def _exists(branch, length, fold, up):
    """Whether the branch of a continuation (from the short end if ``up``, else
    the long end) exists at ``length``: True, False, "fold" or None (unknown)."""
    if branch.start_snapped or not len(branch.points):
        return None
    if fold is not None and math.isfinite(fold):
        if abs(length - fold) <= FOLD_TOL * max(1.0, fold):
            return "fold"
        return (length < fold) if up else (length > fold)
    if branch.reason:  # lost without a fold, short of the range: known where it was followed
        covered = branch.lengths.max() if up else branch.lengths.min()
        return True if (length <= covered + 1e-12 if up else length >= covered - 1e-12) else None
    return True


def fold_position(folds: FoldLengths, length: float) -> FoldPosition:
    """Where ``length`` sits against the fold lengths ``folds``.

    Parameters
    ----------
    folds : FoldLengths
        From :func:`fold_lengths`.
    length : float
        L/a of a sheet of that planform, curvature and material.

    Examples
    --------
    >>> from skfem_sheet.bistability import BranchPoint
    >>> def branch(Ls, fold):
    ...     return Branch(tuple(BranchPoint(L, 0.1, True, 0, 3) for L in Ls), fold,
    ...                   reason="" if fold is None else "fold")
    >>> sheet = Sheet(length=1.3, curvature=2.5)
    >>> f = FoldLengths(sheet, 0.1, (0.6, 2.4),
    ...                 Fold("standout", 1.347, 0.1, (0, 1), 0, 0.1, 1.35),
    ...                 Fold("popup", 1.202, 0.3, (1, 0), 0, 0.1, 1.2),
    ...                 branch([0.6, 1.3], 1.347), branch([2.4, 1.21], 1.202), 0.1)
    >>> fold_position(f, 1.3).where, fold_position(f, 1.0).where, fold_position(f, 2).states
    ('between', 'below', 1)
    >>> print(fold_position(f, 1.0).text)
    L/a = 1 is below the pop-up length L0* = 1.20200: one state, curvature-dominated (aloft)
    """
    L = float(length)
    lo, hi = folds.length_range
    L0, L1 = folds.popup_length, folds.standout_length

    def fmt(name, x, end):
        return (f"{name} = {x:.5f}" if math.isfinite(x) else
                f"{name} not in [{lo:g}, {hi:g}] (the branch held to L/a = {end:g})")

    if folds.sheet.curvature == 0.0:
        return FoldPosition(L, "one branch", 1, f"a flat clamp (a/R = 0): one state at every "
                                                 f"length, L/a = {L:g} too")
    if not lo <= L <= hi:
        return FoldPosition(L, "unknown", None, f"L/a = {L:g} lies outside the lengths searched, "
                                                f"[{lo:g}, {hi:g}]")
    if folds.decreasing is folds.increasing and not math.isfinite(L1):
        return FoldPosition(L, "one branch", 1,
                            f"no fold in [{lo:g}, {hi:g}]: one state at every length (the "
                            f"curvature-first branch from L/a = {lo:g} is the gravity-first "
                            f"one from {hi:g}), L/a = {L:g} too")
    cd = _exists(folds.increasing, L, L1, up=True)
    gd = _exists(folds.decreasing, L, L0, up=False)
    if "fold" in (cd, gd):
        which = "standout length L1*" if cd == "fold" else "pop-up length L0*"
        x = L1 if cd == "fold" else L0
        return FoldPosition(L, "at a fold", None,
                            f"L/a = {L:g} is within {FOLD_TOL:g} of the {which} = {x:.5f}: at "
                            f"the fold, where one of the two states ends")
    if cd is True and gd is True:
        return FoldPosition(L, "between", 2,
                            f"L/a = {L:g} lies between the pop-up length "
                            f"{fmt('L0*', L0, lo)} and the standout length "
                            f"{fmt('L1*', L1, hi)}: two states (bistable)")
    if cd is True and gd is False:
        return FoldPosition(L, "below", 1,
                            f"L/a = {L:g} is below the pop-up length L0* = {L0:.5f}: one "
                            f"state, curvature-dominated (aloft)")
    if cd is False and gd is True:
        return FoldPosition(L, "above", 1,
                            f"L/a = {L:g} is above the standout length L1* = {L1:.5f}: one "
                            f"state, gravity-dominated (drooped)")
    why = []
    for name, b, e in (("curvature-dominated", folds.increasing, cd),
                       ("gravity-dominated", folds.decreasing, gd)):
        if e is None:
            why.append(f"the {name} branch was not followed to L/a = {L:g}"
                       + (f" ({b.reason})" if b.reason else "")
                       + (" (its load path snapped where it started)" if b.start_snapped else ""))
    return FoldPosition(L, "unknown", None, f"where L/a = {L:g} sits is unknown: "
                        + "; ".join(why or ["neither branch was found there"]))


@dataclass(frozen=True)
class FoldLengths:
    """The fold lengths of a sheet's planform at its curvature and material.

    :func:`fold_lengths` returns it: ``L1*`` (standout), where the
    curvature-dominated branch ends, and ``L0*`` (pop-up), where the
    gravity-dominated one ends, each located on the mesh ``hmax``
    (:class:`Fold`), and where the sheet's own length sits against them.

    Attributes
    ----------
    sheet : Sheet
        The sheet asked about (its planform, curvature and material make the
        family of lengths; its length is placed against the folds).
    hmax : float
        The mesh the folds were located on.
    length_range : (float, float)
        The lengths searched.
    standout, popup : Fold or None
        The located folds (None where the branch held over the range, or
        was lost without a fold: ``message`` says which).
    increasing, decreasing : Branch
        The two continuations (curvature-first from the short end,
        gravity-first from the long end; possibly one and the same): their
        points on ``branch_hmax``, their ``fold`` the located one on ``hmax``.
    trace_hmax : float
        The mesh the branches were traced on and their folds first located
        (:func:`trace_mesh`).
    branch_hmax : float
        The mesh of ``increasing`` and ``decreasing`` (``hmax`` with
        ``branches=True``, else ``trace_hmax``).
    message : str
        Why a fold is missing, or "".
    factorizations : int
        Factorisations on the mesh ``hmax`` (the folds located there; with
        ``branches=True`` also the branches).
    trace_factorizations : int
        Factorisations of the traces on ``trace_hmax`` (when it is another mesh).
    wall_time_s : float

    Examples
    --------
    >>> f = fold_lengths(Sheet(length=1.3, curvature=2.5), hmax=0.2,
    ...                  lengths=(1.0, 1.7))  # doctest: +SKIP
    >>> f.popup_length, f.standout_length, f.bistable, f.in_window  # doctest: +SKIP
    """

    sheet: Sheet
    hmax: float
    length_range: tuple
    standout: Fold | None
    popup: Fold | None
    increasing: Branch
    decreasing: Branch
    trace_hmax: float
    branch_hmax: float = math.nan
    message: str = ""
    factorizations: int = 0
    trace_factorizations: int = 0
    wall_time_s: float = 0.0

    # -- the answer -----------------------------------------------------------
    @property
    def standout_length(self) -> float:
        """``L1*/a``, NaN where none was found."""
        return self.standout.length if self.standout is not None else math.nan

    @property
    def popup_length(self) -> float:
        """``L0*/a``, NaN where none was found."""
        return self.popup.length if self.popup is not None else math.nan

    @property
    def standout_deflection(self) -> float:
        return self.standout.deflection if self.standout is not None else math.nan

    @property
    def popup_deflection(self) -> float:
        return self.popup.deflection if self.popup is not None else math.nan

    @property
    def bistable(self) -> bool:
        """Both folds found with ``L0* < L1*``: the lengths in between have two
        stable states."""
        return bool(self.popup_length < self.standout_length)

    @property
    def window(self) -> tuple:
        """``(L0*, L1*)`` of a bistable family, else ``(nan, nan)``."""
        return (self.popup_length, self.standout_length) if self.bistable else (math.nan,) * 2

    @property
    def width(self) -> float:
        """``L1* - L0*`` (NaN unless both were found)."""
        return self.standout_length - self.popup_length

    @property
    def position(self) -> FoldPosition:
        """Where ``sheet.length`` sits against the folds (:func:`fold_position`)."""
        return fold_position(self, self.sheet.length)

    @property
    def in_window(self):
        """Whether ``sheet.length`` lies in the bistable window (two stable
        states), or None where that is unknown."""
        pos = self.position
        return None if pos.states is None else pos.states == 2

    # -- the old names ----------------------------------------------------------
    @property
    def tip_width(self) -> float:
        return self.sheet.tip_width

    @property
    def curvature(self) -> float:
        return self.sheet.curvature

    @property
    def coarse_hmax(self):
        """The trace mesh where it is not ``hmax`` (else None)."""
        return None if self.trace_hmax == self.hmax else self.trace_hmax

    @property
    def coarse_newton_iterations(self) -> int:
        return self.trace_factorizations

    @property
    def tol(self) -> float:
        """The folds' location tolerance in L/a (:data:`FOLD_TOL`)."""
        return FOLD_TOL

    # -- SI ---------------------------------------------------------------------
    def in_si(self) -> dict | None:
        """The fold lengths and deflections in metres (None for a sheet
        without SI scales): ``popup_length_m``, ``standout_length_m``,
        ``popup_deflection_m``, ``standout_deflection_m``, ``length_m``
        (the sheet's), ``length_range_m``."""
        si = self.sheet.si
        if si is None:
            return None
        return {"popup_length_m": si.metres(self.popup_length),
                "standout_length_m": si.metres(self.standout_length),
                "popup_deflection_m": si.metres(self.popup_deflection),
                "standout_deflection_m": si.metres(self.standout_deflection),
                "length_m": si.metres(self.sheet.length),
                "length_range_m": [si.metres(x) for x in self.length_range],
                "base_width_m": si.base_width}

    # -- in words -----------------------------------------------------------------
    def fold_text(self, kind: str) -> str:
        """One fold and what it is, in words (the command line's table).

        Examples
        --------
        >>> f = FoldLengths(Sheet(length=1.3, curvature=2.5), 0.1, (0.6, 2.4), None, None,
        ...                 Branch(()), Branch(()), 0.1)
        >>> f.fold_text("standout")
        'none in range (the branch followed from L/a = 0.6 held to L/a = 2.4)'
        """
        fold = self.standout if kind == "standout" else self.popup
        branch = self.increasing if kind == "standout" else self.decreasing
        name = KINDS[kind][0]
        lo, hi = self.length_range
        si = self.sheet.si
        if fold is not None:
            mm = "" if si is None else f" (L* = {1e3 * si.metres(fold.length):.5g} mm)"
            check = {True: "", False: ", the eigenvalue crossing NOT confirmed",
                     None: ", crossing unknown"}[fold.confirmed]
            return (f"{fold.length:.5f}{mm}, d/a {fold.deflection:.4f} there  (the {name} "
                    f"branch ends there{check})")
        if branch.start_snapped:
            end = lo if kind == "standout" else hi
            return (f"none: the {name} branch does not exist at L/a = {end:g}, where it was "
                    f"started (widen the lengths)")
        if branch.reason:
            return f"not found: the {name} branch was lost without a fold ({branch.reason})"
        start, end = (lo, hi) if kind == "standout" else (hi, lo)
        # the branch is named for the state it starts from; with no fold the
        # states along it may change names, so say where it was followed
        return f"none in range (the branch followed from L/a = {start:g} held to L/a = {end:g})"

    def lines(self) -> list:
        """The answer in words, a line each (what ``bistability`` prints)."""
        lo, hi = self.length_range
        sheet = self.sheet
        family = (f"this planform (b/a = {sheet.tip_width:g}) at a/R = {sheet.curvature:g}"
                  if sheet.planform is None else
                  f"this planform ({sheet.planform!r}) at a/R = {sheet.curvature:g}")
        out = [f"fold lengths of {sheet.describe().split(', ', 1)[1]}; hmax {self.hmax:g}"
               + (f" (branches traced on {self.trace_hmax:g})"
                  if self.trace_hmax != self.hmax else "")
               + f", L/a searched in [{lo:g}, {hi:g}]  ({self.wall_time_s:.0f} s):",
               f"  standout length L1*/a = {self.fold_text('standout')}",
               f"  pop-up length   L0*/a = {self.fold_text('popup')}"]
        if self.bistable:
            out.append(f"  {family} is bistable for {self.popup_length:.5f} < L/a < "
                       f"{self.standout_length:.5f}: two stable states at each length in "
                       f"between")
        elif math.isfinite(self.width):
            out.append(f"  {family}: L1* <= L0*, no length with two stable states")
        else:
            out.append(f"  {family} is not bistable for any L/a in [{lo:g}, {hi:g}] searched")
        out.append(f"  this sheet (L/a = {sheet.length:g}"
                   + ("" if sheet.si is None else
                      f", L = {1e3 * sheet.si.metres(sheet.length):.4g} mm")
                   + f"): {self.position.text}")
        return out

    def __str__(self) -> str:
        return "\n".join(self.lines())

    def __repr__(self) -> str:
        def f(x):
            return "nan" if not math.isfinite(x) else f"{x:.5f}"
        return (f"FoldLengths({self.sheet!r}, hmax={self.hmax:g}: L0* = {f(self.popup_length)}, "
                f"L1* = {f(self.standout_length)}, bistable={self.bistable}, "
                f"in_window={self.in_window})")

    def _repr_pretty_(self, p, cycle) -> None:
        p.text(repr(self) if cycle else str(self))

    def _repr_html_(self) -> str:
        from html import escape

        return "<pre>" + escape(str(self)) + "</pre>"

    def summary(self) -> dict:
        """JSON-ready summary (the command line's ``--json``): ``popup_length``,
        ``standout_length`` (None where none), ``bistable``, the located
        folds, both branches, where the sheet's length sits, and the SI
        values (``si``) of a sheet made from SI quantities."""
        def num(x):
            return x if math.isfinite(x) else None

        one = self.decreasing is self.increasing
        return {"popup_length": num(self.popup_length),
                "standout_length": num(self.standout_length),
                "bistable": self.bistable, "bistable_width": num(self.width),
                "popup": None if self.popup is None else self.popup.to_json(),
                "standout": None if self.standout is None else self.standout.to_json(),
                "tol": FOLD_TOL, "sheet": self.sheet.to_dict(),
                "tip_width": self.sheet.tip_width, "curvature": self.sheet.curvature,
                "thickness": self.sheet.thickness, "modulus": self.sheet.modulus,
                "hmax": self.hmax, "trace_hmax": self.trace_hmax,
                "branch_hmax": self.branch_hmax, "length_range": list(self.length_range),
                "position": self.position.to_json(), "in_window": self.in_window,
                "curvature_dominated": self.increasing.summary(),
                "gravity_dominated": self.decreasing.summary(), "one_branch": one,
                "message": self.message, "factorizations": self.factorizations,
                "trace_factorizations": self.trace_factorizations,
                "wall_time_s": self.wall_time_s, "si": self.in_si(), "version": __version__}
