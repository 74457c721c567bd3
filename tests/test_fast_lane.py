"""The fast lane (``make test-fast``): its selection, the Makefile's ``FAST``, holds no test
marked as needing OpenFOAM, the plugin, ParaView or chromium; and the marks are the one check
for those programs (tests/conftest.py), written nowhere else."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

from .conftest import FOAM_TOOLS, NEEDS

REPO = Path(__file__).resolve().parents[1]

#: collects with ``-m EXPR`` (argv[1]) and prints every selected test's marks
_COLLECT = """
import json, sys
import pytest

class Marks:
    found = {}

    def pytest_collection_finish(self, session):
        self.found = {i.nodeid: sorted({m.name for m in i.iter_markers()}) for i in session.items}

marks = Marks()
code = pytest.main(["--collect-only", "-q", "-p", "no:cacheprovider", "-m", sys.argv[1]],
                   plugins=[marks])
print("MARKS " + json.dumps(marks.found))
sys.exit(code)
"""


def fast_expression() -> str:
    m = re.search(r"^FAST := (.+)$", (REPO / "Makefile").read_text(), re.M)
    assert m, "the Makefile has no FAST := line"
    return m[1].strip()


def test_the_fast_lane_deselects_every_mark_that_needs_a_program():
    expr = fast_expression()
    for mark in (*NEEDS, "slow", "install"):
        assert f"not {mark}" in expr.split(" and "), mark


@pytest.mark.slow
def test_the_fast_lane_selects_no_test_that_needs_a_program():
    r = subprocess.run([sys.executable, "-c", _COLLECT, fast_expression()], cwd=REPO,
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    line = next(x for x in r.stdout.splitlines() if x.startswith("MARKS "))
    found = json.loads(line[len("MARKS "):])
    assert len(found) > 100, "the fast lane selects (almost) nothing"
    bad = {t: m for t, m in found.items() if set(m) & {*NEEDS, "slow", "install"}}
    assert bad == {}


def test_no_test_checks_for_a_program_but_the_marks():
    """``shutil.which("pimpleFoam")`` and the like are in tests/conftest.py alone: a test says
    what it needs with a mark (``openfoam``, ``plugin``, ``paraview``, ``browser``)."""
    programs = "|".join(re.escape(p) for p in (*FOAM_TOOLS, "pvbatch", "chromium"))
    check = re.compile(rf"""which\(\s*["']({programs})["']\)\s*is\b|PLUGIN_LIB\.is_file\(\)""")
    found = [f"{p.relative_to(REPO)}:{n}" for p in sorted((REPO / "tests").rglob("*.py"))
             if p.name != "conftest.py"
             for n, line in enumerate(p.read_text().splitlines(), 1) if check.search(line)]
    assert found == []
