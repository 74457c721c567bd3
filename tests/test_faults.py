"""Faults and bad input: nothing lost, nothing silent (docs/faults.md).

The first half needs no OpenFOAM: a real step-server (threads, the smoke whale) is fed fuzzed
frames, clients of another protocol version, a second server, bad scenes and meshes, unstable
steps and NaN, TCP without a token. The second half (marked ``openfoam``) runs the real
pimpleFoam with the plugin on the smoke preset, kills the server or the solver mid-run and
resumes. The soak (1,000 coupled steps, marked ``slow``) is ``scripts/soak.py``.
"""

from __future__ import annotations

import importlib.util
import os
import re
import shutil
import signal
import socket
import stat
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from adapter.cli import build_parser
from adapter.coupling import protocol as wire
from adapter.coupling.mapping import PatchMap
from adapter.coupling.protocol import (
    ENDPOINT_NAME,
    HEADER,
    MAGIC,
    SOCKET_NAME,
    ErrorCode,
    MessageType,
)
from adapter.coupling.server import StepServer
from adapter.errors import AdapterError, GeometryError, SceneError
from adapter.foam import case as C
from adapter.foam import folders as F
from adapter.foam import mesh as M
from adapter.foam import run as R
from adapter.foam import tools as T
from adapter.motion.animator import Animator
from adapter.motion.integrators import make_integrator
from adapter.scene import load_scene

from .wire_client import Client, ServerSaid, finished, points_near, server_starter

REPO = Path(__file__).resolve().parents[1]
#: the plugin's words for a server that is gone (stepServerStream.C), from a send, a receive
#: or an end of file
LOST_SERVER = (r"the step-server stopped or crashed: (sending to|receiving from) it failed"
               r"|the step-server closed the connection \(EOF\): it stopped or crashed")
#: fuzz cases in total (the issue asks for at least 10,000)
FUZZ_CASES = int(os.environ.get("FUZZ_CASES", 10_000))


@pytest.fixture(scope="module")
def scene():
    return load_scene(preset="smoke")


@pytest.fixture(scope="module")
def animator(scene):
    return Animator(scene)


@pytest.fixture(scope="module")
def points(animator):
    """60 patch points near the whale: on random triangles, lifted 1 mm off the surface."""
    return points_near(animator.surface, 60, seed=1)


@pytest.fixture(scope="module")
def truth(scene, animator, points):
    """The patch displacement at time t, from an independent animator (the uninterrupted run)."""
    ref = Animator(scene, animator.surface)
    patch = PatchMap.from_surface(points, animator.surface)
    cache = {}

    def at(t):
        if t not in cache:
            ref.reset()
            cache[t] = patch.apply(ref.displacement(t))
        return cache[t]

    return at


@pytest.fixture
def case(tmp_path):
    d = tmp_path / "case"
    d.mkdir()
    return d


@pytest.fixture
def serve(scene, animator):
    start, stop_all = server_starter(scene, animator, first_client_timeout=60)
    yield start
    stop_all()


# --- fuzzing ----------------------------------------------------------------------------------

#: flow times the fuzzing clients may ask for (a few internal steps: cheap to replay)
FUZZ_TIMES = (0.002, 0.004, 0.006)
#: connections opened at once per generated example
PER_EXAMPLE = 2
#: the rank count a fuzzing client's valid HELLO speaks for
FUZZ_RANKS = 2


def _header(magic, version, kind, length, seq):
    return HEADER.pack(magic, version, kind, length, seq)


def _fuzz_strategy(points):
    """A connection's bytes and the times its valid REQUESTs ask for: (bytes, {seq: t}).

    Two kinds of connection. Garbage: one to four frames of random bytes, headers with each
    field sometimes right (foreign magic, other versions, unknown types, lengths up to 2**32 - 1
    with the payload cut short), well-formed frames of every type but HELLO with random
    payloads, HELLOs wrong in one field. Sessions: a valid HELLO (for 2 ranks), then REQUESTs
    and WRITEs for cheap, non-finite or negative times, payloads of the wrong length, messages
    only a server may send, a second HELLO, BYE. Either may be cut short anywhere. Random
    bytes never reach the animator as a time after a valid HELLO: a time of 1e300 would be
    marched to, which is a hang of its own (docs/faults.md, open points).
    """
    u32 = st.integers(0, 2**32 - 1)
    garbage = st.binary(max_size=80).map(lambda b: (b, {}))
    header = st.builds(
        lambda m, v, k, n, s, p: (_header(m, v, k, n, s) + p, {}),
        st.one_of(st.just(MAGIC), st.binary(min_size=4, max_size=4)),
        st.one_of(st.just(wire.VERSION), st.integers(0, 2**16 - 1)),
        st.integers(0, 2**16 - 1) | st.sampled_from([int(m) for m in MessageType]),
        st.one_of(st.integers(0, 256), st.integers(wire.MAX_PAYLOAD - 8, 2**32 - 1), u32),
        u32, st.binary(max_size=120))
    not_hello = st.sampled_from([m for m in MessageType if m != MessageType.HELLO])
    random_payload = st.builds(
        lambda k, p, s: (wire.encode_frame(k, p, s), {}),
        not_hello, st.one_of(st.binary(max_size=70), st.binary(min_size=56, max_size=56)), u32)
    bad_hello = st.builds(
        lambda n_ranks, n, shift, tok, s: (wire.encode_frame(
            MessageType.HELLO, wire.pack_hello(n_ranks, points[:n] + shift, tok), s), {}),
        st.sampled_from([FUZZ_RANKS, 0, 1, 5]),
        st.integers(1, len(points)), st.sampled_from([100.0, -3.0, np.nan, np.inf]),
        st.sampled_from(["", "token"]), u32)
    hello_payload = st.binary(max_size=200).map(
        lambda p: (wire.encode_frame(MessageType.HELLO, p, 1), {}))
    garbage_frame = st.one_of(garbage, header, random_payload, bad_hello, hello_payload)

    valid_hello = st.builds(lambda n: (wire.encode_frame(
        MessageType.HELLO, wire.pack_hello(FUZZ_RANKS, points[:n]), 1), {}),
        st.integers(0, len(points)))
    times = st.sampled_from(FUZZ_TIMES + (np.nan, np.inf, -np.inf, -1.0))
    request = times.map(lambda t: ("REQUEST", t))
    write = times.map(lambda t: (wire.encode_frame(MessageType.WRITE, wire.pack_write(t), 2), {}))
    sizes = {MessageType.REQUEST: 56, MessageType.WRITE: 8}
    wrong_size = st.builds(
        lambda k, p, s: (wire.encode_frame(k, p, s), {}),
        st.sampled_from(list(sizes)), st.binary(max_size=70), u32).filter(
        lambda f: len(f[0]) - wire.HEADER_SIZE != sizes[wire.decode_header(f[0][:16])[0]])
    server_only = st.builds(
        lambda k, p: (wire.encode_frame(k, p, 3), {}),
        st.sampled_from([MessageType.WELCOME, MessageType.DISPLACEMENT, MessageType.ACK,
                         MessageType.ERROR]), st.binary(max_size=40))
    bye = st.just((wire.encode_frame(MessageType.BYE, b"", 4), {}))
    session_frame = st.one_of(request, request, request, write, wrong_size, server_only,
                              valid_hello, bye, garbage)
    session = st.builds(lambda h, asks, rest: [h, *asks, *rest], valid_hello,
                        st.lists(request, min_size=0, max_size=3),
                        st.lists(session_frame, min_size=0, max_size=2))

    def join(frames, cut):
        chunks, asked = [], {}
        for i, f in enumerate(frames):
            if f[0] == "REQUEST":        # numbered here, so that every reply names its request
                seq = 10_000 + i
                chunks.append(wire.encode_frame(MessageType.REQUEST, wire.pack_request(f[1]),
                                                seq))
                if np.isfinite(f[1]) and f[1] >= 0:
                    asked[seq] = f[1]
            else:
                chunks.append(f[0])
        data = b"".join(chunks)
        return (data if cut is None else data[:cut]), asked

    frames = st.one_of(st.lists(garbage_frame, min_size=1, max_size=4), session)
    return st.builds(join, frames, st.none() | st.none() | st.integers(0, 400))


def _read_replies(sock: socket.socket) -> list:
    """Every frame the server sent until it closed; raw bytes are decoded strictly."""
    data = bytearray()
    sock.settimeout(40)
    while True:
        try:
            chunk = sock.recv(1 << 16)
        except ConnectionResetError:
            break
        if not chunk:
            break
        data += chunk
    frames = []
    while data:
        assert len(data) >= wire.HEADER_SIZE, f"the server sent a partial header: {bytes(data)!r}"
        kind, length, seq = wire.decode_header(bytes(data[:wire.HEADER_SIZE]))
        end = wire.HEADER_SIZE + length
        assert len(data) >= end, "the server sent a truncated frame"
        frames.append(wire.Frame(kind, seq, bytes(data[wire.HEADER_SIZE:end])))
        del data[:end]
    return frames


@pytest.mark.slow
def test_fuzzed_frames_never_crash_or_lie(case, serve, animator, points, truth):
    """10,000 connections of garbage, truncated, oversized and mistyped frames on one server.

    The server answers each with nothing wrong: only WELCOME, DISPLACEMENT, ACK or one final
    ERROR with a known code and a message (a second link while one holds the case: ERROR 7); a
    DISPLACEMENT is the exact motion at the time asked. A well-behaved client, every 1000
    connections, gets exact displacements.
    """
    srv = serve(case, keep_serving=True)      # one link per case: link after link
    keeper_t = [0.01]

    def keeper_checks(t):
        keeper = Client(case)
        keeper.hello(points[:20], n_ranks=2)
        assert np.array_equal(keeper.displacement(t), truth(t)[:20])
        keeper.bye()

    keeper_checks(keeper_t[-1])
    count = [0]
    checked = [0]                    # DISPLACEMENT replies compared with the truth

    @settings(max_examples=FUZZ_CASES // PER_EXAMPLE, deadline=None, database=None,
              derandomize=True, suppress_health_check=list(HealthCheck))
    @given(st.lists(_fuzz_strategy(points), min_size=PER_EXAMPLE, max_size=PER_EXAMPLE))
    def connections(batch):
        """Open the connections at once, send each its bytes, then read every reply."""
        socks = []
        for data, _ in batch:
            count[0] += 1
            sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
            sock.connect(str(case / SOCKET_NAME))
            socks.append(sock)
            try:
                sock.sendall(data)
                sock.shutdown(socket.SHUT_WR)
            except OSError:          # the server already answered ERROR and closed
                pass
        for sock, (_, asked) in zip(socks, batch, strict=True):
            try:
                replies = _read_replies(sock)
            finally:
                sock.close()
            check(replies, asked)
        assert srv.thread.is_alive()
        if count[0] % 1000 == 0:         # a well-behaved client, during the fuzzing
            keeper_t.append(round(keeper_t[-1] + 0.01, 6))
            keeper_checks(keeper_t[-1])

    def check(replies, asked):
        for i, f in enumerate(replies):
            assert f.type in (MessageType.WELCOME, MessageType.DISPLACEMENT, MessageType.ACK,
                              MessageType.ERROR), f
            if f.type == MessageType.ERROR:
                assert i == len(replies) - 1, "the server went on after an ERROR"
                code, message = wire.unpack_error(f.payload)
                assert code in set(ErrorCode) and len(message) > 10
            elif f.type == MessageType.WELCOME:
                n, _, dt = wire.unpack_welcome(f.payload)
                assert n <= len(points) and dt == animator.dt
            elif f.type == MessageType.DISPLACEMENT:
                t, disp = wire.unpack_displacement(f.payload)
                assert f.seq in asked and asked[f.seq] == t, (f.seq, t, asked)
                assert np.isfinite(disp).all()
                assert np.array_equal(disp, truth(t)[:len(disp)]), f"wrong motion at t = {t}"
                checked[0] += 1

    t0 = time.perf_counter()
    connections()
    elapsed = time.perf_counter() - t0
    print(f"fuzzing: {count[0]} connections in {elapsed:.1f} s, {checked[0]} displacements "
          f"checked")
    assert count[0] >= FUZZ_CASES and checked[0] >= FUZZ_CASES // 20
    # after the fuzzing: a fresh link gets exactly the right motion
    late = Client(case)
    late.hello(points, n_ranks=2)
    for t in (keeper_t[-1] + 0.01, keeper_t[-1] + 0.02):
        assert np.array_equal(late.displacement(t), truth(t))
    late.bye()
    srv.stop()
    assert finished(srv) == 0
    assert not (case / SOCKET_NAME).exists()


# --- version, second server, security --------------------------------------------------------


def test_other_protocol_versions_are_refused_naming_both(case, serve, points, truth):
    srv = serve(case)
    good = Client(case)
    good.hello(points[:10])
    for version in (0, 1, 3, 7, 65535):
        for kind, payload in ((MessageType.HELLO, wire.pack_hello(1, points[:10])),
                              (MessageType.REQUEST, wire.pack_request(0.01))):
            c = Client(case)
            with pytest.raises(ServerSaid) as info:
                c.call(kind, payload, version=version)
            assert info.value.code == ErrorCode.VERSION_MISMATCH
            assert f"version {version}" in info.value.message
            assert f"version {wire.VERSION}" in info.value.message
            c.sock.close()
    # a version change in the middle of a connection is refused too, and closes only it
    mid = Client(case)
    with pytest.raises(ServerSaid, match="version 3"):
        mid.call(MessageType.HELLO, wire.pack_hello(1, points[:10]), version=3)
    assert np.array_equal(good.displacement(0.01), truth(0.01)[:10])
    good.bye()
    assert finished(srv) == 0


def _serve_cli(case: Path, *extra) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", "adapter.cli", "serve", "--case", str(case), "--preset", "smoke",
         "--wait", "120", *extra],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=REPO)


def _wait_for_socket(case: Path, proc: subprocess.Popen, timeout=90.0) -> None:
    deadline = time.monotonic() + timeout
    while not (case / SOCKET_NAME).exists():
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < deadline, "the server made no socket"
        time.sleep(0.1)


@pytest.mark.slow
def test_second_server_on_a_case_is_refused_naming_the_first(case, points):
    first = _serve_cli(case)
    try:
        _wait_for_socket(case, first)
        second = subprocess.run(
            [sys.executable, "-m", "adapter.cli", "serve", "--case", str(case), "--preset",
             "smoke"], capture_output=True, text=True, cwd=REPO, timeout=120)
        assert second.returncode == 2
        assert f"another step-server (pid {first.pid}) is already serving" in second.stderr
        assert f"kill {first.pid}" in second.stderr and "Traceback" not in second.stderr
        # the first one is untouched: it still serves
        c = Client(case)
        c.hello(points[:5])
        c.displacement(0.01)
        c.bye()
        out, err = first.communicate(timeout=60)
        assert first.returncode == 0, err
    finally:
        if first.poll() is None:
            first.kill()
            first.wait()


def test_socket_is_private_whatever_the_umask(case, serve):
    old = os.umask(0)
    try:
        srv = serve(case)
    finally:
        os.umask(old)
    mode = (case / SOCKET_NAME).lstat().st_mode
    assert stat.S_ISSOCK(mode) and stat.S_IMODE(mode) == 0o600
    srv.stop()
    finished(srv)


def test_tcp_is_loopback_by_default_and_needs_the_token_otherwise(case, serve, points):
    assert build_parser().parse_args(["serve", "--case", "."]).host == "127.0.0.1"
    srv = serve(case, tcp_port=0)
    assert srv.tcp_address[0] == "127.0.0.1"
    srv.stop()
    finished(srv)
    # on all interfaces: only with a token, and a client without it is refused
    srv = serve(case, tcp_port=0, host="0.0.0.0", token="s3cret")
    address = ("127.0.0.1", srv.tcp_address[1])
    for token in ("", "wrong", "s3cret!"):
        c = Client(address=address)
        with pytest.raises(ServerSaid) as info:
            c.hello(points[:5], token=token)
        assert info.value.code == ErrorCode.BAD_TOKEN and "token" in info.value.message
        c.sock.close()
    for data in (b"", b"WHAL"):         # nothing, or half a header, then gone: no harm
        s = socket.create_connection(address)
        s.sendall(data)
        s.close()
    c = Client(address=address)
    c.hello(points[:5], token="s3cret")
    c.displacement(0.01)
    c.bye()
    assert finished(srv) == 0


# --- bad scenes and geometries ----------------------------------------------------------------


def _write_obj(path: Path, points, faces) -> None:
    lines = [f"v {x!r} {y!r} {z!r}" for x, y, z in np.asarray(points, dtype=float).tolist()]
    lines += ["f " + " ".join(str(i + 1) for i in f) for f in faces]
    path.write_text("\n".join(lines) + "\n")


def _mesh_scene(tmp_path: Path, surface, damage: str) -> Path:
    """A scene file naming an OBJ copy of the smoke whale with one kind of damage."""
    pts = np.array(surface.points, dtype=float)
    tris = np.array(surface.triangles)
    marks = {k: pts[v].tolist() for k, v in surface.landmarks.items()}
    if damage == "open":
        tris = tris[1:]
    elif damage == "nan":
        pts[17, 2] = np.nan
    elif damage == "degenerate":
        a, b, c = tris[5]
        pts = np.vstack([pts, (pts[a] + pts[b]) / 2])   # a zero-area sliver on edge a-b
        tris = np.vstack([tris[:5], [[a, len(pts) - 1, c], [len(pts) - 1, b, c]], tris[6:]])
        tris = np.vstack([tris, [[a, b, len(pts) - 1]], [[b, a, len(pts) - 1]]])
    elif damage == "landmark":
        marks["flipper_left"] = [7.0, 12.0, 9.0]
    _write_obj(tmp_path / "whale.obj", pts, tris)
    lm = "\n".join(f"{k} = [{v[0]!r}, {v[1]!r}, {v[2]!r}]" for k, v in marks.items())
    f = tmp_path / "scene.toml"
    f.write_text(f'preset = "smoke"\n[geometry]\nsource = "whale.obj"\n'
                 f"[geometry.landmarks]\n{lm}\n")
    return f


SCENE_TEXT = {
    "unknown key": ("[springs]\nstiffnes_scale = 2\n", SceneError,
                    r"springs\.stiffnes_scale: unknown key; allowed here: .*stiffness_scale"),
    "unknown section": ("[spring]\nmu = 1\n", SceneError, r"spring: unknown key"),
    "wrong type": ("[flow]\nspeed_m_s = \"fast\"\n", SceneError,
                   r"flow\.speed_m_s: expected a number, got 'fast' \(str\)"),
    "bool for number": ("[springs]\nk_head = true\n", SceneError, r"springs\.k_head: expected"),
    "negative constant": ("[springs]\nk_tail = -40\n", SceneError,
                          r"springs\.k_tail: value -40\.0 is out of range"),
    "negative damping": ("[springs]\nmu = -0.1\n", SceneError, r"springs\.mu: value -0\.1"),
    "NaN constant": ("[springs]\nk_pivot = nan\n", SceneError,
                     r"springs\.k_pivot: expected a finite number"),
    "negative frequency": ("[stroke]\nfrequency_hz = -0.13\n", SceneError,
                           r"stroke\.frequency_hz: value -0\.13 is out of range"),
    "no damping for forward Euler": ("[springs]\nmu = 0\nnu = 0\n", SceneError,
                                     r"forward_euler has no stable step .* raise mu"),
    "missing mesh file": ("[geometry]\nsource = \"nowhere.stl\"\n", GeometryError,
                          r"mesh file .*nowhere\.stl does not exist"),
}
MESH_DAMAGE = {
    "open surface": ("open", r"the surface is open: \d+ edge\(s\) belong to one face only"),
    "NaN points": ("nan", r"1 point\(s\) are NaN or infinite, first at index 17"),
    "degenerate faces": ("degenerate", r"degenerate faces: .* zero area"),
    "landmark off the body": ("landmark", r"landmark flipper_left at \[7\.0, 12\.0, 9\.0\] "
                                          r"is .* m from the nearest surface point .* not on "
                                          r"the body"),
}


@pytest.mark.parametrize("name", list(SCENE_TEXT) + list(MESH_DAMAGE))
def test_bad_scene_or_geometry_is_a_clear_error(tmp_path, animator, name):
    """Each bad input fails where the server would build its animator, naming the problem."""
    if name in SCENE_TEXT:
        text, error, message = SCENE_TEXT[name]
        f = tmp_path / "scene.toml"
        f.write_text('preset = "smoke"\n' + text)
    else:
        damage, message = MESH_DAMAGE[name]
        error = GeometryError
        f = _mesh_scene(tmp_path, animator.surface, damage)
    with pytest.raises(error, match=message):
        Animator(load_scene(f))


def test_the_undamaged_obj_copy_is_accepted(tmp_path, animator):
    """The table's meshes fail for their damage alone: the same file undamaged animates."""
    a = Animator(load_scene(_mesh_scene(tmp_path, animator.surface, "none")))
    assert np.isfinite(a.displacement(0.01)).all()


@pytest.mark.slow
@pytest.mark.parametrize("name", ["negative constant", "open surface"])
def test_bad_input_on_the_command_line_is_one_line_not_a_traceback(tmp_path, case, animator,
                                                                   name):
    if name in SCENE_TEXT:
        f = tmp_path / "scene.toml"
        f.write_text('preset = "smoke"\n' + SCENE_TEXT[name][0])
        message = SCENE_TEXT[name][2]
    else:
        f = _mesh_scene(tmp_path, animator.surface, MESH_DAMAGE[name][0])
        message = MESH_DAMAGE[name][1]
    r = subprocess.run([sys.executable, "-m", "adapter.cli", "serve", "--case", str(case),
                        "--scene", str(f)], capture_output=True, text=True, cwd=REPO, timeout=120)
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert r.stderr.startswith("whale-adapter serve: error: ") and re.search(message, r.stderr)
    assert not (case / SOCKET_NAME).exists()


@pytest.mark.parametrize("shift, tolerance", [((0.0, 0.0, 100.0), 0.05), ((0.0, 0.0, 1.0), 0.05),
                                              ((0.0, 0.0, 0.2), 0.01)])
def test_patch_far_from_the_whale_is_refused_naming_the_distance(case, serve, points, shift,
                                                                 tolerance):
    """A patch too far from the whale for its mapping to mean anything: ERROR 3 at HELLO."""
    srv = serve(case, map_tolerance=tolerance)
    c = Client(case)
    with pytest.raises(ServerSaid) as info:
        c.hello(points + np.array(shift))
    assert info.value.code == ErrorCode.BAD_HELLO
    assert re.search(r"lies [0-9.e+-]+ m from the whale surface, more than the allowed "
                     r"[0-9.e+-]+ m", info.value.message)
    assert "same scene" in info.value.message
    ok = Client(case)                    # the server goes on
    ok.hello(points)
    ok.bye()
    assert finished(srv) == 0


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


# --- with the real pimpleFoam (smoke preset) --------------------------------------------------

def openfoam(test):
    """Mark a test that runs the real pimpleFoam; skipped only without it or the plugin."""
    return pytest.mark.openfoam(pytest.mark.plugin(test))


#: flow steps of the fault runs (written every 4 steps, as the smoke preset does)
FAULT_STEPS = 24
_TIME_LINE = re.compile(r"^Time = ([-+0-9.eE]+)\s*$", re.M)
_VEC = re.compile(r"\(([-+0-9.eE]+) ([-+0-9.eE]+) ([-+0-9.eE]+)\)")
#: what a written time holds when OpenFOAM wrote it to the end
_FIELDS = ("U", "p", "phi", "pointDisplacement", "polyMesh/points", "uniform/time")


def _set_end(case: Path, steps: int, write_every: int | None = None) -> float:
    """endTime = steps * deltaT (exact: deltaT is a binary fraction); returns deltaT."""
    from PyFoam.RunDictionary.ParsedParameterFile import ParsedParameterFile

    d = ParsedParameterFile(str(case / "system" / "controlDict"))
    dt = float(d["deltaT"])
    d["endTime"] = steps * dt
    if write_every:
        d["writeInterval"] = write_every
    d.writeFile()
    return dt


def _whale_displacement(time_dir: Path) -> np.ndarray:
    text = (time_dir / "pointDisplacement").read_text()
    start = text.index("value", text.index("whale", text.index("boundaryField")))
    m = re.compile(r"(\d+)\s*\(").search(text, start)
    vecs = _VEC.findall(text, m.end())[:int(m.group(1))]
    return np.array(vecs, dtype=float)


def _written(case: Path) -> dict:
    """name -> {relative file: bytes} of every time folder but 0."""
    out = {}
    for t, d in F.time_dirs(case):
        if t > 0:
            out[d.name] = {str(f.relative_to(d)): f.read_bytes() for f in d.rglob("*")
                           if f.is_file()}
    return out


def _complete(files: dict) -> bool:
    return all(f in files for f in _FIELDS)


@pytest.fixture(scope="module")
def foam_case(tmp_path_factory, scene):
    """A meshed smoke case of FAULT_STEPS steps, and the whale's displacement at every written
    time of its uninterrupted run: name -> (P, 3)."""
    base = tmp_path_factory.mktemp("faults")
    mesh = base / "mesh"
    C.prepare_case(scene, mesh)
    M.mesh_case(mesh)
    dt = _set_end(mesh, FAULT_STEPS)
    ref = base / "reference"
    shutil.copytree(mesh, ref)
    R.run_case(ref, progress=False)
    written = {d.name: _whale_displacement(d) for t, d in F.time_dirs(ref) if t > 0}
    assert len(written) == FAULT_STEPS // 4
    return mesh, dt, written


def _launch(case: Path):
    """The step-server and serial pimpleFoam, as two processes (what run-case does)."""
    log = open(case / "log.server", "w")  # noqa: SIM115 - closed by the caller
    server = subprocess.Popen(
        [sys.executable, "-m", "adapter.cli", "serve", "--case", str(case), "--preset", "smoke",
         "--wait", "300"], cwd=case, stdout=log, stderr=subprocess.STDOUT)
    _wait_for_socket(case, server)
    foam_log = open(case / "log.pimpleFoam", "w")  # noqa: SIM115
    foam = subprocess.Popen(["pimpleFoam"], cwd=case, env=T.foam_env(), stdout=foam_log,
                            stderr=subprocess.STDOUT)
    return server, foam, [log, foam_log]


def _wait_for_step(case: Path, foam, dt: float, ok, timeout=240.0) -> int:
    """Wait until pimpleFoam starts a step k with ok(k); returns k."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        assert foam.poll() is None, (case / "log.pimpleFoam").read_text()[-3000:]
        times = _TIME_LINE.findall((case / "log.pimpleFoam").read_text(errors="replace"))
        if times:
            k = round(float(times[-1]) / dt)
            if ok(k):
                return k
        time.sleep(0.02)
    raise AssertionError("pimpleFoam did not reach the step")


def _stop(*procs) -> None:
    for p in procs:
        if p.poll() is None:
            p.kill()
            p.wait()


def _resume_and_compare(case: Path, reference: dict, before: dict) -> None:
    """run-case again (server and pimpleFoam from the latest time): the written times from
    before are untouched, and every written time equals the uninterrupted run's, bit for bit."""
    R.run_case(case, progress=False)
    after = _written(case)
    for name, files in before.items():
        assert after[name] == files, f"time {name} changed on resume"
    assert sorted(after, key=float) == sorted(reference, key=float)
    for name, want in reference.items():
        np.testing.assert_array_equal(_whale_displacement(case / name), want, err_msg=name)
    text = (case / "adapter" / "keypoints.csv").read_text()
    assert "nan" not in text.lower()       # the restart's first REQUEST has no forces: empty
    rows = text.splitlines()[1:]
    ts = [float(r.split(",")[0]) for r in rows]
    assert len(ts) == FAULT_STEPS and ts == sorted(set(ts))


@openfoam
def test_server_killed_mid_run(tmp_path, foam_case):
    """kill -9 the server: pimpleFoam stops with a FatalError naming the server within 10 s,
    the written times are intact, and run-case resumes with identical displacements."""
    mesh, dt, reference = foam_case
    case = tmp_path / "case"
    shutil.copytree(mesh, case)
    server, foam, logs = _launch(case)
    try:
        # after the second write, early in a write interval: the solver's next call on the
        # server is a REQUEST, not the WRITE of a time being written
        _wait_for_step(case, foam, dt, lambda k: k > 8 and k % 4 == 1)
        before = _written(case)
        assert len(before) >= 2 and all(_complete(f) for f in before.values())
        t_kill = time.monotonic()
        server.send_signal(signal.SIGKILL)
        rc = foam.wait(30)
        to_fatal = time.monotonic() - t_kill
    finally:
        _stop(foam, server)
        for f in logs:
            f.close()
    print(f"pimpleFoam stopped {to_fatal:.2f} s after the server was killed")
    text = (case / "log.pimpleFoam").read_text(errors="replace")
    assert rc != 0 and to_fatal < 10.0
    assert "FOAM FATAL ERROR" in text and "stepServer: REQUEST at time" in text, text[-2000:]
    assert re.search(LOST_SERVER, text)
    # it names the server's socket and the endpoint file that named it, in plain words
    assert f"(step-server at {case / SOCKET_NAME}, named in {case / ENDPOINT_NAME})" in text
    assert _written(case) == before, "a written time changed or a partial one appeared"
    _resume_and_compare(case, reference, before)


@openfoam
def test_pimplefoam_killed_mid_run(tmp_path, foam_case):
    """kill -9 pimpleFoam: the server notices, saves its state, exits 0 with a message; the
    run resumes from the latest written time with identical displacements."""
    mesh, dt, reference = foam_case
    case = tmp_path / "case"
    shutil.copytree(mesh, case)
    server, foam, logs = _launch(case)
    try:
        _wait_for_step(case, foam, dt, lambda k: k > 8 and k % 4 == 2)
        foam.send_signal(signal.SIGKILL)
        foam.wait(30)
        t_kill = time.monotonic()
        rc = server.wait(30)
        to_exit = time.monotonic() - t_kill
    finally:
        _stop(foam, server)
        for f in logs:
            f.close()
    out = (case / "log.server").read_text()
    print(f"the server exited {to_exit:.2f} s after pimpleFoam was killed")
    assert rc == 0, out
    m = re.search(r"a client vanished without BYE \(pimpleFoam killed\?\); saved the state at "
                  r"t = ([0-9.e+-]+) s", out)
    assert m, out
    assert (case / "adapter" / f"state_{m.group(1)}.npz").is_file()
    assert not (case / SOCKET_NAME).exists()
    before = _written(case)
    assert before and all(_complete(f) for f in before.values())
    _resume_and_compare(case, reference, before)


@openfoam
def test_server_killed_while_a_time_is_written(tmp_path, foam_case):
    """The server dies during the solve of a write step: resuming must still just work."""
    mesh, dt, reference = foam_case
    case = tmp_path / "case"
    shutil.copytree(mesh, case)
    server, foam, logs = _launch(case)
    try:
        deadline = time.monotonic() + 240
        while time.monotonic() < deadline:       # step 12 (written) is in its flow solve
            parts = re.split(r"^Time = ", (case / "log.pimpleFoam").read_text(errors="replace"),
                             flags=re.M)
            if len(parts) > 1 and round(float(parts[-1].split()[0]) / dt) == 12 \
                    and re.search(r"Solving for (Ux|p)", parts[-1]):
                break
            assert foam.poll() is None
            time.sleep(0.005)
        before = _written(case)
        server.send_signal(signal.SIGKILL)
        assert foam.wait(30) != 0
    finally:
        _stop(foam, server)
        for f in logs:
            f.close()
    assert "stepServer: WRITE at time" in (case / "log.pimpleFoam").read_text(errors="replace")
    _resume_and_compare(case, reference, before)


@pytest.fixture(scope="module")
def foam_case_2ranks(tmp_path_factory, foam_case):
    """The fault case's uninterrupted 2-rank run: name -> whale displacement (P, 3)."""
    mesh, _, _ = foam_case
    ref = tmp_path_factory.mktemp("faults2") / "reference"
    shutil.copytree(mesh, ref)
    R.run_case(ref, ranks=2, progress=False, reconstruct=True)
    written = {d.name: _whale_displacement(d) for t, d in F.time_dirs(ref) if t > 0}
    assert len(written) == FAULT_STEPS // 4
    return written


@openfoam
def test_parallel_run_killed_resumes_from_the_ranks(tmp_path, foam_case, foam_case_2ranks):
    """A 2-rank run-case whose server is killed after the second write: run-case names the
    FatalError; the written times are only in processor*/; run-case again resumes from them
    (no new decomposePar) and ends with the uninterrupted 2-rank run's whale displacements."""
    import psutil

    mesh, dt, _ = foam_case
    reference = foam_case_2ranks
    case = tmp_path / "case"
    shutil.copytree(mesh, case)
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(REPO), env.get("PYTHONPATH")]))
    run = subprocess.Popen([sys.executable, "-m", "adapter.cli", "run-case", "--case", str(case),
                            "--np", "2"], cwd=tmp_path, stdout=subprocess.PIPE,
                           stderr=subprocess.PIPE, text=True, env=env)
    try:
        deadline = time.monotonic() + 240
        while time.monotonic() < deadline:
            assert run.poll() is None, run.communicate()
            log = case / "log.pimpleFoam"
            times = _TIME_LINE.findall(log.read_text(errors="replace")) if log.exists() else []
            k = round(float(times[-1]) / dt) if times else 0
            if k > 8 and k % 4 == 1:
                break
            time.sleep(0.02)
        server = [p for p in psutil.Process(run.pid).children(recursive=True)
                  if "serve" in p.cmdline()]
        assert len(server) == 1
        server[0].kill()
        out, err = run.communicate(timeout=60)
    finally:
        _stop(run)
    assert run.returncode == 2, (out, err)
    # run-case says OpenFOAM's own message, not only "see log.pimpleFoam"
    assert re.search(LOST_SERVER, err), err
    assert [t for t, _ in F.time_dirs(case)] == [0.0]          # nothing reconstructed yet
    latest = F.processor_latest(case)
    assert latest is not None and latest >= 8 * dt
    before = {p.name: _written(p) for p in F.processor_dirs(case)}
    decomposed = (case / "log.decomposePar").stat().st_mtime_ns
    assert F.resume_time(case) == latest

    R.run_case(case, ranks=2, progress=False, reconstruct=True)
    assert (case / "log.decomposePar").stat().st_mtime_ns == decomposed   # not re-decomposed
    for name, times in before.items():
        after = _written(case / name)
        for t, files in times.items():
            assert after[t] == files, f"{name}/{t} changed on resume"
    first = _TIME_LINE.findall((case / "log.pimpleFoam").read_text(errors="replace"))[0]
    assert float(first) == pytest.approx(latest + dt, abs=1e-12)
    assert sorted(_written(case), key=float) == sorted(reference, key=float)
    # mesh motion is not yet restart-exact in parallel: the flow may differ by ~1e-3, the
    # whale's served displacement may not
    for name, want in reference.items():
        np.testing.assert_allclose(_whale_displacement(case / name), want, rtol=0, atol=1e-9,
                                   err_msg=name)
    assert "nan" not in (case / "adapter" / "keypoints.csv").read_text().lower()


def _load_soak():
    spec = importlib.util.spec_from_file_location("soak", REPO / "scripts" / "soak.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@openfoam
@pytest.mark.slow
def test_soak_server_memory_is_flat(tmp_path):
    """1,000 coupled smoke steps (about 2.5 min here): the server's RSS does not grow after
    the warm-up (the first 10 % of the steps: numba, pyvista at the first WRITE)."""
    report = _load_soak().soak(tmp_path / "soak", steps=1000, write_every=50, interval=1.0)
    print(f"soak: RSS {report['rss_after_warmup_mb']} MB at step "
          f"{report['rss_after_warmup_step']}, {report['rss_end_mb']} MB at step "
          f"{report['rss_end_step']}, {report['wall_s']} s")
    assert report["steps"] == 1000 and report["rss_end_step"] >= 900
    assert report["rss_growth_after_warmup_mb"] <= 10.0


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
