"""Stable steps against truths from outside adapter/motion/stability.py: on a small closed spring
network, the exact forward-Euler bound from the eigenvalues of the linearised system (its
Jacobian taken by finite differences of the force law, its eigenvalues by numpy), and forward
Euler itself, written out here, run at and just past the bounds."""

import numpy as np
import pytest
from scipy.spatial import ConvexHull

from adapter.body.springs import network_from_edges
from adapter.motion.stability import predict


def _closed_net(mu=0.5, nu=0.05, form="paper", n=40, seed=3):
    """A triangulated closed surface (the convex hull of points on an elongated ellipsoid),
    with spring constants rising from 40 to 400 along x as on the whale."""
    rng = np.random.default_rng(seed)
    p = rng.standard_normal((n, 3))
    p /= np.linalg.norm(p, axis=1)[:, None]
    p *= [3.0, 1.0, 0.8]
    tri = ConvexHull(p).simplices
    edges = np.unique(np.sort(np.r_[tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]], axis=1),
                      axis=0)
    k = 40.0 + 360.0 * (p[:, 0] - p[:, 0].min()) / np.ptp(p[:, 0])
    return p, network_from_edges(p, edges, k, mu, nu, form)


def _exact_fe_bound(net, X):
    """max dt with |1 + dt lambda| <= 1 for every eigenvalue lambda of the linearised system
    x' = v, v' = F(x, v): dt <= -2 Re(lambda) / |lambda|^2. The Jacobian of F is taken by
    central differences of the reference force law (tests/test_springs.py checks it by hand)."""
    m = 3 * net.n_nodes
    V0 = np.zeros_like(X)
    Jx, Jv = np.empty((m, m)), np.empty((m, m))
    h = 1e-6
    for a in range(m):
        e = np.zeros(m)
        e[a] = h
        E = e.reshape(-1, 3)
        Jx[:, a] = ((net.forces_numpy(X + E, V0) - net.forces_numpy(X - E, V0)) / (2 * h)).ravel()
        Jv[:, a] = ((net.forces_numpy(X, V0 + E) - net.forces_numpy(X, V0 - E)) / (2 * h)).ravel()
    A = np.block([[np.zeros((m, m)), np.eye(m)], [Jx, Jv]])
    lam = np.linalg.eigvals(A)
    lam = lam[np.abs(lam) > 1e-7 * np.abs(lam).max()]  # rigid motions and neutral modes
    assert (lam.real < 1e-9 * np.abs(lam).max()).all()  # the network itself is stable
    return float(np.min(-2 * lam.real / np.abs(lam) ** 2)), lam


def _fe_growth(net, X0, dt, n_steps, seed=0):
    """Forward Euler, X' = X + dt V, V' = V + dt F(X, V), from rest plus a tiny random
    perturbation: the largest deviation at the end over its largest over the first tenth."""
    rng = np.random.default_rng(seed)
    X = X0 + 1e-7 * rng.standard_normal(X0.shape)
    V = 1e-7 * rng.standard_normal(X0.shape)
    early = 0.0
    for n in range(n_steps):
        X, V = X + dt * V, V + dt * net.forces(X, V)
        if n < n_steps // 10:
            early = max(early, np.abs(X - X0).max(), np.abs(V).max())
    return max(np.abs(X - X0).max(), np.abs(V).max()) / early


@pytest.mark.parametrize("mu, form", [(0.5, "paper"), (0.5, "symmetric"), (3.0, "paper")])
def test_forward_euler_bounds_against_the_exact_spectrum(mu, form):
    X, net = _closed_net(mu=mu, form=form)
    exact, _ = _exact_fe_bound(net, X)
    kw = dict(methods=("forward_euler",))
    modal = predict(net, X, exact=True, **kw)["forward_euler"]
    fast = predict(net, X, exact=False, **kw)["forward_euler"]
    assert modal == pytest.approx(exact, rel=1e-5)
    # the fast bound (large meshes) is always stable, and not needlessly small
    assert fast <= exact * (1 + 1e-9), (fast, exact)
    assert fast >= 0.5 * exact, (fast, exact)


def test_forward_euler_does_not_grow_at_the_fast_bound_and_grows_just_past_the_exact_one():
    X, net = _closed_net()
    exact, lam = _exact_fe_bound(net, X)
    fast = predict(net, X, exact=False, methods=("forward_euler",))["forward_euler"]
    # 5 % past the exact bound the worst mode's growth per step is |1 + dt lambda| > 1: run
    # long enough for it to grow 1e4 times
    g = np.abs(1 + 1.05 * exact * lam).max()
    n_steps = int(np.log(1e4) / np.log(g)) + 1
    assert n_steps < 100_000
    assert _fe_growth(net, X, 1.05 * exact, n_steps) > 100
    assert _fe_growth(net, X, fast, n_steps) <= 1.0
