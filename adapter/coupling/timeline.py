"""The motion timeline: the animator advanced to the times OpenFOAM asks for, with work-ahead.

Each time is computed once (the last few are kept, so that a lagging request gets the same
bytes); while OpenFOAM solves the flow, a thread already advances the animator to the next
expected time (the last step repeated), and a wrong guess is undone from the checkpoint taken
before it. The work-ahead starts when the caller says the answer is on its way
(:meth:`Timeline.work_ahead`), not before: its compiled kernels hold the GIL, and the answer
would wait for them. A time behind the animator is reached again from a saved state
(:mod:`.store`) or by replay from t = 0. Each new time also gets the whale's frame
(:class:`~adapter.coupling.frame.FrameLine`), from that time's REQUEST. No sockets: the
step-server's sessions ask :meth:`Timeline.motion`.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import threading
import time
from collections import OrderedDict
from collections.abc import Callable

import numpy as np

from adapter.coupling.frame import STILL, FrameLine, FrameState
from adapter.coupling.protocol import ErrorCode, Request, WireError
from adapter.coupling.store import copy_state, time_name
from adapter.errors import UnstableError

log = logging.getLogger(__name__)

#: served times whose node displacement is kept, so a lagging rank gets the same bytes
CACHE_SIZE = 4
#: the largest jump ahead, in stroke cycles, that a REQUEST or WRITE may ask for
MAX_JUMP_CYCLES = 1000


@dataclasses.dataclass
class Served:
    """The motion at one served time, and the animator state right after computing it; the
    whale's frame there and the frame's state after it (None: no frame answered)."""

    t: float
    disp: np.ndarray       # (N, 3) node displacement (m)
    vel: np.ndarray        # (N, 3) node velocity (m/s)
    ckpt: dict
    animator_time: float
    frame: FrameState = STILL
    frame_state: dict | None = None


@dataclasses.dataclass
class Ahead:
    """Work done ahead: the state before it, and the motion at the predicted time."""

    target: float
    pre: dict
    disp: np.ndarray
    vel: np.ndarray
    compute_s: float
    post: dict             # the animator's state after it (the hit's checkpoint, taken ahead)
    animator_time: float


@dataclasses.dataclass
class TimelineStats:
    """What the timeline did: steps computed, work-ahead hits and tries, seconds per step."""

    steps: int = 0
    ahead_hits: int = 0
    ahead_tries: int = 0
    advance_s: list = dataclasses.field(default_factory=list)


class Timeline:
    """One animator, advanced (or rewound) to the times asked for.

    Parameters
    ----------
    animator : the :class:`~adapter.motion.animator.Animator` (at t = 0 or at a saved state).
    store : a :class:`~adapter.coupling.store.StateStore` to go back with and to resume from
        (None: replay from t = 0).
    on_served : called as ``on_served(served, restart)`` for every newly computed time, with
        the animator lock held (``restart``: the first time, or one before the last served).
    frames : the whale's frame, answered at every newly computed time (None: :data:`STILL`).
    """

    def __init__(self, animator, store=None,
                 on_served: Callable[[Served, bool], None] | None = None,
                 frames: FrameLine | None = None):
        self.animator = animator
        self.store = store
        self.on_served = on_served
        self.frames = frames
        self.stats = TimelineStats()
        #: the model's failure message, once the whale has blown up (then nothing is computed)
        self.failure: str | None = None
        #: the newest time computed on the served line of states
        self.last: Served | None = None
        self._lock = threading.Lock()            # the animator and the work-ahead
        self._cache_lock = threading.Lock()      # the served times
        self._served: OrderedDict[float, Served] = OrderedDict()
        self._ahead: Ahead | None = None
        self._ahead_thread: threading.Thread | None = None
        self._ahead_next: tuple[int, float] | None = None   # (generation, target) to start
        self._generation = 0

    # --- asking -----------------------------------------------------------------------------

    def served(self, t: float) -> Served | None:
        """The motion at t if it is still kept, else None."""
        with self._cache_lock:
            return self._served.get(t)

    def check_time(self, t: float, what: str) -> None:
        """A time the animator can reach: finite, not negative, and not absurdly far ahead
        (a jump of more than MAX_JUMP_CYCLES stroke cycles would keep the animator busy for
        hours with the lock held: refused instead of hanging)."""
        if not math.isfinite(t) or t < 0:
            raise WireError(ErrorCode.BAD_FRAME,
                            f"bad {what}: time {t} s is not a finite time >= 0")
        a = self.animator
        jump = MAX_JUMP_CYCLES * a.period
        newest = self.store.newest_time() if self.store is not None else 0.0
        if t > a.time + jump and t > newest + jump:
            raise WireError(
                ErrorCode.BAD_FRAME,
                f"bad {what}: time {t:g} s is more than {MAX_JUMP_CYCLES} stroke cycles ahead of "
                f"the whale (at {a.time:g} s); check the case's time settings")

    def motion(self, t: float, last_t: float | None = None, restarted: bool = True,
               request: Request | None = None) -> Served:
        """The motion at t, computed once (a repeat gets the kept state).

        ``last_t`` is the latest time this client asked for (None: none yet) and ``restarted``
        whether it may go back before the times already served (its first REQUEST);
        ``request`` the REQUEST asking (its loads for the frame; None: not known). Raises
        :class:`WireError` (time backwards) and :class:`~adapter.errors.UnstableError`.
        """
        served = self.served(t)
        if served is not None:
            return served
        if last_t is not None and t < last_t:
            raise WireError(ErrorCode.TIME_BACKWARDS,
                            f"time went backwards: the client asked for t = {t!r} s after "
                            f"t = {last_t!r} s")
        with self._lock:
            if self.failure is not None:
                raise UnstableError(self.failure)
            served = self.served(t)
            if served is not None:
                return served
            last = self.last
            if last is not None and t < last.t and not restarted:
                raise WireError(ErrorCode.TIME_BACKWARDS,
                                f"time went backwards: t = {t!r} s is earlier than t = {last.t!r} "
                                f"s already served (only a restarted client may go back)")
            return self._compute(t, request)

    def side_motion(self, t: float) -> Served:
        """The motion at a time never served, leaving the served line of states untouched."""
        with self._lock:
            a = self.animator
            self._generation += 1
            if self._ahead is not None:
                a.restore(copy_state(self._ahead.pre))
                self._ahead = None
            here = copy_state(a.checkpoint())
            try:
                if self._behind(t):
                    self._seek_back(t)
                disp = np.array(a.displacement(t), dtype=np.float64)
                vel = np.array(a.velocity(t), dtype=np.float64)
                served = Served(t, disp, vel, copy_state(a.checkpoint()), float(a.time))
            finally:
                a.restore(here)
        return served

    def fail(self, message: str) -> bool:
        """Mark the model failed (nothing is computed after); True the first time."""
        with self._cache_lock:
            first = self.failure is None
            if first:
                self.failure = message
        return first

    def work_ahead(self) -> None:
        """Start advancing the animator to the next expected time in the background (the
        last step repeated), if the last :meth:`motion` computed a new time after another;
        call it once the answer has been sent, so that the two do not share the GIL."""
        with self._cache_lock:
            pending, self._ahead_next = self._ahead_next, None
        if pending is None:
            return
        thread = threading.Thread(target=self._work_ahead, args=pending, daemon=True,
                                  name="step-server work-ahead")
        self._ahead_thread = thread
        thread.start()

    def join(self, timeout: float = 30.0) -> None:
        """Wait for a running work-ahead."""
        if self._ahead_thread is not None:
            self._ahead_thread.join(timeout=timeout)

    # --- computing (the animator lock held) -------------------------------------------------

    def _behind(self, t: float) -> bool:
        """Whether t is behind the animator's reach (it marches forward only, and keeps the
        step before its current one)."""
        a = self.animator
        return t < a.time - a.dt

    def _compute(self, t: float, request: Request | None = None) -> Served:
        """Advance (or rewind) the animator to t; the frame there."""
        t0 = time.perf_counter()
        a = self.animator
        self._generation += 1
        ahead, self._ahead = self._ahead, None
        last = self.last
        hit = None
        if ahead is not None:
            self.stats.ahead_tries += 1
            tol = 1e-9 * max(abs(ahead.target), 1.0)
            hit = t >= ahead.target - tol and not self._behind(t)
            if not hit:
                a.restore(copy_state(ahead.pre))
        restart = last is None or t < last.t
        if self._behind(t):
            self._seek_back(t)
        elif last is None:
            self._jump_from_state(t)
        if hit and ahead is not None and t == ahead.target:
            served = Served(t, ahead.disp, ahead.vel, ahead.post, ahead.animator_time)
        else:
            disp = np.array(a.displacement(t), dtype=np.float64)
            vel = np.array(a.velocity(t), dtype=np.float64)
            if not np.isfinite(disp).all():
                raise UnstableError(f"the whale's displacement at t = {t} s is not finite; "
                                    f"lower [integrator] dt_s")
            served = Served(t, disp, vel, copy_state(a.checkpoint()), float(a.time))
        if self.frames is not None:
            served.frame, served.frame_state = self.frames.answer(t, request, restart)
            served.disp = served.frame.rotated(served.disp, a.surface.points)
        compute_s = time.perf_counter() - t0
        if hit:
            self.stats.ahead_hits += 1
        self.stats.advance_s.append(ahead.compute_s + compute_s
                                    if hit and ahead is not None else compute_s)
        with self._cache_lock:
            self._served[t] = served
            while len(self._served) > CACHE_SIZE:
                self._served.popitem(last=False)
            if restart:
                for old in [k for k in self._served if k > t]:
                    del self._served[old]
            self.stats.steps += 1
        if self.on_served is not None:
            self.on_served(served, restart)
        prev = last.t if last is not None and not restart else None
        self.last = served
        note = {None: "no work-ahead", True: "work-ahead hit", False: "work-ahead miss"}[hit]
        extra = f" (ahead {1e3 * ahead.compute_s:.3g} ms)" if ahead is not None else ""
        log.info("t=%s compute %.3g ms, %s%s%s", time_name(t), 1e3 * compute_s, note, extra,
                 ", restart" if restart and last is not None else "")
        with self._cache_lock:
            self._ahead_next = ((self._generation, t + (t - prev))
                                if prev is not None and t > prev else None)
        return served

    def _work_ahead(self, gen: int, target: float) -> None:
        with self._lock:
            if gen != self._generation or self.failure is not None or self.last is None:
                return
            a = self.animator
            pre = self.last.ckpt
            t0 = time.perf_counter()
            try:
                disp = np.array(a.displacement(target), dtype=np.float64)
                vel = np.array(a.velocity(target), dtype=np.float64)
                if not np.isfinite(disp).all():
                    raise UnstableError("not finite")
            except Exception as exc:    # undone; the real request will meet it again
                a.restore(copy_state(pre))
                log.info("work-ahead to t=%s failed (%s); undone", time_name(target), exc)
                return
            post = copy_state(a.checkpoint())
            self._ahead = Ahead(target, pre, disp, vel, time.perf_counter() - t0, post,
                                float(a.time))

    def _seek_back(self, t: float) -> None:
        """Restore the animator to a state that can reach t: a saved state, else t = 0."""
        if self.store is None or not self.store.restore(self.animator, t):
            log.info("replaying from t = 0 to t = %s (no saved state fits)", time_name(t))
            self.animator.reset()

    def _jump_from_state(self, t: float) -> None:
        """On a fresh server, start from the newest saved state that can reach t."""
        if self.store is not None:
            self.store.restore(self.animator, t, newer_than=float(self.animator.time))
