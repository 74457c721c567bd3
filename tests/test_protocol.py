"""The wire format of docs/protocol.md: round trips, partial reads, and every rejection."""

import socket
import struct
import threading

import numpy as np
import pytest

from adapter.coupling import protocol as wire
from adapter.coupling.protocol import ErrorCode, MessageType, WireError
from adapter.errors import ProtocolError


def test_header_layout_matches_the_spec():
    frame = wire.encode_frame(MessageType.REQUEST, b"x" * 104, seq=7)
    assert frame[:4] == b"WHAL"
    assert struct.unpack("<HHII", frame[4:16]) == (3, 3, 104, 7)
    assert len(frame) == 16 + 104
    decoded = wire.decode_frame(frame)
    assert (decoded.type, decoded.seq, decoded.payload) == (MessageType.REQUEST, 7, b"x" * 104)


def test_message_round_trips():
    pts = np.arange(12.0).reshape(4, 3) / 7
    payload = wire.pack_hello(4, pts, token="sécret")
    # version 2: u32 nRanks, u32 nPoints, u32 token length, token, points (no rank field)
    assert struct.unpack_from("<III", payload) == (4, 4, len("sécret".encode()))
    assert len(payload) == 12 + len("sécret".encode()) + 24 * 4
    hello = wire.unpack_hello(payload)
    assert (hello.n_ranks, hello.token) == (4, "sécret")
    assert np.array_equal(hello.points, pts)
    assert wire.unpack_welcome(wire.pack_welcome(4, 0.25, 1e-3)) == (4, 0.25, 1e-3)
    req = wire.unpack_request(wire.pack_request(0.1, (1, 2, 3), (4, 5, 6), (7, 8, 9),
                                                (10, 11, 12)))
    assert req.time == 0.1 and req.pressure_force.tolist() == [1, 2, 3]
    assert req.viscous_force.tolist() == [4, 5, 6]
    assert req.pressure_moment.tolist() == [7, 8, 9]
    assert req.viscous_moment.tolist() == [10, 11, 12]
    assert req.loads().tolist() == list(range(1, 13)) and req.known()
    unknown = wire.unpack_request(wire.pack_request(0.2))
    assert np.isnan(unknown.loads()).all() and not unknown.known()
    reply = wire.unpack_displacement(wire.pack_displacement(0.3, (1.3, 0, -2), (0.5, 0, 0), pts))
    assert reply.time == 0.3 and np.array_equal(reply.displacement, pts)
    assert reply.frame_velocity.tolist() == [1.3, 0, -2]
    assert reply.frame_acceleration.tolist() == [0.5, 0, 0]
    assert wire.unpack_write(wire.pack_write(0.5)) == 0.5
    assert wire.unpack_error(wire.pack_error(5, "späť")) == (5, "späť")


def _pair():
    a, b = socket.socketpair()
    return a, b


def test_read_frame_assembles_partial_reads():
    a, b = _pair()
    frames = wire.encode_frame(MessageType.WRITE, wire.pack_write(1.5), 3) + wire.encode_frame(
        MessageType.BYE, b"", 4)

    def trickle():
        for i in range(len(frames)):
            a.send(frames[i:i + 1])

    th = threading.Thread(target=trickle)
    th.start()
    f1, f2 = wire.read_frame(b, 5), wire.read_frame(b, 5)
    th.join()
    assert (f1.type, f1.seq, wire.unpack_write(f1.payload)) == (MessageType.WRITE, 3, 1.5)
    assert (f2.type, f2.seq, f2.payload) == (MessageType.BYE, 4, b"")
    a.close()
    with pytest.raises(wire.ConnectionClosed):
        wire.read_frame(b, 5)
    b.close()


@pytest.mark.parametrize(
    "data, code, words",
    [
        (b"JUNK" + bytes(12), ErrorCode.BAD_FRAME, "magic"),
        (struct.pack("<4sHHII", b"WHAL", 3, 3, wire.MAX_PAYLOAD + 1, 1), ErrorCode.BAD_FRAME,
         "exceeds the limit"),
        (struct.pack("<4sHHII", b"WHAL", 3, 42, 0, 1), ErrorCode.BAD_FRAME, "unknown message"),
        (struct.pack("<4sHHII", b"WHAL", 1, 1, 0, 1), ErrorCode.VERSION_MISMATCH, "version 1"),
        (struct.pack("<4sHHII", b"WHAL", 2, 3, 56, 1), ErrorCode.VERSION_MISMATCH, "version 2"),
        (struct.pack("<4sHHII", b"WHAL", 3, 3, 104, 1) + bytes(10), ErrorCode.BAD_FRAME,
         "truncated"),
        (b"WHA", ErrorCode.BAD_FRAME, "truncated"),
    ],
)
def test_read_frame_rejects(data, code, words):
    a, b = _pair()
    a.sendall(data)
    a.shutdown(socket.SHUT_WR)
    with pytest.raises(WireError) as info:
        wire.read_frame(b, 5)
    assert info.value.code == code and words in str(info.value)
    assert isinstance(info.value, ProtocolError)
    a.close()
    b.close()


def test_version_mismatch_names_both_versions():
    with pytest.raises(WireError, match="version 7.*version 3"):
        wire.decode_header(struct.pack("<4sHHII", b"WHAL", 7, 1, 0, 1))


def test_truncated_frame_times_out():
    a, b = _pair()
    a.sendall(wire.encode_frame(MessageType.REQUEST, wire.pack_request(1.0))[:20])
    with pytest.raises(WireError, match="timed out"):
        wire.read_frame(b, frame_timeout=0.2)
    a.close()
    b.close()


def test_bad_payloads():
    with pytest.raises(WireError) as info:
        wire.unpack_hello(wire.pack_hello(1, np.zeros((3, 3)))[:-8])
    assert info.value.code == ErrorCode.BAD_HELLO and "3 points" in str(info.value)
    with pytest.raises(WireError, match="0 ranks"):
        wire.unpack_hello(wire.pack_hello(0, np.zeros((1, 3))))
    with pytest.raises(WireError, match="REQUEST"):
        wire.unpack_request(b"\0" * 103)
    with pytest.raises(WireError, match="DISPLACEMENT"):
        wire.unpack_displacement(wire.pack_displacement(0.0, (0, 0, 0), (0, 0, 0),
                                                        np.zeros((2, 3)))[:-1])
    with pytest.raises(ValueError, match="3 values each"):
        wire.pack_displacement(0.0, (1, 0), (0, 0, 0), np.zeros((1, 3)))


# --- hand-built frames: the bytes of docs/protocol.md, packed here, not by the module ----------

def _frame(version, msg_type, payload=b"", seq=1):
    # offset 0 magic "WHAL", 4 u16 version, 6 u16 type, 8 u32 length, 12 u32 sequence number
    return struct.pack("<4sHHII", b"WHAL", version, msg_type, len(payload), seq) + payload


#: the protocol version of docs/protocol.md
SPEC_VERSION = 3


def _hello(n_ranks, points, token=b""):
    # u32 nRanks, u32 nPoints, u32 tokenLength, token, nPoints x 3 f64
    pts = [float(c) for p in points for c in p]
    return (struct.pack("<III", n_ranks, len(points), len(token)) + token
            + struct.pack(f"<{len(pts)}d", *pts))


@pytest.mark.parametrize("version", [0, 1, 2, 4, 0xFFFF])
@pytest.mark.parametrize("msg_type", [1, 3, 7])
def test_a_hand_built_frame_of_another_version_is_refused(version, msg_type):
    payload = _hello(1, [(1.0, 2.0, 3.0)]) if msg_type == 1 else b""
    data = _frame(version, msg_type, payload)
    for decode in (wire.decode_frame, lambda d: wire.decode_header(d[:16])):
        with pytest.raises(WireError) as info:
            decode(data)
        assert info.value.code == ErrorCode.VERSION_MISMATCH == 2
        assert f"version {version}" in str(info.value) and "version 3" in str(info.value)
    # and over a socket, before the payload is read
    a, b = _pair()
    a.sendall(data)
    with pytest.raises(WireError) as info:
        wire.read_frame(b, 5)
    assert info.value.code == ErrorCode.VERSION_MISMATCH
    a.close()
    b.close()


def test_a_hand_built_frame_of_the_spec_version_is_accepted():
    payload = _hello(2, [(1.0, 2.0, 3.0), (-4.0, 0.5, 6.25)], token=b"ab")
    frame = wire.decode_frame(_frame(SPEC_VERSION, 1, payload, seq=9))
    assert (frame.type, frame.seq, frame.payload) == (MessageType.HELLO, 9, payload)
    hello = wire.unpack_hello(frame.payload)
    assert (hello.n_ranks, hello.token) == (2, "ab")
    assert hello.points.tolist() == [[1.0, 2.0, 3.0], [-4.0, 0.5, 6.25]]


@pytest.mark.parametrize("token", [b"", b"ab"])
@pytest.mark.parametrize("extra", [b"\0", b"\0" * 7, b"\0" * 24])
def test_a_hand_built_hello_with_trailing_bytes_is_refused(token, extra):
    payload = _hello(1, [(1.0, 2.0, 3.0), (4.0, 5.0, 6.0)], token) + extra
    with pytest.raises(WireError) as info:
        wire.unpack_hello(payload)
    assert info.value.code == ErrorCode.BAD_HELLO == 3
    assert f"got {len(payload)}" in str(info.value)


def test_a_hand_built_hello_one_byte_short_is_refused():
    payload = _hello(1, [(1.0, 2.0, 3.0)])[:-1]
    with pytest.raises(WireError) as info:
        wire.unpack_hello(payload)
    assert info.value.code == ErrorCode.BAD_HELLO


# --- every rejection carries its docs/protocol.md code and names what was wrong -----------------

_BIG = wire.MAX_PAYLOAD


@pytest.mark.parametrize("call, code, words", [
    (lambda: wire.encode_frame(MessageType.REQUEST, b"\0" * (_BIG + 1)), 1,
     f"payload of {_BIG + 1} bytes exceeds the limit of {_BIG} bytes"),
    (lambda: wire.decode_header(b"WHAL\x01\x00"), 1, "frame header has 6 bytes, expected 16"),
    (lambda: wire.decode_frame(_frame(SPEC_VERSION, 7, b"")[:16] + b"x"), 1,
     "header announces 0 payload bytes, got 1"),
    (lambda: wire.unpack_hello(bytes(11)), 3, "bad HELLO: payload has 11 bytes, expected at "
     "least 12"),
    (lambda: wire.unpack_hello(_hello(0, [])), 3, "^bad HELLO: 0 ranks$"),
    (lambda: wire.unpack_hello(struct.pack("<III", 1, 0, 2) + b"\xff\xfe"), 3,
     "^bad HELLO: token is not UTF-8$"),
    (lambda: wire.unpack_welcome(bytes(19)), 1, "bad WELCOME: payload has 19 bytes, expected 20"),
    (lambda: wire.unpack_request(bytes(57)), 1, "bad REQUEST: payload has 57 bytes, expected 104"),
    (lambda: wire.unpack_request(bytes(56)), 1, "bad REQUEST: payload has 56 bytes, expected 104"),
    (lambda: wire.unpack_displacement(bytes(59)), 1,
     "bad DISPLACEMENT: payload has 59 bytes, expected at least 60"),
    (lambda: wire.unpack_displacement(struct.pack("<7dI", 0.5, *[0] * 6, 1) + bytes(23)), 1,
     "bad DISPLACEMENT: payload has 83 bytes, expected 84"),
    # a version-2 DISPLACEMENT (no frame block) for one point is too short for its count
    (lambda: wire.unpack_displacement(struct.pack("<dI", 0.5, 1) + bytes(24)), 1,
     "bad DISPLACEMENT: payload has 36 bytes, expected at least 60"),
    (lambda: wire.unpack_write(bytes(7)), 1, "bad WRITE: payload has 7 bytes, expected 8"),
    (lambda: wire.unpack_error(bytes(3)), 1, "bad ERROR: payload has 3 bytes, expected at least 4"),
])
def test_each_rejection_has_its_code_and_message(call, code, words):
    with pytest.raises(WireError) as info:
        call()
    assert info.value.code == code and isinstance(info.value.code, ErrorCode)
    if words.startswith("^"):  # the whole message
        assert str(info.value) == words.strip("^$")
    else:
        assert words in str(info.value)


def test_limits_and_minimal_payloads_are_accepted():
    # a payload of exactly the limit may be sent and announced
    assert len(wire.encode_frame(MessageType.DISPLACEMENT, bytes(_BIG))) == 16 + _BIG
    assert wire.decode_header(struct.pack("<4sHHII", b"WHAL", SPEC_VERSION, 4, _BIG, 2)) == (
        MessageType.DISPLACEMENT, _BIG, 2)
    # defaults: no payload, sequence number 0
    assert wire.encode_frame(MessageType.BYE) == struct.pack("<4sHHII", b"WHAL", SPEC_VERSION, 7,
                                                             0, 0)
    # the smallest valid payloads: a one-rank HELLO with no points and no token, an empty
    # DISPLACEMENT, an ERROR with an empty message
    hello = wire.unpack_hello(struct.pack("<III", 1, 0, 0))
    assert (hello.n_ranks, hello.token, hello.points.shape) == (1, "", (0, 3))
    reply = wire.unpack_displacement(struct.pack("<7dI", 2.5, *[0.0] * 6, 0))
    assert reply.time == 2.5 and reply.displacement.shape == (0, 3)
    assert wire.unpack_error(struct.pack("<I", 6)) == (6, "")


def test_unsigned_fields_and_hand_packed_payloads():
    """u32 fields past 2**31 (unsigned, docs/protocol.md), integer coordinates sent as f64,
    and the module's packers against the byte layout of the spec."""
    big = 2**31 + 5
    assert wire.unpack_error(struct.pack("<I", big) + "é".encode())[0] == big
    assert wire.pack_error(big, "x") == struct.pack("<I", big) + b"x"
    assert wire.pack_hello(big + 1, [[1, 2, 3]], token="é") == _hello(
        big + 1, [(1.0, 2.0, 3.0)], "é".encode())
    hello = wire.unpack_hello(_hello(big + 1, [(1.0, 2.0, 3.0)]))
    assert hello.n_ranks == big + 1
    pts = [[1, 2, 3], [4, 5, 6]]  # integers: sent as float64
    # DISPLACEMENT: f64 time, 3 f64 frame velocity, 3 f64 frame acceleration, u32 nPoints, points
    assert wire.pack_displacement(0.25, [1, 0, 0], [0, 0, 2], pts) == struct.pack(
        "<7dI6d", 0.25, 1, 0, 0, 0, 0, 2, 2, *range(1, 7))
    # REQUEST: f64 time, pressure force, viscous force, pressure moment, viscous moment
    assert wire.pack_request(0.5, [1, 2, 3], [4, 5, 6], [7, 8, 9], [10, 11, 12]) == struct.pack(
        "<13d", 0.5, *range(1, 13))
    assert wire.pack_hello(1, pts)[12:] == struct.pack("<6d", *range(1, 7))
    # a bad byte in an ERROR message is replaced, not raised
    assert wire.unpack_error(struct.pack("<I", 1) + b"a\xffb") == (1, "a\ufffdb")


def test_read_frame_restores_the_socket_timeout_and_names_what_was_truncated():
    a, b = _pair()
    b.settimeout(2.5)
    a.sendall(_frame(SPEC_VERSION, 7))
    assert wire.read_frame(b, 5).type == MessageType.BYE
    assert b.gettimeout() == 2.5
    for data, words in ((_frame(SPEC_VERSION, 7)[:9], "after 8 of 15 header rest bytes"),
                        (_frame(SPEC_VERSION, 5, bytes(8))[:20], "after 4 of 8 payload bytes")):
        a.sendall(data)
        with pytest.raises(WireError, match=words):
            wire.read_frame(b, 0.2)
        assert b.gettimeout() == 2.5
    a.close()
    with pytest.raises(wire.ConnectionClosed) as info:
        wire.read_frame(b, 5)
    assert str(info.value) == "peer closed the connection"
    b.close()


def test_send_frame_writes_the_spec_bytes():
    a, b = _pair()
    wire.send_frame(a, MessageType.WRITE, struct.pack("<d", 1.5), seq=12)
    wire.send_frame(a, MessageType.BYE)
    want = _frame(SPEC_VERSION, 5, struct.pack("<d", 1.5), seq=12) + _frame(SPEC_VERSION, 7, seq=0)
    got = b""
    while len(got) < len(want):
        got += b.recv(4096)
    assert got == want
    a.close()
    b.close()


class _OneByteAtATime:
    """A socket stand-in whose every read returns a single byte (a worst-case kernel)."""

    def __init__(self, data):
        self.data, self.timeout = bytearray(data), None

    def recv_into(self, view, n):
        if not self.data:
            return 0
        view[0] = self.data.pop(0)
        return 1

    def gettimeout(self):
        return self.timeout

    def settimeout(self, t):
        self.timeout = t


def test_read_frame_assembles_a_frame_read_one_byte_at_a_time():
    payload = struct.pack("<d", 1.5)
    frame = wire.read_frame(_OneByteAtATime(_frame(SPEC_VERSION, 5, payload, seq=3)), 5)
    assert (frame.type, frame.seq, frame.payload) == (MessageType.WRITE, 3, payload)
