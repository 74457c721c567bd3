"""The integrators' compiled steps (numba): each explicit method's step as one pass over the
arrays, the spring network's force kernel (:func:`~adapter.body.springs.edge_forces`) fused
with the update, and the time-aware right-hand side (the stroke's force and the fluke gate at
every stage's own time: gait.drive_force, gait.drive_place).

Every kernel has the same signature, ``(X, V, i, j, rest, ki, kj, mu, nu, dt, X1, V1, drive,
coef)``: the state (N, 3), the network's edge arrays and damping, the step, the (N, 3) outputs
written in place, the drive's arrays (:class:`~adapter.motion.drive.DriveArrays`,
:data:`NO_DRIVE` for none) and its coefficients per stage
(one row per stage of the method, :data:`NO_COEF` for none). :mod:`adapter.motion.integrators`
holds the family that calls them.
"""

from __future__ import annotations

import numba
import numpy as np

from adapter.body.springs import edge_forces
from adapter.motion.drive import DriveArrays
from adapter.motion.gait import drive_force, drive_place


@numba.njit(cache=True, error_model="numpy")
def rhs(X, V, s, i, j, rest, ki, kj, mu, nu, drive, coef, out):  # pragma: no cover
    """out = the acceleration at stage ``s`` of a step: the network's force at (X, V) plus the
    drive's term at the stage's time (row ``s`` of ``coef``). From the second stage on, the
    drive's kinematic nodes (the fluke gate) are first placed on the stage state, in place
    (the first stage is the state handed in, which already meets the constraint)."""
    if s > 0:
        drive_place(X, V, drive, coef[s])
    edge_forces(X, V, i, j, rest, ki, kj, mu, nu, out)
    drive_force(X, V, out, drive, coef[s])


@numba.njit(cache=True, error_model="numpy")
def fe_kernel(X, V, i, j, rest, ki, kj, mu, nu, dt, X1, V1, drive,
               coef):  # pragma: no cover
    fe_checked(X, V, i, j, rest, ki, kj, mu, nu, dt, X1, V1, X, drive, coef)


@numba.njit(cache=True, error_model="numpy")
def fe_checked(X, V, i, j, rest, ki, kj, mu, nu, dt, X1, V1, ref, drive,
                coef):  # pragma: no cover
    """Forward Euler fused with the check: returns max |X1 - ref|, inf on NaN or infinity."""
    rhs(X, V, 0, i, j, rest, ki, kj, mu, nu, drive, coef, V1)
    x0, v0, r = X.reshape(-1), V.reshape(-1), ref.reshape(-1)
    x1, v1 = X1.reshape(-1), V1.reshape(-1)
    m = 0.0
    for a in range(x0.shape[0]):
        x = x0[a] + dt * v0[a]
        v = v0[a] + dt * v1[a]
        x1[a] = x
        v1[a] = v
        if not (np.isfinite(x) and np.isfinite(v)):
            m = np.inf
        elif abs(x - r[a]) > m:
            m = abs(x - r[a])
    return m


@numba.njit(cache=True, error_model="numpy")
def se_kernel(X, V, i, j, rest, ki, kj, mu, nu, dt, X1, V1, drive,
               coef):  # pragma: no cover
    rhs(X, V, 0, i, j, rest, ki, kj, mu, nu, drive, coef, V1)
    for a in range(X.shape[0]):
        for d in range(3):
            v = V[a, d] + dt * V1[a, d]
            V1[a, d] = v
            X1[a, d] = X[a, d] + dt * v


@numba.njit(cache=True, error_model="numpy")
def verlet_kernel(X, V, i, j, rest, ki, kj, mu, nu, dt, X1, V1, drive,
                   coef):  # pragma: no cover
    a0 = np.empty_like(X)
    vp = np.empty_like(X)
    rhs(X, V, 0, i, j, rest, ki, kj, mu, nu, drive, coef, a0)
    h = 0.5 * dt
    for a in range(X.shape[0]):
        for d in range(3):
            vh = V[a, d] + h * a0[a, d]
            V1[a, d] = vh
            X1[a, d] = X[a, d] + dt * vh
            vp[a, d] = vh + h * a0[a, d]
    # at t + dt; the gate is placed on X1 (its fluke rows are placed again after the step)
    rhs(X1, vp, 1, i, j, rest, ki, kj, mu, nu, drive, coef, a0)
    for a in range(X.shape[0]):
        for d in range(3):
            V1[a, d] += h * a0[a, d]


@numba.njit(cache=True, error_model="numpy")
def rk4_kernel(X, V, i, j, rest, ki, kj, mu, nu, dt, X1, V1, drive,
                coef):  # pragma: no cover
    n = X.shape[0]
    Xs = np.empty_like(X)
    Vs = np.empty_like(X)
    F = np.empty_like(X)
    h = 0.5 * dt
    w = dt / 6.0
    # stage 1: k1 = (V, F(t, X, V))
    rhs(X, V, 0, i, j, rest, ki, kj, mu, nu, drive, coef, F)
    for a in range(n):
        for d in range(3):
            X1[a, d] = X[a, d] + w * V[a, d]
            V1[a, d] = V[a, d] + w * F[a, d]
            Xs[a, d] = X[a, d] + h * V[a, d]
            Vs[a, d] = V[a, d] + h * F[a, d]
    # stages 2 and 3: k = (Vs, F(t + dt/2, Xs, Vs)) at the midpoint
    for stage in range(2):
        rhs(Xs, Vs, 1 + stage, i, j, rest, ki, kj, mu, nu, drive, coef, F)
        step = h if stage == 0 else dt
        for a in range(n):
            for d in range(3):
                vs = Vs[a, d]
                X1[a, d] += 2.0 * w * vs
                V1[a, d] += 2.0 * w * F[a, d]
                Xs[a, d] = X[a, d] + step * vs
                Vs[a, d] = V[a, d] + step * F[a, d]
    # stage 4 at the end of the step
    rhs(Xs, Vs, 3, i, j, rest, ki, kj, mu, nu, drive, coef, F)
    for a in range(n):
        for d in range(3):
            X1[a, d] += w * Vs[a, d]
            V1[a, d] += w * F[a, d]


@numba.njit(cache=True, error_model="numpy")
def deviation(X, V, ref):  # pragma: no cover - compiled
    """Largest |X - ref| over all entries; inf if X or V holds NaN or infinity."""
    m = 0.0
    for a in range(X.shape[0]):
        for d in range(3):
            x = X[a, d]
            v = V[a, d]
            if not (np.isfinite(x) and np.isfinite(v)):
                return np.inf
            r = abs(x - ref[a, d])
            if r > m:
                m = r
    return m


#: the drive of a free network (no stroke force, no kinematic nodes)
NO_DRIVE = DriveArrays.none()
NO_COEF = np.zeros((4, 5))
