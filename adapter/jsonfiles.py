"""Strict JSON: every file and printout the package writes parses with a strict parser (no
NaN, no Infinity). :func:`finite` is the one cleaner (a float that is not finite becomes
None: a figure that was never measured is absent, not a number); :func:`dumps` and
:func:`write_json` apply it and refuse anything else JSON has no word for (``allow_nan=False``).
A leaf: it imports nothing of the package.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

#: a case's record: what prepare_case recorded about it (scene, derived numbers, mesh); the
#: case object is :class:`adapter.foam.case.Case`, the names are here for the rooms below it
CASE_RECORD = "adapter-case.json"
#: the record's key that says a case is half the domain (adapter/foam/symmetry.py)
SYMMETRY_PLANE = "symmetry_plane"
#: a case's summary: the figures of its run (:mod:`adapter.foam.summary`)
CASE_SUMMARY = "adapter-summary.json"


def finite(obj):
    """``obj`` with every NaN or infinite float, nested ones included, as None."""
    if isinstance(obj, dict):
        return {k: finite(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [finite(v) for v in obj]
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def dumps(obj, indent: int | None = 2) -> str:
    """``obj`` as strict JSON (:func:`finite` first)."""
    return json.dumps(finite(obj), indent=indent, allow_nan=False)


def write_json(path, obj) -> None:
    """``obj`` as indented strict JSON into ``path`` (its folder made), with a final newline."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(dumps(obj) + "\n")
