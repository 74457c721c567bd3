"""The fins' hydrofoil sections (adapter/body/procedural.py): the NACA four-digit thickness
form against its published values (Abbott and von Doenhoff 1959: half-thickness t/2 at 0.30 c,
leading-edge radius 1.1019 (t/c)^2 c, a closed trailing edge), and the procedural whale's
flippers and flukes measured from its surface: symmetric sections, thickest near 0.3 c, with
the thickness ratios docs/geometry.md gives."""

import numpy as np
import pytest

from adapter.body.fins import foil_half_thickness
from adapter.body.geometry import build_surface
from adapter.body.regions import FLIPPERS, FLUKES


def test_naca_thickness_form_by_its_published_values():
    t = 0.2
    assert foil_half_thickness(np.array(0.3), t) == pytest.approx(0.5 * t, rel=2e-4)
    assert foil_half_thickness(np.array(0.0), t) == 0.0
    assert abs(foil_half_thickness(np.array(1.0), t)) < 1e-4 * t  # closed trailing edge
    # thickest at 0.30 c (within the 0.01 c grid)
    x = np.linspace(0, 1, 101)
    assert x[np.argmax(foil_half_thickness(x, t))] == pytest.approx(0.30, abs=0.011)
    # the leading-edge circle: y^2 = 2 r x near x = 0, r = 1.1019 t^2
    x0 = 1e-6
    r = foil_half_thickness(np.array(x0), t) ** 2 / (2 * x0)
    assert r == pytest.approx(1.1019 * t * t, rel=0.01)


def _sections(surface, region, span_axis, stations):
    """(station, chord, thickness) of the region's left half (y > 0) in slabs across the span:
    chord the extent along x, thickness the extent normal to the chord line (the section's
    second principal direction in the plane across the span)."""
    p = surface.points
    tri = surface.triangles[surface.triangle_regions() == region]
    nodes = np.unique(tri)
    nodes = nodes[p[nodes, 1] > 0]
    q = p[nodes]
    axis = np.asarray(span_axis, float)
    axis /= np.linalg.norm(axis)
    along = (q - q.mean(axis=0)) @ axis
    out = []
    for u in stations:
        lo, hi = np.quantile(along, [u - 0.03, u + 0.03])
        slab = q[(along >= lo) & (along <= hi)]
        centred = slab - slab.mean(axis=0)
        centred -= np.outer(centred @ axis, axis)  # the section's plane, across the span
        normal = np.linalg.svd(centred, full_matrices=False)[2][1]
        out.append((u, np.ptp(slab[:, 0]), np.ptp(centred @ normal)))
    return out


@pytest.mark.parametrize("region, axis, stations, low, high", [
    (FLIPPERS, (0.45, 0.75, -0.48), (0.3, 0.45, 0.6), 0.17, 0.30),  # Fish and Battle: 0.20-0.28
    # the fluke region holds the tail stock behind the tail base: slabs beside it
    (FLUKES, (0.0, 1.0, 0.0), (0.5, 0.65, 0.8), 0.10, 0.22),
])
def test_the_fins_are_streamlined_sections_of_the_given_thickness(smoke_scene, region, axis,
                                                                 stations, low, high):
    """Mid-span slabs of the default-resolution whale: thickness over chord within the range
    (the slab's extent along x is a little longer than the section's chord where the fin is
    swept, so the measured ratio reads low), far from the old elliptic flippers' 0.07-0.13."""
    surface = build_surface(smoke_scene.replace(geometry={"nodes": 11272}))
    for u, chord, thick in _sections(surface, region, axis, stations):
        assert low < thick / chord < high, (u, chord, thick)
