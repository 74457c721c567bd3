"""The animator: the stroke's events, the fluke gate against its table, and the motion
depending on time alone."""

import numpy as np
import pytest

from adapter.errors import AnimatorTimeError, CheckpointError, TimeBehindError
from adapter.motion.animator import Animator
from adapter.motion.gait import load_fluke_table, rotation_y


def test_displacement_depends_on_time_alone(smoke_scene, smoke_surface):
    T = smoke_scene.period_s
    target = 0.61 * T
    a = Animator(smoke_scene, smoke_surface)
    b = Animator(smoke_scene, smoke_surface)
    # a: asked at many odd times on the way; b: asked once
    for t in np.linspace(0, target, 37)[:-1] + 0.0123:
        a.displacement(t)
    np.testing.assert_array_equal(a.displacement(target), b.displacement(target))
    # and a repeat of the same time gives the same bits
    np.testing.assert_array_equal(a.displacement(target), b.displacement(target))


def test_between_steps_is_linear_and_backwards_is_refused(smoke_animator):
    a = smoke_animator
    t0 = 40 * a.dt
    x0, x1 = a.displacement(t0), a.displacement(t0 + a.dt)
    np.testing.assert_allclose(a.displacement(t0 + 0.25 * a.dt), x0 + 0.25 * (x1 - x0),
                               rtol=1e-12, atol=1e-12)
    a.displacement(t0 + 10 * a.dt)
    with pytest.raises(ValueError, match="only marches forward") as info:
        a.displacement(t0)
    assert isinstance(info.value, TimeBehindError)      # named, and still a ValueError
    with pytest.raises(AnimatorTimeError, match="finite and >= 0"):
        a.displacement(float("nan"))
    # a checkpoint of another whale (another step) is refused by name
    foreign = dict(a.checkpoint(), dt=np.float64(2 * a.dt))
    with pytest.raises(CheckpointError, match="another scene"):
        a.restore(foreign)


def test_checkpoint_restore_is_exact(smoke_animator):
    a = smoke_animator
    a.displacement(0.5)
    ck = a.checkpoint()
    later = a.displacement(1.2)
    a.restore(ck)
    np.testing.assert_array_equal(a.displacement(1.2), later)
    a.reset()
    np.testing.assert_array_equal(a.displacement(0.0), np.zeros_like(later))


def test_stroke_events(paper_animator):
    a = paper_animator
    n = a.steps_per_quarter
    dyn = a.dynamic
    np.testing.assert_allclose(a.V[dyn, 2], a.profile[dyn])  # upward profile at t = 0
    np.testing.assert_allclose(a.V[dyn, :2], 0)
    a.advance_to(n - 1)
    X, V = a.X.copy(), a.V.copy()
    expected_v = V[dyn] + a.dt * a.network.forces(X, V)[dyn]
    a.advance_to(n)  # the top: one more step, then every velocity negated
    np.testing.assert_allclose(a.V[dyn], -expected_v, rtol=1e-12, atol=1e-12)
    a.advance_to(2 * n)  # back at equilibrium: the downward profile replaces the velocities
    np.testing.assert_allclose(a.V[dyn, 2], -a.profile[dyn])
    np.testing.assert_allclose(a.V[dyn, :2], 0)


def test_profile_has_head_and_tail_with_flipper_region_against_them(smoke_animator):
    a = smoke_animator
    lm = a.surface.landmarks
    v = a.profile
    assert v[lm["tail_base"]] > 0 and v[lm["rostrum"]] > 0
    assert v[lm["flipper_left"]] < 0 and v[lm["flipper_right"]] < 0
    assert np.all(v[a.fluke] == 0)  # the fluke is the gate's, not the springs'


def test_fluke_follows_the_table(smoke_scene, paper_animator):
    a = paper_animator
    table = load_fluke_table("quadrature15")
    T = smoke_scene.period_s
    for t in (0.4 * T, 0.77 * T, 1.31 * T):  # past the start-up ramp (0.25 T)
        t = round(t / a.dt) * a.dt  # on an internal step (between steps: interpolated)
        X = a.positions(t)
        hinge = X[a.hinge_nodes].mean(axis=0)
        expected = hinge + (a.rest[a.fluke] - a.hinge0) @ rotation_y(table(t / T)).T
        np.testing.assert_allclose(X[a.fluke], expected, atol=1e-9)
        # the angle of the tip, read back from the geometry, is the table's
        tip = a.surface.landmarks["fluke_tip_left"]
        arm0 = a.rest[tip] - a.hinge0
        arm = X[tip] - hinge
        ang = np.arctan2(arm[2], arm[0]) - np.arctan2(arm0[2], arm0[0])
        assert ang == pytest.approx(table(t / T), abs=1e-9)


def test_table_interpolates_linearly_and_wraps():
    table = load_fluke_table("default")
    ph, ang = table.phase, table.angle
    mid = 0.5 * (ph[3] + ph[4])
    assert table(mid) == pytest.approx(0.5 * (ang[3] + ang[4]))
    assert table(1.0 + mid) == pytest.approx(table(mid))
    assert len(ph) == 30


def test_bad_table_is_named(tmp_path):
    from adapter.errors import SceneError

    f = tmp_path / "t.csv"
    f.write_text("phase,angle_deg\n0.0,1\n0.5,nan\n")
    with pytest.raises(SceneError, match="NaN"):
        load_fluke_table(str(f))
    f.write_text("phase,angle_deg\n0.5,1\n0.2,2\n")
    with pytest.raises(SceneError, match="rise strictly"):
        load_fluke_table(str(f))


def test_every_quarter_event_and_the_wrap_into_the_next_cycle(paper_animator):
    """The paper's cycle (docs/stroke.md): at the start of quarter 0 the upward profile, at
    1 every velocity negated, at 2 the downward profile, at 3 negated again, then quarter 0
    of the next cycle. Checked at each of the six event steps of 1.5 cycles, against one
    forward Euler step written out here: positions where the step puts them (an event does
    not move the whale), velocities as the event leaves them, and the next step's positions
    moved by those velocities."""
    a = paper_animator
    assert a.scene.integrator.method == "forward_euler"
    n_q, dt, dyn = a.steps_per_quarter, a.dt, a.dynamic
    up = np.zeros_like(a.V[dyn])
    up[:, 2] = a.profile[dyn]
    for q in range(1, 7):
        n = q * n_q
        a.advance_to(n - 1)
        X, V = a.X.copy(), a.V.copy()
        x_new = X + dt * V
        v_new = V + dt * a.network.forces(X, V)  # the velocity the step reaches, before the event
        a.advance_to(n)
        np.testing.assert_allclose(a.X[dyn], x_new[dyn], rtol=0, atol=1e-12)
        expected = {0: up, 1: -v_new[dyn], 2: -up, 3: -v_new[dyn]}[q % 4]
        np.testing.assert_allclose(a.V[dyn], expected, rtol=0, atol=1e-12, err_msg=f"quarter {q}")
        X, V = a.X.copy(), a.V.copy()
        a.advance_to(n + 1)
        np.testing.assert_allclose(a.X[dyn], (X + dt * V)[dyn], rtol=0, atol=1e-12)
