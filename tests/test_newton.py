"""newton.timed: the time of a call is added to the counter, also on errors."""
import time

import pytest

from skfem_sheet.newton import Stats, timed


def test_timed_adds_the_wall_time_and_returns_the_result():
    stats = Stats()
    assert timed(stats, "assembly_s", lambda a, b: a + b, 2, 3) == 5
    t0 = stats.assembly_s
    timed(stats, "assembly_s", time.sleep, 0.02)
    assert stats.assembly_s - t0 >= 0.02 and stats.linear_solve_s == 0.0


def test_timed_counts_a_call_that_raises():
    stats = Stats()

    def fail():
        time.sleep(0.01)
        raise RuntimeError("boom")

    with pytest.raises(RuntimeError, match="boom"):
        timed(stats, "linear_solve_s", fail)
    assert stats.linear_solve_s >= 0.01
