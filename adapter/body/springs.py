"""The spring-mass network of the paper (Duffy et al., section 3).

Nodes of unit mass; every edge a spring whose rest length is its initial length. The force on
node i is, exactly as the paper writes it,

    F_i = sum_j { mu (V_j - V_i) + k_j (X_j - X_i) (1 - l_ij / |X_j - X_i|) } - nu V_i

with the spring constant k_j of the *neighbour* node j. The pair forces are then not equal and
opposite where k_i != k_j, so the paper's form does not conserve momentum (see
:func:`momentum_rate`); ``form="symmetric"`` uses (k_i + k_j) / 2 for both ends of an edge.

On the hot path, :meth:`SpringNetwork.forces` runs one compiled pass over the edges (numba);
:meth:`SpringNetwork.forces_numpy` is the same law as sparse matrix products over arrays, kept as
the readable reference that the tests compare against and the benchmark's baseline.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numba
import numpy as np
import scipy.sparse as sp


@numba.njit(cache=True, error_model="numpy")
def edge_forces(X, V, i, j, rest, k_on_i, k_on_j, mu, nu, out):  # pragma: no cover - compiled
    """One pass over the edges: spring and damping pair forces, then fluid resistance; the
    force (N, 3) is written into ``out`` and returned (the integrators' kernels call it).

    Works on flat views (3 a + d), as a C kernel would: numba then needs no row strides.
    """
    x = X.reshape(-1)
    v = V.reshape(-1)
    o = out.reshape(-1)
    for a in range(o.shape[0]):
        o[a] = -nu * v[a]
    for e in range(i.shape[0]):
        a = 3 * i[e]
        b = 3 * j[e]
        dx = x[b] - x[a]
        dy = x[b + 1] - x[a + 1]
        dz = x[b + 2] - x[a + 2]
        f = 1.0 - rest[e] / np.sqrt(dx * dx + dy * dy + dz * dz)
        dvx = mu * (v[b] - v[a])
        dvy = mu * (v[b + 1] - v[a + 1])
        dvz = mu * (v[b + 2] - v[a + 2])
        ka = k_on_i[e] * f
        kb = k_on_j[e] * f
        o[a] += ka * dx + dvx
        o[a + 1] += ka * dy + dvy
        o[a + 2] += ka * dz + dvz
        o[b] -= kb * dx + dvx
        o[b + 1] -= kb * dy + dvy
        o[b + 2] -= kb * dz + dvz
    return out


@dataclass(frozen=True)
class SpringNetwork:
    """Edges, rest lengths and per-node constants, with the sparse operators built once.

    Attributes
    ----------
    i, j : (E,) int64, the two ends of every edge (each edge once).
    rest : (E,) float64, rest lengths l_ij (m).
    k_node : (N,) float64, per-node spring constants (1/s^2 for unit mass).
    mu, nu : damping and fluid resistance (1/s).
    form : "paper" or "symmetric".
    k_on_i, k_on_j : (E,) float64, the constant each edge's spring has at its end i, at its
        end j (derived; the arguments of :func:`edge_forces`).
    """

    i: np.ndarray
    j: np.ndarray
    rest: np.ndarray
    k_node: np.ndarray
    mu: float
    nu: float
    form: str = "paper"
    # derived in __post_init__
    k_on_i: np.ndarray = field(init=False, repr=False, compare=False)
    k_on_j: np.ndarray = field(init=False, repr=False, compare=False)
    laplacian: sp.csr_matrix = field(init=False, repr=False, compare=False)
    _signed: sp.csr_matrix = field(init=False, repr=False, compare=False)
    _damping: sp.csr_matrix = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        n = len(self.k_node)
        e = len(self.i)
        ones = np.ones(e)
        cols = np.arange(e)
        # scatter matrices: node i gathers from its edges
        scatter_i = sp.csr_matrix((ones, (self.i, cols)), shape=(n, e))
        scatter_j = sp.csr_matrix((ones, (self.j, cols)), shape=(n, e))
        if self.form == "paper":
            k_on_i, k_on_j = self.k_node[self.j], self.k_node[self.i]
        else:
            k_on_i = k_on_j = 0.5 * (self.k_node[self.i] + self.k_node[self.j])
        # F_spring = S_i diag(k_on_i) g - S_j diag(k_on_j) g, g_e = (X_j - X_i)(1 - l/|.|)
        signed = (scatter_i @ sp.diags(k_on_i) - scatter_j @ sp.diags(k_on_j)).tocsr()
        object.__setattr__(self, "k_on_i", np.ascontiguousarray(k_on_i, dtype=np.float64))
        object.__setattr__(self, "k_on_j", np.ascontiguousarray(k_on_j, dtype=np.float64))
        adjacency = sp.csr_matrix(
            (np.ones(2 * e), (np.r_[self.i, self.j], np.r_[self.j, self.i])), shape=(n, n)
        )
        laplacian = (sp.diags(np.asarray(adjacency.sum(axis=1)).ravel()) - adjacency).tocsr()
        object.__setattr__(self, "_signed", signed)
        object.__setattr__(self, "_damping", (-self.mu * laplacian - self.nu * sp.eye(n)).tocsr())
        object.__setattr__(self, "laplacian", laplacian)

    @property
    def n_nodes(self) -> int:
        return len(self.k_node)

    def forces(self, X: np.ndarray, V: np.ndarray) -> np.ndarray:
        """(N, 3) force on every node (= acceleration, unit masses) at positions X, velocities V."""
        out = np.empty_like(X)
        return edge_forces(X, V, self.i, self.j, self.rest, self.k_on_i, self.k_on_j,
                            self.mu, self.nu, out)

    def damping_force(self, V: np.ndarray) -> np.ndarray:
        """The velocity part of the force alone: mu (V_j - V_i) summed over the edges, minus
        nu V_i (linear in V; V may be (N,) for one component)."""
        return self._damping @ V

    def forces_numpy(self, X: np.ndarray, V: np.ndarray) -> np.ndarray:
        """The same law as :meth:`forces`, as sparse matrix products (the reference)."""
        d = X[self.j] - X[self.i]
        length = np.sqrt(np.einsum("ij,ij->i", d, d))
        g = d * (1.0 - self.rest / length)[:, None]
        return self._signed @ g + self._damping @ V


def network_from_edges(points, edges, k_node, mu, nu, form="paper") -> SpringNetwork:
    """A :class:`SpringNetwork` whose rest lengths are the edge lengths at ``points``."""
    edges = np.asarray(edges, dtype=np.int64)
    rest = np.linalg.norm(points[edges[:, 1]] - points[edges[:, 0]], axis=1)
    return SpringNetwork(edges[:, 0].copy(), edges[:, 1].copy(), rest,
                         np.asarray(k_node, dtype=np.float64), float(mu), float(nu), form)


def momentum_rate(net: SpringNetwork, X: np.ndarray, V: np.ndarray) -> np.ndarray:
    """(3,) rate of change of total momentum from the internal forces (spring and damping).

    Zero for the symmetric form; for the paper's form it is
    sum_e (k_j - k_i) g_e, the imbalance of the unequal pair forces. Fluid resistance (nu),
    an external force, is left out.
    """
    d = X[net.j] - X[net.i]
    length = np.sqrt(np.einsum("ij,ij->i", d, d))
    g = d * (1.0 - net.rest / length)[:, None]
    if net.form == "paper":
        return ((net.k_node[net.j] - net.k_node[net.i])[:, None] * g).sum(axis=0)
    return np.zeros(3)


def smooth_step(x: np.ndarray, edge: float, width: float) -> np.ndarray:
    """0 well below ``edge``, 1 well above, a cubic smoothstep over ``width`` around it."""
    t = np.clip((x - edge) / width + 0.5, 0.0, 1.0)
    return t * t * (3 - 2 * t)


def region_constants(s: np.ndarray, head_end: float, tail_start: float, k_head: float,
                     k_pivot: float, k_tail: float, transition: float) -> np.ndarray:
    """(N,) per-node spring constants: k_head, rising to k_pivot in the pivot (thorax)
    region between ``head_end`` and ``tail_start``, falling to k_tail behind it."""
    up = smooth_step(s, head_end, transition)
    down = smooth_step(s, tail_start, transition)
    return k_head + (k_pivot - k_head) * up + (k_tail - k_pivot) * down


# -- the force's derivatives (the integrators' Jacobian, the stability analysis) ------------

def _edge_blocks(net: SpringNetwork, X: np.ndarray, symmetric: bool):
    d = X[net.j] - X[net.i]
    length = np.linalg.norm(d, axis=1)
    unit = d / length[:, None]
    ratio = net.rest / length
    # d g / d d for g = d (1 - l/|d|): (1 - l/|d|) I + (l/|d|) n n^T
    J = (ratio[:, None, None] * unit[:, :, None] * unit[:, None, :]
         + (1.0 - ratio)[:, None, None] * np.eye(3)[None])
    if symmetric or net.form == "symmetric":
        k_i = k_j = 0.5 * (net.k_node[net.i] + net.k_node[net.j])
    else:
        k_i, k_j = net.k_node[net.j], net.k_node[net.i]  # constant felt at i, at j
    return J, k_i, k_j


def stiffness_matrix(net: SpringNetwork, points: np.ndarray,
                     symmetric: bool = True) -> sp.csr_matrix:
    """(3N, 3N) linearised stiffness K = -dF/dX at ``points``: K u is minus the change of the
    spring force for a small displacement u. At rest it is sum_e k n n^T (n the edge's unit
    direction); away from rest it includes the geometric term (1 - l/|d|)(I - n n^T).

    ``symmetric=True`` uses (k_i + k_j)/2 at both ends of an edge (a symmetric matrix) even for
    the paper's form; ``False`` is the true Jacobian of the network's force.
    """
    n = net.n_nodes
    J, k_i, k_j = _edge_blocks(net, points, symmetric)
    a = np.arange(3)
    rows, cols, vals = [], [], []
    for (r, c, w) in ((net.i, net.i, k_i), (net.i, net.j, -k_i),
                      (net.j, net.j, k_j), (net.j, net.i, -k_j)):
        rows.append((3 * r[:, None, None] + a[None, :, None]) + 0 * a[None, None, :])
        cols.append((3 * c[:, None, None] + a[None, None, :]) + 0 * a[None, :, None])
        vals.append(w[:, None, None] * J)
    return sp.csr_matrix(
        (np.concatenate([v.ravel() for v in vals]),
         (np.concatenate([r.ravel() for r in rows]), np.concatenate([c.ravel() for c in cols]))),
        shape=(3 * n, 3 * n),
    )


def force_jacobian(net: SpringNetwork, X: np.ndarray) -> sp.csr_matrix:
    """(3N, 3N) dF/dX of the network's spring force at positions X (x, y, z interleaved)."""
    return -stiffness_matrix(net, X, symmetric=False)


def damping_matrix(net: SpringNetwork) -> sp.csr_matrix:
    """(3N, 3N) C = -dF/dV = (mu L + nu I) (x) I_3, constant."""
    c = net.mu * net.laplacian + net.nu * sp.identity(net.n_nodes)
    return sp.kron(c, sp.identity(3)).tocsr()
