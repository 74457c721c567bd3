"""The animator: marches the spring-mass whale forward and hands out displacements.

Asked for a time t, :class:`Animator` advances its one current state with a fixed internal
step ``dt`` (a whole fraction of the quarter stroke, so the stroke's events fall on steps) and
returns the displacement of every node from rest, interpolated linearly between the two
internal steps around t. The answer depends on t alone, not on how often or at which times
the animator was asked, so a flow solver with any time step, or a restart, sees the same
motion. No history of steps is kept: the state is the positions and velocities now and one
step back.
"""

from __future__ import annotations

import math

import numpy as np

from adapter.body.geometry import build_surface
from adapter.body.springs import network_from_edges, region_constants
from adapter.errors import GeometryError, SceneError, UnstableError
from adapter.motion.gait import (
    QUARTER_EVENTS,
    SmoothStroke,
    joint_bend,
    load_fluke_table,
    place_gate,
    ramp,
    smootherstep,
    velocity_profile,
)
from adapter.motion.integrators import make_integrator
from adapter.motion.stability import stable_dt

#: half-width (fraction of L) of the band of body nodes just ahead of the tail base whose
#: mean motion carries the fluke hinge
HINGE_BAND = 0.015


class Animator:
    """The whale of a scene, advanced incrementally.

    Parameters
    ----------
    scene : :class:`~adapter.scene.Scene`.
    surface : the :class:`~adapter.body.surface.WhaleSurface` to animate (built from the scene if
        omitted).
    """

    def __init__(self, scene, surface=None):
        self.scene = scene
        self.surface = surface if surface is not None else build_surface(scene)
        surf = self.surface
        self.rest = surf.points
        s = surf.s
        self.tail_base_s = float(s[surf.landmarks["tail_base"]])
        #: fluke nodes (behind the tail base) move as a hinged gate, not as springs
        self.fluke = s > self.tail_base_s
        self.dynamic = ~self.fluke
        band = self.dynamic & (s > self.tail_base_s - 2 * HINGE_BAND)
        if band.sum() < 3:
            raise GeometryError(
                "too few body nodes just ahead of the tail base to carry the fluke hinge; "
                "check geometry.landmarks.tail_base"
            )
        self.hinge_nodes = np.flatnonzero(band)
        self.hinge0 = self.rest[self.hinge_nodes].mean(axis=0)
        self._fluke_nodes = np.flatnonzero(self.fluke)
        self._fluke_arm = self.rest[self._fluke_nodes] - self.hinge0
        #: the share of the fluke angle each fluke node turns by (1: the paper's hinge)
        self._fluke_bend = joint_bend(s[self._fluke_nodes], self.tail_base_s,
                                      scene.stroke.fluke_joint)

        sp_ = scene.springs
        r = scene.regions
        k = region_constants(s, r.head_end, r.tail_start, sp_.k_head, sp_.k_pivot, sp_.k_tail,
                             sp_.transition) * sp_.stiffness_scale
        self.network = network_from_edges(self.rest, surf.edges, k, sp_.mu, sp_.nu, sp_.form)
        self.profile = velocity_profile(s, self.dynamic, scene.stroke, self.tail_base_s)
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
        self._moving = np.flatnonzero(self.dynamic)
        self._moving_profile = self.profile[self._moving]
        #: smooth: the velocity force of the network on the target per unit G(t): the push
        #: cancels it (damping between nodes and the fluid resistance nu)
        self._moving_damping = self.network.damping_force(self.profile)[self._moving]
        w_t = 2 * math.pi * st.tether * st.frequency_hz
        self._tether_k, self._tether_c = w_t * w_t, 2 * w_t
        # the stroke's part of the right-hand side, for the integrators' stages (the layout of
        # gait.drive_place / drive_force); the paper's stroke has no force, only the gate
        some = self._moving if self.smooth else np.zeros(0, dtype=np.int64)
        c64 = np.ascontiguousarray
        #: (rest, moving, profile, damping, (k, c), hinge nodes, fluke nodes, arms, hinge0,
        #: bend): the arrays of the time-aware right-hand side (integrators.Integrator.step)
        self.stage_arrays = (
            c64(self.rest, dtype=np.float64), c64(some, dtype=np.int64),
            c64(self._moving_profile[: len(some)], dtype=np.float64),
            c64(self._moving_damping[: len(some)], dtype=np.float64),
            np.array([self._tether_k, self._tether_c], dtype=np.float64),
            c64(self.hinge_nodes, dtype=np.int64), c64(self._fluke_nodes, dtype=np.int64),
            c64(self._fluke_arm, dtype=np.float64), c64(self.hinge0, dtype=np.float64),
            c64(self._fluke_bend, dtype=np.float64))

        method = scene.integrator.method
        # predicted on the free (spring-moved) nodes; the fluke gate is kinematic. The smooth
        # stroke's tether is stiffness and damping in the right-hand side: the smaller of the
        # steps with and without it (its damping lowers symplectic Euler's and Verlet's bound
        # by 5-7 %, and would allow forward Euler 3 times its step: kept as it was)
        self.stable_dt = stable_dt(self.network, self.rest, method, free=self.dynamic)
        if self.smooth and self._tether_k > 0:
            self.stable_dt = min(self.stable_dt, stable_dt(
                self.network, self.rest, method, free=self.dynamic,
                tether=(self._tether_k, self._tether_c)))
        quarter = self.period / 4
        if scene.integrator.dt_s > 0:
            target = scene.integrator.dt_s
            if target > self.stable_dt:
                raise UnstableError(
                    f"integrator.dt_s = {target:.3g} s is beyond the largest stable step "
                    f"predicted for {method}, {self.stable_dt:.3g} s: the run would blow up; "
                    "lower integrator.dt_s, set it to 0 to use the predicted step times "
                    "integrator.safety, or choose another integrator.method"
                )
        elif self.stable_dt > 0:
            target = scene.integrator.safety * min(self.stable_dt, quarter)
            if self.smooth:
                # resolve the stroke's and the tether's time scales (a few % of a radian per
                # step), so that every method's time error stays small at its default step
                target = min(target, 0.05 / max(math.sqrt(self._tether_k), 2 * math.pi
                                                / self.period))
        else:
            raise SceneError(
                f"integrator.method = {method} has no stable step with springs.mu = "
                f"{sp_.mu} and springs.nu = {sp_.nu} (forward Euler needs damping); raise mu"
            )
        #: internal steps per quarter stroke, and the internal step (s)
        self.steps_per_quarter = max(1, math.ceil(quarter / target - 1e-9))
        self.dt = quarter / self.steps_per_quarter
        self.integrator = make_integrator(
            method, self.network.forces, self.dt, runaway=2.0 * surf.length,
            reference=self.rest, stable_dt=self.stable_dt, network=self.network,
            reuse_buffers=True,
        )
        self.reset()

    @classmethod
    def with_integrator(cls, scene, method: str | None = None, dt: float | None = None,
                        nodes: int | None = None, **springs) -> Animator:
        """The whale of ``scene`` (with ``nodes`` surface nodes and the ``springs`` entries
        changed, if given) run by ``method`` at the step nearest ``dt`` (s) that divides the
        quarter stroke, with no stability check: for the studies.

        Without ``method`` the whale runs forward Euler at its predicted step; without ``dt``
        ``method`` runs at that step.
        """
        changes = {}
        if nodes:
            changes["geometry"] = {"nodes": nodes}
        if springs:
            changes["springs"] = springs
        sc = scene.replace(**changes) if changes else scene
        # a safe step for construction; set_integrator replaces it
        a = cls(sc.replace(integrator={"method": "forward_euler", "dt_s": 0.0}))
        if method is not None:
            a.set_integrator(method, dt or a.integrator.dt)
        return a

    def set_integrator(self, method: str, dt: float) -> None:
        """Run with the integrator ``method`` at the step nearest ``dt`` (s) that divides the
        quarter stroke (no stability check: for the studies), and reset to t = 0."""
        quarter = self.period / 4
        self.steps_per_quarter = max(1, int(round(quarter / dt)))
        self.dt = quarter / self.steps_per_quarter
        self.integrator = make_integrator(method, self.network.forces, self.dt,
                                          runaway=2.0 * self.surface.length, reference=self.rest,
                                          stable_dt=self.stable_dt, network=self.network)
        self.reset()

    # -- state ------------------------------------------------------------------------------

    def reset(self) -> None:
        """Back to t = 0: the flat equilibrium with the upward profile as velocity."""
        self.integrator.restart(n_steps=0)
        self.step_index = 0
        self.X = self.rest.copy()
        self.V = np.zeros_like(self.rest)
        self._constrain(self.X, self.V, 0.0)
        self._event(0)
        self.X_prev, self.V_prev = self.X, self.V

    @property
    def time(self) -> float:
        """Time (s) of the current internal state."""
        return self.step_index * self.dt

    def checkpoint(self) -> dict:
        """The whole state, as arrays; :meth:`restore` returns to it exactly."""
        return {"step_index": np.int64(self.step_index), "X": self.X.copy(),
                "V": self.V.copy(), "X_prev": self.X_prev.copy(), "V_prev": self.V_prev.copy(),
                "dt": np.float64(self.dt)}

    def restore(self, ckpt: dict) -> None:
        """Return to a state taken by :meth:`checkpoint` (of an animator of the same scene)."""
        if float(ckpt["dt"]) != self.dt or ckpt["X"].shape != self.X.shape:
            raise ValueError("the checkpoint belongs to another scene (step or node count differ)")
        self.integrator.restart()
        self.step_index = int(ckpt["step_index"])
        self.X, self.V = ckpt["X"].copy(), ckpt["V"].copy()
        self.X_prev, self.V_prev = ckpt["X_prev"].copy(), ckpt["V_prev"].copy()

    # -- stepping ---------------------------------------------------------------------------

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

    def _event(self, n: int) -> None:
        """The stroke's velocity change on arriving at internal step ``n``.

        Smooth: none; the push and the tether are a force in the integrator's right-hand side
        (:meth:`stage_coefficients`, gait.stroke_force), evaluated at every stage time.
        Negate: the event at the start of each quarter (gait.QUARTER_EVENTS)."""
        if self.smooth:
            return
        if n % self.steps_per_quarter:
            return
        what = QUARTER_EVENTS[(n // self.steps_per_quarter) % 4]
        dyn = self.dynamic
        if what == "negate":
            self.V[dyn] = -self.V[dyn]
        else:
            sign = 1.0 if what == "up" else -1.0
            self.V[dyn] = 0.0
            self.V[dyn, 2] = sign * self.profile[dyn]

    def _constrain(self, X: np.ndarray, V: np.ndarray, t: float) -> None:
        """Place the fluke gate: shifted with the hinge, rotated by the table's angle at t."""
        theta, theta_dot = self.fluke_angle(t)
        place_gate(X, V, self.rest, self.hinge_nodes, self._fluke_nodes, self._fluke_arm,
                   self.hinge0, theta, theta_dot, self._fluke_bend)

    def fluke_angle(self, t: float) -> tuple[float, float]:
        """(angle, angular velocity) of the fluke gate at time t (rad, rad/s), ramp included."""
        phase = t / self.period
        if self.smooth:
            r, r_dot = smootherstep(t, self.ramp_s)[:2]
        else:
            r, r_dot = ramp(t, self.ramp_s)
        angle = self.fluke_table(phase)
        return r * angle, r * self.fluke_table.rate(phase) / self.period + r_dot * angle

    def advance_to(self, n_target: int) -> None:
        """March the state forward to internal step ``n_target`` (no step back: a smaller
        target leaves the state as it is)."""
        while self.step_index < n_target:
            n = self.step_index + 1
            t0, t1 = self.step_index * self.dt, n * self.dt
            tr = self.ramp_s
            if self.smooth and t0 + 1e-9 * self.dt < tr < t1 - 1e-9 * self.dt:
                # the ramp's end: the stroke's time law is only C2 there (the quintic's third
                # derivative jumps), which costs a step across it the method's order (RK4 falls
                # to 2); two sub-steps meet there instead
                Xm, Vm = self.integrator.step(self.X, self.V, t0, drive=self, dt=tr - t0)
                self._constrain(Xm, Vm, tr)
                X, V = self.integrator.step(Xm, Vm, tr, drive=self, dt=t1 - tr)
            else:
                X, V = self.integrator.step(self.X, self.V, t0, drive=self)
            self._constrain(X, V, n * self.dt)
            self.X_prev, self.V_prev = self.X, self.V
            self.X, self.V, self.step_index = X, V, n
            self._event(n)

    def _locate(self, t: float) -> tuple[int, float]:
        if not math.isfinite(t) or t < 0:
            raise ValueError(f"time must be finite and >= 0, got {t}")
        x = t / self.dt
        m = math.floor(x + 1e-9)
        frac = max(0.0, x - m)
        if frac < 1e-9:
            frac = 0.0
        return m, frac

    def _state_at(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        m, frac = self._locate(t)
        need = m + (1 if frac > 0 else 0)
        if need < self.step_index - 1 or (need == self.step_index - 1 and frac > 0):
            raise ValueError(
                f"t = {t} s is behind the animator (now at {self.time} s): it only marches "
                "forward; restore a checkpoint or reset() to go back"
            )
        self.advance_to(need)
        if m == self.step_index:
            return self.X, self.V
        # m == step_index - 1: between the previous and the current step
        if frac == 0.0:
            return self.X_prev, self.V_prev
        return (self.X_prev + frac * (self.X - self.X_prev),
                self.V_prev + frac * (self.V - self.V_prev))

    def positions(self, t: float) -> np.ndarray:
        """(N, 3) node positions (m) at time t (s)."""
        return self._state_at(t)[0].copy()

    def displacement(self, t: float) -> np.ndarray:
        """(N, 3) displacement (m) of every node from rest at time t (s)."""
        return self._state_at(t)[0] - self.rest

    def velocity(self, t: float) -> np.ndarray:
        """(N, 3) node velocities (m/s) at time t (s)."""
        return self._state_at(t)[1].copy()
