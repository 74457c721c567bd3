"""`make bench-flow`: what a moving-mesh flow step costs against a static one, side by side.

From a written time T of a coupled case (default: `runs/default`, which `make run-case`
writes; its latest written time), three copies continue for the same steps on this machine, one
after the other:

- ``static``: the mesh frozen as it is at T (``staticFvMesh``; ``correctPhi no``, which a static
  mesh needs): the flow alone;
- ``coupled``: the case with the step-server, ``whaleBlendedDisplacement`` and ``correctPhi
  yes``, its ``pcorr`` solver set as the template (foam_case/system/fvSolution) sets it;
- ``coupled, pcorr to 1e-5``: the same with the flux correction solved to an absolute 1e-5
  (``relTol 0``), as the template did before;
- ``coupled, p by GaussSeidel``: the template's case with the pressure's GAMG smoothed by
  GaussSeidel instead of DIC, as the template did before.

It prints the CPU seconds per step (OpenFOAM's ExecutionTime, the first step left out), the
ratio to the static step, the pressure's GAMG V-cycles a step, and, for the coupled runs, the
mean Fx and power over the steps (the motion is a function of time, so the coupled runs differ
in their solver settings alone), and writes ``out/bench-flow.json``. Nothing of the source
case is changed.

    make bench-flow                          # runs/default, 44 steps
    .venv/bin/python scripts/bench_flow.py --case runs/study-default/mesh-1/case --steps 176
"""

from __future__ import annotations

import argparse
import json
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from adapter.coupling.store import time_name  # noqa: E402
from adapter.errors import CaseError  # noqa: E402
from adapter.foam import loads as ld  # noqa: E402
from adapter.foam.case import CASE_RECORD, Case  # noqa: E402
from adapter.foam.dictionaries import parsed_dict, plugin_lib  # noqa: E402
from adapter.foam.stepserver import start_server, stop_server  # noqa: E402
from adapter.foam.tools import foam_env  # noqa: E402
from adapter.foamfiles import time_dirs  # noqa: E402
from adapter.jsonfiles import finite  # noqa: E402

#: the template's flux correction before it was loosened: to an absolute 1e-5
TIGHT_PCORR = {"pcorr": {"tolerance": 1e-5, "relTol": 0}}
#: the template's pressure smoother before DIC
GAUSS_SEIDEL_P = {"p": {"smoother": "GaussSeidel"}}


def template_solvers() -> dict:
    """The template's p and pcorr settings (the source case may have been made before a
    change)."""
    d = parsed_dict(ROOT / "foam_case" / "system" / "fvSolution")
    return {"p": {"smoother": d["solvers"]["p"]["smoother"]},
            "pcorr": {k: d["solvers"]["pcorr"][k] for k in ("tolerance", "relTol")}}


def copy_at(case: Path, time: str, dst: Path, steps: int) -> float:
    """A copy of ``case`` that starts at written time ``time`` and runs ``steps`` steps;
    the end time."""
    dst.mkdir(parents=True)
    for name in ("system", "constant", time, CASE_RECORD):
        src = case / name
        (shutil.copytree if src.is_dir() else shutil.copy)(src, dst / name)
    (dst / "adapter").mkdir()
    # the step-server's state at that time (named with 12 digits, store.time_name)
    for name in (f"state_{time_name(float(time))}.npz", "patch-map.npz"):
        if (case / "adapter" / name).is_file():
            shutil.copy(case / "adapter" / name, dst / "adapter" / name)
    d = parsed_dict(dst / "system" / "controlDict")
    end = float(time) + steps * float(d["deltaT"])
    d["startFrom"] = "startTime"
    d["startTime"] = time
    d["endTime"] = repr(end)
    # nothing written: runTime counts from the start time (timeStep from time index 0, so
    # a write could land mid-run)
    d["writeControl"] = "runTime"
    d["writeInterval"] = repr(2 * (end - float(time)))
    # this checkout's plugin library, not the one the source case was made with
    lib = [f'"{plugin_lib()}"']
    if "libs" in d:
        d["libs"] = lib
        d["functions"]["loads"]["libs"] = lib
    d.writeFile()
    d = parsed_dict(dst / "constant" / "dynamicMeshDict")
    if d["motionSolver"] == "whaleBlendedDisplacement":
        d["motionSolverLibs"] = lib
        d.writeFile()
    return end


def make_static(case: Path, time: str) -> None:
    """Freeze the mesh: staticFvMesh, no flux correction, the whale's displacement fixed."""
    d = parsed_dict(case / "constant" / "dynamicMeshDict")
    d["dynamicFvMesh"] = "staticFvMesh"
    d.writeFile()
    d = parsed_dict(case / "system" / "fvSolution")
    d["PIMPLE"]["correctPhi"] = "no"
    d.writeFile()
    d = parsed_dict(case / time / "pointDisplacement")
    d["boundaryField"]["whale"] = {"type": "fixedValue", "value": "uniform (0 0 0)"}
    d.writeFile()


def set_solvers(case: Path, solvers: dict) -> None:
    """Set ``{solver: {keyword: value}}`` in the case's fvSolution."""
    d = parsed_dict(case / "system" / "fvSolution")
    for name, entries in solvers.items():
        for k, v in entries.items():
            d["solvers"][name][k] = v
    d.writeFile()


def run(case: Path, coupled: bool) -> dict:
    """pimpleFoam in ``case`` (with the step-server when ``coupled``); CPU s per step and,
    from the loads function object, the mean Fx and power over the run."""
    server = start_server(case, Case(case).record) if coupled else None
    try:
        with open(case / "log.pimpleFoam", "w") as log:
            rc = subprocess.run(["pimpleFoam"], cwd=case, stdout=log, stderr=subprocess.STDOUT,
                                env=foam_env()).returncode
    finally:
        stop_server(server)
    text = (case / "log.pimpleFoam").read_text()
    if rc != 0:
        raise CaseError(f"pimpleFoam failed in {case} (exit {rc}); see its log.pimpleFoam")
    cpu = [float(x) for x in re.findall(r"^ExecutionTime = (\S+)", text, re.M)]
    if len(cpu) < 3:
        raise CaseError(f"{case}: fewer than 3 steps in log.pimpleFoam")
    cycles = [int(n) for n in re.findall(r"Solving for p, .* No Iterations (\d+)", text)]
    data = ld.read_loads(case)
    return {"steps": len(cpu), "cpu_s_per_step": (cpu[-1] - cpu[0]) / (len(cpu) - 1),
            "p_cycles_per_step": sum(cycles) / len(cpu),
            "mean_fx_N": float(np.mean(data["total:Fx"])),
            "mean_power_W": float(np.mean(data["total:P"]))}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--case", default=str(ROOT / "runs" / "default"),
                    help="a coupled case that has run (default: runs/default)")
    ap.add_argument("--time", help="the written time to start from (default: the latest)")
    ap.add_argument("--steps", type=int, default=44, help="steps per run (default 44)")
    ap.add_argument("--out", default=str(ROOT / "out" / "bench-flow.json"))
    args = ap.parse_args(argv)
    case = Path(args.case).resolve()
    if not Case(case).has_record:
        ap.error(f"{case} is not a prepared coupled case: run `make run-case` first, or give "
                 "--case")
    times = [p.name for t, p in time_dirs(case) if t > 0]
    time = args.time or (times[-1] if times else None)
    if time not in times:
        ap.error(f"{case} has no written time {time!r} to start from (it has: "
                 f"{', '.join(times) or 'none'})")
    results = {}
    with tempfile.TemporaryDirectory(prefix="bench-flow-") as tmp:
        template = template_solvers()
        for name, coupled, changes in (
                ("static", False, template),
                ("coupled", True, template),
                ("coupled, pcorr to 1e-5", True, {**template, **TIGHT_PCORR}),
                ("coupled, p by GaussSeidel", True, {**template, **GAUSS_SEIDEL_P})):
            dst = Path(tmp) / name.replace(" ", "_").replace(",", "")
            copy_at(case, time, dst, args.steps)
            if not coupled:
                make_static(dst, time)
            set_solvers(dst, changes)
            results[name] = run(dst, coupled)
            print(f"{name:<26} {results[name]['cpu_s_per_step']:.3f} CPU s/step", flush=True)
    base = results["static"]["cpu_s_per_step"]
    print(f"\n{case} from t = {time} s, {args.steps} steps each (CPU s per step, first left out)")
    print(f"{'run':<26} {'s/step':>7} {'x static':>9} {'p cycles':>9} {'mean Fx (N)':>12} "
          f"{'power (W)':>10}")
    for name, r in results.items():
        r["x_static"] = r["cpu_s_per_step"] / base
        fx = f"{r['mean_fx_N']:.2f}" if name != "static" else "-"
        pw = f"{r['mean_power_W']:.1f}" if name != "static" else "-"
        print(f"{name:<26} {r['cpu_s_per_step']:>7.3f} {r['x_static']:>9.2f} "
              f"{r['p_cycles_per_step']:>9.1f} {fx:>12} {pw:>10}")
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(finite({"case": str(case), "time": time, "steps": args.steps,
                                      "runs": results}), indent=2, allow_nan=False))
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
