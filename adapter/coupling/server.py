"""The step-server: serves the whale's displacement to OpenFOAM, one flow time step at a time.

``whale-adapter serve --case DIR`` listens on ``DIR/.whale-adapter.sock`` (and optionally on TCP)
and speaks the protocol of docs/protocol.md with ONE client per case, however many MPI ranks
OpenFOAM runs: the master rank gathers every rank's patch points and sends them in one HELLO,
and scatters the displacements itself. The patch points are mapped onto the whale surface once
(:class:`~adapter.coupling.mapping.PatchMap`); the animator is advanced once per flow time,
and, while OpenFOAM solves the flow, already towards the next expected time (work-ahead, undone
from a checkpoint when the guess was wrong). Writes under ``DIR/adapter/``: ``whale_<t>.vtp`` +
``whale.pvd`` and ``state_<t>.npz`` at every WRITE, a row of ``keypoints.csv`` per served time,
``server.log`` and ``server-stats.json``. See docs/step-server.md.

:class:`StepServer` composes the parts, each in its own module:

- :mod:`.listener`: the listening sockets, the pid file (one server per case), the endpoint file;
- :mod:`.session`: one connection, its HELLO / REQUEST / WRITE / BYE;
- :mod:`.timeline`: the animator advanced to the times asked for, with work-ahead;
- :mod:`.frame`: the whale's frame (inflow and body force) at each served time;
- :mod:`.store`: the restart state files;
- :mod:`.recorder`: the surfaces, keypoints.csv and the statistics.
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import selectors
import socket
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import cast

from adapter.coupling.frame import Frame, FrameLine, fixed_frame_for
from adapter.coupling.listener import (
    PID_NAME,
    Listener,
    is_loopback,
    read_token_file,
    resolve_token,
)
from adapter.coupling.mapping import DEFAULT_TOLERANCE
from adapter.coupling.protocol import (
    ENDPOINT_NAME,
    SOCKET_NAME,
    TOKEN_ENV,
    ErrorCode,
)
from adapter.coupling.recorder import FORCE_COLUMNS, Recorder, ServerStats
from adapter.coupling.session import Links, Session
from adapter.coupling.store import StateStore, fingerprint, time_name
from adapter.coupling.timeline import MAX_JUMP_CYCLES, Timeline
from adapter.errors import ServerStartError
from adapter.jsonfiles import CASE_RECORD
from adapter.options import in_file, in_folder, port, positive
from adapter.scene import PRESETS

__all__ = ["ENDPOINT_NAME", "FORCE_COLUMNS", "MAP_CACHE_NAME", "MAX_JUMP_CYCLES", "OUTPUT_DIR",
           "PID_NAME", "SOCKET_NAME", "TOKEN_ENV", "ServerStartError", "StepServer",
           "read_token_file", "register", "resolve_token", "time_name"]

log = logging.getLogger(__name__)
#: the coupling's logger: server.log gets what every part of the server says
_ROOM_LOG = logging.getLogger("adapter.coupling")

#: the patch's map onto the whale, kept in OUTPUT_DIR between runs (reused while the patch holds)
MAP_CACHE_NAME = "patch-map.npz"
OUTPUT_DIR = "adapter"
#: seconds the clients get to read an ERROR 6 before the server exits anyway
_FATAL_GRACE_S = 10.0


@dataclass(frozen=True)
class _Parts:
    """What :meth:`StepServer.start` builds for a run: the animator's timeline, the outputs'
    recorder and the restart state's store."""

    timeline: Timeline
    recorder: Recorder
    store: StateStore


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
    frame : the whale's frame (:class:`~adapter.coupling.frame.Frame`), answered at every new
        served time and saved with the restart state; None: the scene's tethered inflow
        (:func:`~adapter.coupling.frame.fixed_frame_for`).

    One link per case: while a client that said HELLO is connected, another HELLO gets ERROR 7
    (busy). Use :meth:`serve` (start, then run until the link is done) or :meth:`start` then
    :meth:`run`; both return the exit code: 0 after BYE or a vanished client, 1 on a model
    failure or when no client came.
    """

    def __init__(self, case_dir, scene, *, tcp_port: int | None = None, host: str = "127.0.0.1",
                 token: str | None = None, map_tolerance: float = DEFAULT_TOLERANCE,
                 first_client_timeout: float = 600.0, animator=None, keep_serving: bool = False,
                 frame: Frame | None = None):
        self.case_dir = Path(case_dir)
        self.scene = scene
        self.token = token or None
        self.map_tolerance = map_tolerance
        self.first_client_timeout = first_client_timeout
        self.animator = animator
        self.keep_serving = keep_serving
        self.frame: Frame = frame if frame is not None else fixed_frame_for(scene)
        self.listener = Listener(self.case_dir, tcp_port, host)
        self.out_dir = self.case_dir / OUTPUT_DIR
        #: the patch's map onto the whale, reused while the patch holds
        self.map_cache = self.out_dir / MAP_CACHE_NAME
        self.exit_code: int | None = None
        self.summary = ""
        self.stats: dict = {}
        self.stats_counter = ServerStats()
        self._parts: _Parts | None = None
        self.links = Links(self.case_dir, self.stats_counter)
        self._fatal_at = 0.0
        self._vanished = False
        self._stop = threading.Event()
        self._log_handler: logging.Handler | None = None

    @property
    def timeline(self) -> Timeline:
        """The animator advanced to the times asked for (once started)."""
        return self._started().timeline

    @property
    def recorder(self) -> Recorder:
        """The run's outputs: surfaces, key points, statistics (once started)."""
        return self._started().recorder

    @property
    def store(self) -> StateStore:
        """The restart state files (once started)."""
        return self._started().store

    def _started(self) -> _Parts:
        if self._parts is None:
            raise RuntimeError("the step-server is not started: call start() first")
        return self._parts

    @property
    def tcp_address(self) -> tuple[str, int] | None:
        """(host, port) of the TCP socket, once listening on TCP; else None."""
        return self.listener.tcp_address

    # --- start and stop -----------------------------------------------------------------------

    def start(self) -> None:
        """Check the socket, listen, write the pid file, build the animator."""
        listener = self.listener
        if not self.case_dir.is_dir():
            raise ServerStartError(f"case folder {self.case_dir} does not exist; give --case DIR")
        if listener.tcp_port is not None and not self.token and not is_loopback(listener.host):
            raise ServerStartError(
                f"--host {listener.host} is not a loopback address: give --token (or set "
                f"{TOKEN_ENV}) so that only your OpenFOAM run can connect")
        listener.check_not_running()
        self.out_dir.mkdir(exist_ok=True)
        self._log_handler = logging.FileHandler(self.out_dir / "server.log")
        self._log_handler.setFormatter(logging.Formatter("%(asctime)s %(message)s"))
        _ROOM_LOG.addHandler(self._log_handler)
        _ROOM_LOG.setLevel(logging.INFO)
        try:
            listener.listen()
            listener.write_pid()
            self._build_parts()
            listener.write_endpoint()
        except BaseException:
            self.close()
            raise
        a = self.animator
        log.info("serving %s on %s (pid %d, %d nodes, internal step %g s)", self.case_dir,
                 listener.where(), os.getpid(), len(a.surface.points), a.dt)
        print(f"whale-adapter serve: listening on {listener.where()} (pid {os.getpid()})",
              flush=True)

    def _build_parts(self) -> None:
        """The animator (warmed up), its state store, the recorder and the timeline (with the
        frame)."""
        if self.animator is None:
            from adapter.motion.animator import animator_for  # heavy: imported on demand

            self.animator = animator_for(self.scene)
        else:
            self.animator.reset()
        a = self.animator
        # warm up: load the compiled kernels and take one step now, not in the first
        # exchange that OpenFOAM times (then back to t = 0, bit for bit)
        a.displacement(a.dt)
        a.reset()
        store = StateStore(self.out_dir, fingerprint(self.scene, a.surface, a.dt), a.dt)
        recorder = Recorder(self.out_dir, a.surface)
        timeline = Timeline(a, store, on_served=recorder.served,
                            frames=FrameLine(self.frame, store))
        self._parts = _Parts(timeline, recorder, store)

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
        for s in self.listener.sockets:
            s.setblocking(False)
            sel.register(s, selectors.EVENT_READ)
        started = time.monotonic()
        code = 0
        try:
            while not self._stop.is_set():
                for key, _ in sel.select(timeout=0.05):
                    try:
                        sock, addr = cast(socket.socket, key.fileobj).accept()
                    except OSError:
                        continue
                    self._accept(sock, addr)
                active = len(self.links.linked())
                seen = self.stats_counter.links
                if self.timeline.failure is not None:
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
            self.finish()
        self.exit_code = code
        return code

    def finish(self) -> None:
        """End the run: close the sockets, save the state if the client vanished, write the
        statistics, remove the socket, pid and endpoint files."""
        self.listener.close()
        self.links.close()
        timeline = self.timeline
        timeline.join(timeout=30)
        last = timeline.last
        if self._vanished and last is not None and timeline.failure is None:
            self.store.save(last)
            print(f"whale-adapter serve: a client vanished without BYE (pimpleFoam killed?); "
                  f"saved the state at t = {time_name(last.t)} s", flush=True)
        self.recorder.flush_rows()
        self.stats, self.summary = self.stats_counter.report(timeline.stats, timeline.failure)
        self.stats_counter.write(self.out_dir, self.stats)
        print(f"whale-adapter serve: {self.summary}", flush=True)
        log.info("%s", self.summary)
        self.close()

    def close(self) -> None:
        """Stop listening and remove this server's files, without the end-of-run outputs (a
        server started but never run; :meth:`finish` ends with it)."""
        self.listener.remove_files()
        if self._parts is not None:
            self._parts.recorder.close()
        if self._log_handler is not None:
            _ROOM_LOG.removeHandler(self._log_handler)
            self._log_handler.close()
            self._log_handler = None

    # --- sessions -----------------------------------------------------------------------------

    def _accept(self, sock: socket.socket, addr) -> None:
        sock.setblocking(True)
        if sock.family != socket.AF_UNIX:
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        peer = f"{addr[0]}:{addr[1]}" if isinstance(addr, tuple) else "unix"
        self.links.start(Session(sock, peer, self))

    def client_vanished(self, session: Session, why: str) -> None:
        """A linked client went away without BYE: the state is saved at the end."""
        log.warning("client %s %s", session.peer, why)
        self._vanished = True

    def model_failed(self, message: str, session: Session, seq: int) -> None:
        """The whale blew up: every linked client gets ERROR 6, and the run ends."""
        if self.timeline.fail(message):
            self._fatal_at = time.monotonic()
            log.error("model failure: %s", message)
            print(f"whale-adapter serve: model failure: {message}", flush=True)
        others = self.links.linked(but=session)
        failure = self.timeline.failure
        session.send_error(ErrorCode.MODEL_FAILURE, failure, seq)
        for s in others:
            s.send_error(ErrorCode.MODEL_FAILURE, failure)

    def write(self, t: float) -> None:
        """WRITE(t): surface, ParaView collection and restart state, once per time."""
        self.timeline.check_time(t, "WRITE")
        if self.recorder.written(t):
            return
        served = self.timeline.served(t)
        if served is None:       # lock order: animator before outputs
            served = self.timeline.side_motion(t)
        if self.recorder.write(served, also=self.store.save):
            log.info("wrote the whale and its state at t=%s", time_name(t))


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
    p.add_argument("--case", required=True, type=in_folder, help="the OpenFOAM case folder")
    p.add_argument("--scene", type=in_file, help="scene TOML file (default: built-in scene)")
    p.add_argument("--preset", choices=PRESETS, help="built-in preset")
    p.add_argument("--tcp", "--port", dest="tcp", type=port, metavar="PORT",
                   help="also listen on TCP at this port (--port: the same, as in run-case)")
    p.add_argument("--host", default="127.0.0.1", help="TCP host (default 127.0.0.1)")
    p.add_argument("--token", default=None,
                   help="shared secret clients must send (visible in ps: prefer "
                        "$WHALE_ADAPTER_TOKEN or --token-file)")
    p.add_argument("--token-file", type=in_file, metavar="FILE",
                   help="read the token from FILE (mode 0600, owner only)")
    p.add_argument("--keep-serving", action="store_true",
                   help="serve run after run (one link at a time) until killed")
    p.add_argument("--map-tolerance", type=positive, default=DEFAULT_TOLERANCE, metavar="FRACTION",
                   help="largest patch-to-whale distance, fraction of L (default %(default)s)")
    p.add_argument("--wait", type=positive, default=600.0, metavar="S",
                   help="seconds to wait for the first client (default %(default)s)")
    p.set_defaults(func=_cmd_serve)


def _cmd_serve(args: argparse.Namespace) -> int:
    from adapter.scene import load_scene

    scene = load_scene(args.scene, args.preset)
    token = resolve_token(args.token_file, args.token)
    server = StepServer(args.case, scene, tcp_port=args.tcp, host=args.host, token=token,
                        map_tolerance=args.map_tolerance, first_client_timeout=args.wait,
                        keep_serving=args.keep_serving, frame=case_frame(Path(args.case)))
    return server.serve()


def case_frame(case: Path):
    """The frame a case's record asks for: the free whale's (adapter/coupling/surge.py) when
    it is released, else None (the scene's fixed inflow)."""
    from adapter.coupling.surge import FRAME_LOG, frame_of

    path = case / CASE_RECORD
    if not path.is_file():
        return None
    return frame_of(json.loads(path.read_text()), log_path=case / OUTPUT_DIR / FRAME_LOG)
