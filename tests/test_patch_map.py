"""The patch map's parts on surfaces small enough to check by hand (adapter/coupling/mapping.py):
the closest point of a triangle against an independent construction (the projection onto the
plane, else the closest of the three edges' clamped projections), the weights on a unit square
written out by hand, the rejections and their messages, a damaged cache file. Fast (well under a
second): the mutation tests of mapping.py run it once per mutant (docs/mutation.md)."""

from pathlib import Path

import numpy as np
import pytest

from adapter.coupling.mapping import PatchMap, closest_point_weights
from adapter.errors import GeometryError


def _closest_on_segment(p, a, b):
    ab = b - a
    den = ab @ ab
    t = 0.0 if den == 0 else min(max((p - a) @ ab / den, 0.0), 1.0)
    return a + t * ab


def _closest_on_triangle(p, a, b, c):
    """The textbook construction: the foot of the perpendicular on the plane if it falls
    inside the triangle, else the closest of the three edges' closest points."""
    n = np.cross(b - a, c - a)
    if n @ n > 0:
        q = p - ((p - a) @ n) / (n @ n) * n
        # barycentric coordinates of q by areas
        area = n @ n
        wa = np.cross(c - b, q - b) @ n / area
        wb = np.cross(a - c, q - c) @ n / area
        wc = 1 - wa - wb
        if min(wa, wb, wc) >= 0:
            return q
    cands = [_closest_on_segment(p, a, b), _closest_on_segment(p, b, c),
             _closest_on_segment(p, c, a)]
    return min(cands, key=lambda x: np.linalg.norm(p - x))


def test_closest_point_of_random_triangles_matches_the_textbook_construction():
    """400 random point-triangle pairs in 3-D, every Voronoi region of the triangle among
    them: the weights sum to one, are non-negative, and give the closest point. 60 degenerate
    triangles (two corners equal, or three collinear) get weights of a point of the triangle
    (not always the closest: Ericson's region test takes the triangle to have an area; the
    surface checks refuse zero-area faces)."""
    rng = np.random.default_rng(11)
    n = 460
    a, b, c = (rng.normal(size=(n, 3)) for _ in range(3))
    b[400:420] = a[400:420]                       # a zero-length edge ab
    c[420:440] = b[420:440]                       # a zero-length edge bc
    c[440:460] = a[440:460] + 0.3 * (b[440:460] - a[440:460])  # collinear
    p = 2.0 * rng.normal(size=(n, 3))
    w = closest_point_weights(p, a, b, c)
    np.testing.assert_allclose(w.sum(axis=1), 1.0, atol=1e-12)
    assert w.min() >= -1e-12
    got = w[:, :1] * a + w[:, 1:2] * b + w[:, 2:] * c
    for k in range(400):
        want = _closest_on_triangle(p[k], a[k], b[k], c[k])
        assert np.linalg.norm(p[k] - got[k]) == pytest.approx(np.linalg.norm(p[k] - want),
                                                              abs=1e-12), k
    # every region was visited: inside, on each edge, at each corner
    w = w[:400]
    inside = (w > 0).all(axis=1)
    assert inside.sum() >= 10
    for col in range(3):
        assert (w[:, col] == 1).sum() >= 10                                   # a corner
        assert ((w[:, col] == 0) & ((w > 0).sum(axis=1) == 2)).sum() >= 10    # an edge


def test_the_corner_and_edge_regions_by_hand():
    """The right triangle a = 0, b = x, c = y: a point beyond c, beyond the edge ac and
    beyond the edge bc, with their closest points written out."""
    a, b, c = np.array([0.0, 0, 0]), np.array([1.0, 0, 0]), np.array([0.0, 1, 0])
    cases = {
        (-0.5, 2.0, 0.3): (0, 0, 1),          # vertex c
        (-1.0, 0.25, -0.2): (0.75, 0, 0.25),  # edge ac
        (0.9, 0.6, 1.0): (0, 0.65, 0.35),     # edge bc: the foot (0.65, 0.35)
        (0.1, 0.2, -3.0): (0.7, 0.1, 0.2),    # inside, below the plane
        (3.0, 0.0, 0.0): (0, 1, 0),           # vertex b, on the line of ab
    }
    for p, expected in cases.items():
        w = closest_point_weights(np.array([p]), a[None], b[None], c[None])[0]
        np.testing.assert_allclose(w, expected, atol=1e-15, err_msg=str(p))


# -- a unit square of two triangles, one node unused -----------------------------------------------

SQUARE = np.array([[0.0, 0, 0], [1.0, 0, 0], [1.0, 1, 0], [0.0, 1, 0], [5.0, 5, 5]])
TRIS = np.array([[0, 1, 2], [0, 2, 3]])


def test_a_square_maps_points_by_hand():
    """Points above the square at height h map to their foot: bilinear values of the corners'
    displacements; distance h; the matrix has a row per point and a column per node, the
    unused node's column empty."""
    pts = np.array([[0.75, 0.25, 0.04], [0.25, 0.5, -0.02], [1.0, 1.0, 0.0]])
    m = PatchMap(pts, SQUARE, TRIS, length=1.0)
    assert m.n_points == 3 and m.matrix.shape == (3, 5) and m.n_nodes == 5
    np.testing.assert_allclose(m.distance, [0.04, 0.02, 0.0], atol=1e-15)
    assert m.max_distance == pytest.approx(0.04)
    np.testing.assert_array_equal(m.triangle, [0, 1, 0])
    # (x, y) in triangle (0, 0), (1, 0), (1, 1) is (1 - x) a + (x - y) b + y c; in (0, 0),
    # (1, 1), (0, 1) it is (1 - y) a + x b + (y - x) c
    dense = m.matrix.toarray()
    np.testing.assert_allclose(dense[0], [0.25, 0.5, 0.25, 0, 0], atol=1e-15)
    np.testing.assert_allclose(dense[1], [0.5, 0, 0.25, 0.25, 0], atol=1e-15)
    np.testing.assert_allclose(dense[2], [0, 0, 1, 0, 0], atol=1e-15)
    u = np.arange(15.0).reshape(5, 3)
    out = m.apply(u)
    assert out.flags["C_CONTIGUOUS"] and out.dtype == np.float64
    np.testing.assert_allclose(out, dense @ u, rtol=1e-15)
    np.testing.assert_allclose(m.apply(u.astype(np.int64)), dense @ u, rtol=1e-15)
    assert m.cache_status is None
    with pytest.raises(GeometryError, match=r"node displacement has shape \(4, 3\), expected "
                                            r"\(5, 3\)"):
        m.apply(u[:4])
    with pytest.raises(GeometryError, match=r"shape \(5, 2\), expected \(5, 3\)"):
        m.apply(u[:, :2])


def test_the_tolerance_is_a_fraction_of_the_length_its_limit_allowed():
    """A point 0.1 m off a 2 m surface: allowed at tolerance 0.05 (the limit itself), refused
    just below it, the message naming the point, the distance, the limit and the length."""
    pts = np.array([[0.5, 0.5, 0.0], [0.2, 0.7, 0.1]])
    assert PatchMap(pts, SQUARE, TRIS, length=2.0).max_distance == pytest.approx(0.1)
    with pytest.raises(GeometryError) as info:
        PatchMap(pts, SQUARE, TRIS, length=2.0, tolerance=0.0499)
    assert str(info.value) == (
        "patch point 1 at [0.2, 0.7, 0.1] lies 0.1 m from the whale surface, more than the "
        "allowed 0.0998 m (0.0499 L); is this the whale patch, and is the case built from "
        "the same scene (body length 2 m)?")


def test_bad_points_are_named():
    with pytest.raises(GeometryError, match=r"patch points have shape \(2, 2\), expected "
                                            r"\(P, 3\)"):
        PatchMap(np.zeros((2, 2)), SQUARE, TRIS, 1.0)
    with pytest.raises(GeometryError, match=r"patch points have shape \(1, 2, 3\)"):
        PatchMap(np.zeros((1, 2, 3)), SQUARE, TRIS, 1.0)
    bad = np.zeros((4, 3))
    bad[2, 1] = np.inf
    bad[3, 0] = np.nan
    with pytest.raises(GeometryError, match=r"patch point 2 is not finite: \[0.0, inf, 0.0\]"):
        PatchMap(bad, SQUARE, TRIS, 1.0)
    empty = PatchMap(np.zeros((0, 3)), SQUARE, TRIS, 1.0, cache="/nonexistent/map.npz")
    assert empty.n_points == 0 and empty.matrix.shape == (0, 5) and empty.max_distance == 0.0
    assert empty.cache_status is None  # nothing to map, nothing to keep
    assert empty.triangle.shape == (0,) and empty.weights.shape == (0, 3)
    assert empty.distance.shape == (0,) and empty.apply(np.ones((5, 3))).shape == (0, 3)
    one = PatchMap([[0.5, 0.25, 0.01]], SQUARE, TRIS, 1.0)  # a list, one point
    assert one.n_points == 1 and one.distance == pytest.approx([0.01])
    np.testing.assert_allclose(one.apply(np.eye(5)[:, :3]), [[0.5, 0.25, 0.25]], atol=1e-15)


# -- the cache -------------------------------------------------------------------------------------

def _points():
    rng = np.random.default_rng(2)
    return np.c_[rng.uniform(0, 1, (20, 2)), rng.uniform(-0.01, 0.01, 20)]


@pytest.mark.parametrize("damage", ["tri int32", "tri negative", "tri past the end",
                                    "weights float32", "weights (P, 2)", "distance (P + 1)",
                                    "distance float32", "no weights", "triangle (P, 1)"])
def test_a_cache_file_that_does_not_fit_is_computed_again(tmp_path, damage):
    """A file with the right key but arrays that do not fit these points and this surface
    is not trusted: the map is computed again (and the file rewritten), the same as without
    a cache."""
    pts = _points()
    path = tmp_path / "map.npz"
    fresh = PatchMap(pts, SQUARE, TRIS, 1.0)
    assert PatchMap(pts, SQUARE, TRIS, 1.0, cache=path).cache_status == "saved"
    with np.load(path) as f:
        data = dict(f)
    tri, w, d = data["triangle"], data["weights"], data["distance"]
    changed = {
        "tri int32": ("triangle", tri.astype(np.int32)),
        "tri negative": ("triangle", np.where(np.arange(20) == 3, -1, tri)),
        "tri past the end": ("triangle", np.where(np.arange(20) == 3, 2, tri)),
        "weights float32": ("weights", w.astype(np.float32)),
        "weights (P, 2)": ("weights", w[:, :2].copy()),
        "distance (P + 1)": ("distance", np.r_[d, 0.0]),
        "distance float32": ("distance", d.astype(np.float32)),
        "no weights": ("weights", None),
        "triangle (P, 1)": ("triangle", tri[:, None].copy()),
    }[damage]
    if changed[1] is None:
        del data[changed[0]]
    else:
        data[changed[0]] = changed[1]
    np.savez(path, **data)
    again = PatchMap(pts, SQUARE, TRIS, 1.0, cache=path)
    assert again.cache_status == "saved", damage
    for name in ("triangle", "weights", "distance"):
        np.testing.assert_array_equal(getattr(again, name), getattr(fresh, name))
    assert PatchMap(pts, SQUARE, TRIS, 1.0, cache=path).cache_status == "loaded"


def test_a_map_that_cannot_be_written_leaves_no_temporary_file(tmp_path):
    """The cache path is a folder: the temporary file is written, the rename fails; the map
    works, the status says why, and the temporary file is gone."""
    target = tmp_path / "map.npz"
    target.mkdir()
    (target / "keep").write_text("")
    m = PatchMap(_points(), SQUARE, TRIS, 1.0, cache=target)
    assert m.cache_status.startswith("not saved: ") and "map.npz" in m.cache_status
    assert sorted(p.name for p in tmp_path.iterdir()) == ["map.npz"]
    np.testing.assert_array_equal(m.weights, PatchMap(_points(), SQUARE, TRIS, 1.0).weights)


def test_the_cache_tells_the_surfaces_apart(tmp_path):
    """The same bytes split otherwise between the patch and the surface, the triangles of
    another surface, integer coordinates: each its own map, none loaded for another."""
    path = tmp_path / "map.npz"
    pts = _points()
    assert PatchMap(pts, SQUARE, TRIS, 1.0, cache=path).cache_status == "saved"
    assert PatchMap(pts, SQUARE, TRIS[::-1], 1.0, cache=path).cache_status == "saved"
    assert PatchMap(pts, SQUARE, TRIS, 1.0, cache=path).cache_status == "saved"
    assert PatchMap(pts, SQUARE, TRIS, 1.0, cache=path).cache_status == "loaded"
    grid = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0]])
    a = PatchMap(grid, SQUARE.astype(int), TRIS, 1.0, cache=path)
    b = PatchMap(grid.astype(float), SQUARE, TRIS, 1.0, cache=path)
    assert a.cache_status == "saved" and b.cache_status == "loaded"  # the same numbers


def test_the_map_is_written_beside_the_target_and_renamed(tmp_path, monkeypatch):
    """Atomic: the map goes to a temporary file in the target's own folder (a rename within
    one folder replaces the file in one step, never half written), named after the target
    with .tmp at the end, then renamed onto the target."""
    import os

    from adapter.coupling import mapping

    renames = []
    real = os.replace

    def spy(src, dst):
        renames.append((Path(src), Path(dst)))
        return real(src, dst)

    monkeypatch.setattr(mapping.os, "replace", spy)
    path = tmp_path / "sub" / "map.npz"
    path.parent.mkdir()
    assert PatchMap(_points(), SQUARE, TRIS, 1.0, cache=path).cache_status == "saved"
    [(src, dst)] = renames
    assert dst == path and src.parent == path.parent
    assert src.name.startswith("map.npz.") and src.name.endswith(".tmp") and src != path
    assert sorted(p.name for p in path.parent.iterdir()) == ["map.npz"]
