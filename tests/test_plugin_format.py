"""The plugin's C++ sources: in folders by concern, one library, one style.

Every .C of adapter/foam/plugin is in Make/files (one library, libstepServerDisplacement), and
Make/files lists nothing else; every .C and .H is as the pinned clang-format (the dev extras)
writes it under adapter/foam/plugin/.clang-format (docs/openfoam-plugin.md, "Layout")."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from adapter.resources import PLUGIN_SRC

#: the folders, one per concern (docs/openfoam-plugin.md)
CONCERNS = {"client", "boundaryCondition", "motionSolver", "loads", "frame", "common"}


def _sources() -> list[Path]:
    return sorted(PLUGIN_SRC.rglob("*.[CH]"))


def _clang_format() -> str:
    beside = Path(sys.executable).parent / "clang-format"
    found = str(beside) if beside.exists() else shutil.which("clang-format")
    if found is None:
        pytest.fail("clang-format not found: pip install -e '.[dev]' installs the pinned one")
    return found


def test_the_sources_are_in_the_folders_of_the_concerns():
    folders = {p.parent.relative_to(PLUGIN_SRC).as_posix() for p in _sources()}
    assert folders == CONCERNS


def test_make_files_lists_every_unit_of_the_one_library():
    text = (PLUGIN_SRC / "Make" / "files").read_text()
    listed = [w for w in text.split() if w.endswith(".C")]
    units = [p.relative_to(PLUGIN_SRC).as_posix() for p in _sources() if p.suffix == ".C"]
    assert sorted(listed) == sorted(units) and len(set(listed)) == len(listed)
    assert re.findall(r"^LIB *= *(\S+)$", text, re.M) == [
        "$(FOAM_USER_LIBBIN)/libstepServerDisplacement"]


def test_the_sources_are_formatted():
    done = subprocess.run([_clang_format(), "--dry-run", "--Werror",
                           *(str(p) for p in _sources())],
                          cwd=PLUGIN_SRC, capture_output=True, text=True, timeout=120)
    unformatted = sorted({Path(m).relative_to(PLUGIN_SRC).as_posix() for m in
                          re.findall(r"^(\S+?):\d+:\d+: error:", done.stderr, re.M)})
    assert done.returncode == 0 and unformatted == [], (
        f"not formatted: {unformatted}; run .venv/bin/clang-format -i on them")
