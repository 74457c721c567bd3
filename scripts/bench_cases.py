"""`make bench-cases`: a scene's coupled case on 1 and 2 ranks, full and half domain, side by side.

For each domain (``full``: ``case.symmetry = "off"``; ``half``: ``"auto"``, the symmetry plane
at y = 0, when the whale and its stroke are mirror-symmetric) the case is prepared and meshed
once, then run coupled (the step-server, no gliding run) from t = 0 for ``--writes`` write
intervals on each rank count, one run after the other on this machine. Printed per run: cells,
steps, wall seconds per step (from the log: pimpleFoam with the coupling), that times the steps
of a stroke cycle (the wall time per stroke cycle), the coupling's share of the step (the
plugin's mean exchange over the step; and the same after the first write interval, which
carries the step-server's start: a whole run's share is near the later one), and the mean
drag over the window (the half's already the whole body's). A short window starts in still
water with the inflow ramping in: its steps are cheaper than those of the periodic state, so
compare the runs with each other, not with a whole run. Writes ``<out>/bench-cases.json``.

    make bench-cases                                   # the default scene, two write intervals
    .venv/bin/python scripts/bench_cases.py --preset smoke --out out/bench-smoke
"""

from __future__ import annotations

import argparse
import shutil
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from adapter.foam.case import Case, prepare_case  # noqa: E402
from adapter.foam.logs import PLUGIN_EXCHANGE_RE  # noqa: E402
from adapter.foam.mesh import mesh_case  # noqa: E402
from adapter.foam.run import run_case  # noqa: E402
from adapter.jsonfiles import write_json  # noqa: E402
from adapter.scene import load_scene  # noqa: E402

DOMAINS = {"full": "off", "half": "auto"}


def exchange_after_first_write(log_text: str) -> float | None:
    """The plugin's mean exchange (s) over the requests after its first report, or None.

    The plugin reports its running mean at every write, ``stepServer: N requests, mean M us
    per exchange``; from the first report (n1, m1) and the last (n2, m2) the mean of the
    requests in between is (n2 m2 - n1 m1) / (n2 - n1): the exchange without the
    step-server's start, which the first write interval carries."""
    reports = [(int(m.group(1)), float(m.group(2))) for line in log_text.splitlines()
               if (m := PLUGIN_EXCHANGE_RE.search(line))]
    if len(reports) < 2 or reports[-1][0] <= reports[0][0]:
        return None
    (n1, m1), (n2, m2) = reports[0], reports[-1]
    return (n2 * m2 - n1 * m1) / (n2 - n1) * 1e-6


def _row(domain: str, ranks: int, summary: dict, record: dict, log_text: str = "") -> dict:
    """One run's figures (see the module)."""
    steps_per_cycle = float(record["period_s"]) / float(summary["delta_t_s"])
    step = float(summary["step_s"])
    coupling = summary.get("adapter_s_per_step")
    later = exchange_after_first_write(log_text)
    return {
        "domain": domain, "half": bool(record.get("symmetry_plane")), "ranks": ranks,
        "cells": summary["cells"], "steps": summary["steps"], "step_s": step,
        "cycle_wall_s": step * steps_per_cycle,
        "coupling_share": coupling / step if coupling is not None else None,
        "coupling_share_after_first_write": later / step if later is not None else None,
        "drag_N": summary["drag_N"],
    }


def bench(scene, out: Path, ranks: list, domains: list, writes: int) -> list:
    """Prepare, mesh and run every (domain, ranks) pair; their rows."""
    rows = []
    for domain in domains:
        base = out / domain / "mesh"
        if not (base / "constant" / "polyMesh" / "owner").exists():
            shutil.rmtree(out / domain, ignore_errors=True)
            s = scene.replace(case={"symmetry": DOMAINS[domain], "gliding": False, "end_time_s":
                                    writes * scene.period_s / scene.case.writes_per_cycle})
            prepare_case(s, base, ranks=1)
            mesh_case(base)
        record = Case(base).record
        if domain == "half" and not record.get("symmetry_plane"):
            print("half: the whale or its stroke is not mirror-symmetric; the full domain only",
                  flush=True)
            continue
        for n in ranks:
            case = out / domain / f"np{n}"
            shutil.rmtree(case, ignore_errors=True)
            shutil.copytree(base, case)
            t0 = time.perf_counter()
            summary = run_case(case, ranks=n, progress=False)
            log = case / "log.pimpleFoam"
            rows.append(_row(domain, n, summary, record,
                             log.read_text(errors="replace") if log.is_file() else ""))
            print(f"{domain} np {n}: {summary['steps']} steps in "
                  f"{time.perf_counter() - t0:.0f} s", flush=True)
    return rows


def table(rows: list) -> str:
    """The rows side by side, with each run's wall time per cycle over the first row's."""
    first = rows[0]["cycle_wall_s"] if rows else 1.0
    lines = [f"{'domain':<6} {'ranks':>5} {'cells':>8} {'steps':>5} {'s/step':>7} "
             f"{'s/cycle':>8} {'vs first':>8} {'coupling':>8} {'later':>8} {'drag N':>9}"]
    for r in rows:
        share, later = (f"{100 * r[k]:.2f} %" if r.get(k) is not None else "-"
                        for k in ("coupling_share", "coupling_share_after_first_write"))
        lines.append(f"{r['domain']:<6} {r['ranks']:>5} {r['cells']:>8,} {r['steps']:>5} "
                     f"{r['step_s']:>7.3f} {r['cycle_wall_s']:>8.1f} "
                     f"{r['cycle_wall_s'] / first:>8.2f} {share:>8} {later:>8} "
                     f"{r['drag_N']:>9.1f}")
    lines.append("(coupling: the plugin's mean exchange over the step; later: the same after "
                 "the first write interval, without the step-server's start)")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", help="scene TOML file")
    ap.add_argument("--preset", help="built-in preset (default: default)")
    ap.add_argument("--out", default="out/bench-cases", help="folder for the cases")
    ap.add_argument("--ranks", default="1,2", help="rank counts, comma-separated")
    ap.add_argument("--domains", default="full,half", help="full, half or both")
    ap.add_argument("--writes", type=int, default=2,
                    help="write intervals to run (default 2: half a stroke cycle; the "
                    "coupling after the first needs two)")
    args = ap.parse_args(argv)
    ranks = [int(v) for v in args.ranks.split(",") if v.strip()]
    domains = [v.strip() for v in args.domains.split(",") if v.strip()]
    bad = [d for d in domains if d not in DOMAINS]
    if bad or not ranks or min(ranks) < 1 or args.writes < 1:
        ap.error("--domains: full and/or half; --ranks: whole numbers >= 1; --writes >= 1")
    scene = load_scene(args.scene, preset=args.preset)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rows = bench(scene, out, ranks, domains, args.writes)
    print(table(rows))
    write_json(out / "bench-cases.json", rows)
    print(f"(figures: {out / 'bench-cases.json'})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
