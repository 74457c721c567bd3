"""Recompute the gliding + swimming pair's answer of a finished case, without OpenFOAM.

    .venv/bin/python scripts/recompute_answer.py runs/default
    .venv/bin/python scripts/recompute_answer.py /elsewhere/runs/default --copy-to /tmp/answer

It does what a rerun of ``whale-adapter run-case --case CASE`` does on a finished pair when the
figures' code has changed (adapter/foam/swimrun.py ``answer``: adapter-summary.json,
forces.png, report.html and the printed table), without the run-case machinery around it (the
plugin, the mesh, the step-server are not needed). ``--copy-to DIR`` first copies into DIR only
the files the answer reads (the records, the summaries, the loads and forces, the regions STL,
the controlDicts) and recomputes there, leaving CASE untouched; y+ is then not recomputed (its
fields stay in CASE's time folders), the rest is.
"""

from __future__ import annotations

import argparse
import shutil
import sys
from pathlib import Path

from adapter.errors import CaseError
from adapter.foam import loads as ld
from adapter.foam.case import CASE_RECORD, Case
from adapter.foam.summary import SUMMARY, format_summary
from adapter.foam.swimrun import COST_ROWS, GLIDING, answer

#: what the answer reads, relative to the case (and to its gliding folder); forces: the
#: force.dat of a flow-only case without the plugin, or of a case run before loads.dat held
#: the force
READ = (CASE_RECORD, SUMMARY, "system/controlDict", "constant/triSurface",
        "postProcessing/loads", "postProcessing/forces")


def light_copy(case: Path, to: Path) -> Path:
    """Copy the files of :data:`READ` of ``case`` and of its gliding run into ``to``."""
    for base in (Path("."), Path(GLIDING)):
        for name in READ:
            src = case / base / name
            if not src.exists():
                continue
            dst = to / base / name
            dst.parent.mkdir(parents=True, exist_ok=True)
            if src.is_dir():
                shutil.copytree(src, dst, dirs_exist_ok=True)
            else:
                shutil.copy2(src, dst)
    return to


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("case", type=Path, help="a finished gliding + swimming pair")
    ap.add_argument("--copy-to", type=Path, help="recompute in a light copy here")
    args = ap.parse_args(argv)
    case = args.case
    if not (case / SUMMARY).is_file() or not (case / GLIDING / SUMMARY).is_file():
        print(f"{case}: no finished gliding + swimming pair ({SUMMARY} in it and in "
              f"{GLIDING}/); run `whale-adapter run-case --case {case}` first", file=sys.stderr)
        return 2
    if args.copy_to:
        case = light_copy(case, args.copy_to)
    rec = Case(case).record
    period = float(rec["period_s"])
    glide = case / GLIDING
    data = ld.read_loads(glide)
    try:
        st = ld.cycle_stats(data["Time"], data["total:Fx"], data["total:P"], period, period)
        summary = answer(case, glide, rec, float(st.mean_fx[-1]),
                         float(rec.get("periodic_tolerance", 0.02)),
                         Case(case).summary, Case(glide).summary)
    except (CaseError, KeyError, IndexError) as exc:
        print(f"{case}: cannot recompute the answer: {exc}", file=sys.stderr)
        return 1
    print(format_summary(summary, COST_ROWS))
    return 0


if __name__ == "__main__":
    sys.exit(main())
