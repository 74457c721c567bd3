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
    # the tail's profile rises to the gate
    assert v[a.dynamic & (a.surface.s > a.tail_base_s - 0.1)].max() > 0 and v[lm["rostrum"]] > 0
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


# -- the internal step ------------------------------------------------------------------------

import math  # noqa: E402

from adapter.errors import SceneError, UnstableError  # noqa: E402
from adapter.motion.stability import stable_dt  # noqa: E402


def _tether_rate(scene):
    """The smooth stroke's tether frequency (rad/s): 2 pi tether f."""
    return 2 * math.pi * scene.stroke.tether * scene.stroke.frequency_hz


def test_the_default_step_is_a_whole_fraction_of_the_quarter_under_half_the_stable_one(
        smoke_scene, smoke_surface):
    """integrator.dt_s = 0: the largest step that divides the quarter stroke and is at most
    safety (0.5) times the predicted stable step, and for the smooth stroke at most 0.05 over
    the tether's rate; backward Euler (no stable limit) at that time-scale bound alone, and on
    the paper's stroke at half the quarter."""
    quarter = smoke_scene.period_s / 4
    a = Animator(smoke_scene, smoke_surface)
    assert a.stable_dt == pytest.approx(
        stable_dt(a.network, a.rest, "forward_euler", free=a.dynamic))
    target = 0.5 * a.stable_dt
    n = math.ceil(quarter / target)
    assert a.steps_per_quarter == n and a.dt == pytest.approx(quarter / n, rel=1e-15)
    assert a.integrator.dt == a.dt and a.integrator.stable_dt == a.stable_dt
    be = smoke_scene.replace(integrator={"method": "backward_euler"})
    a = Animator(be, smoke_surface)
    assert math.isinf(a.stable_dt) and a.integrator.name == "backward_euler"
    assert a.steps_per_quarter == math.ceil(quarter / (0.05 / _tether_rate(smoke_scene)))
    assert Animator(be.replace(stroke={"reversal": "negate"}), smoke_surface).steps_per_quarter \
        == 2
    # safety 1: the whole quarter in one step
    one = be.replace(stroke={"reversal": "negate"}, integrator={"safety": 1.0})
    assert Animator(one, smoke_surface).steps_per_quarter == 1
    # a slow stroke with a slack tether: the stroke's own rate 2 pi / T bounds the step
    slow = be.replace(stroke={"tether": 0.5})
    a = Animator(slow, smoke_surface)
    assert a.steps_per_quarter == math.ceil(quarter / (0.05 * slow.period_s / (2 * math.pi)))


def test_the_tether_lowers_the_step_of_the_smooth_stroke(smoke_scene, smoke_surface):
    """Symplectic Euler: the smaller of the stable steps with and without the tether; the
    paper's stroke (no tether) the plain one."""
    sc = smoke_scene.replace(integrator={"method": "symplectic_euler"})
    a = Animator(sc, smoke_surface)
    args = (a.network, a.rest, "symplectic_euler")
    plain = stable_dt(*args, free=a.dynamic)
    k = _tether_rate(sc) ** 2
    tethered = stable_dt(*args, free=a.dynamic, tether=(k, 2 * math.sqrt(k)))
    assert tethered < plain
    assert a.stable_dt == pytest.approx(tethered, rel=1e-6)  # ARPACK's tolerance
    paper = Animator(sc.replace(stroke={"reversal": "negate"}), smoke_surface)
    assert paper.stable_dt == pytest.approx(plain, rel=1e-6)
    no_tether = Animator(sc.replace(stroke={"tether": 0.0}), smoke_surface)
    assert no_tether.stable_dt == pytest.approx(plain, rel=1e-6)
    # a slack tether (k = 0.17 /s^2, below 1) still counts: 0.9 % lower
    slack = Animator(sc.replace(stroke={"tether": 0.5}), smoke_surface)
    k = _tether_rate(slack.scene) ** 2
    assert k < 1
    tethered = stable_dt(*args, free=a.dynamic, tether=(k, 2 * math.sqrt(k)))
    assert tethered < (1 - 5e-3) * plain
    assert slack.stable_dt == pytest.approx(tethered, rel=1e-6)


def test_the_stable_step_is_the_spring_moved_nodes_one(smoke_scene, smoke_surface):
    """The fluke gate is kinematic: its nodes' own modes do not limit the step. With tail
    springs ten times the pivot's (the flukes among them) symplectic Euler's stable step on
    the body alone is more than twice the one with the flukes free, with and without the
    tether."""
    sc = smoke_scene.replace(integrator={"method": "symplectic_euler"},
                             springs={"k_tail": 4000.0})
    for tether in (0.0, 4.0):
        a = Animator(sc.replace(stroke={"tether": tether}), smoke_surface)
        k = _tether_rate(a.scene) ** 2
        tk = {"tether": (k, 2 * math.sqrt(k))} if tether else {}
        body = stable_dt(a.network, a.rest, "symplectic_euler", free=a.dynamic, **tk)
        every = stable_dt(a.network, a.rest, "symplectic_euler", **tk)
        assert body > 2 * every
        assert a.stable_dt == pytest.approx(body, rel=1e-6)


def test_a_step_of_the_scene_is_rounded_down_to_divide_the_quarter(smoke_scene, smoke_surface):
    quarter = smoke_scene.period_s / 4
    a = Animator(smoke_scene.replace(integrator={"dt_s": 0.001}), smoke_surface)
    assert a.steps_per_quarter == 1924 and a.dt == pytest.approx(quarter / 1924, rel=1e-15)
    # a step that divides the quarter is kept as it is
    exact = quarter / 2000
    assert Animator(smoke_scene.replace(integrator={"dt_s": exact}),
                    smoke_surface).steps_per_quarter == 2000
    # the predicted stable step itself is allowed
    stable = Animator(smoke_scene, smoke_surface).stable_dt
    a = Animator(smoke_scene.replace(integrator={"dt_s": float(stable)}), smoke_surface)
    assert a.dt <= stable


def test_a_step_beyond_the_stable_one_or_no_stable_step_is_refused(smoke_scene, smoke_surface):
    a = Animator(smoke_scene, smoke_surface)
    too_big = 1.01 * a.stable_dt
    with pytest.raises(UnstableError, match=(
            rf"integrator.dt_s = {too_big:.3g} s is beyond the largest stable step predicted "
            rf"for forward_euler, {a.stable_dt:.3g} s: the run would blow up; lower "
            r"integrator.dt_s, set it to 0 to use the predicted step times integrator.safety, "
            r"or choose another integrator.method")):
        Animator(smoke_scene.replace(integrator={"dt_s": too_big}), smoke_surface)
    with pytest.raises(SceneError, match=(
            r"integrator.method = forward_euler has no stable step with springs.mu = 0.0 and "
            r"springs.nu = 0.0 \(forward Euler needs damping\); raise mu")):
        Animator(smoke_scene.replace(springs={"mu": 0.0, "nu": 0.0}), smoke_surface)


def test_another_integrator_at_the_nearest_step_that_divides_the_quarter(smoke_scene):
    """with_integrator / set_integrator (the studies): the step nearest the one asked that
    divides the quarter, the whale reset to t = 0, no stability check."""
    a = Animator.with_integrator(smoke_scene, "rk4", 0.0104, nodes=1300, mu=0.7)
    quarter = a.period / 4
    assert a.integrator.name == "rk4" and a.network.mu == 0.7
    assert a.scene.geometry.nodes == 1300 and a.scene.springs.mu == 0.7
    assert a.scene.geometry.length_m == smoke_scene.geometry.length_m
    assert a.steps_per_quarter == round(quarter / 0.0104) == 185
    assert a.dt == pytest.approx(quarter / 185, rel=1e-15) == a.integrator.dt
    assert a.integrator.runaway == 2.0 * a.surface.length
    a.advance_to(3)
    a.set_integrator("verlet", 0.0105)  # 183.15 steps: the nearest is 183
    assert a.steps_per_quarter == 183 and a.step_index == 0 and a.time == 0.0
    np.testing.assert_array_equal(a.X, a.rest)
    assert a.integrator.name == "verlet" and a.integrator.reference is a.rest
    assert a.integrator.runaway == 2.0 * a.surface.length
    assert a.integrator.stable_dt == a.stable_dt and a.integrator.network is a.network
    a.set_integrator("rk4", 10.0)  # more than a quarter: one step a quarter
    assert a.steps_per_quarter == 1 and a.dt == pytest.approx(quarter)
    # no method: forward Euler at its predicted step; a method without a step runs at it
    fe = Animator.with_integrator(smoke_scene.replace(integrator={"method": "rk4"}))
    assert fe.integrator.name == "forward_euler" and fe.dt <= 0.5 * fe.stable_dt
    assert fe.scene.geometry.nodes == 1200
    se = Animator.with_integrator(smoke_scene, "symplectic_euler")
    assert se.integrator.name == "symplectic_euler" and se.dt == pytest.approx(fe.dt)


# -- times between and on the steps ------------------------------------------------------------

def test_a_time_within_rounding_of_a_step_is_that_step(smoke_animator):
    a = smoke_animator
    k = 25
    on = a.positions(k * a.dt)
    assert a.step_index == k
    np.testing.assert_array_equal(a.positions(k * a.dt * (1 + 1e-14)), on)
    np.testing.assert_array_equal(a.positions(k * a.dt * (1 - 1e-14)), on)
    assert a.step_index == k  # no step further for a time within rounding of step k
    # the step before the current one, and between them, are still served; before, not
    nxt = a.positions((k + 1) * a.dt)
    np.testing.assert_array_equal(a.positions(k * a.dt), on)
    np.testing.assert_allclose(a.velocity((k + 0.5) * a.dt),
                               0.5 * (a.velocity(k * a.dt) + a.velocity((k + 1) * a.dt)))
    np.testing.assert_array_equal(a.positions((k + 1) * a.dt), nxt)
    with pytest.raises(TimeBehindError, match=(
            rf"t = {(k - 0.5) * a.dt} s is behind the animator \(now at {(k + 1) * a.dt} s\): "
            r"it only marches forward; restore a checkpoint or reset\(\) to go back")):
        a.positions((k - 0.5) * a.dt)
    with pytest.raises(TimeBehindError):
        a.positions((k - 1) * a.dt)  # two steps back
    with pytest.raises(AnimatorTimeError, match=r"time must be finite and >= 0, got -0.1"):
        a.displacement(-0.1)
    with pytest.raises(AnimatorTimeError, match="got inf"):
        a.displacement(float("inf"))


def test_restore_after_a_failure_runs_again(smoke_animator):
    """A checkpoint restored into an animator whose integrator failed: running again, the
    count of steps the checkpoint's; the time 0 after a reset, flat, with the profile."""
    a = smoke_animator
    a.displacement(30 * a.dt)
    ck = a.checkpoint()
    a.integrator.status = "failed"
    a.restore(ck)
    assert a.integrator.status == "running" and a.time == 30 * a.dt
    a.advance_to(31)
    a.reset()
    assert a.integrator.status == "running" and a.integrator.n_steps == 0 and a.time == 0
    np.testing.assert_array_equal(a.X, a.rest)
    with pytest.raises(CheckpointError, match=r"^the checkpoint belongs to another scene "
                                              r"\(step or node count differ\)$"):
        a.restore(dict(ck, X=ck["X"][:-1]))


def test_the_animator_runs_the_surface_it_is_given(smoke_scene, smoke_surface):
    """The surface handed in (here one of 1300 nodes for the 1200-node smoke scene), its
    network in the scene's form, the integrator checking against its rest shape."""
    from adapter.body.geometry import build_surface

    other = build_surface(smoke_scene.replace(geometry={"nodes": 1300}))
    a = Animator(smoke_scene.replace(springs={"form": "symmetric"}), other)
    assert a.surface is other and a.rest.shape == other.points.shape != smoke_surface.points.shape
    assert a.network.form == "symmetric"
    integ = a.integrator
    assert integ.network is a.network and integ.reference is a.rest
    assert integ.runaway == 2.0 * other.length and integ.stable_dt == a.stable_dt
    t = 0.3 * a.period
    assert a.fluke_angle(t) == a.drive.fluke_angle(t)
    assert Animator(smoke_scene).rest.shape == smoke_surface.points.shape  # built if not given
