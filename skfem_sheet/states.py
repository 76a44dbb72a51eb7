"""Both load paths of one sheet in one call: is it bistable, and what are its states?

:func:`solve_both` solves the sheet along both load paths (curvature-first,
then gravity-first, on the same mesh), says whether the two end states differ
(two states: the sheet is bistable) or are one and the same, with both
deflections and their stability; asked for (``folds=True``), it also finds the
fold lengths ``L0*`` (pop-up) and ``L1*`` (standout) of the sheet's planform at
its curvature and material (:func:`~skfem_sheet.bistability.fold_lengths`,
located) and says where the sheet's length sits against them.  Each end state
carries its name (``Result.branch``: curvature- or gravity-dominated, a
property of the state), so a bistable pair carries two.  The command line's twin is
``skfem-sheet solve --path both [--folds]``.

Whether the end states differ is decided on the states themselves, not on the
names of the branches: the largest distance between the two deformed
positions of a node, ``separation`` (in base widths), against ``same_tol``.
Outside the bistable range both paths reach one state, to round-off; inside
it the two states are apart by a fraction of the width
(``docs/decisions.md``, "Two states are told apart by their positions").
"""
from __future__ import annotations

import inspect
import math
import os
import warnings
from dataclasses import dataclass

import numpy as np

from .bistability import FoldLengths, FoldPosition, fold_lengths, fold_position, fold_range
from .io import check_writable, write_json
from .params import DEFAULT_HMAX, ParameterError, Sheet, check_range
from .result import Result
from .solve import solve
from .version import __version__

__all__ = ["States", "FoldPosition", "solve_both", "fold_position", "sheet_line",
           "with_path", "SAME_TOL"]

# FoldPosition and fold_position live with the fold lengths (bistability); they
# are imported here for the code that took them from this module.
_ = (FoldLengths, FoldPosition, fold_position)

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
    folds : FoldLengths or None
        The fold lengths of the sheet's planform at its curvature and
        material (with ``folds=True``; their mesh: ``folds.hmax``).
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
        return None if self.folds is None else self.folds.position

    @property
    def names(self) -> tuple:
        """``(curvature-first name, gravity-first name)``: what each end state
        is (:attr:`Result.branch <skfem_sheet.result.Result.branch>`, a
        property of the state: one name for one state, two for a bistable
        pair)."""
        return (self.curvature_first.branch, self.gravity_first.branch)

    def in_si(self) -> dict | None:
        """The deflections and the separation in metres (None for a sheet
        without SI scales): ``deflections_m`` (by path), ``separation_m``,
        and the fold lengths' (``folds``, :meth:`FoldLengths.in_si`)."""
        si = self.sheet.si
        if si is None:
            return None
        return {"base_width_m": si.base_width,
                "deflections_m": {"curvature-first": si.metres(self.deflections[0]),
                                  "gravity-first": si.metres(self.deflections[1])},
                "separation_m": si.metres(self.separation),
                "folds": None if self.folds is None else self.folds.in_si()}

    def lines(self, base_width=None) -> list:
        """The verdict in words, a line each (what ``solve --path both`` prints);
        the deflections in millimetres too for a sheet made from SI quantities
        (or with ``base_width``, metres)."""
        r1, r2 = self.curvature_first, self.gravity_first
        if base_width is None and self.sheet.si is not None:
            base_width = self.sheet.si.base_width
        out = [f"sheet: {sheet_line(self.sheet, r1.target_gravity)}; hmax {r1.hmax:g}"
               + ("" if r1.symmetric else ", whole sheet")]
        for r in (r1, r2):
            head = f"{r.path + ':':16s} d/a = {r.deflection:9.6f}" + (
                "" if base_width is None else f" (d = {1e3 * base_width * r.deflection:.4g} mm)")
            if not r.converged:
                out.append(f"{head} (NOT converged: {r.message}; d/a at the load reached)")
                continue
            stable = {True: "stable", False: "unstable", None: "stability unknown"}[r.stable]
            snaps = "".join(f", snapped in the {s.phase} phase at {s.load:.3g} of it"
                            for s in r.snaps)
            out.append(f"{head}  {r.branch}, {stable}{snaps}  ({r.wall_time_s:.1f} s)")
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
            si = self.sheet.si

            def fmt(x):
                if not math.isfinite(x):
                    return "none in range"
                return f"{x:.5f}" + ("" if si is None else f" ({1e3 * si.metres(x):.5g} mm)")

            out.append(f"fold lengths of this planform at a/R = {f.curvature:g} (hmax "
                       f"{f.hmax:g}, L/a in [{f.length_range[0]:g}, "
                       f"{f.length_range[1]:g}]): L0* = {fmt(f.popup_length)}, "
                       f"L1* = {fmt(f.standout_length)}  ({f.wall_time_s:.0f} s)")
            out.append(f"  {pos.text}")
            if pos.states in (1, 2) and self.distinct is not None \
                    and (pos.states == 2) != self.distinct:
                out.append("  (the fold lengths and the two solves disagree: the length is close "
                           "to a fold, or they were found on different meshes)")
        return out

    def __str__(self) -> str:
        return "\n".join(self.lines())

    def __repr__(self) -> str:
        d = ", ".join(f"{x:.6g}" for x in self.deflections)
        return (f"States({self.sheet!r}, hmax={self.curvature_first.hmax:g}: d/a ({d}), "
                f"{'/'.join(self.names)}, bistable={self.bistable})")

    def _repr_pretty_(self, p, cycle) -> None:
        p.text(repr(self) if cycle else str(self))

    def _repr_html_(self) -> str:
        from html import escape

        return "<pre>" + escape(str(self)) + "</pre>"

    def summary(self) -> dict:
        """JSON-ready summary (the ``--json`` of ``solve --path both``): the
        verdict, both results' summaries, the fold lengths and the position;
        for a sheet made from SI quantities also ``si`` (:meth:`in_si`:
        ``deflections_m``, ``separation_m``, the folds in metres)."""
        pos = self.position
        return {"sheet": self.sheet.to_dict(), "gravity": self.curvature_first.target_gravity,
                "hmax": self.curvature_first.hmax, "converged": self.converged,
                "distinct": self.distinct, "bistable": self.bistable,
                "separation": self.separation, "same_tol": self.same_tol,
                "deflections": {"curvature-first": self.deflections[0],
                                "gravity-first": self.deflections[1]},
                "names": {"curvature-first": self.names[0], "gravity-first": self.names[1]},
                "curvature_first": self.curvature_first.summary(),
                "gravity_first": self.gravity_first.summary(),
                "folds": None if self.folds is None else self.folds.summary(),
                "position": None if pos is None else pos.to_json(),
                "si": self.in_si(), "version": __version__}

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


def solve_both(sheet: Sheet, hmax: float = DEFAULT_HMAX, *, folds: bool = False,
               lengths=None, fold_hmax=None, same_tol: float = SAME_TOL,
               progress: bool = False, fold_tol=None, **options) -> States:
    """Solve ``sheet`` along both load paths and say whether it is bistable.

    Parameters
    ----------
    sheet : Sheet
    hmax : float
        Mesh size of both solves (default
        :data:`~skfem_sheet.params.DEFAULT_HMAX`, as :func:`~skfem_sheet.solve.solve`).
    folds : bool
        Also find the fold lengths ``L0*`` and ``L1*`` of the sheet's planform
        at its curvature and material (:func:`~skfem_sheet.bistability.fold_lengths`:
        the branches in L traced, their ends located on the mesh
        ``fold_hmax``), and say where the sheet's length sits against them
        (:attr:`States.position`).  Needs gravity 1.
    lengths : (float, float), optional
        The range of L/a searched for the folds (default
        :func:`~skfem_sheet.bistability.fold_range`: 0.6 to 2.4, widened to
        hold the sheet's length).
    fold_hmax : float, optional
        Mesh size the folds are located on (default ``hmax``: the same mesh
        size as the solves, so that the two answers agree).
    same_tol : float
        End states closer than this (largest nodal distance, in base widths)
        are one state.
    progress : bool
        Progress bars on stderr (the solves and the fold search).
    fold_tol
        Deprecated and ignored (the folds are located to
        :data:`~skfem_sheet.bistability.FOLD_TOL`, not bracketed).
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
    The paper's rectangle at L/a = 1.3, a/R = 2.5 (on a coarse mesh): two
    states, and two names.

    >>> s = solve_both(Sheet(length=1.3, curvature=2.5), hmax=0.2)
    >>> s.bistable, [round(d, 2) for d in s.deflections], s.names
    (True, [0.05, 0.5], ('curvature-dominated', 'gravity-dominated'))
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
    if fold_tol is not None:
        warnings.warn("fold_tol is deprecated and ignored: the folds are located (to "
                      "bistability.FOLD_TOL), not bracketed", DeprecationWarning, stacklevel=2)
    same_tol = check_range("same_tol", same_tol, 0, None, lo_open=True)
    gravity = options.get("gravity", 1.0)
    if folds:
        if gravity != 1.0:
            raise ParameterError(f"folds needs gravity 1 (fold lengths are found under the "
                                 f"sheet's own weight), got gravity {gravity!r}")
        lengths = fold_range(sheet.length, lengths)
        fold_hmax = hmax if fold_hmax is None else check_range("fold_hmax", fold_hmax, 0, None,
                                                               lo_open=True)
    results = [solve(sheet, path=p, hmax=hmax, on_failure="return", progress=progress,
                     **options) for p in ("curvature-first", "gravity-first")]
    separation = float("nan")
    if all(r.converged for r in results):
        separation = _separation(*results)
    found = None
    if folds:
        found = fold_lengths(sheet, hmax=fold_hmax, lengths=lengths,
                             layers=options.get("layers"), solver=options.get("solver", "auto"),
                             progress=progress)
    return States(results[0], results[1], separation, same_tol, found,
                  fold_hmax if folds else None)


def _separation(a: Result, b: Result) -> float:
    """Largest distance between the deformed positions of a node in two end
    states on one mesh (the vertices and the mid-edge nodes)."""
    ua, ub = a.displacement, b.displacement
    if ua.shape != ub.shape:
        raise ParameterError("the two end states are on different meshes")
    d = np.linalg.norm(ua - ub, axis=1).max() if len(ua) else 0.0
    return float(d) if math.isfinite(d) else float("nan")
