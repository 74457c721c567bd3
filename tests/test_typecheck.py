"""The type check of ``make lint`` (mypy, pyproject's [tool.mypy]) is strict about None: a member
left None until start() and used without a check is an error, the checked use is not; and the
wheel says it is typed (adapter/py.typed, shipped as package data)."""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]

_SERVER = '''
class Socket:
    def close(self) -> None: ...

class Server:
    def __init__(self) -> None:
        self.sock: Socket | None = None

    def start(self) -> None:
        self.sock = Socket()

    def stop(self) -> None:
        {stop}
'''


def _mypy(tmp_path: Path, source: str) -> tuple[str, int]:
    api = pytest.importorskip("mypy.api")
    config = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["mypy"]
    path = tmp_path / "planted.py"
    path.write_text(source)
    args = ["--no-incremental", "--python-version", config["python_version"]]
    args += [f"--{k.replace('_', '-')}" for k, v in config.items() if v is True]
    out, err, code = api.run([*args, str(path)])
    return out + err, code


def test_a_member_none_until_started_is_an_error_unchecked(tmp_path):
    out, code = _mypy(tmp_path, _SERVER.format(stop="self.sock.close()"))
    assert code == 1 and 'Item "None" of "Socket | None" has no attribute "close"' in out


def test_the_checked_use_passes(tmp_path):
    out, code = _mypy(tmp_path, _SERVER.format(
        stop="if self.sock is not None:\n            self.sock.close()"))
    assert code == 0, out


def test_the_package_is_marked_typed():
    assert (REPO / "adapter" / "py.typed").is_file()
    data = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["setuptools"]
    assert "py.typed" in data["package-data"]["*"]
