"""Mesh checks: a surface the springs can animate is closed, manifold, free of NaN, duplicate
or unused points and degenerate faces, and one shell; its faces are then oriented outward.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from adapter.body.polygons import triangulate
from adapter.errors import GeometryError


def validate_surface(points: np.ndarray, faces: list, length_scale: float) -> list:
    """Check that a surface can be animated; return its faces oriented outward.

    Raises :class:`GeometryError` for NaN or duplicate points, degenerate faces, an open or
    non-manifold surface, or unused points.
    """
    points = np.asarray(points, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 3:
        raise GeometryError(f"points has shape {points.shape}, expected (N, 3)")
    bad = ~np.isfinite(points).all(axis=1)
    if bad.any():
        raise GeometryError(
            f"{bad.sum()} point(s) are NaN or infinite, first at index {np.flatnonzero(bad)[0]}; "
            "repair the mesh file"
        )
    n = len(points)
    for f in faces:
        if f.size and (f.min() < 0 or f.max() >= n):
            raise GeometryError("a face refers to a point index outside the point list")
    tol = 1e-9 * length_scale
    key = np.round(points / max(tol, 1e-300)).astype(np.int64)
    _, first, counts = np.unique(key, axis=0, return_index=True, return_counts=True)
    if (counts > 1).any():
        i = first[np.argmax(counts > 1)]
        raise GeometryError(
            f"duplicate points: {counts[counts > 1].sum()} points share positions with others "
            f"(e.g. point {i} at {points[i].round(6).tolist()}); merge them before use"
        )
    for f in faces:
        srt = np.sort(f, axis=1)
        repeated = (np.diff(srt, axis=1) == 0).any(axis=1)
        tri = triangulate(points, [f])
        area = 0.5 * np.linalg.norm(
            np.cross(points[tri[:, 1]] - points[tri[:, 0]], points[tri[:, 2]] - points[tri[:, 0]]),
            axis=1,
        )
        tiny = area <= 1e-12 * length_scale**2
        if repeated.any() or tiny.any():
            which = np.flatnonzero(repeated)[:1].tolist() or ["(zero area)"]
            raise GeometryError(
                f"degenerate faces: {int(repeated.sum())} with a repeated corner and "
                f"{int(tiny.sum())} triangle(s) of zero area (first {which}); remove them"
            )
    # every edge in exactly two faces
    sides = []
    for f in faces:
        k = f.shape[1]
        for c in range(k):
            sides.append(np.stack([f[:, c], f[:, (c + 1) % k]], axis=1))
    directed = np.concatenate(sides)
    undirected = np.sort(directed, axis=1)
    uniq, counts = np.unique(undirected, axis=0, return_counts=True)
    if (counts == 1).any():
        e = uniq[counts == 1][0]
        raise GeometryError(
            f"the surface is open: {(counts == 1).sum()} edge(s) belong to one face only "
            f"(e.g. between points {e[0]} and {e[1]}); close the holes (it must be watertight)"
        )
    if (counts > 2).any():
        e = uniq[counts > 2][0]
        raise GeometryError(
            f"the surface is non-manifold: {(counts > 2).sum()} edge(s) belong to three or more "
            f"faces (e.g. between points {e[0]} and {e[1]})"
        )
    used = np.zeros(n, bool)
    for f in faces:
        used[f.ravel()] = True
    if not used.all():
        raise GeometryError(f"{(~used).sum()} point(s) belong to no face; remove them")
    _check_vertex_manifold(faces, n)
    return _orient_outward(points, faces)


def _check_vertex_manifold(faces: list, n: int) -> None:
    """Every vertex's faces must form one fan: two cones touching at a point are refused.

    The link of a vertex (the edges of its faces opposite it) is one cycle on a manifold.
    Each face corner at v joins v's half-edges to its two neighbours in that face; the
    connected components of that graph, counted per vertex, are its fans.
    """
    from scipy.sparse.csgraph import connected_components

    vs, ps, qs = [], [], []
    for f in faces:
        k = f.shape[1]
        for c in range(k):
            vs.append(f[:, c])
            ps.append(f[:, (c - 1) % k])
            qs.append(f[:, (c + 1) % k])
    v, p, q = np.concatenate(vs), np.concatenate(ps), np.concatenate(qs)
    pairs, index = np.unique(np.concatenate([np.stack([v, p], 1), np.stack([v, q], 1)]),
                             axis=0, return_inverse=True)
    index = index.ravel()
    m = len(v)
    graph = sp.coo_matrix((np.ones(m), (index[:m], index[m:])), shape=(len(pairs),) * 2)
    n_comp, labels = connected_components(graph, directed=False)
    owner = np.zeros(n_comp, dtype=np.int64)
    owner[labels] = pairs[:, 0]
    fans = np.bincount(owner, minlength=n)
    bad = np.flatnonzero(fans > 1)
    if bad.size:
        raise GeometryError(
            f"the surface is non-manifold at {bad.size} point(s) (e.g. point {bad[0]}): "
            "two sheets touch there; separate them"
        )


def _orient_outward(points: np.ndarray, faces: list) -> list:
    """Make face orientation consistent (breadth-first over shared edges), then outward."""
    from collections import deque

    flat = [list(map(int, row)) for f in faces for row in f]
    edge_faces: dict = {}
    for fi, poly in enumerate(flat):
        for k in range(len(poly)):
            a, b = poly[k], poly[(k + 1) % len(poly)]
            edge_faces.setdefault((min(a, b), max(a, b)), []).append(fi)
    flipped: list[bool | None] = [None] * len(flat)
    components = 0
    for start in range(len(flat)):
        if flipped[start] is not None:
            continue
        components += 1
        flipped[start] = False
        queue = deque([start])
        while queue:
            fi = queue.popleft()
            poly = flat[fi][::-1] if flipped[fi] else flat[fi]
            for k in range(len(poly)):
                a, b = poly[k], poly[(k + 1) % len(poly)]
                for fj in edge_faces[(min(a, b), max(a, b))]:
                    if fj == fi:
                        continue
                    other = flat[fj]
                    # in a consistent orientation the neighbour runs the edge b -> a
                    m = len(other)
                    runs_ab = any(
                        other[q] == a and other[(q + 1) % m] == b for q in range(m)
                    )
                    want = runs_ab  # then it must be flipped
                    if flipped[fj] is None:
                        flipped[fj] = want
                        queue.append(fj)
                    elif flipped[fj] != want:
                        raise GeometryError(
                            "the surface cannot be oriented (a Moebius-like twist); "
                            "it does not bound a volume"
                        )
    if components > 1:
        raise GeometryError(
            f"the surface has {components} separate pieces; give one closed shell"
        )
    out = []
    start = 0
    for f in faces:
        fl = np.array(flipped[start : start + len(f)], bool)
        g = f.copy()
        g[fl] = g[fl, ::-1]
        out.append(g)
        start += len(f)
    tri = triangulate(points, out)
    a, b, c = points[tri[:, 0]], points[tri[:, 1]], points[tri[:, 2]]
    vol = np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0
    if vol < 0:
        out = [f[:, ::-1].copy() for f in out]
    return out
