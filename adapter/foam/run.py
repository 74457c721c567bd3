"""Running a prepared case: pimpleFoam, serial or on N MPI ranks, with the step-server
(:mod:`adapter.foam.stepserver`) in the background; its log followed (:mod:`adapter.foam.logs`)
with a progress line and the mesh watch, and the summary written (:mod:`adapter.foam.summary`).

Mesh watch (the figures from the blended motion's own check, or with any other motion from
polyMesh's debug switch: :func:`solver_command`): when the non-orthogonality of the moved mesh
passes ``case.max_non_orthogonality`` the solver gets SIGUSR1, which ``-opt-switch
stopAtWriteNowSignal=10`` turns into "write this step and stop", so the run ends on a written,
still valid mesh. The blended mesh motion (``whaleBlendedDisplacement``, ``checkMotion yes``)
checks the new points before the mesh moves and stops the run with a FatalError when they would
make an invalid mesh; that run ends with ``stopped`` saying so and an error. See docs/case.md.
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import time
from pathlib import Path
from typing import NoReturn

from adapter import resources
from adapter.coupling.protocol import TOKEN_ENV
from adapter.errors import SolverRunError
from adapter.foam.case import Case, parallel_settings
from adapter.foam.dictionaries import parsed_dict, plugin_lib, set_decomposition
from adapter.foam.diskspace import check_room
from adapter.foam.eta import PairEta
from adapter.foam.folders import (
    asked_start,
    processor_dirs,
    processor_latest,
    recompute_from,
    restore_zero,
    resume_time,
    serial_latest,
    trim_processor_times,
)
from adapter.foam.logs import LogWatch, Progress, fatal_error, motion_check_stop
from adapter.foam.mesh import checked_mesh, mesh_case
from adapter.foam.outcome import ENDED, RunOutcome, Stop
from adapter.foam.parallel import parallel_command
from adapter.foam.stepserver import start_server, stop_server
from adapter.foam.summary import SUMMARY, summarise
from adapter.foam.tools import check_foam, foam_env, run_utility

#: run_case's stop_when is asked after this many new solver steps
STOP_WHEN_STEPS = 10
#: the signal pimpleFoam turns into "write now and stop" (-opt-switch stopAtWriteNowSignal)
STOP_SIGNAL = signal.SIGUSR1
#: what to do when the blended mesh motion's check stopped a run (docs/case.md, "Mesh watch")
MOTION_ADVICE = ("make the whale's motion gentler where the mesh would fold (a smaller fluke "
                 "pitch: [stroke] fluke_angle_scale), spread the mesh motion over more cells "
                 "([case] motion_inner, motion_outer; more neighbours at a lower power: "
                 "motion_neighbours, motion_power) or mesh that region differently "
                 "(docs/case.md, 'Mesh watch')")


def motion_checks_itself(case: Path) -> bool:
    """Does the case's mesh motion check and report every new mesh itself?

    ``whaleBlendedDisplacement`` with ``checkMotion yes`` (its default) prints the smallest cell
    volume and the largest non-orthogonality of every new mesh, in the words of OpenFOAM's own
    checks, before it moves the mesh; any other motion (the Laplacian) needs polyMesh's debug
    switch for the log watch. A static mesh (``staticFvMesh``) needs no check: True."""
    d = parsed_dict(case / "constant" / "dynamicMeshDict")
    if d["dynamicFvMesh"] == "staticFvMesh":
        return True
    if d["motionSolver"] != "whaleBlendedDisplacement":
        return False
    check = d["whaleBlendedDisplacementCoeffs"].get("checkMotion", "yes")
    return str(check).lower() in ("yes", "on", "true", "1")


def solver_command(case: Path) -> list:
    """pimpleFoam with the stop signal, and polyMesh's debug switch (OpenFOAM checks every moved
    mesh and prints its figures) unless the motion does that itself (:func:`motion_checks_itself`:
    the same check again costs 0.02 CPU s a step on the default mesh)."""
    debug = [] if motion_checks_itself(case) else ["-debug-switch", "polyMesh=1"]
    return ["pimpleFoam", *debug, "-opt-switch", f"stopAtWriteNowSignal={int(STOP_SIGNAL)}"]


def run_case(case_dir, *, ranks: int | None = None, progress: bool = True,
             stop_when=None, host: str | None = None, port: int | None = None,
             token: str | None = None, launcher: str | None = None,
             reconstruct: bool | None = None, eta: PairEta | None = None) -> dict:
    """Run pimpleFoam on a prepared case with the step-server, and summarise the run.

    Meshes the case first when it has no mesh. Serial for one rank, otherwise decomposePar
    (the case's decomposition, :func:`~adapter.foam.dictionaries.set_decomposition`) and
    ``<launcher> pimpleFoam -parallel`` (:mod:`adapter.foam.parallel`; ``launcher`` None: the
    recorded ``case.launcher``, "" there: mpirun); reconstructPar only when ``reconstruct``
    (None: the recorded ``case.reconstruct``), else the written times stay in the processor
    folders (a rerun on as many ranks continues from them). A case that has written times
    continues from the latest (controlDict ``startFrom latestTime``), unless the user set
    ``startFrom startTime`` (or ``firstTime``) there: then the written times after that one
    are removed and recomputed, and said so (:func:`~adapter.foam.folders.recompute_from`;
    a start time that is not a written time is refused).

    ``stop_when(case) -> str | None`` is asked every :data:`STOP_WHEN_STEPS` solver steps and
    once at the end; a reason ends the run (written) as the mesh watch does, and is recorded
    as ``stopped_because`` (not an error). ``eta``: the progress line's estimate by the rule
    that stops the run (:class:`~adapter.foam.eta.PairEta`; None: to the end time).

    ``host``/``port``: the server listens on TCP there (port 0: any free one) and publishes
    it in ``<case>/.whale-adapter.endpoint``; else on the case's UNIX socket. ``token`` (None:
    ``$WHALE_ADAPTER_TOKEN``) reaches the server and the solver through the environment only.

    Returns the summary also written to ``<case>/adapter-summary.json``. Raises
    :class:`~adapter.errors.SolverRunError` naming the log when pimpleFoam fails, or when the
    mesh watch stopped the run (after writing the summary).
    """
    check_foam()
    t_start = time.perf_counter()
    case = Path(case_dir).resolve()
    record = Case(case).record
    ranks = int(ranks or record["parameters"]["ranks"])
    settings = parallel_settings(record, launcher=launcher, reconstruct=reconstruct)
    record = _ready(case, record, ranks, settings)
    ranks_latest, from_ranks = _resume_point(case, ranks)
    start_time = resume_time(case)
    control = parsed_dict(case / "system" / "controlDict")
    end_time = float(control["endTime"])
    if start_time >= end_time - 0.5 * float(control["deltaT"]):
        return _finished(case, record, ranks, from_ranks and settings["reconstruct"], t_start)
    # a run that cannot write all its times is refused before it starts (a full disk would
    # stop it mid-write, its latest time folder half written)
    check_room(case, control.content, start_time, end_time,
               int(record.get("mesh", {}).get("cells", 0)))
    token = token or os.environ.get(TOKEN_ENV) or None
    env = foam_env()
    env.pop(TOKEN_ENV, None)
    if token:
        env[TOKEN_ENV] = token
    cmd = solver_command(case)
    watch = LogWatch(case / "log.pimpleFoam")
    server = None
    try:
        if ranks > 1 and from_ranks and ranks_latest is not None:
            # resume from the ranks' own latest time (a crash left it only there)
            trim_processor_times(case, ranks_latest)
        elif ranks > 1:
            for p in case.glob("processor*"):
                shutil.rmtree(p)
            run_utility(case, ["decomposePar", "-force", "-latestTime"])
        if ranks > 1:
            # the token reaches the ranks on other hosts through the environment (Open MPI's
            # -x), never a file
            cmd = parallel_command(cmd, ranks, settings["launcher"], token=bool(token))
        if not record.get("static_whale"):
            server = start_server(case, record, host=host, port=port, token=token)
        t_flow = time.perf_counter()
        rc, outcome = _run_watched(case, cmd, watch, record, start_time, end_time, progress,
                                   stop_when, env=env, eta=eta)
        flow_wall = time.perf_counter() - t_flow
    finally:
        stop_server(server)
    return _conclude(case, rc, outcome, watch, record, ranks,
                     bool(ranks > 1 and settings["reconstruct"]), (flow_wall, t_start))


def _ready(case: Path, record: dict, ranks: int, settings: dict) -> dict:
    """Make a prepared case ready to run: meshed (when it has no mesh), its mesh checked,
    ``0`` restored, a user's start time taken, decomposed on ``ranks``; the record as it is
    then. Refuses a coupled case without the plugin library."""
    if not (case / "constant" / "polyMesh" / "owner").exists():
        mesh_case(case, ranks=ranks, launcher=settings["launcher"])
        record = Case(case).record
    # a mesh that misses or mangles the body is refused before any solver runs
    checked_mesh(case, record)
    restore_zero(case)
    asked = asked_start(case)
    if asked is not None:
        print(recompute_from(case, *asked))
    if ranks > 1:
        set_decomposition(case, ranks, settings["decomposition"])
    if not record.get("static_whale") and not plugin_lib().is_file():
        raise SolverRunError(f"the boundary condition library {plugin_lib()} is missing; build "
                             f"it with `bash {resources.BUILD_SCRIPT}` (or point "
                             "WHALE_PLUGIN_LIB at a built one)")
    return record


def _resume_point(case: Path, ranks: int) -> tuple[float | None, bool]:
    """(the latest time all processor folders hold or None, whether the run continues from
    them); times in processor folders of another rank count are reconstructed first."""
    ranks_latest = processor_latest(case)
    from_ranks = ranks_latest is not None and ranks_latest > serial_latest(case)
    if ranks_latest is not None and from_ranks and (
            ranks == 1 or len(processor_dirs(case)) != ranks):
        # the latest times are in processor folders of another rank count: reconstruct them
        trim_processor_times(case, ranks_latest)
        run_utility(case, ["reconstructPar", "-newTimes"])
        from_ranks = False
    return ranks_latest, from_ranks


def _conclude(case: Path, rc: int, outcome: RunOutcome, watch: LogWatch, record: dict,
              ranks: int, reconstruct: bool, walls: tuple[float, float]) -> dict:
    """After the solver: its failure raised, the summary written (with why the run stopped)
    and returned; raises when the mesh stopped the run. ``walls``: (the flow's wall time,
    the run's start on the clock)."""
    fatal = None
    if rc != 0:
        fatal = fatal_error((case / "log.pimpleFoam").read_text(errors="replace"))
        checked = motion_check_stop(fatal)
        if checked is None:
            _raise_failed(case, rc, outcome.message(), watch, fatal)
        outcome = checked
        # the mesh motion's own check stopped the run at a step's mesh update, before the
        # mesh moved: that step never ran, every written time holds a valid mesh
        watch.drop_unfinished_step()
    if reconstruct:
        run_utility(case, ["reconstructPar", "-newTimes"])
    (case / "case.foam").touch()
    summary = summarise(case, watch, record, ranks, walls[0], time.perf_counter() - walls[1])
    if outcome.kind is Stop.CRITERION and outcome.reason:
        summary["stopped_because"] = outcome.reason
    stopped = outcome.message(resume_time(case)) if outcome.is_error else None
    if stopped:
        summary["stopped"] = stopped
    Case(case).save_summary(summary)
    if outcome.kind is Stop.MOTION_CHECK:
        raise SolverRunError(f"{stopped}; see {case / SUMMARY}\nWhat to do: {MOTION_ADVICE}\n"
                             "OpenFOAM's message:\n    " + (fatal or "").replace("\n", "\n    ")
                             + f"\n(see {case / 'log.pimpleFoam'})")
    if stopped:
        raise SolverRunError(f"{stopped}; the run stopped at t = {summary['end_time_s']:.4g} s "
                             f"with a written mesh; see {case / SUMMARY}")
    return summary


def _raise_failed(case: Path, rc: int, stopped: str | None, watch: LogWatch,
                  fatal: str | None) -> NoReturn:
    """Raise the error of a failed solver run: the mesh watch's reason or the exit code, the
    first invalid-mesh line, OpenFOAM's own message (unless the watch had stopped it)."""
    what = stopped or f"pimpleFoam failed (exit code {rc})"
    hint = f" ({watch.broken})" if watch.broken and not stopped else ""
    if fatal and not stopped:
        raise SolverRunError(f"{what}{hint}, with OpenFOAM's message:\n    "
                             + fatal.replace("\n", "\n    ")
                             + f"\n(see {case / 'log.pimpleFoam'}; run the same command again"
                             " to continue from the latest written time)")
    raise SolverRunError(f"{what}{hint}; see {case / 'log.pimpleFoam'}")


def _finished(case: Path, record: dict, ranks: int, reconstruct: bool, t_start: float) -> dict:
    """A case already at its end time: nothing to run; its summary (reconstructed first when
    asked and the last times are only in processor folders)."""
    if reconstruct:
        run_utility(case, ["reconstructPar", "-newTimes"])
    (case / "case.foam").touch()
    if Case(case).has_summary:
        return Case(case).summary
    watch = LogWatch(case / "log.pimpleFoam")
    watch.poll()
    summary = summarise(case, watch, record, ranks, 0.0, time.perf_counter() - t_start)
    Case(case).save_summary(summary)
    return summary


def _run_watched(case, cmd, watch, record, start_time, end_time, progress, stop_when=None,
                 env=None, eta=None):
    """Run the solver, follow its log; stop it (write now) when the mesh gets too distorted,
    or when ``stop_when(case)`` gives a reason. Returns (exit code, :class:`RunOutcome`)."""
    limit = float(record.get("max_non_orthogonality", 80.0))
    show = Progress(end_time, start_time, eta=eta) if progress else None
    stopped = None
    asked_at = 0      # steps seen when stop_when was last asked
    with open(case / "log.pimpleFoam", "w") as log:
        try:
            proc = subprocess.Popen(cmd, cwd=case, stdout=log, stderr=subprocess.STDOUT,
                                    env=env or foam_env(), start_new_session=True)
        except FileNotFoundError:
            raise SolverRunError(f"{cmd[0]} is not on PATH (install it, or give the launcher "
                                 "with its full path)") from None
        try:
            while True:
                rc = proc.poll()
                watch.poll()
                if stopped is None and (watch.max_non_orth > limit or watch.broken):
                    what = (f"mesh non-orthogonality reached {watch.max_non_orth:.1f} deg "
                            f"(limit case.max_non_orthogonality = {limit:g})")
                    if watch.broken:
                        what = f"the moved mesh is invalid ({watch.broken})"
                    stopped = RunOutcome(Stop.MESH_WATCH, what)
                    proc.send_signal(STOP_SIGNAL)
                # asked every STOP_WHEN_STEPS new steps (not on a wall clock: a fast run
                # would reach its end between two questions) and once more at the end
                steps = len(watch.times)
                if stopped is None and stop_when and (
                        steps - asked_at >= STOP_WHEN_STEPS or rc is not None and steps > asked_at):
                    asked_at = steps
                    reason = stop_when(case)
                    stopped = None if reason is None else RunOutcome(Stop.CRITERION, reason)
                    if reason and rc is None:
                        proc.send_signal(STOP_SIGNAL)
                if show:
                    show.show(watch)
                if rc is not None:
                    break
                time.sleep(0.1)
        except BaseException:
            os.killpg(proc.pid, signal.SIGTERM)
            proc.wait()
            raise
    watch.poll()
    if show:
        show.show(watch, final=True)
    return rc, stopped or ENDED
