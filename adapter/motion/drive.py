"""The whale's drive: the stroke and the fluke gate, the time-dependent part of the motion.

:class:`StrokeDrive` is what the integrators take as ``drive=`` (Integrator.step): the arrays
of the time-aware right-hand side (:attr:`StrokeDrive.stage_arrays`, the layout of
gait.drive_place / gait.drive_force) and their coefficients at every stage time
(:meth:`StrokeDrive.stage_coefficients`). It also places the fluke gate on a state
(:meth:`StrokeDrive.place`), draws the joint on the surface the whale shows
(:meth:`StrokeDrive.shape`) and, for the paper's stroke, applies the velocity events at the
quarter strokes (:meth:`StrokeDrive.event`). The animator owns one.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from adapter.errors import GeometryError
from adapter.motion.gait import (
    QUARTER_EVENTS,
    SmoothStroke,
    joint_blend,
    load_fluke_table,
    place_gate,
    ramp,
    smootherstep,
)


def _floats(a) -> np.ndarray:
    """A contiguous float64 array: the numba kernels' type for values."""
    return np.ascontiguousarray(a, dtype=np.float64)


def _labels(a) -> np.ndarray:
    """A contiguous int64 array: the numba kernels' type for node labels."""
    return np.ascontiguousarray(a, dtype=np.int64)


class DriveArrays(NamedTuple):
    """The arrays of the time-aware right-hand side, the ``drive`` of every compiled kernel
    (adapter.motion.kernels) and of gait.drive_place / gait.drive_force, which unpack it in
    this order (numba takes a named tuple as a tuple). M moving nodes (none for the paper's
    stroke, which has no force), F fluke nodes."""

    #: (N, 3) rest positions (m)
    rest: np.ndarray
    #: (M,) int64, the nodes the smooth stroke pushes and tethers
    moving: np.ndarray
    #: (M,) their velocity profile (m/s, gait.velocity_profile)
    profile: np.ndarray
    #: (M,) the network's damping force on the profile, which the push cancels
    damping: np.ndarray
    #: (2,) the tether's (k, c): stiffness (1/s2) and damping (1/s) on every moving node
    tether: np.ndarray
    #: (H,) int64, the spring nodes just ahead of the tail base whose mean carries the hinge
    hinge_nodes: np.ndarray
    #: (F,) int64, the fluke gate's nodes (behind the tail base)
    fluke_nodes: np.ndarray
    #: (F, 3) their arms from the hinge at rest (m)
    arm0: np.ndarray
    #: (3,) the hinge nodes' mean at rest (m)
    hinge0: np.ndarray

    @classmethod
    def none(cls) -> DriveArrays:
        """The drive of a free network: no stroke force, no kinematic nodes."""
        nodes, values = np.zeros(0, dtype=np.int64), np.zeros(0)
        return cls(np.zeros((0, 3)), nodes, values, values, np.zeros(2), nodes, nodes,
                   np.zeros((0, 3)), np.zeros(3))


#: half the depth (fraction of L) of the band of body nodes just ahead of the tail base whose
#: mean motion carries the fluke hinge
HINGE_BAND = 0.015


class StrokeDrive:
    """The stroke and the fluke gate of one whale.

    Parameters
    ----------
    scene : :class:`~adapter.scene.Scene` (its ``stroke`` and period).
    rest : (N, 3) rest positions (m).
    s : (N,) position of every node along the body, fraction of L.
    tail_base_s : s of the tail base (the fluke hinge).
    dynamic : (N,) bool, the nodes the springs move (the rest, behind the tail base, are the
        fluke gate's).
    profile : (N,) the stroke's velocity profile (m/s, gait.velocity_profile).
    network : the :class:`~adapter.body.springs.SpringNetwork` (its damping force on the
        profile, which the smooth stroke's push cancels).
    """

    def __init__(self, scene, rest, s, tail_base_s, dynamic, profile, network):
        self.rest, self.dynamic, self.profile = rest, dynamic, profile
        # the paper's hinge: the mean of the body nodes just ahead of the tail base
        band = dynamic & (s > tail_base_s - 2 * HINGE_BAND)
        if band.sum() < 3:
            raise GeometryError(
                "too few body nodes just ahead of the tail base to carry the fluke hinge; "
                "check geometry.landmarks.tail_base"
            )
        self.hinge_nodes = np.flatnonzero(band)
        self.hinge0 = rest[self.hinge_nodes].mean(axis=0)
        self._fluke_nodes = np.flatnonzero(~dynamic)
        self._fluke_arm = rest[self._fluke_nodes] - self.hinge0
        joint = scene.stroke.fluke_joint
        #: the nodes the joint draws (the peduncle within ``fluke_joint`` of the tail base,
        #: and the fluke), each with its share b of the fluke's turn (:meth:`shape`)
        self.joint_nodes = np.flatnonzero(s > tail_base_s - joint) if joint > 0 else _labels(())
        self._joint_b = joint_blend(s[self.joint_nodes], tail_base_s, joint)[:, None]
        self._joint_arm = rest[self.joint_nodes] - self.hinge0
        st = scene.stroke
        #: "smooth" (a continuous push along the profile) or "negate" (the paper's events)
        self.reversal = st.reversal
        self.smooth = st.reversal == "smooth"
        self.fluke_table = load_fluke_table(st.fluke_table, scene.base_dir,
                                            st.fluke_angle_scale, spline=self.smooth)
        self.period = scene.period_s
        #: the start-up: the fluke angle (and, smooth, the stroke) ramps in over it (s)
        self.ramp_s = (st.ramp_cycles if self.smooth else st.fluke_ramp) * self.period
        self._stroke = SmoothStroke(self.period, self.ramp_s)
        moving = np.flatnonzero(dynamic)
        #: smooth: the velocity force of the network on the target per unit G(t): the push
        #: cancels it (damping between nodes and the fluid resistance nu)
        moving_damping = network.damping_force(profile)[moving]
        w_t = 2 * math.pi * st.tether * st.frequency_hz
        #: (k, c): the smooth stroke's tether, a stiffness and a damping on every moving node
        self.tether = (w_t * w_t, 2 * w_t)
        # the paper's stroke has no force, only the gate
        some = moving if self.smooth else _labels(())
        #: the arrays of the time-aware right-hand side (integrators.Integrator.step)
        self.stage_arrays = DriveArrays(
            _floats(rest), _labels(some), _floats(profile[moving][: len(some)]),
            _floats(moving_damping[: len(some)]), _floats(self.tether),
            _labels(self.hinge_nodes), _labels(self._fluke_nodes), _floats(self._fluke_arm),
            _floats(self.hinge0))

    def stage_coefficients(self, t: float, dt: float, stages) -> np.ndarray:
        """(len(stages), 5) rows (G'(s), G(s), D(s), theta(s), theta'(s)) at the stage times
        s = t + c dt of an integrator step (c in ``stages``): the smooth stroke's time law
        (gait.SmoothStroke; zero for the paper's stroke, whose events are not a force) and the
        fluke gate's angle. The first stage is the state handed in, already gated: its angle
        is not needed."""
        out = np.zeros((len(stages), 5))
        for k, c in enumerate(stages):
            ts = t + c * dt
            if self.smooth:
                out[k, :3] = self._stroke.at(ts)
            if k:
                out[k, 3:] = self.fluke_angle(ts)
        return out

    def fluke_angle(self, t: float) -> tuple[float, float]:
        """(angle, angular velocity) of the fluke gate at time t (rad, rad/s), ramp included."""
        phase = t / self.period
        if self.smooth:
            r, r_dot = smootherstep(t, self.ramp_s)[:2]
        else:
            r, r_dot = ramp(t, self.ramp_s)
        angle = self.fluke_table(phase)
        return r * angle, r * self.fluke_table.rate(phase) / self.period + r_dot * angle

    def place(self, X: np.ndarray, V: np.ndarray, t: float) -> None:
        """Place the fluke gate, in place: shifted with the hinge, rotated by the table's angle
        at t."""
        theta, theta_dot = self.fluke_angle(t)
        place_gate(X, V, self.rest, self.hinge_nodes, self._fluke_nodes, self._fluke_arm,
                   self.hinge0, theta, theta_dot)

    def shape(self, X: np.ndarray, V: np.ndarray | None, t: float):
        """The surface the whale shows at t, from its state (X, V) at t: the state itself with
        the paper's hinge, else new arrays with the joint drawn (V None: positions only).

        The state is the paper's: the springs move the body up to the tail base and the gate
        turns the fluke about the hinge, which folds the surface there. The joint bends it
        instead: node m of :attr:`joint_nodes` is shown at

            (1 - b_m) X_m + b_m (hinge + R(theta) arm_m)

        the blend (b_m of :func:`~adapter.motion.gait.joint_blend`: 0 where the joint meets
        the body, 1 at the tail base and on the fluke) of where the springs put it and where
        the gate would, turning it rigidly with the fluke about the hinge. So the blades are
        the paper's gate whatever the joint's length, and only the peduncle's surface within
        the joint is drawn. Velocities are the time derivative of the same expression."""
        if not len(self.joint_nodes):
            return X, V
        theta, theta_dot = self.fluke_angle(t)
        c, s = math.cos(theta), math.sin(theta)
        hinge = X[self.hinge_nodes].mean(axis=0)
        ax, ay, az = self._joint_arm.T
        rx, rz = c * ax - s * az, s * ax + c * az
        gate = np.column_stack([hinge[0] + rx, hinge[1] + ay, hinge[2] + rz])
        b, k = self._joint_b, self.joint_nodes
        Xs = X.copy()
        Xs[k] = (1 - b) * X[k] + b * gate
        if V is None:
            return Xs, None
        v = V[self.hinge_nodes].mean(axis=0)
        gate_v = np.column_stack([v[0] - theta_dot * rz, np.full_like(rx, v[1]),
                                  v[2] + theta_dot * rx])
        Vs = V.copy()
        Vs[k] = (1 - b) * V[k] + b * gate_v
        return Xs, Vs

    def event(self, V: np.ndarray, n: int, steps_per_quarter: int) -> None:
        """The stroke's velocity change (in place) on arriving at internal step ``n``.

        Smooth: none; the push and the tether are a force in the integrator's right-hand side
        (:meth:`stage_coefficients`, gait.stroke_force), evaluated at every stage time.
        Negate: the event at the start of each quarter (gait.QUARTER_EVENTS)."""
        if self.smooth or n % steps_per_quarter:
            return
        what = QUARTER_EVENTS[(n // steps_per_quarter) % 4]
        dyn = self.dynamic
        if what == "negate":
            V[dyn] = -V[dyn]
        else:
            sign = 1.0 if what == "up" else -1.0
            V[dyn] = 0.0
            V[dyn, 2] = sign * self.profile[dyn]
