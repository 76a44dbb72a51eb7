"""The one step-acceptance rule of the continuation drivers.

A continuation step predicts a point (along the tangent or the secant of the
last two points) and corrects it (Newton).  On a smooth branch the corrector
distance -- how far the corrected point lies from the prediction, in the
problem's correction norm -- is second order in the step ``h``: it falls
about fourfold when ``h`` is halved.  A step whose Newton converged onto
another branch moves O(1), however short it is.  This is the asymptotic step
control of Allgower & Georg (*Introduction to Numerical Continuation
Methods*, SIAM 2003, section 6.1) on the distance alone: with its nominal
value ``delta``, a step whose distance is over four times nominal is
rejected and retried at half the length -- the halving test: on a smooth
branch its distance then falls at least fourfold and it passes, a jump does
not shrink and is cut until the step is below ``minimum`` -- and an accepted
one sets the next step to ``h (delta / distance)^(1/q)`` (``q`` the order of
the predictor's error, 2 for a linear predictor, 3 for a quadratic one),
between half and twice ``h``.  (Allgower & Georg also weigh Newton's
contraction; on a thin structure a bending step leaves a membrane residual that
the next correction removes, so the second correction is often as large as
the first on a perfectly smooth branch, and the contraction says nothing
about the step.)  The corrector's first Newton correction is the
first-order estimate of that distance (the estimate Allgower & Georg's
step control is built on): a correction whose first step is already beyond
the rejection bound (:attr:`StepRule.bound`) is stopped there and the step
rejected, instead of being corrected to the end only to be rejected (or to
fail after all of Newton's iterations, as a step too long for Newton's basin
does).  No other rule accepts or rejects a step's size: the drivers
add only what the mathematics says about the point itself (the corrector
converged; the inertia changes only where the parameter turns).

Examples
--------
>>> rule = StepRule(delta=0.01)
>>> rule.next_step(0.1, 0.0025)   # a quarter of nominal: the next step twice as long
0.2
>>> rule.rejects(0.09)  # nine times nominal: rejected (the step is halved)
True
>>> rule.bound  # also the bound on the corrector's first Newton correction
0.04
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..params import check_range

__all__ = ["StepRule", "corrector_distance"]


@dataclass(frozen=True)
class StepRule:
    """Step lengths and the nominal corrector behaviour (see the module).

    Attributes
    ----------
    initial : float
        First step (arclength in the problem's norm; a natural step advances
        the parameter by the step times the tangent's parameter component).
    minimum : float
        Below this the driver gives up (a failure, reported as such).
    maximum : float
        Largest step.
    delta : float
        Nominal corrector distance (in the problem's ``correction_norm``):
        the distance aimed at between a step's prediction and its corrected
        point.  It sets the cost: the number of steps of a branch scales like
        ``1 / sqrt(delta)``.
    """

    initial: float = 0.25
    minimum: float = 1e-4
    maximum: float = 1.0
    delta: float = 0.05

    def __post_init__(self):
        check_range("initial", self.initial, 0, None, lo_open=True)
        check_range("minimum", self.minimum, 0, self.initial, lo_open=True)
        check_range("maximum", self.maximum, self.initial, None)
        check_range("delta", self.delta, 0, None, lo_open=True)

    @property
    def bound(self) -> float:
        """The largest corrector distance accepted: four times the nominal one.
        Also the bound on the corrector's first Newton correction (its
        estimate of the distance; see the module)."""
        return 4.0 * self.delta

    def rejects(self, distance: float) -> bool:
        """Whether a step whose corrector distance is ``distance`` is rejected:
        more than :attr:`bound` (or not finite)."""
        return not float(distance) <= self.bound

    def next_step(self, h: float, distance: float, order: int = 2) -> float:
        """The step after an accepted one of length ``h``: ``h (delta /
        distance)^(1/order)`` (``order``: the power of ``h`` the distance
        grows with, 2 for a linear predictor, 3 for a quadratic one), at
        least halved and at most doubled, at most ``maximum``."""
        ratio = self.delta / max(float(distance), 1e-300)
        f = min(max(ratio ** (1.0 / order), 0.5), 2.0)
        return float(min(self.maximum, h * f))


def corrector_distance(counter, res, u_pred, p_pred) -> float:
    """Distance of the corrected point ``res`` from its prediction: the
    correction norm of the state and the largest parameter change."""
    dp = np.abs(np.asarray(res.p) - np.asarray(p_pred))
    return max(counter.correction_norm(res.u - u_pred), float(dp.max()) if dp.size else 0.0)
