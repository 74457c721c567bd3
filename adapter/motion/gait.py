"""The stroke: initial velocity profiles (paper section 3.1) and the fluke as a hinged gate.

Two ways to turn the stroke (``stroke.reversal``):

``"negate"`` (the paper's). A full cycle, quarter by quarter (each quarter lasts T / 4 for the
stroke period T):

    0. from the flat equilibrium, the *upward* profile as initial velocity;
    1. at the top of the upstroke every velocity is negated, and the whale runs back the same
       time toward equilibrium;
    2. the *downward* profile (the upward one negated) replaces the velocities;
    3. at the bottom every velocity is negated again.

Cycles repeat. Each event is an instantaneous change of every node's velocity.

``"smooth"`` (the default, for coupled runs). The same profile drives the same network, but as
a smooth target: every moving node is pushed along ``profile * G(t)``, the velocity of the
displacement ``profile * D(t)``, D(t) = r(t) sin(w t) / w, with r a quintic ramp from 0 to 1
over ``stroke.ramp_cycles`` (:class:`SmoothStroke`). The push is the acceleration that moves a
free unit mass along the target against the network's velocity force (damping between nodes
and the fluid resistance nu), ``profile G'(t) - damping(profile) G(t)``, with a tether toward
the target; both are a force term of the right-hand side, evaluated by the integrator at every
stage time (:func:`stroke_force`), so every method keeps its order. The springs and damping act
on top of it as in the paper. The wall velocity is continuous at the start and at every
reversal, and up and down strokes are mirror images.

The fluke (every node behind the tail base) is not part of the spring system: it is a gate
hinged at the tail base, shifted with it and rotated by the angle of a table interpolated in
time: piecewise linearly with ``"negate"``, by a periodic cubic spline (continuous angular
velocity) with ``"smooth"``. That is the paper's hinge, and it folds the surface at the tail
base; with ``stroke.fluke_joint`` > 0 (the default scene's 0.06) the surface shown draws the
peduncle over that length ahead of the tail base as a smooth blend from where the springs put
it to where the fluke's turn would carry it (:func:`joint_blend`,
:meth:`~adapter.motion.drive.StrokeDrive.shape`), so the surface, and the mesh layers on it, are
not creased, while the springs and the blades move as the paper has them. The gate is a
kinematic constraint: the integrators place it on every stage state at the stage's time
(:func:`drive_place`), and the animator after every step.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass, field
from pathlib import Path

import numba
import numpy as np

from adapter.errors import SceneError
from adapter.scene import DATA_DIR

#: what happens to the velocities at the start of each quarter of the cycle ("negate" stroke)
QUARTER_EVENTS = ("up", "negate", "down", "negate")
#: the ways the stroke turns (scene key ``stroke.reversal``)
REVERSALS = ("smooth", "negate")


def velocity_profile(s: np.ndarray, dynamic: np.ndarray, stroke, tail_base_s: float) -> np.ndarray:
    """(N,) upward initial speed of every node (m/s); zero on the fluke (kinematic) nodes.

    With u = (s - pivot) / (s_C - pivot) behind the pivot and w = (pivot - s) / pivot ahead:

    - tail region: ``tail_speed * u ** tail_exponent``;
    - head region: ``head_speed * w ** head_exponent * (w - d) / (1 - d)``, d being w at
      ``head_node``: the rostrum moves with the tail, while between ``head_node`` and the
      pivot (the flipper region) the body moves against them, as observed (paper, section 1);
      ``head_node = 0`` drops the dip.

    With ``recoil = "heave"`` the profile's mean over the moving nodes (unit masses) is removed
    too, so that the stroke carries no net vertical momentum.
    """
    p = stroke.pivot
    u = np.clip((s - p) / (tail_base_s - p), 0, None)
    w = np.clip((p - s) / p, 0, None)
    tail = stroke.tail_speed * u**stroke.tail_exponent
    if stroke.head_node > 0:
        d = (p - stroke.head_node) / p
        head = stroke.head_speed * w**stroke.head_exponent * (w - d) / (1 - d)
    else:
        head = stroke.head_speed * w ** stroke.head_exponent
    v = np.where(s >= p, tail, head)
    v = np.where(dynamic, v, 0.0)
    if stroke.recoil == "heave":
        v = np.where(dynamic, v - v[dynamic].mean(), 0.0)
    return stroke.velocity_scale * v


@dataclass(frozen=True)
class FlukeTable:
    """Fluke angle through one cycle: ``phase`` in [0, 1), ``angle`` in radians.

    ``spline=False`` interpolates piecewise linearly (the angular velocity jumps at every
    row), ``spline=True`` by a periodic cubic spline (angle and angular velocity continuous).
    """

    phase: np.ndarray
    angle: np.ndarray
    spline: bool = False
    # the periodic closure and the spline's coefficients, set in __post_init__
    _xp: list = field(init=False, repr=False, compare=False)
    _fp: list = field(init=False, repr=False, compare=False)
    _coef: list = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        # the periodic closure, built once as plain floats: the table is read at every
        # internal step, where numpy's per-call overhead would cost more than the lookup
        object.__setattr__(self, "_xp", [*map(float, self.phase), float(self.phase[0]) + 1.0])
        object.__setattr__(self, "_fp", [*map(float, self.angle), float(self.angle[0])])
        if self.spline:
            from scipy.interpolate import CubicSpline

            cs = CubicSpline(self._xp, self._fp, bc_type="periodic")
            # per segment: the four polynomial coefficients, as plain floats
            object.__setattr__(self, "_coef", [tuple(map(float, cs.c[:, k]))
                                               for k in range(cs.c.shape[1])])

    def _segment(self, phase: float) -> tuple[int, float]:
        """(k, phase in [0, 1) wrapped) with xp[k] <= phase < xp[k + 1]."""
        x = phase % 1.0
        if x < self._xp[0]:  # before the first row: the wrap-around segment
            x += 1.0
        k = min(max(bisect.bisect_right(self._xp, x) - 1, 0), len(self._xp) - 2)
        return k, x

    def __call__(self, phase: float) -> float:
        """Angle (rad) at a phase, periodic."""
        k, x = self._segment(phase)
        xp, fp = self._xp, self._fp
        if self.spline:
            a, b, c, d = self._coef[k]
            h = x - xp[k]
            return ((a * h + b) * h + c) * h + d
        return fp[k] + (fp[k + 1] - fp[k]) * (x - xp[k]) / (xp[k + 1] - xp[k])

    def rate(self, phase: float) -> float:
        """d angle / d phase (rad per cycle) of the interpolant."""
        k, x = self._segment(phase)
        xp, fp = self._xp, self._fp
        if self.spline:
            a, b, c, _ = self._coef[k]
            h = x - xp[k]
            return (3 * a * h + 2 * b) * h + c
        return (fp[k + 1] - fp[k]) / (xp[k + 1] - xp[k])


#: the fluke tables shipped with the package (scene key ``stroke.fluke_table``)
SHIPPED_TABLES = {"default": "fluke_angles.csv", "quadrature15": "fluke_angles_quadrature15.csv"}


def load_fluke_table(name: str, base_dir: str | Path = ".", scale: float = 1.0,
                     spline: bool = False) -> FlukeTable:
    """Read a fluke angle table: a shipped one (:data:`SHIPPED_TABLES`) or a CSV with columns
    ``phase,angle_deg``.

    Lines starting with ``#`` are comments. Phases must rise strictly within [0, 1).
    """
    if name in SHIPPED_TABLES:
        path = DATA_DIR / SHIPPED_TABLES[name]
    else:
        path = Path(base_dir) / name
    where = f"stroke.fluke_table ({path})"
    if not path.is_file():
        raise SceneError(f"{where}: file not found; give a CSV with columns phase,angle_deg")
    rows = [ln.strip() for ln in path.read_text().splitlines()
            if ln.strip() and not ln.lstrip().startswith("#")]
    if not rows or rows[0].replace(" ", "") != "phase,angle_deg":
        raise SceneError(f"{where}: the first row must be the header phase,angle_deg")
    try:
        data = np.array([[float(x) for x in r.split(",")] for r in rows[1:]])
    except ValueError as exc:
        raise SceneError(f"{where}: {exc}") from None
    if data.ndim != 2 or data.shape[1] != 2 or len(data) < 2:
        raise SceneError(f"{where}: expected at least two rows of two numbers")
    if not np.isfinite(data).all():
        raise SceneError(f"{where}: NaN or infinite values")
    phase, angle = data[:, 0], data[:, 1]
    if phase[0] < 0 or phase[-1] >= 1 or (np.diff(phase) <= 0).any():
        raise SceneError(f"{where}: phases must rise strictly within [0, 1)")
    if np.abs(angle).max() * scale >= 90:
        raise SceneError(f"{where}: angles must stay within +-90 degrees")
    return FlukeTable(phase, np.radians(angle * scale), spline=spline)


def ramp(t: float, duration: float) -> tuple[float, float]:
    """Start-up ramp (value, derivative): 0 -> 1 over ``duration`` as a cubic smoothstep.

    The whale starts flat (paper, section 3.1) while the table may start pitched; the ramp
    brings the fluke angle in without a jump in the geometry handed to a flow solver.
    """
    if duration <= 0 or t >= duration:
        return 1.0, 0.0
    x = max(t, 0.0) / duration
    return x * x * (3 - 2 * x), 6 * x * (1 - x) / duration


def smootherstep(t: float, duration: float) -> tuple[float, float, float]:
    """Start-up ramp (value, first and second derivative): 0 -> 1 over ``duration`` as the
    quintic 10 x^3 - 15 x^4 + 6 x^5, whose first and second derivatives vanish at both ends."""
    if duration <= 0 or t >= duration:
        return 1.0, 0.0, 0.0
    x = max(t, 0.0) / duration
    return (x**3 * (10 - 15 * x + 6 * x * x), 30 * x * x * (1 - x) ** 2 / duration,
            60 * x * (1 - x) * (1 - 2 * x) / duration**2)


class SmoothStroke:
    """The smooth stroke's time law per unit profile speed (m/s): the target displacement
    ``D(t) = r(t) sin(w t) / w`` and its velocity ``G(t) = D'(t)``, w = 2 pi / period, r the
    quintic ramp over ``ramp_s`` (:func:`smootherstep`). Phase 0 is the tail at rest moving
    up, 0.25 the top, 0.75 the bottom, as for the fluke table."""

    def __init__(self, period: float, ramp_s: float):
        self.omega = 2 * math.pi / period
        self.ramp_s = ramp_s

    def displacement(self, t: float) -> float:
        r = smootherstep(t, self.ramp_s)[0]
        return r * math.sin(self.omega * t) / self.omega

    def velocity(self, t: float) -> float:
        r, r1, _ = smootherstep(t, self.ramp_s)
        w = self.omega
        return r1 * math.sin(w * t) / w + r * math.cos(w * t)

    def acceleration(self, t: float) -> float:
        """G'(t)."""
        r, r1, r2 = smootherstep(t, self.ramp_s)
        w = self.omega
        s, c = math.sin(w * t), math.cos(w * t)
        return r2 * s / w + 2 * r1 * c - r * w * s

    def at(self, t: float) -> tuple[float, float, float]:
        """(G'(t), G(t), D(t)) in one go (the right-hand side's coefficients)."""
        r, r1, r2 = smootherstep(t, self.ramp_s)
        w = self.omega
        s, c = math.sin(w * t), math.cos(w * t)
        return r2 * s / w + 2 * r1 * c - r * w * s, r1 * s / w + r * c, r * s / w


def rotation_y(theta: float) -> np.ndarray:
    """Rotation in the x-z plane that raises +x toward +z by ``theta`` (rad)."""
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, 0.0, -s], [0.0, 1.0, 0.0], [s, 0.0, c]])


@numba.njit(cache=True, error_model="numpy")
def stroke_force(X, V, out, rest, moving, profile, damping, g_dot, g, d, k, c):
    """Add the smooth stroke's force at one time to ``out`` (in place), on the moving nodes.

    For every moving node a (index ``moving[a]``): the push ``profile G'(t) - damping G(t)``
    on its vertical acceleration (the target's acceleration less the network's velocity force
    on the target), and the tether ``-k (x - x_target) - c (v - v_target)`` with
    ``x_target = rest + profile D(t) e_z`` and ``v_target = profile G(t) e_z``
    (see :class:`SmoothStroke`; ``g_dot, g, d`` are G'(t), G(t), D(t)). A term of the
    right-hand side: the integrators evaluate it at every stage time (:func:`drive_stage`)."""
    for a in range(moving.shape[0]):
        i = moving[a]
        p = profile[a]
        out[i, 0] -= k * (X[i, 0] - rest[i, 0]) + c * V[i, 0]
        out[i, 1] -= k * (X[i, 1] - rest[i, 1]) + c * V[i, 1]
        out[i, 2] += (g_dot * p - g * damping[a]
                      - k * (X[i, 2] - rest[i, 2] - d * p) - c * (V[i, 2] - g * p))


@numba.njit(cache=True, error_model="numpy")
def place_gate(X, V, rest, hinge_nodes, fluke_nodes, arm0, hinge0, theta, theta_dot):
    """Place the paper's fluke gate (in place): every fluke node turned rigidly by the
    table's angle about the hinge, which moves with the spring nodes just ahead of the tail
    base (``hinge_nodes``; ``hinge0`` their mean at rest).

    Gate node m is placed at ``rest + shift + (R(theta) - I) arm0[m]``: ``shift`` the hinge
    nodes' mean displacement, ``arm0`` the node's rest position less ``hinge0`` and R the turn
    of :func:`rotation_y` (written so that the flat pose is exactly the rest). Velocities are
    the time derivative of the same expression.
    """
    hx = hy = hz = vx = vy = vz = 0.0
    for k in hinge_nodes:
        hx += X[k, 0]
        hy += X[k, 1]
        hz += X[k, 2]
        vx += V[k, 0]
        vy += V[k, 1]
        vz += V[k, 2]
    n = hinge_nodes.shape[0]
    sx, sy, sz = hx / n - hinge0[0], hy / n - hinge0[1], hz / n - hinge0[2]
    vx, vy, vz = vx / n, vy / n, vz / n
    c, s = np.cos(theta), np.sin(theta)
    for m in range(fluke_nodes.shape[0]):
        i = fluke_nodes[m]
        ax, az = arm0[m, 0], arm0[m, 2]
        rx = c * ax - s * az
        rz = s * ax + c * az
        X[i, 0] = rest[i, 0] + sx + (rx - ax)
        X[i, 1] = rest[i, 1] + sy
        X[i, 2] = rest[i, 2] + sz + (rz - az)
        V[i, 0] = vx - theta_dot * rz
        V[i, 1] = vy
        V[i, 2] = vz + theta_dot * rx


@numba.njit(cache=True, error_model="numpy")
def drive_place(X, V, drive, coef):
    """Place the fluke gate on a stage state (X, V, in place) at the stage's time: the fluke
    is a kinematic constraint, so the springs attached to it must see it where it is at that
    time, inside the step and not only after it.

    ``drive`` is :attr:`~adapter.motion.drive.StrokeDrive.stage_arrays` (rest, moving, profile,
    damping, (k, c), hinge nodes, gate nodes, arms, hinge0), ``coef`` the row
    (G'(t), G(t), D(t), theta(t), theta'(t)) at the stage's time t."""
    rest, _, _, _, _, hinge, fluke, arm0, hinge0 = drive
    if fluke.shape[0] > 0:
        place_gate(X, V, rest, hinge, fluke, arm0, hinge0, coef[3], coef[4])


@numba.njit(cache=True, error_model="numpy")
def drive_force(X, V, out, drive, coef):
    """Add the stroke's force at the stage's time to ``out`` (the network's force at the stage
    state): :func:`stroke_force` with the arrays of ``drive`` and the row ``coef`` (see
    :func:`drive_place`)."""
    rest, moving, profile, damping, kc, _, _, _, _ = drive
    stroke_force(X, V, out, rest, moving, profile, damping, coef[0], coef[1], coef[2],
                 kc[0], kc[1])


def joint_blend(s: np.ndarray, tail_base_s: float, joint: float) -> np.ndarray:
    """How far each node of the drawn surface has gone over from where the springs put it to
    the fluke's rigid turn (the b of :meth:`~adapter.motion.drive.StrokeDrive.shape`): 1 on
    the fluke (behind the tail base); over a joint of
    length ``joint`` (fraction of L) ahead of the tail base, the quintic
    :func:`smootherstep` of ``(s - (tail_base - joint)) / joint``, 0 where the joint meets
    the spring-driven body (no crease there), 1 at the tail base (none there either)."""
    if joint <= 0:
        return np.ones_like(s)
    u = np.clip((s - (tail_base_s - joint)) / joint, 0.0, 1.0)
    return u**3 * (10 - 15 * u + 6 * u * u)
