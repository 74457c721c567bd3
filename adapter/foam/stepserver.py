"""The step-server as a child of a run: started (``python -m adapter.cli serve``) before the
solver, in its own session, its output in ``<case>/log.server``; a run waits until it has
published its endpoint file, and lets it finish after the solver (it exits on the clients' BYE
and writes its statistics)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

from adapter import resources
from adapter.coupling.protocol import ENDPOINT_NAME, TOKEN_ENV
from adapter.errors import ServerStartError
from adapter.foam.casescene import case_scene_file


def server_command(case: Path, record: dict) -> list:
    """``whale-adapter serve`` for the case, with the case's own scene
    (``<case>/adapter-scene.toml``, :mod:`adapter.foam.casescene`); a case prepared before it
    had one: with the scene file or preset recorded."""
    cmd = [sys.executable, "-m", "adapter.cli", "serve", "--case", str(case)]
    own = case_scene_file(case)
    if own is not None:
        return cmd + ["--scene", str(own.resolve())]
    if record.get("scene_file"):
        cmd += ["--scene", record["scene_file"]]
    if record.get("preset"):
        cmd += ["--preset", record["preset"]]
    return cmd


def start_server(case: Path, record: dict, timeout: float = 60.0, host: str | None = None,
                 port: int | None = None, token: str | None = None) -> subprocess.Popen:
    """Start the step-server; return once it has published its endpoint file. TCP when a host
    or a port is given. The token goes through the environment, never the command line."""
    endpoint = case / ENDPOINT_NAME
    log = open(case / "log.server", "w")  # noqa: SIM115 - closed by stop_server
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(resources.REPO), env.get("PYTHONPATH")]))
    env.pop(TOKEN_ENV, None)
    if token:
        env[TOKEN_ENV] = token
    cmd = server_command(case, record)
    if host is not None or port is not None:
        cmd += ["--tcp", str(port or 0), "--host", host or "127.0.0.1"]
    proc = subprocess.Popen(cmd, cwd=case, stdout=log, stderr=subprocess.STDOUT,
                            start_new_session=True, env=env)
    proc._whale_log = log  # type: ignore[attr-defined]
    t0 = time.perf_counter()
    while not endpoint_of(endpoint, proc.pid):
        if proc.poll() is not None:
            log.close()
            raise ServerStartError(f"the step-server stopped at start (exit code "
                                   f"{proc.returncode}); see {case / 'log.server'}")
        if time.perf_counter() - t0 > timeout:
            stop_server(proc)
            raise ServerStartError(f"the step-server published no endpoint {endpoint} within "
                                   f"{timeout:.0f} s; see {case / 'log.server'}")
        time.sleep(0.1)
    return proc


def endpoint_of(path: Path, pid: int) -> bool:
    """Whether the endpoint file at path is the one server ``pid`` wrote."""
    try:
        return f"\npid {pid}\n" in path.read_text()
    except OSError:
        return False


def stop_server(proc: subprocess.Popen | None, grace: float = 15.0) -> None:
    """Let the server finish (it exits after the clients' BYE and writes its statistics);
    terminate it when it is still there after ``grace`` seconds."""
    if proc is None:
        return
    try:
        proc.wait(grace)
    except subprocess.TimeoutExpired:
        proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(5)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
    log = getattr(proc, "_whale_log", None)
    if log is not None:
        log.close()

