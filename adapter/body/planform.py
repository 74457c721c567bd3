"""A fin's planform measured from its triangles: span, mean chord and thickness ratio.

What a drag estimate for a flipper or a fluke needs (adapter/foam/estimates.py), read from the
surface itself, not from the numbers that built it, so that it holds for any fin shape and for
a whale read from a mesh file:

- the fin's plane: the two largest principal axes of its area-weighted triangle centroids (the
  smallest, its normal ``n``, is the thickness direction: a fin is much thinner than it is wide);
- the chord direction ``c``: the flow direction projected into that plane (the chord is the
  length along the flow, the one the Reynolds number is built on); the span direction
  ``s = n x c``, whichever way the fin points (a right whale's flippers point out, back and
  down, its flukes sideways);
- :data:`SECTIONS` cuts of the surface by planes normal to ``s``, at the midpoints of equal
  spanwise strips: each cut's chord is its extent along ``c``, its thickness the largest extent
  along ``n`` at one chordwise place. A cut that crosses the fin's open edges (its root, where
  the region joins the body: a flipper's slanted junction with the flank, the flukes' tail
  stock behind the tail base) is not a section of the fin and is left out;
- span: the fin's extent along ``s``; mean chord: the mean of the closed cuts' chords
  (planform area over span); thickness ratio t/c: their thicknesses over their chords,
  weighted by chord (sum of t over sum of c, the strips being equally wide).

A region with a fin on either side of the mirror plane y = y0 (the flippers; the flukes, one
blade across it) is measured side by side (:func:`mirrored_planform`): each side on its own,
the other side mirrored onto the first, the figures the mean of the sides, and how far the sides
differ reported, so that a whale that is not mirror-symmetric is measured, not assumed.
"""

from __future__ import annotations

import numpy as np

from adapter.errors import GeometryError

#: spanwise cuts of a fin (midpoints of equal strips)
SECTIONS = 24
#: chordwise places per cut where the thickness is measured
CHORDWISE = 400
#: the smallest share of the flow direction in a fin's plane (|c| before normalising) below which
#: the fin faces the flow and has no chord along it
MIN_FLOW_IN_PLANE = 0.3


def triangle_areas(tri: np.ndarray) -> np.ndarray:
    """(T,) areas (m2) of (T, 3, 3) triangles."""
    return 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)


def fin_axes(tri: np.ndarray, flow=(1.0, 0.0, 0.0)) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(span, chord, normal) unit vectors of a fin of (T, 3, 3) triangles, as the module says."""
    area = triangle_areas(tri)
    centroid = tri.mean(axis=1)
    mean = (area[:, None] * centroid).sum(axis=0) / area.sum()
    d = centroid - mean
    cov = (area[:, None, None] * d[:, :, None] * d[:, None, :]).sum(axis=0) / area.sum()
    normal = np.linalg.eigh(cov)[1][:, 0]
    flow = np.asarray(flow, dtype=np.float64) / np.linalg.norm(flow)
    chord = flow - (flow @ normal) * normal
    if np.linalg.norm(chord) < MIN_FLOW_IN_PLANE:
        raise GeometryError(
            f"the fin's plane (normal {np.round(normal, 3).tolist()}) faces the flow: it has no "
            "chord along it, so no drag estimate is made for it")
    chord /= np.linalg.norm(chord)
    return np.cross(normal, chord), chord, normal


def open_edges(tri: np.ndarray) -> np.ndarray:
    """(T, 3) bool: which edges (corners 0-1, 1-2, 2-0) of the (T, 3, 3) triangles belong to no
    other triangle of them (corners matched to 1e-9 of the extent): the fin's root, where it
    joins the rest of the surface."""
    flat = tri.reshape(-1, 3)
    scale = max(float(np.ptp(flat, axis=0).max()), 1e-12)
    _, ids = np.unique(np.round(flat / (1e-9 * scale)).astype(np.int64), axis=0,
                       return_inverse=True)
    ids = ids.reshape(-1, 3)
    pairs = np.stack([np.sort(ids[:, [i, j]], axis=1) for i, j in _EDGES], axis=1)
    code = pairs[:, :, 0] * (int(ids.max()) + 1) + pairs[:, :, 1]
    _, where, count = np.unique(code.ravel(), return_inverse=True, return_counts=True)
    return (count[where] == 1).reshape(-1, 3)


#: a triangle's edges, by corner
_EDGES = ((0, 1), (1, 2), (2, 0))


def section(tri: np.ndarray, axis: np.ndarray, at: float,
            open_edge: np.ndarray | None = None) -> tuple[np.ndarray, bool]:
    """(M, 2, 3) segments where the plane ``p . axis = at`` cuts the (T, 3, 3) triangles (a corner
    on the plane counts as above it, so every cut triangle gives exactly one segment), and
    whether the cut crosses one of the ``open_edge`` (T, 3) (:func:`open_edges`): an open cut,
    through the fin's root, not a closed section of it."""
    d = tri @ axis - at
    above = d >= 0
    cut = above.any(axis=1) & ~above.all(axis=1)
    tri, d, above = tri[cut], d[cut], above[cut]
    ends = []
    for i, j in _EDGES:
        crosses = above[:, i] != above[:, j]
        w = np.where(crosses, d[:, i] / np.where(crosses, d[:, i] - d[:, j], 1.0), 0.0)
        ends.append((tri[:, i] + w[:, None] * (tri[:, j] - tri[:, i]), crosses))
    # each cut triangle has exactly two crossing edges: take them in edge order
    pts = np.stack([e for e, _ in ends], axis=1)             # (M, 3 edges, 3)
    mask = np.stack([c for _, c in ends], axis=1)            # (M, 3)
    order = np.argsort(~mask, axis=1, kind="stable")[:, :2]
    is_open = bool(open_edge is not None and (mask & open_edge[cut]).any())
    return np.take_along_axis(pts, order[:, :, None], axis=1), is_open


def cut_chord_and_thickness(segments: np.ndarray, chord: np.ndarray,
                            normal: np.ndarray) -> tuple[float, float]:
    """(chord, largest thickness) in m of one cut: its extent along ``chord``, and the largest
    extent along ``normal`` at one of :data:`CHORDWISE` chordwise places."""
    xi = segments @ chord                                    # (M, 2)
    zeta = segments @ normal
    lo, hi = xi.min(), xi.max()
    places = lo + (hi - lo) * (np.arange(CHORDWISE) + 0.5) / CHORDWISE
    a, b = xi.min(axis=1), xi.max(axis=1)
    covers = (a[:, None] <= places) & (places <= b[:, None])            # (M, J)
    dxi = np.where(xi[:, 1] != xi[:, 0], xi[:, 1] - xi[:, 0], 1.0)
    w = (places[None, :] - xi[:, :1]) / dxi[:, None]
    z = zeta[:, :1] + w * (zeta[:, 1:] - zeta[:, :1])
    top = np.where(covers, z, -np.inf).max(axis=0)
    bottom = np.where(covers, z, np.inf).min(axis=0)
    thick = top - bottom
    return float(hi - lo), float(thick[np.isfinite(thick)].max(initial=0.0))


def planform(tri: np.ndarray, flow=(1.0, 0.0, 0.0), sections: int = SECTIONS) -> dict:
    """Span (m), mean chord (m), thickness ratio and planform area (m2) of one fin of (T, 3, 3)
    triangles, and its axes, as the module says."""
    tri = np.asarray(tri, dtype=np.float64)
    if tri.ndim != 3 or tri.shape[1:] != (3, 3) or len(tri) < 4:
        raise GeometryError(f"a fin's triangles have shape {tri.shape}, expected (T, 3, 3) "
                            "with T >= 4")
    span_axis, chord_axis, normal = fin_axes(tri, flow)
    eta = tri @ span_axis
    lo, hi = float(eta.min()), float(eta.max())
    root = open_edges(tri)
    cuts = []                              # (chord, thickness, closed) per cut
    for k in range(sections):
        seg, is_open = section(tri, span_axis, lo + (hi - lo) * (k + 0.5) / sections, root)
        if len(seg):
            cuts.append((*cut_chord_and_thickness(seg, chord_axis, normal), not is_open))
    closed = [c for c in cuts if c[2]] or cuts
    if not closed:
        raise GeometryError("no cut across the fin's span meets its triangles: is it a fin?")
    chords, thicks = np.array([c[0] for c in closed]), np.array([c[1] for c in closed])
    span = hi - lo
    return {"span_m": span, "mean_chord_m": float(chords.mean()),
            "t_c": float(thicks.sum() / chords.sum()),
            "planform_area_m2": float(chords.mean() * span), "cuts": len(closed),
            "wetted_area_m2": float(triangle_areas(tri).sum()),
            "span_axis": span_axis.tolist(), "chord_axis": chord_axis.tolist(),
            "normal": normal.tolist()}


#: the figures of a side that mirrored_planform averages over the sides
_AVERAGED = ("span_m", "mean_chord_m", "t_c", "planform_area_m2", "wetted_area_m2")


def mirrored_planform(tri: np.ndarray, y0: float, flow=(1.0, 0.0, 0.0),
                      sections: int = SECTIONS) -> dict:
    """The planform of a region with a fin on either side of the plane y = ``y0``: each side
    (triangles by their centroid; corners across the plane moved onto it, so that a blade
    crossing it, the flukes', is cut there; the side y < y0 mirrored) measured by
    :func:`planform`, the figures the mean over the sides, ``sides`` how many had triangles,
    and ``mirror_mismatch`` the largest relative difference between the two sides' figures
    (0 for a mirror-symmetric region)."""
    tri = np.asarray(tri, dtype=np.float64)
    centroid_y = tri[:, :, 1].mean(axis=1)
    sides = []
    for keep, mirror in ((centroid_y > y0, False), (centroid_y < y0, True)):
        if keep.sum() >= 4:
            sides.append(planform(_onto_positive_side(tri[keep], y0, mirror), flow, sections))
    if not sides:
        raise GeometryError(f"the region has {len(tri)} triangles, too few on either side of "
                            f"y = {y0:.4g} m to measure a fin")
    out = {k: float(np.mean([s[k] for s in sides])) for k in _AVERAGED}
    mismatch = 0.0
    if len(sides) == 2:
        mismatch = max(abs(sides[0][k] - sides[1][k]) / max(abs(out[k]), 1e-300)
                       for k in _AVERAGED)
    return {**out, "sides": len(sides), "mirror_mismatch": float(mismatch)}


def _onto_positive_side(tri: np.ndarray, y0: float, mirror: bool) -> np.ndarray:
    """One side's triangles on y >= y0: mirrored there if ``mirror``, corners still across the
    plane moved onto it."""
    out = tri.copy()
    if mirror:
        out[:, :, 1] = 2 * y0 - out[:, :, 1]
    out[:, :, 1] = np.maximum(out[:, :, 1], y0)
    return out
