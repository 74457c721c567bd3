"""The wire format of docs/protocol.md: round trips, partial reads, and every rejection."""

import socket
import struct
import threading

import numpy as np
import pytest

from adapter import protocol as wire
from adapter.errors import ProtocolError
from adapter.protocol import ErrorCode, MessageType, WireError


def test_header_layout_matches_the_spec():
    frame = wire.encode_frame(MessageType.REQUEST, b"x" * 56, seq=7)
    assert frame[:4] == b"WHAL"
    assert struct.unpack("<HHII", frame[4:16]) == (2, 3, 56, 7)
    assert len(frame) == 16 + 56
    decoded = wire.decode_frame(frame)
    assert (decoded.type, decoded.seq, decoded.payload) == (MessageType.REQUEST, 7, b"x" * 56)


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
    req = wire.unpack_request(wire.pack_request(0.1, (1, 2, 3), (4, 5, 6)))
    assert req.time == 0.1 and req.pressure_force.tolist() == [1, 2, 3]
    assert req.viscous_force.tolist() == [4, 5, 6]
    assert np.isnan(wire.unpack_request(wire.pack_request(0.2)).pressure_force).all()
    t, d = wire.unpack_displacement(wire.pack_displacement(0.3, pts))
    assert t == 0.3 and np.array_equal(d, pts)
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
        (struct.pack("<4sHHII", b"WHAL", 2, 3, wire.MAX_PAYLOAD + 1, 1), ErrorCode.BAD_FRAME,
         "exceeds the limit"),
        (struct.pack("<4sHHII", b"WHAL", 2, 42, 0, 1), ErrorCode.BAD_FRAME, "unknown message"),
        (struct.pack("<4sHHII", b"WHAL", 1, 1, 0, 1), ErrorCode.VERSION_MISMATCH, "version 1"),
        (struct.pack("<4sHHII", b"WHAL", 2, 3, 56, 1) + bytes(10), ErrorCode.BAD_FRAME,
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
    with pytest.raises(WireError, match="version 7.*version 2"):
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
        wire.unpack_request(b"\0" * 55)
    with pytest.raises(WireError, match="DISPLACEMENT"):
        wire.unpack_displacement(wire.pack_displacement(0.0, np.zeros((2, 3)))[:-1])
