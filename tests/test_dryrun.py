"""The dry-run: every file it writes, read back; and the default scene's acceptance figures."""

import json
import subprocess
import sys
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from adapter.motion import dryrun
from adapter.scene import load_scene

PAPER_NODES, PAPER_EDGES = 11272, 22510


@pytest.fixture(scope="module")
def smoke_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("dry")
    cmd = [sys.executable, "-m", "adapter.cli", "dry-run", "--preset", "smoke", "--cycles", "2",
           "--out", str(out), "--no-progress"]
    res = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stderr
    return out, res.stdout


@pytest.mark.slow
def test_summary_has_every_figure(smoke_run):
    out, stdout = smoke_run
    s = json.loads((out / "summary.json").read_text())
    for key in ("nodes", "edges", "period_s", "peak_to_peak_m", "phase_deg", "amplitude_min_at",
                "closure_error_m", "volume_change", "steps", "wall_s"):
        assert key in s, key
    for kp in dryrun.KEYPOINTS:
        assert np.isfinite(s["peak_to_peak_m"][kp]) and np.isfinite(s["phase_deg"][kp])
    assert s["phase_deg"]["fluke_tip"] == 0.0
    assert s["cycles"] == 2 and len(s["closure_error_per_cycle_m"]) == 2
    assert "fluke tip" in stdout


@pytest.mark.slow
def test_keypoints_csv_reads_back(smoke_run):
    out, _ = smoke_run
    scene = load_scene(preset="smoke")
    lines = (out / "keypoints.csv").read_text().splitlines()
    assert lines[0] == "t,rostrum,flipper,tail_base,fluke_tip"
    data = np.loadtxt(out / "keypoints.csv", delimiter=",", skiprows=1)
    assert data.shape == (2 * scene.output.samples_per_cycle + 1, 5)
    assert np.all(np.diff(data[:, 0]) > 0) and data[-1, 0] == pytest.approx(2 * scene.period_s)
    np.testing.assert_allclose(data[0, 1:], 0, atol=1e-12)  # starts flat
    # the summary's amplitudes are those of the CSV's last cycle
    s = json.loads((out / "summary.json").read_text())
    last = data[:, 0] >= scene.period_s - 1e-9
    assert np.ptp(data[last, 4]) == pytest.approx(s["peak_to_peak_m"]["fluke_tip"], rel=1e-6)


@pytest.mark.slow
def test_pvd_and_frames_read_back(smoke_run):
    out, _ = smoke_run
    scene = load_scene(preset="smoke")
    root = ET.parse(out / "whale.pvd").getroot()
    sets = root.findall("./Collection/DataSet")
    assert len(sets) == 2 * scene.output.frames_per_cycle + 1
    times = [float(d.get("timestep")) for d in sets]
    assert times == sorted(times) and times[0] == 0.0
    import pyvista as pv

    first = pv.read(out / sets[0].get("file"))
    mid = pv.read(out / sets[len(sets) // 3].get("file"))
    assert {"displacement", "velocity"} <= set(mid.point_data.keys())
    np.testing.assert_allclose(first.point_data["displacement"], 0, atol=1e-12)
    # positions are rest + displacement
    np.testing.assert_allclose(mid.points - mid.point_data["displacement"], first.points,
                               atol=1e-9)
    assert np.abs(mid.point_data["displacement"]).max() > 0.1


@pytest.mark.slow
@pytest.mark.parametrize("name", ["keypoints.png", "frames.png"])
def test_pictures_are_not_blank(smoke_run, name):
    out, _ = smoke_run
    import matplotlib.image as mpimg

    img = mpimg.imread(out / name)
    assert img.shape[0] > 300 and img.shape[1] > 600
    grey = img[..., :3].mean(axis=2)
    # a picture, not a flat colour: a good share of pixels differ from the background
    background = np.median(grey)
    assert (np.abs(grey - background) > 0.1).mean() > 0.03


@pytest.mark.slow
def test_default_dry_run_reproduces_the_stroke(tmp_path):
    """The paper's stroke on the default whale: the first round's acceptance figures (two
    cycles, ~1 minute)."""
    scene = load_scene().replace(stroke={"reversal": "negate", "fluke_table": "quadrature15",
                                         "velocity_scale": 0.92052})
    s = dryrun.run(scene, tmp_path, progress=False, write_files=False)
    assert abs(s["nodes"] / PAPER_NODES - 1) < 0.02
    assert abs(s["edges"] / PAPER_EDGES - 1) < 0.02
    assert abs(s["phase_deg"]["rostrum"]) < 30  # head and flukes in phase
    assert abs(s["phase_deg"]["flipper"]) > 150  # flipper region out of phase
    assert 0.3 <= s["amplitude_min_at"] <= 0.5
    assert abs(s["fluke_tip_error"]) < 0.10
    assert s["volume_change"] < 0.01
    assert s["measured_period_s"] == pytest.approx(scene.period_s, rel=0.05)
