"""What the tests share to drive a real step-server: a client that speaks the protocol as the
C++ boundary condition does (docs/protocol.md), and a server started in a thread."""

from __future__ import annotations

import socket
import threading
from pathlib import Path

import numpy as np

from adapter.coupling import protocol as wire
from adapter.coupling.protocol import SOCKET_NAME, MessageType
from adapter.coupling.server import StepServer


class ServerSaid(Exception):
    """The server answered with an ERROR frame."""

    def __init__(self, code, message):
        super().__init__(f"ERROR {code}: {message}")
        self.code, self.message = code, message


class Client:
    """OpenFOAM's master rank (a case's one link), on the UNIX socket or (``address``) on TCP."""

    def __init__(self, case: Path | None = None, address=None):
        if address is None:
            self.sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
            self.sock.connect(str(case / SOCKET_NAME))
        else:
            self.sock = socket.create_connection(address, timeout=20)
        self.seq = 0

    def call(self, msg_type, payload=b"", version=wire.VERSION):
        self.seq += 1
        self.sock.sendall(wire.encode_frame(msg_type, payload, self.seq, version=version))
        return self.reply()

    def reply(self):
        frame = wire.read_frame(self.sock, 20)
        if frame.type == MessageType.ERROR:
            raise ServerSaid(*wire.unpack_error(frame.payload))
        assert frame.seq == self.seq
        return frame

    def hello(self, points, n_ranks=1, token=""):
        f = self.call(MessageType.HELLO, wire.pack_hello(n_ranks, points, token))
        assert f.type == MessageType.WELCOME
        return wire.unpack_welcome(f.payload)

    def request(self, t, fp=(np.nan,) * 3, fv=(np.nan,) * 3, mp=(np.nan,) * 3,
                mv=(np.nan,) * 3):
        """(the DISPLACEMENT payload's bytes, the (P, 3) displacement) at time t."""
        payload, reply = self.exchange(t, fp, fv, mp, mv)
        return payload, reply.displacement

    def exchange(self, t, fp=(np.nan,) * 3, fv=(np.nan,) * 3, mp=(np.nan,) * 3,
                 mv=(np.nan,) * 3):
        """(the DISPLACEMENT payload's bytes, the decoded DISPLACEMENT) at time t, for the
        forces ``fp``, ``fv`` and moments ``mp``, ``mv``."""
        f = self.call(MessageType.REQUEST, wire.pack_request(t, fp, fv, mp, mv))
        assert f.type == MessageType.DISPLACEMENT
        reply = wire.unpack_displacement(f.payload)
        assert reply.time == t
        return f.payload, reply

    def displacement(self, t):
        """The (P, 3) displacement at time t."""
        return self.request(t)[1]

    def write(self, t):
        assert self.call(MessageType.WRITE, wire.pack_write(t)).type == MessageType.ACK

    def bye(self):
        self.seq += 1
        wire.send_frame(self.sock, MessageType.BYE, b"", self.seq)
        self.sock.close()


def server_starter(scene, animator, first_client_timeout):
    """A function that starts real servers in threads, and one that stops them all."""
    started = []

    def start(case_dir, **kw):
        kw.setdefault("animator", animator)
        srv = StepServer(case_dir, kw.pop("scene", scene),
                         first_client_timeout=first_client_timeout, **kw)
        srv.start()
        srv.thread = threading.Thread(target=srv.run, daemon=True)
        srv.thread.start()
        started.append(srv)
        return srv

    def stop_all():
        for srv in started:
            srv.stop()
            srv.thread.join(10)

    return start, stop_all


def finished(srv, timeout=15):
    """The server's exit code, once its thread has ended (fails if it has not)."""
    srv.thread.join(timeout)
    assert not srv.thread.is_alive(), "server did not exit"
    return srv.exit_code


def points_near(surface, n: int, seed: int) -> np.ndarray:
    """(n, 3) patch points near the whale: on random triangles, lifted ~1 mm off the surface."""
    rng = np.random.default_rng(seed)
    tri = rng.integers(0, len(surface.triangles), n)
    w = rng.dirichlet([1.0, 1.0, 1.0], n)
    pts = np.einsum("pk,pkd->pd", w, surface.points[surface.triangles[tri]])
    return pts + 1e-3 * rng.normal(size=pts.shape)
