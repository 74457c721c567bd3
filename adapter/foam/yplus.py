"""y+ on the whale: area-weighted statistics from an OpenFOAM case's written files.

:func:`yplus_stats` reads the ``yPlus`` field (written by OpenFOAM's ``yPlus`` function object,
system/controlDict) on the whale patch at one written time, and the patch's face areas from the
mesh of that time, and returns area-weighted statistics: median, percentiles, the fractions of
the area in the ranges that matter for the wall treatment (``nutUSpaldingWallFunction`` is valid
up to a first-cell-centre y+ of about 300; the log layer is 30-300).

Only numpy: the OpenFOAM ASCII files (``points``, ``faces``, ``boundary``, fields; plain or
``.gz``) are parsed directly. A moving-mesh case writes ``polyMesh/points`` into its time
folders; the mesh of a time is the newest ``polyMesh`` at or before it, else ``constant``.

:func:`parse_layer_report` reads snappyHexMesh's per-patch layer table from its log, and
:func:`layer_coverage` the area-weighted layer coverage from the ``nSurfaceLayers`` field that
snappyHexMesh writes with ``writeFlags (layerFields)``.
"""

from __future__ import annotations

import gzip
import re
from pathlib import Path

import numpy as np

from adapter.errors import AdapterError, CaseError, FoamFileError
from adapter.foamfiles import time_dirs

#: the y+ limits reported as fractions of the area below them
YPLUS_LIMITS = (1.0, 5.0, 30.0, 300.0)


# --------------------------------------------------------------------------------------------
# OpenFOAM ASCII files


def read_foam_text(path) -> str:
    """The text of an OpenFOAM file, ``path`` or ``path.gz``, without comments.

    Raises :class:`~adapter.errors.FoamFileError` when neither exists or the file is binary."""
    p = Path(path)
    if p.is_file():
        data = p.read_bytes()
    elif p.with_name(p.name + ".gz").is_file():
        data = p.with_name(p.name + ".gz").read_bytes()
    else:
        raise FoamFileError(f"{p} is missing (nor {p.name}.gz)")
    if data[:2] == b"\x1f\x8b":
        data = gzip.decompress(data)
    text = data.decode("latin-1")
    text = re.sub(r"/\*.*?\*/", " ", text, flags=re.S)
    text = re.sub(r"//[^\n]*", " ", text)
    m = re.search(r"\bformat\s+(\w+)\s*;", text)
    if m and m.group(1) != "ascii":
        raise FoamFileError(f"{p}: format {m.group(1)}; only ascii files are read "
                            "(set writeFormat ascii)")
    return text


def _body(text: str) -> str:
    """The text after the FoamFile header."""
    m = re.search(r"\bFoamFile\s*\{[^}]*\}", text)
    return text[m.end():] if m else text


def _list_start(text: str, pos: int = 0) -> tuple:
    """(count, index just after the opening parenthesis) of the first ``N (`` list at pos."""
    m = re.compile(r"(\d+)\s*\(").search(text, pos)
    if not m:
        raise FoamFileError("no OpenFOAM list found")
    return int(m.group(1)), m.end()


def _numbers(s: str) -> np.ndarray:
    return np.array(s.replace("(", " ").replace(")", " ").split(), dtype=float)


def read_points(path) -> np.ndarray:
    """(N, 3) points of a ``vectorField`` file (polyMesh/points)."""
    text = _body(read_foam_text(path))
    n, start = _list_start(text)
    end = _matching(text, start - 1)
    pts = _numbers(text[start:end])
    if pts.size != 3 * n:
        raise FoamFileError(f"{path}: expected {n} points, read {pts.size / 3:g}")
    return pts.reshape(n, 3)


def _matching(text: str, open_pos: int, pair: str = "()") -> int:
    """Index of the bracket closing the one at open_pos (``pair``: "()" or "{}")."""
    depth = 0
    for m in re.finditer(re.escape(pair[0]) + "|" + re.escape(pair[1]), text[open_pos:]):
        depth += 1 if m.group() == pair[0] else -1
        if depth == 0:
            return open_pos + m.start()
    raise FoamFileError(f"unbalanced {pair}")


def read_faces(path) -> list:
    """Faces (lists of point labels) of a ``faceList`` or ``faceCompactList`` file."""
    text = read_foam_text(path)
    m = re.search(r"\bclass\s+(\w+)\s*;", text)
    cls = m.group(1) if m else "faceList"
    text = _body(text)
    if cls == "faceCompactList":
        n, start = _list_start(text)
        end = _matching(text, start - 1)
        offsets = _numbers(text[start:end]).astype(np.int64)
        m2, start2 = _list_start(text, end + 1)
        labels = _numbers(text[start2:_matching(text, start2 - 1)]).astype(np.int64)
        return [labels[offsets[i]:offsets[i + 1]] for i in range(n - 1)]
    n, start = _list_start(text)
    end = _matching(text, start - 1)
    faces = [np.array(f.split(), dtype=np.int64)
             for f in re.findall(r"\d+\s*\(([^()]*)\)", text[start:end])]
    if len(faces) != n:
        raise FoamFileError(f"{path}: expected {n} faces, read {len(faces)}")
    return faces


def read_boundary(path) -> dict:
    """Patch name -> {"type", "nFaces", "startFace"} of a polyMesh/boundary file."""
    text = _body(read_foam_text(path))
    _, start = _list_start(text)
    out = {}
    for m in re.finditer(r"(\w[\w.:-]*)\s*\{([^{}]*)\}", text[start:]):
        entries = dict(re.findall(r"(\w+)\s+([^;]+);", m.group(2)))
        out[m.group(1)] = {"type": entries.get("type", "").strip(),
                           "nFaces": int(entries["nFaces"]),
                           "startFace": int(entries["startFace"])}
    return out


def read_patch_field(path, patch: str, n_faces: int | None = None) -> np.ndarray:
    """The values of a field on one patch: ``value uniform X`` or ``value nonuniform List<..>``.

    Scalars give an (n,) array, vectors (n, 3). ``n_faces`` expands a uniform value."""
    text = _body(read_foam_text(path))
    b = re.search(r"\bboundaryField\s*\{", text)
    if not b:
        raise FoamFileError(f"{path}: no boundaryField")
    m = re.compile(r"(?<![\w\"])" + re.escape(patch) + r"\s*\{").search(text, b.end())
    if not m:
        raise FoamFileError(f"{path}: no patch {patch} in boundaryField")
    end = _matching(text, m.end() - 1, "{}")
    entry = text[m.end():end]
    v = re.search(r"\bvalue\s+(uniform|nonuniform)\s+", entry)
    if not v:
        raise FoamFileError(f"{path}: patch {patch} has no value")
    rest = entry[v.end():]
    if v.group(1) == "uniform":
        val = _numbers(rest[:rest.index(";")])
        n = 1 if n_faces is None else n_faces
        return np.tile(val, (n, 1)).squeeze(axis=1) if val.size == 1 else np.tile(val, (n, 1))
    kind = re.match(r"List<(\w+)>\s*", rest)
    rest = rest[kind.end():] if kind else rest
    if re.match(r"0\s*\(\s*\)|0\s*;|0\s*$", rest):
        return np.zeros(0)
    n, start = _list_start(rest)
    vals = _numbers(rest[start:_matching(rest, start - 1)])
    if vals.size % max(n, 1):
        raise FoamFileError(f"{path}: patch {patch}: {vals.size} numbers for {n} values")
    return vals if vals.size == n else vals.reshape(n, -1)


# --------------------------------------------------------------------------------------------
# the mesh of a time


def mesh_file(case, time: str | None, name: str) -> Path:
    """The polyMesh file ``name`` valid at ``time``: the newest time folder at or before it that
    holds ``polyMesh/name`` (a moving mesh writes its points there), else constant/polyMesh."""
    case = Path(case)
    if time is not None:
        t = float(time)
        for value, d in reversed(time_dirs(case)):
            if value <= t * (1 + 1e-12) + 1e-300:
                f = d / "polyMesh" / name
                if f.is_file() or f.with_name(name + ".gz").is_file():
                    return f
    return case / "constant" / "polyMesh" / name


def face_area_vectors(points: np.ndarray, faces: list) -> np.ndarray:
    """(F, 3) area vectors of polygonal faces: half the sum of p_i x p_(i+1).

    This is the sum of the triangle fan's area vectors about any apex, so it equals OpenFOAM's
    ``Sf`` (a fan about the face's estimated centre) for planar and warped faces alike."""
    out = np.zeros((len(faces), 3))
    by_size: dict = {}
    for i, f in enumerate(faces):
        by_size.setdefault(len(f), []).append(i)
    for idx in by_size.values():
        lab = np.array([faces[i] for i in idx])
        p = points[lab]  # (n, vertices, 3)
        out[idx] = 0.5 * np.cross(p, np.roll(p, -1, axis=1)).sum(axis=1)
    return out


def patch_face_areas(case, patch: str = "whale", time: str | None = None) -> np.ndarray:
    """Face areas (m2) of one patch in the mesh of ``time`` (None: constant/polyMesh)."""
    boundary = read_boundary(mesh_file(case, time, "boundary"))
    if patch not in boundary:
        raise CaseError(f"{case}: no patch {patch} (patches: {', '.join(boundary)})")
    start, n = boundary[patch]["startFace"], boundary[patch]["nFaces"]
    faces = read_faces(mesh_file(case, time, "faces"))[start:start + n]
    points = read_points(mesh_file(case, time, "points"))
    return np.linalg.norm(face_area_vectors(points, faces), axis=1)


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
    """Name of the newest time folder holding ``field``."""
    for _, d in reversed(time_dirs(Path(case))):
        if (d / field).is_file() or (d / f"{field}.gz").is_file():
            return d.name
    raise CaseError(f"{case}: no time folder holds {field} (add the yPlus function object "
                    "to system/controlDict and run)")


def yplus_stats(case, time: str | None = None, patch: str = "whale") -> dict:
    """Area-weighted y+ statistics on ``patch`` at ``time`` (None: the newest with yPlus).

    Returns ``faces``, ``area_m2``, ``median``, ``p5``, ``p95``, ``min``, ``max``, ``mean``,
    ``area_below_1``/``_5``/``_30``/``_300`` (fractions of the area with y+ below),
    ``area_le_300``, ``area_30_300``, ``time``; and, when the case was meshed with layers,
    ``layer_report`` (snappyHexMesh's table, :func:`parse_layer_report`) and
    ``layer_area_coverage`` (:func:`layer_coverage`)."""
    case = Path(case)
    time = time if time is not None else latest_time(case)
    tdir = _time_dir(case, time)
    areas = patch_face_areas(case, patch, time)
    yp = read_patch_field(tdir / "yPlus", patch, len(areas))
    if yp.shape != areas.shape:
        raise FoamFileError(f"{tdir / 'yPlus'}: {yp.size} values on {patch}, mesh has "
                            f"{areas.size} faces")
    out = area_stats(yp, areas)
    out["time"] = tdir.name
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


def _time_dir(case: Path, time: str) -> Path:
    d = case / str(time)
    if d.is_dir():
        return d
    for value, p in time_dirs(case):
        if abs(value - float(time)) <= 1e-9 * max(1.0, abs(value)):
            return p
    raise CaseError(f"{case}: no time folder {time}")


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
    ext = _EXTRUDE_RE.findall(text)
    if ext and len(out) == 1:
        n, m = (int(v) for v in ext[-1])
        rep = next(iter(out.values()))
        rep["faces_with_layers"] = n
        rep["face_coverage"] = n / m if m else 0.0
    return out


def layer_coverage(case, patch: str = "whale") -> dict:
    """Area-weighted layer coverage of ``patch`` from snappyHexMesh's ``nSurfaceLayers`` field
    (``writeFlags (layerFields)`` in snappyHexMeshDict; the field is in the newest folder that
    holds it, ``0`` with ``-overwrite``). Returns ``area_with_layers`` (fraction of the area
    whose faces got at least one layer), ``faces_with_layers``, ``faces``, ``mean_layers``
    (area-weighted) and ``area_full_thickness`` (fraction of the area whose ``thicknessFraction``
    is at least 0.99 when that field is there)."""
    case = Path(case)
    src = None
    for _, d in reversed(time_dirs(case)):
        if (d / "nSurfaceLayers").is_file() or (d / "nSurfaceLayers.gz").is_file():
            src = d
            break
    if src is None:
        raise CaseError(f"{case}: no nSurfaceLayers field (snappyHexMesh writeFlags)")
    areas = patch_face_areas(case, patch, None)
    n = read_patch_field(src / "nSurfaceLayers", patch, len(areas))
    total = areas.sum()
    out = {
        "faces": int(areas.size),
        "faces_with_layers": int((n > 0.5).sum()),
        "area_with_layers": float(areas[n > 0.5].sum() / total),
        "mean_layers": float((n * areas).sum() / total),
    }
    frac_file = src / "thicknessFraction"
    if frac_file.is_file() or frac_file.with_name("thicknessFraction.gz").is_file():
        frac = read_patch_field(frac_file, patch, len(areas))
        out["area_full_thickness"] = float(areas[frac >= 0.99].sum() / total)
    return out
