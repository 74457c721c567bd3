"""Running OpenFOAM on several ranks: the launcher that starts them, and reconstruction.

The launcher (``case.launcher``, ``run-case --launcher``; docs/cluster.md) is the command that
goes before ``<utility> ... -parallel``: ``{np}`` in it is replaced by the rank count, and a
launcher without ``{np}`` gets ``-np N`` appended. The default is this machine's Open MPI,
``mpirun --allow-run-as-root --oversubscribe -np {np}``. Open MPI's launchers (mpirun, mpiexec,
orterun) get ``-x WHALE_ADAPTER_TOKEN`` when there is a token, so that it reaches ranks on other
hosts through the environment; other launchers (srun) pass the environment on themselves.
"""

from __future__ import annotations

import shlex
from pathlib import Path

from adapter.coupling.server import TOKEN_ENV
from adapter.errors import CaseError
from adapter.foam.folders import processor_latest, serial_latest
from adapter.foam.tools import run_utility

#: the launcher on this machine (one host, Open MPI, possibly more ranks than cores)
DEFAULT_LAUNCHER = "mpirun --allow-run-as-root --oversubscribe -np {np}"
#: launchers that forward an environment variable with ``-x NAME``
OPEN_MPI = ("mpirun", "mpiexec", "orterun")


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
