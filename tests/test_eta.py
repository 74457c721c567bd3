"""The progress line's ETA (adapter/foam/eta.py) by the pair's stopping rule, not endTime: hand
values, and the default case's measured record (docs/results/2026-12-01-default-case.md)."""

import io
import math
import time
from pathlib import Path

import pytest

from adapter.foam import logs as LG
from adapter.foam.eta import SWIM_STEP_OVER_GLIDE, PairEta, StopRule, minutes, to_end_time


@pytest.mark.parametrize("t, earliest", [
    (0.0, 3.0),     # start-up [0, 1), then the two cycles the test compares: t = 3
    (0.5, 3.0),
    (2.5, 3.0),
    (3.0, 4.0),     # at 3 the test did not pass (the run goes on): the next cycle's end
    (3.4, 4.0),
    (6.99, 7.0),
])
def test_the_earliest_stop_is_two_cycles_after_the_start_up_or_the_next_cycles_end(t, earliest):
    assert StopRule(start_up=1.0, period=1.0, end_time=10.0).earliest(t) == pytest.approx(earliest)


def test_the_earliest_stop_is_never_past_the_end_time():
    assert StopRule(start_up=1.0, period=1.0, end_time=2.5).earliest(0.0) == 2.5
    assert StopRule(start_up=1.0, period=1.0, end_time=3.5).earliest(3.2) == 3.5
    assert to_end_time(30.0).earliest(12.0) == 30.0


def test_the_gliding_eta_holds_the_whole_swimming_run():
    glide = StopRule(start_up=2.0, period=2.0, end_time=40.0)
    swim = StopRule(start_up=4.0, period=2.0, end_time=40.0)
    # gliding at t = 2 s, 100 wall s a simulated s: 4 s of gliding left (to 6 s), then
    # swimming from 0 to 8 s, each step 1.5 gliding steps: 400 + 1200 wall s
    eta = PairEta(glide, then=swim, then_from=0.0, then_cost=1.5)
    assert eta.seconds(2.0, 100.0) == pytest.approx(1600.0)
    # the swimming run resumed at 5 s: to 8 s only
    assert PairEta(glide, then=swim, then_from=5.0, then_cost=1.5).seconds(2.0, 100.0) == \
        pytest.approx(400.0 + 1.5 * 300.0)
    # swimming itself at t = 7 s: 1 s left
    assert PairEta(swim).seconds(7.0, 100.0) == pytest.approx(100.0)
    assert math.isnan(PairEta(swim).seconds(7.0, math.nan))


@pytest.mark.parametrize("seconds, text", [
    (731.0, "12 min"), (60.0, "1 min"), (29.0, "< 1 min"), (5400.0, "90 min"),
    (math.nan, "?"), (math.inf, "?"),
])
def test_minutes(seconds, text):
    assert minutes(seconds) == text


def test_on_the_default_cases_record_the_eta_is_a_close_lower_bound():
    """The default case, serial: 177 steps of 0.0435 s a cycle, start-up one cycle; gliding 541
    steps in 311 s, swimming 711 steps in 723 s (it needed three cycles after the start-up,
    the estimate assumes the earliest, two)."""
    period, dt = 177 * 0.0435, 0.0435
    glide = StopRule(start_up=period, period=period, end_time=30 * period)
    swim = StopRule(start_up=period, period=period, end_time=30 * period)
    glide_wall_per_sim = (311 / 541) / dt
    at_start = PairEta(glide, then=swim).seconds(0.0, glide_wall_per_sim)
    assert 0.75 * (311 + 723) < at_start <= 311 + 723
    assert SWIM_STEP_OVER_GLIDE == pytest.approx((723 / 711) / (311 / 541), rel=0.01)


def test_the_progress_line_says_minutes_to_the_pairs_earliest_stop():
    watch = LG.LogWatch(Path("unused"))
    for i in range(10):
        watch.feed(f"Time = {0.1 * (i + 1):g}")
    out = io.StringIO()
    glide = StopRule(start_up=1.0, period=1.0, end_time=30.0)
    show = LG.Progress(end_time=30.0, start_time=0.0, stream=out,
                       eta=PairEta(glide, then=glide, then_cost=2.0))
    show.t_wall = time.perf_counter() - 600.0      # 600 wall s for the first simulated 1 s
    show.show(watch, final=True)
    line = out.getvalue()
    # 2 s of gliding left (1200 s) and 3 s of swimming at twice the cost (3600 s): 80 min
    assert "ETA 80 min (with swimming)" in line
    assert "can stop at 3, end 30" in line
    # a run without a cycle test: to its end time, 29 s left at 600 s each
    out = io.StringIO()
    show = LG.Progress(end_time=30.0, start_time=0.0, stream=out)
    show.t_wall = time.perf_counter() - 600.0
    show.show(watch, final=True)
    assert "t = 1 / 30 s" in out.getvalue() and "ETA 290 min" in out.getvalue()
