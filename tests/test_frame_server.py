"""The whale's frame at the step-server (protocol version 3): answered once per new served time
from that REQUEST's loads, part of the cached reply, and repeated exactly after a restart.

The frame here is a toy of its own, not the surge model: a velocity that integrates the loads
it is given, ``U_(n+1) = U_n + c . loads_n (t_(n+1) - t_n)``, and an acceleration that is that
step's rate, so that every frame depends on every load before it. Its truth is computed here by
the same recurrence on the loads the test sends, independently of the server.
"""

import math
import time

import numpy as np
import pytest

from adapter.coupling.frame import FixedFrame, FrameState
from adapter.coupling.protocol import ErrorCode
from adapter.scene import load_scene

from .wire_client import Client, ServerSaid, finished, points_near, server_starter

DT = 1 / 64
TIMES = [DT * k for k in range(1, 9)]
WRITTEN = 4                             # the WRITE after the 4th time: a restart resumes there
#: the loads' weights in the toy frame's velocity: forces and moments of x, y and z all count
WEIGHTS = np.linspace(-1.0, 1.0, 12) / 1000


def loads_at(k: int) -> np.ndarray:
    """The (12,) loads a client sends with its k-th REQUEST (k >= 1; the first has none)."""
    return np.sin(np.arange(1.0, 13.0) * (k + 0.5)) * 100.0


class IntegratingFrame:
    """A frame whose velocity integrates the loads it is given (NaN loads count as zero)."""

    def __init__(self, u0=1.3):
        self.u, self.t = np.array([u0, 0.0, 0.0]), 0.0
        self.asked: list = []

    def answer(self, time, request):
        self.asked.append((time, request.loads().copy()))
        loads = np.nan_to_num(request.loads(), nan=0.0)
        dt = time - self.t
        du = np.array([WEIGHTS @ loads, 0.5 * (WEIGHTS @ loads), 0.0]) * dt
        self.u, self.t = self.u + du, time
        return FrameState(self.u, du / dt)

    def state(self):
        return {"u": self.u.tolist(), "t": self.t}

    def restore(self, state):
        self.u, self.t = np.array(state["u"]), float(state["t"])


def truth() -> dict:
    """{t: (velocity, acceleration)} of the uninterrupted run, by the recurrence itself."""
    u, t_prev, out = np.array([1.3, 0.0, 0.0]), 0.0, {}
    for k, t in enumerate(TIMES):
        loads = np.zeros(12) if k == 0 else loads_at(k)
        du = np.array([WEIGHTS @ loads, 0.5 * (WEIGHTS @ loads), 0.0]) * (t - t_prev)
        u, t_prev = u + du, t
        out[t] = (u, du / (t - TIMES[k - 1] if k else t))
    return out


@pytest.fixture(scope="module")
def scene():
    return load_scene(preset="smoke")


@pytest.fixture
def serve(scene, smoke_animator):
    start, stop_all = server_starter(scene, smoke_animator, first_client_timeout=30)
    yield start
    stop_all()


@pytest.fixture
def points(smoke_animator):
    return points_near(smoke_animator.surface, 50, seed=1)


def _ask(client, k: int, t: float, first: bool):
    """The k-th REQUEST of a run at t: no loads on a connection's first."""
    if first:
        return client.exchange(t)
    loads = loads_at(k)
    return client.exchange(t, loads[0:3], loads[3:6], loads[6:9], loads[9:12])


def _run(case, serve, points, times, start_k: int, write_at=None):
    """One connection asking for ``times`` (the first of them the k = start_k-th request):
    {t: DISPLACEMENT payload}."""
    frame = IntegratingFrame()
    srv = serve(case, frame=frame)
    c = Client(case)
    c.hello(points)
    got = {}
    for i, t in enumerate(times):
        payload, reply = _ask(c, start_k + i, t, first=i == 0)
        assert _ask(c, start_k + i, t, first=i == 0)[0] == payload      # a repeat: same bytes
        got[t] = payload, reply
        if write_at is not None and t == write_at:
            c.write(t)
    c.bye()
    assert finished(srv) == 0
    return got, frame


def test_the_frame_follows_the_loads_and_repeats_after_a_restart(tmp_path, serve, points):
    """Uninterrupted: every frame is the recurrence's (so each REQUEST's loads reached the
    frame, moments included, once per new time). Restarted from the written time on a fresh
    server, its first REQUEST without loads: the same DISPLACEMENT bytes at every time after."""
    case = tmp_path / "case"
    case.mkdir()
    want = truth()
    whole, frame = _run(case, serve, points, TIMES, 0, write_at=TIMES[WRITTEN - 1])
    assert [t for t, _ in frame.asked] == TIMES                      # once per new time
    for t, (_, reply) in whole.items():
        np.testing.assert_allclose(reply.frame_velocity, want[t][0], rtol=1e-14, atol=0)
        np.testing.assert_allclose(reply.frame_acceleration, want[t][1], rtol=1e-12, atol=1e-15)
    assert (case / "adapter" / f"frame_{TIMES[WRITTEN - 1]!r}.json").is_file()

    again, frame2 = _run(case, serve, points, TIMES[WRITTEN:], WRITTEN)
    # the restart's frame was answered with the loads of the run that did not stop
    np.testing.assert_array_equal(frame2.asked[0][1], loads_at(WRITTEN))
    for t in TIMES[WRITTEN:]:
        assert again[t][0] == whole[t][0], f"t = {t}: not the uninterrupted run's bytes"


def test_a_restart_on_the_same_server_goes_back_to_the_written_frame(tmp_path, serve, points):
    """The client reconnects to a server that served well beyond the written time (its kept
    times do not reach back): the frame goes back to the written time's too."""
    case = tmp_path / "case"
    case.mkdir()
    written = 2
    srv = serve(case, frame=IntegratingFrame(), keep_serving=True)
    c = Client(case)
    c.hello(points)
    whole = {}
    for k, t in enumerate(TIMES):
        whole[t] = _ask(c, k, t, first=k == 0)[0]
        if k == written - 1:
            c.write(t)
    c.bye()
    deadline = time.monotonic() + 10
    while srv.links.linked() and time.monotonic() < deadline:     # the link is let go
        time.sleep(0.01)
    c = Client(case)
    c.hello(points)
    for i, t in enumerate(TIMES[written:]):
        assert _ask(c, written + i, t, first=i == 0)[0] == whole[t], f"t = {t}"
    c.bye()
    srv.stop()
    srv.thread.join(10)


def test_the_default_frame_is_the_scenes_inflow(tmp_path, serve, points, scene):
    case = tmp_path / "case"
    case.mkdir()
    srv = serve(case)
    c = Client(case)
    c.hello(points)
    _, reply = c.exchange(DT)
    assert reply.frame_velocity.tolist() == [scene.flow.speed_m_s, 0.0, 0.0]
    assert reply.frame_acceleration.tolist() == [0.0, 0.0, 0.0]
    c.bye()
    assert finished(srv) == 0


class _Broken(FixedFrame):
    def answer(self, time, request):
        return FrameState((math.nan, 0, 0), (0, 0, 0))


def test_a_non_finite_frame_is_a_model_failure(tmp_path, serve, points):
    case = tmp_path / "case"
    case.mkdir()
    srv = serve(case, frame=_Broken((1, 0, 0)))
    c = Client(case)
    c.hello(points)
    with pytest.raises(ServerSaid) as info:
        c.exchange(DT)
    assert info.value.code == ErrorCode.MODEL_FAILURE
    assert "frame at t = 0.015625 s is not finite" in info.value.message
    assert finished(srv) == 1


def test_use_frame_inflow_switches_only_the_inlet_and_the_body_force(tmp_path, smoke_scene,
                                                                     smoke_surface):
    """A prepared case keeps its (ramped) inflow and has no fvOptions; switched, the inlet of
    0.orig/U is whaleFrameInletVelocity from the ramp's start value, every other U entry as it
    was, and system/fvOptions holds the whaleFrameAcceleration option (the plugin library)."""
    from adapter.foam import case as C
    from adapter.foam import dictionaries as D

    case = tmp_path / "case"
    C.prepare_case(smoke_scene, case, surface=smoke_surface)
    before = D.parsed_dict(case / "0.orig" / "U")
    assert str(before["boundaryField"]["inlet"]["type"]) == "uniformFixedValue"   # the ramp
    assert not (case / "system" / "fvOptions").exists()
    D.use_frame_inflow(case)
    after = D.parsed_dict(case / "0.orig" / "U")
    inlet = after["boundaryField"]["inlet"]
    assert str(inlet["type"]) == "whaleFrameInletVelocity"
    assert str(inlet["value"]) == "uniform (0 0 0)"          # still water, as the ramp starts
    assert after["internalField"] == before["internalField"]
    for name in ("outlet", "sides", "whale"):
        assert after["boundaryField"][name] == before["boundaryField"][name]
    options = D.parsed_dict(case / "system" / "fvOptions")
    option = options[D.FRAME_OPTION]
    assert str(option["type"]) == "whaleFrameAcceleration"
    assert str(D.plugin_lib()) in str(option["libs"])
