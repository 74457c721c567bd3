"""The project's named exceptions.

Each subclasses the built-in exception it refines, and each message says what was wrong and
what to do next.
"""


class AdapterError(Exception):
    """Base class of every error the adapter raises on purpose."""


class SceneError(AdapterError, ValueError):
    """A scene file has an unknown key or a bad value; the message names its path in the file."""


class GeometryError(AdapterError, ValueError):
    """A surface mesh cannot be animated: open, non-manifold, NaN or duplicate points, ..."""


class UnstableError(AdapterError, FloatingPointError):
    """The spring-mass model blew up (NaN or runaway motion); the message names a stable step."""


class ProtocolError(AdapterError, ConnectionError):
    """A peer broke the step-server wire protocol (docs/protocol.md)."""


class CaseError(AdapterError, ValueError):
    """An OpenFOAM case folder cannot be prepared, run or read as asked: it already holds another
    case, was not made by ``run-case``, or holds no figures yet; the message says what to do."""


class MeshError(CaseError):
    """A case's mesh misses or mangles the body (too few whale faces for its levels, an area or
    volume unlike the surface's, prism layers on too little of it); the message names the
    setting that fixes it."""


class FoamFileError(AdapterError, ValueError):
    """An OpenFOAM file (mesh, field, dictionary) cannot be read; the message names the file."""


class SolverRunError(AdapterError, RuntimeError):
    """An OpenFOAM utility or solver failed; the message points at its log file."""


class ServerStartError(AdapterError, RuntimeError):
    """The step-server cannot start: socket in use, unsafe TCP host, bad case folder."""


class ParaViewError(AdapterError, RuntimeError):
    """ParaView (pvbatch, xvfb-run) is missing, or its script failed; the message says why."""


class VTKFileError(AdapterError, ValueError):
    """A VTK file (.vtp, .pvd) cannot be read: cut short or not what its name says."""


class UsageError(AdapterError, ValueError):
    """A command-line option is missing or out of range; the message names the option."""


class IntegratorError(AdapterError, ValueError):
    """An integrator asked for wrongly: an unknown method name, a step that is not positive,
    backward Euler without its spring network."""


class AnimatorTimeError(AdapterError, ValueError):
    """The animator cannot give this time: negative or not finite."""


class TimeBehindError(AnimatorTimeError):
    """A time behind the animator, which only marches forward: restore a checkpoint or
    reset() first."""


class CheckpointError(AdapterError, ValueError):
    """A checkpoint of another scene (its step or node count differ) handed to restore()."""
