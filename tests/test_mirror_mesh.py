"""``case.symmetry = "mirror"`` (adapter/foam/symmetry.py): the full domain meshed as the half and
its mirror image. The truths come from the mirror itself: every point of the mesh has its image
among the points (snappyHexMesh's own full-domain mesh does not, so the check can fail), the
cells are twice the half's, the plane is gone from the patches, and the coupled smoke whale on
it feels a side force under a thousandth of its drag, a tenth or less of what it feels on
snappyHexMesh's own full-domain mesh."""

import numpy as np
import pytest
from scipy.spatial import cKDTree

from adapter.errors import SceneError
from adapter.foam import case as C
from adapter.foam import loads as LD
from adapter.foam import mesh as M
from adapter.foam import run as R
from adapter.foam import symmetry as Y
from adapter.foam.foamascii import mesh_file, read_boundary, read_points

from .conftest import needs_foam_and_plugin


def _unmatched_mirror_points(case) -> int:
    """How many mesh points have no mirror image (about y = 0) among the points, within 1e-9 m."""
    pts = read_points(mesh_file(case, None, "points"))
    distance, _ = cKDTree(pts).query(pts * np.array([1.0, -1.0, 1.0]))
    return int(np.count_nonzero(distance > 1e-9))


def test_mirror_needs_a_mirror_symmetric_whale(tmp_path, smoke_scene):
    scene = smoke_scene.replace(case={"symmetry": "mirror"},
                                rigid={"enabled": True, "translation_m": (0.0, 0.1, 0.0)})
    with pytest.raises(SceneError, match='symmetry = "mirror" needs'):
        C.prepare_case(scene, tmp_path / "case")
    assert not (tmp_path / "case" / "adapter-case.json").exists()


def _mesh(scene, case):
    C.prepare_case(scene, case)
    return M.mesh_case(case)



@needs_foam_and_plugin
def test_the_mirrored_mesh_is_its_own_mirror_image_and_feels_no_side_force(tmp_path, smoke_scene):
    mirror = tmp_path / "mirror"
    info = _mesh(smoke_scene.replace(case={"symmetry": "mirror"}), mirror)
    half = _mesh(smoke_scene.replace(case={"symmetry": "auto"}), tmp_path / "half")
    _mesh(smoke_scene.replace(case={"symmetry": "off"}), tmp_path / "full")

    assert info["cells"] == 2 * half["cells"]
    assert Y.PATCH not in read_boundary(mesh_file(mirror, None, "boundary"))
    assert _unmatched_mirror_points(mirror) == 0
    assert _unmatched_mirror_points(tmp_path / "full") > 0       # snappyHexMesh's own is not
    record = C.read_record(mirror)
    assert record[Y.MIRROR_KEY] and not record[Y.RECORD_KEY]

    side = {}
    for case in (mirror, tmp_path / "full"):
        R.run_case(case, progress=False)
        loads = LD.read_loads(case)
        fx, fy = np.abs(loads["total:Fx"]), np.abs(loads["total:Fy"])
        assert fx.min() > 1.0
        side[case.name] = fy.max() / fx.min()
    print(f"largest |Fy| / smallest |Fx|: {side}")
    assert side["mirror"] < 1e-3
    assert side["full"] > 10 * side["mirror"]
