"""The fins' own prism layers: the whale meshed as a patch a region and merged back into one
(adapter/foam/finpatches.py), its layer record and layer fields (adapter/foam/mesh.py)."""

from __future__ import annotations

import numpy as np
import pytest

from adapter.errors import FoamFileError
from adapter.foam import bodymesh as B
from adapter.foam import case as C
from adapter.foam import finpatches as F
from adapter.foam import foamascii as FA
from adapter.foam import mesh as M
from adapter.foam import yplus as Y
from adapter.foam.dictionaries import parsed_dict

_FIELD = """FoamFile
{
    version     2.0;
    format      ascii;
    class       volScalarField;
    object      nSurfaceLayers;
}
dimensions      [0 0 0 0 0 0 0];
internalField   uniform 0;
boundaryField
{
    inlet
    {
        type            fixedValue;
        value           uniform 0;
    }
    whale_body
    {
        type            fixedValue;
        value           nonuniform List<scalar>
3
(
1
2
3
)
;
    }
    whale_flippers
    {
        type            fixedValue;
        value           uniform 4;
    }
    whale_flukes
    {
        type            fixedValue;
        value           nonuniform List<scalar> 2(0 5);
    }
    outlet
    {
        type            zeroGradient;
    }
}
"""


def test_merged_field_text_holds_the_parts_values_in_their_order(tmp_path):
    """The three entries become one ``whale`` entry with the values given; the other patches
    are left as written (read back by the project's own field reader)."""
    values = np.array([1, 2, 3, 4, 4, 0, 5], dtype=float)
    text = F.merged_field_text(_FIELD, F.PATCHES, values)
    path = tmp_path / "nSurfaceLayers"
    path.write_text(text)
    assert FA.read_patch_field(path, "whale", 7).tolist() == values.tolist()
    assert FA.read_patch_field(path, "inlet", 2).tolist() == [0, 0]
    assert "outlet" in text and "zeroGradient" in text
    for part in F.PATCHES:
        with pytest.raises(FoamFileError):
            FA.read_patch_field(path, part)
    with pytest.raises(FoamFileError, match="whale_flukes"):
        F.merged_field_text(_FIELD.replace("whale_flukes", "other"), F.PATCHES, values)


def test_joined_rows_sum_faces_and_weight_means_by_faces():
    """Two rows by hand: 100 faces of 3 layers 30 mm (90 %), 300 of 2 layers 6 mm (60 %)."""
    rows = [{"faces": 100, "mean_layers": 3.0, "thickness_m": 0.030, "thickness_pct": 90.0},
            {"faces": 300, "mean_layers": 2.0, "thickness_m": 0.006, "thickness_pct": 60.0}]
    out = M.joined_rows(rows, (380, 400))
    assert out["faces"] == 400
    assert out["mean_layers"] == pytest.approx(2.25)
    assert out["thickness_m"] == pytest.approx(0.012)
    assert out["thickness_pct"] == pytest.approx(67.5)
    assert out["faces_with_layers"] == 380
    assert out["face_coverage"] == pytest.approx(0.95)


def test_fin_layers_mesh_the_regions_surface_and_the_body_check_reads_the_body(
        tmp_path, smoke_scene, smoke_surface):
    """With the fins' own layers snappyHexMesh meshes whale_regions.stl (three solids) with a
    layer entry a patch, and the body check still finds the body's layer count."""
    scene = smoke_scene.replace(case={"layers": 3, "fin_layers": 2})
    case = tmp_path / "case"
    C.prepare_case(scene, case, surface=smoke_surface)
    d = parsed_dict(case / "system" / "snappyHexMeshDict")
    assert list(d["geometry"]).count("whale_regions.stl") == 1
    assert "whale.stl" not in d["geometry"]
    layers = d["addLayersControls"]["layers"]
    assert sorted(layers) == sorted(F.PATCHES)
    assert layers["whale_flukes"]["firstLayerThickness"] == pytest.approx(0.002)
    assert B.mesh_levels(case)["layers"] == 3


@pytest.mark.openfoam
@pytest.mark.parametrize("ranks", [1, 2])
def test_smoke_whale_with_fin_layers_is_one_patch(tmp_path, smoke_scene, smoke_surface, ranks):
    """A smoke-sized whale whose fins get two thin layers of their own while the body gets one,
    snappyHexMesh on one rank or two (the mesh and the layer fields reconstructed): its three
    patches are one whale patch afterwards, the fins' layers are thinner than the body's, and
    the coverage read from the merged layer field is the regions' own."""
    scene = smoke_scene.replace(case={"layers": 1, "first_layer_m": 0.25, "fin_layers": 2,
                                      "fin_first_layer_m": 0.05,
                                      "parallel_meshing": ranks > 1})
    case = tmp_path / "case"
    C.prepare_case(scene, case, surface=smoke_surface, static_whale=True, ranks=ranks)
    asked = parsed_dict(case / "system" / "snappyHexMeshDict")["addLayersControls"]["layers"]
    assert asked["whale_flippers"]["nSurfaceLayers"] == 2
    info = M.mesh_case(case)
    assert info["meshed_on_ranks"] == ranks
    boundary = FA.read_boundary(case / "constant" / "polyMesh" / "boundary")
    assert "whale" in boundary and not set(F.PATCHES) & set(boundary)
    layers = info["layers"]
    regions = layers["regions"]
    # the smoke mesh's 1 m cells keep no face of the thin flukes' own: no such patch
    assert list(regions) == ["body", "flippers"]
    assert sum(r["faces"] for r in regions.values()) == layers["faces"] == info["whale_faces"]
    assert regions["flippers"]["thickness_m"] < regions["body"]["thickness_m"]
    cov = Y.layer_coverage(case)
    assert cov["faces"] == info["whale_faces"]
    assert cov["area_with_layers"] == pytest.approx(layers["area_with_layers"], abs=1e-4)
    areas = FA.patch_face_areas(case, "whale")
    n = FA.read_patch_field(case / "0" / "nSurfaceLayers", "whale", len(areas))
    # the regions' faces are the merged patch's in their order: body, flippers
    k = np.cumsum([0] + [r["faces"] for r in regions.values()])
    for i, r in enumerate(regions):
        a, m = areas[k[i]:k[i + 1]], n[k[i]:k[i + 1]]
        assert regions[r]["area_with_layers"] == pytest.approx(a[m > 0.5].sum() / a.sum(),
                                                               abs=1e-4)
