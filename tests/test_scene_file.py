"""The case's own scene (adapter/foam/casescene.py, adapter/scenefile.py): written by
prepare_case with every value and absolute paths, it loads back to the same scene from
anywhere, the case's step-server loads it (an in-memory change of the scene reaches the
server), the free whale's case carries it, and a rerun is compared with it. No OpenFOAM."""

from __future__ import annotations

import dataclasses
import shutil
from pathlib import Path

import pytest

from adapter.coupling import server as SV
from adapter.foam import case as C
from adapter.foam import command as CMD
from adapter.foam.casescene import CASE_SCENE, load_case_scene, write_case_scene
from adapter.foam.freerun import prepare_free
from adapter.foam.stepserver import server_command
from adapter.motion.gait import load_fluke_table
from adapter.scene import load_scene
from adapter.scenefile import scene_toml


@pytest.fixture(scope="module")
def smoke():
    return load_scene(preset="smoke")


def _at(scene, folder: Path):
    return dataclasses.replace(scene, base_dir=str(folder))


@pytest.mark.parametrize("preset", ["default", "smoke", "fine"])
def test_a_preset_round_trips(tmp_path, preset):
    scene = load_scene(preset=preset)
    written = write_case_scene(scene, tmp_path, f"preset {preset}")
    assert written == tmp_path / CASE_SCENE
    assert load_scene(written) == _at(scene, tmp_path)
    # on top of another preset too: every value is written, not what differs from one
    assert load_scene(written, preset="smoke" if preset != "smoke" else "fine") == \
        _at(scene, tmp_path)


def _user_scene(folder: Path):
    """A scene file in ``folder`` naming a mesh file, a fluke table and a decomposeParDict by
    relative paths, with landmarks and floats that a short decimal would not give back."""
    (folder / "meshes").mkdir(parents=True)
    (folder / "meshes" / "whale.stl").write_text("solid x\nendsolid x\n")
    (folder / "angles.csv").write_text("phase,angle_deg\n0,0\n0.5,20\n")
    (folder / "myDecomposeParDict").write_text("numberOfSubdomains 2;\n")
    (folder / "my.toml").write_text(
        'preset = "smoke"\n'
        '[geometry]\nsource = "meshes/whale.stl"\n'
        'landmarks = { tail_base = [11.5, 0.0, 0.1], "odd key" = [1, 2, 3] }\n'
        '[stroke]\nfluke_table = "angles.csv"\n'
        '[case]\ndecomposition = "myDecomposeParDict"\n'
        'launcher = "srun -n {np} \\"quoted\\""\n')
    return load_scene(folder / "my.toml").replace(
        stroke={"fluke_joint": 0.06, "velocity_scale": 1.04786, "tail_speed": 0.1 + 0.2},
        rigid={"translation_phase_deg": 1 / 3, "translation_m": (5e-324, -0.0, 1e300)})


def test_a_changed_scene_with_paths_round_trips_from_anywhere(tmp_path, monkeypatch):
    src = tmp_path / "src"
    scene = _user_scene(src)
    case = tmp_path / "case"
    written = write_case_scene(scene, case, f"scene file {src / 'my.toml'}")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    back = load_scene(written)
    # the paths absolute, by hand; every other value as it was, bit for bit
    assert back == _at(scene, case).replace(
        geometry={"source": str(src / "meshes" / "whale.stl")},
        stroke={"fluke_table": str(src / "angles.csv")},
        case={"decomposition": str(src / "myDecomposeParDict")})
    assert back.stroke.tail_speed == 0.30000000000000004
    assert back.rigid.translation_m == (5e-324, -0.0, 1e300)
    assert back.geometry.landmarks["odd key"] == (1.0, 2.0, 3.0)
    assert back.case.launcher == 'srun -n {np} "quoted"'
    # the files it names are found from here
    assert back.resolve(back.geometry.source).is_file()
    table = load_fluke_table(back.stroke.fluke_table, back.base_dir)
    assert table.phase.tolist() == [0.0, 0.5]
    # the header says where the scene came from, as a comment
    assert f"# Started from: scene file {src / 'my.toml'}" in written.read_text()


def test_the_writer_takes_the_values_a_scene_holds():
    text = scene_toml(load_scene(preset="smoke"))
    assert 'name = "smoke"' in text and "preset" not in text and "base_dir" not in text
    assert "refinement = [1, 2]" in text and "landmarks = {}" in text
    assert "nu_m2_s = 1e-06" in text and "gliding = false" in text


def _served_scene(case: Path, record: dict, monkeypatch):
    """The scene ``whale-adapter serve`` builds its StepServer with, from the case's server
    command (adapter/foam/stepserver.py) run through the command line as the run starts it."""
    from adapter.cli import main

    seen = {}

    class Caught(Exception):
        pass

    def fake_server(case_dir, scene, **kwargs):
        seen["scene"] = scene
        raise Caught

    monkeypatch.setattr(SV, "StepServer", fake_server)
    cmd = server_command(case, record)
    assert cmd[1:4] == ["-m", "adapter.cli", "serve"]
    with pytest.raises(Caught):
        main(cmd[3:])
    return seen["scene"]


def test_the_server_animates_the_scene_the_case_was_prepared_from(tmp_path, smoke,
                                                                  smoke_surface, monkeypatch):
    """The study's speeds and an API user's change: a scene changed in memory, no file."""
    scene = smoke.replace(stroke={"fluke_joint": 0.06, "velocity_scale": 1.04786},
                          flow={"speed_m_s": 1.625})
    case = tmp_path / "case"
    C.prepare_case(scene, case, surface=smoke_surface)
    record = C.read_record(case)
    assert record["scene_file"] is None and record["preset"] == "smoke"   # the provenance
    served = _served_scene(case, record, monkeypatch)
    assert served.stroke.fluke_joint == 0.06 and served.stroke.velocity_scale == 1.04786
    assert served.flow.speed_m_s == 1.625
    assert served == _at(scene, case)

    # the free whale's case (a copy at the tethered run's latest time) serves the same
    shutil.copytree(case / "0.orig", case / "0.05")
    free = prepare_free(case, drag=100.0)
    assert _served_scene(free, C.read_record(free), monkeypatch) == _at(scene, free)


def test_an_older_case_without_its_scene_serves_the_recorded_preset(tmp_path, smoke,
                                                                   smoke_surface, monkeypatch):
    case = tmp_path / "old"
    C.prepare_case(smoke.replace(stroke={"fluke_joint": 0.06}), case, surface=smoke_surface)
    (case / CASE_SCENE).unlink()
    assert _served_scene(case, C.read_record(case), monkeypatch).stroke.fluke_joint == 0.0


class _Meshing(Exception):
    """run-case got past its checks of a rerun (to meshing, which needs OpenFOAM)."""


def _rerun(monkeypatch, *args):
    from adapter.cli import main

    def mesh_case(*a, **k):
        raise _Meshing
    monkeypatch.setattr(CMD, "mesh_case", mesh_case)
    return main(["run-case", *args])


def test_a_rerun_is_compared_with_the_cases_own_scene(tmp_path, monkeypatch, capsys):
    my = tmp_path / "my.toml"
    my.write_text('preset = "smoke"\n[stroke]\nfluke_joint = 0.03\n')
    case = tmp_path / "case"
    # prepared by run-case (to meshing), with a run setting that goes into its scene
    with pytest.raises(_Meshing):
        _rerun(monkeypatch, "--scene", str(my), "--launcher", "srun -n {np}", "--case", str(case))
    assert load_case_scene(case).case.launcher == "srun -n {np}"
    # the same scene, named by its file or by a copy of it: continued (to meshing)
    with pytest.raises(_Meshing):
        _rerun(monkeypatch, "--scene", str(my), "--case", str(case))
    shutil.copy(my, tmp_path / "copy.toml")
    with pytest.raises(_Meshing):
        _rerun(monkeypatch, "--scene", str(tmp_path / "copy.toml"), "--np", "3",
               "--launcher", "srun", "--case", str(case))
    # the scene file edited after preparing: refused, naming the value, in one line
    my.write_text('preset = "smoke"\n[stroke]\nfluke_joint = 0.06\n')
    assert _rerun(monkeypatch, "--scene", str(my), "--case", str(case)) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert f"--scene {my} (recorded: scene {my}; its values differ from the case's own " \
           f"scene {case / CASE_SCENE} in stroke.fluke_joint (0.06 vs 0.03))" in err
    assert load_case_scene(case).stroke.fluke_joint == 0.03       # the case keeps its own
    # another preset
    assert _rerun(monkeypatch, "--preset", "default", "--case", str(case)) == 2
    err = capsys.readouterr().err
    assert "--preset default (recorded: scene" in err and " more)" in err


def test_a_rerun_of_an_older_case_is_compared_with_its_record(tmp_path, smoke, smoke_surface,
                                                              monkeypatch, capsys):
    case = tmp_path / "old"
    C.prepare_case(smoke, case, surface=smoke_surface)
    (case / CASE_SCENE).unlink()
    with pytest.raises(_Meshing):
        _rerun(monkeypatch, "--preset", "smoke", "--case", str(case))
    assert _rerun(monkeypatch, "--preset", "default", "--case", str(case)) == 2
    assert "--preset default (recorded: preset smoke)" in capsys.readouterr().err


def test_the_report_shows_the_scene_the_server_animates(tmp_path, smoke, smoke_surface):
    from adapter.foam.report import write_report

    case = tmp_path / "case"
    C.prepare_case(smoke.replace(stroke={"fluke_joint": 0.06}), case, surface=smoke_surface)
    page = write_report(case, {}).read_text()
    assert "fluke_joint = 0.06\n" in page and str(case / CASE_SCENE) in page
