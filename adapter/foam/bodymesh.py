"""The meshed body checked against its surface, before any solver runs.

snappyHexMesh refines at a surface only where an edge of the background mesh cuts it: a body
thinner than the background cell can be missed altogether ("Number of intersected edges : 0"
in the log's initial surface intersections), and the whale patch is then a few coarse faces
that snapping pulls onto the body, with an area and volume near the surface's. So the check
compares four figures of the whale patch (``constant/polyMesh``) with the surface
(``constant/triSurface/whale.stl``) and the case's own snappyHexMeshDict:

* the face count against the fewest the surface's refinement level implies: the surface's
  area over the square of the cell at the level's minimum, times :data:`FACE_SHARE`;
* the area and the enclosed volume (the divergence theorem over the patch, whose normals
  point into the body) against the STL's, within :data:`AREA_TOLERANCE` and
  :data:`VOLUME_TOLERANCE`;
* with prism layers asked for, the share of the area that got them against
  :data:`MIN_LAYER_AREA`.

:func:`body_check` returns the figures and ``refused``, a one-line message naming the cause
and the setting that fixes it, or None; :func:`refuse_if_bad` raises it as a
:class:`~adapter.errors.MeshError`. See docs/case.md, "The mesh against the body".
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np

from adapter.errors import MeshError
from adapter.foam import symmetry
from adapter.foam.dictionaries import parsed_dict
from adapter.foam.foamascii import (
    face_area_vectors,
    mesh_file,
    read_boundary,
    read_faces,
    read_points,
)

#: the whale patch has at least this share of the faces its surface level implies
FACE_SHARE = 0.5
#: the patch's area within this relative difference of the STL's
AREA_TOLERANCE = 0.25
#: the patch's enclosed volume within this relative difference of the STL's
VOLUME_TOLERANCE = 0.25
#: with prism layers asked for, at least this share of the whale's area has them
MIN_LAYER_AREA = 0.5

_INITIAL = re.compile(r"Determining initial surface intersections(.*?)Calculated surface "
                      r"intersections", re.S)
_INTERSECTED = re.compile(r"Number of intersected edges\s*:\s*(\d+)")


def patch_figures(case, patch: str = "whale") -> dict:
    """``faces``, ``area_m2`` and ``volume_m3`` (enclosed, from the faces' area vectors and
    centres: V = -1/3 sum c_f . S_f, the patch's normals pointing out of the water) of a patch
    of ``constant/polyMesh``."""
    boundary = read_boundary(mesh_file(case, None, "boundary"))
    if patch not in boundary:
        raise MeshError(f"{case}: the mesh has no {patch} patch (patches: "
                        f"{', '.join(boundary)}); see {Path(case) / 'log.snappyHexMesh'}")
    start, n = boundary[patch]["startFace"], boundary[patch]["nFaces"]
    faces = read_faces(mesh_file(case, None, "faces"))[start:start + n]
    points = read_points(mesh_file(case, None, "points"))
    s = face_area_vectors(points, faces)
    centres = np.array([points[f].mean(axis=0) for f in faces]) if n else np.zeros((0, 3))
    return {"faces": int(n), "area_m2": float(np.linalg.norm(s, axis=1).sum()),
            "volume_m3": float(-(centres * s).sum() / 3.0)}


def stl_figures(path) -> dict:
    """``area_m2`` and ``volume_m3`` (enclosed, whatever the orientation) of a closed STL."""
    from adapter.body.meshfile import read_surface
    from adapter.body.planform import triangle_areas

    points, faces = read_surface(path)
    tri = np.concatenate([f if f.shape[1] == 3 else np.concatenate([f[:, :3], f[:, [0, 2, 3]]])
                          for f in faces])
    a, b, c = points[tri[:, 0]], points[tri[:, 1]], points[tri[:, 2]]
    return {"area_m2": float(triangle_areas(points[tri]).sum()),
            "volume_m3": float(abs(np.einsum("ij,ij->i", a, np.cross(b, c)).sum()) / 6.0)}


def initial_intersections(log_text: str) -> int | None:
    """The most background edges that cut the surface in snappyHexMesh's initial surface
    intersections (before any refinement); None when the log has no such section."""
    m = _INITIAL.search(log_text)
    if not m:
        return None
    counts = [int(v) for v in _INTERSECTED.findall(m.group(1))]
    return max(counts) if counts else None


def mesh_levels(case) -> dict:
    """The whale's surface ``level`` (min, max) and ``layers`` (0 without the layer stage) in
    the case's system/snappyHexMeshDict."""
    path = Path(case) / "system" / "snappyHexMeshDict"
    d = parsed_dict(path).content
    try:
        level = [int(v) for v in
                 d["castellatedMeshControls"]["refinementSurfaces"]["whale"]["level"]]
    except (KeyError, TypeError, ValueError):
        raise MeshError(f"{path}: no castellatedMeshControls/refinementSurfaces/whale/level "
                        "(min max); the whale's surface levels are needed to check its mesh"
                        ) from None
    layers = 0
    if str(d.get("addLayers", "no")).lower() in ("yes", "on", "true", "1"):
        # the body's entry when the fins have layers of their own (adapter.foam.finpatches)
        asked = d["addLayersControls"]["layers"]
        entry = asked.get("whale") or asked.get("whale_body") or {}
        layers = int(entry.get("nSurfaceLayers", 0))
    return {"level": level, "layers": layers}


def body_check(case, record: dict, layers: dict | None = None) -> dict:
    """The figures of the whale patch against the surface and the case's levels, and
    ``refused``: the one-line reason the mesh misses or mangles the body, or None.

    ``record``: the case record (``parameters/cell_size``, ``body_size_m``, ``length_m``);
    ``layers``: :func:`~adapter.foam.mesh.layer_record`'s table (``area_with_layers``)."""
    case = Path(case)
    mesh = patch_figures(case)
    if symmetry.is_half(case):
        # the half y >= 0 of the whale: its area and, with the plane through the origin, its
        # enclosed volume are half the surface's (adapter/foam/symmetry.py)
        mesh = {k: 2 * v for k, v in mesh.items()}
    stl = stl_figures(case / "constant" / "triSurface" / "whale.stl")
    levels = mesh_levels(case)
    cell = float(min(record["parameters"]["cell_size"]))
    surface_cell = cell / 2 ** levels["level"][0]
    log = case / "log.snappyHexMesh"
    out = {
        "faces": mesh["faces"],
        "faces_implied": int(math.ceil(FACE_SHARE * stl["area_m2"] / surface_cell**2)),
        "surface_cell_m": surface_cell,
        "area_m2": mesh["area_m2"], "stl_area_m2": stl["area_m2"],
        "area_ratio": mesh["area_m2"] / stl["area_m2"],
        "volume_m3": mesh["volume_m3"], "stl_volume_m3": stl["volume_m3"],
        "volume_ratio": mesh["volume_m3"] / stl["volume_m3"],
        "layers_asked": levels["layers"],
        "area_with_layers": (layers or {}).get("area_with_layers"),
        "initial_intersected_edges": (initial_intersections(log.read_text(errors="replace"))
                                      if log.is_file() else None),
    }
    out["refused"] = _reason(out, levels, cell, record)
    return out


def _reason(f: dict, levels: dict, cell: float, record: dict) -> str | None:
    size = record.get("body_size_m") or [0.0, 0.0, 0.0]
    thickness = float(min(size[1], size[2]))
    length = float(record.get("length_m") or size[0])
    level = levels["level"][0]
    if f["faces"] < f["faces_implied"]:
        count = (f"the whale patch has {f['faces']} faces where refinement level {level} "
                 f"({f['surface_cell_m']:.3g} m cells) implies at least {f['faces_implied']} "
                 f"for its {f['stl_area_m2']:.3g} m2")
        if f["initial_intersected_edges"] == 0 and thickness > 0:
            # a long body's section holds a grid line when its diameter is >= cell x sqrt 2
            most = _floor2(thickness / math.sqrt(2) / length)
            return (f"the mesh misses the body: no edge of the {cell:.3g} m background cells "
                    f"cuts its surface (it is {thickness:.3g} m thick), so snappyHexMesh "
                    f"refined nothing there and {count}; set case.background_cell to at most "
                    f"{most:g} (body lengths, {most * length:.3g} m: the thickness / sqrt 2), "
                    "or case.background_cell_m if the scene sets that")
        return (f"the mesh misses the body: {count} (see log.snappyHexMesh); lower "
                "case.background_cell or raise case.refinement")
    for what, key, tol in (("area", "area", AREA_TOLERANCE),
                           ("enclosed volume", "volume", VOLUME_TOLERANCE)):
        ratio = f[f"{key}_ratio"]
        if not abs(ratio - 1.0) <= tol:
            unit = "m2" if key == "area" else "m3"
            return (f"the mesh mangles the body: the whale patch's {what} is "
                    f"{f[f'{key}_{unit}']:.4g} {unit}, {ratio:.0%} of the surface's "
                    f"({f[f'stl_{key}_{unit}']:.4g} {unit} in constant/triSurface/"
                    f"whale.stl; allowed {1 - tol:.0%}-{1 + tol:.0%}); raise case.refinement "
                    f"(its surface cells are {f['surface_cell_m']:.3g} m) or lower "
                    "case.background_cell")
    covered = f["area_with_layers"]
    if f["layers_asked"] > 0 and covered is not None and covered < MIN_LAYER_AREA:
        return (f"the mesh mangles the body's wall: prism layers on {covered:.0%} of the "
                f"whale's area (case.layers = {f['layers_asked']}; at least "
                f"{MIN_LAYER_AREA:.0%} expected); raise case.refinement, or set case.layers "
                "= 0 to mesh without layers")
    return None


def _floor2(x: float) -> float:
    """``x`` rounded down to two significant digits."""
    step = 10.0 ** (math.floor(math.log10(x)) - 1)
    return round(math.floor(x / step + 1e-9) * step, 12)


def refuse_if_bad(check: dict) -> None:
    """Raise :class:`~adapter.errors.MeshError` with the check's reason, if it has one."""
    if check.get("refused"):
        raise MeshError(check["refused"])
