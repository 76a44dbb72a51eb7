"""Load paths: continuation in the loads, with snaps at located folds (branch selection).

In the bistable region the equilibrium reached depends on the load path
(paper, "Finite-element simulations" and SI "Numerical Method"):
``"curvature-first"`` ramps the clamp curvature at zero gravity, then
gravity (the curvature-dominated shape); ``"gravity-first"`` ramps gravity,
then the curvature (the gravity-dominated shape).

Each phase is traced by the engine's load-path driver
(:func:`skfem_sheet.engine.ramp`) in its load fraction ``lam``, with the
sheet as :class:`~skfem_sheet.sheet_engine.LoadPhase` and every step accepted
by the one step rule (:class:`~skfem_sheet.engine.StepRule`).  Under
quasi-static loading the sheet leaves its branch exactly where the load has
a **turning point** (a fold, one eigenvalue of the constrained Hessian
crossing zero); the driver locates it, and the sheet **snaps**: it is moved
off the fold along the null vector, downhill in energy, settled onto the
stable state at the fold load, and the ramp goes on from there
(:class:`Snap`).  A merely steep branch is followed and records no snap; a
snap must move the state and leaves its fold for good.  The end state at full
load is verified stable, else the path fails and says so.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, field, replace

import numpy as np

from .analyses.observables import tip_deflection
from .analyses.stability import stability
from .engine import StepRule, Tolerances, ramp
from .engine.protocol import Counting
from .linalg import LinearSolverError, make_linear_solver
from .newton import NewtonOptions, Stats, newton, pseudo_transient, timed
from .params import ParameterError, check_range
from .sheet_engine import LoadPhase, SheetLoadProblem

__all__ = ["PATHS", "StepOptions", "Snap", "Fold", "PathOutcome", "load_phases",
           "follow_path", "snap_from_fold", "landed_on_its_fold", "settle", "newton_tolerances",
           "end_state_verdict", "elastica_state", "cylinder_state"]

PATHS = ("curvature-first", "gravity-first")

log = logging.getLogger(__name__)

#: Largest tangent whose inertia is checked with SuperLU when the solver cannot tell.
_SUPERLU_CHECK_DOFS = 100_000


@dataclass(frozen=True)
class StepOptions:
    """The load steps: their lengths and the one acceptance rule
    (:class:`~skfem_sheet.engine.StepRule`).

    Lengths are counted per unit of the sheet's size ``max(1, L/a)``: a step is
    an arclength in the phase's load fraction and the state.

    Attributes
    ----------
    initial_step : float
        First step of each phase.
    min_step : float
        Below this the path is declared failed (and says where).
    max_step : float
        Largest step.
    corrector_distance : float
        Nominal distance (largest displacement) between a step's prediction
        and its corrected state.  A step that lands more than four times
        further is rejected and halved, and the next step aims at this distance.
        The points on the way are solved to a tenth of it; the end of the path
        and the folds to the tolerances of ``NewtonOptions``.
    fold_tolerance : float
        A located fold's load fraction is known to this
        (:func:`~skfem_sheet.engine.fold.fold_on_branch`'s ``ptol``): a
        hundredth of how far the fold loads move between hmax 0.1 and 0.03.
    elastica_start : bool
        Start the gravity ramp of a flat clamp at full load from the heavy
        elastica (see :func:`elastica_state`) instead of stepping from zero.
    """

    initial_step: float = 0.25
    min_step: float = 1e-4
    max_step: float = 1.0
    corrector_distance: float = 0.05
    fold_tolerance: float = 1e-5
    elastica_start: bool = True

    def __post_init__(self):
        check_range("initial_step", self.initial_step, 0, None, lo_open=True)
        check_range("min_step", self.min_step, 0, self.initial_step, lo_open=True)
        check_range("max_step", self.max_step, self.initial_step, None)
        check_range("corrector_distance", self.corrector_distance, 0, 1, lo_open=True)
        check_range("fold_tolerance", self.fold_tolerance, 0, 0.01, lo_open=True)

    def rule(self, scale: float = 1.0) -> StepRule:
        """The engine's step rule for a sheet of size ``scale`` (``max(1, L/a)``)."""
        return StepRule(initial=self.initial_step * scale, minimum=self.min_step * scale,
                        maximum=self.max_step * scale, delta=self.corrector_distance * scale)

    def intermediate_utol(self, scale: float = 1.0) -> float:
        """Newton's tolerance (largest displacement correction) at the points
        on the way: a tenth of the nominal corrector distance."""
        return 0.1 * self.corrector_distance * scale


@dataclass(frozen=True)
class Snap:
    """A snap-through: the followed branch ended at a located fold of the
    load, and the sheet jumped onto the stable state at that load.

    Attributes
    ----------
    phase : str
        ``"curvature"`` or ``"gravity"``: the load that was ramped.
    load : float
        The fold's load, as a fraction of the phase (``lam``).
    curvature, gravity : float
        The loads (a/R and the gravity factor) at the fold.
    fold_deflection : float
        Tip deflection d/a at the fold (the last state of the branch).
    landing_deflection : float
        Tip deflection d/a of the stable state the sheet landed on.
    negative_eigenvalues : tuple
        ``(before, after)``: negative eigenvalues of the constrained Hessian
        on the branch before the fold and on the step past it (one more: one
        eigenvalue crossed zero); ``None`` entries where unknown.
    hmax : float
        Mesh size on which the fold was located.
    """

    phase: str
    load: float
    curvature: float
    gravity: float
    fold_deflection: float
    landing_deflection: float
    negative_eigenvalues: tuple = (None, None)
    hmax: float = float("nan")

    def to_json(self) -> dict:
        """A plain dict (the ``snaps`` entries of ``solve --json``)."""
        return {"phase": self.phase, "load": self.load, "curvature": self.curvature,
                "gravity": self.gravity, "fold_deflection": self.fold_deflection,
                "landing_deflection": self.landing_deflection,
                "negative_eigenvalues": list(self.negative_eigenvalues), "hmax": self.hmax}


@dataclass(frozen=True)
class Fold:
    """A fold met by a load path, with what a finer mesh needs to locate it
    again: the fold state, its null vector, the state landed on.

    Attributes
    ----------
    snap : Snap
    w : ndarray
        The full dof vector at the fold.
    v : ndarray
        Null vector on the free dofs (largest displacement 1).
    landing : ndarray
        The full dof vector landed on (at the fold load).
    before : ndarray or None
        The full dof vector of the branch's last point before the fold (a
        point of the branch away from the fold, where a finer mesh whose fold
        lies elsewhere can take the branch up; None if not known).
    before_load : float
        Its load fraction ``lam`` (NaN if not known).
    """

    snap: Snap
    w: np.ndarray = field(repr=False)
    v: np.ndarray = field(repr=False)
    landing: np.ndarray = field(repr=False)
    before: np.ndarray = field(default=None, repr=False)
    before_load: float = float("nan")


@dataclass
class PathOutcome:
    """What happened along a path (mutable while the path runs)."""

    w: np.ndarray
    converged: bool = False
    reason: str = ""
    kappa: float = 0.0
    g: float = 0.0
    steps: list = field(default_factory=list)  # (phase, lam, iterations) per accepted point
    distances: list = field(default_factory=list)  # corrector distance of each (nan: no step)
    rejected_steps: int = 0
    snaps: list = field(default_factory=list)  # Snap, in order
    folds: list = field(default_factory=list)  # Fold, in order (one per snap)
    stable: object = None  # inertia verdict at the end state (None: not known)
    negative_eigenvalues: object = None
    snap_iterations: int = 0  # pseudo-transient steps of the snaps


def load_phases(path: str, kappa: float, gravity: float = 1.0):
    """The phases of a load path as ``(name, start, end)``: the loads
    ``(curvature, gravity)`` at the start and the end of each phase.

    ``gravity`` is the full gravity factor (1: the sheet's own weight); a
    phase whose load is zero is left out (no phase at all for ``kappa = 0``
    and ``gravity = 0``: the reference state is the answer).

    Examples
    --------
    >>> load_phases("gravity-first", 2.5)
    [('gravity', (0.0, 0.0), (0.0, 1.0)), ('curvature', (0.0, 1.0), (2.5, 1.0))]
    """
    if path not in PATHS:
        raise ParameterError(f"path must be one of {', '.join(PATHS)}, got {path!r}")
    kappa, gravity = float(kappa), float(gravity)
    if path == "curvature-first":
        phases = [("curvature", (0.0, 0.0), (kappa, 0.0)),
                  ("gravity", (kappa, 0.0), (kappa, gravity))]
    else:
        phases = [("gravity", (0.0, 0.0), (0.0, gravity)),
                  ("curvature", (0.0, gravity), (kappa, gravity))]
    if kappa == 0.0:
        phases = [p for p in phases if p[0] == "gravity"]
    if gravity == 0.0:
        phases = [p for p in phases if p[0] == "curvature"]
    return phases


def newton_tolerances(options: NewtonOptions, utol: float | None = None) -> Tolerances:
    """The sheet's Newton stopping rule as the engine's :class:`Tolerances`
    (residual relative to the full weight, largest displacement correction);
    with ``utol``, for the loose points on the way: that correction bound and a
    residual of at most the sheet's own weight (without it, a first iterate
    past a fold can pass as a point of the branch: ``docs/decisions.md``,
    "The loose points' residual bound")."""
    tol = Tolerances(rtol=options.rtol, utol=options.utol, max_iterations=options.max_iterations,
                     max_halvings=options.max_halvings, divergence_floor=0.1)
    return tol if utol is None else replace(tol, rtol=1.0, utol=utol)


def _elastica_jump(problem, solver, stats, options, gravity):
    w = elastica_state(problem, gravity)
    if w is None:
        return None
    return newton(problem, w, gravity, solver, options, stats)


def _negatives(problem, solver):
    """Negative directions of the factorised matrix on the incompressible
    subspace, ``None`` if the back-end cannot tell (the pseudo-transient
    shift control)."""
    return stability(problem, solver)[1]


def settle(problem, w, g, solver, newton_options: NewtonOptions, step_options: StepOptions,
           stats: Stats):
    """Settle ``w`` onto a stable equilibrium at gravity ``g``: pseudo-transient
    continuation (:func:`~skfem_sheet.newton.pseudo_transient`, drawn to
    stable states) to the load path's intermediate tolerance, then Newton to
    ``newton_options``.  Where a sheet snaps (from a state moved off its
    fold) and where Newton from a state carried from another mesh leaves its
    basin (:class:`~skfem_sheet.starts.CoarseStart`).

    Returns
    -------
    (NewtonResult, NewtonResult or None)
        The pseudo-transient's outcome and, if it settled, Newton's.
    """
    scale = max(1.0, problem.sheet.length)  # displacements grow with the length
    loose = replace(newton_options, rtol=1.0, utol=step_options.intermediate_utol(scale))
    # (the pseudo-transient's default trust radius, 0.1, per unit of the sheet's size)
    pt = pseudo_transient(problem, w, g, solver, loose, stats, radius=0.1 * scale,
                          negatives=_negatives)
    if not pt.converged:
        return pt, None
    res = newton(problem, pt.w, g, solver, newton_options, stats)
    if res.converged:
        return pt, res
    # the loose settle stopped where the flow is slow but no equilibrium is
    # near (Newton from there leaves): the flow goes on, drawn to the stable
    # state, to the end tolerance (its last steps are Newton's)
    more = pseudo_transient(problem, pt.w, g, solver, newton_options, stats,
                            radius=0.1 * scale, negatives=_negatives)
    pt = replace(more, iterations=pt.iterations + more.iterations)
    if not more.converged:
        return pt, None
    return pt, newton(problem, more.w, g, solver, newton_options, stats)


def snap_from_fold(sheet: SheetLoadProblem, phase: LoadPhase, name: str, fold, *,
                   newton_options: NewtonOptions, step_options: StepOptions,
                   negative_eigenvalues=(None, None)):
    """The snap at a located fold: leave it along its null vector, downhill
    in energy, and settle at the fold load onto the stable state there.

    The fold state is moved by the nominal corrector distance along the null
    vector ``v`` to the side where the energy ``a s^3 / 6`` falls
    (``s = -sign(a)``, ``a = v . D^2 R[v, v]``), settled by pseudo-transient
    continuation (:func:`~skfem_sheet.newton.pseudo_transient`), solved by
    Newton to ``newton_options`` and verified stable.

    Returns
    -------
    (Fold or None, str)
        The fold with its snap record and the landed state, or None and why
        the snap failed.
    """
    problem, solver, stats = sheet.problem, sheet.solver, sheet.stats
    scale = max(1.0, problem.sheet.length)  # displacements grow with the length
    eps = step_options.corrector_distance * scale
    kappa, g = phase.loads(fold.p)
    v = np.asarray(fold.v, dtype=float)
    vu = np.abs(v[sheet.free < sheet.nu_dof])
    v = v / float(vu.max())
    if fold.a != 0:
        sign = -float(np.sign(fold.a))
    else:  # a cusp-like fold: the lower energy side
        trial = [sheet.energy(fold.u + s * eps * v, (kappa, g))
                 for s in (1.0, -1.0)]
        sign = 1.0 if trial[0] <= trial[1] else -1.0
    w_fold = sheet.full(fold.u, (kappa, g))
    n_pt = 0
    for side in (sign, -sign):
        # the other side only where the settle came back to the fold itself
        # (the sign of a, of a fold nearly flat in the load, pointed back onto
        # the branch the fold ends)
        w0 = sheet.full(fold.u + side * eps * v, (kappa, g))
        pt, res = settle(problem, w0, g, solver, newton_options, step_options, stats)
        n_pt += pt.iterations
        if not pt.converged:
            return None, f"the snap from the fold did not settle: {pt.reason}", n_pt
        if not res.converged:
            return None, f"the landed state did not converge: {res.reason}", n_pt
        if not landed_on_its_fold(res.w, w_fold, problem.nu_dof, newton_options.utol):
            break
    else:
        return None, "the snap from the fold settled back on the fold on both sides", n_pt
    stable, k = end_state_verdict(problem, solver, res.w, stats)
    if stable is False:
        return None, (f"the snap landed on an unstable state ({k} negative eigenvalue(s))"), \
            n_pt
    snap = Snap(name, float(fold.value), kappa, g, tip_deflection(problem, w_fold),
                tip_deflection(problem, res.w), tuple(negative_eigenvalues),
                float(problem.sheet_mesh.hmax))
    return Fold(snap, w_fold, v, res.w), "", n_pt


def _same_fold(snap, phase_name, load, ptol) -> bool:
    """Whether the fold at ``load`` of the phase ``phase_name`` is the one of
    ``snap`` (the load within the two locations' tolerance ``ptol`` each)."""
    return snap.phase == phase_name and abs(load - snap.load) <= 2.0 * ptol * max(1.0, abs(load))


def landed_on_its_fold(landing, w_fold, nu_dof: int, utol: float) -> bool:
    """Whether a snap's landing is its own fold state: the largest
    displacement between them at most twice the tolerance ``utol`` the
    landing was solved to.  At the fold load the only equilibrium near the
    fold state is the fold itself, a degenerate root, to which Newton
    converges linearly with contraction 1/2 (its error then is up to its last
    correction): a landing that close did not leave the fold, and is no
    snap (the state did not move)."""
    return float(np.abs(landing[:nu_dof] - w_fold[:nu_dof]).max()) <= 2.0 * utol


def follow_path(problem, path: str, kappa: float, solver, *,
                newton_options: NewtonOptions = NewtonOptions(),
                step_options: StepOptions = StepOptions(),
                stats: Stats | None = None, w0=None, progress=None,
                on_step=None, resume: tuple | None = None,
                gravity: float = 1.0) -> PathOutcome:
    """Run a load path from the reference state (or ``w0``) to full load.

    Parameters
    ----------
    problem : SheetProblem
    path : {"curvature-first", "gravity-first"}
    kappa : float
        Target clamp curvature a/R.
    solver : linear-solver back-end
    newton_options : NewtonOptions
        The tolerances of the end state (and of the folds and snaps).
    step_options : StepOptions
        The load steps.
    stats : ~skfem_sheet.newton.Stats, optional
        Counts the work (updated in place).
    w0 : ndarray or None
        Start state (default: the reference state, zero).
    progress : callable(fraction_of_path) or None
    on_step : callable(problem, w, kappa, g) or None
        Called after each accepted point with its state and load.
    resume : (phase, lam) or None
        Resume the path part-way: ``w0`` is an equilibrium at the load
        fraction ``lam`` of the phase named ``phase`` (``"curvature"`` or
        ``"gravity"``, see :func:`load_phases`); the earlier phases are
        skipped and ``steps``/``snaps`` hold only what follows.
    gravity : float
        Full gravity factor (1: the sheet's own weight; 0: no gravity).

    Returns
    -------
    PathOutcome
        ``converged`` tells whether full load was reached on an equilibrium
        that is stable or whose stability the linear solver cannot tell
        (``stable``, ``negative_eigenvalues``); otherwise ``reason``,
        ``kappa`` and ``g`` say how far it got and why it stopped.
        ``snaps`` (and ``folds``, with the states) hold one entry per
        located fold the sheet snapped from, in order.
    """
    stats = stats if stats is not None else Stats()
    phases = load_phases(path, kappa, gravity)
    names = [name for name, _, _ in phases]
    w = np.zeros(problem.ndof) if w0 is None else np.array(w0, dtype=float)
    out = PathOutcome(w=w)
    first, lam0 = 0, 0.0
    if resume is not None:
        if w0 is None:
            raise ParameterError("resume needs w0, the state at the resumed load")
        if not (isinstance(resume, tuple) and len(resume) == 2 and resume[0] in names):
            raise ParameterError(f"resume must be (phase, lam) with phase one of "
                                 f"{', '.join(names)}, got {resume!r}")
        first = names.index(resume[0])
        lam0 = check_range("resume lam", float(resume[1]), 0, 1)
        start, end = phases[first][1:]
        out.kappa, out.g = (float(a + lam0 * (b - a)) for a, b in zip(start, end))
    sheet = SheetLoadProblem(problem, solver, stats, newton_options)
    tight = newton_tolerances(newton_options)
    scale = max(1.0, problem.sheet.length)  # displacements grow with the length
    loose = newton_tolerances(newton_options, step_options.intermediate_utol(scale))
    held = None  # the factorisation at w, if the solver holds one
    last_fact = None
    for iphase, (name, start, end) in enumerate(phases):
        if iphase < first:
            continue
        lam = lam0 if iphase == first else 0.0
        last_phase = iphase == len(phases) - 1
        phase = LoadPhase(sheet, start, end)
        counter = Counting(phase)
        if (name == "gravity" and start[0] == 0.0 and step_options.elastica_start
                and not np.any(w)):
            # flat sheet from the reference state: at full load from the elastica
            res = _elastica_jump(problem, solver, stats,
                                 newton_options if last_phase else
                                 replace(newton_options, rtol=1.0,
                                         utol=step_options.intermediate_utol(scale)), end[1])
            if res is not None and res.converged:
                w, lam = res.w, 1.0
                out.w, (out.kappa, out.g) = w, end
                out.steps.append((name, lam, res.iterations))
                out.distances.append(float("nan"))
                held = last_fact = sheet.held(w[problem.free], end)
                if on_step is not None:
                    on_step(problem, w, *end)
            elif res is not None:
                out.rejected_steps += 1

        def accepted(point, res, name=name, phase=phase, iphase=iphase):
            nonlocal last_fact
            loads = phase.loads(point.p)
            out.steps.append((name, float(point.p[0]), int(point.iterations)))
            out.distances.append(float(point.distance))
            out.kappa, out.g = loads
            last_fact = res.factorization
            if on_step is not None:
                on_step(problem, sheet.full(point.u, loads), *loads)
            if progress is not None:
                progress((iphase + float(point.p[0])) / len(phases))

        while lam < 1.0:
            u = w[problem.free]
            before = counter.stats()
            branch = ramp(counter, u, [lam], "lam", 1.0, rule=step_options.rule(scale), tol=loose,
                          end_tol=tight if last_phase else loose,
                          start=None if held is None else (u, held), on_step=accepted,
                          fold_tol=step_options.fold_tolerance)
            held = None
            stats.newton_iterations += (counter.stats() - before).newton_iterations
            out.rejected_steps += branch.rejected
            if branch.points:
                end_point = branch.points[-1]
                lam = float(end_point.p[0])
                w = sheet.full(end_point.u, phase.loads(end_point.p))
                out.w = w
                out.kappa, out.g = phase.loads(end_point.p)
            if branch.completed:
                lam = 1.0
                # the next phase starts where this one ended, with its tangent
                # from the Hessian there (not a MIP matrix)
                held = last_fact if getattr(last_fact, "exact", False) else None
                break
            fold = branch.fold
            if fold is None:
                out.reason = (f"{name} phase stopped at {lam:.4g} of its range "
                              f"(kappa={out.kappa:.4g}, g={out.g:.4g}): {branch.reason}")
                return out
            if any(_same_fold(s, name, fold.value, step_options.fold_tolerance)
                   for s in out.snaps):
                # a snap must leave its fold for good: a path led back to it
                # would snap from it again and again
                out.reason = (f"{name} phase, fold at {fold.value:.6g} of its range: the "
                              f"branch the snap from it landed on leads back to it")
                return out
            f0 = stats.factorizations
            found, why, n_pt = snap_from_fold(sheet, phase, name, fold,
                                              newton_options=newton_options,
                                              step_options=step_options,
                                              negative_eigenvalues=fold.crossing or (None, None))
            log.debug("snap: %d factorisations, %d pseudo-transient steps",
                      stats.factorizations - f0, n_pt)
            out.snap_iterations += n_pt
            if found is None:
                out.reason = (f"{name} phase, fold at {fold.value:.6g} of its range: {why}")
                return out
            found = replace(found, before=w, before_load=lam)
            out.snaps.append(found.snap)
            out.folds.append(found)
            w, lam = found.landing, float(fold.value)
            out.w, out.kappa, out.g = w, found.snap.curvature, found.snap.gravity
            held = last_fact = sheet.held(w[problem.free], phase.loads([lam]))
            out.steps.append((name, lam, 0))
            out.distances.append(float("nan"))
            if on_step is not None:
                on_step(problem, w, out.kappa, out.g)
    if not phases:
        out.kappa, out.g = 0.0, 0.0
    # the end state must be a stable equilibrium (or say that it is not known),
    # read from the Hessian at it
    if last_fact is None or not getattr(last_fact, "exact", False) \
            or getattr(last_fact, "generation", -1) != sheet.generation:
        K = timed(stats, "assembly_s", problem.tangent, w)
        try:
            timed(stats, "linear_solve_s", solver.factorize, K, w)
            stats.factorizations += 1
        except LinearSolverError as err:
            out.reason = f"singular tangent at the end state ({err})"
            return out
    stable, k = end_state_verdict(problem, solver, w, stats)
    out.stable, out.negative_eigenvalues = stable, k
    if stable is False:
        out.reason = (f"ended on an unstable equilibrium ({k} negative eigenvalue(s) of the "
                      f"constrained Hessian) at kappa={out.kappa:.4g}, g={out.g:.4g}: the "
                      f"path crossed no turning point it could locate")
        return out
    out.converged = True
    return out


def elastica_state(problem, g):
    """Initial guess at gravity ``g`` and a flat clamp from the heavy elastica.

    The mid-surface follows the elastica's centre line ``r(s)`` (with the
    sheet's width profile), material normals stay normal and unstretched:
    ``x(X, Y, Z) = r(X) + Y e_y + Z n(X)``.  The 3D solution differs from it
    only by the anticlastic boundary layers and the clamp's Saint-Venant
    region, so Newton converges from it in a few iterations where plain load
    stepping from the flat state needs many small steps.
    Returns ``None`` if the elastica cannot be solved.
    """
    # deferred: importing skfem_sheet.reduced costs ~0.2 s and only this guess needs it
    from .reduced.elastica import elastica

    sheet = problem.sheet
    e = elastica(sheet.replace(modulus=sheet.modulus / g, curvature=0.0))
    if not e.converged or not np.all(np.isfinite(e.phi)):
        return None
    s, phi = e.s, e.phi
    ds = np.diff(s)
    rx = np.concatenate([[0.0], np.cumsum(0.5 * ds * (np.cos(phi[1:]) + np.cos(phi[:-1])))])
    rz = np.concatenate([[0.0], np.cumsum(0.5 * ds * (np.sin(phi[1:]) + np.sin(phi[:-1])))])
    X = problem.nodes
    ph = np.interp(X[:, 0], s, phi)
    U = np.stack([np.interp(X[:, 0], s, rx) - X[:, 2] * np.sin(ph) - X[:, 0],
                  np.zeros(len(X)),
                  np.interp(X[:, 0], s, rz) + X[:, 2] * (np.cos(ph) - 1.0)], axis=1)
    w = np.zeros(problem.ndof)
    w[: problem.nu_dof] = U.ravel()
    return w


def _cylinder_displacement(y, z, kappa):
    """Displacement of the isochoric cylinder of :func:`cylinder_state` at
    reference points ``(x, y, z)`` (independent of ``x``), shape ``y.shape + (3,)``."""
    y = np.asarray(y, dtype=float)
    z = np.asarray(z, dtype=float)
    s = np.sqrt(1.0 - 2.0 * kappa * z)  # rho / R
    theta = kappa * y
    U = np.zeros(y.shape + (3,))
    U[..., 1] = s * y * np.sinc(theta / np.pi) - y
    U[..., 2] = (y * np.sin(0.5 * theta) * np.sinc(theta / (2 * np.pi))
                 + 2.0 * z * np.cos(theta) / (1.0 + s) - z)
    return U


def cylinder_state(problem, kappa, pressure="zero"):
    """The sheet bent into the clamp's cylinder: a candidate initial state at
    zero gravity and full clamp curvature ``kappa``.

    Every cross-section ``x = X`` is mapped like the clamp's section
    (:func:`~skfem_sheet.kernels.clamp_displacement`): the mid-plane onto the
    arc of radius ``R = 1/kappa`` through the origin, the thickness direction
    along the arc's normal; but the radius of the fibre at ``Z`` is
    ``rho = R sqrt(1 - 2 kappa Z)`` (``rho drho = -R dZ``), so the map is
    isochoric (``J = 1``) where the clamp's ``rho = R - Z`` has
    ``J = 1 - kappa Z``.  The two differ by ``kappa Z^2 / 2`` (6e-4 at
    ``a/R = 5``, ``h = 0.03``); the clamped dofs are set to the clamp values
    exactly.  Written in a form exact as ``kappa -> 0`` (the reference state)::

        U_y = s Y sinc(kappa Y / pi) - Y,
        U_z = Y sin(kappa Y / 2) sinc(kappa Y / 2 pi) + 2 Z cos(kappa Y) / (1 + s) - Z,

    with ``s = sqrt(1 - 2 kappa Z)``, ``U_x = 0``.

    Parameters
    ----------
    problem : SheetProblem
    kappa : float
        Clamp curvature a/R (``kappa h < 1``).
    pressure : {"zero", "plate"}
        ``"zero"``: the reference pressure; ``"plate"``: the pressure that
        frees the cylinder's faces (``sigma_rr = 0``: ``p = mu (R^2/rho^2 - 1)``).

    Returns
    -------
    ndarray
        The dof vector.

    Notes
    -----
    As a start of Newton at zero gravity it does not pay, so the load paths do
    not use it: the sheet is no cylinder (away from the clamp the transverse
    curvature relaxes and the centre line lifts); the record:
    ``benchmarks/results/speed/solve_cylinder_start_hmax0.1.txt``.
    """
    if pressure not in ("zero", "plate"):
        raise ParameterError(f"pressure must be 'zero' or 'plate', got {pressure!r}")
    h = problem.sheet.thickness
    kappa = check_range("kappa", kappa, 0, 1.0 / h, hi_open=True,
                        hint="the inner fibre's radius R - h/2 must stay positive")
    X = problem.nodes
    U = _cylinder_displacement(X[:, 1], X[:, 2], kappa)
    p = np.zeros(problem.n_vertices)
    if pressure == "plate":
        Z = X[: problem.n_vertices, 2]
        p = problem.mu * (1.0 / (1.0 - 2.0 * kappa * Z) - 1.0)
    w = problem.space.join(U, p)
    w[problem.clamp_dofs] = problem.clamp_values(kappa)
    return w



def end_state_verdict(problem, solver, w, stats):
    """Stability of the equilibrium ``w``: ``(stable, k)``, the one end-state
    check of the load paths and of :func:`skfem_sheet.solve.solve`'s finish.

    Read from the last factorised tangent; where that inertia cannot be
    trusted (unknown, or not positive definite without a negative eigenvalue)
    once more from the tangent at ``w``, and then from a SuperLU factorisation
    of it (exact inertia with diagonal pivoting; up to ``_SUPERLU_CHECK_DOFS``
    unknowns).

    Parameters
    ----------
    problem : SheetProblem
    solver : linear-solver back-end
        Holds the last factorised tangent; left factorised at ``w`` if a
        re-check was needed.
    w : ndarray
        The equilibrium.
    stats : ~skfem_sheet.newton.Stats
        Counts the factorisations of the re-checks.

    Returns
    -------
    (stable, k) : (bool or None, int or None)
        ``stable`` None if no factorisation can tell; ``k`` the number of
        negative eigenvalues of the constrained Hessian.
    """
    verdict = stability(problem, solver)
    if verdict[0] is not None and not (verdict[0] is False and not verdict[1]):
        return verdict
    K = timed(stats, "assembly_s", problem.tangent, w)
    try:
        timed(stats, "linear_solve_s", solver.factorize, K, w)
    except LinearSolverError:
        return None, None
    stats.factorizations += 1
    verdict = stability(problem, solver)
    if (verdict[0] is None and getattr(solver, "name", "") != "superlu"
            and K.shape[0] <= _SUPERLU_CHECK_DOFS):
        check = make_linear_solver("superlu")
        try:
            timed(stats, "linear_solve_s", check.factorize, K, w)
        except LinearSolverError:
            return None, None
        stats.factorizations += 1
        verdict = stability(problem, check)
    return verdict

