"""Room for a run's writes (adapter/foam/diskspace.py): the writes counted by hand from
controlDict's settings, a written time's size measured, a run refused on a file system too small
for it (a tmpfs of 1 MB when this machine lets us mount one) before anything is written."""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

import pytest

from adapter.errors import CaseError
from adapter.foam import diskspace as DS


def test_the_writes_left_counted_as_controldict_spells_them():
    # 0.5 s steps, a write every 4 steps = every 2 s: from 3 to 11 s writes at 5, 7, 9, 11
    steps = {"deltaT": 0.5, "writeControl": "timeStep", "writeInterval": 4}
    assert DS.writes_left(steps, 3.0, 11.0) == 4
    assert DS.writes_left({**steps, "purgeWrite": 2}, 3.0, 11.0) == 2
    # runTime: the interval in seconds
    assert DS.writes_left({"deltaT": 0.1, "writeControl": "runTime", "writeInterval": 2.5},
                          0.0, 10.0) == 4
    # a kind it cannot count (clockTime): nothing assumed
    assert DS.writes_left({"deltaT": 0.1, "writeControl": "clockTime",
                           "writeInterval": 60}, 0.0, 10.0) == 0


def _time(folder: Path, sizes: dict) -> None:
    folder.mkdir(parents=True)
    for name, n in sizes.items():
        (folder / name).parent.mkdir(parents=True, exist_ok=True)
        (folder / name).write_bytes(b"x" * n)


def test_a_written_time_is_measured_summed_over_the_ranks(tmp_path):
    # no written time yet: the cells times the default case's bytes per cell
    assert DS.write_bytes(tmp_path, 1000) == 1000 * DS.BYTES_PER_CELL
    _time(tmp_path / "0", {"U": 10})                   # the initial fields do not count
    assert DS.write_bytes(tmp_path, 1000) == 1000 * DS.BYTES_PER_CELL
    _time(tmp_path / "2.5", {"U": 300, "polyMesh/points": 700})
    assert DS.write_bytes(tmp_path, 1000) == 1000
    for rank, n in ((0, 4000), (1, 6000)):
        _time(tmp_path / f"processor{rank}" / "5", {"p": n})
    assert DS.write_bytes(tmp_path, 1000) == 10000


@pytest.fixture
def small_disk(tmp_path):
    """A real file system of 300 MB (tmpfs, its pages taken only when written), or skip where
    mounting is not allowed."""
    mnt = tmp_path / "small"
    mnt.mkdir()
    if os.geteuid() != 0 or subprocess.call(["mount", "-t", "tmpfs", "-o", "size=300m", "tmpfs",
                                             str(mnt)], stderr=subprocess.DEVNULL) != 0:
        pytest.skip("cannot mount a tmpfs here (needs root)")
    try:
        yield mnt
    finally:
        subprocess.call(["umount", str(mnt)])


def test_a_run_that_cannot_write_its_times_is_refused_before_it_starts(small_disk):
    case = small_disk / "case"
    (case / "10").mkdir(parents=True)
    with open(case / "10" / "U", "wb") as f:          # one written time of 10 MB (sparse)
        f.truncate(10 * 2**20)
    control = {"deltaT": 1.0, "writeControl": "timeStep", "writeInterval": 10}
    # 20 writes of 10 MB and 200 MB spare: 400 MB, on 300 MB
    with pytest.raises(CaseError) as err:
        DS.check_room(case, control, 10.0, 210.0, 50)
    msg = str(err.value)
    assert "20 writes (10 MB each" in msg and "writes_per_cycle" in msg and "\n" not in msg
    assert (case / "10" / "U").stat().st_size == 10 * 2**20     # nothing lost
    # keeping the latest write only (purgeWrite 1): 210 MB, it goes on
    DS.check_room(case, {**control, "purgeWrite": 1}, 10.0, 210.0, 50)
    # and 9 writes (290 MB) fit, 10 (300 MB and the tmpfs's own) do not
    DS.check_room(case, control, 10.0, 100.0, 50)
    with pytest.raises(CaseError):
        DS.check_room(case, control, 10.0, 120.0, 50)


def test_a_run_with_room_goes_on(tmp_path):
    _time(tmp_path / "10", {"U": 1000})
    control = {"deltaT": 1.0, "writeControl": "timeStep", "writeInterval": 10}
    DS.check_room(tmp_path, control, 10.0, 210.0, 50)      # 20 kB on this machine's disk
