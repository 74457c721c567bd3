"""The flow study's error bar by region (adapter/studies/study_analysis.py, region_study):
each region's gliding drag through the three-mesh procedure of Celik et al. (2008), against a
closed form and the verdicts on the default study's flipper and fluke figures."""

import math

import pytest

from adapter.studies import study_analysis as A
from adapter.studies import study_report as R


def test_the_regions_gliding_drag_has_its_own_convergence_and_gci():
    """Each region's gliding drag on the three meshes: the body f = 300 + h^2 on h = 1, 1.3,
    1.69 (p = 2; GCI by hand: 1.25 (f2 - f1) / (1.3^2 - 1) = 1.25 N, 0.4153 % of f1); the
    flippers and flukes of the default study of 2026-12-07 (147.4, 167.1, 183.8 N: the
    differences grow; 60.9, 79.6, 100.6 N: order 0.44, too slow). The table says which."""
    h = {1: 1.0, 2: 1.3, 3: 1.69}
    values = {"body": [300 + h[k] ** 2 for k in h], "flippers": [147.4, 167.1, 183.8],
              "flukes": [60.9, 79.6, 100.6]}
    meshes = {k: {"background_cell_m": h[k], "gliding_drag": 500.0 + h[k],
                  "swimming_fx": -900.0 - h[k], "swimming_power": 4000.0 + h[k],
                  "cells": 1000, "wall_s_per_cycle": 10.0,
                  "region_gliding_drag": {name: v[k - 1] for name, v in values.items()}}
              for k in h}
    regions = A.meshes_compared(meshes)["regions"]
    body = regions["body"]
    assert body["convergence"] == "monotone" and body["p"] == pytest.approx(2.0, rel=1e-9)
    assert body["extrapolated"] == pytest.approx(300.0, rel=1e-12)
    assert body["gci_fine_abs"] == pytest.approx(1.25, rel=1e-9)
    assert body["gci_fine_of_value"] == pytest.approx(1.25 / 301.0, rel=1e-9)
    assert regions["flippers"]["convergence"] == "divergent"
    assert regions["flippers"].get("gci_fine_of_value") is None
    flukes = regions["flukes"]
    assert flukes["convergence"] == "too slow"
    assert flukes["p_observed"] == pytest.approx(math.log(21.0 / 18.7) / math.log(1.3))
    table = R.format_study({"cases": {f"mesh-{k}/case": meshes[k] for k in h},
                            "meshes": A.meshes_compared(meshes)})
    assert "body         301.0 /  301.7 /  302.9  monotone    p 2.00  GCI(mesh 1) 0.42% (1.2 N)" \
        in table
    assert "flippers     147.4 /  167.1 /  183.8  divergent   the differences grow" in table
    assert "flukes        60.9 /   79.6 /  100.6  too slow    observed order 0.44" in table
    # a mesh without regions (a body without the whale's landmarks, an older study): none
    del meshes[2]["region_gliding_drag"]
    assert A.meshes_compared(meshes)["regions"] == {}
