"""The paper's landmarks: the named points of the whale, defined once for the whole package.

:data:`LANDMARKS` is the one list of names (the surface's ``landmarks`` dict, the scene's
``geometry.landmarks``, the step-server's key points); :func:`landmarks_from_scene` finds a
mesh file's landmark nodes from the scene's coordinates.
"""

from __future__ import annotations

import numpy as np

from adapter.errors import GeometryError

#: the landmark names, in the paper's order
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


def landmarks_from_scene(points, landmarks: dict, length: float, tolerance: float) -> dict:
    """Name -> node index of a mesh file's landmarks: the surface point nearest each of the
    scene's coordinates (``landmarks``: name -> [x, y, z]), which must lie within
    ``tolerance`` x ``length`` of it."""
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
