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
from adapter.errors import (
    AnimatorTimeError,
    CheckpointError,
    SceneError,
    TimeBehindError,
    UnstableError,
)
from adapter.motion.drive import StrokeDrive
from adapter.motion.gait import velocity_profile
from adapter.motion.integrators import make_integrator
from adapter.motion.stability import stable_dt


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
        if not surf.is_whale:
            raise SceneError(
                f"{scene.geometry.source} has none of the whale's landmarks, which the "
                "spring-mass stroke needs (geometry.landmarks): a body in rigid motion "
                "([rigid]) runs with run-case or validate; it has no dry-run of its own")
        self.rest = surf.points
        s = surf.s
        self.tail_base_s = float(s[surf.landmarks["tail_base"]])
        #: the gate's nodes (behind the tail base) move as the fluke gate places them, not as
        #: springs
        self.fluke = s > self.tail_base_s
        self.dynamic = ~self.fluke
        sp_ = scene.springs
        r = scene.regions
        k = region_constants(s, r.head_end, r.tail_start, sp_.k_head, sp_.k_pivot, sp_.k_tail,
                             sp_.transition) * sp_.stiffness_scale
        self.network = network_from_edges(self.rest, surf.edges, k, sp_.mu, sp_.nu, sp_.form)
        self.profile = velocity_profile(s, self.dynamic, scene.stroke, self.tail_base_s)
        self.period = scene.period_s
        #: the stroke and the fluke gate: the time-dependent part of the motion
        self.drive = StrokeDrive(scene, self.rest, s, self.tail_base_s, self.dynamic,
                                 self.profile, self.network)
        d = self.drive
        self.hinge_nodes, self.hinge0, self.fluke_table = d.hinge_nodes, d.hinge0, d.fluke_table
        self.reversal, self.smooth, self.ramp_s = d.reversal, d.smooth, d.ramp_s
        self.stable_dt, target = _step_target(scene, self.network, self.rest, self.dynamic,
                                              d.smooth, d.tether)
        quarter = self.period / 4
        #: internal steps per quarter stroke, and the internal step (s)
        self.steps_per_quarter = max(1, math.ceil(quarter / target - 1e-9))
        self.dt = quarter / self.steps_per_quarter
        self.integrator = make_integrator(
            scene.integrator.method, self.network.forces, self.dt, runaway=2.0 * surf.length,
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
        self.drive.place(self.X, self.V, 0.0)
        self.drive.event(self.V, 0, self.steps_per_quarter)
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
            raise CheckpointError("the checkpoint belongs to another scene (step or node count "
                                  "differ)")
        self.integrator.restart()
        self.step_index = int(ckpt["step_index"])
        self.X, self.V = ckpt["X"].copy(), ckpt["V"].copy()
        self.X_prev, self.V_prev = ckpt["X_prev"].copy(), ckpt["V_prev"].copy()

    # -- stepping ---------------------------------------------------------------------------

    def fluke_angle(self, t: float) -> tuple[float, float]:
        """(angle, angular velocity) of the fluke gate at time t (rad, rad/s), ramp included."""
        return self.drive.fluke_angle(t)

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
                Xm, Vm = self.integrator.step(self.X, self.V, t0, drive=self.drive, dt=tr - t0)
                self.drive.place(Xm, Vm, tr)
                X, V = self.integrator.step(Xm, Vm, tr, drive=self.drive, dt=t1 - tr)
            else:
                X, V = self.integrator.step(self.X, self.V, t0, drive=self.drive)
            self.drive.place(X, V, n * self.dt)
            self.X_prev, self.V_prev = self.X, self.V
            self.X, self.V, self.step_index = X, V, n
            self.drive.event(self.V, n, self.steps_per_quarter)

    def _locate(self, t: float) -> tuple[int, float]:
        if not math.isfinite(t) or t < 0:
            raise AnimatorTimeError(f"time must be finite and >= 0, got {t}")
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
            raise TimeBehindError(
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
        """(N, 3) node positions (m) at time t (s): the surface the whale shows, its joint
        drawn (StrokeDrive.shape)."""
        X, _ = self._state_at(t)
        return self.drive.shape(X, None, t)[0].copy()

    def displacement(self, t: float) -> np.ndarray:
        """(N, 3) displacement (m) of every node from rest at time t (s)."""
        X, _ = self._state_at(t)
        return self.drive.shape(X, None, t)[0] - self.rest

    def velocity(self, t: float) -> np.ndarray:
        """(N, 3) node velocities (m/s) at time t (s)."""
        X, V = self._state_at(t)
        return self.drive.shape(X, V, t)[1].copy()

    def hinge_velocity(self, t: float) -> np.ndarray:
        """(3,) velocity (m/s) of the fluke's hinge at time t (s): the mean of the spring
        nodes that carry it."""
        return self._state_at(t)[1][self.hinge_nodes].mean(axis=0)


def _step_target(scene, network, rest, free, smooth: bool, tether) -> tuple[float, float]:
    """(the predicted stable step, the step aimed at) of the scene's method, in s.

    Predicted on the ``free`` (spring-moved) nodes; the fluke gate is kinematic. The smooth
    stroke's tether (``tether``: (k, c)) is stiffness and damping in the right-hand side: the
    smaller of the steps with and without it (its damping lowers symplectic Euler's and
    Verlet's bound by 5-7 %, and would allow forward Euler 3 times its step: kept as it was).
    """
    method = scene.integrator.method
    tether_k, tether_c = tether
    stable = stable_dt(network, rest, method, free=free)
    if smooth and tether_k > 0:
        stable = min(stable, stable_dt(network, rest, method, free=free,
                                       tether=(tether_k, tether_c)))
    quarter = scene.period_s / 4
    if scene.integrator.dt_s > 0:
        target = scene.integrator.dt_s
        if target > stable:
            raise UnstableError(
                f"integrator.dt_s = {target:.3g} s is beyond the largest stable step "
                f"predicted for {method}, {stable:.3g} s: the run would blow up; "
                "lower integrator.dt_s, set it to 0 to use the predicted step times "
                "integrator.safety, or choose another integrator.method"
            )
    elif stable > 0:
        target = scene.integrator.safety * min(stable, quarter)
        if smooth:
            # resolve the stroke's and the tether's time scales (a few % of a radian per
            # step), so that every method's time error stays small at its default step
            target = min(target, 0.05 / max(math.sqrt(tether_k), 2 * math.pi
                                            / scene.period_s))
    else:
        sp_ = scene.springs
        raise SceneError(
            f"integrator.method = {method} has no stable step with springs.mu = "
            f"{sp_.mu} and springs.nu = {sp_.nu} (forward Euler needs damping); raise mu"
        )
    return stable, target


def animator_for(scene, surface=None):
    """The scene's moving body: the spring-mass whale (:class:`Animator`), or a closed body in
    rigid prescribed motion (:class:`~adapter.motion.rigid.RigidMotion`) when
    ``rigid.enabled``."""
    if scene.rigid.enabled:
        from adapter.motion.rigid import RigidMotion

        return RigidMotion(scene, surface)
    return Animator(scene, surface)
