"""The flow study (adapter/studies/study.py, adapter/studies/gci.py): the GCI arithmetic against the
worked example of Celik et al. (2008), the three meshes' cell sizes, the study's machinery with a
model runner (known convergence, known self-propelled speed, stop and resume, chart, chooser),
and the study on the smoke whale with the real pimpleFoam."""

import json
import math
import time

import pytest

from adapter.errors import AdapterError
from adapter.foam import case as C
from adapter.foam import dictionaries as D
from adapter.foam import parameters as P
from adapter.foam import summary as SM
from adapter.studies import gci as G
from adapter.studies import study as S
from adapter.studies import study_analysis as A
from adapter.studies import study_report as R

from .conftest import NEEDS_FOAM_AND_PLUGIN


def test_gci_reproduces_celik_2008_table_1():
    """Celik et al. (2008), J. Fluids Eng. 130(7) 078001, Table 1, first column (2D meshes of
    18,000, 8,000 and 4,500 cells on the same domain; the reattachment length 6.063, 5.972,
    5.863). Published: r21 = 1.5, r32 = 1.333, p = 1.53, phi_ext21 = 6.1685, e_a21 = 1.5 %,
    e_ext21 = 1.7 %, GCI_fine21 = 2.2 %."""
    h = [G.representative_h(n, 76.0, dim=2) for n in (18000, 8000, 4500)]
    r21, r32 = h[1] / h[0], h[2] / h[1]
    assert round(r21, 3) == 1.5 and round(r32, 3) == 1.333
    g = G.gci(6.063, 5.972, 5.863, r21, r32)
    assert g["convergence"] == "monotone"
    assert round(g["p"], 2) == 1.53
    assert round(g["extrapolated"], 4) == 6.1685
    assert round(100 * g["e_a"], 1) == 1.5
    assert round(100 * g["e_ext"], 1) == 1.7
    assert round(100 * g["gci_fine"], 1) == 2.2
    assert g["gci_fine_abs"] == pytest.approx(g["gci_fine"] * 6.063)


def test_gci_with_one_ratio_is_the_closed_form_and_classifies_convergence():
    r = 1.3
    f1, f2, f3 = 10.0, 10.5, 11.4  # monotone: R = 0.5 / 0.9
    g = G.gci(f1, f2, f3, r)
    p = math.log((f3 - f2) / (f2 - f1)) / math.log(r)
    assert g["p"] == pytest.approx(p, rel=1e-12)
    assert g["extrapolated"] == pytest.approx(f1 + (f1 - f2) / (r**p - 1))
    assert g["gci_fine_abs"] == pytest.approx(1.25 * 0.5 / (r**p - 1))
    # an exact power law: f = 3 + 2 h^2 on h = 1, 1.3, 1.69 gives p = 2 and f_ext = 3
    fs = [3 + 2 * hh**2 for hh in (1.0, 1.3, 1.69)]
    g2 = G.gci(*fs, 1.3)
    assert g2["p"] == pytest.approx(2.0, rel=1e-9)
    assert g2["extrapolated"] == pytest.approx(3.0, rel=1e-12)
    assert G.gci(10.0, 9.8, 10.3, r)["convergence"] == "oscillatory"
    div = G.gci(10.0, 11.0, 11.5, r)
    assert div["convergence"] == "divergent" and div["gci_fine"] is None


def _smoke_with_layers(smoke_scene):
    # the automatic step (dt_s = 0): the study fixes mesh 2's on all three
    return smoke_scene.replace(case={"layers": 3, "first_layer_m": 0.05,
                                     "layer_expansion": 1.5, "dt_s": 0.0,
                                     "writes_per_cycle": 4})


@pytest.mark.slow
@pytest.mark.parametrize("finest, own, layers", [("scene", 1, "first-kept"),
                                                 ("refined", 2, "first-kept"),
                                                 ("refined", 2, "similar")])
def test_three_meshes_scale_every_cell_by_the_ratio(tmp_path, smoke_scene, smoke_surface,
                                                    finest, own, layers):
    """Background cell and the prism stack scale by r (``similar``: every layer, count and
    expansion kept; ``first-kept``: the stack, first layer kept), mesh ``own`` is the scene's,
    dt is the same on all three; the dictionaries prepare_case writes carry it."""
    scene = _smoke_with_layers(smoke_scene)
    r = 1.4
    cases = {c["name"]: c for c in S.plan_cases(scene, smoke_surface, r, (0.9, 1.0, 1.1),
                                                 finest=finest, layers=layers)}
    assert list(cases) == ["mesh-3/case", "mesh-2/case", "mesh-1/case", "mesh-2/dt-half",
                           "mesh-2/speed-0.9", "mesh-2/speed-1.1"]
    stack0 = S.stack_thickness(0.05, 3, 1.5)
    params = {}
    for k in (1, 2, 3):
        sc = cases[f"mesh-{k}/case"]["scene"]
        assert sc.case.background_cell == pytest.approx(scene.case.background_cell
                                                        * r ** (k - own))
        first = 0.05 * r ** (k - own) if layers == "similar" else 0.05
        assert sc.case.first_layer_m == pytest.approx(first, rel=1e-12)
        # the fins' own first layer (the default's 2 mm) follows the body's rule
        fin = 0.002 * r ** (k - own) if layers == "similar" else 0.002
        assert sc.case.fin_first_layer_m == pytest.approx(fin, rel=1e-12)
        if layers == "similar":
            assert (sc.case.layers, sc.case.layer_expansion) == (3, 1.5)
        assert S.stack_thickness(sc.case.first_layer_m, sc.case.layers,
                                 sc.case.layer_expansion) == pytest.approx(
                                                                     stack0 * r ** (k - own),
                                                                     rel=1e-5)
        assert sc.case.refinement == scene.case.refinement
        params[k] = C.prepare_case(sc, tmp_path / f"m{k}", surface=smoke_surface)
        snappy = D.parsed_dict(tmp_path / f"m{k}" / "system" / "snappyHexMeshDict")
        assert snappy["addLayersControls"]["expansionRatio"] == pytest.approx(
            sc.case.layer_expansion)
        assert snappy["addLayersControls"]["firstLayerThickness"] == pytest.approx(first)
    h = {k: math.prod(params[k].cell_size) ** (1 / 3) for k in params}
    assert h[2] / h[1] == pytest.approx(r, rel=0.08) and h[3] / h[2] == pytest.approx(r, rel=0.08)
    assert params[1].delta_t == params[2].delta_t == params[3].delta_t
    half = P.case_parameters(cases["mesh-2/dt-half"]["scene"], smoke_surface.points.min(axis=0),
                             smoke_surface.points.max(axis=0), length=smoke_surface.length)
    assert half.delta_t == params[2].delta_t / 2
    # the step is the scene's own mesh's automatic one, not the finest mesh's
    own_dt = P.case_parameters(scene, smoke_surface.points.min(axis=0),
                               smoke_surface.points.max(axis=0),
                               length=smoke_surface.length).delta_t
    assert params[1].delta_t == own_dt
    if finest == "refined":
        assert params[1].delta_t != P.case_parameters(
            S.mesh_scene(scene, 1, r, finest), smoke_surface.points.min(axis=0),
            smoke_surface.points.max(axis=0), length=smoke_surface.length).delta_t
    assert cases["mesh-2/speed-1.1"]["scene"].flow.speed_m_s == pytest.approx(
        1.1 * scene.flow.speed_m_s)
    with pytest.raises(AdapterError, match="at least 1.3"):
        S.plan_cases(scene, smoke_surface, 1.2)


def test_the_study_runs_tethered_pairs_without_the_free_stage(smoke_scene, smoke_surface):
    """The default scene swims free after its pair (free.enabled); the study's cases do not:
    docs/case.md's study is pairs, its self-propelled speed the speeds part's root."""
    scene = smoke_scene.replace(free={"enabled": True})
    cases = S.plan_cases(scene, smoke_surface, 1.3, (0.9, 1.0, 1.1))
    assert len(cases) == 6
    assert not any(c["scene"].free.enabled for c in cases)


def test_a_study_planned_before_the_layer_rules_continues_with_the_first_layer_kept(
        tmp_path, smoke_scene, smoke_surface):
    """study-plan.json files written before ``layers`` existed were studies that kept the first
    layer: asked for similar layers they are refused, naming the rule they ran; asked for
    first-kept they continue (here: to the first case's run, where the model stops)."""
    kw = dict(ratio=1.3, speeds=(0.85, 1.0, 1.15), surface=smoke_surface, progress=False,
              finest="scene")
    plan = {"scene_file": None, "preset": smoke_scene.name, "ratio": 1.3,
            "speeds": [0.85, 1.0, 1.15], "finest": "scene"}
    (tmp_path / S.PLAN).write_text(json.dumps(plan))
    model = _Model(stop_at=1)
    with pytest.raises(AdapterError, match="layers: 'first-kept'; asked: layers: 'similar'"):
        S.run_study(smoke_scene, tmp_path, runner=model.runner, mesher=model.mesher,
                    layers="similar", **kw)
    assert model.calls == []
    with pytest.raises(KeyboardInterrupt):
        S.run_study(smoke_scene, tmp_path, runner=model.runner, mesher=model.mesher,
                    layers="first-kept", **kw)
    assert model.calls == ["mesh-3/case"]
    assert json.loads((tmp_path / S.PLAN).read_text())["layers"] == "first-kept"


def test_layer_rule_changes_the_layer_count_when_the_expansion_cannot_reach():
    n, e = S.layer_rule(0.008, 3, 1.5, 1 / 2.0)  # 19 mm: below 3 x 8 mm at expansion 1
    assert n == 2 and 1.0 <= e <= 3.0
    assert S.stack_thickness(0.008, n, e) == pytest.approx(0.019, rel=1e-5)


class _Model:
    """A stand-in for OpenFOAM: figures that follow f = f0 + c h^2 on the background cell h,
    mean Fx = 300 (U^2 - 1.96) + 0.5 h^2 at speed U; the case's summary as run_swim_and_glide
    writes it. ``stop_at``: raise KeyboardInterrupt (a stop) at that call."""

    def __init__(self, stop_at=None):
        self.calls = []
        self.stop_at = stop_at

    def mesher(self, case):
        (case / "constant" / "polyMesh").mkdir(parents=True, exist_ok=True)
        (case / "constant" / "polyMesh" / "owner").write_text("model")
        rec = C.read_record(case)
        h = math.prod(rec["parameters"]["cell_size"]) ** (1 / 3)
        rec["mesh"] = {"cells": int(1e5 / h**3)}
        C.write_json(case / C.CASE_RECORD, rec)
        return rec["mesh"]

    def runner(self, case, record, tolerance, ranks, progress):
        self.calls.append(case.relative_to(case.parents[1]).as_posix())
        if self.stop_at is not None and len(self.calls) == self.stop_at:
            raise KeyboardInterrupt
        h = math.prod(record["parameters"]["cell_size"]) ** (1 / 3)
        u = record["speed_m_s"]
        cost = {"gliding_drag_N": 500 + 2 * h**2, "swimming_mean_fx_N":
                300 * (u**2 - 1.96) + 0.5 * h**2, "swimming_mean_power_W": 1000 * u + 5 * h**2,
                "mass_kg": 2000.0, "periodic_change": {"reached": True},
                "regions": {"body": {"gliding_drag_N": 300 + h**2}}}
        summary = {"swimming_cost": cost, "steps": 10, "step_s": 0.5 * 1e5 / h**3 / 1e4,
                   "cells": record["mesh"]["cells"], "yplus": {}}
        C.write_json(case / SM.SUMMARY, summary)
        return summary


@pytest.mark.slow
def test_study_machinery_with_a_model_runner_stops_resumes_and_answers(tmp_path, smoke_scene,
                                                                        smoke_surface, capsys):
    out = tmp_path / "study"
    kw = dict(ratio=1.3, speeds=(0.85, 1.0, 1.15), surface=smoke_surface, progress=False)
    first = _Model(stop_at=3)
    with pytest.raises(KeyboardInterrupt):
        S.run_study(smoke_scene, out, runner=first.runner, mesher=first.mesher, **kw)
    assert first.calls == ["mesh-3/case", "mesh-2/case", "mesh-1/case"]
    second = _Model()
    lines = []
    study = S.run_study(smoke_scene, out, runner=second.runner, mesher=second.mesher,
                        log=lines.append, **kw)
    # the finished cases are skipped; the stopped one continues (not prepared again)
    assert second.calls == ["mesh-1/case", "mesh-2/dt-half", "mesh-2/speed-0.85",
                            "mesh-2/speed-1.15"]
    assert any("mesh-3/case: finished earlier, skipped" in x for x in lines)
    assert any("mesh-1/case: continuing it" in x for x in lines)
    assert any("speed-0.85: mesh copied from mesh-2/case" in x for x in lines)
    assert (out / "mesh-2/speed-0.85/constant/polyMesh/owner").read_text() == "model"
    # a third run has nothing to do
    third = _Model()
    S.run_study(smoke_scene, out, runner=third.runner, mesher=third.mesher, **kw)
    assert third.calls == []
    # the arithmetic: p = 2 and the h -> 0 values
    saved = json.loads((out / S.RESULT).read_text())
    figs = saved["meshes"]["figures"]
    for key, f0 in (("gliding_drag", 500.0), ("swimming_fx", 300 * (1.3**2 - 1.96)),
                    ("swimming_power", 1300.0)):
        assert figs[key]["convergence"] == "monotone"
        assert figs[key]["p"] == pytest.approx(2.0, rel=1e-6)
        assert figs[key]["extrapolated"] == pytest.approx(f0, abs=1e-6)
    body = saved["meshes"]["regions"]["gliding_drag"]["body"]   # from each case's summary
    assert body["p"] == pytest.approx(2.0, rel=1e-6)
    assert body["extrapolated"] == pytest.approx(300.0, abs=1e-6)
    h2 = saved["cases"]["mesh-2/case"]["background_cell_m"]
    assert figs["swimming_fx"]["difference"]["2"] == pytest.approx(0.5 * h2**2 / 500, rel=1e-6)
    assert saved["time_step"]["swimming_power_change"] == 0.0
    sp = saved["self_propelled"]
    assert sp["status"] == "ok" and sp["bracketed"]
    us = math.sqrt(1.96 - 0.5 * h2**2 / 300)
    assert sp["speed_m_s"] == pytest.approx(us, rel=1e-9)
    assert sp["power_W"] == pytest.approx(1000 * us + 5 * h2**2, rel=1e-9)
    assert sp["cost_of_transport_J_kg_m"] == pytest.approx(sp["power_W"] / (2000 * us))
    # mesh 2's band: 1.25 x 0.5 h2^2 on Fx, over dFx/dU = 600 U*
    assert sp["speed_uncertainty_m_s"] == pytest.approx(1.25 * 0.5 * h2**2 / (600 * us),
                                                        rel=1e-6)
    assert (out / S.CHART).stat().st_size > 10_000
    page = (out / R.REPORT).read_text()   # the page: tests/test_report.py opens one in chromium
    assert "mesh-2/speed-1.15" in page and page.count("data:image/png;base64,") == 1
    table = R.format_study(study)
    assert "mean power (W)" in table and "self-propelled speed" in table
    # the chooser: the coarsest mesh within the tolerance
    d = {k: max(g["difference"][str(k)] for g in figs.values()) for k in (1, 2, 3)}
    assert d[1] < d[2] < d[3]
    assert A.choose_flow_mesh(saved, d[2] * 1.01)["mesh"] == 2
    assert A.choose_flow_mesh(saved, d[3] * 1.01)["mesh"] == 3
    none = A.choose_flow_mesh(saved, d[1] / 2)
    h1 = saved["cases"]["mesh-1/case"]["background_cell_m"]
    assert none["mesh"] is None and none["background_cell_m_needed"] < h1
    # the model's order 2: half the error at h1 / sqrt(2), within the study's span (h3 to h1,
    # 1 / 1.69 of h1); a hundredth at h1 / 10, far beyond it
    assert none["background_cell_m_needed"] == pytest.approx(h1 / math.sqrt(2), rel=1e-6)
    assert not none["beyond_study"]
    far = A.choose_flow_mesh(saved, d[1] / 100)
    assert far["background_cell_m_needed"] == pytest.approx(h1 / 10, rel=1e-6)
    assert far["beyond_study"]
    from adapter.cli import main

    assert main(["choose", "--flow-study", str(out), "--tolerance", str(d[2] * 1.01)]) == 0
    assert "mesh-2 (background cell" in capsys.readouterr().out
    # another plan in the same folder is refused
    with pytest.raises(AdapterError, match="another plan"):
        S.run_study(smoke_scene, out, runner=third.runner, mesher=third.mesher,
                    **{**kw, "ratio": 1.5})
    with pytest.raises(AdapterError, match="another plan.*layers: 'similar'.*'first-kept'"):
        S.run_study(smoke_scene, out, runner=third.runner, mesher=third.mesher,
                    **{**kw, "layers": "first-kept"})
    # so is the same plan with any other value of the scene (not only another file's name)
    other = smoke_scene.replace(stroke={"frequency_hz": smoke_scene.stroke.frequency_hz * 1.1})
    with pytest.raises(AdapterError, match="another scene.*stroke.frequency_hz"):
        S.run_study(other, out, runner=third.runner, mesher=third.mesher, **kw)


#: the smoke whale with long flow steps: 8 a cycle (a binary period of 8 s, steps of 1 s),
#: two cycles (16 steps) per run: the start-up and one measured cycle
FAST = {"stroke": {"frequency_hz": 0.125, "ramp_cycles": 1.0},
        "case": {"cycles": 2.0, "dt_s": 1.0, "writes_per_cycle": 2, "gliding": True,
                 "inflow_ramp_cycles": 0.5}}


def _foam(test):
    for mark in reversed(NEEDS_FOAM_AND_PLUGIN):
        test = mark(test)
    return test


@_foam
def test_study_on_the_smoke_whale_with_pimplefoam(tmp_path, smoke_scene, smoke_surface):
    """The mesh part on three real smoke meshes (blockMesh, snappyHexMesh, the gliding and
    swimming pair with the step-server), tiny cycles; study.json and the chart."""
    scene = smoke_scene.replace(**FAST)
    out = tmp_path / "study"
    t0 = time.perf_counter()
    study = S.run_study(scene, out, ratio=1.3, parts=("meshes",), surface=smoke_surface,
                        progress=False)
    wall = time.perf_counter() - t0
    assert study["failed"] == {} and study["not_finished"] == [], study
    cells = [study["cases"][f"mesh-{k}/case"]["cells"] for k in (1, 2, 3)]
    assert cells[0] > cells[1] > cells[2]
    for k in (1, 2, 3):
        rec = C.read_record(out / f"mesh-{k}" / "case")
        assert rec["parameters"]["delta_t"] == 1.0
        assert (out / f"mesh-{k}" / "case" / "gliding" / SM.SUMMARY).is_file()
    assert set(study["meshes"]["figures"]) == {"gliding_drag", "swimming_fx", "swimming_power"}
    assert (out / S.CHART).is_file() and (out / S.RESULT).is_file()
    # run again: every case finished, nothing runs
    lines = []
    S.run_study(scene, out, ratio=1.3, parts=("meshes",), surface=smoke_surface,
                progress=False, log=lines.append)
    assert sum("finished earlier, skipped" in x for x in lines) == 3, lines
    print(f"smoke study, three meshes: {wall:.1f} s")


def test_oscillating_or_diverging_meshes_are_not_extrapolated():
    """Celik's p from |R| near 1 extrapolates far outside the values (mean Fx -886, -934, -884
    on the default gave +405 N): an oscillating sequence keeps the finest mesh's value with
    half the range as its band (Stern et al. 2001), a diverging one the whole spread, flagged
    as a lower bound; a monotone one is still extrapolated."""
    h = {1: 1.0, 2: 1.3, 3: 1.69}

    def meshes(drag, fx, power):
        return {k: {"background_cell_m": h[k], "gliding_drag": drag[k - 1],
                    "swimming_fx": fx[k - 1], "swimming_power": power[k - 1]} for k in h}

    ms = A.mesh_study(meshes([650.25, 626.53, 621.45], [-885.6, -934.2, -883.8],
                             [1000.0, 1010.0, 1030.0]))
    fx, drag, power = (ms["figures"][k] for k in ("swimming_fx", "gliding_drag",
                                                   "swimming_power"))
    assert fx["convergence"] == "oscillatory" and fx["reference"].startswith("finest")
    assert fx["band_mesh2_abs"] == pytest.approx(0.5 * (934.2 - 883.8))
    assert fx["difference"]["1"] == 0.0
    assert drag["convergence"] == "divergent" and drag["band_is_lower_bound"]
    assert drag["band_mesh2_abs"] == pytest.approx(650.25 - 621.45)
    # monotone: e21 = 10, e32 = 20 at r = 1.3: p = ln 2 / ln 1.3 = 2.64, above the formal 2,
    # so f_ext = 1000 - 10 / (1.3^2 - 1) (with p observed it would be 990)
    assert power["convergence"] == "monotone" and power["reference"] == "extrapolated"
    assert power["extrapolated"] == pytest.approx(1000 - 10 / 0.69, rel=1e-9)


def test_an_order_above_the_formal_one_is_capped_and_one_too_slow_is_not_extrapolated():
    """f = 100 + c h^p on h = 1, 1.3, 1.69: p = 3 is above the schemes' formal order 2, so the
    extrapolation and the GCI take p = 2 (Roache), and say so; p = 0.2 is below 0.5: no
    extrapolation, the spread a lower bound, the chooser vouches for no mesh."""
    h = {1: 1.0, 2: 1.3, 3: 1.69}

    def figure(p):
        return [100 + h[k] ** p for k in (1, 2, 3)]

    cases = {f"mesh-{k}/case": {"background_cell_m": h[k], "gliding_drag": figure(0.2)[k - 1],
                                "swimming_fx": -figure(1.0)[k - 1],
                                "swimming_power": figure(3.0)[k - 1], "cells": 1000 * k,
                                "wall_s_per_cycle": 10.0 / k} for k in h}
    ms = A.mesh_study({k: cases[f"mesh-{k}/case"] for k in h})
    drag, fx, power = (ms["figures"][k] for k in ("gliding_drag", "swimming_fx",
                                                   "swimming_power"))
    f1, f2 = figure(3.0)[:2]
    assert power["order_capped"] and power["p_observed"] == pytest.approx(3.0, rel=1e-9)
    assert power["p"] == 2.0
    assert power["extrapolated"] == pytest.approx((1.69 * f1 - f2) / 0.69, rel=1e-12)
    assert power["gci_fine_abs"] == pytest.approx(1.25 * (f2 - f1) / 0.69, rel=1e-12)
    assert fx["p"] == pytest.approx(1.0, rel=1e-9) and not fx.get("order_capped")
    assert drag["convergence"] == "too slow" and drag["extrapolated"] is None
    assert drag["p_observed"] == pytest.approx(0.2, rel=1e-9) and drag["band_is_lower_bound"]
    # mean Fx is measured against the finest mesh's drag, not an extrapolation of it
    assert fx["scale"] == pytest.approx(figure(0.2)[0])
    report = A.choose_flow_mesh({"cases": cases, "meshes": ms}, 0.5)
    assert report["mesh"] is None and report["divergent"] == ["gliding drag (N)"]
    table = R.format_study({"cases": cases, "meshes": ms})
    assert "observed order 3.00, above the formal 2" in table
    assert "observed order 0.20: too slow to extrapolate" in table


def test_the_chooser_counts_the_band_of_an_unextrapolated_value_and_refuses_divergence():
    """A mesh is never "0 % off" its own value: where the three oscillate, every mesh's error
    is its difference from mesh 1 plus mesh 1's band (half the range); where one figure
    diverges, no mesh is vouched for (the real default study: drag 661 / 690 / 695 N)."""
    h = {1: 1.0, 2: 1.3, 3: 1.69}

    def study(drag, fx, power):
        cases = {f"mesh-{k}/case": {"background_cell_m": h[k], "gliding_drag": drag[k - 1],
                                    "swimming_fx": fx[k - 1], "swimming_power": power[k - 1],
                                    "cells": 1000 * k, "wall_s_per_cycle": 10.0 / k}
                 for k in h}
        return {"cases": cases, "meshes": A.mesh_study(
            {k: cases[f"mesh-{k}/case"] for k in h})}

    # all three oscillate: 100, 97, 104 (R = -3/7): band 3.5; mesh 2 is 3 + 3.5 off, mesh 3 4 + 3.5
    osc = study([100.0, 97.0, 104.0], [-100.0, -97.0, -104.0], [1000.0, 970.0, 1040.0])
    assert all(g["convergence"] == "oscillatory" for g in osc["meshes"]["figures"].values())
    assert A.choose_flow_mesh(osc, 0.036)["mesh"] == 1
    assert A.choose_flow_mesh(osc, 0.034)["mesh"] is None
    assert A.choose_flow_mesh(osc, 0.066)["mesh"] == 2
    chosen = A.choose_flow_mesh(osc, 0.076)
    assert chosen["mesh"] == 3 and chosen["worst_difference"] == pytest.approx(0.075)
    # the table gives Celik's GCI of an oscillating figure beside its band: p from |R| = 3/7
    p = math.log(7 / 3) / math.log(1.3)
    gci = 1.25 * 0.03 / (1.3**p - 1)
    table = R.format_study({**osc, "cases": {k: {**c, "cells": 1000}
                                             for k, c in osc["cases"].items()}})
    assert f"band +-35; Celik's GCI from |R| {gci:.2%} (p {p:.2f})" in table
    # one figure diverges: nothing can be vouched for, whatever the tolerance
    div = study([660.7, 690.0, 694.5], [-100.0, -97.0, -104.0], [4149.5, 4044.1, 4261.8])
    report = A.choose_flow_mesh(div, 0.5)
    assert report["mesh"] is None and report["divergent"] == ["gliding drag (N)"]
    assert report["worst_difference"] == pytest.approx((694.5 - 660.7) / 660.7)


def test_the_time_step_check_compares_the_same_cycle_of_both_runs():
    """The default run stopped after four cycles, the halved step after three: the check takes
    the third of each, not each run's last (which differ by the periodic tolerance alone)."""
    period = 1 / 0.13
    starts = [period * k for k in (1, 2, 3, 4)]
    base = {"delta_t_s": 0.08, "gliding_drag": 500.0, "swimming_fx": -952.0,
            "swimming_power": 4400.0,
            "cycle_means": {"start_s": starts, "fx_N": [-930.0, -960.0, -950.0, -952.0],
                            "power_W": [4300.0, 4460.0, 4430.0, 4400.0]}}
    half = {"delta_t_s": 0.04, "gliding_drag": 505.0, "swimming_fx": -965.0,
            "swimming_power": 4440.0,
            "cycle_means": {"start_s": starts[:3], "fx_N": [-940.0, -975.0, -965.0],
                            "power_W": [4350.0, 4470.0, 4451.5]}}
    ts = A.time_step_check(base, half)
    assert ts["cycle_start_s"] == pytest.approx(3 * period)
    assert ts["swimming_fx_change_of_drag"] == pytest.approx(15.0 / 500.0)   # not 13 / 500
    assert ts["swimming_power_change"] == pytest.approx(21.5 / 4430.0)       # not 40 / 4400
    assert ts["gliding_drag_change"] == pytest.approx(5.0 / 500.0)
    assert "(the cycle from 23.08 s in both)" in R.format_study({"cases": {}, "time_step": ts})
    # an older study's results without cycle means: their last cycles, as before
    for r in (base, half):
        del r["cycle_means"]
    ts = A.time_step_check(base, half)
    assert ts["cycle_start_s"] is None
    assert ts["swimming_fx_change_of_drag"] == pytest.approx(13.0 / 500.0)


def test_the_mesh_study_compares_the_same_cycle_of_every_mesh():
    """Mesh 1 stopped after four cycles, meshes 2 and 3 after three: the study takes the third
    of each (the same flow time on every mesh), not each run's last."""
    period = 1 / 0.13
    starts = [period * k for k in (1, 2, 3, 4)]

    def mesh(h, drag, fx, power):
        n = len(fx)
        return {"background_cell_m": h, "gliding_drag": drag, "swimming_fx": fx[-1],
                "swimming_power": power[-1], "wall_s_per_cycle": 40.0 / h, "cells": 1000,
                "cycle_means": {"start_s": starts[:n], "fx_N": fx, "power_W": power}}

    meshes = {1: mesh(1.0, 520.0, [-1000.0, -1030.0, -1025.0, -1027.0],
                      [4450.0, 4480.0, 4476.0, 4470.0]),
              2: mesh(1.3, 560.0, [-950.0, -980.0, -971.0], [4400.0, 4490.0, 4460.0]),
              3: mesh(1.69, 605.0, [-850.0, -880.0, -874.0], [4300.0, 4390.0, 4383.0])}
    matched, start = A.same_cycle(meshes)
    assert start == pytest.approx(3 * period)
    assert [matched[k]["swimming_fx"] for k in (1, 2, 3)] == [-1025.0, -971.0, -874.0]
    assert [matched[k]["swimming_power"] for k in (1, 2, 3)] == [4476.0, 4460.0, 4383.0]
    assert meshes[1]["swimming_fx"] == -1027.0            # the caller's results untouched
    ms = A.meshes_compared(meshes)
    assert ms["cycle_start_s"] == pytest.approx(3 * period)
    assert ms["figures"]["swimming_fx"]["values"] == [-1025.0, -971.0, -874.0]
    cases = {f"mesh-{k}/case": meshes[k] for k in (1, 2, 3)}
    table = R.format_study({"cases": cases, "meshes": ms})
    assert "Fx and power over the cycle from 23.08 s on every mesh" in table
    assert "   -1025.0     4476.0" in table                 # mesh 1's row: cycle 3, not 4
    # one mesh without cycle means (an older study): every mesh's own last cycle
    del meshes[2]["cycle_means"]
    same, start = A.same_cycle(meshes)
    assert start is None and same[1]["swimming_fx"] == -1027.0


def test_the_study_names_its_scene_file_and_the_preset_under_it(tmp_path, smoke_scene):
    # a scene file layered on a preset is not that preset: study.json, the chart's title and
    # the report say the file
    named = A.analyse(tmp_path, smoke_scene, [], 1.3, scene_file=tmp_path / "edges.toml")
    assert named["scene"] == "edges (smoke)"
    assert A.analyse(tmp_path, smoke_scene, [], 1.3)["scene"] == "smoke"
