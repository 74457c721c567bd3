"""A run's summary: the numbers of ``<case>/adapter-summary.json`` (:func:`summarise`, from the
log watch, the case record, the step-server's statistics and the loads) and the table run-case
prints (:func:`format_summary`, one line per row of :data:`SUMMARY_ROWS`)."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path
from typing import Any

import numpy as np

from adapter.foam import symmetry
from adapter.foam.loads import read_loads
from adapter.foam.logs import LogWatch
from adapter.foamfiles import time_dirs
from adapter.jsonfiles import (
    CASE_SUMMARY,
    finite,  # the one cleaner (also reached from here)
)

#: the run's summary, in the case folder
SUMMARY = CASE_SUMMARY


def read_forces(case_dir) -> np.ndarray:
    """(T, 10) time, total, pressure and viscous force (N) on the whale: the ``total`` group of
    whaleLoads' loads.dat (:func:`~adapter.foam.loads.read_loads`), else (a flow-only case
    without the plugin, or a case run before loads.dat held every step's force) OpenFOAM's
    forces function object's force.dat. Both the whole body's for a half-domain case."""
    loads = read_loads(case_dir)
    names = [f"total:F{part}{axis}" for part in ("", "p", "v") for axis in "xyz"]
    if all(n in loads for n in names):
        return np.column_stack([loads["Time"]] + [loads[n] for n in names])
    return _read_forces_dat(case_dir)


def _read_forces_dat(case_dir) -> np.ndarray:
    """The forces function object's rows; files of restarted runs are merged, a later file
    wins for a time present twice."""
    rows: dict = {}
    base = Path(case_dir) / "postProcessing" / "forces"
    files = [f for _, d in time_dirs(base) for f in sorted(d.glob("force*.dat"))]
    for f in files:
        for line in f.read_text().splitlines():
            if not line.strip() or line.startswith("#"):
                continue
            nums = [float(v) for v in re.findall(r"[-+0-9.eE]+(?:[eE][-+]?\d+)?",
                                                 line.replace("(", " ").replace(")", " "))]
            if len(nums) >= 10:
                rows[nums[0]] = nums[:10]
    if not rows:
        return np.zeros((0, 10))
    forces = np.array([rows[t] for t in sorted(rows)])
    # a half-domain case: the whole body's (adapter/foam/symmetry.py)
    return symmetry.whole_body_forces(forces) if symmetry.is_half(case_dir) else forces


def summarise(case: Path, watch: LogWatch, record: dict, ranks: int, flow_wall: float,
              wall: float) -> dict:
    """The run's summary (numbers for adapter-summary.json)."""
    steps = len(watch.times)
    step_s = watch.seconds_per_step()
    adapter_s = float("nan")
    if watch.plugin is not None:
        adapter_s = watch.plugin[1] * 1e-6
    stats_path = case / "adapter" / "server-stats.json"
    stats = json.loads(stats_path.read_text()) if stats_path.is_file() else {}
    mesh = record.get("mesh", {})
    forces = read_forces(case)
    period = float(record["period_s"])
    drag = float("nan")
    window = 0.0
    if len(forces):
        t = forces[:, 0]
        sel = t >= t[-1] - period * (1 - 1e-9)
        drag = float(forces[sel, 1].mean())
        window = float(t[sel][-1] - t[sel][0])
    summary = {
        "case": str(case),
        "preset": record.get("preset"),
        "static_whale": bool(record.get("static_whale")),
        "cells": mesh.get("cells"),
        "steps": steps,
        "ranks": ranks,
        "end_time_s": watch.times[-1] if watch.times else None,
        "delta_t_s": record["parameters"]["delta_t"],
        "step_s": step_s,
        "cpu_s_per_step": watch.cpu_seconds_per_step(),
        "flow_s_per_step": step_s - (0.0 if math.isnan(adapter_s) else adapter_s),
        "adapter_s_per_step": adapter_s,
        "adapter_requests": watch.plugin[0] if watch.plugin else None,
        "whale_points": mesh.get("whale_points"),
        # from the step-server: summed over ranks (a point two ranks share counts twice)
        "patch_points": stats.get("patch_points", mesh.get("whale_points")),
        "max_mapping_distance_m": stats.get("max_mapping_distance_m"),
        "worst_cell_quality": {
            "max_non_orthogonality_deg": watch.max_non_orth,
            "min_cell_volume_m3": watch.min_volume,
            "initial_max_non_orthogonality_deg": mesh.get("max_non_orthogonality"),
            "initial_max_skewness": mesh.get("max_skewness"),
        },
        "max_courant": watch.max_courant,
        "drag_N": drag,
        "drag_window_s": window,
        "flow_wall_s": round(flow_wall, 2),
        "wall_s": round(wall, 2),
    }
    return finite(summary)


#: the rows of :func:`format_summary`: (label, key of the summary (a/b for nested), format);
#: the format is a str.format spec with the unit, or a callable value -> str
SUMMARY_ROWS: list[tuple[str, str, Any]] = [
    ("case", "case", "{}"),
    ("preset", "preset", "{}"),
    ("static whale", "static_whale", lambda v: "yes" if v else "no"),
    ("cells", "cells", "{:,}"),
    ("ranks", "ranks", "{}"),
    ("steps (this run)", "steps", "{}"),
    ("end time", "end_time_s", "{:.6g} s"),
    ("time step", "delta_t_s", "{:.6g} s"),
    ("wall time per step", "step_s", "{:.3g} s"),
    ("  of which coupling", "adapter_s_per_step", lambda v: f"{v * 1e3:.3g} ms"),
    ("CPU time per step", "cpu_s_per_step", "{:.3g} s"),
    ("coupling requests", "adapter_requests", "{:,}"),
    ("whale patch points", "whale_points", "{:,}"),
    ("largest mapping distance", "max_mapping_distance_m", "{:.3g} m"),
    ("largest non-orthogonality", "worst_cell_quality/max_non_orthogonality_deg",
     "{:.1f} deg"),
    ("  before motion", "worst_cell_quality/initial_max_non_orthogonality_deg", "{:.1f} deg"),
    ("smallest cell volume", "worst_cell_quality/min_cell_volume_m3", "{:.3g} m3"),
    ("largest Courant number", "max_courant", "{:.3g}"),
    ("mean drag", "drag_N", "{:.4g} N"),
    ("  over", "drag_window_s", "{:.4g} s"),
    ("pimpleFoam wall time", "flow_wall_s", "{:.1f} s"),
    ("run-case wall time", "wall_s", "{:.1f} s"),
    ("stopped", "stopped", "{}"),
]


def format_summary(summary: dict, rows=None) -> str:
    """The run's summary as a two-column text table, one line per row of ``rows`` (default
    :data:`SUMMARY_ROWS`) whose key the summary holds (missing or None: left out)."""
    lines = summary_rows(summary, rows)
    width = max((len(label) for label, _ in lines), default=0)
    return "\n".join(f"{label:<{width}}  {text}" for label, text in lines)


def summary_rows(summary: dict, rows=None) -> list[tuple[str, str]]:
    """``(label, formatted value)`` for each row of ``rows`` (default :data:`SUMMARY_ROWS`)
    whose key the summary holds (missing or None: left out): :func:`format_summary`'s lines,
    and the report's tables."""
    lines = []
    for label, key, fmt in rows or SUMMARY_ROWS:
        value: Any = summary
        for part in key.split("/"):
            value = value.get(part) if isinstance(value, dict) else None
        if value is None:
            continue
        try:
            text = fmt(value) if callable(fmt) else fmt.format(value)
        except (TypeError, ValueError):
            text = str(value)
        lines.append((label, text))
    return lines
