"""A sphere oscillating in still water: the added mass of potential flow.

A sphere of radius R moved rigidly along x, ``x(t) = X sin(w t)``, in fluid at rest feels, in
potential flow, the reaction of its added mass ``m_a = 0.5 rho (4/3 pi R^3)``: the force
``F(t) = -m_a x''(t) = m_a X w^2 sin(w t)``, whose amplitude is ``m_a X w^2`` (about 530 N for
R = 1 m, X = 0.1 m, T = 4 s, rho = 1025 kg/m3) and which is in phase with ``-x''``, so that the
power the body puts into the water, ``P = -F . u``, averages to zero over a cycle (the added
mass stores energy and gives it back). The viscous part, the Stokes layer's, is of order
``delta / R`` with ``delta = sqrt(2 nu / w)`` (1.1 mm here): under 1 % at this Stokes number.
A finite domain raises the added mass: for a sphere in a concentric sphere of radius b it is
``m_a (1 + 2 (R/b)^3) / (1 - (R/b)^3)`` (Lamb, Hydrodynamics, section 92), the reference here
with b the distance to the nearest domain face.

The case is the whale's: the sphere's STL meshed by run-case's snappyHexMesh with its layer
rules, the ``[rigid]`` scene option served by the step-server to ``stepServerDisplacement``,
``whaleBlendedDisplacement`` moving the mesh, ``whaleLoads`` integrating force and power, the
template's pimpleFoam settings (laminar). The measured force is fitted over the third cycle
with ``a sin(w t) + b cos(w t) + c``.
"""

from __future__ import annotations

import dataclasses
import math
import time
from pathlib import Path

import numpy as np

from adapter.validation.suite import CaseResult, Check

RADIUS_M = 1.0
AMPLITUDE_M = 0.1
PERIOD_S = 4.0
RHO = 1025.0
NU = 1.0e-6
#: domain faces this many radii from the centre (the finite-domain correction is 0.5 % at 10)
DOMAIN_RADII = 10.0
CYCLES = 3


def added_mass(radius: float = RADIUS_M, rho: float = RHO) -> float:
    """Potential-flow added mass of a sphere in unbounded fluid (kg)."""
    return 0.5 * rho * 4.0 / 3.0 * math.pi * radius**3


def confined_added_mass(radius: float, outer: float, rho: float = RHO) -> float:
    """Added mass of a sphere at the centre of a fixed concentric sphere of radius ``outer``
    (Lamb 1932, section 92)."""
    q = (radius / outer) ** 3
    return added_mass(radius, rho) * (1 + 2 * q) / (1 - q)


def force_amplitude(mass: float, amplitude: float = AMPLITUDE_M,
                    period: float = PERIOD_S) -> float:
    """Amplitude of ``m_a x''`` for ``x = X sin(w t)`` (N)."""
    return mass * amplitude * (2 * math.pi / period) ** 2


def stokes_layer_m(period: float = PERIOD_S, nu: float = NU) -> float:
    """Thickness sqrt(2 nu / w) of the oscillating boundary layer (m)."""
    return math.sqrt(2 * nu / (2 * math.pi / period))


def stokes_mean_power(radius: float = RADIUS_M, amplitude: float = AMPLITUDE_M,
                      period: float = PERIOD_S, rho: float = RHO, nu: float = NU) -> float:
    """Cycle-mean power (W) of the dissipative force on a sphere oscillating with a thin
    Stokes layer, ``6 pi mu R (1 + R / delta) u`` (Landau & Lifshitz, Fluid Mechanics, s. 24,
    problem 5)."""
    omega = 2 * math.pi / period
    speed = amplitude * omega
    force = 6 * math.pi * rho * nu * radius * (1 + radius / stokes_layer_m(period, nu)) * speed
    return 0.5 * force * speed


def fit_harmonic(t: np.ndarray, f: np.ndarray, omega: float) -> tuple[float, float, float]:
    """Least-squares ``f = a sin(w t) + b cos(w t) + c``: (a, b, c)."""
    basis = np.column_stack([np.sin(omega * t), np.cos(omega * t), np.ones_like(t)])
    (a, b, c), *_ = np.linalg.lstsq(basis, f, rcond=None)
    return float(a), float(b), float(c)


def icosphere(radius: float, subdivisions: int) -> tuple[np.ndarray, np.ndarray]:
    """A closed triangulated sphere: an icosahedron subdivided ``subdivisions`` times, every
    vertex projected onto the sphere; outward triangles."""
    g = (1 + 5**0.5) / 2
    v = [(-1, g, 0), (1, g, 0), (-1, -g, 0), (1, -g, 0), (0, -1, g), (0, 1, g), (0, -1, -g),
         (0, 1, -g), (g, 0, -1), (g, 0, 1), (-g, 0, -1), (-g, 0, 1)]
    f = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
         (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8),
         (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    points = [np.array(p, dtype=np.float64) / np.linalg.norm(p) for p in v]
    faces = f
    for _ in range(subdivisions):
        mid: dict = {}
        new = []
        for a, b, c in faces:
            ab, bc, ca = (_middle(points, mid, i, j) for i, j in ((a, b), (b, c), (c, a)))
            new += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        faces = new
    return radius * np.array(points), np.array(faces, dtype=np.int64)


def _middle(points: list, mid: dict, i: int, j: int) -> int:
    """The index of the unit point halfway between points i and j (added once per edge)."""
    key = (min(i, j), max(i, j))
    if key not in mid:
        m = points[i] + points[j]
        points.append(m / np.linalg.norm(m))
        mid[key] = len(points) - 1
    return mid[key]


def scene_text(stl: Path, *, quick: bool, ranks: int) -> str:
    """The scene: the sphere's STL in rigid motion along x, still water, laminar."""
    length = 2 * RADIUS_M
    # the domain in body lengths: `radii` from the centre to every face
    radii = 3.0 if quick else DOMAIN_RADII
    span = (radii * RADIUS_M - RADIUS_M) / length
    cell, refine, layers = (0.5, "[2, 2]", 0) if quick else (0.5, "[4, 5]", 3)
    end = 0.4 if quick else CYCLES * PERIOD_S
    return f"""# the oscillating sphere of adapter/validation/sphere.py
[geometry]
source = "{stl.name}"
length_m = {length}

[rigid]
enabled = true
frequency_hz = {1 / PERIOD_S}
translation_m = [{AMPLITUDE_M}, 0.0, 0.0]

[flow]
speed_m_s = 0.0
rho_kg_m3 = {RHO}
nu_m2_s = {NU}

[case]
upstream = {span}
downstream = {span}
half_width = {radii * RADIUS_M / length}
background_cell = {cell}
refinement = {refine}
layers = {layers}
layer_non_orthogonality = 75.0   # as validated (docs/validation.md); the whale's default is lower
symmetry = "off"                 # the whole domain: the added mass's confinement is its radius
turbulence = "laminar"
outer_correctors = 2             # as validated (docs/validation.md); the whale's default is 3
dt_s = {PERIOD_S / 100}
end_time_s = {end}
writes_per_cycle = 1
inflow_ramp_cycles = 0.0
gliding = false
ranks = {ranks}
motion_inner = 0.05
motion_outer = 2.0
"""


#: the runs: (label, time scheme); the first is the whale case's template as it is
VARIANTS = (("Euler", "Euler"), ("backward", "backward"))


def run(out_dir, *, ranks: int = 1, quick: bool = False) -> CaseResult:
    """Mesh and run the oscillating sphere with each time scheme of :data:`VARIANTS`; its
    force against the added mass. A case folder that has run is read again, not rerun."""
    from adapter.body.meshfile import write_surface
    from adapter.foam.loads import read_loads
    from adapter.scene import load_scene

    t0 = time.perf_counter()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    stl = out / "sphere.stl"
    points, faces = icosphere(RADIUS_M, 2 if quick else 4)
    write_surface(stl, points, [faces])
    scene_file = out / "sphere.toml"
    scene_file.write_text(scene_text(stl, quick=quick, ranks=ranks))
    scene = load_scene(scene_file)
    checks, notes, cells = [], [], 0
    for label, ddt in VARIANTS[:1] if quick else VARIANTS:
        case = out / f"case-{label}"
        run_variant(scene, scene_file, case, ddt, ranks)
        result = evaluate(read_loads(case), case, quick)
        checks += [dataclasses.replace(c, name=f"{label}: {c.name}") for c in result.checks]
        notes += [f"{label}: {n}" for n in result.notes]
        cells = result.cells
    return CaseResult("sphere", "sphere oscillating in still water", checks, cells=cells,
                      ranks=ranks, wall_s=time.perf_counter() - t0, case_dir=str(out),
                      notes=notes)


def run_variant(scene, scene_file: Path, case: Path, ddt: str, ranks: int) -> None:
    """Prepare, mesh and run one case with the time scheme ``ddt`` (``case.time_scheme``)."""
    from adapter.foam.case import prepare_case
    from adapter.foam.mesh import mesh_case
    from adapter.foam.run import run_case

    if not (case / "system" / "controlDict").exists():
        prepare_case(scene.replace(case={"time_scheme": ddt}), case, ranks=ranks,
                     scene_file=scene_file)
    if not (case / "constant" / "polyMesh" / "owner").exists():
        mesh_case(case, ranks=ranks)
    run_case(case, ranks=ranks, progress=False)


def evaluate(data: dict, case: Path, quick: bool) -> CaseResult:
    """The checks of a run's loads columns: the last whole cycle's force and power."""
    from adapter.foam.case import Case

    record = Case(case).record
    omega = 2 * math.pi / PERIOD_S
    t = data["Time"]
    window = (t > t[-1] - PERIOD_S + 1e-9) if not quick else np.ones_like(t, dtype=bool)
    tw = t[window]
    fx, fp, fv = (data[k][window] for k in ("total:Fx", "total:Fpx", "total:Fvx"))
    power = data["total:P"][window]
    a, b, _ = fit_harmonic(tw, fx, omega)
    ap, bp, _ = fit_harmonic(tw, fp, omega)
    av, bv, _ = fit_harmonic(tw, fv, omega)
    amp = math.hypot(a, b)
    # the reference force is +sin(w t): the phase of the fit from it (deg, + leads)
    phase = math.degrees(math.atan2(b, a))
    mesh = record.get("mesh", {})
    # the body rests at the origin: the nearest domain face
    par = record["parameters"]
    half = float(np.min(np.abs([*par["domain_min"], *par["domain_max"]])))
    ref_mass = confined_added_mass(RADIUS_M, half)
    ref_amp = force_amplitude(ref_mass)
    reactive = 0.5 * ref_mass * AMPLITUDE_M**2 * omega**3
    checks = [
        Check("force amplitude (pressure + viscous)", amp, ref_amp, 0.03, "N",
              source="m_a X w^2, m_a = 0.5 rho V (Lamb 1932, s. 92, confined)"),
        Check("phase of F against -x''", phase, 0.0, 3.0, "deg", absolute=True,
              source="potential flow: in phase"),
        Check("cycle-mean power / peak reactive power", float(power.mean()) / reactive, 0.0,
              0.01, absolute=True, source="potential flow: no mean power"),
        Check("Stokes layer's mean power / peak reactive power (theory)",
              stokes_mean_power() / reactive),
        Check("pressure part, amplitude", math.hypot(ap, bp), unit="N"),
        Check("viscous part, amplitude", math.hypot(av, bv), unit="N"),
        Check("viscous part / total", math.hypot(av, bv) / amp if amp else math.nan,
              0.0, 0.01, absolute=True, source="Stokes layer: O(delta/R), delta = "
              f"{1e3 * stokes_layer_m():.2f} mm"),
    ]
    notes = [f"reference added mass {ref_mass:.1f} kg (unbounded {added_mass():.1f} kg; "
             f"domain faces {half:.3g} m from the centre)",
             f"fit over t = {tw[0]:.2f}..{tw[-1]:.2f} s, {len(tw)} steps"]
    if quick:
        notes.append("quick: a tiny mesh and a few steps, the machinery only")
    return CaseResult("sphere", "sphere oscillating in still water", checks,
                      cells=int(mesh.get("cells", 0)), case_dir=str(case), notes=notes)
