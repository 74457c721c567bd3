"""A rigid prescribed motion: any closed body translated and turned as a closed form of time.

The scene's ``[rigid]`` section (:class:`~adapter.scene.Rigid`) gives a translation
``x(t) = r(t) A sin(w t + phi_x)`` and a turn ``theta(t) = r(t) Theta sin(w t + phi_theta)``
about the axis ``n`` through the centre ``c`` (right-hand rule), ``w = 2 pi f`` and ``r(t)`` the
ramp from 0 to 1 over ``ramp_cycles`` (the quintic smoothstep of
:func:`~adapter.motion.gait.smootherstep`, so that velocity and
acceleration start from zero). A point ``p`` of the body at rest is at

    ``c + x(t) + R(theta(t)) (p - c)``,

so its displacement is ``x + (R - I)(p - c)`` and its velocity ``x' + theta' n x R (p - c)``.
:class:`RigidMotion` has the animator's interface (:class:`~adapter.motion.animator.Animator`:
``displacement(t)``, ``velocity(t)``, ``checkpoint``/``restore``/``reset``), so the
step-server serves it unchanged; it keeps no state but the latest time asked for, and its
answer at t is exact, whatever was asked before.
"""

from __future__ import annotations

import math

import numpy as np

from adapter.body.geometry import build_surface
from adapter.motion.gait import smootherstep

#: the bookkeeping step (s) is the period over this: the timeline's "behind" test and the
#: server's log use it; the motion itself has no step
STEPS_PER_CYCLE = 1000


def rotation_matrix(axis: np.ndarray, angle: float) -> np.ndarray:
    """The rotation by ``angle`` (rad) about the unit ``axis`` (Rodrigues' formula)."""
    n = np.asarray(axis, dtype=np.float64)
    k = np.array([[0.0, -n[2], n[1]], [n[2], 0.0, -n[0]], [-n[1], n[0], 0.0]])
    return np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * (k @ k)


class RigidLaw:
    """The scene's rigid motion as functions of time: translation, angle and their rates."""

    def __init__(self, rigid):
        self.omega = 2 * math.pi * rigid.frequency_hz
        self.amplitude = np.asarray(rigid.translation_m, dtype=np.float64)
        self.phase_x = math.radians(rigid.translation_phase_deg)
        self.theta0 = math.radians(rigid.rotation_deg)
        self.phase_theta = math.radians(rigid.rotation_phase_deg)
        axis = np.asarray(rigid.rotation_axis, dtype=np.float64)
        self.axis = axis / np.linalg.norm(axis)
        self.centre = np.asarray(rigid.rotation_centre_m, dtype=np.float64)
        self.ramp_s = rigid.ramp_cycles / rigid.frequency_hz

    def _wave(self, t: float, phase: float) -> tuple[float, float, float]:
        """(s, s', s'') of r(t) sin(w t + phase)."""
        r, dr, d2r = smootherstep(t, self.ramp_s)
        w = self.omega
        sn, cs = math.sin(w * t + phase), math.cos(w * t + phase)
        return (r * sn, dr * sn + r * w * cs,
                d2r * sn + 2 * dr * w * cs - r * w * w * sn)

    def translation(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(x, x', x'') of the translation at t (m, m/s, m/s2)."""
        x, v, a = self._wave(t, self.phase_x)
        return x * self.amplitude, v * self.amplitude, a * self.amplitude

    def angle(self, t: float) -> tuple[float, float, float]:
        """(theta, theta', theta'') of the turn at t (rad, rad/s, rad/s2)."""
        th, w, dw = self._wave(t, self.phase_theta)
        return th * self.theta0, w * self.theta0, dw * self.theta0

    def displacement(self, points: np.ndarray, t: float) -> np.ndarray:
        """(N, 3) displacement at t of the body's points at rest ``points``."""
        x = self.translation(t)[0]
        arm = points - self.centre
        rot = rotation_matrix(self.axis, self.angle(t)[0])
        return x + arm @ (rot - np.eye(3)).T

    def velocity(self, points: np.ndarray, t: float) -> np.ndarray:
        """(N, 3) velocity at t of the body's points at rest ``points``."""
        dx = self.translation(t)[1]
        theta, dtheta, _ = self.angle(t)
        turned = (points - self.centre) @ rotation_matrix(self.axis, theta).T
        return dx + np.cross(dtheta * self.axis, turned)


class RigidMotion:
    """A closed body moved by the scene's rigid law, with the animator's interface.

    Parameters
    ----------
    scene : a :class:`~adapter.scene.Scene` with ``rigid.enabled``.
    surface : its :class:`~adapter.body.surface.WhaleSurface` (built from the scene if omitted).
    """

    def __init__(self, scene, surface=None):
        self.scene = scene
        self.surface = surface if surface is not None else build_surface(scene)
        self.rest = self.surface.points
        self.law = RigidLaw(scene.rigid)
        self.period = scene.period_s
        self.dt = self.period / STEPS_PER_CYCLE
        self._t = 0.0

    @property
    def time(self) -> float:
        """The latest time asked for (s)."""
        return self._t

    def reset(self) -> None:
        self._t = 0.0

    def checkpoint(self) -> dict:
        return {"time": np.float64(self._t), "dt": np.float64(self.dt)}

    def restore(self, ckpt: dict) -> None:
        self._t = float(ckpt["time"])

    def displacement(self, t: float) -> np.ndarray:
        """(N, 3) displacement (m) of every node from rest at time t (s)."""
        self._t = float(t)
        return self.law.displacement(self.rest, t)

    def velocity(self, t: float) -> np.ndarray:
        """(N, 3) node velocities (m/s) at time t (s)."""
        self._t = float(t)
        return self.law.velocity(self.rest, t)
