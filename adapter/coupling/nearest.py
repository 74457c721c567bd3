"""The exact closest surface triangle of each patch point: a uniform grid over the surface and
one compiled (numba) pass, in chunks over the available cores. Used by
:class:`~adapter.coupling.mapping.PatchMap`.
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor

import numba
import numpy as np

from adapter.errors import GeometryError

#: grid cell side, in median triangle bounding-box sizes
CELL = 1.0
#: points per compiled call (threads take chunks in turn)
CHUNK = 16384


def nearest_triangles(pts, verts, tris):
    """Closest triangle, barycentric weights and distance for each point, exactly.

    Each triangle is listed in every cell of a uniform grid that its bounding box touches. A
    point visits the cells in shells of growing Chebyshev distance from its own cell and keeps
    the closest triangle so far; a cell farther than that (distance to the cell's box) is
    skipped, and so is a triangle farther than that by its bounding ball (distance to the
    centroid less the radius); the search stops once a whole shell lies farther. The closest
    point of the closest triangle lies in some cell that lists the triangle and is no farther
    than it, so the search is exact. Ties go to the lowest triangle index, so the answer
    depends only on the point (not on the order of the visit, the grid or the chunks). One
    compiled pass (:func:`_nearest_kernel`), in chunks over the available cores.
    """
    corners = np.ascontiguousarray(verts[tris])               # (T, 3, 3)
    if len(corners) == 0:
        raise GeometryError("the whale surface has no triangles")
    centroids = corners.mean(axis=1)
    radii = np.linalg.norm(corners - centroids[:, None, :], axis=2).max(axis=1)
    vmax = float(np.abs(verts).max())
    lo, cell, dims, cell_start, cell_tris = _grid(corners, vmax)
    n = len(pts)
    tri = np.empty(n, dtype=np.int64)
    w = np.empty((n, 3))
    d = np.empty(n)
    args = (corners, centroids, radii, lo, cell, dims, cell_start, cell_tris, vmax)
    chunks = [(s, min(s + CHUNK, n)) for s in range(0, n, CHUNK)]
    n_workers = min(workers(), len(chunks))

    def run(chunk):
        a, b = chunk
        _nearest_kernel(pts[a:b], *args, tri[a:b], w[a:b], d[a:b])

    if n_workers <= 1:
        for chunk in chunks:
            run(chunk)
    else:
        with ThreadPoolExecutor(max_workers=n_workers) as pool:
            list(pool.map(run, chunks))
    return tri, w, d


def workers() -> int:
    """The cores this process may run on."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:                                    # not Linux
        return max(1, os.cpu_count() or 1)


def _grid(corners, vmax):
    """A uniform grid of cubic cells over the surface, each cell listing the triangles whose
    bounding box (widened by a rounding margin) touches it.

    Returns the grid's lower corner (3,), the cell side, the cell counts (3,) int64, and the
    lists: triangles by cell (``cell_tris``, ascending within a cell) with each cell's start
    in it (``cell_start``, one more entry than cells, x slowest). The cell side is the median
    bounding-box size of a triangle, grown until there are at most 8 cells per triangle.
    """
    margin = 1e-9 * (1.0 + vmax)
    box_lo = corners.min(axis=1) - margin
    box_hi = corners.max(axis=1) + margin
    lo = box_lo.min(axis=0)
    extent = box_hi.max(axis=0) - lo
    cell = CELL * float(np.median((box_hi - box_lo).max(axis=1)))
    while True:
        dims = np.floor(extent / cell).astype(np.int64) + 1
        if int(np.prod(dims)) <= 8 * len(corners) + 64:
            break
        cell *= 1.5
    first = np.clip(np.floor((box_lo - lo) / cell).astype(np.int64), 0, dims - 1)
    last = np.clip(np.floor((box_hi - lo) / cell).astype(np.int64), 0, dims - 1)
    cell_start, cell_tris = _bin(first, last, dims)
    return lo, cell, dims, cell_start, cell_tris


@numba.njit(cache=True, nogil=True)
def _bin(first, last, dims):
    """Triangle t in every cell of the block first[t]..last[t] (inclusive): CSR lists."""
    ny, nz = dims[1], dims[2]
    start = np.zeros(dims[0] * ny * nz + 1, dtype=np.int64)
    for t in range(first.shape[0]):
        for jx in range(first[t, 0], last[t, 0] + 1):
            for jy in range(first[t, 1], last[t, 1] + 1):
                for jz in range(first[t, 2], last[t, 2] + 1):
                    start[(jx * ny + jy) * nz + jz + 1] += 1
    for k in range(1, start.shape[0]):
        start[k] += start[k - 1]
    fill = start[:-1].copy()
    tris = np.empty(start[-1], dtype=np.int64)
    for t in range(first.shape[0]):
        for jx in range(first[t, 0], last[t, 0] + 1):
            for jy in range(first[t, 1], last[t, 1] + 1):
                for jz in range(first[t, 2], last[t, 2] + 1):
                    k = (jx * ny + jy) * nz + jz
                    tris[fill[k]] = t
                    fill[k] += 1
    return start, tris


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _closest(px, py, pz, c):
    """Weights and distance of the point of triangle c (3, 3) closest to p.

    The scalar twin of :func:`closest_point_weights` followed by the distance
    ``|p - (wa a + wb b + wc c)|`` summed left to right, as the numpy search before it did: the
    same operations in the same order, so the same bits (numba contracts no multiply-add
    without fastmath; tests/test_mapping.py checks the bits against the numpy formulas).
    """
    ax, ay, az = c[0, 0], c[0, 1], c[0, 2]
    bx, by, bz = c[1, 0], c[1, 1], c[1, 2]
    cx, cy, cz = c[2, 0], c[2, 1], c[2, 2]
    abx, aby, abz = bx - ax, by - ay, bz - az
    acx, acy, acz = cx - ax, cy - ay, cz - az
    apx, apy, apz = px - ax, py - ay, pz - az
    d1 = abx * apx + aby * apy + abz * apz
    d2 = acx * apx + acy * apy + acz * apz
    bpx, bpy, bpz = px - bx, py - by, pz - bz
    d3 = abx * bpx + aby * bpy + abz * bpz
    d4 = acx * bpx + acy * bpy + acz * bpz
    cpx, cpy, cpz = px - cx, py - cy, pz - cz
    d5 = abx * cpx + aby * cpy + abz * cpz
    d6 = acx * cpx + acy * cpy + acz * cpz
    vc = d1 * d4 - d3 * d2
    vb = d5 * d2 - d1 * d6
    va = d3 * d6 - d5 * d4
    if (d1 <= 0) and (d2 <= 0):                                        # vertex a
        wa, wb, wc = 1.0, 0.0, 0.0
    elif (d3 >= 0) and (d4 <= d3):                                     # vertex b
        wa, wb, wc = 0.0, 1.0, 0.0
    elif (vc <= 0) and (d1 >= 0) and (d3 <= 0):                        # edge ab
        den = d1 - d3
        v = d1 / den if den != 0 else 0.0
        wa, wb, wc = 1 - v, v, 0.0
    elif (d6 >= 0) and (d5 <= d6):                                     # vertex c
        wa, wb, wc = 0.0, 0.0, 1.0
    elif (vb <= 0) and (d2 >= 0) and (d6 <= 0):                        # edge ac
        den = d2 - d6
        v = d2 / den if den != 0 else 0.0
        wa, wb, wc = 1 - v, 0.0, v
    elif (va <= 0) and ((d4 - d3) >= 0) and ((d5 - d6) >= 0):          # edge bc
        den = (d4 - d3) + (d5 - d6)
        v = (d4 - d3) / den if den != 0 else 0.0
        wa, wb, wc = 0.0, 1 - v, v
    else:                                                              # inside
        den = va + vb + vc
        v = vb / den if den != 0 else 0.0
        u = vc / den if den != 0 else 0.0
        wa, wb, wc = 1 - v - u, v, u
    qx = wa * ax + wb * bx + wc * cx
    qy = wa * ay + wb * by + wc * cy
    qz = wa * az + wb * bz + wc * cz
    dx, dy, dz = px - qx, py - qy, pz - qz
    return wa, wb, wc, np.sqrt(dx * dx + dy * dy + dz * dz)


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _nearest_kernel(pts, corners, centroids, radii, lo, cell, dims, cell_start, cell_tris, vmax,
                    out_tri, out_w, out_d):
    """The closest triangle of each point (see :func:`_nearest`), into out_tri, out_w, out_d."""
    nx, ny, nz = dims[0], dims[1], dims[2]
    for i in range(pts.shape[0]):
        px, py, pz = pts[i, 0], pts[i, 1], pts[i, 2]
        # rounding guard of the lower bounds, as in the exact ball search it replaces
        slack = 1e-9 * (1.0 + max(vmax, abs(px), abs(py), abs(pz)))
        # the point's cell, clamped into the grid (a lower bound still holds: a cell s cells
        # away along one axis is at least (s - 1) cells away from the point along it)
        fx = min(max(np.floor((px - lo[0]) / cell), 0.0), nx - 1.0)
        fy = min(max(np.floor((py - lo[1]) / cell), 0.0), ny - 1.0)
        fz = min(max(np.floor((pz - lo[2]) / cell), 0.0), nz - 1.0)
        ix, iy, iz = int(fx), int(fy), int(fz)
        smax = max(ix, nx - 1 - ix, iy, ny - 1 - iy, iz, nz - 1 - iz)
        best, best_t = np.inf, -1
        bwa, bwb, bwc = 0.0, 0.0, 0.0
        for s in range(smax + 1):
            if s > 0 and (s - 1) * cell > best + slack:
                break
            for jx in range(max(ix - s, 0), min(ix + s, nx - 1) + 1):
                ex = abs(jx - ix)
                # distance along x from the point to the cell's slab
                gx = max(lo[0] + jx * cell - px, px - (lo[0] + (jx + 1) * cell), 0.0)
                for jy in range(max(iy - s, 0), min(iy + s, ny - 1) + 1):
                    ey = abs(jy - iy)
                    gy = max(lo[1] + jy * cell - py, py - (lo[1] + (jy + 1) * cell), 0.0)
                    on_shell = ex == s or ey == s
                    step = 1 if on_shell else 2 * s
                    if s == 0:
                        step = 1
                    for jz in range(iz - s, iz + s + 1, step):
                        if jz < 0 or jz > nz - 1:
                            continue
                        gz = max(lo[2] + jz * cell - pz, pz - (lo[2] + (jz + 1) * cell), 0.0)
                        if np.sqrt(gx * gx + gy * gy + gz * gz) > best + slack:
                            continue
                        k = (jx * ny + jy) * nz + jz
                        for m in range(cell_start[k], cell_start[k + 1]):
                            t = cell_tris[m]
                            ox = px - centroids[t, 0]
                            oy = py - centroids[t, 1]
                            oz = pz - centroids[t, 2]
                            if np.sqrt(ox * ox + oy * oy + oz * oz) - radii[t] > best + slack:
                                continue
                            wa, wb, wc, dist = _closest(px, py, pz, corners[t])
                            if dist < best or (dist == best and t < best_t):
                                best, best_t = dist, t
                                bwa, bwb, bwc = wa, wb, wc
        out_tri[i] = best_t
        out_w[i, 0] = bwa
        out_w[i, 1] = bwb
        out_w[i, 2] = bwc
        out_d[i] = best

