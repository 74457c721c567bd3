"""The fins' leading edges: where snappyHexMesh puts finer cells at
``case.flipper_edge_level`` and ``case.fluke_edge_level``.

A fin's pressure drag on the default's cells is mostly its leading edge's: the suction peak
there and the recovery behind it want cells a few times smaller than the leading-edge radius
(docs/results/2026-12-07-fin-edges.md). Refining the forward part of each section buys what
refining the whole fin buys, for fewer cells.

The stream runs along +x, so a section's leading edge is its forward-most point. A section
is taken as the fin's triangles in a strip of span: along ``|y - axis_y|`` (the flippers grow
outward and the flukes spread sideways from the body's axis), ``strip_m`` wide. Within a
strip a triangle's chord position is ``(x - x_min) / (x_max - x_min)`` of its centroid.
"""

from __future__ import annotations

import numpy as np

#: the forward share of each section's chord refined at the edge levels
EDGE_FRACTION = 0.1


def leading_edge_mask(centroids: np.ndarray, axis_y: float, strip_m: float,
                      fraction: float = EDGE_FRACTION) -> np.ndarray:
    """Which triangles (by their (T, 3) centroids) lie in the forward ``fraction`` of their
    section's chord, sections being strips of ``|y - axis_y|`` ``strip_m`` wide."""
    c = np.asarray(centroids, dtype=float)
    if len(c) == 0:
        return np.zeros(0, dtype=bool)
    span = np.abs(c[:, 1] - axis_y)
    strip = np.floor((span - span.min()) / strip_m).astype(int)
    keep = np.zeros(len(c), dtype=bool)
    for k in np.unique(strip):
        mine = strip == k
        x = c[mine, 0]
        chord = x.max() - x.min()
        keep[mine] = x - x.min() <= fraction * chord
    return keep
