"""Map OpenFOAM patch points onto the whale surface, once per rank.

Each patch point is tied to the closest point of the closest surface triangle by three
barycentric weights, so a node displacement (N, 3) becomes a patch displacement (P, 3) with one
sparse matrix product. The mapping is a pure function of each point's coordinates: a point
shared by two MPI ranks gets the same triangle, the same weights, the same bits.
"""

from __future__ import annotations

import hashlib
import os
import tempfile
import zipfile
from pathlib import Path

import numpy as np
import scipy.sparse

from adapter.coupling.nearest import nearest_triangles
from adapter.errors import GeometryError

#: default rejection threshold: a patch point farther than this fraction of L from the surface
DEFAULT_TOLERANCE = 0.05
_CACHE_VERSION = 1            # bump when the map of a point could change


def _dot(a, b):
    # explicit sum in a fixed order: the same bits whatever the batch layout
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]


def _div(num, den):
    out = np.zeros_like(num)
    np.divide(num, den, out=out, where=den != 0)
    return out


def closest_point_weights(p, a, b, c):
    """Barycentric weights (M, 3) of the point of triangle (a, b, c) closest to p.

    All arguments are (M, 3) arrays; row i is one point-triangle pair. Ericson's region test
    (Real-Time Collision Detection, 5.1.5), vectorised; degenerate triangles give weights of a
    vertex or an edge.
    """
    ab, ac, ap = b - a, c - a, p - a
    d1, d2 = _dot(ab, ap), _dot(ac, ap)
    bp = p - b
    d3, d4 = _dot(ab, bp), _dot(ac, bp)
    cp = p - c
    d5, d6 = _dot(ab, cp), _dot(ac, cp)
    vc = d1 * d4 - d3 * d2
    vb = d5 * d2 - d1 * d6
    va = d3 * d6 - d5 * d4
    one, zero = np.ones_like(d1), np.zeros_like(d1)
    v_ab = _div(d1, d1 - d3)
    w_ac = _div(d2, d2 - d6)
    w_bc = _div(d4 - d3, (d4 - d3) + (d5 - d6))
    den = va + vb + vc
    v_in, w_in = _div(vb, den), _div(vc, den)
    conditions = [
        (d1 <= 0) & (d2 <= 0),                                   # vertex a
        (d3 >= 0) & (d4 <= d3),                                  # vertex b
        (vc <= 0) & (d1 >= 0) & (d3 <= 0),                       # edge ab
        (d6 >= 0) & (d5 <= d6),                                  # vertex c
        (vb <= 0) & (d2 >= 0) & (d6 <= 0),                       # edge ac
        (va <= 0) & ((d4 - d3) >= 0) & ((d5 - d6) >= 0),         # edge bc
    ]
    wb = np.select(conditions, [zero, one, v_ab, zero, zero, 1 - w_bc], v_in)
    wc = np.select(conditions, [zero, zero, zero, one, w_ac, w_bc], w_in)
    wa = np.select(conditions, [one, zero, 1 - v_ab, zero, 1 - w_ac, zero], 1 - v_in - w_in)
    return np.stack([wa, wb, wc], axis=-1)


class PatchMap:
    """Patch points tied to the whale surface by barycentric weights.

    Parameters
    ----------
    points : (P, 3) float, the patch's undeformed point coordinates (m).
    surface_points : (N, 3) float, the surface's rest positions (m).
    triangles : (T, 3) int, the surface triangles.
    length : body length L (m), the scale of the tolerance.
    tolerance : largest allowed point-surface distance, as a fraction of L.
    cache : a file (``.npz``) keeping the map between runs, or None. When it holds the map of
        these very points onto this very surface (a SHA-256 of their bytes), the map is loaded
        from it; otherwise it is computed and the file is (re)written. The tolerance is checked
        either way.

    Attributes
    ----------
    matrix : (P, N) scipy.sparse.csr_matrix, three weights per row.
    triangle : (P,) int64, the triangle each point maps to.
    distance : (P,) float, each point's distance to the surface (m).
    max_distance : the largest of them (m), 0 for an empty patch.
    cache_status : "loaded", "saved", "not saved: <reason>", or None without a cache.

    Raises GeometryError when a point is not finite or lies farther than the tolerance.
    """

    def __init__(self, points, surface_points, triangles, length: float,
                 tolerance: float = DEFAULT_TOLERANCE, cache=None):
        pts = np.asarray(points, dtype=np.float64)
        if pts.ndim != 2 or pts.shape[1] != 3:
            raise GeometryError(f"patch points have shape {pts.shape}, expected (P, 3)")
        if not np.isfinite(pts).all():
            bad = int(np.flatnonzero(~np.isfinite(pts).all(axis=1))[0])
            raise GeometryError(f"patch point {bad} is not finite: {pts[bad].tolist()}")
        verts = np.asarray(surface_points, dtype=np.float64)
        tris = np.asarray(triangles, dtype=np.int64)
        n_points, n_nodes = len(pts), len(verts)
        self.n_nodes = n_nodes
        self.length = float(length)
        self.tolerance = float(tolerance)
        self.cache_status: str | None = None
        if n_points == 0:
            self.triangle = np.zeros(0, dtype=np.int64)
            self.weights = np.zeros((0, 3))
            self.distance = np.zeros(0)
        elif cache is None:
            self.triangle, self.weights, self.distance = nearest_triangles(pts, verts, tris)
        else:
            key = _cache_key(pts, verts, tris)
            found = _load_cache(Path(cache), key, n_points, len(tris))
            if found is not None:
                self.triangle, self.weights, self.distance = found
                self.cache_status = "loaded"
            else:
                self.triangle, self.weights, self.distance = nearest_triangles(pts, verts, tris)
                self.cache_status = _save_cache(Path(cache), key, self.triangle, self.weights,
                                                self.distance)
        self.max_distance = float(self.distance.max()) if n_points else 0.0
        limit = self.tolerance * self.length
        if self.max_distance > limit:
            worst = int(np.argmax(self.distance))
            raise GeometryError(
                f"patch point {worst} at {pts[worst].tolist()} lies {self.max_distance:.4g} m "
                f"from the whale surface, more than the allowed {limit:.4g} m "
                f"({self.tolerance:g} L); is this the whale patch, and is the case built from "
                f"the same scene (body length {self.length:g} m)?"
            )
        indptr = np.arange(0, 3 * n_points + 1, 3, dtype=np.int64)
        self.matrix = scipy.sparse.csr_matrix(
            (self.weights.ravel(), tris[self.triangle].ravel(), indptr),
            shape=(n_points, n_nodes),
        )

    @property
    def n_points(self) -> int:
        return self.matrix.shape[0]

    def apply(self, node_displacement) -> np.ndarray:
        """Patch displacement (P, 3) from a node displacement (N, 3), in m."""
        u = np.asarray(node_displacement, dtype=np.float64)
        if u.shape != (self.n_nodes, 3):
            raise GeometryError(
                f"node displacement has shape {u.shape}, expected ({self.n_nodes}, 3)")
        return np.ascontiguousarray(self.matrix @ u)

    @classmethod
    def from_surface(cls, points, surface, tolerance: float = DEFAULT_TOLERANCE,
                     cache=None) -> PatchMap:
        """Map onto a WhaleSurface (anything with points, triangles and length)."""
        return cls(points, surface.points, surface.triangles, surface.length, tolerance, cache)


def _cache_key(pts, verts, tris) -> str:
    """SHA-256 of the patch points' and the surface's bytes (and the cache layout's version)."""
    h = hashlib.sha256(f"whale-adapter patch map v{_CACHE_VERSION}".encode())
    for a, dtype in ((pts, "<f8"), (verts, "<f8"), (tris, "<i8")):
        a = np.ascontiguousarray(a, dtype=dtype)
        h.update(repr(a.shape).encode())
        h.update(a.data)
    return h.hexdigest()


def _load_cache(path: Path, key: str, n_points: int, n_triangles: int):
    """(triangle, weights, distance) from path if it holds the map of ``key``, else None."""
    try:
        with np.load(path, allow_pickle=False) as f:
            if str(f["key"]) != key:
                return None
            tri, w, d = f["triangle"], f["weights"], f["distance"]
    except (OSError, KeyError, ValueError, zipfile.BadZipFile):
        return None                                           # absent, unreadable or foreign
    if (tri.shape != (n_points,) or w.shape != (n_points, 3) or d.shape != (n_points,)
            or tri.dtype != np.int64 or w.dtype != np.float64 or d.dtype != np.float64
            or tri.min() < 0 or tri.max() >= n_triangles):
        return None
    return tri, w, d


def _save_cache(path: Path, key: str, tri, w, d) -> str:
    """Write the map to path atomically (a temporary file, then a rename); the outcome."""
    tmp = None
    try:
        with tempfile.NamedTemporaryFile(dir=path.parent, prefix=path.name + ".",
                                         suffix=".tmp", delete=False) as f:
            tmp = Path(f.name)
            np.savez(f, key=np.array(key), triangle=tri, weights=w, distance=d)
        os.replace(tmp, path)
    except OSError as exc:
        if tmp is not None:
            tmp.unlink(missing_ok=True)
        return f"not saved: {exc}"
    return "saved"
