"""The public solver: ``solve(sheet, path=..., hmax=...) -> Result``.

A façade: it validates the arguments, builds the discrete problem, reaches
full load through one start strategy (:mod:`skfem_sheet.starts`), polishes
the end state and returns a :class:`~skfem_sheet.result.Result`.  The load
path itself is :func:`skfem_sheet.continuation.follow_path`'s.
"""
from __future__ import annotations

import time

import numpy as np

from .analyses.mode import mode_of
from .analyses.observables import tip_deflection
from .analyses.sensitivity import check_parameters, state_sensitivities
from .analyses.stability import antisymmetric_stability
from .build import BuildChain
from .continuation import PATHS, StepOptions
from .linalg import make_linear_solver
from .mesh import estimate_dofs
from .newton import NewtonOptions, Stats, polish, timed
from .params import ParameterError, Sheet, check_range
from .problem import SheetProblem
from .result import Result, SolveError, StartRecord
from .starts import STARTS, CoarseStart, Job, PathStart, make_start

__all__ = ["MAX_DOFS", "STARTS", "CoarseStart", "PathStart", "Result", "SolveError",
           "StartRecord", "build_problem", "solve"]

#: Largest problem accepted (about 6 GB of factor with PARDISO on 2 cores).
MAX_DOFS = 1_500_000


def _back_substitutions(linear) -> int:
    """Right-hand sides the linear solver back-substituted (0 if it does not count)."""
    counts = getattr(linear, "counts", None)
    return int(counts.back_substitutions) if counts is not None else 0


def build_problem(sheet: Sheet, hmax: float, layers=None, quadrature_order: int = 2,
                  half: bool = False, refine: int = 0, *,
                  chain: BuildChain | None = None) -> SheetProblem:
    """The discrete problem :func:`solve` solves: ``sheet`` on its mesh
    (:func:`~skfem_sheet.mesh.sheet_mesh` with ``hmax``, ``layers``,
    ``half``, ``refine``), built by ``chain`` (its mesh, space and assembler
    reused if it kept them) or, without one, afresh.

    Examples
    --------
    >>> chain = BuildChain()
    >>> p = build_problem(Sheet(length=0.5), 0.15, None, 2, half=True, chain=chain)
    >>> q = build_problem(Sheet(length=0.5, curvature=2.0), 0.15, None, 2, half=True,
    ...                   chain=chain)
    >>> p.sheet_mesh.half, p.assembler is q.assembler
    (True, True)
    """
    return (chain if chain is not None else BuildChain(0)).problem(
        sheet, hmax, layers, quadrature_order, half, refine)


def _branch(path, snaps):
    """The branch a load path's history points to (its own, switched at each
    located fold the sheet snapped from): the name of a state that did not
    reach full load, which has no S-curve of its own to be read from."""
    names = ("curvature-dominated", "gravity-dominated")
    own = 0 if path == "curvature-first" else 1
    return names[(own + len(snaps)) % 2]


def solve(sheet: Sheet, path: str = "curvature-first", hmax: float = 0.03, *,
          layers=None, refine: int = 0, solver: str = "auto", quadrature_order: int = 2,
          symmetric: bool = True,
          newton_options: NewtonOptions | None = None,
          step_options: StepOptions | None = None,
          on_failure: str = "raise", progress: bool = False, series=None,
          start="coarse", coarse_hmax: float | None = None,
          gravity: float = 1.0, sensitivities=(), chain: BuildChain | None = None) -> Result:
    """Equilibrium of a clamped, curved sheet under its own weight.

    Parameters
    ----------
    sheet : Sheet
    path : {"curvature-first", "gravity-first"}
        Load path, which selects the branch in the bistable range: the
        curvature ramp first (the sheet stays aloft), or gravity first (it
        droops).  Each phase is traced by continuation in its load; where the
        load has a turning point (a fold, located) the sheet snaps onto the
        stable state at that load (``Result.snaps``).
    hmax : float
        Mesh size (in-plane edge length; layers through the thickness are at
        most ``hmax`` thick).
    layers : int, optional
        Number of element layers through the thickness.
    refine : int
        Nested mesh refinement, 0 to 4 (default 0): every edge of the mesh
        made at ``hmax`` halved ``refine`` times (8x the elements per step),
        the clean sequence for convergence studies.
    solver : {"auto", "pardiso", "superlu"}
        Linear-solver back-end (see :mod:`skfem_sheet.linalg`).
    quadrature_order : {2, 3, 4}
    symmetric : bool
        Solve the mirror-symmetric half ``y >= 0`` (default: half the
        unknowns, the same answer to round-off for a symmetric equilibrium);
        ``False`` solves the whole sheet, which admits asymmetric shapes.
    newton_options : NewtonOptions, optional
        Newton's tolerances (of the end state, the folds and the snaps) and
        the final polish (``final_utol``).
    step_options : StepOptions, optional
        The load steps (lengths and the nominal corrector distance).
    on_failure : {"raise", "return"}
        If the full load is not reached: raise :class:`SolveError` (default)
        or return a :class:`Result` with ``converged=False``.
    progress : bool
        Show a progress bar on stderr.
    series : skfem_sheet.io.Series, optional
        Collects the state of every accepted load step on the mesh ``hmax``
        (``series.write`` writes them as a ParaView series).
    start : {"coarse", "path"} or a start strategy
        How full load is reached (:mod:`skfem_sheet.starts`): ``"coarse"``
        (default, :class:`~skfem_sheet.starts.CoarseStart`: the load path on
        a coarse mesh, carried to the mesh ``hmax`` by its located folds) or
        ``"path"`` (:class:`~skfem_sheet.starts.PathStart`: the load path on
        the mesh ``hmax``); both reach the same equilibrium
        (``Result.start_record`` says how).
    coarse_hmax : float, optional
        Mesh of the coarse path (default
        :meth:`~skfem_sheet.starts.CoarseStart.coarse_mesh`).
    gravity : float
        The gravity load as a fraction of the sheet's own weight, in [0, 10]
        (default 1; 0: no gravity, the clamp's curvature alone, one phase
        on both paths).
    sensitivities : iterable of str or str
        Parameters to differentiate the outputs by, from ``modulus``,
        ``thickness``, ``curvature``, ``gravity``, ``length``, ``tip_width``
        (:mod:`skfem_sheet.analyses.sensitivity`; ``Result.sensitivities``).
    chain : BuildChain, optional
        Builds the meshes, spaces and assemblers and keeps them for the next
        solve given the same chain (:mod:`skfem_sheet.build`).

    Returns
    -------
    Result
        A converged end state is polished to ``newton_options.final_utol``
        (back-substitutions with the last factorisation).

    Examples
    --------
    >>> r = solve(Sheet(length=0.5), hmax=0.1)
    >>> r.converged, 0.09 < r.deflection < 0.11
    (True, True)
    """
    if not isinstance(sheet, Sheet):
        raise ParameterError(f"sheet must be a skfem_sheet.Sheet, got {type(sheet).__name__}")
    if path not in PATHS:
        raise ParameterError(f"path must be one of {', '.join(PATHS)}, got {path!r}")
    strategy = make_start(start, coarse_hmax)
    if on_failure not in ("raise", "return"):
        raise ParameterError(f"on_failure must be 'raise' or 'return', got {on_failure!r}")
    if quadrature_order not in (2, 3, 4):
        raise ParameterError(f"quadrature_order must be one of 2, 3, 4, got {quadrature_order!r}")
    hmax = check_range("hmax", hmax, 0, None, lo_open=True)
    gravity = check_range("gravity", gravity, 0, 10,
                          hint="a fraction of the sheet's own weight")
    if not isinstance(symmetric, (bool, np.bool_)):
        raise ParameterError(f"symmetric must be True or False, got {symmetric!r}")
    sensitivities = check_parameters(sensitivities, sheet)
    if series is not None and not callable(getattr(series, "on_step", None)):
        raise ParameterError(f"series must be a skfem_sheet.io.Series, got {series!r}")
    if chain is not None and not isinstance(chain, BuildChain):
        raise ParameterError(f"chain must be a skfem_sheet.build.BuildChain or None, got "
                             f"{type(chain).__name__}")
    chain = chain if chain is not None else BuildChain(max_meshes=2)
    ndofs = estimate_dofs(sheet, hmax, layers, half=symmetric, refine=refine)
    if ndofs > MAX_DOFS:
        what = f"hmax={hmax:g}" + (f" with refine={refine}" if refine else "")
        raise ParameterError(f"hmax must be larger{' or refine smaller' if refine else ''}: "
                             f"{what} gives about {ndofs:,} unknowns, "
                             f"more than the {MAX_DOFS:,} that fit in memory here")
    linear = make_linear_solver(solver)
    solver_name = linear.name
    for name, value, kind in (("newton_options", newton_options, NewtonOptions),
                              ("step_options", step_options, StepOptions)):
        if value is not None and not isinstance(value, kind):
            raise ParameterError(f"{name} must be a {kind.__name__} or None, "
                                 f"got {type(value).__name__}")
    newton_options = newton_options or NewtonOptions()
    step_options = step_options or StepOptions()

    t0 = time.perf_counter()
    stats = Stats()
    problem = build_problem(sheet, hmax, layers, quadrature_order, bool(symmetric), int(refine),
                            chain=chain)
    if getattr(linear, "needs_layout", False):  # the saddle-point structure (pyamg)
        linear.attach(problem.saddle_point_layout())
    bar = None
    if progress:
        # deferred: only progress bars need tqdm
        from tqdm.auto import tqdm

        bar = tqdm(total=100, desc=f"{path} L={sheet.length:g} b={sheet.tip_width:g} "
                   f"a/R={sheet.curvature:g}", leave=False,
                   bar_format="{desc}: {percentage:3.0f}%|{bar}| [{elapsed}<{remaining}{postfix}]")

    def report(frac):
        if bar is not None:
            bar.n = round(100 * frac)
            bar.set_postfix(newton=stats.newton_iterations, refresh=False)
            bar.refresh()

    # the series' frames are passed on one step late, so that the last one
    # can be the polished end state (the Result's)
    pending = []

    def on_step(pr, w_step, k, g):
        if pending:
            series.on_step(*pending.pop())
        pending.append((pr, np.array(w_step, dtype=float), k, g))

    job = Job(problem=problem, path=path, kappa=sheet.curvature, gravity=gravity, linear=linear,
              solver=solver, newton_options=newton_options, step_options=step_options,
              stats=stats, report=report, on_step=None if series is None else on_step,
              build=lambda h: build_problem(sheet, h, None, quadrature_order, bool(symmetric),
                                            0, chain=chain))
    try:
        out = strategy.reach(job)
    finally:
        if bar is not None:
            bar.close()
    w, n_polish = out.w, 0
    if out.converged or (out.kappa, out.g) == (sheet.curvature, gravity):
        # either start: the same tight end state (d to final_utol, not utol);
        # also an end state at full load that failed its stability check
        w, n_polish = polish(problem, w, out.g, linear, stats,
                             utol=newton_options.final_utol,
                             max_iterations=newton_options.polish_iterations,
                             first=10 * newton_options.utol)
    if pending:
        pr, w_last, k, g = pending.pop()
        if out.converged and pr is problem and (k, g) == (out.kappa, out.g):
            w_last = w  # the end state, as the Result holds it
        series.on_step(pr, w_last, k, g)
    sens = None
    t_sens = time.perf_counter()
    if sensitivities and out.converged:
        # with the factorisation at the end state (before the antisymmetric check)
        sens = state_sensitivities(problem, w, out.g, sensitivities, linear=linear)
    t_sens = time.perf_counter() - t_sens
    converged, message = out.converged, out.reason
    stable, n_neg = (out.stable, out.negative_eigenvalues) if out.converged else (None, None)
    # the state's name, read from the state (its S-curve's bend there,
    # analyses.mode), with the solve's factorisation; the path's history stays
    # in the snaps
    mode = mode_of(problem, w, out.g, linear) if out.converged else None
    back_substitutions = _back_substitutions(linear)
    if converged:
        del job, linear  # done with: the check's own factorisation may be large
        stable, n_neg, why = _stable_against_every_perturbation(
            problem, w, stable, n_neg, symmetric, solver, stats)
        if why:
            converged, message = False, why
    result = Result(
        sheet=sheet, path=path, hmax=hmax,
        deflection=tip_deflection(problem, w), converged=converged,
        message=message, kappa=out.kappa, gravity=out.g,
        dofs=int(problem.ndof), newton_iterations=stats.newton_iterations,
        factorizations=stats.factorizations, load_steps=len(out.steps),
        rejected_steps=out.rejected_steps,
        wall_time_s=time.perf_counter() - t0 - t_sens, assembly_s=stats.assembly_s,
        linear_solve_s=stats.linear_solve_s,
        energy=problem.energy(w, out.g),
        volume_change=problem.deformed_volume(w) / problem.volume0 - 1.0,
        solver=solver_name, layers=problem.sheet_mesh.layers,
        steps=tuple(out.steps), snaps=tuple(out.snaps), symmetric=bool(symmetric),
        branch=mode.name if mode is not None else _branch(path, out.snaps), stable=stable,
        negative_eigenvalues=n_neg, mode=mode,
        refine=int(refine), problem=problem, w=w,
        back_substitutions=back_substitutions, polish_iterations=n_polish,
        target_gravity=gravity, start_record=out.record, sensitivities=sens)
    if not converged and on_failure == "raise":
        what = ("solve did not reach full load" if not out.converged
                else "solve reached full load on an unstable state")
        raise SolveError(f"{what}: {message}", result)
    return result


def _stable_against_every_perturbation(problem, w, stable, n_neg, symmetric, solver, stats):
    """The end state's stability against every perturbation: ``(stable,
    (symmetric count, antisymmetric count), why not)``.

    The half model's own inertia (``n_neg``, from the start strategy) counts
    the mirror-symmetric perturbations; the antisymmetric ones, which it does
    not see, are counted by the same half mesh's Hessian under the mirror's
    other condition (:func:`~skfem_sheet.analyses.stability.antisymmetric_stability`,
    one factorisation): the two counts are the whole sheet's.  A whole sheet
    (``symmetric=False``) is checked against every perturbation by its own
    inertia: ``(k, None)``."""
    if not symmetric:
        return stable, (n_neg, None), ""
    K = timed(stats, "assembly_s", problem.tangent, w)
    t = time.perf_counter()
    anti = antisymmetric_stability(problem, w, solver, K=K)
    stats.linear_solve_s += time.perf_counter() - t
    stats.factorizations += anti.factorizations
    pair = (n_neg, anti.negative_eigenvalues)
    if anti.stable is False:
        kind = f" (a {anti.mode} mode)" if anti.mode else ""
        return False, pair, (
            f"the symmetric end state is unstable to antisymmetric perturbations: "
            f"{anti.negative_eigenvalues} negative eigenvalue(s) of the Hessian under the "
            f"mirror's other condition{kind}; the sheet leaves its mirror symmetry there "
            f"(solve the whole sheet, symmetric=False)")
    both = None if stable is None or anti.stable is None else bool(stable and anti.stable)
    return both, pair, ""
