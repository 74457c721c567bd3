"""The real pimpleFoam with the plugin on the smoke preset: the server or the
solver killed mid-run, and the run resumed (docs/faults.md; marked ``openfoam``)."""

from __future__ import annotations

import importlib.util
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from adapter.coupling.protocol import (
    ENDPOINT_NAME,
    SOCKET_NAME,
)
from adapter.foam import case as C
from adapter.foam import folders as F
from adapter.foam import mesh as M
from adapter.foam import run as R
from adapter.foam import tools as T

from .conftest import LOST_SERVER, REPO, _wait_for_socket

# --- with the real pimpleFoam (smoke preset) --------------------------------------------------

def openfoam(test):
    """Mark a test that runs the real pimpleFoam; skipped only without it or the plugin."""
    return pytest.mark.openfoam(pytest.mark.plugin(test))


#: flow steps of the fault runs (written every 4 steps, as the smoke preset does)
FAULT_STEPS = 24
_TIME_LINE = re.compile(r"^Time = ([-+0-9.eE]+)\s*$", re.M)
_VEC = re.compile(r"\(([-+0-9.eE]+) ([-+0-9.eE]+) ([-+0-9.eE]+)\)")
#: what a written time holds when OpenFOAM wrote it to the end
_FIELDS = ("U", "p", "phi", "pointDisplacement", "polyMesh/points", "uniform/time")


def _set_end(case: Path, steps: int, write_every: int | None = None) -> float:
    """endTime = steps * deltaT (exact: deltaT is a binary fraction); returns deltaT."""
    from PyFoam.RunDictionary.ParsedParameterFile import ParsedParameterFile

    d = ParsedParameterFile(str(case / "system" / "controlDict"))
    dt = float(d["deltaT"])
    d["endTime"] = steps * dt
    if write_every:
        d["writeInterval"] = write_every
    d.writeFile()
    return dt


def _whale_displacement(time_dir: Path) -> np.ndarray:
    text = (time_dir / "pointDisplacement").read_text()
    start = text.index("value", text.index("whale", text.index("boundaryField")))
    m = re.compile(r"(\d+)\s*\(").search(text, start)
    vecs = _VEC.findall(text, m.end())[:int(m.group(1))]
    return np.array(vecs, dtype=float)


def _written(case: Path) -> dict:
    """name -> {relative file: bytes} of every time folder but 0."""
    out = {}
    for t, d in F.time_dirs(case):
        if t > 0:
            out[d.name] = {str(f.relative_to(d)): f.read_bytes() for f in d.rglob("*")
                           if f.is_file()}
    return out


def _complete(files: dict) -> bool:
    return all(f in files for f in _FIELDS)


@pytest.fixture(scope="module")
def foam_case(tmp_path_factory, scene):
    """A meshed smoke case of FAULT_STEPS steps, and the whale's displacement at every written
    time of its uninterrupted run: name -> (P, 3)."""
    base = tmp_path_factory.mktemp("faults")
    mesh = base / "mesh"
    C.prepare_case(scene, mesh)
    M.mesh_case(mesh)
    dt = _set_end(mesh, FAULT_STEPS)
    ref = base / "reference"
    shutil.copytree(mesh, ref)
    R.run_case(ref, progress=False)
    written = {d.name: _whale_displacement(d) for t, d in F.time_dirs(ref) if t > 0}
    assert len(written) == FAULT_STEPS // 4
    return mesh, dt, written


def _launch(case: Path):
    """The step-server and serial pimpleFoam, as two processes (what run-case does)."""
    log = open(case / "log.server", "w")  # noqa: SIM115 - closed by the caller
    server = subprocess.Popen(
        [sys.executable, "-m", "adapter.cli", "serve", "--case", str(case), "--preset", "smoke",
         "--wait", "300"], cwd=case, stdout=log, stderr=subprocess.STDOUT)
    _wait_for_socket(case, server)
    foam_log = open(case / "log.pimpleFoam", "w")  # noqa: SIM115
    foam = subprocess.Popen(["pimpleFoam"], cwd=case, env=T.foam_env(), stdout=foam_log,
                            stderr=subprocess.STDOUT)
    return server, foam, [log, foam_log]


def _wait_for_step(case: Path, foam, dt: float, ok, timeout=240.0) -> int:
    """Wait until pimpleFoam starts a step k with ok(k); returns k."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        assert foam.poll() is None, (case / "log.pimpleFoam").read_text()[-3000:]
        times = _TIME_LINE.findall((case / "log.pimpleFoam").read_text(errors="replace"))
        if times:
            k = round(float(times[-1]) / dt)
            if ok(k):
                return k
        time.sleep(0.02)
    raise AssertionError("pimpleFoam did not reach the step")


def _stop(*procs) -> None:
    for p in procs:
        if p.poll() is None:
            p.kill()
            p.wait()


def _resume_and_compare(case: Path, reference: dict, before: dict) -> None:
    """run-case again (server and pimpleFoam from the latest time): the written times from
    before are untouched, and every written time equals the uninterrupted run's, bit for bit."""
    R.run_case(case, progress=False)
    after = _written(case)
    for name, files in before.items():
        assert after[name] == files, f"time {name} changed on resume"
    assert sorted(after, key=float) == sorted(reference, key=float)
    for name, want in reference.items():
        np.testing.assert_array_equal(_whale_displacement(case / name), want, err_msg=name)
    text = (case / "adapter" / "keypoints.csv").read_text()
    assert "nan" not in text.lower()       # the restart's first REQUEST has no forces: empty
    rows = text.splitlines()[1:]
    ts = [float(r.split(",")[0]) for r in rows]
    assert len(ts) == FAULT_STEPS and ts == sorted(set(ts))


@openfoam
def test_server_killed_mid_run(tmp_path, foam_case):
    """kill -9 the server: pimpleFoam stops with a FatalError naming the server within 10 s,
    the written times are intact, and run-case resumes with identical displacements."""
    mesh, dt, reference = foam_case
    case = tmp_path / "case"
    shutil.copytree(mesh, case)
    server, foam, logs = _launch(case)
    try:
        # after the second write, early in a write interval: the solver's next call on the
        # server is a REQUEST, not the WRITE of a time being written
        _wait_for_step(case, foam, dt, lambda k: k > 8 and k % 4 == 1)
        before = _written(case)
        assert len(before) >= 2 and all(_complete(f) for f in before.values())
        t_kill = time.monotonic()
        server.send_signal(signal.SIGKILL)
        rc = foam.wait(30)
        to_fatal = time.monotonic() - t_kill
    finally:
        _stop(foam, server)
        for f in logs:
            f.close()
    print(f"pimpleFoam stopped {to_fatal:.2f} s after the server was killed")
    text = (case / "log.pimpleFoam").read_text(errors="replace")
    assert rc != 0 and to_fatal < 10.0
    assert "FOAM FATAL ERROR" in text and "stepServer: REQUEST at time" in text, text[-2000:]
    assert re.search(LOST_SERVER, text)
    # it names the server's socket and the endpoint file that named it, in plain words
    assert f"(step-server at {case / SOCKET_NAME}, named in {case / ENDPOINT_NAME})" in text
    assert _written(case) == before, "a written time changed or a partial one appeared"
    _resume_and_compare(case, reference, before)


@openfoam
def test_pimplefoam_killed_mid_run(tmp_path, foam_case):
    """kill -9 pimpleFoam: the server notices, saves its state, exits 0 with a message; the
    run resumes from the latest written time with identical displacements."""
    mesh, dt, reference = foam_case
    case = tmp_path / "case"
    shutil.copytree(mesh, case)
    server, foam, logs = _launch(case)
    try:
        _wait_for_step(case, foam, dt, lambda k: k > 8 and k % 4 == 2)
        foam.send_signal(signal.SIGKILL)
        foam.wait(30)
        t_kill = time.monotonic()
        rc = server.wait(30)
        to_exit = time.monotonic() - t_kill
    finally:
        _stop(foam, server)
        for f in logs:
            f.close()
    out = (case / "log.server").read_text()
    print(f"the server exited {to_exit:.2f} s after pimpleFoam was killed")
    assert rc == 0, out
    m = re.search(r"a client vanished without BYE \(pimpleFoam killed\?\); saved the state at "
                  r"t = ([0-9.e+-]+) s", out)
    assert m, out
    assert (case / "adapter" / f"state_{m.group(1)}.npz").is_file()
    assert not (case / SOCKET_NAME).exists()
    before = _written(case)
    assert before and all(_complete(f) for f in before.values())
    _resume_and_compare(case, reference, before)


@openfoam
def test_server_killed_while_a_time_is_written(tmp_path, foam_case):
    """The server dies during the solve of a write step: resuming must still just work."""
    mesh, dt, reference = foam_case
    case = tmp_path / "case"
    shutil.copytree(mesh, case)
    server, foam, logs = _launch(case)
    try:
        deadline = time.monotonic() + 240
        while time.monotonic() < deadline:       # step 12 (written) is in its flow solve
            parts = re.split(r"^Time = ", (case / "log.pimpleFoam").read_text(errors="replace"),
                             flags=re.M)
            if len(parts) > 1 and round(float(parts[-1].split()[0]) / dt) == 12 \
                    and re.search(r"Solving for (Ux|p)", parts[-1]):
                break
            assert foam.poll() is None
            time.sleep(0.005)
        before = _written(case)
        server.send_signal(signal.SIGKILL)
        assert foam.wait(30) != 0
    finally:
        _stop(foam, server)
        for f in logs:
            f.close()
    assert "stepServer: WRITE at time" in (case / "log.pimpleFoam").read_text(errors="replace")
    _resume_and_compare(case, reference, before)


@pytest.fixture(scope="module")
def foam_case_2ranks(tmp_path_factory, foam_case):
    """The fault case's uninterrupted 2-rank run: name -> whale displacement (P, 3)."""
    mesh, _, _ = foam_case
    ref = tmp_path_factory.mktemp("faults2") / "reference"
    shutil.copytree(mesh, ref)
    R.run_case(ref, ranks=2, progress=False, reconstruct=True)
    written = {d.name: _whale_displacement(d) for t, d in F.time_dirs(ref) if t > 0}
    assert len(written) == FAULT_STEPS // 4
    return written


@openfoam
def test_parallel_run_killed_resumes_from_the_ranks(tmp_path, foam_case, foam_case_2ranks):
    """A 2-rank run-case whose server is killed after the second write: run-case names the
    FatalError; the written times are only in processor*/; run-case again resumes from them
    (no new decomposePar) and ends with the uninterrupted 2-rank run's whale displacements."""
    import psutil

    mesh, dt, _ = foam_case
    reference = foam_case_2ranks
    case = tmp_path / "case"
    shutil.copytree(mesh, case)
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(REPO), env.get("PYTHONPATH")]))
    run = subprocess.Popen([sys.executable, "-m", "adapter.cli", "run-case", "--case", str(case),
                            "--np", "2"], cwd=tmp_path, stdout=subprocess.PIPE,
                           stderr=subprocess.PIPE, text=True, env=env)
    try:
        deadline = time.monotonic() + 240
        while time.monotonic() < deadline:
            assert run.poll() is None, run.communicate()
            log = case / "log.pimpleFoam"
            times = _TIME_LINE.findall(log.read_text(errors="replace")) if log.exists() else []
            k = round(float(times[-1]) / dt) if times else 0
            if k > 8 and k % 4 == 1:
                break
            time.sleep(0.02)
        server = [p for p in psutil.Process(run.pid).children(recursive=True)
                  if "serve" in p.cmdline()]
        assert len(server) == 1
        server[0].kill()
        out, err = run.communicate(timeout=60)
    finally:
        _stop(run)
    assert run.returncode == 2, (out, err)
    # run-case says OpenFOAM's own message, not only "see log.pimpleFoam"
    assert re.search(LOST_SERVER, err), err
    assert [t for t, _ in F.time_dirs(case)] == [0.0]          # nothing reconstructed yet
    latest = F.processor_latest(case)
    assert latest is not None and latest >= 8 * dt
    before = {p.name: _written(p) for p in F.processor_dirs(case)}
    decomposed = (case / "log.decomposePar").stat().st_mtime_ns
    assert F.resume_time(case) == latest

    R.run_case(case, ranks=2, progress=False, reconstruct=True)
    assert (case / "log.decomposePar").stat().st_mtime_ns == decomposed   # not re-decomposed
    for name, times in before.items():
        after = _written(case / name)
        for t, files in times.items():
            assert after[t] == files, f"{name}/{t} changed on resume"
    first = _TIME_LINE.findall((case / "log.pimpleFoam").read_text(errors="replace"))[0]
    assert float(first) == pytest.approx(latest + dt, abs=1e-12)
    assert sorted(_written(case), key=float) == sorted(reference, key=float)
    # mesh motion is not yet restart-exact in parallel: the flow may differ by ~1e-3, the
    # whale's served displacement may not
    for name, want in reference.items():
        np.testing.assert_allclose(_whale_displacement(case / name), want, rtol=0, atol=1e-9,
                                   err_msg=name)
    assert "nan" not in (case / "adapter" / "keypoints.csv").read_text().lower()


def _load_soak():
    spec = importlib.util.spec_from_file_location("soak", REPO / "scripts" / "soak.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@openfoam
@pytest.mark.slow
def test_soak_server_memory_is_flat(tmp_path):
    """1,000 coupled smoke steps (about 2.5 min here): the server's RSS does not grow after
    the warm-up (the first 10 % of the steps: numba, pyvista at the first WRITE)."""
    report = _load_soak().soak(tmp_path / "soak", steps=1000, write_every=50, interval=1.0)
    print(f"soak: RSS {report['rss_after_warmup_mb']} MB at step "
          f"{report['rss_after_warmup_step']}, {report['rss_end_mb']} MB at step "
          f"{report['rss_end_step']}, {report['wall_s']} s")
    assert report["steps"] == 1000 and report["rss_end_step"] >= 900
    assert report["rss_growth_after_warmup_mb"] <= 10.0
