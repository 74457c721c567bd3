"""Bad scenes and geometries, in process and on the command line: a clear
error, never a traceback (docs/faults.md)."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from adapter.coupling.protocol import (
    SOCKET_NAME,
    ErrorCode,
)
from adapter.errors import GeometryError, SceneError
from adapter.motion.animator import Animator
from adapter.scene import load_scene

from ..wire_client import Client, ServerSaid, finished
from .conftest import REPO

# --- bad scenes and geometries ----------------------------------------------------------------


def _write_obj(path: Path, points, faces) -> None:
    lines = [f"v {x!r} {y!r} {z!r}" for x, y, z in np.asarray(points, dtype=float).tolist()]
    lines += ["f " + " ".join(str(i + 1) for i in f) for f in faces]
    path.write_text("\n".join(lines) + "\n")


def _mesh_scene(tmp_path: Path, surface, damage: str) -> Path:
    """A scene file naming an OBJ copy of the smoke whale with one kind of damage."""
    pts = np.array(surface.points, dtype=float)
    tris = np.array(surface.triangles)
    marks = {k: pts[v].tolist() for k, v in surface.landmarks.items()}
    if damage == "open":
        tris = tris[1:]
    elif damage == "nan":
        pts[17, 2] = np.nan
    elif damage == "degenerate":
        a, b, c = tris[5]
        pts = np.vstack([pts, (pts[a] + pts[b]) / 2])   # a zero-area sliver on edge a-b
        tris = np.vstack([tris[:5], [[a, len(pts) - 1, c], [len(pts) - 1, b, c]], tris[6:]])
        tris = np.vstack([tris, [[a, b, len(pts) - 1]], [[b, a, len(pts) - 1]]])
    elif damage == "landmark":
        marks["flipper_left"] = [7.0, 12.0, 9.0]
    _write_obj(tmp_path / "whale.obj", pts, tris)
    lm = "\n".join(f"{k} = [{v[0]!r}, {v[1]!r}, {v[2]!r}]" for k, v in marks.items())
    f = tmp_path / "scene.toml"
    f.write_text(f'preset = "smoke"\n[geometry]\nsource = "whale.obj"\n'
                 f"[geometry.landmarks]\n{lm}\n")
    return f


SCENE_TEXT = {
    "unknown key": ("[springs]\nstiffnes_scale = 2\n", SceneError,
                    r"springs\.stiffnes_scale: unknown key; allowed here: .*stiffness_scale"),
    "unknown section": ("[spring]\nmu = 1\n", SceneError, r"spring: unknown key"),
    "wrong type": ("[flow]\nspeed_m_s = \"fast\"\n", SceneError,
                   r"flow\.speed_m_s: expected a number, got 'fast' \(str\)"),
    "bool for number": ("[springs]\nk_head = true\n", SceneError, r"springs\.k_head: expected"),
    "negative constant": ("[springs]\nk_tail = -40\n", SceneError,
                          r"springs\.k_tail: value -40\.0 is out of range"),
    "negative damping": ("[springs]\nmu = -0.1\n", SceneError, r"springs\.mu: value -0\.1"),
    "NaN constant": ("[springs]\nk_pivot = nan\n", SceneError,
                     r"springs\.k_pivot: expected a finite number"),
    "negative frequency": ("[stroke]\nfrequency_hz = -0.13\n", SceneError,
                           r"stroke\.frequency_hz: value -0\.13 is out of range"),
    "no damping for forward Euler": ("[springs]\nmu = 0\nnu = 0\n", SceneError,
                                     r"forward_euler has no stable step .* raise mu"),
    "missing mesh file": ("[geometry]\nsource = \"nowhere.stl\"\n", GeometryError,
                          r"mesh file .*nowhere\.stl does not exist"),
}
MESH_DAMAGE = {
    "open surface": ("open", r"the surface is open: \d+ edge\(s\) belong to one face only"),
    "NaN points": ("nan", r"1 point\(s\) are NaN or infinite, first at index 17"),
    "degenerate faces": ("degenerate", r"degenerate faces: .* zero area"),
    "landmark off the body": ("landmark", r"landmark flipper_left at \[7\.0, 12\.0, 9\.0\] "
                                          r"is .* m from the nearest surface point .* not on "
                                          r"the body"),
}


@pytest.mark.parametrize("name", list(SCENE_TEXT) + list(MESH_DAMAGE))
def test_bad_scene_or_geometry_is_a_clear_error(tmp_path, animator, name):
    """Each bad input fails where the server would build its animator, naming the problem."""
    if name in SCENE_TEXT:
        text, error, message = SCENE_TEXT[name]
        f = tmp_path / "scene.toml"
        f.write_text('preset = "smoke"\n' + text)
    else:
        damage, message = MESH_DAMAGE[name]
        error = GeometryError
        f = _mesh_scene(tmp_path, animator.surface, damage)
    with pytest.raises(error, match=message):
        Animator(load_scene(f))


def test_the_undamaged_obj_copy_is_accepted(tmp_path, animator):
    """The table's meshes fail for their damage alone: the same file undamaged animates."""
    a = Animator(load_scene(_mesh_scene(tmp_path, animator.surface, "none")))
    assert np.isfinite(a.displacement(0.01)).all()


@pytest.mark.slow
@pytest.mark.parametrize("name", ["negative constant", "open surface"])
def test_bad_input_on_the_command_line_is_one_line_not_a_traceback(tmp_path, case, animator,
                                                                   name):
    if name in SCENE_TEXT:
        f = tmp_path / "scene.toml"
        f.write_text('preset = "smoke"\n' + SCENE_TEXT[name][0])
        message = SCENE_TEXT[name][2]
    else:
        f = _mesh_scene(tmp_path, animator.surface, MESH_DAMAGE[name][0])
        message = MESH_DAMAGE[name][1]
    r = subprocess.run([sys.executable, "-m", "adapter.cli", "serve", "--case", str(case),
                        "--scene", str(f)], capture_output=True, text=True, cwd=REPO, timeout=120)
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert r.stderr.startswith("whale-adapter serve: error: ") and re.search(message, r.stderr)
    assert not (case / SOCKET_NAME).exists()


@pytest.mark.parametrize("shift, tolerance", [((0.0, 0.0, 100.0), 0.05), ((0.0, 0.0, 1.0), 0.05),
                                              ((0.0, 0.0, 0.2), 0.01)])
def test_patch_far_from_the_whale_is_refused_naming_the_distance(case, serve, points, shift,
                                                                 tolerance):
    """A patch too far from the whale for its mapping to mean anything: ERROR 3 at HELLO."""
    srv = serve(case, map_tolerance=tolerance)
    c = Client(case)
    with pytest.raises(ServerSaid) as info:
        c.hello(points + np.array(shift))
    assert info.value.code == ErrorCode.BAD_HELLO
    assert re.search(r"lies [0-9.e+-]+ m from the whale surface, more than the allowed "
                     r"[0-9.e+-]+ m", info.value.message)
    assert "same scene" in info.value.message
    ok = Client(case)                    # the server goes on
    ok.hello(points)
    ok.bye()
    assert finished(srv) == 0
