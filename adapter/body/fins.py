"""The procedural whale's fins: their sections (NACA four-digit foils turning into ellipses at
the tip) and growing a fin out of a rectangular patch of the body's quads by extrusion
(:func:`fin_layers`); :mod:`adapter.body.procedural` places the flippers and the flukes.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

# Section thickness over chord, (root, tip): the flippers' from the humpback flipper's
# sections (Fish and Battle 1995: symmetric, 0.20-0.28, mean 0.23); the flukes' a choice in
# the range of cetacean fluke sections (docs/geometry.md). Both sections are NACA four-digit.
FLIPPER_THICKNESS = (0.23, 0.20)
# ... and over the outer fifth of the span, where the chord closes, the flipper's sections
# round off to t/c 0.30 at the tip (the humpback's thickest point moves back to 0.49 c there)
FLIPPER_TIP_ROUNDING = 0.10
#: the outer share of a fin's span over which its sections turn from the foil into an ellipse
TIP_ROUND = 0.2
FLUKE_THICKNESS = (0.20, 0.12)
#: a fin's foil root (adapter/body/footprint.py ``foil_root``): its nose lies this share
#: of a ring spacing ahead of the patch, its trailing point this share behind it
ROOT_LEAD = 0.5
ROOT_TRAIL = 0.5



def foil_half_thickness(xc: np.ndarray, thickness_ratio: float) -> np.ndarray:
    """Half-thickness over chord of the symmetric NACA four-digit section at chord fraction
    ``xc`` (0 at the leading edge), with the closed trailing edge (last coefficient -0.1036):
    a round leading edge of radius 1.1019 (t/c)^2 c, the thickest point at 0.30 c and a sharp
    trailing edge (Abbott and von Doenhoff 1959, eq. 6.2)."""
    x = np.clip(xc, 0.0, 1.0)
    return 5.0 * thickness_ratio * (0.2969 * np.sqrt(x) - 0.1260 * x - 0.3516 * x**2
                                    + 0.2843 * x**3 - 0.1036 * x**4)


@dataclass(frozen=True)
class Fin:
    """A fin grown out of a rectangular patch of the body's quads (one side; mirrored)."""

    ring0: int  # first ring of the patch
    a: int  # quads along the body
    phi0: int  # first phi index (left side)
    b: int  # quads around the body
    layers: int
    root: np.ndarray  # root centre (m)
    direction: np.ndarray  # unit growth direction
    length: float
    chord: Callable[[float], float]  # chord(t) in m, t in [0, 1] from root to tip
    thickness_ratio: Callable[[float], float]  # the section's thickness over chord at t
    tip_round: float = TIP_ROUND  # the outer share of the span with elliptic sections (1: all)
    sweep: Callable[[float], float] | None = None  # extra displacement along x (m) at t
    chord_axis: np.ndarray = field(default_factory=lambda: np.array([1.0, 0.0, 0.0]))


def flat(t: float) -> float:
    """A placeholder chord or thickness law, for a fin whose patch alone is wanted."""
    return 0.0


def patch_loop(f: Fin, n_phi: int) -> tuple[list, list]:
    """Boundary loop (ring, phi) of the patch, and its interior nodes, on the left side."""
    i0, i1, j0, j1 = f.ring0, f.ring0 + f.a, f.phi0, f.phi0 + f.b
    loop = [(i, j0) for i in range(i0, i1)]
    loop += [(i1, j) for j in range(j0, j1)]
    loop += [(i, j1) for i in range(i1, i0, -1)]
    loop += [(i0, j) for j in range(j1, j0, -1)]
    inner = [(i, j) for i in range(i0 + 1, i1) for j in range(j0 + 1, j1)]
    return loop, inner


def fin_section(f: Fin, t: float, alpha: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(chord fraction, half-thickness over chord) of the fin's section at span station ``t``
    for nodes at angles ``alpha`` around it (pi: the leading edge, 0: the trailing edge): the
    NACA four-digit foil with chord fraction 1 - cos(pi tau / 2), tau the share of the way
    from the leading to the trailing edge, which puts the nodes closest together at the round
    leading edge and evenly toward the sharp trailing edge. Toward the tip the sections turn
    into ellipses of the same t/c (over the outer ``f.tip_round`` of the span): the tip cap
    joins the last section with faces the stroke does not fold, which a sharp trailing edge
    and a clustered leading edge would make slivers."""
    tau = 1 - np.abs(np.angle(np.exp(1j * alpha))) / np.pi
    xc_foil = 1 - np.cos(0.5 * np.pi * tau)
    xc_ellipse = 0.5 * (1 + np.cos(alpha))
    half_ellipse = 0.5 * np.abs(np.sin(alpha))
    w = 1.0 if f.tip_round >= 1 else float(
        np.clip((t - (1 - f.tip_round)) / f.tip_round, 0.0, 1.0))
    w = w * w * (3 - 2 * w)
    tc = f.thickness_ratio(t)
    xc = (1 - w) * xc_foil + w * xc_ellipse
    half = (1 - w) * foil_half_thickness(xc, tc) + w * tc * half_ellipse
    return xc, half


def fin_layers(f: Fin, loop_xyz: np.ndarray, inner_rc: list) -> tuple[np.ndarray, np.ndarray]:
    """Positions of the extruded loops (layers, P, 3) and of the moved interior (tip) nodes."""
    P = len(loop_xyz)
    d = f.direction / np.linalg.norm(f.direction)
    e1 = f.chord_axis - (f.chord_axis @ d) * d
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(d, e1)
    # loop index -> angle alpha around the section: the long sides (along the body) map to
    # the chord's upper and lower faces, the short sides to its leading edge (alpha = pi, head
    # side) and trailing edge (alpha = 0); the sections' shape: fin_section
    step = 2 * np.pi / P
    alpha = np.pi + (f.b / 2 + np.arange(P)) * step
    upper = np.sign(np.round(np.sin(alpha), 12))
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
        ch = f.chord(t)
        xc, half = fin_section(f, t, alpha)
        return (c + ch * (xc - 0.5)[:, None] * e1
                - side * (upper * half * ch)[:, None] * e2)

    root_ring = ring(0.0) - f.root + centre0
    # every layer's loop, the root's shape fading out as (1 - t)^3
    layers = np.array([ring(k / f.layers) + (1 - k / f.layers) ** 3 * (loop_xyz - root_ring)
                       for k in range(1, f.layers + 1)])
    # interior nodes make the rounded tip cap
    tip = []
    c1, ch, tc = centre(1.0), f.chord(1.0), f.thickness_ratio(1.0)
    for i, j in inner_rc:
        p = -1 + 2 * (i - f.ring0) / f.a
        q = -1 + 2 * (j - f.phi0) / f.b
        # the tip section (an ellipse), shrunk to 0.9 of itself, with a rounded bulge outward
        th = tc * ch
        bulge = 0.5 * min(ch, 3 * th) * np.sqrt(max(0.0, 1 - p * p)) * np.sqrt(max(0.0, 1 - q * q))
        tip.append(c1 + 0.45 * ch * p * e1 - side * 0.45 * th * q * e2 + bulge * d)
    return layers, np.array(tip).reshape(-1, 3)
