"""Faults and bad input: nothing lost, nothing silent (docs/faults.md). The fixtures and
helpers the fault tests share: a real step-server (threads, the smoke whale), patch points near
the whale and the displacement of the uninterrupted run to compare with.

The files by concern: ``test_fuzzing`` (fuzzed frames), ``test_refusals`` (clients of another
protocol version, a second server, the socket's and TCP's security), ``test_bad_scenes`` (bad
scenes and meshes), ``test_time_steps`` (unstable steps, NaN, unreadable restart state, absurd
times); these need no OpenFOAM. ``test_killed`` (marked ``openfoam``) runs the real pimpleFoam
with the plugin on the smoke preset, kills the server or the solver mid-run and resumes. The
soak (1,000 coupled steps, marked ``slow``) is ``scripts/soak.py``.
"""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import pytest

from adapter.coupling.mapping import PatchMap
from adapter.coupling.protocol import (
    SOCKET_NAME,
)
from adapter.motion.animator import Animator
from adapter.scene import load_scene

from ..wire_client import points_near, server_starter

REPO = Path(__file__).resolve().parents[2]
#: the plugin's words for a server that is gone (stepServerStream.C), from a send, a receive
#: or an end of file
LOST_SERVER = (r"the step-server stopped or crashed: (sending to|receiving from) it failed"
               r"|the step-server closed the connection \(EOF\): it stopped or crashed")

@pytest.fixture(scope="module")
def scene():
    return load_scene(preset="smoke")


@pytest.fixture(scope="module")
def animator(scene):
    return Animator(scene)


@pytest.fixture(scope="module")
def points(animator):
    """60 patch points near the whale: on random triangles, lifted 1 mm off the surface."""
    return points_near(animator.surface, 60, seed=1)


@pytest.fixture(scope="module")
def truth(scene, animator, points):
    """The patch displacement at time t, from an independent animator (the uninterrupted run)."""
    ref = Animator(scene, animator.surface)
    patch = PatchMap.from_surface(points, animator.surface)
    cache = {}

    def at(t):
        if t not in cache:
            ref.reset()
            cache[t] = patch.apply(ref.displacement(t))
        return cache[t]

    return at


@pytest.fixture
def case(tmp_path):
    d = tmp_path / "case"
    d.mkdir()
    return d


@pytest.fixture
def serve(scene, animator):
    start, stop_all = server_starter(scene, animator, first_client_timeout=60)
    yield start
    stop_all()


def _serve_cli(case: Path, *extra) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", "adapter.cli", "serve", "--case", str(case), "--preset", "smoke",
         "--wait", "120", *extra],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=REPO)


def _wait_for_socket(case: Path, proc: subprocess.Popen, timeout=90.0) -> None:
    deadline = time.monotonic() + timeout
    while not (case / SOCKET_NAME).exists():
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < deadline, "the server made no socket"
        time.sleep(0.1)
