"""The force-controlled solve (:func:`apply_tip_force`): the tip force ramped
on a solved sheet, the snaps at its folds (:class:`TipForceRamp`).
"""
from __future__ import annotations

from dataclasses import dataclass, field

from ..analyses.observables import tip_deflection
from ..continuation import StepOptions, end_state_verdict, newton_tolerances, snap_from_fold
from ..engine import StepRule, ramp
from ..engine.protocol import Counting
from ..linalg import LinearSolverError, make_linear_solver
from ..newton import NewtonOptions, Stats
from ..params import ParameterError, check_range
from ..result import Result
from ..sheet_engine import LoadPhase, SheetForceProblem, SheetLoadProblem
from .trace import FOLD_TOLERANCE


# -----------------------------------------------------------------------------
# the force-controlled solve
# -----------------------------------------------------------------------------
@dataclass(frozen=True)
class TipForceRamp:
    """A solved sheet under a tip force ramped from zero (:func:`apply_tip_force`).

    Attributes
    ----------
    force : float
        The tip force reached (``rho g a^3``).
    converged : bool
        The force was reached on a stable equilibrium.
    reason : str
    start_deflection, deflection : float
        d/a of the start state (F = 0) and of the end state (at ``force``).
    tip_displacement : float
        ``w_tip`` at the end.
    stable : bool or None
    negative_eigenvalues : int or None
    snaps : tuple of Snap
        One per fold met on the way (``phase`` ``"tip force"``, ``load`` the
        fold's F), the sheet landing on the stable state at that force.
    factorizations : int
        Every factorisation of the ramp, the snaps and the end state's verdict.
    problem : SheetProblem
        The sheet with the tip force ``force``.
    w : ndarray
        The end state.
    """

    force: float
    converged: bool
    reason: str
    start_deflection: float
    deflection: float
    tip_displacement: float
    stable: object
    negative_eigenvalues: object
    snaps: tuple = ()
    factorizations: int = 0
    problem: object = field(default=None, repr=False)
    w: object = field(default=None, repr=False)

    @property
    def snapped(self) -> bool:
        return bool(self.snaps)


def apply_tip_force(result: Result, force: float, *, solver: str = "auto",
                    newton_options: NewtonOptions | None = None,
                    step_options: StepOptions | None = None) -> TipForceRamp:
    """The force-controlled solve: ramp the tip force from 0 to ``force`` on
    the end state of a solve.

    The load paths' ramp (:func:`skfem_sheet.engine.ramp`) in F at full
    load; at a fold the sheet snaps as on a load path
    (:func:`~skfem_sheet.continuation.snap_from_fold`) and the ramp goes on.

    Parameters
    ----------
    result : Result
        A converged solve (its state at F = 0, its mesh).
    force : float
        The tip force (``rho g a^3``, positive upward).
    solver : str
    newton_options : NewtonOptions, optional
    step_options : StepOptions, optional
        The snap's settle (its corrector distance and intermediate tolerance).

    Returns
    -------
    TipForceRamp

    Examples
    --------
    >>> from skfem_sheet.params import Sheet
    >>> from skfem_sheet.solve import solve
    >>> r = solve(Sheet(length=0.6, curvature=1.0), hmax=0.25)
    >>> out = apply_tip_force(r, -0.002)
    >>> out.converged, out.snapped, out.deflection > r.deflection
    (True, False, True)
    """
    if not isinstance(result, Result) or not result.converged or result.problem is None:
        raise ParameterError("result must be a converged Result of skfem_sheet.solve")
    force = float(check_range("force", force, -1e6, 1e6))
    newton_options = newton_options or NewtonOptions()
    step_options = step_options or StepOptions()
    problem = result.problem.with_tip_force(0.0)
    _ = problem.tip_load  # a sheet without a tip face is refused here
    kappa, g = float(result.kappa), float(result.gravity)
    linear = make_linear_solver(solver)
    if getattr(linear, "needs_layout", False):
        linear.attach(problem.saddle_point_layout())
    stats = Stats()
    P = SheetForceProblem(problem, linear, kappa, g, stats)
    counter = Counting(P)
    size = max(1.0, problem.sheet.length)
    # steps in the sheet's arclength norm (displacements; F adds little):
    # a hundredth of the sheet's size to start, the corrector distance of
    # the load paths' points
    rule = StepRule(initial=0.01 * size, minimum=1e-5 * size, maximum=0.1 * size,
                    delta=0.2 * step_options.corrector_distance * size)
    tight = newton_tolerances(newton_options)
    loose = newton_tolerances(newton_options, 0.1 * rule.delta)
    u, F, snaps, reason = result.w[P.free], 0.0, [], ""
    held = None
    while True:
        b = ramp(counter, u, [F], 0, force, rule=rule, tol=loose, end_tol=tight,
                 start=held, fold_tol=FOLD_TOLERANCE)
        if b.points:
            u, F = b.points[-1].u, float(b.points[-1].p[0])
        if b.completed:
            break
        if b.fold is None:
            reason = f"the ramp stopped at F = {F:.6g}: {b.reason}"
            break
        fold = b.fold
        at = SheetLoadProblem(problem.with_tip_force(fold.value), linear, stats, newton_options)
        phase = LoadPhase(at, (kappa, g), (kappa, g))  # the loads held, F the fold's
        found, why, _ = snap_from_fold(at, phase, "tip force", fold,
                                       newton_options=newton_options, step_options=step_options,
                                       negative_eigenvalues=fold.crossing or (None, None))
        if found is None:
            reason = f"the snap at the fold F = {fold.value:.6g} failed: {why}"
            break
        snaps.append(found.snap)
        u, F = found.landing[P.free], float(fold.value)
        held = None
        if len(snaps) > 8:
            reason = "more than 8 snaps"
            break
    end = problem.with_tip_force(F)
    w = P.full(u, [F])
    stable = k = None
    if not reason:
        # the verdict from the Hessian at the end state itself
        try:
            linear.factorize(end.tangent(w), w)
            stats.factorizations += 1
            stable, k = end_state_verdict(end, linear, w, stats)
        except LinearSolverError as err:
            reason = f"singular tangent at the end state ({err})"
        if stable is False:
            reason = f"ended on an unstable equilibrium ({k} negative eigenvalue(s))"
    return TipForceRamp(F, not reason, reason, float(result.deflection),
                        tip_deflection(end, w), end.tip_displacement(w), stable, k,
                        tuple(snaps), int(stats.factorizations), end, w)
