"""The whale's surface: a procedural North Atlantic right whale, or any closed mesh file.

The procedural whale is one closed, quad-dominant surface (the paper's mesh has about two edges
per node, as a quad surface does): a body tube of rings from the rostrum to the fluke notch,
with the flippers and the flukes grown out of it by face extrusion, so that the whole animal is a
single watertight shell (what snappyHexMesh wants). Proportions and their sources are in
docs/geometry.md.

Coordinates: x along the body from the rostrum (x = 0) to the fluke notch (x = L), y to the
whale's left, z up. Positions along the body are fractions s = x / L.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import scipy.sparse as sp
from scipy.interpolate import PchipInterpolator

from adapter.errors import GeometryError

LANDMARKS = (
    "rostrum",
    "flipper_left",
    "flipper_right",
    "tail_base",
    "fluke_tip_left",
    "fluke_tip_right",
)

#: where the tail base (fluke hinge, the paper's point C) sits, fraction of L
TAIL_BASE_S = 0.92

#: the body regions the loads are split into (docs/geometry.md), by index
REGIONS = ("body", "flippers", "flukes")
BODY, FLIPPERS, FLUKES = 0, 1, 2

# Side-view depth, fraction of L, by distance from the rostrum (Daoust et al. 2018, digitised
# from a necropsy drawing); the ends close the nose and the tail stock.
_DEPTH = {0.0: 0.0, 0.01: 0.035, 0.025: 0.062, 0.05: 0.093, 0.10: 0.123, 0.20: 0.156,
          0.30: 0.194, 0.40: 0.210, 0.45: 0.212, 0.50: 0.203, 0.60: 0.177, 0.70: 0.145,
          0.80: 0.097, 0.90: 0.046, 0.95: 0.026, 0.985: 0.016, 1.0: 0.0}
# Top-view width, fraction of L: 0.149 L at 0.10 L (Miller, photogrammetry); wider than deep
# at the head, near circular mid-body with a girth diameter near 0.24 L at 0.40-0.45 L
# (Fortune et al. 2012), narrower than deep over the rear half (Christiansen et al. 2019).
_WIDTH = {0.0: 0.0, 0.01: 0.045, 0.025: 0.08, 0.05: 0.112, 0.10: 0.149, 0.20: 0.19,
          0.30: 0.225, 0.40: 0.250, 0.45: 0.252, 0.50: 0.235, 0.60: 0.185, 0.70: 0.125,
          0.80: 0.072, 0.90: 0.030, 0.95: 0.018, 0.985: 0.012, 1.0: 0.0}
# Share of the depth above the body axis: the lower lips make the head deep below the
# arched rostrum; the body is symmetric about its axis from mid-body on.
_TOP_SHARE = {0.0: 0.5, 0.05: 0.42, 0.15: 0.40, 0.30: 0.45, 0.45: 0.5, 1.0: 0.5}
# Height of the body axis (fraction of L): the arched rostrum.
_AXIS_Z = {0.0: 0.025, 0.05: 0.028, 0.15: 0.022, 0.30: 0.008, 0.45: 0.0, 1.0: 0.0}


def _profile(table: dict) -> PchipInterpolator:
    s = np.array(sorted(table))
    return PchipInterpolator(s, np.array([table[k] for k in s]))


@dataclass
class WhaleSurface:
    """A closed surface mesh with the paper's landmarks.

    Attributes
    ----------
    points : (N, 3) float64, rest positions (m).
    faces : list of (F_k, n_k) int arrays, polygons grouped by corner count (3 or 4), outward.
    landmarks : name -> node index, for every name in :data:`LANDMARKS`.
    length : body length L (m), rostrum to tail end along x.
    origin : position of the rostrum's axis point; s = (x - origin[0]) / length.
    face_regions : None, or a list parallel to ``faces``: the region index (:data:`REGIONS`)
        each face was built as (the procedural whale: its flipper and fluke fins); None for a
        mesh file (:meth:`triangle_regions` then finds the flippers geometrically).
    """

    points: np.ndarray
    faces: list
    landmarks: dict
    length: float
    origin: np.ndarray = field(default_factory=lambda: np.zeros(3))
    face_regions: list | None = None

    @property
    def n_nodes(self) -> int:
        return len(self.points)

    @property
    def edges(self) -> np.ndarray:
        """(E, 2) int64, every undirected edge once, smaller index first."""
        return _unique_edges(self.faces)

    @property
    def triangles(self) -> np.ndarray:
        """(T, 3) int64: triangles, with each quad split along its shorter diagonal."""
        return triangulate(self.points, self.faces)

    @property
    def s(self) -> np.ndarray:
        """(N,) position of every node along the body, fraction of L from the rostrum."""
        return (self.points[:, 0] - self.origin[0]) / self.length

    def volume(self, points: np.ndarray | None = None) -> float:
        """Enclosed volume (m^3) of the surface with the given node positions."""
        p = self.points if points is None else points
        t = self.triangles
        a, b, c = p[t[:, 0]], p[t[:, 1]], p[t[:, 2]]
        return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)

    def triangle_regions(self) -> np.ndarray:
        """(T,) int region index (:data:`REGIONS`) of every triangle of :attr:`triangles`.

        Flukes: triangles whose centroid lies behind the tail base (s > s of the landmark
        ``tail_base``, the animator's fluke gate). Flippers (of the rest): the faces built as
        flippers when :attr:`face_regions` is known (the procedural whale), else the geometric
        rule of :func:`flipper_triangles`. Body: everything else.
        """
        tri = self.triangles
        centroid = self.points[tri].mean(axis=1)
        s_c = (centroid[:, 0] - self.origin[0]) / self.length
        if self.face_regions is not None:
            per_tri = [r if f.shape[1] == 3 else np.concatenate([r, r])
                       for f, r in zip(self.faces, self.face_regions, strict=True)]
            flippers = np.concatenate(per_tri) == FLIPPERS
        else:
            flippers = flipper_triangles(self.points, tri, self.landmarks, self.origin,
                                         self.length)
        out = np.full(len(tri), BODY, dtype=np.int64)
        out[flippers] = FLIPPERS
        out[s_c > float(self.s[self.landmarks["tail_base"]])] = FLUKES
        return out

    def region_areas(self) -> dict:
        """Area (m2) of every region of :meth:`triangle_regions`."""
        p, tri = self.points, self.triangles
        area = 0.5 * np.linalg.norm(np.cross(p[tri[:, 1]] - p[tri[:, 0]],
                                             p[tri[:, 2]] - p[tri[:, 0]]), axis=1)
        reg = self.triangle_regions()
        return {name: float(area[reg == k].sum()) for k, name in enumerate(REGIONS)}

    def write_regions_stl(self, path: str | Path) -> None:
        """An ASCII STL with one solid per region, named as :data:`REGIONS` (the whaleLoads
        function object's ``regions`` surface; docs/openfoam-plugin.md)."""
        write_region_stl(path, self.points, self.triangles, self.triangle_regions())

    def write(self, path: str | Path, point_data: dict | None = None) -> None:
        """Write the surface; the format follows the suffix (STL, OBJ, VTK, VTU, VTP, PLY ...).

        STL gets triangles (what snappyHexMesh reads); the other formats keep the quads.
        """
        write_surface(path, self.points, self.faces, point_data=point_data)


def write_surface(path, points, faces, point_data=None) -> None:
    """Write a surface with meshio (pyvista for .vtp, which meshio does not write)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    suffix = path.suffix.lower()
    if suffix == ".vtp":
        import pyvista as pv

        flat = np.concatenate(
            [np.column_stack([np.full(len(f), f.shape[1]), f]).ravel() for f in faces]
        )
        poly = pv.PolyData(np.asarray(points, dtype=np.float64), flat)
        for name, values in (point_data or {}).items():
            poly.point_data[name] = np.asarray(values)
        poly.save(str(path), binary=True)
        return
    import meshio

    if suffix == ".stl":
        cells = [("triangle", triangulate(points, faces))]
    else:
        cells = [("triangle" if f.shape[1] == 3 else "quad", f) for f in faces]
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


#: how far (factor on the section's ellipse) a triangle must stick out of the body's section to
#: count as a flipper's (flipper_triangles)
FLIPPER_MARGIN = 1.05


def flipper_triangles(points, triangles, landmarks, origin, length, bins: int = 100):
    """Flipper triangles of a mesh file without region information (a geometric rule).

    A triangle is a flipper's when its centroid (a) lies within the flipper's reach: closer to
    the landmark ``flipper_left`` or ``flipper_right`` (the flipper tips) than that tip is to
    the body's axis (the x line through the rostrum), and (b) lies outside the body's section
    at its station: outside the ellipse whose half-width is the body's largest |y - y_rostrum|
    there and whose half-heights are those of the midline (dorsal above, ventral below the
    middle height). The section of a station (one of ``bins`` slices of s, empty slices
    interpolated, each widened to the largest of it and its two neighbours) comes from the
    nodes near the midline (the heights) and the nodes above the middle height (the width),
    where a right whale's flippers, rooted low on the flanks, are not; the ellipse is centred
    at the height of the widest such node and grown by :data:`FLIPPER_MARGIN`. The flipper's
    root, on the body's section, counts as body.
    """
    p = np.asarray(points, dtype=np.float64)
    centroid = p[triangles].mean(axis=1)
    y0 = float(origin[1])
    centres = (np.arange(bins) + 0.5) / bins

    def slice_of(x):
        return np.clip(((x - origin[0]) / length * bins).astype(int), 0, bins - 1)

    def per_slice(values, which, op, fill):
        out = np.full(bins, fill)
        op.at(out, b_n[which], values[which])
        ok = np.isfinite(out) & (out != fill)
        return np.interp(centres, centres[ok], out[ok]) if ok.any() else out

    def widened(x):
        return np.maximum(np.maximum(x, np.r_[x[:1], x[:-1]]), np.r_[x[1:], x[-1:]])

    b_n = slice_of(p[:, 0])
    ay = np.abs(p[:, 1] - y0)
    ymax = per_slice(ay, np.ones(len(p), bool), np.maximum, -np.inf)
    mid = ay <= 0.25 * ymax[b_n]
    zlo = per_slice(p[:, 2], mid, np.minimum, np.inf)
    zhi = per_slice(p[:, 2], mid, np.maximum, -np.inf)
    zmid = 0.5 * (zlo + zhi)
    upper = p[:, 2] >= zmid[b_n]
    half = per_slice(ay, upper, np.maximum, -np.inf)
    # the ellipse's centre: the height of the section's widest upper node
    zc = zmid.copy()
    for k in np.unique(b_n[upper]):
        sel = np.flatnonzero(upper & (b_n == k))
        zc[k] = p[sel[np.argmax(ay[sel])], 2]
    half = widened(half)
    up, down = widened(zhi - zc), widened(zc - zlo)
    b_c = slice_of(centroid[:, 0])
    dz = centroid[:, 2] - zc[b_c]
    height = np.where(dz >= 0, up[b_c], down[b_c])
    outside = ((np.abs(centroid[:, 1] - y0) / np.maximum(half[b_c], 1e-300)) ** 2
               + (dz / np.maximum(height, 1e-300)) ** 2) > FLIPPER_MARGIN ** 2
    out = np.zeros(len(triangles), bool)
    for name in ("flipper_left", "flipper_right"):
        tip = p[landmarks[name]]
        reach = float(np.hypot(tip[1] - y0, tip[2] - origin[2]))
        out |= outside & (np.linalg.norm(centroid - tip, axis=1) < reach)
    return out


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


def _unique_edges(faces: list) -> np.ndarray:
    pairs = []
    for f in faces:
        n = f.shape[1]
        for k in range(n):
            pairs.append(np.stack([f[:, k], f[:, (k + 1) % n]], axis=1))
    e = np.sort(np.concatenate(pairs), axis=1)
    return np.unique(e, axis=0).astype(np.int64)


# ----------------------------------------------------------------------------------------
# Validation


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
    directed = []
    for f in faces:
        k = f.shape[1]
        for c in range(k):
            directed.append(np.stack([f[:, c], f[:, (c + 1) % k]], axis=1))
    directed = np.concatenate(directed)
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

    v, p, q = [], [], []
    for f in faces:
        k = f.shape[1]
        for c in range(k):
            v.append(f[:, c])
            p.append(f[:, (c - 1) % k])
            q.append(f[:, (c + 1) % k])
    v, p, q = np.concatenate(v), np.concatenate(p), np.concatenate(q)
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
    flipped = [None] * len(flat)
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


# ----------------------------------------------------------------------------------------
# The procedural right whale


def _ring_positions(n_x: int) -> np.ndarray:
    """Stations s of the body rings (poles excluded), denser at both ends."""
    u = (np.arange(n_x) + 1.0) / (n_x + 1.0)
    return u - 0.6 * np.sin(2 * np.pi * u) / (2 * np.pi)


def _section(s: np.ndarray, n_phi: int, length: float) -> np.ndarray:
    """(len(s), n_phi, 3) ring points; phi = 0 is dorsal, phi = 90 deg the left side (+y).

    The right half mirrors the left exactly (y -> -y), so the whale is symmetric to the bit.
    """
    depth = _profile(_DEPTH)(s) * length
    width = _profile(_WIDTH)(s) * length
    top = _profile(_TOP_SHARE)(s)
    axis_z = _profile(_AXIS_Z)(s) * length
    half = n_phi // 2
    phi = 2 * np.pi * np.arange(half + 1) / n_phi  # 0 .. pi, left half and both midlines
    # superellipse, a little boxy at the head, elliptic elsewhere
    expo = 2.0 + 0.4 * np.clip(1 - s / 0.3, 0, 1)
    cz, sy = np.cos(phi)[None, :], np.sin(phi)[None, :]
    e = 2.0 / expo[:, None]
    y = 0.5 * width[:, None] * np.abs(sy) ** e
    zf = np.sign(cz) * np.abs(cz) ** e
    h = np.where(zf >= 0, top[:, None], 1 - top[:, None]) * depth[:, None]
    z = axis_z[:, None] + h * zf
    y[:, 0] = 0.0
    y[:, half] = 0.0
    pts = np.zeros((len(s), n_phi, 3))
    pts[:, :, 0] = s[:, None] * length
    pts[:, : half + 1, 1] = y
    pts[:, : half + 1, 2] = z
    mirror = n_phi - np.arange(half + 1, n_phi)
    pts[:, half + 1 :, 1] = -y[:, mirror]
    pts[:, half + 1 :, 2] = z[:, mirror]
    return pts


@dataclass(frozen=True)
class _Fin:
    """A fin grown out of a rectangular patch of the body's quads (one side; mirrored)."""

    ring0: int  # first ring of the patch
    a: int  # quads along the body
    phi0: int  # first phi index (left side)
    b: int  # quads around the body
    layers: int
    root: np.ndarray  # root centre (m)
    direction: np.ndarray  # unit growth direction
    length: float
    chord: object  # chord(t) in m, t in [0, 1] from root to tip
    thickness: object
    sweep: object = None  # extra displacement along x (m) as function of t
    chord_axis: np.ndarray = field(default_factory=lambda: np.array([1.0, 0.0, 0.0]))


def _patch_loop(f: _Fin, n_phi: int) -> tuple[list, list]:
    """Boundary loop (ring, phi) of the patch, and its interior nodes, on the left side."""
    i0, i1, j0, j1 = f.ring0, f.ring0 + f.a, f.phi0, f.phi0 + f.b
    loop = [(i, j0) for i in range(i0, i1)]
    loop += [(i1, j) for j in range(j0, j1)]
    loop += [(i, j1) for i in range(i1, i0, -1)]
    loop += [(i0, j) for j in range(j1, j0, -1)]
    inner = [(i, j) for i in range(i0 + 1, i1) for j in range(j0 + 1, j1)]
    return loop, inner


def _fin_layers(f: _Fin, loop_xyz: np.ndarray, inner_rc: list) -> tuple[np.ndarray, np.ndarray]:
    """Positions of the extruded loops (layers, P, 3) and of the moved interior (tip) nodes."""
    P = len(loop_xyz)
    d = f.direction / np.linalg.norm(f.direction)
    e1 = f.chord_axis - (f.chord_axis @ d) * d
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(d, e1)
    # loop index -> angle on the section ellipse: the long sides (along the body) map to the
    # chord's upper and lower faces, the short sides to its leading and trailing edges
    step = 2 * np.pi / P
    alpha = np.pi + (f.b / 2 + np.arange(P)) * step
    # which face is which: the first long side runs at phi0, compare with the other side
    side = np.sign((loop_xyz[: f.a + 1].mean(0) - loop_xyz[f.a + f.b : 2 * f.a + f.b].mean(0)) @ e2)
    side = side if side != 0 else 1.0
    centre0 = loop_xyz.mean(axis=0)

    def centre(t):
        c = f.root + t * f.length * d
        if f.sweep is not None:
            c = c + np.array([f.sweep(t), 0.0, 0.0])
        return c

    def ring(t):
        c = centre(t)
        ch, th = f.chord(t), f.thickness(t)
        return (c + 0.5 * ch * np.cos(alpha)[:, None] * e1
                - side * 0.5 * th * np.sin(alpha)[:, None] * e2)

    root_ring = ring(0.0) - f.root + centre0
    layers = []
    for k in range(1, f.layers + 1):
        t = k / f.layers
        blend = (1 - t) ** 3
        layers.append(ring(t) + blend * (loop_xyz - root_ring))
    layers = np.array(layers)
    # interior nodes make the rounded tip cap
    tip = []
    c1, ch, th = centre(1.0), f.chord(1.0), f.thickness(1.0)
    for i, j in inner_rc:
        p = -1 + 2 * (i - f.ring0) / f.a
        q = -1 + 2 * (j - f.phi0) / f.b
        bulge = 0.5 * min(ch, 3 * th) * np.sqrt(max(0.0, 1 - p * p)) * np.sqrt(max(0.0, 1 - q * q))
        tip.append(c1 + 0.45 * ch * p * e1 - side * 0.45 * th * q * e2 + bulge * d)
    return layers, np.array(tip).reshape(-1, 3)


def procedural_whale(length: float = 15.0, nodes: int = 11272, fluke_span: float = 0.32,
                     with_regions: bool = False):
    """Build the procedural right whale: (points, faces, landmarks), and with ``with_regions``
    a fourth item, ``face_regions``: per face group the region index (:data:`REGIONS`) each
    face was built as: the flipper fins' extrusion layers and tip caps FLIPPERS, the fluke
    fins' FLUKES, the rest BODY.

    ``nodes`` is met to within a ring of the body (about 0.6 % at the default 11,272).
    """
    if nodes < 400:
        raise GeometryError(f"nodes = {nodes} is too coarse for a whale; use at least 400")
    r = np.sqrt(nodes / 11272.0)
    n_phi = max(16, 4 * int(round(18 * r)))
    fa, fb, fm = max(3, round(8 * r)), 2, max(3, round(16 * r))  # flipper patch and layers
    ka, kb, km = max(3, round(10 * r)), max(2, 2 * round(2 * r)), max(4, round(24 * r))  # flukes
    # the fluke root runs from 0.92 L to the tail end (the notch): its ring count ka depends
    # on the ring count n_x, which depends on the fin nodes; a few rounds settle both
    for _ in range(4):
        fin_nodes = 2 * fm * 2 * (fa + fb) + 2 * km * 2 * (ka + kb)
        n_x = int(round((nodes - 2 - fin_nodes) / n_phi))
        if n_x < 20:
            raise GeometryError(f"nodes = {nodes} leaves too few body rings; use more nodes")
        s = _ring_positions(n_x)
        ka = max(3, (n_x - 2) - int(np.argmin(np.abs(s - 0.92))))
    rings = _section(s, n_phi, length)

    def ring_at(sv):
        return int(np.argmin(np.abs(s - sv)))

    # Flippers: broad paddles behind the head, about 0.11 L long, rooted low on the side
    fl_ring = ring_at(0.305) - fa // 2
    fl_phi = int(round(n_phi * 118 / 360)) - fb // 2
    fl_loop, fl_inner = _patch_loop(
        _Fin(fl_ring, fa, fl_phi, fb, fm, np.zeros(3), np.ones(3), 1, None, None), n_phi
    )
    fl_root = rings[tuple(np.array(fl_loop).T)].mean(axis=0)
    root_chord = float(np.ptp(rings[tuple(np.array(fl_loop).T)][:, 0]))
    flipper = _Fin(
        fl_ring, fa, fl_phi, fb, fm,
        root=fl_root,
        direction=np.array([0.45, 0.75, -0.48]),
        length=0.11 * length,
        chord=lambda t: root_chord * (1 + 0.35 * np.sin(np.pi * min(t, 1) ** 0.8))
        * np.sqrt(max(1 - t**6, 0.04)),
        thickness=lambda t: 0.012 * length * (1 - 0.55 * t),
    )
    # Flukes: swept wings from the sides of the tail stock, span fluke_span * L tip to tip
    ku_ring = n_x - 2 - ka
    ku_phi = n_phi // 4 - kb // 2
    ku_loop, _ = _patch_loop(
        _Fin(ku_ring, ka, ku_phi, kb, km, np.zeros(3), np.ones(3), 1, None, None), n_phi
    )
    ku_xyz = rings[tuple(np.array(ku_loop).T)]
    ku_root = ku_xyz.mean(axis=0)
    half_span = 0.5 * fluke_span * length - ku_root[1]
    fluke = _Fin(
        ku_ring, ka, ku_phi, kb, km,
        root=ku_root,
        direction=np.array([0.0, 1.0, 0.0]),
        length=half_span,
        chord=lambda t: 0.085 * length * (1.0 + 0.25 * np.sin(np.pi * min(t, 1.0)))
        * np.sqrt(max(1 - t**2.2, 0.015)),
        thickness=lambda t: 0.016 * length * (1 - 0.75 * t),
        sweep=lambda t: 0.075 * length * t**1.6,
    )

    # assemble: nose pole, rings, tail pole, then the fins' layers
    n_body = n_x * n_phi
    nose, tail = n_body, n_body + 1

    def node(i, j):
        return i * n_phi + (j % n_phi)

    pts = [rings.reshape(-1, 3), np.array([[0.0, 0.0, _profile(_AXIS_Z)(0.0) * length],
                                           [length, 0.0, 0.0]])]
    i = np.arange(n_x - 1)[:, None]
    j = np.arange(n_phi)[None, :]
    quads = np.stack(
        [node(i, j), node(i + 1, j), node(i + 1, j + 1), node(i, j + 1)], axis=-1
    ).reshape(-1, 4)
    jj = np.arange(n_phi)
    tris = np.concatenate(
        [
            np.stack([np.full(n_phi, nose), node(0, jj + 1), node(0, jj)], axis=1),
            np.stack([np.full(n_phi, tail), node(n_x - 1, jj), node(n_x - 1, jj + 1)], axis=1),
        ]
    )
    removed = set()
    new_quads = []
    new_regions = []
    next_index = n_body + 2
    fin_tips = {}
    for name, fin, loop_rc, inner_rc in (
        ("flipper", flipper, fl_loop, fl_inner),
        ("fluke", fluke, ku_loop, _patch_loop(fluke, n_phi)[1]),
    ):
        for sign in (1, -1):
            def mj(jv, sign=sign):
                return jv if sign == 1 else (n_phi - jv) % n_phi
            loop_idx = np.array([node(a, mj(b)) for a, b in loop_rc])
            inner_idx = np.array([node(a, mj(b)) for a, b in inner_rc], dtype=np.int64)
            # the patch's quads make way for the fin (kept as sorted tuples: winding-free)
            for a in range(fin.ring0, fin.ring0 + fin.a):
                for b in range(fin.phi0, fin.phi0 + fin.b):
                    removed.add(tuple(sorted((node(a, mj(b)), node(a + 1, mj(b)),
                                              node(a + 1, mj(b + 1)), node(a, mj(b + 1))))))
            left_loop_xyz = rings[tuple(np.array(loop_rc).T)]
            layers, tip = _fin_layers(fin, left_loop_xyz, inner_rc)
            if sign == -1:
                layers = layers * np.array([1.0, -1.0, 1.0])
                tip = tip * np.array([1.0, -1.0, 1.0])
            P = len(loop_idx)
            layer_idx = [loop_idx]
            for k in range(fin.layers):
                idx = np.arange(next_index, next_index + P)
                next_index += P
                pts.append(layers[k])
                layer_idx.append(idx)
            region = FLIPPERS if name == "flipper" else FLUKES
            for k in range(fin.layers):
                lo, hi = layer_idx[k], layer_idx[k + 1]
                for m in range(P):
                    new_quads.append((lo[m], lo[(m + 1) % P], hi[(m + 1) % P], hi[m]))
                    new_regions.append(region)
            # the tip cap re-uses the patch's quads: boundary nodes become the last layer
            remap = dict(zip(loop_idx.tolist(), layer_idx[-1].tolist(), strict=True))
            for a in range(fin.ring0, fin.ring0 + fin.a):
                for b in range(fin.phi0, fin.phi0 + fin.b):
                    q = [node(a, mj(b)), node(a + 1, mj(b)), node(a + 1, mj(b + 1)),
                         node(a, mj(b + 1))]
                    new_quads.append(tuple(remap.get(v, v) for v in q))
                    new_regions.append(region)
            # move the interior patch nodes to the tip
            pts[0][inner_idx] = tip
            tip_candidates = np.concatenate([layer_idx[-1], inner_idx])
            fin_tips[(name, sign)] = tip_candidates
    points = np.concatenate(pts)
    keep = np.array([tuple(sorted(q)) not in removed for q in quads.tolist()])
    body_quads = quads[keep]
    faces = [tris.astype(np.int64),
             np.concatenate([body_quads, np.array(new_quads, dtype=np.int64)])]

    def farthest(cands, direction):
        return int(cands[np.argmax(points[cands] @ direction)])

    lm = {
        "rostrum": nose,
        "flipper_left": farthest(fin_tips[("flipper", 1)], flipper.direction),
        "flipper_right": farthest(fin_tips[("flipper", -1)],
                                  flipper.direction * np.array([1, -1, 1])),
        "tail_base": node(ring_at(TAIL_BASE_S), 0),
        "fluke_tip_left": farthest(fin_tips[("fluke", 1)], np.array([0.0, 1.0, 0.0])),
        "fluke_tip_right": farthest(fin_tips[("fluke", -1)], np.array([0.0, -1.0, 0.0])),
    }
    if with_regions:
        face_regions = [np.full(len(tris), BODY, dtype=np.int64),
                        np.concatenate([np.full(len(body_quads), BODY, dtype=np.int64),
                                        np.array(new_regions, dtype=np.int64)])]
        return points, faces, lm, face_regions
    return points, faces, lm


def read_surface(path: str | Path) -> tuple[np.ndarray, list]:
    """Read a closed surface mesh with meshio: (points, faces grouped by corner count)."""
    import meshio

    path = Path(path)
    if not path.is_file():
        raise GeometryError(f"mesh file {path} does not exist")
    try:
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
        points, faces = _merge_coincident(points, faces)
    return points, faces


def _merge_coincident(points, faces):
    scale = max(np.ptp(points, axis=0).max(), 1e-12)
    key = np.round(points / (1e-9 * scale)).astype(np.int64)
    _, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
    inverse = inverse.ravel()
    return points[first], [inverse[f] for f in faces]


def _landmarks_from_scene(points, landmarks: dict, length: float, tolerance: float) -> dict:
    missing = [k for k in LANDMARKS if k not in landmarks]
    if missing:
        raise GeometryError(
            f"geometry.landmarks is missing {', '.join(missing)}; a mesh file needs all of "
            f"{', '.join(LANDMARKS)} as [x, y, z] in the file's coordinates"
        )
    out = {}
    for name in LANDMARKS:
        p = np.asarray(landmarks[name], dtype=np.float64)
        d = np.linalg.norm(points - p, axis=1)
        i = int(np.argmin(d))
        if d[i] > tolerance * length:
            raise GeometryError(
                f"landmark {name} at {p.tolist()} is {d[i]:.3g} m from the nearest surface "
                f"point (allowed {tolerance * length:.3g} m = geometry.landmark_tolerance * L): "
                "it is not on the body"
            )
        out[name] = i
    return out


def build_surface(scene) -> WhaleSurface:
    """The scene's whale surface, checked (closed, manifold, oriented outward)."""
    g = scene.geometry
    if g.source == "procedural":
        points, faces, landmarks, face_regions = procedural_whale(
            g.length_m, g.nodes, g.fluke_span, with_regions=True)
        length = g.length_m
        origin = np.zeros(3)
        # orientation flips rows in place: the regions stay parallel to the faces
        faces = validate_surface(points, faces, length)
    else:
        points, faces = read_surface(scene.resolve(g.source))
        extent = float(np.ptp(points[:, 0]))
        faces = validate_surface(points, faces, max(extent, 1e-12))
        landmarks = _landmarks_from_scene(points, g.landmarks, extent, g.landmark_tolerance)
        origin = points[landmarks["rostrum"]].copy()
        length = float(points[:, 0].max() - origin[0])
        if length <= 0:
            raise GeometryError(
                "the mesh must lie along +x from its rostrum (x grows toward the tail)"
            )
        face_regions = None
    return WhaleSurface(points, faces, landmarks, length, origin, face_regions)


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "geometry", help="write the scene's whale surface (STL, OBJ, VTK)",
        description="Build the scene's whale surface (the procedural right whale or the "
        "scene's mesh file), check it (closed, manifold, outward) and write it to each --out "
        "file, the format by suffix (docs/geometry.md).")
    p.add_argument("--scene", help="scene TOML file (default: built-in default)")
    p.add_argument("--preset", help="built-in preset: default, smoke, fine")
    p.add_argument("--out", required=True, nargs="+", help="output file(s); format by suffix")
    p.set_defaults(func=_cmd_geometry)


def _cmd_geometry(args: argparse.Namespace) -> int:
    from adapter.scene import load_scene

    scene = load_scene(args.scene, preset=args.preset)
    surface = build_surface(scene)
    for out in args.out:
        surface.write(out)
        print(f"wrote {out}: {surface.n_nodes} nodes, {len(surface.edges)} edges")
    return 0
