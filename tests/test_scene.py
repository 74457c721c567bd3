"""The scene file: defaults, presets, overrides, and errors that name their path."""

import pytest

from adapter.errors import SceneError
from adapter.scene import load_scene


def test_defaults_are_the_papers_setting():
    s = load_scene()
    assert s.name == "default"
    assert s.geometry.length_m == 15.0 and s.geometry.nodes == 11272
    assert s.integrator.method == "forward_euler"
    assert s.springs.form == "paper"
    assert s.stroke.pivot == pytest.approx(0.40)
    # Strouhal number f A / U near 0.3 (A = fluke-tip peak to peak)
    st = s.stroke.frequency_hz * s.calibration.fluke_amplitude * s.geometry.length_m
    assert st / s.flow.speed_m_s == pytest.approx(0.3, abs=0.02)


def test_presets_and_user_file_layer(tmp_path):
    f = tmp_path / "mine.toml"
    f.write_text('preset = "smoke"\n[springs]\nmu = 0.8\n[stroke]\nfluke_table = "angles.csv"\n')
    s = load_scene(f)
    assert s.name == "smoke" and s.geometry.nodes == 1200  # from the preset
    assert s.springs.mu == 0.8 and s.springs.nu == 0.05  # user value over the defaults
    assert s.resolve(s.stroke.fluke_table) == tmp_path / "angles.csv"


@pytest.mark.parametrize(
    "text, path",
    [
        ("[springs]\nmuu = 1\n", r"springs\.muu: unknown key"),
        ("[springs]\nmu = -1\n", r"springs\.mu: value -1\.0 is out of range"),
        ("[springs]\nmu = \"a lot\"\n", r"springs\.mu: expected a number"),
        ("[geometry]\nnodes = 1.5\n", r"geometry\.nodes: expected a whole number"),
        ("[integrator]\nmethod = \"euler\"\n", r"integrator\.method: expected one of"),
        ("[stroke]\npivot = 1.4\n", r"stroke\.pivot"),
        ("[stroke]\nhead_node = 0.5\n", r"stroke\.head_node must lie ahead"),
        ("[regions]\nhead_end = 0.6\n", r"regions\.head_end must be smaller"),
        ("[case]\nrefinement = [3, 1]\n", r"case\.refinement"),
        ("[case]\nlayers = -1\n", r"case\.layers: value -1 is out of range"),
        ("[case]\nlayers = 2.5\n", r"case\.layers: expected a whole number"),
        ("[case]\nfirst_layer_m = 0\n", r"case\.first_layer_m: value 0\.0 is out of range"),
        ("[case]\nlayer_expansion = 0.8\n", r"case\.layer_expansion"),
        ("[geometry.landmarks]\nrostrum = [0, 0]\n", r"geometry\.landmarks\.rostrum"),
        ("nonsense = 1\n", r"nonsense: unknown key"),
        ("[springs\n", r"not valid TOML"),
        ("preset = \"huge\"\n", r"preset: expected one of"),
    ],
)
def test_bad_scene_names_the_path(tmp_path, text, path):
    f = tmp_path / "bad.toml"
    f.write_text(text)
    with pytest.raises(SceneError, match=path) as info:
        load_scene(f)
    assert str(f) in str(info.value)


def test_missing_file_is_named(tmp_path):
    with pytest.raises(SceneError, match="does not exist"):
        load_scene(tmp_path / "nope.toml")
