"""VTK files: a surface as ``.vtp`` (VTK XML PolyData) and a time series as ``.pvd`` (a ParaView
collection: one ``DataSet`` per time, naming its file).

A leaf module: it imports nothing from the adapter but its exceptions. Every file is written
atomically (a temporary file in the same folder, then a rename), so a reader never sees half of
one.
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from collections.abc import Iterable, Mapping
from pathlib import Path

import numpy as np

from adapter.errors import VTKFileError


def _replace_text(path: Path, text: str) -> None:
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(text)
    os.replace(tmp, path)


def write_vtp(path, points, faces, point_data: Mapping | None = None,
              field_data: Mapping | None = None) -> None:
    """Write a surface as binary VTK XML PolyData.

    Parameters
    ----------
    path : the ``.vtp`` file.
    points : (N, 3) point coordinates.
    faces : (F, k) point indices of F faces of k corners each (triangles: k = 3), or a list of
        such arrays (triangles and quads).
    point_data : name -> (N,) or (N, c) values per point.
    field_data : name -> an array that belongs to the whole surface (``time``: [t]).
    """
    import pyvista as pv  # heavy: imported when a file is written

    path = Path(path)
    blocks = [faces] if isinstance(faces, np.ndarray) else list(faces)
    flat = np.concatenate([
        np.column_stack([np.full(len(f), np.shape(f)[1], dtype=np.int64),
                         np.asarray(f, dtype=np.int64)]).ravel() for f in blocks])
    mesh = pv.PolyData(np.asarray(points, dtype=np.float64), flat)
    for name, values in (point_data or {}).items():
        mesh.point_data[name] = np.asarray(values)
    for name, values in (field_data or {}).items():
        mesh.field_data[name] = np.asarray(values)
    tmp = path.with_name(path.stem + ".tmp.vtp")
    mesh.save(tmp, binary=True)
    os.replace(tmp, path)


def write_pvd(path, datasets: Mapping[float, str] | Iterable[tuple[float, str]]) -> None:
    """Write a ParaView collection: ``datasets`` maps each time (s) to its file (relative to
    the collection's folder), written in time order, each time exactly (``repr``)."""
    items = datasets.items() if isinstance(datasets, Mapping) else datasets
    root = ET.Element("VTKFile", type="Collection", version="0.1", byte_order="LittleEndian")
    coll = ET.SubElement(root, "Collection")
    for t, name in sorted((float(t), str(name)) for t, name in items):
        ET.SubElement(coll, "DataSet", timestep=repr(t), group="", part="0", file=name)
    ET.indent(root)
    _replace_text(Path(path), ET.tostring(root, encoding="unicode", xml_declaration=True) + "\n")


def read_pvd(path) -> dict[float, str]:
    """{time (s): file} of a ParaView collection.

    Raises :class:`~adapter.errors.VTKFileError` when the file is not a readable collection
    (cut short, not XML, a ``DataSet`` without a time or a file); ``OSError`` when it cannot be
    opened.
    """
    path = Path(path)
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as exc:
        raise VTKFileError(f"{path} is not a readable ParaView collection ({exc}); "
                           f"remove it to start a new one") from None
    out = {}
    for ds in root.iter("DataSet"):
        t, name = _number(ds.get("timestep")), ds.get("file")
        if t is None or name is None:
            raise VTKFileError(f"{path}: a DataSet has no readable timestep and file "
                               f"({ET.tostring(ds, encoding='unicode').strip()}); remove it to "
                               f"start a new collection")
        out[t] = name
    return out


def _number(text: str | None) -> float | None:
    if text is None:
        return None
    try:
        return float(text)
    except (TypeError, ValueError):
        return None
