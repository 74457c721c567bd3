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
