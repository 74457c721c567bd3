"""Forward Euler against the closed form of one damped spring; failure handling."""

import numpy as np
import pytest

from adapter.body.springs import network_from_edges
from adapter.errors import UnstableError
from adapter.motion.integrators import ForwardEuler, make_integrator


def _damped_spring(k=4.0, mu=0.3):
    """Two unit masses on one spring: the relative coordinate is a damped oscillator with
    stiffness 2k and damping 2mu (each mass feels the other's spring and damping)."""
    X0 = np.array([[0.0, 0, 0], [1.0, 0, 0]])
    net = network_from_edges(X0, [[0, 1]], [k, k], mu=mu, nu=0.0, form="symmetric")
    return X0, net


def _closed_form(t, k, mu, x0):
    w0 = np.sqrt(2 * k)
    zeta = 2 * mu / (2 * w0)
    wd = w0 * np.sqrt(1 - zeta**2)
    return np.exp(-zeta * w0 * t) * x0 * (np.cos(wd * t) + zeta * w0 / wd * np.sin(wd * t))


def _run(dt, t_end=2.0, k=4.0, mu=0.3, stretch=0.1):
    X0, net = _damped_spring(k, mu)
    X = X0.copy()
    X[1, 0] += stretch
    V = np.zeros_like(X)
    integ = ForwardEuler(net.forces, dt)
    for _ in range(int(round(t_end / dt))):
        X, V = integ.step(X, V)
    return (X[1, 0] - X[0, 0] - 1.0), _closed_form(t_end, k, mu, stretch)


def test_forward_euler_matches_closed_form_first_order():
    errors = []
    for dt in (2e-3, 1e-3, 5e-4):
        num, exact = _run(dt)
        errors.append(abs(num - exact))
    # first order: halving the step halves the error (the amplitude is small: linear regime)
    ratios = np.array(errors[:-1]) / np.array(errors[1:])
    assert np.all(np.abs(ratios - 2.0) < 0.2), ratios
    assert errors[-1] < 2e-4


def test_blow_up_raises_and_the_integrator_refuses_to_go_on():
    X0, net = _damped_spring(k=400.0, mu=0.0)
    X = X0.copy()
    X[1, 0] += 0.1
    V = np.zeros_like(X)
    integ = ForwardEuler(net.forces, 0.2, runaway=10.0, reference=X0, stable_dt=0.001)
    with pytest.raises(UnstableError, match="0.001"):
        for _ in range(1000):
            X, V = integ.step(X, V)
    assert integ.status == "failed"
    with pytest.raises(UnstableError):
        integ.step(X0, np.zeros_like(X0))


def test_unknown_method_is_named():
    with pytest.raises(ValueError, match="unknown integrator 'leapfrogish'"):
        make_integrator("leapfrogish", lambda X, V: X, 0.1)


# -- the whole family -----------------------------------------------------------------------

from adapter.motion.integrators import METHODS  # noqa: E402
from adapter.motion.stability import mode_stable_dt  # noqa: E402

THEORY = {"forward_euler": 1, "symplectic_euler": 1, "verlet": 2, "rk4": 4,
          "backward_euler": 1}


def _run_method(method, dt, t_end=2.0, k=4.0, mu=0.3, stretch=0.01):
    X0, net = _damped_spring(k, mu)
    X = X0.copy()
    X[1, 0] += stretch
    V = np.zeros_like(X)
    integ = make_integrator(method, net.forces, dt, network=net)
    for _ in range(int(round(t_end / dt))):
        X, V = integ.step(X, V)
    return (X[1, 0] - X[0, 0] - 1.0), _closed_form(t_end, k, mu, stretch)


@pytest.mark.parametrize("method", sorted(METHODS))
def test_each_method_converges_at_its_order(method):
    dts = (0.02, 0.01, 0.005) if method != "rk4" else (0.04, 0.02, 0.01)
    errors = [abs(np.subtract(*_run_method(method, dt))) for dt in dts]
    order = np.polyfit(np.log(dts), np.log(errors), 1)[0]
    assert abs(order - THEORY[method]) < 0.2, (method, errors, order)


@pytest.mark.parametrize("method", sorted(METHODS))
def test_compiled_step_equals_the_numpy_step(method):
    rng = np.random.default_rng(1)
    X0 = rng.standard_normal((30, 3))
    edges = np.array([[a, b] for a in range(30) for b in range(a + 1, 30) if rng.random() < 0.2])
    net = network_from_edges(X0, edges, rng.uniform(1, 5, 30), mu=0.2, nu=0.05)
    X = X0 + 0.05 * rng.standard_normal(X0.shape)
    V = 0.1 * rng.standard_normal(X0.shape)
    fast = make_integrator(method, net.forces, 0.01, network=net)
    slow = make_integrator(method, net.forces_numpy, 0.01, network=net)
    for a, b in zip(fast.step(X, V), slow.step(X, V), strict=True):
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12)


def test_single_oscillator_limits_are_the_classical_ones():
    w2, c = np.array([100.0]), np.array([0.0])
    assert mode_stable_dt("symplectic_euler", w2, c)[0] == pytest.approx(0.2, rel=1e-6)
    assert mode_stable_dt("verlet", w2, c)[0] == pytest.approx(0.2, rel=1e-6)
    assert mode_stable_dt("rk4", w2, c)[0] == pytest.approx(2 * np.sqrt(2) / 10, rel=1e-3)
    assert mode_stable_dt("forward_euler", w2, c)[0] < 1e-6  # none without damping
    # lightly damped: forward Euler's c / omega^2
    assert mode_stable_dt("forward_euler", w2, np.array([0.5]))[0] == pytest.approx(0.005,
                                                                                     rel=1e-6)
    assert np.isinf(mode_stable_dt("backward_euler", w2, c)[0])


def test_backward_euler_needs_the_network():
    X0, net = _damped_spring()
    with pytest.raises(ValueError, match="network"):
        make_integrator("backward_euler", net.forces, 0.1)


def test_each_methods_facts_are_its_class_attributes_and_the_docs_table_says_so():
    """Order, stages, force calls, cost and stability limit are written once, on the method's
    class: the stability analysis, the studies and docs/numerics.md read them from there."""
    from pathlib import Path

    from adapter.errors import IntegratorError
    from adapter.motion import stability
    from adapter.motion.integrators import method_table
    from adapter.studies import chooser, numerics

    for name, cls in METHODS.items():
        assert cls.name == name and cls.order >= 1 and len(cls.stages) >= 1
        assert numerics.THEORY_ORDER[name] == cls.order
        assert chooser.STEP_COST[name] == cls.step_cost >= cls.force_calls
        assert stability.OMEGA_DT_LIMIT[name] == cls.omega_dt_limit
        assert (name in stability.EXPLICIT) == cls.explicit
        limit = mode_stable_dt(name, np.array([1.0]), np.array([0.0]))[0]
        if cls.explicit:
            assert limit == pytest.approx(cls.omega_dt_limit, rel=1e-3, abs=1e-5)
        else:
            assert np.isinf(limit) and np.isinf(cls.omega_dt_limit)
    docs = Path(__file__).resolve().parent.parent / "docs" / "numerics.md"
    assert method_table() in docs.read_text()
    with pytest.raises(IntegratorError, match="unknown integrator 'leapfrogish'"):
        mode_stable_dt("leapfrogish", np.array([1.0]), np.array([0.0]))


# -- the base class's bookkeeping: step count, status, the check, the buffers ---------------

from adapter.errors import IntegratorError  # noqa: E402


def _free_particles(n=4):
    """n unit masses on no spring and no damping: X_k = X_0 + k dt V exactly."""
    X0 = np.arange(3.0 * n).reshape(n, 3)
    V0 = np.zeros_like(X0)
    V0[:, 0] = 1.0
    return X0, V0


@pytest.mark.parametrize("compiled", [True, False])
def test_runaway_is_caught_at_the_step_that_passes_the_limit(compiled):
    """Free particles at 1 m/s, steps of 0.25 s, runaway 1 m: the fourth step reaches 1 m
    exactly (still allowed), the fifth 1.25 m fails and says after how many steps; the failed
    integrator refuses to go on until restarted. Both the compiled checked step (the network's
    own force) and the generic one (a plain function)."""
    X0, V0 = _free_particles()
    net = network_from_edges(X0, [[0, 1]], np.zeros(4), mu=0.0, nu=0.0)
    force = net.forces if compiled else (lambda X, V: np.zeros_like(X))
    integ = ForwardEuler(force, 0.25, runaway=1.0, reference=X0, stable_dt=0.001,
                         network=net)
    assert integ.status == "running" and integ.n_steps == 0
    X, V = X0, V0
    for k in range(1, 5):
        X, V = integ.step(X, V)
        assert integ.n_steps == k
    np.testing.assert_array_equal(X - X0, np.outer([1.0] * 4, [1.0, 0, 0]))
    with pytest.raises(UnstableError) as info:
        integ.step(X, V)
    assert str(info.value) == (
        "forward_euler with dt = 0.25 s blew up after 5 steps (NaN or runaway motion); the "
        "largest stable step predicted for forward_euler is 0.001 s: lower integrator.dt_s (or "
        "set it to 0 to use the predicted stable step), or raise the damping springs.mu")
    assert integ.status == "failed"
    with pytest.raises(UnstableError, match="forward_euler: the integrator has failed before; "
                                            "start anew"):
        integ.step(X0, V0)
    integ.restart()
    assert integ.status == "running" and integ.n_steps == 5  # the count kept
    integ.restart(n_steps=2)
    assert integ.n_steps == 2
    integ.step(X0, V0)
    assert integ.n_steps == 3


def test_without_a_predicted_step_the_message_has_no_hint_and_nan_is_caught():
    X0, V0 = _free_particles()
    integ = ForwardEuler(lambda X, V: np.zeros_like(X), 0.25, runaway=1.0, reference=X0)
    V = V0.copy()
    V[2, 1] = np.nan
    with pytest.raises(UnstableError) as info:
        integ.step(X0, V)
    assert str(info.value).startswith("forward_euler with dt = 0.25 s blew up after 1 steps "
                                      "(NaN or runaway motion): lower integrator.dt_s")


def test_without_a_runaway_limit_only_nan_fails():
    """runaway None: any finite excursion is allowed, with or without a reference; without a
    reference a runaway limit has nothing to measure from."""
    X0, V0 = _free_particles()
    for kw in ({"reference": X0}, {"runaway": 1.0}, {}):
        integ = ForwardEuler(lambda X, V: np.zeros_like(X), 10.0, **kw)
        X, V = integ.step(X0, V0)
        np.testing.assert_array_equal(X - X0, 10.0 * V0)
        with pytest.raises(UnstableError):
            integ.step(X, np.full_like(V, np.inf))


def test_check_takes_states_of_any_shape():
    """The check on the arrays the stability analysis uses (1-D, or N x 2), as on N x 3."""
    integ = ForwardEuler(lambda X, V: -X, 0.1, runaway=1.0, reference=np.full(3, 4.0))
    integ.check(np.array([4.5, 3.0, 4.2]), np.zeros(3))
    with pytest.raises(UnstableError):
        integ.check(np.array([4.5, 2.5, 4.2]), np.zeros(3))
    with pytest.raises(UnstableError):
        ForwardEuler(lambda X, V: -X, 0.1).check(np.zeros(3), np.array([0.0, np.nan, 0.0]))
    with pytest.raises(UnstableError):
        ForwardEuler(lambda X, V: -X, 0.1).check(np.array([0.0, np.nan, 0.0]), np.zeros(3))
    ref = np.zeros((2, 2))
    integ = ForwardEuler(lambda X, V: -X, 0.1, runaway=1.0, reference=ref)
    integ.check(np.array([[0.5, -1.0], [0.0, 0.2]]), np.zeros((2, 2)))
    with pytest.raises(UnstableError):
        integ.check(np.array([[0.5, 1.5], [0.0, 0.2]]), np.zeros((2, 2)))
    integ = ForwardEuler(lambda X, V: -X, 0.1, runaway=1.0, reference=np.zeros((2, 4)))
    integ.check(np.array([[0.5, -1.0, 0, 1.0], [0.0, 0.2, 0, 0]]), np.zeros((2, 4)))
    with pytest.raises(UnstableError):  # the fourth column counts
        integ.check(np.array([[0.5, -1.0, 0, 1.5], [0.0, 0.2, 0, 0]]), np.zeros((2, 4)))
    with pytest.raises(UnstableError):  # an N x 3 state checked against its reference
        ForwardEuler(lambda X, V: -X, 0.1, runaway=1.0, reference=np.zeros((2, 3))).check(
            np.array([[0.0, 0, 0], [0, 0, -1.01]]), np.zeros((2, 3)))


@pytest.mark.parametrize("dt", [0.0, -0.1, float("nan")])
def test_a_step_that_is_not_positive_is_refused(dt):
    with pytest.raises(IntegratorError, match=rf"rk4: dt must be positive, got {dt}"):
        make_integrator("rk4", lambda X, V: X, dt)


def test_the_messages_say_what_to_do():
    with pytest.raises(IntegratorError, match=r"known: backward_euler, forward_euler, rk4, "
                                              r"symplectic_euler, verlet"):
        make_integrator("leapfrogish", lambda X, V: X, 0.1)
    X0, net = _damped_spring()
    with pytest.raises(IntegratorError, match=r"backward_euler needs the spring network for "
                                              r"its Jacobian: make_integrator\(\.\.\., "
                                              r"network=net\)"):
        make_integrator("backward_euler", net.forces, 0.1)


def _chain():
    """Five nodes on a line with springs and damping, stretched unevenly."""
    rng = np.random.default_rng(5)
    X0 = np.c_[np.arange(5.0), np.zeros(5), np.zeros(5)]
    net = network_from_edges(X0, [[k, k + 1] for k in range(4)], rng.uniform(2, 6, 5),
                             mu=0.4, nu=0.1)
    X = X0 + 0.05 * rng.standard_normal(X0.shape)
    V = 0.1 * rng.standard_normal(X0.shape)
    return net, X, V


@pytest.mark.parametrize("method", ["forward_euler", "symplectic_euler", "verlet", "rk4"])
def test_reused_buffers_keep_a_state_two_steps_and_give_the_same_steps(method):
    """reuse_buffers: the compiled steps write into three array sets in turn, so a returned
    state stays as returned through the next two steps and shares its memory with the state
    returned three steps later; the steps are the same as with fresh arrays, which are never
    overwritten (the default)."""
    net, X, V = _chain()
    reuse = make_integrator(method, net.forces, 0.01, network=net, reuse_buffers=True)
    fresh = make_integrator(method, net.forces, 0.01, network=net)
    a, b = [(X, V)], [(X, V)]
    kept = []
    for _ in range(7):
        a.append(reuse.step(*a[-1]))
        b.append(fresh.step(*b[-1]))
        np.testing.assert_array_equal(a[-1][0], b[-1][0])
        np.testing.assert_array_equal(a[-1][1], b[-1][1])
        kept.append((a[-1][0].copy(), a[-1][1].copy()))
        if len(a) >= 4:  # the state of two steps before is still intact
            np.testing.assert_array_equal(a[-3][0], kept[-3][0])
            np.testing.assert_array_equal(a[-3][1], kept[-3][1])
    for k in range(1, 5):
        assert np.shares_memory(a[k][0], a[k + 3][0]) and np.shares_memory(a[k][1], a[k + 3][1])
        assert not np.shares_memory(a[k][0], a[k + 1][0])
    for k in range(1, 8):  # fresh arrays: every returned state as it was
        np.testing.assert_array_equal(b[k][0], kept[k - 1][0])
        assert not any(np.shares_memory(b[k][0], b[m][0]) for m in range(1, 8) if m != k)
    # a state of another size (two more nodes, on no spring) gets buffers of its own
    Xb, Vb = reuse.step(np.vstack([X, [[9.0, 0, 0], [10.0, 0, 0]]]), np.vstack([V, V[:2]]))
    assert Xb.shape == Vb.shape == (7, 3)
    np.testing.assert_array_equal(Xb[:5], fresh.step(X, V)[0])


def test_another_networks_force_is_not_replaced_by_the_compiled_one():
    """The compiled step computes the network's own force: with the force of another network
    (other constants), or a wrapper of it, the step is the generic one with the force given,
    written out here as forward Euler."""
    net, X, V = _chain()
    other = network_from_edges(net_rest := np.c_[np.arange(5.0), np.zeros(5), np.zeros(5)],
                               [[k, k + 1] for k in range(4)], np.full(5, 50.0), mu=2.0, nu=0.0)
    assert net_rest.shape == (5, 3)
    for force in (other.forces, lambda x, v: other.forces(x, v)):
        integ = make_integrator("forward_euler", force, 0.01, network=net)
        X1, V1 = integ.step(X, V)
        np.testing.assert_allclose(X1, X + 0.01 * V, rtol=1e-15)
        np.testing.assert_allclose(V1, V + 0.01 * other.forces(X, V), rtol=1e-14)
    # a step of its own size (the animator's split step): dt for this step only
    integ = make_integrator("forward_euler", net.forces, 0.01, network=net)
    X1, V1 = integ.step(X, V, dt=0.003)
    np.testing.assert_allclose(V1, V + 0.003 * net.forces(X, V), rtol=1e-14)
    assert integ.dt == 0.01


def _affine_residual(net, X, V, X1, V1, dt):
    """Backward Euler's own equations, X1 = X + dt V1 and V1 = V + dt F(X1, V1)."""
    return (np.abs(X1 - X - dt * V1).max(),
            np.abs(V1 - V - dt * net.forces(X1, V1)).max())


def test_backward_euler_solves_its_implicit_equations_on_a_linear_force():
    """Nodes on a line moving along it: the spring force is linear in the stretch there
    (k (d - l) for d > 0), so the linearised step is backward Euler exactly: the new state
    satisfies X1 = X + dt V1 and V1 = V + dt F(X1, V1) to rounding, at a step 50 times
    forward Euler's stable one."""
    net, X, V = _chain()
    X[:, 1:] = 0.0
    V[:, 1:] = 0.0
    dt = 0.5
    integ = make_integrator("backward_euler", net.forces, dt, network=net)
    X1, V1 = integ.step(X, V)
    rx, rv = _affine_residual(net, X, V, X1, V1, dt)
    assert rx < 1e-14 and rv < 1e-12, (rx, rv)
    assert np.abs(V1 - V).max() > 0.01  # it moved
