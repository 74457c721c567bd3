"""Time steps, model failure, NaN, unreadable restart state and absurd times
(docs/faults.md)."""

from __future__ import annotations

import re

import numpy as np
import pytest

from adapter.coupling import protocol as wire
from adapter.coupling.protocol import (
    ErrorCode,
    MessageType,
)
from adapter.coupling.server import StepServer
from adapter.errors import AdapterError
from adapter.motion.animator import Animator
from adapter.motion.integrators import make_integrator

from ..wire_client import Client, ServerSaid, finished

# --- time steps, model failure, NaN -----------------------------------------------------------


def test_a_large_flow_step_is_sub_stepped(case, serve, animator, points, truth):
    """Flow steps of 0.35 s (450 internal steps each) give exactly the finely stepped motion."""
    srv = serve(case)
    c = Client(case)
    _, _, dt = c.hello(points)
    assert dt == animator.dt and dt < 0.5 * animator.stable_dt * 1.000001
    for t in (0.35, 0.7):
        d = c.displacement(t)
        assert np.isfinite(d).all() and np.array_equal(d, truth(t))
    c.bye()
    assert finished(srv) == 0


def _numbers(text: str) -> list:
    return [float(x) for x in re.findall(r"\d+(?:\.\d+)?(?:e[-+]?\d+)?", text)]


@pytest.mark.parametrize("factor", [1.5, 20.0])
def test_a_forced_step_past_the_stable_one_is_refused_naming_it(scene, animator, factor):
    """integrator.dt_s beyond the predicted stable step: an error naming that step."""
    bad = scene.replace(integrator={"dt_s": factor * animator.stable_dt})
    with pytest.raises(AdapterError) as info:
        Animator(bad, animator.surface)
    named = _numbers(str(info.value))
    assert any(abs(x - animator.stable_dt) <= 0.01 * animator.stable_dt for x in named), \
        f"the message does not name the stable step {animator.stable_dt:.3g} s: {info.value}"
    assert "dt_s" in str(info.value)


def test_a_blow_up_reaches_the_client_as_error_6_never_as_nan(case, serve, scene, points):
    """The real integrator run at 20x its stable step: ERROR 6 naming the stable step."""
    a = Animator(scene)
    a.integrator = make_integrator(scene.integrator.method, a.network.forces, 20 * a.dt,
                                   runaway=2.0 * a.surface.length, reference=a.rest,
                                   stable_dt=a.stable_dt, network=a.network)
    srv = serve(case, animator=a)
    c = Client(case)
    c.hello(points)
    served = 0
    with pytest.raises(ServerSaid) as info:
        for k in range(1, 200):
            assert np.isfinite(c.displacement(0.01 * k)).all()
            served += 1
    assert info.value.code == ErrorCode.MODEL_FAILURE
    assert "blew up" in info.value.message
    assert f"{a.stable_dt:.3g} s" in info.value.message
    assert finished(srv) == 1
    assert srv.stats["model_failure"] == info.value.message
    rows = (case / "adapter" / "keypoints.csv").read_text().splitlines()[1:]
    assert len(rows) == served
    assert all(np.isfinite(np.array(r.split(",")[1:19], dtype=float)).all() for r in rows)


@pytest.mark.parametrize("when", ["asked", "worked ahead"])
def test_a_non_finite_motion_is_never_sent(case, serve, scene, points, when):
    """An animator that returns NaN (instead of raising) still ends in ERROR 6, not NaN."""
    class Broken(Animator):
        def displacement(self, t):
            d = super().displacement(t)
            if t > 0.025:
                d = d.copy()
                d[3, 1] = np.nan
            return d

    srv = serve(case, animator=Broken(scene))
    c = Client(case)
    c.hello(points)
    times = (0.01, 0.02, 0.03) if when == "worked ahead" else (0.01, 0.03)
    for t in times[:-1]:
        assert np.isfinite(c.displacement(t)).all()
    with pytest.raises(ServerSaid) as info:
        c.displacement(times[-1])
    assert info.value.code == ErrorCode.MODEL_FAILURE and "not finite" in info.value.message
    assert "dt_s" in info.value.message
    assert finished(srv) == 1


# --- restart state ----------------------------------------------------------------------------


@pytest.mark.parametrize("content", [
    pytest.param(b"", id="empty"),
    pytest.param(b"PK\x03\x04 cut short", id="cut-zip"),
    pytest.param(b"not a zip file at all", id="garbage")])
def test_an_unreadable_state_file_is_ignored_on_restart(case, serve, points, truth, content):
    """A state file cut short (disk full, a partial copy) must not block the restart."""
    srv = serve(case)
    c = Client(case)
    c.hello(points)
    c.displacement(0.01)
    c.call(MessageType.WRITE, wire.pack_write(0.01))
    c.bye()
    assert finished(srv) == 0
    (case / "adapter" / "state_0.015.npz").write_bytes(content)
    srv = serve(case)
    c = Client(case)
    c.hello(points)
    assert np.array_equal(c.displacement(0.02), truth(0.02))
    c.bye()
    assert finished(srv) == 0



def test_absurd_and_negative_times_are_refused_not_hung(tmp_path, smoke_scene):
    """A REQUEST 1e300 s ahead would keep the animator marching for ever: it is an ERROR."""
    srv = StepServer(tmp_path, smoke_scene)
    srv.start()
    try:
        for t, words in ((1e300, "stroke cycles ahead"), (-1.0, "finite time >= 0")):
            with pytest.raises(wire.WireError, match=words):
                srv.timeline.check_time(t, "REQUEST")
        srv.timeline.check_time(10 * smoke_scene.period_s, "REQUEST")  # a long step is fine
    finally:
        srv.close()
