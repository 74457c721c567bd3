"""Provenance: the licence, the citation and the changelog agree with pyproject.toml, so that a
version bump that forgets one of them fails here."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]


def changelog_versions(text: str) -> list[str]:
    """The released or planned versions of a Keep a Changelog file, newest first (a bare
    ``[Unreleased]`` heading has none)."""
    return re.findall(r"^## \[(\d+\.\d+\.\d+[^\]]*)\]", text, re.M)


def test_the_changelog_s_top_version_is_pyproject_s():
    versions = changelog_versions((ROOT / "CHANGELOG.md").read_text())
    assert versions, "CHANGELOG.md has no '## [X.Y.Z]' section"
    assert versions[0] == PROJECT["version"], (versions[0], PROJECT["version"])
    assert len(set(versions)) == len(versions), "a version twice"


@pytest.mark.parametrize("text, top", [
    ("# Changelog\n## [Unreleased]\n## [1.2.0] - 2026-01-01\n## [1.1.0]\n", "1.2.0"),
    ("## [0.3.0] - Unreleased\n### Added\n## [0.2.0]\n", "0.3.0"),
])
def test_the_top_version_is_the_first_numbered_heading(text, top):
    assert changelog_versions(text)[0] == top


def test_the_licence_file_is_the_licence_pyproject_names():
    text = (ROOT / "LICENSE").read_text()
    assert PROJECT["license"] == "MIT" and text.startswith("MIT License\n")
    assert "Copyright (c)" in text and "the whale-adapter authors" in text


def test_the_citation_names_this_version_and_the_paper():
    text = (ROOT / "CITATION.cff").read_text()
    assert re.search(rf"^version: {re.escape(PROJECT['version'])}$", text, re.M)
    assert re.search(rf"^license: {PROJECT['license']}$", text, re.M)
    yaml = pytest.importorskip("yaml")
    cff = yaml.safe_load(text)
    assert cff["cff-version"] == "1.2.0" and cff["type"] == "software"
    assert cff["title"] == PROJECT["name"]
    paper = cff["references"][0]
    assert paper["title"] == "Numerical animation of a North Atlantic right whale"
    assert [a["family-names"] for a in paper["authors"]] == [
        "Duffy", "McGregor", "McGregor", "Nowacek", "Sussman"]
