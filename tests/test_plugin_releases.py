"""The plugin's OpenFOAM releases (docs/openfoam-plugin.md, "Releases"): whaleFoamCompat.H, the
one place of their differences, picks each release's member by the OPENFOAM macro that wmake's
rules define, stops where OPENFOAM is missing or older than v1912, and lists the releases it
knows, which build_plugin.sh reports. Only the preprocessor runs (g++ -E): no OpenFOAM needed."""

import re
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PLUGIN = ROOT / "adapter" / "foam" / "plugin"
COMPAT = PLUGIN / "common" / "whaleFoamCompat.H"

needs_gxx = pytest.mark.skipif(shutil.which("g++") is None, reason="g++ is not on PATH")


def _expand(*defines):
    source = '#include "whaleFoamCompat.H"\nwriteFile::whaleFileAtStartTime("loads");\n'
    return subprocess.run(["g++", "-E", "-P", "-x", "c++", *defines, f"-I{COMPAT.parent}", "-"],
                          input=source, capture_output=True, text=True)


@needs_gxx
@pytest.mark.parametrize(("api", "member"), [("1912", "createFile"), ("2206", "createFile"),
                                             ("2212", "newFileAtStartTime"),
                                             ("2312", "newFileAtStartTime")])
def test_the_start_time_file_is_each_releases_member(api, member):
    done = _expand(f"-DOPENFOAM={api}")
    assert done.returncode == 0, done.stderr
    assert f'writeFile::{member}("loads");' in done.stdout


@needs_gxx
@pytest.mark.parametrize("defines", [(), ("-DOPENFOAM=12",)])
def test_no_openfoam_com_release_stops_with_a_reason(defines):
    done = _expand(*defines)
    assert done.returncode != 0 and "#error" in done.stderr and "v1912 or later" in done.stderr


def test_the_known_releases_are_the_docs_and_the_scripts():
    known = re.search(r"^ *known-apis: *(.*)$", COMPAT.read_text(), re.M).group(1).split()
    assert known == ["1912", "2312"]
    doc = (ROOT / "docs" / "openfoam-plugin.md").read_text()
    for api in known:
        assert f"| OpenFOAM.com **v{api}**" in doc, api
    for script in ("build_plugin.sh", "check_plugin_compile.sh"):
        assert "known-apis:" in (ROOT / "scripts" / script).read_text(), script
    # the call goes through the header, not to one release's member
    loads = (PLUGIN / "loads" / "whaleLoads.C").read_text()
    assert "whaleFileAtStartTime" in loads and "createFile(\"" not in loads
