"""Stable time steps of the integrators on a spring network, predicted from its linearisation.

Linearised about a configuration X, the network is u'' = -K u - C u' with unit masses, where
K = -dF/dX (:func:`~adapter.body.springs.stiffness_matrix`; not symmetric for the paper's
force law, which gives the two ends of an edge different constants) and
C = -dF/dV = (mu L + nu I) (x) I_3 (:func:`~adapter.body.springs.damping_matrix`; L the graph
Laplacian). The fluke nodes are moved by the gate, not by the springs, so their rows and
columns are dropped: only the free nodes take part.

The eigenvalues lambda of the first-order matrix A = [[0, I], [-K, -C]] (:func:`spectrum`)
decide. Each complex pair is one damped oscillator with omega^2 = |lambda|^2 and damping
c = -2 Re(lambda) (exact when K and C share their modes, the usual modal picture otherwise);
a real eigenvalue -r is treated as a pure damping mode (omega = 0, c = r). For each such mode
the step's 2x2 amplification matrix G(dt) is built by running the method itself on the scalar
oscillator, and the largest dt with spectral radius rho(G) <= 1 is found by bisection
(:func:`mode_stable_dt`). The method's stable step is the smallest over the modes. For a
lightly damped mode this gives the classical limits:

- forward Euler: dt <= c / omega^2 (= 2 zeta / omega): without damping no step is stable;
- symplectic Euler and velocity Verlet: omega dt < 2;
- classical RK4: omega dt < 2.83;
- backward Euler: any step (A-stable), reported as infinity.

The paper's own criterion, dt |F_i| <= 1 for every node, is :func:`paper_criterion_dt`.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from adapter.body.springs import SpringNetwork, damping_matrix, stiffness_matrix
from adapter.errors import IntegratorError
from adapter.motion.integrators import METHODS

#: stability limit of omega * dt for an undamped oscillator, per method (the methods' own
#: ``omega_dt_limit``; forward Euler's 0: no step is stable without damping)
OMEGA_DT_LIMIT = {name: cls.omega_dt_limit for name, cls in METHODS.items()}
#: the explicit methods, whose stable step is finite (the methods' own ``explicit``)
EXPLICIT = tuple(name for name, cls in METHODS.items() if cls.explicit)
#: systems up to this size (2 x free degrees of freedom) get every eigenvalue (dense)
DENSE_LIMIT = 1200
#: eigenvalues of largest modulus computed for larger systems
N_MODES = 120


def _free_dofs(n_nodes: int, free) -> np.ndarray:
    nodes = np.arange(n_nodes) if free is None else np.flatnonzero(np.asarray(free)) \
        if np.asarray(free).dtype == bool else np.asarray(free, dtype=np.int64)
    return (3 * nodes[:, None] + np.arange(3)).ravel()


def first_order_matrix(net: SpringNetwork, points: np.ndarray, free=None,
                       tether=(0.0, 0.0)) -> sp.csr_matrix:
    """(2m, 2m) A = [[0, I], [-K, -C]] on the free degrees of freedom (m = 3 x free nodes).

    ``free``: boolean mask (N,) or indices of the nodes the springs move (all if None).
    ``tether``: (k, c), a stiffness and a damping on every free node (the smooth stroke's
    tether, gait.stroke_force), added to K and C.
    """
    dofs = _free_dofs(net.n_nodes, free)
    m = len(dofs)
    K = stiffness_matrix(net, points, symmetric=False)[dofs][:, dofs] \
        + tether[0] * sp.identity(m)
    C = damping_matrix(net)[dofs][:, dofs] + tether[1] * sp.identity(m)
    return sp.bmat([[None, sp.identity(m)], [-K, -C]], format="csr")


def spectrum(net: SpringNetwork, points: np.ndarray, free=None,
             n_modes: int | None = None, tether=(0.0, 0.0)) -> np.ndarray:
    """Eigenvalues of :func:`first_order_matrix`: all of them (dense) for small systems,
    else the ``n_modes`` (default :data:`N_MODES`) of largest modulus (scipy.sparse.linalg.eigs),
    which hold the stiffest, step-limiting modes."""
    A = first_order_matrix(net, points, free, tether)
    if A.shape[0] <= DENSE_LIMIT and n_modes is None:
        return np.linalg.eigvals(A.toarray())
    from scipy.sparse.linalg import eigs

    k = min(n_modes or N_MODES, A.shape[0] - 2)
    return eigs(A, k=k, which="LM", tol=1e-8, return_eigenvectors=False)


def mode_parameters(lam: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(omega^2, c) of the damped oscillators behind eigenvalues ``lam`` of A.

    Neutral modes (|lambda| ~ 0: the out-of-plane motion a truss surface does not resist to
    first order) are left out.
    """
    lam = np.asarray(lam, dtype=complex)
    scale = np.abs(lam).max() if lam.size else 1.0
    keep = np.abs(lam) > 1e-9 * scale
    lam = lam[keep]
    complex_ = np.abs(lam.imag) > 1e-9 * scale
    w2 = np.where(complex_, np.abs(lam) ** 2, 0.0)
    c = np.where(complex_, -2.0 * lam.real, -lam.real)
    return w2, c


def _method(name: str):
    """The integrator class called ``name``; :class:`IntegratorError` for an unknown one."""
    if name not in METHODS:
        raise IntegratorError(f"unknown integrator {name!r}; known: {', '.join(METHODS)}")
    return METHODS[name]


def _oscillator_step(method: str, w2, c, h):
    """The 2x2 amplification matrix of one step of ``method`` on x'' = -w2 x - c x'."""
    def force(x, v):
        return -w2 * x - c * v

    integ = METHODS[method](force, 1.0)
    one, zero = np.ones_like(w2), np.zeros_like(w2)
    x1, v1 = integ.method_step(one, zero, h)
    x2, v2 = integ.method_step(zero, one, h)
    return x1, x2, v1, v2


def spectral_radius(method: str, w2, c, h) -> np.ndarray:
    """rho(G(h)) of ``method`` per mode (arrays broadcast)."""
    g11, g12, g21, g22 = _oscillator_step(method, w2, c, h)
    tr = g11 + g22
    det = g11 * g22 - g12 * g21
    root = np.sqrt(tr.astype(complex) ** 2 - 4 * det)
    return np.maximum(np.abs(tr + root), np.abs(tr - root)) / 2


def mode_stable_dt(method: str, w2: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Largest stable step of ``method`` per damped oscillator (omega^2, c), by bisection on
    the spectral radius of its amplification matrix."""
    w2 = np.atleast_1d(np.asarray(w2, dtype=float))
    c = np.atleast_1d(np.asarray(c, dtype=float))
    if not _method(method).explicit:
        return np.full(w2.shape, np.inf)
    lo = np.zeros_like(w2)
    hi = 4.0 / np.sqrt(w2 + 0.25 * c * c)
    for _ in range(8):  # make sure hi is unstable
        ok = spectral_radius(method, w2, c, hi) <= 1 + 1e-12
        if not ok.any():
            break
        hi = np.where(ok, 2 * hi, hi)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        ok = spectral_radius(method, w2, c, mid) <= 1 + 1e-12
        lo = np.where(ok, mid, lo)
        hi = np.where(ok, hi, mid)
    return lo


def predict(net: SpringNetwork, points: np.ndarray, free=None, methods=None,
            exact: bool | None = None, tether=(0.0, 0.0)) -> dict:
    """Method -> largest stable step (s) predicted from the linearised network at ``points``.

    ``exact=True`` takes the modes from the eigenvalues of A (:func:`spectrum`: all of them
    up to :data:`DENSE_LIMIT` rows, else the :data:`N_MODES` of largest modulus; on the 500-
    and 600-node whales the step-limiting modes are among those); ``False`` the fast estimate
    for large meshes (:func:`_fast_modes`); ``None`` picks exact up to twice DENSE_LIMIT rows.
    ``tether``: (k, c) on every free node (the smooth stroke's tether), see
    :func:`first_order_matrix`. It shifts every mode to (omega^2 + k, c_m + c) when K and C
    share their modes; the fast estimate takes that shift for the stiffest mode, and for
    forward Euler min(bound without it, c / k) (each mode's (c_m + c) / (omega^2 + k) is at
    least the smaller of c_m / omega^2 and c / k).
    """
    methods = methods or tuple(METHODS)
    dofs = _free_dofs(net.n_nodes, free)
    if exact is None:
        exact = 2 * len(dofs) <= 2 * DENSE_LIMIT
    out = {}
    if exact:
        w2, c = mode_parameters(spectrum(net, points, free, tether=tether))
        for m in methods:
            out[m] = float(mode_stable_dt(m, w2, c).min()) if len(w2) else np.inf
        return out
    top, fe_dt = _fast_modes(net, points, dofs, need_fe="forward_euler" in methods)
    if tether[0] > 0 or tether[1] > 0:
        top = (top[0] + tether[0], top[1] + tether[1])
        fe_dt = min(fe_dt, tether[1] / tether[0]) if tether[0] > 0 else fe_dt
    for m in methods:
        if m == "forward_euler":
            out[m] = fe_dt
        else:
            out[m] = float(mode_stable_dt(m, *top).min())
    return out


def _fast_modes(net, points, dofs, need_fe=True):
    """For large meshes: the stiffest mode of the symmetric part of K, (omega^2, c) with c its
    Rayleigh quotient of C; and a lower bound on forward Euler's step.

    Forward Euler needs dt <= c / omega^2 per mode, i.e. dt <= 1 / theta_max with theta the
    largest ratio u^T K u / u^T C u. Edge by edge, k (n . du)^2 <= k |du|^2, so
    theta_max <= k_max / mu, and theta_max <= lambda_max(K) / nu: the step
    max(mu / k_max, nu / lambda_max(K)) is always stable. On the smoke whale it is 24 %, 6.5 %,
    4.9 % and 3 % below the exact modal value (:func:`predict` with ``exact=True``) at mu = 0.05,
    0.3, 0.5 and 3 (tests/test_numerics.py): on the safe side, most so at low damping.
    """
    from scipy.sparse.linalg import eigsh

    K = stiffness_matrix(net, points, symmetric=False)[dofs][:, dofs]
    K = (0.5 * (K + K.T)).tocsr()
    C = damping_matrix(net)[dofs][:, dofs]
    w, v = eigsh(K, k=1, which="LA", tol=1e-6)
    u = v[:, 0]
    top = (np.array([w[0]]), np.array([float(u @ (C @ u) / (u @ u))]))
    fe_dt = np.nan
    if need_fe:
        if net.form == "symmetric":
            k_edge = 0.5 * (net.k_node[net.i] + net.k_node[net.j])
        else:
            k_edge = np.maximum(net.k_node[net.i], net.k_node[net.j])
        fe_dt = max(net.mu / k_edge.max(), net.nu / w[0])
    return top, fe_dt


def stable_dt(net: SpringNetwork, points: np.ndarray, method: str, free=None,
              exact: bool | None = None, tether=(0.0, 0.0)) -> float:
    """Largest stable step (s) of ``method`` predicted from the linearised network at
    ``points`` (inf for backward Euler). ``free``: the nodes the springs move (all if None);
    ``exact``: see :func:`predict` (exact for small meshes, else the fast estimate);
    ``tether``: (k, c) on every free node, see :func:`predict`."""
    if not _method(method).explicit:
        return np.inf
    return predict(net, points, free, methods=(method,), exact=exact, tether=tether)[method]


def paper_criterion_dt(F: np.ndarray) -> float:
    """The paper's criterion dt |F_i| <= 1 for every node: the step 1 / max_i |F_i| (s) it
    allows at forces F (N, 3). (Dimensionally it compares m/s with 1: it changes with units.)"""
    peak = float(np.sqrt(np.einsum("ij,ij->i", F, F)).max())
    return 1.0 / peak if peak > 0 else np.inf
