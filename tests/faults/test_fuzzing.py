"""Fuzzed frames against a real step-server: it never crashes and never lies
(docs/faults.md)."""

from __future__ import annotations

import os
import socket
import time

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from adapter.coupling import protocol as wire
from adapter.coupling.protocol import (
    HEADER,
    MAGIC,
    SOCKET_NAME,
    ErrorCode,
    MessageType,
)

from ..wire_client import Client, ServerSaid, finished

#: fuzz cases in total (the issue asks for at least 10,000)
FUZZ_CASES = int(os.environ.get("FUZZ_CASES", 10_000))



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
        not_hello, st.one_of(st.binary(max_size=120), st.binary(min_size=104, max_size=104)), u32)
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
    sizes = {MessageType.REQUEST: 104, MessageType.WRITE: 8}
    wrong_size = st.builds(
        lambda k, p, s: (wire.encode_frame(k, p, s), {}),
        st.sampled_from(list(sizes)), st.binary(max_size=120), u32).filter(
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

    def hello_when_free(n_points):
        # a fuzzed link that said HELLO holds the case until the server has read its end,
        # which can wait for a work-ahead begun for that link (its compiled kernels hold the
        # GIL): a well-behaved client met ERROR 7 right after a batch (CI, 2026-12-02; for over
        # 5 s beside a 2-rank flow run, 2026-12-03), so it asks again for up to 30 s; any other
        # error, or BUSY past that, fails the test
        deadline = time.monotonic() + 30.0
        while True:
            client = Client(case)
            try:
                client.hello(points[:n_points], n_ranks=2)
                return client
            except ServerSaid as said:
                if said.code != ErrorCode.BUSY or time.monotonic() > deadline:
                    raise
                time.sleep(0.05)

    def keeper_checks(t):
        keeper = hello_when_free(20)
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
                reply = wire.unpack_displacement(f.payload)
                t, disp = reply.time, reply.displacement
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
    late = hello_when_free(len(points))
    for t in (keeper_t[-1] + 0.01, keeper_t[-1] + 0.02):
        assert np.array_equal(late.displacement(t), truth(t))
    late.bye()
    srv.stop()
    assert finished(srv) == 0
    assert not (case / SOCKET_NAME).exists()
