"""Stable steps against truths from outside adapter/motion/stability.py: on a small closed spring
network, the exact forward-Euler bound from the eigenvalues of the linearised system (its
Jacobian taken by finite differences of the force law, its eigenvalues by numpy), and forward
Euler itself, written out here, run at and just past the bounds."""

import numpy as np
import pytest
import scipy.sparse as sp
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
    Jx, Jv = _fd_jacobians(net, X)
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


@pytest.mark.slow
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


@pytest.mark.slow
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


# -- one damped oscillator x'' = -w2 x - c x': each method's stable step from its own
#    amplification matrix, written out here from the method's definition --------------------

def _G(method, w2, c, h):
    """The 2x2 map (x, v) -> (x1, v1) of one step, from the step rules of
    adapter/motion/integrators.py worked out by hand for a = -w2 x - c v (RK4: R(hA) with
    R(z) = 1 + z + z^2/2 + z^3/6 + z^4/24)."""
    A = np.array([[0.0, 1.0], [-w2, -c]])
    if method == "forward_euler":                  # x1 = x + h v, v1 = v + h a
        return np.eye(2) + h * A
    if method == "symplectic_euler":               # v1 = v + h a, x1 = x + h v1
        return np.array([[1 - h * h * w2, h * (1 - h * c)], [-h * w2, 1 - h * c]])
    if method == "verlet":                         # x1 = x + h v + h^2/2 a0; the predictor
        return np.array([                          # v + h a0 damps a1; v1 = v + h/2 (a0 + a1)
            [1 - h * h * w2 / 2, h - h * h * c / 2],
            [-h * w2 + h ** 3 * w2 ** 2 / 4 + c * h * h * w2 / 2,
             1 - h * c - h * h * w2 / 2 + h ** 3 * w2 * c / 4 + h * h * c * c / 2]])
    if method == "rk4":
        Z = h * A
        return np.eye(2) + Z + Z @ Z / 2 + Z @ Z @ Z / 6 + Z @ Z @ Z @ Z / 24
    raise ValueError(method)


def _h_star(method, w2, c):
    """The largest h with every eigenvalue of _G inside the unit circle (bisection here)."""
    def ok(h):
        return np.abs(np.linalg.eigvals(_G(method, w2, c, h))).max() <= 1 + 1e-12
    lo, hi = 0.0, 1.0
    while ok(hi):
        lo, hi = hi, 2 * hi
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if ok(mid) else (lo, mid)
    return lo


def test_the_hand_amplification_matrices_are_the_methods():
    """_G is the integrators' own step on the oscillator (so the bounds below are theirs)."""
    from adapter.motion.integrators import METHODS
    for name in ("forward_euler", "symplectic_euler", "verlet", "rk4"):
        w2, c, h = 7.0, 0.3, 0.11
        integ = METHODS[name](lambda x, v, w2=w2, c=c: -w2 * x - c * v, 1.0)
        cols = [integ.method_step(np.array(1.0), np.array(0.0), h),
                integ.method_step(np.array(0.0), np.array(1.0), h)]
        G = np.array([[cols[0][0], cols[1][0]], [cols[0][1], cols[1][1]]])
        assert G == pytest.approx(_G(name, w2, c, h), rel=1e-13, abs=1e-15)


#: (omega^2, c): lightly damped, near critical, overdamped, pure damping, stiff
OSCILLATORS = [(100.0, 0.5), (4.0, 3.9), (1.0, 10.0), (0.0, 2.0), (2.5e5, 30.0)]


@pytest.mark.parametrize("method", ["forward_euler", "symplectic_euler", "verlet", "rk4"])
def test_mode_stable_dt_of_one_oscillator(method):
    from adapter.motion.stability import mode_stable_dt
    w2 = np.array([o[0] for o in OSCILLATORS])
    c = np.array([o[1] for o in OSCILLATORS])
    got = mode_stable_dt(method, w2, c)
    assert got.shape == w2.shape
    want = np.array([_h_star(method, a, b) for a, b in OSCILLATORS])
    pure = w2 == 0
    assert got[~pure] == pytest.approx(want[~pure], rel=1e-9)
    # pure damping: G has the eigenvalue 1 and R(-h c); where R nears 1 as well the
    # discriminant tr^2 - 4 det loses half its digits and the bisection stops up to 1e-4
    # short of the bound (RK4: 3e-5), on the safe side
    assert got[pure] <= want[pure] * (1 + 1e-12)
    assert got[pure] == pytest.approx(want[pure], rel=1e-4)
    # one mode at a time, scalars in: the same
    assert mode_stable_dt(method, w2[0], c[0]) == pytest.approx([want[0]], rel=1e-9)


def test_closed_forms_of_the_stable_step():
    """Forward Euler |1 + h lambda| <= 1: h = c / w2 (underdamped), 2 / |lambda_max|
    (overdamped); symplectic Euler (Jury): h = 4 / (c + sqrt(c^2 + 4 w2)); undamped, the
    classical limits omega h = 2 (symplectic Euler, Verlet) and 2 sqrt(2) (RK4)."""
    from adapter.motion.stability import mode_stable_dt
    fe = mode_stable_dt("forward_euler", [100.0, 1.0, 0.0], [0.5, 10.0, 2.0])
    assert fe == pytest.approx([0.5 / 100, 2 / (5 + np.sqrt(24)), 1.0], rel=1e-9)
    w2, c = np.array([100.0, 1.0, 0.0, 9.0]), np.array([0.5, 10.0, 2.0, 0.0])
    se = mode_stable_dt("symplectic_euler", w2, c)
    assert se == pytest.approx(4 / (c + np.sqrt(c * c + 4 * w2)), rel=1e-9)
    w2 = np.array([1e-4, 1.0, 400.0, 2.5e7])                # from a soft mode to a stiff one
    for method, limit in (("symplectic_euler", 2.0), ("verlet", 2.0),
                          ("rk4", 2 * np.sqrt(2))):
        assert mode_stable_dt(method, w2, 0 * w2) * np.sqrt(w2) == \
            pytest.approx(limit, rel=1e-9)
    # undamped forward Euler: no step is stable
    assert (mode_stable_dt("forward_euler", [1.0, 1e4], [0.0, 0.0])
            < 1e-5 / np.array([1, 100])).all()
    # the implicit method: any step
    assert mode_stable_dt("backward_euler", [1.0, 4.0], [0.1, 0.0]).tolist() == [np.inf] * 2


def test_spectral_radius_closed_forms():
    """rho of forward Euler's G is |1 + h lambda| = sqrt(1 - h c + h^2 w2) (underdamped);
    of symplectic Euler's sqrt(det G) = sqrt(1 - h c) while its eigenvalues are complex."""
    from adapter.motion.stability import spectral_radius
    w2, c, h = np.array([100.0, 25.0]), np.array([0.5, 1.0]), np.array([0.01, 0.02])
    assert spectral_radius("forward_euler", w2, c, h) == \
        pytest.approx(np.sqrt(1 - h * c + h * h * w2), rel=1e-12)
    assert spectral_radius("symplectic_euler", w2, c, h) == \
        pytest.approx(np.sqrt(1 - h * c), rel=1e-12)
    # overdamped: real eigenvalues 1 + h lambda, lambda = -c/2 +- sqrt(c^2/4 - w2)
    lam = -5 - np.sqrt(24)
    assert spectral_radius("forward_euler", 1.0, 10.0, 0.3) == pytest.approx(abs(1 + 0.3 * lam))


@pytest.mark.parametrize("method", ["symplectic_euler", "verlet", "rk4", "forward_euler"])
def test_the_oscillator_stays_bounded_just_below_the_step_and_grows_just_past_it(method):
    """Measured: the method itself run 3000 steps at 0.99 and 1.01 x the predicted step."""
    from adapter.motion.integrators import METHODS
    from adapter.motion.stability import mode_stable_dt
    w2, c = 400.0, 20.0                          # damping ratio 0.5
    h = float(mode_stable_dt(method, w2, c)[0])

    def amplitude(dt):
        integ = METHODS[method](lambda x, v: -w2 * x - c * v, dt)
        x, v = np.array(1.0), np.array(0.0)
        for _ in range(3000):
            x, v = integ.method_step(x, v, dt)
        return np.hypot(x, v / np.sqrt(w2))

    assert amplitude(0.99 * h) <= 1.0
    assert not amplitude(1.01 * h) <= 2.0        # grown (or overflowed to nan)


# -- the modes of a small network against an exact modal analysis ---------------------------

def _fd_jacobians(net, X):
    """dF/dX and dF/dV by central differences of the reference force law."""
    m = 3 * net.n_nodes
    V0 = np.zeros_like(X)
    Jx, Jv = np.empty((m, m)), np.empty((m, m))
    h = 1e-6
    for a in range(m):
        E = np.zeros(m)
        E[a] = h
        E = E.reshape(-1, 3)
        Jx[:, a] = ((net.forces_numpy(X + E, V0) - net.forces_numpy(X - E, V0)) / (2 * h)).ravel()
        Jv[:, a] = ((net.forces_numpy(X, V0 + E) - net.forces_numpy(X, V0 - E)) / (2 * h)).ravel()
    return Jx, Jv


def _deformed(n=14, seed=5, form="paper", mu=0.4, nu=0.1):
    X, net = _closed_net(mu=mu, nu=nu, form=form, n=n, seed=seed)
    # away from rest, so the geometric stiffness takes part
    return X * [1.04, 0.97, 1.02], net


def test_first_order_matrix_and_spectrum_against_finite_differences():
    """A = [[0, I], [dF/dX, dF/dV]] on the free nodes, with a tether (k, c) on them, and its
    eigenvalues, against numpy's eig of the finite-difference Jacobians."""
    from adapter.motion.stability import first_order_matrix, spectrum
    X, net = _deformed()
    Jx, Jv = _fd_jacobians(net, X)
    free = np.ones(net.n_nodes, bool)
    free[[0, 5, 6]] = False
    dofs = (3 * np.flatnonzero(free)[:, None] + np.arange(3)).ravel()
    m = len(dofs)
    k, c = 3.0, 0.25
    ff = np.ix_(dofs, dofs)
    want = np.block([[np.zeros((m, m)), np.eye(m)],
                     [Jx[ff] - k * np.eye(m), Jv[ff] - c * np.eye(m)]])
    for f in (free, np.flatnonzero(free), list(np.flatnonzero(free))):
        A = first_order_matrix(net, X, f, tether=(k, c))
        assert isinstance(A, sp.csr_matrix)              # as documented
        A = A.toarray()
        assert A.shape == (2 * m, 2 * m)
        assert A == pytest.approx(want, abs=1e-6 * np.abs(want).max())
    lam = np.sort_complex(spectrum(net, X, free, tether=(k, c)))
    exact = np.sort_complex(np.linalg.eigvals(want))
    assert len(lam) == 2 * m
    assert lam == pytest.approx(exact, abs=1e-5 * np.abs(exact).max())
    # every node free (None) is the whole network
    assert first_order_matrix(net, X).shape == (6 * net.n_nodes,) * 2


def test_the_largest_modes_of_a_larger_system(monkeypatch):
    """Past DENSE_LIMIT (or with n_modes) only the modes of largest modulus: those of numpy's
    full eig."""
    from adapter.motion import stability
    X, net = _deformed()
    A = stability.first_order_matrix(net, X).toarray()
    full = np.linalg.eigvals(A)
    top = np.sort(np.abs(full))[::-1]
    lam = stability.spectrum(net, X, n_modes=10)
    assert len(lam) == 10
    assert np.sort(np.abs(lam))[::-1] == pytest.approx(top[:10], rel=1e-6)
    monkeypatch.setattr(stability, "DENSE_LIMIT", A.shape[0] - 1)
    monkeypatch.setattr(stability, "N_MODES", 12)
    lam = stability.spectrum(net, X)
    assert len(lam) == 12
    assert np.sort(np.abs(lam))[::-1] == pytest.approx(top[:12], rel=1e-6)
    # more modes asked than there are: all but two (eigs' limit)
    assert len(stability.spectrum(net, X, n_modes=10 ** 6)) == A.shape[0] - 2
    monkeypatch.setattr(stability, "DENSE_LIMIT", A.shape[0])
    assert len(stability.spectrum(net, X)) == A.shape[0]


def test_mode_parameters_of_known_eigenvalues():
    """A pair -c/2 +- i sqrt(w2 - c^2/4) is the oscillator (w2, c); a real -r is pure
    damping (0, r); |lambda| below 1e-9 of the largest is neutral and left out."""
    from adapter.motion.stability import mode_parameters
    w2, c = 400.0, 3.0
    pair = -c / 2 + 1j * np.sqrt(w2 - c * c / 4) * np.array([1, -1])
    lam = np.r_[pair, -7.0, 1e-12, 1e-6 + 0j, 0.0]
    got_w2, got_c = mode_parameters(lam)
    assert got_w2 == pytest.approx([w2, w2, 0.0, 0.0])
    assert got_c == pytest.approx([c, c, 7.0, -1e-6])
    # a slow pair just above the threshold is kept as an oscillator
    slow = 1e-7 * np.array([1j, -1j])
    w2s, cs = mode_parameters(np.r_[20j, -20j, slow])
    assert w2s == pytest.approx([400, 400, 1e-14, 1e-14], rel=1e-9)
    assert cs == pytest.approx([0, 0, 0, 0], abs=1e-20)
    # the threshold is relative to the largest: 1e-4 next to 1e6 is neutral
    w2b, cb = mode_parameters(np.array([1e6j, -1e6j, -1e-4 + 0j]))
    assert w2b == pytest.approx([1e12, 1e12]) and cb == pytest.approx([0, 0], abs=1e-6)
    # exactly at the thresholds: left out; real
    w2e, ce = mode_parameters(np.array([2j, -2j, 2e-9, -0.5 + 2e-9j]))
    assert w2e == pytest.approx([4, 4, 0]) and ce == pytest.approx([0, 0, 0.5])
    e_w2, e_c = mode_parameters(np.array([]))
    assert e_w2.size == 0 and e_c.size == 0


def _modes_from_fd(net, X, free=None, tether=(0.0, 0.0)):
    Jx, Jv = _fd_jacobians(net, X)
    dofs = np.arange(3 * net.n_nodes) if free is None else \
        (3 * np.flatnonzero(free)[:, None] + np.arange(3)).ravel()
    m = len(dofs)
    A = np.block([[np.zeros((m, m)), np.eye(m)],
                  [Jx[np.ix_(dofs, dofs)] - tether[0] * np.eye(m),
                   Jv[np.ix_(dofs, dofs)] - tether[1] * np.eye(m)]])
    lam = np.linalg.eigvals(A)
    return lam[np.abs(lam) > 1e-7 * np.abs(lam).max()]


@pytest.mark.slow
@pytest.mark.parametrize("tether", [(0.0, 0.0), (50.0, 0.3)])
def test_predict_exact_against_the_modes_of_finite_differences(tether):
    """Every method's step: the smallest over the exact modes (numpy eig of the
    finite-difference system) of each mode's bound (_h_star, from the hand amplification
    matrix); backward Euler: infinite."""
    from adapter.motion.stability import predict, stable_dt
    X, net = _deformed()
    free = np.ones(net.n_nodes, bool)
    free[[1, 2]] = False
    lam = _modes_from_fd(net, X, free, tether)
    assert (lam.real < 0).all()
    complex_ = np.abs(lam.imag) > 1e-9 * np.abs(lam).max()
    w2 = np.where(complex_, np.abs(lam) ** 2, 0.0)
    c = np.where(complex_, -2 * lam.real, -lam.real)
    got = predict(net, X, free, exact=True, tether=tether)
    assert set(got) == {"forward_euler", "symplectic_euler", "verlet", "rk4", "backward_euler"}
    assert got["backward_euler"] == np.inf
    for method in ("forward_euler", "symplectic_euler", "verlet", "rk4"):
        # the stiffest few and the least damped few decide; check all of them
        want = min(_h_star(method, a, b) for a, b in zip(w2, c, strict=True))
        assert got[method] == pytest.approx(want, rel=1e-5), method
        assert stable_dt(net, X, method, free, exact=True, tether=tether) == got[method]
    # exact=None on a small system is the exact analysis
    assert predict(net, X, free, methods=("rk4",), tether=tether) == {"rk4": got["rk4"]}


def _sym_top(net, X, free=None):
    """The stiffest mode of the symmetric part of K = -dF/dX and its Rayleigh damping."""
    Jx, Jv = _fd_jacobians(net, X)
    dofs = np.arange(3 * net.n_nodes) if free is None else \
        (3 * np.flatnonzero(free)[:, None] + np.arange(3)).ravel()
    K = -Jx[np.ix_(dofs, dofs)]
    w, v = np.linalg.eigh(0.5 * (K + K.T))
    u = v[:, -1]
    return w[-1], float(u @ (-Jv[np.ix_(dofs, dofs)]) @ u)


@pytest.mark.slow
@pytest.mark.parametrize("form", ["paper", "symmetric"])
def test_the_fast_estimate_is_the_documented_bound(form):
    """exact=False: the other methods' step is that of the stiffest mode of K's symmetric
    part with its Rayleigh damping; forward Euler's is max(mu / k_max, nu / lambda_max(K)),
    k_max the largest constant any edge applies (the force law's own k_on_i, k_on_j); with a
    tether (k, c) the mode is shifted and forward Euler's step is at most c / k."""
    from adapter.motion.stability import predict, stable_dt
    for mu, nu in ((0.4, 0.1), (0.02, 40.0)):           # the mu term wins, then the nu term
        X, net = _deformed(form=form, mu=mu, nu=nu)
        lmax, cr = _sym_top(net, X)
        k_max = max(net.k_on_i.max(), net.k_on_j.max())
        got = predict(net, X, exact=False)
        assert got["forward_euler"] == pytest.approx(max(mu / k_max, nu / lmax), rel=1e-6)
        for method in ("symplectic_euler", "verlet", "rk4"):
            assert got[method] == pytest.approx(_h_star(method, lmax, cr), rel=1e-5), method
        assert got["backward_euler"] == np.inf
        assert stable_dt(net, X, "forward_euler", exact=False) == \
            pytest.approx(got["forward_euler"], rel=1e-9)
        for k, c in ((30.0, 0.5), (30.0, 1e4), (0.0, 0.5), (30.0, 0.0), (0.5, 1e-3),
                     (0.5, 0.0)):
            t = predict(net, X, exact=False, tether=(k, c))
            fe = min(got["forward_euler"], c / k) if k > 0 else got["forward_euler"]
            assert t["forward_euler"] == pytest.approx(fe, rel=1e-6)
            assert t["rk4"] == pytest.approx(_h_star("rk4", lmax + k, cr + c), rel=1e-5)
    # only the methods asked for; without forward Euler, its bound is not computed
    assert set(predict(net, X, exact=False, methods=("verlet",))) == {"verlet"}
    # some nodes held: the stiffest mode of the free ones
    free = np.ones(net.n_nodes, bool)
    free[[3, 4, 9]] = False
    lmax, cr = _sym_top(net, X, free)
    got = predict(net, X, free, exact=False)
    assert got["forward_euler"] == pytest.approx(max(net.mu / k_max, net.nu / lmax), rel=1e-6)
    assert got["rk4"] == pytest.approx(_h_star("rk4", lmax, cr), rel=1e-5)


def test_a_network_without_stiffness_or_damping_has_no_step_limit():
    """Every mode neutral (no springs, no damping): nothing limits the step."""
    from adapter.motion.stability import predict
    X, net = _closed_net(mu=0.0, nu=0.0, n=10)
    net = network_from_edges(X, np.c_[net.i, net.j], 0 * net.k_node, 0.0, 0.0)
    got = predict(net, X, exact=True)
    assert got == dict.fromkeys(got, np.inf) and len(got) == 5
    # nor on a network whose every node is held (free: no index, or an all-False mask)
    X, net = _deformed()
    for free in ([], np.zeros(net.n_nodes, bool)):
        assert predict(net, X, free, exact=True) == got


def test_the_mode_bracket_is_unstable_from_the_start():
    """mode_stable_dt brackets each mode with 4 / sqrt(w2 + c^2/4); for every explicit
    method and damping ratio from 0 to 100 that step is already unstable (so its doubling
    loop is a safety net: docs/mutation.md lists its mutants as equivalent)."""
    from adapter.motion.stability import spectral_radius
    w2 = np.ones(400)
    c = 2 * np.r_[0, np.geomspace(1e-4, 100, 399)]
    hi = 4.0 / np.sqrt(w2 + 0.25 * c * c)
    for method in ("forward_euler", "symplectic_euler", "verlet", "rk4"):
        assert (spectral_radius(method, w2, c, hi) > 1 + 1e-6).all(), method


def test_exact_is_chosen_by_size(monkeypatch):
    """exact=None: the modal analysis up to DENSE_LIMIT free degrees of freedom (A of twice
    that), the fast estimate past it."""
    from adapter.motion import stability
    X, net = _deformed(mu=0.02, nu=40.0)
    exact = stability.predict(net, X, exact=True, methods=("forward_euler",))
    fast = stability.predict(net, X, exact=False, methods=("forward_euler",))
    assert exact["forward_euler"] != pytest.approx(fast["forward_euler"], rel=1e-3)
    monkeypatch.setattr(stability, "DENSE_LIMIT", 3 * net.n_nodes)
    assert stability.predict(net, X, methods=("forward_euler",))["forward_euler"] == \
        pytest.approx(exact["forward_euler"], rel=1e-9)
    monkeypatch.setattr(stability, "DENSE_LIMIT", 3 * net.n_nodes - 1)
    assert stability.predict(net, X, methods=("forward_euler",))["forward_euler"] == \
        pytest.approx(fast["forward_euler"], rel=1e-9)


def test_stable_dt_names_and_refuses():
    from adapter.errors import IntegratorError
    from adapter.motion.stability import stable_dt
    X, net = _deformed()
    assert stable_dt(net, X, "backward_euler") == np.inf
    with pytest.raises(IntegratorError, match=r"unknown integrator 'leapfrog'; known: "
                                              r"forward_euler, .*backward_euler"):
        stable_dt(net, X, "leapfrog")


def test_paper_criterion_dt():
    """dt |F_i| <= 1 for every node: 1 / the largest force's length (a 3-4-12 force is 13)."""
    from adapter.motion.stability import paper_criterion_dt
    F = np.array([[1.0, 2.0, 2.0], [3.0, -4.0, 12.0], [0.0, 0.0, -5.0]])
    assert paper_criterion_dt(F) == pytest.approx(1 / 13, rel=1e-15)
    assert paper_criterion_dt(np.zeros((4, 3))) == np.inf
    assert paper_criterion_dt(F / 26) == pytest.approx(2.0, rel=1e-15)


@pytest.mark.slow
def test_the_fast_estimate_converges_on_a_larger_network():
    """On 1200 degrees of freedom the stiffest mode to the digits of a dense eigensolver
    (K's symmetric part from springs.stiffness_matrix, which tests/test_springs.py checks
    against finite differences)."""
    from adapter.body.springs import damping_matrix, stiffness_matrix
    from adapter.motion.stability import predict
    X, net = _closed_net(n=400, seed=2)
    X = X * [1.04, 0.97, 1.02]
    K = stiffness_matrix(net, X, symmetric=False).toarray()
    w, v = np.linalg.eigh(0.5 * (K + K.T))
    u = v[:, -1]
    c = float(u @ damping_matrix(net).toarray() @ u)
    got = predict(net, X, exact=False, methods=("rk4", "forward_euler"))
    assert got["rk4"] == pytest.approx(_h_star("rk4", w[-1], c), rel=1e-6)
    k_max = max(net.k_on_i.max(), net.k_on_j.max())
    assert got["forward_euler"] == pytest.approx(max(net.mu / k_max, net.nu / w[-1]), rel=1e-6)


def test_the_fast_estimate_takes_the_stiffest_mode_of_a_compressed_network():
    """Squeezed to half its rest size, the network's geometric stiffness (1 - l/|d|) is
    negative across its edges and K's eigenvalue of largest modulus is negative: the fast
    estimate still takes the largest (stiffest) one, as finite differences give it."""
    from adapter.motion.stability import predict
    X, net = _closed_net(n=14, seed=5)
    X = 0.5 * X
    lmax, cr = _sym_top(net, X)
    Jx, _ = _fd_jacobians(net, X)
    w = np.linalg.eigvalsh(-0.5 * (Jx + Jx.T))
    assert lmax > 0 and abs(w[0]) > lmax                  # the case in point
    got = predict(net, X, exact=False, methods=("rk4", "forward_euler"))
    assert got["rk4"] == pytest.approx(_h_star("rk4", lmax, cr), rel=1e-5)
    k_max = max(net.k_on_i.max(), net.k_on_j.max())
    assert got["forward_euler"] == pytest.approx(max(net.mu / k_max, net.nu / lmax), rel=1e-6)
