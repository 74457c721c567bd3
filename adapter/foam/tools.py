"""Running OpenFOAM's tools: the environment Debian's binaries want, the check that OpenFOAM is
there, and one utility run in a case with its output in ``log.<utility>``."""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

from adapter.errors import SolverRunError

#: Debian's OpenFOAM wants this one variable (shared/notes/openfoam-on-debian.md)
FOAM_DIR = "/usr/share/openfoam"


def foam_env() -> dict:
    """The environment for Debian's OpenFOAM binaries (WM_PROJECT_DIR set when unset)."""
    env = dict(os.environ)
    env.setdefault("WM_PROJECT_DIR", FOAM_DIR)
    return env


def check_foam() -> None:
    """Raise :class:`~adapter.errors.SolverRunError` when OpenFOAM is not on PATH."""
    if shutil.which("pimpleFoam") is None:
        raise SolverRunError("OpenFOAM is not on PATH (no pimpleFoam); install it with "
                             "scripts/install_openfoam.sh")


def run_utility(case_dir, args: list, log_name: str | None = None) -> Path:
    """Run one OpenFOAM utility in the case, its output to ``log.<utility>``.

    Raises :class:`~adapter.errors.SolverRunError` naming the log when it fails.
    """
    case = Path(case_dir)
    log = case / f"log.{log_name or Path(args[0]).name}"
    with open(log, "w") as fh:
        try:
            rc = subprocess.call(args, cwd=case, stdout=fh, stderr=subprocess.STDOUT,
                                 env=foam_env())
        except FileNotFoundError:
            raise SolverRunError(f"{args[0]} is not on PATH (install it, or give the launcher "
                                 "with its full path)") from None
    text = log.read_text(errors="replace")
    if rc != 0 or "FOAM FATAL" in text:
        raise SolverRunError(f"{args[0]} failed (exit code {rc}); see {log}")
    return log
