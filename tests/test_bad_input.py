"""Every sub-command of ``whale-adapter`` given bad input, in a subprocess as a user runs it:
a file where a folder is expected and a folder where a file is, missing files, negative and
non-numeric values, unknown presets, scenes with a value out of range and mesh files that are
missing, open or without landmarks. Each must exit with code 2 and one line on stderr that names
what was wrong (no traceback, no warning), before any work starts.

The sub-commands are read from :func:`adapter.cli.build_parser`, so a new one without bad
inputs here fails :func:`test_every_sub_command_is_given_bad_input`. The runs go four at a time
(one module-scoped fixture); each takes about a second, most of it importing the package.
Every case also runs in-process through the same :func:`~adapter.cli.main`.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor

import pytest

from adapter.cli import build_parser, main

#: (sub-command's arguments, a fragment its one stderr line must hold)
BAD = {
    "geometry": [
        (["--out", "x.xyz"], "unknown surface format"),
        (["--out", "afile/x.stl"], "afile is a file, not a folder"),
        (["--out", "folder"], "folder is a folder; give a file name"),
        (["--preset", "nope", "--out", "x.stl"], "preset: expected one of"),
        (["--scene", "missing.toml", "--out", "x.stl"], "missing.toml does not exist"),
        (["--scene", "folder", "--out", "x.stl"], "folder is a folder"),
        (["--scene", "range.toml", "--out", "x.stl"], "springs.mu: value -1.0 is out of range "
                                                       "[0, inf)"),
        (["--scene", "nomesh.toml", "--out", "x.stl"],
         "nomesh.toml: geometry.source = 'nothere.stl': mesh file"),
        (["--scene", "open.toml", "--out", "x.stl"],
         "open.toml: geometry.source = 'open.stl': the surface is open"),
        (["--scene", "nolandmarks.toml", "--out", "x.stl"],
         "nolandmarks.toml: geometry.source = 'closed.stl': geometry.landmarks is missing"),
        ([], "required: --out"),
    ],
    "dry-run": [
        (["--out", "afile"], "afile is a file"),
        (["--out", "afile/sub"], "afile is a file, not a folder"),
        (["--out", "d", "--cycles", "-1"], "--cycles: expected a whole number at least 1"),
        (["--out", "d", "--cycles", "abc"], "--cycles: expected a whole number, got 'abc'"),
        (["--out", "d", "--preset", "nope"], "preset: expected one of"),
        (["--out", "d", "--scene", "missing.toml"], "missing.toml does not exist"),
        (["--out", "d", "--bogus"], "unrecognized arguments: --bogus"),
    ],
    "calibrate": [
        (["--report", "afile/x.json"], "afile is a file, not a folder"),
        (["--report", "folder"], "folder is a folder"),
        (["--preset", "nope"], "preset: expected one of"),
        (["--scene", "range.toml"], "out of range [0, inf)"),
    ],
    "serve": [
        (["--case", "afile"], "afile is a file"),
        (["--case", "missing"], "missing does not exist"),
        (["--case", "folder", "--wait", "-1"], "--wait: expected a number above 0"),
        (["--case", "folder", "--tcp", "-5"], "--tcp/--port: expected a whole number within "
                                              "[0, 65535]"),
        (["--case", "folder", "--port", "http"], "--tcp/--port: expected a whole number, got "
                                                 "'http'"),
        (["--case", "folder", "--map-tolerance", "-0.1"], "--map-tolerance: expected a number "
                                                          "above 0"),
        (["--case", "folder", "--token-file", "missing"], "--token-file: missing does not exist"),
        (["--case", "folder", "--preset", "nope"], "--preset: invalid choice"),
        ([], "required: --case"),
    ],
    "run-case": [
        (["--case", "afile"], "afile is a file"),
        (["--case", "afile/sub"], "afile is a file, not a folder"),
        (["--case", "c", "--np", "-1"], "--np: expected a whole number at least 1"),
        (["--case", "c", "--np", "two"], "--np: expected a whole number, got 'two'"),
        (["--case", "c", "--port", "-1"], "--port: expected a whole number within [0, 65535]"),
        (["--case", "c", "--token-file", "missing"], "--token-file: missing does not exist"),
        (["--case", "c", "--decomposition", "missing"], "--decomposition missing: give"),
        (["--case", "c", "--preset", "nope"], "preset: expected one of"),
        (["--case", "c", "--scene", "folder"], "folder is a folder"),
        (["--case", "c", "--scene", "range.toml"], "out of range [0, inf)"),
    ],
    "study": [
        (["--out", "afile"], "afile is a file"),
        (["--out", "s", "--ratio", "-1"], "--ratio: expected a number at least 1.3"),
        (["--out", "s", "--ratio", "x"], "--ratio: expected a number, got 'x'"),
        (["--out", "s", "--speeds", "a,b,c"], "--speeds: expected a number, got 'a'"),
        (["--out", "s", "--speeds=-1,1,2"], "--speeds: expected a number above 0, got '-1'"),
        (["--out", "s", "--parts", "nope"], "--parts: unknown nope"),
        (["--out", "s", "--np", "0"], "--np: expected a whole number at least 1"),
        (["--out", "s", "--preset", "nope"], "preset: expected one of"),
    ],
    "numerics": [
        (["--out", "afile"], "afile is a file"),
        (["--out", "n", "--preset", "nope"], "preset: expected one of"),
        ([], "required: --out"),
    ],
    "choose": [
        (["--tolerance", "-1"], "--tolerance: expected a number above 0"),
        (["--tolerance", "abc"], "--tolerance: expected a number, got 'abc'"),
        (["--tolerance", "nan"], "--tolerance: expected a number above 0, got 'nan'"),
        (["--cell-size", "-1"], "--cell-size: expected a number above 0"),
        (["--cell-size", "1", "--flow-dt", "0"], "--flow-dt: expected a number above 0"),
        (["--tolerance", "1", "--fps", "-1"], "--fps: expected a number above 0"),
        (["--tolerance", "1", "--nodes", "-5"], "--nodes: expected a whole number within "
                                                "[400, 2000000]"),
        (["--tolerance", "1", "--dt", "-1"], "--dt: expected a number above 0"),
        (["--tolerance", "1", "--method", "euler"], "--method: invalid choice"),
        (["--flow-study", "missing", "--tolerance", "0.05"], "missing does not exist"),
        (["--flow-study", "afile", "--tolerance", "0.05"], "afile is a file"),
        (["--flow-study", "folder"], "give --tolerance"),
        (["--preset", "nope", "--tolerance", "1"], "preset: expected one of"),
        ([], "give --cell-size (coupled) or --tolerance"),
    ],
    "paraview": [
        (["missing"], "missing does not exist"),
        (["afile"], "afile is a file"),
        (["folder", "--size", "-1", "-1"], "--size: expected a whole number at least 64"),
        (["folder", "--times", "-1"], "--times: expected a number at least 0"),
        (["folder", "--out", "afile"], "afile is a file"),
        (["folder"], "has neither case.foam nor whale.pvd"),
    ],
    "validate": [
        (["--out", "afile"], "afile is a file"),
        (["--out", "v", "--cases", "nope"], "unknown validation case nope"),
        (["--out", "v", "--np", "-1"], "--np: expected a whole number at least 1"),
        (["--out", "v", "--np", "x"], "--np: expected a whole number, got 'x'"),
    ],
}

CASES = [(cmd, args, fragment) for cmd, rows in BAD.items() for args, fragment in rows]

#: besides the first two of every sub-command, these run in a subprocess too: the ones of the
#: issue (#27) and the mesh files (a warning shows only there); the rest run in-process, the
#: same main(), 50 times faster (importing the package takes a second)
ALSO_IN_A_SUBPROCESS = [
    ("geometry", ["--scene", "open.toml", "--out", "x.stl"]),
    ("geometry", ["--scene", "nolandmarks.toml", "--out", "x.stl"]),
    ("geometry", ["--scene", "range.toml", "--out", "x.stl"]),
    ("run-case", ["--case", "c", "--decomposition", "missing"]),
    ("run-case", ["--case", "c", "--scene", "range.toml"]),
    ("choose", ["--tolerance", "-1"]),
]
SUBPROCESS = [(cmd, args, f) for cmd, rows in BAD.items()
              for k, (args, f) in enumerate(rows) if k < 2 or (cmd, args) in ALSO_IN_A_SUBPROCESS]


def _sub_commands() -> list[str]:
    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    return list(sub.choices)


def _files(root):
    """The bad inputs' files: a file, a folder, scenes with a bad value or a bad mesh file."""
    import meshio
    import numpy as np

    (root / "afile").write_text("not a folder\n")
    (root / "folder").mkdir()
    (root / "range.toml").write_text("[springs]\nmu = -1\n")
    p = np.array([[0, 0, 0], [10, 0, 0], [0, 1, 0], [0, 0, 1.0]])
    tri = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    # ASCII STL, as most tools write it (meshio's reader warned about its header)
    meshio.Mesh(p, [("triangle", tri[:3])]).write(str(root / "open.stl"), binary=False)
    meshio.Mesh(p, [("triangle", tri)]).write(str(root / "closed.stl"), binary=False)
    for name, mesh in (("nomesh", "nothere.stl"), ("open", "open.stl"),
                       ("nolandmarks", "closed.stl")):
        (root / f"{name}.toml").write_text(f'[geometry]\nsource = "{mesh}"\n')


def _run(cwd, cmd, args):
    env = {**os.environ, "PYTHONWARNINGS": "default"}    # a warning would show
    return subprocess.run([sys.executable, "-m", "adapter.cli", cmd, *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=120)


def _check(cmd, code, stderr, fragment):
    lines = stderr.splitlines()
    assert "Traceback" not in stderr, stderr
    assert code == 2 and len(lines) == 1, (code, stderr)
    assert lines[0].startswith(f"whale-adapter {cmd}: error: "), lines[0]
    assert fragment in lines[0], lines[0]


@pytest.fixture(scope="module")
def root(tmp_path_factory):
    path = tmp_path_factory.mktemp("bad-input")
    _files(path)
    return path


@pytest.fixture(scope="module")
def runs(root):
    with ThreadPoolExecutor(max_workers=4) as pool:
        done = list(pool.map(lambda c: _run(root, c[0], c[1]), SUBPROCESS))
    return {(cmd, tuple(args)): r for (cmd, args, _), r in zip(SUBPROCESS, done, strict=True)}


def test_every_sub_command_is_given_bad_input():
    assert set(_sub_commands()) == set(BAD), "a sub-command without bad inputs (or a stale one)"
    assert {cmd for cmd, _, _ in SUBPROCESS} == set(BAD)


def _ids(cases):
    return [f"{c}-{' '.join(a) or 'none'}" for c, a, _ in cases]


@pytest.mark.slow
@pytest.mark.parametrize("cmd, args, fragment", SUBPROCESS, ids=_ids(SUBPROCESS))
def test_bad_input_in_a_subprocess(runs, cmd, args, fragment):
    r = runs[(cmd, tuple(args))]
    _check(cmd, r.returncode, r.stderr, fragment)


@pytest.mark.parametrize("cmd, args, fragment", CASES, ids=_ids(CASES))
def test_bad_input_in_process(root, monkeypatch, capsys, cmd, args, fragment):
    monkeypatch.chdir(root)
    monkeypatch.setattr(signal, "signal", lambda *a: None)   # run-case's SIGTERM handler
    try:
        code = main([cmd, *args])
    except SystemExit as exc:       # argparse's own errors
        code = exc.code
    _check(cmd, code, capsys.readouterr().err, fragment)


@pytest.mark.slow
def test_no_bad_input_left_anything_behind(runs, root):
    """Refused before any work: no output folder or case was made."""
    made = {p.name for p in root.iterdir()} - {"afile", "folder", "range.toml", "open.stl",
                                               "closed.stl", "nomesh.toml", "open.toml",
                                               "nolandmarks.toml"}
    assert not made, f"bad inputs left {sorted(made)}"
