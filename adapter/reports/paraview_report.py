"""ParaView pictures of a run (``whale-adapter paraview DIR``).

A plain-Python driver: it checks DIR, chooses the times to draw, and runs the ParaView script
``adapter/reports/pvscripts/report.py`` under ``xvfb-run -a pvbatch``
(Debian's ParaView 5.11 needs an X display, see docs/paraview.md), printing the script's
progress lines as they come.

DIR is either

- a coupled case (``case.foam``, made by ``whale-adapter run-case``): the whale patch coloured by
  p in Pa (OpenFOAM's kinematic p times rho from adapter-case.json), the mid-plane slice y = 0
  coloured by |U| and the adapter's ``adapter/whale.pvd`` as a faint wireframe, or
- a dry-run output folder (``whale.pvd``, made by ``whale-adapter dry-run``): the whale surface
  coloured by |displacement|.

Into ``--out`` (default ``DIR/paraview``) go side and angled PNGs at the chosen times, an
animation (``animation/frame.NNNN.png`` and ``animation.ogv``), ``whale.pvsm`` for the ParaView
GUI (its file names relative to its folder: :func:`relative_state`), ``report.json`` (every
picture with its time and camera) and ``paraview.log`` (pvbatch's whole output).
"""

from __future__ import annotations

import argparse
import html
import json
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

from adapter.errors import AdapterError, ParaViewError
from adapter.foamfiles import time_dirs
from adapter.jsonfiles import CASE_RECORD, CASE_SUMMARY, write_json
from adapter.options import in_folder, non_negative, number, out_folder
from adapter.vtkfiles import read_pvd

#: the pvbatch script, run by ParaView's own Python
PV_SCRIPT = Path(__file__).resolve().parent / "pvscripts" / "report.py"
#: the X screen xvfb-run starts (24-bit: ParaView's OpenGL wants a true-colour visual)
XVFB_SCREEN = "-screen 0 1920x1080x24"
#: pictures per run: the quarter strokes of the last cycle (the paper's Figures 2-5)
N_FIGURES = 4
#: progress lines of the pvbatch script start with this
_PREFIX = "report: "
_REL = 1e-9
#: what pvbatch says when the X server went away under it (a display-number race): tried again
X_FAILURE = "bad X server connection"
_X_RETRIES = 3



def find_paraview() -> tuple[str, str]:
    """Paths of ``xvfb-run`` and ``pvbatch``; :class:`ParaViewError` naming the fix if absent."""
    pvbatch, xvfb = shutil.which("pvbatch"), shutil.which("xvfb-run")
    if pvbatch is None or xvfb is None:
        missing = [name for name, path in (("pvbatch", pvbatch), ("xvfb-run", xvfb)) if not path]
        raise ParaViewError(
            f"{' and '.join(missing)} not found: install ParaView and Xvfb with "
            "`make paraview-deps` (scripts/install_paraview.sh, Debian packages paraview "
            "python3-paraview xvfb xauth, about 2 minutes)")
    return xvfb, pvbatch


def input_kind(path: Path) -> str:
    """``"case"`` for a coupled case, ``"surface"`` for a dry-run folder; AdapterError else."""
    if not path.is_dir():
        raise AdapterError(
            f"{path} is not a folder; make one first with `whale-adapter run-case --preset smoke "
            f"--case {path}` (coupled case) or `whale-adapter dry-run --preset smoke --out "
            f"{path}` (dry-run)")
    if (path / "case.foam").is_file():
        return "case"
    if (path / "system" / "controlDict").is_file():
        if not (path / "constant" / "polyMesh").is_dir():
            raise AdapterError(f"{path} holds a case without a mesh; run it first with "
                               f"`whale-adapter run-case --case {path}`")
        # ParaView's OpenFOAM reader opens a case through an empty marker file
        (path / "case.foam").touch()
        return "case"
    if (path / "whale.pvd").is_file():
        return "surface"
    raise AdapterError(
        f"{path} has neither case.foam nor whale.pvd; make one first with `whale-adapter run-case"
        f" --case {path}` (coupled case) or `whale-adapter dry-run --out {path}` (dry-run)")


def case_layout(case: Path) -> tuple[str, list]:
    """(``"Reconstructed"`` or ``"Decomposed"``, the written times after 0 ParaView can show).

    The decomposed case when its processor folders hold more times than the case folder (a
    parallel run reconstructs only the time the next stage starts from). Time 0 is left out:
    ParaView's OpenFOAM reader skips it by default, and the template's 0/ files hold
    ``$Uinlet``-style macros that the reader cannot read.
    """
    times = [t for t, _ in time_dirs(case) if t > 0]
    ranks = [t for t, _ in time_dirs(case / "processor0") if t > 0]
    if len(ranks) > len(times):
        return "Decomposed", ranks
    if times:
        return "Reconstructed", times
    raise AdapterError(f"{case} has no written time after 0 to show; run it first with "
                       f"`whale-adapter run-case --case {case}`")


def pvd_times(pvd: Path) -> list:
    """The times of a ParaView collection file, sorted."""
    times = sorted(read_pvd(pvd))
    if not times:
        raise AdapterError(f"{pvd} lists no frame; write it again with `whale-adapter dry-run`")
    return times


def read_period(path: Path, kind: str) -> float | None:
    """The stroke period T (s): adapter-case.json / adapter-summary.json of a case, summary.json
    of a dry-run; None when none of them has it."""
    names = (CASE_SUMMARY, CASE_RECORD) if kind == "case" else ("summary.json",)
    for name in names:
        f = path / name
        if f.is_file():
            try:
                value = json.loads(f.read_text()).get("period_s")
            except (json.JSONDecodeError, AttributeError):
                continue
            if value:
                return float(value)
    return None


def read_rho(path: Path) -> float | None:
    """The case's water density (kg/m3): adapter-case.json's ``rho_kg_m3``, else the forces
    function's ``rhoInf`` in system/controlDict; None when neither has it."""
    try:
        value = json.loads((path / CASE_RECORD).read_text()).get("rho_kg_m3")
        if value:
            return float(value)
    except (OSError, json.JSONDecodeError, AttributeError, TypeError, ValueError):
        pass
    try:
        m = re.search(r"^\s*rhoInf\s+([-+0-9.eE]+)\s*;", (path / "system" / "controlDict")
                      .read_text(), re.M)
    except OSError:
        return None
    return float(m.group(1)) if m else None


def _nearest(times: list, t: float) -> float:
    return min(times, key=lambda s: (abs(s - t), s))


def choose_times(times: list, period: float | None, n: int = N_FIGURES) -> list:
    """The written times to draw: nearest to 0, T/4, T/2, 3T/4 of the last whole stroke cycle.

    All written times when there are ``n`` or fewer; evenly spaced over the run when it is
    shorter than one period or the period is unknown. Sorted, without repeats.
    """
    times = sorted(times)
    if len(times) <= n:
        return times
    t0, t1 = times[0], times[-1]
    if period and t1 - t0 >= period * (1 - _REL):
        start = (int(t1 / period + _REL) - 1) * period
        if start < t0 - _REL * period:
            start = t1 - period
        targets = [start + k * period / n for k in range(n)]
    else:
        targets = [t0 + k * (t1 - t0) / (n - 1) for k in range(n)]
    return sorted({_nearest(times, t) for t in targets})


def video_rate(times: list, period: float | None) -> int:
    """Frames per second that show one stroke cycle in about 4 s (2..30; 10 without T)."""
    if not period or len(times) < 2 or times[-1] <= times[0]:
        return 10
    per_cycle = (len(times) - 1) / (times[-1] - times[0]) * period
    return max(2, min(30, round(per_cycle / 4)))


def pvbatch_command(path: Path, out: Path, kind: str, times: list, *, case_type: str,
                    size=(1600, 900), animation: bool = True, fps: int = 10,
                    rho: float | None = None) -> list:
    """The ``xvfb-run -a pvbatch report.py ...`` command line."""
    xvfb, pvbatch = find_paraview()
    # -a takes the first free display from -n on; starting from a number of our own keeps
    # parallel runs (and a server still shutting down on :99) out of each other's way
    server_num = 100 + os.getpid() % 800
    cmd = [xvfb, "-a", "-n", str(server_num), "-s", XVFB_SCREEN, pvbatch, str(PV_SCRIPT),
           "--input", str(path), "--out", str(out), "--kind", kind, "--case-type", case_type,
           "--size", str(size[0]), str(size[1]), "--fps", str(fps),
           "--times", *[repr(float(t)) for t in times]]
    if not animation:
        cmd.append("--no-animation")
    if rho:
        cmd += ["--rho", repr(float(rho))]
    return cmd


def _run_streaming(cmd: list, log, stream, cwd: Path) -> tuple[int, list, bool]:
    """Run ``cmd``, copy its output to ``log``, echo its progress lines; (exit code, last
    lines, whether pvbatch could not reach the X server anywhere in its output)."""
    log.write(" ".join(cmd) + "\n")
    log.flush()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            env=pvbatch_env(), cwd=cwd)
    tail: list = []
    x_failed = False
    assert proc.stdout is not None    # stdout=PIPE
    for line in proc.stdout:
        log.write(line)
        tail = (tail + [line.rstrip()])[-25:]
        x_failed = x_failed or X_FAILURE in line
        if line.startswith(_PREFIX):
            print("paraview: " + line[len(_PREFIX):].rstrip(), file=stream, flush=True)
    return proc.wait(), tail, x_failed


def pvbatch_env() -> dict:
    """The environment for pvbatch: ParaView runs Debian's python3, not the venv's."""
    env = {k: v for k, v in os.environ.items()
           if k not in ("PYTHONHOME", "PYTHONPATH", "VIRTUAL_ENV", "PYTHONSTARTUP")}
    env.pop("DISPLAY", None)  # xvfb-run sets its own; never draw on the user's screen
    return env


def render(path, out=None, times=None, *, size=(1600, 900), animation: bool = True,
           stream=sys.stdout) -> dict:
    """Draw the case or dry-run folder ``path`` with ParaView; the report.json contents.

    Parameters
    ----------
    path : a coupled case (case.foam) or a dry-run output folder (whale.pvd).
    out : output folder; None is ``path/paraview``.
    times : times (s) to draw, each moved to the nearest written time; None chooses them
        (:func:`choose_times`).
    size : picture size in pixels (width, height).
    animation : also write the PNG series over all times and the video.
    stream : where the progress lines go.
    """
    path = Path(path).resolve()
    find_paraview()            # first: nothing is written into a folder ParaView cannot draw
    kind = input_kind(path)
    if kind == "case":
        case_type, written = case_layout(path)
    else:
        case_type, written = "Reconstructed", pvd_times(path / "whale.pvd")
    period = read_period(path, kind)
    if times:
        chosen = sorted({_nearest(written, float(t)) for t in times})
        for t in times:
            s = _nearest(written, float(t))
            if abs(s - float(t)) > 1e-9 * max(1.0, abs(s)):
                print(f"paraview: t = {t:g} s is not a written time; drawing t = {s:.6g} s",
                      file=stream, flush=True)
    else:
        chosen = choose_times(written, period)
    out = Path(out).resolve() if out else path / "paraview"
    out.mkdir(parents=True, exist_ok=True)
    cmd = pvbatch_command(path, out, kind, chosen, case_type=case_type, size=size,
                          animation=animation, fps=video_rate(written, period),
                          rho=read_rho(path) if kind == "case" else None)
    what = "coupled case" if kind == "case" else "dry-run"
    print(f"paraview: {what} {path}: {len(written)} written times, drawing "
          f"{', '.join(f'{t:.6g}' for t in chosen)} s" + (f" (T = {period:.4g} s)" if period
                                                           else ""), file=stream, flush=True)
    log_path = out / "paraview.log"
    t0 = time.perf_counter()
    with open(log_path, "w") as log:
        for attempt in range(1 + _X_RETRIES):
            rc, tail, x_failed = _run_streaming(cmd, log, stream, out)
            if rc == 0 or not x_failed or attempt == _X_RETRIES:
                break
            print("paraview: pvbatch could not connect to Xvfb; trying again on another "
                  "display", file=stream, flush=True)
            cmd[cmd.index("-n") + 1] = str(int(cmd[cmd.index("-n") + 1]) + 17)
    wall = time.perf_counter() - t0
    report_file = out / "report.json"
    if rc != 0 or not report_file.is_file():
        shown = "\n".join("  " + s for s in tail)
        raise ParaViewError(f"pvbatch failed (exit code {rc}) drawing {path}; the last lines:\n"
                            f"{shown}\nwhole output: {log_path}")
    report = json.loads(report_file.read_text())
    relative_state(out / report["state"])
    report["wall_s"] = wall
    write_json(report_file, report)
    print(f"paraview: {len(report['images'])} pictures, "
          f"{report.get('animation', {}).get('frames', 0)} animation frames and "
          f"{report['state']} in {out} ({wall:.1f} s)", file=stream, flush=True)
    return report


#: a file-name property of a ParaView state file (readers' FileName, FileNames) and its values
_FILE_PROPERTY_RE = re.compile(r'(<Property name="FileNames?"[^>]*>)(.*?)(</Property>)', re.S)
_VALUE_RE = re.compile(r'(<Element index="\d+" value=")([^"]*)(")')


def relative_state(state: Path) -> None:
    """Rewrite the file names in the ParaView state file ``state`` relative to its folder
    (``../case.foam``), so that the state still opens when the case moves: ParaView writes
    them absolute. ParaView resolves a relative name against its working folder, so the
    state opens from its own folder (docs/paraview.md, "The state file")."""
    state = Path(state)
    folder = state.parent.resolve()

    def relative(value: re.Match) -> str:
        name = html.unescape(value.group(2))
        if os.path.isabs(name):
            name = os.path.relpath(name, folder)
        return value.group(1) + html.escape(name, quote=True) + value.group(3)

    text = _FILE_PROPERTY_RE.sub(
        lambda p: p.group(1) + _VALUE_RE.sub(relative, p.group(2)) + p.group(3),
        state.read_text())
    state.write_text(text)


# --------------------------------------------------------------------------------------------
# command line


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "paraview",
        help="ParaView pictures, animation and state file of a case or dry-run",
        description="Draw a coupled case (case.foam: whale patch by p, mid-plane slice by |U|, "
        "adapter surface) or a dry-run folder (whale.pvd) with ParaView under xvfb-run: side "
        "and angled PNGs at chosen times, an animation, and whale.pvsm for the ParaView GUI. "
        "Needs ParaView and Xvfb (make paraview-deps).",
    )
    p.add_argument("dir", metavar="DIR", type=_drawable_folder,
                   help="coupled case folder or dry-run output folder (make paraview: the "
                   "case just run, CASE, default runs/default; DIR=out/dry-run a dry-run)")
    p.add_argument("--times", type=non_negative, nargs="+", metavar="T",
                   help="times (s) to draw, each moved to the nearest written time (default: "
                   "0, T/4, T/2, 3T/4 of the last stroke cycle, or every time when fewer)")
    p.add_argument("--out", type=out_folder, help="output folder (default: DIR/paraview)")
    p.add_argument("--size", type=number(int, 64), nargs=2, default=(1600, 900), metavar=("W", "H"),
                   help="picture size in pixels (default 1600 900)")
    p.add_argument("--no-animation", action="store_true",
                   help="only the pictures at --times and the state file")
    p.set_defaults(func=_cmd_paraview)


def _drawable_folder(text: str) -> Path:
    """DIR, an existing folder; a missing one says how to make it."""
    if not Path(text).expanduser().exists():
        raise argparse.ArgumentTypeError(
            f"{text} does not exist: run the case first (make run-case, or `whale-adapter "
            f"run-case --case {text}`), or name a dry-run folder (make paraview DIR=out/dry-run)")
    return in_folder(text)


def _cmd_paraview(args: argparse.Namespace) -> int:
    if min(args.size) < 64:
        raise AdapterError(f"--size: expected at least 64 x 64 pixels, got {args.size}")
    render(args.dir, args.out, args.times, size=tuple(args.size),
           animation=not args.no_animation)
    return 0
