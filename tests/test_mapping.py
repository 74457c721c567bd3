"""Patch points onto the whale surface: exact nearest triangle, determinism, rejection."""

from types import SimpleNamespace

import numpy as np
import pytest

from adapter.body.geometry import build_surface
from adapter.coupling import mapping, nearest
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


def brute_force(pts, surface, chunk=64):
    """The closest triangle of every point over all triangles, by the numpy formulas
    (closest_point_weights, then the distance), ties to the lowest triangle index."""
    corners = surface.points[surface.triangles]
    a, b, c = corners[:, 0], corners[:, 1], corners[:, 2]
    n_tri = len(corners)
    tri, w, d = [], [], []
    for s in range(0, len(pts), chunk):
        p = np.repeat(pts[s:s + chunk], n_tri, axis=0)
        reps = len(p) // n_tri
        ww = closest_point_weights(p, np.tile(a, (reps, 1)), np.tile(b, (reps, 1)),
                                   np.tile(c, (reps, 1)))
        cc = np.tile(corners, (reps, 1, 1))
        q = ww[:, :1] * cc[:, 0] + ww[:, 1:2] * cc[:, 1] + ww[:, 2:] * cc[:, 2]
        diff = p - q
        dd = np.sqrt(diff[:, 0] * diff[:, 0] + diff[:, 1] * diff[:, 1] + diff[:, 2] * diff[:, 2])
        dd, ww = dd.reshape(reps, n_tri), ww.reshape(reps, n_tri, 3)
        best = np.argmin(dd, axis=1)                 # the first of equal minima: lowest index
        tri.append(best)
        w.append(ww[np.arange(reps), best])
        d.append(dd[np.arange(reps), best])
    return np.concatenate(tri), np.concatenate(w), np.concatenate(d)


def hard_points(surface, seed=8):
    """Points near and far, inside and outside the grid, on vertices and on edges (ties)."""
    rng = np.random.default_rng(seed)
    lo, hi = surface.points.min(axis=0), surface.points.max(axis=0)
    edges = surface.triangles[rng.integers(0, len(surface.triangles), 150)]
    return np.vstack([
        sample_on_surface(surface, 300, seed=seed, offset=0.002 * surface.length),
        sample_on_surface(surface, 150, seed=seed + 1, offset=0.04 * surface.length),
        rng.uniform(lo - 3, hi + 3, size=(150, 3)),
        surface.points[rng.integers(0, len(surface.points), 150)],
        0.5 * (surface.points[edges[:, 0]] + surface.points[edges[:, 1]]),
        np.round(rng.uniform(lo, hi, size=(100, 3)), 1),
        [[1e3, 0.0, 0.0], [-40.0, 30.0, -20.0]],
    ])


def test_search_gives_the_brute_force_bits(surface):
    """The compiled search equals, bit for bit, the numpy formulas over every triangle."""
    pts = hard_points(surface)
    m = PatchMap.from_surface(pts, surface, tolerance=1e6)
    tri, w, d = brute_force(pts, surface)
    assert np.array_equal(m.distance, d)
    assert np.array_equal(m.triangle, tri)
    assert np.array_equal(m.weights, w)


def test_chunks_and_threads_do_not_change_the_bits(surface, monkeypatch):
    pts = hard_points(surface, seed=9)
    whole = PatchMap.from_surface(pts, surface, tolerance=1e6)
    monkeypatch.setattr(nearest, "CHUNK", 7)
    monkeypatch.setattr(nearest, "workers", lambda: 2)
    split = PatchMap.from_surface(pts, surface, tolerance=1e6)
    for name in ("triangle", "weights", "distance"):
        assert np.array_equal(getattr(whole, name), getattr(split, name)), name


@pytest.fixture
def count_searches(monkeypatch):
    calls = []
    search = mapping.nearest_triangles

    def counted(pts, verts, tris):
        calls.append(len(pts))
        return search(pts, verts, tris)

    monkeypatch.setattr(mapping, "nearest_triangles", counted)
    return calls


def test_cache_is_reused_only_for_the_same_patch_and_surface(surface, tmp_path, count_searches):
    pts = sample_on_surface(surface, 400, seed=10, offset=0.002 * surface.length)
    path = tmp_path / "patch-map.npz"
    first = PatchMap.from_surface(pts, surface, cache=path)
    assert first.cache_status == "saved" and path.exists() and count_searches == [400]
    again = PatchMap.from_surface(pts.copy(), surface, cache=path)
    assert again.cache_status == "loaded" and count_searches == [400]
    for name in ("triangle", "weights", "distance"):
        assert np.array_equal(getattr(first, name), getattr(again, name)), name
    assert (first.matrix != again.matrix).nnz == 0
    # the tolerance is checked on a loaded map too
    with pytest.raises(GeometryError, match="from the whale surface"):
        PatchMap.from_surface(pts, surface, tolerance=1e-9, cache=path)
    assert len(count_searches) == 1
    # one point moved by one bit: computed again, and the file now holds the new patch
    moved = pts.copy()
    moved[123, 0] = np.nextafter(moved[123, 0], np.inf)
    assert PatchMap.from_surface(moved, surface, cache=path).cache_status == "saved"
    assert len(count_searches) == 2
    assert PatchMap.from_surface(moved, surface, cache=path).cache_status == "loaded"
    # another surface: computed again
    other = SimpleNamespace(points=surface.points * 1.001, triangles=surface.triangles,
                            length=surface.length)
    assert PatchMap.from_surface(moved, other, cache=path).cache_status == "saved"
    assert len(count_searches) == 3
    # a damaged file is computed again, not trusted
    path.write_bytes(b"not a map")
    assert PatchMap.from_surface(moved, surface, cache=path).cache_status == "saved"
    assert len(count_searches) == 4
    # a folder that cannot be written: the map still works, the status says why
    bad = PatchMap.from_surface(pts, surface, cache=tmp_path / "missing" / "patch-map.npz")
    assert bad.cache_status.startswith("not saved:") and np.array_equal(bad.weights, first.weights)
    assert not list(tmp_path.glob("*.tmp"))


def test_server_restart_with_the_same_patch_loads_the_map(tmp_path, count_searches):
    """A restarted run (a fresh server, the same patch) loads the map from
    adapter/patch-map.npz; a changed patch is mapped again. Same bytes either way."""
    from adapter.motion.animator import Animator

    from .wire_client import Client, finished, points_near, server_starter

    scene = load_scene(preset="smoke")
    animator = Animator(scene)
    start, stop_all = server_starter(scene, animator, first_client_timeout=30)
    case = tmp_path / "case"
    case.mkdir()
    pts = points_near(animator.surface, 500, seed=1)

    def run(points):
        srv = start(case)
        c = Client(case)
        c.hello(points)
        payload = c.request(0.01)[0]
        c.bye()
        assert finished(srv) == 0
        return payload

    try:
        first = run(pts)
        assert count_searches == [500] and (case / "adapter" / "patch-map.npz").exists()
        assert run(pts) == first and count_searches == [500]
        assert "map loaded" in (case / "adapter" / "server.log").read_text()
        changed = pts.copy()
        changed[0] += 1e-4
        run(changed)
        assert count_searches == [500, 500]
    finally:
        stop_all()
