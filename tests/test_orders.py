"""Each integrator keeps its order on the whole whale: the smooth stroke's force and the fluke
gate are part of the right-hand side, imposed at every stage time (not split off after each
step). The truth is a run at a much smaller step; the orders are observed, not assumed."""

import numpy as np
import pytest

from adapter.motion.animator import Animator
from adapter.motion.integrators import make_integrator
from adapter.motion.stability import stable_dt
from adapter.studies import numerics as nm

#: steps per quarter stroke, in the asymptotic range on the small smoke whale
STEPS = {"forward_euler": (400, 800), "verlet": (100, 200), "rk4": (48, 96)}
THEORY = {"forward_euler": 1, "verlet": 2, "rk4": 4}


@pytest.fixture(scope="module")
def whale(smoke_scene):
    """The small whale with the smooth stroke (the default) and the fluke gate; the smoke
    preset's ramp ends inside the half-stroke (0.05 cycle), so the step split there counts."""
    a = Animator.with_integrator(smoke_scene, nodes=nm.SMALL_NODES)
    assert a.smooth and a.fluke.any() and 0 < a.ramp_s < a.period / 2
    return a


@pytest.fixture(scope="module")
def truth(whale):
    X, _ = nm.whale_run(whale, "rk4", 2048)  # 21 times RK4's finest step below
    return X


@pytest.mark.slow
@pytest.mark.parametrize("method", sorted(STEPS))
def test_observed_order_on_the_whole_whale_is_the_methods(whale, truth, method):
    quarter = whale.period / 4
    errors = []
    for n in STEPS[method]:
        X, _ = nm.whale_run(whale, method, n)
        errors.append(float(np.linalg.norm(X - truth, axis=1).max()))
    dts = [quarter / n for n in STEPS[method]]
    order = np.polyfit(np.log(dts), np.log(errors), 1)[0]
    print(method, errors, f"order {order:.2f}")
    assert abs(order - THEORY[method]) < 0.2, (method, errors, order)


@pytest.mark.slow
@pytest.mark.parametrize("method", ["forward_euler", "symplectic_euler", "verlet", "rk4",
                                    "backward_euler"])
def test_compiled_driven_step_equals_the_generic_one(whale, method):
    """The stroke's force and the gate inside the numba kernels, against the same right-hand
    side assembled in Python around the network's force (the generic path)."""
    a = whale
    a.set_integrator(method, a.period / 4 / 100)
    a.advance_to(37)  # inside the ramp, the whale moving
    X, V, t = a.X.copy(), a.V.copy(), a.time
    fast = make_integrator(method, a.network.forces, a.dt, network=a.network)
    slow = make_integrator(method, lambda x, v: a.network.forces_numpy(x, v), a.dt,
                           network=a.network)
    for dt in (a.dt, 0.3 * a.dt):  # and a split step
        f = fast.step(X, V, t, drive=a.drive, dt=dt)
        s = slow.step(X, V, t, drive=a.drive, dt=dt)
        for x, y in zip(f, s, strict=True):
            np.testing.assert_allclose(x[a.dynamic], y[a.dynamic], rtol=1e-11, atol=1e-12)
        assert np.abs(f[1] - V).max() > 0  # the step moved


@pytest.mark.slow
def test_the_tether_is_in_the_stable_step(whale):
    """The tether's damping lowers symplectic Euler's bound: the animator's prediction takes
    the smaller of the steps with and without it."""
    a = whale
    free = a.dynamic
    # the fast estimate (as on large whales); with every mode (exact=True, 6 s): 0.0375 s
    # against 0.0403 s, and measured 0.0385 s with the tether (docs/numerics.md)
    plain = stable_dt(a.network, a.rest, "symplectic_euler", free=free, exact=False)
    tethered = stable_dt(a.network, a.rest, "symplectic_euler", free=free, exact=False,
                         tether=a.drive.tether)
    assert tethered < 0.97 * plain, (plain, tethered)
    # the animator's (forward Euler here) is never above the plain prediction
    assert a.stable_dt <= (1 + 1e-9) * stable_dt(a.network, a.rest, "forward_euler", free=free)
