"""A case's folders: its ``processor<N>`` folders, the time a run starts from, the initial
fields. The time folders are scanned by :func:`adapter.foamfiles.time_dirs` (imported here too,
for the case's modules that reach them through this one)."""

from __future__ import annotations

import shutil
from pathlib import Path

from adapter.foamfiles import time_dirs


def processor_dirs(case: Path) -> list:
    """The case's ``processor<N>`` folders, in rank order."""
    procs = [p for p in Path(case).glob("processor*") if p.is_dir() and p.name[9:].isdigit()]
    return sorted(procs, key=lambda p: int(p.name[9:]))


def processor_latest(case: Path) -> float | None:
    """The latest time every processor folder holds, or None (no processor folders)."""
    common = None
    for p in processor_dirs(case):
        names = {d.name for _, d in time_dirs(p)}
        common = names if common is None else common & names
    return max((float(n) for n in common), default=None) if common else None


def trim_processor_times(case: Path, latest: float) -> None:
    """Remove the processor time folders after ``latest`` (a time only some ranks wrote)."""
    for p in processor_dirs(case):
        for t, d in time_dirs(p):
            if t > latest:
                shutil.rmtree(d)


def serial_latest(case: Path) -> float:
    """The latest time folder of the case folder itself (0 when it has none)."""
    times = time_dirs(case)
    return times[-1][0] if times else 0.0


def resume_time(case_dir) -> float:
    """The time a run of the case starts from: its latest written time, in the case folder or
    (after a parallel run that was not reconstructed) in every processor folder."""
    case = Path(case_dir)
    serial = serial_latest(case)
    procs = processor_latest(case)
    return serial if procs is None else max(serial, procs)


def restore_zero(case: Path) -> None:
    """Copy the initial fields of 0.orig that 0/ lacks (snappyHexMesh -overwrite writes its
    layer fields nSurfaceLayers, thickness, thicknessFraction into 0/ first; they stay)."""
    zero = Path(case) / "0"
    zero.mkdir(exist_ok=True)
    for f in (Path(case) / "0.orig").iterdir():
        if f.is_file() and not (zero / f.name).exists():
            shutil.copy2(f, zero / f.name)
