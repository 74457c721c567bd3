"""The stroke's mesh motion alone: how bent does a case's mesh get, without solving the flow.

A meshed case (``whale-adapter run-case --mesh-only``, or any run-case folder) is copied without
its time folders, and OpenFOAM's ``moveMesh`` runs its dynamicMeshDict through the stroke with
the step-server serving the whale, as pimpleFoam would: the same mesh at every time, for a
minute of work instead of a flow run. The blended motion's own check prints each new mesh's
figures (``checkMotion``); printed here are the worst non-orthogonality, when, and the first.
``--set key=value`` changes an entry of ``whaleBlendedDisplacementCoeffs`` in the copy (e.g.
``clusters=0``, ``rotationDistance=0.2``) to compare the motion's settings on one mesh.

    .venv/bin/python scripts/motion_only.py runs/default --out /tmp/motion [--end 11] \
        [--set clusters=0 ...]

Exit code 1 when moveMesh fails (the motion check stopped it: the log's last lines say where).
"""

from __future__ import annotations

import argparse
import re
import shutil
import subprocess
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from adapter.foam.case import Case  # noqa: E402
from adapter.foam.dictionaries import parsed_dict  # noqa: E402
from adapter.foam.logs import NON_ORTHOGONALITY_RE  # noqa: E402
from adapter.foam.stepserver import start_server, stop_server  # noqa: E402
from adapter.foam.tools import foam_env  # noqa: E402

COEFFS = "whaleBlendedDisplacementCoeffs"


def copy_case(src: Path, out: Path, end: float | None, settings: list) -> None:
    """The mesh, the set-up and the initial fields of ``src`` in ``out``; no writes but the end."""
    if out.exists():
        shutil.rmtree(out)
    out.mkdir(parents=True)
    for name in ("constant", "system", "adapter-case.json", "adapter-scene.toml"):
        (shutil.copytree if (src / name).is_dir() else shutil.copy2)(src / name, out / name)
    shutil.copytree(src / "0.orig", out / "0")
    control = parsed_dict(out / "system" / "controlDict")
    control["functions"] = {}
    control["writeInterval"] = 10**9
    if end is not None:
        control["endTime"] = end
    control.writeFile()
    motion = parsed_dict(out / "constant" / "dynamicMeshDict")
    for kv in settings:
        key, _, value = kv.partition("=")
        motion[COEFFS][key] = value
    motion.writeFile()


def worst(log: Path) -> tuple:
    """(worst, its time, first, steps) of the motion check's lines in moveMesh's log."""
    t, figures = None, []
    for line in log.read_text().splitlines():
        m = re.match(r"^Time = (\S+)", line)
        if m:
            t = float(m.group(1))
        m = NON_ORTHOGONALITY_RE.search(line)
        if m and t is not None:
            figures.append((float(m.group(1)), t))
    if not figures:
        return None, None, None, 0
    deg, when = max(figures)
    return deg, when, figures[0][0], len(figures)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("case", type=Path, help="a meshed run-case folder")
    ap.add_argument("--out", type=Path, required=True, help="the copy to move (replaced)")
    ap.add_argument("--end", type=float, help="end time (s; default the case's)")
    ap.add_argument("--set", dest="settings", action="append", default=[], metavar="KEY=VALUE",
                    help=f"an entry of {COEFFS}")
    args = ap.parse_args()
    src = args.case.resolve()
    if not (src / "constant" / "polyMesh" / "owner").is_file():
        ap.error(f"{src} has no mesh: mesh it first (whale-adapter run-case --mesh-only)")
    out = args.out.resolve()
    copy_case(src, out, args.end, args.settings)
    server = start_server(out, Case(out).record)
    try:
        with open(out / "log.moveMesh", "w") as log:
            rc = subprocess.call(["moveMesh"], cwd=out, stdout=log, stderr=subprocess.STDOUT,
                                 env=foam_env())
    finally:
        stop_server(server)
    deg, when, first, steps = worst(out / "log.moveMesh")
    if deg is not None:
        print(f"{steps} steps: worst non-orthogonality {deg:.2f} deg at t = {when:.4g} s "
              f"(the first step's {first:.2f}); {' '.join(args.settings) or 'as meshed'}")
    if rc != 0:
        print(f"moveMesh failed (exit code {rc}); see {out / 'log.moveMesh'}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
