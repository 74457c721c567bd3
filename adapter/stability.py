"""Stable time steps of the integrators on a spring network, predicted from its linearisation.

Linearised about rest, the network is M u'' + C u' + K u = 0 with unit masses, the stiffness
K = sum over edges of k (n n^T) (n the edge's rest direction) and the damping
C = mu * Laplacian + nu * I. For a mode with stiffness omega^2 and damping c:

- forward Euler is stable only for dt <= c / omega^2 (= 2 zeta / omega): no damping, no step;
- symplectic Euler and velocity Verlet need omega dt < 2;
- classical RK4 about omega dt < 2.8;
- backward Euler is stable for any step.

The highest mode is found with scipy.sparse.linalg.eigsh on the symmetrised stiffness.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import eigsh

from .springs import SpringNetwork

#: stability limit of omega * dt on the imaginary axis, per method (None: see ``stable_dt``)
OMEGA_DT_LIMIT = {"symplectic_euler": 2.0, "verlet": 2.0, "rk4": 2.785, "backward_euler": np.inf}


def stiffness_matrix(net: SpringNetwork, points: np.ndarray,
                     symmetric: bool = True) -> sp.csr_matrix:
    """(3N, 3N) linearised stiffness K at rest: K u is minus the spring force for small u."""
    n = net.n_nodes
    d = points[net.j] - points[net.i]
    unit = d / np.linalg.norm(d, axis=1)[:, None]
    if symmetric or net.form == "symmetric":
        k_i = k_j = 0.5 * (net.k_node[net.i] + net.k_node[net.j])
    else:
        k_i, k_j = net.k_node[net.j], net.k_node[net.i]  # constant felt at i, at j
    nn = unit[:, :, None] * unit[:, None, :]  # (E, 3, 3)
    rows, cols, vals = [], [], []
    for a in range(3):
        for b in range(3):
            for (r, c, w) in ((net.i, net.i, k_i), (net.i, net.j, -k_i),
                              (net.j, net.j, k_j), (net.j, net.i, -k_j)):
                rows.append(3 * r + a)
                cols.append(3 * c + b)
                vals.append(w * nn[:, a, b])
    return sp.csr_matrix(
        (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(3 * n, 3 * n)
    )


def highest_mode(net: SpringNetwork, points: np.ndarray) -> tuple[float, float]:
    """(omega^2, c) of the stiffest mode: its stiffness and its damping (Rayleigh quotient)."""
    K = stiffness_matrix(net, points, symmetric=True)
    w, v = eigsh(K, k=1, which="LA", tol=1e-6)
    vec = v[:, 0].reshape(-1, 3)
    lap_q = float(np.einsum("ij,ij->", vec, net.laplacian @ vec))
    return float(w[0]), net.mu * lap_q + net.nu


def stable_dt(net: SpringNetwork, points: np.ndarray, method: str) -> float:
    """Largest stable step (s) of ``method`` predicted from the highest mode."""
    omega2, c = highest_mode(net, points)
    if method == "forward_euler":
        return c / omega2 if c > 0 else 0.0
    return OMEGA_DT_LIMIT[method] / np.sqrt(omega2)
