"""The rigid prescribed motion ([rigid]): the scene keys, the law against hand values and
finite differences, a body without the whale's landmarks, and a real step-server serving it.
"""

import math

import numpy as np
import pytest

from adapter.body.geometry import build_surface
from adapter.body.meshfile import write_surface
from adapter.errors import SceneError
from adapter.motion.animator import Animator, animator_for
from adapter.motion.gait import smootherstep
from adapter.motion.rigid import RigidLaw, RigidMotion
from adapter.scene import load_scene
from adapter.validation.sphere import icosphere

from .wire_client import Client, finished, server_starter


def write_scene(tmp_path, rigid: str, extra: str = "") -> object:
    points, faces = icosphere(1.0, 2)
    write_surface(tmp_path / "ball.stl", points, [faces])
    path = tmp_path / "ball.toml"
    path.write_text(f'[geometry]\nsource = "ball.stl"\nlength_m = 2.0\n[rigid]\nenabled = true\n'
                    f"{rigid}\n{extra}")
    return load_scene(path)


def test_scene_keys_and_their_checks(tmp_path):
    s = write_scene(tmp_path, "frequency_hz = 0.5\ntranslation_m = [0.1, 0, 0]\n"
                              "rotation_axis = [0, 1, 0]")
    assert s.rigid.translation_m == (0.1, 0.0, 0.0) and s.rigid.rotation_axis == (0.0, 1.0, 0.0)
    assert s.period_s == 2.0                       # the rigid motion's period, not the stroke's
    with pytest.raises(SceneError, match="rigid.rotation_axis"):
        write_scene(tmp_path, "rotation_axis = [0, 0, 0]")
    with pytest.raises(SceneError, match="rigid.translation_m: expected a point"):
        write_scene(tmp_path, "translation_m = [1, 2]")
    # still water: only a rigid body with a given flow step
    with pytest.raises(SceneError, match="still water"):
        write_scene(tmp_path, "", "[flow]\nspeed_m_s = 0.0\n[case]\ndt_s = 0.0\n")
    assert write_scene(tmp_path, "", "[flow]\nspeed_m_s = 0.0\n[case]\ndt_s = 0.01\n") \
        .flow.speed_m_s == 0.0
    whale = tmp_path / "whale.toml"
    whale.write_text("[flow]\nspeed_m_s = 0.0\n[case]\ndt_s = 0.01\n")
    with pytest.raises(SceneError, match="still water"):
        load_scene(whale)


def test_translation_and_turn_against_hand_values(tmp_path):
    s = write_scene(tmp_path, "frequency_hz = 0.25\ntranslation_m = [0.1, 0, 0]\n"
                              "rotation_deg = 90\nrotation_phase_deg = 0\n"
                              "rotation_centre_m = [1, 0, 0]")
    law = RigidLaw(s.rigid)
    p = np.array([[2.0, 0.0, 0.0], [1.0, 0.0, 5.0]])
    # t = T/4: sin = 1, x = 0.1 along x; a quarter turn about z through (1, 0, 0) takes
    # (2, 0, 0) to (1, 1, 0) and leaves a point on the axis where it is
    d = law.displacement(p, 1.0)
    assert np.allclose(d, [[0.1 - 1.0, 1.0, 0.0], [0.1, 0.0, 0.0]], atol=1e-12)
    # t = 0: at rest position, moving at A w along x and turning at Theta w
    v = law.velocity(p, 0.0)
    w = 2 * math.pi * 0.25
    assert np.allclose(v, [[0.1 * w, math.pi / 2 * w, 0.0], [0.1 * w, 0.0, 0.0]], atol=1e-12)


def test_velocity_is_the_derivative_of_the_displacement(tmp_path):
    s = write_scene(tmp_path, "frequency_hz = 0.3\ntranslation_m = [0.1, -0.2, 0.05]\n"
                              "translation_phase_deg = 20\nrotation_deg = 35\n"
                              "rotation_phase_deg = 90\nrotation_axis = [0.2, 1, 0.3]\n"
                              "rotation_centre_m = [0.3, 0.1, 0]\nramp_cycles = 1.5")
    law = RigidLaw(s.rigid)
    p = np.random.default_rng(0).normal(size=(50, 3))
    h = 1e-6
    for t in (0.0, 0.7, 2.4, 5.0, 9.1):
        fd = (law.displacement(p, t + h) - law.displacement(p, max(t - h, 0.0))) / (
            h + min(h, t))
        assert np.abs(fd - law.velocity(p, t)).max() < 1e-6
        # a rigid motion keeps every distance
        moved = p + law.displacement(p, t)
        assert np.allclose(np.linalg.norm(moved[1:] - moved[0], axis=1),
                           np.linalg.norm(p[1:] - p[0], axis=1), atol=1e-12)


def test_ramp_starts_from_rest():
    assert smootherstep(0.0, 2.0) == (0.0, 0.0, 0.0)
    assert smootherstep(2.0, 2.0) == (1.0, 0.0, 0.0) and smootherstep(5.0, 0.0) == (1.0, 0.0, 0.0)
    r, dr, _ = smootherstep(1.0, 2.0)
    assert r == 0.5 and dr == pytest.approx(30 / 16 / 2)    # 30 u^2 (1-u)^2 / T at u = 1/2


def test_a_body_without_landmarks_gets_no_whale_regions(tmp_path):
    s = write_scene(tmp_path, "translation_m = [0.1, 0, 0]")
    surface = build_surface(s)
    assert not surface.is_whale and surface.landmarks == {}
    assert surface.length == pytest.approx(2.0, rel=1e-9)
    assert set(surface.triangle_regions().tolist()) == {0}          # all BODY
    assert isinstance(animator_for(s), RigidMotion)
    assert isinstance(animator_for(load_scene(preset="smoke")), Animator)
    # without [rigid] a mesh file still needs the whale's landmarks
    with pytest.raises(Exception, match="landmarks"):
        build_surface(s.replace(rigid={"enabled": False}))


def test_prepare_case_refines_no_flippers_or_flukes(tmp_path):
    from adapter.foam.case import FLIPPERS_STL, FLUKE_BLADE_STL, prepare_case
    from adapter.foam.dictionaries import parsed_dict

    s = write_scene(tmp_path, "translation_m = [0.1, 0, 0]",
                    "[flow]\nspeed_m_s = 0.0\n[case]\ndt_s = 0.04\n")
    case = tmp_path / "case"
    prepare_case(s, case, scene_file=tmp_path / "ball.toml")
    tri = case / "constant" / "triSurface"
    assert not (tri / FLIPPERS_STL).exists() and not (tri / FLUKE_BLADE_STL).exists()
    regions = parsed_dict(case / "system" / "snappyHexMeshDict")["castellatedMeshControls"][
        "refinementRegions"]
    assert "flippers" not in regions and "flukeBlade" not in regions


def test_the_step_server_serves_the_rigid_motion(tmp_path):
    s = write_scene(tmp_path, "frequency_hz = 0.25\ntranslation_m = [0.1, 0, 0.02]\n"
                              "rotation_deg = 10\nrotation_axis = [0, 1, 0]\n"
                              "rotation_phase_deg = 90")
    motion = RigidMotion(s)
    surf = motion.surface
    # patch points on the surface's triangles: the affine rigid field interpolates exactly
    rng = np.random.default_rng(1)
    tri = rng.integers(0, len(surf.triangles), 300)
    w = rng.dirichlet([1.0, 1.0, 1.0], 300)
    pts = np.einsum("pk,pkd->pd", w, surf.points[surf.triangles[tri]])
    start, stop_all = server_starter(s, motion, first_client_timeout=30)
    case = tmp_path / "case"
    case.mkdir()
    try:
        srv = start(case)
        c = Client(case)
        c.hello(pts)
        law = RigidLaw(s.rigid)
        for t in (0.05, 0.1, 0.15, 0.1, 1.3):     # a step back, as a restart asks
            _, disp = c.request(t)
            assert np.abs(disp - law.displacement(pts, t)).max() < 1e-12
        c.bye()
        assert finished(srv) == 0
    finally:
        stop_all()


def test_a_rigid_body_has_no_dry_run_and_says_so(tmp_path, capsys):
    from adapter.cli import main

    write_scene(tmp_path, "translation_m = [0.1, 0, 0]")
    code = main(["dry-run", "--scene", str(tmp_path / "ball.toml"), "--out",
                 str(tmp_path / "out")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "none of the whale's landmarks" in err[0]
