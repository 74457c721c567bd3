"""Running OpenFOAM on several ranks: the launcher that starts them, and reconstruction.

The launcher (``case.launcher``, ``run-case --launcher``; docs/cluster.md) is the command that
goes before ``<utility> ... -parallel``: ``{np}`` in it is replaced by the rank count, and a
launcher without ``{np}`` gets ``-np N`` appended. The default is this machine's Open MPI,
``mpirun --allow-run-as-root --oversubscribe -np {np}``. Open MPI's launchers (mpirun, mpiexec,
orterun) get ``-x WHALE_ADAPTER_TOKEN`` when there is a token, so that it reaches ranks on other
hosts through the environment; other launchers (srun) pass the environment on themselves.
"""

from __future__ import annotations

import math
import os
import shlex
from pathlib import Path

from adapter.coupling.protocol import TOKEN_ENV
from adapter.errors import CaseError
from adapter.foam.folders import processor_dirs, processor_latest, serial_latest
from adapter.foam.tools import run_utility
from adapter.foamfiles import time_dirs
from adapter.options import count

#: the launcher on this machine (one host, Open MPI, possibly more ranks than cores)
DEFAULT_LAUNCHER = "mpirun --allow-run-as-root --oversubscribe -np {np}"
#: launchers that forward an environment variable with ``-x NAME``
OPEN_MPI = ("mpirun", "mpiexec", "orterun")
#: the cgroup's CPU limit: v2's cpu.max ("QUOTA PERIOD" or "max PERIOD"), v1's quota and period
CGROUP_V2 = Path("/sys/fs/cgroup/cpu.max")
CGROUP_V1 = (Path("/sys/fs/cgroup/cpu/cpu.cfs_quota_us"),
             Path("/sys/fs/cgroup/cpu/cpu.cfs_period_us"))


def machine_cores(cgroup_v2: Path = CGROUP_V2, cgroup_v1: tuple = CGROUP_V1) -> int:
    """The cores this process may use: the CPUs it may run on (``os.sched_getaffinity``, else
    ``os.cpu_count()``), fewer when its cgroup's CPU quota is smaller (quota / period rounded
    up: 1.5 CPUs are 2 ranks); at least 1. What ``case.ranks = 0`` and ``--np auto`` run on."""
    try:
        cores = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        cores = os.cpu_count() or 1
    quota = _cgroup_quota(cgroup_v2, cgroup_v1)
    if quota is not None:
        cores = min(cores, math.ceil(quota))
    return max(1, cores)


def _cgroup_quota(v2: Path, v1: tuple) -> float | None:
    """The cgroup's CPU quota in CPUs, or None without a limit (or a readable file)."""
    try:
        words = v2.read_text().split()
        if len(words) == 2 and words[0] != "max":
            return int(words[0]) / int(words[1])
        if words:
            return None
    except (OSError, ValueError):
        pass
    try:
        quota, period = (int(f.read_text()) for f in v1)
    except (OSError, ValueError):
        return None
    return quota / period if quota > 0 and period > 0 else None


def resolve_ranks(ranks: int) -> int:
    """``ranks`` as asked, or :func:`machine_cores` for 0 (``case.ranks = 0``, ``--np auto``)."""
    return int(ranks) if ranks else machine_cores()


def launcher_words(launcher: str | None, ranks: int, token: bool = False) -> list:
    """The launcher's words for ``ranks`` ranks (see the module's description).

    ``launcher``: a command line ("" or None: :data:`DEFAULT_LAUNCHER`); ``token``: forward
    ``$WHALE_ADAPTER_TOKEN`` (Open MPI's ``-x``). Raises :class:`~adapter.errors.CaseError`
    when it cannot be split into words."""
    text = launcher or DEFAULT_LAUNCHER
    try:
        words = shlex.split(text)
    except ValueError as exc:
        raise CaseError(f"launcher {text!r}: {exc}; quote it as a shell would") from None
    if not words:
        raise CaseError("the launcher is empty; give a command such as 'srun -n {np}' or "
                        "leave case.launcher unset for mpirun")
    if any("{np}" in w for w in words):
        words = [w.replace("{np}", str(ranks)) for w in words]
    else:
        words += ["-np", str(ranks)]
    if token and Path(words[0]).name in OPEN_MPI:
        words += ["-x", TOKEN_ENV]
    return words


def parallel_command(args: list, ranks: int, launcher: str | None = None,
                     token: bool = False) -> list:
    """``<launcher words> <args> -parallel``: an OpenFOAM application on ``ranks`` ranks."""
    return [*launcher_words(launcher, ranks, token), *args, "-parallel"]


def has_unreconstructed_times(case: Path) -> bool:
    """Whether every processor folder holds a time later than the case folder's latest."""
    latest = processor_latest(case)
    return latest is not None and latest > serial_latest(case)


def reconstruct_new_times(case: Path) -> bool:
    """reconstructPar -newTimes when the processor folders hold times the case folder lacks
    (the readers of fields and meshes, :mod:`adapter.foam.yplus`, need them there); whether
    it ran."""
    if not has_unreconstructed_times(case):
        return False
    run_utility(case, ["reconstructPar", "-newTimes"])
    return True


def reconstruct_latest_time(case: Path) -> bool:
    """reconstructPar of the latest time every processor folder holds, when the case folder
    lacks it: what a stage that starts from a run's last time needs (the earlier times stay
    in the processor folders, where ParaView and the y+ reader read them); whether it ran."""
    latest = processor_latest(case)
    if latest is None or latest <= serial_latest(case):
        return False
    name = next(d.name for t, d in time_dirs(processor_dirs(case)[0]) if t == latest)
    run_utility(case, ["reconstructPar", "-time", name])
    return True


def ranks_option(text: str) -> int:
    """``--np`` (run-case, study): a whole number of MPI ranks, at least 1, or ``auto``: the
    machine's cores (:func:`machine_cores`)."""
    return machine_cores() if text.strip().lower() == "auto" else count(text)
