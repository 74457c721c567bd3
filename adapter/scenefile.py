"""A scene written out as a TOML file that :func:`adapter.scene.load_scene` reads back to the
same scene: every value of every section (not what differs from a preset), floats by ``repr``
so that they load bit for bit.

The values a scene holds are few: bools, ints, floats, strings, lists of them (tuples: points,
the refinement levels), lists of lists and a table of points (``geometry.landmarks``). The
scene's ``name`` (the preset it started from) is written as ``name``, not ``preset``: the file
loads the same on top of any preset. ``base_dir`` is not written (it is the folder the file
is loaded from); a path the scene names relative to its ``base_dir`` must be made absolute
before (:func:`with_absolute_paths`) for the file to load from anywhere.
"""

from __future__ import annotations

import dataclasses
import math
import os
import re
from pathlib import Path

_BARE_KEY = re.compile(r"^[A-Za-z0-9_-]+$")
_ESCAPES = {'"': '\\"', "\\": "\\\\", "\b": "\\b", "\t": "\\t", "\n": "\\n", "\f": "\\f",
            "\r": "\\r"}


def toml_string(text: str) -> str:
    """A TOML basic string: quotes, backslashes and control characters escaped."""
    out = []
    for ch in text:
        if ch in _ESCAPES:
            out.append(_ESCAPES[ch])
        elif ord(ch) < 0x20 or ord(ch) == 0x7F:
            out.append(f"\\u{ord(ch):04x}")
        else:
            out.append(ch)
    return '"' + "".join(out) + '"'


def toml_key(key: str) -> str:
    return key if _BARE_KEY.match(key) else toml_string(key)


def toml_value(value) -> str:
    """One value as TOML (bool before int: a bool is an int in Python)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if not math.isfinite(value):
            raise ValueError(f"{value!r}: TOML scene values are finite")
        return repr(value)       # the shortest text that reads back to the same double
    if isinstance(value, str):
        return toml_string(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        items = ", ".join(f"{toml_key(str(k))} = {toml_value(v)}" for k, v in value.items())
        return "{" + (f" {items} " if items else "") + "}"
    raise TypeError(f"{type(value).__name__} {value!r}: not a scene value")


def scene_toml(scene, header: str = "") -> str:
    """The scene as TOML text: ``header`` (a comment, each line prefixed with ``# ``), the
    name, then one table per section in the scene's field order."""
    lines = [f"# {ln}".rstrip() for ln in header.splitlines()]
    tables = []
    for f in dataclasses.fields(scene):
        value = getattr(scene, f.name)
        if f.name == "base_dir":
            continue
        if dataclasses.is_dataclass(value):
            tables.append((f.name, value))
        else:
            lines.append(f"{toml_key(f.name)} = {toml_value(value)}")
    for name, section in tables:
        lines += ["", f"[{toml_key(name)}]"]
        lines += [f"{toml_key(g.name)} = {toml_value(getattr(section, g.name))}"
                  for g in dataclasses.fields(section)]
    return "\n".join(lines) + "\n"


def with_absolute_paths(scene, path_fields: dict):
    """The scene with each path of ``path_fields`` absolute: ``{"section.key": names}``, where
    ``names`` are the key's values that are not paths (e.g. ``geometry.source``'s
    ``"procedural"``); a path is resolved as :meth:`adapter.scene.Scene.resolve` does (against
    the scene's ``base_dir``, itself against the working folder when relative)."""
    changes: dict[str, dict] = {}
    for dotted, names in path_fields.items():
        section, key = dotted.split(".")
        value = getattr(getattr(scene, section), key)
        if value and value not in names:
            changes.setdefault(section, {})[key] = os.path.abspath(scene.resolve(value))
    return scene.replace(**changes) if changes else scene


def write_scene(scene, path: str | os.PathLike, header: str = "") -> Path:
    """:func:`scene_toml` into ``path`` (its folder made); returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(scene_toml(scene, header), encoding="utf-8")
    return path
