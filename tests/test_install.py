"""`pip install .` gives a working tool: the wheel, installed non-editable into a fresh virtual
environment outside the repository, runs --version, --help, a smoke dry-run and a smoke
run-case from a folder outside the repository (template case and build script from the
wheel). Marked ``install`` (``pytest -m install``); about 1-2 minutes.

To save downloads the fresh venv sees this environment's site-packages through a ``.pth`` line
(like ``--system-site-packages``): the dependencies come from there, ``adapter`` from the
wheel (the editable install's hook is not loaded that way, and PYTHONPATH is cleared).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

from adapter.foam import case as C
from adapter.foam import summary as S

REPO = Path(__file__).resolve().parents[1]

pytestmark = [pytest.mark.install, pytest.mark.slow]


def _run(cmd, cwd, env, timeout=600) -> subprocess.CompletedProcess:
    r = subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)
    assert r.returncode == 0, \
        f"{cmd} failed ({r.returncode}):\n{r.stdout[-3000:]}\n{r.stderr[-3000:]}"
    return r


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    """(the venv's bin folder, a clean environment, a work folder outside the repository)"""
    base = tmp_path_factory.mktemp("install")
    assert REPO not in base.parents
    # build from a copy of the sources (pip would write build/ and *.egg-info into the tree)
    src = base / "src"
    shutil.copytree(REPO, src, symlinks=True, ignore=shutil.ignore_patterns(
        ".venv", ".git", "build", "runs", "out", "__pycache__", ".pytest_cache", "*.egg-info"))
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    _run([sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(base / "dist"),
          str(src)], cwd=base, env=env)
    wheel = next((base / "dist").glob("whale_adapter-*.whl"))
    venv = base / "venv"
    _run([getattr(sys, "_base_executable", sys.executable), "-m", "venv", str(venv)], cwd=base,
         env=env)
    py = venv / "bin" / "python"
    site = Path(_run([str(py), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                     cwd=base, env=env).stdout.strip())
    (site / "zz_shared_deps.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    _run([str(py), "-m", "pip", "install", "--no-deps", "-q", str(wheel)], cwd=base, env=env)
    env["PATH"] = f"{venv / 'bin'}{os.pathsep}{env.get('PATH', '')}"
    work = base / "work"
    work.mkdir()
    return venv / "bin", env, work


def test_installed_package_is_the_wheel_with_its_data(installed):
    bin_dir, env, work = installed
    out = _run([str(bin_dir / "python"), "-c",
                "import adapter, adapter.foam.case as C, adapter.resources as R; "
                "print(adapter.__file__); print(C.TEMPLATE_DIR); print(R.BUILD_SCRIPT); "
                "print(R.IN_REPOSITORY)"], cwd=work, env=env).stdout.split("\n")
    venv = bin_dir.parent
    assert Path(out[0]).is_relative_to(venv), out
    assert Path(out[1]).is_relative_to(venv) and (Path(out[1]) / "system/controlDict").is_file()
    assert Path(out[2]).is_relative_to(venv) and Path(out[2]).is_file()
    assert out[3] == "False"


def test_version_and_help(installed):
    bin_dir, env, work = installed
    exe = str(bin_dir / "whale-adapter")
    assert _run([exe, "--version"], cwd=work, env=env).stdout.startswith("whale-adapter 0.")
    text = _run([exe, "--help"], cwd=work, env=env).stdout
    for command in ("dry-run", "run-case", "serve", "paraview"):
        assert command in text


def test_smoke_dry_run(installed):
    bin_dir, env, work = installed
    _run([str(bin_dir / "whale-adapter"), "dry-run", "--preset", "smoke", "--cycles", "1",
          "--out", "dry", "--no-progress"], cwd=work, env=env)
    for name in ("whale.pvd", "keypoints.csv", "summary.json"):
        assert (work / "dry" / name).is_file(), name


@pytest.mark.openfoam
@pytest.mark.plugin
def test_smoke_run_case(installed):
    bin_dir, env, work = installed
    env = dict(env, WHALE_PLUGIN_LIB=str(C.PLUGIN_LIB))
    r = _run([str(bin_dir / "whale-adapter"), "run-case", "--preset", "smoke", "--case", "case"],
             cwd=work, env=env)
    assert "largest non-orthogonality" in r.stdout
    assert (work / "case" / S.SUMMARY).is_file()
    assert (work / "case" / "adapter" / "keypoints.csv").is_file()       # the server ran
