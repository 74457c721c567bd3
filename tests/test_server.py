"""The step-server end to end: a small client speaks the protocol to a real server.

Each test serves the real Animator on the ``smoke`` preset in its own case folder (tmp_path).
"""

import json
import os
import socket
import stat
import struct
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from adapter.coupling import protocol as wire
from adapter.coupling.listener import PID_NAME
from adapter.coupling.mapping import PatchMap
from adapter.coupling.protocol import ENDPOINT_NAME, SOCKET_NAME, ErrorCode, MessageType
from adapter.coupling.server import ServerStartError, StepServer, time_name
from adapter.errors import UnstableError
from adapter.motion.animator import Animator
from adapter.scene import load_scene

from .wire_client import Client, ServerSaid, finished, points_near, server_starter

DT = 0.01
TIMES = [DT * k for k in range(1, 7)]


@pytest.fixture(scope="module")
def scene():
    return load_scene(preset="smoke")


@pytest.fixture(scope="module")
def animator(scene):
    """The animator the servers use (each server resets it)."""
    return Animator(scene)


@pytest.fixture(scope="module")
def reference(scene):
    """An independent animator: the uninterrupted truth."""
    ref = Animator(scene)
    ref.reset()
    cache = {t: np.array(ref.displacement(t)) for t in TIMES}
    return ref, cache


@pytest.fixture(scope="module")
def points(animator):
    """Patch points near the whale: on random triangles, lifted 1 mm off the surface."""
    return points_near(animator.surface, 600, seed=0)


@pytest.fixture
def case(tmp_path):
    d = tmp_path / "case"
    d.mkdir()
    return d


@pytest.fixture
def serve(scene, animator):
    start, stop_all = server_starter(scene, animator, first_client_timeout=30)
    yield start
    stop_all()


def expected(surface, pts, node_disp):
    return PatchMap.from_surface(pts, surface).apply(node_disp)


def test_serves_mapped_animator_displacement(case, serve, animator, points, reference):
    srv = serve(case)
    c = Client(case)
    n, max_dist, dt = c.hello(points)
    assert n == len(points) and 0 < max_dist < 0.01 and dt == animator.dt
    _, truth = reference
    for t in TIMES[:4]:
        payload, disp = c.request(t, (1.0, 2.0, 3.0), (0.1, 0.2, 0.3))
        assert np.abs(disp - expected(animator.surface, points, truth[t])).max() <= 1e-12
        assert c.request(t)[0] == payload                        # a repeat: the same bytes
    # the flow step shrinks: work-ahead guessed too far and is undone, still exact
    ref, _ = reference
    ref.reset()
    for t in (0.045, 0.047, 0.08):
        _, disp = c.request(t)
        assert np.abs(disp - expected(animator.surface, points, ref.displacement(t))).max() <= 1e-12
    c.bye()
    assert finished(srv) == 0
    stats = json.loads((case / "adapter" / "server-stats.json").read_text())
    assert stats["requests"] == 11 and stats["steps"] == 7 and stats["patch_points"] == 600
    assert stats["work_ahead_hits"] >= 2 and stats["mean_compute_s"] > 0
    rows = (case / "adapter" / "keypoints.csv").read_text().splitlines()
    assert rows[0].startswith("t,rostrum_x,rostrum_y,rostrum_z,") and rows[0].endswith("fz_v")
    assert len(rows) == 1 + 7 and len(rows[1].split(",")) == 1 + 18 + 6
    first = np.array(rows[1].split(","), dtype=float)
    assert first[0] == TIMES[0] and first[-6:].tolist() == [1, 2, 3, 0.1, 0.2, 0.3]
    assert not (case / SOCKET_NAME).exists()


def test_one_link_per_case_whatever_the_rank_count(case, serve, animator, points):
    """The master rank of a 2-rank run sends both ranks' points (100 shared ones twice) in one
    HELLO; a second client is refused as busy; the run ends with the link's BYE."""
    srv = serve(case)
    pa, pb = points[:300], points[200:]                          # 100 points on both ranks
    a = Client(case)
    assert a.hello(np.concatenate([pa, pb]), n_ranks=2)[0] == 700
    other = Client(case)
    with pytest.raises(ServerSaid) as info:
        other.hello(pb, n_ranks=2)
    assert info.value.code == ErrorCode.BUSY and "one link per case" in info.value.message
    for t in TIMES[:3]:
        _, d = a.request(t, (3, 3, 3), (0, 0, 2))
        assert np.array_equal(d[200:300], d[300:400])           # shared points: the same bits
    a.write(TIMES[2])
    a.bye()
    assert finished(srv) == 0                                    # no wait for a second rank
    rows = (case / "adapter" / "keypoints.csv").read_text().splitlines()[1:]
    assert len(rows) == 3
    assert np.array(rows[0].split(","), dtype=float)[-6:].tolist() == [3, 3, 3, 0, 0, 2]
    assert srv.stats["steps"] == 3 and srv.stats["requests"] == 3
    assert srv.stats["links"] == 1 and srv.stats["ranks"] == 2


def test_unknown_forces_leave_the_csv_fields_empty_never_nan(case, serve, points):
    """After a restart OpenFOAM's first REQUEST carries no forces (NaN): keypoints.csv gets
    empty force fields for that row, never the text nan."""
    srv = serve(case)
    c = Client(case)
    c.hello(points)
    c.request(TIMES[0])                                           # NaN forces
    c.request(TIMES[1], (1, 2, 3), (0.1, 0.2, 0.3))
    c.bye()
    assert finished(srv) == 0
    text = (case / "adapter" / "keypoints.csv").read_text()
    assert "nan" not in text.lower()
    rows = [r.split(",") for r in text.splitlines()[1:]]
    assert len(rows) == 2 and all(len(r) == 1 + 18 + 6 for r in rows)
    assert rows[0][-6:] == [""] * 6 and all(rows[0][:19])
    assert np.array(rows[1], dtype=float)[-6:].tolist() == [1, 2, 3, 0.1, 0.2, 0.3]


def test_write_outputs_read_back(case, serve, animator, points, reference):
    import pyvista as pv

    srv = serve(case)
    c = Client(case)
    c.hello(points)
    for t in TIMES[:3]:
        c.request(t)
    c.write(TIMES[1])                                             # an earlier served time
    c.write(TIMES[2])
    c.bye()
    assert finished(srv) == 0
    out = case / "adapter"
    mesh = pv.read(out / f"whale_{time_name(TIMES[2])}.vtp")
    s = animator.surface
    truth = reference[1][TIMES[2]]
    assert mesh.n_points == len(s.points) and mesh.n_cells == len(s.triangles)
    assert np.array_equal(mesh.point_data["displacement"], truth)
    assert np.allclose(mesh.points, s.points + truth)
    assert mesh.point_data["velocity"].shape == (len(s.points), 3)
    pvd = (out / "whale.pvd").read_text()
    assert pvd.count("<DataSet") == 2 and f'file="whale_{time_name(TIMES[1])}.vtp"' in pvd
    with np.load(out / f"state_{time_name(TIMES[2])}.npz") as z:
        assert float(z["time"]) == TIMES[2] and any(k.startswith("ckpt:") for k in z.files)


@pytest.mark.parametrize("source", ["state", "replay"])
def test_restart_is_bit_identical(case, serve, points, source):
    srv = serve(case)
    c = Client(case)
    c.hello(points)
    original = {}
    for t in TIMES:
        original[t] = c.request(t, (1, 0, 0), (0, 0, 0))[0]
        if t == TIMES[2]:
            c.write(t)
    c.bye()
    assert finished(srv) == 0
    if source == "replay":
        for f in (case / "adapter").glob("state_*.npz"):
            f.unlink()
    # OpenFOAM restarts from the written time TIMES[2]: a fresh server, a fresh connection
    srv = serve(case)
    c = Client(case)
    c.hello(points)
    for t in TIMES[3:]:
        assert c.request(t)[0] == original[t]
    c.bye()
    assert finished(srv) == 0
    ts = [float(r.split(",")[0]) for r in
          (case / "adapter" / "keypoints.csv").read_text().splitlines()[1:]]
    assert ts == TIMES


def test_rewind_within_one_server_on_a_fresh_connection(case, serve, points):
    srv = serve(case, keep_serving=True)
    a = Client(case)
    a.hello(points[:300], n_ranks=2)
    original = {}
    for t in TIMES:
        original[t] = a.request(t)[0]
    with pytest.raises(ServerSaid) as info:
        a.request(TIMES[1])                                    # not a repeat: backwards
    assert info.value.code == ErrorCode.TIME_BACKWARDS
    b = Client(case)                                           # the run, restarted
    b.hello(points[:300], n_ranks=2)
    assert [b.request(t)[0] for t in TIMES[1:]] == [original[t] for t in TIMES[1:]]
    b.bye()
    srv.stop()
    assert finished(srv) == 0
    assert srv.stats["links"] == 2


def test_bad_clients_do_not_kill_the_server(case, serve, points):
    srv = serve(case)
    far = Client(case)
    with pytest.raises(ServerSaid) as info:
        far.hello(points + [0.0, 0.0, 100.0])
    assert info.value.code == ErrorCode.BAD_HELLO and " m from the whale" in info.value.message
    good = Client(case)
    good.hello(points[:50])
    good.request(TIMES[0])
    sent = [
        b"GARBAGE GARBAGE GARBAGE",
        struct.pack("<4sHHII", b"WHAL", wire.VERSION, 3, 2**31, 1),   # oversized
        wire.encode_frame(MessageType.REQUEST, wire.pack_request(0.1), 1)[:30],   # truncated
        wire.encode_frame(MessageType.REQUEST, wire.pack_request(0.1), 1),        # no HELLO
    ]
    for data in sent:
        bad = Client(case)
        bad.sock.sendall(data)
        bad.sock.shutdown(socket.SHUT_WR)
        with pytest.raises(ServerSaid) as info:
            bad.reply()
        assert info.value.code == ErrorCode.BAD_FRAME
        bad.sock.close()
    for old in (1, 2):                  # an older plugin: ERROR 2 naming both versions
        v_old = Client(case)
        v_old.sock.sendall(wire.encode_frame(MessageType.HELLO, wire.pack_hello(1, points), 1,
                                             version=old))
        with pytest.raises(ServerSaid) as info:
            v_old.reply()
        assert info.value.code == ErrorCode.VERSION_MISMATCH
        assert f"version {old}" in info.value.message and "version 3" in info.value.message
    busy = Client(case)
    with pytest.raises(ServerSaid) as info:
        busy.hello(points[:5])                                  # the case has its link
    assert info.value.code == ErrorCode.BUSY
    good.request(TIMES[1])                                      # still serving
    good.bye()
    assert finished(srv) == 0


def test_token(case, serve, points):
    srv = serve(case, token="s3cret")
    for token in ("", "wrong"):
        with pytest.raises(ServerSaid) as info:
            Client(case).hello(points[:5], token=token)
        assert info.value.code == ErrorCode.BAD_TOKEN
    c = Client(case)
    c.hello(points[:5], token="s3cret")
    c.bye()
    assert finished(srv) == 0


def test_non_loopback_tcp_needs_a_token(case, scene, animator):
    srv = StepServer(case, scene, tcp_port=0, host="0.0.0.0", animator=animator)
    with pytest.raises(ServerStartError, match="--token"):
        srv.start()


def test_tcp_loopback(case, serve, points):
    srv = serve(case, tcp_port=0)
    sock = socket.create_connection(srv.tcp_address)
    wire.send_frame(sock, MessageType.HELLO, wire.pack_hello(1, points[:10]), 1)
    assert wire.read_frame(sock, 10).type == MessageType.WELCOME
    wire.send_frame(sock, MessageType.BYE, b"", 2)
    sock.close()
    assert finished(srv) == 0


def test_socket_is_private_and_a_second_server_is_refused(case, serve, scene, animator):
    srv = serve(case)
    sock = case / SOCKET_NAME
    assert stat.S_IMODE(sock.stat().st_mode) == 0o600
    with pytest.raises(ServerStartError, match=f"pid {os.getpid()}"):
        StepServer(case, scene, animator=animator).start()
    srv.stop()
    finished(srv)
    # a stale socket (server killed) is removed
    stale = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    stale.bind(str(sock))
    stale.close()
    srv = serve(case)
    srv.stop()
    finished(srv)


def test_vanished_client_saves_state(case, serve, points):
    srv = serve(case)
    c = Client(case)
    c.hello(points[:20])
    c.request(TIMES[0])
    c.request(TIMES[1])
    c.sock.close()                                             # pimpleFoam killed
    assert finished(srv) == 0
    assert (case / "adapter" / f"state_{time_name(TIMES[1])}.npz").exists()


def test_model_failure_reaches_the_client(case, serve, scene, points):
    class Failing(Animator):
        def displacement(self, t):
            if t > 0.015:
                raise UnstableError("the whale blew up; use [integrator] dt_s <= 1e-4")
            return super().displacement(t)

    srv = serve(case, animator=Failing(scene))
    a = Client(case)
    a.hello(points[:20], n_ranks=2)
    a.request(0.01)
    with pytest.raises(ServerSaid) as info:
        a.request(0.02)
    assert info.value.code == ErrorCode.MODEL_FAILURE and "dt_s" in info.value.message
    assert finished(srv) == 1


@pytest.mark.slow
def test_command_line(case, points):
    env = dict(os.environ)
    proc = subprocess.Popen(
        [sys.executable, "-m", "adapter.cli", "serve", "--case", str(case), "--preset", "smoke",
         "--wait", "60"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
        cwd=Path(__file__).parents[1])
    try:
        deadline = time.monotonic() + 60
        while True:
            try:
                c = Client(case)
                break
            except (FileNotFoundError, ConnectionRefusedError):
                assert proc.poll() is None, proc.stderr.read()
                assert time.monotonic() < deadline
                time.sleep(0.1)
        c.hello(points[:30])
        c.request(TIMES[0])
        c.bye()
        out, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 0, err
    assert "1 requests served" in out


def test_endpoint_file_names_where_the_server_listens(case, serve, points):
    """UNIX only: the socket path; TCP: host and port (never the token); written by rename,
    removed at exit."""
    srv = serve(case)
    text = (case / ENDPOINT_NAME).read_text()
    assert f"unix {case / SOCKET_NAME}\n" in text and f"pid {os.getpid()}\n" in text
    Client(case).bye()
    srv.stop()
    finished(srv)
    assert not (case / ENDPOINT_NAME).exists()

    srv = serve(case, tcp_port=0, host="localhost", token="s3cret")
    fields = dict(line.split(" ", 1) for line in
                  (case / ENDPOINT_NAME).read_text().splitlines()
                  if not line.startswith("#"))
    assert fields["host"] == "localhost" and int(fields["port"]) == srv.tcp_address[1]
    assert "unix" not in fields and "s3cret" not in str(fields)
    assert not list(case.glob("*.tmp"))
    c = Client(address=(fields["host"], int(fields["port"])))
    c.hello(points[:5], token="s3cret")
    c.bye()
    assert finished(srv) == 0
    assert not (case / ENDPOINT_NAME).exists()


def test_another_hosts_server_is_never_judged_stale(case, scene, animator):
    """A pid file from another host: this host cannot probe its socket nor its pid, so the
    start is refused naming that host, and its socket and endpoint are left alone."""
    (case / PID_NAME).write_text("4242 node-elsewhere\n")
    (case / ENDPOINT_NAME).write_text("host node-elsewhere\nport 4000\n")
    stale_looking = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    stale_looking.bind(str(case / SOCKET_NAME))          # refuses connections here
    stale_looking.close()
    with pytest.raises(ServerStartError, match="on host node-elsewhere .pid 4242."):
        StepServer(case, scene, animator=animator).start()
    for name in (PID_NAME, ENDPOINT_NAME, SOCKET_NAME):
        assert (case / name).exists(), name
    # the same host's pid file: the dead socket is judged stale and replaced
    (case / PID_NAME).write_text(f"4242 {socket.gethostname()}\n")
    srv = StepServer(case, scene, animator=animator)
    srv.start()
    assert "unix " in (case / ENDPOINT_NAME).read_text()
    srv.finish()


def test_token_file_must_be_private(tmp_path, monkeypatch):
    from adapter.coupling.server import resolve_token

    f = tmp_path / "token"
    f.write_text("s3cret\n")
    f.chmod(0o644)
    with pytest.raises(ServerStartError, match="chmod 600"):
        resolve_token(f)
    f.chmod(0o600)
    assert resolve_token(f) == "s3cret"
    monkeypatch.setenv("WHALE_ADAPTER_TOKEN", "from-env")
    assert resolve_token(None) == "from-env"
    monkeypatch.delenv("WHALE_ADAPTER_TOKEN")
    assert resolve_token(None) is None
