"""engine.correct's options for the sheet's Newton (a post-step stopping test, a
divergence floor) and the engine's pseudo-transient iteration, on small problems."""
import numpy as np
import pytest

from skfem_sheet.engine import FunctionProblem, Tolerances
from skfem_sheet.engine.corrector import correct, newton, plain_linearization
from skfem_sheet.engine.protocol import Counting
from skfem_sheet.engine.transient import TransientSystem, pseudo_transient
from skfem_sheet.params import ParameterError


def _sqrt2():
    return FunctionProblem(lambda u, p: u**2 - p[0], lambda u, p: np.diag(2 * u))


def test_post_step_test_returns_the_stepped_iterate_without_an_extra_linearisation():
    """With ``converged`` the test is made at the new iterate after each step:
    the returned state is that iterate, and the number of linearisations is the
    number of steps (none is spent only to confirm)."""
    counter = Counting(_sqrt2())
    seen = []

    def converged(u, p, fact, extra):
        seen.append(float(u[0]))
        # a simplified-Newton correction with the factorisation at hand
        return abs(fact.solve(-counter.residual(u, p))[0]) <= 1e-12

    res = correct(counter, np.array([1.0]), np.array([2.0]), plain_linearization(counter),
                  Tolerances(), converged=converged)
    assert res.converged and res.u[0] == seen[-1]
    assert abs(res.u[0] - np.sqrt(2.0)) < 1e-12
    assert res.iterations == len(seen) == res.stats.factorizations
    # the default rule spends one linearisation more to confirm (from the same start)
    plain = newton(_sqrt2(), np.array([1.0]), [2.0], tol=Tolerances(rtol=1e-12, utol=1e-12))
    assert plain.converged and plain.iterations == res.iterations + 1


def test_error_estimate_stops_one_linearisation_earlier_within_utol():
    """With ``error_estimate`` the iteration stops once the contraction of the
    last two corrections puts the corrected iterate within ``utol`` of the
    solution: on u^2 = 2 from 3 (corrections 1.17, 0.371, 0.0471, 7.85e-4,
    2.18e-7, 1.7e-14) one linearisation fewer than the rule that waits for
    a correction below ``utol`` where the estimate falls below ``utol`` a
    step before the correction does (utol 1e-4 and 1e-9; at 1e-6 both stop
    at the fifth), and the returned point is as close as the estimate says
    (Newton converges quadratically, so closer still)."""
    same = [newton(_sqrt2(), np.array([3.0]), [2.0],
                   tol=Tolerances(rtol=np.inf, utol=1e-6, error_estimate=e)).iterations
            for e in (False, True)]
    assert same == [5, 5]
    for utol in (1e-4, 1e-9):
        rule = Tolerances(rtol=np.inf, utol=utol)
        plain = newton(_sqrt2(), np.array([3.0]), [2.0], tol=rule)
        est = newton(_sqrt2(), np.array([3.0]), [2.0],
                     tol=Tolerances(rtol=np.inf, utol=utol, error_estimate=True))
        assert plain.converged and est.converged
        assert est.iterations == plain.iterations - 1
        c = [h[1] for h in est.history]
        theta = c[-1] / c[-2]
        assert theta <= 0.5 and theta / (1 - theta) * c[-1] <= utol
        assert abs(est.u[0] - np.sqrt(2.0)) <= utol
    # no estimate without a contraction: a first correction alone never stops
    one = newton(_sqrt2(), np.array([np.sqrt(2.0) + 1e-7]), [2.0],
                 tol=Tolerances(rtol=np.inf, utol=1e-3, error_estimate=True))
    assert one.converged and one.iterations == 1  # by the plain rule (1e-7 <= utol)
    with pytest.raises(ParameterError, match="error_estimate"):
        Tolerances(error_estimate=1)


def test_divergence_floor_tolerates_small_oscillating_corrections():
    """Corrections that grow beyond 10x the first but stay below the floor are
    not 'diverging' with a floor; without one they are."""

    class Identity:
        def solve(self, b):
            return b

    def run(floor):
        seq = iter([1e-3, 1e-3, 2e-2, 1e-3, 1e-13])  # the corrections, in turn

        def linearize(u, p):
            d = next(seq)
            return (0.0 if d < 1e-12 else 1.0), np.array([d]), np.zeros(1), Identity(), None
        return correct(Counting(_sqrt2()), np.array([0.0]), np.array([0.0]), linearize,
                       Tolerances(divergence_floor=floor), admissible=lambda u, p: True)

    assert run(None).reason == "diverging"
    ok = run(0.1)
    assert ok.converged and ok.iterations == 5
    with pytest.raises(ParameterError, match="divergence_floor"):
        Tolerances(divergence_floor=-1.0)


def test_pair_contraction_stops_where_a_correction_outgrows_the_one_two_before():
    """With ``pair_contraction``, a correction larger than the one two
    linearisations before ends the iteration as "not contracting"; corrections
    that alternate in size while they shrink pairwise (as a thin sheet's,
    measured on the rectangle at a/R 2.5: a second correction up to 6.3 times
    the first, the third at most 0.23 times the first) still converge, in the
    same linearisations.  Sequences of corrections of the sheet's rows past a
    fold (hmax 0.05): this one is stopped at the third linearisation instead
    of at the limit (the ninth)."""

    class Identity:
        def solve(self, b):
            return b

    def run(corrections, pair):
        seq = iter(corrections)

        def linearize(u, p):
            d = next(seq)
            return (0.0 if d < 1e-12 else 1.0), np.array([d]), np.zeros(1), Identity(), None
        return correct(Counting(_sqrt2()), np.array([0.0]), np.array([0.0]), linearize,
                       Tolerances(utol=1e-10, max_iterations=9, pair_contraction=pair),
                       admissible=lambda u, p: True)

    converging = [0.001546, 0.009768, 0.000359, 0.000991, 1.5e-05, 1e-13]
    assert run(converging, False).converged and run(converging, True).converged
    assert run(converging, True).iterations == run(converging, False).iterations == 6
    past_fold = [0.029112, 0.030536, 0.030004, 0.013357, 0.19517, 0.037419, 0.129334,
                 0.017668, 0.02]
    assert run(past_fold, False).reason == "max iterations"
    stopped = run(past_fold, True)
    assert not stopped.converged and stopped.iterations == 3
    assert stopped.reason.startswith("not contracting")


class _Well(TransientSystem):
    """E = u^4/4 - u^2/2 (minima at +-1, saddle at 0), M = 1."""

    def __init__(self):
        self.factorizations = 0

    def residual(self, u):
        return u**3 - u

    def tangent(self, u):
        return 3 * u**2 - 1

    def factorize(self, K, u, sigma):
        self.factorizations += 1
        self.a = K + sigma
        return int(np.sum(self.a < 0))

    def correction(self, r):
        return -r / self.a


def test_pseudo_transient_leaves_the_saddle_for_a_minimum():
    for u0, target in ((0.05, 1.0), (-0.05, -1.0)):
        res = pseudo_transient(_Well(), np.array([u0]), utol=1e-12, shift=1.0)
        assert res.converged and res.u[0] == pytest.approx(target, abs=1e-10)
    # plain Newton from the same start converges to the saddle
    plain = newton(FunctionProblem(lambda u, p: u**3 - u, lambda u, p: np.diag(3 * u**2 - 1)),
                   np.array([0.05]), [0.0])
    assert plain.converged and abs(plain.u[0]) < 1e-10


def test_pseudo_transient_step_is_limited_by_the_radius_and_reports_failure():
    res = pseudo_transient(_Well(), np.array([5.0]), utol=1e-12, shift=1e-3, radius=0.5)
    assert res.converged and res.u[0] == pytest.approx(1.0, abs=1e-10)
    assert max(res.corrections) > 0.5  # the big corrections were cut to the radius
    short = pseudo_transient(_Well(), np.array([5.0]), utol=1e-12, shift=1e-3, radius=0.5,
                             max_iterations=3)
    assert not short.converged and "did not settle" in short.reason
    assert short.u[0] == pytest.approx(5.0 - 3 * 0.5, abs=1e-12)  # three cut steps


def test_pseudo_transient_refuses_an_indefinite_model():
    class Never(_Well):
        def factorize(self, K, u, sigma):
            super().factorize(K, u, sigma)
            return 1

    sys = Never()
    res = pseudo_transient(sys, np.array([0.5]), utol=1e-8, shift=1.0)
    assert not res.converged and "positive definite" in res.reason and res.iterations == 0
    # the shift grew by x4, x16, x64 and then to the cap (1e6 times the
    # initial shift), where it was tried too: five factorisations to give up
    assert sys.factorizations == 5


class _Ridge(_Well):
    """E = c (u^4/4 - u^2/2): a saddle whose tangent stays near -c over many
    steps of the radius, so that every shift below c leaves a negative
    direction there."""

    def __init__(self, c):
        super().__init__()
        self.c, self.shifts = c, []

    def residual(self, u):
        return self.c * super().residual(u)

    def tangent(self, u):
        return self.c * super().tangent(u)

    def factorize(self, K, u, sigma):
        k = super().factorize(K, u, sigma)
        self.shifts.append((float(u[0]), sigma, k))
        return k


def test_pseudo_transient_does_not_retry_a_shift_found_too_small():
    """A shift that left a negative direction is not tried again at the next
    state (the tangent changed little): on a deep ridge the first shift tried
    at each state is above every shift found too small at the state before
    (without the memory the step rule divided the shift back into that range,
    and each such state refactorised again: 39 factorisations, here 37), and
    the settle still ends on the minimum with plain Newton."""
    sys = _Ridge(100.0)
    res = pseudo_transient(sys, np.array([0.01]), utol=1e-12, shift=1.0, radius=0.05,
                           max_decrease=64.0)
    assert res.converged and res.u[0] == pytest.approx(1.0, abs=1e-10)
    states = {}
    for u, sigma, k in sys.shifts:
        states.setdefault(u, []).append((sigma, k))
    tries = list(states.values())
    assert len(tries[0]) > 2  # the first state escalated from 1 to past 100
    for before, after in zip(tries, tries[1:]):
        too_small = [sigma for sigma, k in before if k > 0]
        if too_small:
            assert after[0][0] > max(too_small)
    assert tries[-1][-1] == (0.0, 0)  # plain Newton at the end
    assert sys.factorizations <= 37


def test_pseudo_transient_shift_falls_faster_while_the_steps_are_short():
    """After a large shift (sigma 1e6) the full steps are far shorter than the
    radius; with max_decrease the shift falls by up to that factor per step,
    the settle ends on the same minimum in fewer steps, and max_decrease 4 is
    the fixed quartering."""
    slow = pseudo_transient(_Well(), np.array([0.05]), utol=1e-12, shift=1e6, radius=0.5)
    fast = pseudo_transient(_Well(), np.array([0.05]), utol=1e-12, shift=1e6, radius=0.5,
                            max_decrease=64.0)
    assert slow.converged and fast.converged
    assert fast.u[0] == pytest.approx(1.0, abs=1e-10) and slow.u[0] == pytest.approx(1.0, abs=1e-10)
    assert fast.iterations < slow.iterations - 3
    same = pseudo_transient(_Well(), np.array([0.05]), utol=1e-12, shift=1e6, radius=0.5,
                            max_decrease=4.0)
    assert same.iterations == slow.iterations and np.array_equal(same.u, slow.u)
    with pytest.raises(ParameterError, match="max_decrease"):
        pseudo_transient(_Well(), np.array([0.05]), utol=1e-12, max_decrease=2.0)
