"""The flow study's analysis: the figures of each finished case, the mesh study (Richardson
extrapolation and Roache's GCI, adapter/studies/gci.py), the time-step check, the
self-propelled speed, and the coarsest mesh of a finished study for a tolerance.

Plain functions over the cases' summaries and study.json's content; the plan and the run are
in :mod:`adapter.studies.study`, the chart and the table in :mod:`adapter.studies.study_report`.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from adapter.errors import AdapterError
from adapter.foam.case import Case
from adapter.foam.loads import read_loads, window_mean
from adapter.foam.summary import SUMMARY
from adapter.studies import gci as G

#: the figures of the mesh study: (key in study.json, key of swimming_cost, label)
FIGURES = (("gliding_drag", "gliding_drag_N", "gliding drag (N)"),
           ("swimming_fx", "swimming_mean_fx_N", "mean swimming Fx (N)"),
           ("swimming_power", "swimming_mean_power_W", "mean power (W)"))


def case_done(case: Path) -> bool:
    """The pair of this folder has its answer (``swimming_cost`` in adapter-summary.json)."""
    path = case / SUMMARY
    if not path.is_file():
        return False
    try:
        return "swimming_cost" in json.loads(path.read_text())
    except json.JSONDecodeError:
        return False



def case_result(case: Path) -> dict | None:
    """The figures of one finished pair (None when it has none)."""
    if not case_done(case):
        return None
    s = Case(case).summary
    rec = Case(case).record
    cost = s["swimming_cost"]
    par = rec["parameters"]
    dt = float(par["delta_t"])
    period = float(rec["period_s"])
    step = s.get("step_s")
    if step is None and s.get("steps"):
        step = float(s.get("flow_wall_s") or 0.0) / s["steps"]
    cells = rec.get("mesh", {}).get("cells") or s.get("cells")
    size = par["cell_size"]
    yp = s.get("yplus") or {}
    return {
        "case": str(case),
        "cells": cells,
        "background_cell_m": float(np.prod(size)) ** (1 / 3),
        "smallest_cell_m": par["smallest_cell_m"],
        "delta_t_s": dt,
        "speed_m_s": float(rec["speed_m_s"]),
        "layers": rec.get("mesh", {}).get("layers", {}).get("thickness_m"),
        "gliding_drag": cost.get("gliding_drag_N"),
        "swimming_fx": cost.get("swimming_mean_fx_N"),
        "swimming_power": cost.get("swimming_mean_power_W"),
        "froude_efficiency": cost.get("froude_efficiency"),
        "cost_of_transport": cost.get("cost_of_transport_J_kg_m"),
        "mass_kg": cost.get("mass_kg"),
        "periodic_reached": (cost.get("periodic_change") or {}).get("reached"),
        "cycle_means": cost.get("cycle_means"),
        "wall_s_per_step": step,
        "wall_s_per_cycle": step * period / dt if step else None,
        "yplus_median": yp.get("median"),
        "yplus_area_le_300": yp.get("worst_area_le_300"),
        "region_gliding_drag": {name: r.get("gliding_drag_N")
                                for name, r in (cost.get("regions") or {}).items()},
        "region_cycle_fx": region_cycle_fx(case, cost, period),
    }


def region_cycle_fx(case: Path, cost: dict, period: float) -> dict:
    """Each region's mean Fx over each stroke cycle of ``cost["cycle_means"]`` (the swimming
    run's loads, as the whole whale's cycle means are taken): {region: [one per cycle]}; {}
    without regions or cycle means."""
    starts = (cost.get("cycle_means") or {}).get("start_s") or []
    names = list(cost.get("regions") or {})
    loads = read_loads(case) if starts and names else {}
    if not all(f"whale.{name}:Fx" in loads for name in names):
        return {}
    return {name: [window_mean(loads["Time"], loads[f"whale.{name}:Fx"], a, a + period)
                   for a in starts] for name in names}


def _scale(name: str, values: dict) -> float:
    """What a figure's differences are measured against: mean Fx against the gliding drag
    (mean Fx can be near zero; the periodic test does the same), the others against
    themselves."""
    ref = values["gliding_drag"] if name == "swimming_fx" else values[name]
    return abs(ref) if ref else float("nan")


#: the formal order in space of the momentum equation's schemes (linearUpwind, linear; k and
#: omega are upwind, first order): an observed order above it lies outside the asymptotic
#: range, so the extrapolation and the GCI take this order instead (Roache's choice)
FORMAL_ORDER = 2.0
#: below this observed order the three meshes are too far from the asymptotic range for
#: Richardson extrapolation (a GCI would be many times the differences)
SLOWEST_ORDER = 0.5


def bounded_order(g: dict) -> dict:
    """A monotone figure ``g`` (:func:`adapter.studies.gci.gci`'s dict) with its observed order
    held to [SLOWEST_ORDER, FORMAL_ORDER]: above, extrapolated and GCI from FORMAL_ORDER
    (``p_observed`` keeps the observed one, ``order_capped`` True); below, ``convergence``
    "too slow" and no extrapolation or GCI, like a divergent figure."""
    p = g.get("p")
    if g["convergence"] != "monotone" or p is None or SLOWEST_ORDER <= p <= FORMAL_ORDER:
        return g
    if p < SLOWEST_ORDER:
        return {**g, "convergence": "too slow", "p_observed": p, "extrapolated": None,
                "gci_fine": None, "gci_fine_abs": None, "gci_coarse": None, "e_ext": None}
    f1, f2, f3 = g["values"]
    return {**g, **G.with_order(f1, f2, f3, g["r21"], g["r32"], FORMAL_ORDER, g["safety"]),
            "p_observed": p, "order_capped": True}


def mesh_study(meshes: dict) -> dict:
    """GCI of each figure from the three meshes' results ({1: result, 2: ..., 3: ...})."""
    h = {k: meshes[k]["background_cell_m"] for k in (1, 2, 3)}
    r21, r32 = h[2] / h[1], h[3] / h[2]
    out = {"r21": r21, "r32": r32, "figures": {}}
    gs = {}
    for key, _, label in FIGURES:
        f = [meshes[k][key] for k in (1, 2, 3)]
        if all(v is not None for v in f):
            gs[key] = bounded_order(G.gci(f[0], f[1], f[2], r21, r32))
            gs[key]["label"] = label
    # the best value of each figure: extrapolated when the three converge monotonically; the
    # finest mesh's otherwise (an oscillating or diverging sequence gives no trustworthy
    # extrapolation: Celik's p from |R| near 1 extrapolates far outside the values)
    best = {key: g["extrapolated"] if g["convergence"] in ("monotone", "converged")
            and g["extrapolated"] is not None else g["values"][0] for key, g in gs.items()}
    for key, g in gs.items():
        scale = _scale(key, best) if "gliding_drag" in best else abs(best[key])
        values = g["values"]
        g.update(reference="extrapolated" if best[key] is not values[0] else
                 f"finest mesh (no extrapolation: {g['convergence']})", scale=scale,
                 spread_abs=max(values) - min(values),
                 difference={str(k): abs(meshes[k][key] - best[key]) / scale
                             for k in (1, 2, 3)})
        if g["convergence"] in ("monotone", "converged") and g["gci_fine_abs"] is not None:
            g["gci_fine_of_scale"] = g["gci_fine_abs"] / scale
            # mesh 2's band: 1.25 x its difference from the extrapolated value
            g["band_mesh2_abs"] = G.SAFETY * abs(meshes[2][key] - best[key])
        elif g["convergence"] == "oscillatory":
            # Stern et al. (2001), J. Fluids Eng. 123(4) 793: half the range of the solutions
            g["gci_fine_of_scale"] = None
            g["band_mesh2_abs"] = 0.5 * g["spread_abs"]
        else:
            # divergent: no error estimate exists; the spread of the three is a lower bound
            g["gci_fine_of_scale"] = None
            g["band_mesh2_abs"] = g["spread_abs"]
            g["band_is_lower_bound"] = True
        out["figures"][key] = g
    return out


def self_propelled(points: list, mass: float | None, fx_band: float | None = None,
                   power_band_rel: float | None = None) -> dict:
    """Mean Fx, power against speed (``points``: dicts speed_m_s, swimming_fx,
    swimming_power): the speed where a quadratic least-squares fit of Fx(U) (linear with two
    points) is zero, the power there from the same fit of P(U), and the cost of transport.
    ``bracketed``: the data change sign; otherwise the root is extrapolated (at most half the
    speed range beyond it) and flagged. ``fx_band`` (N) and ``power_band_rel`` (mesh
    uncertainty of the middle mesh) give the uncertainty of the speed and the cost."""
    pts = sorted((p for p in points if p.get("swimming_fx") is not None),
                 key=lambda p: p["speed_m_s"])
    if len(pts) < 2:
        return {"status": "fewer than two speeds finished"}
    u = np.array([p["speed_m_s"] for p in pts])
    fx = np.array([p["swimming_fx"] for p in pts])
    pw = np.array([p["swimming_power"] for p in pts])
    deg = min(2, len(pts) - 1)
    cf = np.polyfit(u, fx, deg)
    cp = np.polyfit(u, pw, deg)
    span = u[-1] - u[0]
    roots = [float(r.real) for r in np.roots(cf) if abs(r.imag) < 1e-9
             and u[0] - 0.5 * span <= r.real <= u[-1] + 0.5 * span]
    out = {"fit": "quadratic least squares in U" if deg == 2 else "linear",
           "speeds_m_s": u.tolist(), "fx_N": fx.tolist(), "power_W": pw.tolist(),
           "fx_coefficients": cf.tolist(), "power_coefficients": cp.tolist(),
           "bracketed": bool(np.any(np.sign(fx[:-1]) != np.sign(fx[1:])))}
    if not roots:
        out["status"] = "mean Fx does not reach 0 within half the speed range beyond the data"
        return out
    mid = 0.5 * (u[0] + u[-1])
    us = min(roots, key=lambda r: abs(r - mid))
    slope = float(np.polyval(np.polyder(cf), us))
    power = float(np.polyval(cp, us))
    out.update(status="ok" if out["bracketed"] else "extrapolated", speed_m_s=us,
               power_W=power, dfx_du_N_s_m=slope)
    if mass:
        out["cost_of_transport_J_kg_m"] = power / (mass * us)
    if fx_band is not None and slope:
        du = abs(fx_band / slope)
        out["speed_uncertainty_m_s"] = du
        dp_du = float(np.polyval(np.polyder(cp), us))
        rel_p = math.hypot(power_band_rel or 0.0, dp_du * du / power if power else 0.0)
        out["power_uncertainty_W"] = rel_p * abs(power)
        if mass:
            out["cost_of_transport_uncertainty"] = out["cost_of_transport_J_kg_m"] * math.hypot(
                rel_p, du / us)
    return out


def region_study(meshes: dict) -> dict:
    """Each region's gliding drag and mean swimming Fx (body, flippers, flukes: the loads'
    regions) on the three meshes, with convergence, observed order and GCI as the whole
    whale's (:func:`bounded_order`): which part of the whale the mesh's error sits in. Mean Fx
    over the last stroke cycle all three measured, as the totals' (:func:`same_cycle`).
    ``{"gliding_drag": {region: ...}, "swimming_fx": {...}}``; a figure is left out when a mesh
    lacks it (a body without the whale's landmarks, an older study)."""
    h = {k: meshes[k]["background_cell_m"] for k in (1, 2, 3)}
    r21, r32 = h[2] / h[1], h[3] / h[2]
    ks = (1, 2, 3)
    idx = _last_common_cycle([meshes[k] for k in ks])
    values = {"gliding_drag": [meshes[k].get("region_gliding_drag") or {} for k in ks],
              "swimming_fx": [{name: v[i] for name, v in
                               (meshes[k].get("region_cycle_fx") or {}).items()}
                              if i is not None else {} for k, i in zip(ks, idx, strict=True)]}
    out: dict = {}
    for figure, per_mesh in values.items():
        for name in per_mesh[0]:
            f = [d[name] for d in per_mesh if d.get(name) is not None]
            if len(f) < 3 or not f[0]:
                continue
            f1, f2, f3 = (float(v) for v in f)
            g = bounded_order(G.gci(f1, f2, f3, r21, r32))
            if g["convergence"] == "oscillatory":
                # as the totals': half the range (Stern et al. 2001), not Celik's p from |R|
                g["band_abs"] = 0.5 * (max(f) - min(f))
            elif g.get("gci_fine_abs") is not None:
                g["gci_fine_of_value"] = g["gci_fine_abs"] / abs(f1)
            out.setdefault(figure, {})[name] = g
    return out


def _last_common_cycle(results: list) -> list:
    """For each result, the index of the last stroke cycle that every result measured (matched
    by its start time), or None for all when one has no cycle means or there is none."""
    starts: list = [(r.get("cycle_means") or {}).get("start_s") or [] for r in results]
    if not all(starts):
        return [None] * len(results)
    for a in reversed(starts[0]):
        idx = [next((j for j, b in enumerate(st)
                     if math.isclose(a, b, rel_tol=1e-9, abs_tol=1e-9)), None) for st in starts]
        if all(i is not None for i in idx):
            return idx
    return [None] * len(results)


def same_cycle(meshes: dict) -> tuple[dict, float | None]:
    """The runs' results (the meshes' {1: ..., 2: ..., 3: ...}, or any runs') with mean Fx and
    mean power taken over the last stroke cycle all of them measured, and that cycle's start (s).

    Each run stops when its own cycle means repeat to within the periodic tolerance, so one
    mesh may stop a cycle later than another and its last cycle differ from theirs by that
    tolerance alone; the same cycle of every mesh leaves the mesh's effect alone. Results
    without cycle means (an older study) keep their own last cycles (start None)."""
    keys = sorted(meshes)
    idx = _last_common_cycle([meshes[k] for k in keys])
    if idx[0] is None:
        return meshes, None
    out = {}
    for k, i in zip(keys, idx, strict=True):
        c = meshes[k]["cycle_means"]
        out[k] = {**meshes[k], "swimming_fx": c["fx_N"][i], "swimming_power": c["power_W"][i]}
    return out, meshes[keys[0]]["cycle_means"]["start_s"][idx[0]]


def meshes_compared(meshes: dict) -> dict:
    """study.json's "meshes": :func:`mesh_study` over the last cycle every mesh measured
    (:func:`same_cycle`), with that cycle's start (``cycle_start_s``, None for an older study
    whose results have no cycle means), and the regions' gliding drag and mean Fx
    (:func:`region_study`)."""
    matched, start = same_cycle(meshes)
    return {**mesh_study(matched), "cycle_start_s": start, "regions": region_study(meshes)}


def analyse(out: Path, scene, cases: list, ratio: float, failed: dict | None = None,
            scene_file=None) -> dict:
    """study.json's content from the finished cases. Its ``scene`` names the scene file when
    there is one (its stem and the preset it layers on: "edges (default)"), else the preset."""
    results = {c["name"]: case_result(out / c["name"]) for c in cases}
    label = f"{Path(scene_file).stem} ({scene.name})" if scene_file else scene.name
    study: dict = {"scene": label, "ratio": ratio, "cases": results, "failed": failed or {},
             "not_finished": [n for n, r in results.items() if r is None]}
    meshes = {k: results.get(f"mesh-{k}/case") for k in (1, 2, 3)}
    if all(meshes.values()):
        study["meshes"] = meshes_compared(meshes)
    base, half = results.get("mesh-2/case"), results.get("mesh-2/dt-half")
    if base and half:
        study["time_step"] = time_step_check(base, half)
    speed_pts = [r for n, r in results.items() if r and (n.startswith("mesh-2/speed-")
                                                         or n == "mesh-2/case")]
    if len({p["speed_m_s"] for p in speed_pts}) >= 2 and any(
            n.startswith("mesh-2/speed-") for n in results):
        figs = study.get("meshes", {}).get("figures", {})
        fx_band = figs.get("swimming_fx", {}).get("band_mesh2_abs")
        pw = figs.get("swimming_power", {})
        p_rel = (pw["band_mesh2_abs"] / abs(base["swimming_power"])
                 if pw.get("band_mesh2_abs") is not None and base else None)
        mass = next((p["mass_kg"] for p in speed_pts if p.get("mass_kg")), None)
        study["self_propelled"] = self_propelled(speed_pts, mass, fx_band, p_rel)
    return study


def time_step_check(base: dict, half: dict) -> dict:
    """What halving the step does: the gliding drag's change and, over the same stroke cycle
    (the last whole one both runs measured), mean Fx's (of the gliding drag) and mean power's.

    Each run stops when its own cycle means repeat to within the periodic tolerance (2 % of
    the drag), so their last cycles can differ by that much on their own, as much as the step
    moves them; the same cycle of both leaves the step alone. Results without cycle means (an
    older study) compare their last cycles, as ``cycle_start_s`` None says."""
    runs, start = same_cycle({"base": base, "half": half})
    fx_b, fx_h = runs["base"]["swimming_fx"], runs["half"]["swimming_fx"]
    p_b, p_h = runs["base"]["swimming_power"], runs["half"]["swimming_power"]
    drag = abs(base["gliding_drag"]) or float("nan")
    return {
        "delta_t_s": [base["delta_t_s"], half["delta_t_s"]],
        "cycle_start_s": start,
        "gliding_drag_change": abs(half["gliding_drag"] - base["gliding_drag"]) / drag,
        "swimming_fx_change_of_drag": abs(fx_h - fx_b) / drag,
        "swimming_power_change": abs(p_h - p_b) / abs(p_b),
    }


def mesh_error(g: dict, k: int) -> float:
    """Mesh ``k``'s error estimate for figure ``g`` of the mesh study (a fraction of its scale):
    its difference from the extrapolated value, or, when the three meshes oscillate (no
    extrapolation: the reference is mesh 1's own value), that difference plus mesh 1's band,
    half the range of the three (Stern et al. 2001), so that mesh 1 is not "0 % off" its own
    value."""
    d = g["difference"][str(k)]
    if g.get("reference") == "extrapolated":
        return d
    return d + 0.5 * g["spread_abs"] / g["scale"]


def choose_flow_mesh(study: dict, tolerance: float) -> dict:
    """The coarsest mesh of a finished study whose figures all lie within ``tolerance`` (a
    fraction of each figure's scale: mean Fx of the gliding drag) of their best values
    (:func:`mesh_error`); None when even mesh 1 does not, with the cell size the worst figure
    would need (from its observed order; ``beyond_study`` when that is finer than mesh 1 by
    more than the study spans from mesh 3 to mesh 1), or when a figure diverges over the
    three meshes or converges too slowly (``divergent``: its error is unknown; the spread of
    the three is a lower bound)."""
    ms = study.get("meshes")
    if not ms or not ms.get("figures"):
        raise AdapterError("the study has no finished mesh study (study.json 'meshes')")
    figs = ms["figures"]
    unknown = ("divergent", "too slow")
    divergent = [g["label"] for g in figs.values() if g["convergence"] in unknown]
    if divergent:
        return {"mesh": None, "tolerance": tolerance, "divergent": divergent,
                "worst_difference": max(g["spread_abs"] / g["scale"] for g in figs.values()
                                        if g["convergence"] in unknown),
                "background_cell_m_needed": None}
    for k in (3, 2, 1):
        worst = max(mesh_error(g, k) for g in figs.values())
        if worst <= tolerance:
            r = study["cases"][f"mesh-{k}/case"]
            return {"mesh": k, "worst_difference": worst, "cells": r["cells"],
                    "background_cell_m": r["background_cell_m"],
                    "wall_s_per_cycle": r["wall_s_per_cycle"], "tolerance": tolerance}
    need = None
    r1 = study["cases"]["mesh-1/case"]
    for g in figs.values():
        d = mesh_error(g, 1)
        if d > tolerance and g.get("p"):
            h = r1["background_cell_m"] * (tolerance / d) ** (1 / g["p"])
            need = h if need is None else min(need, h)
    # a cell finer than mesh 1 by more than the study's own span (mesh 3 to mesh 1) is an
    # extrapolation of the observed order beyond the meshes that measured it
    span = r1["background_cell_m"] / study["cases"]["mesh-3/case"]["background_cell_m"]
    return {"mesh": None, "tolerance": tolerance,
            "worst_difference": max(mesh_error(g, 1) for g in figs.values()),
            "background_cell_m_needed": need,
            "beyond_study": need is not None and need < r1["background_cell_m"] * span}
