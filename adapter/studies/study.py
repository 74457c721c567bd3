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
  layers (``layers``): by default every layer scales with the cells (count and expansion
  kept: the meshes are geometrically similar, and the first cell centre's y+ scales too);
  ``"first-kept"`` keeps the first layer's thickness and scales the stack's total thickness
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

Here: the plan and the run; the analysis in :mod:`adapter.studies.study_analysis`, the chart
and the table in :mod:`adapter.studies.study_report`.
"""

from __future__ import annotations

import argparse
import json
import shutil
import time
from pathlib import Path

import numpy as np

from adapter.errors import AdapterError, UsageError
from adapter.foam.case import Case, prepare_case, write_json
from adapter.foam.casescene import portable, scene_differences
from adapter.foam.mesh import mesh_case
from adapter.foam.parallel import ranks_option
from adapter.foam.parameters import case_parameters, stack_thickness
from adapter.foam.summary import finite
from adapter.options import default_folder, in_file, number, out_folder, positive
from adapter.scenefile import write_scene
from adapter.studies.study_analysis import analyse, case_done
from adapter.studies.study_report import format_study, plot_accuracy_vs_cost, write_study_report

PLAN = "study-plan.json"
#: every value of the scene the study was started with: a continued study must ask the same
SCENE = "study-scene.toml"
RESULT = "study.json"
CHART = "accuracy-vs-cost.png"
DEFAULT_RATIO = 1.3
DEFAULT_SPEEDS = (0.85, 1.0, 1.15, 1.3, 1.45)
PARTS = ("meshes", "dt", "speeds")
#: what ``whale-adapter study`` (and ``make study``) runs unless told
CLI_PARTS = ("meshes", "dt")
#: the snappyHexMesh layer fields a copied mesh takes along (0/)
_LAYER_FIELDS = ("nSurfaceLayers", "thickness", "thicknessFraction")


# --------------------------------------------------------------------------------------------
# the meshes and cases


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
#: how the prism layers follow the cells: ``similar`` scales every layer with them (the
#: meshes geometrically similar); ``first-kept`` keeps the first layer (its y+) and scales
#: the stack's total thickness (:func:`layer_rule`)
LAYER_RULES = ("similar", "first-kept")


def mesh_scene(scene, k: int, ratio: float, finest: str = "scene", layers: str = "similar"):
    """The scene of mesh ``k`` (1 finest, 3 coarsest): every cell ``ratio`` ** (k - 1) times the
    scene's (``finest = "scene"``) or ``ratio`` ** (k - 2) (``"refined"``: mesh 2 is the
    scene's) in the background cell and, by ``layers`` (:data:`LAYER_RULES`), the prism
    stack (the body's; with ``similar`` the fins' own first layer too); the snappy levels
    kept."""
    if finest not in FINEST:
        raise AdapterError(f"finest = {finest!r}: choose one of {', '.join(FINEST)}")
    if layers not in LAYER_RULES:
        raise AdapterError(f"layers = {layers!r}: choose one of {', '.join(LAYER_RULES)}")
    c = scene.case
    scale = ratio ** (k - (1 if finest == "scene" else 2))
    changes = {}
    if c.background_cell_m > 0:
        changes["background_cell_m"] = c.background_cell_m * scale
    else:
        changes["background_cell"] = c.background_cell * scale
    if layers == "similar":
        changes["first_layer_m"] = c.first_layer_m * scale
        changes["fin_first_layer_m"] = c.fin_first_layer_m * scale
    else:
        # the fins' own first layer kept too, their stack growing by the body's expansion
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
               parts=PARTS, finest: str = "scene", layers: str = "similar") -> list:
    """The study's cases in the order they run: dicts with ``name`` (folder relative to the
    study), ``scene``, ``part``, ``mesh`` (1-3), ``mesh_from`` (a case whose mesh it reuses, or
    None), ``dt_s``, ``speed_factor``."""
    if ratio < 1.3:
        raise AdapterError(f"--ratio {ratio}: the refinement ratio must be at least 1.3 "
                           "(Celik et al. 2008)")
    # the study's cases are tethered pairs: its speeds part finds the self-propelled speed,
    # and a free run on every case would multiply the study's cost
    scene = scene.replace(free={"enabled": False})
    dt = study_dt(scene, surface)
    cases = []
    meshes = {k: mesh_scene(scene, k, ratio, finest, layers).replace(case={"dt_s": dt})
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


def _check_scene(out: Path, scene, source: str) -> None:
    """Refuse a study folder whose study was started with another scene (any value, not only
    its file's name); write the scene there when the folder has none yet."""
    path = out / SCENE
    if not path.is_file():
        out.mkdir(parents=True, exist_ok=True)
        write_scene(portable(scene), path,
                    "The scene this flow study was started with, every value, written by\n"
                    "whale-adapter: continuing the study in this folder asks for the same.\n"
                    f"Started from: {source}")
        return
    from adapter.scene import load_scene

    differs = scene_differences(scene, load_scene(path))
    if differs:
        raise AdapterError(
            f"{out} holds a study of another scene ({'; '.join(differs[:3])}"
            f"{'; ...' if len(differs) > 3 else ''}: asked vs {path.name}); run it with the "
            "same scene to continue it, or choose another --out")


def _check_plan(out: Path, plan: dict) -> None:
    path = out / PLAN
    if path.is_file():
        # plans written before "finest" and "layers" existed ran these
        old = {"finest": "refined", "layers": "first-kept", **json.loads(path.read_text())}
        differs = [k for k in ("scene_file", "preset", "ratio", "speeds", "finest", "layers")
                   if old.get(k) != plan.get(k)]
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
    rec, base = Case(dst).record, Case(src).record
    rec["mesh"] = dict(base.get("mesh", {}), copied_from=str(src))
    Case(dst).save(rec)


def _meshed(case: Path) -> bool:
    return "mesh" in Case(case).record and (case / "constant" / "polyMesh" / "owner").is_file()


def run_study(scene, out, *, ratio: float = DEFAULT_RATIO, speeds=DEFAULT_SPEEDS,
              parts=PARTS, ranks=None, scene_file=None, progress: bool = True, runner=None,
              mesher=None, surface=None, log=print, finest: str = "scene",
              layers: str = "similar") -> dict:
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
            "preset": scene.name, "ratio": ratio, "speeds": speeds, "finest": finest,
            "layers": layers}
    _check_plan(out, plan)
    _check_scene(out, scene, plan["scene_file"] or f"preset {scene.name}")
    cases = plan_cases(scene, surface, ratio, speeds, parts, finest, layers)
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
            record = Case(case).record
            runner(case, record, float(record["periodic_tolerance"]), ranks, progress)
            log(f"{head}: done ({time.perf_counter() - t0:.0f} s into the study)")
        except AdapterError as exc:
            failed[c["name"]] = str(exc)
            log(f"{head}: failed: {exc}")
    study = analyse(out, scene, cases, ratio, failed, scene_file)
    study["finest"] = finest
    study["layers"] = layers
    study["wall_s_this_run"] = round(time.perf_counter() - t0, 1)
    write_json(out / RESULT, finite(study))
    try:
        plot_accuracy_vs_cost(study, out / CHART)
    except AdapterError as exc:
        log(f"no chart: {exc}")
    write_study_report(out, study, out / CHART)
    return study


# --------------------------------------------------------------------------------------------
# command line


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "study", help="the flow study: three meshes (GCI), the time step, the speeds if asked",
        description="Run the scene's gliding + swimming pair on three systematically refined "
        "meshes (one refinement ratio on every cell size; Richardson extrapolation and "
        "Roache's GCI for gliding drag, mean swimming Fx and mean power), on the middle mesh "
        "with the time step halved, and with --parts ...,speeds at several flow speeds (the "
        "self-propelled speed, mean Fx = 0). Writes <out>/study.json and "
        "<out>/accuracy-vs-cost.png; run it again to continue a stopped study (docs/case.md, "
        "'The flow study').")
    p.add_argument("--scene", type=in_file, help="scene TOML file (default: built-in default)")
    p.add_argument("--preset", help="built-in preset: default, smoke, fine")
    p.add_argument("--out", type=out_folder,
                   help="study folder (default: runs/study-<scene file's stem> with --scene, "
                   "as make study SCENE=my.toml gives runs/study-my; else runs/study-<preset>)")
    p.add_argument("--ratio", type=number(float, 1.3), default=DEFAULT_RATIO,
                   help=f"refinement ratio between the meshes, >= 1.3 (default {DEFAULT_RATIO})")
    p.add_argument("--finest", choices=FINEST, default="refined",
                   help="which mesh is the finest: one refined beyond the scene's (default; "
                   "mesh 2 the scene's) or the scene's own (meshes 2 and 3 coarser)")
    p.add_argument("--layers", choices=LAYER_RULES, default="similar",
                   help="how the prism layers follow the cells: every layer scaled with them "
                   "(default; the meshes geometrically similar, the first cell's y+ scales "
                   "too) or the first layer kept (the same y+, the stack's thickness scaled)")
    p.add_argument("--speeds", default=",".join(f"{f:g}" for f in DEFAULT_SPEEDS),
                   help="flow speeds as multiples of the scene's, comma-separated (default "
                   "%(default)s)")
    p.add_argument("--parts", default=",".join(CLI_PARTS),
                   help="which parts to run: meshes, dt, speeds (default %(default)s: run-case's "
                   "free stage gives the self-propelled speed, speeds checks it)")
    p.add_argument("--np", type=ranks_option, default=None, dest="ranks",
                   help="MPI ranks per case, or auto: the machine's cores (default: the "
                        "scene's case.ranks; 0 there: auto)")
    p.add_argument("--quiet", "-q", action="store_true",
                   help="no progress and no report on stdout, only warnings and errors on stderr")
    p.set_defaults(func=_cmd_study)


def _cmd_study(args: argparse.Namespace) -> int:
    from adapter.scene import load_scene

    scene = load_scene(args.scene, preset=args.preset)
    parts = tuple(s.strip() for s in args.parts.split(",") if s.strip())
    bad = [s for s in parts if s not in PARTS]
    if bad:
        raise UsageError(f"--parts: unknown {', '.join(bad)}; choose from {', '.join(PARTS)}")
    try:
        speeds = [positive(s) for s in args.speeds.split(",") if s.strip()]
    except argparse.ArgumentTypeError as exc:
        raise UsageError(f"--speeds: {exc}") from None
    if "speeds" in parts and len(speeds) < 3:
        raise UsageError("--speeds: give at least three speeds")
    out = Path(args.out or default_folder(args.scene, args.preset, prefix="study-"))
    study = run_study(scene, out, ratio=args.ratio, speeds=speeds, parts=parts,
                      finest=args.finest, layers=args.layers, ranks=args.ranks,
                      scene_file=args.scene,
                      progress=not args.quiet)
    print(f"\n{out}: the flow study")
    print(format_study(study))
    print(f"(all figures: {out / RESULT}; chart: {out / CHART})")
    return 1 if study["failed"] else 0

