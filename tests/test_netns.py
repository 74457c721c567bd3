"""The rendezvous across hosts, in two network namespaces the test creates.

The server's namespace and the solver's are joined by a veth pair with the test's own addresses
(10.201.0.1/24, 10.201.0.2/24). The step-server listens on TCP at its veth address with a token
and publishes the endpoint in the case; pimpleFoam (serial and 2 ranks) runs in the other
namespace, finds the server through the endpoint file and gets the token from the environment.
The run finishes, the whale displacements equal a serial UNIX-socket run's bit for bit, the
server saw one link from the solver's address, and no file under the case holds the token.

Skipped unless root, ``ip netns`` works, and OpenFOAM and the plugin are there.
"""

from __future__ import annotations

import os
import secrets
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from adapter.coupling.server import ENDPOINT_NAME, TOKEN_ENV
from adapter.foam import case as C
from adapter.foam import dictionaries as D
from adapter.foam import folders as F
from adapter.foam import mesh as M
from adapter.foam import run as R
from adapter.foam import tools as T

from .conftest import NEEDS_FOAM_AND_PLUGIN
from .test_coupled import _whale_displacement

REPO = Path(__file__).resolve().parents[1]
SERVER_ADDR, SOLVER_ADDR = "10.201.0.1", "10.201.0.2"


def _netns_works() -> bool:
    if os.geteuid() != 0 or shutil.which("ip") is None:
        return False
    probe = f"whprobe{os.getpid()}"
    ok = subprocess.run(["ip", "netns", "add", probe], capture_output=True).returncode == 0
    if ok:
        subprocess.run(["ip", "netns", "del", probe], capture_output=True)
    return ok


pytestmark = [
    *NEEDS_FOAM_AND_PLUGIN,
    pytest.mark.skipif(shutil.which("mpirun") is None, reason="no mpirun"),
    pytest.mark.skipif(not _netns_works(), reason="needs root and a working `ip netns`"),
]


def _ip(*args: str) -> None:
    subprocess.run(["ip", *args], check=True, capture_output=True)


@pytest.fixture
def namespaces(request):
    """(server namespace, solver namespace), joined by a veth pair; removed afterwards."""
    tag = f"{os.getpid() % 100000}"
    srv, foam = f"whsrv{tag}", f"whfoam{tag}"
    a, b = f"whva{tag}", f"whvb{tag}"

    def cleanup():
        for ns in (srv, foam):           # deleting a namespace deletes its end of the veth
            subprocess.run(["ip", "netns", "del", ns], capture_output=True)
        subprocess.run(["ip", "link", "del", a], capture_output=True)

    request.addfinalizer(cleanup)
    _ip("netns", "add", srv)
    _ip("netns", "add", foam)
    _ip("link", "add", a, "type", "veth", "peer", "name", b)
    _ip("link", "set", a, "netns", srv)
    _ip("link", "set", b, "netns", foam)
    for ns, dev, addr in ((srv, a, SERVER_ADDR), (foam, b, SOLVER_ADDR)):
        _ip("-n", ns, "addr", "add", f"{addr}/24", "dev", dev)
        _ip("-n", ns, "link", "set", dev, "up")
        _ip("-n", ns, "link", "set", "lo", "up")
    return srv, foam


@pytest.fixture(scope="module")
def meshed(tmp_path_factory, smoke_scene, smoke_surface):
    case = tmp_path_factory.mktemp("netns") / "mesh"
    C.prepare_case(smoke_scene, case, surface=smoke_surface)
    M.mesh_case(case)
    return case


@pytest.fixture(scope="module")
def unix_reference(tmp_path_factory, meshed):
    """The serial run on the case's UNIX socket: (last time name, whale displacement)."""
    case = tmp_path_factory.mktemp("netns") / "unix"
    shutil.copytree(meshed, case)
    R.run_case(case, ranks=1, progress=False)
    name, last = F.time_dirs(case)[-1][1].name, F.time_dirs(case)[-1][1]
    return name, _whale_displacement(case, last)


def _in_ns(ns: str, cmd: list, case: Path, env: dict, log: str) -> int:
    with open(case / log, "w") as fh:
        return subprocess.call(["ip", "netns", "exec", ns, *cmd], cwd=case, stdout=fh,
                               stderr=subprocess.STDOUT, env=env, timeout=600)


@pytest.mark.parametrize("ranks", [1, 2])
def test_server_and_solver_in_two_network_namespaces(tmp_path, meshed, unix_reference,
                                                     namespaces, ranks):
    ns_server, ns_solver = namespaces
    case = tmp_path / "case"
    shutil.copytree(meshed, case)
    token = secrets.token_hex(16)
    env = T.foam_env()
    env[TOKEN_ENV] = token
    env["PYTHONPATH"] = str(REPO)

    server_log = open(case / "log.server", "w")  # noqa: SIM115
    server = subprocess.Popen(
        ["ip", "netns", "exec", ns_server, sys.executable, "-m", "adapter.cli", "serve",
         "--case", str(case), "--preset", "smoke", "--tcp", "0", "--host", SERVER_ADDR,
         "--wait", "300"], cwd=case, stdout=server_log, stderr=subprocess.STDOUT, env=env)
    try:
        endpoint = case / ENDPOINT_NAME
        deadline = time.monotonic() + 120
        while f"host {SERVER_ADDR}\n" not in (endpoint.read_text() if endpoint.exists() else ""):
            assert server.poll() is None, (case / "log.server").read_text()
            assert time.monotonic() < deadline, "the server published no endpoint"
            time.sleep(0.2)
        assert token not in endpoint.read_text()

        F.restore_zero(case)
        if ranks == 1:
            rc = _in_ns(ns_solver, ["pimpleFoam"], case, env, "log.pimpleFoam")
        else:
            d = D.parsed_dict(case / "system" / "decomposeParDict")
            d["numberOfSubdomains"] = ranks
            d["coeffs"]["n"] = f"({ranks} 1 1)"
            d.writeFile()
            T.run_utility(case, ["decomposePar", "-force"])
            rc = _in_ns(ns_solver, ["mpirun", "--allow-run-as-root", "--oversubscribe", "-np",
                                    str(ranks), "-x", TOKEN_ENV, "pimpleFoam", "-parallel"],
                        case, env, "log.pimpleFoam")
        assert rc == 0, (case / "log.pimpleFoam").read_text()[-3000:]
        assert server.wait(60) == 0, (case / "log.server").read_text()
    finally:
        if server.poll() is None:
            server.kill()
            server.wait()
        server_log.close()
    if ranks > 1:
        T.run_utility(case, ["reconstructPar", "-newTimes"])

    # one link, over TCP from the solver's namespace
    log = (case / "adapter" / "server.log").read_text()
    assert f"link {SOLVER_ADDR}:" in log and f"for {ranks} rank(s)" in log
    assert "1 link)" in (case / "log.server").read_text()
    foam_log = (case / "log.pimpleFoam").read_text()
    assert f"stepServer: connected to tcp://{SERVER_ADDR}:" in foam_log

    name, want = unix_reference
    got = _whale_displacement(case, case / name)
    assert np.abs(got).max() > 1e-3
    np.testing.assert_array_equal(got, want)

    # the token is in no file of the case: time and processor folders, logs, outputs
    needle = token.encode()
    files = [p for p in case.rglob("*") if p.is_file() and not p.is_symlink()]
    assert len(files) > 50
    holding = [str(p.relative_to(case)) for p in files if needle in p.read_bytes()]
    assert holding == []
