"""Clients of another protocol version, a second server on a case, the socket's
permissions and TCP's token: refused, naming what they met (docs/faults.md)."""

from __future__ import annotations

import os
import socket
import stat
import subprocess
import sys

import numpy as np
import pytest

from adapter.cli import build_parser
from adapter.coupling import protocol as wire
from adapter.coupling.protocol import (
    SOCKET_NAME,
    ErrorCode,
    MessageType,
)

from ..wire_client import Client, ServerSaid, finished
from .conftest import REPO, _serve_cli, _wait_for_socket

# --- version, second server, security --------------------------------------------------------


def test_other_protocol_versions_are_refused_naming_both(case, serve, points, truth):
    srv = serve(case)
    good = Client(case)
    good.hello(points[:10])
    for version in (0, 1, 2, 4, 7, 65535):
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
    with pytest.raises(ServerSaid, match="version 2"):
        mid.call(MessageType.HELLO, wire.pack_hello(1, points[:10]), version=2)
    assert np.array_equal(good.displacement(0.01), truth(0.01)[:10])
    good.bye()
    assert finished(srv) == 0


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
