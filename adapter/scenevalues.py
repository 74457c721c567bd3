"""The scene's value checks: one TOML value against a field's type and metadata
(:mod:`adapter.scene` builds the tree with them), and a scene file's TOML read."""

from __future__ import annotations

import math
import tomllib
import typing

from adapter.errors import SceneError


def within(low, high=math.inf, ends="[]"):
    """A field's check, low <= v <= high, "(" or ")" in ``ends`` excluding that end."""
    def check(v):
        return low <= v <= high and (v != low or ends[0] == "[") and (v != high or ends[1] == "]")
    check.range = f"{ends[0]}{low:.10g}, {high:.10g}{ends[1]}".replace("inf]", "inf)")  # type: ignore[attr-defined]
    return check


def describe(value) -> str:
    return f"{value!r} ({type(value).__name__})"


_EXPECTED = {str: "a string", bool: "true or false", dict: "a table"}   # taken as they are


def convert(value, annotation, path: str, meta: dict):
    """Check one TOML value against a field's type and metadata, returning the value to store."""
    kind = annotation if isinstance(annotation, type) else typing.get_origin(annotation)
    if kind is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise SceneError(f"{path}: expected a number, got {describe(value)}")
        value = float(value)
        if not math.isfinite(value):
            raise SceneError(f"{path}: expected a finite number, got {value}")
    elif kind is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise SceneError(f"{path}: expected a whole number, got {describe(value)}")
    elif kind in _EXPECTED:
        if not isinstance(value, kind):
            raise SceneError(f"{path}: expected {_EXPECTED[kind]}, got {describe(value)}")
        if isinstance(value, dict):
            value = {k: point(v, f"{path}.{k}") for k, v in value.items()}
    elif kind is tuple and meta.get("vector"):
        value = point(value, path)
    elif kind is tuple:
        if not isinstance(value, (list, tuple)) or not all(
            isinstance(v, int) and not isinstance(v, bool) for v in value
        ):
            raise SceneError(f"{path}: expected a list of whole numbers, got {describe(value)}")
        value = tuple(value)
    choices = meta.get("choices")
    if choices is not None and value not in choices:
        raise SceneError(f"{path}: expected one of {', '.join(choices)}; got {value!r}")
    check = meta.get("check")
    if check is not None and not check(value):
        allowed = f" {check.range}" if hasattr(check, "range") else ""   # within's interval
        raise SceneError(f"{path}: value {value!r} is out of range{allowed} (docs/scene.md)")
    return value


def point(value, path: str):
    if (
        not isinstance(value, (list, tuple))
        or len(value) != 3
        or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value)
        or not all(math.isfinite(v) for v in value)
    ):
        raise SceneError(f"{path}: expected a point [x, y, z] of three finite numbers, "
                         f"got {value!r}")
    return tuple(float(v) for v in value)


def read_toml(text: str, where: str) -> dict:
    """A TOML file's text as a table; ``where`` names it in the error of a bad file."""
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"{where}: not valid TOML: {exc}") from None
