"""Shared fixtures: the smoke scene and its whale, built once per session; the marks of the
tests that run OpenFOAM with the plugin library."""

import shutil

import pytest

from adapter.body.geometry import build_surface
from adapter.foam import case as C
from adapter.motion.animator import Animator
from adapter.scene import load_scene


@pytest.fixture(scope="session")
def smoke_scene():
    return load_scene(preset="smoke")


@pytest.fixture(scope="session")
def smoke_surface(smoke_scene):
    return build_surface(smoke_scene)


@pytest.fixture()
def smoke_animator(smoke_scene, smoke_surface):
    return Animator(smoke_scene, smoke_surface)


@pytest.fixture()
def paper_animator(smoke_scene, smoke_surface):
    """The paper's stroke: velocities negated at the top and bottom, the 15 deg table."""
    scene = smoke_scene.replace(stroke={"reversal": "negate", "fluke_table": "quadrature15",
                                        "velocity_scale": 0.94462})
    return Animator(scene, smoke_surface)


#: tests that run pimpleFoam with the plugin library on a case they build with blockMesh
NEEDS_FOAM_AND_PLUGIN = [
    pytest.mark.openfoam,
    pytest.mark.slow,
    pytest.mark.skipif(shutil.which("pimpleFoam") is None or shutil.which("blockMesh") is None,
                       reason="OpenFOAM (pimpleFoam, blockMesh) is not on PATH"),
    pytest.mark.skipif(not C.PLUGIN_LIB.is_file(),
                       reason=f"the library {C.PLUGIN_LIB} is not built (scripts/build_plugin.sh)"),
]
