"""The ``run-case`` command: prepare, mesh and run the case (:mod:`adapter.foam.case`,
:mod:`adapter.foam.mesh`, :mod:`adapter.foam.run`), or the gliding + swimming pair of a scene
that asks for it (:mod:`adapter.foam.swimrun`)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from adapter.coupling.server import resolve_token
from adapter.errors import CaseError, UsageError
from adapter.foam.case import CASE_RECORD, Case, parallel_settings, prepare_case
from adapter.foam.casescene import case_scene_file, scene_differences
from adapter.foam.dictionaries import DECOMPOSITIONS, choose_decomposition, parsed_dict
from adapter.foam.folders import asked_start, resume_time
from adapter.foam.mesh import mesh_case
from adapter.foam.parallel import ranks_option
from adapter.foam.report import REPORT, write_report
from adapter.foam.run import run_case
from adapter.foam.summary import SUMMARY, format_summary
from adapter.foam.swimrun import COST_ROWS, run_swim_and_glide
from adapter.options import default_folder, in_file, out_folder, port
from adapter.scene import load_scene

#: run-case's exit code when the swimming run ended without reaching its periodic state
NOT_PERIODIC = 3


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "run-case",
        help="prepare, mesh and run the OpenFOAM whale-in-channel case",
        description="Prepare the case from the template (foam_case/) and the scene unless --case "
        "already holds one, mesh it when it has no mesh, then run pimpleFoam with the "
        "step-server and write adapter-summary.json. Exit code 2: a bad input; "
        f"{NOT_PERIODIC}: the swimming run ended without reaching its periodic state (a "
        "warning says by how much).",
    )
    p.add_argument("--scene", type=in_file, help="scene TOML file (default: built-in default)")
    p.add_argument("--preset", help="built-in preset: default, smoke, fine")
    p.add_argument("--case", "--out", dest="case", default=None, type=out_folder,
                   help="case folder (default: runs/<scene file's stem> with --scene, as make "
                        "run-case SCENE=my.toml gives runs/my; else runs/<preset>); --out is "
                        "the same, the output place's spelling in the other commands")
    p.add_argument("--np", type=ranks_option, default=None, dest="ranks",
                   help="MPI ranks, or auto: the machine's cores (default: the scene's "
                        "case.ranks; 0 there: auto)")
    p.add_argument("--mesh-only", action="store_true", help="prepare and mesh, do not run")
    p.add_argument("--static-whale", action="store_true",
                   help="flow only: the whale does not move, no step-server or plugin needed")
    p.add_argument("--host", default=None,
                   help="the step-server listens on TCP at this host name or address (e.g. "
                        "0.0.0.0 for every interface; published in the case's endpoint file) "
                        "instead of the case's UNIX socket; a non-loopback host needs a token")
    p.add_argument("--port", type=port, default=None,
                   help="TCP port of the step-server (default 0: any free one)")
    p.add_argument("--token-file", default=None, metavar="FILE", type=in_file,
                   help="the shared secret, in a file only its owner may read (chmod 600); "
                        "default $WHALE_ADAPTER_TOKEN. Never written into the case")
    p.add_argument("--launcher", default=None, metavar="CMD",
                   help="how the MPI ranks are started, e.g. 'srun -n {np}' or 'mpirun "
                        "--hostfile hosts -np {np}' ({np}: the rank count; without it -np N "
                        "is appended); default: the scene's case.launcher, else mpirun on this "
                        "machine (docs/cluster.md)")
    p.add_argument("--decomposition", default=None, metavar="D",
                   help="hierarchical ((N 1 1), the default), case (keep the case's "
                        "own system/decomposeParDict, setting only numberOfSubdomains) or a "
                        "decomposeParDict file to copy into the case and keep")
    p.add_argument("--parallel-mesh", action="store_true", default=None,
                   help="run snappyHexMesh on the --np ranks (decomposePar of the blockMesh "
                        "mesh, then reconstructParMesh)")
    p.add_argument("--reconstruct", action="store_true", default=None,
                   help="reconstructPar after a parallel run (default: the scene's "
                        "case.reconstruct; the written times stay in processor*/)")
    p.add_argument("--quiet", "-q", action="store_true",
                   help="no progress and no report on stdout, only warnings and errors on stderr")
    p.set_defaults(func=_cmd_run_case)


def _cmd_run_case(args: argparse.Namespace) -> int:
    if args.decomposition not in (None, *DECOMPOSITIONS):
        if not Path(args.decomposition).is_file():
            raise UsageError(f"--decomposition {args.decomposition}: give hierarchical, case "
                             "or an existing decomposeParDict file")
        args.decomposition = str(Path(args.decomposition).resolve())   # a file, from here
    case = Path(args.case or default_folder(args.scene, args.preset))
    exists = (case / "system" / "controlDict").exists()
    if exists:
        # refuses a folder not made by run-case before anything (blockMesh) touches it
        record = Case(case).record
        _check_same_case(case, record, args)
        asked = asked_start(case)
        t0 = resume_time(case) if asked is None else asked[0]
        done = _done(case, t0, pair_too=asked is None)
        if done:
            print(f"{case} already holds a finished case ({_recorded(record)}): {done}")
        elif asked is None:
            print(f"{case} already holds a case ({_recorded(record)}): continuing it from "
                  f"t = {t0:.6g} s")
        else:
            # run_case says what it recomputes from there, or refuses a time not written
            print(f"{case} already holds a case ({_recorded(record)})")
        if args.decomposition is not None:
            _record_decomposition(case, record, args.decomposition)
    else:
        scene = load_scene(args.scene, preset=args.preset)
        given = {"launcher": args.launcher, "decomposition": args.decomposition,
                 "parallel_meshing": args.parallel_mesh, "reconstruct": args.reconstruct}
        scene = scene.replace(case={k: v for k, v in given.items() if v is not None})
        params = prepare_case(scene, case, ranks=args.ranks, static_whale=args.static_whale,
                              scene_file=args.scene)
        print(f"prepared {case}: background {params.cells[0]}x{params.cells[1]}x{params.cells[2]}"
              f" cells, smallest cell {params.smallest_cell_m:.3g} m, dt {params.delta_t:.4g} s,"
              f" {params.n_steps} steps to t = {params.end_time:.4g} s")
    if args.mesh_only or not (case / "constant" / "polyMesh" / "owner").exists():
        info = mesh_case(case, ranks=args.ranks, parallel=args.parallel_mesh,
                         launcher=args.launcher)
        print(f"meshed {case}: {info.get('cells')} cells, whale patch {info.get('whale_faces')} "
              f"faces / {info.get('whale_points')} points, max non-orthogonality "
              f"{info.get('max_non_orthogonality')} deg, {info['mesh_s']} s")
        if args.mesh_only:
            return 0
    record = Case(case).record
    if record.get("gliding", False) and not record.get("static_whale"):
        summary = run_swim_and_glide(case, record, float(record["periodic_tolerance"]),
                                     ranks=args.ranks, launcher=args.launcher,
                                     reconstruct=args.reconstruct, progress=not args.quiet)
        print(f"\n{case}: what swimming costs the whale")
        print(format_summary(summary, COST_ROWS))
        print(f"(all figures: {case / SUMMARY}; picture: {case / 'forces.png'})")
        print(f"(report: {case / REPORT})")
        return _warn_unless_periodic(case, summary)
    token = resolve_token(args.token_file)
    summary = run_case(case, ranks=args.ranks, host=args.host, port=args.port, token=token,
                       launcher=args.launcher, reconstruct=args.reconstruct,
                       progress=not args.quiet)
    print(format_summary(summary))
    print(f"(all figures: {case / SUMMARY})")
    print(f"(report: {write_report(case, summary)})")
    return 0


def _done(case: Path, t0: float, pair_too: bool = True) -> str | None:
    """Why a prepared case starting from ``t0`` has nothing left to run (it is at its end
    time, or, ``pair_too``, the pair's swimming run reached its periodic state), or None."""
    control = parsed_dict(case / "system" / "controlDict")
    end = float(control["endTime"])
    if t0 >= end - 0.5 * float(control["deltaT"]):
        return (f"it reached its end time ({end:.6g} s), nothing to run (to run it longer, "
                "raise endTime in its system/controlDict)")
    summary = Case(case).summary
    if pair_too and summary.get("swimming_cost", {}).get("periodic_change", {}).get("reached"):
        return "its swimming run reached its periodic state, nothing to run"
    return None


def _warn_unless_periodic(case: Path, summary: dict) -> int:
    """0, or :data:`NOT_PERIODIC` with a warning on stderr when the swimming run ended without
    reaching its periodic state (its figures are then those of a start-up, not of the gait);
    a warning too when the gliding run ended before its drag was steady."""
    cost = summary["swimming_cost"]
    if not cost.get("gliding_run", {}).get("stopped_because"):
        print(f"whale-adapter run-case: warning: the gliding run {case / 'gliding'} reached its "
              "end time before its drag was steady: the gliding drag is that of its last "
              "stroke period", file=sys.stderr)
    change = cost["periodic_change"]
    if change["reached"]:
        return 0
    how = ("fewer than two stroke cycles after the start-up" if change["power"] is None else
           f"the last two cycles' mean Fx changed {change['fx_of_gliding_drag']:.1%} of the "
           f"gliding drag and mean power {change['power']:.1%}")
    end = summary.get("end_time_s")
    at = f" at t = {end:.6g} s" if end is not None else ""
    print(f"whale-adapter run-case: warning: {case} ended{at} without reaching its periodic "
          f"state ({how}; tolerance {change['tolerance']:.1%}): its figures are not those of a "
          f"periodic state. Raise endTime in {case / 'system' / 'controlDict'} and run the "
          "same command again to continue it", file=sys.stderr)
    return NOT_PERIODIC


def _differs_from_own(own: Path, record: dict, args: argparse.Namespace) -> list:
    diff = scene_differences(load_scene(args.scene, preset=args.preset), load_scene(own))
    if not diff:
        return []
    asked = " ".join(filter(None, [args.scene and f"--scene {Path(args.scene).resolve()}",
                                   args.preset and f"--preset {args.preset}"]))
    more = f" and {len(diff) - 3} more" if len(diff) > 3 else ""
    return [f"{asked} (recorded: {_recorded(record)}; its values differ from the case's own "
            f"scene {own} in {', '.join(diff[:3])}{more})"]


def _differs_from_record(record: dict, args: argparse.Namespace) -> list:
    differs = []
    if args.scene:
        asked = str(Path(args.scene).resolve())
        if asked != record.get("scene_file"):
            differs.append(f"--scene {asked} (recorded: {_recorded(record)})")
    if args.preset and (args.preset != record.get("preset")
                        or (not args.scene and record.get("scene_file"))):
        differs.append(f"--preset {args.preset} (recorded: {_recorded(record)})")
    return differs


def _record_decomposition(case: Path, record: dict, value: str) -> None:
    """--decomposition on a prepared case: recorded (a file copied in) for this and later runs."""
    record["parallel"] = parallel_settings(record, decomposition=choose_decomposition(
        case, value))
    Case(case).save(record)


def _recorded(record: dict) -> str:
    what = (f"scene {record['scene_file']}" if record.get("scene_file")
            else f"preset {record.get('preset')}")
    return what + (", static whale" if record.get("static_whale") else "")


def _check_same_case(case: Path, record: dict, args: argparse.Namespace) -> None:
    """A rerun may name the case's scene/preset again (make run-case does); refuse another:
    one whose values differ from the case's own scene (adapter-scene.toml), or for a case
    prepared before it had one, another scene file or preset than recorded."""
    own = case_scene_file(case)
    if own is not None:
        differs = _differs_from_own(own, record, args) if args.scene or args.preset else []
    else:
        differs = _differs_from_record(record, args)
    if args.static_whale and not record.get("static_whale"):
        differs.append("--static-whale (recorded: a coupled, moving whale)")
    if differs:
        raise CaseError(
            f"{case} already holds a case of another set-up: {'; '.join(differs)} "
            f"(from {case / CASE_RECORD}). Run it as it is with `whale-adapter run-case --case "
            f"{case}` (no --scene/--preset), or prepare the new one in another --case "
            f"(make run-case CASE=...), or remove {case} first")
