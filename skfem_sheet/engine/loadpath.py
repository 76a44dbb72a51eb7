"""Natural continuation in a load parameter with adaptive steps: the load paths' driver.

A load parameter ``lam`` runs from a start to an end (``1``, the full load);
each step is attempted by the caller (predict, correct with
:func:`~skfem_sheet.engine.corrector.correct`, verify) and this driver only
controls the steps: they grow after easy corrections, shrink a little after
hard ones, are halved after a failure, and below ``min_step`` the ramp fails.
Where the steps have been cut below ``snap_step`` the followed branch is taken
to end at a fold: the next attempts are told to *snap* (e.g. settle by
:func:`~skfem_sheet.engine.transient.pseudo_transient` onto another branch)
until one succeeds.

The driver knows nothing of the problem: what an attempt does is the caller's.

Examples
--------
A branch that ends at ``lam = 0.6``; beyond it a snap lands on the other one:

>>> branch = ["first"]
>>> def attempt(lam, lam_new, snapping):
...     if snapping:
...         branch[0] = "second"
...     ok = lam_new <= 0.6 or branch[0] == "second"
...     return Attempt(ok, 2 if ok else 5, "" if ok else "no equilibrium")
>>> out = ramp(0.0, RampControl(snap_step=0.05), attempt)
>>> out.converged, out.lam, [round(x, 4) for x in out.snapped], out.rejected
(True, 1.0, [0.625], 6)
"""
from __future__ import annotations

from dataclasses import dataclass, field

from ..params import ParameterError, check_range

__all__ = ["Attempt", "RampControl", "RampOutcome", "growth", "ramp"]


@dataclass(frozen=True)
class RampControl:
    """Adaptive step control of :func:`ramp` (fractions of the range).

    Attributes
    ----------
    initial_step, min_step, max_step : float
        First step; below ``min_step`` the ramp fails; the largest step.
    grow : float
        Growth factor after an easy step (at most ``easy_iterations``).
    easy_iterations : int
    snap_step : float or None
        Cut below this, the next attempts snap (``None``: never).
    snap_at_failure : bool
        The first snapping attempt is made at the load that has just failed
        (beyond the fold, where the snap must happen), not at half the step
        (which may still be short of the fold and cost a settle that does
        not snap); later snapping attempts halve the step as usual.
    """

    initial_step: float = 0.25
    min_step: float = 1e-3
    max_step: float = 1.0
    grow: float = 2.0
    easy_iterations: int = 2
    snap_step: float | None = None
    snap_at_failure: bool = True

    def __post_init__(self):
        check_range("initial_step", self.initial_step, 0, 1, lo_open=True)
        check_range("min_step", self.min_step, 0, self.initial_step, lo_open=True)
        check_range("max_step", self.max_step, self.initial_step, 1)
        check_range("grow", self.grow, 1, 10)
        if self.snap_step is not None and not self.snap_step > 0:
            raise ParameterError(f"snap_step must be > 0 or None, got {self.snap_step!r}")


@dataclass(frozen=True)
class Attempt:
    """Outcome of one attempted step.

    Attributes
    ----------
    converged : bool
        The step is accepted.
    iterations : int
        Corrector iterations (they set the next step).
    reason : str
        Why not converged.
    stop : str
        If not empty, the ramp ends here with this reason (e.g. a verified
        end state that is unstable).
    """

    converged: bool
    iterations: int
    reason: str = ""
    stop: str = ""


@dataclass(frozen=True)
class RampOutcome:
    """Where :func:`ramp` ended and why.

    Attributes
    ----------
    lam : float
        The last accepted load.
    converged : bool
        The end was reached.
    reason : str
        "step below min_step" or an attempt's ``stop`` ("" if converged).
    last_failure : str
        The reason of the last failed attempt.
    steps, rejected : int
        Accepted and rejected attempts.
    snapped : tuple
        Loads of the accepted steps that were snaps.
    """

    lam: float
    converged: bool
    reason: str = ""
    last_failure: str = ""
    steps: int = 0
    rejected: int = 0
    snapped: tuple = field(default=())


def growth(iterations: int, control: RampControl) -> float:
    """Step-size factor after a converged step: grow after easy corrections,
    shrink a little after hard ones (aiming at ``easy_iterations``)."""
    if iterations <= control.easy_iterations:
        return control.grow
    if iterations == control.easy_iterations + 1:
        return 1.0 + 0.5 * (control.grow - 1.0)
    if iterations == control.easy_iterations + 2:
        return 1.0
    return 0.7


def ramp(lam: float, control: RampControl, attempt, *, end: float = 1.0) -> RampOutcome:
    """Natural continuation from ``lam`` to ``end`` with adaptive steps.

    Parameters
    ----------
    lam : float
        Start (already an equilibrium).
    control : RampControl
    attempt : callable(lam, lam_new, snapping) -> Attempt
        Try the step from the accepted ``lam`` to ``lam_new``; ``snapping``
        says that the steps were cut below ``snap_step`` (the branch is taken
        to end: leave it).
    end : float

    Returns
    -------
    RampOutcome
    """
    step, snapping = control.initial_step, False
    steps = rejected = 0
    snapped, last = [], ""
    while lam < end:
        lam_new = min(end, lam + step)
        res = attempt(lam, lam_new, snapping)
        if res.stop:
            return RampOutcome(lam, False, res.stop, last, steps, rejected, tuple(snapped))
        if res.converged:
            if snapping:
                snapped.append(lam_new)
                snapping = False
            lam, steps = lam_new, steps + 1
            step = min(control.max_step, step * growth(res.iterations, control))
            continue
        rejected, last = rejected + 1, res.reason
        step *= 0.5
        if control.snap_step is not None and not snapping and step < control.snap_step:
            snapping = True
            if control.snap_at_failure:
                step *= 2.0  # retry the failed load, now snapping
        elif step < control.min_step:
            return RampOutcome(lam, False, "step below min_step", last, steps, rejected,
                               tuple(snapped))
    return RampOutcome(lam, True, "", last, steps, rejected, tuple(snapped))
