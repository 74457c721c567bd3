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
