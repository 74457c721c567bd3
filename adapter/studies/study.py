"""The flow study (``whale-adapter study``): error bars on the answer, accuracy against cost, and
the self-propelled speed.

For one scene it runs, each case in its own folder under ``<study>/``:

- ``mesh-1/case``, ``mesh-2/case``, ``mesh-3/case``: the gliding + swimming pair
  (:func:`adapter.foam.swimrun.run_swim_and_glide`) on three systematically refined meshes, each
  ``ratio`` times coarser than the one before. ``finest = "scene"`` (the default): mesh 1 is
  the scene's own mesh; ``"refined"``: mesh 2 is, and mesh 1 has every cell ``ratio`` times
  smaller (with the paper's hinged fluke gate the surface folds at the hinge within one
  network edge, which a mesh finer than the default cannot follow: docs/stroke.md). The
  blockMesh background cell (``case.background_cell``, or ``background_cell_m``)
  scales, the snappyHexMesh levels stay, so every castellated cell scales with it. The prism
  layers: the first layer keeps its thickness (the first cell centre's y+ stays where the
  wall function holds it), the stack's total thickness scales with the cells
  (:func:`layer_rule`). The flow step is the same on all three (the scene's ``case.dt_s``, or
  the automatic step of the scene's own mesh), so the three differ in space only.
- ``mesh-2/dt-half``: mesh 2 with the flow step halved (the time-step check; exactly half
  of mesh 2's rounded step).
- ``mesh-2/speed-<f>``: mesh 2 at ``f`` times the scene's flow speed (``f = 1`` is
  ``mesh-2/case``); mean swimming Fx against speed, fitted by a quadratic in U (least squares;
  through the points for three) and solved for mean Fx = 0: the self-propelled speed, with the
  power and cost of transport there.

Then Richardson extrapolation and Roache's GCI (adapter/studies/gci.py) for gliding drag, mean
swimming Fx and mean power; ``<study>/study.json``, a table, and ``accuracy-vs-cost.png``.
A stopped study run again continues: finished cases are skipped, unfinished ones resume from
their latest written time (run_case). See docs/case.md, "The flow study".
"""

from __future__ import annotations

import argparse
import json
import math
import shutil
import time
from pathlib import Path

import numpy as np

from adapter.errors import AdapterError
from adapter.foam.case import CASE_RECORD, prepare_case, read_record, write_json
from adapter.foam.mesh import mesh_case
from adapter.foam.parameters import case_parameters
from adapter.foam.summary import SUMMARY
from adapter.studies import gci as G

PLAN = "study-plan.json"
RESULT = "study.json"
CHART = "accuracy-vs-cost.png"
DEFAULT_RATIO = 1.3
DEFAULT_SPEEDS = (0.85, 1.0, 1.15, 1.3, 1.45)
PARTS = ("meshes", "dt", "speeds")
#: the figures of the mesh study: (key in study.json, key of swimming_cost, label)
FIGURES = (("gliding_drag", "gliding_drag_N", "gliding drag (N)"),
           ("swimming_fx", "swimming_mean_fx_N", "mean swimming Fx (N)"),
           ("swimming_power", "swimming_mean_power_W", "mean power (W)"))
#: the snappyHexMesh layer fields a copied mesh takes along (0/)
_LAYER_FIELDS = ("nSurfaceLayers", "thickness", "thicknessFraction")


# --------------------------------------------------------------------------------------------
# the meshes and cases


def stack_thickness(first: float, layers: int, expansion: float) -> float:
    """Total thickness of ``layers`` prism layers from ``first`` growing by ``expansion``."""
    if layers <= 0:
        return 0.0
    if abs(expansion - 1.0) < 1e-12:
        return first * layers
    return first * (expansion**layers - 1) / (expansion - 1)


def layer_rule(first: float, layers: int, expansion: float, scale: float) -> tuple:
    """(layers, expansion) for a mesh whose cells are ``scale`` times the scene's: the first
    layer stays ``first`` thick (its y+ stays in the wall function's band), the stack's total
    thickness becomes ``scale`` times the scene's. The expansion is solved for (bisection,
    within the scene's allowed 1-3); when no expansion in 1-3 reaches it with the scene's
    layer count, one layer fewer or more is tried, and so on."""
    if layers <= 0:
        return layers, expansion
    target = scale * stack_thickness(first, layers, expansion)
    for dn in (0, -1, 1, -2, 2, -3, 3):
        n = layers + dn
        if n < 1 or n > 20:
            continue
        lo, hi = 1.0, 3.0
        if not stack_thickness(first, n, lo) <= target <= stack_thickness(first, n, hi):
            continue
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            if stack_thickness(first, n, mid) < target:
                lo = mid
            else:
                hi = mid
        return n, round(0.5 * (lo + hi), 6)
    raise AdapterError(f"no prism layer stack from a first layer of {first} m with expansion "
                       f"1-3 is {target:.4g} m thick; choose another refinement ratio")


FINEST = ("scene", "refined")


def mesh_scene(scene, k: int, ratio: float, finest: str = "scene"):
    """The scene of mesh ``k`` (1 finest, 3 coarsest): every cell ``ratio`` ** (k - 1) times the
    scene's (``finest = "scene"``) or ``ratio`` ** (k - 2) (``"refined"``: mesh 2 is the
    scene's) in the background cell and the prism stack, the first layer and the snappy levels
    kept."""
    if finest not in FINEST:
        raise AdapterError(f"finest = {finest!r}: choose one of {', '.join(FINEST)}")
    c = scene.case
    scale = ratio ** (k - (1 if finest == "scene" else 2))
    changes = {}
    if c.background_cell_m > 0:
        changes["background_cell_m"] = c.background_cell_m * scale
    else:
        changes["background_cell"] = c.background_cell * scale
    n, e = layer_rule(c.first_layer_m, c.layers, c.layer_expansion, scale)
    changes.update(layers=n, layer_expansion=e)
    return scene.replace(case=changes)


def study_dt(scene, surface) -> float:
    """The flow step every mesh of the study uses (case.dt_s before rounding): the scene's
    ``case.dt_s``, or the automatic step of the scene's own mesh (mesh 2)."""
    if scene.case.dt_s > 0:
        return scene.case.dt_s
    pts = np.asarray(surface.points)
    p = case_parameters(scene, pts.min(axis=0), pts.max(axis=0), length=surface.length)
    return 0.5 * p.smallest_cell_m / scene.flow.speed_m_s


def _speed_name(f: float) -> str:
    return f"speed-{f:g}"


def plan_cases(scene, surface, ratio: float = DEFAULT_RATIO, speeds=DEFAULT_SPEEDS,
               parts=PARTS, finest: str = "scene") -> list:
    """The study's cases in the order they run: dicts with ``name`` (folder relative to the
    study), ``scene``, ``part``, ``mesh`` (1-3), ``mesh_from`` (a case whose mesh it reuses, or
    None), ``dt_s``, ``speed_factor``."""
    if ratio < 1.3:
        raise AdapterError(f"--ratio {ratio}: the refinement ratio must be at least 1.3 "
                           "(Celik et al. 2008)")
    dt = study_dt(scene, surface)
    cases = []
    meshes = {k: mesh_scene(scene, k, ratio, finest).replace(case={"dt_s": dt})
              for k in (1, 2, 3)}
    if "meshes" in parts:
        for k in (3, 2, 1):
            cases.append({"name": f"mesh-{k}/case", "scene": meshes[k], "part": "meshes",
                          "mesh": k, "mesh_from": None, "dt_s": dt, "speed_factor": 1.0})
    base = "mesh-2/case"
    if "dt" in parts:
        # exactly half of mesh 2's (rounded) step: half its write interval's step
        pts = np.asarray(surface.points)
        p2 = case_parameters(meshes[2], pts.min(axis=0), pts.max(axis=0),
                             length=surface.length)
        half = scene.period_s / scene.case.writes_per_cycle / (2 * p2.steps_per_write)
        cases.append({"name": "mesh-2/dt-half", "scene": meshes[2].replace(
            case={"dt_s": half}), "part": "dt", "mesh": 2, "mesh_from": base,
            "dt_s": half, "speed_factor": 1.0})
    if "speeds" in parts:
        u = scene.flow.speed_m_s
        for f in sorted(speeds):
            if abs(f - 1.0) < 1e-9:
                if "meshes" not in parts:
                    cases.append({"name": base, "scene": meshes[2], "part": "meshes", "mesh": 2,
                                  "mesh_from": None, "dt_s": dt, "speed_factor": 1.0})
                continue
            cases.append({"name": f"mesh-2/{_speed_name(f)}", "scene": meshes[2].replace(
                flow={"speed_m_s": u * f}), "part": "speeds", "mesh": 2, "mesh_from": base,
                "dt_s": dt, "speed_factor": f})
    return cases


def _check_plan(out: Path, plan: dict) -> None:
    path = out / PLAN
    if path.is_file():
        old = json.loads(path.read_text())
        differs = [k for k in ("scene_file", "preset", "ratio", "speeds", "finest")
                   if old.get(k, "refined" if k == "finest" else None) != plan.get(k)]
        if differs:
            was = ", ".join(f"{k}: {old.get(k)!r}" for k in differs)
            asked = ", ".join(f"{k}: {plan.get(k)!r}" for k in differs)
            raise AdapterError(
                f"{out} holds a study of another plan ({was}; asked: {asked}); run it with "
                "the same options to continue it, or choose another --out")
    out.mkdir(parents=True, exist_ok=True)
    write_json(path, plan)


def _copy_mesh(src: Path, dst: Path) -> None:
    """The mesh of ``src`` (constant/polyMesh, snappyHexMesh's layer fields in 0/, the mesh
    record) into the prepared case ``dst``."""
    target = dst / "constant" / "polyMesh"
    if target.exists():
        shutil.rmtree(target)
    shutil.copytree(src / "constant" / "polyMesh", target)
    (dst / "0").mkdir(exist_ok=True)
    for name in _LAYER_FIELDS:
        if (src / "0" / name).is_file():
            shutil.copy2(src / "0" / name, dst / "0" / name)
    rec, base = read_record(dst), read_record(src)
    rec["mesh"] = dict(base.get("mesh", {}), copied_from=str(src))
    write_json(dst / CASE_RECORD, rec)


def _meshed(case: Path) -> bool:
    return "mesh" in read_record(case) and (case / "constant" / "polyMesh" / "owner").is_file()


def case_done(case: Path) -> bool:
    """The pair of this folder has its answer (``swimming_cost`` in adapter-summary.json)."""
    path = case / SUMMARY
    if not path.is_file():
        return False
    try:
        return "swimming_cost" in json.loads(path.read_text())
    except json.JSONDecodeError:
        return False


def run_study(scene, out, *, ratio: float = DEFAULT_RATIO, speeds=DEFAULT_SPEEDS,
              parts=PARTS, ranks=None, scene_file=None, progress: bool = True, runner=None,
              mesher=None, surface=None, log=print, finest: str = "scene") -> dict:
    """Prepare, mesh and run every case of the study (skipping finished ones), then analyse.

    ``runner(case, record, tolerance, ranks, progress) -> summary`` runs one pair (default
    :func:`adapter.foam.swimrun.run_swim_and_glide`); ``mesher(case)`` meshes a prepared case
    (default :func:`adapter.foam.mesh.mesh_case`). Returns study.json's content."""
    if runner is None:
        from adapter.foam.swimrun import run_swim_and_glide

        def runner(case, record, tolerance, ranks, progress):
            return run_swim_and_glide(case, record, tolerance, ranks=ranks, progress=progress)
    mesher = mesher or mesh_case
    out = Path(out).resolve()
    if surface is None:
        from adapter.body.geometry import build_surface

        surface = build_surface(scene)
    speeds = sorted(float(f) for f in speeds)
    plan = {"scene_file": str(Path(scene_file).resolve()) if scene_file else None,
            "preset": scene.name, "ratio": ratio, "speeds": speeds, "finest": finest}
    _check_plan(out, plan)
    cases = plan_cases(scene, surface, ratio, speeds, parts, finest)
    failed = {}
    t0 = time.perf_counter()
    for i, c in enumerate(cases, 1):
        case = out / c["name"]
        head = f"[study {i}/{len(cases)}] {c['name']}"
        if (case / "system" / "controlDict").exists() and case_done(case):
            log(f"{head}: finished earlier, skipped")
            continue
        try:
            if not (case / "system" / "controlDict").exists():
                params = prepare_case(c["scene"], case, ranks=ranks, scene_file=scene_file,
                                      surface=surface)
                log(f"{head}: prepared (background cell {params.cell_size[0]:.4g} m, "
                    f"dt {params.delta_t:.5g} s, speed {c['scene'].flow.speed_m_s:.4g} m/s)")
            else:
                log(f"{head}: continuing it")
            if not _meshed(case):
                src = out / c["mesh_from"] if c["mesh_from"] else None
                if src is not None and _meshed(src):
                    _copy_mesh(src, case)
                    log(f"{head}: mesh copied from {c['mesh_from']}")
                else:
                    info = mesher(case)
                    log(f"{head}: meshed, {info.get('cells')} cells")
            record = read_record(case)
            runner(case, record, float(record["periodic_tolerance"]), ranks, progress)
            log(f"{head}: done ({time.perf_counter() - t0:.0f} s into the study)")
        except AdapterError as exc:
            failed[c["name"]] = str(exc)
            log(f"{head}: failed: {exc}")
    study = analyse(out, scene, cases, ratio, failed)
    study["finest"] = finest
    study["wall_s_this_run"] = round(time.perf_counter() - t0, 1)
    write_json(out / RESULT, _finite(study))
    try:
        plot_accuracy_vs_cost(study, out / CHART)
    except AdapterError as exc:
        log(f"no chart: {exc}")
    return study


# --------------------------------------------------------------------------------------------
# the analysis


def case_result(case: Path) -> dict | None:
    """The figures of one finished pair (None when it has none)."""
    if not case_done(case):
        return None
    s = json.loads((case / SUMMARY).read_text())
    rec = read_record(case)
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
        "wall_s_per_step": step,
        "wall_s_per_cycle": step * period / dt if step else None,
        "yplus_median": yp.get("median"),
        "yplus_area_le_300": yp.get("worst_area_le_300"),
    }


def _scale(name: str, values: dict) -> float:
    """What a figure's differences are measured against: mean Fx against the gliding drag
    (mean Fx can be near zero; the periodic test does the same), the others against
    themselves."""
    ref = values["gliding_drag"] if name == "swimming_fx" else values[name]
    return abs(ref) if ref else float("nan")


def mesh_study(meshes: dict) -> dict:
    """GCI of each figure from the three meshes' results ({1: result, 2: ..., 3: ...})."""
    h = {k: meshes[k]["background_cell_m"] for k in (1, 2, 3)}
    r21, r32 = h[2] / h[1], h[3] / h[2]
    out = {"r21": r21, "r32": r32, "figures": {}}
    gs = {}
    for key, _, label in FIGURES:
        f = [meshes[k][key] for k in (1, 2, 3)]
        if all(v is not None for v in f):
            gs[key] = G.gci(*f, r21, r32)
            gs[key]["label"] = label
    # the best value of each figure: extrapolated, or the finest mesh's when divergent
    best = {key: g["extrapolated"] if g["extrapolated"] is not None else g["values"][0]
            for key, g in gs.items()}
    for key, g in gs.items():
        scale = _scale(key, best) if "gliding_drag" in best else abs(best[key])
        g.update(reference="extrapolated" if g["extrapolated"] is not None
                 else "finest mesh (no extrapolation: divergent)", scale=scale,
                 difference={str(k): abs(meshes[k][key] - best[key]) / scale
                             for k in (1, 2, 3)})
        if g["gci_fine_abs"] is not None:
            g["gci_fine_of_scale"] = g["gci_fine_abs"] / scale
            # mesh 2's band: 1.25 x its difference from the extrapolated value
            g["band_mesh2_abs"] = G.SAFETY * abs(meshes[2][key] - best[key])
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


def analyse(out: Path, scene, cases: list, ratio: float, failed: dict | None = None) -> dict:
    """study.json's content from the finished cases."""
    results = {c["name"]: case_result(out / c["name"]) for c in cases}
    study = {"scene": scene.name, "ratio": ratio, "cases": results, "failed": failed or {},
             "not_finished": [n for n, r in results.items() if r is None]}
    meshes = {k: results.get(f"mesh-{k}/case") for k in (1, 2, 3)}
    if all(meshes.values()):
        study["meshes"] = mesh_study(meshes)
    base, half = results.get("mesh-2/case"), results.get("mesh-2/dt-half")
    if base and half:
        drag = abs(base["gliding_drag"]) or float("nan")
        study["time_step"] = {
            "delta_t_s": [base["delta_t_s"], half["delta_t_s"]],
            "gliding_drag_change": abs(half["gliding_drag"] - base["gliding_drag"]) / drag,
            "swimming_fx_change_of_drag": abs(half["swimming_fx"] - base["swimming_fx"]) / drag,
            "swimming_power_change": abs(half["swimming_power"] - base["swimming_power"])
            / abs(base["swimming_power"]),
        }
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


def _finite(obj):
    if isinstance(obj, dict):
        return {k: _finite(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_finite(v) for v in obj]
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


# --------------------------------------------------------------------------------------------
# what it shows


def plot_accuracy_vs_cost(study: dict, path: Path) -> None:
    """Each figure's difference from its extrapolated value (of its scale, %) against the wall
    time per swimming cycle of each mesh; hollow markers: the GCI of the finest mesh."""
    ms = study.get("meshes")
    if not ms or not ms.get("figures"):
        raise AdapterError("the three meshes have not all finished: nothing to chart")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cost = {k: (study["cases"][f"mesh-{k}/case"] or {}).get("wall_s_per_cycle") for k in
            (1, 2, 3)}
    fig, ax = plt.subplots(figsize=(7.5, 4.8), dpi=110)
    for n, g in enumerate(ms["figures"].values()):
        colour = f"C{n}"
        pts = [(cost[k], 100 * g["difference"][str(k)]) for k in (1, 2, 3)
               if cost[k] and g["difference"][str(k)] > 0]
        if pts:
            x, y = zip(*sorted(pts), strict=True)
            ax.plot(x, y, "o-", color=colour, label=f"{g['label']}: |f - f_ext| / scale")
            for k in (1, 2, 3) if n == 0 else ():
                if cost[k] and g["difference"][str(k)] > 0:
                    ax.annotate(f"mesh {k}", (cost[k], 100 * g["difference"][str(k)]),
                                textcoords="offset points", xytext=(4, 4), fontsize=7)
        if g.get("gci_fine_of_scale") and cost[1]:
            ax.plot([cost[1]], [100 * g["gci_fine_of_scale"]], "o", mfc="none", ms=10,
                    color=colour, label=f"{g['label']}: GCI of mesh 1 ({g['convergence']})")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("wall time per stroke cycle, swimming (s)")
    ax.set_ylabel("error estimate (% of the figure; Fx: of the gliding drag)")
    ax.set_title(f"Accuracy against cost: {study.get('scene')}, refinement ratio "
                 f"{study.get('ratio')}", fontsize=10)
    ax.grid(True, which="both", color="0.9")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def format_study(study: dict) -> str:
    """The short table printed at the end."""
    lines = []
    ms = study.get("meshes")
    rows = [(f"mesh-{k}", study["cases"].get(f"mesh-{k}/case")) for k in (1, 2, 3)]
    if any(r for _, r in rows):
        lines.append(f"{'mesh':<8}{'cells':>10}{'cell (m)':>10}{'drag (N)':>11}{'Fx (N)':>10}"
                     f"{'power (W)':>11}{'s/cycle':>9}")
        for name, r in rows:
            if r:
                lines.append(f"{name:<8}{r['cells'] or 0:>10,}{r['background_cell_m']:>10.3g}"
                             f"{r['gliding_drag']:>11.1f}{r['swimming_fx']:>10.1f}"
                             f"{r['swimming_power']:>11.1f}{r['wall_s_per_cycle'] or 0:>9.0f}")
    if ms:
        lines.append(f"refinement ratios r21 {ms['r21']:.3f}, r32 {ms['r32']:.3f}")
        for g in ms["figures"].values():
            ext = "-" if g["extrapolated"] is None else f"{g['extrapolated']:.1f}"
            p = "-" if g["p"] is None else f"{g['p']:.2f}"
            gf = "-" if g.get("gci_fine_of_scale") is None else f"{g['gci_fine_of_scale']:.2%}"
            lines.append(f"  {g['label']:<22} {g['convergence']:<11} p {p:>5}  extrapolated "
                         f"{ext:>9}  GCI(mesh 1) {gf}")
    ts = study.get("time_step")
    if ts:
        lines.append(f"time step {ts['delta_t_s'][0]:.4g} -> {ts['delta_t_s'][1]:.4g} s: drag "
                     f"{ts['gliding_drag_change']:.2%}, Fx {ts['swimming_fx_change_of_drag']:.2%}"
                     f" of drag, power {ts['swimming_power_change']:.2%}")
    sp = study.get("self_propelled")
    if sp and sp.get("speed_m_s") is not None:
        unc = (f" +- {sp['speed_uncertainty_m_s']:.2g}" if sp.get("speed_uncertainty_m_s")
               is not None else "")
        cot = sp.get("cost_of_transport_J_kg_m")
        lines.append(f"self-propelled speed {sp['speed_m_s']:.3g}{unc} m/s ({sp['status']}, "
                     f"{sp['fit']}), power {sp['power_W']:.0f} W"
                     + (f", cost of transport {cot:.3g} J/(kg m)" if cot else ""))
    elif sp:
        lines.append(f"self-propelled speed: {sp.get('status')}")
    if study.get("not_finished"):
        lines.append("not finished: " + ", ".join(study["not_finished"]))
    return "\n".join(lines)


def choose_flow_mesh(study: dict, tolerance: float) -> dict:
    """The coarsest mesh of a finished study whose figures all lie within ``tolerance`` (a
    fraction of each figure's scale: mean Fx of the gliding drag) of the extrapolated values;
    None when even mesh 1 does not, with the cell size the worst figure would need (from its
    observed order)."""
    ms = study.get("meshes")
    if not ms or not ms.get("figures"):
        raise AdapterError("the study has no finished mesh study (study.json 'meshes')")
    figs = ms["figures"]
    for k in (3, 2, 1):
        worst = max(g["difference"][str(k)] for g in figs.values())
        if worst <= tolerance:
            r = study["cases"][f"mesh-{k}/case"]
            return {"mesh": k, "worst_difference": worst, "cells": r["cells"],
                    "background_cell_m": r["background_cell_m"],
                    "wall_s_per_cycle": r["wall_s_per_cycle"], "tolerance": tolerance}
    need = None
    r1 = study["cases"]["mesh-1/case"]
    for g in figs.values():
        d = g["difference"]["1"]
        if d > tolerance and g.get("p"):
            h = r1["background_cell_m"] * (tolerance / d) ** (1 / g["p"])
            need = h if need is None else min(need, h)
    return {"mesh": None, "tolerance": tolerance,
            "worst_difference": max(g["difference"]["1"] for g in figs.values()),
            "background_cell_m_needed": need}


# --------------------------------------------------------------------------------------------
# command line


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "study", help="the flow study: three meshes (GCI), time step, self-propelled speed",
        description="Run the scene's gliding + swimming pair on three systematically refined "
        "meshes (one refinement ratio on every cell size; Richardson extrapolation and "
        "Roache's GCI for gliding drag, mean swimming Fx and mean power), on the middle mesh "
        "with the time step halved, and at several flow speeds (the self-propelled speed, "
        "mean Fx = 0). Writes <out>/study.json and <out>/accuracy-vs-cost.png; run it again "
        "to continue a stopped study (docs/case.md, 'The flow study').")
    p.add_argument("--scene", help="scene TOML file (default: built-in default)")
    p.add_argument("--preset", help="built-in preset: default, smoke, fine")
    p.add_argument("--out", help="study folder (default: runs/study-<preset>)")
    p.add_argument("--ratio", type=float, default=DEFAULT_RATIO,
                   help=f"refinement ratio between the meshes, >= 1.3 (default {DEFAULT_RATIO})")
    p.add_argument("--finest", choices=FINEST, default="scene",
                   help="which mesh is the finest: the scene's own (default; meshes 2 and 3 "
                   "coarser) or one refined beyond it (mesh 2 the scene's)")
    p.add_argument("--speeds", default=",".join(f"{f:g}" for f in DEFAULT_SPEEDS),
                   help="flow speeds as multiples of the scene's, comma-separated (default "
                   "%(default)s)")
    p.add_argument("--parts", default=",".join(PARTS),
                   help="which parts to run: meshes, dt, speeds (default all)")
    p.add_argument("--np", type=int, default=None, dest="ranks", help="MPI ranks per case")
    p.set_defaults(func=_cmd_study)


def _cmd_study(args: argparse.Namespace) -> int:
    from adapter.scene import load_scene

    scene = load_scene(args.scene, preset=args.preset)
    parts = tuple(s.strip() for s in args.parts.split(",") if s.strip())
    bad = [s for s in parts if s not in PARTS]
    if bad:
        raise AdapterError(f"--parts: unknown {', '.join(bad)}; choose from {', '.join(PARTS)}")
    try:
        speeds = [float(s) for s in args.speeds.split(",") if s.strip()]
    except ValueError:
        raise AdapterError(f"--speeds: expected numbers, got {args.speeds!r}") from None
    if "speeds" in parts and len(speeds) < 3:
        raise AdapterError("--speeds: give at least three speeds")
    out = Path(args.out or Path("runs") / f"study-{scene.name}")
    study = run_study(scene, out, ratio=args.ratio, speeds=speeds, parts=parts,
                      finest=args.finest,
                      ranks=args.ranks, scene_file=args.scene)
    print(f"\n{out}: the flow study")
    print(format_study(study))
    print(f"(all figures: {out / RESULT}; chart: {out / CHART})")
    return 1 if study["failed"] else 0

