"""Time integrators for dX/dt = V, dV/dt = F(X, V): one small family.

The base class :class:`Integrator` owns the step size, the step count and the status, checks
every new state, and refuses to step once it has failed; each method implements only
``_step`` and states its facts as class attributes, which the stability analysis, the studies
and docs/numerics.md (:func:`method_table`) read (the contract: :class:`Integrator`,
"Implementing a method"). :data:`METHODS` maps the names a scene file uses to the classes.

Velocity Verlet with a velocity-dependent force: with a0 = F(X, V),
``Vh = V + dt/2 a0``, ``X' = X + dt Vh``, ``a1 = F(X', Vh + dt/2 a0)`` (the velocity at the
new position predicted to first order), ``V' = Vh + dt/2 a1``. Undamped it is the usual
Verlet; the damping term is then integrated by the trapezoidal rule (Heun), so the method stays
second order. The acceleration is not carried from step to step, because the animator changes
X and V between steps (the fluke gate, the stroke's events).

Backward Euler: with J_x = dF/dX and J_v = dF/dV at (X, V),
``(I - dt J_v - dt^2 J_x) dV = dt (F + dt J_x V)``, ``V' = V + dV``, ``X' = X + dt V'``: one
sparse LU solve per step (scipy.sparse.linalg.splu; the paper's force is not symmetric).

Given the :class:`~adapter.body.springs.SpringNetwork` (``network=``) whose force it is, each
explicit step runs as one compiled pass (numba), no temporary arrays beyond the two returned.

Time-aware right-hand side. ``step(X, V, t, drive=...)`` integrates
dV/dt = F(X, V) + F_drive(t, X, V) with the constraint of the drive's kinematic nodes: at every
stage (at its own time t + c dt: the ``stages`` of each class) the fluke gate is placed on the
stage state and the stroke's force is added to the network's (gait.drive_place,
gait.drive_force), inside the compiled kernels too. Applied instead once per step, after it
(operator splitting), they made every method first order on the whole whale.
"""

from __future__ import annotations

from typing import Callable, ClassVar

import numpy as np

from adapter.body.springs import damping_matrix, force_jacobian
from adapter.errors import IntegratorError, UnstableError
from adapter.motion.drive import DriveArrays
from adapter.motion.gait import drive_force, drive_place
from adapter.motion.kernels import (
    NO_COEF,
    NO_DRIVE,
    deviation,
    fe_checked,
    fe_kernel,
    rk4_kernel,
    se_kernel,
    verlet_kernel,
)

Force = Callable[[np.ndarray, np.ndarray], np.ndarray]


# -- the family -----------------------------------------------------------------------------

class Integrator:
    """Base class: advances (X, V) by a fixed step ``dt`` with the force function ``force``.

    Parameters
    ----------
    force : callable (X, V) -> (N, 3) acceleration (unit masses: the force).
    dt : the step (s).
    runaway : largest displacement (m) from ``reference`` allowed before the run is called
        unstable; ``None`` checks only for NaN and infinity.
    reference : (N, 3) rest positions used by the runaway check.
    stable_dt : the largest stable step (s) predicted for this method, named in the error.
    network : the :class:`~adapter.body.springs.SpringNetwork` whose ``forces`` is ``force``;
        enables the compiled steps, and is required by ``backward_euler`` (its Jacobian).
    reuse_buffers : let the compiled steps write into three array sets in turn instead of new
        arrays (a returned state is overwritten three steps later).

    Implementing a method
    ---------------------
    Subclass, set the facts (the class attributes below) and implement the one hook,
    ``_step(X, V, dt) -> (X1, V1)``: the new state as new arrays of any shape (the stability
    analysis steps a scalar oscillator), unchecked and uncounted (:meth:`step` checks and
    counts), the right-hand side taken only from ``self._f(X, V, s)`` at stage ``s`` of
    ``stages``. ``kernel`` (and ``checked_kernel``, fused with the check) may name the same
    step compiled (adapter.motion.kernels); :meth:`step` runs it instead of ``_step`` when the
    force is the network's. It is data, not a second hook: the same step to round-off.
    """

    #: the name a scene file uses (integrator.method), the key of :data:`METHODS`
    name = "base"
    #: the order of accuracy
    order = 0
    #: the times of the right-hand side's evaluations within a step, in steps from its start
    stages: ClassVar[tuple[float, ...]] = (0.0,)
    #: force evaluations per step (the work of one step, for the charts)
    force_calls = 1
    #: the relative cost of one step, in force evaluations (the chooser's measure)
    step_cost = 1
    #: explicit: a finite stable step (predicted by adapter.motion.stability)
    explicit = True
    #: the stability limit of omega dt on an undamped oscillator (forward Euler: 0, no step
    #: is stable without damping; backward Euler: inf, any step)
    omega_dt_limit = 0.0
    #: one step, in a line (the docs' table)
    step_rule = ""
    #: the step compiled, where there is one (see "Implementing a method")
    kernel: ClassVar[Callable | None] = None
    #: the compiled step fused with the check (returns the largest deviation)
    checked_kernel: ClassVar[Callable | None] = None

    def __init__(self, force: Force, dt: float, runaway: float | None = None,
                 reference: np.ndarray | None = None, stable_dt: float | None = None,
                 network=None, reuse_buffers: bool = False):
        if not dt > 0:
            raise IntegratorError(f"{self.name}: dt must be positive, got {dt}")
        self.force = force
        self.dt = float(dt)
        self.runaway = runaway
        self.reference = reference
        self.stable_dt = stable_dt
        self.network = network
        self.n_steps = 0
        self.status = "running"
        #: with ``reuse_buffers`` a compiled step writes into three array sets in turn: a
        #: returned state stays valid for two more steps (enough for the animator, which keeps
        #: the current and the previous step and copies what it hands out)
        self._buffers: list | None = [] if reuse_buffers else None
        self._turn = 0
        self._kernel_args = None
        #: the drive of the step under way (its arrays and coefficients; None: none)
        self._drive: DriveArrays | None = None
        self._coef = NO_COEF
        if network is not None and _same_force(force, network):
            net = network
            self._kernel_args = (net.i, net.j, net.rest, net.k_on_i, net.k_on_j,
                                 float(net.mu), float(net.nu))

    def step(self, X: np.ndarray, V: np.ndarray, t: float = 0.0, drive=None,
             dt: float | None = None) -> tuple[np.ndarray, np.ndarray]:
        """One step from (X, V) at time t; raises :class:`UnstableError` (and fails for good)
        on blow-up. ``dt`` replaces the integrator's step for this step only (the animator
        splits the step that holds the stroke ramp's end).

        ``drive``: a time-dependent part of the right-hand side (the animator's stroke and
        fluke gate), evaluated at every stage's own time: an object with ``stage_arrays`` (the
        tuple of :attr:`~adapter.motion.drive.StrokeDrive.stage_arrays`) and
        ``stage_coefficients(t, dt, stages)`` (one row per stage). The state (X, V) handed in
        must already meet the drive's constraint at t (the gate placed); the fluke rows of the
        state returned are the method's, to be placed again at t + dt by the caller.

        The new state is checked before it is returned: a NaN or runaway state is never
        handed on.
        """
        if self.status == "failed":
            raise UnstableError(f"{self.name}: the integrator has failed before; start anew")
        h = self.dt if dt is None else float(dt)
        if drive is None:
            self._drive, self._coef = None, NO_COEF
            drv = NO_DRIVE
        else:
            drv = self._drive = drive.stage_arrays
            self._coef = drive.stage_coefficients(t, h, self.stages)
        kernel, checked = type(self).kernel, type(self).checked_kernel
        if self._kernel_args is not None and kernel is not None:
            X1, V1 = self._outputs(X, V)
            if checked is not None and self.reference is not None:
                # the paper's method on the hot path: step and check in one pass
                dev = checked(X, V, *self._kernel_args, h, X1, V1, self.reference, drv, self._coef)
                self.n_steps += 1
                self._verdict(dev)
                return X1, V1
            kernel(X, V, *self._kernel_args, h, X1, V1, drv, self._coef)
        else:
            X1, V1 = self._step(X, V, h)
        self.n_steps += 1
        self.check(X1, V1)
        return X1, V1

    def _outputs(self, X: np.ndarray, V: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Arrays for the new state: fresh ones, or with ``reuse_buffers`` the next of three
        sets taken in turn. Three, because the caller holds the state it passed in and the one
        before it (the animator's current and previous steps); allocating ~0.3 MB twice per
        step instead costs page faults that made the step a quarter slower."""
        if self._buffers is None:
            return np.empty_like(X), np.empty_like(V)
        if not self._buffers or self._buffers[0][0].shape != X.shape:
            self._buffers = [(np.empty_like(X), np.empty_like(V)) for _ in range(3)]
        self._turn = (self._turn + 1) % 3
        return self._buffers[self._turn]

    def check(self, X: np.ndarray, V: np.ndarray) -> None:
        """Fail if the state holds NaN or infinity, or has run away from the reference."""
        ref = self.reference if self.reference is not None else X
        if X.dtype == np.float64 and X.ndim == 2 and X.shape[1] == 3 and V.shape == X.shape:
            dev = deviation(X, V, ref)
        else:
            dev = (np.abs(X - ref).max() if np.isfinite(X).all() and np.isfinite(V).all()
                   else np.inf)
        self._verdict(dev)

    def _verdict(self, dev: float) -> None:
        """Fail (for good) if the largest deviation from the reference is past the runaway
        limit, or infinite (the state holds NaN or infinity: ``deviation``'s answer), or not
        a number."""
        limit = self.runaway if (self.runaway is not None and self.reference is not None) \
            else np.inf
        if not (dev <= limit and dev < np.inf):
            self.status = "failed"
            hint = (f"; the largest stable step predicted for {self.name} is "
                    f"{self.stable_dt:.3g} s" if self.stable_dt else "")
            raise UnstableError(
                f"{self.name} with dt = {self.dt:.3g} s blew up after {self.n_steps} steps "
                f"(NaN or runaway motion){hint}: lower integrator.dt_s (or set it to 0 to use "
                "the predicted stable step), or raise the damping springs.mu"
            )

    def restart(self, n_steps: int | None = None) -> None:
        """Running again, from a state the owner set (a reset to t = 0, a restored checkpoint):
        the failed status is cleared and the step count set to ``n_steps`` (None keeps it)."""
        self.status = "running"
        if n_steps is not None:
            self.n_steps = n_steps

    def method_step(self, X, V, dt):
        """The method's own step from (X, V) over ``dt``, on arrays of any shape: no check, no
        count, no compiled kernel (the stability analysis runs it on a scalar oscillator)."""
        return self._step(X, V, dt)

    def _f(self, X: np.ndarray, V: np.ndarray, s: int) -> np.ndarray:
        """The right-hand side at stage ``s`` of the step under way: the force, plus the
        drive's term at the stage's time (the gate placed on a copy of the stage state)."""
        if self._drive is None:
            return self.force(X, V)
        coef = self._coef[s]
        if s > 0:
            X, V = X.copy(), V.copy()
            drive_place(X, V, self._drive, coef)
        F = np.array(self.force(X, V), dtype=np.float64)
        drive_force(X, V, F, self._drive, coef)
        return F

    def _step(self, X, V, dt):
        """The method's step (the one hook; see "Implementing a method")."""
        raise NotImplementedError


def _same_force(force, network) -> bool:
    """True if ``force`` is ``network.forces`` (the compiled kernels compute that force)."""
    return getattr(force, "__self__", None) is network and \
        getattr(force, "__name__", "") == "forces"


class ForwardEuler(Integrator):
    """The paper's method: first order, explicit."""

    name = "forward_euler"
    order = 1
    step_rule = "X' = X + dt V,  V' = V + dt F(X, V)  (the paper's)"
    kernel = fe_kernel
    checked_kernel = fe_checked

    def _step(self, X, V, dt):
        F = self._f(X, V, 0)
        return X + dt * V, V + dt * F


class SymplecticEuler(Integrator):
    """Semi-implicit Euler: the velocity first, then the position with the new velocity."""

    name = "symplectic_euler"
    order = 1
    omega_dt_limit = 2.0
    step_rule = "V' = V + dt F(X, V),  X' = X + dt V'"
    kernel = se_kernel

    def _step(self, X, V, dt):
        V1 = V + dt * self._f(X, V, 0)
        return X + dt * V1, V1


class Verlet(Integrator):
    """Velocity Verlet; the damping by a first-order velocity predictor (second order)."""

    name = "verlet"
    order = 2
    stages = (0.0, 1.0)
    force_calls = step_cost = 2
    omega_dt_limit = 2.0
    step_rule = "velocity Verlet, damping by a velocity predictor"
    kernel = verlet_kernel

    def _step(self, X, V, dt):
        a0 = self._f(X, V, 0)
        Vh = V + 0.5 * dt * a0
        X1 = X + dt * Vh
        a1 = self._f(X1, Vh + 0.5 * dt * a0, 1)
        return X1, Vh + 0.5 * dt * a1


class RK4(Integrator):
    """Classical fourth-order Runge-Kutta on the first-order system (X, V)."""

    name = "rk4"
    order = 4
    stages = (0.0, 0.5, 0.5, 1.0)
    force_calls = step_cost = 4
    omega_dt_limit = 2.828
    step_rule = "classical Runge-Kutta on (X, V)"
    kernel = rk4_kernel

    def _step(self, X, V, dt):
        f = self._f
        k1x, k1v = V, f(X, V, 0)
        k2x = V + 0.5 * dt * k1v
        k2v = f(X + 0.5 * dt * k1x, k2x, 1)
        k3x = V + 0.5 * dt * k2v
        k3v = f(X + 0.5 * dt * k2x, k3x, 2)
        k4x = V + dt * k3v
        k4v = f(X + dt * k3x, k4x, 3)
        return (X + dt / 6 * (k1x + 2 * k2x + 2 * k3x + k4x),
                V + dt / 6 * (k1v + 2 * k2v + 2 * k3v + k4v))


class BackwardEuler(Integrator):
    """Linearised backward Euler (Baraff & Witkin 1998): one sparse solve per step; needs
    ``network=`` for the spring force's Jacobian (:func:`~adapter.body.springs.force_jacobian`).
    """

    name = "backward_euler"
    order = 1
    #: the drive is taken at the end of the step, as the method takes the force
    stages = (1.0,)
    #: one force call, its Jacobian and a sparse LU: about ten force evaluations
    step_cost = 10
    explicit = False
    omega_dt_limit = np.inf
    step_rule = "one linearised implicit step (Baraff & Witkin 1998)"

    def __init__(self, force: Force, dt: float, **kwargs):
        super().__init__(force, dt, **kwargs)
        if self.network is None:
            raise IntegratorError("backward_euler needs the spring network for its Jacobian: "
                             "make_integrator(..., network=net)")
        self._c = damping_matrix(self.network)  # C = -dF/dV, constant
        self._eye = None
        self._tether: tuple[np.ndarray, object] | None = None

    def _step(self, X, V, dt):
        import scipy.sparse as sp
        from scipy.sparse.linalg import splu

        jx = force_jacobian(self.network, X)
        n = jx.shape[0]
        if self._eye is None:
            self._eye = sp.identity(n, format="csc")
        # the drive's force at t + dt (its time law explicit, at the state at t)
        F = self._f(X, V, 0).ravel()
        v = V.ravel()
        c, kx = self._c, jx
        if self._drive is not None and len(self._drive.moving):
            # the tether is stiffness and damping on the moving nodes: implicit too
            moving, (k_t, c_t) = self._drive.moving, self._drive.tether
            if self._tether is None or self._tether[0] is not moving:
                on = np.zeros(n)
                on[(3 * moving[:, None] + np.arange(3)).ravel()] = 1.0
                self._tether = (moving, sp.diags(on))
            diag = self._tether[1]
            c, kx = c + c_t * diag, jx - k_t * diag
        system = (self._eye + dt * c - (dt * dt) * kx).tocsc()
        dv = splu(system).solve(dt * (F + dt * (kx @ v)))
        V1 = (v + dv).reshape(V.shape)
        return X + dt * V1, V1


METHODS: dict[str, type[Integrator]] = {
    cls.name: cls for cls in (ForwardEuler, SymplecticEuler, Verlet, RK4, BackwardEuler)
}


def make_integrator(name: str, force: Force, dt: float, **kwargs) -> Integrator:
    """The integrator called ``name`` (a key of :data:`METHODS`); keyword arguments go to
    :class:`Integrator` (``runaway``, ``reference``, ``stable_dt``, ``network``)."""
    try:
        cls = METHODS[name]
    except KeyError:
        raise IntegratorError(
            f"unknown integrator {name!r}; known: {', '.join(sorted(METHODS))}"
        ) from None
    return cls(force, dt, **kwargs)


def method_table() -> str:
    """The facts of every method of :data:`METHODS` as a Markdown table (docs/numerics.md)."""
    def limit(cls):
        if not cls.explicit:
            return "any (A-stable)"
        return "needs damping" if cls.omega_dt_limit == 0 else f"{cls.omega_dt_limit:g}"

    rows = ["| name | order | one step | stages | force calls | step cost | omega dt limit |",
            "|---|---|---|---|---|---|---|"]
    for cls in METHODS.values():
        stages = ", ".join(f"{c:g}" for c in cls.stages)
        rows.append(f"| {cls.name} | {cls.order} | {cls.step_rule} | {stages} | "
                    f"{cls.force_calls} | {cls.step_cost} | {limit(cls)} |")
    return "\n".join(rows) + "\n"
