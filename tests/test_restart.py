"""Restarts of the coupled smoke whale case repeat the uninterrupted run: from an odd and an
even written step, from the latest written time (later folders removed, as after a crash) and
from a user's ``startFrom startTime``, U, p, the face fluxes phi, the mesh's face fluxes
meshPhi and the mesh points at the end agree with the uninterrupted run's to 1e-9.

Without the plugin's gamgRestartOrder (the GAMG agglomeration's direction set back to forward
whenever the mesh moves) a restart from an odd step differed by 5e-6 m/s in U: OpenFOAM's pair
agglomeration keeps its direction in a static flag that alternates with every level built
since the process started (docs/case.md, "Exact restarts")."""

import re
import shutil
from pathlib import Path

import numpy as np
import pytest

from adapter.foam import case as C
from adapter.foam import folders as F
from adapter.foam import mesh as M
from adapter.foam import run as R
from adapter.foam.foamascii import read_foam_text, read_points
from adapter.scene import load_scene

from .conftest import NEEDS_FOAM_AND_PLUGIN

pytestmark = NEEDS_FOAM_AND_PLUGIN

FIELDS = ("U", "p", "phi", "meshPhi", "Uf")
TOLERANCE = 1e-9


def internal_field(path: Path) -> np.ndarray:
    """The numbers of a field file's ``internalField nonuniform List<...>``, flat."""
    text = read_foam_text(path)
    m = re.search(r"internalField\s+nonuniform\s+List<\w+>\s*\d+\s*\(", text)
    assert m, f"{path}: no nonuniform internalField"
    body = text[m.end():text.index("\n)\n", m.end())]
    return np.array(body.replace("(", " ").replace(")", " ").split(), float)


def _control(case: Path, **entries) -> None:
    path = case / "system" / "controlDict"
    text = path.read_text()
    for key, value in entries.items():
        text, n = re.subn(rf"^{key}\s+[^;]+;", f"{key} {value};", text, flags=re.M)
        assert n == 1, key
    path.write_text(text)


def _run_every_step_written(scene, case: Path) -> tuple:
    """``scene``'s case run without a break, written at every one of its 8 steps."""
    C.prepare_case(scene, case)
    _control(case, writeInterval=1)
    M.mesh_case(case)
    R.run_case(case, progress=False)
    times = [d.name for _, d in F.time_dirs(case)]
    assert len(times) == 9
    return case, times


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The smoke case, written at every one of its 8 steps, run without a break."""
    return _run_every_step_written(load_scene(preset="smoke"),
                                   tmp_path_factory.mktemp("restart") / "reference")


def _differences(case: Path, reference: Path, time: str) -> dict:
    out = {name: float(np.abs(internal_field(case / time / name)
                              - internal_field(reference / time / name)).max())
           for name in FIELDS}
    out["points"] = float(np.abs(read_points(case / time / "polyMesh" / "points")
                                 - read_points(reference / time / "polyMesh" / "points")).max())
    return out


def _copy_until(reference: Path, target: Path, times: list, step: int) -> Path:
    """The reference case as a crash after ``step`` would leave it: later times removed."""
    shutil.copytree(reference, target)
    for name in times[step + 1:]:
        shutil.rmtree(target / name)
    return target


@pytest.mark.parametrize("step", [3, 4])
def test_a_restart_from_the_latest_written_step_repeats_the_run(tmp_path, reference, step):
    ref, times = reference
    case = _copy_until(ref, tmp_path / "case", times, step)
    summary = R.run_case(case, progress=False)
    assert summary["steps"] == 8 - step
    for time in (times[step + 1], times[-1]):
        diff = _differences(case, ref, time)
        print(f"restart from step {step}, t = {time}: {diff}")
        assert max(diff.values()) < TOLERANCE, (time, diff)


@pytest.mark.parametrize("step", [3, 4])
def test_a_restart_from_a_users_start_time_repeats_the_run(tmp_path, reference, step):
    ref, times = reference
    case = tmp_path / "case"
    shutil.copytree(ref, case)
    _control(case, startFrom="startTime", startTime=times[step])
    summary = R.run_case(case, progress=False)
    assert summary["steps"] == 8 - step
    diff = _differences(case, ref, times[-1])
    print(f"startTime {times[step]} (step {step}): {diff}")
    assert max(diff.values()) < TOLERANCE, diff


@pytest.fixture(scope="module")
def reference_backward(tmp_path_factory):
    """The smoke case with the second-order ``backward`` time scheme, written every step."""
    return _run_every_step_written(
        load_scene(preset="smoke").replace(case={"time_scheme": "backward"}),
        tmp_path_factory.mktemp("restart-backward") / "reference")


def test_a_backward_restart_from_an_odd_step_repeats_the_run(tmp_path, reference_backward):
    """``backward`` needs two old levels: U_0, phi_0 and the mesh's V0 written at the time."""
    ref, times = reference_backward
    step = 3
    case = _copy_until(ref, tmp_path / "case", times, step)
    assert (case / times[step] / "U_0").is_file()
    summary = R.run_case(case, progress=False)
    assert summary["steps"] == 8 - step
    diff = _differences(case, ref, times[-1])
    print(f"backward, restart from step {step}: {diff}")
    assert max(diff.values()) < TOLERANCE, diff


@pytest.fixture(scope="module")
def reference_2_ranks(tmp_path_factory):
    """The same on 2 ranks, its times left in the processor folders."""
    case = tmp_path_factory.mktemp("restart2") / "reference"
    C.prepare_case(load_scene(preset="smoke"), case, ranks=2)
    _control(case, writeInterval=1)
    M.mesh_case(case)
    R.run_case(case, progress=False)
    times = [d.name for _, d in F.time_dirs(case / "processor0")]
    assert len(times) == 9 and F.processor_latest(case) == float(times[-1])
    return case, times


@pytest.mark.parametrize("step", [3, 4])
@pytest.mark.parametrize("how", ["latest", "startTime"])
def test_a_restart_on_2_ranks_repeats_the_run(tmp_path, reference_2_ranks, how, step):
    ref, times = reference_2_ranks
    case = tmp_path / "case"
    shutil.copytree(ref, case)
    if how == "latest":
        for rank in F.processor_dirs(case):
            for name in times[step + 1:]:
                shutil.rmtree(rank / name)
    else:
        _control(case, startFrom="startTime", startTime=times[step])
    summary = R.run_case(case, progress=False)
    assert summary["steps"] == 8 - step
    for rank in ("processor0", "processor1"):
        diff = _differences(case / rank, ref / rank, times[-1])
        print(f"2 ranks, {how} from step {step}, {rank}: {diff}")
        assert max(diff.values()) < TOLERANCE, (rank, diff)
