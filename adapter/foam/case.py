"""The OpenFOAM whale-in-channel case: prepare, mesh and run it (``whale-adapter run-case``).

The template case is ``foam_case/`` at the top of the repository. :func:`prepare_case` copies it,
writes the scene's whale surface to ``constant/triSurface/whale.stl`` and sets the dictionaries
with PyFoam's ``ParsedParameterFile`` from the scene's ``[case]`` and ``[flow]`` sections (the
numbers themselves come from the pure function :func:`case_parameters`). :func:`mesh_case` runs
blockMesh, snappyHexMesh and checkMesh; :func:`run_case` runs pimpleFoam (serial or on N MPI
ranks) with the step-server (``whale-adapter serve``) in the background, shows progress, watches
the mesh quality and writes ``<case>/adapter-summary.json``. The command itself is
:mod:`adapter.foam.command`.

Mesh watch: pimpleFoam runs with ``-debug-switch polyMesh=1``, which makes OpenFOAM v1912's
``polyMesh::movePoints`` check every new mesh (``checkMeshMotion``) and print the smallest cell
volume and the largest face non-orthogonality of every step. The log is parsed as it grows; when
the non-orthogonality passes ``case.max_non_orthogonality`` the solver gets SIGUSR1, which
``-opt-switch stopAtWriteNowSignal=10`` turns into "write this step and stop", so the run ends on
a written, still valid mesh. See docs/case.md.
"""

from __future__ import annotations

import json
import math
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from adapter import resources
from adapter.coupling.protocol import CONNECT_TIMEOUT_S, REPLY_TIMEOUT_S
from adapter.errors import AdapterError, SolverRunError
from adapter.foam.yplus import time_dirs

_REPO = resources.REPO
#: the template case (foam_case/ of the repository, adapter/_foam_case in a wheel)
TEMPLATE_DIR = resources.TEMPLATE_DIR
#: the boundary condition library built by scripts/build_plugin.sh (resources.build_dir())
PLUGIN_LIB = resources.PLUGIN_LIB
#: Debian's OpenFOAM wants this one variable (shared/notes/openfoam-on-debian.md)
FOAM_DIR = "/usr/share/openfoam"
#: what prepare_case records about the case (scene, derived numbers, mesh)
CASE_RECORD = "adapter-case.json"
SUMMARY = "adapter-summary.json"
#: the regions surface the loads function object reads (constant/triSurface/)
REGIONS_STL = "whale_regions.stl"
#: inflow turbulence: intensity and free-stream eddy-viscosity ratio
TURBULENCE_INTENSITY = 0.01
EDDY_VISCOSITY_RATIO = 10.0
#: run_case's stop_when is asked after this many new solver steps
STOP_WHEN_STEPS = 10
#: the signal pimpleFoam turns into "write now and stop" (-opt-switch stopAtWriteNowSignal)
_STOP_SIGNAL = signal.SIGUSR1

_TIME_RE = re.compile(r"^Time = ([-+0-9.eE]+)\s*$")
_EXEC_RE = re.compile(r"^ExecutionTime = ([-+0-9.eE]+) s")
_NONORTH_RE = re.compile(r"Mesh non-orthogonality Max: ([-+0-9.eE]+)")
_MINVOL_RE = re.compile(r"Min volume = ([-+0-9.eE]+?)\.\s")
_COURANT_RE = re.compile(r"^Courant Number mean: \S+ max: ([-+0-9.eE]+)")
_PLUGIN_RE = re.compile(r"stepServer: ([0-9]+) requests, mean ([0-9.]+) us per exchange\s*$")
_BROKEN_RE = re.compile(r"\*\*\*(Zero or negative cell volume|Error in face pyramids"
                        r"|Number of non-orthogonality errors)")


# --------------------------------------------------------------------------------------------
# the numbers of a case


@dataclass(frozen=True)
class CaseParameters:
    """Every number prepare_case writes into the dictionaries (SI units).

    Attributes
    ----------
    domain_min, domain_max : (3,) corners of the blockMesh box (m).
    cells : (3,) background cell counts along x, y, z.
    cell_size : (3,) background cell size along x, y, z (m).
    smallest_cell_m : edge of a cell at the highest surface refinement level (m).
    delta_t : flow time step (s), a binary fraction (a multiple of 2**-k s).
    time_precision : controlDict timePrecision: enough digits to name every time exactly.
    steps_per_write : time steps between writes.
    n_steps : time steps of the run (a whole number of write intervals).
    end_time : simulated end (s) = n_steps * delta_t.
    location_in_mesh : (3,) a point in the water, upstream of the rostrum (m).
    near_box_min, near_box_max : (3,) the refinement box around the whale (m).
    k_inlet, omega_inlet : inflow turbulence (m2/s2, 1/s).
    ranks : MPI ranks (1 is serial).
    inflow_ramp_s : the inflow ramps from still water to the scene's speed over this (s).
    motion_inner_m, motion_outer_m : whaleBlendedDisplacement's innerDistance and
        outerDistance (m): ``case.motion_inner`` / ``motion_outer`` body lengths, the outer one
        at most 0.8 of the gap between the body's bounding box and the nearest domain face
        (the outer boundaries stay put), the inner one at most half the outer one.
    """

    domain_min: tuple
    domain_max: tuple
    cells: tuple
    cell_size: tuple
    smallest_cell_m: float
    delta_t: float
    time_precision: int
    steps_per_write: int
    n_steps: int
    end_time: float
    location_in_mesh: tuple
    near_box_min: tuple
    near_box_max: tuple
    k_inlet: float
    omega_inlet: float
    ranks: int
    inflow_ramp_s: float = 0.0
    motion_inner_m: float = 0.5
    motion_outer_m: float = 10.0


def case_parameters(scene, bounds_min, bounds_max, ranks: int | None = None,
                    length: float | None = None) -> CaseParameters:
    """The case's numbers from the scene and the whale's bounding box.

    Parameters
    ----------
    scene : a :class:`~adapter.scene.Scene`.
    bounds_min, bounds_max : (3,) the whale surface's bounding box (m).
    ranks : MPI ranks; None takes ``scene.case.ranks``.
    length : the body's length L (m): the surface's own (``WhaleSurface.length``, what
        prepare_case passes); None takes ``scene.geometry.length_m``.

    The background cell is ``case.background_cell`` body lengths (``case.background_cell_m``
    metres when > 0). The domain reaches ``upstream`` body lengths before the rostrum,
    ``downstream`` after the flukes and ``half_width`` to each side and above and below the
    body's centre. The time step is ``0.5 * smallest cell / U`` unless ``case.dt_s > 0``;
    either is rounded down so that the write interval (one stroke cycle /
    ``writes_per_cycle``) is a whole number of steps, then down to a binary fraction
    (:func:`_binary_step`), and the end time is rounded up to a whole number of write
    intervals (at most a tenth of one short) so that a run ends on a
    written (restartable) time.
    """
    c = scene.case
    length = float(length) if length else scene.geometry.length_m
    cell = c.background_cell_m if c.background_cell_m > 0 else c.background_cell * length
    lo = np.asarray(bounds_min, dtype=float)
    hi = np.asarray(bounds_max, dtype=float)
    centre = 0.5 * (lo + hi)
    dmin = np.array([lo[0] - c.upstream * length, centre[1] - c.half_width * length,
                     centre[2] - c.half_width * length])
    dmax = np.array([hi[0] + c.downstream * length, centre[1] + c.half_width * length,
                     centre[2] + c.half_width * length])
    cells = np.maximum(1, np.round((dmax - dmin) / cell)).astype(int)
    size = (dmax - dmin) / cells
    smallest = float(size.min()) / 2 ** c.refinement[1]
    speed = scene.flow.speed_m_s
    dt = c.dt_s if c.dt_s > 0 else 0.5 * smallest / speed
    write_interval = scene.period_s / c.writes_per_cycle
    steps_per_write = max(1, math.ceil(write_interval / dt * (1 - 1e-12)))
    dt = _binary_step(write_interval / steps_per_write)
    write_interval = steps_per_write * dt
    end = c.end_time_s if c.end_time_s > 0 else c.cycles * scene.period_s
    # whole write intervals; up to a tenth of one short of the end asked for (the binary step
    # makes the interval a little shorter than a stroke cycle / writes_per_cycle)
    n_writes = max(1, math.ceil(end / write_interval - 0.1))
    n_steps = n_writes * steps_per_write
    # a point in the water halfway between the inlet and the rostrum, off any cell face
    location = (float(lo[0] - 0.5 * c.upstream * length + 0.1234567 * size[0]),
                float(centre[1] + 0.1234567 * size[1]), float(centre[2] + 0.1234567 * size[2]))
    grow = 0.1 * length
    gap = float(min((lo - dmin).min(), (dmax - hi).min()))
    outer = min(c.motion_outer * length, 0.8 * gap)
    inner = min(c.motion_inner * length, 0.5 * outer)
    k = 1.5 * (TURBULENCE_INTENSITY * speed) ** 2
    omega = k / (EDDY_VISCOSITY_RATIO * scene.flow.nu_m2_s)
    return CaseParameters(
        domain_min=tuple(float(v) for v in dmin),
        domain_max=tuple(float(v) for v in dmax),
        cells=tuple(int(v) for v in cells),
        cell_size=tuple(float(v) for v in size),
        smallest_cell_m=smallest,
        delta_t=dt,
        time_precision=_time_precision(dt),
        steps_per_write=steps_per_write,
        n_steps=n_steps,
        end_time=n_steps * dt,
        location_in_mesh=location,
        near_box_min=tuple(float(v) for v in lo - grow),
        near_box_max=tuple(float(v) for v in hi + grow),
        k_inlet=k,
        omega_inlet=omega,
        ranks=int(ranks if ranks is not None else c.ranks),
        inflow_ramp_s=c.inflow_ramp_cycles * scene.period_s,
        motion_inner_m=float(inner),
        motion_outer_m=float(outer),
    )


def _binary_step(dt: float) -> float:
    """``dt`` rounded down to a multiple of 2**-k s, with k >= 10 and at least 64 such quanta.

    OpenFOAM adds deltaT to the time every step and names written times with timePrecision
    digits; with a binary-fraction step every sum is exact and every name is the exact value,
    so a restart from a written time reaches the same times, bit for bit, as the first run
    (and the step-server is asked for the same times).
    """
    k = max(10, math.ceil(math.log2(64.0 / dt)))
    return math.floor(dt * 2.0**k) / 2.0**k


def _time_precision(dt: float) -> int:
    """Significant digits that print every multiple of ``dt`` below 10**5 s exactly."""
    k = max(10, math.ceil(math.log2(64.0 / dt))) if dt > 0 else 10
    return k + 5


# --------------------------------------------------------------------------------------------
# preparing


def parsed_dict(path: Path):
    """An OpenFOAM dictionary as PyFoam's ParsedParameterFile (``writeFile()`` writes it back)."""
    from PyFoam.RunDictionary.ParsedParameterFile import ParsedParameterFile

    # comments are dropped: PyFoam re-attaches them to the wrong entries when it writes
    return ParsedParameterFile(str(path), preserveComments=False)


def _vector(v) -> str:
    return "(" + " ".join(repr(float(x)) for x in v) + ")"


def _uniform(v) -> str:
    return "uniform " + (_vector(v) if np.ndim(v) else repr(float(v)))


def prepare_case(scene, case_dir, *, ranks: int | None = None, static_whale: bool = False,
                 scene_file: str | os.PathLike | None = None, surface=None) -> CaseParameters:
    """Make a ready-to-mesh case in ``case_dir`` from the template and the scene.

    Parameters
    ----------
    scene : a :class:`~adapter.scene.Scene`.
    case_dir : folder to create; it must not hold a case yet (no ``system/controlDict``).
    ranks : MPI ranks (decomposeParDict); None takes ``scene.case.ranks``.
    static_whale : the whale patch gets ``fixedValue uniform (0 0 0)`` instead of the
        step-server boundary condition, and the plugin library is not loaded (a flow-only case,
        no server needed).
    scene_file : the scene's TOML file, recorded so that the step-server loads the same scene.
    surface : a :class:`~adapter.body.geometry.WhaleSurface`; None builds the scene's.

    Returns the :class:`CaseParameters` written; they are also recorded in
    ``<case>/adapter-case.json``.
    """
    case = Path(case_dir)
    if (case / "system" / "controlDict").exists():
        raise AdapterError(
            f"{case} already holds a case; run it with `whale-adapter run-case --case {case}`, "
            "or remove it / choose another --case to prepare a new one"
        )
    if not (TEMPLATE_DIR / "system" / "controlDict").is_file():
        raise AdapterError(f"the template case {TEMPLATE_DIR} is missing; reinstall the "
                           "package (pip install . or pip install -e . from the repository)")
    if surface is None:
        from adapter.body.geometry import build_surface

        surface = build_surface(scene)
    _check_length(scene, surface)
    case.mkdir(parents=True, exist_ok=True)
    shutil.copytree(TEMPLATE_DIR, case, dirs_exist_ok=True)
    stl = case / "constant" / "triSurface" / "whale.stl"
    surface.write(stl)
    # the same triangles as three solids (body, flippers, flukes) for the loads' regions; a
    # second file, as snappyHexMesh makes one patch per solid (whale_body, ...) of a
    # multi-solid STL and the whale must stay one patch
    surface.write_regions_stl(stl.with_name(REGIONS_STL))
    pts = np.asarray(surface.points)
    params = case_parameters(scene, pts.min(axis=0), pts.max(axis=0), ranks=ranks,
                             length=surface.length)
    _write_dictionaries(case, scene, params, static_whale)
    from adapter.foam.loads import body_dimensions

    tail_base_s = float(surface.s[surface.landmarks["tail_base"]])
    st = scene.stroke
    ramp = (st.ramp_cycles if st.reversal == "smooth" else st.fluke_ramp) * scene.period_s
    record = {
        "scene_file": str(Path(scene_file).resolve()) if scene_file else None,
        # the start-up discarded from the figures: the ramp, at least one cycle
        "ramp_s": max(ramp, scene.period_s),
        "rho_kg_m3": scene.flow.rho_kg_m3,
        "nu_m2_s": scene.flow.nu_m2_s,
        "body": body_dimensions(surface, tail_base_s),
        "gliding": scene.case.gliding,
        "periodic_tolerance": scene.case.periodic_tolerance,
        "preset": scene.name,
        "static_whale": static_whale,
        "length_m": float(surface.length),
        "body_size_m": [float(v) for v in np.ptp(pts, axis=0)],
        "period_s": scene.period_s,
        "speed_m_s": scene.flow.speed_m_s,
        "max_non_orthogonality": scene.case.max_non_orthogonality,
        "surface_nodes": int(len(pts)),
        "parameters": asdict(params),
    }
    write_json(case / CASE_RECORD, record)
    return params


#: how far a mesh file's own length may differ from geometry.length_m
LENGTH_MISMATCH = 0.03


def _check_length(scene, surface) -> None:
    """A mesh-file body whose length (rostrum to the farthest x) is not geometry.length_m is
    refused: the stroke amplitude and the calibration are set in units of geometry.length_m,
    the case in units of the mesh's own length (a mesh file is not scaled)."""
    want, have = scene.geometry.length_m, float(surface.length)
    if abs(have / want - 1) > LENGTH_MISMATCH:
        raise AdapterError(
            f"the mesh {scene.geometry.source} is {have:.4g} m long (rostrum to the farthest x) "
            f"but geometry.length_m = {want:g} m; mesh files are not scaled: set "
            f"geometry.length_m = {have:.4g} in the scene, or scale the mesh file to "
            f"{want:g} m")


def _write_dictionaries(case: Path, scene, p: CaseParameters, static_whale: bool) -> None:
    c = scene.case
    d = parsed_dict(case / "system" / "blockMeshDict")
    for axis, lo, hi, n in zip("xyz", p.domain_min, p.domain_max, p.cells, strict=True):
        d[f"{axis}min"] = lo
        d[f"{axis}max"] = hi
        d[f"n{axis}"] = n
    d.writeFile()

    d = parsed_dict(case / "system" / "snappyHexMeshDict")
    d["geometry"]["nearWhale"]["min"] = _vector(p.near_box_min)
    d["geometry"]["nearWhale"]["max"] = _vector(p.near_box_max)
    cm = d["castellatedMeshControls"]
    cm["refinementSurfaces"]["whale"]["level"] = f"({c.refinement[0]} {c.refinement[1]})"
    near = max(0, c.refinement[0] - 1)
    cm["refinementRegions"]["nearWhale"]["levels"] = f"(({near} {near}))"
    cm["locationInMesh"] = _vector(p.location_in_mesh)
    d["addLayers"] = c.layers > 0
    lc = d["addLayersControls"]
    lc["layers"] = {"whale": {"nSurfaceLayers": c.layers}} if c.layers > 0 else {}
    lc["relativeSizes"] = False
    lc["firstLayerThickness"] = c.first_layer_m
    lc["expansionRatio"] = c.layer_expansion
    # the smallest layer thickness kept: a third of the first layer's
    lc["minThickness"] = c.first_layer_m / 3
    d.writeFile()

    d = parsed_dict(case / "system" / "controlDict")
    lib = f'"{_plugin_lib()}"'
    if static_whale and not _plugin_lib().is_file():
        # a flow-only case without the plugin library: no loads function object either
        del d["libs"]
        del d["functions"]["loads"]
    else:
        d["libs"] = [lib]
        d["functions"]["loads"]["libs"] = [lib]
        d["functions"]["loads"]["rhoInf"] = scene.flow.rho_kg_m3
    d["endTime"] = p.end_time
    d["deltaT"] = p.delta_t
    d["timePrecision"] = p.time_precision
    d["writeInterval"] = p.steps_per_write
    d["functions"]["forces"]["rhoInf"] = scene.flow.rho_kg_m3
    d.writeFile()

    d = parsed_dict(case / "constant" / "dynamicMeshDict")
    if c.mesh_motion == "blended" and (_plugin_lib().is_file() or not static_whale):
        d["motionSolver"] = "whaleBlendedDisplacement"
        d["motionSolverLibs"] = [lib]
        coeffs = d["whaleBlendedDisplacementCoeffs"]
        coeffs["innerDistance"] = p.motion_inner_m
        coeffs["outerDistance"] = p.motion_outer_m
    else:
        # the Laplacian (also for a flow-only case without the plugin library)
        d["motionSolver"] = "displacementLaplacian"
        d["motionSolverLibs"] = ['"libfvMotionSolvers.so"']
    d.writeFile()

    d = parsed_dict(case / "system" / "decomposeParDict")
    d["numberOfSubdomains"] = p.ranks
    d["coeffs"]["n"] = f"({p.ranks} 1 1)"
    d.writeFile()

    d = parsed_dict(case / "constant" / "transportProperties")
    d["nu"] = scene.flow.nu_m2_s
    d.writeFile()

    d = parsed_dict(case / "constant" / "turbulenceProperties")
    d["simulationType"] = "laminar" if c.turbulence == "laminar" else "RAS"
    d["RAS"]["RASModel"] = "kOmegaSST"
    d.writeFile()

    zero = case / "0.orig"
    d = parsed_dict(zero / "U")
    d["Uinlet"] = _vector((scene.flow.speed_m_s, 0.0, 0.0))
    if p.inflow_ramp_s > 0:
        # still water, the inflow ramped in smoothly: no impulsive start
        d["internalField"] = "uniform (0 0 0)"
        d["boundaryField"]["inlet"] = {
            "type": "uniformFixedValue",
            "uniformValue": "table " + inflow_ramp_table(scene.flow.speed_m_s, p.inflow_ramp_s),
            "value": "uniform (0 0 0)",
        }
    d.writeFile()
    d = parsed_dict(zero / "k")
    d["kInlet"] = p.k_inlet
    d.writeFile()
    d = parsed_dict(zero / "omega")
    d["omegaInlet"] = p.omega_inlet
    d.writeFile()
    d = parsed_dict(zero / "pointDisplacement")
    if static_whale:
        d["boundaryField"]["whale"] = {"type": "fixedValue", "value": "uniform (0 0 0)"}
    else:
        d["boundaryField"]["whale"] = {
            "type": "stepServerDisplacement",
            # no socket/port: the master rank reads <case>/.whale-adapter.endpoint, where the
            # server says it listens (UNIX socket or TCP); no token (the environment's)
            "connectTimeout": CONNECT_TIMEOUT_S,
            "replyTimeout": REPLY_TIMEOUT_S,
            "rhoInf": scene.flow.rho_kg_m3,
            "value": "uniform (0 0 0)",
        }
    d.writeFile()


def inflow_ramp_table(speed: float, duration: float, points: int = 24) -> str:
    """An OpenFOAM table ``((t (u 0 0)) ...)``: the inflow from 0 to ``speed`` over
    ``duration`` as the quintic smoothstep (zero acceleration at both ends), sampled at
    ``points`` + 1 times (linear between them); constant after."""
    rows = []
    for k in range(points + 1):
        x = k / points
        u = speed * x**3 * (10 - 15 * x + 6 * x * x)
        rows.append(f"({duration * x!r} ({u!r} 0 0))")
    return "(" + " ".join(rows) + ")"


def _plugin_lib() -> Path:
    return Path(os.environ.get("WHALE_PLUGIN_LIB", PLUGIN_LIB))


def write_json(path: Path, data: dict) -> None:
    path.write_text(json.dumps(data, indent=2) + "\n")


def read_record(case_dir) -> dict:
    """The record prepare_case wrote (``<case>/adapter-case.json``)."""
    path = Path(case_dir) / CASE_RECORD
    if not path.is_file():
        raise AdapterError(f"{path} is missing: {case_dir} was not made by "
                           "`whale-adapter run-case`, so it is neither meshed nor run; choose "
                           "another (new or empty) --case to prepare a case with --scene/--preset")
    return json.loads(path.read_text())


# --------------------------------------------------------------------------------------------
# running OpenFOAM utilities


def foam_env() -> dict:
    """The environment for Debian's OpenFOAM binaries (WM_PROJECT_DIR set when unset)."""
    env = dict(os.environ)
    env.setdefault("WM_PROJECT_DIR", FOAM_DIR)
    return env


def _check_foam() -> None:
    if shutil.which("pimpleFoam") is None:
        raise SolverRunError("OpenFOAM is not on PATH (no pimpleFoam); install it with "
                             "scripts/install_openfoam.sh")


def run_utility(case_dir, args: list, log_name: str | None = None) -> Path:
    """Run one OpenFOAM utility in the case, its output to ``log.<utility>``.

    Raises :class:`~adapter.errors.SolverRunError` naming the log when it fails.
    """
    case = Path(case_dir)
    log = case / f"log.{log_name or Path(args[0]).name}"
    with open(log, "w") as fh:
        rc = subprocess.call(args, cwd=case, stdout=fh, stderr=subprocess.STDOUT, env=foam_env())
    text = log.read_text(errors="replace")
    if rc != 0 or "FOAM FATAL" in text:
        raise SolverRunError(f"{args[0]} failed (exit code {rc}); see {log}")
    return log


def _restore_zero(case: Path) -> None:
    """Copy the initial fields of 0.orig that 0/ lacks (snappyHexMesh -overwrite writes its
    layer fields nSurfaceLayers, thickness, thicknessFraction into 0/ first; they stay)."""
    zero = case / "0"
    zero.mkdir(exist_ok=True)
    for f in (case / "0.orig").iterdir():
        if f.is_file() and not (zero / f.name).exists():
            shutil.copy2(f, zero / f.name)


def mesh_case(case_dir) -> dict:
    """blockMesh, snappyHexMesh -overwrite and checkMesh in a prepared case.

    Returns the mesh's facts parsed from checkMesh: cells, whale_faces, whale_points,
    max_non_orthogonality, max_skewness, mesh_ok; also recorded in adapter-case.json. Raises
    :class:`~adapter.errors.SolverRunError` when a utility fails or the whale patch is missing.
    """
    _check_foam()
    case = Path(case_dir)
    read_record(case)  # a folder not made by run-case is refused before blockMesh touches it
    t0 = time.perf_counter()
    run_utility(case, ["blockMesh"])
    run_utility(case, ["snappyHexMesh", "-overwrite"])
    log = run_utility(case, ["checkMesh"])
    info = parse_check_mesh(log.read_text(errors="replace"))
    info["mesh_s"] = round(time.perf_counter() - t0, 2)
    info.update(layer_record(case))
    if not info.get("whale_faces"):
        raise SolverRunError(f"snappyHexMesh made no whale patch; see {case / 'log.snappyHexMesh'}"
                             f" ({_no_patch_hint(read_record(case))})")
    _restore_zero(case)
    record_path = case / CASE_RECORD
    if record_path.is_file():
        record = json.loads(record_path.read_text())
        record["mesh"] = info
        write_json(record_path, record)
    return info


def layer_record(case_dir) -> dict:
    """The whale's prism layers after snappyHexMesh: ``{"layers": {...}}`` with the log's table
    (``faces``, ``faces_with_layers``, ``face_coverage``, ``mean_layers``, ``thickness_m``,
    ``thickness_pct``) and the area-weighted coverage from the ``nSurfaceLayers`` field
    (``area_with_layers``, ``area_full_thickness``); empty when the case has no layers."""
    from adapter.foam.yplus import layer_coverage, parse_layer_report

    case = Path(case_dir)
    log = case / "log.snappyHexMesh"
    report = parse_layer_report(log.read_text(errors="replace")).get("whale") \
        if log.is_file() else None
    if not report:
        return {}
    try:
        cov = layer_coverage(case, "whale")
    except AdapterError:
        cov = {}
    for key in ("area_with_layers", "area_full_thickness"):
        if key in cov:
            report[key] = round(cov[key], 4)
    for key in ("face_coverage",):
        if key in report:
            report[key] = round(report[key], 4)
    return {"layers": report}


def _no_patch_hint(record: dict) -> str:
    """Why snappyHexMesh may have kept no whale: cells too coarse for the body, most often."""
    smallest = record.get("parameters", {}).get("smallest_cell_m")
    size = record.get("body_size_m")
    if smallest and size and smallest > 0.25 * min(size[1], size[2]):
        return (f"the smallest cell, {smallest:.3g} m, is too coarse for a body "
                f"{min(size[1], size[2]):.3g} m across: lower case.background_cell (body "
                "lengths) or case.background_cell_m, or raise case.refinement")
    return "is locationInMesh in the water?"


def parse_check_mesh(text: str) -> dict:
    """Cells, whale patch size and quality from a checkMesh log."""
    info: dict = {}
    m = re.search(r"^\s*cells:\s+(\d+)", text, re.M)
    if m:
        info["cells"] = int(m.group(1))
    m = re.search(r"^\s*whale\s+(\d+)\s+(\d+)\s", text, re.M)
    if m:
        info["whale_faces"], info["whale_points"] = int(m.group(1)), int(m.group(2))
    m = re.search(r"Mesh non-orthogonality Max: ([-+0-9.eE]+)", text)
    if m:
        info["max_non_orthogonality"] = float(m.group(1))
    m = re.search(r"Max skewness = ([-+0-9.eE]+)", text)
    if m:
        info["max_skewness"] = float(m.group(1))
    info["mesh_ok"] = "Mesh OK." in text
    return info


# --------------------------------------------------------------------------------------------
# watching the solver log


class LogWatch:
    """Follows a pimpleFoam log as it grows and keeps what the run reports.

    Attributes: times (every ``Time =``), seen (wall clock when each appeared), exec_times
    (``ExecutionTime``, s), max_non_orth (deg) and min_volume (m^3) over every mesh motion
    check, max_courant, plugin (requests, mean us), broken (the first line reporting an invalid
    mesh, or None).
    """

    def __init__(self, path: Path):
        self.path = Path(path)
        self._pos = 0
        self._rest = ""
        self.times: list = []
        self.seen: list = []
        self.exec_times: list = []
        self.max_non_orth = float("nan")
        self.last_non_orth = float("nan")
        self.min_volume = float("nan")
        self.max_courant = float("nan")
        self.plugin: tuple | None = None
        self.broken: str | None = None

    def poll(self) -> None:
        """Read what was appended since the last call."""
        try:
            with open(self.path, errors="replace") as fh:
                fh.seek(self._pos)
                chunk = fh.read()
                self._pos = fh.tell()
        except FileNotFoundError:
            return
        lines = (self._rest + chunk).split("\n")
        self._rest = lines.pop()
        for line in lines:
            self.feed(line)

    def feed(self, line: str) -> None:
        """Take one log line."""
        line = re.sub(r"^\[\d+\] ", "", line)
        if m := _TIME_RE.match(line):
            self.times.append(float(m.group(1)))
            self.seen.append(time.perf_counter())
        elif m := _EXEC_RE.match(line):
            self.exec_times.append(float(m.group(1)))
        elif m := _NONORTH_RE.search(line):
            v = float(m.group(1))
            self.last_non_orth = v
            self.max_non_orth = _nanmax(self.max_non_orth, v)
        elif m := _MINVOL_RE.search(line):
            self.min_volume = _nanmin(self.min_volume, float(m.group(1)))
        elif m := _COURANT_RE.match(line):
            self.max_courant = _nanmax(self.max_courant, float(m.group(1)))
        elif m := _PLUGIN_RE.search(line):
            self.plugin = (int(m.group(1)), float(m.group(2)))
        if self.broken is None and _BROKEN_RE.search(line):
            self.broken = line.strip()

    def seconds_per_step(self) -> float:
        """Mean wall seconds per step, leaving out the first (start-up) step.

        Measured from when each ``Time =`` line appeared in the log (polled every 0.1 s), so it
        includes the time the solver waits for the step-server."""
        s = self.seen
        if len(s) >= 3:
            return (s[-1] - s[0]) / (len(s) - 1)
        return float("nan")

    def cpu_seconds_per_step(self) -> float:
        """Mean CPU seconds per step of the (master) solver process, from ExecutionTime."""
        e = self.exec_times
        if len(e) >= 3:
            return (e[-1] - e[0]) / (len(e) - 1)
        if e:
            return e[-1] / len(e)
        return float("nan")


def _nanmax(a: float, b: float) -> float:
    return b if math.isnan(a) else max(a, b)


def _nanmin(a: float, b: float) -> float:
    return b if math.isnan(a) else min(a, b)


class _Progress:
    """One progress line: simulated time / end time, s per step, ETA, mesh quality."""

    def __init__(self, end_time: float, start_time: float, stream=sys.stderr):
        self.end = end_time
        self.start = start_time
        self.stream = stream
        self.tty = stream.isatty()
        self.t_wall = time.perf_counter()
        self.last_print = 0.0
        self.last_line = ""

    def show(self, watch: LogWatch, final: bool = False) -> None:
        if not watch.times:
            return
        now = time.perf_counter()
        if not final and not self.tty and now - self.last_print < 10:
            return
        t = watch.times[-1]
        steps = len(watch.times)
        per_step = (now - self.t_wall) / steps
        remaining = (self.end - t) / max(t - self.start, 1e-12) * (now - self.t_wall)
        line = (f"pimpleFoam  t = {t:.4g} / {self.end:.4g} s  step {steps}  "
                f"{per_step:.2f} s/step  ETA {remaining:.0f} s  "
                f"non-orth {watch.last_non_orth:.1f} deg (max {watch.max_non_orth:.1f})")
        if line == self.last_line and not final:
            return
        self.last_line = line
        self.last_print = now
        if self.tty:
            print("\r" + line, end="\n" if final else "", file=self.stream, flush=True)
        else:
            print(line, file=self.stream, flush=True)


# --------------------------------------------------------------------------------------------
# running the case


def _processor_dirs(case: Path) -> list:
    """The case's ``processor<N>`` folders, in rank order."""
    procs = [p for p in case.glob("processor*") if p.is_dir() and p.name[9:].isdigit()]
    return sorted(procs, key=lambda p: int(p.name[9:]))


def _processor_latest(case: Path) -> float | None:
    """The latest time every processor folder holds, or None (no processor folders)."""
    common = None
    for p in _processor_dirs(case):
        names = {d.name for _, d in time_dirs(p)}
        common = names if common is None else common & names
    return max((float(n) for n in common), default=None) if common else None


def _trim_processor_times(case: Path, latest: float) -> None:
    """Remove the processor time folders after ``latest`` (a time only some ranks wrote)."""
    for p in _processor_dirs(case):
        for t, d in time_dirs(p):
            if t > latest:
                shutil.rmtree(d)


def resume_time(case_dir) -> float:
    """The time a run of the case starts from: its latest written time, in the case folder or
    (after a parallel run that stopped before reconstructPar) in every processor folder."""
    case = Path(case_dir)
    times = time_dirs(case)
    serial = times[-1][0] if times else 0.0
    procs = _processor_latest(case)
    return serial if procs is None else max(serial, procs)


def fatal_error(log_text: str) -> str | None:
    """The message lines of the first ``--> FOAM FATAL (IO) ERROR`` block of a log, or None.

    OpenFOAM prints the header, the message, then ``From function ...`` / ``in file ...`` and
    ``FOAM exiting``; rank prefixes (``[1] ``) of a parallel run are dropped."""
    lines = [re.sub(r"^\[\d+\] ?", "", line) for line in log_text.splitlines()]
    for i, line in enumerate(lines):
        m = re.search(r"--> FOAM FATAL (?:IO )?ERROR:?(.*)$", line)
        if not m:
            continue
        out = [m.group(1).strip()] if m.group(1).strip() else []
        for rest in lines[i + 1:]:
            text = rest.strip()
            if text.startswith(("From function", "From ", "in file", "FOAM exiting",
                                "FOAM parallel run exiting", "--> FOAM")):
                break
            if text:
                out.append(text)
        return "\n".join(out) if out else None
    return None


def _server_command(case: Path, record: dict) -> list:
    cmd = [sys.executable, "-m", "adapter.cli", "serve", "--case", str(case)]
    if record.get("scene_file"):
        cmd += ["--scene", record["scene_file"]]
    if record.get("preset"):
        cmd += ["--preset", record["preset"]]
    return cmd


def _start_server(case: Path, record: dict, timeout: float = 60.0, host: str | None = None,
                  port: int | None = None, token: str | None = None) -> subprocess.Popen:
    """Start the step-server; return once it has published its endpoint file. TCP when a host
    or a port is given. The token goes through the environment, never the command line."""
    from adapter.coupling.protocol import ENDPOINT_NAME, TOKEN_ENV

    endpoint = case / ENDPOINT_NAME
    log = open(case / "log.server", "w")  # noqa: SIM115 - closed by _stop_server
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(_REPO), env.get("PYTHONPATH")]))
    env.pop(TOKEN_ENV, None)
    if token:
        env[TOKEN_ENV] = token
    cmd = _server_command(case, record)
    if host is not None or port is not None:
        cmd += ["--tcp", str(port or 0), "--host", host or "127.0.0.1"]
    proc = subprocess.Popen(cmd, cwd=case, stdout=log, stderr=subprocess.STDOUT,
                            start_new_session=True, env=env)
    proc._whale_log = log  # type: ignore[attr-defined]
    t0 = time.perf_counter()
    while not _endpoint_of(endpoint, proc.pid):
        if proc.poll() is not None:
            log.close()
            raise SolverRunError(f"the step-server stopped at start (exit code {proc.returncode});"
                                 f" see {case / 'log.server'}")
        if time.perf_counter() - t0 > timeout:
            _stop_server(proc)
            raise SolverRunError(f"the step-server published no endpoint {endpoint} within "
                                 f"{timeout:.0f} s; see {case / 'log.server'}")
        time.sleep(0.1)
    return proc


def _endpoint_of(path: Path, pid: int) -> bool:
    """Whether the endpoint file at path is the one server ``pid`` wrote."""
    try:
        return f"\npid {pid}\n" in path.read_text()
    except OSError:
        return False


def _stop_server(proc: subprocess.Popen | None, grace: float = 15.0) -> None:
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


def run_case(case_dir, *, ranks: int | None = None, progress: bool = True,
             stop_when=None, host: str | None = None, port: int | None = None,
             token: str | None = None) -> dict:
    """Run pimpleFoam on a prepared case with the step-server, and summarise the run.

    Meshes the case first when it has no mesh. Serial for one rank, otherwise decomposePar,
    ``mpirun -np N pimpleFoam -parallel`` and reconstructPar. A case that has written times
    continues from the latest (controlDict ``startFrom latestTime``).

    ``stop_when(case) -> str | None`` is asked every :data:`STOP_WHEN_STEPS` solver steps and
    once at the end; a reason ends the run (written) as the mesh watch does, and is recorded
    as ``stopped_because`` (not an error).

    ``host``/``port``: the server listens on TCP there (port 0: any free one) and publishes
    it in ``<case>/.whale-adapter.endpoint``; else on the case's UNIX socket. ``token`` (None:
    ``$WHALE_ADAPTER_TOKEN``) reaches the server and the solver through the environment only.

    Returns the summary also written to ``<case>/adapter-summary.json``. Raises
    :class:`~adapter.errors.SolverRunError` naming the log when pimpleFoam fails, or when the
    mesh watch stopped the run (after writing the summary).
    """
    _check_foam()
    t_start = time.perf_counter()
    case = Path(case_dir).resolve()
    record = read_record(case)
    ranks = int(ranks or record["parameters"]["ranks"])
    if not (case / "constant" / "polyMesh" / "owner").exists():
        mesh_case(case)
        record = read_record(case)
    _restore_zero(case)
    if ranks > 1:
        d = parsed_dict(case / "system" / "decomposeParDict")
        d["numberOfSubdomains"] = ranks
        d["coeffs"]["n"] = f"({ranks} 1 1)"
        d.writeFile()
    static = bool(record.get("static_whale"))
    if not static and not _plugin_lib().is_file():
        raise SolverRunError(f"the boundary condition library {_plugin_lib()} is missing; build "
                             f"it with `bash {resources.BUILD_SCRIPT}` (or point "
                             "WHALE_PLUGIN_LIB at a built one)")
    times = time_dirs(case)
    serial_latest = times[-1][0] if times else 0.0
    ranks_latest = _processor_latest(case)
    from_ranks = ranks_latest is not None and ranks_latest > serial_latest
    if from_ranks and (ranks == 1 or len(_processor_dirs(case)) != ranks):
        # the latest times are in processor folders of another rank count: reconstruct them
        _trim_processor_times(case, ranks_latest)
        run_utility(case, ["reconstructPar", "-newTimes"])
        from_ranks = False
    start_time = resume_time(case)
    control = parsed_dict(case / "system" / "controlDict")
    end_time = float(control["endTime"])
    if start_time >= end_time - 0.5 * float(control["deltaT"]):
        return _finished(case, record, ranks, from_ranks, t_start)
    from adapter.coupling.protocol import TOKEN_ENV

    token = token or os.environ.get(TOKEN_ENV) or None
    env = foam_env()
    env.pop(TOKEN_ENV, None)
    if token:
        env[TOKEN_ENV] = token
    solver = ["pimpleFoam", "-debug-switch", "polyMesh=1",
              "-opt-switch", f"stopAtWriteNowSignal={int(_STOP_SIGNAL)}"]
    server = None
    stopped = None
    watch = LogWatch(case / "log.pimpleFoam")
    try:
        if ranks > 1 and from_ranks:
            # resume from the ranks' own latest time (a crash left it only there)
            _trim_processor_times(case, ranks_latest)
        elif ranks > 1:
            for p in case.glob("processor*"):
                shutil.rmtree(p)
            run_utility(case, ["decomposePar", "-force", "-latestTime"])
        if ranks > 1:
            # the token reaches the ranks on other hosts through mpirun's -x, not a file
            forward = ["-x", TOKEN_ENV] if token else []
            cmd = ["mpirun", "--allow-run-as-root", "--oversubscribe", "-np", str(ranks),
                   *forward, *solver, "-parallel"]
        else:
            cmd = solver
        if not static:
            server = _start_server(case, record, host=host, port=port, token=token)
        t_flow = time.perf_counter()
        rc, stopped = _run_watched(case, cmd, watch, record, start_time, end_time, progress,
                                   stop_when, env=env)
        flow_wall = time.perf_counter() - t_flow
    finally:
        _stop_server(server)
    if rc != 0:
        what = stopped or f"pimpleFoam failed (exit code {rc})"
        hint = f" ({watch.broken})" if watch.broken and not stopped else ""
        fatal = None if stopped else fatal_error(
            (case / "log.pimpleFoam").read_text(errors="replace"))
        if fatal:
            raise SolverRunError(f"{what}{hint}, with OpenFOAM's message:\n    "
                                 + fatal.replace("\n", "\n    ")
                                 + f"\n(see {case / 'log.pimpleFoam'}; run the same command again"
                                 " to continue from the latest written time)")
        raise SolverRunError(f"{what}{hint}; see {case / 'log.pimpleFoam'}")
    if ranks > 1:
        run_utility(case, ["reconstructPar", "-newTimes"])
    (case / "case.foam").touch()
    summary = summarise(case, watch, record, ranks, flow_wall, time.perf_counter() - t_start)
    if stopped and not stopped.startswith("mesh watch"):
        summary["stopped_because"] = stopped
        stopped = None
    if stopped:
        summary["stopped"] = stopped
    write_json(case / SUMMARY, summary)
    if stopped:
        raise SolverRunError(f"{stopped}; the run stopped at t = {summary['end_time_s']:.4g} s "
                             f"with a written mesh; see {case / SUMMARY}")
    return summary


def _finished(case: Path, record: dict, ranks: int, from_ranks: bool, t_start: float) -> dict:
    """A case already at its end time: nothing to run; its summary (reconstructed first when
    the last times are only in processor folders)."""
    if from_ranks:
        run_utility(case, ["reconstructPar", "-newTimes"])
    (case / "case.foam").touch()
    if (case / SUMMARY).is_file():
        return json.loads((case / SUMMARY).read_text())
    watch = LogWatch(case / "log.pimpleFoam")
    watch.poll()
    summary = summarise(case, watch, record, ranks, 0.0, time.perf_counter() - t_start)
    write_json(case / SUMMARY, summary)
    return summary


def _run_watched(case, cmd, watch, record, start_time, end_time, progress, stop_when=None,
                 env=None):
    """Run the solver, follow its log; stop it (write now) when the mesh gets too distorted,
    or when ``stop_when(case)`` gives a reason."""
    limit = float(record.get("max_non_orthogonality", 80.0))
    show = _Progress(end_time, start_time) if progress else None
    stopped = None
    asked_at = 0      # steps seen when stop_when was last asked
    with open(case / "log.pimpleFoam", "w") as log:
        proc = subprocess.Popen(cmd, cwd=case, stdout=log, stderr=subprocess.STDOUT,
                                env=env or foam_env(), start_new_session=True)
        try:
            while True:
                rc = proc.poll()
                watch.poll()
                if stopped is None and (watch.max_non_orth > limit or watch.broken):
                    what = (f"mesh non-orthogonality reached {watch.max_non_orth:.1f} deg "
                            f"(limit case.max_non_orthogonality = {limit:g})")
                    if watch.broken:
                        what = f"the moved mesh is invalid ({watch.broken})"
                    stopped = f"mesh watch: {what}"
                    proc.send_signal(_STOP_SIGNAL)
                # asked every STOP_WHEN_STEPS new steps (not on a wall clock: a fast run
                # would reach its end between two questions) and once more at the end
                steps = len(watch.times)
                if stopped is None and stop_when and (
                        steps - asked_at >= STOP_WHEN_STEPS or rc is not None and steps > asked_at):
                    asked_at = steps
                    stopped = stop_when(case)
                    if stopped and rc is None:
                        proc.send_signal(_STOP_SIGNAL)
                if show:
                    show.show(watch)
                if rc is not None:
                    break
                time.sleep(0.1)
        except BaseException:
            os.killpg(proc.pid, signal.SIGTERM)
            proc.wait()
            raise
    watch.poll()
    if show:
        show.show(watch, final=True)
    return rc, stopped


def read_forces(case_dir) -> np.ndarray:
    """(T, 10) time, total, pressure and viscous force (N) on the whale from postProcessing.

    Files of restarted runs are merged; a later file wins for a time present twice.
    """
    rows: dict = {}
    base = Path(case_dir) / "postProcessing" / "forces"
    files = sorted(base.glob("*/force*.dat"), key=lambda p: float(p.parent.name))
    for f in files:
        for line in f.read_text().splitlines():
            if not line.strip() or line.startswith("#"):
                continue
            nums = [float(v) for v in re.findall(r"[-+0-9.eE]+(?:[eE][-+]?\d+)?",
                                                 line.replace("(", " ").replace(")", " "))]
            if len(nums) >= 10:
                rows[nums[0]] = nums[:10]
    if not rows:
        return np.zeros((0, 10))
    return np.array([rows[t] for t in sorted(rows)])


def summarise(case: Path, watch: LogWatch, record: dict, ranks: int, flow_wall: float,
              wall: float) -> dict:
    """The run's summary (numbers for adapter-summary.json)."""
    steps = len(watch.times)
    step_s = watch.seconds_per_step()
    adapter_s = float("nan")
    if watch.plugin is not None:
        adapter_s = watch.plugin[1] * 1e-6
    stats_path = case / "adapter" / "server-stats.json"
    stats = json.loads(stats_path.read_text()) if stats_path.is_file() else {}
    mesh = record.get("mesh", {})
    forces = read_forces(case)
    period = float(record["period_s"])
    drag = float("nan")
    window = 0.0
    if len(forces):
        t = forces[:, 0]
        sel = t >= t[-1] - period * (1 - 1e-9)
        drag = float(forces[sel, 1].mean())
        window = float(t[sel][-1] - t[sel][0])
    summary = {
        "case": str(case),
        "preset": record.get("preset"),
        "static_whale": bool(record.get("static_whale")),
        "cells": mesh.get("cells"),
        "steps": steps,
        "ranks": ranks,
        "end_time_s": watch.times[-1] if watch.times else None,
        "delta_t_s": record["parameters"]["delta_t"],
        "step_s": step_s,
        "cpu_s_per_step": watch.cpu_seconds_per_step(),
        "flow_s_per_step": step_s - (0.0 if math.isnan(adapter_s) else adapter_s),
        "adapter_s_per_step": adapter_s,
        "adapter_requests": watch.plugin[0] if watch.plugin else None,
        "whale_points": mesh.get("whale_points"),
        # from the step-server: summed over ranks (a point two ranks share counts twice)
        "patch_points": stats.get("patch_points", mesh.get("whale_points")),
        "max_mapping_distance_m": stats.get("max_mapping_distance_m"),
        "worst_cell_quality": {
            "max_non_orthogonality_deg": watch.max_non_orth,
            "min_cell_volume_m3": watch.min_volume,
            "initial_max_non_orthogonality_deg": mesh.get("max_non_orthogonality"),
            "initial_max_skewness": mesh.get("max_skewness"),
        },
        "max_courant": watch.max_courant,
        "drag_N": drag,
        "drag_window_s": window,
        "flow_wall_s": round(flow_wall, 2),
        "wall_s": round(wall, 2),
    }
    return {k: (None if isinstance(v, float) and math.isnan(v) else v)
            for k, v in summary.items()}


#: the rows of :func:`format_summary`: (label, key of the summary (a/b for nested), format);
#: the format is a str.format spec with the unit, or a callable value -> str
SUMMARY_ROWS = [
    ("case", "case", "{}"),
    ("preset", "preset", "{}"),
    ("static whale", "static_whale", lambda v: "yes" if v else "no"),
    ("cells", "cells", "{:,}"),
    ("ranks", "ranks", "{}"),
    ("steps (this run)", "steps", "{}"),
    ("end time", "end_time_s", "{:.6g} s"),
    ("time step", "delta_t_s", "{:.6g} s"),
    ("wall time per step", "step_s", "{:.3g} s"),
    ("  of which coupling", "adapter_s_per_step", lambda v: f"{v * 1e3:.3g} ms"),
    ("CPU time per step", "cpu_s_per_step", "{:.3g} s"),
    ("coupling requests", "adapter_requests", "{:,}"),
    ("whale patch points", "whale_points", "{:,}"),
    ("largest mapping distance", "max_mapping_distance_m", "{:.3g} m"),
    ("largest non-orthogonality", "worst_cell_quality/max_non_orthogonality_deg",
     "{:.1f} deg"),
    ("  before motion", "worst_cell_quality/initial_max_non_orthogonality_deg", "{:.1f} deg"),
    ("smallest cell volume", "worst_cell_quality/min_cell_volume_m3", "{:.3g} m3"),
    ("largest Courant number", "max_courant", "{:.3g}"),
    ("mean drag", "drag_N", "{:.4g} N"),
    ("  over", "drag_window_s", "{:.4g} s"),
    ("pimpleFoam wall time", "flow_wall_s", "{:.1f} s"),
    ("run-case wall time", "wall_s", "{:.1f} s"),
    ("stopped", "stopped", "{}"),
]


def format_summary(summary: dict, rows=None) -> str:
    """The run's summary as a two-column text table, one line per row of ``rows`` (default
    :data:`SUMMARY_ROWS`) whose key the summary holds (missing or None: left out)."""
    lines = []
    for label, key, fmt in rows or SUMMARY_ROWS:
        value = summary
        for part in key.split("/"):
            value = value.get(part) if isinstance(value, dict) else None
        if value is None:
            continue
        try:
            text = fmt(value) if callable(fmt) else fmt.format(value)
        except (TypeError, ValueError):
            text = str(value)
        lines.append((label, text))
    width = max((len(label) for label, _ in lines), default=0)
    return "\n".join(f"{label:<{width}}  {text}" for label, text in lines)
