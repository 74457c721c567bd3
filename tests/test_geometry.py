"""The procedural whale, landmarks and regions, mesh files, and bad geometry."""

import numpy as np
import pytest

from adapter.body.checks import validate_surface
from adapter.body.geometry import build_surface
from adapter.body.landmarks import LANDMARKS, TAIL_BASE_S
from adapter.body.meshfile import read_surface
from adapter.body.procedural import procedural_whale
from adapter.errors import GeometryError
from adapter.scene import load_scene

PAPER_NODES, PAPER_EDGES = 11272, 22510


@pytest.fixture(scope="module")
def default_surface():
    return build_surface(load_scene())


@pytest.mark.slow
def test_default_resolution_matches_the_paper_within_two_percent(default_surface):
    assert abs(default_surface.n_nodes / PAPER_NODES - 1) < 0.02
    assert abs(len(default_surface.edges) / PAPER_EDGES - 1) < 0.02


@pytest.mark.slow
def test_whale_is_mirror_symmetric_to_the_bit(default_surface):
    p = default_surface.points
    mirrored = p * np.array([1.0, -1.0, 1.0])
    # every mirrored point is a point of the surface, exactly
    key = {tuple(row) for row in p.tolist()}
    assert all(tuple(row) in key for row in mirrored.tolist())


@pytest.mark.slow
def test_proportions(default_surface):
    p, L = default_surface.points, default_surface.length
    assert np.ptp(p[:, 0]) == pytest.approx(L, rel=0.06)  # fluke tips slightly past the notch
    fluke = default_surface.s > TAIL_BASE_S
    span = np.ptp(p[fluke, 1])
    assert 0.30 * L < span < 0.35 * L  # fluke span 0.32 L (the tip cap adds a little)
    # deepest section near 0.45 L: the depth figures of Daoust et al. 2018
    s = default_surface.s
    mid = np.abs(s - 0.45) < 0.01
    depth = np.ptp(p[mid, 2]) / L
    assert depth == pytest.approx(0.212, rel=0.05)


@pytest.mark.slow
def test_landmarks_and_regions(default_surface):
    surf = default_surface
    p, s, lm = surf.points, surf.s, surf.landmarks
    assert set(lm) == set(LANDMARKS)
    assert s[lm["rostrum"]] == pytest.approx(0.0, abs=1e-12)
    assert s[lm["tail_base"]] == pytest.approx(TAIL_BASE_S, abs=0.01)
    for side, sign in (("left", 1), ("right", -1)):
        fl, ft = p[lm[f"flipper_{side}"]], p[lm[f"fluke_tip_{side}"]]
        assert np.sign(fl[1]) == sign and np.sign(ft[1]) == sign
        assert 0.3 < s[lm[f"flipper_{side}"]] < 0.45  # behind the head
        assert fl[2] < 0  # below the axis
        assert s[lm[f"fluke_tip_{side}"]] > TAIL_BASE_S
        assert abs(ft[1]) == pytest.approx(np.abs(p[s > TAIL_BASE_S, 1]).max())  # widest fluke
    np.testing.assert_array_equal(p[lm["flipper_left"]] * [1, -1, 1], p[lm["flipper_right"]])


def test_surface_is_closed_and_oriented_outward(smoke_surface):
    assert smoke_surface.volume() > 0
    # volume of a fat 15 m whale: tens of cubic metres
    assert 30 < smoke_surface.volume() < 120


@pytest.mark.parametrize("suffix", [".stl", ".obj", ".vtk", ".ply"])
def test_write_read_round_trip(smoke_surface, tmp_path, suffix):
    path = tmp_path / f"whale{suffix}"
    smoke_surface.write(path)
    points, faces = read_surface(path)
    validate_surface(points, faces, 15.0)
    # the same point cloud (STL merges its repeated corners back)
    a = np.unique(np.round(smoke_surface.points, 4), axis=0)
    b = np.unique(np.round(points, 4), axis=0)
    assert a.shape == b.shape
    np.testing.assert_allclose(a, b, atol=1e-4)


def test_mesh_file_with_landmarks_animates_like_the_procedural_one(smoke_surface, tmp_path):
    path = tmp_path / "animal.obj"
    smoke_surface.write(path)
    marks = {k: smoke_surface.points[v].tolist() for k, v in smoke_surface.landmarks.items()}
    scene = load_scene(preset="smoke").replace(
        geometry={"source": str(path), "landmarks": marks})
    surf = build_surface(scene)
    assert surf.n_nodes == smoke_surface.n_nodes
    for k in LANDMARKS:
        np.testing.assert_allclose(surf.points[surf.landmarks[k]],
                                   smoke_surface.points[smoke_surface.landmarks[k]], atol=1e-5)


def _cube():
    p = np.array([[x, y, z] for x in (0.0, 1) for y in (0.0, 1) for z in (0.0, 1)])
    q = np.array([[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4],
                  [1, 5, 7, 3]])
    return p, [q]


def test_cube_is_valid():
    p, f = _cube()
    out = validate_surface(p, f, 1.0)
    assert len(out[0]) == 6


@pytest.mark.parametrize(
    "damage, message",
    [
        ("open", "open"),
        ("nan", "NaN"),
        ("duplicate", "duplicate points"),
        ("degenerate", "degenerate"),
        ("nonmanifold", "non-manifold"),
        ("two_pieces", "separate pieces"),
        ("touching_at_a_point", "non-manifold at 1 point"),
    ],
)
def test_bad_geometry_is_named(damage, message):
    p, f = _cube()
    q = f[0]
    if damage == "open":
        f = [q[:-1]]
    elif damage == "nan":
        p = p.copy()
        p[3, 1] = np.nan
    elif damage == "duplicate":
        p = np.vstack([p, p[0]])
        f = [np.vstack([q[:-1], [[8, 5, 7, 3]]])]
    elif damage == "degenerate":
        f = [np.vstack([q, [[0, 1, 1, 3]], [[0, 1, 1, 3]]])]
    elif damage == "nonmanifold":
        # a fin: one extra quad hanging on the edge (0, 1), closed by its own twin
        p = np.vstack([p, [[0, -1, 0], [1, -1, 0]]])
        f = [np.vstack([q, [[0, 1, 9, 8]], [[8, 9, 1, 0]]])]
    elif damage == "two_pieces":
        p = np.vstack([p, p + 5])
        f = [np.vstack([q, q + 8])]
    elif damage == "touching_at_a_point":
        # a second cube sharing only the corner (1, 1, 1), point 7, with the first
        p2 = p + 1.0
        p = np.vstack([p, p2[1:]])  # p2[0] is (1, 1, 1) = p[7]
        remap = np.r_[7, np.arange(8, 15)]
        f = [np.vstack([q, remap[q]])]
    with pytest.raises(GeometryError, match=message):
        validate_surface(p, f, 1.0)


def test_landmark_off_the_body_is_named(smoke_surface, tmp_path):
    path = tmp_path / "animal.stl"
    smoke_surface.write(path)
    marks = {k: smoke_surface.points[v].tolist() for k, v in smoke_surface.landmarks.items()}
    marks["tail_base"] = [13.0, 0.0, 5.0]
    scene = load_scene(preset="smoke").replace(
        geometry={"source": str(path), "landmarks": marks})
    with pytest.raises(GeometryError, match="landmark tail_base .* not on the body"):
        build_surface(scene)


def test_too_coarse_is_refused():
    with pytest.raises(GeometryError, match="too coarse"):
        procedural_whale(15.0, 100)


def test_whale_without_flippers_is_the_same_tube_closed_on_the_flank():
    """geometry.flippers = false (the appendage drag as a difference of two runs): the flank
    is closed by the body's own quads where the flippers grew, every other node is the
    flippered whale's, and the flipper landmarks sit on the flank at the root's station
    (docs/geometry.md: s = 0.31, low on the side)."""
    p0, f0, lm0, r0 = procedural_whale(15.0, 1200, with_regions=True, flipper_root="rectangle")
    p1, f1, lm1, r1 = procedural_whale(15.0, 1200, with_regions=True, flipper_root="rectangle",
                                       flippers=False)
    validate_surface(p1, f1, 15.0)
    assert not any((r == 1).any() for r in r1)     # no face is a flipper's
    assert any((r == 1).any() for r in r0)
    # the flipperless whale's nodes are the flippered one's, but the two patches' interiors
    # (moved to the tips there) and the fins' layers (none here)
    same = np.all(np.isclose(p1[:, None, :], p0[None, :, :], atol=1e-12), axis=2).any(axis=1)
    moved = np.flatnonzero(~same)
    assert 0 < len(moved) <= 2 * 8    # at most the interiors of two 8 x 2 patches
    fl = p1[lm1["flipper_left"]]
    assert fl[0] / 15.0 == pytest.approx(0.305, abs=0.03) and fl[1] > 0 and fl[2] < 0
    np.testing.assert_array_equal(fl * [1, -1, 1], p1[lm1["flipper_right"]])
    assert lm1["rostrum"] == lm0["rostrum"] and lm1["tail_base"] == lm0["tail_base"]
