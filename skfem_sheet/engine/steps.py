"""The one step-acceptance rule of the continuation drivers.

A continuation step predicts a point and corrects it.  On a smooth branch
the corrector distance (corrected point to prediction, in the problem's
correction norm) is second order in the step ``h``; a step whose Newton
converged onto another branch moves O(1), however short.  This is the
asymptotic step control of Allgower & Georg (*Introduction to Numerical
Continuation Methods*, SIAM 2003, sec. 6.1) on the distance alone: with its
nominal value ``delta``, a distance over four times nominal rejects the step,
retried at half the length (the halving test: a smooth branch's distance
falls fourfold, a jump's does not), and an accepted step sets the next to
``h (delta / distance)^(1/q)`` (``q`` the predictor's order), between half
and twice ``h``.  Newton's contraction is not weighed (on a thin structure
the second correction is often as large as the first on a smooth branch).  A
correction whose first Newton step is already beyond :attr:`StepRule.bound`
is stopped there and the step rejected.  No other rule accepts or rejects a
step's size: the drivers add only what the mathematics says about the point
(the corrector converged; the inertia changes only where the parameter
turns).

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
