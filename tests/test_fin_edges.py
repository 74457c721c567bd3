"""The fins' leading edges refined at ``case.flipper_edge_level`` and ``fluke_edge_level``
(adapter/body/leadingedge.py, the case's dictionaries and surfaces)."""

from __future__ import annotations

import numpy as np
import pytest

from adapter.body import leadingedge as LE
from adapter.body.meshfile import read_stl_solids
from adapter.foam import case as C
from adapter.foam.dictionaries import parsed_dict


def _wing(sweep: float, y0: float = 0.5, span: float = 1.5, sections: int = 31,
          around: int = 21) -> tuple[np.ndarray, np.ndarray]:
    """A tapered, swept wing along +y and its mirror image, built from sections at known chord
    fractions (cosine spaced, upper and lower surface): each triangle's centroid and its true
    chord fraction (the mean of its corners' fractions; x is linear in the fraction)."""
    xi = 0.5 * (1 - np.cos(np.linspace(0.0, np.pi, around)))
    cents, fracs = [], []
    ys = np.linspace(y0, y0 + span, sections)
    for ya, yb in zip(ys[:-1], ys[1:], strict=True):
        for side in (1.0, -1.0):
            corner = []
            for y in (ya, yb):
                chord = 1.5 - 0.4 * (y - y0)
                lead = sweep * (y - y0)
                corner.append(np.stack([lead + xi * chord, np.full_like(xi, y),
                                        side * 0.06 * chord * np.sin(np.pi * xi)], axis=1))
            a, b = corner
            for i in range(around - 1):
                for tri, f in (((a[i], a[i + 1], b[i]), (xi[i], xi[i + 1], xi[i])),
                               ((a[i + 1], b[i + 1], b[i]), (xi[i + 1], xi[i + 1], xi[i]))):
                    cents.append(np.mean(tri, axis=0))
                    fracs.append(np.mean(f))
    c, f = np.array(cents), np.array(fracs)
    mirror = c * [1.0, -1.0, 1.0]
    return np.concatenate([c, mirror]), np.concatenate([f, f])


@pytest.mark.parametrize("sweep", [0.0, 0.5])
def test_the_mask_takes_the_forward_tenth_of_each_section(sweep):
    """On a wing whose chord fraction is known by construction, every triangle well inside the
    forward tenth is taken and none well behind it, on both sides of the axis."""
    centroids, fraction = _wing(sweep)
    mask = LE.leading_edge_mask(centroids, 0.0, strip_m=0.05)
    assert mask[fraction <= 0.07].all()
    assert not mask[fraction >= 0.14].any()
    assert np.array_equal(mask[:len(mask) // 2], mask[len(mask) // 2:])
    assert LE.leading_edge_mask(np.zeros((0, 3)), 0.0, 0.05).size == 0


def test_edge_levels_give_the_fins_edges_their_cells(tmp_path, smoke_scene, smoke_surface):
    """The edge levels write each fin's leading-edge strip as a refinement region within one
    cell of that level: the background cell (blockMeshDict, by hand) halved `level` times."""
    scene = smoke_scene.replace(case={"flipper_edge_level": 3, "fluke_edge_level": 4})
    case = tmp_path / "case"
    C.prepare_case(scene, case, surface=smoke_surface)
    block = parsed_dict(case / "system" / "blockMeshDict")
    cell = min((block[f"{a}max"] - block[f"{a}min"]) / block[f"n{a}"] for a in "xyz")
    d = parsed_dict(case / "system" / "snappyHexMeshDict")
    regions = d["castellatedMeshControls"]["refinementRegions"]
    for name, level in (("flipperEdges", 3), ("flukeEdges", 4)):
        assert d["geometry"][f"{name}.stl"]["name"] == name
        assert regions[name]["mode"] == "distance"
        dist, got = regions[name]["levels"][0]
        assert (got, dist) == (level, pytest.approx(cell / 2 ** level))
    # the strips are the fins' own triangles, the forward ones of their fin
    tri = case / "constant" / "triSurface"
    whole = read_stl_solids(tri / "whale_regions.stl")
    for stl, fin in (("flipperEdges.stl", "flippers"), ("flukeEdges.stl", "flukes")):
        strip = read_stl_solids(tri / stl)[stl.removesuffix(".stl")]
        own = {tuple(np.round(t.ravel(), 9)) for t in whole[fin]}
        assert 0 < len(strip) < 0.5 * len(whole[fin])
        assert all(tuple(np.round(t.ravel(), 9)) in own for t in strip)
        assert strip[:, :, 0].mean() < whole[fin][:, :, 0].mean()


def test_no_edge_regions_without_edge_levels(tmp_path, smoke_scene, smoke_surface):
    C.prepare_case(smoke_scene, tmp_path / "case", surface=smoke_surface)
    d = parsed_dict(tmp_path / "case" / "system" / "snappyHexMeshDict")
    assert not {"flipperEdges.stl", "flukeEdges.stl"} & set(d["geometry"])
    assert not (tmp_path / "case" / "constant" / "triSurface" / "flukeEdges.stl").exists()
