"""Every check of the scene file at its edge (adapter/scene.py): each kind of value refused with
the message that names its path, each range at its limits as docs/scene.md and the comments of
adapter/data/scenes/default.toml give them, the relations between keys, the presets and the
scene's folder. Fast (about a second): the mutation tests of scene.py run it once per mutant
(docs/mutation.md)."""

import math
from pathlib import Path

import pytest

from adapter.errors import SceneError
from adapter.scene import DATA_DIR, default_scene, load_scene


def _load(tmp_path, text):
    f = tmp_path / "s.toml"
    f.write_text(text)
    return load_scene(f)


def _refused(tmp_path, text, message):
    f = tmp_path / "s.toml"
    f.write_text(text)
    with pytest.raises(SceneError) as info:
        load_scene(f)
    assert str(info.value) == f"{f}: {message}"


# -- each kind of value ----------------------------------------------------------------------------

@pytest.mark.parametrize("text, message", [
    ("[springs]\nmu = true\n", "springs.mu: expected a number, got True (bool)"),
    ("[springs]\nmu = \"1\"\n", "springs.mu: expected a number, got '1' (str)"),
    ("[springs]\nmu = inf\n", "springs.mu: expected a finite number, got inf"),
    ("[springs]\nmu = nan\n", "springs.mu: expected a finite number, got nan"),
    ("[geometry]\nnodes = 1200.0\n", "geometry.nodes: expected a whole number, got 1200.0 "
                                     "(float)"),
    ("[geometry]\nnodes = true\n", "geometry.nodes: expected a whole number, got True (bool)"),
    ("[springs]\nform = 1\n", "springs.form: expected a string, got 1 (int)"),
    ("[case]\ngliding = 1\n", "case.gliding: expected true or false, got 1 (int)"),
    ("[case]\ngliding = \"yes\"\n", "case.gliding: expected true or false, got 'yes' (str)"),
    ("[case]\nrefinement = 2\n", "case.refinement: expected a list of whole numbers, got 2 "
                                 "(int)"),
    ("[case]\nrefinement = [1, 2.0]\n", "case.refinement: expected a list of whole numbers, "
                                        "got [1, 2.0] (list)"),
    ("[case]\nrefinement = [true, 2]\n", "case.refinement: expected a list of whole numbers, "
                                         "got [True, 2] (list)"),
    ("[geometry]\nlandmarks = 3\n", "geometry.landmarks: expected a table, got 3 (int)"),
    ("[geometry.landmarks]\nrostrum = [0, 0, true]\n",
     "geometry.landmarks.rostrum: expected a point [x, y, z] of three finite numbers, got "
     "[0, 0, True]"),
    ("[geometry.landmarks]\nrostrum = [0, 0, nan]\n",
     "geometry.landmarks.rostrum: expected a point [x, y, z] of three finite numbers, got "
     "[0, 0, nan]"),
    ("[geometry.landmarks]\nrostrum = [0, 0, 0, 0]\n",
     "geometry.landmarks.rostrum: expected a point [x, y, z] of three finite numbers, got "
     "[0, 0, 0, 0]"),
    ("[geometry.landmarks]\nrostrum = \"front\"\n",
     "geometry.landmarks.rostrum: expected a point [x, y, z] of three finite numbers, got "
     "'front'"),
    ("[geometry.landmarks]\nrostrum = [0, \"0\", 0]\n",
     "geometry.landmarks.rostrum: expected a point [x, y, z] of three finite numbers, got "
     "[0, '0', 0]"),
    ("[springs]\nform = \"paperish\"\n", "springs.form: expected one of paper, symmetric; got "
                                         "'paperish'"),
    ("springs = 3\n", "springs: expected a table, got 3 (int)"),
    ("base_dir = \"/\"\n", "base_dir: unknown key; allowed here: name, geometry, regions, "
                           "springs, stroke, rigid, calibration, integrator, flow, output, "
                           "case, free"),
    ("[flow]\nspeed = 1\n", "flow.speed: unknown key; allowed here: speed_m_s, rho_kg_m3, "
                            "nu_m2_s"),
    ("preset = \"smoke\"\n[stroke]\npivot = 1.5\n",
     "stroke.pivot: value 1.5 is out of range [0, 1] (docs/scene.md)"),
])
def test_a_bad_value_is_refused_naming_its_path(tmp_path, text, message):
    _refused(tmp_path, text, message)


def test_good_values_are_stored_as_their_kind(tmp_path):
    s = _load(tmp_path, "[springs]\nmu = 1\n[case]\nrefinement = [0, 8]\ngliding = false\n"
                        "[geometry.landmarks]\nrostrum = [1, 2.5, -3]\n")
    assert s.springs.mu == 1.0 and isinstance(s.springs.mu, float)
    assert s.case.refinement == (0, 8) and s.case.gliding is False
    assert s.geometry.landmarks == {"rostrum": (1.0, 2.5, -3.0)}
    assert all(isinstance(v, float) for v in s.geometry.landmarks["rostrum"])


# -- the ranges at their limits --------------------------------------------------------------------

@pytest.mark.parametrize("key, ok, bad, allowed", [
    ("geometry.length_m", [1e-9], [0.0], "(0, inf)"),
    ("geometry.nodes", [400, 2_000_000], [399, 2_000_001], "[400, 2000000]"),
    ("geometry.fluke_span", [0.1, 0.5], [0.0999, 0.5001], "[0.1, 0.5]"),
    ("regions.head_end", [0.0], [-0.01], "[0, 1]"),
    ("regions.tail_start", [1.0], [1.01], "[0, 1]"),
    ("springs.mu", [0.0], [-1e-9], "[0, inf)"),
    ("springs.nu", [0.0], [-1e-9], "[0, inf)"),
    ("springs.k_pivot", [1e-9], [0.0], "(0, inf)"),
    ("stroke.fluke_ramp", [0.0, 4.0], [-0.01, 4.01], "[0, 4]"),
    ("stroke.fluke_joint", [0.0, 0.1], [-0.01, 0.1001], "[0, 0.1]"),
    ("stroke.ramp_cycles", [0.0, 10.0], [-0.01, 10.01], "[0, 10]"),
    ("stroke.head_node", [0.0], [-0.01], "[0, 1]"),
    ("integrator.safety", [1.0, 1e-9], [0.0, 1.01], "(0, 1]"),
    ("integrator.dt_s", [0.0], [-1e-9], "[0, inf)"),
    ("output.cycles", [1], [0], "[1, inf)"),
    ("output.frames_per_cycle", [4], [3], "[4, inf)"),
    ("output.samples_per_cycle", [8], [7], "[8, inf)"),
    ("case.max_non_orthogonality", [1e-9, 89.99], [0.0, 90.0], "(0, 90)"),
    ("case.layers", [0, 20], [-1, 21], "[0, 20]"),
    ("case.flipper_level", [0, 8], [-1, 9], "[0, 8]"),
    ("case.fluke_level", [0, 8], [-1, 9], "[0, 8]"),
    ("case.fluke_clearance", [0.0, 0.2], [-0.01], "[0, inf)"),
    ("case.layer_expansion", [1.0, 3.0], [0.99, 3.01], "[1, 3]"),
    ("case.writes_per_cycle", [1], [0], "[1, inf)"),
    ("case.ranks", [0, 1], [-1], "[0, inf)"),
])
def test_each_range_at_its_limits(tmp_path, key, ok, bad, allowed):
    """... and the error gives the range, as an interval ("(" and ")": that end excluded)."""
    section, name = key.split(".")
    for v in ok:
        s = _load(tmp_path, f"[{section}]\n{name} = {v!r}\n")
        assert getattr(getattr(s, section), name) == v
    for v in bad:
        _refused(tmp_path, f"[{section}]\n{name} = {v!r}\n",
                 f"{key}: value {float(v) if isinstance(v, float) else v!r} is out of range "
                 f"{allowed} (docs/scene.md)")


@pytest.mark.parametrize("text, message", [
    ("[stroke]\nhead_node = 0.4\npivot = 0.4\n",
     "stroke.head_node must lie ahead of (be smaller than) stroke.pivot"),
    ("[regions]\nhead_end = 0.5\ntail_start = 0.5\n",
     "regions.head_end must be smaller than regions.tail_start"),
    ("[case]\nrefinement = [1, 2, 3]\n",
     "case.refinement: expected [min, max] levels with 0 <= min <= max <= 8"),
    ("[case]\nrefinement = [3]\n",
     "case.refinement: expected [min, max] levels with 0 <= min <= max <= 8"),
    ("[case]\nrefinement = [-1, 2]\n",
     "case.refinement: expected [min, max] levels with 0 <= min <= max <= 8"),
    ("[case]\nrefinement = [3, 9]\n",
     "case.refinement: expected [min, max] levels with 0 <= min <= max <= 8"),
    ("[case]\nrefinement = [2, 4]\nflipper_level = 2\n",
     "case.flipper_level = 2 refines nothing (refinement min is 2): give a level above it, "
     "or 0 for none"),
    ("[case]\nrefinement = [2, 4]\nfluke_level = 1\n",
     "case.fluke_level = 1 refines nothing (refinement min is 2): give a level above it, "
     "or 0 for none"),
    ("[case]\nrefinement = [2, 4]\nfluke_edge_level = 2\n",
     "case.fluke_edge_level = 2 refines nothing (refinement min is 2): give a level above it, "
     "or 0 for none"),
])
def test_the_relations_between_keys(tmp_path, text, message):
    _refused(tmp_path, text, message)
    ok = {"stroke": "[stroke]\nhead_node = 0.399\npivot = 0.4\n",
          "regions": "[regions]\nhead_end = 0.49\ntail_start = 0.5\n",
          "case": "[case]\nrefinement = [3, 3]\nflipper_level = 4\n"}[message.split(".")[0]]
    _load(tmp_path, ok)


# -- presets, the folder, replace ------------------------------------------------------------------

def test_presets_layer_over_the_defaults(tmp_path):
    d = default_scene()
    assert d.name == "default" and d.base_dir == "."
    assert d.period_s == pytest.approx(1 / 0.13)
    smoke = load_scene(preset="smoke")
    assert smoke.name == "smoke" and smoke.geometry.nodes == 1200
    assert smoke.springs == d.springs  # what the preset leaves alone
    fine = load_scene(preset="fine")
    assert fine.name == "fine" and fine.case.refinement == (3, 4) and fine.case.ranks == 2
    # what fine.toml leaves alone is default.toml's, not the bare defaults of the code
    assert fine.stroke.velocity_scale == d.stroke.velocity_scale == 1.02856
    assert fine.case.cycles == d.case.cycles == 5.0 and fine.case.time_scheme == "backward"
    assert d.case.dt_s == 0.088 and fine.case.dt_s == 0.044
    # a user's section changes its keys alone: the preset's others stay
    s = _load(tmp_path, "preset = \"smoke\"\n[stroke]\npivot = 0.41\n")
    assert s.stroke.pivot == 0.41 and s.stroke.velocity_scale == smoke.stroke.velocity_scale
    assert s.stroke.ramp_cycles == 0.05
    # a file names its preset, or takes the one given; the folder is the file's own
    s = _load(tmp_path, "[springs]\nmu = 0.9\n")
    assert s.name == "default" and s.springs.mu == 0.9
    assert s.base_dir == str(tmp_path.resolve())
    f = tmp_path / "s.toml"
    assert load_scene(f, preset="smoke").geometry.nodes == 1200
    f.write_text("preset = \"smoke\"\n")
    assert load_scene(f, preset="smoke").name == "smoke"
    with pytest.raises(SceneError, match=rf"^{f}: preset 'smoke' conflicts with 'fine'$"):
        load_scene(f, preset="fine")
    with pytest.raises(SceneError, match=r"^scene: preset: expected one of default, smoke, "
                                         r"fine; got 'huge'$"):
        load_scene(preset="huge")
    with pytest.raises(SceneError, match=rf"^scene file {tmp_path / 'no.toml'} does not exist; "
                                         r"give an existing TOML file$"):
        load_scene(tmp_path / "no.toml")
    f.write_text("[springs\n")
    with pytest.raises(SceneError, match=rf"^{f}: not valid TOML: "):
        load_scene(f)


def test_the_shipped_scenes_are_valid_toml_files():
    for name in ("default", "smoke", "fine"):
        assert (DATA_DIR / "scenes" / f"{name}.toml").is_file()


def test_paths_resolve_against_the_scene_folder(tmp_path):
    s = _load(tmp_path, "")
    assert s.resolve("t.csv") == tmp_path.resolve() / "t.csv"
    assert s.resolve("/abs/t.csv") == Path("/abs/t.csv")
    assert s.resolve("~/t.csv") == Path.home() / "t.csv"
    assert default_scene().resolve("t.csv") == Path(".") / "t.csv"


def test_replace_changes_some_keys_and_checks_them():
    s = default_scene()
    r = s.replace(springs={"mu": 2}, name="mine")
    assert r.springs.mu == 2.0 and r.springs.nu == s.springs.nu and r.name == "mine"
    assert s.springs.mu == 0.5  # frozen: the original untouched
    with pytest.raises(SceneError, match=r"^springs\.mu: value -1\.0 is out of range"):
        s.replace(springs={"mu": -1})
    with pytest.raises(SceneError, match=r"^stroke\.head_node must lie ahead"):
        s.replace(stroke={"head_node": 0.5})
    with pytest.raises(SceneError, match=r"^springs\.muu: unknown key"):
        s.replace(springs={"muu": 1})
    assert math.isclose(s.replace(stroke={"frequency_hz": 0.25}).period_s, 4.0)
    # the section's other keys are the scene's, not the code's bare defaults
    smoke = load_scene(preset="smoke")
    r = smoke.replace(stroke={"pivot": 0.41})
    assert r.stroke.pivot == 0.41 and r.stroke.velocity_scale == smoke.stroke.velocity_scale
    assert r.stroke.ramp_cycles == 0.05 and r.geometry.nodes == 1200
