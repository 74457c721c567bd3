"""How a solver run ended (:func:`adapter.foam.run.run_case`): a small typed value, told apart
by its kind, not by the words of its message."""

from __future__ import annotations

import enum
from dataclasses import dataclass


class Stop(enum.Enum):
    """Why a run ended."""
    END = "end time"                # it reached its end time (or the solver ended by itself)
    CRITERION = "criterion"         # run_case's stop_when gave a reason: written and stopped
    MESH_WATCH = "mesh watch"       # the log watch saw a too distorted or invalid moved mesh
    MOTION_CHECK = "motion check"   # the mesh motion's own check refused the next mesh


@dataclass(frozen=True)
class RunOutcome:
    """``kind``; ``reason``: what the watch, the criterion or the motion check said;
    ``time``: for :attr:`Stop.MOTION_CHECK`, the time (s) whose mesh would have been invalid."""
    kind: Stop
    reason: str = ""
    time: float | None = None

    @property
    def is_error(self) -> bool:
        """The mesh stopped the run (the watch or the motion check): run_case raises."""
        return self.kind in (Stop.MESH_WATCH, Stop.MOTION_CHECK)

    def message(self, last_written: float | None = None) -> str | None:
        """The words of the summary's ``stopped``/``stopped_because`` (None at the end time);
        ``last_written``: the latest written time, named by a motion check's message."""
        if self.kind is Stop.END:
            return None
        if self.kind is Stop.CRITERION:
            return self.reason
        if self.kind is Stop.MESH_WATCH:
            return f"mesh watch: {self.reason}"
        return (f"mesh watch: the mesh at t = {self.time:.12g} s would be invalid "
                f"({self.reason}); stopped before moving it; the last written time "
                f"{last_written:.12g} s is valid")


#: a run that reached its end
ENDED = RunOutcome(Stop.END)
