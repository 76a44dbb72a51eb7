"""The fold lengths of a Sheet: :func:`fold_lengths` follows both branches in
L (on a coarser trace mesh where the results' mesh is finer, :func:`trace_mesh`)
and locates each fold once more on a mesh made at it (:func:`locate_on_mesh`),
searching the range :func:`fold_range`; :func:`fold_lengths_of` is its
deprecated form.
"""
from __future__ import annotations

import numbers
import time
import warnings
from dataclasses import replace

import numpy as np
from tqdm.auto import tqdm

from ..engine.fold import fold_on_branch, inertia_crossing
from ..engine.protocol import Counting
from ..foldcurve.options import MESH_LENGTH_GRID
from ..foldcurve.refine import settled_fold
from ..params import DEFAULT_HMAX, QUICK_HMAX, ParameterError, Sheet, check_range
from ..sheet_shape import TOLERANCES
from ..starts import CoarseStart
from .folds import KINDS, Fold, FoldLengths
from .follow import (
    FOLD_TOL,
    SameBranch,
    branch_problem,
    check_common,
    follow_branch,
    resolve_min_step,
)

#: The mesh on which :func:`fold_lengths` traces the branches where the
#: results' mesh is finer (coarse to fine, :func:`trace_mesh`): its folds are
#: then located again on the fine mesh, a few factorisations each.
TRACE_HMAX = QUICK_HMAX


def trace_mesh(hmax: float, coarse_hmax=None) -> float:
    """The mesh the branches of :func:`fold_lengths` are traced on for
    results on ``hmax``: ``coarse_hmax`` if given (coarser than ``hmax``;
    0 or ``hmax``: none, the results' mesh itself), else :data:`TRACE_HMAX`
    where ``hmax`` is finer, else ``hmax``.

    Examples
    --------
    >>> trace_mesh(0.03), trace_mesh(0.1), trace_mesh(0.2), trace_mesh(0.03, 0)
    (0.1, 0.1, 0.2, 0.03)
    """
    hmax = check_range("hmax", hmax, 0, None, lo_open=True)
    if coarse_hmax is None:
        return max(hmax, TRACE_HMAX)
    if coarse_hmax == 0 or coarse_hmax == hmax:
        return hmax
    return check_range("coarse_hmax", coarse_hmax, hmax, None, lo_open=True,
                       hint="a coarser mesh than hmax, or 0 for none")


def fold_range(length: float, lengths=None) -> tuple:
    """The range of L/a searched for the folds of a sheet of ``length``:
    ``lengths`` (checked to hold it), or 0.6 to 2.4 widened to hold it with a
    margin (0.8 and 1.25 times it).

    Examples
    --------
    >>> fold_range(1.375), fold_range(3.0), fold_range(1.3, (1.0, 1.7))
    ((0.6, 2.4), (0.6, 3.75), (1.0, 1.7))
    """
    if lengths is None:
        return (min(0.6, 0.8 * length), max(2.4, min(20.0, 1.25 * length)))
    try:
        lo, hi = (float(x) for x in lengths)
    except (TypeError, ValueError):
        raise ParameterError(f"lengths must be (short, long), got {lengths!r}") from None
    lo, hi = (check_range("lengths", x, 0.05, 20.0) for x in (lo, hi))
    if not lo < hi:
        raise ParameterError(f"lengths must be (short, long) with short < long, got {lengths!r}")
    if not lo <= length <= hi:
        raise ParameterError(f"lengths must hold the sheet's length {length:g}: "
                             f"short <= {length:g} <= long, got {lengths!r}")
    return lo, hi


def _mesh_length(L: float) -> float:
    """The length a fold's mesh is made at: ``L`` on the grid
    :data:`~skfem_sheet.foldcurve.options.MESH_LENGTH_GRID` (the fold
    curves' rule, so that a fold is located on the same mesh whichever code
    finds it, and does not follow round-off in where it was first found)."""
    return round(max(MESH_LENGTH_GRID, round(L / MESH_LENGTH_GRID) * MESH_LENGTH_GRID), 10)


def locate_on_mesh(sheet: Sheet, point, problem, kind: str, hmax: float, *, layers=None,
                   solver: str = "auto", keep_state: bool = False, mesh_length=None):
    """A fold located on the mesh ``hmax`` made next to its length.

    The fold ``point`` (a :class:`skfem_sheet.engine.FoldPoint` in L on
    ``problem``) is carried onto a mesh of size ``hmax`` made at its length
    rounded to :data:`~skfem_sheet.foldcurve.options.MESH_LENGTH_GRID` and
    located there along its branch (:func:`~skfem_sheet.engine.fold_on_branch`,
    the load to :data:`FOLD_TOL`), the negative eigenvalue counts on both sides
    checked (where they do not differ by one, located once more a thousand
    times closer); where that does not converge, by Newton on the minimally
    augmented system, from the carried state or from it settled
    (:func:`~skfem_sheet.foldcurve.refine.settled_fold`).  A fold more than a
    grid step from its mesh's length is located once more on the mesh made next
    to it.  ``mesh_length``: make the mesh at this length instead, and keep it.

    Returns
    -------
    (Fold or None, factorisations, reason)
        ``reason`` says why there is none ("" if there is).
    """
    side = KINDS[kind][1]
    total = 0
    for attempt in range(2):
        L_m = _mesh_length(point.value) if mesh_length is None else float(mesh_length)
        p = np.array(point.p, dtype=float)
        if problem.hmax == hmax and abs(problem.mesh_parameters[0] - L_m) < 1e-12:
            Q = problem  # already the mesh made there
            u, v = np.array(point.u, dtype=float), np.array(point.v, dtype=float)
        else:
            Q = branch_problem(sheet.replace(length=L_m), "L", hmax, layers, solver, True)
            u = problem.transferred(Q, point.u, p)
            v = problem.transferred(Q, point.v, p, state=False)
        counter = Counting(Q)
        fold, res = fold_on_branch(counter, u, p, "L", v, tol=TOLERANCES, ptol=FOLD_TOL,
                                   check_inertia=True, reach=0.25)
        if fold is None or int(fold.side) != side:
            why = res.reason if fold is None else "the other kind of fold"
            fold, res, _, _ = settled_fold(counter, None, "L", u, p, v, TOLERANCES)
            if fold is not None and int(fold.side) == side:
                fold = replace(fold, crossing=inertia_crossing(counter, fold.u, fold.p,
                                                               fold.v, 1e-4))
            elif fold is not None:
                fold, why = None, f"{why}; the fold system: the other kind of fold"
            else:
                why = f"{why}; the fold system: {res.reason}"
        if fold is not None and fold.crossing is not None and \
                abs(int(fold.crossing[1]) - int(fold.crossing[0])) != 1:
            # the crossing not seen along the null vector: at a flat fold (a small
            # fold coefficient) the critical eigenvalue changes slowly along it, and
            # the located state, within the tolerance of the fold, is not near enough;
            # located once more from there, closer, and checked again
            closer, _ = fold_on_branch(counter, fold.u, fold.p, "L", fold.v, tol=TOLERANCES,
                                       ptol=FOLD_TOL * 1e-3, check_inertia=True)
            if closer is not None and int(closer.side) == side:
                fold = closer
        total += counter.stats().factorizations
        if fold is None:
            return None, total, why
        # on the mesh made next to it (within a grid step: meshes made a grid
        # step apart are other unstructured meshes, whose folds differ by their
        # discretisation error), or on the second mesh, made next to where it
        # came out on the first
        if (attempt == 1 or mesh_length is not None
                or abs(fold.value - L_m) <= MESH_LENGTH_GRID + 1e-9):
            d = Q.deflection(fold.u, fold.p)
            if not keep_state:
                Q.release()
            return (Fold(kind, fold.value, d, fold.crossing, fold.negative_eigenvalues, hmax,
                         L_m, total, fold if keep_state else None, Q if keep_state else None),
                    total, "")
        point, problem = fold, Q


def fold_lengths(sheet: Sheet, *legacy, hmax: float = DEFAULT_HMAX, lengths=None,
                 branches: bool = False, coarse_hmax=None, step: float = 0.1, layers=None,
                 solver: str = "auto", progress: bool = False, on_point=(None, None),
                 keep_states: bool = False, min_step=None, tol=None, names: bool = False,
                 **legacy_keywords) -> FoldLengths:
    """The fold lengths ``L0*`` and ``L1*`` of a sheet's planform at its
    curvature and material, located, and where the sheet's length sits.

    1. **The branches, traced** on the mesh :func:`trace_mesh` gives: the
       curvature-dominated branch from ``lengths[0]`` with increasing L, the
       gravity-dominated one from ``lengths[1]`` with decreasing L
       (:func:`follow_length`), each to its located fold (traced once where
       the one reaches the other's start without a fold, :func:`_same_state`).
    2. **The folds, located on the mesh ``hmax``** made at each
       (:func:`locate_on_mesh`: a few factorisations per fold).
    3. **The branches on ``hmax``** (``branches=True``, or ``on_point``): each
       followed on ``hmax`` up to its located fold, guided by the traced one.

    Parameters
    ----------
    sheet : Sheet
        The planform, clamp curvature, thickness and modulus of the family
        of lengths (any planform); its own length is placed against the
        folds (:attr:`FoldLengths.position`).
    hmax : float
        The mesh the folds are located on (default
        :data:`~skfem_sheet.params.DEFAULT_HMAX`, the paper's;
        :data:`~skfem_sheet.params.QUICK_HMAX` for a quick look).
    lengths : (float, float), optional
        The range of L/a searched (default :func:`fold_range`: 0.6 to 2.4,
        widened to hold the sheet's length).
    branches : bool
        Also follow both branches on the mesh ``hmax`` (step 3; else the
        returned branches are the traced ones).
    coarse_hmax : float, optional
        The trace mesh (:func:`trace_mesh`; 0: none, everything on ``hmax``).
    step : float
        Largest length step of the continuations.
    layers, solver
        Of the meshes (:func:`~skfem_sheet.mesh.sheet_mesh`) and the linear
        solver (:func:`~skfem_sheet.linalg.make_linear_solver`).
    progress : bool
        Progress bars on stderr.
    on_point : (callable or None, callable or None)
        The ``on_point`` of the two continuations on the mesh ``hmax``
        (:func:`follow_length`; implies ``branches``).
    keep_states : bool
        Keep each fold's state, null vector and problem (:attr:`Fold.point`,
        :attr:`Fold.problem`: for its sensitivities).
    min_step, tol
        The shortest step (:func:`follow_length`; ``tol`` deprecated).
    names : bool
        Name each point of the returned branches as ``solve`` names a state
        (:attr:`BranchPoint.name`).
    legacy, legacy_keywords
        The old call, ``fold_lengths(tip_width, curvature, thickness=...,
        modulus=..., ...)``, still works for one release, with a
        :class:`DeprecationWarning` (:func:`fold_lengths_of`).

    Returns
    -------
    FoldLengths
        ``popup_length``, ``standout_length`` (NaN where none), ``bistable``,
        ``in_window``, ``position``; a branch that held over the range or
        was lost without a fold is said so in ``message`` and in
        :meth:`FoldLengths.fold_text`.

    Examples
    --------
    >>> f = fold_lengths(Sheet(length=1.3, curvature=2.5), hmax=0.2, lengths=(1.0, 1.7),
    ...                  step=0.15)
    >>> f.bistable, f.in_window, round(f.popup_length, 2), round(f.standout_length, 2)
    (True, True, 1.24, 1.36)
    """
    options = dict(hmax=hmax, lengths=lengths, branches=branches, coarse_hmax=coarse_hmax,
                   step=step, layers=layers, solver=solver, progress=progress,
                   on_point=on_point, keep_states=keep_states, min_step=min_step, tol=tol,
                   names=names)
    if not isinstance(sheet, Sheet):
        if isinstance(sheet, numbers.Real) and not isinstance(sheet, bool):
            # the old call fold_lengths(tip_width, curvature, ...): one release more
            return fold_lengths_of(sheet, *legacy, **legacy_keywords, **options)
        raise ParameterError(f"sheet must be a skfem_sheet.Sheet, got {type(sheet).__name__}")
    if legacy or legacy_keywords:
        names = ", ".join(sorted(legacy_keywords)) or f"{len(legacy)} positional"
        raise ParameterError(f"fold_lengths(sheet, ...) takes the planform, curvature, "
                             f"thickness and modulus from the Sheet, got also {names} "
                             f"(give them to the Sheet)")
    t0 = time.perf_counter()
    hmax = check_range("hmax", hmax, 0, None, lo_open=True)
    lo, hi = fold_range(sheet.length, lengths)
    h_trace = trace_mesh(hmax, coarse_hmax)
    min_step = resolve_min_step(tol, min_step)
    check_common(sheet, hmax, step)
    on_point = tuple(on_point) if on_point is not None else (None, None)
    if len(on_point) != 2:
        raise ParameterError(f"on_point must be a pair (curvature-dominated, "
                             f"gravity-dominated), got {on_point!r}")
    fine_branches = bool(branches) or any(f is not None for f in on_point)
    flat = sheet.curvature == 0.0  # a flat clamp: both load paths are one problem, one branch
    base = sheet.replace(length=lo)
    common = dict(layers=layers, solver=solver, symmetric=True, step=step, min_step=min_step,
                  jump=0.1)
    guided = fine_branches and h_trace != hmax
    guides = [[] if guided else None, [] if guided else None]
    trace_on = (None, None) if (fine_branches and h_trace != hmax) else on_point
    last = []

    def keep_last(problem, w, length, user=trace_on[0]):
        last[:] = [problem, w]
        if user is not None:
            user(problem, w, length)

    trace_names = bool(names) and not (fine_branches and h_trace != hmax)
    bars = _bars(progress, lo, hi)
    try:
        up = follow_branch("L", base, hi, path="curvature-first", hmax=h_trace,
                     **{**common, "layers": layers if h_trace == hmax else None},
                     progress=bars[0], on_point=keep_last, record=guides[0],
                     names=trace_names)
        down = up
        if not flat:
            # the gravity-dominated branch is the curvature-dominated one where
            # the latter reaches the long end without a fold and the
            # gravity-first start there is its end (whose states were asked
            # for is traced)
            twin = (tuple(last) if up.fold is None and not up.reason and last
                    and trace_on[1] is None else None)
            down = follow_branch("L", base.replace(length=hi), lo, path="gravity-first",
                           hmax=h_trace, **{**common,
                                            "layers": layers if h_trace == hmax else None},
                           progress=bars[1], on_point=trace_on[1], record=guides[1],
                           twin=twin, names=trace_names)
            if isinstance(down, SameBranch):
                up = replace(up, newton_iterations=up.newton_iterations
                             + down.newton_iterations)
                down = up
    finally:  # also when a continuation raises: no bar left open on the terminal
        for b in bars:
            if b is not None:
                b.close()
    trace_work = up.newton_iterations + (0 if down is up else down.newton_iterations)
    # the folds on the results' mesh, made at their lengths
    located, notes, fine_work = {}, [], 0
    for kind, b in (("standout", up), ("popup", down)):
        if b.start_snapped:
            notes.append(f"the {KINDS[kind][0]} branch does not exist at L/a = "
                         f"{lo if kind == 'standout' else hi:g}, where it was started")
            continue
        if b.fold_point is None:
            if b.reason and not (kind == "popup" and down is up):
                notes.append(f"the {KINDS[kind][0]} branch was lost without a fold at L/a "
                             f"{b.lengths[-1] if len(b.points) else float('nan'):.4g}: "
                             f"{b.reason}")
            continue
        if kind == "popup" and down is up:
            continue
        fold, n, why = locate_on_mesh(sheet, b.fold_point, b.problem, kind, hmax,
                                      layers=layers, solver=solver, keep_state=keep_states)
        fine_work += n
        if fold is None:
            notes.append(f"the {kind} fold found at L/a {b.fold:.5f} on hmax {h_trace:g} was "
                         f"not located on hmax {hmax:g}: {why}")
        elif fold.confirmed is False:
            notes.append(f"at the {kind} fold (L/a {fold.length:.5f}) the negative eigenvalue "
                         f"counts on both sides, {fold.crossing}, do not differ by one")
        located[kind] = fold
    # the branches end at their folds as located on hmax (their points are the trace's)
    one = down is up
    up = _ending_at(up.without_states(), located.get("standout"))
    down = up if one else _ending_at(down.without_states(), located.get("popup"))
    if fine_branches and h_trace != hmax:
        up, down, n = _fine_branches(sheet, base, lo, hi, hmax, h_trace, common, guides,
                                     located, up, down, on_point, progress, flat, solver,
                                     names)
        fine_work += n
    return FoldLengths(sheet, hmax, (lo, hi), located.get("standout"), located.get("popup"),
                       up, down, h_trace, hmax if fine_branches else h_trace,
                       "; ".join(notes), int(fine_work if h_trace != hmax
                                             else fine_work + trace_work),
                       int(trace_work if h_trace != hmax else 0), time.perf_counter() - t0)


def _ending_at(branch, fold):
    """``branch`` with its fold the located ``fold`` (its length and deflection on
    the results' mesh), or as it is without one."""
    if fold is None:
        return branch
    return replace(branch, fold=fold.length, fold_deflection=fold.deflection)


#: A branch followed on the fine mesh up to its located fold stops this far
#: (L/a) before it (where Newton at fixed length still converges: the state
#: moves like the square root of the distance to the fold).
FOLD_GAP = 0.01


def _fine_branches(sheet, base, lo, hi, hmax, h_trace, common, guides, located, up, down,
                   on_point, progress, flat, solver, names=False):
    """The two branches on the mesh ``hmax`` (:func:`fold_lengths`, step 3):
    from their starts (reached from the trace mesh) up to their located folds
    (or the range's end), guided by the traced branches; ``(up, down,
    factorisations)``."""
    start = CoarseStart(hmax=h_trace)
    out, work = [], 0
    bars = _bars(progress, lo, hi)
    try:
        for k, (kind, sheet_at, stop_end, path, traced) in enumerate((
                ("standout", base, hi, "curvature-first", up),
                ("popup", base.replace(length=hi), lo, "gravity-first", down))):
            if k == 1 and (flat or (down is up and on_point[1] is None
                                    and out[0].fold is None)):
                out.append(out[0])
                break
            fold = located.get(kind)
            direction = 1.0 if k == 0 else -1.0
            stop = stop_end if fold is None else fold.length - direction * FOLD_GAP
            if traced.start_snapped or (stop - sheet_at.length) * direction <= 0:
                out.append(replace(traced, points=(), newton_iterations=0))
                continue
            b = follow_branch("L", sheet_at, stop, path=path, hmax=hmax, **common,
                        progress=bars[k], on_point=on_point[k], start=start,
                        guide=guides[k], locate=fold is None, names=names)
            work += b.newton_iterations
            if fold is None and b.fold_point is not None:
                # a fold on this mesh that the trace did not have (near the cusp, where
                # the window opens between the two meshes): located on its own mesh too
                fold, n, _ = locate_on_mesh(sheet, b.fold_point, b.problem, kind, hmax,
                                            layers=common["layers"], solver=solver)
                work += n
                located[kind] = fold
            if fold is not None:
                b = replace(b, fold=fold.length, fold_deflection=fold.deflection,
                            reason=b.reason or traced.reason,
                            bracket=b.bracket or traced.bracket)
            out.append(b.without_states())
    finally:
        for bar in bars:
            if bar is not None:
                bar.close()
    return out[0], out[1], work


def fold_lengths_of(tip_width: float = 1.0, curvature: float = 2.5, *, thickness: float = 0.03,
                    modulus: float = 735.0, lengths=(0.6, 2.4), hmax: float = DEFAULT_HMAX,
                    **options) -> FoldLengths:
    """Deprecated: the old ``fold_lengths(tip_width, curvature, ...)``, whose
    material was loose keyword arguments that defaulted to the paper's (so
    that a sheet of another material got the paper's fold lengths without a
    word).  Use :func:`fold_lengths` with a :class:`~skfem_sheet.params.Sheet`."""
    warnings.warn("fold_lengths(tip_width, curvature, thickness=, modulus=) is deprecated: "
                  "pass the Sheet, fold_lengths(Sheet(length=..., tip_width=..., "
                  "curvature=..., thickness=..., modulus=...), hmax=...)",
                  DeprecationWarning, stacklevel=2)
    lengths = (0.6, 2.4) if lengths is None else lengths
    lo, hi = (float(x) for x in lengths)
    sheet = Sheet(length=lo, tip_width=tip_width, curvature=curvature, thickness=thickness,
                  modulus=modulus)
    return fold_lengths(sheet, hmax=hmax, lengths=(lo, hi), **options)


class _Bar:
    def __init__(self, desc, start, stop):
        self.start = start
        self.bar = tqdm(total=round(abs(stop - start), 3), desc=desc, unit="L",
                        bar_format="{desc}: {percentage:3.0f}%|{bar}| [{elapsed}{postfix}]")

    def __call__(self, length):
        self.bar.n = round(abs(length - self.start), 3)
        self.bar.set_postfix_str(f"L/a = {length:.3f}", refresh=True)

    def close(self):
        self.bar.close()


def _bars(progress, lo, hi):
    if not progress:
        return None, None
    return _Bar("curvature-dominated, L up", lo, hi), _Bar("gravity-dominated, L down", hi, lo)
