"""``whale-adapter paraview``: real ParaView (pvbatch under xvfb-run) on smoke outputs.

The rendering tests run the whole command on a one-cycle smoke dry-run and on a coupled smoke
case (real pimpleFoam + plugin + step-server), then check every picture against the geometry:
the whale's surface at the picture's time (the adapter's VTP files) is projected with the camera
that report.json records, by the pinhole / parallel projection written out here, and the pixels
inside that silhouette must differ from the pixels in a ring around it. The state file is loaded
back in pvpython. Skipped when ParaView (pvbatch) is not installed (``make paraview-deps``); the
coupled case is skipped without OpenFOAM or the built plugin.

The time choice, the input checks and the missing-ParaView message are tested without ParaView.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image, ImageDraw
from scipy.ndimage import distance_transform_edt

from adapter.errors import AdapterError
from adapter.reports import paraview_report as R

from .conftest import missing


def needs_paraview(test):
    """Marks a test paraview (skipped when pvbatch is not installed) and slow."""
    return pytest.mark.paraview(pytest.mark.slow(test))


#: silhouette erosion / ring (pixels) for the pixel statistics
ERODE_PX = 5
RING_PX = (10, 40)


def _cli(*args: str, cwd=None) -> subprocess.CompletedProcess:
    proc = subprocess.run([sys.executable, "-m", "adapter.cli", *args], capture_output=True,
                          text=True, cwd=cwd)
    assert proc.returncode == 0, f"whale-adapter {' '.join(args)} failed:\n{proc.stdout}\n" \
                                 f"{proc.stderr}"
    return proc


# --------------------------------------------------------------------------------------------
# without ParaView


def test_choose_times_quarter_strokes_of_last_cycle():
    T = 4.0
    times = list(np.round(np.arange(0, 2 * T + 1e-9, T / 8), 9))
    assert R.choose_times(times, T) == [4.0, 5.0, 6.0, 7.0]


def test_choose_times_few_or_short_runs():
    assert R.choose_times([0.2, 0.4, 0.6], 7.7) == [0.2, 0.4, 0.6]
    times = [0.1 * k for k in range(1, 11)]  # 1 s of a 7.7 s period: evenly spaced
    assert R.choose_times(times, 7.7) == [0.1, 0.4, 0.7000000000000001, 1.0]
    assert R.choose_times(times, None) == R.choose_times(times, 7.7)


def test_input_checks(tmp_path):
    with pytest.raises(AdapterError, match="whale-adapter dry-run"):
        R.input_kind(tmp_path)
    with pytest.raises(AdapterError, match="not a folder"):
        R.input_kind(tmp_path / "nothing")
    (tmp_path / "whale.pvd").write_text('<DataSet timestep="0.5" file="a.vtp"/>')
    assert R.input_kind(tmp_path) == "surface"
    assert R.pvd_times(tmp_path / "whale.pvd") == [0.5]
    case = tmp_path / "case"
    (case / "system").mkdir(parents=True)
    (case / "system" / "controlDict").write_text("")
    with pytest.raises(AdapterError, match="without a mesh"):
        R.input_kind(case)
    (case / "constant" / "polyMesh").mkdir(parents=True)
    assert R.input_kind(case) == "case" and (case / "case.foam").is_file()
    with pytest.raises(AdapterError, match="no written time"):
        R.case_layout(case)
    (case / "0").mkdir()
    (case / "processor0" / "0.25").mkdir(parents=True)
    assert R.case_layout(case) == ("Decomposed", [0.25])
    (case / "0.5").mkdir()
    assert R.case_layout(case) == ("Reconstructed", [0.5])
    # a parallel run that reconstructed only its last time: the ranks' times are the run's
    (case / "processor0" / "0.5").mkdir()
    (case / "processor0" / "0.75").mkdir()
    assert R.case_layout(case) == ("Decomposed", [0.25, 0.5, 0.75])


def test_missing_paraview_says_how_to_install(monkeypatch):
    monkeypatch.setattr(R.shutil, "which", lambda name: None)
    with pytest.raises(R.ParaViewError, match="make paraview-deps"):
        R.find_paraview()


def test_missing_paraview_is_found_before_anything_is_written(monkeypatch, tmp_path):
    case = tmp_path / "case"
    (case / "system").mkdir(parents=True)
    (case / "system" / "controlDict").write_text("")
    (case / "constant" / "polyMesh").mkdir(parents=True)
    monkeypatch.setattr(R.shutil, "which", lambda name: None)
    with pytest.raises(R.ParaViewError, match="make paraview-deps"):
        R.render(case)
    assert not (case / "case.foam").exists() and not (case / "paraview").exists()


def test_pressure_in_pascal_from_the_case_record(monkeypatch, tmp_path):
    (tmp_path / "system").mkdir()
    assert R.read_rho(tmp_path) is None
    (tmp_path / "system" / "controlDict").write_text(
        "functions\n{\n    forces\n    {\n        rho rhoInf;\n        rhoInf 1000;\n    }\n}\n")
    assert R.read_rho(tmp_path) == 1000.0                        # an older case: controlDict
    (tmp_path / "adapter-case.json").write_text(json.dumps({"rho_kg_m3": 1025.0}))
    assert R.read_rho(tmp_path) == 1025.0
    monkeypatch.setattr(R, "find_paraview", lambda: ("xvfb-run", "pvbatch"))
    cmd = R.pvbatch_command(tmp_path, tmp_path / "out", "case", [0.1], case_type="Reconstructed",
                            rho=1025.0)
    assert cmd[cmd.index("--rho") + 1] == "1025.0"


# --------------------------------------------------------------------------------------------
# with ParaView: the pictures


def _pvd_files(pvd: Path) -> dict:
    text = pvd.read_text()
    return {float(t): pvd.parent / f
            for t, f in re.findall(r'timestep="([^"]+)"[^>]*file="([^"]+)"', text)}


def _read_triangles(vtp: Path) -> tuple[np.ndarray, np.ndarray]:
    """(points (N, 3), triangles (M, 3)) of a VTP surface (pyvista: meshio does not read VTP)."""
    import pyvista as pv

    mesh = pv.read(str(vtp)).triangulate()
    return np.asarray(mesh.points), np.asarray(mesh.faces).reshape(-1, 4)[:, 1:]


def project(points: np.ndarray, cam: dict, size) -> np.ndarray:
    """Pixel (column, row) of each (N, 3) point seen by the camera ``cam`` (report.json)."""
    W, H = size
    pos, foc = np.asarray(cam["position"]), np.asarray(cam["focal_point"])
    d = foc - pos
    d /= np.linalg.norm(d)
    right = np.cross(d, cam["view_up"])
    right /= np.linalg.norm(right)
    up = np.cross(right, d)
    if cam["parallel_projection"]:
        rel = points - foc
        k = (H / 2) / cam["parallel_scale"]
        x, y = rel @ right * k, rel @ up * k
    else:
        rel = points - pos
        k = (H / 2) / np.tan(np.radians(cam["view_angle"]) / 2) / (rel @ d)
        x, y = rel @ right * k, rel @ up * k
    return np.column_stack([W / 2 + x, H / 2 - y])


def silhouette(points: np.ndarray, triangles: np.ndarray, cam: dict, size) -> np.ndarray:
    """Boolean (H, W) mask of the pixels the triangulated surface covers."""
    px = project(points, cam, size)
    img = Image.new("L", tuple(size), 0)
    draw = ImageDraw.Draw(img)
    for tri in triangles:
        draw.polygon([tuple(px[i]) for i in tri], fill=255)
    return img


def pixel_stats(png: Path, surface_vtp: Path, cam: dict, size, offset=(0, 0, 0)) -> dict:
    """Pixel statistics inside the whale's projected silhouette (moved by ``offset``, m) and
    in a ring around it: mean colours, their distance, fractions of white pixels."""
    rgb = np.asarray(Image.open(png).convert("RGB"), dtype=float)
    assert rgb.shape[:2] == (size[1], size[0])
    points, tris = _read_triangles(surface_vtp)
    points = points + np.asarray(offset, dtype=float)
    mask = np.asarray(silhouette(points, tris, cam, size)) > 0
    inside = distance_transform_edt(mask) > ERODE_PX
    outside = distance_transform_edt(~mask)
    ring = (outside > RING_PX[0]) & (outside <= RING_PX[1])
    white = np.all(rgb > 245, axis=2)
    return {
        "image_std": float(rgb.std()),
        "colours": len(np.unique(rgb.astype(np.uint32) @ np.array([1 << 16, 1 << 8, 1],
                                                                     dtype=np.uint32))),
        "inside_px": int(inside.sum()),
        "inside_mean": rgb[inside].mean(axis=0),
        "ring_mean": rgb[ring].mean(axis=0),
        "inside_white": float(white[inside].mean()),
        "ring_white": float(white[ring].mean()),
        "distance": float(np.linalg.norm(rgb[inside].mean(axis=0) - rgb[ring].mean(axis=0))),
    }


def _load_state(state: Path) -> dict:
    """LoadState in pvpython under xvfb-run: every source's type, cell count and file name."""
    snippet = (
        "import json, sys\n"
        "from paraview import simple as pvs\n"
        "pvs.LoadState(sys.argv[1])\n"
        "t = pvs.GetActiveView().ViewTime\n"
        "out = {}\n"
        "for (name, _), s in pvs.GetSources().items():\n"
        "    s.UpdatePipeline(t)\n"
        "    f = s.GetProperty('FileName')\n"
        "    out[name] = [s.GetXMLName(), s.GetDataInformation().GetNumberOfCells(),\n"
        "                 f.GetElement(0) if f is not None else None]\n"
        "print('STATE ' + json.dumps(out))\n"
    )
    script = state.parent / "_load_state.py"
    script.write_text(snippet)
    # Xvfb now and then fails to come up for a client ("bad X server connection"): that is
    # the virtual screen, not the state file, so try again on another display number
    for attempt in range(3):
        proc = subprocess.run(["xvfb-run", "-a", "-n", str(700 + 37 * attempt + os.getpid() % 97),
                               "-s", R.XVFB_SCREEN, "pvpython", str(script), str(state)],
                              capture_output=True, text=True, cwd=state.parent,
                              env=R.pvbatch_env())
        if R.X_FAILURE not in proc.stdout + proc.stderr:
            break
    line = [s for s in proc.stdout.splitlines() if s.startswith("STATE ")]
    assert proc.returncode == 0 and line, f"LoadState failed:\n{proc.stdout}\n{proc.stderr}"
    return json.loads(line[0][len("STATE "):])


@pytest.fixture(scope="module")
def dry_report(tmp_path_factory):
    out = tmp_path_factory.mktemp("paraview-dry")
    _cli("dry-run", "--preset", "smoke", "--cycles", "1", "--out", str(out), "--no-progress")
    _cli("paraview", str(out))
    return out, json.loads((out / "paraview" / "report.json").read_text())


@pytest.fixture(scope="module")
def case_report(tmp_path_factory):
    reason = missing("openfoam") or missing("plugin") or (
        "mpirun is not on PATH" if shutil.which("mpirun") is None else None)
    if reason:
        pytest.skip(f"{reason}: no coupled case to draw")
    case = tmp_path_factory.mktemp("paraview-case") / "smoke"
    _cli("run-case", "--preset", "smoke", "--case", str(case))
    _cli("paraview", str(case))
    return case, json.loads((case / "paraview" / "report.json").read_text())


@needs_paraview
@pytest.mark.parametrize("which", ["dry", "case"])
def test_pictures_show_the_whale(which, request):
    folder, report = request.getfixturevalue(f"{which}_report")
    out = folder / "paraview"
    pvd = folder / "whale.pvd" if which == "dry" else folder / "adapter" / "whale.pvd"
    surfaces = _pvd_files(pvd)
    views = {img["view"] for img in report["images"]}
    assert views == {"side", "angled"}
    assert len(report["images"]) == 2 * len({img["time"] for img in report["images"]})
    if which == "dry":
        # one cycle, 8 frames per cycle: the quarter strokes
        T = json.loads((folder / "summary.json").read_text())["period_s"]
        assert [img["time"] for img in report["images"][::2]] == pytest.approx(
            [0, T / 4, T / 2, 3 * T / 4], abs=1e-6)
    for img in report["images"]:
        png = out / img["file"]
        assert png.is_file() and png.stat().st_size > 10_000, png
        t = min(surfaces, key=lambda s: abs(s - img["time"]))
        assert abs(t - img["time"]) < 1e-6, f"no adapter surface at t = {img['time']}"
        s = pixel_stats(png, surfaces[t], img["camera"], report["size"])
        msg = f"{img['file']}: {s}"
        # not blank: many colours, real contrast
        assert s["image_std"] > 20 and s["colours"] > 500, msg
        # the whale's silhouette is large and its pixels differ from the ring around it
        assert s["inside_px"] > 0.02 * report["size"][0] * report["size"][1], msg
        assert s["distance"] > 40, msg
        if which == "dry":
            # white background: the silhouette is drawn, the ring around it is empty
            assert s["inside_white"] < 0.02 and s["ring_white"] > 0.9, msg
            # control: the same silhouette 6 m higher up falls on empty background
            moved = pixel_stats(png, surfaces[t], img["camera"], report["size"], (0, 0, 6.0))
            assert moved["inside_white"] > 0.9, f"{img['file']} moved: {moved}"
        else:
            # the slice fills the background: no white around the whale or on it
            assert s["inside_white"] < 0.05 and s["ring_white"] < 0.05, msg


@needs_paraview
@pytest.mark.parametrize("which", ["dry", "case"])
def test_animation_and_state(which, request):
    folder, report = request.getfixturevalue(f"{which}_report")
    out = folder / "paraview"
    anim = report["animation"]
    frames = sorted((out / "animation").glob("frame.*.png"))
    assert len(frames) == anim["frames"] == len(report["times"])
    assert (out / anim["video"]).stat().st_size > 1000
    # no absolute path of the folder: the state opens when the folder moves (relative names
    # resolve against pvpython's working folder, the state's own: _load_state)
    assert str(folder) not in (out / "whale.pvsm").read_text()
    state = _load_state(out / "whale.pvsm")
    if which == "dry":
        kind, cells, fname = state["whale.pvd"]
        assert kind == "PVDReader" and fname == "../whale.pvd"
        import pyvista as pv

        first = next(iter(_pvd_files(folder / "whale.pvd").values()))
        assert cells == pv.read(str(first)).n_cells
    else:
        assert state["case.foam"][0] == "OpenFOAMReader"
        assert state["case.foam"][2] == "../case.foam"
        assert state["whale patch"][0] == "ExtractBlock" and state["whale patch"][1] > 50
        assert state["mid-plane slice y=0"][0] == "Cut"
        assert state["mid-plane slice y=0"][1] > 100
        assert state["adapter whale.pvd"][0] == "PVDReader"
        assert state["adapter whale.pvd"][1] > state["whale patch"][1]
        # pressure in Pa, said in the colour bar's title
        assert report["p_unit"] == "Pa" and report["rho_kg_m3"] == 1025.0
        assert "p (Pa)" in report["p_title"]
        assert "whale p in Pa" in state
    # the folder moved: its copy's state opens the copy's data
    moved = folder.parent / f"{folder.name}-moved"
    shutil.copytree(folder, moved)
    assert _load_state(moved / "paraview" / "whale.pvsm") == state
    shutil.rmtree(moved)


@needs_paraview
def test_the_pressure_colours_span_the_pictures_times(case_report, tmp_path):
    """The whale's pressure is coloured over the pictures' times, not over every written time
    (the start-up's accelerating inflow lifts the default case's whole patch by 40 kPa, which
    left the pictures of the periodic state one colour); the range over all times stays in
    report.json. Truth: the patch's point pressure read by pyvista (VTK's OpenFOAM reader,
    as ParaView's), times rho."""
    import pyvista as pv

    from adapter.scene import load_scene

    case, _ = case_report
    rho = load_scene(preset="smoke").flow.rho_kg_m3
    reader = pv.OpenFOAMReader(str(case / "case.foam"))
    reader.disable_all_patch_arrays()
    reader.enable_patch_array("patch/whale")
    reader.disable_patch_array("internalMesh")
    p = {}
    for t in reader.time_values[1:]:
        reader.set_active_time_value(t)
        p[t] = rho * np.asarray(reader.read()["boundary"]["whale"].point_data["p"])
    first = min(p)
    shown = float(np.abs(p[first]).max())
    everywhere = (min(v.min() for v in p.values()), max(v.max() for v in p.values()))
    # the control: the first written time alone has a smaller largest |p| than all of them
    assert shown < 0.95 * max(abs(everywhere[0]), abs(everywhere[1]))
    out = tmp_path / "pv"
    _cli("paraview", str(case), "--times", repr(first), "--out", str(out), "--no-animation")
    report = json.loads((out / "report.json").read_text())
    assert report["colour_ranges"]["p"] == pytest.approx([-shown, shown], rel=1e-5)
    assert report["data_range"]["p"] == pytest.approx(list(everywhere), rel=1e-5)
