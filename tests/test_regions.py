"""The whale's body regions (body, flippers, flukes): the triangle classification of the smoke
whale, the regions STL run-case writes for the loads function object, and the per-region
figures of the swim/glide answer. (The function object's region groups in a real pimpleFoam
run: tests/test_loads.py.)"""

from __future__ import annotations

import numpy as np
import pytest

from adapter.body import meshfile, regions
from adapter.body.surface import WhaleSurface
from adapter.errors import GeometryError
from adapter.foam import loads as ld
from adapter.foam.case import FLIPPERS_STL, REGIONS_STL, prepare_case
from adapter.foam.swimrun import COST_ROWS
from adapter.scene import load_scene


def _areas(surface):
    p, tri = surface.points, surface.triangles
    return 0.5 * np.linalg.norm(np.cross(p[tri[:, 1]] - p[tri[:, 0]], p[tri[:, 2]] - p[tri[:, 0]]),
                                axis=1)


def test_smoke_whale_regions_area_fractions_and_places(smoke_surface):
    surf = smoke_surface
    reg = surf.triangle_regions()
    tri, p, L = surf.triangles, surf.points, surf.length
    assert reg.shape == (len(tri),)
    assert set(np.unique(reg)) == {regions.BODY, regions.FLIPPERS, regions.FLUKES}
    area = _areas(surf)
    frac = {name: area[reg == k].sum() / area.sum() for k, name in enumerate(regions.REGIONS)}
    # measured on the smoke whale (1206 nodes): body 0.804, flippers 0.111, flukes 0.085
    assert abs(frac["flippers"] - 0.111) < 0.005, frac
    assert abs(frac["flukes"] - 0.085) < 0.005, frac
    assert surf.region_areas() == {n: area[reg == k].sum() for k, n in enumerate(regions.REGIONS)}

    centroid = p[tri].mean(axis=1)
    s_c = centroid[:, 0] / L
    tail_base = surf.s[surf.landmarks["tail_base"]]
    # flukes: exactly the triangles behind the tail base
    np.testing.assert_array_equal(reg == regions.FLUKES, s_c > tail_base)
    # flippers: around the flipper tips, on both sides, none on the midline or the head
    fl = reg == regions.FLIPPERS
    for name, side in (("flipper_left", 1), ("flipper_right", -1)):
        tip = p[surf.landmarks[name]]
        mine = fl & (np.sign(centroid[:, 1]) == side)
        assert mine.sum() > 0.4 * fl.sum()
        assert np.linalg.norm(centroid[mine] - tip, axis=1).max() < 0.16 * L
    assert np.abs(centroid[fl, 1]).min() > 0.08 * L
    assert 0.25 < s_c[fl].min() and s_c[fl].max() < 0.45
    # the two flippers mirror each other
    left = area[fl & (centroid[:, 1] > 0)].sum()
    assert abs(left / area[fl].sum() - 0.5) < 1e-9


def test_geometric_flipper_rule_of_mesh_files_finds_the_procedural_flippers(smoke_surface):
    """A mesh file has no face regions: the geometric rule, tried on the procedural whale
    whose flippers are known: no body triangle taken, the flipper's root strip missed
    (measured 13 % of the flipper area on the smoke whale, 10 % on the default)."""
    surf = smoke_surface
    truth = surf.triangle_regions() == regions.FLIPPERS
    rule = regions.flipper_triangles(surf.points, surf.triangles, surf.landmarks, surf.origin,
                               surf.length)
    area = _areas(surf)
    assert not (rule & ~truth).any()
    assert area[rule].sum() > 0.82 * area[truth].sum()
    as_file = WhaleSurface(surf.points, surf.faces, surf.landmarks, surf.length, surf.origin)
    np.testing.assert_array_equal(as_file.triangle_regions() == regions.FLIPPERS, rule)


def test_prepared_case_has_the_three_solids_and_the_regions_entry(smoke_scene, smoke_surface,
                                                                  tmp_path):
    prepare_case(smoke_scene, tmp_path / "case", surface=smoke_surface)
    tri_dir = tmp_path / "case" / "constant" / "triSurface"
    solids = meshfile.read_stl_solids(tri_dir / REGIONS_STL)
    assert list(solids) == list(regions.REGIONS)
    reg = smoke_surface.triangle_regions()
    p, tri = smoke_surface.points, smoke_surface.triangles
    for k, name in enumerate(regions.REGIONS):
        np.testing.assert_array_equal(solids[name], p[tri[reg == k]])   # same triangles, order
    # snappyHexMesh's whale.stl stays one solid: one patch whale
    assert (tri_dir / "whale.stl").read_bytes()[:5] != b"solid" or \
        len(meshfile.read_stl_solids(tri_dir / "whale.stl")) == 1
    control = (tmp_path / "case" / "system" / "controlDict").read_text()
    assert f'regions "$FOAM_CASE/constant/triSurface/{REGIONS_STL}";' in control
    # the flippers alone, for snappyHexMesh's refinement region (case.flipper_level)
    alone = meshfile.read_stl_solids(tri_dir / FLIPPERS_STL)
    assert list(alone) == ["flippers"]
    np.testing.assert_array_equal(alone["flippers"], p[tri[reg == regions.FLIPPERS]])
    with pytest.raises(ValueError, match="no region 'fins': the regions are body, flippers"):
        smoke_surface.write_regions_stl(tmp_path / "fins.stl", only="fins")


def test_the_flukes_blade_leaves_out_the_hinge(tmp_path, smoke_surface):
    """flukeBlade.stl (case.fluke_level's region): the flukes' triangles whose centroid lies
    more than the clearance (m) behind the tail base, by the landmark's own s; clearance 0 is
    all of the flukes, and a clearance past the fluke tips is refused."""
    p, tri = smoke_surface.points, smoke_surface.triangles
    centroid_s = (p[tri].mean(axis=1)[:, 0] - smoke_surface.origin[0]) / smoke_surface.length
    tail_base = smoke_surface.s[smoke_surface.landmarks["tail_base"]]
    flukes = smoke_surface.triangle_regions() == regions.FLUKES
    for clearance in (0.0, 0.3, 0.75):
        smoke_surface.write_fluke_blade_stl(tmp_path / "blade.stl", clearance)
        blade = meshfile.read_stl_solids(tmp_path / "blade.stl")
        assert list(blade) == ["flukeBlade"]
        want = flukes & (centroid_s > tail_base + clearance / smoke_surface.length)
        assert 0 < want.sum() <= flukes.sum()
        np.testing.assert_array_equal(blade["flukeBlade"], p[tri[want]])
    assert want.sum() < flukes.sum()
    with pytest.raises(GeometryError, match="no fluke triangle lies 3 m behind the tail base: "
                       "give a smaller case.fluke_clearance"):
        smoke_surface.write_fluke_blade_stl(tmp_path / "none.stl", 3.0)


def test_region_figures_add_up_to_the_totals(tmp_path):
    """Synthetic loads of three regions over 3 cycles: the region means are those of the
    total's windows, and add up to the total's."""
    period, n = 1.0, 40
    t = np.arange(1, 3 * n + 1) / n
    rng = np.random.default_rng(1)
    cols = {}
    for k, name in enumerate(regions.REGIONS):
        wave = 10 * np.sin(2 * np.pi * t) + rng.normal(size=len(t))
        cols[f"whale.{name}:Fx"] = (k + 1) * 100 + wave
        cols[f"whale.{name}:P"] = (k + 1) * 50 + rng.normal(size=len(t))
        cols[f"whale.{name}:A"] = np.full(len(t), 10.0 * (k + 1))
    swim = {"Time": t, **cols}
    # the gliding run stopped mid-period: its drag is the last whole period's, as the total's
    m = len(t) - n // 2
    glide = {"Time": t[:m], **{k: v[:m] + 7 for k, v in cols.items()}}
    fig = ld.region_figures(swim, glide, period, start_up=1.0)
    assert list(fig) == list(regions.REGIONS)
    total_fx = sum(cols[f"whale.{r}:Fx"] for r in regions.REGIONS)
    total_p = sum(cols[f"whale.{r}:P"] for r in regions.REGIONS)
    st = ld.cycle_stats(t, total_fx, total_p, period, 1.0)
    gst = ld.cycle_stats(t[:m], total_fx[:m] + 21, total_p[:m], period, period)
    assert abs(sum(f["fx_N"] for f in fig.values()) - st.mean_fx[-1]) < 1e-9
    assert abs(sum(f["power_W"] for f in fig.values()) - st.mean_power[-1]) < 1e-9
    assert abs(sum(f["gliding_drag_N"] for f in fig.values()) - gst.mean_fx[-1]) < 1e-9
    last = t > 2.0
    np.testing.assert_allclose(fig["flukes"]["fx_N"], cols["whale.flukes:Fx"][last].mean())
    assert fig["flippers"]["area_m2"] == 20.0
    assert ld.region_figures({"Time": t}, {}, period, 1.0) == {}
    keys = [key for _, key, _ in COST_ROWS]
    for r in regions.REGIONS:
        assert f"swimming_cost/regions/{r}/power_W" in keys
        assert f"swimming_cost/regions/{r}" in keys      # the gliding drag, beside its estimate


def test_a_whale_without_flippers_is_meshed_on_the_flippered_ones_cells(tmp_path):
    """geometry.flippers = false: the whale STL has no flipper, but snappyHexMesh refines at
    the flippers it would have (the same cells for the drag difference of the two runs);
    a body with neither gets no flipper refinement."""
    fine = load_scene(preset="smoke").replace(case={"flipper_level": 3})
    prepare_case(fine, tmp_path / "with")
    prepare_case(fine.replace(geometry={"flippers": False}), tmp_path / "without")
    def tri(case):
        return tmp_path / case / "constant" / "triSurface"

    solids = {k: meshfile.read_stl_solids(tri(k) / REGIONS_STL) for k in ("with", "without")}
    assert len(solids["with"]["flippers"]) > 0 and len(solids["without"]["flippers"]) == 0
    assert ((tri("with") / FLIPPERS_STL).read_text()
            == (tri("without") / FLIPPERS_STL).read_text())
    shm = (tmp_path / "without" / "system" / "snappyHexMeshDict").read_text()
    assert "flippers" in shm
