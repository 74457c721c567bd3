"""Mutation testing of the core modules with mutmut, one module at a time (docs/mutation.md).

For each module of ``[tool.whale-adapter.mutation]`` in pyproject.toml (or those named on the
command line) this copies the package and the tests into ``out/mutation/<module>/``, writes
there a pyproject.toml whose ``[tool.mutmut]`` mutates that module alone against its own fast
tests, runs ``mutmut run``, and collects the score and every surviving mutant's diff into
``out/mutation/report.md`` and ``out/mutation/summary.json``.

    python scripts/mutation.py                       # every module of the table
    python scripts/mutation.py adapter/coupling/protocol.py   # one
    python scripts/mutation.py --jobs 1              # mutmut's --max-children (default 2)
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import time
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "out" / "mutation"


def _toml_list(items) -> str:
    return "[" + ", ".join(json.dumps(str(x), allow_nan=False) for x in items) + "]"


def _workdir(module: str, tests: list[str], base: dict) -> Path:
    work = OUT / Path(module).stem
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir(parents=True)
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc", "build")
    shutil.copytree(ROOT / "adapter", work / "adapter", ignore=ignore)
    shutil.copytree(ROOT / "tests", work / "tests", ignore=ignore)
    # some tests check the code against the documents (docs/numerics.md's method table)
    shutil.copytree(ROOT / "docs", work / "docs", ignore=shutil.ignore_patterns("img"))
    markers = base["tool"]["pytest"]["ini_options"].get("markers", [])
    mm = base["tool"]["mutmut"]
    (work / "pyproject.toml").write_text(
        "[tool.mutmut]\n"
        f"source_paths = {_toml_list(mm['source_paths'])}\n"
        f"only_mutate = {_toml_list([module])}\n"
        'also_copy = ["docs/"]\n'
        f"pytest_add_cli_args = {_toml_list(mm.get('pytest_add_cli_args', []))}\n"
        f"pytest_add_cli_args_test_selection = {_toml_list(tests)}\n\n"
        "[tool.pytest.ini_options]\n"
        'testpaths = ["tests"]\n'
        f"markers = {_toml_list(markers)}\n"
    )
    return work


def _mutmut(work: Path, *args: str, log=None) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}  # mutants/ must win
    env["NUMBA_CACHE_DIR"] = str(work / ".numba-cache")
    return subprocess.run([sys.executable, "-m", "mutmut", *args], cwd=work, env=env,
                          text=True, stdout=log or subprocess.PIPE, stderr=subprocess.STDOUT)


def run_module(module: str, tests: list[str], base: dict, jobs: int) -> dict:
    work = _workdir(module, tests, base)
    t0 = time.monotonic()
    with open(work / "mutmut-run.log", "w") as log:
        proc = _mutmut(work, "run", "--max-children", str(jobs), log=log)
    wall = time.monotonic() - t0
    _mutmut(work, "export-cicd-stats")
    stats_file = work / "mutants" / "mutmut-cicd-stats.json"
    stats = json.loads(stats_file.read_text()) if stats_file.exists() else {}
    listing = _mutmut(work, "results").stdout
    survivors = []
    for line in listing.splitlines():
        name, _, status = line.strip().rpartition(": ")
        if name and status != "killed":
            diff = _mutmut(work, "show", name).stdout
            survivors.append({"name": name, "status": status, "diff": diff})
    killed = stats.get("killed", 0)
    counted = killed + stats.get("survived", 0) + stats.get("timeout", 0) \
        + stats.get("suspicious", 0) + stats.get("no_tests", 0)
    timeouts = stats.get("timeout", 0)
    return {"module": module, "tests": tests, "wall_s": round(wall, 1),
            "exit_code": proc.returncode, "stats": stats,
            # a timeout is counted as caught (the mutant hangs the tests), as mutmut does
            "score": (killed + timeouts) / counted if counted else None,
            "survivors": survivors}


def write_report(new: list[dict]) -> Path:
    """The report of every module run so far: earlier runs' results are kept unless rerun."""
    summary = OUT / "summary.json"
    old = json.loads(summary.read_text()) if summary.exists() else []
    rerun = {r["module"] for r in new}
    results = [r for r in old if r["module"] not in rerun] + new
    lines = ["# Mutation report (mutmut)", ""]
    lines.append("| module | tests | mutants | killed | timeout | survived | no tests | "
                 "score | wall time |")
    lines.append("|---|---|---|---|---|---|---|---|---|")
    for r in results:
        s = r["stats"]
        score = "n/a" if r["score"] is None else f"{100 * r['score']:.1f} %"
        lines.append(f"| {r['module']} | {', '.join(Path(t).name for t in r['tests'])} | "
                     f"{s.get('total', '?')} | {s.get('killed', '?')} | {s.get('timeout', 0)} | "
                     f"{s.get('survived', '?')} | {s.get('no_tests', 0)} | {score} | "
                     f"{r['wall_s']:.0f} s |")
    for r in results:
        if r["survivors"]:
            lines += ["", f"## Not killed in {r['module']}", ""]
            for m in r["survivors"]:
                lines += [f"### {m['name']} ({m['status']})", "", "```diff",
                          m["diff"].strip(), "```", ""]
    path = OUT / "report.md"
    path.write_text("\n".join(lines) + "\n")
    summary.write_text(json.dumps(results, indent=2, allow_nan=False))
    return path


def main(argv=None) -> int:
    base = tomllib.loads((ROOT / "pyproject.toml").read_text())
    table = base["tool"]["whale-adapter"]["mutation"]
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("modules", nargs="*", help=f"modules (default: {', '.join(table)})")
    p.add_argument("--jobs", type=int, default=2, help="mutants run at once (default 2)")
    args = p.parse_args(argv)
    modules = args.modules or list(table)
    unknown = [m for m in modules if m not in table]
    if unknown:
        p.error(f"no test selection for {unknown}: add them to [tool.whale-adapter.mutation]")
    results = []
    for m in modules:
        print(f"mutmut: {m} against {', '.join(table[m])} ...", flush=True)
        r = run_module(m, table[m], base, args.jobs)
        results.append(r)
        s = r["stats"]
        print(f"  {s.get('killed', '?')} killed, {s.get('timeout', 0)} timeout, "
              f"{s.get('survived', '?')} survived of {s.get('total', '?')}"
              + (f": score {100 * r['score']:.1f} %" if r["score"] is not None else "")
              + f" ({r['wall_s']:.0f} s)", flush=True)
    print(f"report: {write_report(results).relative_to(ROOT)}")
    return 0 if all(r["exit_code"] == 0 for r in results) else 1


if __name__ == "__main__":
    sys.exit(main())
