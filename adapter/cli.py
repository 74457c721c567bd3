"""The ``whale-adapter`` command line.

Each sub-command lives in the module of its idea and registers itself here through a
``register(subparsers)`` function: dry-run and calibrate (:mod:`adapter.motion.dryrun`,
:mod:`adapter.studies.calibration`), geometry (:mod:`adapter.body.geometry`), serve
(:mod:`adapter.coupling.server`), run-case (:mod:`adapter.foam.command`),
study (:mod:`adapter.studies.study`), validate (:mod:`adapter.validation.suite`).
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import os
import signal
import sys
import threading

from adapter.errors import AdapterError, GeometryError

#: modules that register sub-commands; a module that is not there yet is skipped
_COMMAND_MODULES = (
    "adapter.body.geometry",
    "adapter.motion.dryrun",
    "adapter.studies.calibration",
    "adapter.coupling.server",
    "adapter.foam.command",
    "adapter.studies.study",
    "adapter.studies.numerics",
    "adapter.studies.chooser",
    "adapter.reports.paraview_report",
    "adapter.validation.suite",
)


def version() -> str:
    """The installed distribution's version (pyproject.toml), or "unknown" (not installed)."""
    from importlib.metadata import PackageNotFoundError
    from importlib.metadata import version as dist_version

    try:
        return dist_version("whale-adapter")
    except PackageNotFoundError:
        return "unknown (not installed: pip install .)"


class _Parser(argparse.ArgumentParser):
    """An argument parser whose errors are one line (no usage block): what was wrong and
    where to read more; exit code 2. Sub-command parsers are of the same class."""

    def error(self, message, prog=None):
        prog = prog or self.prog
        self.exit(2, f"{prog}: error: {message} (see {prog} --help)\n")

    def parse_args(self, args=None, namespace=None):
        """As argparse's, an unknown option blamed on its sub-command, not on the whole."""
        ns, extras = self.parse_known_args(args, namespace)
        if extras:
            command = getattr(ns, "command", None)
            self.error(f"unrecognized arguments: {' '.join(extras)}",
                       f"{self.prog} {command}" if command else None)
        return ns


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="whale-adapter",
        description="Spring-mass right whale animation coupled to OpenFOAM (see README.md).",
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {version()}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name in _COMMAND_MODULES:
        try:
            module = importlib.import_module(name)
        except ModuleNotFoundError as exc:
            if exc.name != name:
                raise
            continue
        module.register(sub)
    return parser


@contextlib.contextmanager
def _quiet(quiet: bool):
    """``--quiet``: nothing on stdout (warnings and errors go to stderr, and stay)."""
    if not quiet:
        yield
        return
    with open(os.devnull, "w") as sink, contextlib.redirect_stdout(sink):
        yield


def _terminate(signum, frame):
    """SIGTERM (a batch system's, a kill): unwind like Ctrl-C, so that the solver and the
    step-server that run-case started (in their own sessions) are stopped too."""
    raise KeyboardInterrupt


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    main_thread = threading.current_thread() is threading.main_thread()
    if args.command in ("run-case", "study") and main_thread:
        signal.signal(signal.SIGTERM, _terminate)
    try:
        with _quiet(getattr(args, "quiet", False)):
            return int(args.func(args) or 0)
    except GeometryError as exc:    # the scene's surface: say which scene file
        where = f"{args.scene}: " if getattr(args, "scene", None) else ""
        print(f"whale-adapter {args.command}: error: {where}{exc}", file=sys.stderr)
        return 2
    except AdapterError as exc:
        print(f"whale-adapter {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"whale-adapter {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
