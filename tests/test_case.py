"""The OpenFOAM case: numbers, dictionaries, log parsing, reruns and refusals, the summary
table; no OpenFOAM but a rerun of the smoke preset (meshing and runs: tests/test_case_mesh.py).
"""

from __future__ import annotations

import io
import json
import shutil
from pathlib import Path

import meshio
import numpy as np
import pytest
from PyFoam.RunDictionary.ParsedParameterFile import ParsedParameterFile

from adapter.body.geometry import build_surface
from adapter.errors import AdapterError
from adapter.foam import case as C
from adapter.foam import logs as LG
from adapter.foam import parameters as P
from adapter.foam import run as R
from adapter.foam import summary as S
from adapter.foam.outcome import RunOutcome, Stop
from adapter.foam.swimrun import prepare_gliding
from adapter.scene import load_scene


@pytest.fixture(scope="module")
def smoke():
    return load_scene(preset="smoke")


@pytest.fixture(scope="module")
def smoke_surface(smoke):
    return build_surface(smoke)


def _read(path):
    return ParsedParameterFile(str(path))


# --- the numbers --------------------------------------------------------------------------


def test_parameters_domain_and_cells():
    scene = load_scene(preset="default")
    lo, hi = np.array([0.0, -2.4, -1.6]), np.array([15.6, 2.4, 1.6])
    p = P.case_parameters(scene, lo, hi)
    L, c = scene.geometry.length_m, scene.case
    assert p.domain_min[0] == pytest.approx(-c.upstream * L)
    assert p.domain_max[0] == pytest.approx(15.6 + c.downstream * L)
    assert p.domain_max[1] - p.domain_min[1] == pytest.approx(2 * c.half_width * L)
    assert p.domain_min[2] + p.domain_max[2] == pytest.approx(0.0)
    for n, size, a, b in zip(p.cells, p.cell_size, p.domain_min, p.domain_max, strict=True):
        assert n * size == pytest.approx(b - a)
        assert abs(size - c.background_cell * L) < 0.1 * c.background_cell * L
    assert p.smallest_cell_m == pytest.approx(min(p.cell_size) / 2 ** c.refinement[1])
    # the flippers' cells: a level finer than the surface's finest (and 0 for none)
    assert c.flipper_level == c.refinement[1] + 1
    assert p.flipper_cell_m == pytest.approx(min(p.cell_size) / 2 ** c.flipper_level)
    assert P.case_parameters(scene.replace(case={"flipper_level": 0}), lo, hi).flipper_cell_m \
        == 0.0
    # the same at the flukes' blade
    assert p.fluke_cell_m == pytest.approx(min(p.cell_size) / 2 ** c.fluke_level)
    assert P.case_parameters(scene.replace(case={"fluke_level": 0}), lo, hi).fluke_cell_m == 0.0
    # the point snappyHexMesh keeps lies in the water: in the box, upstream of the whale
    assert p.domain_min[0] < p.location_in_mesh[0] < lo[0]
    assert p.ranks == c.ranks


def test_parameters_time_step_and_writes():
    scene = load_scene(preset="default").replace(case={"dt_s": 0.0})   # the automatic step
    p = P.case_parameters(scene, [0, -2, -2], [15, 2, 2])
    write_interval = scene.period_s / scene.case.writes_per_cycle
    # Courant-based step, rounded down to a whole fraction of the write interval, then to a
    # binary fraction (exact sums and time names)
    assert p.delta_t <= 0.5 * p.smallest_cell_m / scene.flow.speed_m_s * (1 + 1e-12)
    assert p.delta_t * p.steps_per_write == pytest.approx(write_interval, rel=0.02)
    assert p.delta_t * p.steps_per_write <= write_interval
    k = p.time_precision - 5
    assert (p.delta_t * 2**k).is_integer()
    # the end: whole write intervals, at most a tenth of one short of the cycles asked for
    asked = scene.case.cycles * scene.period_s
    assert asked - 0.1 * write_interval <= p.end_time <= asked + write_interval
    assert p.n_steps % p.steps_per_write == 0
    assert p.end_time == sum([p.delta_t] * p.n_steps)  # OpenFOAM's running sum, exactly
    assert float(format(p.end_time, f".{p.time_precision}g")) == p.end_time
    # k = 1.5 (I U)^2, omega = k / (10 nu)
    assert p.k_inlet == pytest.approx(1.5 * (0.01 * scene.flow.speed_m_s) ** 2)
    assert p.omega_inlet == pytest.approx(p.k_inlet / (10 * scene.flow.nu_m2_s))


def test_parameters_explicit_step_end_time_and_ranks():
    scene = load_scene(preset="default").replace(case={"dt_s": 0.05, "end_time_s": 1.0})
    p = P.case_parameters(scene, [0, -2, -2], [15, 2, 2], ranks=3)
    assert p.delta_t <= 0.05
    assert p.delta_t > 0.045
    # the end is rounded to whole write intervals so that the run ends on a written time
    interval = p.delta_t * p.steps_per_write
    assert 1.0 - 0.1 * interval <= p.end_time < 1.0 + interval
    assert p.ranks == 3


def test_prepare_case_mesh_motion_laplacian(tmp_path, smoke, smoke_surface):
    scene = smoke.replace(case={"mesh_motion": "laplacian"})
    C.prepare_case(scene, tmp_path / "c", surface=smoke_surface)
    dyn = _read(tmp_path / "c" / "constant" / "dynamicMeshDict")
    assert dyn["motionSolver"] == "displacementLaplacian"
    assert "libfvMotionSolvers.so" in str(dyn["motionSolverLibs"])
    # no check of its own: OpenFOAM's (polyMesh debug) reports every moved mesh to the watch
    assert R.solver_command(tmp_path / "c")[1:3] == ["-debug-switch", "polyMesh=1"]


def test_the_layer_stages_non_orthogonality_limit_is_the_scenes(tmp_path, smoke, smoke_surface):
    C.prepare_case(smoke.replace(case={"layer_non_orthogonality": 61.5}), tmp_path / "c",
                   surface=smoke_surface)
    text = (tmp_path / "c" / "system" / "meshQualityDict").read_text()
    relaxed = text[text.index("relaxed"):]
    assert "maxNonOrtho     61.5;" in relaxed.split("}")[0]
    assert '#includeEtc "caseDicts/mesh/generation/meshQualityDict.cfg"' in text


def test_the_blended_motion_runs_without_openfoams_second_check(tmp_path, smoke, smoke_surface):
    C.prepare_case(smoke, tmp_path / "c", surface=smoke_surface)
    assert R.motion_checks_itself(tmp_path / "c")
    assert R.solver_command(tmp_path / "c") == ["pimpleFoam", "-opt-switch",
                                                f"stopAtWriteNowSignal={int(R.STOP_SIGNAL)}"]
    dyn = tmp_path / "c" / "constant" / "dynamicMeshDict"
    dyn.write_text(dyn.read_text().replace("checkMotion yes", "checkMotion no"))
    assert "-debug-switch" in R.solver_command(tmp_path / "c")


def test_a_static_whale_is_on_a_static_mesh_as_the_gliding_run(tmp_path, smoke, smoke_surface):
    # --static-whale: neither moved nor checked every step (pimpleFoam builds a staticFvMesh),
    # with either mesh motion's entries left unread, and no polyMesh debug switch for the watch
    for motion in ("blended", "laplacian"):
        case = tmp_path / motion
        C.prepare_case(smoke.replace(case={"mesh_motion": motion}), case,
                       surface=smoke_surface, static_whale=True)
        assert _read(case / "constant" / "dynamicMeshDict")["dynamicFvMesh"] == "staticFvMesh"
        whale = _read(case / "0.orig" / "pointDisplacement")["boundaryField"]["whale"]
        assert whale["type"] == "fixedValue"
        assert R.solver_command(case) == ["pimpleFoam", "-opt-switch",
                                          f"stopAtWriteNowSignal={int(R.STOP_SIGNAL)}"]
    # the gliding copy of a coupled case is held still the same way
    C.prepare_case(smoke, tmp_path / "coupled", surface=smoke_surface)
    glide = prepare_gliding(tmp_path / "coupled")
    assert _read(glide / "constant" / "dynamicMeshDict")["dynamicFvMesh"] == "staticFvMesh"
    for zero in ("0", "0.orig"):
        assert _read(glide / zero / "pointDisplacement").content == \
            _read(tmp_path / "blended" / "0.orig" / "pointDisplacement").content


def test_log_watch_reads_the_blended_motions_figures():
    watch = LG.LogWatch(Path("unused"))
    for angle, vol in ((64.5, 2e-6), (63.0, 3e-6)):
        watch.feed(f"whaleBlendedDisplacement: the new mesh: Min volume = {vol}. Total volume ="
                   f" 1000. Mesh non-orthogonality Max: {angle} average: 9.1 (5 of 9 cells moved)")
    assert (watch.min_volume, watch.max_non_orth, watch.last_non_orth) == (2e-6, 64.5, 63.0)


def test_a_static_mesh_reports_no_motion_figures_not_nan(tmp_path):
    # a gliding run's log: steps, but no mesh motion and so no non-orthogonality line
    watch = LG.LogWatch(Path("unused"))
    for i in range(4):
        watch.feed(f"Time = {0.1 * (i + 1):g}")
        watch.feed(f"ExecutionTime = {0.5 * (i + 1):g} s  ClockTime = {i + 1} s")
    out = io.StringIO()
    LG.Progress(end_time=1.0, start_time=0.0, stream=out).show(watch, final=True)
    assert "static mesh" in out.getvalue() and "nan" not in out.getvalue()
    record = {"period_s": 1.0, "parameters": {"delta_t": 0.1}, "mesh": {"cells": 10}}
    summary = S.summarise(tmp_path, watch, record, ranks=1, flow_wall=2.0, wall=3.0)
    text = json.dumps(summary, allow_nan=False)  # strict JSON: raises on a NaN anywhere
    assert json.loads(text)["worst_cell_quality"]["max_non_orthogonality_deg"] is None
    assert summary["cpu_s_per_step"] == pytest.approx(0.5)


def test_smoke_preset_is_small(smoke, smoke_surface):
    pts = smoke_surface.points
    p = P.case_parameters(smoke, pts.min(0), pts.max(0))
    assert int(np.prod(p.cells)) < 5000
    assert p.n_steps <= 10
    assert p.n_steps // p.steps_per_write >= 2  # at least two written times (restart tests)


# --- the dictionaries ---------------------------------------------------------------------


def test_prepare_case_writes_readable_dictionaries(tmp_path, smoke, smoke_surface):
    case = tmp_path / "case"
    p = C.prepare_case(smoke, case, surface=smoke_surface)

    bm = _read(case / "system" / "blockMeshDict")
    for axis, lo, hi, n in zip("xyz", p.domain_min, p.domain_max, p.cells, strict=True):
        assert float(bm[f"{axis}min"]) == pytest.approx(lo)
        assert float(bm[f"{axis}max"]) == pytest.approx(hi)
        assert int(bm[f"n{axis}"]) == n

    cd = _read(case / "system" / "controlDict")
    assert float(cd["endTime"]) == p.end_time
    assert float(cd["deltaT"]) == p.delta_t
    assert int(cd["timePrecision"]) == p.time_precision
    assert int(cd["writeInterval"]) == p.steps_per_write
    assert cd["writeControl"] == "timeStep"
    assert str(C.PLUGIN_LIB) in str(cd["libs"])
    # the force is loads.dat's (whaleLoads); OpenFOAM's forces would compute it once more
    assert cd["functions"]["loads"]["patches"] == ["whale"]
    assert float(cd["functions"]["loads"]["rhoInf"]) == smoke.flow.rho_kg_m3
    assert "forces" not in cd["functions"]

    sh = _read(case / "system" / "snappyHexMeshDict")
    cm = sh["castellatedMeshControls"]
    assert list(cm["refinementSurfaces"]["whale"]["level"]) == list(smoke.case.refinement)
    assert [float(v) for v in cm["locationInMesh"]] == pytest.approx(p.location_in_mesh)
    assert sh["addLayers"] in (False, "false")
    # no flipper refinement in the smoke preset: neither the region nor its surface
    assert smoke.case.flipper_level == 0 and smoke.case.fluke_level == 0
    assert "flippers" not in cm["refinementRegions"] and "flippers.stl" not in sh["geometry"]
    assert "flukeBlade" not in cm["refinementRegions"] and "flukeBlade.stl" not in sh["geometry"]
    assert not (case / "constant" / "triSurface" / C.FLUKE_BLADE_STL).exists()

    dp = _read(case / "system" / "decomposeParDict")
    assert int(dp["numberOfSubdomains"]) == 1
    assert dp["method"] == "hierarchical"

    assert float(_read(case / "constant" / "transportProperties")["nu"]) == smoke.flow.nu_m2_s
    assert _read(case / "constant" / "turbulenceProperties")["simulationType"] == "laminar"
    dyn = _read(case / "constant" / "dynamicMeshDict")
    assert dyn["motionSolver"] == "whaleBlendedDisplacement"
    assert str(C.PLUGIN_LIB) in str(dyn["motionSolverLibs"])
    coeffs = dyn["whaleBlendedDisplacementCoeffs"]
    assert float(coeffs["innerDistance"]) == pytest.approx(p.motion_inner_m)
    assert float(coeffs["outerDistance"]) == pytest.approx(p.motion_outer_m)
    # the outer boundaries stay put: the blending ends inside the domain (the near box is the
    # body's bounding box grown on every side)
    gap = min(min(np.subtract(p.near_box_min, p.domain_min)),
              min(np.subtract(p.domain_max, p.near_box_max)))
    assert 0 < p.motion_inner_m < p.motion_outer_m
    assert p.motion_outer_m < gap + 0.5 * (np.subtract(p.near_box_max, p.near_box_min)).min()

    u = _read(case / "0.orig" / "U")
    assert [float(v) for v in u["Uinlet"]] == [smoke.flow.speed_m_s, 0.0, 0.0]
    assert float(_read(case / "0.orig" / "k")["kInlet"]) == pytest.approx(p.k_inlet)
    assert float(_read(case / "0.orig" / "omega")["omegaInlet"]) == pytest.approx(p.omega_inlet)
    whale = _read(case / "0.orig" / "pointDisplacement")["boundaryField"]["whale"]
    assert whale["type"] == "stepServerDisplacement"
    # the rendezvous is the server's endpoint file (the default); never a token in the case
    assert not {"socket", "port", "host", "token"} & set(whale)

    stl = meshio.read(case / "constant" / "triSurface" / "whale.stl")
    assert len(stl.points) > 0
    assert np.allclose(stl.points.min(0), smoke_surface.points.min(0), atol=1e-5)

    record = json.loads((case / C.CASE_RECORD).read_text())
    assert record["preset"] == "smoke"
    assert record["parameters"]["n_steps"] == p.n_steps


@pytest.mark.slow
def test_prepare_case_default_is_turbulent_and_static_option(tmp_path, smoke_surface,
                                                             monkeypatch):
    scene = load_scene(preset="default")
    case = tmp_path / "case"
    # without the plugin library a static whale needs no library (and gets no loads)
    monkeypatch.setenv("WHALE_PLUGIN_LIB", str(tmp_path / "absent.so"))
    C.prepare_case(scene, case, surface=smoke_surface, static_whale=True, ranks=2)
    # the flippers' refinement region: cells within one cell of flipper_level of the flippers
    p = json.loads((case / C.CASE_RECORD).read_text())["parameters"]
    cm = _read(case / "system" / "snappyHexMeshDict")["castellatedMeshControls"]
    geometry = _read(case / "system" / "snappyHexMeshDict")["geometry"]
    # and the flukes' blade's, fluke_level
    for name, key, stl in (("flippers", "flipper_level", C.FLIPPERS_STL),
                           ("flukeBlade", "fluke_level", C.FLUKE_BLADE_STL)):
        region = cm["refinementRegions"][name]
        assert region["mode"] == "distance"
        (distance, level), = region["levels"]
        assert level == getattr(scene.case, key)
        assert distance == pytest.approx(min(p["cell_size"]) / 2 ** level)
        assert geometry[stl]["name"] == name
        assert (case / "constant" / "triSurface" / stl).is_file()
    # the blade begins fluke_clearance of its cells behind the tail base
    smoke_surface.write_fluke_blade_stl(tmp_path / "blade.stl",
                                        scene.case.fluke_clearance * distance)
    assert (tmp_path / "blade.stl").read_bytes() == \
        (case / "constant" / "triSurface" / C.FLUKE_BLADE_STL).read_bytes()
    tp = _read(case / "constant" / "turbulenceProperties")
    assert tp["simulationType"] == "RAS"
    assert tp["RAS"]["RASModel"] == "kOmegaSST"
    assert _read(case / "0.orig" / "pointDisplacement")["boundaryField"]["whale"]["type"] \
        == "fixedValue"
    control = _read(case / "system" / "controlDict")
    assert "libs" not in control and "loads" not in control["functions"]
    # ... and OpenFOAM's forces in its place: the drag still has its force.dat
    forces = control["functions"]["forces"]
    assert forces["type"] == "forces" and forces["patches"] == ["whale"]
    assert float(forces["rhoInf"]) == scene.flow.rho_kg_m3
    # with it, the static whale keeps the library for its loads function object
    lib = tmp_path / "lib.so"
    lib.write_bytes(b"")
    monkeypatch.setenv("WHALE_PLUGIN_LIB", str(lib))
    C.prepare_case(scene, tmp_path / "case2", surface=smoke_surface, static_whale=True)
    control = _read(tmp_path / "case2" / "system" / "controlDict")
    assert str(lib) in str(control["libs"]) and control["functions"]["loads"]["type"] \
        == "whaleLoads"
    dp = _read(case / "system" / "decomposeParDict")
    assert int(dp["numberOfSubdomains"]) == 2
    assert list(dp["coeffs"]["n"]) == [2, 1, 1]


def test_prepare_case_refuses_an_existing_case(tmp_path, smoke, smoke_surface):
    C.prepare_case(smoke, tmp_path / "case", surface=smoke_surface)
    with pytest.raises(AdapterError, match="already holds a case"):
        C.prepare_case(smoke, tmp_path / "case", surface=smoke_surface)


# --- parsing logs and outputs -------------------------------------------------------------

_SOLVER_LOG = """\
Time = 0.192

PIMPLE: iteration 1
GAMG:  Solving for cellDisplacementx, Initial residual = 0, Final residual = 0, No Iterations 0
bool polyMesh::checkMeshMotion(const pointField&, const bool, const bool) const: checking
    Min volume = 0.00332646760493572. Max volume = 7.767.  Total volume = 166995.  Cell volumes OK.
    Mesh non-orthogonality Max: 56.8464626881224 average: 7.72095115634614
stepServer: 4 requests, mean 21306.4 us per exchange
ExecutionTime = 1.36 s  ClockTime = 2 s

Courant Number mean: 0.0637 max: 1.4357
Time = 0.288

[0] bool polyMesh::checkMeshMotion(const pointField&, const bool, const bool) const: checking
    Min volume = 1e-05. Max volume = 7.7.  Total volume = 166995.3.  Cell volumes OK.
 ***Error in face pyramids: 1 faces are incorrectly oriented.
    Mesh non-orthogonality Max: 79.5 average: 7.8
stepServer: 8 requests, mean 13250.6 us per exchange
ExecutionTime = 2.5 s  ClockTime = 3 s
"""


def test_log_watch_parses_a_solver_log(tmp_path):
    log = tmp_path / "log.pimpleFoam"
    half = len(_SOLVER_LOG) // 2
    log.write_text(_SOLVER_LOG[:half])
    watch = LG.LogWatch(log)
    watch.poll()
    log.write_text(_SOLVER_LOG)  # the log grew, a line was cut in the middle
    watch.poll()
    assert watch.times == [0.192, 0.288]
    assert watch.exec_times == [1.36, 2.5]
    assert watch.max_non_orth == 79.5
    assert watch.min_volume == 1e-05
    assert watch.max_courant == pytest.approx(1.4357)
    assert watch.plugin == (8, 13250.6)
    assert "face pyramids" in watch.broken


def test_read_forces_merges_restarts(tmp_path):
    base = tmp_path / "postProcessing" / "forces"
    header = ("# Forces\n# CofR                : (0 0 0)\n#\n# Time          total_x total_y "
              "total_z   pressure_x ...\n")
    (base / "0").mkdir(parents=True)
    (base / "0" / "force.dat").write_text(header + "".join(
        f"{t}\t({t} 0 1)\t({t - 1} 0 1)\t(1 0 0)\n" for t in (1, 2, 3)))
    (base / "2").mkdir()
    (base / "2" / "force.dat").write_text(header + "3\t(30 0 1e+02)\t(29 0 1)\t(1 0 0)\n")
    f = S.read_forces(tmp_path)
    assert f.shape == (3, 10)
    assert f[:, 0].tolist() == [1, 2, 3]
    assert f[2, 1] == 30 and f[2, 3] == 100


def test_read_forces_takes_the_loads_total_before_force_dat(tmp_path):
    # a case with both (run before the template dropped forces): loads.dat's total:F*
    test_read_forces_merges_restarts(tmp_path)
    names = [f"{g}:{c}" for g in ("total", "whale") for c in
             ("Fx", "Fy", "Fz", "Fpx", "Fpy", "Fpz", "Fvx", "Fvy", "Fvz", "P", "Pp", "Pv", "A")]
    (tmp_path / "postProcessing" / "loads" / "0").mkdir(parents=True)
    (tmp_path / "postProcessing" / "loads" / "0" / "loads.dat").write_text(
        "# Loads\n# Time " + " ".join(names) + "\n" + "".join(
            f"{t} " + " ".join(str(10 * t + k) for k in range(26)) + "\n" for t in (1, 2)))
    f = S.read_forces(tmp_path)
    assert f[:, 0].tolist() == [1, 2] and f[1].tolist() == [2, *range(20, 29)]


def test_parse_check_mesh():
    text = """
    cells:            36605
                   Patch    Faces   Points                  Surface topology
                   inlet      529      576  ok (non-closed singly connected)
                   whale     1853     2050      ok (closed singly connected)
    Mesh non-orthogonality Max: 56.8464626881224 average: 7.72
    Max skewness = 2.36 OK.
Mesh OK.
"""
    info = LG.parse_check_mesh(text)
    assert info == {"cells": 36605, "whale_faces": 1853, "whale_points": 2050,
                    "max_non_orthogonality": 56.8464626881224, "max_skewness": 2.36,
                    "mesh_ok": True}


# --- reruns, refusals, the summary table (issue 12) ---------------------------------------


def test_fatal_error_text_is_taken_from_the_log():
    log = """Time = 0.384

[1]
[1]
[1] --> FOAM FATAL ERROR:
[1] stepServer: REQUEST at time 0.384 s: the server closed the connection (did the server stop?)
[1] socket /tmp/x/.whale-adapter.sock
[1]
[1]     From function void Foam::stepServerClient::exchange()
[1]     in file stepServerClient.C at line 301.
[1]
FOAM parallel run exiting
"""
    assert LG.fatal_error(log) == ("stepServer: REQUEST at time 0.384 s: the server closed the "
                                  "connection (did the server stop?)\n"
                                  "socket /tmp/x/.whale-adapter.sock")
    assert LG.fatal_error("Time = 1\nExecutionTime = 2 s\n") is None


def test_the_motion_checks_fatal_error_is_recognised(tmp_path):
    log = "\n".join([
        "Time = 0.046875", "", "PIMPLE: iteration 1", "", "",
        "--> FOAM FATAL ERROR: ",
        "whaleBlendedDisplacement: the mesh at t = 0.046875 s would be invalid (face pyramids: "
        "2 faces incorrectly oriented); stopped before moving it",
        "    face pyramids: 2 faces incorrectly oriented: the worst -1.9e-06 m3 (pyramid volume),"
        " face centre at (-0.15 0.91 0.05) m",
        "The mesh of the latest written time, t = 0.03125 s, is valid: every mesh this run moved"
        " to passed this check (checkMesh -time 0.03125).", "",
        "    From function void Foam::meshMotionCheck::check(const Foam::pointField&)", ""])
    assert LG.motion_check_stop(LG.fatal_error(log)) == RunOutcome(
        Stop.MOTION_CHECK, "face pyramids: 2 faces incorrectly oriented", 0.046875)
    assert LG.motion_check_stop(LG.fatal_error(log.replace("would be", "will be"))) is None
    assert LG.motion_check_stop(None) is None
    # the step the check stopped in never ran: the run ends at the one before
    watch = LG.LogWatch(tmp_path / "log.pimpleFoam")
    for line in ("Time = 0.015625", "ExecutionTime = 0.02 s", "Time = 0.03125",
                 "ExecutionTime = 0.03 s", "Time = 0.046875"):
        watch.feed(line)
    watch.drop_unfinished_step()
    assert watch.times == [0.015625, 0.03125] and len(watch.seen) == 2
    watch.drop_unfinished_step()
    assert watch.times == [0.015625, 0.03125]


def test_format_summary_is_a_table_of_the_rows_present():
    summary = {"case": "/tmp/c", "preset": "smoke", "static_whale": False, "cells": 4303,
               "steps": 8, "end_time_s": 0.383, "adapter_s_per_step": 0.0125, "drag_N": None,
               "worst_cell_quality": {"max_non_orthogonality_deg": 57.84}}
    text = S.format_summary(summary)
    lines = text.splitlines()
    assert lines[0].split() == ["case", "/tmp/c"]
    assert any(line.split()[-2:] == ["4,303"] or line.endswith(" 4,303") for line in lines)
    assert "12.5 ms" in text and "57.8 deg" in text and "0.383 s" in text
    assert "drag" not in text                                   # None: left out
    assert not text.lstrip().startswith("{")                    # not JSON
    # data-driven: another row list
    assert S.format_summary({"x": 2.0}, rows=[("ex", "x", "{:.1f} m")]) == "ex  2.0 m"


def test_run_case_refuses_a_foreign_folder_before_meshing(tmp_path, capsys):
    from adapter.cli import main

    case = tmp_path / "foreign"
    shutil.copytree(C.TEMPLATE_DIR, case)        # a case folder, but not made by run-case
    assert main(["run-case", "--case", str(case)]) == 2
    err = capsys.readouterr().err
    assert "adapter-case.json is missing" in err and "another" in err
    assert not (case / "log.blockMesh").exists() and not (case / "constant" / "polyMesh").exists()


@pytest.mark.openfoam
@pytest.mark.slow
def test_run_case_twice_with_the_same_preset_continues(tmp_path, capsys):
    """What `make run-case SCENE=smoke CASE=DIR` does twice: the second run reuses the case;
    another preset is refused, naming both."""
    from adapter.cli import main

    case = tmp_path / "twice"
    args = ["run-case", "--preset", "smoke", "--static-whale", "--case", str(case)]
    assert main(args) == 0
    out = capsys.readouterr().out
    # the summary table; a static mesh has only its figures before the run (checkMesh)
    assert "before motion" in out and "mean drag" in out and not out.rstrip().endswith("}")
    end = C.read_record(case)["parameters"]["end_time"]
    assert main(args) == 0
    out = capsys.readouterr().out
    # finished: it says so, and does not say it continues
    assert f"{case} already holds a finished case (preset smoke, static whale): it reached " \
           f"its end time ({end:.6g} s), nothing to run" in out
    assert "continuing" not in out
    assert main(["run-case", "--preset", "default", "--case", str(case)]) == 2
    err = capsys.readouterr().err
    assert "--preset default (recorded: preset smoke" in err and "another --case" in err
