"""Surface mesh files: any closed surface meshio reads (STL, OBJ, PLY, VTK, ...) in, the
whale's surface and its region STL out.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from adapter import vtkfiles
from adapter.body.polygons import triangulate
from adapter.body.regions import REGIONS
from adapter.errors import GeometryError

#: what an unknown suffix is told to give instead
FORMATS = ".stl, .obj, .ply, .vtk or .vtp (or another suffix meshio writes)"


def writable(path) -> bool:
    """Does :func:`write_surface` know ``path``'s format (by its suffix: meshio's, or .vtp)?"""
    import meshio

    name = Path(path).name.lower()
    return name.endswith(".vtp") or any(name.endswith(e) for e in meshio.extension_to_filetypes)


def write_surface(path, points, faces, point_data=None) -> None:
    """Write a surface with meshio (.vtp, which meshio does not write, with
    :func:`adapter.vtkfiles.write_vtp`)."""
    if not writable(path):
        raise GeometryError(f"{path}: unknown surface format; give {FORMATS}")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    suffix = path.suffix.lower()
    if suffix == ".vtp":
        vtkfiles.write_vtp(path, points, faces, point_data=point_data)
        return
    import meshio

    if suffix == ".stl":
        cells = [("triangle", triangulate(points, faces))]
    else:
        # int32 indices: PLY has no 64-bit integers (meshio would cast them, saying so)
        cells = [("triangle" if f.shape[1] == 3 else "quad", np.asarray(f, dtype=np.int32))
                 for f in faces]
    mesh = meshio.Mesh(np.asarray(points, dtype=np.float64), cells,
                       point_data=dict(point_data or {}))
    kwargs = {"binary": True} if suffix == ".stl" else {}
    mesh.write(str(path), **kwargs)


def write_region_stl(path, points, triangles, regions, names=REGIONS) -> None:
    """ASCII STL, one solid per name (in this order, empty ones included) holding the
    triangles of that region index; outward normals."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    p = np.asarray(points, dtype=np.float64)
    lines = []
    for k, name in enumerate(names):
        tri = triangles[regions == k]
        a, b, c = p[tri[:, 0]], p[tri[:, 1]], p[tri[:, 2]]
        n = np.cross(b - a, c - a)
        n /= np.maximum(np.linalg.norm(n, axis=1), 1e-300)[:, None]
        lines.append(f"solid {name}")
        for nv, va, vb, vc in zip(n, a, b, c, strict=True):
            lines.append("  facet normal {:.9e} {:.9e} {:.9e}".format(*nv))
            lines.append("    outer loop")
            for v in (va, vb, vc):
                lines.append("      vertex {!r} {!r} {!r}".format(*map(float, v)))
            lines.append("    endloop")
            lines.append("  endfacet")
        lines.append(f"endsolid {name}")
    path.write_text("\n".join(lines) + "\n")


def read_stl_solids(path) -> dict:
    """The triangles of every solid of an ASCII STL: ``{name: (T, 3, 3) array}``, in file
    order (a name given twice gathers both)."""
    solids: dict = {}
    current = None
    verts: list = []
    for line in Path(path).read_text().splitlines():
        words = line.split()
        if not words:
            continue
        if words[0] == "solid":
            current = words[1] if len(words) > 1 else ""
            solids.setdefault(current, [])
        elif words[0] == "vertex":
            verts.append([float(v) for v in words[1:4]])
        elif words[0] == "endloop":
            solids[current].append(verts)
            verts = []
    return {k: np.array(v, dtype=np.float64).reshape(-1, 3, 3) for k, v in solids.items()}


def read_surface(path: str | Path) -> tuple[np.ndarray, list]:
    """Read a closed surface mesh with meshio: (points, faces grouped by corner count)."""
    import meshio

    path = Path(path)
    if not path.is_file():
        raise GeometryError(f"mesh file {path} does not exist")
    try:
        # meshio tells an ASCII STL from a binary one by reading its header as a triangle
        # count, which overflows numpy's uint32 for ASCII text: a warning about nothing
        with np.errstate(over="ignore"):
            mesh = meshio.read(str(path))
    except Exception as exc:  # meshio raises many kinds; say which file and why
        raise GeometryError(f"cannot read {path} with meshio: {exc}") from None
    points = np.asarray(mesh.points, dtype=np.float64)
    if points.shape[1] == 2:
        raise GeometryError(f"{path}: points has shape {points.shape}, expected (N, 3)")
    faces = []
    for block in mesh.cells:
        if block.type in ("triangle", "quad"):
            faces.append(np.asarray(block.data, dtype=np.int64))
    if not faces:
        raise GeometryError(f"{path} has no triangles or quads; give a surface mesh")
    # STL repeats every corner: merge coincident points first
    if path.suffix.lower() == ".stl":
        points, faces = merge_coincident(points, faces)
    return points, faces


def merge_coincident(points, faces):
    """Coincident points (to 1e-9 of the extent) merged into one: (points, faces renumbered)."""
    scale = max(np.ptp(points, axis=0).max(), 1e-12)
    key = np.round(points / (1e-9 * scale)).astype(np.int64)
    _, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
    inverse = inverse.ravel()
    return points[first], [inverse[f] for f in faces]
