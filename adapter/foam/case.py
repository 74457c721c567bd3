"""The OpenFOAM whale-in-channel case folder: prepare it from the template and the scene, and
read back what was recorded about it (``whale-adapter run-case``).

The template case is ``foam_case/`` at the top of the repository. :func:`prepare_case` copies it,
writes the scene's whale surface to ``constant/triSurface/whale.stl`` and sets the dictionaries
(:mod:`adapter.foam.dictionaries`) from the numbers of
:func:`~adapter.foam.parameters.case_parameters`. The rest of the case's life is in its
neighbours: meshing (:mod:`adapter.foam.mesh`), running the OpenFOAM tools
(:mod:`adapter.foam.tools`), watching the solver's log (:mod:`adapter.foam.logs`), the run
(:mod:`adapter.foam.run`) and its summary (:mod:`adapter.foam.summary`); the command is
:mod:`adapter.foam.command`. See docs/case.md.
"""

from __future__ import annotations

import json
import os
import shutil
from dataclasses import asdict, replace
from pathlib import Path

import numpy as np

from adapter import jsonfiles, resources
from adapter.body.regions import FLIPPERS
from adapter.coupling.protocol import SOCKET_NAME
from adapter.errors import CaseError, SceneError
from adapter.foam import symmetry
from adapter.foam.casescene import write_case_scene
from adapter.foam.dictionaries import (
    EDGE_STLS,
    PLUGIN_LIB,
    REGIONS_STL,
    choose_decomposition,
    write_dictionaries,
)
from adapter.foam.loads import body_dimensions
from adapter.foam.parallel import resolve_ranks
from adapter.foam.parameters import CaseParameters, case_parameters, level_cell_m

#: the template case (foam_case/ of the repository, adapter/_foam_case in a wheel)
TEMPLATE_DIR = resources.TEMPLATE_DIR
#: what prepare_case records about the case (scene, derived numbers, mesh)
CASE_RECORD = jsonfiles.CASE_RECORD
#: the figures of the case's run (:mod:`adapter.foam.summary`)
CASE_SUMMARY = jsonfiles.CASE_SUMMARY
#: the flippers' triangles alone (constant/triSurface/), snappyHexMesh's refinement region
FLIPPERS_STL = "flippers.stl"
FLUKE_BLADE_STL = "flukeBlade.stl"

__all__ = ["CASE_RECORD", "CASE_SUMMARY", "Case", "FLIPPERS_STL", "FLUKE_BLADE_STL",
           "LENGTH_MISMATCH", "PLUGIN_LIB", "REGIONS_STL", "SOCKET_NAME", "TEMPLATE_DIR",
           "check_length", "prepare_case", "read_record", "write_json"]


def prepare_case(scene, case_dir, *, ranks: int | None = None, static_whale: bool = False,
                 scene_file: str | os.PathLike | None = None, surface=None) -> CaseParameters:
    """Make a ready-to-mesh case in ``case_dir`` from the template and the scene.

    Parameters
    ----------
    scene : a :class:`~adapter.scene.Scene`.
    case_dir : folder to create; it must not hold a case yet (no ``system/controlDict``).
    ranks : MPI ranks (decomposeParDict); None takes ``scene.case.ranks``; 0 (the scene's
        default): the machine's cores (:func:`~adapter.foam.parallel.machine_cores`).
    static_whale : the whale patch gets ``fixedValue uniform (0 0 0)`` instead of the
        step-server boundary condition, and the plugin library is not loaded (a flow-only case,
        no server needed).
    scene_file : the scene's TOML file the scene was loaded from, recorded (provenance).
    surface : a :class:`~adapter.body.surface.WhaleSurface`; None builds the scene's.

    Returns the :class:`CaseParameters` written; they are also recorded in
    ``<case>/adapter-case.json``. The scene itself, every value, goes into
    ``<case>/adapter-scene.toml`` (:mod:`adapter.foam.casescene`): the one the case's
    step-server loads.
    """
    case = Path(case_dir)
    if (case / "system" / "controlDict").exists():
        raise CaseError(
            f"{case} already holds a case; run it with `whale-adapter run-case --case {case}`, "
            "or remove it / choose another --case to prepare a new one"
        )
    if not (TEMPLATE_DIR / "system" / "controlDict").is_file():
        raise CaseError(f"the template case {TEMPLATE_DIR} is missing; reinstall the "
                        "package (pip install . or pip install -e . from the repository)")
    if surface is None:
        from adapter.body.geometry import build_surface

        surface = build_surface(scene)
    check_length(scene, surface)
    given = scene
    if not surface.is_whale:
        # a body without the whale's landmarks has no flippers or flukes to refine at (or to
        # give layers of their own)
        scene = scene.replace(case={"flipper_level": 0, "fluke_level": 0, "fin_layers": 0,
                                    "flipper_edge_level": 0, "fluke_edge_level": 0})
    fins = _flippers_to_refine(scene, surface)
    if fins is None:
        scene = scene.replace(case={"flipper_level": 0, "flipper_edge_level": 0})
    case.mkdir(parents=True, exist_ok=True)
    shutil.copytree(TEMPLATE_DIR, case, dirs_exist_ok=True)
    write_case_scene(given, case, f"scene file {Path(scene_file).resolve()}" if scene_file
                     else f"preset {scene.name}")
    stl = _write_surfaces(case, surface, fins)
    pts = np.asarray(surface.points)
    ranks = resolve_ranks(ranks if ranks is not None else scene.case.ranks)
    params = case_parameters(scene, pts.min(axis=0), pts.max(axis=0), ranks=ranks,
                             length=surface.length)
    # the flukes' blade, case.fluke_clearance of its cells behind the hinge (so that the
    # hinge's cells are alike, in cells, on every mesh of the flow study): its refinement region
    if scene.case.fluke_level > 0:
        surface.write_fluke_blade_stl(stl.with_name(FLUKE_BLADE_STL),
                                      scene.case.fluke_clearance * params.fluke_cell_m)
    _write_edges(stl, scene, surface, fins, params)
    decomposition = choose_decomposition(case, scene.case.decomposition, scene.base_dir)
    half = symmetry.use_half_domain(scene, surface)
    mirror = symmetry.use_mirror_mesh(scene, surface)
    meshed_half = half or mirror
    if meshed_half:
        lo, hi, cells = symmetry.half_box(params.domain_min, params.domain_max, params.cells,
                                          params.cell_size)
        params = replace(params, domain_min=lo, domain_max=hi, cells=cells)
    write_dictionaries(case, scene, params, static_whale, decomposition)
    if meshed_half:
        symmetry.write_half_domain(case, fields=half)
    Case(case).save({**_case_record(scene, surface, params, scene_file, static_whale, half,
                                    decomposition),
                     symmetry.MIRROR_KEY: mirror})
    return params


def _flippers_to_refine(scene, surface):
    """The surface whose flippers snappyHexMesh refines at (case.flipper_level): the whale's
    own; for the procedural whale without its flippers (``geometry.flippers = false``) the
    flippered one's, so that the two runs of a drag difference have the same cells; None for
    a surface with no flippers to refine at."""
    if not surface.is_whale:
        return None
    if surface.region_areas()["flippers"]:
        return surface
    g = scene.geometry
    if g.source == "procedural" and not g.flippers:
        from adapter.body.geometry import build_surface

        return build_surface(scene.replace(geometry={"flippers": True}))
    return None


def _write_surfaces(case: Path, surface, fins) -> Path:
    """The whale's surface into ``constant/triSurface/``: ``whale.stl``, its regions and the
    flippers of ``fins`` alone (:func:`_flippers_to_refine`); returns the path of whale.stl."""
    stl = case / "constant" / "triSurface" / "whale.stl"
    surface.write(stl)
    # the same triangles as three solids (body, flippers, flukes) for the loads' regions; a
    # second file, as snappyHexMesh makes one patch per solid (whale_body, ...) of a
    # multi-solid STL and the whale must stay one patch
    surface.write_regions_stl(stl.with_name(REGIONS_STL))
    # the flippers alone: snappyHexMesh's refinement region around them (case.flipper_level)
    if fins is not None:
        fins.write_regions_stl(stl.with_name(FLIPPERS_STL), only="flippers")
    return stl


def _write_edges(stl: Path, scene, surface, fins, params: CaseParameters) -> None:
    """The fins' leading edges (case.flipper_edge_level, fluke_edge_level): snappyHexMesh's
    refinement regions ``flipperEdges.stl`` and ``flukeEdges.stl``, sections two such cells
    wide; the flukes' is their blade's (case.fluke_clearance of the blade's cells, or of the
    edge's without finer blade cells, behind the hinge)."""
    c = scene.case
    if c.flipper_edge_level > 0 and fins is not None:
        cell = level_cell_m(params.cell_size, c.flipper_edge_level)
        fins.write_leading_edge_stl(stl.with_name(EDGE_STLS[0]),
                                    fins.triangle_regions() == FLIPPERS, "flipperEdges", 2 * cell)
    if c.fluke_edge_level > 0:
        cell = level_cell_m(params.cell_size, c.fluke_edge_level)
        blade = surface.fluke_blade(c.fluke_clearance * (params.fluke_cell_m or cell))
        surface.write_leading_edge_stl(stl.with_name(EDGE_STLS[1]), blade, "flukeEdges", 2 * cell)


def _case_record(scene, surface, params: CaseParameters, scene_file, static_whale: bool,
                 half: bool, decomposition: str) -> dict:
    """What prepare_case records about the case (``adapter-case.json``)."""
    pts = np.asarray(surface.points)
    # a body without the whale's landmarks is all body: its "tail base" lies past its end
    tail_base_s = float(surface.s[surface.landmarks["tail_base"]]) if surface.is_whale else 2.0
    st = scene.stroke
    if scene.rigid.enabled:
        ramp = scene.rigid.ramp_cycles * scene.period_s
    else:
        ramp = (st.ramp_cycles if st.reversal == "smooth" else st.fluke_ramp) * scene.period_s
    return {
        "scene_file": str(Path(scene_file).resolve()) if scene_file else None,
        # the start-up discarded from the figures: the ramp, at least one cycle
        "ramp_s": max(ramp, scene.period_s),
        "rho_kg_m3": scene.flow.rho_kg_m3,
        "nu_m2_s": scene.flow.nu_m2_s,
        "body": body_dimensions(surface, tail_base_s),
        "gliding": scene.case.gliding,
        "periodic_tolerance": scene.case.periodic_tolerance,
        # the free whale's frame follows the flow's time scheme (adapter/coupling/surge.py)
        "time_scheme": scene.case.time_scheme,
        "preset": scene.name,
        "static_whale": static_whale,
        symmetry.RECORD_KEY: half,
        "length_m": float(surface.length),
        "body_size_m": [float(v) for v in np.ptp(pts, axis=0)],
        "period_s": scene.period_s,
        "speed_m_s": scene.flow.speed_m_s,
        # free swimming (adapter/foam/freerun.py) and the Strouhal number's amplitude
        "free": asdict(scene.free),
        "fluke_amplitude_m": scene.calibration.fluke_amplitude * float(surface.length),
        "max_non_orthogonality": scene.case.max_non_orthogonality,
        "surface_nodes": int(len(pts)),
        "parameters": asdict(params),
        "parallel": {"launcher": scene.case.launcher, "decomposition": decomposition,
                     "parallel_meshing": scene.case.parallel_meshing,
                     "reconstruct": scene.case.reconstruct},
    }


#: how far a mesh file's own length may differ from geometry.length_m
LENGTH_MISMATCH = 0.03


def check_length(scene, surface) -> None:
    """A mesh-file body whose length (rostrum to the farthest x) is not geometry.length_m is
    refused: the stroke amplitude and the calibration are set in units of geometry.length_m,
    the case in units of the mesh's own length (a mesh file is not scaled)."""
    want, have = scene.geometry.length_m, float(surface.length)
    if abs(have / want - 1) > LENGTH_MISMATCH:
        raise SceneError(
            f"the mesh {scene.geometry.source} is {have:.4g} m long (rostrum to the farthest x) "
            f"but geometry.length_m = {want:g} m; mesh files are not scaled: set "
            f"geometry.length_m = {have:.4g} in the scene, or scale the mesh file to "
            f"{want:g} m")


def write_json(path: Path, data: dict) -> None:
    """``data`` as indented strict JSON into ``path`` (the case record, the summary): a NaN
    or infinite figure is written as null (:func:`adapter.jsonfiles.finite`)."""
    jsonfiles.write_json(path, data)


def parallel_settings(record: dict, **given) -> dict:
    """How a case runs on several ranks: ``launcher``, ``decomposition``, ``parallel_meshing``,
    ``reconstruct``; each from ``given`` unless None there, else from the record (prepared from
    the scene's ``[case]``), else the default (a case prepared before these settings)."""
    out = {"launcher": "", "decomposition": "hierarchical", "parallel_meshing": False,
           "reconstruct": False}
    out.update(record.get("parallel") or {})
    out.update({k: v for k, v in given.items() if v is not None})
    return out


def read_record(case_dir) -> dict:
    """The record prepare_case wrote (``<case>/adapter-case.json``)."""
    path = Path(case_dir) / CASE_RECORD
    if not path.is_file():
        raise CaseError(f"{path} is missing: {case_dir} was not made by "
                        "`whale-adapter run-case`, so it is neither meshed nor run; choose "
                        "another (new or empty) --case to prepare a case with --scene/--preset")
    return json.loads(path.read_text())


class Case:
    """A case folder made by :func:`prepare_case` (after foamlib's ``FoamCase``): its path, its
    folders and files as properties, its record (``adapter-case.json``, read once, written by
    :meth:`save`) and its summary (``adapter-summary.json``).

    >>> case = Case("out/case")
    >>> case.record["parameters"]["ranks"]           # read on first use, CaseError if missing
    >>> case.save({**case.record, "mesh": info})      # the one writer of the record
    """

    def __init__(self, path: str | os.PathLike) -> None:
        self.path = Path(path)
        self._record: dict | None = None

    def __repr__(self) -> str:
        return f"Case({str(self.path)!r})"

    def __fspath__(self) -> str:
        return str(self.path)

    def __truediv__(self, other: str | os.PathLike) -> Path:
        return self.path / other

    # -- the record ---------------------------------------------------------------------------
    @property
    def record_file(self) -> Path:
        return self.path / CASE_RECORD

    @property
    def has_record(self) -> bool:
        return self.record_file.is_file()

    @property
    def record(self) -> dict:
        """The record, read on first use (:func:`read_record`: a one-line
        :class:`~adapter.errors.CaseError` when the folder has none)."""
        if self._record is None:
            self._record = read_record(self.path)
        return self._record

    def reload(self) -> dict:
        """The record as the file holds it now (another step may have written it)."""
        self._record = None
        return self.record

    def save(self, record: dict | None = None) -> None:
        """Write ``record`` (None: the one held) as the case's record, and hold it."""
        if record is not None:
            self._record = record
        write_json(self.record_file, self.record)

    # -- the summary --------------------------------------------------------------------------
    @property
    def summary_file(self) -> Path:
        return self.path / CASE_SUMMARY

    @property
    def has_summary(self) -> bool:
        return self.summary_file.is_file()

    @property
    def summary(self) -> dict:
        """The summary of the last run as written, ``{}`` when the case has none yet (read
        each time: a run rewrites it)."""
        return json.loads(self.summary_file.read_text()) if self.has_summary else {}

    def save_summary(self, summary: dict) -> None:
        write_json(self.summary_file, summary)

    # -- folders, dictionaries, logs ----------------------------------------------------------
    @property
    def system(self) -> Path:
        return self.path / "system"

    @property
    def constant(self) -> Path:
        return self.path / "constant"

    @property
    def poly_mesh(self) -> Path:
        return self.constant / "polyMesh"

    @property
    def tri_surface(self) -> Path:
        return self.constant / "triSurface"

    @property
    def control_dict(self) -> Path:
        return self.system / "controlDict"

    def log(self, tool: str) -> Path:
        """The log of an OpenFOAM tool run in the case (``log.<tool>``)."""
        return self.path / f"log.{tool}"

    @property
    def logs(self) -> list[Path]:
        """The tools' logs the case holds (``log.*``), by name."""
        return sorted(p for p in self.path.glob("log.*") if p.is_file())
