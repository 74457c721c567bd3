"""The coupled run: real pimpleFoam + the stepServerDisplacement plugin + the step-server.

On the smoke preset, serial and on two MPI ranks: the whale patch's pointDisplacement at the
last written time equals the animator's displacement at that time mapped onto the patch points
(to 1e-9 m), and a restart from an earlier written time continues with identical
displacements. Skipped without OpenFOAM or without the built plugin (scripts/build_plugin.sh).
"""

from __future__ import annotations

import re
import shutil

import numpy as np
import pytest

from adapter.body.geometry import build_surface
from adapter.coupling.mapping import DEFAULT_TOLERANCE, PatchMap
from adapter.foam import case as C
from adapter.foam import folders as F
from adapter.foam import mesh as M
from adapter.foam import run as R
from adapter.motion.animator import Animator
from adapter.scene import load_scene

from .conftest import NEEDS_FOAM_AND_PLUGIN

pytestmark = [
    *NEEDS_FOAM_AND_PLUGIN,
    pytest.mark.skipif(shutil.which("mpirun") is None, reason="mpirun is not on PATH"),
]

_NUM = r"[-+0-9.eE]+"
_VEC = re.compile(rf"\(({_NUM}) ({_NUM}) ({_NUM})\)")


def _foam_list(text: str, start: int) -> np.ndarray:
    """The vector list that starts after ``start`` in an OpenFOAM ASCII file: N ( (x y z) ... )."""
    m = re.compile(r"(\d+)\s*\(").search(text, start)
    n = int(m.group(1))
    vecs = _VEC.findall(text, m.end())[:n]
    assert len(vecs) == n
    return np.array(vecs, dtype=float)


def _points(path) -> np.ndarray:
    text = path.read_text()
    return _foam_list(text, text.index("}") + 1)


def _faces(path) -> list:
    text = path.read_text()
    m = re.compile(r"\n(\d+)\s*\n\(").search(text, text.index("}") + 1)
    n = int(m.group(1))
    return [list(map(int, f.split())) for f in re.findall(r"\d+\(([\d ]+)\)", text[m.end():])[:n]]


def _whale_mesh_points(case) -> np.ndarray:
    """Labels of the whale patch's points in OpenFOAM's order (first appearance in its faces)."""
    boundary = (case / "constant" / "polyMesh" / "boundary").read_text()
    m = re.search(r"whale\s*\{[^}]*?nFaces\s+(\d+);\s*startFace\s+(\d+);", boundary)
    n, start = int(m.group(1)), int(m.group(2))
    faces = _faces(case / "constant" / "polyMesh" / "faces")[start:start + n]
    seen: dict = {}
    for f in faces:
        for p in f:
            seen.setdefault(p, len(seen))
    return np.array(list(seen), dtype=int)


def _whale_displacement(case, time_dir) -> np.ndarray:
    text = (time_dir / "pointDisplacement").read_text()
    i = text.index("whale", text.index("boundaryField"))
    j = text.index("value", i)
    return _foam_list(text, j)


@pytest.fixture(scope="module")
def smoke():
    return load_scene(preset="smoke")


@pytest.fixture(scope="module")
def surface(smoke):
    return build_surface(smoke)


@pytest.fixture(scope="module")
def meshed(tmp_path_factory, smoke, surface):
    case = tmp_path_factory.mktemp("coupled") / "mesh"
    C.prepare_case(smoke, case, surface=surface)
    M.mesh_case(case)
    return case


def _expected(case, smoke, surface, t) -> np.ndarray:
    rest = _points(case / "constant" / "polyMesh" / "points")[_whale_mesh_points(case)]
    patch = PatchMap(rest, surface.points, surface.triangles, surface.length, DEFAULT_TOLERANCE)
    return patch.apply(Animator(smoke, surface).displacement(t))


@pytest.mark.parametrize("ranks", [1, 2])
def test_coupled_smoke_run_and_restart(tmp_path, meshed, smoke, surface, ranks):
    case = tmp_path / "case"
    shutil.copytree(meshed, case)
    summary = R.run_case(case, ranks=ranks, progress=False, reconstruct=True)
    record = C.read_record(case)
    assert summary["steps"] == record["parameters"]["n_steps"]
    assert summary["ranks"] == ranks
    assert summary["adapter_requests"] == record["parameters"]["n_steps"]
    # the server counts each rank's points: points on a processor boundary count twice
    assert summary["whale_points"] == record["mesh"]["whale_points"]
    if ranks == 1:
        assert summary["patch_points"] == record["mesh"]["whale_points"]
    else:
        assert summary["patch_points"] >= record["mesh"]["whale_points"]
    assert summary["max_mapping_distance_m"] < DEFAULT_TOLERANCE * smoke.geometry.length_m

    times = F.time_dirs(case)
    (t_last, last), (t_prev, _) = times[-1], times[-2]
    got = _whale_displacement(case, last)
    want = _expected(case, smoke, surface, t_last)
    assert got.shape == want.shape
    assert np.abs(got).max() > 1e-3  # the whale did move
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-9)

    # restart from the previous written time: the same times (binary-fraction steps), the same
    # displacement at the end, bit for bit
    again = tmp_path / "restart"
    shutil.copytree(case, again, ignore=shutil.ignore_patterns("processor*"))
    shutil.rmtree(again / last.name)
    R.run_case(again, ranks=ranks, progress=False, reconstruct=True)
    assert F.time_dirs(again)[-1][0] == t_last
    np.testing.assert_array_equal(_whale_displacement(again, again / last.name), got)
    assert t_prev < t_last


def test_run_case_over_tcp_with_a_token_from_the_environment(tmp_path, meshed, smoke, surface,
                                                             monkeypatch):
    """run-case --host/--port: the server listens on TCP, publishes the endpoint, the 2 ranks'
    master connects there with the token from the environment (mpirun -x); the token is in no
    file of the case."""
    token = "tcp-token-0f3c9a"
    monkeypatch.setenv("WHALE_ADAPTER_TOKEN", token)
    case = tmp_path / "case"
    shutil.copytree(meshed, case)
    R.run_case(case, ranks=2, progress=False, host="127.0.0.1", port=0,
               reconstruct=True)
    log = (case / "log.pimpleFoam").read_text()
    assert "stepServer: connected to tcp://127.0.0.1:" in log
    t_last, last = F.time_dirs(case)[-1]
    np.testing.assert_allclose(_whale_displacement(case, last),
                               _expected(case, smoke, surface, t_last), rtol=0, atol=1e-9)
    holding = [p for p in case.rglob("*") if p.is_file() and token.encode() in p.read_bytes()]
    assert holding == []
