"""Both load paths of one sheet in one call: is it bistable, and what are its states?

:func:`solve_both` solves the sheet along both load paths (curvature-first,
then gravity-first, on the same mesh), says whether the two end states differ
(two states: the sheet is bistable) or are one and the same, with both
deflections and their stability; asked for (``folds=True``), it also finds the
fold lengths ``L0*`` (pop-up) and ``L1*`` (standout) of the sheet's planform at
its curvature (:func:`~skfem_sheet.bistability.fold_lengths`) and says where
the sheet's length sits against them.  The command line's twin is
``skfem-sheet solve --path both [--folds]``.

Whether the end states differ is decided on the states themselves, not on the
names of the branches: the largest distance between the two deformed
positions of a node, ``separation`` (in base widths), against ``same_tol``.
Outside the bistable range both paths reach one state (measured at hmax 0.1,
the rectangle at a/R = 2.5: 2e-16 apart at L/a = 0.8 and 1e-15 at L/a = 2;
0.65 apart at L/a = 1.3, inside it).
"""
from __future__ import annotations

import inspect
import math
import os
from dataclasses import dataclass

import numpy as np

from .bistability import Bistability, fold_lengths
from .io import check_writable, write_json
from .params import ParameterError, Sheet, check_range
from .result import Result
from .solve import solve
from .version import __version__

__all__ = ["States", "FoldPosition", "solve_both", "fold_position", "sheet_line",
           "with_path", "SAME_TOL"]

#: Two end states closer than this (largest nodal distance, in base widths) are one state.
SAME_TOL = 1e-5

#: Options of :func:`~skfem_sheet.solve.solve` that :func:`solve_both` sets itself.
_OWN = ("sheet", "path", "hmax", "on_failure", "progress", "series")
_SOLVE_OPTIONS = tuple(n for n in inspect.signature(solve).parameters if n not in _OWN)


def sheet_line(sheet: Sheet, gravity: float = 1.0) -> str:
    """Every parameter of ``sheet`` in one line (the headers of the command line).

    Examples
    --------
    >>> sheet_line(Sheet(length=1.3, curvature=2.5))
    'L/a = 1.3, b/a = 1, a/R = 2.5, h/a = 0.03, E/(rho g a) = 735, gravity 1'
    """
    width = (f"b/a = {sheet.tip_width:.6g}" if sheet.planform is None
             else f"planform (b/a = {sheet.tip_width:.6g} at the tip)")
    return (f"L/a = {sheet.length:.6g}, {width}, a/R = {sheet.curvature:.6g}, "
            f"h/a = {sheet.thickness:.6g}, E/(rho g a) = {sheet.modulus:.6g}, "
            f"gravity {gravity:.6g}")


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
        gravity-dominated state), ``"at a fold"`` (inside a fold's bracket,
        ``+- tol``), ``"one branch"`` (a flat clamp: both paths are one
        problem) or ``"unknown"`` (outside what the continuations covered).
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


def _exists(branch, length, fold, tol, up):
    """Whether the branch of a continuation (from the short end if ``up``, else
    the long end) exists at ``length``: True, False, "fold" or None (unknown)."""
    if branch.start_snapped or not len(branch.points):
        return None
    if fold is not None:
        if abs(length - fold) <= tol:
            return "fold"
        return (length < fold) if up else (length > fold)
    covered = branch.lengths.max() if up else branch.lengths.min()
    return True if (length <= covered + 1e-12 if up else length >= covered - 1e-12) else None


def fold_position(folds: Bistability, length: float) -> FoldPosition:
    """Where ``length`` sits against the fold lengths ``folds``.

    Parameters
    ----------
    folds : Bistability
        From :func:`~skfem_sheet.bistability.fold_lengths`.
    length : float
        L/a of a sheet of that planform and curvature.

    Examples
    --------
    >>> from skfem_sheet.bistability import Branch, BranchPoint
    >>> def branch(Ls, fold):
    ...     pts = tuple(BranchPoint(L, 0.1, True, 0, 3) for L in Ls)
    ...     return Branch(pts, fold, (fold - 0.005, fold + 0.005))
    >>> f = Bistability(1.0, 2.5, 0.1, (0.6, 2.4), 1.202, 1.347, True,
    ...                 branch([0.6, 1.3], 1.347), branch([2.4, 1.21], 1.202))
    >>> fold_position(f, 1.3).where, fold_position(f, 1.0).where, fold_position(f, 2).states
    ('between', 'below', 1)
    >>> print(fold_position(f, 1.0).text)
    L/a = 1 is below the pop-up length L0* = 1.202: one state, curvature-dominated (aloft)
    """
    L = float(length)
    lo, hi = folds.length_range
    L0, L1, tol = folds.popup_length, folds.standout_length, folds.tol

    def fmt(name, x, end):
        return (f"{name} = {x:.3f}" if x is not None else
                f"{name} not in [{lo:g}, {hi:g}] (the branch held to L/a = {end:g})")

    if folds.curvature == 0.0:
        return FoldPosition(L, "one branch", 1, f"a flat clamp (a/R = 0): one state at every "
                                                 f"length, L/a = {L:g} too")
    if not lo <= L <= hi:
        return FoldPosition(L, "unknown", None, f"L/a = {L:g} lies outside the lengths searched, "
                                                f"[{lo:g}, {hi:g}]")
    cd = _exists(folds.increasing, L, L1, tol, up=True)
    gd = _exists(folds.decreasing, L, L0, tol, up=False)
    if "fold" in (cd, gd):
        which = "standout length L1*" if cd == "fold" else "pop-up length L0*"
        x = L1 if cd == "fold" else L0
        return FoldPosition(L, "at a fold", None,
                            f"L/a = {L:g} is within +-{tol:g} of the {which} = {x:.3f}: at the "
                            f"fold, where one of the two states ends (closer than the folds "
                            f"were located)")
    if cd is True and gd is True:
        return FoldPosition(L, "between", 2,
                            f"L/a = {L:g} lies between the pop-up length "
                            f"{fmt('L0*', L0, lo)} and the standout length "
                            f"{fmt('L1*', L1, hi)}: two states (bistable)")
    if cd is True and gd is False:
        return FoldPosition(L, "below", 1,
                            f"L/a = {L:g} is below the pop-up length L0* = {L0:.3f}: one "
                            f"state, curvature-dominated (aloft)")
    if cd is False and gd is True:
        return FoldPosition(L, "above", 1,
                            f"L/a = {L:g} is above the standout length L1* = {L1:.3f}: one "
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
class States:
    """The sheet along both load paths (:func:`solve_both`).

    Attributes
    ----------
    curvature_first, gravity_first : Result
        The two solves (same sheet, mesh and options).
    separation : float
        Largest distance between the two end states' deformed positions of a
        node, in base widths (``nan`` unless both converged).
    same_tol : float
        End states closer than this are one state.
    folds : Bistability or None
        The fold lengths of the sheet's planform at its curvature (with
        ``folds=True``).
    fold_hmax : float or None
        The mesh size they were found on.

    Examples
    --------
    >>> s = solve_both(Sheet(length=0.5, curvature=2.5), hmax=0.2)
    >>> s.distinct, s.bistable, len(s.states)
    (False, False, 1)
    """

    curvature_first: Result
    gravity_first: Result
    separation: float
    same_tol: float = SAME_TOL
    folds: object = None
    fold_hmax: object = None

    @property
    def sheet(self) -> Sheet:
        return self.curvature_first.sheet

    @property
    def converged(self) -> bool:
        """Both paths reached full load."""
        return bool(self.curvature_first.converged and self.gravity_first.converged)

    @property
    def distinct(self):
        """The two end states differ (True), are one (False), or unknown (None: a
        path failed)."""
        if not self.converged:
            return None
        return bool(self.separation > self.same_tol)

    @property
    def bistable(self):
        """Two distinct stable states (None if unknown: a path failed, or a
        stability the linear solver cannot tell)."""
        if self.distinct is None:
            return None
        if not self.distinct:
            return False
        st = (self.curvature_first.stable, self.gravity_first.stable)
        return None if None in st else bool(all(st))

    @property
    def deflections(self) -> tuple:
        """``(curvature-first d/a, gravity-first d/a)``."""
        return (self.curvature_first.deflection, self.gravity_first.deflection)

    @property
    def states(self) -> tuple:
        """The distinct end states: two Results, or one if both paths reach one
        (or either path failed: the converged ones)."""
        both = (self.curvature_first, self.gravity_first)
        if self.distinct:
            return both
        if self.distinct is False:
            return both[:1]
        return tuple(r for r in both if r.converged)

    @property
    def position(self):
        """Where the length sits against the fold lengths (:class:`FoldPosition`),
        or None without ``folds``."""
        return None if self.folds is None else fold_position(self.folds, self.sheet.length)

    def lines(self, base_width=None) -> list:
        """The verdict in words, a line each (what ``solve --path both`` prints);
        with ``base_width`` (metres), the deflections in millimetres too."""
        r1, r2 = self.curvature_first, self.gravity_first
        out = [f"sheet: {sheet_line(self.sheet, r1.target_gravity)}; hmax {r1.hmax:g}"
               + ("" if r1.symmetric else ", whole sheet")]
        for r in (r1, r2):
            head = f"{r.path + ':':16s} d/a = {r.deflection:9.6f}" + (
                "" if base_width is None else f" (d = {1e3 * base_width * r.deflection:.4g} mm)")
            if not r.converged:
                out.append(f"{head} (NOT converged: {r.message}; d/a at the load reached)")
                continue
            stable = {True: "stable", False: "unstable", None: "stability unknown"}[r.stable]
            branch = f"{r.branch}, " if self.distinct else ""
            snaps = "".join(f", snapped in the {s.phase} phase at {s.load:.3g} of it"
                            for s in r.snaps)
            out.append(f"{head}  {branch}{stable}{snaps}  ({r.wall_time_s:.1f} s)")
        if self.distinct is None:
            out.append("bistable: unknown (a load path did not reach full load)")
        elif self.distinct:
            verdict = {True: "bistable", False: "not bistable (a state is unstable)",
                       None: "bistable if both are stable (stability unknown)"}[self.bistable]
            out.append(f"two distinct states, {self.separation:.3g} a apart at most: this sheet "
                       f"is {verdict}")
        else:
            out.append(f"one state: both load paths reach it (they end {self.separation:.1g} a "
                       f"apart at most): this sheet is not bistable")
        pos = self.position
        if pos is not None:
            f = self.folds
            fmt = ("none in range" if x is None else f"{x:.3f} +- {f.tol:g}"
                   for x in (f.popup_length, f.standout_length))
            out.append(f"fold lengths of this planform at a/R = {f.curvature:g} (hmax "
                       f"{self.fold_hmax:g}, L/a in [{f.length_range[0]:g}, "
                       f"{f.length_range[1]:g}]): L0* = {next(fmt)}, L1* = {next(fmt)}  "
                       f"({f.wall_time_s:.0f} s)")
            out.append(f"  {pos.text}")
            if pos.states in (1, 2) and self.distinct is not None \
                    and (pos.states == 2) != self.distinct:
                out.append("  (the fold lengths and the two solves disagree: the length is close "
                           "to a fold, or they were found on different meshes)")
        return out

    def __str__(self) -> str:
        return "\n".join(self.lines())

    def summary(self) -> dict:
        """JSON-ready summary (the ``--json`` of ``solve --path both``): the
        verdict, both results' summaries, the fold lengths and the position."""
        pos = self.position
        return {"sheet": self.sheet.to_dict(), "gravity": self.curvature_first.target_gravity,
                "hmax": self.curvature_first.hmax, "converged": self.converged,
                "distinct": self.distinct, "bistable": self.bistable,
                "separation": self.separation, "same_tol": self.same_tol,
                "deflections": {"curvature-first": self.deflections[0],
                                "gravity-first": self.deflections[1]},
                "curvature_first": self.curvature_first.summary(),
                "gravity_first": self.gravity_first.summary(),
                "folds": None if self.folds is None else
                dict(self.folds.summary(), hmax=self.fold_hmax),
                "position": None if pos is None else pos.to_json(),
                "version": __version__}

    def write(self, filename) -> list:
        """Write the summary (``.json``), or each end state (``.vtu``: the path
        inserted before the suffix, ``up.vtu`` -> ``up.curvature-first.vtu``
        and ``up.gravity-first.vtu``); returns the files written."""
        name = check_writable("filename", filename, [".json", ".vtu"])
        if name.lower().endswith(".json"):
            write_json(self.summary(), name)
            return [name]
        out = []
        for r in (self.curvature_first, self.gravity_first):
            out.append(with_path(name, r.path))
            r.write(out[-1])
        return out


def with_path(filename, path: str) -> str:
    """``filename`` with the load path inserted before its suffix.

    Examples
    --------
    >>> with_path("out/up.vtu", "gravity-first")
    'out/up.gravity-first.vtu'
    """
    root, ext = os.path.splitext(os.fspath(filename))
    return f"{root}.{path}{ext}"


def solve_both(sheet: Sheet, hmax: float = 0.03, *, folds: bool = False, lengths=None,
               fold_hmax=None, fold_tol: float = 0.005, same_tol: float = SAME_TOL,
               progress: bool = False, **options) -> States:
    """Solve ``sheet`` along both load paths and say whether it is bistable.

    Parameters
    ----------
    sheet : Sheet
    hmax : float
        Mesh size of both solves (default 0.03, as :func:`~skfem_sheet.solve.solve`).
    folds : bool
        Also find the fold lengths ``L0*`` and ``L1*`` of the sheet's planform
        (a trapezoid of its tip width) at its curvature, by continuation in L
        both ways (:func:`~skfem_sheet.bistability.fold_lengths`; about a
        minute at hmax 0.1, several on finer meshes), and say where the sheet's
        length sits against them (:attr:`States.position`).  Needs gravity 1.
    lengths : (float, float), optional
        The range of L/a searched for the folds (default 0.6 to 2.4, widened
        to hold the sheet's length).
    fold_hmax : float, optional
        Mesh size of the fold search (default ``hmax``: the same mesh as the
        solves, so that the two answers agree).
    fold_tol : float
        The folds are located to ``+- fold_tol``.
    same_tol : float
        End states closer than this (largest nodal distance, in base widths)
        are one state.
    progress : bool
        Progress bars on stderr (the solves and the fold search).
    **options
        Any other option of :func:`~skfem_sheet.solve.solve` (``layers``,
        ``refine``, ``solver``, ``symmetric``, ``start``, ``coarse_hmax``,
        ``gravity``, ``newton_options``, ``step_options``,
        ``quadrature_order``), the same for both paths.

    Returns
    -------
    States
        A path that does not reach full load is reported (``converged``
        False on it, ``distinct`` and ``bistable`` None), never raised.

    Examples
    --------
    The paper's rectangle at L/a = 1.3, a/R = 2.5 (on a coarse mesh):

    >>> s = solve_both(Sheet(length=1.3, curvature=2.5), hmax=0.2)
    >>> s.bistable, [round(d, 2) for d in s.deflections]
    (True, [0.05, 0.5])
    """
    if not isinstance(sheet, Sheet):
        raise ParameterError(f"sheet must be a skfem_sheet.Sheet, got {type(sheet).__name__}")
    unknown = sorted(set(options) - set(_SOLVE_OPTIONS))
    if unknown:
        own = [n for n in unknown if n in _OWN]
        raise ParameterError(
            f"{unknown[0]} is not an option of solve_both"
            + (" (it sets it itself; solve each path on its own for that)" if own else "")
            + f"; allowed: {', '.join(_SOLVE_OPTIONS)}")
    same_tol = check_range("same_tol", same_tol, 0, None, lo_open=True)
    gravity = options.get("gravity", 1.0)
    if folds:
        if sheet.planform is not None:
            raise ParameterError("folds needs a trapezoid sheet (fold lengths are found for a "
                                 "tip width b/a); this sheet has a planform")
        if gravity != 1.0:
            raise ParameterError(f"folds needs gravity 1 (fold lengths are found under the "
                                 f"sheet's own weight), got gravity {gravity!r}")
        lengths = _fold_range(sheet.length, lengths)
        fold_hmax = hmax if fold_hmax is None else fold_hmax
    results = [solve(sheet, path=p, hmax=hmax, on_failure="return", progress=progress,
                     **options) for p in ("curvature-first", "gravity-first")]
    separation = float("nan")
    if all(r.converged for r in results):
        separation = _separation(*results)
    found = None
    if folds:
        found = fold_lengths(sheet.tip_width, sheet.curvature, lengths=lengths, hmax=fold_hmax,
                             layers=options.get("layers"), solver=options.get("solver", "auto"),
                             tol=fold_tol, thickness=sheet.thickness, modulus=sheet.modulus,
                             progress=progress)
    return States(results[0], results[1], separation, same_tol, found,
                  fold_hmax if folds else None)


def _fold_range(length, lengths):
    """The range of L/a of the fold search: ``lengths``, or 0.6 to 2.4 widened to
    hold ``length`` with a margin; it must hold ``length``."""
    if lengths is None:
        return (min(0.6, 0.8 * length), max(2.4, min(20.0, 1.25 * length)))
    try:
        lo, hi = (float(x) for x in lengths)
    except (TypeError, ValueError):
        raise ParameterError(f"lengths must be (short, long), got {lengths!r}") from None
    if not lo < length < hi:
        raise ParameterError(f"lengths must hold the sheet's length {length:g}: "
                             f"short < {length:g} < long, got {lengths!r}")
    return lo, hi


def _separation(a: Result, b: Result) -> float:
    """Largest distance between the deformed positions of a node in two end
    states on one mesh (the vertices and the mid-edge nodes)."""
    ua, ub = a.displacement, b.displacement
    if ua.shape != ub.shape:
        raise ParameterError("the two end states are on different meshes")
    d = np.linalg.norm(ua - ub, axis=1).max() if len(ua) else 0.0
    return float(d) if math.isfinite(d) else float("nan")
