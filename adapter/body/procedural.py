"""The procedural North Atlantic right whale.

One closed, quad-dominant surface (the paper's mesh has about two edges per node, as a quad
surface does): a body tube of rings from the rostrum to the fluke notch, with the flippers and
the flukes grown out of it by face extrusion, so that the whole animal is a single watertight
shell (what snappyHexMesh wants). Proportions and their sources are in docs/geometry.md.

Coordinates: x along the body from the rostrum (x = 0) to the fluke notch (x = L), y to the
whale's left, z up. Positions along the body are fractions s = x / L.
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import PchipInterpolator

from adapter.body.fins import (
    FLIPPER_THICKNESS,
    FLIPPER_TIP_ROUNDING,
    FLUKE_THICKNESS,
    TIP_ROUND,
    Fin,
    fin_layers,
    flat,
    patch_loop,
)
from adapter.body.footprint import foil_root
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


def _profile(table: dict) -> PchipInterpolator:
    s = np.array(sorted(table))
    return PchipInterpolator(s, np.array([table[k] for k in s]))


def _ring_positions(n_x: int) -> np.ndarray:
    """Stations s of the body rings (poles excluded), denser at both ends."""
    u = (np.arange(n_x) + 1.0) / (n_x + 1.0)
    return u - 0.6 * np.sin(2 * np.pi * u) / (2 * np.pi)


def _left_half(s: np.ndarray, phi: np.ndarray, length: float) -> tuple[np.ndarray, np.ndarray]:
    """(y, z), each (len(s), len(phi)), of the body's surface at stations ``s`` and angles
    ``phi`` in [0, pi] (0 dorsal, pi/2 the left side): the smooth surface the rings sample."""
    depth = _profile(_DEPTH)(s) * length
    width = _profile(_WIDTH)(s) * length
    top = _profile(_TOP_SHARE)(s)
    axis_z = _profile(_AXIS_Z)(s) * length
    # superellipse, a little boxy at the head, elliptic elsewhere
    expo = 2.0 + 0.4 * np.clip(1 - s / 0.3, 0, 1)
    cz, sy = np.cos(phi)[None, :], np.sin(phi)[None, :]
    e = 2.0 / expo[:, None]
    y = 0.5 * width[:, None] * np.abs(sy) ** e
    zf = np.sign(cz) * np.abs(cz) ** e
    h = np.where(zf >= 0, top[:, None], 1 - top[:, None]) * depth[:, None]
    z = axis_z[:, None] + h * zf
    return y, z


def _section(s: np.ndarray, n_phi: int, length: float) -> np.ndarray:
    """(len(s), n_phi, 3) ring points; phi = 0 is dorsal, phi = 90 deg the left side (+y).

    The right half mirrors the left exactly (y -> -y), so the whale is symmetric to the bit.
    """
    half = n_phi // 2
    phi = 2 * np.pi * np.arange(half + 1) / n_phi  # 0 .. pi, left half and both midlines
    y, z = _left_half(s, phi, length)
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


def procedural_whale(length: float = 15.0, nodes: int = 11272, fluke_span: float = 0.32,
                     with_regions: bool = False, sections: str = "naca",
                     flipper_root: str = "foil", fluke_root: str = "rectangle",
                     flippers: bool = True):
    """Build the procedural right whale: (points, faces, landmarks), and with ``with_regions``
    a fourth item, ``face_regions``: per face group the region index (:data:`REGIONS`) each
    face was built as: the flipper fins' extrusion layers and tip caps FLIPPERS, the fluke
    fins' FLUKES, the rest BODY.

    ``nodes`` is met to within a ring of the body (about 0.6 % at the default 11,272).
    ``sections``: the fins' sections, ``"naca"`` (hydrofoils) or ``"ellipse"`` (the first
    rounds' elliptic sections, blunt at both edges). ``flipper_root``: the flippers' root
    loop on the flank, ``"foil"`` (the root section's outline,
    :func:`adapter.body.footprint.foil_root`) or ``"rectangle"`` (the paper's way: the
    patch's rectangle, a blunt shoulder at its leading side while the layers blend it into
    the sections). ``fluke_root``: the same for the flukes' root loop on the tail stock's
    side, the foil cut at the patch's last ring. ``flippers`` False: the body without them,
    its flank closed where they grow, the landmarks ``flipper_left`` and ``flipper_right`` the
    flank nodes at the middle of their root patches (the appendages' drag as the difference of
    two runs, the towing tank's way: docs/geometry.md).
    """
    if nodes < 400:
        raise GeometryError(f"nodes = {nodes} is too coarse for a whale; use at least 400")
    if sections not in ("naca", "ellipse"):
        raise GeometryError(f"fin sections {sections!r}: use \"naca\" or \"ellipse\"")
    for name, root in (("flipper", flipper_root), ("fluke", fluke_root)):
        if root not in ("foil", "rectangle"):
            raise GeometryError(f"{name} root {root!r}: use \"foil\" or \"rectangle\"")
    naca = sections == "naca"
    n_phi, s, n_x, (fa, fb, fm), (ka, kb, km) = _resolution(nodes)
    rings = _section(s, n_phi, length)
    flipper, fl_loop, fl_inner = _flipper(rings, s, n_phi, (fa, fb, fm), length, naca)
    fluke, ku_loop = _fluke(rings, n_x, n_phi, (ka, kb, km), length, fluke_span, naca)
    body = _Body(rings, n_x, n_phi, length)
    if flippers:
        moved = foil_root(s, n_phi, flipper, _left_half, length) if flipper_root == "foil" else {}
        body.attach("flipper", flipper, fl_loop, fl_inner, moved)
    moved = {}
    if fluke_root == "foil":
        moved = foil_root(s, n_phi, fluke, _left_half, length, cut=True)
    body.attach("fluke", fluke, ku_loop, patch_loop(fluke, n_phi)[1], moved)
    points, faces, face_regions = body.surface()

    def farthest(cands, direction):
        return int(cands[np.argmax(points[cands] @ direction)])

    tips = body.fin_tips
    if not flippers:    # the middle of each root patch, on the flank
        ring, phi = flipper.ring0 + flipper.a // 2, flipper.phi0 + flipper.b // 2
        tips[("flipper", 1)] = [body.node(ring, phi)]
        tips[("flipper", -1)] = [body.node(ring, -phi)]
    lm = {
        "rostrum": body.nose,
        "flipper_left": farthest(tips[("flipper", 1)], flipper.direction),
        "flipper_right": farthest(tips[("flipper", -1)],
                                  flipper.direction * np.array([1, -1, 1])),
        "tail_base": body.node(int(np.argmin(np.abs(s - TAIL_BASE_S))), 0),
        "fluke_tip_left": farthest(tips[("fluke", 1)], np.array([0.0, 1.0, 0.0])),
        "fluke_tip_right": farthest(tips[("fluke", -1)], np.array([0.0, -1.0, 0.0])),
    }
    if with_regions:
        return points, faces, lm, face_regions
    return points, faces, lm


def flipper_fin(length: float = 15.0, nodes: int = 11272, sections: str = "naca") -> Fin:
    """The left flipper of :func:`procedural_whale` as it is built (root, direction, length,
    chord and thickness laws, tip rounding), for a study of the flipper on its own."""
    n_phi, s, _, counts, _ = _resolution(nodes)
    rings = _section(s, n_phi, length)
    return _flipper(rings, s, n_phi, counts, length, sections == "naca")[0]


def _resolution(nodes: int):
    """The body's and the fins' node counts for ``nodes`` in all: (n_phi, the ring stations
    s, n_x, the flipper's (patch a, patch b, layers), the flukes')."""
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
    return n_phi, s, n_x, (fa, fb, fm), (ka, kb, km)


def _flipper(rings, s, n_phi: int, counts, length: float, naca: bool):
    """The left flipper (:class:`Fin`), its patch's loop and interior: a broad paddle behind
    the head, about 0.11 L long, rooted low on the side."""
    fa, fb, fm = counts
    fl_ring = int(np.argmin(np.abs(s - 0.305))) - fa // 2
    fl_phi = int(round(n_phi * 118 / 360)) - fb // 2
    fl_loop, fl_inner = patch_loop(
        Fin(fl_ring, fa, fl_phi, fb, fm, np.zeros(3), np.ones(3), 1, flat, flat), n_phi
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

    flipper = Fin(fl_ring, fa, fl_phi, fb, fm, root=fl_root,
                  direction=np.array([0.45, 0.75, -0.48]), length=0.11 * length,
                  chord=flipper_chord, thickness_ratio=flipper_thickness,
                  tip_round=TIP_ROUND if naca else 1.0)
    return flipper, fl_loop, fl_inner


def _fluke(rings, n_x: int, n_phi: int, counts, length: float, fluke_span: float, naca: bool):
    """The left fluke (:class:`Fin`) and its patch's loop: a swept wing from the side of the
    tail stock, span ``fluke_span`` L tip to tip."""
    ka, kb, km = counts
    ku_ring = n_x - 2 - ka
    ku_phi = n_phi // 4 - kb // 2
    ku_loop, _ = patch_loop(
        Fin(ku_ring, ka, ku_phi, kb, km, np.zeros(3), np.ones(3), 1, flat, flat), n_phi
    )
    ku_root = rings[tuple(np.array(ku_loop).T)].mean(axis=0)
    half_span = 0.5 * fluke_span * length - ku_root[1]

    def fluke_chord(t):
        return 0.085 * length * (1.0 + 0.25 * np.sin(np.pi * min(t, 1.0))) * np.sqrt(
            max(1 - t**2.2, 0.015))

    def fluke_thickness(t):
        if not naca:  # the first rounds' ellipses: 0.016 L thick at the root to 0.004 L
            return 0.016 * length * (1 - 0.75 * t) / fluke_chord(t)
        return FLUKE_THICKNESS[0] + (FLUKE_THICKNESS[1] - FLUKE_THICKNESS[0]) * t

    fluke = Fin(ku_ring, ka, ku_phi, kb, km, root=ku_root, direction=np.array([0.0, 1.0, 0.0]),
                length=half_span, chord=fluke_chord, thickness_ratio=fluke_thickness,
                sweep=lambda t: 0.075 * length * t**1.6, tip_round=TIP_ROUND if naca else 1.0)
    return fluke, ku_loop


class _Body:
    """The surface as it is assembled: the body tube (nose pole, rings, tail pole), then each
    fin's layers on both sides (:meth:`attach`), then the faces (:meth:`surface`)."""

    def __init__(self, rings, n_x: int, n_phi: int, length: float):
        self.rings, self.n_x, self.n_phi = rings, n_x, n_phi
        n_body = n_x * n_phi
        self.nose, self.tail = n_body, n_body + 1
        self.pts = [rings.reshape(-1, 3), np.array([[0.0, 0.0, _profile(_AXIS_Z)(0.0) * length],
                                                    [length, 0.0, 0.0]])]
        self.removed: set = set()
        self.new_quads: list = []
        self.new_regions: list = []
        self.next_index = n_body + 2
        self.fin_tips: dict = {}

    def node(self, i, j):
        return i * self.n_phi + (j % self.n_phi)

    def attach(self, name: str, fin: Fin, loop_rc, inner_rc, moved=None) -> None:
        """Grow ``fin`` out of its patch on the left side and its mirror on the right;
        ``moved``: ``{(ring, phi index): position}``, body nodes of the left side moved first
        (:func:`adapter.body.footprint.foil_root`; the right side's mirrored), its root loop
        among them."""
        moved = moved or {}
        for (i, j), xyz in moved.items():
            self.pts[0][self.node(i, j)] = xyz
            self.pts[0][self.node(i, -j)] = xyz * np.array([1.0, -1.0, 1.0])
        root = self.pts[0][[self.node(i, j) for i, j in loop_rc]].copy()
        for sign in (1, -1):
            self._attach_side(name, fin, loop_rc, inner_rc, sign, root)

    def _attach_side(self, name: str, fin: Fin, loop_rc, inner_rc, sign: int,
                     root: np.ndarray) -> None:
        node, n_phi = self.node, self.n_phi

        def mj(jv):
            return jv if sign == 1 else (n_phi - jv) % n_phi

        def patch_quad(a, b):
            return [node(a, mj(b)), node(a + 1, mj(b)), node(a + 1, mj(b + 1)),
                    node(a, mj(b + 1))]

        patch = [(a, b) for a in range(fin.ring0, fin.ring0 + fin.a)
                 for b in range(fin.phi0, fin.phi0 + fin.b)]
        loop_idx = np.array([node(a, mj(b)) for a, b in loop_rc])
        inner_idx = np.array([node(a, mj(b)) for a, b in inner_rc], dtype=np.int64)
        # the patch's quads make way for the fin (kept as sorted tuples: winding-free)
        for a, b in patch:
            self.removed.add(tuple(sorted(patch_quad(a, b))))
        layers, tip = fin_layers(fin, root, inner_rc)
        if sign == -1:
            layers = layers * np.array([1.0, -1.0, 1.0])
            tip = tip * np.array([1.0, -1.0, 1.0])
        P = len(loop_idx)
        layer_idx = [loop_idx]
        for k in range(fin.layers):
            layer_idx.append(np.arange(self.next_index, self.next_index + P))
            self.next_index += P
            self.pts.append(layers[k])
        region = FLIPPERS if name == "flipper" else FLUKES
        for k in range(fin.layers):
            lo, hi = layer_idx[k], layer_idx[k + 1]
            for m in range(P):
                self.new_quads.append((lo[m], lo[(m + 1) % P], hi[(m + 1) % P], hi[m]))
                self.new_regions.append(region)
        # the tip cap re-uses the patch's quads: boundary nodes become the last layer
        remap = dict(zip(loop_idx.tolist(), layer_idx[-1].tolist(), strict=True))
        for a, b in patch:
            self.new_quads.append(tuple(remap.get(v, v) for v in patch_quad(a, b)))
            self.new_regions.append(region)
        # move the interior patch nodes to the tip
        self.pts[0][inner_idx] = tip
        self.fin_tips[(name, sign)] = np.concatenate([layer_idx[-1], inner_idx])

    def surface(self):
        """(points, faces, face_regions): the poles' triangles, then the body's quads left
        after the fins' patches and the fins' quads."""
        node, n_x, n_phi = self.node, self.n_x, self.n_phi
        i = np.arange(n_x - 1)[:, None]
        j = np.arange(n_phi)[None, :]
        quads = np.stack(
            [node(i, j), node(i + 1, j), node(i + 1, j + 1), node(i, j + 1)], axis=-1
        ).reshape(-1, 4)
        jj = np.arange(n_phi)
        nose, tail = self.nose, self.tail
        tris = np.concatenate([
            np.stack([np.full(n_phi, nose), node(0, jj + 1), node(0, jj)], axis=1),
            np.stack([np.full(n_phi, tail), node(n_x - 1, jj), node(n_x - 1, jj + 1)], axis=1),
        ])
        points = np.concatenate(self.pts)
        keep = np.array([tuple(sorted(q)) not in self.removed for q in quads.tolist()])
        body_quads = quads[keep]
        faces = [tris.astype(np.int64),
                 np.concatenate([body_quads, np.array(self.new_quads, dtype=np.int64)])]
        face_regions = [np.full(len(tris), BODY, dtype=np.int64),
                        np.concatenate([np.full(len(body_quads), BODY, dtype=np.int64),
                                        np.array(self.new_regions, dtype=np.int64)])]
        return points, faces, face_regions
