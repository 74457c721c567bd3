"""The stroke drive (adapter/motion/drive.py) and the integrators carrying it, on a small rod
instead of the whale: 41 stations of three nodes along 10 m, the tail base at 8 m, the fluke
behind it. Truths from outside the modules: the fluke table file's formula (-28 cos 2 pi phase
degrees), the smoothstep polynomials and the closed-form target r(t) sin(w t) / w written out
here, finite differences in time, a rotation about the hinge written out here, the paper's
quarter events (docs/stroke.md), and a rod without springs, whose exact motion under the smooth
stroke is its target. Fast (about a second): the mutation tests of drive.py and integrators.py
run it once per mutant (docs/mutation.md)."""

import math

import numpy as np
import pytest

from adapter.body.springs import network_from_edges
from adapter.errors import GeometryError
from adapter.motion.drive import StrokeDrive
from adapter.motion.gait import velocity_profile
from adapter.motion.integrators import METHODS, make_integrator
from adapter.scene import load_scene

T = 8.0                 # the stroke period (s)
TAIL_BASE = 0.8         # s of the tail base


def _rod(stiffness=40.0):
    """(rest (N, 3), s (N,), edges): three rows of nodes along x, a triangle at every station."""
    x = np.arange(41) * 0.25
    rows = [(0.0, -0.2, 0.0), (0.0, 0.2, 0.0), (0.0, 0.0, 0.3)]
    rest = np.array([[xi + dx, dy, dz] for xi in x for dx, dy, dz in rows])
    edges = []
    for k in range(41):
        a = 3 * k
        edges += [(a, a + 1), (a + 1, a + 2), (a, a + 2)]
        if k < 40:
            edges += [(a + r, a + 3 + r) for r in range(3)] + [(a, a + 4), (a + 1, a + 5)]
    return rest, rest[:, 0] / 10.0, np.array(edges)


def _scene(**stroke):
    base = {"frequency_hz": 1 / T, "ramp_cycles": 0.5, "tether": 4.0, "fluke_joint": 0.0,
            "reversal": "smooth", "fluke_table": "default", "fluke_ramp": 0.25,
            "fluke_angle_scale": 1.0, "velocity_scale": 1.0}
    return load_scene(preset="smoke").replace(stroke={**base, **stroke})


def _drive(scene=None, stiffness=40.0, mu=0.5, nu=0.05, dynamic=None):
    scene = scene or _scene()
    rest, s, edges = _rod()
    dynamic = s <= TAIL_BASE if dynamic is None else dynamic
    net = network_from_edges(rest, edges, np.full(len(rest), stiffness), mu, nu)
    profile = velocity_profile(s, dynamic, scene.stroke, TAIL_BASE)
    return StrokeDrive(scene, rest, s, TAIL_BASE, dynamic, profile, net), net


def _quintic(x):
    x = min(max(x, 0.0), 1.0)
    return x**3 * (10 - 15 * x + 6 * x * x)


def _cubic(x):
    x = min(max(x, 0.0), 1.0)
    return x * x * (3 - 2 * x)


def _table_deg(phase):
    return -28.0 * math.cos(2 * math.pi * phase)  # adapter/data/fluke_angles.csv's formula


# -- the hinge -------------------------------------------------------------------------------

def test_the_hinge_is_the_band_of_body_nodes_just_ahead_of_the_tail_base():
    d, _ = _drive()
    # s > 0.8 - 0.03 on the body: the stations at x = 7.75 and 8 (s 0.775 and 0.8)
    assert d.hinge_nodes.tolist() == list(range(3 * 31, 3 * 33))
    np.testing.assert_allclose(d.hinge0, [7.875, 0.0, 0.1], atol=1e-15)
    assert d.tether == pytest.approx(((2 * math.pi * 0.5) ** 2, 2 * 2 * math.pi * 0.5))
    # critically damped: c^2 = 4 k
    assert d.tether[1] ** 2 == pytest.approx(4 * d.tether[0])


def test_the_hinge_band_is_0_03_L_deep():
    """The stations shifted along s: 0.765 is 0.035 L ahead of the tail base, outside the
    band; 0.79 inside it; 0.815 is on the fluke."""
    scene = _scene()
    rest, s, edges = _rod()
    s = s + 0.015
    dynamic = s <= TAIL_BASE
    net = network_from_edges(rest, edges, np.full(len(rest), 40.0), 0.5, 0.05)
    d = StrokeDrive(scene, rest, s, TAIL_BASE, dynamic, np.zeros(len(s)), net)
    assert d.hinge_nodes.tolist() == [93, 94, 95]
    assert d.reversal == "smooth" and d.smooth


def test_too_few_hinge_nodes_is_a_named_geometry_error():
    scene = _scene()
    rest, s, edges = _rod()
    net = network_from_edges(rest, edges, np.full(len(rest), 40.0), 0.5, 0.05)
    dynamic = s <= 0.7  # nothing on the body within 0.03 L of the tail base at 0.8
    with pytest.raises(GeometryError, match="too few body nodes just ahead of the tail base "
                                            "to carry the fluke hinge; check "
                                            "geometry.landmarks.tail_base"):
        StrokeDrive(scene, rest, s, TAIL_BASE, dynamic, np.zeros(len(s)), net)
    # two nodes are too few, three enough
    dynamic = s <= TAIL_BASE
    dynamic[3 * 31:3 * 33 - 2] = False  # two hinge nodes left
    with pytest.raises(GeometryError, match="too few"):
        StrokeDrive(scene, rest, s, TAIL_BASE, dynamic, np.zeros(len(s)), net)
    dynamic[3 * 33 - 3] = True  # three
    assert len(StrokeDrive(scene, rest, s, TAIL_BASE, dynamic, np.zeros(len(s)),
                           net).hinge_nodes) == 3


# -- the fluke angle ------------------------------------------------------------------------------

@pytest.mark.parametrize("t", [0.3, 1.7, 3.9, 4.0, 5.2, 9.1, 13.0])
def test_smooth_fluke_angle_is_the_ramped_table(t):
    """Smooth: the table's spline times the quintic ramp over ramp_cycles (0.5 T = 4 s); its
    rate the time derivative (central difference)."""
    d, _ = _drive()
    angle, rate = d.fluke_angle(t)
    assert math.degrees(angle) == pytest.approx(_quintic(t / 4.0) * _table_deg(t / T), abs=2e-3)
    h = 1e-5
    fd = (d.fluke_angle(t + h)[0] - d.fluke_angle(t - h)[0]) / (2 * h)
    assert rate == pytest.approx(fd, rel=1e-6, abs=1e-9)


@pytest.mark.parametrize("t", [0.3, 1.1, 2.5, 5.1, 9.7])
def test_paper_fluke_angle_is_the_linear_table_with_the_cubic_ramp(t):
    """Negate: the 15 deg table interpolated linearly, ramped in by the cubic over fluke_ramp
    (0.25 T = 2 s); the rate is the derivative inside a table segment."""
    d, _ = _drive(_scene(reversal="negate", fluke_table="quadrature15"))
    assert not d.smooth and d.reversal == "negate" and d.ramp_s == pytest.approx(2.0)
    ph = np.arange(30) / 30
    deg = -15 * np.cos(2 * np.pi * ph)
    linear = np.interp(t / T % 1.0, np.r_[ph, 1.0], np.r_[deg, deg[0]])
    angle, rate = d.fluke_angle(t)
    assert math.degrees(angle) == pytest.approx(_cubic(t / 2.0) * linear, abs=1e-3)
    h = 1e-6
    fd = (d.fluke_angle(t + h)[0] - d.fluke_angle(t - h)[0]) / (2 * h)
    assert rate == pytest.approx(fd, rel=1e-6)


# -- the stage coefficients --------------------------------------------------------------------

@pytest.mark.parametrize("t", [0.5, 3.95, 6.0])
def test_stage_coefficients_are_the_time_law_at_every_stage_time(t):
    """Rows (G', G, D, theta, theta') at t + c dt: D the closed form, G and G' its time
    derivatives by differences, theta the ramped table; the first row's angle is not needed
    (the state handed in already has the gate placed)."""
    d, _ = _drive()
    dt = 0.1
    stages = (0.0, 0.5, 0.5, 1.0)
    rows = d.stage_coefficients(t, dt, stages)
    assert rows.shape == (4, 5)
    w = 2 * math.pi / T

    def D(x):
        return _quintic(x / 4.0) * math.sin(w * x) / w

    h = 1e-4
    for row, c in zip(rows, stages, strict=True):
        ts = t + c * dt
        g = (D(ts + h) - D(ts - h)) / (2 * h)
        g_dot = (D(ts + h) - 2 * D(ts) + D(ts - h)) / h**2
        np.testing.assert_allclose(row[:3], [g_dot, g, D(ts)], rtol=1e-5, atol=1e-7)
    np.testing.assert_array_equal(rows[0, 3:], [0.0, 0.0])
    for k in (1, 2, 3):
        np.testing.assert_allclose(rows[k, 3:], d.fluke_angle(t + stages[k] * dt), rtol=1e-14)
    assert rows[3, 3] != rows[1, 3]


def test_the_paper_stroke_has_no_force_only_the_gate():
    d, _ = _drive(_scene(reversal="negate"))
    rows = d.stage_coefficients(1.0, 0.2, (0.0, 1.0))
    np.testing.assert_array_equal(rows[:, :3], 0.0)
    np.testing.assert_allclose(rows[1, 3:], d.fluke_angle(1.2), rtol=1e-14)
    moving, profile, damping = d.stage_arrays[1:4]
    assert len(moving) == len(profile) == len(damping) == 0


# -- the gate --------------------------------------------------------------------------------------

def test_place_turns_the_fluke_about_the_hinge_and_its_velocity_is_the_time_derivative():
    d, _ = _drive()
    rest = d.rest
    fluke = ~d.dynamic
    hinge = d.hinge_nodes
    # the body somewhere, moving: the hinge band lifted 0.1 m and sliding at 0.2 m/s forward
    lift = np.zeros_like(rest)
    lift[:, 2] = 0.1
    vel = np.zeros_like(rest)
    vel[:, 0] = 0.2

    def placed(t):
        X, V = rest + lift + vel * (t - 5.0), vel.copy()
        d.place(X, V, t)
        return X, V

    t = 5.0
    X, V = placed(t)
    theta = math.radians(_table_deg(t / T))
    c, s = math.cos(theta), math.sin(theta)
    R = np.array([[c, 0, -s], [0, 1, 0], [s, 0, c]])
    hinge_now = X[hinge].mean(axis=0)
    np.testing.assert_allclose(hinge_now, d.hinge0 + [0, 0, 0.1], atol=1e-14)
    arm0 = rest[fluke] - d.hinge0
    # to the spline's error against the formula (under 3e-6 rad with 30 rows)
    np.testing.assert_allclose(X[fluke], hinge_now + arm0 @ R.T, atol=1e-5)
    np.testing.assert_allclose(X[d.dynamic], (rest + lift)[d.dynamic])  # the body untouched
    # the tip raised above the hinge by its arm times sin(theta) (theta > 0 raises +x to +z)
    h = 1e-6
    fd = (placed(t + h)[0] - placed(t - h)[0]) / (2 * h)
    np.testing.assert_allclose(V[fluke], fd[fluke], atol=1e-7)
    assert np.abs(V[fluke, 2]).max() > 0.05


def test_a_joint_draws_the_peduncle_between_the_springs_and_the_turn_about_the_hinge():
    """fluke_joint 0.1 L (1 m on the rod): the state is the paper's (the springs up to the
    tail base at 8 m, the gate behind it), and the surface shown draws the stations from
    s = 0.7 on as the blend of where the state has them and where the fluke's turn about the
    hinge (the mean of the stations at 7.75 and 8 m) would carry them, written out here: the
    joint's first station (7 m) is the state's, its middle (7.5 m) the quintic's half of
    each, the tail base and the fluke the turn; the body ahead and the state are untouched;
    the velocities are the shown positions' time derivative."""
    rest, s, _ = _rod()
    d, _ = _drive(_scene(fluke_joint=0.1))
    assert d.hinge_nodes.tolist() == list(range(3 * 31, 3 * 33))  # the paper's band
    assert d.joint_nodes.tolist() == list(range(3 * 29, 3 * 41))  # s > 0.7

    def state(t):
        X = rest.copy()
        X[:, 2] += (0.1 + 0.05 * rest[:, 0]) * (1 + 0.1 * (t - 7.0))  # a lifted, tilted body
        X[:, 0] += 0.01 * np.sin(rest[:, 0]) * t                      # bent along x
        V = np.zeros_like(rest)
        V[:, 2] = 0.1 * (0.1 + 0.05 * rest[:, 0])
        V[:, 0] = 0.01 * np.sin(rest[:, 0])
        d.place(X, V, t)
        return X, V

    def shown(t):
        X, V = state(t)
        kept = X.copy(), V.copy()
        Xs, Vs = d.shape(X, V, t)
        np.testing.assert_array_equal(X, kept[0])  # the state is not touched
        np.testing.assert_array_equal(V, kept[1])
        return Xs, Vs, X

    t = 7.0
    Xs, Vs, X = shown(t)
    theta = math.radians(_table_deg(t / T))
    c, s_ = math.cos(theta), math.sin(theta)
    R = np.array([[c, 0, -s_], [0, 1, 0], [s_, 0, c]])
    hinge0 = np.array([7.875, 0.0, 0.1])
    hinge_now = X[3 * 31:3 * 33].mean(axis=0)

    def turned(k):
        return hinge_now + R @ (rest[k] - hinge0)

    for station, share in ((20, None), (28, None), (29, _quintic(0.25)), (30, _quintic(0.5)),
                           (31, _quintic(0.75)), (32, 1.0), (36, 1.0), (40, 1.0)):
        for k in range(3 * station, 3 * station + 3):
            want = X[k] if share is None else (1 - share) * X[k] + share * turned(k)
            # the spline's error against the table's formula: under 3e-6 rad
            np.testing.assert_allclose(Xs[k], want, atol=2e-5, err_msg=f"station {station}")
    assert np.abs(Xs[3 * 30:3 * 31] - X[3 * 30:3 * 31]).max() > 0.01  # the joint is drawn
    h = 1e-6
    fd = (shown(t + h)[0] - shown(t - h)[0]) / (2 * h)
    np.testing.assert_allclose(Vs, fd, atol=1e-6)
    # the paper's hinge draws nothing: the state is the surface
    d0, _ = _drive()
    X, V = state(t)
    assert d0.shape(X, V, t)[0] is X


# -- the paper's events ---------------------------------------------------------------------------

def test_the_quarter_events_of_the_paper_stroke():
    """At step n, a multiple of the quarter's q steps: up profile (quarter 0), every body
    velocity negated (1), down profile (2), negated (3); the fluke's velocities are the gate's
    and stay; nothing between quarters, nothing at all for the smooth stroke."""
    d, _ = _drive(_scene(reversal="negate"))
    q = 7
    rng = np.random.default_rng(3)
    V0 = rng.standard_normal((len(d.rest), 3))
    dyn = d.dynamic
    up = np.zeros((dyn.sum(), 3))
    up[:, 2] = d.profile[dyn]
    for n, expected in ((0, up), (q, -V0[dyn]), (2 * q, -up), (3 * q, -V0[dyn]), (4 * q, up),
                        (9 * q, -V0[dyn]), (q + 1, V0[dyn]), (2 * q - 1, V0[dyn])):
        V = V0.copy()
        d.event(V, n, q)
        np.testing.assert_array_equal(V[dyn], expected, err_msg=f"step {n}")
        np.testing.assert_array_equal(V[~dyn], V0[~dyn])
    smooth, _ = _drive()
    V = V0.copy()
    smooth.event(V, 0, q)
    np.testing.assert_array_equal(V, V0)


# -- the integrators carrying the drive -------------------------------------------------------

@pytest.mark.parametrize("method", sorted(METHODS))
def test_a_rod_without_springs_follows_its_target(method):
    """Springs off (k 1e-9), damping and fluid resistance on: the smooth stroke's push cancels
    the velocity force on the target and the tether holds the nodes on it, so from rest the
    exact motion is the target itself, profile r(t) sin(w t) / w upward on every body node;
    each method follows it to its own error over 180 steps of 25 ms (through the ramp's
    end). No damping between nodes (mu): the body nodes next to the pitching fluke would
    feel it."""
    scene = _scene()
    d, net = _drive(scene, stiffness=1e-9, mu=0.0, nu=0.5)
    dt = 0.025
    integ = make_integrator(method, net.forces, dt, network=net, reference=d.rest,
                            runaway=100.0)
    X, V = d.rest.copy(), np.zeros_like(d.rest)
    d.place(X, V, 0.0)
    w = 2 * math.pi / T
    dyn = d.dynamic
    tol = {"forward_euler": 4e-3, "symplectic_euler": 4e-3, "backward_euler": 4e-3,
           "verlet": 1e-4, "rk4": 1e-6}[method]
    for n in range(180):
        X, V = integ.step(X, V, n * dt, drive=d)
        d.place(X, V, (n + 1) * dt)
    t = 180 * dt
    target = d.profile[dyn] * _quintic(t / 4.0) * math.sin(w * t) / w
    np.testing.assert_allclose(X[dyn, 2] - d.rest[dyn, 2], target, rtol=0, atol=tol)
    np.testing.assert_allclose(X[dyn, :2], d.rest[dyn, :2], rtol=0, atol=tol)
    assert np.abs(target).max() > 0.3  # it moved
    np.testing.assert_allclose(V[dyn, 2], d.profile[dyn] * math.cos(w * t), rtol=0,
                               atol=20 * tol)


def _stroke_rhs(d, net, X, V, t):
    """The right-hand side of the driven rod at (X, V, t), assembled here: the network's force
    plus, on every body node, the push profile G'(t) + nu profile G(t) (the target's
    acceleration less the network's velocity force on it, -nu profile G with mu = 0) and the
    tether
    -k (x - x_target) - c (v - v_target), with D, G, G' of the closed form by differences."""
    w = 2 * math.pi / T
    k, c = d.tether

    def D(x):
        return _quintic(x / 4.0) * math.sin(w * x) / w

    h = 1e-4
    g = (D(t + h) - D(t - h)) / (2 * h)
    g_dot = (D(t + h) - 2 * D(t) + D(t - h)) / h**2
    F = net.forces(X, V)
    p = d.profile
    dyn = d.dynamic
    F[dyn] -= k * (X[dyn] - d.rest[dyn]) + c * V[dyn]
    F[dyn, 2] += g_dot * p[dyn] + g * net.nu * p[dyn] + k * D(t) * p[dyn] + c * g * p[dyn]
    return F


def test_backward_euler_with_the_tether_solves_its_implicit_equations():
    """No springs and no damping between nodes (mu = 0): the driven rod's right-hand side is
    affine in (X, V), so the linearised step, with the tether taken implicitly and the push at
    the step's end, is backward Euler exactly: V1 = V + dt F(X1, V1, t + dt), X1 = X + dt V1
    on every node, at a step beyond the tether's explicit limit; two drives of other
    body nodes in turn through one integrator, each as a fresh integrator steps it."""
    d, net = _drive(stiffness=1e-9, mu=0.0, nu=0.5)
    rng = np.random.default_rng(7)
    X = d.rest + 0.05 * rng.standard_normal(d.rest.shape)
    V = 0.2 * rng.standard_normal(d.rest.shape)
    dt, t = 0.4, 2.5
    integ = make_integrator("backward_euler", net.forces, dt, network=net)
    X1, V1 = integ.step(X, V, t, drive=d)
    dyn = d.dynamic
    F1 = _stroke_rhs(d, net, X1, V1, t + dt)
    # every node: the fluke's rows (no stroke force on them) are the method's too
    np.testing.assert_allclose(X1, X + dt * V1, rtol=0, atol=1e-13)
    np.testing.assert_allclose(V1, V + dt * F1, rtol=0, atol=1e-6)
    assert np.abs(V1 - V)[dyn].max() > 0.1
    # another drive (the tail base further forward: other moving nodes) through the same
    # integrator, and back
    scene = _scene()
    rest, s, _ = _rod()
    other_dyn = s <= 0.6
    other = StrokeDrive(scene, rest, s, 0.6, other_dyn,
                        velocity_profile(s, other_dyn, scene.stroke, 0.6), net)
    for drv in (other, d):
        new = make_integrator("backward_euler", net.forces, dt, network=net)
        for a, b in zip(integ.step(X, V, t, drive=drv), new.step(X, V, t, drive=drv),
                        strict=True):
            np.testing.assert_array_equal(a, b)
    # the step's time defaults to 0
    np.testing.assert_array_equal(integ.step(X, V, drive=d)[1], integ.step(X, V, 0.0,
                                                                          drive=d)[1])


def test_a_table_of_its_own_is_read_from_the_scene_folder(tmp_path):
    """stroke.fluke_table names a CSV relative to the scene file's folder; smooth: its
    periodic spline, scaled by fluke_angle_scale. Two rows, 10 deg at phase 0 and -10 at 0.5:
    by symmetry the spline is flat at both rows, so on the first half it is the Hermite cubic
    10 - 20 (3 u^2 - 2 u^3), u = 2 phase: 0 at a quarter, falling at 60 deg per cycle there
    (the straight line's 40), times 2."""
    import dataclasses

    (tmp_path / "mine.csv").write_text("phase,angle_deg\n0.0,10\n0.5,-10\n")
    scene = dataclasses.replace(_scene(fluke_table="mine.csv", fluke_angle_scale=2.0,
                                       ramp_cycles=0.0), base_dir=str(tmp_path))
    d, _ = _drive(scene)
    assert math.degrees(d.fluke_angle(0.0)[0]) == pytest.approx(20.0)
    assert math.degrees(d.fluke_angle(T / 2)[0]) == pytest.approx(-20.0)
    assert math.degrees(d.fluke_angle(T / 4)[0]) == pytest.approx(0.0, abs=1e-12)
    assert math.degrees(d.fluke_angle(T / 4)[1]) * T == pytest.approx(-120.0)
    assert math.degrees(d.fluke_angle(T / 8)[0]) == pytest.approx(
        2 * (10 - 20 * (3 * 0.25**2 - 2 * 0.25**3)))
