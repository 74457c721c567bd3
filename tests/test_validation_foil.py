"""The foil validation cases (adapter/validation/naca0012.py, flapping.py, foil.py): the
reference arithmetic against hand values, and each case's quick mode on its tiny mesh."""

import json
import math

import numpy as np
import pytest

from adapter.errors import CaseError
from adapter.validation import flapping, foil, naca0012
from adapter.validation.suite import run_suite

from .conftest import NEEDS_FOAM_AND_PLUGIN


def test_naca0012_profile_is_12_percent_thick_at_0_3_chord_with_a_sharp_edge():
    # the NACA 0012 is 0.12 c thick at 0.3 c; TMR's sharp-edged copy is scaled by 1/1.00893
    assert 2 * foil.half_thickness(0.3) == pytest.approx(0.12, rel=0.01)
    x = np.linspace(0, 1, 20001)
    # TMR: "approximately 11.894 %" (the 12.0036 % of the open-edged formula / 1.00893)
    assert 2 * foil.half_thickness(x).max() == pytest.approx(0.11894, abs=5e-5)
    assert foil.half_thickness(1.0) == pytest.approx(0.0, abs=1e-7)
    assert foil.half_thickness(0.0) == 0.0
    # the TMR's own rescaled polynomial (naca0012_val.html)
    for x in (0.05, 0.3, 0.9):
        tmr = 0.594689181 * (0.298222773 * x**0.5 - 0.127125232 * x - 0.357907906 * x**2
                             + 0.291984971 * x**3 - 0.105174606 * x**4)
        assert foil.half_thickness(x) == pytest.approx(tmr, rel=1e-7)


def test_expansion_ratio_of_a_hand_grading():
    # cells 1, 2, 4 fill 7: last / first = 4
    assert foil.expansion_ratio(1.0, 7.0, 3) == pytest.approx(4.0, rel=1e-9)
    assert foil.expansion_ratio(2.0, 6.0, 3) == 1.0
    with pytest.raises(CaseError, match="no geometric grading"):
        foil.expansion_ratio(10.0, 1.0, 2)


def test_ittc57_line_at_re_6e6_on_both_sides():
    # 0.075 / (log10 6e6 - 2)^2 = 0.075 / 4.77815^2
    assert naca0012.friction_line(6e6, 1.0) == pytest.approx(0.0032850, rel=1e-4)
    assert naca0012.friction_line(6e6, 2.03) == pytest.approx(2.03 * 0.0032850, rel=1e-4)


def test_drag_and_lift_turn_with_the_stream():
    a = 10.0
    u = (math.cos(math.radians(a)), math.sin(math.radians(a)))
    cd, cl = naca0012.coefficients(3 * u[0], 3 * u[1], a, 2.0)
    assert (cd, cl) == (pytest.approx(1.5), pytest.approx(0.0, abs=1e-12))
    cd, cl = naca0012.coefficients(-u[1], u[0], a, 0.5)
    assert (cd, cl) == (pytest.approx(0.0, abs=1e-12), pytest.approx(2.0))


def test_thrust_coefficient_and_efficiency_of_a_hand_signal():
    # Fx = -2 + 3 sin: mean thrust 2 N; P = 5 + 4 cos: mean 5 W; U = 1.5 m/s
    t = np.linspace(0, 1, 400, endpoint=False)
    fx = -2 + 3 * np.sin(2 * np.pi * t)
    power = 5 + 4 * np.cos(2 * np.pi * t)
    ct, eta = flapping.thrust_and_efficiency(fx, power, q_area=0.5, speed=1.5)
    assert ct == pytest.approx(4.0)
    assert eta == pytest.approx(2 * 1.5 / 5)
    # a foil that takes energy from the flow has no efficiency (NaN, null in JSON)
    assert math.isnan(flapping.thrust_and_efficiency(fx, -power, 0.5, 1.5)[1])
    with pytest.raises(CaseError, match="finite"):
        flapping.thrust_and_efficiency(fx[:3], [1.0, np.nan, 2.0], 0.5, 1.5)


def test_pitch_amplitude_and_frequency_of_read_et_al_motion():
    # theta0 = atan(pi St) - 15 deg; f = St U / (2 h0)
    assert flapping.pitch_amplitude_deg(0.3) == pytest.approx(28.3038, abs=1e-3)
    assert flapping.pitch_amplitude_deg(0.4) == pytest.approx(36.4881, abs=1e-3)
    assert flapping.frequency_hz(0.3) == pytest.approx(0.2)
    with pytest.raises(CaseError, match="under alpha_max"):
        flapping.pitch_amplitude_deg(0.05)


def test_read_reference_interpolates_the_digitised_curves():
    ct, eta = flapping.read_reference(0.3)
    assert ct == pytest.approx(0.3108 + (0.3 - 0.2504) / (0.3030 - 0.2504) * (0.3939 - 0.3108),
                               rel=1e-9)
    assert eta == pytest.approx(0.6409 + (0.3 - 0.2517) / (0.3007 - 0.2517) * (0.6 - 0.6409),
                                rel=1e-9)
    assert flapping.read_reference(0.6) == (None, None)


def test_block_mesh_entries_use_every_vertex_and_close_the_c_grid():
    e = foil.block_mesh_entries(naca0012.QUICK)
    blocks = [line for line in e["blocks"].splitlines() if line.startswith("hex")]
    assert len(blocks) == 6
    faces = dict(zip(e["boundary"][::2], e["boundary"][1::2], strict=True))
    assert len(faces[foil.WALL]["faces"]) == 4
    assert len(faces[foil.FARFIELD]["faces"]) == 8
    assert len(faces["frontAndBack"]["faces"]) == 12


def _finite_json(path):
    """validation.json parses with no NaN (json refuses them with allow_nan False)."""
    text = path.read_text()
    json.loads(text, parse_constant=lambda c: (_ for _ in ()).throw(ValueError(c)))
    return json.loads(text)


def _case_marks(f):
    """The marks of a test that runs OpenFOAM with the plugin (conftest)."""
    for m in NEEDS_FOAM_AND_PLUGIN:
        f = m(f)
    return f


@_case_marks
def test_naca0012_quick_mode_runs_both_angles(tmp_path):
    results = run_suite(tmp_path, ["naca0012"], quick=True, echo=lambda s: None)
    r = results[0]
    assert r.cells == naca0012.QUICK.cells == 256
    names = [c.name for c in r.checks]
    assert "Cd at 0 deg" in names and "Cl at 10 deg" in names
    by = {c.name: c for c in r.checks}
    # the parts add up to the total, and the free stream at 10 deg gives lift
    total = by["Cd at 0 deg"].measured
    assert by["  pressure part Cd_p at 0 deg"].measured + \
        by["  viscous part Cd_v at 0 deg"].measured == pytest.approx(total, rel=1e-6)
    assert by["Cl at 10 deg"].measured > 0.2
    assert abs(by["Cl at 0 deg"].measured) < 0.01
    doc = _finite_json(tmp_path / "validation.json")
    assert doc["cases"][0]["name"] == "naca0012"
    for a in (0, 10):
        assert (tmp_path / "naca0012" / f"alpha{a}" / "postProcessing" / "loads").is_dir()


@_case_marks
def test_flapping_quick_mode_is_served_by_the_step_server(tmp_path):
    from adapter.body.meshfile import read_surface
    from adapter.body.polygons import triangulate
    from adapter.coupling.mapping import PatchMap
    from adapter.foam.foamascii import read_boundary, read_faces, read_points
    from adapter.foam.loads import read_loads

    results = run_suite(tmp_path, ["flapping"], quick=True, echo=lambda s: None)
    r = results[0]
    case = tmp_path / "flapping" / "St0.2"
    # the server's surface is the mesh's wall: every patch point is a node of the STL
    stl_points, stl_faces = read_surface(case / "foil.stl")
    mesh = case / "constant" / "polyMesh"
    patch = read_boundary(mesh / "boundary")[foil.WALL]
    faces = read_faces(mesh / "faces")[patch["startFace"]:patch["startFace"] + patch["nFaces"]]
    patch_points = read_points(mesh / "points")[np.unique(np.concatenate(faces))]
    assert len(stl_points) == len(patch_points)
    pm = PatchMap(patch_points, stl_points, triangulate(stl_points, stl_faces), length=1.0)
    assert pm.max_distance < 1e-6          # the STL is single precision
    served = (case / "log.server").read_text()
    steps = flapping.STEPS_PER_CYCLE[True] * flapping.CYCLES[True]
    assert f"{round(steps)} requests served" in served
    # the foil moved: it put power into the water, heaved and pitched by the law
    loads = read_loads(case)
    assert np.abs(loads[f"{foil.WALL}:P"]).max() > 0
    by = {c.name: c for c in r.checks}
    assert by["  pitch amplitude theta0 at St 0.2"].measured == pytest.approx(17.1419, abs=1e-3)
    _finite_json(tmp_path / "validation.json")


def test_a_case_that_is_not_a_foils_is_refused_not_removed(tmp_path):
    (tmp_path / "system").mkdir()
    (tmp_path / "system" / "controlDict").write_text("keep me")
    with pytest.raises(CaseError, match="not a validation foil's"):
        foil.prepare_foil_case(tmp_path, naca0012.QUICK, speed=1.0, nu=1e-6, rho=1025.0,
                               alpha_deg=0.0, turbulence=True)
    assert (tmp_path / "system" / "controlDict").read_text() == "keep me"
