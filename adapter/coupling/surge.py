"""Free swimming: the whale's own speed from its momentum balance (docs/free-swimming.md).

The flow is solved in the whale's frame. The frame's velocity ``u_f`` is the velocity of the
water far from the whale as the whale sees it (the inlet's velocity, ``(U, 0, 0)`` with ``U``
the forward speed); the whale's own velocity is ``-u_f``. Newton's law for the whale,
``m d(-u_f)/dt = F`` with ``F`` the water's force on it, gives along each free axis

    m du_f/dt = -F

The measured ``F`` holds the water's reaction to the frame's acceleration (the added mass
``m_a``: ``F = G + m_a du_f/dt``, G the rest), so the same law is ``(m + m_a) du_f/dt = -G``.
The flow step that measured ``F`` ran with the acceleration of the step before, so each step
takes ``G = F - m_a a_prev`` and advances ``(m + m_a) du_f/dt = -G``: the explicit coupling of a
light body with the added mass moved to the left, stable whatever m_a / m (an error in the
estimate of m_a only lags the reaction by one step).

At the release the frame's speed may first be brought, over ``approach_s`` and with the forces
not heeded, from the tethered speed to an estimate of the self-propelled one
(``free.approach_cycles``, :func:`release_speed`): a half-cosine in time, the body force its
derivative.

Early on a lighter mass may speed the approach to the self-propelled state (``free.light``):
the force's running mean over the last stroke period acts on ``light * (m + m_a)`` while the
stroke's swing about that mean acts on the true ``m + m_a``, so the swing of the speed within a
cycle stays that of the real whale; it does so once the window holds a whole period of forces
after the approach (before that, the true mass alone). At a periodic state that running mean
is zero and the law is the true mass's. The true mass alone (``du_f/dt = -G / (m + m_a)``) may
take over for good once the running mean is small (``switch``, :class:`Schedule`), or
``light_cycles`` periods after the approach at the latest.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from adapter.coupling.added_mass import HEAVE, SURGE, Inertia, spheroid_added_inertia
from adapter.coupling.frame import FrameState
from adapter.errors import CaseError
from adapter.jsonfiles import SYMMETRY_PLANE

#: the frame's log in a case's adapter/ folder (:class:`SurgeFrame`'s ``log_path``)
FRAME_LOG = "frame.dat"


@dataclass(frozen=True)
class Schedule:
    """When the free whale's speed starts to follow its forces, and the lighter mass early on."""

    release_s: float          #: the frame keeps its velocity until this time
    period_s: float           #: the stroke period: the running mean's window
    light: float = 1.0        #: the running mean's mass, fraction of m + m_a (1: none)
    light_cycles: float = 0.0  #: at most this many stroke periods after the approach
    #: ... or until, a period or more after the approach, the running mean of the force along
    #: x is under ``switch`` times ``reference_N`` (0: no early end)
    switch: float = 0.0
    reference_N: float = 0.0
    #: after the release the speed goes to ``approach_speed`` over this long (0: no approach)
    approach_s: float = 0.0
    approach_speed: float = 0.0

    def free_from(self) -> float:
        """When the momentum balance takes over: the release, after the approach."""
        return self.release_s + self.approach_s

    def light_until(self) -> float:
        return self.free_from() + self.light_cycles * self.period_s

    def settles(self, t: float, mean_x: float) -> bool:
        """Whether the lighter mass ends at ``t`` with this running mean along x."""
        return (self.switch > 0 and t >= self.free_from() + self.period_s
                and abs(mean_x) < self.switch * self.reference_N)

    def approach(self, t: float, start_speed: float) -> float:
        """The frame's speed at ``t`` during the approach: from ``start_speed`` at the release
        to ``approach_speed`` at its end along a half-cosine (no jump of the acceleration at
        either end beyond one step's)."""
        tau = min(max((t - self.release_s) / self.approach_s, 0.0), 1.0)
        return start_speed + (self.approach_speed - start_speed) * 0.5 * (1 - math.cos(
            math.pi * tau))


def release_speed(speed: float, drag: float, mean_fx: float) -> float:
    """An estimate of the self-propelled speed from the tethered pair at ``speed``: its gliding
    drag ``drag`` and its stroke's mean Fx ``mean_fx`` (negative: thrust to spare). The drag
    taken to grow as U^2 and the stroke's thrust power T U to stay what it was, the balance
    ``drag (U / speed)^2 = (drag - mean_fx) speed / U`` gives U^3 = speed^3 (1 - mean_fx /
    drag); ``speed`` itself when the pair says nothing (not finite, no drag, or no thrust),
    and within 0.5-2 times ``speed``. Only the approach uses it: the momentum balance finds
    the speed (docs/free-swimming.md, "The approach")."""
    if not (math.isfinite(speed) and math.isfinite(drag) and math.isfinite(mean_fx)
            and speed > 0 and drag > 0 and mean_fx < drag):
        return speed
    return speed * min(max((1.0 - mean_fx / drag) ** (1.0 / 3.0), 0.5), 2.0)


class SurgeFrame:
    """The whale's frame for the step-server (adapter/coupling/frame.py's Frame).

    Parameters
    ----------
    speed : the forward speed at the start (m/s): the frame's velocity is (speed, 0, 0).
    inertia : :class:`Inertia`.
    schedule : :class:`Schedule`.
    heave : the whale also moves up and down (z): the frame's vertical velocity under the swing
        of the vertical force about its running mean (the recoil; a slow trim, :data:`TRIM`,
        holds the mean depth).
    force_scale : the patch's share of the whole whale's force along x and z (2 on a half
        domain, whose patch is half the whale).
    log_path : a file that gets a row per new served time: time, the frame's velocity and
        acceleration along x and z, the whole whale's force along x and z (N), and 1 while the
        lighter mass acts (0 after), the pitch (rad); rows after a restored time are dropped
        at a restore.
    pitch : the pitch recoil (:class:`PitchRecoil`), None: none.
    backward : the flow's time scheme is backward (``case.time_scheme``): the body force the
        flow gets is backward's derivative of the frame velocities it is sent,
        ``(3 a_n - a_(n-1)) / 2`` for ``u_(n+1) = u_n + a_n dt``, not ``a_n`` (Euler's), so
        that the far field's acceleration and the body force agree (see
        :attr:`body_acceleration`).
    """

    def __init__(self, speed: float, inertia: Inertia, schedule: Schedule, heave: bool = False,
                 force_scale: float = 1.0, log_path: Path | None = None,
                 pitch: PitchRecoil | None = None, backward: bool = False):
        self.inertia = inertia
        self.backward = bool(backward)
        self.schedule = schedule
        self.axes = (SURGE, HEAVE) if heave else (SURGE,)
        self.force_scale = float(force_scale)
        self.t: float | None = None
        self.start_speed = float(speed)
        self.velocity = np.array([float(speed), 0.0, 0.0])
        self.acceleration = np.zeros(3)
        #: the acceleration of the velocity step before this one (backward's older level)
        self.previous_acceleration = np.zeros(3)
        self._means: deque = deque()   # (t, G along the free axes) over the last period
        #: when the true mass took over (None: not yet)
        self.true_from: float | None = None
        self.log_path = log_path
        self.pitch = pitch

    # --- the Frame interface -------------------------------------------------------------

    def answer(self, time: float, request):
        """The frame at ``time`` from the REQUEST's forces (those of the step that ended at the
        last served time); a first request (no forces: NaN) keeps the acceleration."""
        if self.t is None or time <= self.t or time <= self.schedule.release_s:
            self.t = time if self.t is None else max(self.t, time)
            return self._state_now()
        force = (np.asarray(request.pressure_force, float)
                 + np.asarray(request.viscous_force, float)) * self.force_scale
        approaching = self.schedule.approach_s > 0 and time <= self.schedule.free_from() + 1e-12
        if approaching:
            new = self._approach_acceleration(time)
        elif np.all(np.isfinite(force[list(self.axes)])):
            new = self._acceleration(force, self.t)
        else:
            new = self.acceleration.copy()
        self.previous_acceleration, self.acceleration = self.acceleration, new
        if self.pitch is not None and not approaching:
            moment = (np.asarray(request.pressure_moment, float)
                      + np.asarray(request.viscous_moment, float)) * self.force_scale
            about = moment[1] - float(np.cross(self.pitch.centre, force)[1])
            if np.isfinite(about):
                self.pitch.advance(about, self.t, time - self.t)
        self.velocity = self.velocity + self.acceleration * (time - self.t)
        self.t = time
        self._log(force)
        return self._state_now()

    def _approach_acceleration(self, time: float) -> np.ndarray:
        """The acceleration over a step of the approach: the one that reaches its prescribed
        speed (:meth:`Schedule.approach`) at ``time``; the forces are not heeded."""
        assert self.t is not None       # answer() served a time before
        new = np.zeros(3)
        new[SURGE] = (self.schedule.approach(time, self.start_speed)
                      - self.velocity[SURGE]) / (time - self.t)
        return new

    @property
    def body_acceleration(self) -> np.ndarray:
        """The body force per unit mass for the step the velocity was last advanced over: the
        time scheme's derivative of the frame velocity, Euler's ``a_n`` or backward's
        ``(3 u_(n+1) - 4 u_n + u_(n-1)) / (2 dt) = (3 a_n - a_(n-1)) / 2`` (a constant step).
        With ``a_n`` under backward the far field would accelerate by one and the body force
        push by the other; on a neutrally buoyant whale the difference's pressure force, the
        displaced mass times ``(a_n - a_(n-1)) / 2``, feeds a two-step swing that grows."""
        if not self.backward:
            return self.acceleration.copy()
        return 1.5 * self.acceleration - 0.5 * self.previous_acceleration

    def _state_now(self):
        if self.pitch is None:
            return FrameState(self.velocity.copy(), self.body_acceleration.copy())
        return FrameState(self.velocity.copy(), self.body_acceleration.copy(), self.pitch.theta,
                          self.pitch.centre)

    def _log(self, force: np.ndarray) -> None:
        if self.log_path is None:
            return
        new = not self.log_path.is_file()
        self.log_path.parent.mkdir(parents=True, exist_ok=True)
        light = float(self.light_now)
        with open(self.log_path, "a") as f:
            if new:
                f.write("# Time Ux Uz ax az Fx Fz light pitch (m/s, m/s2, N, rad; the whale's "
                        "frame)\n")
            pitch = self.pitch.theta if self.pitch is not None else 0.0
            row = (self.t, self.velocity[0], self.velocity[2], self.acceleration[0],
                   self.acceleration[2], force[0], force[2], light, pitch)
            f.write(" ".join(f"{v:.12g}" for v in row) + "\n")

    def state(self) -> dict:
        return {"t": self.t, "true_from": self.true_from, "velocity": self.velocity.tolist(),
                "acceleration": self.acceleration.tolist(),
                "previous_acceleration": self.previous_acceleration.tolist(),
                "means": [[t, list(g)] for t, g in self._means],
                **(self.pitch.state() if self.pitch is not None else {})}

    def restore(self, state: dict) -> None:
        self.t = state["t"]
        if self.log_path is not None and self.log_path.is_file() and self.t is not None:
            keep = [line for line in self.log_path.read_text().splitlines(keepends=True)
                    if line.startswith("#") or float(line.split()[0]) <= self.t]
            self.log_path.write_text("".join(keep))
        self.true_from = state["true_from"]
        self.velocity = np.array(state["velocity"], float)
        self.acceleration = np.array(state["acceleration"], float)
        # a state saved before the key existed was Euler's: the body force was the acceleration
        self.previous_acceleration = np.array(
            state.get("previous_acceleration", self.acceleration), float)
        self._means.clear()
        self._means.extend((t, np.array(g, float)) for t, g in state["means"])
        if self.pitch is not None:
            self.pitch.restore(state)

    # --- the law -------------------------------------------------------------------------

    def _acceleration(self, force: np.ndarray, t_force: float) -> np.ndarray:
        """du_f/dt over the next step from the force measured over the step ending at
        ``t_force`` (which ran with the current acceleration)."""
        axes = list(self.axes)
        total = np.array([self.inertia.mass_kg + self.inertia.added(a) for a in axes])
        added = np.array([self.inertia.added(a) for a in axes])
        rest = force[axes] - added * self.body_acceleration[axes]     # G
        window = self.schedule.period_s
        self._means.append((t_force, rest))
        while self._means and self._means[0][0] <= t_force - window:
            self._means.popleft()
        accel = np.zeros(3)
        mean = np.mean([g for _, g in self._means], axis=0)
        if self.true_from is None and (t_force >= self.schedule.light_until()
                                       or self.schedule.light >= 1.0
                                       or self.schedule.settles(t_force, mean[0])):
            self.true_from = t_force
        # the lighter mass acts once the running mean is a whole period's: a mean of the
        # first few samples after the release is the stroke's swing, which the lighter mass
        # would amplify fivefold (the true mass moves the speed meanwhile)
        whole = t_force >= self.schedule.free_from() + window * (1 - 1e-9)
        if self.true_from is None and whole:
            accel[axes] = -(rest - mean) / total - mean / (self.schedule.light * total)
        else:
            accel[axes] = -rest / total
        if HEAVE in self.axes:      # the recoil: the swing about the mean, the trim holds depth
            k = axes.index(HEAVE)
            w0 = TRIM * 2.0 * math.pi / self.schedule.period_s
            accel[HEAVE] = -(rest[k] - mean[k]) / total[k] - w0 * self.velocity[HEAVE]
        return accel

    @property
    def light_now(self) -> bool:
        return self.true_from is None and self.schedule.light < 1.0


#: the trim that holds the recoiling whale's mean attitude and depth (its flippers, not
#: modelled): a critically damped return at this fraction of the stroke's angular frequency,
#: slow beside the stroke (the recoil's swing at the stroke frequency changes by 1.6 %)
TRIM = 1.0 / 8.0


class PitchRecoil:
    """The whale's pitch about its centre of mass under the swing of its pitching moment:
    ``(I + I_a) d2(theta)/dt2 = (G - mean G)`` with ``G = M + I_a alpha_prev`` (the added
    inertia moved to the left as the surge's added mass is) and the trim's critically damped
    return (:data:`TRIM`). ``inertia`` and ``added`` in kg m2, ``centre`` (3,) in m."""

    def __init__(self, inertia: float, added: float, centre, period: float):
        self.total = float(inertia) + float(added)
        self.added = float(added)
        self.centre = np.asarray(centre, float)
        self.period = float(period)
        self.theta = self.omega = self.alpha = 0.0
        self._means: deque = deque()

    def advance(self, moment_y: float, t_force: float, dt: float) -> None:
        """One step from the pitching moment about the centre measured over the step ending at
        ``t_force`` (which ran with the current angular acceleration)."""
        rest = moment_y + self.added * self.alpha
        self._means.append((t_force, rest))
        while self._means and self._means[0][0] <= t_force - self.period:
            self._means.popleft()
        mean = float(np.mean([g for _, g in self._means]))
        w0 = TRIM * 2.0 * math.pi / self.period
        self.alpha = (rest - mean) / self.total - 2.0 * w0 * self.omega - w0 * w0 * self.theta
        self.omega += self.alpha * dt
        self.theta += self.omega * dt

    def state(self) -> dict:
        return {"pitch": self.theta, "pitch_rate": self.omega, "pitch_acceleration": self.alpha,
                "pitch_centre": self.centre.tolist(),
                "pitch_means": [[t, g] for t, g in self._means]}

    def restore(self, state: dict) -> None:
        self.theta, self.omega = float(state["pitch"]), float(state["pitch_rate"])
        self.alpha = float(state["pitch_acceleration"])
        self._means.clear()
        self._means.extend((float(t), float(g)) for t, g in state["pitch_means"])


# --- from a case's record ----------------------------------------------------------------------

def inertia_of(record: dict) -> Inertia:
    """The whale's mass (its enclosed volume at the water's density: neutrally buoyant) and
    added masses (``free.added_mass`` of the mass, 0: the prolate spheroid's, Lamb)."""
    body = record["body"]
    inertia = Inertia.of_body(float(body["volume_m3"]), float(body["length_m"]),
                              float(body["diameter_m"]), float(record["rho_kg_m3"]))
    share = float(record.get("free", {}).get("added_mass", 0.0))
    if share > 0:
        inertia = Inertia(inertia.mass_kg, share * inertia.mass_kg, inertia.added_heave_kg)
    return inertia


def frame_of(record: dict, log_path: Path | None = None) -> SurgeFrame | None:
    """The step-server's frame for a case record (adapter-case.json): a :class:`SurgeFrame`
    when the record says the whale is released (``free_release_s``), else None."""
    if "free_release_s" not in record:
        return None
    free = record["free"]
    schedule = Schedule(float(record["free_release_s"]), float(record["period_s"]),
                        float(free["light"]), float(free["light_cycles"]),
                        switch=float(free["light_switch"]),
                        reference_N=float(record["free_reference_drag_N"]),
                        approach_s=float(record.get("free_approach_s", 0.0)),
                        approach_speed=float(record.get("free_approach_speed_m_s", 0.0)))
    return SurgeFrame(float(record["speed_m_s"]), inertia_of(record), schedule,
                      heave=bool(free["heave"]),
                      force_scale=2.0 if record.get(SYMMETRY_PLANE) else 1.0,
                      log_path=log_path,
                      pitch=pitch_of(record) if free.get("pitch") else None,
                      backward=record.get("time_scheme", "Euler") == "backward")


def pitch_of(record: dict) -> PitchRecoil:
    """The pitch recoil of a case record's whale: its moment of inertia about y through its
    centroid at the water's density, and the prolate spheroid's added inertia (Lamb's k' on
    the whale's own volume, ``rho V (a^2 + b^2) / 5`` with a = L / 2, b = D / 2)."""
    body = record["body"]
    if "pitch_inertia_m5" not in body:
        raise CaseError("free.pitch needs the body's pitch inertia in the case record "
                        "(adapter-case.json); prepare the case again with this version")
    rho, volume = float(record["rho_kg_m3"]), float(body["volume_m3"])
    length, diameter = float(body["length_m"]), float(body["diameter_m"])
    added = spheroid_added_inertia(length, diameter) * rho * volume * (
        (length / 2) ** 2 + (diameter / 2) ** 2) / 5.0
    return PitchRecoil(rho * float(body["pitch_inertia_m5"]), added, body["centroid_m"],
                       float(record["period_s"]))
