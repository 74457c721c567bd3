"""Strict JSON from every file and command: no ``NaN`` or ``Infinity``, which strict parsers
(JavaScript's JSON.parse, jq, serde) reject. The source is read with ``ast``: every
``json.dump``/``json.dumps`` in adapter/ and scripts/ says ``allow_nan=False`` (a NaN then
fails where it is written, not in a reader); the commands that wrote NaN (the smoke dry-run's
summary.json, ``choose``'s stable step of backward Euler) are run and parsed strictly."""

from __future__ import annotations

import ast
import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

from adapter.jsonfiles import dumps, finite, write_json

ROOT = Path(__file__).resolve().parent.parent


def loose_json_calls(source: str) -> list[int]:
    """Lines of ``json.dump(...)``/``json.dumps(...)`` calls without ``allow_nan=False``."""
    lines = []
    for node in ast.walk(ast.parse(source)):
        if not (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
                and node.func.attr in ("dump", "dumps")
                and isinstance(node.func.value, ast.Name) and node.func.value.id == "json"):
            continue
        strict = any(k.arg == "allow_nan" and isinstance(k.value, ast.Constant)
                     and k.value.value is False for k in node.keywords)
        if not strict:
            lines.append(node.lineno)
    return lines


def _strict(text: str):
    """``json.loads`` that refuses NaN, Infinity and -Infinity."""
    def refuse(name):
        raise ValueError(f"not strict JSON: {name}")
    return json.loads(text, parse_constant=refuse)


def test_every_json_dump_in_the_package_and_scripts_refuses_nan():
    files = sorted((ROOT / "adapter").rglob("*.py")) + sorted((ROOT / "scripts").rglob("*.py"))
    loose = {str(f.relative_to(ROOT)): n for f in files
             if (n := loose_json_calls(f.read_text()))}
    assert not loose, f"json.dump(s) without allow_nan=False: {loose}"


@pytest.mark.parametrize("code, found", [
    ("import json\njson.dumps({'a': 1})\n", [2]),
    ("import json\nx = json.dump(d, f,\n  indent=2)\n", [2]),
    ("import json\njson.dumps(d, allow_nan=True)\n", [2]),
    ("import json\njson.dumps(d, indent=2, allow_nan=False)\n", []),
    ("import json\njson.loads(s)\n", []),
])
def test_the_source_check_finds_a_loose_call(code, found):
    assert loose_json_calls(code) == found


def test_the_one_cleaner_writes_null_for_what_json_has_no_word_for(tmp_path):
    doc = {"a": math.nan, "b": [1.0, math.inf, {"c": -math.inf}], "d": (2, "x"), "e": None}
    assert finite(doc) == {"a": None, "b": [1.0, None, {"c": None}], "d": [2, "x"], "e": None}
    assert _strict(dumps(doc)) == finite(doc)
    write_json(tmp_path / "new" / "x.json", doc)           # its folder made
    assert _strict((tmp_path / "new" / "x.json").read_text()) == finite(doc)
    with pytest.raises(ValueError):
        _strict('{"a": NaN}')


def _run(*args, cwd):
    return subprocess.run([sys.executable, "-m", "adapter.cli", *args], cwd=cwd,
                          capture_output=True, text=True, timeout=300)


@pytest.mark.slow
def test_the_smoke_dry_run_writes_strict_json(tmp_path):
    res = _run("dry-run", "--preset", "smoke", "--out", "out", "--quiet", cwd=tmp_path)
    assert res.returncode == 0, res.stderr[-2000:]
    summary = _strict((tmp_path / "out" / "summary.json").read_text())
    # one cycle is too short to measure a period: absent, not NaN
    assert "measured_period_s" in summary and summary["measured_period_s"] is None


@pytest.mark.slow
def test_choose_prints_strict_json(tmp_path):
    """Backward Euler has no stable step limit (infinite): printed as null."""
    res = _run("choose", "--preset", "smoke", "--tolerance", "0.05", "--nodes", "600",
               "--method", "backward_euler", "--dt", "0.05", cwd=tmp_path)
    assert res.returncode == 0, res.stderr[-2000:]
    report = _strict(res.stdout[res.stdout.index("\n{") + 1:])
    assert report["options"][0]["stable_dt"] is None
