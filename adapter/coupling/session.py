"""One connection to the step-server: reads frames and answers them (docs/protocol.md).

HELLO opens the case's one link (the patch mapped onto the whale), REQUEST(t) gets the whale's
frame and the patch's displacement at t, WRITE(t) writes the whale and its state at a time
OpenFOAM wrote, BYE ends the link. A protocol violation is answered with an ERROR frame and
closes the connection; a client that vanishes without BYE is reported to the server (which then
saves its state).
"""

from __future__ import annotations

import hmac
import logging
import socket
import threading
import time

import numpy as np

from adapter.coupling import protocol as wire
from adapter.coupling.mapping import PatchMap
from adapter.coupling.protocol import TOKEN_ENV, ErrorCode, MessageType, WireError
from adapter.coupling.store import time_name
from adapter.errors import GeometryError, UnstableError

log = logging.getLogger(__name__)


class Session:
    """One client connection of a :class:`~adapter.coupling.server.StepServer`.

    Parameters
    ----------
    sock : the connected socket (blocking).
    peer : the client's name for the log (``host:port`` or ``unix``).
    server : the server it belongs to: its ``animator``, ``timeline``, ``recorder``, ``links``
        (:class:`Links`), ``stats_counter``, ``token``, ``map_tolerance`` and ``map_cache``,
        and ``write``, ``model_failed``, ``client_vanished``.
    """

    def __init__(self, sock: socket.socket, peer: str, server):
        self.sock = sock
        self.peer = peer
        self.server = server
        self.send_lock = threading.Lock()
        #: after HELLO: the rank count the link speaks for (information)
        self.n_ranks: int | None = None
        #: after HELLO: the client's points mapped onto the whale
        self.patch: PatchMap | None = None
        self.first_request = True
        self.last_t: float | None = None
        self.said_bye = False
        self.error_sent = False
        self.last_reply: tuple[float, bytes] | None = None

    @property
    def linked(self) -> bool:
        """Whether this client said HELLO (it holds the case's link)."""
        return self.n_ranks is not None

    def send(self, msg_type, payload=b"", seq=0) -> float:
        """Send one frame; returns the seconds it took."""
        t0 = time.perf_counter()
        with self.send_lock:
            wire.send_frame(self.sock, msg_type, payload, seq)
        return time.perf_counter() - t0

    def send_error(self, code, message, seq=0) -> None:
        """Send an ERROR frame, once per connection; a broken socket is ignored."""
        if self.error_sent:
            return
        self.error_sent = True
        try:
            self.send(MessageType.ERROR, wire.pack_error(code, message), seq)
        except OSError:
            pass

    def shutdown(self) -> None:
        """Wake the thread blocked reading this connection (the server is finishing)."""
        try:
            self.sock.shutdown(socket.SHUT_RDWR)
        except OSError:
            pass

    # --- the loop -----------------------------------------------------------------------------

    def serve(self) -> None:
        """Read and answer frames until BYE, an error or the end of the connection."""
        server = self.server
        seq = 0
        try:
            while True:
                t_wait = time.perf_counter()
                frame = wire.read_frame(self.sock)
                t_recv = time.perf_counter()
                seq = frame.seq
                if self.error_sent:          # an ERROR 6 is waiting in the client's buffer
                    break
                if not self.handle(frame, t_wait, t_recv):
                    break
        except wire.ConnectionClosed:
            if self.linked and not self.said_bye and not self.error_sent:
                server.client_vanished(self, "closed the connection without BYE")
        except WireError as exc:
            log.warning("client %s: %s", self.peer, exc)
            server.links.drop(self)            # before the ERROR: the client may reconnect at once
            self.send_error(exc.code, str(exc), seq)
        except OSError as exc:
            if self.linked and not self.said_bye and not self.error_sent:
                server.client_vanished(self, f"connection lost ({exc})")
        except Exception as exc:      # never let one client bring the server down
            log.exception("client %s: internal error", self.peer)
            server.links.drop(self)
            self.send_error(ErrorCode.BAD_FRAME, f"internal server error: {exc}", seq)
        finally:
            server.links.drop(self)
            try:
                self.sock.close()
            except OSError:
                pass

    def handle(self, frame: wire.Frame, t_wait: float, t_recv: float) -> bool:
        """Answer one frame; False closes the connection."""
        kind = frame.type
        if not self.linked and kind != MessageType.HELLO:
            raise WireError(ErrorCode.BAD_FRAME,
                            f"expected HELLO as the first message, got {kind.name}")
        failure = self.server.timeline.failure
        if failure is not None:
            self.send_error(ErrorCode.MODEL_FAILURE, failure, frame.seq)
            return False
        if kind == MessageType.HELLO:
            if self.linked:
                raise WireError(ErrorCode.BAD_FRAME, "HELLO sent twice on one connection")
            return self._hello(frame)
        if kind == MessageType.REQUEST:
            return self._request(frame, t_recv)
        if kind == MessageType.WRITE:
            self.server.write(wire.unpack_write(frame.payload))
            self.send(MessageType.ACK, b"", frame.seq)
            return True
        if kind == MessageType.BYE:
            self.said_bye = True
            log.info("client %s said BYE", self.peer)
            return False
        raise WireError(ErrorCode.BAD_FRAME, f"a client may not send {kind.name}")

    def _hello(self, frame: wire.Frame) -> bool:
        server = self.server
        hello = wire.unpack_hello(frame.payload)
        token = server.token
        if token is not None and not hmac.compare_digest(
                hello.token.encode("utf-8"), token.encode("utf-8")):
            what = "no token" if not hello.token else "a wrong token"
            raise WireError(ErrorCode.BAD_TOKEN,
                            f"the client sent {what}; set {TOKEN_ENV} for OpenFOAM's "
                            f"master rank to the token the server was started with")
        server.links.check_free(self)
        surface = server.animator.surface
        t0 = time.perf_counter()
        try:
            patch = PatchMap(hello.points, surface.points, surface.triangles, surface.length,
                             server.map_tolerance, cache=server.map_cache)
        except GeometryError as exc:
            raise WireError(ErrorCode.BAD_HELLO, f"bad HELLO: {exc}") from None
        server.links.claim(self, hello.n_ranks, patch)
        log.info("link %s for %d rank(s): %d patch points, max mapping distance %.3g m "
                 "(map %s in %.2f s)", self.peer, hello.n_ranks, patch.n_points,
                 patch.max_distance, patch.cache_status or "computed",
                 time.perf_counter() - t0)
        welcome = wire.pack_welcome(patch.n_points, patch.max_distance, server.animator.dt)
        self.send(MessageType.WELCOME, welcome, frame.seq)
        return True

    def _request(self, frame: wire.Frame, t_recv: float) -> bool:
        server = self.server
        t_start = time.perf_counter()
        req = wire.unpack_request(frame.payload)
        t = req.time
        server.timeline.check_time(t, "REQUEST")
        if self.last_reply is not None and self.last_reply[0] == t:
            payload = self.last_reply[1]
        else:
            try:
                served = server.timeline.motion(t, self.last_t, restarted=self.first_request,
                                                request=req)
            except UnstableError as exc:
                server.model_failed(str(exc), self, frame.seq)
                return False
            if self.patch is None:   # handle() lets only a linked session ask
                raise WireError(ErrorCode.BAD_FRAME, "REQUEST before HELLO")
            payload = wire.pack_displacement(t, served.frame.velocity, served.frame.acceleration,
                                             self.patch.apply(served.disp))
            self.last_reply = (t, payload)
        self.first_request = False
        self.last_t = t if self.last_t is None else max(self.last_t, t)
        t_ready = time.perf_counter()
        send_s = self.send(MessageType.DISPLACEMENT, payload, frame.seq)
        # the rest while OpenFOAM solves this step: only now, the answer sent (the work-ahead's
        # compiled kernels hold the GIL); the next REQUEST comes on this thread, after it
        server.timeline.work_ahead()
        server.recorder.add_forces(t, np.concatenate([req.pressure_force, req.viscous_force]))
        server.stats_counter.add_request(t_ready - t_start, (t_start - t_recv) + send_s)
        log.debug("%s t=%s compute %.3g ms send %.3g ms", self.peer, time_name(t),
                  1e3 * (t_ready - t_start), 1e3 * send_s)
        return True


class Links:
    """The open connections of one server, each served by its own thread, and the case's one
    link among them (the session that said HELLO).

    Parameters
    ----------
    case_dir : the case served (for the busy message).
    stats : the server's :class:`~adapter.coupling.recorder.ServerStats` (links counted).
    """

    def __init__(self, case_dir, stats):
        self.case_dir = case_dir
        self.stats = stats
        self._lock = threading.Lock()
        self._sessions: set[Session] = set()
        self._threads: list[threading.Thread] = []

    def start(self, session: Session) -> None:
        """Serve ``session`` in a thread of its own."""
        with self._lock:
            self._sessions.add(session)
        thread = threading.Thread(target=session.serve, daemon=True,
                                  name=f"step-server {session.peer}")
        self._threads = [t for t in self._threads if t.is_alive()] + [thread]
        thread.start()

    def drop(self, session: Session) -> None:
        """Forget a session (its connection is closing)."""
        with self._lock:
            self._sessions.discard(session)

    def linked(self, but: Session | None = None) -> list[Session]:
        """The sessions that said HELLO (but ``but``)."""
        with self._lock:
            return [s for s in self._sessions if s is not but and s.linked]

    def check_free(self, session: Session) -> None:
        """One link per case: ERROR 7 while another client that said HELLO is connected."""
        with self._lock:
            self._check_free(session)

    def _check_free(self, session: Session) -> None:
        other = next((s for s in self._sessions if s is not session and s.linked), None)
        if other is not None:
            raise WireError(ErrorCode.BUSY,
                            f"server busy: {self.case_dir} is already served to a client "
                            f"({other.peer}, {other.n_ranks} rank(s)); one link per case: is "
                            f"another run using this case?")

    def claim(self, session: Session, n_ranks: int, patch) -> None:
        """Give ``session`` (its patch mapped) the case's one link, if still free."""
        with self._lock:
            self._check_free(session)
            session.n_ranks = n_ranks
            session.patch = patch
            self.stats.add_link(n_ranks, patch.n_points, patch.max_distance)

    def close(self, timeout: float = 5.0) -> None:
        """Wake every session's thread (its socket shut down) and wait for it."""
        with self._lock:
            sessions = list(self._sessions)
        for s in sessions:
            s.shutdown()
        for t in list(self._threads):
            t.join(timeout=timeout)
