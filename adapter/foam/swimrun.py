"""run-case's two runs on one mesh, and the answer: what swimming costs the whale.

1. **Gliding** (``<case>/gliding/``): the same whale on the same mesh, not moving
   (staticFvMesh), from still water with the inflow ramped in (``case.inflow_ramp_cycles``),
   until the mean drag over a stroke period changes by
   less than ``case.periodic_tolerance`` from one period to the next.
2. **Swimming** (``<case>/``): the coupled run, started the same way, the stroke ramping in over
   its first ``stroke.ramp_cycles`` (the start-up, discarded), until the cycle-mean Fx (against
   the gliding drag) and the cycle-mean power each change by less than the tolerance between
   the last two cycles; at most ``case.cycles`` cycles.

From the loads of both (adapter/foam/loads.py): mean drag gliding, mean Fx and power swimming,
the tethered whale's Froude efficiency and cost of transport, with the spike checks and van
der Hoop et al.'s reference drag; the drag, Fx and power also per body region (body, flippers,
flukes: ``swimming_cost/regions``), each region's gliding drag beside an estimate from its own size
(:mod:`adapter.foam.estimates`). Written into ``<case>/adapter-summary.json`` under
``"swimming_cost"``, drawn in ``<case>/forces.png`` and put on ``<case>/report.html``
(:mod:`adapter.foam.report`).

With ``free.enabled`` two more runs follow, the free whale and gliding at its speed
(:mod:`adapter.foam.freerun`), their figures under ``"self_propelled"``.
"""

from __future__ import annotations

import shutil
from pathlib import Path

from adapter.errors import CaseError
from adapter.foam import estimates as est
from adapter.foam import loads as ld
from adapter.foam.case import Case
from adapter.foam.dictionaries import hold_still, parsed_dict
from adapter.foam.eta import PairEta, StopRule
from adapter.foam.folders import asked_start, resume_time
from adapter.foam.freerun import FREE_ROWS, run_free, steady_gliding
from adapter.foam.report import write_report
from adapter.foam.run import run_case
from adapter.foam.summary import finite

GLIDING = "gliding"


def prepare_gliding(case: Path) -> Path:
    """``<case>/gliding``: a copy of the prepared, meshed case with the whale held still
    (pointDisplacement fixed, staticFvMesh, no step-server); kept when it exists."""
    glide = case / GLIDING
    if (glide / "system" / "controlDict").exists():
        return glide
    glide.mkdir()
    for name in ("system", "constant", "0.orig"):
        shutil.copytree(case / name, glide / name)
    shutil.copytree(case / "0.orig", glide / "0")
    record = Case(case).record
    record["static_whale"] = True
    Case(glide).save(record)
    hold_still(glide)
    return glide


def _stats(case: Path, period: float, start_up: float) -> ld.CycleStats | None:
    data = ld.read_loads(case)
    if not data:
        return None
    return ld.cycle_stats(data["Time"], data["total:Fx"], data["total:P"], period, start_up)


def run_swim_and_glide(case: Path, scene_record: dict, tolerance: float, ranks=None,
                       progress: bool = True, launcher: str | None = None,
                       reconstruct: bool | None = None) -> dict:
    """Run gliding then swimming (each resumed if it was stopped); the answer. ``ranks``,
    ``launcher``, ``reconstruct``: as :func:`~adapter.foam.run.run_case`'s."""
    options = {"ranks": ranks, "progress": progress, "launcher": launcher,
               "reconstruct": reconstruct}
    period = float(scene_record["period_s"])
    ramp = float(scene_record.get("ramp_s", period))
    glide = prepare_gliding(case)

    glide_steady = steady_gliding(period, tolerance, start_up=period)
    # the ETA: gliding to its earliest steady period, then the whole swimming run to its
    # earliest periodic cycle (adapter/foam/eta.py)
    glide_rule = StopRule(start_up=period, period=period, end_time=_end_time(glide))
    swim_rule = StopRule(start_up=ramp, period=period, end_time=_end_time(case))
    g_summary = _run_unless_done(glide, glide_steady, {
        **options, "eta": PairEta(glide_rule, then=swim_rule, then_from=resume_time(case))})
    g_stats = _stats(glide, period, period)
    if g_stats is None or not len(g_stats.starts):
        raise CaseError(f"the gliding run {glide} wrote no complete stroke period of loads; "
                        "raise case.cycles")
    drag = float(g_stats.mean_fx[-1])

    def swim_periodic(c):
        st = _stats(c, period, ramp)
        if st is not None and len(st.starts) >= 2 and ld.is_periodic(st, drag, tolerance):
            dfx, dp = ld.periodic_change(st, drag)
            return (f"periodic: cycle mean Fx changed {dfx:.2%} of the gliding drag, mean power"
                    f" {dp:.2%}, over the last two cycles")
        return None

    s_summary = _run_unless_done(case, swim_periodic, {**options, "eta": PairEta(swim_rule)})
    summary = answer(case, glide, scene_record, drag, tolerance, s_summary, g_summary)
    if scene_record.get("free", {}).get("enabled"):
        summary["self_propelled"] = finite(run_free(
            case, glide, drag, lambda c, rule: _run_unless_done(c, rule, {**options, "eta": None}),
            mean_fx=float(summary["swimming_cost"]["swimming_mean_fx_N"])))
        Case(case).save_summary(summary)
        write_report(case, summary, COST_ROWS)
    return summary


def _end_time(case: Path) -> float:
    return float(parsed_dict(case / "system" / "controlDict")["endTime"])


def _run_unless_done(case: Path, criterion, options: dict) -> dict:
    """Run the case until ``criterion`` holds, unless its written loads already meet it (a
    rerun of a finished pair only recomputes the figures) and its controlDict asks for no
    other start (a user's ``startFrom startTime`` is a run from there)."""
    held = Case(case)
    reached = (criterion(case) if held.has_summary and asked_start(case) is None
               else None)
    if reached:
        print(f"{case}: {reached} (already reached: not run again)")
        return held.summary
    return run_case(case, stop_when=criterion, **options)


def yplus_over_run(case: Path) -> dict:
    """Area-weighted y+ on the whale at every written time that has it: the worst fraction of
    the area with y+ <= 300 (Spalding's wall function holds there) and the last time's
    statistics (adapter/foam/yplus.py, which reads a parallel run's times in its processor
    folders: nothing is reconstructed for it)."""
    from adapter.foam.yplus import area_stats, patch_yplus, written_times, yplus_stats

    names = [name for name in written_times(case) if float(name) > 0]
    if not names:
        return {}
    per_time = [(name, area_stats(*patch_yplus(case, name)[:2])) for name in names[:-1]]
    last = yplus_stats(case, names[-1])
    per_time.append((names[-1], last))
    return {
        "times": len(per_time),
        "worst_area_le_300": min(st["area_le_300"] for _, st in per_time),
        "worst_area_30_300": min(st["area_30_300"] for _, st in per_time),
        "fraction_le_300": last["area_le_300"],
        "median": last["median"], "p5": last["p5"], "p95": last["p95"],
        "time": last["time"],
        "layer_area_coverage": last.get("layer_area_coverage"),
    }


def answer(case: Path, glide: Path, rec: dict, drag: float, tolerance: float,
           s_summary: dict, g_summary: dict) -> dict:
    """The figures, into adapter-summary.json (``swimming_cost``), forces.png and report.html."""
    period = float(rec["period_s"])
    ramp = float(rec.get("ramp_s", period))
    data = ld.read_loads(case)
    st = ld.cycle_stats(data["Time"], data["total:Fx"], data["total:P"], period, ramp)
    if not len(st.starts):
        raise CaseError(f"{case}: no complete stroke cycle after the start-up; raise "
                        "case.cycles")
    dfx, dp = ld.periodic_change(st, drag)
    window = (st.starts[-1], st.starts[-1] + period)
    t = data["Time"]
    spikes = ld.spike_figures(t, data["total:Fx"], data["total:Fy"], data["total:Fz"],
                              data["total:P"], window)
    body = rec.get("body", {})
    speed = float(rec["speed_m_s"])
    mass = ld.BODY_DENSITY * float(body.get("volume_m3", float("nan")))
    cost = ld.cost_figures(drag, float(st.mean_fx[-1]), float(st.mean_power[-1]), speed, mass)
    ref = ld.van_der_hoop_drag(speed, float(body.get("length_m", rec["length_m"])),
                               float(body.get("diameter_m", float("nan"))),
                               float(body.get("wetted_area_m2", float("nan"))),
                               float(rec.get("rho_kg_m3", 1025.0)),
                               float(rec.get("nu_m2_s", 1e-6)))
    gd = ld.read_loads(glide)
    side = _last_period_mean(gd, "total:Fy", period)
    result = {
        "gliding_drag_N": drag,
        # the split over the window of the drag (the last whole period after the first)
        "gliding_drag_pressure_N": _last_period_mean(gd, "total:Fpx", period),
        "gliding_drag_viscous_N": _last_period_mean(gd, "total:Fvx", period),
        "swimming_mean_fx_N": float(st.mean_fx[-1]),
        "swimming_mean_power_W": float(st.mean_power[-1]),
        **cost,
        "cycles_measured": int(len(st.starts)),
        "start_up_s": ramp,
        "cycle_means": {"start_s": st.starts.tolist(), "fx_N": st.mean_fx.tolist(),
                        "power_W": st.mean_power.tolist()},
        "periodic_change": {"fx_of_gliding_drag": dfx, "power": dp, "tolerance": tolerance,
                            "reached": ld.is_periodic(st, drag, tolerance)},
        "spikes": {**spikes,
                   "drop_1pct_fx_of_gliding_drag": spikes["drop_1pct_fx_N"] / abs(drag),
                   "drop_1pct_fx_of_mean_fx": spikes["drop_1pct_fx_N"] / abs(st.mean_fx[-1]),
                   "drop_1pct_power": spikes["drop_1pct_power_W"]
                   / abs(st.mean_power[-1])},
        "gliding_side_force_N": side,
        "gliding_side_force_of_drag": abs(side) / abs(drag) if drag else float("nan"),
        # per body region (whale.body, whale.flippers, whale.flukes): same windows; each with
        # its estimate from its own size (adapter/foam/estimates.py)
        "regions": est.with_estimates(ld.region_figures(data, gd, period, ramp),
                                      est.case_estimates(case, rec)),
        # the model on the whole whale's area (the body region's: regions/body/estimate_N)
        "van_der_hoop": ref,
        "gliding_vs_van_der_hoop": drag / ref["drag_N"] - 1.0,
        "gliding_run": {k: g_summary.get(k) for k in ("steps", "flow_wall_s", "end_time_s",
                                                      "stopped_because")},
    }
    summary = dict(s_summary)
    summary["swimming_cost"] = finite(result)
    summary["yplus"] = finite(yplus_over_run(case))
    summary["yplus_gliding"] = finite(yplus_over_run(glide))
    Case(case).save_summary(summary)
    from adapter.reports.render import plot_forces

    plot_forces(data, gd, period, ramp, case / "forces.png", figures=summary["swimming_cost"])
    write_report(case, summary, COST_ROWS)
    return summary


def _last_period_mean(data: dict, key: str, period: float) -> float:
    """Mean of a gliding column over the window of the gliding drag (ld.cycle_stats from the
    second period on, the last whole one)."""
    if not data:
        return float("nan")
    st = ld.cycle_stats(data["Time"], data[key], data[key], period, period)
    return float(st.mean_fx[-1]) if len(st.starts) else float("nan")


#: the rows run-case prints after the pair (case.format_summary: label, key, format): the
#: free whale's first when it ran, then the tethered pair's
COST_ROWS = [
    *FREE_ROWS,
    ("gliding drag", "swimming_cost/gliding_drag_N", "{:.0f} N"),
    ("  pressure part", "swimming_cost/gliding_drag_pressure_N", "{:.0f} N"),
    ("  viscous part", "swimming_cost/gliding_drag_viscous_N", "{:.0f} N"),
    ("gliding: side force Fy", "swimming_cost/gliding_side_force_N", "{:.1f} N"),
    ("  |Fy| / gliding drag", "swimming_cost/gliding_side_force_of_drag", est.side_force_text),
    ("van der Hoop et al. model, whole whale's area", "swimming_cost/van_der_hoop/drag_N",
     "{:.0f} N"),
    ("tethered swimming: mean Fx", "swimming_cost/swimming_mean_fx_N", "{:.0f} N"),
    ("tethered swimming: mean power into the water", "swimming_cost/swimming_mean_power_W",
     "{:.0f} W"),
    *[row for name in ("body", "flippers", "flukes") for row in (
        (f"  {name}: gliding drag", f"swimming_cost/regions/{name}", est.drag_text),
        (f"  {name}: pressure part", f"swimming_cost/regions/{name}/gliding_pressure_share",
         "{:.0%}"),
        (f"  {name}: mean power", f"swimming_cost/regions/{name}/power_W", "{:.0f} W"))],
    ("tethered: Froude efficiency", "swimming_cost/froude_efficiency", "{:.2f}"),
    ("tethered: cost of transport", "swimming_cost/cost_of_transport_J_kg_m",
     "{:.3g} J/(kg m)"),
    ("mass (enclosed volume x 1025 kg/m3)", "swimming_cost/mass_kg", "{:,.0f} kg"),
    ("cycles measured after the start-up", "swimming_cost/cycles_measured", "{}"),
    ("cycle-to-cycle change: Fx (of drag)", "swimming_cost/periodic_change/fx_of_gliding_drag",
     "{:.1%}"),
    ("cycle-to-cycle change: power", "swimming_cost/periodic_change/power", "{:.1%}"),
    ("largest step |F| / RMS of |F|", "swimming_cost/spikes/max_force_over_rms", "{:.2f}"),
    ("drop worst 1 % of steps: mean Fx moves", "swimming_cost/spikes/drop_1pct_fx_N", "{:.1f} N"),
    ("  the same, smooth part of Fx", "swimming_cost/spikes/smooth_drop_1pct_fx_N", "{:.1f} N"),
    ("drop worst 1 % of steps: mean power", "swimming_cost/spikes/drop_1pct_power", "{:.1%}"),
    ("y+ <= 300: share of the area, worst write", "yplus/worst_area_le_300", "{:.1%}"),
    ("y+ median (area-weighted, last write)", "yplus/median", "{:.0f}"),
    ("cells", "cells", "{:,}"),
    ("steps (swimming, this run)", "steps", "{}"),
    ("wall time per step", "step_s", "{:.3g} s"),
    ("pimpleFoam wall time (swimming)", "flow_wall_s", "{:.0f} s"),
    ("gliding: pimpleFoam wall time", "swimming_cost/gliding_run/flow_wall_s", "{:.0f} s"),
    ("swimming stopped", "stopped_because", "{}"),
]
