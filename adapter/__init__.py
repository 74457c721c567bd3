"""whale-adapter: a spring-mass right whale (Duffy et al.) driving an OpenFOAM moving mesh.

Public surface:

- :func:`load_scene`, :class:`Scene` -- every parameter of a run, from one TOML file;
- :func:`build_surface`, :class:`WhaleSurface` -- the whale's surface mesh, landmarks, regions;
- :class:`Animator` -- advances the spring-mass whale to any time and returns displacements;
- the named exceptions of :mod:`adapter.errors`.
"""

from .errors import (
    AdapterError,
    GeometryError,
    ProtocolError,
    SceneError,
    SolverRunError,
    UnstableError,
)
from .scene import Scene, load_scene

__all__ = [
    "AdapterError",
    "GeometryError",
    "ProtocolError",
    "SceneError",
    "SolverRunError",
    "UnstableError",
    "Scene",
    "load_scene",
]
