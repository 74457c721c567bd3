"""Command-line option types, for argparse's ``type=``: numbers in a range, files to read,
folders and files to write. A bad value fails while the command line is parsed, before any
work, with one line that names the option and says what was expected (exit code 2).
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path


def number(kind=float, low: float = -math.inf, high: float = math.inf, *,
           strict: bool = False):
    """A ``kind`` (float or int) in ``[low, high]`` (``strict``: above ``low``), finite."""
    what = "a whole number" if kind is int else "a number"

    def convert(text: str):
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}") from None
        if not math.isfinite(value) or not (low < value if strict else low <= value) \
                or value > high:
            bound = (f"{'above' if strict else 'at least'} {low:.10g}" if high == math.inf
                     else f"within [{low:.10g}, {high:.10g}]")
            raise argparse.ArgumentTypeError(f"expected {what} {bound}, got {text!r}")
        return value

    convert.__name__ = kind.__name__      # argparse's fallback message names the type
    return convert


positive = number(float, 0, strict=True)
non_negative = number(float, 0)
count = number(int, 1)
port = number(int, 0, 65535)


def _file_in_the_way(path: Path) -> Path | None:
    """The nearest of ``path``'s existing ancestors when it is not a folder."""
    for parent in path.absolute().parents:
        if parent.exists():
            return None if parent.is_dir() else parent
    return None


def out_folder(text: str) -> Path:
    """A folder to write into: absent (it is made) or a folder, with no file in its way."""
    path = Path(text).expanduser()
    if path.exists() and not path.is_dir():
        raise argparse.ArgumentTypeError(f"{text} is a file; give a folder")
    blocker = _file_in_the_way(path)
    if blocker is not None:
        raise argparse.ArgumentTypeError(f"{text}: {blocker} is a file, not a folder")
    return path


def out_file(text: str) -> Path:
    """A file to write: absent or a file, its folder a folder (made when absent)."""
    path = Path(text).expanduser()
    if path.is_dir():
        raise argparse.ArgumentTypeError(f"{text} is a folder; give a file name")
    blocker = _file_in_the_way(path)
    if blocker is not None:
        raise argparse.ArgumentTypeError(f"{text}: {blocker} is a file, not a folder")
    return path


def in_file(text: str) -> Path:
    """A file to read: it exists and is a file."""
    path = Path(text).expanduser()
    if path.is_dir():
        raise argparse.ArgumentTypeError(f"{text} is a folder; give a file")
    if not path.is_file():
        raise argparse.ArgumentTypeError(f"{text} does not exist")
    return path


def in_folder(text: str) -> Path:
    """A folder to read: it exists and is a folder."""
    path = Path(text).expanduser()
    if path.exists() and not path.is_dir():
        raise argparse.ArgumentTypeError(f"{text} is a file; give a folder")
    if not path.is_dir():
        raise argparse.ArgumentTypeError(f"{text} does not exist")
    return path
