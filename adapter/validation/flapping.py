"""Validation case 3: a heaving and pitching NACA 0012 (Read, Hover & Triantafyllou 2003, J.
Fluids Struct. 17: 163-183), the flow the flukes make (docs/validation.md, "Heaving and
pitching NACA 0012").

The foil of :mod:`adapter.validation.foil` (c = 1 m, U = 1 m/s, Re = 40,000) heaves
``h(t) = h0 sin(w t)`` with h0 = 0.75 c and pitches about c/3 by ``theta(t) = theta0 sin(w t +
90 deg)`` (pitch leads heave by 90 deg; theta nose-up), so that the angle of attack
``alpha(t) = theta(t) - atan(h'(t) / U)`` reaches ``alpha_max`` = 15 deg at mid-stroke:
``theta0 = atan(pi St) - alpha_max``, St = f 2 h0 / U (Read et al.'s definitions). The motion
is the scene's ``[rigid]`` option, served by the step-server (its surface: the closed STL of
the mesh's own wall points, so that the mapping is exact) to ``stepServerDisplacement``, the
mesh moved by ``whaleBlendedDisplacement`` with ``rotation yes`` (rigid within innerDistance);
whaleLoads integrates force and power: ``CT = mean(-Fx) / (0.5 rho U^2 c s)`` and the
propulsive efficiency ``eta = mean(-Fx) U / mean(P)``, P = -sum F_f . U_f the power the foil
puts into the water (adapter/foam/loads.py), over the whole cycles after the ramp-in.

Laminar: at Re = 40,000 the boundary layer over a chord is laminar (a flat plate's transition
is at Re_x of about 5e5), and the forces of a foil at these angles are those of the leading-edge
vortex it sheds, pressure forces that no turbulence model of the whale's (kOmegaSST, fully
turbulent from the leading edge) would improve; what 2D laminar flow misses is the
three-dimensional break-up of those vortices in the experiment (aspect ratio 6, end plates).

Reference: Read et al. 2003's measurements for h0/c = 0.75, psi = 90 deg, alpha_max = 15 deg
(their thrust coefficient and efficiency against St, the alpha_max = 15 deg curves), as
replotted against a boundary-element model by Pan, Dong, Zhu & Yue (2012, J. Fluid Mech. 698:
446-467, their figure 9 a and g) and digitised in a public Puffer.jl script (file 32451731811
of the code index, read 2026-12-01; the paper itself was not readable here, so the values are
second-hand digitisations, about +-0.01 in CT and eta).
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from adapter.coupling.protocol import CONNECT_TIMEOUT_S, REPLY_TIMEOUT_S
from adapter.errors import CaseError
from adapter.foam.dictionaries import parsed_dict, plugin_lib
from adapter.foam.stepserver import start_server, stop_server
from adapter.validation import foil
from adapter.validation.suite import CaseResult, Check

REYNOLDS = 40_000.0
SPEED = 1.0
RHO = 1025.0
HEAVE = 0.75                 # h0 / c
PIVOT = 1.0 / 3.0            # x / c
ALPHA_MAX_DEG = 15.0
STROUHALS = (0.2, 0.3, 0.4)
#: Read et al. 2003 (module docstring): St, CT and St, eta of the alpha_max = 15 deg curves
READ_ST_CT = ((0.2021, 0.2504, 0.3030, 0.3499, 0.4024),
              (0.2276, 0.3108, 0.3939, 0.4770, 0.5878))
READ_ST_ETA = ((0.2000, 0.2517, 0.3007, 0.3510, 0.4014),
               (0.6886, 0.6409, 0.6000, 0.5864, 0.5523))
SOURCE = ("Read et al. 2003, h0/c 0.75, psi 90, alpha_max 15 (via Pan et al. 2012 fig. 9a, g, "
          "digitised)")
TOLERANCE = 0.20
#: the real mesh (~15,600 cells, first cell 1e-3 c: y+ about 1 at Re 40,000) and the quick one
REAL = foil.FoilMesh(n_front=40, n_rear=50, n_wake=40, n_normal=60, first_cell=1e-3,
                     radius=15.0, wake=15.0, le_cell=0.005, te_cell=0.005)
QUICK = foil.FoilMesh(n_front=6, n_rear=6, n_wake=4, n_normal=8, first_cell=5e-3,
                      radius=10.0, wake=10.0, le_cell=0.03, te_cell=0.03)
#: cycles: the ramp-in (discarded), then the measured ones; steps a cycle
RAMP_CYCLES = 1
CYCLES = {True: 0.02, False: 2}
STEPS_PER_CYCLE = {True: 400, False: 600}
#: whaleBlendedDisplacement: rigid within INNER chords of the foil, still beyond OUTER
INNER, OUTER = 1.0, 8.0


def pitch_amplitude_deg(st: float, heave: float = HEAVE, alpha_max: float = ALPHA_MAX_DEG,
                        ) -> float:
    """theta0 (deg) for alpha_max at mid-stroke: atan(w h0 / U) - alpha_max, w h0 / U = pi St
    (St = f 2 h0 / U). Raises :class:`~adapter.errors.CaseError` when the heave alone stays
    under alpha_max (theta0 would be negative: the foil would pitch against the flow)."""
    if not st > 0:
        raise CaseError(f"Strouhal number {st!r}: give a positive number")
    theta = math.degrees(math.atan(math.pi * st)) - alpha_max
    if theta < 0:
        raise CaseError(f"St = {st:g}: the heave's own angle of attack "
                        f"{math.degrees(math.atan(math.pi * st)):.1f} deg is under alpha_max = "
                        f"{alpha_max:g} deg; raise St or lower alpha_max")
    return theta


def frequency_hz(st: float, heave: float = HEAVE, chord: float = 1.0,
                 speed: float = SPEED) -> float:
    """f = St U / (2 h0)."""
    return st * speed / (2 * heave * chord)


def thrust_and_efficiency(fx, power, q_area: float, speed: float) -> tuple:
    """(CT, eta) of whole cycles of samples: CT = mean(-Fx) / q_area, eta = mean(-Fx) U /
    mean(P), NaN when the mean power is not positive (the foil takes energy from the flow: no
    propulsive efficiency). Raises :class:`~adapter.errors.CaseError` for no samples or
    samples that are not finite."""
    fx, power = np.asarray(fx, dtype=float), np.asarray(power, dtype=float)
    if fx.size == 0 or fx.size != power.size or not np.isfinite(fx).all() \
            or not np.isfinite(power).all():
        raise CaseError(f"{fx.size} force and {power.size} power samples, all finite "
                        "expected")
    thrust, p = float(-fx.mean()), float(power.mean())
    return thrust / q_area, (thrust * speed / p if p > 0 else math.nan)


def read_reference(st: float) -> tuple:
    """Read et al.'s (CT, eta) at ``st``, interpolated linearly in their digitised curves;
    None outside the curves' range."""
    (s1, ct), (s2, eta) = READ_ST_CT, READ_ST_ETA
    if not (min(s1) - 0.005 <= st <= max(s1) + 0.005):
        return None, None
    return float(np.interp(st, s1, ct)), float(np.interp(st, s2, eta))


def scene_text(stl: Path, st: float, mesh: foil.FoilMesh, ramp: float) -> str:
    """The step-server's scene: the foil's STL in the rigid heave and pitch at ``st``, ramped
    in over ``ramp`` cycles."""
    c = mesh.chord
    return f"""# the heaving and pitching foil of adapter/validation/flapping.py, St = {st:g}
[geometry]
source = "{stl.name}"
length_m = {c!r}

[rigid]
enabled = true
frequency_hz = {frequency_hz(st, chord=c)!r}
translation_m = [0.0, {HEAVE * c!r}, 0.0]
translation_phase_deg = 0.0
# nose-up theta: the leading edge up, a turn about -z
rotation_deg = {pitch_amplitude_deg(st)!r}
rotation_phase_deg = 90.0
rotation_axis = [0.0, 0.0, -1.0]
rotation_centre_m = [{PIVOT * c!r}, 0.0, 0.0]
ramp_cycles = {ramp!r}

[flow]
speed_m_s = {SPEED!r}
rho_kg_m3 = {RHO!r}
nu_m2_s = {SPEED * c / REYNOLDS!r}
"""


def set_motion(case: Path, st: float, mesh: foil.FoilMesh, quick: bool) -> dict:
    """The moving case: the step-server's boundary condition on the foil, the blended mesh
    motion, the time step and the run's length; returns the run's times."""
    c = mesh.chord
    period = 1.0 / frequency_hz(st, chord=c)
    steps = STEPS_PER_CYCLE[quick]
    cycles = RAMP_CYCLES + CYCLES[quick] if not quick else CYCLES[quick]
    n_steps = max(3, int(round(cycles * steps)))
    d = parsed_dict(case / "constant" / "dynamicMeshDict")
    d["dynamicFvMesh"] = "dynamicMotionSolverFvMesh"
    d["motionSolver"] = "whaleBlendedDisplacement"
    d["motionSolverLibs"] = [f'"{plugin_lib()}"']
    coeffs = d["whaleBlendedDisplacementCoeffs"]
    for key, value in (("innerDistance", INNER * c), ("outerDistance", OUTER * c),
                       ("rotation", "yes"), ("rotationDistance", OUTER * c),
                       ("checkMotion", "yes")):
        coeffs[key] = value
    d.writeFile()
    d = parsed_dict(case / "0.orig" / "pointDisplacement")
    d["boundaryField"][foil.WALL] = {
        "type": "stepServerDisplacement", "connectTimeout": CONNECT_TIMEOUT_S,
        "replyTimeout": REPLY_TIMEOUT_S, "rhoInf": RHO, "value": "uniform (0 0 0)"}
    d.writeFile()
    d = parsed_dict(case / "system" / "controlDict")
    d["deltaT"] = period / steps
    d["endTime"] = n_steps * period / steps
    d["writeInterval"] = steps
    d["purgeWrite"] = 2
    d.writeFile()
    return {"period_s": period, "steps": n_steps, "dt_s": period / steps}


def run_strouhal(case: Path, st: float, mesh: foil.FoilMesh, quick: bool, ranks: int) -> dict:
    """Prepare, mesh and run one Strouhal number with the step-server; its figures."""
    foil.prepare_foil_case(case, mesh, speed=SPEED, nu=SPEED * mesh.chord / REYNOLDS, rho=RHO,
                           alpha_deg=0.0, turbulence=False, ranks=ranks)
    times = set_motion(case, st, mesh, quick)
    info = foil.mesh_foil(case)
    stl = foil.write_wall_stl(case, case / "foil.stl")
    scene = case / "foil.toml"
    scene.write_text(scene_text(stl, st, mesh, 0.0 if quick else RAMP_CYCLES))
    t0 = time.perf_counter()
    server = start_server(case, {"scene_file": str(scene)})
    try:
        foil.run_solver(case, ranks)
    finally:
        stop_server(server)
    wall = time.perf_counter() - t0
    return {**info, **times, **strouhal_figures(case, times, mesh, quick), "solver_s": wall}


def strouhal_figures(case: Path, times: dict, mesh: foil.FoilMesh, quick: bool) -> dict:
    """CT and eta over the whole cycles after the ramp-in (quick: every step), the thrust's
    pressure part, and the change of CT between the last two of those cycles."""
    loads = foil.wall_loads(case)
    w = foil.WALL
    t, period = loads["Time"], times["period_s"]
    q_area = foil.force_scale(mesh, RHO, SPEED)
    start = 0.0 if quick else RAMP_CYCLES * period
    cycles = max(1, int(math.floor((t[-1] - start) / period + 1e-6)))
    per_cycle = []
    for k in range(cycles):
        sel = (t > start + k * period + 1e-9) & (t <= start + (k + 1) * period + 1e-9)
        if quick:
            sel = t > 0
        per_cycle.append(thrust_and_efficiency(loads[f"{w}:Fx"][sel], loads[f"{w}:P"][sel],
                                               q_area, SPEED))
    sel = t > start + 1e-9
    ct_p = float(-loads[f"{w}:Fpx"][sel].mean() / q_area)
    ct, eta = thrust_and_efficiency(loads[f"{w}:Fx"][sel], loads[f"{w}:P"][sel], q_area, SPEED)
    change = abs(per_cycle[-1][0] - per_cycle[-2][0]) / abs(ct) if len(per_cycle) > 1 \
        else math.nan
    return {"ct": ct, "eta": eta, "ct_pressure": ct_p, "cycles": cycles,
            "ct_cycle_change": change}


def run(out_dir, *, ranks: int = 1, quick: bool = False) -> CaseResult:
    """Each Strouhal number in ``out_dir/St<st>``; CT and eta against Read et al."""
    out = Path(out_dir)
    mesh = QUICK if quick else REAL
    sts = STROUHALS[:1] if quick else STROUHALS
    figs = {st: run_strouhal(out / f"St{st:g}", st, mesh, quick, ranks) for st in sts}
    rows = []
    for st, f in figs.items():
        ct_ref, eta_ref = read_reference(st)
        rows += [
            Check(f"CT at St {st:g}", f["ct"], ct_ref, TOLERANCE, source=SOURCE),
            Check(f"eta at St {st:g}", f["eta"], eta_ref, TOLERANCE, source=SOURCE),
            Check(f"  pressure part of CT at St {st:g}", f["ct_pressure"]),
            Check(f"  CT change, last two cycles, St {st:g}", f["ct_cycle_change"]),
            Check(f"  pitch amplitude theta0 at St {st:g}", pitch_amplitude_deg(st), unit="deg"),
        ]
    foil.plain_floats(rows)
    first = figs[sts[0]]
    notes = [f"{first['steps']} steps at St {sts[0]:g} (dt = T / {STEPS_PER_CYCLE[quick]}), "
             f"{first['cycles']} measured cycle(s) after a {0 if quick else RAMP_CYCLES}-cycle "
             "ramp; solver "
             + ", ".join(f"{f['solver_s']:.0f} s" for f in figs.values())
             + f"; worst non-orthogonality at rest "
             f"{first.get('max_non_orthogonality', math.nan):.1f} deg",
             "laminar at Re 40,000 (module docstring)"]
    if quick:
        notes.append("quick: a tiny mesh and a few steps, the machinery only")
    return CaseResult(name="flapping", title="heaving and pitching NACA 0012, Re 40,000",
                      checks=rows, cells=mesh.cells, ranks=ranks, case_dir=str(out),
                      notes=notes)
