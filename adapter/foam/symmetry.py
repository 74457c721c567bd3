"""Half the domain when the flow is mirror-symmetric about y = 0 (``case.symmetry``).

A body whose surface is its own mirror image about y = 0 (the procedural whale is, to the bit;
a mesh file is checked: every point mirrored has a point within :data:`MIRROR_TOLERANCE` body
lengths), driven by a motion that keeps the mirror (the whale's stroke; a rigid motion without
sideways translation and rotating, if at all, about an axis along y through y = 0), makes a flow
symmetric about y = 0. ``case.symmetry = "auto"`` then meshes the half y >= 0 only: the
blockMesh box starts at y = 0, where a ``symmetryPlane`` patch named :data:`PATCH` replaces
that side of ``sides`` in the mesh and in every field of ``0.orig`` (U, p, k, omega, nut,
pointDisplacement: its points keep to the plane, the whale's points on it included, as the
motion's ``constrainDisplacement`` applies the plane's constraint). ``"off"``: the full domain.
``"mirror"``: the full domain on a mirror-symmetric mesh: the half is meshed as for "auto",
then OpenFOAM's ``mirrorMesh`` adds its mirror image and the plane's faces become inner faces
(:func:`mirror_half_mesh`), so that the mesh does not break the mirror where snappyHexMesh's
full-domain mesh does (its two halves differ by a few dozen cells); the fields are the full
domain's and the loads the whole body's as they are.

The loads of a half are made the whole body's where they are read (:func:`whole_body`): the
forces along x and z, the power and the moment about y doubled; the sideways force and the
moments about x and z are zero for the whole by the mirror (the half's own are not meaningful).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from adapter.jsonfiles import CASE_RECORD, SYMMETRY_PLANE

#: the symmetry plane's patch
PATCH = "symmetry"
#: a mirrored point within this many body lengths of a surface point counts as matched
MIRROR_TOLERANCE = 1e-6
#: the fields of 0.orig that get the plane
FIELDS = ("U", "p", "k", "omega", "nut", "pointDisplacement")
#: the record key (adapter-case.json): True for a half-domain case
RECORD_KEY = SYMMETRY_PLANE
#: the record key: True for a full-domain case meshed as a half and its mirror image
MIRROR_KEY = "mirror_mesh"


def is_mirror_symmetric(points, length: float, tolerance: float = MIRROR_TOLERANCE) -> bool:
    """Whether the (N, 3) ``points`` mirrored about y = 0 each land within ``tolerance`` *
    ``length`` of one of them."""
    from scipy.spatial import cKDTree

    pts = np.asarray(points, dtype=float)
    mirrored = pts * np.array([1.0, -1.0, 1.0])
    distance, _ = cKDTree(pts).query(mirrored)
    return bool(np.max(distance) <= tolerance * length)


def motion_keeps_the_mirror(scene) -> bool:
    """Whether the scene's motion keeps a mirror-symmetric body so (see the module)."""
    r = scene.rigid
    if not r.enabled:
        return True           # the whale's stroke: in the x-z plane
    if r.translation_m[1] != 0.0:
        return False
    if r.rotation_deg == 0.0:
        return True
    axis = np.asarray(r.rotation_axis, dtype=float)
    along_y = axis[0] == 0.0 and axis[2] == 0.0 and axis[1] != 0.0
    return bool(along_y and r.rotation_centre_m[1] == 0.0)


def use_half_domain(scene, surface) -> bool:
    """``case.symmetry`` "auto" with a mirror-symmetric body and motion: True."""
    if scene.case.symmetry != "auto" or not motion_keeps_the_mirror(scene):
        return False
    return is_mirror_symmetric(surface.points, surface.length)


def use_mirror_mesh(scene, surface) -> bool:
    """``case.symmetry`` "mirror": True, and a body or motion that is not mirror-symmetric is
    refused (:class:`~adapter.errors.SceneError`)."""
    if scene.case.symmetry != "mirror":
        return False
    if not (motion_keeps_the_mirror(scene)
            and is_mirror_symmetric(surface.points, surface.length)):
        from adapter.errors import SceneError

        raise SceneError('case.symmetry = "mirror" needs a whale and a motion that are '
                         'mirror-symmetric about y = 0; this scene\'s are not: use "off"')
    return True


def half_box(domain_min, domain_max, cells, cell_size) -> tuple:
    """(domain_min, domain_max, cells) of the half y >= 0 of the full box: from y = 0 to the
    full box's ymax rounded up to whole background cells of the full box's size."""
    ny = max(1, math.ceil(domain_max[1] / cell_size[1] - 1e-9))
    lo = (domain_min[0], 0.0, domain_min[2])
    hi = (domain_max[0], ny * cell_size[1], domain_max[2])
    return lo, hi, (cells[0], ny, cells[2])


def write_half_domain(case: Path, fields: bool = True) -> None:
    """The :data:`PATCH` plane at the blockMesh box's ymin face (the box itself written from
    :func:`half_box`'s corners), and in every field of ``0.orig`` unless not ``fields`` (a
    mirrored mesh's)."""
    from adapter.foam.dictionaries import parsed_dict

    d = parsed_dict(case / "system" / "blockMeshDict")
    boundary = d["boundary"]
    sides = boundary[boundary.index("sides") + 1]
    # (0 1 5 4): the face at ymin (vertices 0 1 5 4 all at $ymin)
    sides["faces"] = [f for f in sides["faces"] if [str(v) for v in f] != ["0", "1", "5", "4"]]
    boundary += [PATCH, {"type": "symmetryPlane", "faces": [[0, 1, 5, 4]]}]
    d.writeFile()
    for name in FIELDS if fields else ():
        f = parsed_dict(case / "0.orig" / name)
        f["boundaryField"][PATCH] = {"type": "symmetryPlane"}
        f.writeFile()


MIRROR_MESH_DICT = """FoamFile
{
    version 2.0; format ascii; class dictionary; object mirrorMeshDict;
}
planeType       pointAndNormal;
pointAndNormalDict { point (0 0 0); normal (0 -1 0); }
planeTolerance  1e-6;
"""


#: the fields snappyHexMesh's layer stage writes into 0/
LAYER_FIELDS = ("nSurfaceLayers", "thickness", "thicknessFraction")


def mirror_half_mesh(case: Path) -> None:
    """``constant/polyMesh`` (the half y >= 0 with the :data:`PATCH` plane) made whole by its
    mirror image (``mirrorMesh -overwrite``): the plane's faces become inner faces and the
    plane, left empty, is taken out of the boundary, so that the mesh's patches are the full
    domain's; snappyHexMesh's layer fields (:data:`LAYER_FIELDS`, the half's) are removed.
    Raises :class:`~adapter.errors.MeshError` when faces stay on the plane."""
    import re

    from adapter.errors import MeshError
    from adapter.foam.foamascii import read_boundary
    from adapter.foam.tools import run_utility

    (case / "system" / "mirrorMeshDict").write_text(MIRROR_MESH_DICT)
    run_utility(case, ["mirrorMesh", "-overwrite"])
    # snappyHexMesh's layer fields are the half's: mirrorMesh maps no field
    for name in LAYER_FIELDS:
        (case / "0" / name).unlink(missing_ok=True)
    path = case / "constant" / "polyMesh" / "boundary"
    patches = read_boundary(path)
    if patches[PATCH]["nFaces"] != 0:
        raise MeshError(f"{case}: mirrorMesh left {patches[PATCH]['nFaces']} faces on the "
                        f"plane y = 0 (see {case / 'log.mirrorMesh'})")
    text = path.read_text()
    text, gone = re.subn(rf"\n\s*{PATCH}\s*\{{[^{{}}]*\}}", "", text)
    text, counted = re.subn(rf"^{len(patches)}\s*$", str(len(patches) - 1), text, count=1,
                            flags=re.M)
    assert gone == 1 and counted == 1, path
    path.write_text(text)


def is_half(case) -> bool:
    """Whether the case (its adapter-case.json) is a half-domain case."""
    path = Path(case) / CASE_RECORD
    if not path.is_file():
        return False
    return bool(json.loads(path.read_text()).get(RECORD_KEY, False))


def whole_body(columns: dict) -> dict:
    """loads.dat columns (``region:Fx``, ...) of a half made the whole body's (see the module):
    a new dict, ``Time`` as it is, the areas doubled too."""
    out = {}
    for key, values in columns.items():
        what = key.rsplit(":", 1)[-1]
        if what in ("Fy", "Fpy", "Fvy", "Mx", "Mz", "Mpx", "Mpz", "Mvx", "Mvz"):
            out[key] = np.zeros_like(values)
        elif what[:1] in ("F", "P", "M", "A"):
            out[key] = 2.0 * np.asarray(values)
        else:
            out[key] = values
    return out


def whole_body_forces(forces: np.ndarray) -> np.ndarray:
    """The forces function object's (T, 10) rows (time, total, pressure, viscous force) of a
    half made the whole body's: x and z doubled, y zero."""
    out = np.array(forces, dtype=float, copy=True)
    out[:, 1:] *= np.tile([2.0, 0.0, 2.0], 3)
    return out
