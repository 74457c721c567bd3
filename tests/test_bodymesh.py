"""The meshed body against its surface (adapter/foam/bodymesh.py): the patch's area and
enclosed volume of a hand-made box, snappyHexMesh's initial intersections from its log, and,
with OpenFOAM (meshing only, no solver), the issue's slender body of revolution refused on a
preset whose background cell is larger than its diameter, accepted once the cell is small
enough, and the smoke whale accepted."""

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

from adapter.body.meshfile import write_surface
from adapter.errors import MeshError
from adapter.foam import bodymesh as B
from adapter.foam import case as C
from adapter.foam import mesh as M
from adapter.foam import run as R
from adapter.scene import load_scene

HEADER = "FoamFile\n{\n    version 2.0;\n    format ascii;\n    class %s;\n    object %s;\n}\n"


def _box_polymesh(folder: Path, size=(2.0, 1.0, 0.5)):
    """A polyMesh holding only a whale patch: the six faces of a box, their normals pointing
    into it (out of the water, as OpenFOAM orients a boundary face)."""
    a, b, c = size
    pts = np.array([[x, y, z] for x in (0, a) for y in (0, b) for z in (0, c)])
    # each face's corners in the order whose right-hand normal points into the box
    quads = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2],
             [1, 3, 7, 5]]
    poly = folder / "constant" / "polyMesh"
    poly.mkdir(parents=True)
    (poly / "points").write_text(HEADER % ("vectorField", "points") + f"{len(pts)}\n(\n"
                                 + "".join(f"({x} {y} {z})\n" for x, y, z in pts) + ")\n")
    (poly / "faces").write_text(HEADER % ("faceList", "faces") + f"{len(quads)}\n(\n"
                                + "".join(f"4({' '.join(map(str, q))})\n" for q in quads)
                                + ")\n")
    (poly / "boundary").write_text(HEADER % ("polyBoundaryMesh", "boundary")
                                   + "1\n(\n    whale\n    {\n        type wall;\n"
                                   "        nFaces 6;\n        startFace 0;\n    }\n)\n")
    return pts, quads


def test_a_box_patch_has_the_boxs_area_and_volume(tmp_path):
    """2 x 1 x 0.5 m: area 2 (2 + 1 + 0.5) = 7 m2, volume 1 m3; the same box as an STL."""
    pts, quads = _box_polymesh(tmp_path)
    f = B.patch_figures(tmp_path)
    assert f["faces"] == 6
    assert f["area_m2"] == pytest.approx(7.0, rel=1e-12)
    assert f["volume_m3"] == pytest.approx(1.0, rel=1e-12)
    write_surface(tmp_path / "box.stl", pts, [np.array(quads)])
    s = B.stl_figures(tmp_path / "box.stl")
    assert s["area_m2"] == pytest.approx(7.0, rel=1e-6)      # STL: single precision
    assert s["volume_m3"] == pytest.approx(1.0, rel=1e-6)
    with pytest.raises(MeshError, match="the mesh has no hull patch"):
        B.patch_figures(tmp_path, "hull")


MISSED = """Determining initial surface intersections
-----------------------------------------

Edge intersection testing:
    Number of edges             : 61820
    Number of edges to retest   : 0
    Number of intersected edges : 0
Edge intersection testing:
    Number of edges             : 61820
    Number of edges to retest   : 61820
    Number of intersected edges : 0
Calculated surface intersections in = 0.03 s
"""


def test_the_initial_intersections_are_read_from_the_log():
    assert B.initial_intersections("Create time\n" + MISSED + "Number of intersected edges : "
                                   "92\n") == 0
    cut = MISSED.replace("retest   : 61820\n    Number of intersected edges : 0",
                         "retest   : 61820\n    Number of intersected edges : 16")
    assert B.initial_intersections(cut) == 16
    assert B.initial_intersections("no such section") is None


# --- on OpenFOAM: meshing only ---------------------------------------------------------------

LENGTH = 4.4
RATIO = 0.12          # diameter / length


def _slender_scene(folder: Path, case_lines: str = ""):
    """The issue's slender closed body of revolution, a prolate spheroid 4.4 m long and
    0.528 m across, as an STL with landmarks, on the default preset (background cell 0.133 L
    = 0.59 m, more than its diameter)."""
    r = 0.5 * RATIO * LENGTH
    u = np.linspace(0.0, np.pi, 61)[1:-1]
    x = 0.5 * LENGTH * (1 - np.cos(u))
    radius = r * np.sqrt(np.clip(1 - (2 * x / LENGTH - 1) ** 2, 0, None))
    th = np.linspace(0, 2 * np.pi, 24, endpoint=False)
    rings = np.array([[xi, ri * np.cos(t), ri * np.sin(t)] for xi, ri in zip(x, radius, strict=True)
                      for t in th])
    pts = np.vstack([[0.0, 0.0, 0.0], rings, [LENGTH, 0.0, 0.0]])
    nt, n, last = len(th), len(x), len(rings) + 1

    def ring(i, j):
        return 1 + i * nt + j % nt

    tri = [[0, ring(0, j + 1), ring(0, j)] for j in range(nt)]
    for i in range(n - 1):
        for j in range(nt):
            tri += [[ring(i, j), ring(i, j + 1), ring(i + 1, j + 1)],
                    [ring(i, j), ring(i + 1, j + 1), ring(i + 1, j)]]
    tri += [[last, ring(n - 1, j), ring(n - 1, j + 1)] for j in range(nt)]
    folder.mkdir(parents=True, exist_ok=True)
    write_surface(folder / "slender.stl", pts, [np.array(tri)])

    def near(*p):
        return pts[np.argmin(np.linalg.norm(pts - np.array(p), axis=1))].tolist()

    marks = {"rostrum": pts[0].tolist(), "flipper_left": near(0.3 * LENGTH, r, 0),
             "flipper_right": near(0.3 * LENGTH, -r, 0), "tail_base": near(0.92 * LENGTH, 0, r),
             "fluke_tip_left": near(0.99 * LENGTH, r, 0),
             "fluke_tip_right": near(0.99 * LENGTH, -r, 0)}
    path = folder / "slender.toml"
    path.write_text('preset = "default"\n[geometry]\nsource = "slender.stl"\n'
                    f"length_m = {LENGTH}\n[geometry.landmarks]\n"
                    + "".join(f"{k} = {v!r}\n" for k, v in marks.items())
                    + f"[case]\n{case_lines}")
    return load_scene(path), path


@pytest.mark.openfoam
def test_a_mesh_that_misses_the_slender_body_is_refused_before_the_solver(tmp_path):
    """No background edge cuts the body: refused by mesh_case, naming the cause and the
    setting (case.background_cell at most 0.528 / sqrt 2 / 4.4 = 0.0849 -> 0.084), recorded,
    and refused again by run_case before pimpleFoam or the step-server starts."""
    scene, path = _slender_scene(tmp_path)
    case = tmp_path / "case"
    C.prepare_case(scene, case, static_whale=True, scene_file=path)
    with pytest.raises(MeshError) as err:
        M.mesh_case(case)
    message = str(err.value)
    assert "\n" not in message
    assert message.startswith("the mesh misses the body: no edge of the ")
    assert "(it is 0.528 m thick)" in message
    assert "set case.background_cell to at most 0.084 (body lengths" in message
    check = C.read_record(case)["mesh"]["body_check"]
    assert check["refused"] == message and check["initial_intersected_edges"] == 0
    assert check["faces"] < check["faces_implied"]
    with pytest.raises(MeshError, match="the mesh misses the body"):
        R.run_case(case, progress=False)
    assert not (case / "log.pimpleFoam").exists()


@pytest.mark.openfoam
def test_the_slender_body_meshed_on_cells_it_suggests_is_accepted(tmp_path):
    """The suggested background cell (a small domain around the body, to mesh in seconds):
    refined at the surface, the patch's area and volume within a few % of the spheroid's."""
    scene, path = _slender_scene(tmp_path, "background_cell = 0.084\nupstream = 0.3\n"
                                 "downstream = 0.3\nhalf_width = 0.3\n")
    case = tmp_path / "case"
    C.prepare_case(scene, case, static_whale=True, scene_file=path)
    info = M.mesh_case(case)
    check = info["body_check"]
    assert check["refused"] is None, check
    assert check["initial_intersected_edges"] > 0
    assert check["faces"] >= check["faces_implied"]
    # the prolate spheroid's own volume, 4/3 pi a b^2 with a = L / 2, b = 0.06 L, its
    # sections 24-gons: n sin(2 pi / n) / (2 pi) of the circle's area
    spheroid = 4 / 3 * math.pi * (LENGTH / 2) * (0.5 * RATIO * LENGTH) ** 2
    polygon = 24 * math.sin(2 * math.pi / 24) / (2 * math.pi)
    assert check["stl_volume_m3"] == pytest.approx(spheroid * polygon, rel=0.002)
    assert abs(check["volume_ratio"] - 1) < 0.1 and abs(check["area_ratio"] - 1) < 0.1


@pytest.mark.openfoam
def test_the_smoke_whale_is_accepted_and_a_mangled_one_refused(tmp_path):
    """The smoke whale passes; against a surface 1.5 times larger (area x 2.25, volume x 3.375:
    the same mesh now misses most of it) the check refuses it naming the area; with prism
    layers asked for and on 30 % of the area, naming the layers."""
    case = tmp_path / "case"
    scene = load_scene(preset="smoke")
    C.prepare_case(scene, case, static_whale=True)
    check = M.mesh_case(case)["body_check"]
    assert check["refused"] is None, check
    record = C.read_record(case)
    stl = case / "constant" / "triSurface" / "whale.stl"
    original = stl.read_bytes()
    from adapter.body.meshfile import read_surface

    pts, faces = read_surface(stl)
    write_surface(stl, 1.5 * pts, faces)
    big = B.body_check(case, record)
    assert big["area_ratio"] == pytest.approx(check["area_ratio"] / 2.25, rel=1e-6)
    assert big["volume_ratio"] == pytest.approx(check["volume_ratio"] / 3.375, rel=1e-6)
    assert big["refused"].startswith("the mesh mangles the body: the whale patch's area is ")
    assert "raise case.refinement" in big["refused"]
    stl.write_bytes(original)
    snappy = case / "system" / "snappyHexMeshDict"
    text = snappy.read_text()
    snappy.write_text(re.sub(r"\blayers\s*\{\s*\}", "layers { whale { nSurfaceLayers 3; } }",
                             text.replace("addLayers no;", "addLayers yes;")))
    assert B.mesh_levels(case) == {"level": [1, 2], "layers": 3}
    thin = B.body_check(case, record, {"area_with_layers": 0.3})
    assert thin["refused"].startswith("the mesh mangles the body's wall: prism layers on 30% "
                                      "of the whale's area (case.layers = 3")
    json.dumps(check, allow_nan=False)
