"""The OpenFOAM case meshed and run: the smoke mesh, finer cells at the flippers and flukes, a
static run, a body of another length, the motion check stopping a run before the mesh inverts.

Tests marked ``openfoam`` run the real blockMesh/snappyHexMesh/checkMesh/pimpleFoam and are
skipped without them. None of them needs the step-server: the runs here use
``static_whale=True`` (tests/test_coupled.py covers the coupled run); one needs the plugin's
mesh motion (its check stopping a run before the mesh inverts).
"""

from __future__ import annotations

import json
import math
import shutil

import numpy as np
import pytest
from PyFoam.Basics.DataStructures import Field, Vector
from PyFoam.RunDictionary.ParsedParameterFile import ParsedParameterFile

from adapter.body import meshfile
from adapter.body.geometry import build_surface
from adapter.errors import AdapterError, SolverRunError
from adapter.foam import case as C
from adapter.foam import foamascii as FA
from adapter.foam import folders as F
from adapter.foam import mesh as M
from adapter.foam import parameters as P
from adapter.foam import run as R
from adapter.foam import summary as S
from adapter.scene import load_scene


@pytest.fixture(scope="module")
def smoke():
    return load_scene(preset="smoke")


@pytest.fixture(scope="module")
def smoke_surface(smoke):
    return build_surface(smoke)


# --- with OpenFOAM ------------------------------------------------------------------------


@pytest.fixture(scope="module")
def smoke_mesh(tmp_path_factory, smoke, smoke_surface):
    """A meshed smoke case with a static whale, shared by the tests below (copy before use)."""
    case = tmp_path_factory.mktemp("smoke") / "case"
    C.prepare_case(smoke, case, surface=smoke_surface, static_whale=True)
    info = M.mesh_case(case)
    return case, info


@pytest.mark.openfoam
def test_smoke_mesh_has_a_whale_patch(smoke_mesh):
    case, info = smoke_mesh
    assert 1000 < info["cells"] < 20000
    assert info["whale_faces"] > 50
    assert info["max_non_orthogonality"] < 70
    boundary = (case / "constant" / "polyMesh" / "boundary").read_text()
    assert "whale" in boundary
    for name in ("blockMesh", "snappyHexMesh", "checkMesh"):
        assert (case / f"log.{name}").is_file()
    assert (case / "0" / "U").is_file()


def _whale_faces(case):
    """Centres and areas of the whale patch's faces."""
    mesh = case / "constant" / "polyMesh"
    pts = FA.read_points(mesh / "points")
    patch = FA.read_boundary(mesh / "boundary")["whale"]
    faces = FA.read_faces(mesh / "faces")[patch["startFace"]:][:patch["nFaces"]]
    centres = np.array([pts[f].mean(axis=0) for f in faces])
    return centres, np.linalg.norm(FA.face_area_vectors(pts, faces), axis=1)


@pytest.mark.openfoam
@pytest.mark.parametrize("key, stl, solid", [("flipper_level", C.FLIPPERS_STL, "flippers"),
                                             ("fluke_level", C.FLUKE_BLADE_STL, "flukeBlade")])
def test_the_flippers_and_flukes_get_finer_cells(tmp_path, smoke, smoke_surface, smoke_mesh,
                                                 key, stl, solid):
    """case.flipper_level (fluke_level) one above the smoke surface's finest level (2): each
    level halves a cell's edge, so the whale's faces on the flippers shrink to about a quarter
    of their area on the same smoke mesh without it; the flukes' blade (at most 0.31 m thick),
    which the plain smoke mesh's 1 m faces miss altogether, gets faces. Faces beyond the
    refinement's buffer (3 cells of level 2 around the level-3 cells, snappyHexMesh's
    nCellsBetweenLevels) keep their size."""
    from scipy.spatial import cKDTree

    plain, _ = smoke_mesh
    case = tmp_path / "case"
    # (half a level-3 cell of clearance: the smoke flukes are 1.8 m long, the cells 0.49 m)
    C.prepare_case(smoke.replace(case={key: 3, "fluke_clearance": 0.5}), case,
                   surface=smoke_surface, static_whale=True)
    M.mesh_case(case)
    region = meshfile.read_stl_solids(case / "constant" / "triSurface" / stl)
    # points all over the region's triangles (vertices, edge midpoints, centroid): distances
    # to its surface, not to its vertices alone
    tri = region[solid]
    weights = np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1], [.5, .5, 0], [0, .5, .5], [.5, 0, .5],
                        [1 / 3, 1 / 3, 1 / 3]])
    near = cKDTree(np.einsum("sk,tkd->tsd", weights, tri).reshape(-1, 3))
    cell = min(C.read_record(case)["parameters"]["cell_size"])   # level 0
    on, far = {}, {}
    for name, folder in (("fine", case), ("plain", plain)):
        centres, areas = _whale_faces(folder)
        distance = near.query(centres)[0]
        on[name] = areas[distance < cell / 2**3]
        far[name] = np.median(areas[distance > 3 * cell / 2**2 + cell / 2**2])
    if key == "flipper_level":
        assert np.median(on["fine"]) < 0.4 * np.median(on["plain"])
    else:   # no face of the plain mesh on the blade; the fine ones smaller than level 2's
        assert on["plain"].size == 0 and on["fine"].size >= 20
        assert np.median(on["fine"]) < 0.4 * (cell / 2**2) ** 2
    assert far["fine"] == pytest.approx(far["plain"], rel=0.02)


@pytest.mark.openfoam
def test_mesh_failure_names_the_log(tmp_path, smoke, smoke_surface):
    case = tmp_path / "case"
    C.prepare_case(smoke, case, surface=smoke_surface, static_whale=True)
    (case / "system" / "blockMeshDict").write_text("FoamFile { class dictionary; }\nbroken\n")
    with pytest.raises(SolverRunError, match="log.blockMesh"):
        M.mesh_case(case)


@pytest.mark.openfoam
@pytest.mark.slow
def test_static_smoke_run(tmp_path, smoke_mesh):
    src, _ = smoke_mesh
    case = tmp_path / "case"
    shutil.copytree(src, case)
    summary = R.run_case(case, progress=False)
    record = C.read_record(case)
    assert summary["steps"] == record["parameters"]["n_steps"]
    assert summary["end_time_s"] == pytest.approx(record["parameters"]["end_time"], rel=1e-9)
    assert math.isfinite(summary["drag_N"]) and summary["drag_N"] > 0
    # a static mesh (staticFvMesh) is neither moved nor checked during the run: the mesh's
    # own figures only, from checkMesh before it
    worst = summary["worst_cell_quality"]
    assert worst["max_non_orthogonality_deg"] is None and worst["min_cell_volume_m3"] is None
    assert worst["initial_max_non_orthogonality_deg"] < 70
    assert json.loads((case / S.SUMMARY).read_text()) == summary
    assert (case / "case.foam").exists()
    written = [t for t, _ in F.time_dirs(case)]
    assert len(written) == 1 + record["parameters"]["n_steps"] // \
        record["parameters"]["steps_per_write"]


# --- other animals: a body of another length ----------------------------------------------

DOLPHIN_M = 2.5


def _scaled_scene(tmp_path, surface, length_m):
    """A scene on the smoke preset whose body is the smoke whale scaled to 2.5 m (rostrum to
    the farthest x: a mesh file's length), as an STL."""
    pts = surface.points - surface.points[surface.landmarks["rostrum"]]
    pts = pts * (DOLPHIN_M / pts[:, 0].max())
    from adapter.body.meshfile import write_surface

    write_surface(tmp_path / "dolphin.stl", pts, surface.faces)
    marks = "\n".join(f"{name} = [{float(p[0])!r}, {float(p[1])!r}, {float(p[2])!r}]"
                      for name, p in ((n, pts[i]) for n, i in surface.landmarks.items()))
    path = tmp_path / "dolphin.toml"
    path.write_text(f'preset = "smoke"\n[geometry]\nsource = "dolphin.stl"\n'
                    f"length_m = {length_m}\n[geometry.landmarks]\n{marks}\n")
    return load_scene(path)


def test_a_mesh_file_of_another_length_is_refused_naming_both(tmp_path, smoke_surface):
    scene = _scaled_scene(tmp_path, smoke_surface, 15.0)
    with pytest.raises(AdapterError, match=r"is 2\.5 m long .* geometry\.length_m = 15 m"):
        C.prepare_case(scene, tmp_path / "case", static_whale=True)
    assert not (tmp_path / "case").exists()


def test_cell_sizes_follow_the_body_length(tmp_path, smoke, smoke_surface):
    from adapter.body.geometry import build_surface

    scene = _scaled_scene(tmp_path, smoke_surface, DOLPHIN_M)
    surface = build_surface(scene)
    assert surface.length == pytest.approx(DOLPHIN_M)
    pts = surface.points
    p = P.case_parameters(scene, pts.min(axis=0), pts.max(axis=0), length=surface.length)
    whale = P.case_parameters(smoke, smoke_surface.points.min(axis=0),
                              smoke_surface.points.max(axis=0), length=smoke_surface.length)
    # about the same mesh, scaled (the procedural whale's L = 15 m leaves out the flukes'
    # overhang; a mesh file's length is rostrum to the farthest x)
    assert np.abs(np.array(p.cells) - whale.cells).max() <= 2
    assert p.smallest_cell_m == pytest.approx(whale.smallest_cell_m * DOLPHIN_M / 15.0,
                                              rel=0.1)
    # the older key, in metres, still wins when set
    metres = scene.replace(case={"background_cell_m": 4.0})
    assert P.case_parameters(metres, pts.min(axis=0), pts.max(axis=0),
                             length=surface.length).smallest_cell_m == pytest.approx(1.0, rel=0.1)


@pytest.mark.openfoam
@pytest.mark.slow
def test_a_smaller_animal_meshes_and_runs_on_the_smoke_preset(tmp_path, smoke_surface):
    """A 2.5 m closed mesh on the smoke preset: cells scale with the body, so it meshes with a
    whale patch like the 15 m whale's, and a static run goes to the end."""
    scene = _scaled_scene(tmp_path, smoke_surface, DOLPHIN_M)
    case = tmp_path / "case"
    params = C.prepare_case(scene, case, static_whale=True, scene_file=tmp_path / "dolphin.toml")
    assert params.smallest_cell_m < 0.2
    assert params.domain_max[0] - params.domain_min[0] == pytest.approx(
        (1 + scene.case.upstream + scene.case.downstream) * DOLPHIN_M, rel=0.05)
    info = M.mesh_case(case)
    assert info["whale_faces"] > 50
    summary = R.run_case(case, progress=False)
    assert summary["steps"] == C.read_record(case)["parameters"]["n_steps"]


@pytest.mark.openfoam
@pytest.mark.slow
@pytest.mark.plugin
def test_run_case_stops_before_the_mesh_inverts(tmp_path, smoke_mesh):
    src, _ = smoke_mesh
    case = tmp_path / "case"
    shutil.copytree(src, case)
    # the whale lifted at 30 m/s by OpenFOAM's oscillatingDisplacement (omega 1: 30 sin t m, no
    # step-server): the blended mesh between the whale and outerDistance (10 m) folds at step 4
    # (5.7 m), before the first write after 0 (every 4 steps)
    for folder in ("0", "0.orig"):
        d = ParsedParameterFile(str(case / folder / "pointDisplacement"))
        d["boundaryField"]["whale"] = {"type": "oscillatingDisplacement",
                                       "amplitude": Vector(0, 0, 30), "omega": 1,
                                       "value": Field(Vector(0, 0, 0))}
        d.writeFile()
    control = ParsedParameterFile(str(case / "system" / "controlDict"))
    control["libs"] = ['"libfvMotionSolvers.so"', *control["libs"]]
    control.writeFile()
    # the smoke mesh is a static whale's (staticFvMesh): made a moving mesh again
    dynamic = ParsedParameterFile(str(case / "constant" / "dynamicMeshDict"))
    dynamic["dynamicFvMesh"] = "dynamicMotionSolverFvMesh"
    dynamic.writeFile()
    assert "checkMotion yes" in (case / "constant" / "dynamicMeshDict").read_text()
    dt = C.read_record(case)["parameters"]["delta_t"]
    with pytest.raises(SolverRunError) as err:
        R.run_case(case, progress=False)
    message = str(err.value)
    stopped = (f"mesh watch: the mesh at t = {4 * dt:.12g} s would be invalid (cell volumes: ")
    assert message.startswith(stopped)
    assert "; stopped before moving it; the last written time 0 s is valid; see " in message
    assert "What to do: " in message and "fluke_angle_scale" in message
    assert "centre at (" in message                        # OpenFOAM's message, the places
    summary = json.loads((case / S.SUMMARY).read_text())
    assert summary["stopped"].startswith(stopped)
    assert summary["stopped"] in message
    assert summary["steps"] == 3 and summary["end_time_s"] == pytest.approx(3 * dt)
    assert [t for t, _ in F.time_dirs(case)] == [0]      # nothing invalid written
