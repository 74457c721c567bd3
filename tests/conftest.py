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
