"""y+ on the whale: area-weighted statistics from an OpenFOAM case's written files.

:func:`yplus_stats` reads the ``yPlus`` field (written by OpenFOAM's ``yPlus`` function object,
system/controlDict) on the whale patch at one written time, and the patch's face areas from the
mesh of that time, and returns area-weighted statistics: median, percentiles, the fractions of
the area in the ranges that matter for the wall treatment (``nutUSpaldingWallFunction`` is valid
up to a first-cell-centre y+ of about 300; the log layer is 30-300).

The files (the mesh of a time, the fields on a patch) are read by :mod:`adapter.foam.foamascii`.

:func:`parse_layer_report` reads snappyHexMesh's per-patch layer table from its log, and
:func:`layer_coverage` the area-weighted layer coverage from the ``nSurfaceLayers`` field that
snappyHexMesh writes with ``writeFlags (layerFields)``.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from adapter.errors import AdapterError, CaseError, FoamFileError
from adapter.foam.foamascii import patch_face_areas, read_patch_field
from adapter.foam.folders import processor_dirs
from adapter.foamfiles import time_dirs

#: the y+ limits reported as fractions of the area below them
YPLUS_LIMITS = (1.0, 5.0, 30.0, 300.0)


# --------------------------------------------------------------------------------------------
# statistics


def weighted_quantile(values, weights, q) -> np.ndarray:
    """Quantiles ``q`` (0..1) of ``values`` weighted by ``weights`` (the area-weighted
    distribution: each value holds its weight's share, centred on its cumulative midpoint)."""
    v = np.asarray(values, dtype=float)
    w = np.asarray(weights, dtype=float)
    order = np.argsort(v)
    v, w = v[order], w[order]
    c = (np.cumsum(w) - 0.5 * w) / w.sum()
    return np.interp(np.atleast_1d(q), c, v)


def area_stats(values, areas) -> dict:
    """Area-weighted statistics of per-face y+ values."""
    v = np.asarray(values, dtype=float)
    a = np.asarray(areas, dtype=float)
    if v.shape != a.shape or v.size == 0:
        raise FoamFileError(f"{v.size} values for {a.size} faces")
    total = float(a.sum())
    p5, med, p95 = weighted_quantile(v, a, [0.05, 0.5, 0.95])
    out = {
        "faces": int(v.size),
        "area_m2": total,
        "median": float(med),
        "p5": float(p5),
        "p95": float(p95),
        "min": float(v.min()),
        "max": float(v.max()),
        "mean": float((v * a).sum() / total),
    }
    for lim in YPLUS_LIMITS:
        out[f"area_below_{lim:g}"] = float(a[v < lim].sum() / total)
    out["area_le_300"] = float(a[v <= 300].sum() / total)
    out["area_30_300"] = float(a[(v >= 30) & (v <= 300)].sum() / total)
    return out


def latest_time(case, field: str = "yPlus") -> str:
    """Name of the newest time folder holding ``field``, in the case folder or (a parallel run
    not reconstructed) in its processor folders."""
    times = written_times(case, field)
    if times:
        return times[-1]
    raise CaseError(f"{case}: no time folder holds {field} (add the yPlus function object "
                    "to system/controlDict and run)")


def written_times(case, field: str = "yPlus") -> list:
    """Names of the time folders holding ``field``, oldest first: the case folder's, and the
    times only the processor folders hold (a parallel run reads them there, unreconstructed)."""
    case = Path(case)
    found = {t: d.name for t, d in time_dirs(case) if _holds(d, field)}
    procs = processor_dirs(case)
    if procs:
        for t, d in time_dirs(procs[0]):
            if t not in found and _holds(d, field):
                found[t] = d.name
    return [found[t] for t in sorted(found)]


def _holds(folder: Path, field: str) -> bool:
    return (folder / field).is_file() or (folder / f"{field}.gz").is_file()


def yplus_stats(case, time: str | None = None, patch: str = "whale") -> dict:
    """Area-weighted y+ statistics on ``patch`` at ``time`` (None: the newest with yPlus).

    Returns ``faces``, ``area_m2``, ``median``, ``p5``, ``p95``, ``min``, ``max``, ``mean``,
    ``area_below_1``/``_5``/``_30``/``_300`` (fractions of the area with y+ below),
    ``area_le_300``, ``area_30_300``, ``time``; and, when the case was meshed with layers,
    ``layer_report`` (snappyHexMesh's table, :func:`parse_layer_report`) and
    ``layer_area_coverage`` (:func:`layer_coverage`)."""
    case = Path(case)
    time = time if time is not None else latest_time(case)
    yp, areas, name = patch_yplus(case, time, patch)
    out = area_stats(yp, areas)
    out["time"] = name
    log = case / "log.snappyHexMesh"
    if log.is_file():
        report = parse_layer_report(log.read_text(errors="replace")).get(patch)
        if report:
            out["layer_report"] = report
    try:
        out["layer_area_coverage"] = layer_coverage(case, patch)
    except AdapterError:
        pass
    return out


def patch_yplus(case: Path, time: str, patch: str = "whale") -> tuple:
    """(y+ per face, face areas, the time folder's name) on ``patch`` at ``time``: from the case
    folder when it holds the time's y+, else from every processor folder, joined (each holds
    its share of the patch; a statistic of the area does not depend on the faces' order)."""
    own = _find_time_dir(case, time)
    folders = [case] if own is not None and _holds(own, "yPlus") else processor_dirs(case) or [case]
    values, areas = [], []
    for folder in folders:
        tdir = _time_dir(folder, time)
        a = patch_face_areas(folder, patch, time)
        v = read_patch_field(tdir / "yPlus", patch, len(a)) if len(a) else np.zeros(0)
        if v.shape != a.shape:
            raise FoamFileError(f"{tdir / 'yPlus'}: {v.size} values on {patch}, mesh has "
                                f"{a.size} faces")
        values.append(v)
        areas.append(a)
    return np.concatenate(values), np.concatenate(areas), tdir.name


def _time_dir(case: Path, time: str) -> Path:
    d = _find_time_dir(case, time)
    if d is None:
        raise CaseError(f"{case}: no time folder {time}")
    return d


def _find_time_dir(case: Path, time: str) -> Path | None:
    """The time folder named ``time`` or of its value (``1`` for ``1.0``), else None."""
    d = case / str(time)
    if d.is_dir():
        return d
    for value, p in time_dirs(case):
        if abs(value - float(time)) <= 1e-9 * max(1.0, abs(value)):
            return p
    return None


# --------------------------------------------------------------------------------------------
# prism layers

_LAYER_TABLE_RE = re.compile(
    r"^patch\s+faces\s+layers\s+overall thickness\s*\n\s*\[m\]\s+\[%\]\s*\n[-\s]+\n"
    r"((?:\S+\s+\d+\s+[-+0-9.eE]+\s+[-+0-9.eE]+\s+[-+0-9.eE]+\s*\n)+)", re.M)
_EXTRUDE_RE = re.compile(r"^Extruding (\d+) out of (\d+) faces", re.M)


def parse_layer_report(text: str) -> dict:
    """snappyHexMesh's final layer table, per patch: ``faces``, ``mean_layers`` (layers per
    face, averaged over the patch's faces), ``thickness_m`` (mean overall thickness),
    ``thickness_pct`` (of the thickness asked for), and from the last ``Extruding N out of M
    faces`` line ``faces_with_layers`` and ``face_coverage`` (N / M: that line counts the
    faces of every patch that has layers)."""
    out: dict = {}
    tables = list(_LAYER_TABLE_RE.finditer(text))
    if not tables:
        return out
    for line in tables[-1].group(1).strip().splitlines():
        name, faces, layers, thick, pct = line.split()
        out[name] = {"faces": int(faces), "mean_layers": float(layers),
                     "thickness_m": float(thick), "thickness_pct": float(pct)}
    ext = extruded_faces(text)
    if ext and len(out) == 1:
        n, m = ext
        rep = next(iter(out.values()))
        rep["faces_with_layers"] = n
        rep["face_coverage"] = n / m if m else 0.0
    return out


def extruded_faces(text: str) -> tuple | None:
    """(N, M) of snappyHexMesh's last ``Extruding N out of M faces`` line, else None."""
    ext = _EXTRUDE_RE.findall(text)
    return (int(ext[-1][0]), int(ext[-1][1])) if ext else None


def layer_coverage(case, patch: str | tuple = "whale") -> dict:
    """Area-weighted layer coverage of ``patch`` from snappyHexMesh's ``nSurfaceLayers`` field
    (``writeFlags (layerFields)`` in snappyHexMeshDict; the field is in the newest folder that
    holds it, ``0`` with ``-overwrite``). Returns ``area_with_layers`` (fraction of the area
    whose faces got at least one layer), ``faces_with_layers``, ``faces``, ``mean_layers``
    (area-weighted) and ``area_full_thickness`` (fraction of the area whose ``thicknessFraction``
    is at least 0.99 when that field is there). ``patch``: one patch, or several taken as
    one, each one's ``area_with_layers`` (and ``area_full_thickness``) then under ``patches``."""
    case = Path(case)
    src = None
    for _, d in reversed(time_dirs(case)):
        if (d / "nSurfaceLayers").is_file() or (d / "nSurfaceLayers.gz").is_file():
            src = d
            break
    if src is None:
        raise CaseError(f"{case}: no nSurfaceLayers field (snappyHexMesh writeFlags)")
    patches = (patch,) if isinstance(patch, str) else tuple(patch)
    frac_file = src / "thicknessFraction"
    with_frac = frac_file.is_file() or frac_file.with_name("thicknessFraction.gz").is_file()
    areas, n, frac, each = [], [], [], {}
    for name in patches:
        a = patch_face_areas(case, name, None)
        areas.append(a)
        n.append(read_patch_field(src / "nSurfaceLayers", name, len(a)))
        if with_frac:
            frac.append(read_patch_field(frac_file, name, len(a)))
        each[name] = _coverage(a, n[-1], frac[-1] if with_frac else None)
    out = _coverage(np.concatenate(areas), np.concatenate(n),
                    np.concatenate(frac) if with_frac else None)
    if len(patches) > 1:
        out["patches"] = {name: {k: v for k, v in c.items() if k.startswith("area_")}
                          for name, c in each.items()}
    return out


def _coverage(areas: np.ndarray, n: np.ndarray, frac: np.ndarray | None) -> dict:
    """:func:`layer_coverage`'s figures of faces of ``areas`` with ``n`` layers, ``frac`` of
    the thickness asked for (None: not known)."""
    total = areas.sum()
    out = {
        "faces": int(areas.size),
        "faces_with_layers": int((n > 0.5).sum()),
        "area_with_layers": float(areas[n > 0.5].sum() / total),
        "mean_layers": float((n * areas).sum() / total),
    }
    if frac is not None:
        out["area_full_thickness"] = float(areas[frac >= 0.99].sum() / total)
    return out
