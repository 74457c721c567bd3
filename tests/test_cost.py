"""What swimming costs the whale, without OpenFOAM: the cycle means, power, Froude efficiency
and cost of transport of adapter/foam/loads.py and adapter/foam/swimrun.py against signals
whose answers are known in closed form (a constant, a sinusoid, a sign flip).

A whole period of equally spaced samples of sin or cos (any phase, any harmonic below the
Nyquist limit) sums to zero, so a cycle mean of ``C + A sin(2 pi k t / T + phi)`` is ``C`` to
rounding. The pair's figures follow by hand: thrust = D_glide - Fx_swim, efficiency = thrust
U / P, cost of transport = P / (1025 V U)."""

import json
import math
from pathlib import Path

import numpy as np
import pytest

from adapter.errors import CaseError
from adapter.foam import loads as ld
from adapter.foam import swimrun

T = 2.0        # stroke period (s)
N = 40         # samples a period
DT = T / N


def _times(cycles: int) -> np.ndarray:
    return DT * np.arange(1, cycles * N + 1)


def _wave(t, amp, harmonic=1, phase=0.0):
    return amp * np.sin(2 * np.pi * harmonic * t / T + phase)


def test_cycle_means_of_a_constant_and_a_sinusoid_are_the_constant():
    t = _times(4)
    fx = -300.0 + _wave(t, 500.0, 1, 0.3) + _wave(t, 80.0, 3, 1.1)
    power = 4000.0 + _wave(t, 2500.0, 1, math.pi / 2) + _wave(t, 700.0, 2)
    st = ld.cycle_stats(t, fx, power, T, start_up=T)
    np.testing.assert_allclose(st.starts, [2.0, 4.0, 6.0])
    np.testing.assert_allclose(st.mean_fx, -300.0, rtol=1e-12)
    np.testing.assert_allclose(st.mean_power, 4000.0, rtol=1e-12)
    const = ld.cycle_stats(t, np.full(len(t), 661.0), np.full(len(t), 4149.0), T, 0.0)
    assert len(const.starts) == 4
    np.testing.assert_allclose(const.mean_fx, 661.0, rtol=1e-15)
    np.testing.assert_allclose(const.mean_power, 4149.0, rtol=1e-15)


def test_cycle_means_hold_when_the_step_does_not_divide_the_period():
    """88.5 steps a period (the default case's): a mean over each exact period of c + A sin
    is c (closed form). Sample means over the windows alternate 88 and 89 samples and miss it
    by 0.4 % of A in turn; the time means by under 0.01 %."""
    period, dt = 7.6923, 89 / 1024
    t = dt * np.arange(1, 1200)
    fx = 300.0 + 1600.0 * np.sin(2 * np.pi * t / period + 0.3)
    st = ld.cycle_stats(t, fx, fx, period, start_up=10.0)
    assert len(st.starts) >= 8
    np.testing.assert_allclose(st.mean_fx, 300.0, atol=1e-4 * 1600.0)


def test_a_sign_flip_flips_the_cycle_means_and_only_them():
    """Negated signals give negated means: Fx and power keep their own signs (a thrust-
    dominated swimmer has Fx < 0 and P > 0); a mean of the wrong sign is a wrong answer."""
    t = _times(3)
    fx = 250.0 + _wave(t, 900.0)
    power = 1200.0 + _wave(t, 1000.0, 2, 0.4)
    st = ld.cycle_stats(t, fx, power, T, T)
    flipped = ld.cycle_stats(t, -fx, -power, T, T)
    np.testing.assert_allclose(st.mean_fx, 250.0, rtol=1e-12)
    np.testing.assert_allclose(st.mean_power, 1200.0, rtol=1e-12)
    np.testing.assert_allclose(flipped.mean_fx, -250.0, rtol=1e-12)
    np.testing.assert_allclose(flipped.mean_power, -1200.0, rtol=1e-12)
    # Fx flipped alone leaves the power's mean as it was
    mixed = ld.cycle_stats(t, -fx, power, T, T)
    np.testing.assert_allclose(mixed.mean_power, 1200.0, rtol=1e-12)


def test_the_cycle_window_starts_after_the_start_up():
    """A step from 1e6 to 10 at the end of the start-up: the start-up's samples (t <= T) are
    not in any cycle, the first sample after it is."""
    t = _times(3)
    power = np.where(t <= T + 1e-12, 1e6, 10.0)
    st = ld.cycle_stats(t, power, power, T, T)
    np.testing.assert_allclose(st.mean_power, 10.0, rtol=1e-15)


def test_cost_figures_by_hand():
    """D = 350 N, Fx = 50 N: thrust 300 N, at 1.3 m/s 390 W of 600 W: efficiency 0.65;
    600 W / (8,200 kg x 1.3 m/s) = 0.05628517... J/(kg m)."""
    c = ld.cost_figures(350.0, 50.0, 600.0, 1.3, 8200.0)
    assert c["thrust_N"] == pytest.approx(300.0, rel=1e-15)
    assert c["froude_efficiency"] == pytest.approx(0.65, rel=1e-14)
    assert c["cost_of_transport_J_kg_m"] == pytest.approx(0.0562851782363977, rel=1e-12)
    assert c["mass_kg"] == 8200.0
    # a thrust-dominated swimmer (Fx < 0): the thrust exceeds the drag
    c = ld.cost_figures(350.0, -150.0, 1000.0, 1.3, 8200.0)
    assert c["thrust_N"] == pytest.approx(500.0) and c["froude_efficiency"] == pytest.approx(0.65)
    for bad in (-600.0, 0.0, float("nan")):
        with pytest.raises(CaseError, match="not positive"):
            ld.cost_figures(350.0, 50.0, bad, 1.3, 8200.0)


# --- the pair's answer from synthetic loads.dat files --------------------------------------

COLUMNS = ["Fx", "Fy", "Fz", "Fpx", "Fpy", "Fpz", "Fvx", "Fvy", "Fvz", "P", "Pp", "Pv", "A"]
#: the body of the record: a 4 x 2 x 1 m box, V = 8 m3, so m = 1025 x 8 = 8,200 kg
BODY = {"volume_m3": 8.0, "length_m": 4.0, "diameter_m": 1.0, "wetted_area_m2": 28.0}
SPEED = 1.3


def _write(case: Path, t, fx, fpx, power):
    """``postProcessing/loads/0/loads.dat`` with the whaleLoads layout (total: columns)."""
    path = case / "postProcessing" / "loads" / "0" / "loads.dat"
    path.parent.mkdir(parents=True, exist_ok=True)
    rows = []
    for k in range(len(t)):
        values = {"Fx": fx[k], "Fz": 0.1 * fx[k], "Fpx": fpx[k], "Fvx": fx[k] - fpx[k],
                  "P": power[k], "Pp": power[k], "A": 28.0}
        rows.append(f"{t[k]:.12g}" + "".join(f"\t{values.get(c, 0.0):.17g}" for c in COLUMNS))
    path.write_text("# Loads\n# Time" + "".join(f"\ttotal:{c}" for c in COLUMNS) + "\n"
                    + "\n".join(rows) + "\n")


def _pair(tmp_path, swim_power_sign=1.0):
    """A swimming case and its gliding run: gliding Fx = 350 N (250 N of pressure) plus a
    swing, no power; swimming Fx = 50 N and power 600 W plus swings, 4 cycles, the first the
    start-up."""
    case = tmp_path / "case"
    glide = case / swimrun.GLIDING
    t = _times(4)
    g_fx = 350.0 + _wave(t, 40.0, 2, 0.7)
    _write(glide, t, g_fx, 250.0 + _wave(t, 30.0, 2, 0.7), 0.0 * t)
    s_fx = 50.0 + _wave(t, 1800.0, 1, 0.2) + _wave(t, 300.0, 2)
    s_p = swim_power_sign * (600.0 + _wave(t, 550.0, 2, 1.0) + _wave(t, 120.0, 4))
    _write(case, t, s_fx, 0.5 * s_fx, s_p)
    record = {"period_s": T, "ramp_s": T, "speed_m_s": SPEED, "length_m": 4.0, "body": BODY}
    return case, glide, record


def _no_nan(text: str) -> dict:
    def refuse(name):
        raise AssertionError(f"{name} in the summary JSON")

    return json.loads(text, parse_constant=refuse)


@pytest.mark.slow
def test_the_pairs_answer_is_the_hand_figures(tmp_path):
    case, glide, record = _pair(tmp_path)
    drag = float(ld.cycle_stats(*[ld.read_loads(glide)[k] for k in
                                  ("Time", "total:Fx", "total:P")], T, T).mean_fx[-1])
    assert drag == pytest.approx(350.0, rel=1e-12)
    summary = swimrun.answer(case, glide, record, drag, 0.02, {"steps": 160}, {})
    s = summary["swimming_cost"]
    assert s["gliding_drag_N"] == pytest.approx(350.0, rel=1e-12)
    assert s["gliding_drag_pressure_N"] == pytest.approx(250.0, rel=1e-12)
    assert s["gliding_drag_viscous_N"] == pytest.approx(100.0, rel=1e-12)
    assert s["swimming_mean_fx_N"] == pytest.approx(50.0, rel=1e-11)
    assert s["swimming_mean_power_W"] == pytest.approx(600.0, rel=1e-12)
    assert s["thrust_N"] == pytest.approx(300.0, rel=1e-11)
    assert s["froude_efficiency"] == pytest.approx(0.65, rel=1e-11)          # 300 x 1.3 / 600
    assert s["mass_kg"] == pytest.approx(8200.0, rel=1e-15)                  # 1025 x 8
    assert s["cost_of_transport_J_kg_m"] == pytest.approx(0.0562851782363977, rel=1e-11)
    assert s["cycles_measured"] == 3 and s["periodic_change"]["reached"]
    np.testing.assert_allclose(s["cycle_means"]["power_W"], 600.0, rtol=1e-12)
    written = _no_nan((case / "adapter-summary.json").read_text())
    assert written["swimming_cost"]["froude_efficiency"] == pytest.approx(0.65, rel=1e-11)
    assert written["steps"] == 160


def test_a_pair_whose_power_is_negative_is_refused(tmp_path):
    """The stroke would take energy from the flow: no efficiency is reported for it."""
    case, glide, record = _pair(tmp_path, swim_power_sign=-1.0)
    with pytest.raises(CaseError, match=r"-600 W, not positive"):
        swimrun.answer(case, glide, record, 350.0, 0.02, {}, {})
