"""The flukes' root loop on the tail stock (adapter/body/footprint.py, ``foil_root`` with
``cut``): with ``geometry.fluke_root = "foil"`` its long sides lie at the NACA 0020 outline's
half-thickness (Abbott and von Doenhoff 1959, eq. 6.2, written out here) measured around the
stock's rings, which are ellipses behind mid-body (docs/geometry.md); the surface stays
closed, mirror symmetric and sound next to the root; and ``"rectangle"`` is the whale as it
was before the key, bit for bit (docs/geometry.md, "The flukes' root"). Everything is found
from the surface itself: the root loop is the nodes the fluke fin's faces share with the
body's, the rings are the body nodes' stations along x."""

import hashlib

import numpy as np
import pytest

from adapter.body.geometry import build_surface
from adapter.body.procedural import procedural_whale
from adapter.body.regions import BODY, FLUKES
from adapter.body.surface import triangulate
from adapter.errors import GeometryError, SceneError

L = 15.0


def _whale_pair(nodes):
    return {root: procedural_whale(L, nodes, with_regions=True, fluke_root=root)
            for root in ("rectangle", "foil")}


@pytest.fixture(scope="module")
def whales():
    """The default-resolution whale (foil flippers, the default scene) with each fluke root."""
    return _whale_pair(11272)


def _root_loop(whale):
    """The left fluke's root loop: the nodes its faces share with the body's faces (y > 0)."""
    points, faces, _, regions = whale
    quads, reg = faces[1], regions[1]
    shared = np.intersect1d(np.unique(quads[reg == FLUKES]), np.unique(quads[reg == BODY]))
    return shared[points[shared, 1] > 0]


def _rings(whale):
    """The stations x (m) of the body's rings: the x of the body's nodes (the rectangle's
    whale: none of them moved off its ring), poles left out."""
    points, faces, _, regions = whale
    body = np.unique(faces[1][regions[1] == BODY])
    x = np.unique(points[body, 0])
    return x[(x > 0) & (x < L)]


@pytest.mark.parametrize("nodes, points_digest, faces_digest", [
    (11272, "3aca34d6b4a40842", "ddf4311f2659c2f3"),
    (1200, "93e628098443dc73", "869b53069ae29a2a"),
])
def test_the_rectangular_fluke_root_is_the_whale_as_before(smoke_scene, nodes, points_digest,
                                                           faces_digest):
    """The digests of the default scene's whale (foil flipper root) as commit 1d97f23 built it,
    before the flukes had a root setting: node positions rounded to a nanometre, and faces."""
    scene = smoke_scene.replace(geometry={"nodes": nodes, "flipper_root": "foil",
                                          "fluke_root": "rectangle"})
    whale = build_surface(scene)
    p = np.round(whale.points, 9) + 0.0  # + 0.0: no negative zeros
    faces = np.concatenate([f.ravel() for f in whale.faces]).astype(np.int64)
    assert hashlib.sha256(p.tobytes()).hexdigest()[:16] == points_digest
    assert hashlib.sha256(faces.tobytes()).hexdigest()[:16] == faces_digest


def _arc_from_side(points, ring_nodes, node):
    """Arc length (m) from the ring's side (its widest point, z = 0) to ``node``, along the
    ring's ellipse: semi-axis b the dorsal node's height, a from the node of the ring's
    upper left quarter nearest the midline (not moved by the root), phi by the ellipse's
    parametric angle; signed, positive above."""
    q = points[ring_nodes]
    b = q[np.isclose(q[:, 1], 0) & (q[:, 2] > 0), 2].max()
    near = q[(q[:, 1] > 1e-9) & (q[:, 2] > 0)]
    y1, z1 = near[np.argmin(near[:, 1])][1:]
    a = y1 / np.sqrt(1 - (z1 / b) ** 2)
    y, z = points[node, 1:]
    phi = np.arctan2(y / a, z / b)
    t = np.linspace(phi, 0.5 * np.pi, 4001)
    return np.trapezoid(np.hypot(a * np.cos(t), b * np.sin(t)), t)


def test_the_fluke_root_is_the_root_sections_footprint(whales):
    """The long sides' nodes of the left fluke's root loop, at rings near the leading edge, at
    the thickest point (0.30 c), behind it and at the cut trailing edge: each lies, around
    its ring from the stock's side, at the NACA 0020 half-thickness of its chord fraction,
    within 2 mm (0.2 % of the 1.13 m chord). The chord runs from the nose (the loop's foremost
    node, on the surface) to half a ring spacing behind the patch's last ring, where the foil
    is cut: its trailing side keeps the ring. The nose lies half a ring spacing ahead of the
    patch's first ring. At its thickest the footprint is 2.5 times as wide as the patch."""
    points, rect = whales["foil"][0], whales["rectangle"][0]
    rings = _rings(whales["rectangle"])
    loop = _root_loop(whales["foil"])
    on_rings = np.isin(rect[loop, 0], rings)
    k0, k1 = np.searchsorted(rings, [rect[loop, 0].min(), rect[loop, 0].max()])
    x_nose = points[loop, 0].min()
    assert x_nose == pytest.approx(rings[k0] - 0.5 * (rings[k0] - rings[k0 - 1]), abs=1e-9)
    chord = rings[k1] + 0.5 * (rings[k1 + 1] - rings[k1]) - x_nose
    assert chord == pytest.approx(1.13, abs=0.01)
    xc = (rings[k0:k1 + 1] - x_nose) / chord
    thickest = k0 + int(np.argmin(np.abs(xc - 0.3)))
    body_x = rect[:, 0]
    widths = {}
    for k in (k0, k0 + 1, thickest, (thickest + k1) // 2, k1):
        x = np.clip((rings[k] - x_nose) / chord, 0, 1)
        naca = 5 * 0.20 * (0.2969 * np.sqrt(x) - 0.1260 * x - 0.3516 * x**2 + 0.2843 * x**3
                           - 0.1036 * x**4) * chord
        at_ring = loop[on_rings & (rect[loop, 0] == rings[k])]
        ends = at_ring[[np.argmax(points[at_ring, 2]), np.argmin(points[at_ring, 2])]]
        ring_nodes = np.flatnonzero(body_x == rings[k])
        for node, sign in zip(ends, (1, -1), strict=True):
            arc = _arc_from_side(points, ring_nodes, node)
            assert sign * arc == pytest.approx(naca, abs=0.002), (k, node, arc, naca)
        widths[k] = (np.ptp(points[ends, 2]), np.ptp(rect[ends, 2]))
    assert widths[thickest][0] > 2.5 * widths[thickest][1], widths[thickest]


def _stock_faces(whale, rect):
    """The left side's body quads of the tail stock from two rings ahead of the fluke root to
    the tail, and the ring (index into the rectangle's ring stations) each ends on."""
    points, faces, _, regions = whale
    rings = _rings(rect)
    start = rings[np.searchsorted(rings, rect[0][_root_loop(rect), 0].min()) - 2]
    quads = faces[1][regions[1] == BODY]
    x, y = rect[0][quads, 0], rect[0][quads, 1]
    keep = (x.min(axis=1) >= start) & (y.min(axis=1) >= 0)
    return points, quads[keep]


def _corners(points, polys):
    """(F, k) the corners (deg) of faces given by (F, k) node indices."""
    k = polys.shape[1]
    out = []
    for m in range(k):
        a = points[polys[:, (m - 1) % k]] - points[polys[:, m]]
        b = points[polys[:, (m + 1) % k]] - points[polys[:, m]]
        cos = (a * b).sum(1) / np.linalg.norm(a, axis=1) / np.linalg.norm(b, axis=1)
        out.append(np.degrees(np.arccos(np.clip(cos, -1, 1))))
    return np.stack(out, axis=1)


@pytest.mark.parametrize("nodes", [1200, 11272, 45000])
def test_the_fluke_root_keeps_the_stocks_faces_sound(whales, nodes):
    """The footprint, three times as wide as the patch at its thickest, shears the stock's
    quads beside and in front of it: none with a corner under 30 deg (measured 34 at the
    nose's neighbours; the rectangle: 81), and where the rows beside the root make room (to
    0.6 of their width) their triangles, slender on the stock already (10 deg corners at
    either root), keep on every ring at least 0.6 of the rectangle's smallest corner
    (measured 0.64). Also on the smoke and on a finer whale."""
    pair = whales if nodes == 11272 else _whale_pair(nodes)
    rect = pair["rectangle"]
    smallest = {}
    for root, whale in pair.items():
        points, quads = _stock_faces(whale, rect)
        tri = triangulate(points, [quads])
        ring = rect[0][tri, 0].max(axis=1)   # the ring each triangle ends on, at rest
        tri_min = _corners(points, tri).min(axis=1)
        smallest[root] = (_corners(points, quads).min(),
                          {r: tri_min[ring == r].min() for r in np.unique(ring)})
    assert smallest["rectangle"][0] > 80
    assert smallest["foil"][0] > 30, smallest["foil"][0]
    for r, rect_min in smallest["rectangle"][1].items():
        assert smallest["foil"][1][r] > 0.6 * rect_min, (r, smallest["foil"][1][r], rect_min)


def test_the_foil_fluke_root_whale_is_closed_and_mirror_symmetric(whales, smoke_scene):
    """Every edge between exactly two faces, V - E + F = 2 (a sphere), the right side the
    left's mirror image to the bit, the node and face counts unchanged; and the scene's key
    builds it through the checks of build_surface (closed, manifold, outward), its volume a
    little more than the rectangle's (the footprint fills out the fin's root)."""
    points, faces, _, _ = whales["foil"]
    polys = [f for group in faces for f in group.tolist()]
    edges: dict = {}
    for f in polys:
        for m in range(len(f)):
            e = tuple(sorted((f[m], f[(m + 1) % len(f)])))
            edges[e] = edges.get(e, 0) + 1
    assert set(edges.values()) == {2}
    assert len(points) - len(edges) + len(polys) == 2
    left = points[points[:, 1] > 0]
    right = points[points[:, 1] < 0] * np.array([1.0, -1.0, 1.0])
    assert np.array_equal(np.unique(left, axis=0), np.unique(right, axis=0))
    rect = whales["rectangle"]
    assert len(points) == len(rect[0]) and [len(f) for f in faces] == [len(f) for f in rect[1]]
    whale = build_surface(smoke_scene.replace(geometry={"nodes": 11272, "fluke_root": "foil"}))
    volume_rect = build_surface(smoke_scene.replace(geometry={"nodes": 11272})).volume()
    assert volume_rect < whale.volume() < volume_rect + 0.3


def test_an_unknown_fluke_root_is_refused(smoke_scene):
    with pytest.raises(GeometryError, match="fluke root"):
        procedural_whale(L, 1200, fluke_root="wedge")
    with pytest.raises(SceneError, match="fluke_root"):
        smoke_scene.replace(geometry={"fluke_root": "wedge"})
