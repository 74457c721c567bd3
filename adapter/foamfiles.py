"""OpenFOAM's folders as the file system shows them: what a time folder is (a folder whose name
is a number) is said here once. A leaf module: the case's own modules
(:mod:`adapter.foam.folders` and the readers of fields and function-object output) and the
reports (which may not import :mod:`adapter.foam`) scan with :func:`time_dirs`."""

from __future__ import annotations

from pathlib import Path


def time_dirs(case: Path) -> list:
    """``[(time, folder), ...]`` of the folders in ``case`` named by a number, earliest first
    (a case's time folders, or a function object's start-time folders); empty when ``case``
    is not a folder."""
    case = Path(case)
    out = []
    for p in case.iterdir() if case.is_dir() else ():
        if p.is_dir():
            try:
                out.append((float(p.name), p))
            except ValueError:
                pass
    return sorted(out)
