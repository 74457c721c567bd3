"""The scene: one TOML file holding every parameter of a run.

A scene is a tree of frozen dataclasses. :func:`load_scene` reads a TOML file on top of the
built-in defaults (``adapter/data/scenes/default.toml``), so a user's file only names what it
changes. Every key is checked at load: an unknown key or a bad value raises
:class:`~adapter.errors.SceneError` naming its path in the file, e.g. ``springs.mu``. Units are
SI; positions along the body are fractions of the body length L from the rostrum.
"""

from __future__ import annotations

import dataclasses
import typing
from dataclasses import dataclass, field
from pathlib import Path

from adapter.errors import SceneError
from adapter.scenevalues import convert, describe, read_toml
from adapter.scenevalues import within as _within

PRESETS = ("default", "smoke", "fine")
DATA_DIR = Path(__file__).parent / "data"


_positive, _non_negative, _fraction = _within(0, ends="()"), _within(0), _within(0, 1)


@dataclass(frozen=True)
class Geometry:
    """Whale surface: the built-in procedural right whale, or any closed surface mesh file."""

    source: str = "procedural"  #: "procedural" or a path to a mesh meshio can read
    length_m: float = field(default=15.0, metadata={"check": _positive})
    nodes: int = field(default=11272, metadata={"check": _within(400, 2_000_000)})
    fluke_span: float = field(default=0.32, metadata={"check": _within(0.1, 0.5)})  #: of L
    #: the fins' sections: "naca" (hydrofoils, docs/geometry.md) or the old "ellipse"
    fin_sections: str = field(default="naca", metadata={"choices": ("naca", "ellipse")})
    #: the flippers' root on the flank: "foil" (the root section's footprint) or "rectangle"
    flipper_root: str = field(default="foil", metadata={"choices": ("foil", "rectangle")})
    #: the flukes' root on the tail stock: "foil" (the root section's footprint) or "rectangle"
    fluke_root: str = field(default="rectangle", metadata={"choices": ("foil", "rectangle")})
    #: false: the procedural body without its flippers (their drag as a difference of two runs)
    flippers: bool = True
    landmarks: dict = field(default_factory=dict)  #: a mesh file's LANDMARKS, its coordinates (m)
    landmark_tolerance: float = field(default=0.01, metadata={"check": _positive})


@dataclass(frozen=True)
class Regions:
    """Regions along the body (fractions of L from the rostrum)."""

    head_end: float = field(default=0.27, metadata={"check": _fraction})
    tail_start: float = field(default=0.55, metadata={"check": _fraction})


@dataclass(frozen=True)
class Springs:
    """Spring constants (per node, N/m for unit mass), damping mu and fluid resistance nu."""

    k_pivot: float = field(default=400.0, metadata={"check": _positive})
    k_head: float = field(default=40.0, metadata={"check": _positive})
    k_tail: float = field(default=40.0, metadata={"check": _positive})
    #: width of the smooth step between region constants, fraction of L
    transition: float = field(default=0.05, metadata={"check": _positive})
    stiffness_scale: float = field(default=1.0, metadata={"check": _positive})
    mu: float = field(default=0.5, metadata={"check": _non_negative})
    nu: float = field(default=0.05, metadata={"check": _non_negative})
    #: "paper": k_j of the neighbour node (pair forces unequal); "symmetric": (k_i + k_j) / 2
    form: str = field(default="paper", metadata={"choices": ("paper", "symmetric")})


@dataclass(frozen=True)
class Stroke:
    """The prescribed stroke (paper section 3.1) and the fluke gate."""

    frequency_hz: float = field(default=0.13, metadata={"check": _positive})
    pivot: float = field(default=0.40, metadata={"check": _fraction})
    #: initial vertical speed at the tail base and at the rostrum (m/s), before velocity_scale
    tail_speed: float = field(default=1.0, metadata={"check": _non_negative})
    head_speed: float = field(default=0.3, metadata={"check": _non_negative})
    tail_exponent: float = field(default=2.0, metadata={"check": _positive})
    head_exponent: float = field(default=1.0, metadata={"check": _positive})
    #: where the head profile crosses zero (fraction of L; 0 drops the flippers' dip)
    head_node: float = field(default=0.2, metadata={"check": _fraction})
    #: "heave": remove the profile's net vertical momentum (recoil), "none": keep it
    recoil: str = field(default="none", metadata={"choices": ("heave", "none")})
    velocity_scale: float = field(default=1.0, metadata={"check": _positive})
    #: fluke angle table: "default" (shipped data file) or a path to a CSV (phase, angle_deg)
    fluke_table: str = "default"
    fluke_angle_scale: float = field(default=1.0, metadata={"check": _non_negative})
    #: the fluke angle ramps in from flat over this fraction of the first cycle ("negate")
    fluke_ramp: float = field(default=0.25, metadata={"check": _within(0, 4)})
    #: the fluke's turn blended in over this length ahead of the tail base (L); 0: the hinge
    fluke_joint: float = field(default=0.0, metadata={"check": _within(0, 0.1)})
    #: "smooth" (continuous wall velocity) or "negate" (the paper: velocities negated)
    reversal: str = field(default="smooth", metadata={"choices": ("smooth", "negate")})
    #: "smooth": the stroke and the fluke angle ramp in from rest over this many cycles
    ramp_cycles: float = field(default=1.0, metadata={"check": _within(0, 10)})
    #: "smooth": the nodes' critically damped tether's frequency, x frequency_hz (0: none)
    tether: float = field(default=4.0, metadata={"check": _non_negative})


@dataclass(frozen=True)
class Calibration:
    """Targets for ``whale-adapter calibrate``."""

    #: peak-to-peak fluke-tip amplitude as a fraction of L
    fluke_amplitude: float = field(default=0.2, metadata={"check": _positive})
    tolerance: float = field(default=0.02, metadata={"check": _positive})


@dataclass(frozen=True)
class Integrator:
    """Time integration of the spring-mass system."""

    method: str = field(
        default="forward_euler",
        metadata={"choices": ("forward_euler", "symplectic_euler", "verlet", "rk4",
                              "backward_euler")},
    )
    #: internal step (s); 0 chooses the largest stable step times ``safety``
    dt_s: float = field(default=0.0, metadata={"check": _non_negative})
    safety: float = field(default=0.5, metadata={"check": _within(0, 1, "(]")})


@dataclass(frozen=True)
class Rigid:
    """A rigid prescribed motion of any closed body instead of the stroke (docs/scene.md)."""

    enabled: bool = False
    frequency_hz: float = field(default=0.25, metadata={"check": _positive})
    translation_m: tuple = field(default=(0.0, 0.0, 0.0), metadata={"vector": True})
    translation_phase_deg: float = 0.0
    rotation_deg: float = 0.0
    rotation_phase_deg: float = 0.0
    rotation_axis: tuple = field(default=(0.0, 0.0, 1.0), metadata={"vector": True})
    rotation_centre_m: tuple = field(default=(0.0, 0.0, 0.0), metadata={"vector": True})
    ramp_cycles: float = field(default=0.0, metadata={"check": _within(0, 10)})


@dataclass(frozen=True)
class Flow:
    """The water and the swimming speed."""

    speed_m_s: float = field(default=1.3, metadata={"check": _non_negative})
    rho_kg_m3: float = field(default=1025.0, metadata={"check": _positive})
    nu_m2_s: float = field(default=1.0e-6, metadata={"check": _positive})


@dataclass(frozen=True)
class Output:
    """Dry-run output."""

    cycles: int = field(default=2, metadata={"check": _within(1)})
    frames_per_cycle: int = field(default=24, metadata={"check": _within(4)})
    samples_per_cycle: int = field(default=120, metadata={"check": _within(8)})


@dataclass(frozen=True)
class Case:
    """The OpenFOAM whale-in-channel case (foam_case/)."""

    #: domain, in body lengths: upstream of the rostrum, downstream of the flukes, half size in y, z
    upstream: float = field(default=1.5, metadata={"check": _positive})
    downstream: float = field(default=3.0, metadata={"check": _positive})
    half_width: float = field(default=1.5, metadata={"check": _positive})
    #: background blockMesh cell size, in body lengths (the body's own length)
    background_cell: float = field(default=2.0 / 15.0, metadata={"check": _positive})
    #: the same in metres when > 0 (the older key): it wins over background_cell
    background_cell_m: float = field(default=0.0, metadata={"check": _non_negative})
    #: snappyHexMesh surface refinement levels (min, max)
    refinement: tuple = field(default=(2, 4))
    #: snappyHexMesh level near the flippers and the flukes' blade (0: none; docs/scene.md)
    flipper_level: int = field(default=5, metadata={"check": _within(0, 8)})
    fluke_level: int = field(default=5, metadata={"check": _within(0, 8)})
    #: ... and at the forward tenth of their sections' chords (0: none; docs/case.md)
    flipper_edge_level: int = field(default=0, metadata={"check": _within(0, 8)})
    fluke_edge_level: int = field(default=0, metadata={"check": _within(0, 8)})
    fluke_clearance: float = field(default=12.0, metadata={"check": _non_negative})
    #: simulated stroke cycles; end time = cycles / frequency unless end_time_s > 0
    cycles: float = field(default=1.0, metadata={"check": _positive})
    end_time_s: float = field(default=0.0, metadata={"check": _non_negative})
    #: flow step (s); 0 chooses 0.5 * smallest cell / speed
    dt_s: float = field(default=0.0, metadata={"check": _non_negative})
    writes_per_cycle: int = field(default=4, metadata={"check": _within(1)})
    turbulence: str = field(default="kOmegaSST", metadata={"choices": ("kOmegaSST", "laminar")})
    #: PIMPLE's outer correctors a flow step (1: PISO-like; the mesh moves once a step)
    outer_correctors: int = field(default=1, metadata={"check": _within(1, 20)})
    #: PIMPLE's pressure correctors within each outer corrector (fvSolution nCorrectors)
    pressure_correctors: int = field(default=2, metadata={"check": _within(1, 20)})
    #: the flow's time scheme (fvSchemes ddtSchemes): first-order "Euler" or second-order
    #: "backward" (docs/case.md, "Time scheme")
    time_scheme: str = field(default="Euler", metadata={"choices": ("Euler", "backward")})
    ranks: int = field(default=0, metadata={"check": _within(0)})   # 0: the machine's cores
    #: the inflow ramps in from still water over this many stroke cycles (0: impulsive)
    inflow_ramp_cycles: float = field(default=0.5, metadata={"check": _non_negative})
    #: run-case also runs the whale gliding (same mesh, no stroke) for the drag baseline
    gliding: bool = True
    #: periodic state: cycle-to-cycle change of mean Fx (of the gliding drag) and mean power
    periodic_tolerance: float = field(default=0.02, metadata={"check": _positive})
    #: the largest non-orthogonality (deg) snappyHexMesh's layer stage may leave (its relaxed
    #: limit: the moving mesh starts from it and the stroke adds a few degrees)
    layer_non_orthogonality: float = field(default=69.0, metadata={"check": _within(0, 90, "()")})
    #: stop before cells invert: largest non-orthogonality (deg) allowed
    max_non_orthogonality: float = field(default=80.0, metadata={"check": _within(0, 90, "()")})
    #: prism layers on the whale (0: none), the first layer's thickness (m), their ratio
    layers: int = field(default=3, metadata={"check": _within(0, 20)})
    first_layer_m: float = field(default=0.007, metadata={"check": _positive})
    layer_expansion: float = field(default=1.5, metadata={"check": _within(1, 3)})
    #: the flippers' and flukes' own layers (0: the body's) and first layer (m), docs/case.md
    fin_layers: int = field(default=0, metadata={"check": _within(0, 20)})
    fin_first_layer_m: float = field(default=0.002, metadata={"check": _positive})
    #: how the mesh follows the whale: "blended" (whaleBlendedDisplacement, faded out between
    #: motion_inner and motion_outer body lengths) or "laplacian" (displacementLaplacian)
    mesh_motion: str = field(default="blended", metadata={"choices": ("blended", "laplacian")})
    motion_inner: float = field(default=1.0 / 30.0, metadata={"check": _non_negative})
    motion_outer: float = field(default=2.0 / 3.0, metadata={"check": _positive})
    #: each blended point follows this many whale points, weighted by 1 / distance**motion_power
    motion_neighbours: int = field(default=16, metadata={"check": _within(2, 1024)})
    motion_power: float = field(default=3.0, metadata={"check": _within(1, 6)})
    #: > 0: the weights are the whale points' areas within (1 + motion_shell) r_nearest, and
    #: with motion_clusters > 0 of cubes of them motion_clusters r_nearest across (docs/case.md)
    motion_shell: float = field(default=0.0, metadata={"check": _non_negative})
    motion_clusters: float = field(default=0.0, metadata={"check": _non_negative})
    #: > 0: the points also turn with the whale, in full within the prism layers and blended out
    #: over motion_rotation layer thicknesses beyond them (rotations fitted to so many points)
    motion_rotation: float = field(default=0.0, metadata={"check": _non_negative})
    motion_rotation_neighbours: int = field(default=16, metadata={"check": _within(3, 1024)})
    #: on several ranks (docs/cluster.md): launcher ("": mpirun; ``{np}``: the ranks), the
    #: decomposition, snappyHexMesh on the ranks, reconstructPar; symmetry "auto": half domain
    launcher: str = ""
    decomposition: str = "hierarchical"
    parallel_meshing: bool = False
    reconstruct: bool = False
    #: "mirror": the full domain meshed as the half and its mirror image (a mirror-symmetric mesh)
    symmetry: str = field(default="auto", metadata={"choices": ("auto", "off", "mirror")})


@dataclass(frozen=True)
class Free:
    """Free swimming (docs/free-swimming.md): the whale's forward speed from its forces."""

    #: run-case runs the free whale after the tethered one, from its last cycle
    enabled: bool = False
    #: at the release the speed goes from the tethered one to the pair's estimate of the
    #: self-propelled one over this many periods, forces not heeded (0: released as it is)
    approach_cycles: float = field(default=0.5, metadata={"check": _non_negative})
    #: the force's mean over a period acts on this fraction of the mass early on (1: never)
    light: float = field(default=0.2, metadata={"check": _within(0, 1, "(]")})
    light_cycles: float = field(default=10.0, metadata={"check": _non_negative})   # at most
    #: ... or until that running mean is under this fraction of the gliding drag (0: never)
    light_switch: float = field(default=0.0, metadata={"check": _non_negative})
    #: stop: cycle-mean speed change over the last two cycles measured, cycle-mean Fx of the drag
    speed_tolerance: float = field(default=0.005, metadata={"check": _positive})
    fx_tolerance: float = field(default=0.01, metadata={"check": _positive})
    cycles: float = field(default=10.0, metadata={"check": _positive})   # at most, after release
    #: surge added mass, fraction of the mass (0: the prolate spheroid of the body's L and D)
    added_mass: float = field(default=0.0, metadata={"check": _non_negative})
    #: recoil (docs/free-swimming.md): the swing of the vertical force moves the whale up and
    #: down, that of the pitching moment turns it about its centre of mass
    heave: bool = False
    pitch: bool = False


@dataclass(frozen=True)
class Scene:
    """Every parameter of a run. Build with :func:`load_scene`."""

    name: str = "default"
    geometry: Geometry = field(default_factory=Geometry)
    regions: Regions = field(default_factory=Regions)
    springs: Springs = field(default_factory=Springs)
    stroke: Stroke = field(default_factory=Stroke)
    rigid: Rigid = field(default_factory=Rigid)
    calibration: Calibration = field(default_factory=Calibration)
    integrator: Integrator = field(default_factory=Integrator)
    flow: Flow = field(default_factory=Flow)
    output: Output = field(default_factory=Output)
    case: Case = field(default_factory=Case)
    free: Free = field(default_factory=Free)
    #: folder the scene file came from; relative paths in the scene resolve against it
    base_dir: str = "."

    @property
    def period_s(self) -> float:
        """Duration of one full stroke cycle (s): of the rigid motion when it is enabled."""
        return 1.0 / (self.rigid.frequency_hz if self.rigid.enabled else
                      self.stroke.frequency_hz)

    def resolve(self, path: str) -> Path:
        """A path named in the scene file, relative to that file's folder."""
        p = Path(path).expanduser()
        return p if p.is_absolute() else Path(self.base_dir) / p

    def replace(self, **sections) -> Scene:
        """A copy with some fields of some sections changed: ``replace(springs={"mu": 1})``."""
        changes = {}
        for name, values in sections.items():
            current = getattr(self, name)
            if dataclasses.is_dataclass(current):
                changes[name] = _build(type(current), values, name, start=current)
            else:
                changes[name] = values
        return dataclasses.replace(self, **changes)


def _build(cls, table, path: str, start=None):
    if not isinstance(table, dict):
        raise SceneError(f"{path}: expected a table, got {describe(table)}")
    hints = typing.get_type_hints(cls)
    known = {f.name: f for f in dataclasses.fields(cls)}
    values = {}
    for key, value in table.items():
        sub = f"{path}.{key}" if path else key
        if key not in known or key == "base_dir":
            allowed = ", ".join(k for k in known if k != "base_dir")
            raise SceneError(f"{sub}: unknown key; allowed here: {allowed}")
        if dataclasses.is_dataclass(hints[key]):
            values[key] = _build(hints[key], value, sub, start=getattr(start, key, None))
        else:
            values[key] = convert(value, hints[key], sub, dict(known[key].metadata))
    obj = dataclasses.replace(start, **values) if start is not None else cls(**values)
    _check_relations(obj, path)
    return obj


def _check_relations(obj, path: str) -> None:
    if isinstance(obj, Stroke) and not obj.head_node < obj.pivot:
        raise SceneError(f"{path}.head_node must lie ahead of (be smaller than) {path}.pivot")
    if isinstance(obj, Regions) and not obj.head_end < obj.tail_start:
        raise SceneError(f"{path}.head_end must be smaller than {path}.tail_start")
    if isinstance(obj, Rigid) and not any(obj.rotation_axis):
        raise SceneError(f"{path}.rotation_axis: give a direction, not [0, 0, 0]")
    still = isinstance(obj, Scene) and obj.flow.speed_m_s == 0
    if still and not (obj.rigid.enabled and obj.case.dt_s > 0):
        raise SceneError("flow.speed_m_s = 0 (still water) needs rigid.enabled and case.dt_s > 0")
    ref = obj.refinement if isinstance(obj, Case) else (0, 0)
    if len(ref) != 2 or not 0 <= ref[0] <= ref[1] <= 8:
        raise SceneError(f"{path}.refinement: expected [min, max] levels with 0 <= min <= max <= 8")
    levels = ("flipper_level", "fluke_level", "flipper_edge_level", "fluke_edge_level")
    for key in levels if isinstance(obj, Case) else ():
        if 0 < getattr(obj, key) <= obj.refinement[0]:
            raise SceneError(f"{path}.{key} = {getattr(obj, key)} refines nothing (refinement "
                             f"min is {obj.refinement[0]}): give a level above it, or 0 for none")
    if isinstance(obj, Case) and obj.motion_clusters > 0 and not obj.motion_shell > 0:
        raise SceneError(f"{path}.motion_clusters needs {path}.motion_shell > 0 (the clusters "
                         "carry the whale points' areas): set both, or motion_clusters = 0")


def default_scene() -> Scene:
    """The built-in default scene (the paper's setting)."""
    return load_scene(preset="default")


def load_scene(path: str | Path | None = None, preset: str | None = None) -> Scene:
    """Load a scene: the defaults, then a preset, then the user's file.

    Parameters
    ----------
    path : a TOML file, or None for the preset alone.
    preset : ``default``, ``smoke`` or ``fine``; a file may also name one as ``preset = "..."``.
    """
    scene = Scene()
    data_dir = DATA_DIR / "scenes"
    user, where, base_dir = {}, "scene", "."
    if path is not None:
        path = Path(path)
        if not path.is_file():
            raise SceneError(f"scene file {path} does not exist; give an existing TOML file")
        where, base_dir = str(path), str(path.resolve().parent)
        user = read_toml(path.read_text(), where)
        file_preset = user.pop("preset", None)
        if file_preset is not None:
            if preset is not None and preset != file_preset:
                raise SceneError(f"{where}: preset {file_preset!r} conflicts with {preset!r}")
            preset = file_preset
    preset = preset or "default"
    if preset not in PRESETS:
        raise SceneError(f"{where}: preset: expected one of {', '.join(PRESETS)}; got {preset!r}")
    layers = [("default", (data_dir / "default.toml").read_text())]
    if preset != "default":
        layers.append((preset, (data_dir / f"{preset}.toml").read_text()))
    for name, text in layers:
        table = read_toml(text, f"built-in scene {name}")
        scene = _with_table(scene, table, f"built-in scene {name}")
    scene = dataclasses.replace(scene, name=preset)
    if user:
        scene = _with_table(scene, user, where)
    return dataclasses.replace(scene, base_dir=base_dir)


def _with_table(scene: Scene, table: dict, where: str) -> Scene:
    try:
        return _build(Scene, table, "", start=scene)
    except SceneError as exc:
        raise SceneError(f"{where}: {exc}") from None
