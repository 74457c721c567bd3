"""A case's folders: its ``processor<N>`` folders, the time a run starts from (the latest
written one, or the one the user's controlDict asks for), the initial fields. The time folders
are scanned by :func:`adapter.foamfiles.time_dirs` (imported here too, for the case's modules
that reach them through this one)."""

from __future__ import annotations

import shutil
from pathlib import Path

from adapter.errors import CaseError
from adapter.foam.dictionaries import parsed_dict
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


# --- a start the user asked for ---------------------------------------------------------------

def written_times(case: Path) -> list[float]:
    """The times a run could start from: the case folder's time folders and the times every
    processor folder holds, sorted."""
    procs = processor_dirs(case)
    common = None
    for p in procs:
        names = {t for t, _ in time_dirs(p)}
        common = names if common is None else common & names
    return sorted({t for t, _ in time_dirs(case)} | (common or set()))


def asked_start(case: Path) -> tuple[float, str] | None:
    """``(t, words)`` when ``system/controlDict`` asks a run to start elsewhere than at the
    latest written time: ``startFrom startTime`` (t: its ``startTime``) or ``firstTime`` (the
    earliest written time); None for ``latestTime``, run-case's own setting."""
    control = Path(case) / "system" / "controlDict"
    d = parsed_dict(control)
    how = str(d["startFrom"])
    if how == "latestTime":
        return None
    if how == "startTime":
        return float(d["startTime"]), f"startFrom startTime; startTime {d['startTime']}"
    if how == "firstTime":
        times = written_times(case)
        return (times[0] if times else 0.0), "startFrom firstTime"
    raise CaseError(f"{control}: startFrom {how} is not one of firstTime, startTime, latestTime")


def _same_time(a: float, b: float) -> bool:
    return abs(a - b) <= 1e-9 * max(1.0, abs(b))


def recompute_from(case: Path, t: float, words: str) -> str:
    """Honour a start at ``t`` that ``system/controlDict`` asks for (``words``, as
    :func:`asked_start` gives them): every written time after it is removed (case and
    processor folders), the rows after it of ``postProcessing/*/<t0>/*.dat`` too, and
    ``startFrom`` set back to ``latestTime`` (a rerun continues the recomputed run); what was
    done, in one line. A ``t`` that is not a written time is refused: run-case starts only
    where the fields and the mesh were written."""
    case = Path(case)
    times = written_times(case)
    if not any(_same_time(w, t) for w in times):
        before = [w for w in times if w < t]
        after = [w for w in times if w > t]
        near = ", ".join(f"{w:.12g}" for w in before[-1:] + after[:1])
        raise CaseError(f"{case / 'system' / 'controlDict'} asks to start from t = {t:.12g} s "
                        f"({words}), which is not a written time (nearest: {near} s): set "
                        "startTime to a written time to recompute from there, or startFrom "
                        f"latestTime to continue from the latest ({times[-1]:.12g} s)")
    later = [w for w in times if w > t and not _same_time(w, t)]
    for folder in [case, *processor_dirs(case)]:
        for w, d in time_dirs(folder):
            if w > t and not _same_time(w, t):
                shutil.rmtree(d)
    _trim_post_processing(case, t)
    d = parsed_dict(case / "system" / "controlDict")
    d["startFrom"] = "latestTime"
    d.writeFile()
    if len(later) > 1:
        removed = (f"removed the {len(later)} written times after it ({later[0]:.12g} to "
                   f"{later[-1]:.12g} s)")
    else:
        removed = (f"removed the written time after it ({later[0]:.12g} s)" if later
                   else "no written time after it")
    return (f"{case}: recomputing from t = {t:.12g} s, as system/controlDict asks ({words}): "
            f"{removed}; startFrom set back to latestTime, so that a rerun continues")


def _trim_post_processing(case: Path, t: float) -> None:
    """postProcessing's output after ``t``: the folders of runs that started at ``t`` or later
    removed (their rows are all later, and OpenFOAM would write beside a file left there), rows
    after it dropped from the others' ``.dat`` files (a row starts with its time)."""
    for fo in (Path(case) / "postProcessing").glob("*"):
        for t0, d in time_dirs(fo):
            if t0 > t or _same_time(t0, t):
                shutil.rmtree(d)
                continue
            for f in d.glob("*.dat"):
                lines = f.read_text(errors="replace").splitlines(keepends=True)
                keep = [line for line in lines if not _row_after(line, t)]
                if len(keep) != len(lines):
                    f.write_text("".join(keep))


def _row_after(line: str, t: float) -> bool:
    words = line.split(maxsplit=1)
    try:
        return bool(words) and float(words[0]) > t and not _same_time(float(words[0]), t)
    except ValueError:
        return False
