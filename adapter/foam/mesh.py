"""Meshing a prepared case: blockMesh, snappyHexMesh and checkMesh, and what the mesh is
recorded as (cells, the whale patch, quality, the prism layers) in ``adapter-case.json``."""

from __future__ import annotations

import shutil
import time
from pathlib import Path

from adapter.errors import AdapterError, MeshError
from adapter.foam import finpatches, symmetry
from adapter.foam.bodymesh import body_check, refuse_if_bad
from adapter.foam.case import Case, parallel_settings
from adapter.foam.dictionaries import set_decomposition
from adapter.foam.folders import processor_dirs, restore_zero
from adapter.foam.logs import parse_check_mesh
from adapter.foam.parallel import parallel_command
from adapter.foam.tools import check_foam, run_utility
from adapter.foam.yplus import extruded_faces, layer_coverage, parse_layer_report


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
    # the fins' own layers: the whale meshed as a patch a region, merged back into one
    parts = finpatches.whale_parts(case)
    # the layers' record from the half's snappyHexMesh fields, before a mirror doubles the mesh
    layers = layer_record(case, parts or ("whale",))
    if parts:
        finpatches.merge_whale_patches(case, parts)
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


def layer_record(case_dir, patches: tuple = ("whale",)) -> dict:
    """The whale's prism layers after snappyHexMesh: ``{"layers": {...}}`` with the log's table
    (``faces``, ``faces_with_layers``, ``face_coverage``, ``mean_layers``, ``thickness_m``,
    ``thickness_pct``) and the area-weighted coverage from the ``nSurfaceLayers`` field
    (``area_with_layers``, ``area_full_thickness``) over the whale's ``patches``; meshed as a
    patch a region (:mod:`~adapter.foam.finpatches`), the table's rows are summed over them
    (means weighted by faces) and each region's is kept under ``regions``, its area-weighted
    coverage with it. Empty when the case has no layers."""
    case = Path(case_dir)
    log = case / "log.snappyHexMesh"
    text = log.read_text(errors="replace") if log.is_file() else ""
    rows = parse_layer_report(text)
    if not all(p in rows for p in patches):
        return {}
    report = joined_rows([rows[p] for p in patches], extruded_faces(text))
    try:
        cov = layer_coverage(case, patches)
    except AdapterError:
        cov = {}
    for key in ("area_with_layers", "area_full_thickness"):
        if key in cov:
            report[key] = round(cov[key], 4)
    if "face_coverage" in report:
        report["face_coverage"] = round(report["face_coverage"], 4)
    if len(patches) > 1:
        report["regions"] = {p.removeprefix("whale_"): {**rows[p], **{
            k: round(v, 4) for k, v in cov.get("patches", {}).get(p, {}).items()}}
            for p in patches}
    return {"layers": report}


def joined_rows(rows: list, extruded: tuple | None) -> dict:
    """snappyHexMesh's layer rows of the whale's patches as one: faces summed, the layers and
    thicknesses averaged by faces; ``faces_with_layers`` and ``face_coverage`` from its last
    ``Extruding N out of M faces`` (``extruded``: (N, M); it counts every patch with layers,
    the whale's alone)."""
    faces = sum(r["faces"] for r in rows)
    out: dict = {"faces": faces}
    for key in ("mean_layers", "thickness_m", "thickness_pct"):
        value = sum(r[key] * r["faces"] for r in rows) / faces if faces else 0.0
        out[key] = value if len(rows) > 1 else rows[0][key]
    if extruded is not None:
        n, m = extruded
        out["faces_with_layers"] = n
        out["face_coverage"] = n / m if m else 0.0
    return out


def no_patch_hint(record: dict) -> str:
    """Why snappyHexMesh may have kept no whale: cells too coarse for the body, most often."""
    smallest = record.get("parameters", {}).get("smallest_cell_m")
    size = record.get("body_size_m")
    if smallest and size and smallest > 0.25 * min(size[1], size[2]):
        return (f"the smallest cell, {smallest:.3g} m, is too coarse for a body "
                f"{min(size[1], size[2]):.3g} m across: lower case.background_cell (body "
                "lengths) or case.background_cell_m, or raise case.refinement")
    return "is locationInMesh in the water?"

