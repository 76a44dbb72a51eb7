"""Bistability: continuation in the sheet length, fold lengths, stability, the S-curve.

In the bistable range a sheet has two stable equilibria (paper, Figs. 2, 4, 6
and 7): the curvature-dominated (aloft) one, which exists up to the
*standout length* ``L1*``, and the gravity-dominated (drooped) one, which
exists down to the *pop-up length* ``L0*``.  The sheet is bistable for
``L0* < L < L1*``; between the two stable branches lies an unstable one, and
the three form an S-shaped curve of ``d`` against ``L`` whose turning points
(folds) are ``L0*`` and ``L1*``.

How the length is made a continuous parameter: a problem built on a mesh of
length ``L_m`` is stretched in x to any nearby length
(:meth:`skfem_sheet.problem.SheetProblem.with_length`), so one mesh topology
carries the nodal solution from one length to the next; beyond a stretch of
1.35 the sheet is remeshed at the current length and the solution is
interpolated onto the new mesh (:func:`transfer`).

Functions
---------
:func:`follow_length`
    natural continuation in L from a solved sheet, until the branch is lost:
    the fold is bracketed by step halving to ``tol`` (bisection);
:func:`fold_lengths`
    ``L0*`` and ``L1*`` of one (b, a/R): curvature-first from a short sheet
    with increasing L, gravity-first from a long sheet with decreasing L;
:func:`follow_curvature`
    the same in the clamp curvature at fixed L (critical curvatures
    ``1/R0*`` and ``1/R1*``);
:func:`s_curve`
    pseudo-arclength continuation in L through both folds, tracing the
    unstable middle branch;
:func:`stability`
    stable or not, from the inertia of the constrained tangent.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from tqdm.auto import tqdm

from .analyses.observables import free_edge_nodes, tip_deflection
from .analyses.stability import stability
from .analyses.transfer import transfer
from .continuation import follow_path
from .linalg import LinearSolverError, make_linear_solver
from .mesh import sheet_mesh
from .newton import NewtonOptions, Stats, newton, timed
from .params import ParameterError, Sheet, check_range
from .problem import SheetProblem
from .version import __version__

__all__ = ["BranchPoint", "Branch", "Bistability", "SCurve", "stability", "transfer",
           "follow_length", "follow_curvature", "fold_lengths", "s_curve"]

#: Remesh when the stretch of the current mesh leaves [1/MAX_STRETCH, MAX_STRETCH].
MAX_STRETCH = 1.35


@dataclass(frozen=True)
class BranchPoint:
    """One equilibrium at full load: length, tip deflection, stability."""

    length: float
    deflection: float
    stable: object  # bool or None (solver cannot tell)
    negative_eigenvalues: object = None
    newton_iterations: int = 0


class _Curve:
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
class Branch(_Curve):
    """Result of :func:`follow_length`.

    Attributes
    ----------
    points : tuple of BranchPoint
        The converged equilibria, in the order of the continuation.
    fold : float or None
        The length where the branch was lost (midpoint of the bracket), or
        None if it held over the whole range.
    bracket : tuple
        ``(last length on the branch, first length where it was not found)``.
    reason : str
        Why the branch was declared lost at the bracket's end.
    start_snapped : bool
        The starting solve (along its load path) snapped to the other
        branch: the branch the path selects does not exist at the start
        length, and the points are on the other one.
    """

    points: tuple
    fold: object = None
    bracket: tuple = ()
    reason: str = ""
    newton_iterations: int = 0
    wall_time_s: float = 0.0
    start_snapped: bool = False


# ----------------------------------------------------------------------------
# kernels: stability, transfer between meshes, derivative in L
# ----------------------------------------------------------------------------


def _residual_rate(problem, w, g=1.0, rel=1e-6):
    """``d r / d L`` at fixed nodal state (central difference on the stretch)."""
    eps = rel * problem.length
    rp, _ = problem.with_length(problem.length + eps).residual(w, g)
    rm, _ = problem.with_length(problem.length - eps).residual(w, g)
    return (rp - rm) / (2 * eps)


def _length_tangent(problem, w, solver):
    """``dw/dL`` on the free dofs, with the last factorisation: ``K dw = -dr/dL``."""
    dw = np.zeros(problem.ndof)
    dw[problem.free] = solver.solve(-_residual_rate(problem, w)[problem.free])
    return dw


# ----------------------------------------------------------------------------
# a sheet that changes length: one mesh, stretched, remeshed when needed
# ----------------------------------------------------------------------------
class _Stretched:
    """The current mesh (built at some length) and the linear solver on it."""

    def __init__(self, sheet, hmax, layers, solver, symmetric):
        self.hmax, self.layers, self.solver_name, self.half = hmax, layers, solver, symmetric
        self._build(sheet)

    def _build(self, sheet):
        self.base = SheetProblem(sheet, sheet_mesh(sheet, self.hmax, self.layers, half=self.half))
        self.solver = make_linear_solver(self.solver_name)
        if hasattr(self.solver, "attach"):
            self.solver.attach(self.base)

    def at(self, length):
        return self.base.with_length(length)

    def needs_remesh(self, length):
        s = length / self.base.sheet_mesh.length
        return not 1.0 / MAX_STRETCH <= s <= MAX_STRETCH

    def remesh(self, problem, w, options, stats, path):
        """New mesh at ``problem.length``; returns ``(problem, state)`` or None.

        The state is interpolated onto the new mesh and re-converged.  An
        interpolated thin-sheet state is not exactly incompressible on the new
        mesh, and Newton may need many iterations from it; if it fails within
        ``options.max_iterations``, the new mesh is solved afresh along the
        branch's own load path (which selects the same branch inside the
        bistable range; the caller checks the deflection for continuity).
        """
        old = problem
        self._build(problem.sheet)
        new = self.base
        res = newton(new, transfer(old, w, new), 1.0, self.solver, options, stats)
        if res.converged:
            return new, res.w
        out = follow_path(new, path, new.sheet.curvature, self.solver, stats=stats)
        return (new, out.w) if out.converged else None


def _check_common(sheet, hmax, step, tol):
    if not isinstance(sheet, Sheet):
        raise ParameterError(f"sheet must be a skfem_sheet.Sheet, got {type(sheet).__name__}")
    check_range("hmax", hmax, 0, None, lo_open=True)
    check_range("step", step, 0, 1, lo_open=True)
    check_range("tol", tol, 0, step, lo_open=True)


def follow_length(sheet: Sheet, stop: float, *, path: str = "curvature-first", hmax: float = 0.06,
                  layers=None, solver: str = "auto", symmetric: bool = True, step: float = 0.1,
                  tol: float = 0.005, jump: float = 0.1, progress=None,
                  on_point=None) -> Branch:
    """Follow the branch selected by ``path`` at ``sheet.length`` to ``stop``.

    Natural continuation in L at full load: each step is predicted with
    ``dw/dL`` and corrected by Newton.  A step fails if Newton does not
    converge, if the equilibrium found is unstable, or if the deflection
    jumps by more than ``jump`` (it landed on another branch); then the step
    is halved from the last equilibrium.  When a failing step is no longer
    than ``2 tol`` the branch is lost there: the fold is the middle of the
    bracket, to ``+- tol`` (bisection).

    Parameters
    ----------
    sheet : Sheet
        Start: its length, tip width and curvature.
    stop : float
        Length at which to stop if the branch holds (above or below the start).
    path : {"curvature-first", "gravity-first"}
        Load path of the starting solve (selects the branch).
    step : float
        Largest length step.
    tol : float
        Half-width of the final fold bracket.
    on_point : callable(problem, w, length) or None
        Called with the state of each point of the branch (e.g.
        ``skfem_sheet.io.Series().on_point``, then ``Branch.write_series``).

    Returns
    -------
    Branch

    Examples
    --------
    >>> b = follow_length(Sheet(length=0.5, curvature=2.5), 0.7, hmax=0.15, step=0.1)
    >>> b.fold is None, len(b.points)
    (True, 3)
    """
    _check_common(sheet, hmax, step, tol)
    stop = check_range("stop", stop, 0.05, 20.0)
    return _follow(_LengthParameter(), sheet, stop, path=path, hmax=hmax, layers=layers,
                   solver=solver, symmetric=symmetric, step=step, tol=tol, jump=jump,
                   progress=progress, on_point=on_point)


def follow_curvature(sheet: Sheet, stop: float, *, path: str = "gravity-first", hmax: float = 0.06,
                     layers=None, solver: str = "auto", symmetric: bool = True,
                     step: float = 0.25, tol: float = 0.005, jump: float = 0.1,
                     progress=None, on_point=None) -> Branch:
    """Follow a branch in the clamp curvature a/R at fixed length, to ``stop``.

    The same natural continuation as :func:`follow_length`, with the clamp
    curvature as the parameter (the clamped values change; the mesh does
    not).  From the gravity-dominated state at a small curvature, increasing
    a/R finds where it pops up (``1/R0*``); from the curvature-dominated state
    at a large curvature, decreasing a/R finds where it falls (``1/R1*``).
    ``Branch.fold`` and the branch points' ``length`` field then hold
    curvatures.

    Examples
    --------
    >>> b = follow_curvature(Sheet(length=0.6, curvature=1.0), 1.5, hmax=0.15, step=0.25)
    >>> b.fold is None, len(b.points)
    (True, 3)
    """
    _check_common(sheet, hmax, step, tol)
    stop = check_range("stop", stop, 0.0, 2 * np.pi, hi_open=True)
    return _follow(_CurvatureParameter(sheet.curvature), sheet, stop, path=path, hmax=hmax,
                   layers=layers, solver=solver, symmetric=symmetric, step=step, tol=tol,
                   jump=jump, progress=progress, on_point=on_point)


class _LengthParameter:
    """The sheet length as continuation parameter (stretched mesh)."""

    name = "L"

    def value(self, problem):
        return problem.length

    def at(self, track, problem, v):
        return track.at(v)

    def apply(self, problem, w, v):
        return w

    def rate(self, problem, w, solver):
        return _length_tangent(problem, w, solver)


class _CurvatureParameter:
    """The clamp curvature a/R as continuation parameter (clamped values)."""

    name = "a/R"

    def __init__(self, kappa):
        self.kappa = kappa

    def value(self, problem):
        return self.kappa

    def at(self, track, problem, v):
        self.kappa = v
        return problem

    def apply(self, problem, w, v):
        w = w.copy()
        w[problem.clamp_dofs] = problem.clamp_values(v)
        return w

    def rate(self, problem, w, solver):
        """``dw/dkappa``: the clamp rate, and ``K dw_f = -K_fc dw_c`` inside."""
        dw = np.zeros(problem.ndof)
        dw[problem.clamp_dofs] = problem.clamp_rate(self.kappa)
        rhs = -(problem.clamp_coupling(w) @ dw[problem.clamp_dofs])
        dw[problem.free] = solver.solve(rhs)
        return dw


def _follow(param, sheet, stop, *, path, hmax, layers, solver, symmetric, step, tol, jump,
            progress, on_point=None):
    """Natural continuation in ``param`` with fold bisection (see :func:`follow_length`)."""
    t0 = time.perf_counter()
    stats = Stats()
    tight = NewtonOptions()
    track = _Stretched(sheet, hmax, layers, solver, symmetric)
    problem = track.at(sheet.length)
    out = follow_path(problem, path, sheet.curvature, track.solver, stats=stats)
    if not out.converged:
        raise ParameterError(f"the starting sheet (length {sheet.length:g}, a/R "
                             f"{sheet.curvature:g}) could not be solved along {path}: {out.reason}")
    w = out.w
    v = param.value(problem)
    direction = 1.0 if stop >= v else -1.0
    st, k = stability(problem, track.solver)
    points = [BranchPoint(v, tip_deflection(problem, w), st, k, stats.newton_iterations)]
    if on_point is not None:
        on_point(problem, w, v)
    dwdv = param.rate(problem, w, track.solver)
    h = step
    guard = 0.25 * max(1.0, sheet.length)
    fold, bracket, reason = None, (), ""
    while direction * (stop - v) > 1e-12:
        v_try = v + direction * min(h, abs(stop - v))
        if isinstance(param, _LengthParameter) and track.needs_remesh(v_try):
            moved = track.remesh(problem, w, tight, stats, path)
            d_here = tip_deflection(*moved) if moved is not None else np.nan
            if not abs(d_here - points[-1].deflection) <= jump:
                reason = (f"remeshing at L = {v:.4g} failed" if moved is None else
                          f"remeshing at L = {v:.4g} landed on another branch "
                          f"(d = {d_here:.4g} instead of {points[-1].deflection:.4g})")
                break
            problem, w = moved
            dwdv = param.rate(problem, w, track.solver)
        trial = param.at(track, problem, v_try)
        w_pred = param.apply(trial, w + (v_try - v) * dwdv, v_try)
        its0 = stats.newton_iterations
        res = newton(trial, w_pred, 1.0, track.solver, tight, stats, max_first_increment=guard)
        why = "" if res.converged else f"Newton: {res.reason}"
        if res.converged:
            st, k = stability(trial, track.solver)
            d_new = tip_deflection(trial, res.w)
            if st is False:
                why = f"unstable equilibrium ({k} negative eigenvalues)"
            elif abs(d_new - points[-1].deflection) > jump:
                why = f"deflection jumped from {points[-1].deflection:.4g} to {d_new:.4g}"
        if not why:
            problem, w, v = trial, res.w, v_try
            points.append(BranchPoint(float(v), d_new, st, k, stats.newton_iterations - its0))
            if on_point is not None:
                on_point(problem, w, v)
            dwdv = param.rate(problem, w, track.solver)
            h = min(step, 1.5 * h)
            if progress is not None:
                progress(v)
            continue
        param.at(track, problem, v)  # back to the last equilibrium
        if abs(v_try - v) <= 2 * tol + 1e-12:
            bracket = (v, v_try)
            fold, reason = 0.5 * (v + v_try), why
            break
        h = max(0.5 * abs(v_try - v), tol)  # dwdv (a vector) is still valid
    return Branch(tuple(points), fold, bracket, reason, stats.newton_iterations,
                  time.perf_counter() - t0, start_snapped=len(out.snaps) > 0)


@dataclass(frozen=True)
class Bistability:
    """Pop-up and standout lengths of one (tip width, curvature).

    Attributes
    ----------
    popup_length : float or None
        ``L0*``: below it the gravity-dominated branch does not exist (None if
        it held down to the lower end of the range).
    standout_length : float or None
        ``L1*``: above it the curvature-dominated branch does not exist (None
        if it held up to the upper end).
    bistable : bool
        Both folds found with ``L0* < L1*`` and their brackets disjoint
        (``L1* - L0* > 2 tol``): a bistable range narrower than the fold
        resolution is not claimed (near the cusp where it closes, e.g. the
        rectangle at a/R = 1).
    increasing, decreasing : Branch
        The two continuations (curvature-first from the short end,
        gravity-first from the long end; at a/R = 0 one and the same).
        ``start_snapped`` on either means its branch does not exist at the
        end of the range it started from (widen ``lengths``).
    """

    tip_width: float
    curvature: float
    hmax: float
    length_range: tuple
    popup_length: object
    standout_length: object
    bistable: bool
    increasing: Branch
    decreasing: Branch
    tol: float = 0.005
    wall_time_s: float = 0.0

    def summary(self) -> dict:
        """JSON-ready summary (the CLI's ``--json``)."""
        def branch(b):
            return {"lengths": b.lengths.tolist(), "deflection": b.deflections.tolist(),
                    "stable": b.stable, "fold": b.fold,
                    "bracket": list(b.bracket), "reason": b.reason,
                    "newton_iterations": b.newton_iterations, "wall_time_s": b.wall_time_s}

        width = (self.standout_length - self.popup_length
                 if self.popup_length is not None and self.standout_length is not None else None)
        return {"popup_length": self.popup_length, "standout_length": self.standout_length,
                "bistable": self.bistable, "bistable_width": width, "tip_width": self.tip_width,
                "curvature": self.curvature, "hmax": self.hmax, "tol": self.tol,
                "length_range": list(self.length_range),
                "curvature_dominated": branch(self.increasing),
                "gravity_dominated": branch(self.decreasing),
                "wall_time_s": self.wall_time_s, "version": __version__}


def fold_lengths(tip_width: float = 1.0, curvature: float = 2.5, *, lengths=(0.6, 2.4),
                 hmax: float = 0.06, layers=None, solver: str = "auto", step: float = 0.1,
                 tol: float = 0.005, thickness: float = 0.03, modulus: float = 735.0,
                 progress: bool = False, on_point=(None, None)) -> Bistability:
    """Standout and pop-up lengths by continuation in L in both directions.

    The curvature-dominated branch is followed from ``lengths[0]``
    (curvature-first) with increasing L until it is lost (``L1*``), the
    gravity-dominated one from ``lengths[1]`` (gravity-first) with decreasing
    L (``L0*``).  Each fold is located to ``+- tol``.  ``on_point`` is the
    pair of the two continuations' ``on_point`` (see :func:`follow_length`).

    Examples
    --------
    >>> r = fold_lengths(0.0, 2.5, lengths=(0.8, 1.2), hmax=0.15, step=0.2)
    >>> r.bistable
    False
    """
    lo, hi = (check_range("lengths", float(x), 0.05, 20.0) for x in lengths)
    if not lo < hi:
        raise ParameterError(f"lengths must be (short, long) with short < long, got {lengths!r}")
    t0 = time.perf_counter()
    base = Sheet(length=lo, tip_width=tip_width, curvature=curvature, thickness=thickness,
                 modulus=modulus)
    _check_common(base, hmax, step, tol)
    bars = _bars(progress, lo, hi)
    up = follow_length(base, hi, path="curvature-first", hmax=hmax, layers=layers,
                       solver=solver, step=step, tol=tol, progress=bars[0],
                       on_point=on_point[0])
    if base.curvature == 0.0:
        down = up  # a flat clamp: both load paths are one problem, with one branch
    else:
        down = follow_length(base.replace(length=hi), lo, path="gravity-first", hmax=hmax,
                             layers=layers, solver=solver, step=step, tol=tol,
                             progress=bars[1], on_point=on_point[1])
    for b in bars:
        if b is not None:
            b.close()
    # a branch missing where it starts (its path snapped there) has no fold of its own
    L1 = None if up.start_snapped else up.fold
    L0 = None if down.start_snapped else down.fold
    return Bistability(tip_width, curvature, hmax, (lo, hi), L0, L1,
                       bool(L0 is not None and L1 is not None and L1 - L0 > 2 * tol), up, down,
                       tol, time.perf_counter() - t0)


class _Bar:
    def __init__(self, desc, start, stop):
        self.start = start
        self.bar = tqdm(total=round(abs(stop - start), 3), desc=desc, unit="L",
                        bar_format="{desc}: {percentage:3.0f}%|{bar}| L={postfix}")

    def __call__(self, length):
        self.bar.n = round(abs(length - self.start), 3)
        self.bar.set_postfix_str(f"{length:.3f}", refresh=True)

    def close(self):
        self.bar.close()


def _bars(progress, lo, hi):
    if not progress:
        return None, None
    return _Bar("curvature-dominated, L up", lo, hi), _Bar("gravity-dominated, L down", hi, lo)


# ----------------------------------------------------------------------------
# pseudo-arclength continuation: the whole S-curve
# ----------------------------------------------------------------------------
@dataclass(frozen=True)
class SCurve(_Curve):
    """The curve of equilibria d(L) traced by pseudo-arclength continuation.

    Attributes
    ----------
    points : tuple of BranchPoint
        In arclength order (the length goes up, back at ``L1*``, up again after ``L0*``).
    folds : tuple of float
        Lengths of the turning points (where dL/ds changes sign), in order.
    """

    points: tuple
    folds: tuple
    converged: bool
    message: str = ""
    newton_iterations: int = 0
    wall_time_s: float = 0.0

    def summary(self) -> dict:
        return {"lengths": self.lengths.tolist(), "deflection": self.deflections.tolist(),
                "stable": self.stable, "folds": list(self.folds),
                "converged": self.converged, "message": self.message,
                "newton_iterations": self.newton_iterations, "wall_time_s": self.wall_time_s}


def s_curve(sheet: Sheet, stop: float, *, hmax: float = 0.06, layers=None, solver: str = "auto",
            symmetric: bool = True, ds: float = 0.05, ds_max: float = 0.15, max_points: int = 200,
            progress=None, on_point=None) -> SCurve:
    """Pseudo-arclength continuation in L from the curvature-dominated state
    at ``sheet.length`` until the length exceeds ``stop`` (on whatever branch).

    Unknowns ``(w, L)``; the equilibrium equations are bordered by the
    arclength condition ``<t_u, u - u_0> + t_L (L - L_0) = ds`` with the inner
    product ``<a, b> = a_tip b_tip + theta a . b``: the vertical displacement
    of the tip's centre (so that steps are even along the plotted curve
    d(L)) plus the root-mean-square of all displacements (``theta = 1 /
    number of displacement unknowns``), all in units of a; the pressures
    are left out of the norm.  Each corrector
    iteration solves the bordered system with two back-substitutions of the
    tangent (bordering algorithm), which stays usable through the fold where
    the tangent alone is singular.  Turning points are located where ``t_L``
    changes sign, by the vertex of the parabola ``L(s)`` through the three
    points around it.

    One mesh, stretched, serves the whole curve: ``sheet.length`` and ``stop``
    must be within a factor 1.8 of each other.  ``on_point(problem, w, L)``,
    if given, is called with the state of each point (see :func:`follow_length`).
    """
    _check_common(sheet, hmax, 0.5, 0.01)
    stop = check_range("stop", stop, sheet.length, 20.0, lo_open=True)
    if stop / sheet.length > MAX_STRETCH**2:
        raise ParameterError(f"stop must be at most {MAX_STRETCH**2:.2f} times the start length "
                             f"({sheet.length:g}) for one stretched mesh, got {stop:g}")
    t0 = time.perf_counter()
    stats = Stats()
    mid = np.sqrt(sheet.length * stop)
    track = _Stretched(sheet.replace(length=mid), hmax, layers, solver, symmetric)
    problem = track.at(sheet.length)
    out = follow_path(problem, "curvature-first", sheet.curvature, track.solver, stats=stats)
    if not out.converged:
        raise ParameterError(f"the starting sheet could not be solved: {out.reason}")
    w, L = out.w, sheet.length
    nu = problem.nu_dof
    free = problem.free
    u_free = free < nu
    theta = 1.0 / np.count_nonzero(u_free)

    tip_nodes = free_edge_nodes(problem)
    tip = 3 * tip_nodes[np.argmin(np.abs(problem.nodes[tip_nodes, 1]))] + 2
    tip_f = int(np.searchsorted(free, tip))  # its position among the free dofs

    def dot(a, b):  # on full-length displacement vectors
        return theta * float(np.dot(a[:nu], b[:nu])) + float(a[tip] * b[tip])
    rref = float(np.linalg.norm(problem.gravity_load[free]))
    opts = NewtonOptions()

    def tangent_at(prob, w, prev=None):
        b = np.zeros(problem.ndof)
        b[free] = track.solver.solve(_residual_rate(prob, w)[free])
        t_w, t_L = -b, 1.0
        n = np.sqrt(dot(t_w, t_w) + t_L**2)
        t_w, t_L = t_w / n, t_L / n
        if prev is not None and (dot(t_w, prev[0]) + t_L * prev[1]) < 0:
            t_w, t_L = -t_w, -t_L
        return t_w, t_L

    st, k = stability(problem, track.solver)
    points = [BranchPoint(L, tip_deflection(problem, w), st, k, 0)]
    if on_point is not None:
        on_point(problem, w, L)
    tL_hist, s_hist, s = [], [], 0.0
    t = tangent_at(problem, w)
    tL_hist.append(t[1])
    s_hist.append(0.0)
    h, message, converged = ds, "", False
    while len(points) < max_points:
        t_w, t_L = t
        w_p = w + h * t_w
        L_p = L + h * t_L
        ok, its = False, 0
        wk, Lk = w_p.copy(), L_p
        for its in range(1, opts.max_iterations + 1):  # noqa: B007 (its is read after the loop)
            prob = track.at(Lk)
            r, Jmin = timed(stats, "assembly_s", prob.residual, wk, 1.0)
            if not Jmin > 0:
                break
            N = dot(t_w, wk - w) + t_L * (Lk - L) - h
            rn = float(np.linalg.norm(r[free]))
            K = timed(stats, "assembly_s", prob.tangent, wk)
            try:
                timed(stats, "linear_solve_s", track.solver.factorize, K, wk)
            except LinearSolverError:
                break
            stats.factorizations += 1
            stats.newton_iterations += 1
            rate = timed(stats, "assembly_s", _residual_rate, prob, wk)
            a = timed(stats, "linear_solve_s", track.solver.solve, -r[free])
            b = timed(stats, "linear_solve_s", track.solver.solve, rate[free])
            tf = t_w[free]
            ta = theta * float(np.dot(tf[u_free], a[u_free])) + tf[tip_f] * a[tip_f]
            tb = theta * float(np.dot(tf[u_free], b[u_free])) + tf[tip_f] * b[tip_f]
            dL = (-N - ta) / (t_L - tb)
            dw = a - dL * b
            wk[free] += dw
            Lk += dL
            if rn <= opts.rtol * rref and max(np.abs(dw[u_free]).max(), abs(dL)) <= opts.utol:
                ok = True
                break
            if max(np.abs(dw[u_free]).max(), abs(dL)) > 0.5:
                break
        if not ok:
            h *= 0.5
            if h < 1e-3:
                message = f"arclength step below 1e-3 at L = {L:.4g}"
                break
            continue
        # accept: the factorisation is at (almost) the new point
        prob = track.at(Lk)
        w, L = wk, Lk
        s += h
        st, k = stability(prob, track.solver)
        points.append(BranchPoint(float(L), tip_deflection(prob, w), st, k, its))
        if on_point is not None:
            on_point(prob, w, L)
        t = tangent_at(prob, w, prev=t)
        tL_hist.append(t[1])
        s_hist.append(s)
        if progress is not None:
            progress(L)
        h = min(ds_max, h * (1.5 if its <= 3 else 1.0))
        if L > stop:
            converged = True
            break
    folds = _turning_points(np.array(s_hist), np.array(tL_hist), points)
    return SCurve(tuple(points), tuple(folds), converged, message, stats.newton_iterations,
                  time.perf_counter() - t0)


def _turning_points(s, tL, points):
    """Lengths where ``dL/ds`` changes sign: vertex of the parabola through
    the three points around the sign change."""
    L = np.array([p.length for p in points])
    folds = []
    for i in range(1, len(tL)):
        if np.sign(tL[i]) != np.sign(tL[i - 1]):
            j = min(max(i - 1, 1), len(L) - 2)  # centre of a 3-point stencil
            c = np.polyfit(s[j - 1:j + 2], L[j - 1:j + 2], 2)
            sv = -c[1] / (2 * c[0]) if c[0] != 0 else s[j]
            folds.append(float(np.polyval(c, np.clip(sv, s[j - 1], s[j + 1]))))
    return folds

