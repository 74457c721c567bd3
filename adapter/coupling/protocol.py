"""The step-server wire format (docs/protocol.md, version 3).

A frame is a 16-byte header -- magic ``WHAL``, version (u16), message type (u16), payload length
(u32), sequence number (u32), all little-endian -- then the payload. Reals are float64
little-endian. This module packs and unpacks frames and each message's payload; it does no
socket work except :func:`read_frame`, which reads exactly one frame however the bytes arrive.

Every decoding failure raises :class:`WireError`, a :class:`~adapter.errors.ProtocolError`
carrying the protocol's error ``code`` (1 bad frame, 2 version mismatch, 3 bad HELLO) so that a
server can answer it with an ERROR frame.
"""

from __future__ import annotations

import socket
import struct
from dataclasses import dataclass
from enum import IntEnum

import numpy as np

from adapter.errors import ProtocolError

MAGIC = b"WHAL"
#: 3: the whale's frame (inflow and body force) in DISPLACEMENT, moments in REQUEST (2: one link
#: per case, the master rank sends every rank's points; no rank field in HELLO)
VERSION = 3
#: largest payload accepted (bytes)
MAX_PAYLOAD = 64 * 1024 * 1024
HEADER = struct.Struct("<4sHHII")
HEADER_SIZE = HEADER.size  # 16

_F64 = np.dtype("<f8")

# --- the link's shared facts (the C++ client has the same: tests/test_shared_facts.py) -------

#: the server's UNIX socket in the case folder
SOCKET_NAME = ".whale-adapter.sock"
#: where the server says it listens, in the case folder (read by the boundary condition)
ENDPOINT_NAME = ".whale-adapter.endpoint"
#: the environment variable holding the shared secret (never written into the case)
TOKEN_ENV = "WHALE_ADAPTER_TOKEN"
#: the boundary condition's defaults (s): keep retrying the connection for, wait for a reply
CONNECT_TIMEOUT_S = 5
REPLY_TIMEOUT_S = 120


class MessageType(IntEnum):
    """Message types (u16 in the header)."""

    HELLO = 1
    WELCOME = 2
    REQUEST = 3
    DISPLACEMENT = 4
    WRITE = 5
    ACK = 6
    BYE = 7
    ERROR = 9


class ErrorCode(IntEnum):
    """Codes carried by an ERROR message."""

    BAD_FRAME = 1
    VERSION_MISMATCH = 2
    BAD_HELLO = 3
    BAD_TOKEN = 4
    TIME_BACKWARDS = 5
    MODEL_FAILURE = 6
    BUSY = 7


class WireError(ProtocolError):
    """A protocol violation, with the ERROR code the server answers it with."""

    def __init__(self, code: int, message: str):
        super().__init__(message)
        self.code = ErrorCode(code)


class ConnectionClosed(ProtocolError):
    """The peer closed the connection cleanly, between two frames."""


@dataclass(frozen=True)
class Frame:
    """One decoded frame: message type, sequence number and raw payload."""

    type: MessageType
    seq: int
    payload: bytes


@dataclass(frozen=True)
class Hello:
    """A client's HELLO: the solver's rank count (information), the token and the whole patch's
    points (P, 3) in m, every rank's in rank order."""

    n_ranks: int
    token: str
    points: np.ndarray


@dataclass(frozen=True)
class Request:
    """A REQUEST: the time (s), the whole patch's pressure and viscous forces (3,) in N and their
    moments (3,) in N m about the origin, at the last completed step (NaN: not known)."""

    time: float
    pressure_force: np.ndarray
    viscous_force: np.ndarray
    pressure_moment: np.ndarray
    viscous_moment: np.ndarray

    def loads(self) -> np.ndarray:
        """The (12,) forces then moments: pressure force, viscous force, pressure moment,
        viscous moment."""
        return np.concatenate([self.pressure_force, self.viscous_force, self.pressure_moment,
                               self.viscous_moment])

    def known(self) -> bool:
        """Whether every force and moment is finite (not the NaN of a first REQUEST)."""
        return bool(np.isfinite(self.loads()).all())


@dataclass(frozen=True)
class Displacement:
    """A DISPLACEMENT: the time (s), the frame's velocity (3,) in m/s and acceleration (3,) in
    m/s2, and the patch's displacement (P, 3) in m."""

    time: float
    frame_velocity: np.ndarray
    frame_acceleration: np.ndarray
    displacement: np.ndarray


# --- frames -----------------------------------------------------------------------------------


def encode_frame(msg_type: int, payload: bytes = b"", seq: int = 0,
                 version: int = VERSION) -> bytes:
    """One frame: header then payload."""
    if len(payload) > MAX_PAYLOAD:
        raise WireError(ErrorCode.BAD_FRAME,
                        f"payload of {len(payload)} bytes exceeds the limit of {MAX_PAYLOAD} bytes")
    return HEADER.pack(MAGIC, version, int(msg_type), len(payload), seq & 0xFFFFFFFF) + payload


def decode_header(header: bytes) -> tuple[MessageType, int, int]:
    """Check a 16-byte header and return ``(type, payload length, sequence number)``."""
    if len(header) != HEADER_SIZE:
        raise WireError(ErrorCode.BAD_FRAME,
                        f"frame header has {len(header)} bytes, expected {HEADER_SIZE}")
    magic, version, msg_type, length, seq = HEADER.unpack(header)
    if magic != MAGIC:
        raise WireError(ErrorCode.BAD_FRAME,
                        f"bad frame: magic {magic!r}, expected {MAGIC!r} "
                        f"(not a whale-adapter peer?)")
    if version != VERSION:
        raise WireError(ErrorCode.VERSION_MISMATCH,
                        f"protocol version mismatch: the peer speaks version {version}, "
                        f"this side speaks version {VERSION}; rebuild the OpenFOAM plugin and "
                        f"the adapter from the same release")
    if length > MAX_PAYLOAD:
        raise WireError(ErrorCode.BAD_FRAME,
                        f"bad frame: payload length {length} exceeds the limit of "
                        f"{MAX_PAYLOAD} bytes")
    try:
        kind = MessageType(msg_type)
    except ValueError:
        raise WireError(ErrorCode.BAD_FRAME,
                        f"bad frame: unknown message type {msg_type}") from None
    return kind, length, seq


def decode_frame(data: bytes) -> Frame:
    """Decode one complete frame held in ``data`` (header and exactly its payload)."""
    kind, length, seq = decode_header(data[:HEADER_SIZE])
    payload = data[HEADER_SIZE:]
    if len(payload) != length:
        raise WireError(ErrorCode.BAD_FRAME,
                        f"bad frame: header announces {length} payload bytes, got {len(payload)}")
    return Frame(kind, seq, bytes(payload))


def _recv_exact(sock: socket.socket, n: int, what: str) -> bytes:
    buf = bytearray(n)
    view = memoryview(buf)
    got = 0
    while got < n:
        try:
            k = sock.recv_into(view[got:], n - got)
        except TimeoutError:
            raise WireError(ErrorCode.BAD_FRAME,
                            f"truncated frame: timed out after {got} of {n} {what} bytes") from None
        if k == 0:
            if got == 0 and what == "header":
                raise ConnectionClosed("peer closed the connection")
            raise WireError(ErrorCode.BAD_FRAME,
                            f"truncated frame: connection closed after {got} of {n} {what} bytes")
        got += k
    return bytes(buf)


def read_frame(sock: socket.socket, frame_timeout: float | None = 30.0) -> Frame:
    """Read exactly one frame from a blocking socket, however the bytes are split.

    Waits without limit for the first byte (a flow solve may take long), then allows
    ``frame_timeout`` seconds for the rest of the frame. Raises :class:`ConnectionClosed` on a
    clean close between frames and :class:`WireError` for anything malformed; an oversized or
    foreign header is rejected before its payload is read.
    """
    old = sock.gettimeout()
    try:
        sock.settimeout(None)
        first = _recv_exact(sock, 1, "header")
        sock.settimeout(frame_timeout)
        header = first + _recv_exact(sock, HEADER_SIZE - 1, "header rest")
        kind, length, seq = decode_header(header)
        payload = _recv_exact(sock, length, "payload") if length else b""
    finally:
        sock.settimeout(old)
    return Frame(kind, seq, payload)


def send_frame(sock: socket.socket, msg_type: int, payload: bytes = b"", seq: int = 0) -> None:
    """Send one frame (blocking until the kernel has taken all of it)."""
    sock.sendall(encode_frame(msg_type, payload, seq))


# --- payloads ---------------------------------------------------------------------------------


def _f64_array(payload: bytes, offset: int, count: int) -> np.ndarray:
    return np.frombuffer(payload, dtype=_F64, count=count, offset=offset).astype(np.float64)


def _expect_size(payload: bytes, size: int, name: str) -> None:
    if len(payload) != size:
        raise WireError(ErrorCode.BAD_FRAME,
                        f"bad {name}: payload has {len(payload)} bytes, expected {size}")


def pack_hello(n_ranks: int, points, token: str = "") -> bytes:
    """HELLO payload: the solver's rank count, the token, ``points`` (P, 3) in m."""
    pts = np.ascontiguousarray(points, dtype=_F64).reshape(-1, 3)
    tok = token.encode("utf-8")
    return struct.pack("<III", n_ranks, len(pts), len(tok)) + tok + pts.tobytes()


def unpack_hello(payload: bytes) -> Hello:
    """Decode a HELLO payload; a point count that disagrees with the payload is ERROR 3."""
    if len(payload) < 12:
        raise WireError(ErrorCode.BAD_HELLO,
                        f"bad HELLO: payload has {len(payload)} bytes, expected at least 12")
    n_ranks, n_points, n_token = struct.unpack_from("<III", payload)
    expected = 12 + n_token + 24 * n_points
    if len(payload) != expected:
        raise WireError(ErrorCode.BAD_HELLO,
                        f"bad HELLO: {n_points} points and a {n_token}-byte token need "
                        f"{expected} payload bytes, got {len(payload)}")
    if n_ranks == 0:
        raise WireError(ErrorCode.BAD_HELLO, "bad HELLO: 0 ranks")
    try:
        token = payload[12:12 + n_token].decode("utf-8")
    except UnicodeDecodeError:
        raise WireError(ErrorCode.BAD_HELLO, "bad HELLO: token is not UTF-8") from None
    points = _f64_array(payload, 12 + n_token, 3 * n_points).reshape(n_points, 3)
    return Hello(n_ranks, token, points)


_WELCOME = struct.Struct("<Idd")


def pack_welcome(n_points: int, max_distance: float, dt: float) -> bytes:
    """WELCOME payload: points accepted, max mapping distance (m), internal step (s)."""
    return _WELCOME.pack(n_points, max_distance, dt)


def unpack_welcome(payload: bytes) -> tuple[int, float, float]:
    _expect_size(payload, _WELCOME.size, "WELCOME")
    return _WELCOME.unpack(payload)


_REQUEST = struct.Struct("<13d")
_NAN3 = (np.nan,) * 3


def pack_request(time: float, pressure_force=_NAN3, viscous_force=_NAN3, pressure_moment=_NAN3,
                 viscous_moment=_NAN3) -> bytes:
    """REQUEST payload: time (s), the whole patch's pressure and viscous force (3,) in N, then
    its pressure and viscous moment (3,) in N m about the origin."""
    loads = (pressure_force, viscous_force, pressure_moment, viscous_moment)
    return _REQUEST.pack(time, *(float(v) for vec in loads for v in vec))


def unpack_request(payload: bytes) -> Request:
    _expect_size(payload, _REQUEST.size, "REQUEST")
    values = np.array(_REQUEST.unpack(payload))
    return Request(float(values[0]), values[1:4], values[4:7], values[7:10], values[10:13])


#: DISPLACEMENT's fixed part: time, frame velocity (3), frame acceleration (3), point count
_DISPLACEMENT = struct.Struct("<7dI")


def pack_displacement(time: float, frame_velocity, frame_acceleration, displacement) -> bytes:
    """DISPLACEMENT payload: time (s), the frame's velocity (3,) in m/s and acceleration (3,)
    in m/s2, point count, displacement (P, 3) in m."""
    d = np.ascontiguousarray(displacement, dtype=_F64).reshape(-1, 3)
    frame = [float(v) for vec in (frame_velocity, frame_acceleration) for v in vec]
    if len(frame) != 6:
        raise ValueError(f"the frame's velocity and acceleration need 3 values each, got "
                         f"{len(frame)} in all")
    return _DISPLACEMENT.pack(time, *frame, len(d)) + d.tobytes()


def unpack_displacement(payload: bytes) -> Displacement:
    head = _DISPLACEMENT.size
    if len(payload) < head:
        raise WireError(ErrorCode.BAD_FRAME,
                        f"bad DISPLACEMENT: payload has {len(payload)} bytes, expected at least "
                        f"{head}")
    values = _DISPLACEMENT.unpack_from(payload)
    n = values[7]
    _expect_size(payload, head + 24 * n, "DISPLACEMENT")
    return Displacement(values[0], np.array(values[1:4]), np.array(values[4:7]),
                        _f64_array(payload, head, 3 * n).reshape(n, 3))


def pack_write(time: float) -> bytes:
    """WRITE payload: the time (s) OpenFOAM has written."""
    return struct.pack("<d", time)


def unpack_write(payload: bytes) -> float:
    _expect_size(payload, 8, "WRITE")
    return struct.unpack("<d", payload)[0]


def pack_error(code: int, message: str) -> bytes:
    """ERROR payload: code (u32) then a UTF-8 message."""
    return struct.pack("<I", int(code)) + message.encode("utf-8")


def unpack_error(payload: bytes) -> tuple[int, str]:
    if len(payload) < 4:
        raise WireError(ErrorCode.BAD_FRAME,
                        f"bad ERROR: payload has {len(payload)} bytes, expected at least 4")
    (code,) = struct.unpack_from("<I", payload)
    return code, payload[4:].decode("utf-8", errors="replace")
