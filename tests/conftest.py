"""Shared fixtures: the smoke scene and its whale, built once per session; the marks of the
tests that need a program from outside Python.

A test says what it needs with a mark, and the mark alone skips it when that is missing (the
one check, in :func:`pytest_runtest_setup`): ``openfoam`` (OpenFOAM's pimpleFoam, blockMesh
and snappyHexMesh on PATH), ``plugin`` (the built library :data:`adapter.foam.case.PLUGIN_LIB`),
``paraview`` (pvbatch), ``browser`` (chromium). ``make test-fast`` deselects them all, and
``slow`` and ``install`` (the Makefile's ``FAST``).
"""

import shutil

import pytest

from adapter.body.geometry import build_surface
from adapter.foam import case as C
from adapter.motion.animator import Animator
from adapter.scene import load_scene

#: the OpenFOAM programs the tests run (Debian's openfoam package puts them all on PATH)
FOAM_TOOLS = ("pimpleFoam", "blockMesh", "snappyHexMesh")


def missing(mark: str) -> str | None:
    """Why a test marked ``mark`` cannot run here, or None when it can."""
    if mark == "openfoam":
        absent = [t for t in FOAM_TOOLS if shutil.which(t) is None]
        return f"OpenFOAM ({', '.join(absent)}) is not on PATH" if absent else None
    if mark == "plugin":
        return None if C.PLUGIN_LIB.is_file() else \
            f"the library {C.PLUGIN_LIB} is not built (scripts/build_plugin.sh)"
    if mark == "paraview":
        return None if shutil.which("pvbatch") else \
            "ParaView (pvbatch) is not installed; install it with `make paraview-deps`"
    if mark == "browser":
        return None if shutil.which("chromium") else \
            "chromium is not installed (scripts/install_chromium.sh)"
    return None


#: the marks that say what a test needs from outside Python
NEEDS = ("openfoam", "plugin", "paraview", "browser")


@pytest.hookimpl(tryfirst=True)
def pytest_runtest_setup(item):
    """Skip a test whose marks need what is missing, before its fixtures are set up."""
    for mark in NEEDS:
        if item.get_closest_marker(mark) is not None:
            reason = missing(mark)
            if reason:
                pytest.skip(reason)


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
    """The paper's stroke: velocities negated at the top and bottom, the 15 deg table, the
    hinged gate."""
    scene = smoke_scene.replace(stroke={"reversal": "negate", "fluke_table": "quadrature15",
                                        "velocity_scale": 0.94462, "fluke_joint": 0.0})
    return Animator(scene, smoke_surface)


#: tests that run pimpleFoam with the plugin library on a case they build with blockMesh
NEEDS_FOAM_AND_PLUGIN = [pytest.mark.openfoam, pytest.mark.plugin, pytest.mark.slow]


def needs_foam_and_plugin(test):
    """A test function with the marks of :data:`NEEDS_FOAM_AND_PLUGIN` (a decorator, for a
    module whose other tests need neither)."""
    for mark in NEEDS_FOAM_AND_PLUGIN:
        test = mark(test)
    return test
