"""PIMPLE's outer and pressure correctors (``case.outer_correctors``,
``case.pressure_correctors``) in the case's fvSolution, with the mesh moved once a step, and the
time scheme (``case.time_scheme``) in its fvSchemes; the blended motion's neighbour count and
power and shell (``case.motion_neighbours``, ``case.motion_power``, ``case.motion_shell``) in its
dynamicMeshDict."""

from __future__ import annotations

import pytest
from PyFoam.RunDictionary.ParsedParameterFile import ParsedParameterFile

from adapter.errors import SceneError
from adapter.foam import case as C
from adapter.scene import load_scene


def _pimple(tmp_path, scene, surface, key: str, n: int):
    """The PIMPLE dictionary of a case prepared with ``case.<key> = n``."""
    case = tmp_path / f"case-{key}-{n}"
    C.prepare_case(scene.replace(case={key: n}), case, surface=surface)
    return ParsedParameterFile(str(case / "system" / "fvSolution"))["PIMPLE"]


def test_outer_correctors_reach_fvsolution_and_the_mesh_moves_once_a_step(tmp_path, smoke_scene,
                                                                          smoke_surface):
    for n in (1, 3):
        pimple = _pimple(tmp_path, smoke_scene, smoke_surface, "outer_correctors", n)
        assert int(pimple["nOuterCorrectors"]) == n
        assert pimple["moveMeshOuterCorrectors"] in (False, "no")
    assert smoke_scene.case.outer_correctors == 1          # the tests' quick numerics
    assert load_scene(preset="default").case.outer_correctors == 3
    with pytest.raises(SceneError, match="outer_correctors"):
        smoke_scene.replace(case={"outer_correctors": 0})


def test_pressure_correctors_reach_fvsolution(tmp_path, smoke_scene, smoke_surface):
    for n in (1, 3):
        pimple = _pimple(tmp_path, smoke_scene, smoke_surface, "pressure_correctors", n)
        assert int(pimple["nCorrectors"]) == n
    with pytest.raises(SceneError, match="pressure_correctors"):
        smoke_scene.replace(case={"pressure_correctors": 0})


def test_the_time_scheme_reaches_fvschemes(tmp_path, smoke_scene, smoke_surface):
    for scheme in ("Euler", "backward"):
        case = tmp_path / f"case-{scheme}"
        C.prepare_case(smoke_scene.replace(case={"time_scheme": scheme}), case,
                       surface=smoke_surface)
        ddt = ParsedParameterFile(str(case / "system" / "fvSchemes"))["ddtSchemes"]
        assert ddt["default"] == scheme
    assert smoke_scene.case.time_scheme == "Euler"
    assert load_scene(preset="default").case.time_scheme == "backward"
    with pytest.raises(SceneError, match="time_scheme"):
        smoke_scene.replace(case={"time_scheme": "CrankNicolson"})


def test_the_motion_weights_reach_dynamicmeshdict(tmp_path, smoke_scene, smoke_surface):
    for n, power, shell, clusters in ((8, 2.0, 0.0, 0.0), (48, 3.5, 0.25, 0.2)):
        case = tmp_path / f"case-k{n}"
        scene = smoke_scene.replace(case={"motion_neighbours": n, "motion_power": power,
                                          "motion_shell": shell, "motion_clusters": clusters})
        C.prepare_case(scene, case, surface=smoke_surface)
        dyn = ParsedParameterFile(str(case / "constant" / "dynamicMeshDict"))
        coeffs = dyn["whaleBlendedDisplacementCoeffs"]
        assert int(coeffs["nNeighbours"]) == n and float(coeffs["power"]) == power
        assert float(coeffs["shell"]) == shell and float(coeffs["clusters"]) == clusters
    default = load_scene(preset="default").case
    assert (default.motion_neighbours, default.motion_power, default.motion_shell,
            default.motion_clusters) == (256, 2.0, 0.5, 0.0)
    # clusters carry the whale points' areas: no clusters without the shell
    with pytest.raises(SceneError, match="motion_clusters needs case.motion_shell > 0"):
        smoke_scene.replace(case={"motion_shell": 0.0, "motion_clusters": 0.125})
    with pytest.raises(SceneError, match="motion_neighbours"):
        smoke_scene.replace(case={"motion_neighbours": 1})
    with pytest.raises(SceneError, match="motion_power"):
        smoke_scene.replace(case={"motion_power": 0.5})
    with pytest.raises(SceneError, match="motion_shell"):
        smoke_scene.replace(case={"motion_shell": -0.5})


def test_the_layer_rotation_reaches_dynamicmeshdict(tmp_path, smoke_scene, smoke_surface):
    """``case.motion_rotation``: rotation in full over the prism layers' thickness, by hand
    7 mm + 10.5 mm + 15.75 mm = 33.25 mm for three layers from 7 mm growing by 1.5, and
    blended out over that many layer thicknesses beyond them (2: to 3 x 33.25 mm)."""
    scene = smoke_scene.replace(case={"layers": 3, "first_layer_m": 0.007,
                                      "layer_expansion": 1.5, "motion_rotation": 2.0})
    C.prepare_case(scene, tmp_path / "on", surface=smoke_surface)
    coeffs = ParsedParameterFile(str(tmp_path / "on" / "constant" / "dynamicMeshDict"))[
        "whaleBlendedDisplacementCoeffs"]
    assert str(coeffs["rotation"]) == "yes"
    assert float(coeffs["rotationInner"]) == pytest.approx(0.03325, abs=1e-12)
    assert float(coeffs["rotationDistance"]) == pytest.approx(3 * 0.03325, abs=1e-12)
    assert int(coeffs["rotationNeighbours"]) == 16
    C.prepare_case(scene.replace(case={"motion_rotation": 0.0}), tmp_path / "off",
                   surface=smoke_surface)
    coeffs = ParsedParameterFile(str(tmp_path / "off" / "constant" / "dynamicMeshDict"))[
        "whaleBlendedDisplacementCoeffs"]
    assert str(coeffs["rotation"]) == "no"
    with pytest.raises(SceneError, match="motion_rotation"):
        smoke_scene.replace(case={"motion_rotation": -2.0})
    with pytest.raises(SceneError, match="motion_rotation_neighbours"):
        smoke_scene.replace(case={"motion_rotation_neighbours": 2})
