"""The free whale in the real pimpleFoam (adapter/foam/freerun.py, the plugin's frame inflow
and body force): on the smoke whale, Newton's law between what OpenFOAM says: the change of
the inlet velocity it applied against the impulse of the force its loads function object
measured, over the whale's mass."""

from __future__ import annotations

import pytest

from adapter.coupling.surge import inertia_of
from adapter.foam import loads as ld
from adapter.foam.case import Case, prepare_case
from adapter.foam.dictionaries import use_frame_inflow
from adapter.foam.freerun import read_frame_log, written_inlet_speed
from adapter.foam.mesh import mesh_case
from adapter.foam.run import run_case
from adapter.scene import load_scene

pytestmark = [pytest.mark.openfoam, pytest.mark.plugin, pytest.mark.slow]


def free_smoke_case(tmp_path, **free):
    """The smoke case released at t = 0 in a uniform stream at the scene's speed (no ramp, no
    lighter mass unless asked), its inflow the frame's."""
    scene = load_scene(preset="smoke").replace(case={"cycles": 0.1, "inflow_ramp_cycles": 0.0},
                                               free={"enabled": True, "light": 1.0, **free})
    case = tmp_path / "case"
    prepare_case(scene, case)
    mesh_case(case)
    record = Case(case).record
    record["free_release_s"] = 0.0
    record["free_reference_drag_N"] = 100.0
    Case(case).save(record)
    use_frame_inflow(case)
    return case, scene


def test_the_inflow_follows_the_momentum_balance(tmp_path):
    case, scene = free_smoke_case(tmp_path)
    run_case(case, progress=False)
    data, frame = ld.read_loads(case), read_frame_log(case)
    mass = inertia_of(Case(case).record).mass_kg
    t_end, u_end = written_inlet_speed(case)
    steps = data["Time"] <= t_end + 1e-9
    dt = float(Case(case).record["parameters"]["delta_t"])
    # step n's force sets step n+1's acceleration: the impulse of all steps but the last
    impulse = -float(data["total:Fx"][steps][:-1].sum()) * dt
    change = u_end - scene.flow.speed_m_s
    assert abs(change) > 1e-4                      # the whale did change its speed
    assert mass * change == pytest.approx(impulse, rel=0.01)
    # and the step-server's log agrees with what OpenFOAM applied at the inlet
    assert frame["Ux"][frame["Time"] <= t_end + 1e-9][-1] == pytest.approx(u_end, rel=1e-6)


def test_heave_and_pitch_recoil_run_in_the_flow(tmp_path):
    case, scene = free_smoke_case(tmp_path, heave=True, pitch=True)
    run_case(case, progress=False)
    frame = read_frame_log(case)
    t_end, u_end = written_inlet_speed(case)
    assert frame["Time"][-1] == pytest.approx(t_end)
    # the whale pitched and heaved a little, and stayed finite
    assert 0 < abs(frame["pitch"]).max() < 0.1 and abs(frame["Uz"]).max() > 0
    assert abs(u_end - scene.flow.speed_m_s) < 0.5
