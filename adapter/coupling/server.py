"""The step-server: serves the whale's displacement to OpenFOAM, one flow time step at a time.

``whale-adapter serve --case DIR`` listens on ``DIR/.whale-adapter.sock`` (and optionally on TCP)
and speaks the protocol of docs/protocol.md with ONE client per case, however many MPI ranks
OpenFOAM runs: the master rank gathers every rank's patch points and sends them in one HELLO,
and scatters the displacements itself. The patch points are mapped onto the whale surface once
(:class:`~adapter.coupling.mapping.PatchMap`); the animator is advanced once per flow time,
and, while
OpenFOAM solves the flow,
already towards the next expected time (work-ahead, undone from a checkpoint when the guess
was wrong). Writes under ``DIR/adapter/``: ``whale_<t>.vtp`` + ``whale.pvd`` and
``state_<t>.npz`` at every WRITE, a row of ``keypoints.csv`` per served time, ``server.log``
and ``server-stats.json``. See docs/step-server.md.
"""

from __future__ import annotations

import argparse
import dataclasses
import hashlib
import hmac
import ipaddress
import json
import logging
import math
import os
import selectors
import socket
import stat
import threading
import time
import xml.etree.ElementTree as ET
import zipfile
from collections import OrderedDict
from pathlib import Path

import numpy as np

from adapter.coupling import protocol as wire
from adapter.coupling.mapping import DEFAULT_TOLERANCE, PatchMap
from adapter.coupling.protocol import ErrorCode, MessageType, WireError
from adapter.errors import GeometryError, ServerStartError, UnstableError
from adapter.scene import PRESETS

log = logging.getLogger("adapter.coupling.server")

SOCKET_NAME = ".whale-adapter.sock"
PID_NAME = ".whale-adapter.pid"
#: where the server says it listens (read by the boundary condition's master rank)
ENDPOINT_NAME = ".whale-adapter.endpoint"
#: the patch's map onto the whale, kept in OUTPUT_DIR between runs (reused while the patch holds)
MAP_CACHE_NAME = "patch-map.npz"
#: the environment variable holding the shared secret (never written into the case)
TOKEN_ENV = "WHALE_ADAPTER_TOKEN"
OUTPUT_DIR = "adapter"
LANDMARKS = ("rostrum", "flipper_left", "flipper_right", "tail_base", "fluke_tip_left",
             "fluke_tip_right")
FORCE_COLUMNS = ("fx_p", "fy_p", "fz_p", "fx_v", "fy_v", "fz_v")
#: served times whose node displacement is kept, so a lagging rank gets the same bytes
_CACHE_SIZE = 4
_STATE_FORMAT = 1
#: the largest jump ahead, in stroke cycles, that a REQUEST or WRITE may ask for
MAX_JUMP_CYCLES = 1000
#: what reading a cut-short, empty or foreign state file raises
_UNREADABLE = (OSError, KeyError, ValueError, EOFError, zipfile.BadZipFile)
#: seconds the clients get to read an ERROR 6 before the server exits anyway
_FATAL_GRACE_S = 10.0



def time_name(t: float) -> str:
    """The name of a time in file names: ``0.0125``, ``1e-05``."""
    return format(t, ".12g")


@dataclasses.dataclass
class _Served:
    """The motion at one served time, and the animator state right after computing it."""

    t: float
    disp: np.ndarray
    vel: np.ndarray
    ckpt: dict
    animator_time: float


@dataclasses.dataclass
class _Ahead:
    """Work done ahead: the state before it, and the motion at the predicted time."""

    target: float
    pre: dict
    disp: np.ndarray
    vel: np.ndarray
    compute_s: float


@dataclasses.dataclass
class _Row:
    landmarks: np.ndarray            # (3 * n_landmarks,)
    forces: np.ndarray | None        # (6,) the whole patch's, as the link reported them


class _Connection:
    def __init__(self, sock: socket.socket, peer: str):
        self.sock = sock
        self.peer = peer
        self.send_lock = threading.Lock()
        #: after HELLO: the rank count the link speaks for (information)
        self.n_ranks: int | None = None
        self.patch: PatchMap | None = None
        self.first_request = True
        self.last_t: float | None = None
        self.said_bye = False
        self.error_sent = False
        self.last_reply: tuple[float, bytes] | None = None

    def send(self, msg_type, payload=b"", seq=0) -> float:
        """Send one frame; returns the seconds it took."""
        t0 = time.perf_counter()
        with self.send_lock:
            wire.send_frame(self.sock, msg_type, payload, seq)
        return time.perf_counter() - t0

    def send_error(self, code, message, seq=0) -> None:
        if self.error_sent:
            return
        self.error_sent = True
        try:
            self.send(MessageType.ERROR, wire.pack_error(code, message), seq)
        except OSError:
            pass


def _copy_state(ckpt: dict) -> dict:
    return {k: (v.copy() if isinstance(v, np.ndarray) else v) for k, v in ckpt.items()}


def _is_loopback(host: str) -> bool:
    try:
        infos = socket.getaddrinfo(host, None)
    except socket.gaierror:
        return False
    return bool(infos) and all(ipaddress.ip_address(i[4][0]).is_loopback for i in infos)


class StepServer:
    """Serve one case's whale motion to its OpenFOAM ranks.

    Parameters
    ----------
    case_dir : the OpenFOAM case folder; the socket, pid file and ``adapter/`` outputs go here.
    scene : the Scene (``load_scene``).
    tcp_port : also listen on TCP at ``host:tcp_port`` (None: UNIX socket only).
    host : TCP host; anything but loopback needs a ``token``.
    token : shared secret every HELLO must carry (None: no token asked).
    map_tolerance : largest patch-to-surface distance, fraction of L (HELLO fails beyond).
    first_client_timeout : seconds to wait for the first client before giving up (exit 1).
    animator : an already built Animator for this scene (tests); None builds one.
    keep_serving : serve link after link until :meth:`stop` (tests, a server shared by
        successive runs); False ends the run with the case's link.

    One link per case: while a client that said HELLO is connected, another HELLO gets ERROR 7
    (busy). Use :meth:`serve` (start, then run until the link is done) or :meth:`start` then
    :meth:`run`; both return the exit code: 0 after BYE or a vanished client, 1 on a model
    failure or when no client came.
    """

    def __init__(self, case_dir, scene, *, tcp_port: int | None = None, host: str = "127.0.0.1",
                 token: str | None = None, map_tolerance: float = DEFAULT_TOLERANCE,
                 first_client_timeout: float = 600.0, animator=None, keep_serving: bool = False):
        self.case_dir = Path(case_dir)
        self.scene = scene
        self.tcp_port = tcp_port
        self.host = host
        self.token = token or None
        self.map_tolerance = map_tolerance
        self.first_client_timeout = first_client_timeout
        self.animator = animator
        self.keep_serving = keep_serving
        self.socket_path = self.case_dir / SOCKET_NAME
        self.pid_path = self.case_dir / PID_NAME
        self.endpoint_path = self.case_dir / ENDPOINT_NAME
        self.out_dir = self.case_dir / OUTPUT_DIR
        self.exit_code: int | None = None
        self.summary = ""
        self.tcp_address: tuple[str, int] | None = None

        self._listeners: list[socket.socket] = []
        self._state_lock = threading.Lock()      # connections, cache, rows, stats
        self._anim_lock = threading.Lock()       # the animator and the work-ahead
        self._write_lock = threading.Lock()      # WRITE outputs
        self._conns: set[_Connection] = set()
        self._threads: list[threading.Thread] = []
        self._links = 0                           # connections that said HELLO
        self._n_ranks: int | None = None
        self._served: OrderedDict[float, _Served] = OrderedDict()
        self._last: _Served | None = None
        self._prev_t: float | None = None
        self._ahead: _Ahead | None = None
        self._ahead_thread: threading.Thread | None = None
        self._generation = 0
        self._rows: dict[float, _Row] = {}
        self._keypoints_file = None
        self._keypoints_ready = False
        self._pvd: dict[float, str] = {}
        self._written: set[float] = set()
        self._fatal: str | None = None
        self._fatal_at = 0.0
        self._vanished = False
        self._stop = threading.Event()
        self._log_handler: logging.Handler | None = None
        # statistics
        self._req_compute: list[float] = []
        self._req_transfer: list[float] = []
        self._advance_s: list[float] = []        # animator time per step, ahead or not
        self._steps = 0
        self._ahead_hits = 0
        self._ahead_tries = 0
        self._patch_points = 0
        self._max_distance = 0.0

    # --- start and stop -----------------------------------------------------------------------

    def start(self) -> None:
        """Check the socket, listen, write the pid file, build the animator."""
        if not self.case_dir.is_dir():
            raise ServerStartError(f"case folder {self.case_dir} does not exist; give --case DIR")
        if self.tcp_port is not None and not self.token and not _is_loopback(self.host):
            raise ServerStartError(
                f"--host {self.host} is not a loopback address: give --token (or set "
                f"WHALE_ADAPTER_TOKEN) so that only your OpenFOAM run can connect")
        self._check_not_running()
        self.out_dir.mkdir(exist_ok=True)
        self._log_handler = logging.FileHandler(self.out_dir / "server.log")
        self._log_handler.setFormatter(logging.Formatter("%(asctime)s %(message)s"))
        log.addHandler(self._log_handler)
        log.setLevel(logging.INFO)
        try:
            self._listen()
            _atomic_write_text(self.pid_path, f"{os.getpid()} {socket.gethostname()}\n")
            if self.animator is None:
                from adapter.motion.animator import (
                    Animator,  # the animator is heavy; import on demand
                )
                self.animator = Animator(self.scene)
            else:
                self.animator.reset()
            # warm up: load the compiled kernels and take one step now, not in the first
            # exchange that OpenFOAM times (then back to t = 0, bit for bit)
            self.animator.displacement(self.animator.dt)
            self.animator.reset()
            self._surface = self.animator.surface
            self._landmarks = [n for n in LANDMARKS if n in self._surface.landmarks]
            self._landmark_nodes = np.array([self._surface.landmarks[n] for n in self._landmarks],
                                            dtype=np.int64)
            self._fingerprint = self._make_fingerprint()
            self._load_pvd()
            self._write_endpoint()
        except BaseException:
            self._cleanup()
            raise
        where = str(self.socket_path) + (
            f" and tcp {self.tcp_address[0]}:{self.tcp_address[1]}" if self.tcp_address else "")
        log.info("serving %s on %s (pid %d, %d nodes, internal step %g s)", self.case_dir, where,
                 os.getpid(), len(self._surface.points), self.animator.dt)
        print(f"whale-adapter serve: listening on {where} (pid {os.getpid()})", flush=True)

    def _write_endpoint(self) -> None:
        """``<case>/.whale-adapter.endpoint``, atomically (temp file + rename): where a client
        connects. TCP when the server listens on TCP (a wildcard address is published as this
        host's name), else the UNIX socket. Never the token."""
        lines = ["# whale-adapter step-server endpoint (docs/step-server.md)"]
        if self.tcp_address is not None:
            host = self.host
            if host in ("", "0.0.0.0", "::"):
                host = socket.gethostname()
            lines += [f"host {host}", f"port {self.tcp_address[1]}"]
        else:
            lines += [f"unix {self.socket_path}"]
        lines += [f"server_host {socket.gethostname()}", f"pid {os.getpid()}"]
        _atomic_write_text(self.endpoint_path, "\n".join(lines) + "\n")

    def _read_pid(self) -> tuple[str, str | None] | None:
        """(pid, host) from the pid file; host None in an old one-field file; None if absent."""
        try:
            fields = self.pid_path.read_text().split()
        except OSError:
            return None
        if not fields:
            return None
        return fields[0], (fields[1] if len(fields) > 1 else None)

    def _check_not_running(self) -> None:
        """One server per case, across hosts: another host's server is never judged stale here
        (its socket cannot be probed from this host, its pid means nothing here)."""
        owner = self._read_pid()
        here = socket.gethostname()
        if owner is not None and owner[1] is not None and owner[1] != here:
            pid, host = owner
            raise ServerStartError(
                f"a step-server on host {host} (pid {pid}) holds {self.case_dir} (see "
                f"{self.pid_path}); only {host} can tell whether it still runs: stop it there, "
                f"or, if it is gone, remove {self.pid_path.name}, {self.socket_path.name} and "
                f"{self.endpoint_path.name} from the case")
        path = self.socket_path
        if not (path.exists() or path.is_symlink()):
            self.endpoint_path.unlink(missing_ok=True)
            return
        if not stat.S_ISSOCK(path.lstat().st_mode):
            raise ServerStartError(f"{path} exists and is not a socket; remove it")
        probe = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        probe.settimeout(2.0)
        try:
            _connect_unix(probe, path)
        except (ConnectionRefusedError, FileNotFoundError):
            log.info("removing stale socket %s", path)
            path.unlink(missing_ok=True)
            self.endpoint_path.unlink(missing_ok=True)
            return
        except OSError as exc:
            raise ServerStartError(f"cannot probe the socket {path}: {exc}") from None
        finally:
            probe.close()
        pid = owner[0] if owner is not None else "unknown"
        raise ServerStartError(
            f"another step-server (pid {pid}) is already serving {self.case_dir} on {path}; "
            f"wait for its run to end or stop it (kill {pid})")

    def _listen(self) -> None:
        unix = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        old = os.umask(0o177)
        try:
            _bind_unix(unix, self.socket_path)
        finally:
            os.umask(old)
        os.chmod(self.socket_path, 0o600)
        unix.listen(64)
        self._listeners.append(unix)
        if self.tcp_port is not None:
            try:    # a name or an address, IPv4 or IPv6
                family, _, _, _, addr = socket.getaddrinfo(
                    self.host or None, self.tcp_port, type=socket.SOCK_STREAM,
                    flags=socket.AI_PASSIVE)[0]
            except socket.gaierror as exc:
                raise ServerStartError(f"cannot resolve --host {self.host}: {exc}") from None
            tcp = socket.socket(family, socket.SOCK_STREAM)
            tcp.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            try:
                tcp.bind(addr)
            except OSError as exc:
                tcp.close()
                raise ServerStartError(
                    f"cannot listen on {self.host}:{self.tcp_port}: {exc}") from None
            tcp.listen(64)
            self.tcp_address = tcp.getsockname()[:2]
            self._listeners.append(tcp)

    def serve(self) -> int:
        """Start, then serve until the run ends; returns the exit code."""
        self.start()
        return self.run()

    def stop(self) -> None:
        """Ask :meth:`run` to return (from another thread)."""
        self._stop.set()

    def run(self) -> int:
        """Accept clients until the run ends; returns the exit code."""
        sel = selectors.DefaultSelector()
        for s in self._listeners:
            s.setblocking(False)
            sel.register(s, selectors.EVENT_READ)
        started = time.monotonic()
        code = 0
        try:
            while not self._stop.is_set():
                for key, _ in sel.select(timeout=0.05):
                    try:
                        sock, addr = key.fileobj.accept()
                    except OSError:
                        continue
                    self._accept(sock, addr)
                with self._state_lock:
                    active = sum(1 for c in self._conns if c.n_ranks is not None)
                    seen = self._links
                    fatal = self._fatal
                if fatal is not None:
                    if active == 0 or time.monotonic() - self._fatal_at > _FATAL_GRACE_S:
                        code = 1
                        break
                    continue
                if seen and active == 0 and not self.keep_serving:
                    break
                if not seen and time.monotonic() - started > self.first_client_timeout:
                    print(f"whale-adapter serve: no client connected within "
                          f"{self.first_client_timeout:g} s; is pimpleFoam running with the "
                          f"stepServerDisplacement boundary condition?", flush=True)
                    code = 1
                    break
        finally:
            sel.close()
            self._finish()
        self.exit_code = code
        return code

    def _finish(self) -> None:
        for s in self._listeners:
            s.close()
        self._listeners.clear()
        with self._state_lock:
            conns = list(self._conns)
        for c in conns:
            try:
                c.sock.shutdown(socket.SHUT_RDWR)
            except OSError:
                pass
        for t in list(self._threads):
            t.join(timeout=5)
        if self._ahead_thread is not None:
            self._ahead_thread.join(timeout=30)
        if self._vanished and self._last is not None and self._fatal is None:
            self._save_state(self._last)
            print(f"whale-adapter serve: a client vanished without BYE (pimpleFoam killed?); "
                  f"saved the state at t = {time_name(self._last.t)} s", flush=True)
        self._flush_rows(math.inf)
        self._write_stats()
        print(f"whale-adapter serve: {self.summary}", flush=True)
        log.info("%s", self.summary)
        self._cleanup()

    def _cleanup(self) -> None:
        for s in self._listeners:
            s.close()
        self._listeners.clear()
        owner = self._read_pid()
        if owner is not None and owner[0] == str(os.getpid()):
            for path in (self.endpoint_path, self.socket_path, self.pid_path):
                try:
                    path.unlink(missing_ok=True)
                except OSError:
                    pass
        if self._keypoints_file is not None:
            self._keypoints_file.close()
            self._keypoints_file = None
        if self._log_handler is not None:
            log.removeHandler(self._log_handler)
            self._log_handler.close()
            self._log_handler = None

    def _write_stats(self) -> None:
        n = len(self._req_compute)
        mean_c = float(np.mean(self._req_compute)) if n else 0.0
        mean_t = float(np.mean(self._req_transfer)) if n else 0.0
        stats = {
            "requests": n,
            "steps": self._steps,
            "ranks": self._n_ranks or 0,
            "links": self._links,
            "mean_compute_s": mean_c,
            "mean_transfer_s": mean_t,
            "median_compute_s": float(np.median(self._req_compute)) if n else 0.0,
            "median_transfer_s": float(np.median(self._req_transfer)) if n else 0.0,
            "mean_step_advance_s": float(np.mean(self._advance_s)) if self._advance_s else 0.0,
            "work_ahead_hits": self._ahead_hits,
            "work_ahead_tries": self._ahead_tries,
            "patch_points": int(self._patch_points),
            "max_mapping_distance_m": self._max_distance,
            "model_failure": self._fatal,
        }
        self.stats = stats
        self.summary = (
            f"{n} requests served ({self._steps} steps, {stats['ranks']} ranks, "
            f"{self._links} link{'s' if self._links != 1 else ''}), mean compute "
            f"{1e3 * mean_c:.3g} ms per request, transfer {1e3 * mean_t:.3g} ms, work-ahead hits "
            f"{self._ahead_hits}/{self._ahead_tries}")
        if self.out_dir.is_dir():
            (self.out_dir / "server-stats.json").write_text(json.dumps(stats, indent=2) + "\n")

    # --- connections --------------------------------------------------------------------------

    def _accept(self, sock: socket.socket, addr) -> None:
        sock.setblocking(True)
        if sock.family != socket.AF_UNIX:
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        peer = f"{addr[0]}:{addr[1]}" if isinstance(addr, tuple) else "unix"
        conn = _Connection(sock, peer)
        with self._state_lock:
            self._conns.add(conn)
        thread = threading.Thread(target=self._serve_connection, args=(conn,), daemon=True,
                                  name=f"step-server {peer}")
        self._threads = [t for t in self._threads if t.is_alive()] + [thread]
        thread.start()

    def _serve_connection(self, conn: _Connection) -> None:
        seq = 0
        try:
            while True:
                t_wait = time.perf_counter()
                frame = wire.read_frame(conn.sock)
                t_recv = time.perf_counter()
                seq = frame.seq
                if conn.error_sent:          # an ERROR 6 is waiting in the client's buffer
                    break
                if not self._handle(conn, frame, t_wait, t_recv):
                    break
        except wire.ConnectionClosed:
            if conn.n_ranks is not None and not conn.said_bye and not conn.error_sent:
                self._client_vanished(conn, "closed the connection without BYE")
        except WireError as exc:
            log.warning("client %s: %s", conn.peer, exc)
            self._drop(conn)            # before the ERROR: the client may reconnect at once
            conn.send_error(exc.code, str(exc), seq)
        except OSError as exc:
            if conn.n_ranks is not None and not conn.said_bye and not conn.error_sent:
                self._client_vanished(conn, f"connection lost ({exc})")
        except Exception as exc:      # never let one client bring the server down
            log.exception("client %s: internal error", conn.peer)
            self._drop(conn)
            conn.send_error(ErrorCode.BAD_FRAME, f"internal server error: {exc}", seq)
        finally:
            self._drop(conn)
            try:
                conn.sock.close()
            except OSError:
                pass

    def _drop(self, conn: _Connection) -> None:
        with self._state_lock:
            self._conns.discard(conn)

    def _client_vanished(self, conn: _Connection, why: str) -> None:
        log.warning("client %s %s", conn.peer, why)
        self._vanished = True

    def _handle(self, conn: _Connection, frame: wire.Frame, t_wait: float, t_recv: float) -> bool:
        """Answer one frame; False closes the connection."""
        kind = frame.type
        if conn.n_ranks is None and kind != MessageType.HELLO:
            raise WireError(ErrorCode.BAD_FRAME,
                            f"expected HELLO as the first message, got {kind.name}")
        if self._fatal is not None:
            conn.send_error(ErrorCode.MODEL_FAILURE, self._fatal, frame.seq)
            return False
        if kind == MessageType.HELLO:
            if conn.n_ranks is not None:
                raise WireError(ErrorCode.BAD_FRAME, "HELLO sent twice on one connection")
            return self._hello(conn, frame)
        if kind == MessageType.REQUEST:
            return self._request(conn, frame, t_recv)
        if kind == MessageType.WRITE:
            self._write(wire.unpack_write(frame.payload))
            conn.send(MessageType.ACK, b"", frame.seq)
            return True
        if kind == MessageType.BYE:
            conn.said_bye = True
            log.info("client %s said BYE", conn.peer)
            return False
        raise WireError(ErrorCode.BAD_FRAME, f"a client may not send {kind.name}")

    def _hello(self, conn: _Connection, frame: wire.Frame) -> bool:
        hello = wire.unpack_hello(frame.payload)
        if self.token is not None and not hmac.compare_digest(
                hello.token.encode("utf-8"), self.token.encode("utf-8")):
            what = "no token" if not hello.token else "a wrong token"
            raise WireError(ErrorCode.BAD_TOKEN,
                            f"the client sent {what}; set WHALE_ADAPTER_TOKEN for OpenFOAM's "
                            f"master rank to the token the server was started with")
        with self._state_lock:
            self._check_free(conn)
        t0 = time.perf_counter()
        try:
            patch = PatchMap(hello.points, self._surface.points, self._surface.triangles,
                             self._surface.length, self.map_tolerance,
                             cache=self.out_dir / MAP_CACHE_NAME)
        except GeometryError as exc:
            raise WireError(ErrorCode.BAD_HELLO, f"bad HELLO: {exc}") from None
        with self._state_lock:
            self._check_free(conn)
            self._n_ranks = hello.n_ranks
            conn.n_ranks = hello.n_ranks
            self._links += 1
            self._patch_points = patch.n_points
            self._max_distance = max(self._max_distance, patch.max_distance)
            conn.patch = patch
        log.info("link %s for %d rank(s): %d patch points, max mapping distance %.3g m "
                 "(map %s in %.2f s)", conn.peer, hello.n_ranks, patch.n_points,
                 patch.max_distance, patch.cache_status or "computed",
                 time.perf_counter() - t0)
        welcome = wire.pack_welcome(patch.n_points, patch.max_distance, self.animator.dt)
        conn.send(MessageType.WELCOME, welcome, frame.seq)
        return True

    def _check_free(self, conn: _Connection) -> None:
        """One link per case: ERROR 7 while another client that said HELLO is connected."""
        other = next((c for c in self._conns if c is not conn and c.n_ranks is not None), None)
        if other is not None:
            raise WireError(ErrorCode.BUSY,
                            f"server busy: {self.case_dir} is already served to a client "
                            f"({other.peer}, {other.n_ranks} rank(s)); one link per case: is "
                            f"another run using this case?")

    def _check_time(self, t: float, what: str) -> None:
        """A time the animator can reach: finite, not negative, and not absurdly far ahead
        (a jump of more than MAX_JUMP_CYCLES stroke cycles would keep the animator busy for
        hours with the lock held: refused instead of hanging)."""
        if not math.isfinite(t) or t < 0:
            raise WireError(ErrorCode.BAD_FRAME,
                            f"bad {what}: time {t} s is not a finite time >= 0")
        jump = MAX_JUMP_CYCLES * self.animator.period
        if t > self.animator.time + jump and t > self._newest_state_time() + jump:
            raise WireError(
                ErrorCode.BAD_FRAME,
                f"bad {what}: time {t:g} s is more than {MAX_JUMP_CYCLES} stroke cycles ahead of "
                f"the whale (at {self.animator.time:g} s); check the case's time settings")

    def _newest_state_time(self) -> float:
        """The latest time with a saved state file (a restart may start there); 0 if none."""
        times = []
        for path in self.out_dir.glob("state_*.npz"):
            try:
                times.append(float(path.stem[len("state_"):]))
            except ValueError:
                continue
        return max(times, default=0.0)

    def _request(self, conn: _Connection, frame: wire.Frame, t_recv: float) -> bool:
        t_start = time.perf_counter()
        req = wire.unpack_request(frame.payload)
        t = req.time
        self._check_time(t, "REQUEST")
        if conn.last_reply is not None and conn.last_reply[0] == t:
            payload = conn.last_reply[1]
        else:
            try:
                served = self._motion(conn, t)
            except UnstableError as exc:
                self._model_failed(str(exc), conn, frame.seq)
                return False
            payload = wire.pack_displacement(t, conn.patch.apply(served.disp))
            conn.last_reply = (t, payload)
        forces = np.concatenate([req.pressure_force, req.viscous_force])
        conn.first_request = False
        conn.last_t = t if conn.last_t is None else max(conn.last_t, t)
        self._add_forces(t, forces)
        t_ready = time.perf_counter()
        send_s = conn.send(MessageType.DISPLACEMENT, payload, frame.seq)
        with self._state_lock:
            self._req_compute.append(t_ready - t_start)
            self._req_transfer.append((t_start - t_recv) + send_s)
        log.debug("%s t=%s compute %.3g ms send %.3g ms", conn.peer, time_name(t),
                  1e3 * (t_ready - t_start), 1e3 * send_s)
        return True

    def _model_failed(self, message: str, conn: _Connection, seq: int) -> None:
        with self._state_lock:
            if self._fatal is None:
                self._fatal = message
                self._fatal_at = time.monotonic()
                log.error("model failure: %s", message)
                print(f"whale-adapter serve: model failure: {message}", flush=True)
            others = [c for c in self._conns if c is not conn and c.n_ranks is not None]
        conn.send_error(ErrorCode.MODEL_FAILURE, self._fatal, seq)
        for c in others:
            c.send_error(ErrorCode.MODEL_FAILURE, self._fatal)

    # --- the motion ---------------------------------------------------------------------------

    def _motion(self, conn: _Connection, t: float) -> _Served:
        """The motion at t, computed once (a repeat gets the cached state)."""
        with self._state_lock:
            served = self._served.get(t)
        if served is not None:
            return served
        if conn.last_t is not None and t < conn.last_t:
            raise WireError(ErrorCode.TIME_BACKWARDS,
                            f"time went backwards: the client asked for t = {t!r} s after "
                            f"t = {conn.last_t!r} s")
        with self._anim_lock:
            if self._fatal is not None:
                raise UnstableError(self._fatal)
            with self._state_lock:
                served = self._served.get(t)
            if served is not None:
                return served
            last = self._last
            if last is not None and t < last.t and not conn.first_request:
                raise WireError(ErrorCode.TIME_BACKWARDS,
                                f"time went backwards: t = {t!r} s is earlier than t = {last.t!r} "
                                f"s already served (only a restarted client may go back)")
            return self._compute(t)

    def _compute(self, t: float) -> _Served:
        """Advance (or rewind) the animator to t; caller holds the animator lock."""
        t0 = time.perf_counter()
        a = self.animator
        self._generation += 1
        ahead, self._ahead = self._ahead, None
        last = self._last
        hit = None
        if ahead is not None:
            self._ahead_tries += 1
            tol = 1e-9 * max(abs(ahead.target), 1.0)
            hit = t >= ahead.target - tol and t >= a.time - a.dt
            if not hit:
                a.restore(_copy_state(ahead.pre))
        restart = last is None or t < last.t
        if t < a.time - a.dt:
            self._seek_back(t)
        elif last is None:
            self._jump_from_state(t)
        if hit and t == ahead.target:
            disp, vel = ahead.disp, ahead.vel
        else:
            try:
                disp = np.array(a.displacement(t), dtype=np.float64)
            except ValueError:          # behind the animator after all: go back and retry
                self._seek_back(t)
                disp = np.array(a.displacement(t), dtype=np.float64)
            vel = np.array(a.velocity(t), dtype=np.float64)
        if not np.isfinite(disp).all():
            raise UnstableError(f"the whale's displacement at t = {t} s is not finite; "
                                f"lower [integrator] dt_s")
        served = _Served(t, disp, vel, _copy_state(a.checkpoint()), float(a.time))
        compute_s = time.perf_counter() - t0
        if hit:
            self._ahead_hits += 1
        self._advance_s.append(ahead.compute_s + compute_s if hit else compute_s)
        with self._state_lock:
            self._served[t] = served
            while len(self._served) > _CACHE_SIZE:
                self._served.popitem(last=False)
            if restart:
                for old in [k for k in self._served if k > t]:
                    del self._served[old]
            self._steps += 1
        if restart:
            self._restart_outputs(t)
        self._flush_rows(t)
        self._rows[t] = _Row((self._surface.points[self._landmark_nodes]
                              + disp[self._landmark_nodes]).ravel(), None)
        prev = last.t if last is not None and not restart else None
        self._last = served
        note = {None: "no work-ahead", True: "work-ahead hit", False: "work-ahead miss"}[hit]
        extra = f" (ahead {1e3 * ahead.compute_s:.3g} ms)" if ahead is not None else ""
        log.info("t=%s compute %.3g ms, %s%s%s", time_name(t), 1e3 * compute_s, note, extra,
                 ", restart" if restart and last is not None else "")
        if prev is not None and t > prev:
            self._start_work_ahead(t + (t - prev))
        return served

    def _start_work_ahead(self, target: float) -> None:
        gen = self._generation
        thread = threading.Thread(target=self._work_ahead, args=(gen, target), daemon=True,
                                  name="step-server work-ahead")
        self._ahead_thread = thread
        thread.start()

    def _work_ahead(self, gen: int, target: float) -> None:
        with self._anim_lock:
            if gen != self._generation or self._fatal is not None or self._last is None:
                return
            a = self.animator
            pre = self._last.ckpt
            t0 = time.perf_counter()
            try:
                disp = np.array(a.displacement(target), dtype=np.float64)
                vel = np.array(a.velocity(target), dtype=np.float64)
            except Exception as exc:    # undone; the real request will meet it again
                a.restore(_copy_state(pre))
                log.info("work-ahead to t=%s failed (%s); undone", time_name(target), exc)
                return
            self._ahead = _Ahead(target, pre, disp, vel, time.perf_counter() - t0)

    def _seek_back(self, t: float) -> None:
        """Restore the animator to a state that can reach t: a saved state, else t = 0."""
        a = self.animator
        if not self._restore_from_state(t, newer_than=-math.inf):
            log.info("replaying from t = 0 to t = %s (no saved state fits)", time_name(t))
            a.reset()

    def _jump_from_state(self, t: float) -> None:
        """On a fresh server, start from the newest saved state that can reach t."""
        self._restore_from_state(t, newer_than=float(self.animator.time))

    def _restore_from_state(self, t: float, newer_than: float) -> bool:
        """Restore the newest usable saved state at or before ``t``; False if there is none.

        A state file that cannot be read (cut short, empty, another scene's) is passed over
        with a warning: the caller then falls back on the next one, or on replay from t = 0.
        """
        candidates = []
        for path in self.out_dir.glob("state_*.npz"):
            try:
                with np.load(path, allow_pickle=False) as z:
                    if (int(z["format"]) != _STATE_FORMAT
                            or str(z["fingerprint"]) != self._fingerprint):
                        continue
                    at, dt = float(z["animator_time"]), float(z["dt"])
            except _UNREADABLE as exc:
                log.warning("ignoring unreadable state file %s: %s", path, exc)
                continue
            if at - dt <= t and at > newer_than:
                candidates.append((at, path))
        for at, path in sorted(candidates, reverse=True):
            try:
                with np.load(path, allow_pickle=False) as z:
                    ckpt = {k[5:]: (z[k].item() if z[k].ndim == 0 else np.array(z[k]))
                            for k in z.files if k.startswith("ckpt:")}
                self.animator.restore(ckpt)
            except _UNREADABLE as exc:
                log.warning("ignoring unreadable state file %s: %s", path, exc)
                continue
            log.info("restored the animator from %s (t = %s s) to reach t = %s s", path.name,
                     time_name(at), time_name(t))
            return True
        return False

    def _make_fingerprint(self) -> str:
        scene = dataclasses.asdict(self.scene)
        scene.pop("base_dir", None)
        scene.pop("name", None)
        h = hashlib.sha256(json.dumps(scene, sort_keys=True, default=str).encode())
        h.update(np.ascontiguousarray(self._surface.points, dtype=np.float64).tobytes())
        h.update(np.ascontiguousarray(self._surface.triangles, dtype=np.int64).tobytes())
        h.update(repr(float(self.animator.dt)).encode())
        return h.hexdigest()

    # --- outputs ------------------------------------------------------------------------------

    def _add_forces(self, t: float, forces: np.ndarray) -> None:
        with self._state_lock:
            row = self._rows.get(t)
            if row is None:
                return
            row.forces = forces
        self._flush_rows(t, inclusive=True)

    def _flush_rows(self, t: float, inclusive: bool = False) -> None:
        """Write the keypoint rows of times before t (or up to t), in time order."""
        with self._state_lock:
            times = sorted(k for k in self._rows if k < t or (inclusive and k == t))
            rows = [(k, self._rows.pop(k)) for k in times]
            if not rows:
                return
            f = self._keypoints()
            for k, row in rows:
                fields = [repr(float(v)) for v in (k, *row.landmarks)]
                forces = row.forces
                if forces is not None and np.all(np.isfinite(forces)):
                    fields += [repr(float(v)) for v in forces]
                else:
                    # unknown (the first REQUEST after a restart carries no forces yet, or a
                    # link did not report): empty fields, never NaN
                    fields += [""] * len(FORCE_COLUMNS)
                f.write(",".join(fields) + "\n")
            f.flush()

    def _keypoints_header(self) -> str:
        cols = ["t"] + [f"{n}_{x}" for n in self._landmarks for x in "xyz"] + list(FORCE_COLUMNS)
        return ",".join(cols) + "\n"

    def _keypoints(self):
        if self._keypoints_file is None:
            self._keypoints_file = open(self.out_dir / "keypoints.csv", "a")  # noqa: SIM115
        return self._keypoints_file

    def _restart_outputs(self, t: float) -> None:
        """A (re)start at t: drop keypoint rows and ParaView entries from t on."""
        with self._state_lock:
            for k in [k for k in self._rows if k >= t]:
                del self._rows[k]
            if self._keypoints_file is not None:
                self._keypoints_file.close()
                self._keypoints_file = None
            path = self.out_dir / "keypoints.csv"
            header = self._keypoints_header()
            keep = [header]
            if path.exists():
                lines = path.read_text().splitlines(keepends=True)
                if lines and lines[0] == header:
                    for line in lines[1:]:
                        try:
                            if float(line.split(",", 1)[0]) < t and line.endswith("\n"):
                                keep.append(line)
                        except ValueError:
                            continue
            _atomic_write_text(path, "".join(keep))
        with self._write_lock:
            self._pvd = {k: v for k, v in self._pvd.items() if k < t}
            self._written = {k for k in self._written if k < t}
            self._write_pvd()

    def _write(self, t: float) -> None:
        """WRITE(t): surface, ParaView collection and restart state, once per time."""
        self._check_time(t, "WRITE")
        with self._write_lock:
            if t in self._written:
                return
        with self._state_lock:
            served = self._served.get(t)
        if served is None:       # lock order: animator before outputs
            served = self._side_motion(t)
        with self._write_lock:
            if t in self._written:
                return
            self._write_surface(served)
            self._save_state(served)
            self._pvd[t] = f"whale_{time_name(t)}.vtp"
            self._write_pvd()
            self._written.add(t)
        log.info("wrote the whale and its state at t=%s", time_name(t))

    def _side_motion(self, t: float) -> _Served:
        """The motion at a time never served, leaving the served line of states untouched."""
        with self._anim_lock:
            a = self.animator
            self._generation += 1
            if self._ahead is not None:
                a.restore(_copy_state(self._ahead.pre))
                self._ahead = None
            here = _copy_state(a.checkpoint())
            try:
                if t < a.time - a.dt:
                    self._seek_back(t)
                disp = np.array(a.displacement(t), dtype=np.float64)
                vel = np.array(a.velocity(t), dtype=np.float64)
                served = _Served(t, disp, vel, _copy_state(a.checkpoint()), float(a.time))
            finally:
                a.restore(here)
        return served

    def _write_surface(self, served: _Served) -> None:
        import pyvista as pv

        tris = np.asarray(self._surface.triangles, dtype=np.int64)
        faces = np.column_stack([np.full(len(tris), 3, dtype=np.int64), tris]).ravel()
        mesh = pv.PolyData(np.asarray(self._surface.points) + served.disp, faces)
        mesh.point_data["displacement"] = served.disp
        mesh.point_data["velocity"] = served.vel
        mesh.field_data["time"] = np.array([served.t])
        path = self.out_dir / f"whale_{time_name(served.t)}.vtp"
        tmp = path.with_name(path.stem + ".tmp.vtp")
        mesh.save(tmp, binary=True)
        os.replace(tmp, path)

    def _save_state(self, served: _Served) -> None:
        arrays = {f"ckpt:{k}": np.asarray(v) for k, v in served.ckpt.items()}
        arrays.update(format=np.array(_STATE_FORMAT), time=np.array(served.t),
                      animator_time=np.array(served.animator_time),
                      dt=np.array(float(self.animator.dt)),
                      fingerprint=np.array(self._fingerprint))
        path = self.out_dir / f"state_{time_name(served.t)}.npz"
        tmp = path.with_name(path.name + ".tmp")
        with open(tmp, "wb") as f:
            np.savez(f, **arrays)
        os.replace(tmp, path)

    def _load_pvd(self) -> None:
        path = self.out_dir / "whale.pvd"
        if not path.exists():
            return
        try:
            root = ET.parse(path).getroot()
            for ds in root.iter("DataSet"):
                self._pvd[float(ds.get("timestep"))] = ds.get("file")
        except (ET.ParseError, TypeError, ValueError) as exc:
            log.warning("ignoring unreadable %s: %s", path, exc)

    def _write_pvd(self) -> None:
        root = ET.Element("VTKFile", type="Collection", version="0.1", byte_order="LittleEndian")
        coll = ET.SubElement(root, "Collection")
        for t in sorted(self._pvd):
            ET.SubElement(coll, "DataSet", timestep=repr(float(t)), group="", part="0",
                          file=self._pvd[t])
        ET.indent(root)
        _atomic_write_text(self.out_dir / "whale.pvd",
                           ET.tostring(root, encoding="unicode", xml_declaration=True) + "\n")


def read_token_file(path) -> str:
    """The token in ``path`` (one line): a regular file that only its owner may read."""
    path = Path(path)
    try:
        st = path.stat()
    except OSError as exc:
        raise ServerStartError(f"cannot read the token file {path}: {exc.strerror}") from None
    if not stat.S_ISREG(st.st_mode):
        raise ServerStartError(f"the token file {path} is not a regular file")
    if st.st_mode & 0o077:
        raise ServerStartError(f"the token file {path} has mode {stat.S_IMODE(st.st_mode):04o}: "
                               f"others may read it; chmod 600 {path}")
    token = path.read_text().strip()
    if not token:
        raise ServerStartError(f"the token file {path} is empty")
    return token


def resolve_token(token_file=None, token: str | None = None) -> str | None:
    """The token: from a 0600 file, else as given, else ``$WHALE_ADAPTER_TOKEN``, else None."""
    if token_file is not None:
        return read_token_file(token_file)
    return token or os.environ.get(TOKEN_ENV) or None


def _atomic_write_text(path: Path, text: str) -> None:
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(text)
    os.replace(tmp, path)


def _unix_address(path: Path) -> tuple[str, int | None]:
    """A bindable address for path; long paths go through /proc/self/fd (Linux)."""
    s = str(path)
    if len(s.encode()) < 104:
        return s, None
    fd = os.open(path.parent, os.O_RDONLY | os.O_DIRECTORY)
    return f"/proc/self/fd/{fd}/{path.name}", fd


def _bind_unix(sock: socket.socket, path: Path) -> None:
    addr, fd = _unix_address(path)
    try:
        sock.bind(addr)
    finally:
        if fd is not None:
            os.close(fd)


def _connect_unix(sock: socket.socket, path: Path) -> None:
    addr, fd = _unix_address(path)
    try:
        sock.connect(addr)
    finally:
        if fd is not None:
            os.close(fd)


# --- command line -----------------------------------------------------------------------------


def register(subparsers) -> None:
    """Add ``whale-adapter serve``."""
    p = subparsers.add_parser(
        "serve",
        help="serve the whale's displacement to a running OpenFOAM case",
        description="Serve the animated whale's displacement to the stepServerDisplacement "
                    "boundary condition of an OpenFOAM case (docs/step-server.md). Exits when "
                    "the run ends.",
    )
    p.add_argument("--case", required=True, type=Path, help="the OpenFOAM case folder")
    p.add_argument("--scene", type=Path, help="scene TOML file (default: built-in scene)")
    p.add_argument("--preset", choices=PRESETS, help="built-in preset")
    p.add_argument("--tcp", type=int, metavar="PORT", help="also listen on TCP at this port")
    p.add_argument("--host", default="127.0.0.1", help="TCP host (default 127.0.0.1)")
    p.add_argument("--token", default=None,
                   help="shared secret clients must send (visible in ps: prefer "
                        "$WHALE_ADAPTER_TOKEN or --token-file)")
    p.add_argument("--token-file", type=Path, metavar="FILE",
                   help="read the token from FILE (mode 0600, owner only)")
    p.add_argument("--keep-serving", action="store_true",
                   help="serve run after run (one link at a time) until killed")
    p.add_argument("--map-tolerance", type=float, default=DEFAULT_TOLERANCE, metavar="FRACTION",
                   help="largest patch-to-whale distance, fraction of L (default %(default)s)")
    p.add_argument("--wait", type=float, default=600.0, metavar="S",
                   help="seconds to wait for the first client (default %(default)s)")
    p.set_defaults(func=_cmd_serve)


def _cmd_serve(args: argparse.Namespace) -> int:
    from adapter.scene import load_scene

    scene = load_scene(args.scene, args.preset)
    token = resolve_token(args.token_file, args.token)
    server = StepServer(args.case, scene, tcp_port=args.tcp, host=args.host, token=token,
                        map_tolerance=args.map_tolerance, first_client_timeout=args.wait,
                        keep_serving=args.keep_serving)
    return server.serve()
