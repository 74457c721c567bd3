"""How long a run still takes, by the rule that stops it: pure functions of simulated times and
a measured wall rate, for the progress line (:class:`adapter.foam.logs.Progress`).

The gliding + swimming pair (:mod:`adapter.foam.swimrun`) stops each run when its cycle means
repeat, not at ``endTime``: the test compares the last two complete cycles after a start-up, so
it cannot pass before ``start_up + 2 T``, and once past that, not before the end of the cycle
under way. :meth:`StopRule.earliest` is that time (never beyond ``endTime``); the estimate is
the wall time to it, plus, while gliding runs, the whole swimming run to its own earliest stop
(a swimming step costs :data:`SWIM_STEP_OVER_GLIDE` gliding steps). It is a lower bound: a run
whose means need more cycles to settle takes a cycle longer each time it misses.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

#: wall time of a swimming step over a gliding step on the same mesh and time step (the moving
#: mesh, its check, the step-server): 1.01 s against 0.575 s on the default case, serial
#: (docs/results/2026-12-01-default-case.md: swimming 711 steps in 723 s, gliding 541 in 311 s)
SWIM_STEP_OVER_GLIDE = 1.77


@dataclass(frozen=True)
class StopRule:
    """When a run can stop: the cycle test after ``start_up`` (s), cycles of ``period`` (s),
    ``cycles`` complete cycles compared; at ``end_time`` (s) in any case. ``period`` inf: the
    run goes to ``end_time`` (a run without a cycle test)."""

    start_up: float
    period: float
    end_time: float
    cycles: int = 2

    def earliest(self, t: float) -> float:
        """The earliest simulated time (s) at or after ``t`` at which the run can stop: the end
        of the ``cycles``-th complete cycle after the start-up, or, ``t`` past it (the test did
        not pass yet), the end of the cycle under way; at most ``end_time``."""
        if not math.isfinite(self.period):
            return self.end_time
        done = math.floor((t - self.start_up) / self.period + 1e-9) if t > self.start_up else 0
        return min(self.start_up + max(self.cycles, done + 1) * self.period, self.end_time)


def to_end_time(end_time: float) -> StopRule:
    """The rule of a run that goes to its end time."""
    return StopRule(start_up=0.0, period=math.inf, end_time=end_time)


@dataclass(frozen=True)
class PairEta:
    """The estimate of a run (``rule``) and of the run that follows it, if any (``then``,
    starting at simulated time ``then_from`` s, each of its steps ``then_cost`` times this
    run's)."""

    rule: StopRule
    then: StopRule | None = None
    then_from: float = 0.0
    then_cost: float = SWIM_STEP_OVER_GLIDE

    def seconds(self, t: float, wall_per_sim_s: float) -> float:
        """Wall seconds left from simulated time ``t`` (s), the run advancing
        ``1 / wall_per_sim_s`` simulated seconds per wall second; NaN when not measured."""
        left = max(self.rule.earliest(t) - t, 0.0)
        if self.then is not None:
            left += self.then_cost * max(self.then.earliest(self.then_from) - self.then_from, 0.0)
        return left * wall_per_sim_s

    def target(self, t: float) -> float:
        """The simulated time (s) this run can stop at, the earliest (:meth:`StopRule.earliest`)."""
        return self.rule.earliest(t)


def minutes(seconds: float) -> str:
    """``"12 min"``: wall seconds as whole minutes (``"< 1 min"`` under 30 s, ``"?"`` when not
    known)."""
    if not math.isfinite(seconds):
        return "?"
    if seconds < 30:
        return "< 1 min"
    return f"{round(seconds / 60)} min"
