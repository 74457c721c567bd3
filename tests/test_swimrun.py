"""What swimming costs the whale: the arithmetic of adapter/foam/loads.py against worked numbers,
and
run-case's gliding + swimming pair on the smoke whale with the real pimpleFoam."""

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from adapter.errors import AdapterError
from adapter.foam import loads as ld


def _write_loads(path: Path, times, fx, power, extra_header=""):
    path.parent.mkdir(parents=True, exist_ok=True)
    cols = ["Fx", "Fy", "Fz", "Fpx", "Fpy", "Fpz", "Fvx", "Fvy", "Fvz", "P", "Pp", "Pv", "A"]
    head = "# Time" + "".join(f"\ttotal:{c}" for c in cols) + "\n"
    rows = []
    for t, f, p in zip(times, fx, power, strict=True):
        vals = [f, 0, 0.5 * f, f, 0, 0, 0, 0, 0, p, p, 0, 100.0]
        rows.append(f"{t:.10g}" + "".join(f"\t{v:.10g}" for v in vals))
    path.write_text("# Loads\n" + extra_header + head + "\n".join(rows) + "\n")


def test_loads_files_of_restarts_merge_later_wins_and_cut_lines_are_skipped(tmp_path):
    base = tmp_path / "postProcessing" / "loads"
    _write_loads(base / "0" / "loads.dat", [0.1, 0.2, 0.3], [1, 2, 3], [10, 20, 30])
    _write_loads(base / "0.2" / "loads.dat", [0.3, 0.4], [33, 4], [330, 40])
    with open(base / "0.2" / "loads.dat", "a") as fh:
        fh.write("0.5\t1\t2")  # a line a running solver has not finished
    d = ld.read_loads(tmp_path)
    np.testing.assert_array_equal(d["Time"], [0.1, 0.2, 0.3, 0.4])
    np.testing.assert_array_equal(d["total:Fx"], [1, 2, 33, 4])
    np.testing.assert_array_equal(d["total:P"], [10, 20, 330, 40])
    assert ld.read_loads(tmp_path / "nothing") == {}


def test_cycle_means_and_periodicity_of_a_known_signal():
    """Fx = 100 + 50 sin(2 pi t / T) + a decaying 40 exp(-t / T): cycle means known in closed
    form; periodic once the decay is under the tolerance."""
    T, dt = 2.0, 0.001
    t = np.arange(dt, 8 * T + 1e-9, dt)
    fx = 100 + 50 * np.sin(2 * np.pi * t / T) + 40 * np.exp(-t / T)
    power = 1000 + 0 * t
    st = ld.cycle_stats(t, fx, power, T, start_up=T)
    assert len(st.starts) == 7
    for k, a in enumerate(st.starts):
        exact = 100 + 40 * T * (math.exp(-a / T) - math.exp(-(a + T) / T)) / T
        assert st.mean_fx[k] == pytest.approx(exact, rel=2e-4)
    dfx, dp = ld.periodic_change(st, force_scale=100.0)
    last_two = st.mean_fx[-1] - st.mean_fx[-2]
    assert dfx == pytest.approx(abs(last_two) / 100.0) and dp == 0.0
    # early on the decay is 40 (e^-1 - e^-2) / 1 ~ 9 N of 100: not periodic at 2 %
    early = ld.cycle_stats(t[t <= 3 * T + 1e-9], fx[t <= 3 * T + 1e-9], power[t <= 3 * T + 1e-9],
                           T, start_up=T)
    assert not ld.is_periodic(early, 100.0, 0.02)
    assert ld.is_periodic(st, 100.0, 0.02)


def test_worst_drop_is_the_brute_force_worst_case():
    rng = np.random.default_rng(3)
    x = rng.normal(size=200)
    x[17] = 40.0  # one spike
    k = 2  # 1 % of 200
    mean = x.mean()
    best = 0.0
    # brute force over every pair would be 19,900 subsets: fine
    for i in range(len(x)):
        for j in range(i + 1, len(x)):
            keep = np.ones(len(x), bool)
            keep[[i, j]] = False
            best = max(best, abs(x[keep].mean() - mean))
    assert ld.worst_drop(x, 0.01) == pytest.approx(best, rel=1e-12)
    assert k == max(1, int(0.01 * len(x)))


def test_the_smooth_part_tells_a_swing_from_a_spike():
    """A sinusoid M + A cos(2 pi t / T), 400 samples a period: its worst 1 % (4 samples, the
    ones nearest the crest, at phases +-0.5 and +-1.5 steps) lie
    A (cos(pi/400) + cos(3 pi/400)) / 2 above the mean, so dropping them moves the mean by
    4 x that / 396. A one-step spike of 20 A on top moves the raw figure by about 20 A / 396
    (the smooth part keeps 21 / 400 of the spike, spread over a bump: a little of it shows)
    while the smooth part's figure stays within a tenth of that excess of the sinusoid's."""
    n, mean, amp = 400, -886.0, 1450.0
    t = (np.arange(n) + 0.5) / n
    swing = mean + amp * np.cos(2 * np.pi * t)
    exact = 4 * amp * (np.cos(np.pi / n) + np.cos(3 * np.pi / n)) / 2 / (n - 4)
    assert ld.worst_drop(swing) == pytest.approx(exact, rel=1e-9)
    assert ld.worst_drop(ld.smooth_part(swing)) == pytest.approx(exact, rel=1e-9)
    spiked = swing.copy()
    spiked[123] += 20 * amp
    raw = ld.worst_drop(spiked)
    # the spike's sample and three crest samples, from the mean that the spike raised
    top = (20 * amp + amp * np.cos(2 * np.pi * t[123])
           + amp * (2 * np.cos(np.pi / n) + np.cos(3 * np.pi / n)) - 4 * 20 * amp / n)
    assert raw == pytest.approx(top / (n - 4), rel=1e-9)
    excess = raw - exact
    assert abs(ld.worst_drop(ld.smooth_part(spiked)) - exact) < 0.1 * excess
    # the figures as run-case reports them, over one period of samples at times t
    fig = ld.spike_figures(t, spiked, 0 * t, 0 * t, spiked, (0.0, 1.0))
    assert fig["drop_1pct_fx_N"] == pytest.approx(raw)
    assert abs(fig["smooth_drop_1pct_fx_N"] - exact) < 0.1 * excess


def test_flat_plate_friction_of_the_issue():
    """The issue's figure: about 290 N for a flat plate of 125.8 m2 at 1.3 m/s, L = 15 m
    (ITTC-57: Re = 1.95e7, Cf = 0.075 / (7.290 - 2)^2 = 2.680e-3)."""
    ref = ld.van_der_hoop_drag(1.3, 15.0, 3.0, 125.8, 1025.0, 1e-6)
    assert ref["reynolds"] == pytest.approx(1.95e7)
    assert ref["cf_ittc57"] == pytest.approx(2.680e-3, rel=1e-3)
    assert ref["flat_plate_N"] == pytest.approx(292.0, abs=1.0)
    # form factor at d / L = 0.2: 1 + 1.5 * 0.0894 + 7 * 0.008 = 1.190
    assert ref["form_factor"] == pytest.approx(1 + 1.5 * 0.2**1.5 + 7 * 0.2**3)
    assert ref["drag_N"] == pytest.approx(292.0 * 1.190, rel=5e-3)


def test_efficiency_and_cost_of_transport_worked_example():
    # gliding 350 N, swimming mean Fx 50 N: the stroke delivers 300 N at 1.3 m/s = 390 W
    c = ld.cost_figures(350.0, 50.0, 600.0, 1.3, 40000.0)
    assert c["thrust_N"] == 300.0
    assert c["froude_efficiency"] == pytest.approx(390.0 / 600.0)
    assert c["cost_of_transport_J_kg_m"] == pytest.approx(600.0 / (40000.0 * 1.3))
    with pytest.raises(AdapterError, match="not positive"):
        ld.cost_figures(350.0, 50.0, -1.0, 1.3, 40000.0)


def test_body_dimensions_of_a_box():
    """A 4 x 2 x 1 m box: area 28 m2, volume 8 m3, height 1 m, centroid and pitch inertia."""
    from adapter.body.surface import WhaleSurface

    p = np.array([[x, y, z] for x in (0, 4) for y in (-1, 1) for z in (-0.5, 0.5)], float)
    quads = np.array([[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4],
                      [1, 5, 7, 3]])
    surf = WhaleSurface(points=p, faces=[quads], landmarks={}, length=4.0)
    if surf.volume() < 0:
        surf = WhaleSurface(points=p, faces=[quads[:, ::-1].copy()], landmarks={}, length=4.0)
    d = ld.body_dimensions(surf, tail_base_s=1.01)
    assert d["wetted_area_m2"] == pytest.approx(28.0)
    assert d["volume_m3"] == pytest.approx(8.0)
    assert d["diameter_m"] == pytest.approx(1.0)
    # a box's centroid and its moment about y per density: V (lx^2 + lz^2) / 12
    assert d["centroid_m"] == pytest.approx([2.0, 0.0, 0.0], abs=1e-12)
    assert d["pitch_inertia_m5"] == pytest.approx(8.0 * (16.0 + 1.0) / 12.0)


SCENE = """
[geometry]
nodes = 1200
[stroke]
velocity_scale = 1.07368
[case]
background_cell_m = 4.0
refinement = [1, 2]
flipper_level = 0
cycles = 4
dt_s = 0.1
writes_per_cycle = 4
turbulence = "laminar"
layers = 0
gliding = true
[free]
cycles = 3
light_cycles = 1
"""


@pytest.mark.openfoam
@pytest.mark.plugin
@pytest.mark.slow
def test_run_case_runs_gliding_and_swimming_to_a_periodic_state(tmp_path):
    scene = tmp_path / "glide.toml"
    scene.write_text(SCENE)
    case = tmp_path / "case"
    res = subprocess.run([sys.executable, "-m", "adapter.cli", "run-case", "--scene",
                          str(scene), "--case", str(case)], capture_output=True, text=True,
                         timeout=600)
    assert res.returncode == 0, res.stderr[-3000:]
    assert "tethered: Froude efficiency" in res.stdout and "gliding drag" in res.stdout
    s = json.loads((case / "adapter-summary.json").read_text())["swimming_cost"]
    # the report beside it (tests/test_report.py opens one in a browser)
    page = (case / "report.html").read_text()
    assert "What swimming costs the whale" in page and "data:image/png;base64," in page
    assert "(report: " in res.stdout
    glide = ld.read_loads(case / "gliding")
    swim = ld.read_loads(case)
    period = 1 / 0.13
    # the swimming run stopped when periodic, before case.cycles; the gliding run when steady
    # or at case.cycles
    assert s["periodic_change"]["reached"]
    assert "periodic" in json.loads((case / "adapter-summary.json").read_text())[
        "stopped_because"]
    why = s["gliding_run"]["stopped_because"]
    assert why is None and glide["Time"][-1] > 4 * period - 1 or "steady" in why
    assert swim["Time"][-1] < 4 * period - 1  # stopped before case.cycles
    # the figures are the last period's time means of the written loads, each sample holding
    # over the step that ends at it (the scene's 0.1 s runs as 0.0957 s, a binary fraction:
    # adapter/foam/parameters.py; it does not divide the period)
    a = s["cycle_means"]["start_s"][-1]
    t = swim["Time"]
    dt = t[1] - t[0]
    np.testing.assert_allclose(np.diff(t), dt, rtol=1e-9)
    assert dt != pytest.approx(period / round(period / dt), rel=1e-3)
    held = np.clip(np.minimum(t, a + period) - np.maximum(t - dt, a), 0, None)
    assert held.sum() == pytest.approx(period)
    assert s["swimming_mean_fx_N"] == pytest.approx((held * swim["total:Fx"]).sum() / period)
    assert s["swimming_mean_power_W"] == pytest.approx((held * swim["total:P"]).sum() / period)
    g_last = glide["Time"] > glide["Time"][-1] - period
    assert s["gliding_drag_N"] == pytest.approx(glide["total:Fx"][g_last].mean(), rel=0.05)
    # gliding: the whale does not move, so it puts no power into the water
    np.testing.assert_allclose(glide["total:P"], 0.0, atol=1e-9)
    # the start-up is not measured: no cycle starts before the ramp ends
    assert s["cycle_means"]["start_s"][0] >= period - 1e-9
    assert (case / "forces.png").stat().st_size > 10_000
    # then the free whale from the tethered run's last time, and gliding at its speed
    free = json.loads((case / "adapter-summary.json").read_text())["self_propelled"]
    frame = ld.read_loads(case / "free")
    assert frame["Time"][0] > swim["Time"][-1] - 1e-9          # started where tethered ended
    assert "self-propelled speed U_sp" in res.stdout
    u_sp = free["speed_m_s"]
    assert u_sp > 0 and free["mean_power_W"] > 0
    # the figures' definitions (docs/free-swimming.md) from the summary's own parts
    assert free["quasi_propulsive_efficiency"] == pytest.approx(
        free["gliding_drag_at_speed_N"] * u_sp / free["mean_power_W"])
    assert free["cost_of_transport_J_kg_m"] == pytest.approx(
        free["mean_power_W"] / (free["mass_kg"] * u_sp))
    assert free["strouhal"] == pytest.approx(0.2 * 15.0 * 0.13 / u_sp, rel=1e-3)
    glide_sp = ld.read_loads(case / "gliding-free")
    assert glide_sp["Time"][0] > glide["Time"][-1] - 1e-9


def _free_case(tmp_path, speeds, fx_last: float):
    """A free case's record, frame log and loads: period 1 s, released at 0, an approach of
    0.5 s, so measured from 1.5 s; at 1.3 m/s until then, then a mean speed ``speeds[k]`` in
    the k-th period measured (a swing of zero mean on top); Fx 50 N of mean, ``fx_last`` in
    the last period."""
    from adapter.foam.case import Case

    case = tmp_path / "free"
    Case(case).save({"period_s": 1.0, "free_release_s": 0.0, "free_approach_s": 0.5,
                     "free": {"speed_tolerance": 0.005, "fx_tolerance": 0.01}})
    t = np.round(np.arange(1, 100 * (1.5 + len(speeds)) + 1) * 0.01, 10)
    k = np.clip(np.ceil(t - 1.5 - 1e-9).astype(int) - 1, -1, len(speeds) - 1)
    ux = np.where(k < 0, 1.3, np.asarray(speeds)[k]) + 0.05 * np.sin(2 * np.pi * t)
    fx = np.where(k == len(speeds) - 1, fx_last, 50.0) + 30 * np.sin(4 * np.pi * t)
    rows = [f"{a:.10g} {u:.10g} 0 0 0 {f:.10g} 0 1 0" for a, u, f in zip(t, ux, fx, strict=True)]
    (case / "adapter").mkdir()
    (case / "adapter" / "frame.dat").write_text("# Time Ux ...\n" + "\n".join(rows) + "\n")
    _write_loads(case / "postProcessing" / "loads" / "0" / "loads.dat", t, fx, 0 * t)
    return case


def test_the_free_run_is_measured_from_a_period_after_the_approach(tmp_path):
    """The stop rule takes the last two whole cycles from a period after the approach on (the
    running mean then a whole period's), whatever the mass: 1.5 s, 2.5 s, ... here."""
    from adapter.foam.freerun import measured_cycles, settled

    drag = 600.0
    case = _free_case(tmp_path / "a", [1.700, 1.702], 2.0)
    starts, speed, fx = measured_cycles(case)
    np.testing.assert_allclose(starts, [1.5, 2.5])
    np.testing.assert_allclose(speed, [1.700, 1.702], atol=1e-3)
    assert fx[-1] == pytest.approx(2.0, abs=0.5)
    assert "self-propelled" in settled(case, drag)
    # the speed still moving (0.6 %), Fx over 1 % of the drag, or one cycle only: not yet
    assert settled(_free_case(tmp_path / "b", [1.700, 1.710], 2.0), drag) is None
    assert settled(_free_case(tmp_path / "c", [1.700, 1.702], 9.0), drag) is None
    assert settled(_free_case(tmp_path / "d", [1.702], 2.0), drag) is None

