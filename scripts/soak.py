#!/usr/bin/env python
"""Soak: a long coupled smoke run (real pimpleFoam + plugin + step-server), the server's memory.

    .venv/bin/python scripts/soak.py                      # 1,000 steps, out/soak.json
    .venv/bin/python scripts/soak.py --steps 200 --case /tmp/soak

Prepares and meshes a smoke-preset case (unless ``--case`` already holds one), sets its end
time to ``--steps`` flow steps (written every ``--write-every``), runs it with
``adapter.foam.case.run_case`` and samples the step-server's resident memory (psutil, the pid from
``<case>/.whale-adapter.pid``) every ``--interval`` seconds, with the number of steps served so
far (rows of ``adapter/keypoints.csv``). Prints the RSS at the start, after the warm-up and at
the end, and writes every sample to ``--out``. Exit code 1 when the RSS grew by more than
``--max-growth-mb`` between the end of the warm-up (10 % of the steps) and the end.
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
import threading
import time
from pathlib import Path

import psutil

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from adapter.coupling.listener import PID_NAME  # noqa: E402
from adapter.foam import case as C  # noqa: E402
from adapter.foam import mesh as M  # noqa: E402
from adapter.foam import run as R  # noqa: E402
from adapter.jsonfiles import finite  # noqa: E402
from adapter.scene import load_scene  # noqa: E402

_MB = 1024.0 * 1024.0


def _set_end(case: Path, steps: int, write_every: int) -> float:
    """endTime = steps * deltaT (exact: deltaT is a binary fraction); returns deltaT."""
    from PyFoam.RunDictionary.ParsedParameterFile import ParsedParameterFile

    d = ParsedParameterFile(str(case / "system" / "controlDict"))
    dt = float(d["deltaT"])
    d["endTime"] = steps * dt
    d["writeInterval"] = write_every
    d.writeFile()
    return dt


def _steps_served(case: Path) -> int:
    try:
        with open(case / "adapter" / "keypoints.csv") as f:
            return max(0, sum(1 for _ in f) - 1)
    except OSError:
        return 0


def soak(case: Path, steps: int = 1000, write_every: int = 50, interval: float = 1.0,
         preset: str = "smoke", fresh: bool = True) -> dict:
    """Run the soak; returns the report (also what ``--out`` gets)."""
    case = case.resolve()
    if fresh and case.exists():
        shutil.rmtree(case)
    t0 = time.perf_counter()
    if not (case / C.CASE_RECORD).is_file():
        C.prepare_case(load_scene(preset=preset), case)
        M.mesh_case(case)
    dt = _set_end(case, steps, write_every)
    result: dict = {}

    def run():
        try:
            result["summary"] = R.run_case(case, progress=False)
        except BaseException as exc:      # reported below, with the samples taken so far
            result["error"] = repr(exc)

    runner = threading.Thread(target=run, daemon=True)
    t_run = time.perf_counter()
    runner.start()
    samples = []                                  # (wall s, steps served, rss bytes)
    proc = None
    pid_file = case / PID_NAME
    while runner.is_alive():
        if proc is None and pid_file.exists():
            try:
                proc = psutil.Process(int(pid_file.read_text().split()[0]))   # "pid host"
            except (ValueError, psutil.NoSuchProcess):
                proc = None
        if proc is not None:
            try:
                rss = proc.memory_info().rss
            except psutil.NoSuchProcess:
                proc = None
            else:
                samples.append((round(time.perf_counter() - t_run, 2), _steps_served(case), rss))
        runner.join(interval)
    wall = time.perf_counter() - t_run
    if "error" in result:
        raise SystemExit(f"soak: the run failed: {result['error']}")
    served = [s for s in samples if s[1] > 0]
    if not served:
        raise SystemExit("soak: no RSS sample while the server served (run too short?)")
    warm = next((s for s in served if s[1] >= max(1, steps // 10)), served[0])
    last = served[-1]
    # least-squares slope of RSS over steps served, after the warm-up
    after = [s for s in served if s[1] >= warm[1]]
    xs = [s[1] for s in after]
    ys = [s[2] / _MB for s in after]
    slope = 0.0
    if len(after) > 2 and max(xs) > min(xs):
        mx, my = sum(xs) / len(xs), sum(ys) / len(ys)
        slope = (sum((x - mx) * (y - my) for x, y in zip(xs, ys, strict=True))
                 / sum((x - mx) ** 2 for x in xs))
    summary = result["summary"]
    report = {
        "steps": summary["steps"],
        "delta_t_s": dt,
        "write_every": write_every,
        "wall_s": round(wall, 1),
        "prepare_and_mesh_s": round(t_run - t0, 1),
        "s_per_step": round(wall / max(1, summary["steps"]), 4),
        "rss_start_mb": round(served[0][2] / _MB, 1),
        "rss_start_step": served[0][1],
        "rss_after_warmup_mb": round(warm[2] / _MB, 1),
        "rss_after_warmup_step": warm[1],
        "rss_end_mb": round(last[2] / _MB, 1),
        "rss_end_step": last[1],
        "rss_max_mb": round(max(s[2] for s in served) / _MB, 1),
        "rss_growth_after_warmup_mb": round((last[2] - warm[2]) / _MB, 2),
        "rss_slope_mb_per_1000_steps": round(1000 * slope, 3),
        "samples": [[w, n, round(r / _MB, 2)] for w, n, r in samples],
        "case": str(case),
        "run_summary": summary,
    }
    return report


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--steps", type=int, default=1000, help="flow steps (default %(default)s)")
    p.add_argument("--write-every", type=int, default=50,
                   help="steps between writes (default %(default)s)")
    p.add_argument("--case", type=Path, default=REPO / "out" / "soak-case",
                   help="case folder, made afresh (default out/soak-case)")
    p.add_argument("--out", type=Path, default=REPO / "out" / "soak.json")
    p.add_argument("--interval", type=float, default=1.0, help="seconds between RSS samples")
    p.add_argument("--max-growth-mb", type=float, default=10.0,
                   help="largest RSS growth after the warm-up counted as flat (MB)")
    args = p.parse_args(argv)
    report = soak(args.case, args.steps, args.write_every, args.interval)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(finite(report), indent=1, allow_nan=False) + "\n")
    print(f"soak: {report['steps']} coupled steps in {report['wall_s']} s "
          f"({report['s_per_step']} s per step, + {report['prepare_and_mesh_s']} s to prepare)")
    print(f"soak: server RSS {report['rss_start_mb']} MB at step {report['rss_start_step']}, "
          f"{report['rss_after_warmup_mb']} MB at step {report['rss_after_warmup_step']}, "
          f"{report['rss_end_mb']} MB at step {report['rss_end_step']} "
          f"(max {report['rss_max_mb']} MB; slope {report['rss_slope_mb_per_1000_steps']} MB "
          f"per 1000 steps after the warm-up); written to {args.out}")
    flat = report["rss_growth_after_warmup_mb"] <= args.max_growth_mb
    if not flat:
        print(f"soak: RSS grew by {report['rss_growth_after_warmup_mb']} MB after the warm-up, "
              f"more than {args.max_growth_mb} MB", file=sys.stderr)
    return 0 if flat else 1


if __name__ == "__main__":
    sys.exit(main())
