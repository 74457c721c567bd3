"""Room for a run's writes: before the solver starts, the time folders still to be written against
the free space of the case's file system. A solver that runs out of room stops in the middle of
a write and can leave a half-written time folder as the case's latest, the one a rerun would
start from; refused before it starts, the run loses nothing (docs/faults.md)."""

from __future__ import annotations

import math
import shutil
from pathlib import Path

from adapter.errors import CaseError
from adapter.foam.folders import processor_dirs
from adapter.foamfiles import time_dirs

#: bytes a written time takes per cell when the case has written none yet to measure: the default
#: case's 876 (51,379 cells, 45 MB a write over both ranks, 2026-12-08: ascii at 15 digits, the
#: fields, the backward scheme's old-time fields, the face fluxes, the moved points)
BYTES_PER_CELL = 900
#: room kept beyond the time folders: the logs, postProcessing, the summaries
SPARE_BYTES = 200 * 2**20


def write_bytes(case: Path, cells: int) -> float:
    """The size of one written time: the case's latest written time after 0, summed over the
    processor folders of a parallel run, when it has one; else ``cells`` x
    :data:`BYTES_PER_CELL`."""
    for folders in (processor_dirs(case), [case]):
        latest = [time_dirs(p) for p in folders]
        if latest and all(t and t[-1][0] > 0 for t in latest):
            return float(sum(_size(t[-1][1]) for t in latest))
    return float(cells * BYTES_PER_CELL)


def writes_left(control: dict, start: float, end: float) -> int:
    """The time folders a run from ``start`` to ``end`` writes by controlDict's settings (its
    ``writeControl`` timeStep or runTime kinds), at most ``purgeWrite`` kept; 0 when unknown."""
    kind = str(control.get("writeControl", "timeStep"))
    interval = float(control.get("writeInterval", 1))
    if kind == "timeStep":
        interval *= float(control["deltaT"])
    elif kind not in ("runTime", "adjustableRunTime"):
        return 0
    n = max(0, math.floor((end - start) / interval + 1e-6))
    purge = int(control.get("purgeWrite", 0))
    return min(n, purge) if purge > 0 else n


def check_room(case: Path, control: dict, start: float, end: float, cells: int) -> None:
    """Raise :class:`~adapter.errors.CaseError` when the case's file system has less free space
    than the run's writes (:func:`writes_left` x :func:`write_bytes`) and :data:`SPARE_BYTES`."""
    n = writes_left(control, start, end)
    each = write_bytes(case, cells)
    need = n * each + SPARE_BYTES
    free = shutil.disk_usage(case).free
    if n and need > free:
        raise CaseError(
            f"{case} needs about {need / 2**30:.1f} GB for the run's {n} writes "
            f"({each / 2**20:.0f} MB each, {cells:,} cells) and its file system has "
            f"{free / 2**30:.1f} GB free: free some space, or write less often "
            "([case] writes_per_cycle), then run the same command again")


def _size(folder: Path) -> int:
    return sum(f.stat().st_size for f in folder.rglob("*") if f.is_file())
