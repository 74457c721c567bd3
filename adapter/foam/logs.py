"""Reading OpenFOAM's logs: checkMesh's facts, the first fatal error, and :class:`LogWatch`,
which follows a growing pimpleFoam log (times, Courant number, the mesh-motion checks, the
plugin's timing); :class:`Progress` shows it as one line, with the ETA of
:mod:`adapter.foam.eta`.

Mesh watch: the blended mesh motion (``whaleBlendedDisplacement``, ``checkMotion yes``) checks
the new points before the mesh moves, prints the smallest cell volume and the largest face
non-orthogonality of every new mesh in the words of OpenFOAM's own checks (one line:
``whaleBlendedDisplacement: the new mesh: Min volume = V. Mesh non-orthogonality Max: A ...``),
and stops the run with a FatalError when they would make an invalid mesh
(:func:`motion_check_stop` reads it). Any other motion runs with ``-debug-switch polyMesh=1``,
which makes OpenFOAM v1912's ``polyMesh::movePoints`` check every new mesh (``checkMeshMotion``)
and print the same figures (two lines) and the invalid-mesh lines. :data:`NON_ORTHOGONALITY_RE`
also reads checkMesh's. See docs/case.md.
"""

from __future__ import annotations

import math
import re
import sys
import time
from pathlib import Path

from adapter.foam.eta import PairEta, minutes, to_end_time
from adapter.foam.outcome import RunOutcome, Stop

#: the largest face non-orthogonality (deg), as checkMesh and the mesh-motion check print it
NON_ORTHOGONALITY_RE = re.compile(r"Mesh non-orthogonality Max: ([-+0-9.eE]+)")
_TIME_RE = re.compile(r"^Time = ([-+0-9.eE]+)\s*$")
_EXEC_RE = re.compile(r"^ExecutionTime = ([-+0-9.eE]+) s")
_MINVOL_RE = re.compile(r"Min volume = ([-+0-9.eE]+?)\.\s")
_COURANT_RE = re.compile(r"^Courant Number mean: \S+ max: ([-+0-9.eE]+)")
#: the plugin's report at every write: its requests and their mean exchange (us)
PLUGIN_EXCHANGE_RE = re.compile(
    r"stepServer: ([0-9]+) requests, mean ([0-9.]+) us per exchange\s*$")
_BROKEN_RE = re.compile(r"\*\*\*(Zero or negative cell volume|Error in face pyramids"
                        r"|Number of non-orthogonality errors)")
#: the first line of whaleBlendedDisplacement's FatalError (the plugin's meshMotionCheck.C)
_MOTION_CHECK_RE = re.compile(r"the mesh at t = (\S+) s would be invalid \((.*)\); "
                              r"stopped before moving it")


def parse_check_mesh(text: str) -> dict:
    """Cells, whale patch size and quality from a checkMesh log."""
    info: dict = {}
    m = re.search(r"^\s*cells:\s+(\d+)", text, re.M)
    if m:
        info["cells"] = int(m.group(1))
    m = re.search(r"^\s*whale\s+(\d+)\s+(\d+)\s", text, re.M)
    if m:
        info["whale_faces"], info["whale_points"] = int(m.group(1)), int(m.group(2))
    m = NON_ORTHOGONALITY_RE.search(text)
    if m:
        info["max_non_orthogonality"] = float(m.group(1))
    m = re.search(r"Max skewness = ([-+0-9.eE]+)", text)
    if m:
        info["max_skewness"] = float(m.group(1))
    info["mesh_ok"] = "Mesh OK." in text
    return info



def fatal_error(log_text: str) -> str | None:
    """The message lines of the first ``--> FOAM FATAL (IO) ERROR`` block of a log, or None.

    OpenFOAM prints the header, the message, then ``From function ...`` / ``in file ...`` and
    ``FOAM exiting``; rank prefixes (``[1] ``) of a parallel run are dropped."""
    lines = [re.sub(r"^\[\d+\] ?", "", line) for line in log_text.splitlines()]
    for i, line in enumerate(lines):
        m = re.search(r"--> FOAM FATAL (?:IO )?ERROR:?(.*)$", line)
        if not m:
            continue
        out = [m.group(1).strip()] if m.group(1).strip() else []
        for rest in lines[i + 1:]:
            text = rest.strip()
            if text.startswith(("From function", "From ", "in file", "FOAM exiting",
                                "FOAM parallel run exiting", "--> FOAM")):
                break
            if text:
                out.append(text)
        return "\n".join(out) if out else None
    return None


def motion_check_stop(fatal: str | None) -> RunOutcome | None:
    """A :attr:`~adapter.foam.outcome.Stop.MOTION_CHECK` outcome when OpenFOAM's fatal error
    (:func:`fatal_error`) is the mesh motion's check: the mesh at its ``time`` (s) would have
    been invalid, its ``reason`` says how (e.g. ``face pyramids: 2 faces incorrectly
    oriented``), and the run stopped before moving it. None for any other error."""
    m = _MOTION_CHECK_RE.search(fatal or "")
    return RunOutcome(Stop.MOTION_CHECK, m.group(2), float(m.group(1))) if m else None


class LogWatch:
    """Follows a pimpleFoam log as it grows and keeps what the run reports.

    Attributes: times (every ``Time =``), seen (wall clock when each appeared), exec_times
    (``ExecutionTime``, s), max_non_orth (deg) and min_volume (m^3) over every mesh motion
    check, max_courant, plugin (requests, mean us), broken (the first line reporting an invalid
    mesh, or None).
    """

    def __init__(self, path: Path):
        self.path = Path(path)
        self._pos = 0
        self._rest = ""
        self.times: list = []
        self.seen: list = []
        self.exec_times: list = []
        self.max_non_orth = float("nan")
        self.last_non_orth = float("nan")
        self.min_volume = float("nan")
        self.max_courant = float("nan")
        self.plugin: tuple | None = None
        self.broken: str | None = None

    def poll(self) -> None:
        """Read what was appended since the last call."""
        try:
            with open(self.path, errors="replace") as fh:
                fh.seek(self._pos)
                chunk = fh.read()
                self._pos = fh.tell()
        except FileNotFoundError:
            return
        lines = (self._rest + chunk).split("\n")
        self._rest = lines.pop()
        for line in lines:
            self.feed(line)

    def feed(self, line: str) -> None:
        """Take one log line."""
        line = re.sub(r"^\[\d+\] ", "", line)
        if m := _TIME_RE.match(line):
            self.times.append(float(m.group(1)))
            self.seen.append(time.perf_counter())
        elif m := _EXEC_RE.match(line):
            self.exec_times.append(float(m.group(1)))
        elif m := _COURANT_RE.match(line):
            self.max_courant = _nanmax(self.max_courant, float(m.group(1)))
        elif m := PLUGIN_EXCHANGE_RE.search(line):
            self.plugin = (int(m.group(1)), float(m.group(2)))
        # (the blended motion's check prints both on one line, OpenFOAM's check on two)
        if m := NON_ORTHOGONALITY_RE.search(line):
            v = float(m.group(1))
            self.last_non_orth = v
            self.max_non_orth = _nanmax(self.max_non_orth, v)
        if m := _MINVOL_RE.search(line):
            self.min_volume = _nanmin(self.min_volume, float(m.group(1)))
        if self.broken is None and _BROKEN_RE.search(line):
            self.broken = line.strip()

    def drop_unfinished_step(self) -> None:
        """Forget the last ``Time =`` when its step did not finish (no ``ExecutionTime`` after
        it: the run stopped in it, e.g. at its mesh update)."""
        if len(self.times) > len(self.exec_times):
            self.times.pop()
            self.seen.pop()

    def seconds_per_step(self) -> float:
        """Mean wall seconds per step, leaving out the first (start-up) step.

        Measured from when each ``Time =`` line appeared in the log (polled every 0.1 s), so it
        includes the time the solver waits for the step-server."""
        s = self.seen
        if len(s) >= 3:
            return (s[-1] - s[0]) / (len(s) - 1)
        return float("nan")

    def cpu_seconds_per_step(self) -> float:
        """Mean CPU seconds per step of the (master) solver process, from ExecutionTime."""
        e = self.exec_times
        if len(e) >= 3:
            return (e[-1] - e[0]) / (len(e) - 1)
        if e:
            return e[-1] / len(e)
        return float("nan")


def _nanmax(a: float, b: float) -> float:
    return b if math.isnan(a) else max(a, b)


def _nanmin(a: float, b: float) -> float:
    return b if math.isnan(a) else min(a, b)


class Progress:
    """One progress line: simulated time, the time the run can stop at, s per step, the ETA in
    minutes by the run's stopping rule (``eta``, :class:`~adapter.foam.eta.PairEta`; default:
    to the end time), mesh quality."""

    def __init__(self, end_time: float, start_time: float, stream=sys.stderr,
                 eta: PairEta | None = None):
        self.end = end_time
        self.start = start_time
        self.eta = eta or PairEta(to_end_time(end_time))
        self.stream = stream
        self.tty = stream.isatty()
        self.t_wall = time.perf_counter()
        self.last_print = 0.0
        self.last_line = ""

    def show(self, watch: LogWatch, final: bool = False) -> None:
        if not watch.times:
            return
        now = time.perf_counter()
        if not final and not self.tty and now - self.last_print < 10:
            return
        t = watch.times[-1]
        steps = len(watch.times)
        per_step = (now - self.t_wall) / steps
        left = self.eta.seconds(t, (now - self.t_wall) / max(t - self.start, 1e-12))
        target = self.eta.target(t)
        stop = (f"/ {self.end:.4g} s" if target >= self.end else
                f"s (can stop at {target:.4g}, end {self.end:.4g})")
        line = (f"pimpleFoam  t = {t:.4g} {stop}  step {steps}  {per_step:.2f} s/step  "
                f"ETA {minutes(left)}" + (" (with swimming)" if self.eta.then else "") + "  " + (
                    "static mesh" if math.isnan(watch.max_non_orth) else
                    f"non-orth {watch.last_non_orth:.1f} deg (max {watch.max_non_orth:.1f})"))
        if line == self.last_line and not final:
            return
        self.last_line = line
        self.last_print = now
        if self.tty:
            print("\r" + line, end="\n" if final else "", file=self.stream, flush=True)
        else:
            print(line, file=self.stream, flush=True)
