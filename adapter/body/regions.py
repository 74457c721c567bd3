"""The body regions the loads are split into (docs/geometry.md): body, flippers, flukes.

The procedural whale knows its flippers (it built them); a mesh file's are found by the
geometric rule of :func:`flipper_triangles`.
"""

from __future__ import annotations

import numpy as np

#: the body regions the loads are split into (docs/geometry.md), by index
REGIONS = ("body", "flippers", "flukes")
BODY, FLIPPERS, FLUKES = 0, 1, 2


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
    # hypot: a section of no height (the floor's 1e-300) gives a huge ratio, not an overflow
    outside = np.hypot(np.abs(centroid[:, 1] - y0) / np.maximum(half[b_c], 1e-300),
                       dz / np.maximum(height, 1e-300)) > FLIPPER_MARGIN
    out = np.zeros(len(triangles), bool)
    for name in ("flipper_left", "flipper_right"):
        tip = p[landmarks[name]]
        reach = float(np.hypot(tip[1] - y0, tip[2] - origin[2]))
        out |= outside & (np.linalg.norm(centroid - tip, axis=1) < reach)
    return out
