"""Writing a case's dictionaries with PyFoam's ``ParsedParameterFile`` (never string templates):
the mesh (blockMeshDict, snappyHexMeshDict), the run (controlDict, decomposeParDict), the mesh
motion (dynamicMeshDict), the fluid (transportProperties, turbulenceProperties) and the initial
fields of ``0.orig``, from the scene and the case's
:class:`~adapter.foam.parameters.CaseParameters`.
"""

from __future__ import annotations

import math
import os
import re
import shutil
from pathlib import Path

from adapter import resources
from adapter.coupling.protocol import CONNECT_TIMEOUT_S, REPLY_TIMEOUT_S
from adapter.errors import CaseError
from adapter.foam.parameters import CaseParameters, level_cell_m

#: the whale's triangles as three solids, body, flippers, flukes (constant/triSurface/): the
#: loads' regions, and the surface meshed when the fins have layers of their own
REGIONS_STL = "whale_regions.stl"
#: the flippers' and the flukes' leading edges (case.flipper_edge_level, fluke_edge_level)
EDGE_STLS = ("flipperEdges.stl", "flukeEdges.stl")

#: the boundary condition library built by scripts/build_plugin.sh (resources.build_dir())
PLUGIN_LIB = resources.PLUGIN_LIB
#: the decompositions ``case.decomposition`` names (else it names a decomposeParDict file)
DECOMPOSITIONS = ("hierarchical", "case")
#: the step-server boundary condition's timeouts written into 0.orig/pointDisplacement (s) are
#: its own defaults, CONNECT_TIMEOUT_S and REPLY_TIMEOUT_S of coupling/protocol.py


def plugin_lib() -> Path:
    """The plugin library a case loads: ``$WHALE_PLUGIN_LIB``, else :data:`PLUGIN_LIB`."""
    return Path(os.environ.get("WHALE_PLUGIN_LIB", PLUGIN_LIB))


def parsed_dict(path: Path):
    """An OpenFOAM dictionary as PyFoam's ParsedParameterFile (``writeFile()`` writes it back)."""
    from PyFoam.RunDictionary.ParsedParameterFile import ParsedParameterFile

    # comments are dropped: PyFoam re-attaches them to the wrong entries when it writes
    return ParsedParameterFile(str(path), preserveComments=False)


def _vector(v) -> str:
    return "(" + " ".join(repr(float(x)) for x in v) + ")"


def write_dictionaries(case: Path, scene, p: CaseParameters, static_whale: bool,
                       decomposition: str = "hierarchical") -> None:
    """Set every dictionary of the copied template ``case`` from ``scene`` and ``p``.

    ``static_whale``: the whale patch is fixed (``fixedValue``) instead of asking the
    step-server, and without a built plugin library the loads function object and the blended
    mesh motion are left out. ``decomposition``: as :func:`set_decomposition`'s ``method``.
    """
    _write_meshing(case, scene.case, p)
    _write_control(case, scene, p, static_whale)
    _write_mesh_motion(case, scene.case, p, static_whale)
    set_decomposition(case, p.ranks, decomposition)
    _write_physics(case, scene)
    _write_solution(case, scene.case)
    _write_schemes(case, scene.case)
    _write_initial_fields(case, scene, p, static_whale)


def _write_meshing(case: Path, c, p: CaseParameters) -> None:
    """blockMeshDict (the domain) and snappyHexMeshDict (refinement, layers) from the scene's
    ``[case]`` ``c`` and the numbers ``p``."""
    d = parsed_dict(case / "system" / "blockMeshDict")
    for axis, lo, hi, n in zip("xyz", p.domain_min, p.domain_max, p.cells, strict=True):
        d[f"{axis}min"] = lo
        d[f"{axis}max"] = hi
        d[f"n{axis}"] = n
    d.writeFile()

    mq = case / "system" / "meshQualityDict"     # text: PyFoam would drop its #includeEtc
    mq.write_text(re.sub(r"(relaxed\s*\{[^}]*?maxNonOrtho\s+)[0-9.]+;",
                         rf"\g<1>{c.layer_non_orthogonality:g};", mq.read_text(), flags=re.S))

    d = parsed_dict(case / "system" / "snappyHexMeshDict")
    d["geometry"]["nearWhale"]["min"] = _vector(p.near_box_min)
    d["geometry"]["nearWhale"]["max"] = _vector(p.near_box_max)
    cm = d["castellatedMeshControls"]
    cm["refinementSurfaces"]["whale"]["level"] = f"({c.refinement[0]} {c.refinement[1]})"
    near = max(0, c.refinement[0] - 1)
    cm["refinementRegions"]["nearWhale"]["levels"] = f"(({near} {near}))"
    # the finer cells at the flippers and the flukes' blade (removed at level 0)
    for name, level, cell in (("flippers", c.flipper_level, p.flipper_cell_m),
                              ("flukeBlade", c.fluke_level, p.fluke_cell_m)):
        if level > 0:
            cm["refinementRegions"][name]["levels"] = f"(({cell!r} {level}))"
        else:
            del cm["refinementRegions"][name]
            del d["geometry"][f"{name}.stl"]
    # the finer cells within one of them of the fins' leading edges (adapter.body.leadingedge)
    for stl, level in zip(EDGE_STLS, (c.flipper_edge_level, c.fluke_edge_level), strict=True):
        if level > 0:
            name = stl.removesuffix(".stl")
            cell = level_cell_m(p.cell_size, level)
            d["geometry"][stl] = {"type": "triSurfaceMesh", "name": name}
            cm["refinementRegions"][name] = {"mode": "distance", "levels": f"(({cell!r} {level}))"}
    cm["locationInMesh"] = _vector(p.location_in_mesh)
    d["addLayers"] = c.layers > 0
    lc = d["addLayersControls"]
    lc["layers"] = {"whale": {"nSurfaceLayers": c.layers}} if c.layers > 0 else {}
    if c.layers > 0 and c.fin_layers > 0:
        # the fins' own layers: a patch a region (whale_regions.stl's solids), merged back into
        # one whale patch after snappyHexMesh (adapter.foam.finpatches)
        d["geometry"][REGIONS_STL] = d["geometry"]["whale.stl"]
        del d["geometry"]["whale.stl"]
        fin = {"nSurfaceLayers": c.fin_layers, "firstLayerThickness": c.fin_first_layer_m,
               "minThickness": c.fin_first_layer_m / 3}
        lc["layers"] = {"whale_body": {"nSurfaceLayers": c.layers}, "whale_flippers": fin,
                        "whale_flukes": fin}
    lc["relativeSizes"] = False
    lc["firstLayerThickness"] = c.first_layer_m
    lc["expansionRatio"] = c.layer_expansion
    # the smallest layer thickness kept: a third of the first layer's
    lc["minThickness"] = c.first_layer_m / 3
    d.writeFile()


def _write_control(case: Path, scene, p: CaseParameters, static_whale: bool) -> None:
    """controlDict: the plugin library, the loads function object (or OpenFOAM's forces for a
    flow-only case without the plugin), the times."""
    d = parsed_dict(case / "system" / "controlDict")
    lib = f'"{plugin_lib()}"'
    if static_whale and not plugin_lib().is_file():
        # a flow-only case without the plugin library: OpenFOAM's forces in place of loads
        del d["libs"]
        del d["functions"]["loads"]
        d["functions"]["forces"] = stock_forces(scene.flow.rho_kg_m3)
    else:
        d["libs"] = [lib]
        d["functions"]["loads"]["libs"] = [lib]
        d["functions"]["loads"]["rhoInf"] = scene.flow.rho_kg_m3
    d["endTime"] = p.end_time
    d["deltaT"] = p.delta_t
    d["timePrecision"] = p.time_precision
    d["writeInterval"] = p.steps_per_write
    d.writeFile()


def _write_solution(case: Path, c) -> None:
    """fvSolution: PIMPLE's outer correctors (``case.outer_correctors``) and the pressure
    correctors within each (``case.pressure_correctors``); the mesh moves and the step-server
    is asked once a step whatever their number (``moveMeshOuterCorrectors`` off)."""
    d = parsed_dict(case / "system" / "fvSolution")
    d["PIMPLE"]["nOuterCorrectors"] = c.outer_correctors
    d["PIMPLE"]["nCorrectors"] = c.pressure_correctors
    d.writeFile()


def _write_schemes(case: Path, c) -> None:
    """fvSchemes: the time scheme (``case.time_scheme``). With ``backward`` OpenFOAM writes the
    old-time fields (U_0, phi_0, ...) and the mesh's old volumes with every time, so a restart
    has the two levels the scheme needs."""
    d = parsed_dict(case / "system" / "fvSchemes")
    d["ddtSchemes"]["default"] = c.time_scheme
    d.writeFile()


def stock_forces(rho: float) -> dict:
    """OpenFOAM's forces function object on the whale, every step (postProcessing/forces/<t0>/
    force.dat: the totals of whaleLoads' loads.dat, which a case with the plugin writes)."""
    return {"type": "forces", "libs": ['"libforces.so"'], "writeControl": "timeStep",
            "writeInterval": 1, "patches": ["whale"], "rho": "rhoInf", "rhoInf": rho,
            "CofR": [0, 0, 0], "log": "false"}


def _write_mesh_motion(case: Path, c, p: CaseParameters, static_whale: bool) -> None:
    """dynamicMeshDict: the blended mesh motion of the plugin, else the Laplacian."""
    lib = f'"{plugin_lib()}"'
    d = parsed_dict(case / "constant" / "dynamicMeshDict")
    if c.mesh_motion == "blended" and (plugin_lib().is_file() or not static_whale):
        d["motionSolver"] = "whaleBlendedDisplacement"
        d["motionSolverLibs"] = [lib]
        coeffs = d["whaleBlendedDisplacementCoeffs"]
        coeffs["innerDistance"] = p.motion_inner_m
        coeffs["outerDistance"] = p.motion_outer_m
        coeffs["nNeighbours"] = c.motion_neighbours
        coeffs["power"] = c.motion_power
        coeffs["shell"] = c.motion_shell
        # far from the whale, clusters of its points about motion_clusters r_1 across
        coeffs["clusters"] = c.motion_clusters
        # the layer cells turn with the wall (a leading edge's fan of layer cells keeps its shape)
        coeffs["rotation"] = "yes" if c.motion_rotation > 0 else "no"
        if c.motion_rotation > 0:
            coeffs["rotationInner"] = p.rotation_inner_m
            coeffs["rotationDistance"] = p.rotation_distance_m
            coeffs["rotationNeighbours"] = c.motion_rotation_neighbours
        # the new points checked before the mesh moves: an invalid mesh stops the run first
        coeffs["checkMotion"] = "yes"
    else:
        # the Laplacian (also for a flow-only case without the plugin library)
        d["motionSolver"] = "displacementLaplacian"
        d["motionSolverLibs"] = ['"libfvMotionSolvers.so"']
    d.writeFile()


def _write_physics(case: Path, scene) -> None:
    """The viscosity (transportProperties) and the flow model (turbulenceProperties)."""
    c = scene.case
    d = parsed_dict(case / "constant" / "transportProperties")
    d["nu"] = scene.flow.nu_m2_s
    d.writeFile()

    d = parsed_dict(case / "constant" / "turbulenceProperties")
    d["simulationType"] = "laminar" if c.turbulence == "laminar" else "RAS"
    d["RAS"]["RASModel"] = "kOmegaSST"
    d.writeFile()


def _write_initial_fields(case: Path, scene, p: CaseParameters, static_whale: bool) -> None:
    """0.orig: the inflow (ramped in or not), k and omega at the inlet, and the whale's
    pointDisplacement (the step-server's boundary condition, or held still)."""
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
    if static_whale:
        hold_still(case)
        return
    d = parsed_dict(zero / "pointDisplacement")
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


def hold_still(case: Path) -> None:
    """The whale held still on a static mesh: its patch ``fixedValue (0 0 0)`` in
    pointDisplacement (``0.orig`` and ``0`` where they exist) and ``staticFvMesh``, so that
    pimpleFoam neither moves nor checks the mesh (nor asks a step-server); the motion solver's
    entries stay, unread."""
    for zero in ("0.orig", "0"):
        path = case / zero / "pointDisplacement"
        if path.is_file():
            d = parsed_dict(path)
            d["boundaryField"]["whale"] = {"type": "fixedValue", "value": "uniform (0 0 0)"}
            d.writeFile()
    d = parsed_dict(case / "constant" / "dynamicMeshDict")
    d["dynamicFvMesh"] = "staticFvMesh"
    d.writeFile()


def set_decomposition(case: Path, ranks: int, method: str = "hierarchical") -> None:
    """system/decomposeParDict for ``ranks`` subdomains.

    ``method`` (``case.decomposition`` as recorded, :data:`DECOMPOSITIONS`): "hierarchical"
    writes ``hierarchical (ranks 1 1)``; "case" keeps the case's own method and coefficients
    (``simple (1 2 1)``, ``scotch`` where OpenFOAM has it, ...) and sets only
    numberOfSubdomains.
    Raises :class:`~adapter.errors.CaseError` when the case's own ``simple`` or
    ``hierarchical`` split ``n`` does not make ``ranks`` subdomains.
    """
    path = Path(case) / "system" / "decomposeParDict"
    d = parsed_dict(path)
    d["numberOfSubdomains"] = ranks
    if method == "hierarchical":
        d["method"] = "hierarchical"
        d["coeffs"] = {"n": f"({ranks} 1 1)", "order": "xyz"}
    else:
        _check_split(d, ranks, path)
    d.writeFile()


def _check_split(d, ranks: int, path: Path) -> None:
    """A ``simple`` or ``hierarchical`` split ``n`` must make ``ranks`` subdomains."""
    method = str(d["method"]) if "method" in d else ""
    if method not in ("simple", "hierarchical"):
        return
    for key in (f"{method}Coeffs", "coeffs"):
        if key in d and "n" in d[key]:
            try:
                split = [int(v) for v in d[key]["n"]]
            except (TypeError, ValueError):
                return          # decomposePar says what is wrong with it
            break
    else:
        return
    if math.prod(split) != ranks:
        raise CaseError(f"{path}: {method} n ({' '.join(map(str, split))}) makes "
                        f"{math.prod(split)} subdomains, not the {ranks} ranks asked for; "
                        "edit its n or run with as many ranks (--np)")


def choose_decomposition(case: Path, value: str, base_dir: str | Path = ".") -> str:
    """The decomposition to record for ``case.decomposition = value``: a name of
    :data:`DECOMPOSITIONS` as it is; else a decomposeParDict file (relative to ``base_dir``,
    the scene file's folder), copied to ``<case>/system/decomposeParDict``: "case"."""
    if value in DECOMPOSITIONS:
        return value
    src = Path(value).expanduser()
    src = src if src.is_absolute() else Path(base_dir) / src
    if not src.is_file():
        raise CaseError(f"case.decomposition = {value!r}: neither one of "
                        f"{', '.join(DECOMPOSITIONS)} nor a decomposeParDict file ({src} is "
                        "missing)")
    shutil.copyfile(src, Path(case) / "system" / "decomposeParDict")
    return "case"


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




#: the fvOptions entry of the frame's body force (docs/openfoam-plugin.md, "The whale's frame")
FRAME_OPTION = "frameAcceleration"
_FOAM_HEADER = """FoamFile
{{
    version     2.0;
    format      ascii;
    class       dictionary;
    location    "{location}";
    object      {name};
}}
"""


def use_frame_inflow(case: Path, folders=("0.orig", "0")) -> None:
    """Switch a prepared case to the flow in the whale's frame: the inlet of ``U``
    (in ``folders`` where they exist: ``0.orig`` and ``0``, or a time folder to start from)
    becomes ``whaleFrameInletVelocity``, its value the
    inlet's until the first exchange (a ramped inflow's start: its table is dropped, the frame
    decides the inflow from the first step on), and ``system/fvOptions`` gets the
    ``whaleFrameAcceleration`` body force. Both follow the frame the step-server sends with
    every DISPLACEMENT (adapter.coupling.frame); a case not switched keeps its inflow."""
    case = Path(case)
    for zero in folders:
        path = case / zero / "U"
        if not path.is_file():
            continue
        d = parsed_dict(path)
        value = d["boundaryField"]["inlet"].get("value", "uniform $Uinlet")
        d["boundaryField"]["inlet"] = {"type": "whaleFrameInletVelocity", "value": value}
        d.writeFile()
    path = case / "system" / "fvOptions"
    path.write_text(_FOAM_HEADER.format(location="system", name="fvOptions"))
    d = parsed_dict(path)
    d[FRAME_OPTION] = {"type": "whaleFrameAcceleration", "libs": [f'"{plugin_lib()}"'],
                       "fields": "(U)"}
    d.writeFile()
