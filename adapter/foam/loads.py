"""What swimming costs the whale: forces and power from a coupled run, and figures built on them.

The OpenFOAM side writes ``postProcessing/loads/<t0>/loads.dat`` every step (the ``whaleLoads``
function object of the plugin library, docs/openfoam-plugin.md): per patch group the force of
the water on the whale (pressure and viscous, N) and the power the whale puts into the water,
``P = -sum_f F_f . U_f`` (W). This module reads it, splits it into stroke cycles, decides when a
run is periodic, checks that no single step carries the answer, and derives the figures:
mean drag gliding, mean Fx and mean power swimming, Froude efficiency, cost of transport; and
the reference drag of van der Hoop et al. for the same body. See docs/case.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from adapter.body.planform import triangle_areas
from adapter.errors import CaseError
from adapter.foam import symmetry
from adapter.foamfiles import time_dirs

#: the function object's name in system/controlDict (its postProcessing folder)
LOADS_NAME = "loads"
#: seawater density for the whale's mass from its enclosed volume (kg/m3)
BODY_DENSITY = 1025.0


def read_loads(case_dir, name: str = LOADS_NAME, whole: bool = True) -> dict:
    """Columns of every ``loads.dat`` of a case, merged over restarts (a later file wins for a
    time present twice): ``{"Time": (T,), "total:Fx": (T,), ...}``; empty when none. A
    half-domain case's are the whole body's unless ``whole`` is False (the half's own)."""
    base = Path(case_dir) / "postProcessing" / name
    rows: dict = {}
    header: list | None = None
    files = [d / "loads.dat" for _, d in time_dirs(base) if (d / "loads.dat").is_file()]
    for f in files:
        for line in f.read_text().splitlines():
            if line.startswith("#"):
                words = line[1:].split()
                if words and words[0] == "Time":
                    header = words
                continue
            nums = line.split()
            if header is None or len(nums) != len(header):
                continue  # a line cut short by a running solver
            try:
                values = [float(v) for v in nums]
            except ValueError:
                continue
            rows[values[0]] = values
    if not rows or header is None:
        return {}
    data = np.array([rows[t] for t in sorted(rows)])
    columns = {h: data[:, k] for k, h in enumerate(header)}
    # a half-domain case's loads are the whole body's from here on (adapter/foam/symmetry.py)
    return symmetry.whole_body(columns) if whole and symmetry.is_half(case_dir) else columns


@dataclass(frozen=True)
class CycleStats:
    """Per whole stroke cycle after the start-up: start time and the means."""

    starts: np.ndarray
    mean_fx: np.ndarray
    mean_power: np.ndarray


def window_mean(t: np.ndarray, y: np.ndarray, a: float, b: float) -> float:
    """The time mean of ``y`` over [a, b], each sample standing for the time step that ends
    at it (times ``t``, increasing; the first step as long as the second): a step that the
    window cuts counts with the part of it inside.

    Not the mean of the samples inside the window: with a step that does not divide the
    period (the default's 88.5 steps a cycle), consecutive windows hold 88 and 89 samples, and
    the stroke's force, 1.6 kN either way, then moves the sample mean by about 6 N from one
    cycle to the next; weighted by time, by 0.1 N."""
    starts = np.concatenate(([2 * t[0] - t[1]] if len(t) > 1 else [t[0]], t[:-1]))
    inside = np.clip(np.minimum(t, b) - np.maximum(starts, a), 0.0, None)
    return float(np.sum(inside * y) / (b - a))


def cycle_stats(t: np.ndarray, fx: np.ndarray, power: np.ndarray, period: float,
                start_up: float) -> CycleStats:
    """Means of Fx and power over each complete cycle [start_up + k T, start_up + (k+1) T)
    (:func:`window_mean`); a cycle counts once a sample lies inside it and one at or past its
    end."""
    starts, mfx, mp = [], [], []
    k = 0
    eps = 1e-9 * period
    while len(t) and start_up + (k + 1) * period <= t[-1] + eps:
        a, b = start_up + k * period, start_up + (k + 1) * period
        if ((t > a + eps) & (t <= b + eps)).any():
            starts.append(a)
            mfx.append(window_mean(t, fx, a, b))
            mp.append(window_mean(t, power, a, b))
        k += 1
    return CycleStats(np.array(starts), np.array(mfx), np.array(mp))


def region_figures(swim: dict, glide: dict, period: float, start_up: float,
                   patch: str = "whale", names=("body", "flippers", "flukes")) -> dict:
    """Per body region (the ``<patch>.<region>`` groups of loads.dat): mean Fx and mean power
    over the last whole swimming cycle after ``start_up``, the mean gliding drag over the last
    whole period after the first (the windows of the totals, so the regions add up to them),
    with its pressure part and share and its mean side force Fy, and the region's area (m2,
    at the last swimming step). Regions without columns are left
    out; ``{}`` for a run without regions."""
    out = {}
    for name in names:
        fx, power = f"{patch}.{name}:Fx", f"{patch}.{name}:P"
        if fx not in swim or power not in swim:
            continue
        st = cycle_stats(swim["Time"], swim[fx], swim[power], period, start_up)
        entry = {"fx_N": float(st.mean_fx[-1]) if len(st.starts) else float("nan"),
                 "power_W": float(st.mean_power[-1]) if len(st.starts) else float("nan"),
                 "area_m2": float(swim[f"{patch}.{name}:A"][-1])}
        if glide and fx in glide:
            entry.update(_gliding_parts(glide, f"{patch}.{name}", period))
        out[name] = entry
    return out


def _gliding_parts(glide: dict, group: str, period: float) -> dict:
    """A group's mean gliding drag, its pressure part (and share) and its side force Fy, over
    the window of the gliding drag (the last whole period after the first)."""
    def mean(column):
        if f"{group}:{column}" not in glide:
            return float("nan")
        st = cycle_stats(glide["Time"], glide[f"{group}:{column}"], glide[f"{group}:{column}"],
                         period, period)
        return float(st.mean_fx[-1]) if len(st.starts) else float("nan")

    drag, pressure = mean("Fx"), mean("Fpx")
    return {"gliding_drag_N": drag, "gliding_pressure_N": pressure,
            "gliding_pressure_share": pressure / drag if drag else float("nan"),
            "gliding_side_force_N": mean("Fy")}


def periodic_change(stats: CycleStats, force_scale: float) -> tuple[float, float]:
    """(change of mean Fx / force_scale, relative change of mean power) between the last two
    cycles; NaN with fewer than two. Mean Fx can be near zero for a swimmer, so its change is
    measured against a force scale (the gliding drag)."""
    if len(stats.starts) < 2:
        return float("nan"), float("nan")
    dfx = abs(stats.mean_fx[-1] - stats.mean_fx[-2]) / max(abs(force_scale), 1e-30)
    dp = abs(stats.mean_power[-1] - stats.mean_power[-2]) / max(abs(stats.mean_power[-1]),
                                                                 1e-30)
    return float(dfx), float(dp)


def is_periodic(stats: CycleStats, force_scale: float, tolerance: float) -> bool:
    """Both changes between the last two cycles under ``tolerance``."""
    dfx, dp = periodic_change(stats, force_scale)
    return dfx < tolerance and dp < tolerance


def worst_drop(x: np.ndarray, fraction: float = 0.01) -> float:
    """The largest change of mean(x) from dropping any ``fraction`` of the samples (at least
    one): the samples farthest from the mean on one side."""
    n = len(x)
    k = max(1, int(math.floor(fraction * n)))
    if n <= k:
        return float("nan")
    dev = np.sort(x - x.mean())
    return float(max(abs(dev[-k:].sum()), abs(dev[:k].sum())) / (n - k))


#: the harmonics of the stroke frequency kept in the smooth part of a one-cycle signal
SMOOTH_HARMONICS = 10


def smooth_part(x: np.ndarray, harmonics: int = SMOOTH_HARMONICS) -> np.ndarray:
    """The samples of one whole period of a signal, with its Fourier series cut after
    ``harmonics`` harmonics of the period: what is left when no single step stands out (a
    one-step spike spreads over all frequencies, most of it above the cut)."""
    c = np.fft.rfft(x)
    c[harmonics + 1:] = 0.0
    return np.fft.irfft(c, n=len(x))


def spike_figures(t, fx, fy, fz, power, window: tuple) -> dict:
    """Over the window (one stroke period): the largest step |F| against the RMS of |F|, and
    what dropping the worst 1 % of the steps does to the means of Fx and power, for the signal
    and for its smooth part (:func:`smooth_part`). Where the two drops agree, the drop comes
    from the smooth swing of the signal, not from steps that stand out of it."""
    a, b = window
    sel = (t > a) & (t <= b + 1e-9)
    mag = np.sqrt(fx[sel] ** 2 + fy[sel] ** 2 + fz[sel] ** 2)
    rms = float(np.sqrt((mag**2).mean())) if sel.any() else float("nan")
    enough = sel.sum() > 2 * SMOOTH_HARMONICS + 1
    return {
        "max_force_over_rms": float(mag.max() / rms) if sel.any() and rms > 0 else float("nan"),
        "drop_1pct_fx_N": worst_drop(fx[sel]),
        "drop_1pct_power_W": worst_drop(power[sel]),
        "smooth_drop_1pct_fx_N": worst_drop(smooth_part(fx[sel])) if enough else float("nan"),
        "smooth_drop_1pct_power_W": (worst_drop(smooth_part(power[sel])) if enough
                                     else float("nan")),
    }


def ittc57(reynolds: float) -> float:
    """The ITTC-57 friction line, Cf = 0.075 / (log10 Re - 2)^2."""
    return 0.075 / (math.log10(reynolds) - 2.0) ** 2


def van_der_hoop_drag(speed: float, length: float, diameter: float, wetted_area: float,
                      rho: float, nu: float) -> dict:
    """Right-whale drag after van der Hoop et al.: flat-plate (ITTC-57) friction times the form
    factor 1 + 1.5 (d/L)^1.5 + 7 (d/L)^3, on the wetted area."""
    re = speed * length / nu
    cf = ittc57(re)
    r = diameter / length
    form = 1 + 1.5 * r**1.5 + 7 * r**3
    friction = 0.5 * rho * speed**2 * wetted_area * cf
    return {"reynolds": re, "cf_ittc57": cf, "form_factor": form,
            "flat_plate_N": friction, "drag_N": friction * form}


def body_dimensions(surface, tail_base_s: float) -> dict:
    """Wetted area (m2), enclosed volume (m3) and the largest body diameter (m): the tallest
    section of the body ahead of the tail base (height, so the flippers, which stick out
    sideways, do not count)."""
    p = surface.points
    tri = surface.triangles
    area = float(triangle_areas(p[tri]).sum())
    s = surface.s
    body = s < tail_base_s
    bins = np.clip((s[body] * 200).astype(int), 0, 199)
    zmax = np.full(200, -np.inf)
    zmin = np.full(200, np.inf)
    np.maximum.at(zmax, bins, p[body, 2])
    np.minimum.at(zmin, bins, p[body, 2])
    height = zmax - zmin
    return {"wetted_area_m2": area, "volume_m3": surface.volume(),
            "diameter_m": float(height[np.isfinite(height)].max()), "length_m": surface.length,
            **pitch_inertia(p, tri)}


def pitch_inertia(points: np.ndarray, triangles: np.ndarray) -> dict:
    """The enclosed solid's centroid (m) and its ``∫ (x - xc)^2 + (z - zc)^2 dV`` (m5), the
    moment of inertia about the y axis through the centroid per unit density: sums over the
    tetrahedra from the origin to each (outward) triangle, ``∫ x dV = V (xa + xb + xc) / 4`` and
    ``∫ x^2 dV = V (xa^2 + xb^2 + xc^2 + xa xb + xa xc + xb xc) / 10``."""
    a, b, c = (points[triangles[:, k]] for k in range(3))
    vol = np.einsum("ij,ij->i", a, np.cross(b, c)) / 6.0
    total = float(vol.sum())
    first = (vol[:, None] * (a + b + c)).sum(axis=0) / 4.0
    second = (vol[:, None] * (a * a + b * b + c * c + a * b + a * c + b * c)).sum(axis=0) / 10.0
    centroid = first / total
    about = second - total * centroid ** 2
    return {"centroid_m": centroid.tolist(), "pitch_inertia_m5": float(about[0] + about[2])}


def cost_figures(glide_drag: float, swim_fx: float, power: float, speed: float,
                 mass: float) -> dict:
    """Froude efficiency and cost of transport at a prescribed speed.

    The thrust the stroke delivers is what it takes off the gliding drag, ``D_glide - Fx_swim``
    (the whale is held at its speed in the channel, so mean Fx need not vanish); the Froude
    efficiency is that thrust's power over the power put into the water,
    ``(D_glide - Fx_swim) U / P``; the cost of transport is ``P / (m U)`` (J per kg and m)."""
    if not (power > 0):
        raise CaseError(f"the mean power into the water is {power:.4g} W, not positive: "
                        "the stroke takes energy from the flow; check the run's loads.dat")
    thrust = glide_drag - swim_fx
    return {
        "thrust_N": thrust,
        "froude_efficiency": thrust * speed / power,
        "cost_of_transport_J_kg_m": power / (mass * speed),
        "mass_kg": mass,
    }
