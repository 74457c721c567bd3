"""Patch points onto the whale surface: exact nearest triangle, determinism, rejection."""

import numpy as np
import pytest

from adapter.body.geometry import build_surface
from adapter.coupling.mapping import PatchMap, closest_point_weights
from adapter.errors import GeometryError
from adapter.scene import load_scene


@pytest.fixture(scope="module")
def surface():
    return build_surface(load_scene(preset="smoke"))


def sample_on_surface(surface, n, seed=0, offset=0.0):
    """n points on random triangles, moved ``offset`` (m) along a random direction."""
    rng = np.random.default_rng(seed)
    tri = rng.integers(0, len(surface.triangles), n)
    w = rng.dirichlet([1.0, 1.0, 1.0], n)
    corners = surface.points[surface.triangles[tri]]
    pts = np.einsum("pk,pkd->pd", w, corners)
    if offset:
        d = rng.normal(size=pts.shape)
        pts += offset * d / np.linalg.norm(d, axis=1, keepdims=True)
    return pts


def test_closest_point_regions():
    a, b, c = np.array([0.0, 0, 0]), np.array([1.0, 0, 0]), np.array([0.0, 1, 0])
    cases = {
        (0.2, 0.2, 0.5): (0.6, 0.2, 0.2),      # inside, above the plane
        (-1.0, -1.0, 0): (1, 0, 0),            # vertex a
        (2.0, -0.5, 0): (0, 1, 0),             # vertex b
        (0.5, -1.0, 0): (0.5, 0.5, 0),         # edge ab
        (1.0, 1.0, 0): (0, 0.5, 0.5),          # edge bc
    }
    for p, expected in cases.items():
        w = closest_point_weights(np.array([p]), a[None], b[None], c[None])[0]
        assert np.allclose(w, expected), (p, w)
    # a degenerate triangle still gives a point of it
    w = closest_point_weights(np.array([[0.5, 1, 0]]), a[None], b[None], b[None])[0]
    assert np.allclose(w, (0.5, 0.5, 0)) or np.allclose(w.sum(), 1)


def test_points_on_the_surface_map_onto_themselves(surface):
    pts = sample_on_surface(surface, 500)
    m = PatchMap.from_surface(pts, surface)
    assert m.max_distance < 1e-9
    assert np.allclose(m.apply(surface.points), pts, atol=1e-10)
    assert m.matrix.shape == (500, len(surface.points))
    assert np.allclose(np.asarray(m.matrix.sum(axis=1)).ravel(), 1.0)


def test_nearest_triangle_is_exact(surface):
    pts = sample_on_surface(surface, 60, seed=1, offset=0.02 * surface.length)
    m = PatchMap.from_surface(pts, surface)
    corners = surface.points[surface.triangles]
    for p, dist in zip(pts, m.distance, strict=True):
        n = len(corners)
        w = closest_point_weights(np.repeat(p[None], n, 0), corners[:, 0], corners[:, 1],
                                  corners[:, 2])
        brute = np.linalg.norm(p - np.einsum("tk,tkd->td", w, corners), axis=1).min()
        assert dist == pytest.approx(brute, abs=1e-12)


def test_identical_coordinates_map_identically(surface):
    pts = sample_on_surface(surface, 400, seed=2, offset=0.005 * surface.length)
    shared = pts[100:200]
    other = np.vstack([sample_on_surface(surface, 37, seed=3), shared[::-1]])
    u = np.random.default_rng(4).normal(size=(len(surface.points), 3))
    a = PatchMap.from_surface(pts, surface).apply(u)[100:200]
    b = PatchMap.from_surface(other, surface).apply(u)[37:][::-1]
    assert np.array_equal(a, b)


def test_far_patch_is_rejected_naming_the_distance(surface):
    pts = sample_on_surface(surface, 50, seed=5)
    pts[7] += [0.0, 0.0, 0.3 * surface.length]
    with pytest.raises(GeometryError, match=r"patch point 7 .* lies \d.* m from the whale"):
        PatchMap.from_surface(pts, surface)
    m = PatchMap.from_surface(pts, surface, tolerance=0.5)        # configurable
    assert m.max_distance > 0.05 * surface.length


def test_bad_and_empty_patches(surface):
    with pytest.raises(GeometryError, match="not finite"):
        PatchMap.from_surface(np.array([[0.0, np.nan, 0.0]]), surface)
    with pytest.raises(GeometryError, match=r"shape \(4,\), expected \(P, 3\)"):
        PatchMap.from_surface(np.zeros(4), surface)
    empty = PatchMap.from_surface(np.zeros((0, 3)), surface)
    assert empty.max_distance == 0 and empty.apply(surface.points).shape == (0, 3)
