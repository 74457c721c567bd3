"""The plugin's C++ client (stepServerClient) against golden frames written from docs/protocol.md.

A small driver, tests/harness/stepServerClientHarness.C, is compiled once per session with the
client's four sources (stepServerEndpoint.C, stepServerStream.C, stepServerChannel.C,
stepServerClient.C; no OpenFOAM library: the client has no OpenFOAM types) and wmake's flags for
the plugin (linux64Gcc, Opt). Each test runs it against a fake step-server in a thread that
records the client's frames and answers with frames assembled
here with ``struct`` from the document's tables, never with adapter.coupling.protocol: the magic,
version, message types and error codes are read from docs/protocol.md itself.

What the client must do (docs/protocol.md): HELLO and REQUEST, WRITE, BYE byte for byte; WELCOME
and DISPLACEMENT read to the exact values; every ERROR code the document lists turned into the
client's error (stepServerError, which the boundary condition turns into a FatalError) carrying
the server's message; a NaN or infinity in a displacement, a wrong magic, version, size, point
count, time, sequence number or type refused with a message that says which.

``WHALE_CLIENT_SRC`` compiles the client from another folder (scripts/client_bugs.py plants one
bug at a time in a copy and checks that these tests fail).
"""

from __future__ import annotations

import math
import os
import re
import shutil
import socket
import struct
import subprocess
import threading
import time
from pathlib import Path

import pytest

from adapter.resources import PLUGIN_SRC

from .conftest import NEEDS_FOAM_AND_PLUGIN

REPO = Path(__file__).resolve().parents[1]
HARNESS = Path(__file__).parent / "harness" / "stepServerClientHarness.C"
CLIENT_SOURCES = (
    "stepServerEndpoint.C", "stepServerStream.C", "stepServerChannel.C", "stepServerClient.C"
)

pytestmark = [
    *NEEDS_FOAM_AND_PLUGIN,
    pytest.mark.skipif(shutil.which("g++") is None, reason="g++ is not on PATH"),
]

#: wmake's C++ flags for the plugin (build_plugin.sh: WM_OPTIONS=linux64GccDPInt32Opt), from
#: wmake/rules/General/Gcc/c++, linux64Gcc/c++, linux64Gcc/c++Opt and General/general
WMAKE_FLAGS = [
    "-std=c++11", "-m64", "-pthread", "-DOPENFOAM=1912", "-DWM_DP", "-DWM_LABEL_SIZE=32",
    "-Wall", "-Wextra", "-Wold-style-cast", "-Wnon-virtual-dtor", "-Wno-unused-parameter",
    "-Wno-invalid-offsetof", "-Wno-attributes", "-Wno-unknown-pragmas", "-O3",
    "-DNoRepository", "-ftemplate-depth-100", "-fPIC",
]


# -- the document's facts ------------------------------------------------------------------

def _doc_facts() -> dict:
    doc = (REPO / "docs" / "protocol.md").read_text()
    magic = re.search(r"magic, the ASCII bytes `(\w{4})`", doc)[1].encode("ascii")
    version = int(re.search(r"protocol version \(u16\), (\d+)", doc)[1])
    types = {name: int(num) for num, name in re.findall(r"^\| (\d+) \| ([A-Z]+) \|", doc, re.M)}
    para = re.search(r"^Error codes: (.*?)\n\n", doc, re.M | re.S)[1].replace("\n", " ")
    codes = {int(c): what.strip() for c, what in re.findall(r"(?:^|, )(\d+) ([a-z -]+)", para)}
    return {"magic": magic, "version": version, "types": types, "codes": codes}


DOC = _doc_facts()
T = DOC["types"]
HEADER = struct.Struct("<4sHHII")        # magic, u16 version, u16 type, u32 length, u32 seq


def test_the_document_is_read_as_expected():
    """The facts above come from the document; this pins what was read."""
    assert DOC["magic"] == b"WHAL" and DOC["version"] == 3
    assert T == {"HELLO": 1, "WELCOME": 2, "REQUEST": 3, "DISPLACEMENT": 4, "WRITE": 5,
                 "ACK": 6, "BYE": 7, "ERROR": 9}
    assert sorted(DOC["codes"]) == [1, 2, 3, 4, 5, 6, 7]
    assert DOC["codes"][7] == "server busy"


def frame(type_: int, payload: bytes = b"", seq: int = 1, *, magic=None, version=None,
          length=None) -> bytes:
    """A frame as docs/protocol.md draws it; any header field can be spoiled."""
    return HEADER.pack(DOC["magic"] if magic is None else magic,
                       DOC["version"] if version is None else version, type_,
                       len(payload) if length is None else length, seq) + payload


def f64s(values) -> bytes:
    return struct.pack(f"<{len(values)}d", *values)


def welcome(n: int, max_dist: float, dt: float, seq: int = 1) -> bytes:
    return frame(T["WELCOME"], struct.pack("<I", n) + f64s([max_dist, dt]), seq)


def displacement(t: float, values, seq: int = 2, n: int | None = None,
                 frame_uva=None) -> bytes:
    """DISPLACEMENT: f64 time, 3 f64 frame velocity, 3 f64 frame acceleration, u32 nPoints,
    the points' displacements."""
    n = len(values) // 3 if n is None else n
    uva = FRAME_UA if frame_uva is None else frame_uva
    return frame(T["DISPLACEMENT"], f64s([t, *uva]) + struct.pack("<I", n) + f64s(values), seq)


def error(code: int, message: str, seq: int = 1) -> bytes:
    return frame(T["ERROR"], struct.pack("<I", code) + message.encode("utf-8"), seq)


# -- the client's inputs and the frames they must become -------------------------------------

N_RANKS = 3
TOKEN = "sécret-ü"                       # 8 characters, 10 UTF-8 bytes
POINTS = [0.1, -2.5, 1e-300, -0.0, 3.0, 123456.789]             # two points
T1, T2 = 0.1, 0.30000000000000004
NAN3 = [math.nan] * 3                   # loads not known yet (the first REQUEST)
FP, FV = [1.5, -2.25e-7, 1 / 3], [-0.0, 7e12, 2.0 ** -1074]
MP, MV = [-3.5e3, 0.125, 1e-310], [2.0 ** 60, -1 / 7, -0.0]       # moments (N m)
#: the frame of a DISPLACEMENT: velocity (m/s) then acceleration (m/s2)
FRAME_UA = [1.3, -0.0, 2.0 ** -30, -0.25, 1e-300, 1 / 3]
DISP = [1e-3, -2e-3, 0.0, 5e-310, -1.0 / 7, 0.25]
WELCOME_VALUES = (0.05, 1.0 / 2048)


def hello_frame(seq: int = 1) -> bytes:
    token = TOKEN.encode("utf-8")
    payload = struct.pack("<III", N_RANKS, len(POINTS) // 3, len(token)) + token + f64s(POINTS)
    return frame(T["HELLO"], payload, seq)


def request_frame(t: float, fp, fv, mp, mv, seq: int) -> bytes:
    """REQUEST: f64 time, pressure force, viscous force, pressure moment, viscous moment."""
    return frame(T["REQUEST"], f64s([t, *fp, *fv, *mp, *mv]), seq)


def _arg(x: float) -> str:
    return "nan" if math.isnan(x) else x.hex()


HELLO_STEP = ["hello", str(N_RANKS), TOKEN, ",".join(_arg(x) for x in POINTS)]


def request_step(t: float, fp=FP, fv=FV, mp=MP, mv=MV) -> list[str]:
    return ["request", *(_arg(x) for x in [t, *fp, *fv, *mp, *mv])]


# -- the harness and the fake server ---------------------------------------------------------

@pytest.fixture(scope="session")
def harness(tmp_path_factory) -> Path:
    src = Path(os.environ.get("WHALE_CLIENT_SRC", PLUGIN_SRC / "client"))
    exe = tmp_path_factory.mktemp("client-harness") / "stepServerClientHarness"
    cmd = ["g++", *WMAKE_FLAGS, f"-I{src}", str(HARNESS),
           *(str(src / s) for s in CLIENT_SOURCES), "-o", str(exe)]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, f"compiling the client harness failed:\n{r.stderr}"
    assert "warning" not in r.stderr, r.stderr
    return exe


class FakeServer:
    """One connection on 127.0.0.1 (or a UNIX socket): the i-th frame the client sends is
    answered with ``replies[i]`` (bytes; None: no answer; ``(bytes, "close")``: answer, then
    close). Every frame received is kept whole in ``frames``; ``eof``: the client closed the
    link (None when the server closed it first)."""

    def __init__(self, replies, unix_path: Path | None = None):
        self.replies = list(replies)
        self.frames: list[bytes] = []
        self.eof = False
        if unix_path is None:
            self.sock = socket.create_server(("127.0.0.1", 0))
            self.endpoint = f"tcp:{self.sock.getsockname()[1]}"
        else:
            self.sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
            self.sock.bind(str(unix_path))
            self.sock.listen(1)
            self.endpoint = str(unix_path)
        self.sock.settimeout(15)
        self.thread = threading.Thread(target=self._serve, daemon=True)
        self.thread.start()

    def _read(self, conn, n: int) -> bytes | None:
        buf = b""
        while len(buf) < n:
            try:
                chunk = conn.recv(n - len(buf))
            except ConnectionResetError:    # closed with a reply unread: the client gave up
                chunk = b""
            if not chunk:
                return None
            buf += chunk
        return buf

    def _serve(self):
        conn, _ = self.sock.accept()
        conn.settimeout(15)
        with conn:
            while True:
                head = self._read(conn, HEADER.size)
                if head is None:
                    self.eof = True
                    return
                length = HEADER.unpack(head)[3]
                payload = self._read(conn, length) if length else b""
                if payload is None:
                    return
                self.frames.append(head + payload)
                i = len(self.frames) - 1
                reply = self.replies[i] if i < len(self.replies) else None
                if isinstance(reply, tuple):
                    conn.sendall(reply[0])
                    self.eof = None
                    return
                if reply is not None:
                    conn.sendall(reply)

    def close(self):
        self.thread.join(15)
        self.sock.close()


def run_client(harness: Path, replies, steps, *, options=(), unix_path=None, endpoint=None):
    """Run the harness through ``steps`` against a fake server; (stdout lines, exit code,
    the frames the server received, whether the client closed the connection). ``endpoint``:
    the harness's endpoint argument instead of the server's own (``file:<endpoint file>``)."""
    server = FakeServer(replies, unix_path)
    try:
        r = subprocess.run([str(harness), endpoint or server.endpoint, *options, *steps],
                           capture_output=True, text=True, timeout=30)
    finally:
        server.close()
    assert not r.stderr, r.stderr
    return r.stdout.splitlines(), r.returncode, server.frames, server.eof


def reals(words) -> list[float]:
    return [float.fromhex(w) for w in words]


def refused(harness, replies, steps, **kw) -> tuple[str, list[bytes]]:
    """The client's error for this exchange and the frames it sent (and that it stopped and
    closed the link)."""
    out, rc, frames, eof = run_client(harness, replies, steps, **kw)
    assert rc == 3, out
    assert out[-1].startswith("stepServerError: "), out
    assert eof is not False, "the client must close the connection after a failure"
    return out[-1].removeprefix("stepServerError: "), frames


# -- a good session ----------------------------------------------------------------------

def test_a_session_frame_by_frame(harness):
    """HELLO, REQUEST (loads not known yet: NaN), REQUEST, WRITE, BYE, byte for byte, with
    sequence numbers counting up from 1; WELCOME and DISPLACEMENT (the frame, then the points)
    read to the exact bits."""
    frame_2 = FRAME_UA[::-1]
    replies = [welcome(2, *WELCOME_VALUES, seq=1),
               displacement(T1, DISP, seq=2),
               displacement(T2, DISP[::-1], seq=3, frame_uva=frame_2),
               frame(T["ACK"], seq=4)]
    steps = [*HELLO_STEP, *request_step(T1, NAN3, NAN3, NAN3, NAN3), *request_step(T2),
             "write", T2.hex(), "bye"]
    out, rc, frames, eof = run_client(harness, replies, steps)
    assert rc == 0, out
    assert frames == [hello_frame(1),
                      request_frame(T1, NAN3, NAN3, NAN3, NAN3, 2),
                      request_frame(T2, FP, FV, MP, MV, 3),
                      frame(T["WRITE"], f64s([T2]), 4),
                      frame(T["BYE"], b"", 5)]
    assert eof
    assert out[0].split()[:2] == ["WELCOME", "2"]
    assert reals(out[0].split()[2:]) == list(WELCOME_VALUES)
    for k, (uva, values) in enumerate([(FRAME_UA, DISP), (frame_2, DISP[::-1])]):
        frame_words, disp_words = out[1 + 2 * k].split(), out[2 + 2 * k].split()
        assert frame_words[0] == "FRAME" and reals(frame_words[1:]) == uva
        assert disp_words[:2] == ["DISPLACEMENT", "6"]
        for got, want in ((reals(frame_words[1:]), uva), (reals(disp_words[2:]), values)):
            assert got == want
            assert [math.copysign(1, x) for x in got] == [math.copysign(1, x) for x in want]
    assert out[5:] == ["ACK", "BYE"]


def test_a_unix_socket_session(harness, tmp_path_factory):
    """The same client over a UNIX socket (the default endpoint)."""
    path = tmp_path_factory.mktemp("u", numbered=True) / "s.sock"
    if len(str(path)) >= 100:
        pytest.skip("temporary folder too deep for a UNIX socket path")
    out, rc, frames, _ = run_client(harness, [welcome(2, *WELCOME_VALUES)], HELLO_STEP,
                                    unix_path=path)
    assert rc == 0 and frames == [hello_frame(1)] and out[0].startswith("WELCOME 2 ")


def test_a_lost_server_is_named_in_plain_words(harness, tmp_path_factory):
    """The server, found through an endpoint file (as the boundary condition finds it), closes
    the connection after WELCOME: the error says what happened and names the socket and the
    file that named it."""
    folder = tmp_path_factory.mktemp("e", numbered=True)
    path = folder / "s.sock"
    if len(str(path)) >= 100:
        pytest.skip("temporary folder too deep for a UNIX socket path")
    endpoint = folder / "case.endpoint"
    endpoint.write_text(f"# step-server\nunix {path}\n")
    err, _ = refused(harness, [welcome(2, *WELCOME_VALUES), (b"", "close")],
                     [*HELLO_STEP, *request_step(T1)], unix_path=path,
                     endpoint=f"file:{endpoint}")
    assert err == (f"{CLOSED} (step-server at {path}, named in {endpoint})")


def test_an_empty_token_and_no_points(harness):
    out, rc, frames, _ = run_client(harness, [welcome(0, 0.0, 1e-4)], ["hello", "1", "", ""])
    assert rc == 0, out
    assert frames == [frame(T["HELLO"], struct.pack("<III", 1, 0, 0), 1)]


# -- every ERROR code ------------------------------------------------------------------------

#: codes answered to REQUEST (the time and the model); the others to HELLO
AT_REQUEST = {5, 6}


@pytest.mark.parametrize("code", sorted(DOC["codes"]))
def test_every_error_code_becomes_an_error_with_the_message(harness, code):
    message = f"{DOC['codes'][code]}: naïve détail №{code}; what to do next"
    if code in AT_REQUEST:
        replies = [welcome(2, *WELCOME_VALUES), error(code, message, seq=2)]
        steps = [*HELLO_STEP, *request_step(T1), *request_step(T2), "bye"]
        what = "REQUEST"
    else:
        replies = [error(code, message, seq=1)]
        steps = [*HELLO_STEP, *request_step(T1), "bye"]
        what = "HELLO"
    err, frames = refused(harness, replies, steps)
    assert err.startswith(f"server ERROR {code} in reply to {what}: {message} "
                          "(step-server at tcp://")
    assert len(frames) == (2 if code in AT_REQUEST else 1)


def test_an_error_without_a_message(harness):
    assert refused(harness, [error(3, "")], HELLO_STEP)[0].startswith(
        "server ERROR 3 in reply to HELLO:  (step-server at ")


# -- replies the client refuses ----------------------------------------------------------

@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_a_non_finite_displacement_is_refused(harness, bad):
    values = list(DISP)
    values[4] = bad                      # point 1, y
    err, _ = refused(harness, [welcome(2, *WELCOME_VALUES), displacement(T1, values)],
                     [*HELLO_STEP, *request_step(T1)])
    assert err.startswith("DISPLACEMENT contains a non-finite value at point 1 ")


@pytest.mark.parametrize("at", range(6))
def test_a_non_finite_frame_is_refused(harness, at):
    uva = list(FRAME_UA)
    uva[at] = math.nan if at % 2 else math.inf
    err, _ = refused(harness, [welcome(2, *WELCOME_VALUES), displacement(T1, DISP, frame_uva=uva)],
                     [*HELLO_STEP, *request_step(T1)])
    assert err.startswith("DISPLACEMENT carries a non-finite frame velocity or acceleration ")


GOOD_WELCOME = welcome(2, *WELCOME_VALUES)
CLOSED = "the step-server closed the connection (EOF): it stopped or crashed"
WELCOME_PAYLOAD = struct.pack("<Idd", 2, *WELCOME_VALUES)
REFUSED = {
    # name: (replies, expected start of the message)
    "bad magic": ([frame(T["WELCOME"], WELCOME_PAYLOAD, magic=b"WHAM")],
                  "malformed reply in reply to HELLO: bad magic"),
    "newer version": ([frame(T["WELCOME"], WELCOME_PAYLOAD, version=4)],
                      "protocol version mismatch in reply to HELLO: server speaks 4, client 3"),
    "older version": ([frame(T["WELCOME"], WELCOME_PAYLOAD, version=2)],
                      "protocol version mismatch in reply to HELLO: server speaks 2, client 3"),
    "WELCOME with a trailing byte": ([frame(T["WELCOME"], WELCOME_PAYLOAD + b"\0")],
                                     "malformed WELCOME: payload of 21 bytes, expected 20"),
    "WELCOME one byte short": ([frame(T["WELCOME"], WELCOME_PAYLOAD[:-1])],
                               "malformed WELCOME: payload of 19 bytes, expected 20"),
    "WELCOME for other points": ([welcome(3, *WELCOME_VALUES)],
                                 "WELCOME accepted 3 points, but HELLO sent 2"),
    "over the payload limit": ([frame(T["WELCOME"], b"", length=64 * 1024 * 1024 + 1)],
                               "malformed reply in reply to HELLO: payload length 67108865 "
                               "over the 64 MiB limit"),
    "another sequence number": ([welcome(2, *WELCOME_VALUES, seq=7)],
                                "reply in reply to HELLO carries sequence number 7, expected 1"),
    "another type": ([frame(T["ACK"])],
                     "unexpected ACK (type 6) in reply to HELLO, expected WELCOME"),
    "an unknown type": ([frame(8)],
                        "unexpected unknown (type 8) in reply to HELLO, expected WELCOME"),
    "a truncated payload": ([(frame(T["WELCOME"], WELCOME_PAYLOAD)[:-4], "close")],
                            CLOSED),
    "no reply at all": ([(b"", "close")], CLOSED),
    "DISPLACEMENT one point short": (
        [GOOD_WELCOME, displacement(T1, DISP[:3])],
        "malformed DISPLACEMENT: payload of 84 bytes, expected 108 for 2 points"),
    "DISPLACEMENT with a trailing byte": (
        [GOOD_WELCOME, frame(T["DISPLACEMENT"], displacement(T1, DISP)[16:] + b"\0", 2)],
        "malformed DISPLACEMENT: payload of 109 bytes, expected 108 for 2 points"),
    "DISPLACEMENT without the frame (version 2's layout)": (
        [GOOD_WELCOME, frame(T["DISPLACEMENT"], f64s([T1]) + struct.pack("<I", 2) + f64s(DISP),
                             2)],
        "malformed DISPLACEMENT: payload of 60 bytes, expected 108 for 2 points"),
    "DISPLACEMENT naming another count": (
        [GOOD_WELCOME, displacement(T1, DISP, n=5)], "DISPLACEMENT for 5 points, expected 2"),
    "DISPLACEMENT for another time": (
        [GOOD_WELCOME, displacement(T2, DISP)],
        "DISPLACEMENT for time 0.30000000000000004, requested 0.10000000000000001"),
    "a late reply to REQUEST": (
        [GOOD_WELCOME, displacement(T1, DISP, seq=1)],
        "reply in reply to REQUEST carries sequence number 1, expected 2"),
    "ACK with a payload": (
        [GOOD_WELCOME, displacement(T1, DISP), frame(T["ACK"], b"\0", 3)],
        "malformed ACK: payload of 1 bytes, expected 0"),
}


@pytest.mark.parametrize("name", list(REFUSED))
def test_a_malformed_reply_is_refused(harness, name):
    replies, expected = REFUSED[name]
    steps = [*HELLO_STEP, *request_step(T1), "write", T1.hex(), "bye"]
    assert refused(harness, replies, steps)[0].startswith(expected)


def test_no_reply_within_the_timeout(harness):
    t0 = time.monotonic()
    err, _ = refused(harness, [None], HELLO_STEP, options=["--reply-timeout", "0.3"])
    waited = time.monotonic() - t0
    assert err.startswith("no reply within replyTimeout 0.3 s")
    assert 0.3 <= waited < 2.0
