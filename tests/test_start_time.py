"""A user's ``startFrom startTime; startTime t`` in a case's controlDict (adapter/foam/folders.py,
run_case): the written times after t are removed and recomputed, and said so; a t that is not
a written time is refused in one line. Folder handling on a hand-made case; then a real
pimpleFoam run of the smoke case with a static whale (no plugin needed)."""

import re
import shutil
from pathlib import Path

import numpy as np
import pytest

from adapter import resources
from adapter.errors import CaseError
from adapter.foam import case as C
from adapter.foam import folders as F
from adapter.foam import mesh as M
from adapter.foam import run as R
from adapter.foam.foamascii import read_foam_text
from adapter.scene import load_scene

TIMES = ["0", "0.19140625", "0.3828125", "0.57421875"]


def _control(case: Path, start_from: str, start_time: str = "0") -> None:
    path = case / "system" / "controlDict"
    text = path.read_text()
    text = re.sub(r"startFrom\s+\w+;", f"startFrom {start_from};", text)
    text = re.sub(r"startTime\s+[^;]+;", f"startTime {start_time};", text)
    path.write_text(text)


def _fake_case(tmp_path: Path, ranks: int = 0) -> Path:
    """A case folder with the template's controlDict, time folders ``TIMES`` (and, with
    ``ranks``, processor folders holding them too) and loads of a run from 0 with a restart
    at 0.3828125."""
    case = tmp_path / "case"
    (case / "system").mkdir(parents=True)
    shutil.copy(resources.TEMPLATE_DIR / "system" / "controlDict", case / "system")
    for folder in [case, *(case / f"processor{r}" for r in range(ranks))]:
        for name in TIMES:
            (folder / name).mkdir(parents=True)
            (folder / name / "U").write_text(name)
    loads = case / "postProcessing" / "loads"
    rows = "".join(f"{0.0478515625 * k:.12g}\t{k}\n" for k in range(1, 9))
    (loads / "0").mkdir(parents=True)
    (loads / "0" / "loads.dat").write_text("# Time\tFx\n" + rows)
    (loads / "0.3828125").mkdir()
    (loads / "0.3828125" / "loads.dat").write_text("# Time\tFx\n0.43066406250\t9\n")
    return case


def test_latest_time_asks_nothing_and_start_time_asks_its_time(tmp_path):
    case = _fake_case(tmp_path)
    assert F.asked_start(case) is None                      # the template: latestTime
    _control(case, "startTime", "0.19140625")
    assert F.asked_start(case) == (0.19140625, "startFrom startTime; startTime 0.19140625")
    _control(case, "firstTime")
    assert F.asked_start(case) == (0.0, "startFrom firstTime")
    _control(case, "someTime")
    with pytest.raises(CaseError, match="startFrom someTime is not one of firstTime, "
                                        "startTime, latestTime"):
        F.asked_start(case)


@pytest.mark.parametrize("ranks", [0, 2])
def test_a_start_at_a_written_time_removes_the_later_times_and_says_so(tmp_path, ranks):
    case = _fake_case(tmp_path, ranks)
    _control(case, "startTime", "0.19140625")
    said = F.recompute_from(case, *F.asked_start(case))
    assert said == (f"{case}: recomputing from t = 0.19140625 s, as system/controlDict asks "
                    "(startFrom startTime; startTime 0.19140625): removed the 2 written times "
                    "after it (0.3828125 to 0.57421875 s); startFrom set back to latestTime, "
                    "so that a rerun continues")
    for folder in [case, *F.processor_dirs(case)]:
        assert [d.name for _, d in F.time_dirs(folder)] == TIMES[:2]
    assert (case / "0.19140625" / "U").read_text() == "0.19140625"    # kept as it was
    # the loads of the first run up to t, the restart's folder at a later time gone
    rows = (case / "postProcessing" / "loads" / "0" / "loads.dat").read_text().splitlines()
    assert rows == ["# Time\tFx", "0.0478515625\t1", "0.095703125\t2", "0.1435546875\t3",
                    "0.19140625\t4"]
    assert not (case / "postProcessing" / "loads" / "0.3828125").exists()
    assert F.asked_start(case) is None                  # a rerun continues
    assert "startFrom latestTime;" in read_foam_text(case / "system" / "controlDict")


def test_a_start_at_a_time_not_written_is_refused_in_one_line(tmp_path):
    case = _fake_case(tmp_path)
    _control(case, "startTime", "0.2")
    with pytest.raises(CaseError) as err:
        F.recompute_from(case, *F.asked_start(case))
    message = str(err.value)
    assert "\n" not in message
    assert message == (f"{case / 'system' / 'controlDict'} asks to start from t = 0.2 s "
                       "(startFrom startTime; startTime 0.2), which is not a written time "
                       "(nearest: 0.19140625, 0.3828125 s): set startTime to a written time to "
                       "recompute from there, or startFrom latestTime to continue from the "
                       "latest (0.57421875 s)")
    assert [d.name for _, d in F.time_dirs(case)] == TIMES            # nothing removed


def _field(case: Path, time: str, name: str = "U") -> np.ndarray:
    text = read_foam_text(case / time / name)
    m = re.search(r"internalField\s+nonuniform\s+List<vector>\s*(\d+)\s*\(", text)
    body = text[m.end():text.index(")\n)", m.end()) + 1]
    return np.array(body.replace("(", " ").replace(")", " ").split(), float).reshape(-1, 3)


@pytest.mark.openfoam
def test_run_case_recomputes_from_the_users_start_time(tmp_path, capsys):
    """The smoke case, static whale, to its end (8 steps, written every 4); then startTime at
    the middle write: the last time is recomputed (a new folder) from there, said so, and
    matches the first run's; a rerun has nothing to run."""
    case = tmp_path / "case"
    C.prepare_case(load_scene(preset="smoke"), case, static_whale=True)
    M.mesh_case(case)
    R.run_case(case, progress=False)
    names = [d.name for _, d in F.time_dirs(case)]
    assert len(names) == 3
    first = _field(case, names[-1])
    stamp = (case / names[-1] / "U").stat().st_mtime_ns
    capsys.readouterr()
    _control(case, "startTime", names[1])
    summary = R.run_case(case, progress=False)
    out = capsys.readouterr().out
    assert f"recomputing from t = {names[1]} s, as system/controlDict asks" in out
    assert f"removed the written time after it ({names[2]} s)" in out
    assert summary["steps"] == 4
    assert (case / names[-1] / "U").stat().st_mtime_ns > stamp
    again = _field(case, names[-1])
    print(f"U after the recomputed half vs the first run: max |dU| = "
          f"{np.abs(again - first).max():.3g} m/s")
    np.testing.assert_allclose(again, first, rtol=0, atol=1e-9)
    assert F.asked_start(case) is None
