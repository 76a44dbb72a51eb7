"""Load paths: adaptive load stepping in curvature and gravity (branch selection).

In the bistable region the equilibrium reached depends on the load path
(paper, "Finite-element simulations" and SI "Numerical Method"):

``"curvature-first"``
    ramp the clamp curvature at zero gravity, then gravity to 1: selects the
    curvature-dominated (aloft) shape;
``"gravity-first"``
    ramp gravity at zero curvature, then the curvature: selects the
    gravity-dominated (drooped) shape.

Each phase runs a load parameter ``lam`` from 0 to 1 with adaptive steps, by
the engine's natural-continuation driver (:func:`~skfem_sheet.engine.loadpath.ramp`):
every step is warm-started by a tangent predictor (one extra back-substitution
with the last factorisation) and corrected by Newton (the engine's corrector,
through :func:`~skfem_sheet.newton.newton`); steps grow after easy corrections
and are halved after failures.  This module says what a step of a sheet is;
the loops are the engine's.

End states are verified: after a snap-through and at full load the inertia of
the tangent is read (:func:`~skfem_sheet.analyses.stability.stability`); an
unstable equilibrium is left along its unstable eigenvector by a
pseudo-transient settle (recorded as a snap), and a path that cannot leave it
fails with a message saying that it ended on an unstable equilibrium.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
import scipy.sparse.linalg as spla
from scipy.sparse.linalg import ArpackError, ArpackNoConvergence

from .analyses.stability import stability
from .engine.loadpath import Attempt, RampControl, ramp
from .linalg import LinearSolverError, make_linear_solver
from .newton import NewtonOptions, Stats, newton, pseudo_transient, timed
from .params import ParameterError, check_range

__all__ = ["PATHS", "StepOptions", "PathOutcome", "load_phases", "follow_path",
           "end_state_verdict", "elastica_state", "cylinder_state"]

PATHS = ("curvature-first", "gravity-first")

#: Largest tangent whose inertia is checked with SuperLU when the solver cannot tell.
_SUPERLU_CHECK_DOFS = 100_000


@dataclass(frozen=True)
class StepOptions:
    """Adaptive load-step control.

    Attributes
    ----------
    initial_step : float
        First step, as a fraction of each phase.
    min_step : float
        Below this the path is declared failed.
    max_step : float
        Largest step fraction.
    grow : float
        Step growth factor after an easy step (``<= easy_iterations``).
    easy_iterations : int
        Number of Newton iterations considered easy (the step then grows).
    predictor : {"tangent", "hermite"}
        Tangent predictor, or tangent plus the quadratic term through the
        previous converged state.
    elastica_start : bool
        Start the gravity ramp of a flat clamp at full load from the heavy
        elastica (see :func:`elastica_state`) instead of stepping from zero.
    intermediate_utol : float
        Newton tolerance on the displacement correction at intermediate load
        steps (units of a); only the final load is solved to the full
        tolerance of ``NewtonOptions``.  Intermediate states only need to be
        close enough to the branch to start the next step.
    max_correction : float
        A step whose first Newton correction moves a node further than this
        (units of a, times the sheet length when it is longer than 1) is
        rejected and cut: it guards against silently jumping to another branch.
    snap_step : float
        When the steps of the second phase have been cut below this, the branch
        is taken to end there (a fold): the step is solved by pseudo-transient
        continuation, which lets the sheet snap to the other branch, and the
        snap-through is recorded in ``PathOutcome.snaps``.
    snap_radius : float
        Largest displacement of one pseudo-transient step (units of a, times
        the sheet length when it is longer than 1).
    snap_iterations : int
        Largest number of pseudo-transient steps of one snap (the snap is
        then retried from a smaller load step, or the path fails).
    verify : bool
        Read the inertia after every snap and at full load, and leave an
        unstable equilibrium (see :func:`follow_path`).
    max_escapes : int
        Attempts to leave an unstable equilibrium at one load before the path
        fails.
    jump_ratio : float
        Guard on the whole move of a converged (non-snapping) load step: the
        corrector's move ``|w_new - w_pred|_inf`` (displacements) may not
        exceed ``max(jump_ratio * |w_pred - w|_inf, jump_floor * max(1, L))``.
        On a smooth branch the correction is second order in the step and the
        prediction first order; a step whose Newton converged onto another
        branch (across a fold) moves O(1) whatever the step.  Such a step is
        rejected, so that the ramp cuts it until the fold is settled and
        recorded as a snap.  A huge value (say 1e9) switches the guard off.
        1.0: on smooth branches the corrector moved 0.03-0.8 of the
        prediction (a step of 0.25 from a strongly bent state, or a
        prediction with the MIP factorisation the previous step left
        behind); the silent crossing of L 1.4739, a/R 4.8448 gravity-first at
        hmax 0.1 moved 1.2-6.2 times the prediction in each of its steps.
    jump_floor : float
        The guard's floor (units of a, times the sheet length when it is
        longer than 1): corrections below it are always accepted, so that a
        smooth branch cannot be rejected forever as the steps shrink (its
        correction falls as the square of the step).  0.05: half the move
        that :func:`follow_path` calls a snap.
    max_move : float
        The second half of the guard: a converged non-snapping step that moves
        a node further than this (units of a, times the sheet length when it
        is longer than 1) is rejected and cut.  Near a fold the tangent is
        nearly singular and the predictor itself points far along the snap
        mode, so a Newton that converges there has snapped without the
        corrector moving much more than predicted; cut below ``snap_step``,
        the step is settled and the snap recorded (a move of more than
        ``0.1 max(1, L)`` inside a load step below ``snap_step`` is what
        :func:`follow_path` calls a snap).  0.15: with 0.25 the MIP Newton
        still crossed three folds that exact Newton recorded in the stress
        benchmark at hmax 0.1 (whole moves of 0.19-0.22 max(1, L) in one
        step; ``benchmarks/results/stress_n100_seed1_hmax0.1_guard.txt``).  Not in
        the first phase of a path, which has no fold (gravity on a flat
        clamp, or curvature without gravity) and no snapping: there a steep
        branch would only cost steps.
    """

    initial_step: float = 0.25
    min_step: float = 1e-3
    max_step: float = 1.0
    grow: float = 2.0
    easy_iterations: int = 2
    max_correction: float = 0.25
    snap_step: float = 0.02
    intermediate_utol: float = 1e-3
    predictor: str = "tangent"
    elastica_start: bool = True
    snap_radius: float = 0.1
    snap_iterations: int = 80
    verify: bool = True
    max_escapes: int = 2
    jump_ratio: float = 1.0
    jump_floor: float = 0.05
    max_move: float = 0.15

    def __post_init__(self):
        check_range("initial_step", self.initial_step, 0, 1, lo_open=True)
        check_range("min_step", self.min_step, 0, self.initial_step, lo_open=True)
        check_range("max_step", self.max_step, self.initial_step, 1)
        check_range("grow", self.grow, 1, 10)
        check_range("max_correction", self.max_correction, 0, None, lo_open=True)
        check_range("snap_radius", self.snap_radius, 0, None, lo_open=True)
        check_range("snap_iterations", self.snap_iterations, 1, 1000)
        check_range("max_escapes", self.max_escapes, 0, 10)
        check_range("jump_ratio", self.jump_ratio, 0, None, lo_open=True)
        check_range("jump_floor", self.jump_floor, 0, None, lo_open=True)
        check_range("max_move", self.max_move, 0, None, lo_open=True)
        if self.predictor not in ("tangent", "hermite"):
            raise ParameterError(f"predictor must be 'tangent' or 'hermite', got {self.predictor!r}")


@dataclass
class PathOutcome:
    """What happened along a path (mutable while the path runs)."""

    w: np.ndarray
    converged: bool = False
    reason: str = ""
    kappa: float = 0.0
    g: float = 0.0
    steps: list = field(default_factory=list)  # (phase, lam, iterations) per accepted step
    rejected_steps: int = 0
    rejections: list = field(default_factory=list)  # (phase, lam tried, reason, iterations)
    snaps: list = field(default_factory=list)  # (phase, lam, kappa, g) where the branch was lost
    stable: object = None  # inertia verdict at the end state (None: not known)
    negative_eigenvalues: object = None
    snap_iterations: int = 0  # Newton-type iterations spent in pseudo-transient settles
    # (phase, lam tried, predicted move, corrector move, whole move, accepted) of every converged
    # non-snapping step: the data of the jump guard (StepOptions.jump_ratio)
    moves: list = field(default_factory=list)


def load_phases(path: str, kappa: float, gravity: float = 1.0):
    """The phases of a load path as ``(name, load(lam) -> (kappa, g))`` pairs.

    ``gravity`` is the full gravity factor (1: the sheet's own weight); a
    phase whose load is zero is left out (no phase at all for ``kappa = 0``
    and ``gravity = 0``: the reference state is the answer).
    """
    if path not in PATHS:
        raise ParameterError(f"path must be one of {', '.join(PATHS)}, got {path!r}")
    if path == "curvature-first":
        phases = [("curvature", lambda lam: (lam * kappa, 0.0)),
                  ("gravity", lambda lam: (kappa, lam * gravity))]
    else:
        phases = [("gravity", lambda lam: (0.0, lam * gravity)),
                  ("curvature", lambda lam: (lam * kappa, gravity))]
    if kappa == 0.0:
        phases = [p for p in phases if p[0] == "gravity"]
    if gravity == 0.0:
        phases = [p for p in phases if p[0] == "curvature"]
    return phases


def _load_rate(load, lam, eps=1e-6):
    """d(kappa, g)/dlam by a difference (the loads are linear in lam)."""
    k0, g0 = load(lam)
    k1, g1 = load(lam + eps)
    return (k1 - k0) / eps, (g1 - g0) / eps


def _tangent_predictor(problem, w, dkappa, dg, kappa, solver, stats):
    """dw/dlam from ``K_ff dw_f = -(dg f_g)_f - K_fd dw_d`` with the last factorisation."""
    free, clamp = problem.free, problem.clamp_dofs
    dw = np.zeros(problem.ndof)
    if dkappa:
        dw[clamp] = dkappa * problem.clamp_rate(kappa)
    rhs = -dg * problem.gravity_load[free]
    if dkappa:
        rhs -= timed(stats, "assembly_s", problem.clamp_coupling, w) @ dw[clamp]
    dw[free] = timed(stats, "linear_solve_s", solver.solve, rhs)
    return dw


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
    Measured as the start of a Newton solve at zero gravity against the
    curvature ramp of ``curvature-first`` (``benchmarks/solve_speed_cylinder.py``,
    ``benchmarks/results/solve_cylinder_start_hmax0.1.txt``): it does not
    pay, so the load paths do not use it.  The sheet is no cylinder: away
    from the clamp the transverse curvature relaxes and the centre line lifts
    (by 0.3 a at the tip of L/a = 2, a/R = 4), and Newton from the cylinder
    diverges at a/R >~ 3 and needs 6-12 iterations below, where the ramp
    takes 8-24 factorisations in all.
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


def _predict(w, dw, lam, lam_new, prev):
    """Hermite predictor: the tangent ``dw`` at ``lam`` plus the quadratic term
    that makes the curve pass through the previous converged point ``prev``
    (tangent predictor alone on the first step of a phase)."""
    h = lam_new - lam
    if prev is None:
        return w + h * dw
    lam0, w0 = prev
    h0 = lam - lam0
    c = (w0 - w + h0 * dw) / h0**2
    return w + h * dw + h**2 * c


def _elastica_jump(problem, solver, stats, final, tight, loose, gravity=1.0):
    w = elastica_state(problem, gravity)
    if w is None:
        return None
    return newton(problem, w, gravity, solver, tight if final else loose, stats)


def _negatives(problem, solver):
    """Negative directions of the factorised matrix on the incompressible
    subspace, ``None`` if the back-end cannot tell (the pseudo-transient
    shift control)."""
    return stability(problem, solver)[1]


def end_state_verdict(problem, solver, w, stats):
    """Stability of the equilibrium ``w``: ``(stable, k)``, the one end-state
    check of the load paths and of :func:`skfem_sheet.solve.solve`'s
    coarse-to-fine finish.

    Read first from the last factorised tangent (Newton's last iterate but
    one, within the tolerance of ``w``).  If that inertia cannot be trusted
    (``stable`` unknown, e.g. perturbed pivots, or the back-end does not
    report it) or says "not positive definite" without a negative eigenvalue
    (``(False, 0)``: a zero pivot of a nearly singular tangent), once more
    from the tangent at ``w``, and if that still cannot tell, from a SuperLU
    factorisation of it (whose inertia is exact when it pivots on the
    diagonal; only up to ``_SUPERLU_CHECK_DOFS`` unknowns, its fill grows
    fast).

    Parameters
    ----------
    problem : SheetProblem
    solver : linear-solver back-end
        Holds the last factorised tangent; it is left factorised at ``w`` if
        a re-check was needed.
    w : ndarray
        The equilibrium.
    stats : Stats
        Counts the factorisations of the re-checks (and their time).

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


def _unstable_direction(problem, solver, k):
    """Displacement direction (on the free dofs, ``max |v_u| = 1``) of the most
    negative eigenvalue found of ``K v = lambda M v`` on the incompressible
    subspace, from a shift-invert Lanczos (ARPACK) with the factorised tangent
    ``K``: ``(K^{-1} M)`` has the eigenvalues ``1/lambda`` (and 0 for the
    pressure), so the largest ones in magnitude are the ``lambda`` nearest 0,
    which near a lost fold or a saddle include the negative ones.
    ``None`` if none of the ``k + 3`` nearest is negative."""
    free = problem.free
    n = len(free)
    M = problem.assembler.matrix(problem.mass_data)
    op = spla.LinearOperator((n, n), matvec=lambda x: solver.solve(M @ x), dtype=float)
    v0 = solver.solve(M @ np.ones(n))  # deterministic start in the right space
    nev = int(min(max(k, 1) + 3, n - 2))
    try:
        mu, vecs = spla.eigs(op, k=nev, which="LM", v0=v0, tol=1e-8, maxiter=50 * n)
    except (ArpackError, ArpackNoConvergence):
        return None
    lam = np.full(nev, np.inf)
    good = np.abs(mu) > 0
    lam[good] = 1.0 / mu[good].real
    i = int(np.argmin(lam))
    if not lam[i] < 0:
        return None
    v = vecs[:, i].real
    nu_free = free < problem.nu_dof
    j = int(np.argmax(np.abs(v[nu_free])))
    v = v / v[nu_free][j]  # fixed scale and sign
    return v


def _settle(problem, w, g, solver, stats, opts, loose, step_options, scale):
    """Pseudo-transient settle at gravity ``g`` from ``w`` (a loose stopping
    rule: a certified plain Newton step below ``intermediate_utol``), then
    Newton to ``opts``, the tolerance that defines the end state.  Returns the
    Newton result (its ``iterations`` are those of that final Newton solve)
    and the number of pseudo-transient steps."""
    pt = pseudo_transient(problem, w, g, solver, loose, stats,
                          max_iterations=step_options.snap_iterations,
                          radius=step_options.snap_radius * scale, negatives=_negatives)
    if not pt.converged:
        return pt, pt.iterations
    return newton(problem, pt.w, g, solver, opts, stats), pt.iterations


def _escape(problem, w, g, solver, stats, opts, loose, step_options, scale, k):
    """Leave the unstable equilibrium ``w`` (the solver holds its tangent):
    a step of ``0.05 scale`` along the unstable eigenvector (the side of lower
    energy), then :func:`_settle`.  ``None`` if no unstable direction is found."""
    v = _unstable_direction(problem, solver, k)
    if v is None:
        return None, 0
    free = problem.free
    trial = []
    for sign in (1.0, -1.0):
        wt = w.copy()
        wt[free] += sign * 0.05 * scale * v
        trial.append((problem.energy(wt, g), wt))
    wt = trial[1][1] if trial[1][0] < trial[0][0] else trial[0][1]
    return _settle(problem, wt, g, solver, stats, opts, loose, step_options, scale)


def _make_stable(problem, w, kappa, g, solver, stats, opts, loose, step_options, scale):
    """Verify the equilibrium ``w`` at ``(kappa, g)`` and leave it while it is
    unstable.  Returns ``(w, stable, k, escaped, iterations, message)``:
    ``escaped`` tells whether ``w`` changed, ``message`` is empty unless the
    end state is still unstable."""
    stable, k = end_state_verdict(problem, solver, w, stats)
    escaped, iterations = False, 0
    for _ in range(step_options.max_escapes):
        if stable is not False or not k:
            break
        res, n_pt = _escape(problem, w, g, solver, stats, opts, loose, step_options, scale, k)
        iterations += n_pt
        if res is None or not res.converged:
            why = "no unstable direction found" if res is None else res.reason
            msg = (f"ended on an unstable equilibrium ({k} negative eigenvalue(s) of the "
                   f"constrained Hessian) at kappa={kappa:.4g}, g={g:.4g}; leaving it "
                   f"failed: {why}")
            return w, stable, k, escaped, iterations, msg
        w, escaped = res.w, True
        stable, k = end_state_verdict(problem, solver, w, stats)
    if stable is False and k:
        msg = (f"ended on an unstable equilibrium ({k} negative eigenvalue(s) of the "
               f"constrained Hessian) at kappa={kappa:.4g}, g={g:.4g} after "
               f"{step_options.max_escapes} attempt(s) to leave it")
        return w, stable, k, escaped, iterations, msg
    return w, stable, k, escaped, iterations, ""


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
    progress : callable(fraction_of_path) or None
    on_step : callable(problem, w, kappa, g) or None
        Called after each accepted step with its state and load.
    w0 : ndarray or None
        Start state (default: the reference state, zero).
    gravity : float
        Full gravity factor (1: the sheet's own weight; 0: no gravity).
    resume : (phase, lam) or None
        Resume the path part-way: ``w0`` is an equilibrium at the load
        fraction ``lam`` of the phase named ``phase`` (``"curvature"`` or
        ``"gravity"``, see :func:`load_phases`), e.g. a state of this path
        on another mesh, transferred; the earlier phases are skipped and
        ``steps``/``snaps`` hold only what follows.

    Returns
    -------
    PathOutcome
        ``converged`` tells whether full load was reached on an equilibrium
        that is stable or whose stability the linear solver cannot tell
        (``stable``, ``negative_eigenvalues``); otherwise ``reason``,
        ``kappa`` and ``g`` say how far it got and why it stopped.

    Notes
    -----
    Where the second phase's steps have been cut below
    ``StepOptions.snap_step`` the followed branch is taken to end at a fold:
    the next step is settled by :func:`~skfem_sheet.newton.pseudo_transient`
    (a loose, inertia-controlled settle) and a Newton solve, and a jump of
    more than ``0.1 max(1, L)`` is recorded in ``snaps``.  A Newton that
    converges across a fold inside an ordinary step would skip that record
    (and label the branch wrongly): the jump guard
    (``StepOptions.jump_ratio``, ``jump_floor``, ``max_move``) rejects a
    converged step whose corrector moved much further than its predictor,
    or (after the first phase) whose whole move is large, so that the ramp
    cuts it down to ``snap_step`` and settles it; ``PathOutcome.moves``
    holds the guard's data of every converged step.  With
    ``StepOptions.verify`` (default) the inertia is read after every such
    settle and at full load; an unstable equilibrium is perturbed along its
    unstable eigenvector and settled again (a snap at full load is recorded
    as ``(last phase, 1.0, kappa, g)``), and if that fails
    ``StepOptions.max_escapes`` times the path ends with ``converged=False``
    and a ``reason`` that says it ended on an unstable equilibrium.
    """
    stats = stats if stats is not None else Stats()
    phases = load_phases(path, kappa, gravity)
    w = np.zeros(problem.ndof) if w0 is None else np.array(w0, dtype=float)
    out = PathOutcome(w=w)
    first, lam0 = 0, 0.0
    if resume is not None:
        names = [name for name, _ in phases]
        if w0 is None:
            raise ParameterError("resume needs w0, the state at the resumed load")
        if not (isinstance(resume, tuple) and len(resume) == 2 and resume[0] in names):
            raise ParameterError(f"resume must be (phase, lam) with phase one of "
                                 f"{', '.join(names)}, got {resume!r}")
        first = names.index(resume[0])
        lam0 = check_range("resume lam", float(resume[1]), 0, 1)
        out.kappa, out.g = phases[first][1](lam0)
    have_factor = False
    scale = max(1.0, problem.sheet.length)  # displacements grow with the length
    loose = replace(newton_options, rtol=1.0, utol=step_options.intermediate_utol)
    for iphase, (name, load) in enumerate(phases):
        if iphase < first:
            continue
        lam = lam0 if iphase == first else 0.0
        prev = None  # (lam, w) of the previous converged step of this phase
        last_phase = iphase == len(phases) - 1
        if (name == "gravity" and load(0.0)[0] == 0.0 and step_options.elastica_start
                and not np.any(w)):
            # flat sheet from the reference state: start at full load from the elastica
            res = _elastica_jump(problem, solver, stats, last_phase, newton_options, loose,
                                 gravity)
            if res is not None and res.converged:
                w, lam = res.w, 1.0
                out.w, out.kappa, out.g = w, 0.0, gravity
                out.steps.append((name, lam, res.iterations))
                have_factor = True
                if on_step is not None:
                    on_step(problem, w, 0.0, gravity)
                if progress is not None:
                    progress((iphase + lam) / len(phases))
            elif res is not None:
                out.rejected_steps += 1
                out.rejections.append((name, 1.0, "elastica start: " + res.reason,
                                       res.iterations, res.corrections))

        def attempt(lam, lam_new, snapping, name=name, load=load, iphase=iphase,
                    last_phase=last_phase):
            """One load step from the accepted state ``w`` at ``lam``: the tangent
            predictor (one back-substitution with the last factorisation), then
            Newton (or, snapping, a pseudo-transient settle and Newton), then the
            verification of a snapped state."""
            nonlocal w, prev, have_factor

            def reject(res, why):
                """A rejected attempt, recorded; the next one refactorises."""
                nonlocal have_factor
                out.rejected_steps += 1
                out.rejections.append((name, lam_new, why, res.iterations, res.corrections))
                have_factor = False
                return Attempt(False, res.iterations, why)

            k_new, g_new = load(lam_new)
            k_old, _ = load(lam)
            if not have_factor:
                K = timed(stats, "assembly_s", problem.tangent, w)
                try:
                    timed(stats, "linear_solve_s", solver.factorize, K, w)
                except LinearSolverError as err:
                    return Attempt(False, 0, stop=f"singular tangent at the start of the "
                                   f"{name} phase ({err})")
                stats.factorizations += 1
                have_factor = True
            dk, dg = _load_rate(load, lam)
            dw = _tangent_predictor(problem, w, dk, dg, k_old, solver, stats)
            w_pred = _predict(w, dw, lam, lam_new,
                              prev if step_options.predictor == "hermite" else None)
            w_pred[problem.clamp_dofs] = problem.clamp_values(k_new)
            # the branch guard matters once the sheet can be on either branch;
            # it is lifted when the steps have shrunk to a fold (snap-through)
            guard = scale * step_options.max_correction if iphase > 0 and not snapping else np.inf
            final = last_phase and lam_new == 1.0
            opts = newton_options if final else loose
            if snapping:
                # settle loosely, then Newton to this step's tolerance (which
                # also sets up the factorisation at the new state for the
                # next predictor)
                res, n_pt = _settle(problem, w_pred, g_new, solver, stats, opts, loose,
                                    step_options, scale)
                out.snap_iterations += n_pt
            else:
                # an intermediate step may leave its MIP factorisation for the
                # next predictor; the final step's solver must hold the
                # Hessian for the verdict
                res = newton(problem, w_pred, g_new, solver, opts, stats,
                             max_first_increment=guard, exact_on_return=final)
            if not res.converged:
                return reject(res, res.reason)  # its factorisation is useless
            w_new = res.w
            nu = problem.nu_dof
            if not snapping:
                # the guard on the whole move: a corrector that moves much further
                # than the predictor has converged onto another branch
                predicted = float(np.abs(w_pred[:nu] - w[:nu]).max())
                corrected = float(np.abs(w_new[:nu] - w_pred[:nu]).max())
                moved = float(np.abs(w_new[:nu] - w[:nu]).max())
                limit = max(step_options.jump_ratio * predicted,
                            step_options.jump_floor * scale)
                why = ""
                if corrected > limit:
                    why = (f"the corrector moved {corrected:.3g} against a predicted "
                           f"{predicted:.3g} (limit {limit:.3g}): a jump of branch "
                           f"inside the step")
                elif iphase > 0 and moved > step_options.max_move * scale:
                    why = (f"the step moved {moved:.3g} (more than "
                           f"{step_options.max_move * scale:.3g}): a jump of branch "
                           f"inside the step unless it is settled as a snap")
                out.moves.append((name, lam_new, predicted, corrected, moved, not why))
                if why:
                    return reject(res, why)  # factorised on the other branch
            if snapping:
                if step_options.verify:
                    # the settle is drawn to stable states, but check
                    w_new, _, _, _, n_e, msg = _make_stable(
                        problem, w_new, k_new, g_new, solver, stats, opts, loose,
                        step_options, scale)
                    out.snap_iterations += n_e
                    if msg:
                        return Attempt(True, res.iterations, stop=f"{name} phase, snap at "
                                       f"{lam_new:.4g} of its range: {msg}")
                # a snap only if the sheet really left its branch; the
                # damped iteration may also settle just short of the fold
                # (a load step below snap_step moves nodes by a few 1e-2 at most)
                if np.abs(w_new[:nu] - w[:nu]).max() > 0.1 * scale:
                    out.snaps.append((name, lam_new, k_new, g_new))
            prev = (lam, w)
            w = w_new
            out.w, out.kappa, out.g = w, k_new, g_new
            out.steps.append((name, lam_new, res.iterations))
            if on_step is not None:
                on_step(problem, w, k_new, g_new)
            # Newton leaves the factorisation of its last tangent behind
            if progress is not None:
                progress((iphase + lam_new) / len(phases))
            return Attempt(True, res.iterations)

        if lam < 1.0:
            control = RampControl(step_options.initial_step, step_options.min_step,
                                  step_options.max_step, step_options.grow,
                                  step_options.easy_iterations,
                                  step_options.snap_step if iphase > 0 else None)
            done = ramp(lam, control, attempt)
            if done.reason == "step below min_step":
                out.reason = (f"{name} phase stopped at {done.lam:.4g} of its range "
                              f"(kappa={out.kappa:.4g}, g={out.g:.4g}): step below "
                              f"{step_options.min_step:g}; last Newton failure: "
                              f"{done.last_failure}")
                return out
            if not done.converged:
                out.reason = done.reason
                return out
    if step_options.verify:
        # the end state must be a stable equilibrium (or say that it is not known)
        w_end, stable, k, escaped, n_e, msg = _make_stable(
            problem, w, out.kappa, out.g, solver, stats, newton_options, loose,
            step_options, scale)
        out.snap_iterations += n_e
        out.stable, out.negative_eigenvalues = stable, k
        if escaped:
            out.snaps.append((phases[-1][0], 1.0, out.kappa, out.g))
            out.w = w_end
        if msg:
            out.reason = msg
            return out
    else:
        out.stable, out.negative_eigenvalues = stability(problem, solver)
    out.converged = True
    return out
