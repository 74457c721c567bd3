"""Time integrators for dX/dt = V, dV/dt = F(X, V): one small family.

The base class :class:`Integrator` owns the step size, the step count and the status, checks
every new state, and refuses to step once it has failed; each method implements only
``_step``. :data:`METHODS` maps the names a scene file uses to the classes.

Forward Euler is the paper's method:

    X^{n+1} = X^n + dt V^n,    V^{n+1} = V^n + dt F^n.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from .errors import UnstableError

Force = Callable[[np.ndarray, np.ndarray], np.ndarray]


class Integrator:
    """Base class: advances (X, V) by a fixed step ``dt`` with the force function ``force``.

    Parameters
    ----------
    force : callable (X, V) -> (N, 3) acceleration (unit masses: the force).
    dt : the step (s).
    runaway : largest displacement (m) from ``reference`` allowed before the run is called
        unstable; ``None`` checks only for NaN and infinity.
    reference : (N, 3) rest positions used by the runaway check.
    """

    name = "base"
    order = 0

    def __init__(self, force: Force, dt: float, runaway: float | None = None,
                 reference: np.ndarray | None = None, stable_dt: float | None = None):
        if not dt > 0:
            raise ValueError(f"dt must be positive, got {dt}")
        self.force = force
        self.dt = float(dt)
        self.runaway = runaway
        self.reference = reference
        self.stable_dt = stable_dt
        self.n_steps = 0
        self.status = "running"

    def step(self, X: np.ndarray, V: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """One step from (X, V); raises :class:`UnstableError` (and fails for good) on blow-up."""
        if self.status == "failed":
            raise UnstableError(f"{self.name}: the integrator has failed before; start anew")
        X1, V1 = self._step(X, V, self.dt)
        self.n_steps += 1
        self.check(X1, V1)
        return X1, V1

    def check(self, X: np.ndarray, V: np.ndarray) -> None:
        """Fail if the state holds NaN or infinity, or has run away from the reference."""
        bad = not (np.isfinite(X).all() and np.isfinite(V).all())
        if not bad and self.runaway is not None and self.reference is not None:
            bad = np.abs(X - self.reference).max() > self.runaway
        if bad:
            self.status = "failed"
            hint = (f"; the largest stable step predicted for {self.name} is "
                    f"{self.stable_dt:.3g} s" if self.stable_dt else "")
            raise UnstableError(
                f"{self.name} with dt = {self.dt:.3g} s blew up after {self.n_steps} steps "
                f"(NaN or runaway motion){hint}: lower integrator.dt_s (or set it to 0 to use "
                "the predicted stable step), or raise the damping springs.mu"
            )

    def _step(self, X, V, dt):
        raise NotImplementedError


class ForwardEuler(Integrator):
    """The paper's method: first order, explicit."""

    name = "forward_euler"
    order = 1

    def _step(self, X, V, dt):
        F = self.force(X, V)
        return X + dt * V, V + dt * F


METHODS: dict[str, type[Integrator]] = {ForwardEuler.name: ForwardEuler}


def make_integrator(name: str, force: Force, dt: float, **kwargs) -> Integrator:
    """The integrator called ``name`` (a key of :data:`METHODS`)."""
    try:
        cls = METHODS[name]
    except KeyError:
        raise ValueError(
            f"unknown integrator {name!r}; known: {', '.join(sorted(METHODS))}"
        ) from None
    return cls(force, dt, **kwargs)
