"""PIMPLE's outer correctors from the scene (``case.outer_correctors``) in the case's
fvSolution, with the mesh moved once a step."""

from __future__ import annotations

import pytest
from PyFoam.RunDictionary.ParsedParameterFile import ParsedParameterFile

from adapter.errors import SceneError
from adapter.foam import case as C


def test_outer_correctors_reach_fvsolution_and_the_mesh_moves_once_a_step(tmp_path, smoke_scene,
                                                                          smoke_surface):
    for n in (1, 3):
        case = tmp_path / f"case-{n}"
        C.prepare_case(smoke_scene.replace(case={"outer_correctors": n}), case,
                       surface=smoke_surface)
        pimple = ParsedParameterFile(str(case / "system" / "fvSolution"))["PIMPLE"]
        assert int(pimple["nOuterCorrectors"]) == n
        assert pimple["moveMeshOuterCorrectors"] in (False, "no")
    assert smoke_scene.case.outer_correctors == 1
    with pytest.raises(SceneError, match="outer_correctors"):
        smoke_scene.replace(case={"outer_correctors": 0})
