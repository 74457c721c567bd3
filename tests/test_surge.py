"""The free whale's law of motion (adapter/coupling/surge.py) against closed forms: Lamb's added
masses of prolate spheroids, a constant force's uniform acceleration, a linear drag's
exponential approach to its balance, a restart that continues the same path, and the approach
at the release (its half-cosine and the release speed's model root)."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest
from scipy.optimize import brentq

from adapter.coupling.added_mass import Inertia, spheroid_added_inertia, spheroid_added_mass
from adapter.coupling.frame import FrameState
from adapter.coupling.surge import PitchRecoil, Schedule, SurgeFrame, release_speed

NAN3 = (math.nan,) * 3
#: a step that adds up exactly in binary, so that two runs meet the same times
DT = 2.0 ** -6


def request(fx: float, fz: float = 0.0):
    return SimpleNamespace(pressure_force=(fx, 0.0, fz), viscous_force=(0.0, 0.0, 0.0))


@pytest.mark.parametrize("ratio, k1, k2", [
    # Lamb, Hydrodynamics (6th ed.), section 373, and Korotkin, Added Masses of Ship
    # Structures (2009), table 5.1: a/b, k1 (along), k2 (across)
    (1.50, 0.305, 0.621), (2.00, 0.210, 0.704), (4.00, 0.082, 0.860), (6.01, 0.045, 0.918),
    (10.0, 0.021, 0.960)])
def test_spheroid_added_mass_is_lambs(ratio, k1, k2):
    got = spheroid_added_mass(ratio, 1.0)
    assert got == pytest.approx((k1, k2), abs=1.5e-3)


def test_a_sphere_has_half_its_mass_added():
    k1, k2 = spheroid_added_mass(1.0 + 1e-6, 1.0)
    assert k1 == pytest.approx(0.5, abs=1e-4) and k2 == pytest.approx(0.5, abs=1e-4)


def run(frame: SurgeFrame, flow, t_end: float, dt: float, t0: float = 0.0, restart=False):
    """Drive the frame as a flow solver does: each step's force measured with the step's
    acceleration, handed over with the next request. A restart's first request carries the
    force of the fields read at the restart time (the plugin computes it from them)."""
    frame.answer(t0, SimpleNamespace(pressure_force=NAN3, viscous_force=NAN3))
    t = t0
    force = flow(SimpleNamespace(velocity=frame.velocity, acceleration=frame.acceleration)) \
        if restart else None
    rows = []
    while t < t_end - 1e-12:
        t += dt
        state = frame.answer(t, request(*force) if force else
                             SimpleNamespace(pressure_force=NAN3, viscous_force=NAN3))
        force = flow(state)
        rows.append((t, state.velocity[0], state.velocity[2]))
    return np.array(rows)


def with_added_mass(m_a: float, rest):
    """A flow whose measured force holds the added mass's reaction, F = G(u) + m_a du_f/dt."""
    return lambda s: (rest(s.velocity[0]) + m_a * s.acceleration[0], m_a * s.acceleration[2])


def test_a_constant_force_accelerates_by_it_over_mass_plus_added_mass():
    inertia = Inertia(1000.0, 80.0, 860.0)
    frame = SurgeFrame(1.3, inertia, Schedule(0.0, 1.0))
    rows = run(frame, with_added_mass(80.0, lambda u: -54.0), 10.0, 0.01)
    # (m + m_a) du/dt = -G = 54 N: u = 1.3 + 54 t / 1080, from the first step that knows G
    t, u = rows[-1, 0], rows[-1, 1]
    assert u == pytest.approx(1.3 + 54.0 / 1080.0 * (t - 0.01), rel=1e-9)


def test_a_wrong_added_mass_estimate_only_lags():
    # the flow's added mass twice the estimate, and three times the body's mass: still stable
    inertia = Inertia(100.0, 150.0, 0.0)
    frame = SurgeFrame(1.3, inertia, Schedule(0.0, 1.0))
    rows = run(frame, with_added_mass(300.0, lambda u: -54.0), 20.0, 0.01)
    slope = np.gradient(rows[-200:, 1], rows[-200:, 0])
    assert np.all(np.isfinite(rows)) and slope.mean() == pytest.approx(54.0 / 400.0, rel=1e-3)


def test_linear_drag_approaches_its_balance_exponentially():
    # G = c (u - u_sp): u - u_sp decays as exp(-t c / (m + m_a))
    m, m_a, c, u_sp = 5000.0, 400.0, 2000.0, 1.7
    frame = SurgeFrame(1.3, Inertia(m, m_a, 0.0), Schedule(0.0, 1.0))
    rows = run(frame, with_added_mass(m_a, lambda u: c * (u - u_sp)), 8.0, 0.001)
    expected = u_sp + (1.3 - u_sp) * np.exp(-(rows[:, 0] - 0.001) * c / (m + m_a))
    assert np.abs(rows[:, 1] - expected).max() < 2e-3 * abs(1.3 - u_sp)


def test_the_lighter_mass_speeds_the_mean_and_not_the_swing():
    # drag c (u - u_sp) plus a swing of zero mean: the mean approaches with light * tau, the
    # swing of u within a cycle is the true mass's (amplitude S / (M omega))
    m, c, u_sp, swing, period = 5000.0, 2000.0, 1.7, 3000.0, 1.0
    omega = 2 * math.pi / period
    light = Schedule(0.0, period, light=0.2, light_cycles=100.0)
    frames = {"true": SurgeFrame(1.3, Inertia(m, 0.0, 0.0), Schedule(0.0, period)),
              "light": SurgeFrame(1.3, Inertia(m, 0.0, 0.0), light)}
    out = {}
    for name, frame in frames.items():
        t = {"now": 0.0}

        def flow(s, t=t):
            t["now"] += 1e-3
            return (c * (s.velocity[0] - u_sp) + swing * math.sin(omega * t["now"]), 0.0)
        out[name] = run(frame, flow, 12.0, 1e-3)
    tau = m / c
    for name, factor in (("true", 1.0), ("light", 0.2)):
        rows = out[name]
        late = rows[rows[:, 0] > 11.0]
        mean_gap = abs(late[:, 1].mean() - u_sp)
        assert mean_gap == pytest.approx(0.4 * math.exp(-11.5 / (factor * tau)), rel=0.35,
                                         abs=2e-4)
        amplitude = 0.5 * np.ptp(late[:, 1] - np.polyval(np.polyfit(late[:, 0], late[:, 1], 1),
                                                         late[:, 0]))
        assert amplitude == pytest.approx(swing / (m * omega), rel=0.1)


def test_a_restart_continues_the_same_path(tmp_path):
    flow = with_added_mass(80.0, lambda u: 500.0 * (u - 1.6))
    whole = SurgeFrame(1.3, Inertia(1000.0, 80.0, 0.0), Schedule(0.0, 1.0, 0.5, 2.0),
                       log_path=tmp_path / "whole.dat")
    rows = run(whole, flow, 3.0, DT)
    first = SurgeFrame(1.3, Inertia(1000.0, 80.0, 0.0), Schedule(0.0, 1.0, 0.5, 2.0),
                       log_path=tmp_path / "split.dat")
    run(first, flow, 1.5, DT)
    saved = first.state()
    run(first, flow, 2.0, DT, t0=1.5)     # ran on past the save, then stopped
    again = SurgeFrame(1.3, Inertia(1000.0, 80.0, 0.0), Schedule(0.0, 1.0, 0.5, 2.0),
                       log_path=tmp_path / "split.dat")
    again.restore(saved)
    assert again.t == pytest.approx(1.5)
    assert max(float(r.split()[0]) for r in (tmp_path / "split.dat").read_text().splitlines()
               if not r.startswith("#")) <= 1.5 + 1e-12
    rest = run(again, flow, 3.0, DT, t0=1.5, restart=True)
    assert np.array_equal(rest[:, 1:], rows[-len(rest):, 1:])
    assert rest[-1, 1] != pytest.approx(rows[75, 1], abs=1e-3)


def test_the_true_mass_takes_over_once_the_mean_force_is_small():
    # G = c (u - u_sp): the running mean is under 10 N when the mean speed is within 5 mm/s
    m, c, u_sp = 5000.0, 2000.0, 1.7
    early = Schedule(0.0, 1.0, light=0.2, light_cycles=100.0, switch=0.01, reference_N=1000.0)
    frame = SurgeFrame(1.3, Inertia(m, 0.0, 0.0), early)
    rows = run(frame, with_added_mass(0.0, lambda u: c * (u - u_sp)), 12.0, DT)
    assert frame.true_from is not None and frame.true_from >= 1.0
    before = rows[(rows[:, 0] > frame.true_from - 1.0) & (rows[:, 0] <= frame.true_from)]
    assert abs(c * (before[:, 1].mean() - u_sp)) < 10.0 + 0.5
    # afterwards the true mass: the gap decays as exp(-t c / m)
    after = rows[rows[:, 0] > frame.true_from + 0.1]
    gap = np.abs(after[:, 1] - u_sp)
    rate = -np.polyfit(after[:, 0], np.log(gap), 1)[0]
    assert rate == pytest.approx(c / m, rel=0.02)
    never = SurgeFrame(1.3, Inertia(m, 0.0, 0.0), Schedule(0.0, 1.0, 0.2, 100.0))
    run(never, with_added_mass(0.0, lambda u: c * (u - u_sp)), 12.0, DT)
    assert never.true_from is None


def _swing(t_end: float, period: float, frame: SurgeFrame, force, moment=lambda t: 0.0):
    """Run a frame under a vertical force and a pitching moment given in time (the flow's
    added-mass reactions included), returning (t, w, pitch) rows."""
    t, rows = 0.0, []
    frame.answer(0.0, SimpleNamespace(pressure_force=NAN3, viscous_force=NAN3,
                                      pressure_moment=NAN3, viscous_moment=NAN3))
    state = frame._state_now()
    while t < t_end - 1e-12:
        pitch = frame.pitch
        fz = force(t) + frame.inertia.added_heave_kg * state.acceleration[2]
        my = moment(t) - (pitch.added * pitch.alpha if pitch is not None else 0.0)
        t += DT
        state = frame.answer(t, SimpleNamespace(
            pressure_force=(0.0, 0.0, fz), viscous_force=(0.0, 0.0, 0.0),
            pressure_moment=(0.0, my, 0.0), viscous_moment=(0.0, 0.0, 0.0)))
        rows.append((t, state.velocity[2], state.pitch))
    return np.array(rows)


def test_heave_recoil_swings_with_the_force_and_holds_its_depth():
    # a vertical force F0 sin(w t) on m + m_a: the frame's vertical velocity swings by
    # F0 / ((m + m_a) w) (the trim, at w / 8, takes 0.8 % off); a steady force moves nothing
    m, m_a, f0, period = 1000.0, 860.0, 500.0, 2.0
    w = 2 * math.pi / period
    inertia = Inertia(m, 0.0, m_a)
    rows = _swing(40.0, period, SurgeFrame(1.3, inertia, Schedule(0.0, period), heave=True),
                  lambda t: f0 * math.sin(w * t))
    late = rows[rows[:, 0] > 30.0]
    assert 0.5 * np.ptp(late[:, 1]) == pytest.approx(f0 / ((m + m_a) * w), rel=0.03)
    steady = _swing(20.0, period, SurgeFrame(1.3, inertia, Schedule(0.0, period), heave=True),
                    lambda t: f0)
    assert abs(steady[-1, 1]) < 0.02 * f0 / (m + m_a) * period
    assert np.all(rows[:, 2] == 0.0)          # no pitch asked: none


def test_pitch_recoil_swings_by_the_moment_over_the_inertia():
    # M0 sin(w t) on I + I_a: the pitch swings by M0 / ((I + I_a) w^2) (the trim adds 1.6 %)
    inertia, added, m0, period = 2.0e5, 1.0e5, 3000.0, 2.0
    w = 2 * math.pi / period
    recoil = PitchRecoil(inertia, added, (7.0, 0.0, 0.0), period)
    frame = SurgeFrame(1.3, Inertia(1000.0, 0.0, 0.0), Schedule(0.0, period), pitch=recoil)
    rows = _swing(40.0, period, frame, lambda t: 0.0, lambda t: m0 * math.sin(w * t))
    late = rows[rows[:, 0] > 30.0]       # the start's drift gone (the trim's time 1 / (w / 8))
    assert 0.5 * np.ptp(late[:, 2]) == pytest.approx(m0 / ((inertia + added) * w * w),
                                                     rel=0.04)
    steady = _swing(24.0, period, SurgeFrame(1.3, Inertia(1000.0, 0.0, 0.0),
                                             Schedule(0.0, period),
                                             pitch=PitchRecoil(inertia, added, (7, 0, 0), period)),
                    lambda t: 0.0, lambda t: m0)
    assert abs(steady[-1, 2]) < 0.05 * m0 / ((inertia + added) * w * w)


def test_lambs_added_inertia_of_spheroids():
    # Lamb, section 373, table: a/b, k'
    for ratio, k in ((1.50, 0.094), (1.99, 0.240), (2.99, 0.465), (3.99, 0.608),
                     (6.01, 0.764), (9.97, 0.883)):
        assert spheroid_added_inertia(ratio, 1.0) == pytest.approx(k, abs=4e-3)


def test_a_pitched_whale_turns_about_its_centre():
    state = FrameState(np.zeros(3), np.zeros(3), math.radians(2.0), (7.0, 0.0, 0.5))
    rest = np.array([[0.0, 0.0, 0.5], [14.0, 1.0, 0.5], [7.0, 0.0, 0.5]])
    moved = rest + state.rotated(np.zeros((3, 3)), rest)
    # the rostrum (7 m ahead of the centre, at -x) rises by 7 sin 2 deg; the centre stays
    assert moved[0] == pytest.approx([7 - 7 * math.cos(math.radians(2)), 0.0,
                                      0.5 + 7 * math.sin(math.radians(2))])
    assert moved[2] == pytest.approx(rest[2])
    assert np.linalg.norm(moved[1] - moved[2]) == pytest.approx(np.linalg.norm(rest[1] - rest[2]))


@pytest.mark.parametrize("backward", [False, True])
def test_the_body_force_is_the_time_schemes_derivative_of_the_velocities_sent(backward):
    """The flow accelerates its far field by the scheme's derivative of the frame velocities
    it is sent (Euler: (u_n - u_(n-1)) / dt; backward, a constant step: (3 u_n - 4 u_(n-1) +
    u_(n-2)) / (2 dt)); the body force it is sent must be the same, or the difference pushes
    on the displaced water."""
    frame = SurgeFrame(1.3, Inertia(5000.0, 400.0, 0.0), Schedule(0.0, 1.0), backward=backward)
    frame.answer(0.0, SimpleNamespace(pressure_force=NAN3, viscous_force=NAN3))
    sent, t = [], 0.0
    force = None
    for _ in range(200):
        t += DT
        state = frame.answer(t, request(*force) if force else
                             SimpleNamespace(pressure_force=NAN3, viscous_force=NAN3))
        sent.append((state.velocity[0], state.acceleration[0]))
        # a drag toward 1.7 m/s and a swing: the acceleration changes every step
        force = (2000.0 * (state.velocity[0] - 1.7) + 3000.0 * math.sin(2 * math.pi * t), 0.0)
    u, body = np.array(sent).T
    if backward:
        derivative = (3 * u[2:] - 4 * u[1:-1] + u[:-2]) / (2 * DT)
    else:
        derivative = (u[2:] - u[1:-1]) / DT
    assert np.ptp(body) > 1.0                                   # it does change
    assert np.abs(body[2:] - derivative).max() < 1e-9 * np.abs(body).max() + 1e-9


def test_the_release_speed_is_the_root_of_its_model():
    # drag D0 (U / U0)^2 against a thrust of constant power T0 U0 / U, T0 = D0 - Fx: the
    # root found numerically, and the default whale's pair worked by hand
    u0, drag, fx = 1.3, 587.4, -986.0
    root = brentq(lambda u: drag * (u / u0) ** 2 - (drag - fx) * u0 / u, 0.5, 5.0)
    assert release_speed(u0, drag, fx) == pytest.approx(root, rel=1e-12)
    assert release_speed(u0, drag, fx) == pytest.approx(1.3 * 2.67858 ** (1 / 3), rel=1e-5)
    # a slow stroke (drag wins) gives a lower speed; no thrust at all or a pair without
    # figures keeps the tethered speed; the estimate stays within 0.5-2 times it
    assert release_speed(u0, drag, 100.0) < u0
    for bad in (drag, 2 * drag, math.nan):
        assert release_speed(u0, drag, bad) == u0
    assert release_speed(u0, math.inf, fx) == u0
    assert release_speed(u0, drag, -100 * drag) == 2 * u0


@pytest.mark.parametrize("backward", [False, True])
def test_the_approach_follows_its_half_cosine_and_heeds_no_force(backward):
    # release at 1 s, approach over 2 s from 1.3 to 1.7 m/s, then a linear drag balanced at
    # 1.7: the speed is the half-cosine during the approach whatever the force, and stays
    # at the balance afterwards
    release, length, u0, u1 = 1.0, 2.0, 1.3, 1.7
    schedule = Schedule(release, 1.0, approach_s=length, approach_speed=u1)
    frame = SurgeFrame(u0, Inertia(5000.0, 0.0, 0.0), schedule, backward=backward)
    rows, accel, t = [], [], 0.0
    frame.answer(0.0, SimpleNamespace(pressure_force=NAN3, viscous_force=NAN3))
    while t < 6.0 - 1e-12:
        t += DT
        wild = 1e6 if t <= release + length else 2000.0 * (frame.velocity[0] - u1)
        state = frame.answer(t, request(wild))
        rows.append((t, state.velocity[0]))
        accel.append(state.acceleration[0])
    rows = np.array(rows)
    during = (rows[:, 0] > release) & (rows[:, 0] <= release + length + 1e-12)
    tau = (rows[during, 0] - release) / length
    np.testing.assert_allclose(rows[during, 1], u0 + (u1 - u0) * 0.5 * (1 - np.cos(np.pi * tau)),
                               atol=1e-12)
    assert np.all(rows[rows[:, 0] <= release, 1] == u0)
    # the body force is the scheme's derivative of the speeds sent: Euler's (u_n+1 - u_n) / dt,
    # backward's (3 u_n+1 - 4 u_n + u_n-1) / (2 dt)
    u = rows[:, 1]
    k = np.flatnonzero(during)[5:-5]
    want = ((3 * u[k] - 4 * u[k - 1] + u[k - 2]) / (2 * DT) if backward
            else (u[k] - u[k - 1]) / DT)
    np.testing.assert_allclose(np.array(accel)[k], want, rtol=1e-9)
    assert np.max(np.abs(rows[rows[:, 0] > release + length, 1] - u1)) < 1e-6


def test_the_lighter_mass_waits_for_a_whole_period_of_forces():
    # balanced at the release speed, under a swing S sin(w t): until a whole period has been
    # measured the true mass alone moves the speed, u - u0 = S (1 - cos w t) / (M w) at most
    # 2 S / (M w); a mean of the first few samples on the lighter mass would be the swing
    # itself, five times amplified
    m, swing, period, u0 = 5000.0, 3000.0, 1.0, 1.7
    omega = 2 * math.pi / period
    frame = SurgeFrame(u0, Inertia(m, 0.0, 0.0), Schedule(0.0, period, light=0.2,
                                                         light_cycles=100.0))
    t = {"now": 0.0}

    def flow(s, t=t):
        t["now"] += DT
        return (2000.0 * (s.velocity[0] - u0) + swing * math.sin(omega * t["now"]), 0.0)
    rows = run(frame, flow, 1.0, DT)
    assert np.max(np.abs(rows[:, 1] - u0)) < 1.05 * 2 * swing / (m * omega)
