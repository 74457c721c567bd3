"""Where the step-server listens: the case's UNIX socket (and TCP when asked), the pid file that
keeps one server per case, the endpoint file that tells the boundary condition where to connect,
and the token that lets only the case's own run in.
"""

from __future__ import annotations

import ipaddress
import logging
import os
import socket
import stat
from pathlib import Path

from adapter.coupling.protocol import ENDPOINT_NAME, SOCKET_NAME, TOKEN_ENV
from adapter.coupling.store import atomic_write_text
from adapter.errors import ServerStartError

log = logging.getLogger(__name__)

#: the server's pid and host name, in the case folder
PID_NAME = ".whale-adapter.pid"


class Listener:
    """The listening sockets and the files that announce them, in one case folder.

    Parameters
    ----------
    case_dir : the OpenFOAM case folder.
    tcp_port : also listen on TCP at ``host:tcp_port`` (None: the UNIX socket only; 0: a free
        port).
    host : the TCP host, a name or an address (IPv4 or IPv6).
    """

    def __init__(self, case_dir, tcp_port: int | None = None, host: str = "127.0.0.1"):
        self.case_dir = Path(case_dir)
        self.tcp_port = tcp_port
        self.host = host
        self.socket_path = self.case_dir / SOCKET_NAME
        self.pid_path = self.case_dir / PID_NAME
        self.endpoint_path = self.case_dir / ENDPOINT_NAME
        self.sockets: list[socket.socket] = []
        self.tcp_address: tuple[str, int] | None = None

    def where(self) -> str:
        """The socket, and the TCP address if any, for the log."""
        return str(self.socket_path) + (
            f" and tcp {self.tcp_address[0]}:{self.tcp_address[1]}" if self.tcp_address else "")

    def read_pid(self) -> tuple[str, str | None] | None:
        """(pid, host) from the pid file; host None in an old one-field file; None if absent."""
        try:
            fields = self.pid_path.read_text().split()
        except OSError:
            return None
        if not fields:
            return None
        return fields[0], (fields[1] if len(fields) > 1 else None)

    def check_not_running(self) -> None:
        """One server per case, across hosts: another host's server is never judged stale here
        (its socket cannot be probed from this host, its pid means nothing here)."""
        owner = self.read_pid()
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

    def listen(self) -> None:
        """Bind and listen: the UNIX socket (mode 0600), then TCP if asked."""
        unix = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        old = os.umask(0o177)
        try:
            _bind_unix(unix, self.socket_path)
        finally:
            os.umask(old)
        os.chmod(self.socket_path, 0o600)
        unix.listen(64)
        self.sockets.append(unix)
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
            self.sockets.append(tcp)

    def write_pid(self) -> None:
        atomic_write_text(self.pid_path, f"{os.getpid()} {socket.gethostname()}\n")

    def write_endpoint(self) -> None:
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
        atomic_write_text(self.endpoint_path, "\n".join(lines) + "\n")

    def close(self) -> None:
        """Stop listening."""
        for s in self.sockets:
            s.close()
        self.sockets.clear()

    def remove_files(self) -> None:
        """Stop listening, and remove the endpoint, socket and pid files if this process
        wrote them."""
        self.close()
        owner = self.read_pid()
        if owner is not None and owner[0] == str(os.getpid()):
            for path in (self.endpoint_path, self.socket_path, self.pid_path):
                try:
                    path.unlink(missing_ok=True)
                except OSError:
                    pass


def is_loopback(host: str) -> bool:
    """Whether every address of ``host`` is a loopback address."""
    try:
        infos = socket.getaddrinfo(host, None)
    except socket.gaierror:
        return False
    return bool(infos) and all(ipaddress.ip_address(i[4][0]).is_loopback for i in infos)


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


def _unix_address(path: Path) -> tuple[str, int | None]:
    """A bindable address for path; long paths go through /proc/self/fd (Linux)."""
    s = str(path)
    if len(s.encode()) < 104:
        return s, None
    fd = os.open(path.parent, os.O_RDONLY | os.O_DIRECTORY)
    return f"/proc/self/fd/{fd}/{path.name}", fd


def _at_unix_address(action, path: Path) -> None:
    """``action(address)`` (a socket's bind or connect) at ``path``, however long it is."""
    addr, fd = _unix_address(path)
    try:
        action(addr)
    finally:
        if fd is not None:
            os.close(fd)


def _bind_unix(sock: socket.socket, path: Path) -> None:
    _at_unix_address(sock.bind, path)


def _connect_unix(sock: socket.socket, path: Path) -> None:
    _at_unix_address(sock.connect, path)
