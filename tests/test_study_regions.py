"""The flow study's error bars by region (adapter/studies/study_analysis.py, region_study and
region_cycle_fx): each region's gliding drag and mean swimming Fx through the three-mesh
procedure of Celik et al. (2008), against closed forms, hand-made loads and the verdicts on the
default study's figures."""

import json
import math

import pytest

from adapter.foam import symmetry
from adapter.studies import study_analysis as A
from adapter.studies import study_report as R

H = {1: 1.0, 2: 1.3, 3: 1.69}
PERIOD = 1 / 0.13
STARTS = [PERIOD * k for k in (1, 2, 3, 4)]


def _meshes(gliding: dict, cycle_fx: dict) -> dict:
    """Three meshes' results with these regions' gliding drag ({region: [f1, f2, f3]}) and
    mean Fx per cycle ({region: [[mesh 1's cycles], [mesh 2's], [mesh 3's]]})."""
    cycles = {k: len(next(iter(cycle_fx.values()))[k - 1]) for k in H}
    return {k: {"background_cell_m": H[k], "gliding_drag": 500.0 + H[k],
                "swimming_fx": -900.0 - H[k], "swimming_power": 4000.0 + H[k],
                "cells": 1000, "wall_s_per_cycle": 10.0,
                "cycle_means": {"start_s": STARTS[:cycles[k]], "fx_N": [-900.0 - H[k]] * cycles[k],
                                "power_W": [4000.0 + H[k]] * cycles[k]},
                "region_gliding_drag": {name: v[k - 1] for name, v in gliding.items()},
                "region_cycle_fx": {name: v[k - 1] for name, v in cycle_fx.items()}}
            for k in H}


def test_each_region_has_its_own_convergence_and_gci():
    """Gliding drag: the body f = 300 + h^2 on h = 1, 1.3, 1.69 (p = 2; GCI by hand 1.25 (f2 -
    f1) / (1.3^2 - 1) = 1.25 N, 0.4153 % of f1); the flippers and flukes of the default study
    of 2026-12-07 (147.4, 167.1, 183.8 N: the differences grow; 60.9, 79.6, 100.6 N: order
    0.44, too slow). Mean Fx: the flukes -1700 + 30 h^2 on the third cycle, which all three
    measured (mesh 1 ran a fourth, -1.0e6 here so that taking it would show); the body
    oscillating 451.3 / 449.2 / 471.7 N: half the range, 11.25 N, as for the totals."""
    flukes = [[-1.0e9, -1.0e9, -1700 + 30 * H[1] ** 2, -1.0e6],
              [-1.0e9, -1.0e9, -1700 + 30 * H[2] ** 2], [-1.0e9, -1.0e9, -1700 + 30 * H[3] ** 2]]
    body = [[0, 0, 451.3, 0], [0, 0, 449.2], [0, 0, 471.7]]
    meshes = _meshes({"body": [300 + H[k] ** 2 for k in H], "flippers": [147.4, 167.1, 183.8],
                      "flukes": [60.9, 79.6, 100.6]}, {"body": body, "flukes": flukes})
    regions = A.meshes_compared(meshes)["regions"]
    glide, swim = regions["gliding_drag"], regions["swimming_fx"]
    assert glide["body"]["convergence"] == "monotone"
    assert glide["body"]["p"] == pytest.approx(2.0, rel=1e-9)
    assert glide["body"]["extrapolated"] == pytest.approx(300.0, rel=1e-12)
    assert glide["body"]["gci_fine_abs"] == pytest.approx(1.25, rel=1e-9)
    assert glide["body"]["gci_fine_of_value"] == pytest.approx(1.25 / 301.0, rel=1e-9)
    assert glide["flippers"]["convergence"] == "divergent"
    assert glide["flippers"].get("gci_fine_of_value") is None
    assert glide["flukes"]["convergence"] == "too slow"
    assert glide["flukes"]["p_observed"] == pytest.approx(math.log(21.0 / 18.7) / math.log(1.3))
    assert swim["flukes"]["values"] == pytest.approx([-1700 + 30 * H[k] ** 2 for k in H])
    assert swim["flukes"]["extrapolated"] == pytest.approx(-1700.0, rel=1e-12)
    assert swim["flukes"]["gci_fine_abs"] == pytest.approx(1.25 * 30 * 0.69 / 0.69, rel=1e-9)
    assert swim["body"]["convergence"] == "oscillatory"
    assert swim["body"]["band_abs"] == pytest.approx(11.25)
    assert swim["body"].get("gci_fine_of_value") is None
    table = R.format_study({"cases": {f"mesh-{k}/case": meshes[k] for k in H},
                            "meshes": A.meshes_compared(meshes)})
    assert "body         301.0 /  301.7 /  302.9  monotone    p 2.00  GCI(mesh 1) 0.42%" in table
    assert "flippers     147.4 /  167.1 /  183.8  divergent   the differences grow" in table
    assert "flukes        60.9 /   79.6 /  100.6  too slow    observed order 0.44" in table
    assert "mean swimming Fx by region (N), the same cycle" in table
    assert "body         451.3 /  449.2 /  471.7  oscillatory band +-11.2 N" in table
    # a mesh without regions (a body without the whale's landmarks, an older study): none
    for k in H:
        del meshes[k]["region_gliding_drag"], meshes[k]["region_cycle_fx"]
    assert A.meshes_compared(meshes)["regions"] == {}


def test_region_cycle_fx_takes_each_cycle_of_the_swimming_loads(tmp_path):
    """A hand-made loads.dat of a half-domain case, one sample every quarter period: the
    flukes' Fx -500 N over the first cycle and -600 N over the second on the half, so the whole
    whale's -1000 and -1200 N (the half's forces doubled, symmetry.whole_body)."""
    step = PERIOD / 4
    times = [step * (i + 1) for i in range(12)]
    rows = ["# Time\ttotal:Fx\twhale.body:Fx\twhale.flukes:Fx"]
    for t in times:
        flukes = -500.0 if t <= 2 * PERIOD + 1e-9 else -600.0
        rows.append(f"{t}\t{flukes + 100.0}\t100.0\t{flukes}")
    folder = tmp_path / "postProcessing" / "loads" / "0"
    folder.mkdir(parents=True)
    (folder / "loads.dat").write_text("\n".join(rows) + "\n")
    (tmp_path / "adapter-case.json").write_text(json.dumps({symmetry.RECORD_KEY: True}))
    cost = {"cycle_means": {"start_s": [PERIOD, 2 * PERIOD]},
            "regions": {"body": {}, "flukes": {}}}
    fx = A.region_cycle_fx(tmp_path, cost, PERIOD)
    assert fx["flukes"] == pytest.approx([-1000.0, -1200.0], rel=1e-12)
    assert fx["body"] == pytest.approx([200.0, 200.0], rel=1e-12)
    assert A.region_cycle_fx(tmp_path, {"regions": {"body": {}}}, PERIOD) == {}
