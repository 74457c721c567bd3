"""The numbers of a case: :func:`case_parameters`, a pure function of the scene and the whale's
bounding box, gives every number the case's dictionaries hold (:class:`CaseParameters`)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: inflow turbulence: intensity and free-stream eddy-viscosity ratio
TURBULENCE_INTENSITY = 0.01
EDDY_VISCOSITY_RATIO = 10.0


@dataclass(frozen=True)
class CaseParameters:
    """Every number prepare_case writes into the dictionaries (SI units).

    Attributes
    ----------
    domain_min, domain_max : (3,) corners of the blockMesh box (m).
    cells : (3,) background cell counts along x, y, z.
    cell_size : (3,) background cell size along x, y, z (m).
    smallest_cell_m : edge of a cell at the surface's highest refinement level (m): the
        automatic time step's cell (the prism layers and the flippers' cells are finer).
    flipper_cell_m : edge of a cell at ``case.flipper_level`` (m; 0 when none): also the
        distance from the flippers within which cells are refined to it.
    fluke_cell_m : the same for ``case.fluke_level`` and the flukes' blade.
    delta_t : flow time step (s), a binary fraction (a multiple of 2**-k s).
    time_precision : controlDict timePrecision: enough digits to name every time exactly.
    steps_per_write : time steps between writes.
    n_steps : time steps of the run (a whole number of write intervals).
    end_time : simulated end (s) = n_steps * delta_t.
    location_in_mesh : (3,) a point in the water, upstream of the rostrum (m).
    near_box_min, near_box_max : (3,) the refinement box around the whale (m).
    k_inlet, omega_inlet : inflow turbulence (m2/s2, 1/s).
    ranks : MPI ranks (1 is serial).
    inflow_ramp_s : the inflow ramps from still water to the scene's speed over this (s).
    motion_inner_m, motion_outer_m : whaleBlendedDisplacement's innerDistance and
        outerDistance (m): ``case.motion_inner`` / ``motion_outer`` body lengths, the outer one
        at most 0.8 of the gap between the body's bounding box and the nearest domain face
        (the outer boundaries stay put), the inner one at most half the outer one.
    rotation_inner_m, rotation_distance_m : with ``case.motion_rotation`` > 0, the blended
        points turn with the whale's local rotation fully within rotation_inner_m, the prism
        layers' thickness (the first layer's alone without layers), and not beyond
        rotation_distance_m, (1 + motion_rotation) times it; 0 and 0 without rotation.
    """

    domain_min: tuple
    domain_max: tuple
    cells: tuple
    cell_size: tuple
    smallest_cell_m: float
    flipper_cell_m: float
    fluke_cell_m: float
    delta_t: float
    time_precision: int
    steps_per_write: int
    n_steps: int
    end_time: float
    location_in_mesh: tuple
    near_box_min: tuple
    near_box_max: tuple
    k_inlet: float
    omega_inlet: float
    ranks: int
    inflow_ramp_s: float = 0.0
    motion_inner_m: float = 0.5
    motion_outer_m: float = 10.0
    rotation_inner_m: float = 0.0
    rotation_distance_m: float = 0.0


def stack_thickness(first: float, layers: int, expansion: float) -> float:
    """Total thickness of ``layers`` prism layers from ``first`` growing by ``expansion``."""
    if layers <= 0:
        return 0.0
    if abs(expansion - 1.0) < 1e-12:
        return first * layers
    return first * (expansion**layers - 1) / (expansion - 1)


def _layer_rotation(c) -> dict:
    """The rotation's reach with ``case.motion_rotation`` > 0: in full within the prism layers,
    blended out over motion_rotation layer thicknesses beyond them; 0 and 0 without."""
    stack = stack_thickness(c.first_layer_m, c.layers, c.layer_expansion) or c.first_layer_m
    inner = stack if c.motion_rotation > 0 else 0.0
    return {"rotation_inner_m": inner, "rotation_distance_m": (1 + c.motion_rotation) * inner}


def case_parameters(scene, bounds_min, bounds_max, ranks: int | None = None,
                    length: float | None = None) -> CaseParameters:
    """The case's numbers from the scene and the whale's bounding box.

    Parameters
    ----------
    scene : a :class:`~adapter.scene.Scene`.
    bounds_min, bounds_max : (3,) the whale surface's bounding box (m).
    ranks : MPI ranks; None takes ``scene.case.ranks``.
    length : the body's length L (m): the surface's own (``WhaleSurface.length``, what
        prepare_case passes); None takes ``scene.geometry.length_m``.

    The background cell is ``case.background_cell`` body lengths (``case.background_cell_m``
    metres when > 0). The domain reaches ``upstream`` body lengths before the rostrum,
    ``downstream`` after the flukes and ``half_width`` to each side and above and below the
    body's centre. The time step is ``0.5 * smallest cell / U`` unless ``case.dt_s > 0``;
    either is rounded down so that the write interval (one stroke cycle / ``writes_per_cycle``)
    is a whole number of steps, then down to a binary fraction (:func:`_binary_step`), and the
    end time is rounded up to a whole number of write intervals (at most a tenth of one short)
    so that a run ends on a written (restartable) time.
    """
    c = scene.case
    length = float(length) if length else scene.geometry.length_m
    cell = c.background_cell_m if c.background_cell_m > 0 else c.background_cell * length
    lo = np.asarray(bounds_min, dtype=float)
    hi = np.asarray(bounds_max, dtype=float)
    centre = 0.5 * (lo + hi)
    dmin = np.array([lo[0] - c.upstream * length, centre[1] - c.half_width * length,
                     centre[2] - c.half_width * length])
    dmax = np.array([hi[0] + c.downstream * length, centre[1] + c.half_width * length,
                     centre[2] + c.half_width * length])
    cells = np.maximum(1, np.round((dmax - dmin) / cell)).astype(int)
    size = (dmax - dmin) / cells
    smallest = float(size.min()) / 2 ** c.refinement[1]
    flipper_cell = level_cell_m(size, c.flipper_level) if c.flipper_level > 0 else 0.0
    fluke_cell = level_cell_m(size, c.fluke_level) if c.fluke_level > 0 else 0.0
    speed = scene.flow.speed_m_s
    dt = c.dt_s if c.dt_s > 0 else 0.5 * smallest / speed
    write_interval = scene.period_s / c.writes_per_cycle
    steps_per_write = max(1, math.ceil(write_interval / dt * (1 - 1e-12)))
    dt = _binary_step(write_interval / steps_per_write)
    write_interval = steps_per_write * dt
    end = c.end_time_s if c.end_time_s > 0 else c.cycles * scene.period_s
    # whole write intervals; up to a tenth of one short of the end asked for (the binary step
    # makes the interval a little shorter than a stroke cycle / writes_per_cycle)
    n_writes = max(1, math.ceil(end / write_interval - 0.1))
    n_steps = n_writes * steps_per_write
    # a point in the water halfway between the inlet and the rostrum, off any cell face
    location = (float(lo[0] - 0.5 * c.upstream * length + 0.1234567 * size[0]),
                float(centre[1] + 0.1234567 * size[1]), float(centre[2] + 0.1234567 * size[2]))
    grow = 0.1 * length
    gap = float(min((lo - dmin).min(), (dmax - hi).min()))
    outer = min(c.motion_outer * length, 0.8 * gap)
    inner = min(c.motion_inner * length, 0.5 * outer)
    k = 1.5 * (TURBULENCE_INTENSITY * speed) ** 2
    omega = k / (EDDY_VISCOSITY_RATIO * scene.flow.nu_m2_s)
    return CaseParameters(
        domain_min=tuple(float(v) for v in dmin),
        domain_max=tuple(float(v) for v in dmax),
        cells=tuple(int(v) for v in cells),
        cell_size=tuple(float(v) for v in size),
        smallest_cell_m=smallest,
        flipper_cell_m=flipper_cell,
        fluke_cell_m=fluke_cell,
        delta_t=dt,
        time_precision=_time_precision(dt),
        steps_per_write=steps_per_write,
        n_steps=n_steps,
        end_time=n_steps * dt,
        location_in_mesh=location,
        near_box_min=tuple(float(v) for v in lo - grow),
        near_box_max=tuple(float(v) for v in hi + grow),
        k_inlet=k,
        omega_inlet=omega,
        ranks=int(ranks if ranks is not None else c.ranks),
        inflow_ramp_s=c.inflow_ramp_cycles * scene.period_s,
        motion_inner_m=float(inner),
        motion_outer_m=float(outer),
        **_layer_rotation(c),
    )


def level_cell_m(cell_size, level: int) -> float:
    """The edge of a cell at snappyHexMesh ``level`` (m): the background cell's (``cell_size``,
    its edges along x, y, z) shortest edge halved ``level`` times."""
    return float(min(cell_size)) / 2 ** level


def _binary_step(dt: float) -> float:
    """``dt`` rounded down to a multiple of 2**-k s, with k >= 10 and at least 64 such quanta.

    OpenFOAM adds deltaT to the time every step and names written times with timePrecision
    digits; with a binary-fraction step every sum is exact and every name is the exact value,
    so a restart from a written time reaches the same times, bit for bit, as the first run
    (and the step-server is asked for the same times).
    """
    k = max(10, math.ceil(math.log2(64.0 / dt)))
    return math.floor(dt * 2.0**k) / 2.0**k


def _time_precision(dt: float) -> int:
    """Significant digits that print every multiple of ``dt`` below 10**5 s exactly."""
    k = max(10, math.ceil(math.log2(64.0 / dt))) if dt > 0 else 10
    return k + 5

