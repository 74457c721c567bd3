"""The default folders: `run-case --scene my.toml` and `study --scene my.toml` write
into runs/my and runs/study-my, the folders the Makefile names (CASE ?= runs/$(basename
$(notdir $(SCENE)))), not runs/default; plain `make paraview` draws that case, not the dry-run."""

import shutil
import subprocess
from pathlib import Path

import pytest

from adapter.cli import main
from adapter.foam import case as C

ROOT = Path(__file__).resolve().parents[1]


def _prepared(case: Path, scene_file: Path) -> None:
    """A case folder as run-case leaves it for the pair, prepared from ``scene_file``."""
    shutil.copytree(C.TEMPLATE_DIR, case)
    C.write_json(case / C.CASE_RECORD, {"scene_file": str(scene_file.resolve()), "gliding": True,
                                        "static_whale": False, "periodic_tolerance": 0.02})
    (case / "constant" / "polyMesh").mkdir(parents=True, exist_ok=True)
    (case / "constant" / "polyMesh" / "owner").write_text("")


def test_run_case_with_a_scene_file_defaults_to_runs_of_its_stem(tmp_path, monkeypatch, capsys):
    from adapter.foam import command

    monkeypatch.chdir(tmp_path)
    scene = tmp_path / "scenes" / "my.toml"
    scene.parent.mkdir()
    scene.write_text('preset = "smoke"\n')
    _prepared(tmp_path / "runs" / "my", scene)
    ran = []
    monkeypatch.setattr(command, "run_swim_and_glide",
                        lambda case, *a, **k: ran.append(Path(case)) or _summary())
    assert main(["run-case", "--scene", str(scene)]) == 0
    assert ran == [Path("runs/my")]
    assert not (tmp_path / "runs" / "default").exists()
    assert "runs/my already holds a case" in capsys.readouterr().out


def test_study_with_a_scene_file_defaults_to_runs_study_of_its_stem(tmp_path, monkeypatch):
    from adapter.studies import study

    monkeypatch.chdir(tmp_path)
    scene = tmp_path / "my.toml"
    scene.write_text('preset = "smoke"\n')
    outs = []

    def run_study(scene, out, **options):
        outs.append(Path(out))
        raise SystemExit(0)

    monkeypatch.setattr(study, "run_study", run_study)
    with pytest.raises(SystemExit):
        main(["study", "--scene", str(scene)])
    with pytest.raises(SystemExit):
        main(["study", "--preset", "smoke"])
    assert outs == [Path("runs/study-my"), Path("runs/study-smoke")]


@pytest.mark.skipif(shutil.which("make") is None, reason="no make")
@pytest.mark.parametrize("target, option, folder", [("run-case", "--case", "runs/my"),
                                                    ("study", "--out", "runs/study-my")])
def test_the_makefile_names_the_same_folders(target, option, folder):
    """The hand values above are the Makefile's: make -n prints the command it would run."""
    out = subprocess.run(["make", "-n", "-C", str(ROOT), target, "SCENE=scenes/my.toml"],
                         capture_output=True, text=True, check=True).stdout
    line = next(x for x in out.splitlines() if f"whale-adapter {target}" in x)
    assert f"{option} {folder}" in line


def _summary() -> dict:
    return {"end_time_s": 30.0, "swimming_cost": {
        "gliding_drag_N": 660.0, "gliding_run": {"stopped_because": "steady"},
        "periodic_change": {"fx_of_gliding_drag": 0.001, "power": 0.001, "tolerance": 0.02,
                            "reached": True}}}


@pytest.mark.skipif(shutil.which("make") is None, reason="no make")
@pytest.mark.parametrize("variables, folder", [
    ([], "runs/default"),                       # the case plain make run-case wrote
    (["SCENE=smoke"], "runs/smoke"),
    (["SCENE=scenes/my.toml"], "runs/my"),
    (["CASE=runs/x"], "runs/x"),
    (["OUT=out/dry-run"], "out/dry-run"),       # the dry-run make dry-run OUT=... wrote
    (["DIR=out/dry-run"], "out/dry-run"),
    (["DIR=out/d", "CASE=runs/x"], "out/d"),
    (["CASE=runs/x", "OUT=out/o"], "runs/x"),
])
def test_make_paraview_draws_the_case_just_run(variables, folder):
    out = subprocess.run(["make", "-n", "-C", str(ROOT), "paraview", *variables],
                         capture_output=True, text=True, check=True).stdout
    line = next(x for x in out.splitlines() if "whale-adapter paraview" in x)
    assert line.split()[-1] == folder
