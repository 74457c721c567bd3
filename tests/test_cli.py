"""The command line: --version, a description for every sub-command."""

import argparse
import re

import pytest

from adapter.cli import build_parser, main


def test_version(capsys):
    with pytest.raises(SystemExit) as info:
        main(["--version"])
    assert info.value.code == 0
    assert re.fullmatch(r"whale-adapter \S+.*\n", capsys.readouterr().out)


def _subparsers(parser):
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return action.choices
    raise AssertionError("no sub-commands")


def test_every_sub_command_has_a_help_line_and_a_description():
    commands = _subparsers(build_parser())
    assert len(commands) >= 8
    missing = [name for name, p in commands.items() if not (p.description or "").strip()]
    assert not missing, f"sub-commands without a description: {missing}"
    help_text = build_parser().format_help()
    for name in commands:
        assert re.search(rf"^\s+{re.escape(name)}\s*\n?\s+\S", help_text, re.M), name


# --- run-case's ending: finished, not periodic, quiet (the pair faked at its function) ------

def _prepared_pair(tmp_path, written=()):
    """A case folder as run-case leaves it for the gliding + swimming pair: the template, the
    record, a mesh file (never read here) and the written times ``written``."""
    import shutil

    from adapter.foam import case as C

    case = tmp_path / "case"
    shutil.copytree(C.TEMPLATE_DIR, case)
    C.write_json(case / C.CASE_RECORD, {"preset": "default", "gliding": True,
                                        "static_whale": False, "periodic_tolerance": 0.02})
    (case / "constant" / "polyMesh").mkdir(parents=True, exist_ok=True)
    (case / "constant" / "polyMesh" / "owner").write_text("")
    for t in written:
        (case / t).mkdir()
    return case


def _pair_summary(reached: bool, fx=0.031, power=0.004, steady="steady: ...") -> dict:
    return {"end_time_s": 30.0, "swimming_cost": {
        "gliding_drag_N": 660.0, "gliding_run": {"stopped_because": steady},
        "periodic_change": {"fx_of_gliding_drag": fx, "power": power, "tolerance": 0.02,
                            "reached": reached}}}


@pytest.fixture
def fake_pair(monkeypatch):
    """run-case's pair replaced by one that returns ``fake_pair.summary``."""
    from adapter.foam import command

    class Fake:
        summary = _pair_summary(True)
        calls = []

    def run(case, record, tolerance, **options):
        Fake.calls.append(options)
        return Fake.summary

    monkeypatch.setattr(command, "run_swim_and_glide", run)
    return Fake


def test_a_pair_that_never_became_periodic_warns_and_exits_3(tmp_path, capsys, fake_pair):
    from adapter.foam.command import NOT_PERIODIC

    case = _prepared_pair(tmp_path)
    fake_pair.summary = _pair_summary(False)
    assert main(["run-case", "--case", str(case)]) == NOT_PERIODIC == 3
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].startswith("whale-adapter run-case: warning: ")
    assert "without reaching its periodic state" in err[0] and "3.1%" in err[0]
    assert "raise endtime" in err[0].lower()
    # fewer than two cycles: no change to give, said so
    fake_pair.summary = _pair_summary(False, fx=None, power=None)
    assert main(["run-case", "--case", str(case)]) == 3
    assert "fewer than two stroke cycles" in capsys.readouterr().err
    # periodic: 0, no warning
    fake_pair.summary = _pair_summary(True)
    assert main(["run-case", "--case", str(case)]) == 0
    assert capsys.readouterr().err == ""


def test_a_gliding_run_that_never_became_steady_is_a_warning(tmp_path, capsys, fake_pair):
    case = _prepared_pair(tmp_path)
    fake_pair.summary = _pair_summary(True, steady=None)
    assert main(["run-case", "--case", str(case)]) == 0
    err = capsys.readouterr().err
    assert "warning: the gliding run" in err and "before its drag was steady" in err


def test_a_finished_case_says_it_is_finished_not_continuing(tmp_path, capsys, fake_pair):
    case = _prepared_pair(tmp_path, written=["0", "3.84", "7.6923077"])
    assert main(["run-case", "--case", str(case)]) == 0
    out = capsys.readouterr().out
    assert f"{case} already holds a finished case (preset default): it reached its end time " \
           "(7.69231 s), nothing to run" in out
    assert "continuing" not in out
    # not at its end time: it continues
    case = _prepared_pair(tmp_path / "b", written=["0", "3.84"])
    assert main(["run-case", "--case", str(case)]) == 0
    assert "continuing it from t = 3.84 s" in capsys.readouterr().out


def test_quiet_run_case_prints_nothing_but_its_warning(tmp_path, capsys, fake_pair):
    case = _prepared_pair(tmp_path, written=["0", "3.84"])
    fake_pair.summary = _pair_summary(False)
    assert main(["run-case", "--case", str(case), "--quiet"]) == 3
    captured = capsys.readouterr()
    assert captured.out == "" and "warning" in captured.err
    assert fake_pair.calls[-1]["progress"] is False
    assert main(["run-case", "--case", str(case), "-q"]) == 3


@pytest.mark.parametrize("command", ["run-case", "study", "dry-run", "validate"])
def test_the_long_commands_take_quiet(command):
    parser = _subparsers(build_parser())[command]
    assert "--quiet" in parser.format_help() and "-q" in parser.format_help()


@pytest.mark.parametrize("args, dest, value", [
    (["run-case", "--out", "runs/x"], "case", "runs/x"),
    (["run-case", "--case", "runs/x"], "case", "runs/x"),
    (["calibrate", "--out", "c.json"], "report", "c.json"),
    (["calibrate", "--report", "c.json"], "report", "c.json"),
    (["serve", "--case", ".", "--port", "7000"], "tcp", 7000),
    (["serve", "--case", ".", "--tcp", "7000"], "tcp", 7000),
])
def test_the_unified_spellings_are_aliases_of_the_old_ones(args, dest, value):
    """--out for the output place, --port for a TCP port, everywhere; the old spellings stay."""
    got = getattr(build_parser().parse_args(args), dest)
    assert (str(got) if isinstance(value, str) else got) == value
