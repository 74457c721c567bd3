"""whale-adapter: a spring-mass right whale (Duffy et al.) driving an OpenFOAM moving mesh.

Public surface:

- :func:`load_scene`, :class:`Scene` -- every parameter of a run, from one TOML file;
- :func:`build_surface`, :class:`WhaleSurface` -- the whale's surface mesh, landmarks, regions;
- :class:`Animator` -- advances the spring-mass whale to any time and returns displacements;
- the named exceptions of :mod:`adapter.errors`.
"""

from adapter.errors import (
    AdapterError,
    CaseError,
    FoamFileError,
    GeometryError,
    ProtocolError,
    SceneError,
    SolverRunError,
    UnstableError,
)
from adapter.scene import Scene, load_scene


def __getattr__(name):
    # the heavy parts (numba kernels, VTK) load on first use, not on `import adapter`
    if name == "Animator":
        from adapter.motion.animator import Animator

        return Animator
    if name == "build_surface":
        from adapter.body.geometry import build_surface

        return build_surface
    if name == "WhaleSurface":
        from adapter.body.surface import WhaleSurface

        return WhaleSurface
    raise AttributeError(f"module 'adapter' has no attribute {name!r}")


__all__ = [
    "Animator",
    "WhaleSurface",
    "build_surface",
    "AdapterError",
    "CaseError",
    "FoamFileError",
    "GeometryError",
    "ProtocolError",
    "SceneError",
    "SolverRunError",
    "UnstableError",
    "Scene",
    "load_scene",
]
