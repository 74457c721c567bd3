"""Shared fixtures: the smoke scene and its whale, built once per session."""

import pytest

from adapter.animator import Animator
from adapter.geometry import build_surface
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
