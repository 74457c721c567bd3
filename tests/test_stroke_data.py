"""The default stroke against docs/stroke.md's "The stroke from right-whale data": the default
scene holds the table's values, and its speed lies between the tagged right whales' speeds
that the table quotes (van der Hoop et al. 2019: 1.1 m/s filtering, 1.4 m/s descending)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from adapter.scene import load_scene

STROKE_MD = Path(__file__).resolve().parent.parent / "docs" / "stroke.md"
SECTION = "## The stroke from right-whale data"


def _section() -> str:
    text = STROKE_MD.read_text()
    start = text.index(SECTION)
    end = text.find("\n## ", start + len(SECTION))
    return text[start:end if end >= 0 else None]


def _table() -> dict[str, tuple[float, str]]:
    """The table's rows: scene key -> (value, unit) of the column "value in the default scene"."""
    rows = {}
    for line in _section().splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        key = re.search(r"`(\w+\.\w+)`", cells[0]) if len(cells) == 4 else None
        if key:
            number, unit = re.fullmatch(r"([\d.]+)\s*(\S+)", cells[1]).groups()
            rows[key[1]] = (float(number), unit)
    return rows


def _scene_value(scene, key: str) -> float:
    section, name = key.split(".")
    return getattr(getattr(scene, section), name)


def test_the_table_names_the_speed_the_frequency_and_the_amplitude():
    assert _table() == {
        "flow.speed_m_s": (1.3, "m/s"),
        "stroke.frequency_hz": (0.13, "Hz"),
        "calibration.fluke_amplitude": (0.2, "L"),
    }


@pytest.mark.parametrize("preset", ["default", "smoke", "fine"])
def test_the_default_scene_holds_the_documented_stroke(preset):
    scene = load_scene(preset=preset)
    for key, (value, _unit) in _table().items():
        assert _scene_value(scene, key) == pytest.approx(value), key


def test_the_speed_lies_between_the_tagged_whales_filtering_and_descent():
    row = next(line for line in _section().splitlines() if "`flow.speed_m_s`" in line)
    descent = float(re.search(r"descended at ([\d.]+) ", row)[1])
    filtering = float(re.search(r"swam at ([\d.]+) \(\+-[\d.]+\) m/s while filtering", row)[1])
    assert (filtering, descent) == (1.1, 1.4)  # van der Hoop et al. 2019, abstract
    assert filtering <= load_scene().flow.speed_m_s <= descent
