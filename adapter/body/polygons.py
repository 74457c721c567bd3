"""Polygon faces: triangles from quads and the edge list of a face set.

Faces are a list of (F_k, n_k) int arrays, polygons grouped by corner count (3 or 4).
"""

from __future__ import annotations

import numpy as np

from adapter.errors import GeometryError


def triangulate(points: np.ndarray, faces: list) -> np.ndarray:
    """(T, 3) triangles: triangles as they are, quads split along the shorter diagonal."""
    out = []
    for f in faces:
        if f.shape[1] == 3:
            out.append(f)
        elif f.shape[1] == 4:
            d02 = np.linalg.norm(points[f[:, 0]] - points[f[:, 2]], axis=1)
            d13 = np.linalg.norm(points[f[:, 1]] - points[f[:, 3]], axis=1)
            use02 = d02 <= d13
            t1 = np.where(use02[:, None], f[:, [0, 1, 2]], f[:, [0, 1, 3]])
            t2 = np.where(use02[:, None], f[:, [0, 2, 3]], f[:, [1, 2, 3]])
            out.extend([t1, t2])
        else:
            raise GeometryError(f"faces with {f.shape[1]} corners: only triangles and quads")
    return np.concatenate(out).astype(np.int64)


def unique_edges(faces: list) -> np.ndarray:
    """(E, 2) int64, every undirected edge of ``faces`` once, smaller index first."""
    pairs = []
    for f in faces:
        n = f.shape[1]
        for k in range(n):
            pairs.append(np.stack([f[:, k], f[:, (k + 1) % n]], axis=1))
    e = np.sort(np.concatenate(pairs), axis=1)
    return np.unique(e, axis=0).astype(np.int64)
