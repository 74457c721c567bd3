"""The oscillating sphere of the validation suite: its reference arithmetic against hand values,
and its machinery (mesh, step-server, loads, the suite's JSON) on a tiny mesh."""

import json
import math

import numpy as np
import pytest

from adapter.body.checks import validate_surface
from adapter.validation import sphere
from adapter.validation.suite import Check, run_suite

from .conftest import NEEDS_FOAM_AND_PLUGIN


def test_added_mass_force_against_the_hand_value():
    # 0.5 * 1025 * 4/3 pi * 1^3 = 2146.76 kg; (2 pi / 4)^2 * 0.1 = 0.246740 m/s2
    assert sphere.added_mass() == pytest.approx(2146.755, rel=1e-6)
    assert sphere.force_amplitude(sphere.added_mass()) == pytest.approx(529.69, rel=1e-4)
    # Lamb's confined sphere: b = 2 R gives (1 + 2/8) / (1 - 1/8) = 10/7 of the unbounded mass
    assert sphere.confined_added_mass(1.0, 2.0) == pytest.approx(2146.755 * 10 / 7, rel=1e-6)
    assert sphere.stokes_layer_m() == pytest.approx(1.128e-3, rel=1e-3)   # sqrt(2e-6 / (pi/2))


def test_the_fit_recovers_amplitude_and_phase():
    t = np.linspace(0, 4, 103)[1:]
    w = math.pi / 2
    f = 530 * np.sin(w * t + math.radians(2.0)) + 7.0
    a, b, c = sphere.fit_harmonic(t, f, w)
    assert math.hypot(a, b) == pytest.approx(530, rel=1e-9)
    assert math.degrees(math.atan2(b, a)) == pytest.approx(2.0, abs=1e-9)
    assert c == pytest.approx(7.0, abs=1e-9)


def test_the_icosphere_is_closed_and_round():
    points, faces = sphere.icosphere(1.0, 3)
    assert len(faces) == 20 * 4**3 and np.allclose(np.linalg.norm(points, axis=1), 1.0)
    validate_surface(points, [faces], 2.0)              # closed, manifold: raises otherwise


def test_a_check_judges_relative_and_absolute_tolerances():
    assert Check("f", 103.0, 100.0, 0.03).passed
    assert not Check("f", 103.1, 100.0, 0.03).passed
    assert Check("phase", -2.9, 0.0, 3.0, absolute=True).passed
    assert not Check("phase", -3.1, 0.0, 3.0, absolute=True).passed
    assert not Check("f", math.nan, 1.0, 0.5).passed
    assert Check("part", 5.0).passed is None


def _needs_foam(test):
    for mark in reversed(NEEDS_FOAM_AND_PLUGIN):
        test = mark(test)
    return test


@_needs_foam
def test_the_quick_sphere_runs_through_the_coupled_pipeline(tmp_path):
    results = run_suite(tmp_path, ["sphere"], quick=True, echo=lambda s: None)
    doc = json.loads((tmp_path / "validation.json").read_text(),
                     parse_constant=lambda c: pytest.fail(f"non-strict JSON: {c}"))
    assert doc["quick"] and doc["cases"][0]["name"] == "sphere"
    checks = {c.name: c for c in results[0].checks}
    # one cycle on 2,491 cells from an impulsive start: the force is the added mass's to 10 %
    amp = checks["Euler: force amplitude (pressure + viscous)"]
    assert amp.measured == pytest.approx(amp.reference, rel=0.1)
    # the step-server served the rigid motion: the recorded surface moved by X sin(w t)
    keys = (tmp_path / "sphere" / "case-Euler" / "adapter" / "server-stats.json")
    assert json.loads(keys.read_text())["requests"] > 50
