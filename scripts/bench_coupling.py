"""Coupling cost per step at several MPI rank counts on the smoke case.

Prepares and meshes the smoke case once, then runs it (run-case) at each rank count and prints
the plugin's ``stepServer: N requests, mean X us per exchange`` figures (the master's coupling
per step: forces reduced, REQUEST/DISPLACEMENT, slices sent) and the server's link count::

    PYTHONPATH=. .venv/bin/python scripts/bench_coupling.py --ranks 1 2 4 8
"""

from __future__ import annotations

import argparse
import json
import re
import shutil
import tempfile
from pathlib import Path

from adapter.foam import case as C
from adapter.foam import mesh as M
from adapter.foam import run as R
from adapter.scene import load_scene

_STATS = re.compile(r"^stepServer: ([0-9]+) requests, mean ([0-9.]+) us per exchange$", re.M)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ranks", type=int, nargs="+", default=[1, 2, 4, 8])
    ap.add_argument("--work", type=Path, default=None, help="folder for the cases (default: tmp)")
    args = ap.parse_args()
    work = args.work or Path(tempfile.mkdtemp(prefix="bench-coupling-"))
    scene = load_scene(preset="smoke")
    mesh = work / "mesh"
    if not (mesh / "constant" / "polyMesh" / "owner").exists():
        C.prepare_case(scene, mesh)
        M.mesh_case(mesh)
    print("| ranks | requests | mean coupling per step (us) | server links | patch points sent |")
    print("|---|---|---|---|---|")
    for n in args.ranks:
        case = work / f"np{n}"
        shutil.rmtree(case, ignore_errors=True)
        shutil.copytree(mesh, case)
        R.run_case(case, ranks=n, progress=False)
        found = _STATS.findall((case / "log.pimpleFoam").read_text())
        requests, mean_us = found[-1]
        stats = json.loads((case / "adapter" / "server-stats.json").read_text())
        print(f"| {n} | {requests} | {float(mean_us):.0f} | {stats['links']} | "
              f"{stats['patch_points']} |", flush=True)


if __name__ == "__main__":
    main()
