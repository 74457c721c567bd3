"""adapter.foam.foamascii (the OpenFOAM ASCII readers) and adapter.foam.yplus (area-weighted y+
statistics).

The hand-built mesh: two hexahedra side by side, x in [0, 1] and [1, 3], y in [0, 1],
z in [0, 1]. Its bottom (z = 0) faces form the patch ``whale`` with areas 1 and 2 m2 (from
the coordinates, not from the code under test).
"""

from __future__ import annotations

import gzip

import numpy as np
import pytest

from adapter.errors import AdapterError
from adapter.foam import case as C
from adapter.foam import foamascii as FA
from adapter.foam import mesh as M
from adapter.foam import run as R
from adapter.foam import yplus as Y

_HEADER = """/*--------------------------------*- C++ -*----------------------------------*\\
  a comment block ( with parentheses ) 3 ( 1 2 3 )
\\*---------------------------------------------------------------------------*/
FoamFile
{{
    version     2.0;
    format      ascii;
    class       {cls};
    object      {obj};
}}
// * * * * * * * * * * //
"""

# x = 0, 1, 3 ; y = 0, 1 ; z = 0, 1.  point index = i + 3 * j + 6 * k
_XS = (0.0, 1.0, 3.0)


def _points(scale_x: float = 1.0) -> np.ndarray:
    return np.array([(x * scale_x, y, z) for z in (0.0, 1.0) for y in (0.0, 1.0) for x in _XS])


def _pid(i, j, k):
    return i + 3 * j + 6 * k


# internal face first, then the patches: whale (z = 0, two faces), walls (everything else)
_FACES = [
    [_pid(1, 0, 0), _pid(1, 1, 0), _pid(1, 1, 1), _pid(1, 0, 1)],  # x = 1, internal
    [_pid(0, 0, 0), _pid(0, 1, 0), _pid(1, 1, 0), _pid(1, 0, 0)],  # z = 0, cell 0: area 1
    [_pid(1, 0, 0), _pid(1, 1, 0), _pid(2, 1, 0), _pid(2, 0, 0)],  # z = 0, cell 1: area 2
    [_pid(0, 0, 1), _pid(1, 0, 1), _pid(1, 1, 1), _pid(0, 1, 1)],  # z = 1
    [_pid(1, 0, 1), _pid(2, 0, 1), _pid(2, 1, 1), _pid(1, 1, 1)],
    [_pid(0, 0, 0), _pid(0, 0, 1), _pid(0, 1, 1), _pid(0, 1, 0)],  # x = 0
    [_pid(2, 0, 0), _pid(2, 1, 0), _pid(2, 1, 1), _pid(2, 0, 1)],  # x = 3
    [_pid(0, 0, 0), _pid(1, 0, 0), _pid(1, 0, 1), _pid(0, 0, 1)],  # y = 0
    [_pid(1, 0, 0), _pid(2, 0, 0), _pid(2, 0, 1), _pid(1, 0, 1)],
    [_pid(0, 1, 0), _pid(0, 1, 1), _pid(1, 1, 1), _pid(1, 1, 0)],  # y = 1
    [_pid(1, 1, 0), _pid(1, 1, 1), _pid(2, 1, 1), _pid(2, 1, 0)],
]


def _write(path, text: str, gz: bool = False) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    if gz:
        path.with_name(path.name + ".gz").write_bytes(gzip.compress(text.encode()))
    else:
        path.write_text(text)


def _points_text(pts) -> str:
    rows = "\n".join(f"({float(x)!r} {float(y)!r} {float(z)!r})" for x, y, z in pts)
    return _HEADER.format(cls="vectorField", obj="points") + f"\n{len(pts)}\n(\n{rows}\n)\n"


def _faces_text(compact: bool) -> str:
    if compact:
        offsets = np.concatenate([[0], np.cumsum([len(f) for f in _FACES])])
        labels = [v for f in _FACES for v in f]
        return (_HEADER.format(cls="faceCompactList", obj="faces")
                + f"\n{len(offsets)}\n(\n" + "\n".join(map(str, offsets)) + "\n)\n\n"
                + f"{len(labels)}\n(\n" + "\n".join(map(str, labels)) + "\n)\n")
    rows = "\n".join(f"{len(f)}(" + " ".join(map(str, f)) + ")" for f in _FACES)
    return _HEADER.format(cls="faceList", obj="faces") + f"\n{len(_FACES)}\n(\n{rows}\n)\n"


_BOUNDARY = _HEADER.format(cls="polyBoundaryMesh", obj="boundary") + """
2
(
    whale
    {
        type            wall;
        inGroups        1(wall);
        nFaces          2;
        startFace       1;
    }
    walls
    {
        type            wall;
        nFaces          8;
        startFace       3;
    }
)
"""


def _yplus_text(values) -> str:
    vals = "\n".join(repr(float(v)) for v in values)
    return _HEADER.format(cls="volScalarField", obj="yPlus") + f"""
dimensions      [0 0 0 0 0 0 0];
internalField   uniform 0;
boundaryField
{{
    walls
    {{
        type            calculated;
        value           uniform 7;
    }}
    whale
    {{
        type            calculated;
        value           nonuniform List<scalar>
{len(values)}
(
{vals}
)
;
    }}
}}
"""


@pytest.fixture(params=["plain", "compressed-compact"])
def tiny_case(tmp_path, request):
    gz = request.param != "plain"
    case = tmp_path / "case"
    mesh = case / "constant" / "polyMesh"
    _write(mesh / "points", _points_text(_points()), gz)
    _write(mesh / "faces", _faces_text(compact=gz), gz)
    _write(mesh / "boundary", _BOUNDARY, gz)
    _write(case / "1" / "yPlus", _yplus_text([10.0, 100.0]), gz)
    return case


def test_patch_face_areas_of_the_hand_built_mesh(tiny_case):
    assert FA.patch_face_areas(tiny_case, "whale").tolist() == pytest.approx([1.0, 2.0])
    # top 1 + 2, ends 1 and 1, front and back 1 + 2 each
    assert FA.patch_face_areas(tiny_case, "walls").sum() == pytest.approx(3 + 2 + 3 + 3)


def test_yplus_stats_are_area_weighted(tiny_case):
    s = Y.yplus_stats(tiny_case)
    assert s["time"] == "1"
    assert s["faces"] == 2
    assert s["area_m2"] == pytest.approx(3.0)
    assert s["mean"] == pytest.approx((10 * 1 + 100 * 2) / 3)
    assert s["area_below_1"] == 0.0
    assert s["area_below_30"] == pytest.approx(1 / 3)
    assert s["area_30_300"] == pytest.approx(2 / 3)
    assert s["area_le_300"] == pytest.approx(1.0)
    assert (s["min"], s["max"]) == (10.0, 100.0)
    # the 100 face holds two thirds of the area: it is the median and the 95th percentile
    assert s["p95"] == pytest.approx(100.0)
    assert 10.0 < s["median"] <= 100.0
    assert s["p5"] == pytest.approx(10.0)


def test_a_moving_mesh_reads_the_points_of_its_time(tiny_case):
    """Points written into a time folder (a moving mesh) are used for that time and later;
    faces and boundary still come from constant/polyMesh."""
    _write(tiny_case / "0.5" / "polyMesh" / "points", _points_text(_points(scale_x=2.0)))
    assert FA.patch_face_areas(tiny_case, "whale", "1").tolist() == pytest.approx([2.0, 4.0])
    assert FA.patch_face_areas(tiny_case, "whale", "0.25").tolist() == pytest.approx([1.0, 2.0])
    s = Y.yplus_stats(tiny_case, "1")
    assert s["area_m2"] == pytest.approx(6.0)


def test_a_parallel_run_is_read_in_its_processor_folders(tiny_case):
    """Times only the processor folders hold (a parallel run, not reconstructed) are read
    there: each rank's share of the patch, joined, gives the statistics of the whole."""
    for rank, values in enumerate(([10.0, 100.0], [50.0, 50.0])):
        proc = tiny_case / f"processor{rank}"
        for name in ("points", "faces", "boundary"):
            _write(proc / "constant" / "polyMesh" / name,
                   (tiny_case / "constant" / "polyMesh" / name).read_text()
                   if (tiny_case / "constant" / "polyMesh" / name).is_file()
                   else gzip.decompress((tiny_case / "constant" / "polyMesh" /
                                         f"{name}.gz").read_bytes()).decode())
        _write(proc / "2" / "yPlus", _yplus_text(values))
    assert Y.written_times(tiny_case) == ["1", "2"]
    s = Y.yplus_stats(tiny_case)
    assert s["time"] == "2" and s["faces"] == 4
    assert s["area_m2"] == pytest.approx(6.0)
    assert s["mean"] == pytest.approx((10 * 1 + 100 * 2 + 50 * 1 + 50 * 2) / 6)
    # a time the case folder holds is read there
    assert Y.yplus_stats(tiny_case, "1")["faces"] == 2


def test_uniform_values_and_errors(tiny_case, tmp_path):
    field = tmp_path / "f"
    field.write_text(_yplus_text([1.0, 2.0]).replace("walls", "other"))
    assert FA.read_patch_field(field, "other", 4).tolist() == [7.0] * 4
    with pytest.raises(AdapterError, match="no patch nose"):
        FA.read_patch_field(field, "nose")
    with pytest.raises(AdapterError, match="no patch nose"):
        FA.patch_face_areas(tiny_case, "nose")
    with pytest.raises(AdapterError, match="no time folder 2"):
        Y.yplus_stats(tiny_case, "2")


def test_face_area_vectors_of_polygons():
    pts = np.array([[0, 0, 0], [2, 0, 0], [0, 3, 0], [0, 0, 4.0], [5, 5, 5.0]])
    # a right triangle in the plane z = 0 (area 3), one in the plane y = 0 (area 4)
    # (normal +y), and a tilted planar square
    sq = np.array([[0, 0, 0], [1, 0, 1], [1, 1, 1], [0, 1, 0.0]])  # sides 1 and sqrt(2)
    allp = np.vstack([pts, sq])
    a = FA.face_area_vectors(allp, [np.array([0, 1, 2]), np.array([0, 3, 1]),
                                   np.array([5, 6, 7, 8])])
    assert a[0] == pytest.approx([0, 0, 3.0])
    assert a[1] == pytest.approx([0, 4.0, 0])
    assert np.linalg.norm(a[2]) == pytest.approx(np.sqrt(2.0))


def test_weighted_quantile():
    v = [1.0, 2.0, 3.0]
    assert Y.weighted_quantile(v, [1, 1, 1], 0.5)[0] == pytest.approx(2.0)
    assert Y.weighted_quantile(v, [0.01, 0.01, 10], 0.5)[0] == pytest.approx(3.0, abs=0.01)


_LAYER_LOG = """
Extruding 4309 out of 4638 faces (92.9). Removed extrusion at 0 faces.
Added 12000 out of 13914 cells (86.2458).
Extruding 4288 out of 4606 faces (93.0959). Removed extrusion at 0 faces.
Added 11488 out of 13818 cells (83.1).

patch faces    layers   overall thickness
                        [m]       [%]
----- -----    ------   ---       ---
whale 4606     2.49     0.0307    81.4

Layer mesh : cells:63094  faces:199418  points:73924
"""


def test_parse_layer_report():
    r = Y.parse_layer_report(_LAYER_LOG)["whale"]
    assert r == {"faces": 4606, "mean_layers": 2.49, "thickness_m": 0.0307,
                 "thickness_pct": 81.4, "faces_with_layers": 4288,
                 "face_coverage": pytest.approx(4288 / 4606)}
    assert Y.parse_layer_report("no layers here") == {}


@pytest.mark.openfoam
def test_smoke_case_with_layers_and_yplus(tmp_path, smoke_scene, smoke_surface):
    """A smoke-sized case with one prism layer: meshed, run for its 8 steps; the layer record
    and the y+ statistics come out (whale area a few hundred m2 at this coarse surface)."""
    scene = smoke_scene.replace(case={"layers": 1, "first_layer_m": 0.25})
    case = tmp_path / "case"
    C.prepare_case(scene, case, surface=smoke_surface, static_whale=True)
    info = M.mesh_case(case)
    layers = info["layers"]
    assert layers["faces"] == info["whale_faces"]
    assert 0 < layers["area_with_layers"] <= 1
    assert 0 < layers["face_coverage"] <= 1
    assert C.read_record(case)["mesh"]["layers"] == layers
    R.run_case(case, progress=False)
    s = Y.yplus_stats(case)
    assert s["faces"] == info["whale_faces"]
    assert 50 < s["area_m2"] < 500
    assert 0 < s["median"] < s["max"]
    assert s["layer_area_coverage"]["area_with_layers"] == pytest.approx(
        layers["area_with_layers"], abs=1e-4)
