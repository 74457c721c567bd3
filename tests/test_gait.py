"""The stroke's pure parts (adapter/motion/gait.py) without a whale: the velocity profile, the
fluke table and its interpolants, the start-up ramps, the smooth stroke's time law, the gate's
rotation and the bending joint. Truths from outside the module: values computed by hand from
the formulas of docs/stroke.md, closed forms (sin, cos, the smoothstep polynomials), finite
differences, and the table file's own formula. Fast (well under a second): the mutation tests
of gait.py run this file once per mutant (docs/mutation.md)."""

import math
from types import SimpleNamespace

import numpy as np
import pytest

from adapter.errors import SceneError
from adapter.motion.gait import (
    FlukeTable,
    SmoothStroke,
    joint_blend,
    load_fluke_table,
    ramp,
    rotation_y,
    smootherstep,
    velocity_profile,
)


def _stroke(**kw):
    """A stroke with the default scene's shape; velocity_scale 1.5 so that it shows."""
    base = dict(pivot=0.4, tail_speed=1.0, head_speed=0.3, tail_exponent=2.0,
                head_exponent=1.0, head_node=0.2, recoil="none", velocity_scale=1.5)
    return SimpleNamespace(**{**base, **kw})


# nodes along the body (fraction of L); the tail base at 0.8, the last node on the fluke
S = np.array([0.0, 0.1, 0.2, 0.3, 0.4, 0.6, 0.8, 0.9])
DYNAMIC = S <= 0.8


# -- the velocity profile (docs/stroke.md, "The profile") -----------------------------------

def test_profile_by_hand_with_the_flipper_dip():
    # head, w = (0.4 - s) / 0.4 and d = w(0.2) = 0.5: 0.3 w (w - 0.5) / 0.5;
    # tail, u = (s - 0.4) / 0.4: 1.0 u^2; all times 1.5; the fluke node 0
    v = velocity_profile(S, DYNAMIC, _stroke(), tail_base_s=0.8)
    by_hand = 1.5 * np.array([0.3, 0.3 * 0.75 * 0.25 / 0.5, 0.0, 0.3 * 0.25 * -0.25 / 0.5,
                              0.0, 0.25, 1.0, 0.0])
    np.testing.assert_allclose(v, by_hand, rtol=1e-14, atol=1e-15)


def test_profile_exponents_and_speeds_by_hand():
    st = _stroke(tail_speed=2.0, head_speed=0.5, tail_exponent=3.0, head_exponent=2.0,
                 head_node=0.1, velocity_scale=1.0)
    v = velocity_profile(S, DYNAMIC, st, tail_base_s=0.8)
    d = 0.75  # w at s = 0.1

    def head(w):
        return 0.5 * w**2 * (w - d) / (1 - d)

    by_hand = [head(1.0), 0.0, head(0.5), head(0.25), 0.0, 2.0 * 0.5**3, 2.0, 0.0]
    np.testing.assert_allclose(v, by_hand, rtol=1e-14, atol=1e-15)


def test_profile_without_the_dip():
    """head_node = 0: the plain head profile head_speed w^head_exponent, no sign change."""
    v = velocity_profile(S, DYNAMIC, _stroke(head_node=0.0, head_exponent=2.0), tail_base_s=0.8)
    w = np.array([1.0, 0.75, 0.5, 0.25])
    np.testing.assert_allclose(v[:4], 1.5 * 0.3 * w**2, rtol=1e-14)
    np.testing.assert_allclose(v[4:], 1.5 * np.array([0.0, 0.25, 1.0, 0.0]), rtol=1e-14)


def test_profile_heave_recoil_carries_no_net_momentum():
    """recoil = "heave": the profile less its mean over the moving nodes (unit masses), the
    fluke still at rest."""
    plain = velocity_profile(S, DYNAMIC, _stroke(), tail_base_s=0.8)
    heave = velocity_profile(S, DYNAMIC, _stroke(recoil="heave"), tail_base_s=0.8)
    mean = plain[DYNAMIC].sum() / DYNAMIC.sum()
    assert abs(mean) > 0.1  # the plain profile does carry momentum
    np.testing.assert_allclose(heave[DYNAMIC], plain[DYNAMIC] - mean, rtol=1e-13, atol=1e-15)
    assert heave[~DYNAMIC] == 0.0
    assert abs(heave[DYNAMIC].sum()) < 1e-14


# -- the fluke table ---------------------------------------------------------------------------

def _linear():
    # three rows; the wrap-around segment runs from 0.6 to 1.1 (the first row one cycle on)
    return FlukeTable(np.array([0.1, 0.3, 0.6]), np.array([0.2, -0.4, 0.5]))


@pytest.mark.parametrize("phase, angle, rate", [
    (0.1, 0.2, -3.0),                       # on the first row
    (0.2, -0.1, -3.0),                      # half way along the first segment
    (0.45, 0.05, 3.0),                      # half way along the second
    (0.85, 0.35, -0.6),                     # the wrap-around segment: 0.5 -> 0.2 over 0.5
    (0.05, 0.5 - 0.6 * 0.45, -0.6),         # before the first row: still the wrap segment
    (1.45, 0.05, 3.0),                      # periodic
    (-0.55, 0.05, 3.0),
    (-0.95, 0.5 - 0.6 * 0.45, -0.6),
])
def test_linear_table_by_hand(phase, angle, rate):
    t = _linear()
    assert t(phase) == pytest.approx(angle, abs=1e-12)
    assert t.rate(phase) == pytest.approx(rate, abs=1e-12)


def test_linear_table_closes_on_its_first_row_from_below():
    """Just below the first row (one ulp: the wrapped phase rounds onto the first row one
    cycle on) the angle is the first row's, reached along the wrap-around segment."""
    t = _linear()
    below = np.nextafter(0.1, 0.0)
    assert t(below) == pytest.approx(0.2, abs=1e-12)
    assert t.rate(below) == pytest.approx(-0.6, abs=1e-12)
    assert t(np.nextafter(1.1, 0.0)) == pytest.approx(0.2, abs=1e-12)


def test_linear_table_from_the_first_phase_zero_wraps_to_its_first_row():
    t = FlukeTable(np.array([0.0, 0.5]), np.array([1.0, 3.0]))
    assert t(0.75) == pytest.approx(2.0)  # half way from 3 back to 1
    assert t.rate(0.75) == pytest.approx(-4.0)
    assert t(0.999999) == pytest.approx(1.0, abs=1e-5)
    assert t(1.0) == pytest.approx(1.0)


def test_spline_table_through_a_sine_is_a_periodic_c2_interpolant():
    """Thirty samples of sin(2 pi phase): the periodic cubic spline passes through every row
    and stays within its h^4 error of the sine, its rate within h^3 of the derivative; angle
    and rate are continuous across every row and across the cycle's end."""
    ph = np.arange(30) / 30 + 0.01  # not starting at 0: the wrap segment holds phase 0
    t = FlukeTable(ph, np.sin(2 * np.pi * ph), spline=True)
    for p, a in zip(ph, np.sin(2 * np.pi * ph), strict=True):
        assert t(p) == pytest.approx(a, abs=1e-12)
    for p in np.linspace(-1, 2, 301):
        assert t(p) == pytest.approx(math.sin(2 * math.pi * p), abs=5e-5)
        assert t.rate(p) == pytest.approx(2 * math.pi * math.cos(2 * math.pi * p), abs=2e-3)
    e = 1e-9
    for p in [*ph, 1.0, 0.0]:
        # the jumps a slope of 2 pi and a second derivative of 40 allow over 2e-9
        assert t(p - e) == pytest.approx(t(p + e), abs=2e-8)
        assert t.rate(p - e) == pytest.approx(t.rate(p + e), abs=2e-7)
        # the second derivative, from the rate's one-sided differences
        h = 1e-5
        left = (t.rate(p - e) - t.rate(p - h)) / h
        right = (t.rate(p + h) - t.rate(p + e)) / h
        assert left == pytest.approx(right, abs=1e-2)
    for p in (0.005, 0.37, 0.999):
        h = 1e-6
        assert t.rate(p) == pytest.approx((t(p + h) - t(p - h)) / (2 * h), abs=1e-6)


# -- reading a table ---------------------------------------------------------------------------

def test_shipped_tables_are_the_formulas_in_their_files():
    """default: -28 cos(2 pi phase) degrees in 30 rows (the file's formula); quadrature15:
    -15 cos(2 pi phase); fluke_angle_scale scales the angles."""
    for name, amp in (("default", 28.0), ("quadrature15", 15.0)):
        t = load_fluke_table(name)
        assert len(t.phase) == 30 and not t.spline
        np.testing.assert_allclose(t.phase, np.arange(30) / 30, atol=1e-6)
        np.testing.assert_allclose(np.degrees(t.angle), -amp * np.cos(2 * np.pi * t.phase),
                                   atol=1e-3)
    half = load_fluke_table("quadrature15", scale=0.5, spline=True)
    assert half.spline
    np.testing.assert_allclose(np.degrees(half.angle), -7.5 * np.cos(2 * np.pi * half.phase),
                               atol=1e-3)


def test_a_table_file_relative_to_the_working_folder(tmp_path, monkeypatch):
    (tmp_path / "here.csv").write_text("phase,angle_deg\n0.0,10\n0.5,-20\n")
    monkeypatch.chdir(tmp_path)
    np.testing.assert_allclose(load_fluke_table("here.csv").angle, np.radians([10.0, -20.0]))


def test_a_table_file_relative_to_the_scene(tmp_path):
    (tmp_path / "mine.csv").write_text(
        "# a comment\n\nphase, angle_deg\n  # indented comment\n0.0,10\n0.5,-20\n")
    t = load_fluke_table("mine.csv", base_dir=tmp_path, scale=2.0)
    np.testing.assert_allclose(t.phase, [0.0, 0.5])
    np.testing.assert_allclose(t.angle, np.radians([20.0, -40.0]), rtol=1e-15)
    assert t(0.25) == pytest.approx(math.radians(-10.0))
    # the same by its full path, from anywhere
    assert load_fluke_table(str(tmp_path / "mine.csv")).angle[1] == pytest.approx(
        math.radians(-20.0))


@pytest.mark.parametrize("text, scale, message", [
    (None, 1.0, r"mine.csv\): file not found; give a CSV with columns phase,angle_deg"),
    ("", 1.0, "the first row must be the header phase,angle_deg"),
    ("angle_deg,phase\n0,1\n0.5,2\n", 1.0, "the first row must be the header"),
    ("phase,angle_deg\n0.0,1\n0.5,x\n", 1.0, "could not convert"),
    ("phase,angle_deg\n0.0,1\n", 1.0, "expected at least two rows of two numbers"),
    ("phase,angle_deg\n0.0,1,2\n0.5,1,2\n", 1.0, "expected at least two rows of two numbers"),
    ("phase,angle_deg\n0.0\n0.5\n", 1.0, "expected at least two rows of two numbers"),
    ("phase,angle_deg\n", 1.0, "expected at least two rows of two numbers"),
    ("phase,angle_deg\n0.0,1\n0.5,nan\n", 1.0, "NaN or infinite values"),
    ("phase,angle_deg\n0.0,1\n0.5,inf\n", 1.0, "NaN or infinite values"),
    ("phase,angle_deg\n-0.1,1\n0.5,2\n", 1.0, r"phases must rise strictly within \[0, 1\)"),
    ("phase,angle_deg\n0.0,1\n1.0,2\n", 1.0, "phases must rise strictly"),
    ("phase,angle_deg\n0.0,1\n0.5,2\n1.0,3\n", 1.0, "phases must rise strictly"),
    ("phase,angle_deg\n0.0,1\n0.5,2\n0.5,3\n", 1.0, "phases must rise strictly"),
    ("phase,angle_deg\n0.0,1\n0.5,-90\n", 1.0, r"angles must stay within \+-90 degrees"),
    ("phase,angle_deg\n0.0,1\n0.5,50\n", 1.8, "angles must stay within"),
])
def test_a_bad_table_is_refused_by_name(tmp_path, text, scale, message):
    f = tmp_path / "mine.csv"
    if text is not None:
        f.write_text(text)
    with pytest.raises(SceneError, match=message) as info:
        load_fluke_table("mine.csv", base_dir=tmp_path, scale=scale)
    assert str(info.value).startswith(f"stroke.fluke_table ({f})")


def test_the_limits_of_a_table_are_accepted(tmp_path):
    """Phase 0 to just under 1, angles just under 90 degrees: a valid table."""
    f = tmp_path / "edge.csv"
    f.write_text("phase,angle_deg\n0.0,89.9\n0.999,-89.9\n")
    t = load_fluke_table(str(f))
    np.testing.assert_allclose(np.degrees(t.angle), [89.9, -89.9])
    assert load_fluke_table(str(f), scale=1.001).angle[0] == pytest.approx(
        math.radians(89.9 * 1.001))


# -- the start-up ramps --------------------------------------------------------------------------

@pytest.mark.parametrize("dur", [4.0, 0.5])
@pytest.mark.parametrize("x", [0.0, 0.1, 0.25, 0.5, 0.8, 0.999])
def test_ramp_is_the_cubic_smoothstep(x, dur):
    """3 x^2 - 2 x^3 over a 4 s and a 0.5 s ramp; its derivative by central difference."""
    value, rate = ramp(x * dur, dur)
    assert value == pytest.approx(3 * x**2 - 2 * x**3, abs=1e-15)
    h = 1e-6
    fd = (3 * (x + h)**2 - 2 * (x + h)**3 - 3 * (x - h)**2 + 2 * (x - h)**3) / (2 * h) / dur
    assert rate == pytest.approx(fd, abs=1e-9)


@pytest.mark.parametrize("dur", [4.0, 0.5])
@pytest.mark.parametrize("x", [0.0, 0.1, 0.25, 0.5, 0.8, 0.999])
def test_smootherstep_is_the_quintic_with_its_derivatives(x, dur):
    """10 x^3 - 15 x^4 + 6 x^5 over a 4 s and a 0.5 s ramp: first and second derivatives by
    hand."""
    value, d1, d2 = smootherstep(x * dur, dur)
    assert value == pytest.approx(10 * x**3 - 15 * x**4 + 6 * x**5, abs=1e-15)
    assert d1 == pytest.approx((30 * x**2 - 60 * x**3 + 30 * x**4) / dur, rel=1e-12, abs=1e-14)
    assert d2 == pytest.approx((60 * x - 180 * x**2 + 120 * x**3) / dur**2, rel=1e-12,
                               abs=1e-14)


def test_ramps_before_after_and_without_duration():
    for f, done in ((ramp, (1.0, 0.0)), (smootherstep, (1.0, 0.0, 0.0))):
        assert f(4.0, 4.0) == pytest.approx(done, abs=1e-15)
        assert f(7.5, 4.0) == done
        assert f(-1.0, 4.0) == pytest.approx((0.0,) * len(done))  # before the start: at rest
        assert f(3.0, 0.0) == done     # no ramp
        assert f(-1.0, 0.0) == done
        assert f(-1.0, -2.0) == done


# -- the smooth stroke's time law ------------------------------------------------------------------

@pytest.mark.parametrize("t", [0.0, 0.7, 2.9, 5.0, 6.1, 9.3, 17.0])
def test_smooth_stroke_velocity_and_acceleration_are_derivatives(t):
    """Period 8 s, a 6 s ramp: G = D' and G' by central differences of the closed form
    D(t) = r(t) sin(w t) / w, r the quintic; ``at`` is (G', G, D)."""
    T, ramp_s = 8.0, 6.0
    w = 2 * math.pi / T
    st = SmoothStroke(T, ramp_s)

    def D(t):
        x = min(max(t / ramp_s, 0.0), 1.0)
        return (10 * x**3 - 15 * x**4 + 6 * x**5) * math.sin(w * t) / w

    h = 1e-4
    assert st.displacement(t) == pytest.approx(D(t), abs=1e-14)
    if t == 0.0:  # the ramp starts at t = 0: one-sided, and all three vanish
        assert st.at(t) == (0.0, 0.0, 0.0)
        return
    v = (D(t + h) - D(t - h)) / (2 * h)
    a = (D(t + h) - 2 * D(t) + D(t - h)) / h**2
    assert st.velocity(t) == pytest.approx(v, abs=1e-8)
    assert st.acceleration(t) == pytest.approx(a, abs=1e-6)
    assert st.at(t) == pytest.approx((st.acceleration(t), st.velocity(t), st.displacement(t)),
                                     abs=1e-15)


def test_smooth_stroke_after_the_ramp_is_the_sine():
    T = 8.0
    w = 2 * math.pi / T
    st = SmoothStroke(T, 8.0)
    for t in (8.0, 9.0, 10.0, 14.0):
        assert st.at(t) == pytest.approx((-w * math.sin(w * t), math.cos(w * t),
                                          math.sin(w * t) / w), abs=1e-14)
    # phase 0.25 of a cycle: the top (D at its peak T / (2 pi), G zero)
    assert st.displacement(10.0) == pytest.approx(T / (2 * math.pi))
    assert st.velocity(10.0) == pytest.approx(0.0, abs=1e-15)


# -- the gate's rotation and the bending joint -----------------------------------------------------

def test_rotation_raises_x_toward_z():
    th = math.radians(30)
    R = rotation_y(th)
    np.testing.assert_allclose(R @ [1.0, 0, 0], [math.sqrt(3) / 2, 0, 0.5], atol=1e-15)
    np.testing.assert_allclose(R @ [0, 0, 1.0], [-0.5, 0, math.sqrt(3) / 2], atol=1e-15)
    np.testing.assert_allclose(R @ [0, 2.0, 0], [0, 2.0, 0], atol=1e-15)


def test_joint_blend_by_hand():
    s = np.array([0.78, 0.785, 0.79, 0.795, 0.80, 0.9])
    np.testing.assert_array_equal(joint_blend(s, 0.8, 0.0), np.ones(6))
    np.testing.assert_array_equal(joint_blend(s, 0.8, -0.1), np.ones(6))
    # a joint of 0.02 ahead of the tail base: u = (s - 0.78) / 0.02 = 0, 1/4, 1/2, 3/4, 1, 6
    # (held at 1 on the fluke)
    quintic = [0.0, 0.103515625, 0.5, 0.896484375, 1.0, 1.0]
    np.testing.assert_allclose(joint_blend(s, 0.8, 0.02), quintic, rtol=1e-12, atol=1e-15)
    # ahead of the joint (a node the gate would not carry): 0, not negative
    assert joint_blend(np.array([0.77]), 0.8, 0.02)[0] == 0.0
