"""The case object (adapter.foam.case.Case): its record read once and written by one method,
its summary, its folders and logs; a run's outcome (adapter.foam.outcome)."""

import json

import pytest

from adapter.errors import CaseError
from adapter.foam.case import Case
from adapter.foam.outcome import ENDED, RunOutcome, Stop


def test_the_record_is_read_once_and_saved_by_save(tmp_path):
    (tmp_path / "adapter-case.json").write_text(json.dumps({"preset": "smoke"}))
    case = Case(tmp_path)
    assert case.has_record and case.record == {"preset": "smoke"}
    # written behind its back: the held record stands until reload()
    (tmp_path / "adapter-case.json").write_text(json.dumps({"preset": "default"}))
    assert case.record["preset"] == "smoke"
    assert case.reload() == {"preset": "default"}
    case.save({**case.record, "mesh": {"cells": 12}})
    assert json.loads((tmp_path / "adapter-case.json").read_text()) == {
        "preset": "default", "mesh": {"cells": 12}}


def test_a_folder_without_a_record_is_refused_in_one_line(tmp_path):
    case = Case(tmp_path)
    assert not case.has_record
    with pytest.raises(CaseError, match="adapter-case.json is missing") as err:
        _ = case.record
    assert "\n" not in str(err.value)


def test_the_summary_folders_and_logs(tmp_path):
    case = Case(tmp_path)
    assert case.summary == {} and not case.has_summary
    case.save_summary({"steps": 3, "cost": float("nan")})
    assert json.loads((tmp_path / "adapter-summary.json").read_text()) == {"steps": 3,
                                                                           "cost": None}
    assert case.summary == {"steps": 3, "cost": None}
    (tmp_path / "log.blockMesh").write_text("")
    (tmp_path / "log.pimpleFoam").write_text("")
    assert [p.name for p in case.logs] == ["log.blockMesh", "log.pimpleFoam"]
    assert case.log("checkMesh") == tmp_path / "log.checkMesh"
    assert case.poly_mesh == tmp_path / "constant" / "polyMesh"
    assert case.control_dict == tmp_path / "system" / "controlDict"
    assert case / "0" == tmp_path / "0" and str(case.path) == str(tmp_path)


def test_run_outcomes_say_what_stopped_the_run():
    assert ENDED.message() is None and not ENDED.is_error
    assert RunOutcome(Stop.CRITERION, "periodic").message() == "periodic"
    watch = RunOutcome(Stop.MESH_WATCH, "the moved mesh is invalid (x)")
    assert watch.is_error and watch.message() == "mesh watch: the moved mesh is invalid (x)"
    check = RunOutcome(Stop.MOTION_CHECK, "face pyramids: 2 faces", 0.046875)
    assert check.is_error and check.message(0.03125) == (
        "mesh watch: the mesh at t = 0.046875 s would be invalid (face pyramids: 2 faces); "
        "stopped before moving it; the last written time 0.03125 s is valid")
