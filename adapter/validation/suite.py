"""The validation suite: cases run in turn, a table printed, ``<out>/validation.json`` written.

A case is a module of this package with a ``run(out_dir, *, ranks, quick) -> CaseResult``
function; :data:`CASES` names them in the order they run. A figure is a :class:`Check`:
measured against reference, with a tolerance (relative, or absolute when ``absolute``), so
that every row says by itself whether it passed.
"""

from __future__ import annotations

import argparse
import dataclasses
import importlib
import math
import time
from pathlib import Path

from adapter.errors import UsageError
from adapter.jsonfiles import write_json
from adapter.options import count, out_folder

#: case name -> module (run in this order)
CASES = {
    "sphere": "adapter.validation.sphere",
    "naca0012": "adapter.validation.naca0012",
    "flapping": "adapter.validation.flapping",
}
RESULTS = "validation.json"


@dataclasses.dataclass
class Check:
    """One figure: measured against reference within a tolerance.

    ``tolerance`` is relative to ``|reference|`` unless ``absolute`` (then in the figure's own
    unit); ``reference`` None marks a figure reported for reading, not judged (a part of a
    total, a friction line shown beside its part).
    """

    name: str
    measured: float
    reference: float | None = None
    tolerance: float = 0.0
    unit: str = ""
    absolute: bool = False
    source: str = ""

    @property
    def judged(self) -> bool:
        return self.reference is not None

    @property
    def error(self) -> float | None:
        """measured - reference, relative to |reference| unless absolute."""
        if self.reference is None:
            return None
        diff = self.measured - self.reference
        if self.absolute:
            return diff
        return diff / abs(self.reference) if self.reference else math.inf

    @property
    def passed(self) -> bool | None:
        err = self.error
        if err is None:
            return None
        return math.isfinite(self.measured) and abs(err) <= self.tolerance

    def as_dict(self) -> dict:
        d = dataclasses.asdict(self)
        d.update(error=self.error, passed=self.passed)
        return d


@dataclasses.dataclass
class CaseResult:
    """What one case measured: its checks, its mesh, its wall time and notes."""

    name: str
    title: str
    checks: list[Check]
    cells: int = 0
    ranks: int = 1
    wall_s: float = 0.0
    case_dir: str = ""
    notes: list[str] = dataclasses.field(default_factory=list)

    @property
    def passed(self) -> bool:
        return all(c.passed for c in self.checks if c.judged)

    def as_dict(self) -> dict:
        return {"name": self.name, "title": self.title, "passed": self.passed,
                "cells": self.cells, "ranks": self.ranks, "wall_s": self.wall_s,
                "case_dir": self.case_dir, "notes": self.notes,
                "checks": [c.as_dict() for c in self.checks]}


def format_check(c: Check) -> str:
    """One table row: name, measured, reference, error, verdict."""
    unit = f" {c.unit}" if c.unit else ""
    if not c.judged:
        return f"    {c.name:<44} {c.measured:>12.5g}{unit}"
    err = c.error or 0.0    # judged: it has a reference, so an error
    err_s = f"{err:+.3g}{unit}" if c.absolute else f"{100 * err:+.2f} %"
    tol_s = f"{c.tolerance:g}{unit}" if c.absolute else f"{100 * c.tolerance:g} %"
    verdict = "pass" if c.passed else "FAIL"
    return (f"    {c.name:<44} {c.measured:>12.5g}{unit}  ref {c.reference:.5g}{unit}  "
            f"{err_s} (tol {tol_s})  {verdict}")


def format_result(r: CaseResult) -> str:
    head = (f"{r.name}: {r.title} ({r.cells:,} cells, {r.ranks} rank(s), {r.wall_s:.0f} s): "
            f"{'PASS' if r.passed else 'FAIL'}")
    return "\n".join([head, *(format_check(c) for c in r.checks),
                      *(f"    note: {n}" for n in r.notes)])


def run_suite(out_dir, names=None, *, ranks: int = 1, quick: bool = False,
              echo=print) -> list[CaseResult]:
    """Run the named cases (all when None) into ``out_dir/<name>/``; write validation.json
    after each case, so that a stopped suite keeps what it measured."""
    names = list(CASES) if not names else list(names)
    unknown = [n for n in names if n not in CASES]
    if unknown:
        raise UsageError(f"unknown validation case {', '.join(unknown)}; known: "
                         f"{', '.join(CASES)}")
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise UsageError(f"--out {out} is a file; give a folder")
    out.mkdir(parents=True, exist_ok=True)
    results: list[CaseResult] = []
    for name in names:
        module = importlib.import_module(CASES[name])
        t0 = time.perf_counter()
        result = module.run(out / name, ranks=ranks, quick=quick)
        result.wall_s = result.wall_s or time.perf_counter() - t0
        results.append(result)
        echo(format_result(result))
        write_results(out, results, quick)
    return results


def write_results(out: Path, results: list[CaseResult], quick: bool) -> Path:
    path = out / RESULTS
    write_json(path, {"quick": quick, "passed": all(r.passed for r in results),
                      "cases": [r.as_dict() for r in results]})
    return path


def register(subparsers) -> None:
    """Add ``whale-adapter validate``."""
    p = subparsers.add_parser(
        "validate", help="run the flows with known answers (docs/validation.md)",
        description="Run reference flows through the whale case's solver, wall treatment, "
        "loads and (for moving bodies) the step-server and mesh motion; print measured "
        "against reference with pass/fail and write <out>/validation.json.")
    p.add_argument("--out", type=out_folder, default=Path("out/validation"),
                   help="output folder (default %(default)s)")
    p.add_argument("--cases", default="", help=f"comma-separated subset of {', '.join(CASES)}")
    p.add_argument("--np", type=count, default=1, help="MPI ranks (default 1)")
    p.add_argument("--quick", action="store_true",
                   help="tiny meshes and short runs: the machinery, not the answer")
    p.add_argument("--quiet", "-q", action="store_true",
                   help="no progress and no report on stdout, only warnings and errors on stderr")
    p.set_defaults(func=_cmd_validate)


def _cmd_validate(args: argparse.Namespace) -> int:
    if args.np < 1:
        raise UsageError(f"--np {args.np}: give a rank count of at least 1")
    names = [n.strip() for n in args.cases.split(",") if n.strip()]
    results = run_suite(args.out, names or None, ranks=args.np, quick=args.quick)
    passed = all(r.passed for r in results)
    print(f"whale-adapter validate: {sum(r.passed for r in results)} of {len(results)} cases "
          f"passed; {args.out / RESULTS}")
    return 0 if passed else 1
