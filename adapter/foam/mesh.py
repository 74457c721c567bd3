"""Meshing a prepared case: blockMesh, snappyHexMesh and checkMesh, and what the mesh is
recorded as (cells, the whale patch, quality, the prism layers) in ``adapter-case.json``."""

from __future__ import annotations

import shutil
import time
from pathlib import Path

from adapter.errors import AdapterError, MeshError
from adapter.foam import symmetry
from adapter.foam.bodymesh import body_check, refuse_if_bad
from adapter.foam.case import Case, parallel_settings
from adapter.foam.dictionaries import set_decomposition
from adapter.foam.folders import processor_dirs, restore_zero
from adapter.foam.logs import parse_check_mesh
from adapter.foam.parallel import parallel_command
from adapter.foam.tools import check_foam, run_utility
from adapter.foam.yplus import layer_coverage, parse_layer_report


def mesh_case(case_dir, *, ranks: int | None = None, parallel: bool | None = None,
              launcher: str | None = None) -> dict:
    """blockMesh, snappyHexMesh -overwrite and checkMesh in a prepared case.

    ``parallel`` (None: ``case.parallel_meshing`` as recorded) with ``ranks`` > 1 (None: the
    recorded rank count) runs snappyHexMesh on the ranks (:func:`snappy_on_ranks`, started by
    ``launcher``, None: the recorded one) and reconstructs the mesh into ``constant/polyMesh``.

    Returns the mesh's facts parsed from checkMesh: cells, whale_faces, whale_points,
    max_non_orthogonality, max_skewness, mesh_ok, meshed_on_ranks, and the whale patch against
    its surface (``body_check``, :func:`~adapter.foam.bodymesh.body_check`); also recorded in
    adapter-case.json. Raises :class:`~adapter.errors.SolverRunError` when a utility fails,
    :class:`~adapter.errors.MeshError` when the whale patch is missing or (after recording the
    mesh) when the mesh misses or mangles the body.
    """
    check_foam()
    case = Path(case_dir)
    held = Case(case)
    # a folder not made by run-case is refused before blockMesh touches it
    record = held.record
    settings = parallel_settings(record, parallel_meshing=parallel, launcher=launcher)
    ranks = int(ranks or record["parameters"]["ranks"])
    on_ranks = ranks if settings["parallel_meshing"] and ranks > 1 else 1
    t0 = time.perf_counter()
    run_utility(case, ["blockMesh"])
    if on_ranks > 1:
        snappy_on_ranks(case, on_ranks, settings["launcher"], settings["decomposition"])
    else:
        run_utility(case, ["snappyHexMesh", "-overwrite"])
    # the layers' record from the half's snappyHexMesh fields, before a mirror doubles the mesh
    layers = layer_record(case)
    if record.get(symmetry.MIRROR_KEY):
        symmetry.mirror_half_mesh(case)
    log = run_utility(case, ["checkMesh"])
    info = parse_check_mesh(log.read_text(errors="replace"))
    info["mesh_s"] = round(time.perf_counter() - t0, 2)
    info["meshed_on_ranks"] = on_ranks
    info.update(layers)
    if not info.get("whale_faces"):
        raise MeshError(f"the mesh misses the body: snappyHexMesh made no whale patch; see "
                        f"{case / 'log.snappyHexMesh'} ({no_patch_hint(held.reload())})")
    info["body_check"] = body_check(case, record, info.get("layers"))
    restore_zero(case)
    if held.has_record:
        record = held.reload()
        record["mesh"] = info
        held.save(record)
    # recorded first, so that a run of this mesh is refused for the same reason
    refuse_if_bad(info["body_check"])
    return info


def checked_mesh(case: Path, record: dict) -> dict:
    """The recorded body check of the case's mesh (:mod:`adapter.foam.bodymesh`), made and
    recorded now for a mesh meshed before the check existed; raises
    :class:`~adapter.errors.MeshError` when the mesh misses or mangles the body."""
    mesh = record.get("mesh") or {}
    check = mesh.get("body_check")
    if check is None:
        check = body_check(case, record, mesh.get("layers"))
        record = {**record, "mesh": {**mesh, "body_check": check}}
        Case(case).save(record)
    refuse_if_bad(check)
    return check


def snappy_on_ranks(case: Path, ranks: int, launcher: str = "",
                    decomposition: str = "hierarchical") -> None:
    """snappyHexMesh on ``ranks`` ranks: decomposePar of the blockMesh mesh (the case's
    decomposition), ``snappyHexMesh -overwrite -parallel``, reconstructParMesh into
    ``constant/polyMesh`` (and reconstructPar of the layer fields snappyHexMesh wrote into
    ``processor*/0``); the processor folders are removed (a run decomposes the final mesh)."""
    set_decomposition(case, ranks, decomposition)
    for p in processor_dirs(case):
        shutil.rmtree(p)
    run_utility(case, ["decomposePar", "-force"], log_name="decomposePar.mesh")
    run_utility(case, parallel_command(["snappyHexMesh", "-overwrite"], ranks, launcher),
                log_name="snappyHexMesh")
    run_utility(case, ["reconstructParMesh", "-constant"])
    if any((p / "0").is_dir() for p in processor_dirs(case)):
        run_utility(case, ["reconstructPar", "-withZero", "-time", "0"],
                    log_name="reconstructPar.mesh")
    for p in processor_dirs(case):
        shutil.rmtree(p)


def layer_record(case_dir) -> dict:
    """The whale's prism layers after snappyHexMesh: ``{"layers": {...}}`` with the log's table
    (``faces``, ``faces_with_layers``, ``face_coverage``, ``mean_layers``, ``thickness_m``,
    ``thickness_pct``) and the area-weighted coverage from the ``nSurfaceLayers`` field
    (``area_with_layers``, ``area_full_thickness``); empty when the case has no layers."""
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


def no_patch_hint(record: dict) -> str:
    """Why snappyHexMesh may have kept no whale: cells too coarse for the body, most often."""
    smallest = record.get("parameters", {}).get("smallest_cell_m")
    size = record.get("body_size_m")
    if smallest and size and smallest > 0.25 * min(size[1], size[2]):
        return (f"the smallest cell, {smallest:.3g} m, is too coarse for a body "
                f"{min(size[1], size[2]):.3g} m across: lower case.background_cell (body "
                "lengths) or case.background_cell_m, or raise case.refinement")
    return "is locationInMesh in the water?"

