"""OpenFOAM's ASCII files, read with numpy alone: the one home of the format in the package.

:func:`read_foam_text` gives a file's text without comments (``path`` or ``path.gz``, plain or
gzip), refusing a binary one; :func:`read_points`, :func:`read_faces` (``faceList`` and
``faceCompactList``), :func:`read_boundary` and :func:`read_patch_field` (a field's values on
one patch) read what they are named for. A moving-mesh case writes ``polyMesh/points`` into
its time folders: :func:`mesh_file` finds the mesh file valid at a time, and
:func:`patch_face_areas` a patch's face areas in it (:func:`face_area_vectors`).

Case dictionaries are read and written with PyFoam (:mod:`adapter.foam.dictionaries`).
"""

from __future__ import annotations

import functools
import gzip
import re
from pathlib import Path

import numpy as np

from adapter.errors import CaseError, FoamFileError
from adapter.foamfiles import time_dirs

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
    """Faces (lists of point labels) of a ``faceList`` or ``faceCompactList`` file. A file read
    before and not changed since is not parsed again (a moving mesh's faces stay in
    constant/polyMesh while every written time is read); the list is shared: do not change it."""
    path = Path(path)
    real = path if path.is_file() else path.with_name(path.name + ".gz")
    if not real.is_file():
        read_foam_text(path)        # the missing file's error
    stat = real.stat()
    return _read_faces(str(path), stat.st_mtime_ns, stat.st_size)


@functools.lru_cache(maxsize=8)
def _read_faces(path: str, mtime_ns: int, size: int) -> list:
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
