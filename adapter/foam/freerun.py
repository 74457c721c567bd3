"""run-case's free whale: it finds its own speed (docs/free-swimming.md).

After the tethered pair (adapter/foam/swimrun.py), with ``free.enabled``:

3. **Free** (``<case>/free/``): the tethered run's last written time copied as the start, the
   inflow and a uniform body force following the whale's frame (the step-server's
   :class:`~adapter.coupling.surge.SurgeFrame`, through the plugin's ``whaleFrameInletVelocity``
   and ``whaleFrameAcceleration``), its speed first brought to the tethered pair's estimate of
   the self-propelled one over ``free.approach_cycles`` periods, until the whale swims by
   itself: over the last two whole cycles measured (from a period after the approach on) the
   cycle-mean speed changes by less than ``free.speed_tolerance`` and the last cycle's mean
   Fx is under ``free.fx_tolerance`` of the gliding drag; at most ``free.cycles`` cycles.
4. **Gliding at the self-propelled speed** (``<case>/gliding-free/``): the gliding run's last
   time copied, its inflow set to U_sp, until steady: the drag the swimming whale overcomes.

The figures at the self-propelled state go into ``adapter-summary.json`` under
``"self_propelled"`` (:func:`free_figures`).
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np

from adapter.coupling.surge import FRAME_LOG, inertia_of, release_speed
from adapter.errors import CaseError
from adapter.foam import loads as ld
from adapter.foam.case import Case
from adapter.foam.casescene import CASE_SCENE
from adapter.foam.dictionaries import parsed_dict, use_frame_inflow
from adapter.foam.parallel import reconstruct_latest_time
from adapter.foamfiles import time_dirs

FREE = "free"
GLIDING_FREE = "gliding-free"
FRAME_COLUMNS = ("Time", "Ux", "Uz", "ax", "az", "Fx", "Fz", "light", "pitch")


def read_frame_log(case_dir) -> dict:
    """The frame log's columns (:data:`FRAME_COLUMNS`), a later row winning for a time written
    twice (a restart); ``{}`` when there is none."""
    path = Path(case_dir) / "adapter" / FRAME_LOG
    if not path.is_file():
        return {}
    rows = {}
    for line in path.read_text().splitlines():
        words = line.split()
        if line.startswith("#") or len(words) != len(FRAME_COLUMNS):
            continue
        try:
            values = [float(w) for w in words]
        except ValueError:
            continue
        rows[values[0]] = values
    if not rows:
        return {}
    data = np.array([rows[t] for t in sorted(rows)])
    return {name: data[:, k] for k, name in enumerate(FRAME_COLUMNS)}


# --- the cases ------------------------------------------------------------------------------

def _copy_case_at(src: Path, dst: Path, extra=()) -> float:
    """``dst``: src's system, constant, 0.orig and its latest written time (reconstructed
    first, alone), and ``extra`` files of src; returns that time."""
    reconstruct_latest_time(src)
    times = [(t, p) for t, p in time_dirs(src) if t > 0]
    if not times:
        raise CaseError(f"{src} has no written time to start from; run it first")
    t0, folder = times[-1]
    dst.mkdir()
    for name in ("system", "constant", "0.orig", folder.name, *extra):
        if (src / name).is_dir():
            shutil.copytree(src / name, dst / name)
        elif (src / name).is_file():
            (dst / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src / name, dst / name)
    return t0


def _set_end(case: Path, end_time: float) -> None:
    d = parsed_dict(case / "system" / "controlDict")
    d["endTime"] = end_time
    d["startFrom"] = "latestTime"
    d.writeFile()


def prepare_free(case: Path, drag: float, mean_fx: float = float("nan")) -> Path:
    """``<case>/free``: the tethered swimming run at its latest time, released there; kept
    when it exists. ``drag``: the gliding drag, the scale of the lighter mass's end;
    ``mean_fx``: the tethered stroke's mean Fx, with ``drag`` the approach's target speed
    (:func:`~adapter.coupling.surge.release_speed`)."""
    free = case / FREE
    if (free / "system" / "controlDict").exists():
        return free
    record = Case(case).record
    state = [f"adapter/{p.name}" for p in (case / "adapter").glob("state_*.npz")]
    # the case's own scene: the free whale's server animates the tethered one's
    t0 = _copy_case_at(case, free, extra=[*state, CASE_SCENE])
    period = float(record["period_s"])
    record["free_release_s"] = t0
    record["free_reference_drag_N"] = float(drag)
    approach = float(record["free"].get("approach_cycles", 0.0)) * period
    if approach > 0:
        record["free_approach_s"] = approach
        record["free_approach_speed_m_s"] = release_speed(float(record["speed_m_s"]),
                                                          float(drag), float(mean_fx))
    Case(free).save(record)
    _set_end(free, t0 + approach + float(record["free"]["cycles"]) * period)
    use_frame_inflow(free, ("0.orig", time_dirs(free)[-1][1].name))
    return free


def prepare_gliding_at(glide: Path, speed: float) -> Path:
    """``<case>/gliding-free``: the gliding run at its latest time with the inflow ``speed``,
    run on for at most four periods (until steady); kept when it exists."""
    out = glide.parent / GLIDING_FREE
    if (out / "system" / "controlDict").exists():
        return out
    record = Case(glide).record
    t0 = _copy_case_at(glide, out)
    record["speed_m_s"] = speed
    record["gliding_from_s"] = t0
    Case(out).save(record)
    _set_end(out, t0 + 4.0 * float(record["period_s"]))
    u = time_dirs(out)[-1][1] / "U"
    d = parsed_dict(u)
    d["boundaryField"]["inlet"] = {"type": "fixedValue", "value": f"uniform ({speed!r} 0 0)"}
    d.writeFile()
    return out


# --- when the whale swims by itself ----------------------------------------------------------

def measured_from(record: dict) -> float:
    """When the free run's cycles are measured from: a whole period after the approach, once
    the running mean of the momentum balance is a period's (adapter/coupling/surge.py)."""
    return (float(record["free_release_s"]) + float(record.get("free_approach_s", 0.0))
            + float(record["period_s"]))


def measured_cycles(case: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Start, mean speed and mean Fx of each whole cycle from :func:`measured_from` on, from
    the frame log and loads.dat. The lighter mass may still act on them: at a periodic state
    its running mean is zero and the law is the true mass's (docs/free-swimming.md)."""
    record = Case(case).record
    period = float(record["period_s"])
    frame, data = read_frame_log(case), ld.read_loads(case)
    if not frame or not data:
        return np.array([]), np.array([]), np.array([])
    first = measured_from(record)
    speed = ld.cycle_stats(frame["Time"], frame["Ux"], frame["Ux"], period, first)
    force = ld.cycle_stats(data["Time"], data["total:Fx"], data["total:Fx"], period, first)
    n = min(len(speed.starts), len(force.starts))
    return speed.starts[:n], speed.mean_fx[:n], force.mean_fx[:n]


def settled(case: Path, drag: float) -> str | None:
    """The stop rule of the free run: a reason once the whale swims by itself, else None."""
    free = Case(case).record["free"]
    _, speed, fx = measured_cycles(case)
    if len(speed) < 2:
        return None
    change = abs(speed[-1] - speed[-2]) / abs(speed[-1])
    share = abs(fx[-1]) / abs(drag)
    if change < float(free["speed_tolerance"]) and share < float(free["fx_tolerance"]):
        return (f"self-propelled: cycle-mean speed {speed[-1]:.4g} m/s changed {change:.2%}, "
                f"cycle-mean Fx {share:.2%} of the gliding drag")
    return None


def free_figures(free: Path, glide_sp: Path, tethered_drag: float) -> dict:
    """The figures at the self-propelled state, over the last whole measured cycle."""
    record = Case(free).record
    period = float(record["period_s"])
    starts, speed, fx = measured_cycles(free)
    if not len(starts):
        raise CaseError(f"{free}: no whole measured cycle; raise free.cycles")
    window = (starts[-1], starts[-1] + period)
    data, gd = ld.read_loads(free), ld.read_loads(glide_sp)
    t0 = float(Case(glide_sp).record["gliding_from_s"])
    u_sp = float(speed[-1])

    def swim_mean(column: str) -> float:
        return ld.window_mean(data["Time"], data[column], *window)

    def glide_mean(column: str) -> float:
        st = ld.cycle_stats(gd["Time"], gd[column], gd[column], period, t0 + period)
        return float(st.mean_fx[-1]) if len(st.starts) else float("nan")

    power, drag_sp = swim_mean("total:P"), glide_mean("total:Fx")
    inertia = inertia_of(record)
    # a region the mesh has no faces of (a coarse mesh's flukes) has no figures
    fluke_power = swim_mean("whale.flukes:P") if "whale.flukes:P" in data else 0.0
    fluke_eff = (-swim_mean("whale.flukes:Fx") * u_sp / fluke_power) if fluke_power > 0 else None
    body_glide = glide_mean("whale.body:Fx") if "whale.body:Fx" in gd else 0.0
    body_swim = swim_mean("whale.body:Fx") if body_glide > 0 and "whale.body:Fx" in data else None
    return {
        "speed_m_s": u_sp,
        "speed_change_last_two_cycles": float(abs(speed[-1] - speed[-2]) / u_sp)
        if len(speed) > 1 else float("nan"),
        "mean_fx_N": float(fx[-1]), "mean_fx_of_gliding_drag": float(fx[-1]) / tethered_drag,
        "mean_power_W": power,
        "cost_of_transport_J_kg_m": power / (inertia.mass_kg * u_sp),
        "gliding_drag_at_speed_N": drag_sp,
        "quasi_propulsive_efficiency": drag_sp * u_sp / power,
        "flukes_propulsive_efficiency": fluke_eff,
        "strouhal": float(record["fluke_amplitude_m"]) / (period * u_sp),
        "body_drag_swimming_N": body_swim,
        "body_drag_gliding_N": body_glide if body_swim is not None else None,
        "drag_augmentation": body_swim / body_glide if body_swim is not None else None,
        "cycles_measured": int(len(starts)),
        "measured_from_s": measured_from(record),
        "window_s": list(window),
        "mass_kg": inertia.mass_kg,
        "added_surge_kg": inertia.added_surge_kg,
        "release_s": float(record["free_release_s"]),
    }


def written_inlet_speed(case: Path) -> tuple[float, float]:
    """(time, inlet x-velocity) at the latest written time, from OpenFOAM's own U field."""
    t, folder = time_dirs(case)[-1]
    value = parsed_dict(folder / "U")["boundaryField"]["inlet"]["value"]
    return t, float(np.asarray(value.val if hasattr(value, "val") else value).ravel()[0])


def steady_gliding(period: float, tolerance: float, start_up: float):
    """A gliding run's stop rule (the pair's and the one at U_sp): the mean drag over a period
    changes by less than ``tolerance`` from one period to the next, periods counted from
    ``start_up``."""
    def rule(case: Path) -> str | None:
        data = ld.read_loads(case)
        if not data:
            return None
        st = ld.cycle_stats(data["Time"], data["total:Fx"], data["total:P"], period, start_up)
        if len(st.starts) >= 2 and ld.is_periodic(st, st.mean_fx[-1], tolerance):
            change = ld.periodic_change(st, st.mean_fx[-1])[0]
            return f"steady: mean drag changed {change:.2%} over the last stroke period"
        return None
    return rule


def run_free(case: Path, glide: Path, drag: float, runner,
             mean_fx: float = float("nan")) -> dict:
    """Stages 3 and 4 (the module's docstring): the free whale, then gliding at its speed;
    ``runner(case, rule)`` runs a case until ``rule`` says why to stop (swimrun's); ``drag``
    and ``mean_fx``: the tethered pair's (:func:`prepare_free`). Returns :func:`free_figures`,
    with ``settled`` (the free run's stop rule held) and the two runs' wall times."""
    free = prepare_free(case, drag, mean_fx)
    f_summary = runner(free, lambda c: settled(c, drag))
    starts, speed, _ = measured_cycles(free)
    if not len(speed):
        raise CaseError(f"{free}: the free run ended before a whole measured cycle; "
                        "raise free.cycles")
    glide_sp = prepare_gliding_at(glide, float(speed[-1]))
    record = Case(glide_sp).record
    period = float(record["period_s"])
    g_summary = runner(glide_sp, steady_gliding(period, float(record["periodic_tolerance"]),
                                              float(record["gliding_from_s"]) + 0.5 * period))
    figures = free_figures(free, glide_sp, drag)
    figures["settled"] = settled(free, drag) is not None
    from adapter.reports.render import plot_free

    plot_free(read_frame_log(free), ld.read_loads(free), period, figures, case / "free.png")
    figures["free_run"] = {k: f_summary.get(k) for k in ("steps", "flow_wall_s",
                                                        "stopped_because")}
    figures["gliding_at_speed_run"] = {k: g_summary.get(k) for k in ("steps", "flow_wall_s",
                                                                    "stopped_because")}
    return figures


#: the rows run-case prints for the free whale (case.format_summary: label, key, format)
FREE_ROWS = [
    ("self-propelled speed U_sp (free run)", "self_propelled/speed_m_s", "{:.3f} m/s"),
    ("  reached (speed and Fx within tolerance)", "self_propelled/settled", "{}"),
    ("  cycle-mean Fx / gliding drag", "self_propelled/mean_fx_of_gliding_drag", "{:+.2%}"),
    ("  speed change over the last two cycles", "self_propelled/speed_change_last_two_cycles",
     "{:.2%}"),
    ("free: mean power into the water", "self_propelled/mean_power_W", "{:.0f} W"),
    ("free: cost of transport (mechanical)", "self_propelled/cost_of_transport_J_kg_m",
     "{:.3g} J/(kg m)"),
    ("free: gliding drag at U_sp", "self_propelled/gliding_drag_at_speed_N", "{:.0f} N"),
    ("free: quasi-propulsive efficiency D_g U / P", "self_propelled/quasi_propulsive_efficiency",
     "{:.2f}"),
    ("free: flukes' propulsive efficiency", "self_propelled/flukes_propulsive_efficiency",
     "{:.2f}"),
    ("free: Strouhal number f A / U_sp", "self_propelled/strouhal", "{:.2f}"),
    ("free: body's drag swimming / gliding", "self_propelled/drag_augmentation", "{:.2f}"),
]
