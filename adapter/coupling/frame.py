"""The whale's frame: the far-field fluid's velocity and the frame's acceleration at each served
time, handed to OpenFOAM in every DISPLACEMENT (docs/protocol.md, version 3).

The flow is solved in the whale's frame. Its inlet follows the frame velocity ``U_f`` (the
far-field fluid's velocity seen from the whale) and the fluid feels the frame's acceleration
``a_f`` as a uniform body force per unit mass (the plugin's ``whaleFrameInletVelocity`` and
``whaleFrameAcceleration``, docs/openfoam-plugin.md). A :class:`Frame` decides both, once per
new served time, from the loads OpenFOAM reports; this module integrates no equation of motion
itself. :class:`FixedFrame`, the default, is the tethered whale: the scene's inflow, no
acceleration.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from adapter.coupling.protocol import Request
from adapter.errors import UnstableError
from adapter.jsonfiles import dumps


def _vector(value, name: str) -> np.ndarray:
    v = np.array(value, dtype=np.float64).reshape(-1)
    if v.shape != (3,):
        raise ValueError(f"the frame's {name} needs 3 components, got {v.size}")
    v.setflags(write=False)
    return v


@dataclass(frozen=True)
class FrameState:
    """The frame at one served time: ``velocity`` (3,) in m/s, the far-field fluid's velocity in
    the whale's frame (the inlet's), and ``acceleration`` (3,) in m/s2, the uniform body force
    per unit mass on the fluid over the step ending at that time."""

    velocity: np.ndarray
    acceleration: np.ndarray
    #: the whale's pitch recoil (rad): a turn about +y through ``centre`` (m), the rostrum (at -x
    #: of it) rising for a positive pitch, added to the stroke's displacement (:meth:`rotated`)
    pitch: float = 0.0
    centre: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def __post_init__(self):
        object.__setattr__(self, "velocity", _vector(self.velocity, "velocity"))
        object.__setattr__(self, "acceleration", _vector(self.acceleration, "acceleration"))
        object.__setattr__(self, "pitch", float(self.pitch))
        object.__setattr__(self, "centre", _vector(self.centre, "centre"))

    def finite(self) -> bool:
        """Whether every component is finite."""
        return bool(np.isfinite(self.velocity).all() and np.isfinite(self.acceleration).all()
                    and math.isfinite(self.pitch))

    def rotated(self, displacement: np.ndarray, rest: np.ndarray) -> np.ndarray:
        """The displacement (N, 3) of points at ``rest`` (N, 3) with the whole whale turned by
        the pitch about the y axis through the centre (the displacement itself when 0)."""
        if self.pitch == 0.0:
            return displacement
        c, s = math.cos(self.pitch), math.sin(self.pitch)
        r = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])   # about +y
        moved = rest + displacement - self.centre
        return (self.centre + moved @ r.T) - rest


class Frame(Protocol):
    """What the step-server asks of the whale's frame (:class:`FixedFrame` is the default)."""

    def answer(self, time: float, request: Request) -> FrameState:
        """The frame at ``time``: called once per NEW served time, in time order, with that
        time's REQUEST (the loads of the last completed step; NaN on a connection's first
        request, unless the state saved at the write time restarted from holds them)."""
        ...

    def state(self) -> dict:
        """What :meth:`restore` needs to go on from here: JSON-able (saved with the server's
        restart state at each WRITE)."""
        ...

    def restore(self, state: dict) -> None:
        """Go back to a state :meth:`state` returned (a restart)."""
        ...


class FixedFrame:
    """The tethered whale's frame: a constant inflow ``velocity`` (m/s), no acceleration."""

    def __init__(self, velocity):
        self._state = FrameState(velocity, np.zeros(3))

    def answer(self, time: float, request: Request) -> FrameState:
        return self._state

    def state(self) -> dict:
        return {}

    def restore(self, state: dict) -> None:
        pass


def fixed_frame_for(scene) -> FixedFrame:
    """The scene's tethered frame: its inflow ``(flow.speed_m_s, 0, 0)``."""
    return FixedFrame((scene.flow.speed_m_s, 0.0, 0.0))


def unknown_request(time: float) -> Request:
    """A REQUEST at ``time`` whose loads are not known (NaN)."""
    nan = np.full(3, np.nan)
    return Request(time, nan, nan, nan, nan)


def _with_loads(request: Request, loads: np.ndarray) -> Request:
    return Request(request.time, loads[0:3], loads[3:6], loads[6:9], loads[9:12])


class FrameLine:
    """The frame answered along the served times, and gone back to at a restart.

    Parameters
    ----------
    frame : the :class:`Frame` served.
    store : the :class:`~adapter.coupling.store.StateStore` holding the frame files (None: a
        restart goes back to the frame's state at start).

    The :class:`~adapter.coupling.timeline.Timeline` calls :meth:`answer` once per new served
    time, with its animator lock held.
    """

    def __init__(self, frame: Frame, store=None):
        self.frame = frame
        self.store = store
        self._initial = _json_copy(frame.state())
        self._last: float | None = None

    def answer(self, t: float, request: Request | None,
               restart: bool) -> tuple[FrameState, dict]:
        """The frame at a new served time t and the frame's state after it; ``restart``: t
        is a (re)start (the first time, or one before the last served), so the frame goes back
        first to the newest frame file at or before t (else to its state at start)."""
        request = unknown_request(t) if request is None else request
        if restart:
            record = self.store.frame_record(t) if self.store is not None else None
            if record is not None:
                self.frame.restore(_json_copy(record.state))
                if record.time == t:         # served before: the same frame again
                    self._last = t
                    return FrameState(record.velocity, record.acceleration,
                                      float(record.state.get("pitch", 0.0)),
                                      record.state.get("pitch_centre", (0.0, 0.0, 0.0))), \
                        record.state
                if not request.known() and record.next is not None:
                    request = _with_loads(request, record.next)
            else:
                self.frame.restore(_json_copy(self._initial))
        elif self.store is not None and self._last is not None:
            self.store.add_frame_next(self._last, request.loads())
        state = self.frame.answer(t, request)
        if not state.finite():
            raise UnstableError(f"the whale's frame at t = {t} s is not finite (velocity "
                                f"{state.velocity.tolist()}, acceleration "
                                f"{state.acceleration.tolist()})")
        self._last = t
        return state, _json_copy(self.frame.state())


def _json_copy(state: dict) -> dict:
    """A deep copy of a frame's state, through strict JSON (so that it can be saved)."""
    return json.loads(dumps(state, indent=None))


#: the frame of a timeline without one: no inflow, no acceleration
STILL = FrameState(np.zeros(3), np.zeros(3))
