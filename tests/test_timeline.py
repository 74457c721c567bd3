"""The step-server's parts without sockets: the motion timeline (work-ahead, going back, the
time checks), the state store, and the VTK files (adapter/vtkfiles.py) read back."""

import math
import time

import numpy as np
import pytest

from adapter import vtkfiles
from adapter.coupling.protocol import ErrorCode, WireError
from adapter.coupling.store import StateStore, fingerprint
from adapter.coupling.timeline import MAX_JUMP_CYCLES, Timeline
from adapter.errors import UnstableError, VTKFileError
from adapter.motion.animator import Animator

DT = 0.01


@pytest.fixture()
def animator(smoke_scene, smoke_surface):
    return Animator(smoke_scene, smoke_surface)


@pytest.fixture(scope="module")
def truth(smoke_scene, smoke_surface):
    """The uninterrupted displacement at t = DT, 2 DT, ..., 8 DT."""
    ref = Animator(smoke_scene, smoke_surface)
    return {k: np.array(ref.displacement(k * DT)) for k in range(1, 9)}


def _settle(timeline, timeout=30.0):
    """Start the work-ahead (the answer is sent, as the session does) and wait for it."""
    timeline.work_ahead()
    timeline.join(timeout)


def test_steps_match_an_uninterrupted_animator(animator, truth):
    served = []
    tl = Timeline(animator, on_served=lambda s, restart: served.append((s.t, restart)))
    for k in range(1, 5):
        m = tl.motion(k * DT, last_t=(k - 1) * DT if k > 1 else None, restarted=(k == 1))
        np.testing.assert_array_equal(m.disp, truth[k])
        _settle(tl)
    assert served == [(DT, True), (2 * DT, False), (3 * DT, False), (4 * DT, False)]
    assert tl.stats.steps == 4
    # from the third step on the guess (the last step repeated) was right
    assert tl.stats.ahead_tries == 2 and tl.stats.ahead_hits == 2


def test_the_work_ahead_waits_until_the_answer_is_sent(animator, truth):
    # motion() only computes: the guess for the next time starts at work_ahead(), after the
    # session sent the answer (sharing the GIL with the compiled kernels delayed it)
    tl = Timeline(animator)
    for k in range(1, 4):
        tl.motion(k * DT, last_t=(k - 1) * DT if k > 1 else None, restarted=(k == 1))
        tl.join()
    assert tl.stats.ahead_tries == 0
    _settle(tl)                                     # ahead to 4 DT
    hit = tl.motion(4 * DT, last_t=3 * DT, restarted=False)
    assert tl.stats.ahead_tries == 1 and tl.stats.ahead_hits == 1
    np.testing.assert_array_equal(hit.disp, truth[4])
    # the hit's state (taken ahead) continues as an uninterrupted animator would
    _settle(tl)
    np.testing.assert_array_equal(tl.motion(5 * DT, last_t=4 * DT, restarted=False).disp,
                                  truth[5])
    assert tl.stats.ahead_hits == 2


def test_a_repeat_gets_the_same_state_and_a_miss_is_undone(animator, truth):
    tl = Timeline(animator)
    first = tl.motion(DT)
    assert tl.motion(DT) is first                   # computed once
    tl.motion(3 * DT, last_t=DT, restarted=False)   # the work-ahead guesses 5 DT
    _settle(tl)
    m = tl.motion(4 * DT, last_t=3 * DT, restarted=False)      # a miss: undone, still exact
    np.testing.assert_array_equal(m.disp, truth[4])
    assert tl.stats.ahead_tries == 1 and tl.stats.ahead_hits == 0


def test_time_backwards_is_refused_but_a_restart_may_go_back(animator, truth):
    tl = Timeline(animator)
    for k in range(1, 7):
        tl.motion(k * DT)
    _settle(tl)
    with pytest.raises(WireError) as err:
        tl.motion(5.5 * DT, last_t=6 * DT, restarted=False)
    assert err.value.code == ErrorCode.TIME_BACKWARDS
    with pytest.raises(WireError, match="only a restarted client may go back"):
        tl.motion(5.5 * DT, restarted=False)
    assert tl.served(2 * DT) is None                # no longer kept: computed again
    seen = []
    tl.on_served = lambda s, restart: seen.append((s.t, restart))
    back = tl.motion(2 * DT, restarted=True)        # replayed from t = 0 (no store), exact
    np.testing.assert_array_equal(back.disp, truth[2])
    assert seen == [(2 * DT, True)] and tl.served(6 * DT) is None


def test_side_motion_leaves_the_served_line_untouched(animator, truth):
    tl = Timeline(animator)
    tl.motion(DT)
    tl.motion(2 * DT, last_t=DT, restarted=False)
    _settle(tl)
    side = tl.side_motion(0.5 * DT)                 # behind: replayed, then put back
    assert side.t == 0.5 * DT and np.isfinite(side.disp).all()
    m = tl.motion(3 * DT, last_t=2 * DT, restarted=False)
    np.testing.assert_array_equal(m.disp, truth[3])


def test_check_time_refuses_absurd_and_negative_times(animator):
    tl = Timeline(animator)
    for t in (-1.0, math.inf, math.nan, (MAX_JUMP_CYCLES + 1) * animator.period):
        with pytest.raises(WireError):
            tl.check_time(t, "REQUEST")
    tl.check_time(10 * animator.period, "REQUEST")


def test_a_failed_model_computes_nothing_more(animator):
    tl = Timeline(animator)
    assert tl.fail("blown up") and not tl.fail("again")
    with pytest.raises(UnstableError, match="blown up"):
        tl.motion(DT)


def test_a_restart_resumes_from_the_store(tmp_path, animator, smoke_scene, truth):
    store = StateStore(tmp_path, fingerprint(smoke_scene, animator.surface, animator.dt),
                       animator.dt)
    tl = Timeline(animator, store)
    for k in (1, 2, 3, 4):
        tl.motion(k * DT)
    _settle(tl)
    store.save(tl.served(4 * DT))
    assert store.newest_time() == pytest.approx(4 * DT)
    (tmp_path / "state_9.npz").write_bytes(b"cut short")        # passed over with a warning
    fresh = Animator(smoke_scene, animator.surface)
    tl2 = Timeline(fresh, store)
    t0 = time.perf_counter()
    m = tl2.motion(5 * DT)                      # starts from the state at 4 DT, not t = 0
    assert time.perf_counter() - t0 < 60
    np.testing.assert_array_equal(m.disp, truth[5])
    assert fresh.time >= 4 * DT - 1e-12


def test_a_state_of_another_scene_is_not_restored(tmp_path, animator, truth):
    store = StateStore(tmp_path, "one scene", animator.dt)
    tl = Timeline(animator, store)
    tl.motion(3 * DT)
    store.save(tl.served(3 * DT))
    other = StateStore(tmp_path, "another scene", animator.dt)
    assert not other.restore(animator, 3 * DT)


# --- adapter/vtkfiles.py ----------------------------------------------------------------------

def test_pvd_round_trip_and_order(tmp_path):
    path = tmp_path / "whale.pvd"
    vtkfiles.write_pvd(path, {0.2: "b.vtp", 0.1: "a.vtp", 1e-5: "c.vtp"})
    assert vtkfiles.read_pvd(path) == {1e-5: "c.vtp", 0.1: "a.vtp", 0.2: "b.vtp"}
    text = path.read_text()
    assert text.index('"c.vtp"') < text.index('"a.vtp"') < text.index('"b.vtp"')
    assert not list(tmp_path.glob("*.tmp"))
    vtkfiles.write_pvd(path, [])
    assert vtkfiles.read_pvd(path) == {}


@pytest.mark.parametrize("text", ["<VTKFile><Collection><DataSet",
                                  '<VTKFile><DataSet timestep="x" file="a.vtp"/></VTKFile>',
                                  '<VTKFile><DataSet timestep="1"/></VTKFile>'])
def test_an_unreadable_pvd_is_a_named_error(tmp_path, text):
    path = tmp_path / "whale.pvd"
    path.write_text(text)
    with pytest.raises(VTKFileError, match="whale.pvd"):
        vtkfiles.read_pvd(path)


def test_vtp_round_trip(tmp_path):
    pv = pytest.importorskip("pyvista")
    points = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0.5]], dtype=float)
    tris = np.array([[0, 1, 2], [1, 3, 2]])
    disp = np.arange(12.0).reshape(4, 3)
    path = tmp_path / "s.vtp"
    vtkfiles.write_vtp(path, points, tris, point_data={"displacement": disp},
                       field_data={"time": [0.25]})
    mesh = pv.read(path)
    np.testing.assert_array_equal(mesh.points, points)
    np.testing.assert_array_equal(mesh.faces.reshape(-1, 4)[:, 1:], tris)
    np.testing.assert_array_equal(mesh.point_data["displacement"], disp)
    assert mesh.field_data["time"][0] == 0.25
    assert not list(tmp_path.glob("*.tmp*"))
