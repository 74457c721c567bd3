"""The procedural North Atlantic right whale.

One closed, quad-dominant surface (the paper's mesh has about two edges per node, as a quad
surface does): a body tube of rings from the rostrum to the fluke notch, with the flippers and
the flukes grown out of it by face extrusion, so that the whole animal is a single watertight
shell (what snappyHexMesh wants). Proportions and their sources are in docs/geometry.md.

Coordinates: x along the body from the rostrum (x = 0) to the fluke notch (x = L), y to the
whale's left, z up. Positions along the body are fractions s = x / L.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy.interpolate import PchipInterpolator

from adapter.body.landmarks import TAIL_BASE_S
from adapter.body.regions import BODY, FLIPPERS, FLUKES
from adapter.errors import GeometryError

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


def _profile(table: dict) -> PchipInterpolator:
    s = np.array(sorted(table))
    return PchipInterpolator(s, np.array([table[k] for k in s]))


def foil_half_thickness(xc: np.ndarray, thickness_ratio: float) -> np.ndarray:
    """Half-thickness over chord of the symmetric NACA four-digit section at chord fraction
    ``xc`` (0 at the leading edge), with the closed trailing edge (last coefficient -0.1036):
    a round leading edge of radius 1.1019 (t/c)^2 c, the thickest point at 0.30 c and a sharp
    trailing edge (Abbott and von Doenhoff 1959, eq. 6.2)."""
    x = np.clip(xc, 0.0, 1.0)
    return 5.0 * thickness_ratio * (0.2969 * np.sqrt(x) - 0.1260 * x - 0.3516 * x**2
                                    + 0.2843 * x**3 - 0.1036 * x**4)


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
    chord: Callable[[float], float]  # chord(t) in m, t in [0, 1] from root to tip
    thickness_ratio: Callable[[float], float]  # the section's thickness over chord at t
    tip_round: float = TIP_ROUND  # the outer share of the span with elliptic sections (1: all)
    sweep: Callable[[float], float] | None = None  # extra displacement along x (m) at t
    chord_axis: np.ndarray = field(default_factory=lambda: np.array([1.0, 0.0, 0.0]))


def _flat(t: float) -> float:
    """A placeholder chord or thickness law, for a fin whose patch alone is wanted."""
    return 0.0


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
    # loop index -> angle alpha around the section: the long sides (along the body) map to
    # the chord's upper and lower faces, the short sides to its leading edge (alpha = pi, head
    # side) and trailing edge (alpha = 0). The chord fraction 1 - cos(pi tau / 2), tau the
    # share of the way from the leading to the trailing edge, puts the nodes closest together
    # at the round leading edge and evenly toward the sharp trailing edge, whose faces would
    # otherwise be slivers that the stroke's small differences of motion fold
    step = 2 * np.pi / P
    alpha = np.pi + (f.b / 2 + np.arange(P)) * step
    tau = 1 - np.abs(np.angle(np.exp(1j * alpha))) / np.pi
    xc_foil = 1 - np.cos(0.5 * np.pi * tau)
    upper = np.sign(np.round(np.sin(alpha), 12))
    # toward the tip the sections turn into ellipses of the same t/c (over the outer
    # TIP_ROUND of the span): the tip cap joins the last section with faces the stroke does
    # not fold, which a sharp trailing edge and a clustered leading edge would make slivers
    xc_ellipse = 0.5 * (1 + np.cos(alpha))
    half_ellipse = 0.5 * np.abs(np.sin(alpha))

    def section(t):
        """(chord fraction, half-thickness over chord) of the loop's nodes at t."""
        w = 1.0 if f.tip_round >= 1 else float(
            np.clip((t - (1 - f.tip_round)) / f.tip_round, 0.0, 1.0))
        w = w * w * (3 - 2 * w)
        tc = f.thickness_ratio(t)
        xc = (1 - w) * xc_foil + w * xc_ellipse
        half = (1 - w) * foil_half_thickness(xc, tc) + w * tc * half_ellipse
        return xc, half
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
        xc, half = section(t)
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


def procedural_whale(length: float = 15.0, nodes: int = 11272, fluke_span: float = 0.32,
                     with_regions: bool = False, sections: str = "naca"):
    """Build the procedural right whale: (points, faces, landmarks), and with ``with_regions``
    a fourth item, ``face_regions``: per face group the region index (:data:`REGIONS`) each
    face was built as: the flipper fins' extrusion layers and tip caps FLIPPERS, the fluke
    fins' FLUKES, the rest BODY.

    ``nodes`` is met to within a ring of the body (about 0.6 % at the default 11,272).
    ``sections``: the fins' sections, ``"naca"`` (hydrofoils) or ``"ellipse"`` (the first
    rounds' elliptic sections, blunt at both edges).
    """
    if nodes < 400:
        raise GeometryError(f"nodes = {nodes} is too coarse for a whale; use at least 400")
    if sections not in ("naca", "ellipse"):
        raise GeometryError(f"fin sections {sections!r}: use \"naca\" or \"ellipse\"")
    naca = sections == "naca"
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
        _Fin(fl_ring, fa, fl_phi, fb, fm, np.zeros(3), np.ones(3), 1, _flat, _flat), n_phi
    )
    fl_root = rings[tuple(np.array(fl_loop).T)].mean(axis=0)
    root_chord = float(np.ptp(rings[tuple(np.array(fl_loop).T)][:, 0]))
    def flipper_chord(t):
        return root_chord * (1 + 0.35 * np.sin(np.pi * min(t, 1) ** 0.8)) * np.sqrt(
            max(1 - t**6, 0.04))

    def flipper_thickness(t):
        if not naca:  # the first rounds' ellipses: 0.012 L thick at the root to 0.0054 L
            return 0.012 * length * (1 - 0.55 * t) / flipper_chord(t)
        return (FLIPPER_THICKNESS[0] + (FLIPPER_THICKNESS[1] - FLIPPER_THICKNESS[0]) * t
                + FLIPPER_TIP_ROUNDING * t**8)

    flipper = _Fin(
        fl_ring, fa, fl_phi, fb, fm,
        root=fl_root,
        direction=np.array([0.45, 0.75, -0.48]),
        length=0.11 * length,
        chord=flipper_chord,
        thickness_ratio=flipper_thickness,
        tip_round=TIP_ROUND if naca else 1.0,
    )
    # Flukes: swept wings from the sides of the tail stock, span fluke_span * L tip to tip
    ku_ring = n_x - 2 - ka
    ku_phi = n_phi // 4 - kb // 2
    ku_loop, _ = _patch_loop(
        _Fin(ku_ring, ka, ku_phi, kb, km, np.zeros(3), np.ones(3), 1, _flat, _flat), n_phi
    )
    ku_xyz = rings[tuple(np.array(ku_loop).T)]
    ku_root = ku_xyz.mean(axis=0)
    half_span = 0.5 * fluke_span * length - ku_root[1]
    def fluke_chord(t):
        return 0.085 * length * (1.0 + 0.25 * np.sin(np.pi * min(t, 1.0))) * np.sqrt(
            max(1 - t**2.2, 0.015))

    def fluke_thickness(t):
        if not naca:  # the first rounds' ellipses: 0.016 L thick at the root to 0.004 L
            return 0.016 * length * (1 - 0.75 * t) / fluke_chord(t)
        return FLUKE_THICKNESS[0] + (FLUKE_THICKNESS[1] - FLUKE_THICKNESS[0]) * t

    fluke = _Fin(
        ku_ring, ka, ku_phi, kb, km,
        root=ku_root,
        direction=np.array([0.0, 1.0, 0.0]),
        length=half_span,
        chord=fluke_chord,
        thickness_ratio=fluke_thickness,
        sweep=lambda t: 0.075 * length * t**1.6,
        tip_round=TIP_ROUND if naca else 1.0,
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
