"""The drag estimate beside each region's gliding drag (issue 23), without OpenFOAM: the fin
measurement of adapter/body/planform.py against fins whose span, chord and thickness ratio are
known by construction (rectangular and swept planforms with elliptic and NACA 00xx sections,
tilted out, back and down as a right whale's flippers are), and the estimates of
adapter/foam/estimates.py against hand calculations typed from the formulas:

    fin:  D = 0.5 rho U^2 S Cf (1 + 2 t/c + 60 (t/c)^4),  Cf = 0.075 / (log10(U c / nu) - 2)^2
    body: D = 0.5 rho U^2 S Cf (1 + 1.5 (d/L)^1.5 + 7 (d/L)^3),  Cf at U L / nu

With U = 1.3 m/s, rho = 1025 kg/m3: 0.5 rho U^2 = 866.125 Pa. A fin of S = 10 m2, c = 1.5 m,
t/c = 0.12: Re = 1.95e6, log10 Re - 2 = 4.2900346, Cf = 0.075 / 18.404397 = 0.00407511,
k = 1 + 0.24 + 60 x 0.00020736 = 1.2524416, D = 866.125 x 10 x 0.00407511 x 1.2524416 =
44.2056 N. A body of S = 103.5 m2, L = 15 m, d = 3.18 m: Re = 1.95e7, Cf = 0.075 / 27.984466 =
0.00268006, d/L = 0.212, k = 1 + 1.5 x 0.0976116 + 7 x 0.00952813 = 1.2131151, D = 291.452 N.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

from adapter.body.planform import mirrored_planform, planform
from adapter.errors import GeometryError
from adapter.foam import estimates as est

Q = 866.125          # 0.5 x 1025 x 1.3^2 (Pa)


def _ellipse(t_c: float, n: int = 128):
    """(n, 2) points (x along the chord from 0 to 1, z) of an elliptic section of chord 1."""
    th = 2 * np.pi * np.arange(n) / n
    return np.c_[0.5 + 0.5 * np.cos(th), 0.5 * t_c * np.sin(th)]


def _naca(t_c: float, n: int = 100):
    """(2 n - 2, 2) points of a NACA 00xx section of chord 1 (closed trailing edge), cosine
    spaced: upper side from the trailing edge to the leading edge, then the lower side back."""
    x = 0.5 * (1 + np.cos(np.linspace(0, np.pi, n)))
    yt = 5 * t_c * (0.2969 * np.sqrt(x) - 0.1260 * x - 0.3516 * x**2 + 0.2843 * x**3
                    - 0.1036 * x**4)
    return np.r_[np.c_[x, yt], np.c_[x[-2:0:-1], -yt[-2:0:-1]]]


def _rotation(axis: int, angle_deg: float) -> np.ndarray:
    a = np.radians(angle_deg)
    i, j = [k for k in range(3) if k != axis]
    r = np.eye(3)
    r[i, i] = r[j, j] = np.cos(a)
    r[i, j], r[j, i] = -np.sin(a), np.sin(a)
    return r


def fin(section, chord: float, span: float, rings: int = 41, sweep_deg: float = 0.0,
        pitch_deg: float = 0.0, dihedral_deg: float = 0.0, root=(0.0, 0.0, 0.0),
        tip_cap: bool = True) -> np.ndarray:
    """(T, 3, 3) triangles of a fin: the section (chord 1, scaled to ``chord``) in the x-z plane,
    extruded along +y over ``span`` (open at the root, a flat cap at the tip), its leading edge
    swept back by ``sweep_deg`` (streamwise sections kept), pitched about its span axis, then
    turned down about x by ``dihedral_deg``, its root at ``root``."""
    sec = np.asarray(section) * chord
    n = len(sec)
    eta = np.linspace(0.0, span, rings)
    pts = np.array([[x + e * np.tan(np.radians(sweep_deg)), e, z] for e in eta for x, z in sec])
    tris = []
    for r in range(rings - 1):
        for k in range(n):
            a, b = r * n + k, r * n + (k + 1) % n
            tris += [(a, b, b + n), (a, b + n, a + n)]
    if tip_cap:
        centre = len(pts)
        pts = np.r_[pts, [pts[(rings - 1) * n:].mean(axis=0)]]
        tris += [((rings - 1) * n + k, (rings - 1) * n + (k + 1) % n, centre) for k in range(n)]
    # pitch about the span axis (y, through the quarter chord), then the dihedral about x
    pts = (pts - [0.25 * chord, 0, 0]) @ _rotation(1, pitch_deg).T + [0.25 * chord, 0, 0]
    pts = pts @ _rotation(0, -dihedral_deg).T + np.asarray(root)
    return pts[np.array(tris)]


def _areas(tri):
    return 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)


# --- the measurement ----------------------------------------------------------------------

def test_a_rectangular_fin_with_an_elliptic_section():
    """Span 1.65 m, chord 1.5 m, t/c 0.12, by construction."""
    p = planform(fin(_ellipse(0.12), 1.5, 1.65))
    assert p["span_m"] == pytest.approx(1.65, rel=1e-12)
    assert p["mean_chord_m"] == pytest.approx(1.5, rel=1e-9)
    assert p["t_c"] == pytest.approx(0.12, rel=1e-3)
    np.testing.assert_allclose(np.abs(p["span_axis"]), [0, 1, 0], atol=1e-9)
    np.testing.assert_allclose(np.abs(p["normal"]), [0, 0, 1], atol=1e-9)


@pytest.mark.parametrize("t_c", [0.09, 0.15, 0.21])
def test_a_naca_section_gives_its_thickness_ratio(t_c):
    """The NACA 00xx half-thickness formula (closed trailing edge) has its largest thickness
    1.00012 t at 30 % chord (5 t x 0.1000119 x 2 at x = 0.3); the 100-point section within
    0.1 % of it."""
    p = planform(fin(_naca(t_c), 1.2, 2.4))
    assert p["t_c"] == pytest.approx(1.00012 * t_c, rel=1e-3)
    assert p["mean_chord_m"] == pytest.approx(1.2, rel=1e-9)


def test_a_fin_pointing_out_back_and_down_is_measured_along_its_own_axes():
    """Swept back 30 deg (streamwise sections unchanged), pitched 4 deg, turned 40 deg down,
    rooted low on a flank: span, chord and t/c as built, the span axis found (out and down)."""
    tri = fin(_naca(0.15), 1.4, 1.65, sweep_deg=30, pitch_deg=4, dihedral_deg=40,
              root=(4.2, 1.1, -0.6))
    p = planform(tri)
    # to 1e-6: the quads' diagonals all lean one way, so the triangles are not quite
    # mirror-symmetric about the fin's plane
    assert p["span_m"] == pytest.approx(1.65, rel=1e-6)
    assert p["mean_chord_m"] == pytest.approx(1.4, rel=1e-6)
    assert p["t_c"] == pytest.approx(1.00012 * 0.15, rel=1e-3)
    a = np.radians(40)
    np.testing.assert_allclose(np.abs(p["span_axis"]), [0, np.cos(a), np.sin(a)], atol=1e-5)


def test_a_tapered_fin_gives_its_mean_chord_and_chord_weighted_t_c():
    """Chord from 2 m at the root to 1 m at the tip (linear), the same section everywhere
    (t/c 0.1): mean chord 1.5 m, t/c 0.1; planform area 1.5 x 2 = 3 m2."""
    tri = fin(_ellipse(0.1), 1.0, 2.0, tip_cap=False)
    scale = 2.0 - 0.5 * tri[:, :, 1]                    # y from 0 to 2: chord 2 -> 1
    tri = tri.copy()
    tri[:, :, 0] *= scale
    tri[:, :, 2] *= scale
    p = planform(tri)
    # to 1e-6: between rings the flat triangles are not the tapered surface
    assert p["mean_chord_m"] == pytest.approx(1.5, rel=1e-6)
    assert p["planform_area_m2"] == pytest.approx(3.0, rel=1e-6)
    assert p["t_c"] == pytest.approx(0.1, rel=1e-3)
    # the same planform, the thickness 0.2 m everywhere: t/c from 0.1 to 0.2, weighted by
    # chord 0.2 / 1.5 = 0.1333 (the plain mean of t/c over the span would be 0.2 ln 2 = 0.1386)
    tri = fin(_ellipse(0.2), 1.0, 2.0, tip_cap=False)
    tri[:, :, 0] *= 2.0 - 0.5 * tri[:, :, 1]
    assert planform(tri)["t_c"] == pytest.approx(0.2 / 1.5, rel=1e-3)


def test_cuts_through_a_slanted_root_are_left_out():
    """A rectangular fin (chord 1.5 m, t/c 0.12) whose root is cut off along a slanted line,
    y < 0.3 x / c, as a flipper meets a flank: the cuts crossing that open root are no sections
    of the fin, so the mean chord and t/c are the sections', 1.5 m and 0.12; kept, the partial
    cuts there would shorten the mean chord."""
    tri = fin(_ellipse(0.12), 1.5, 1.65, rings=81)
    centroid = tri.mean(axis=1)
    tri = tri[centroid[:, 1] > 0.3 * centroid[:, 0] / 1.5]
    p = planform(tri)
    assert p["cuts"] < 24
    assert p["mean_chord_m"] == pytest.approx(1.5, rel=1e-9)
    assert p["t_c"] == pytest.approx(0.12, rel=1e-3)


def test_a_mirrored_pair_and_a_blade_across_the_mirror_plane():
    """Two mirrored flippers: the figures of one, sides 2, no mismatch. A fluke-like blade from
    y = -2.5 to 2.5 m (chord 1 m, rings not on y = 0): each side's span is 2.5 m."""
    one = fin(_ellipse(0.12), 1.5, 1.65, root=(4.0, 1.0, -0.5), dihedral_deg=30)
    other = one[:, ::-1].copy()
    other[:, :, 1] *= -1
    p = mirrored_planform(np.r_[one, other], 0.0)
    assert p["sides"] == 2 and p["mirror_mismatch"] < 1e-9
    assert p["span_m"] == pytest.approx(1.65, rel=1e-9)
    assert p["t_c"] == pytest.approx(planform(one)["t_c"], rel=1e-12)
    blade = fin(_ellipse(0.1), 1.0, 5.0, rings=40, root=(13.0, -2.5, 0.0))
    b = mirrored_planform(blade, 0.0)
    assert b["sides"] == 2 and b["span_m"] == pytest.approx(2.5, rel=1e-12)
    assert b["mean_chord_m"] == pytest.approx(1.0, rel=1e-9)
    assert b["t_c"] == pytest.approx(0.1, rel=1e-3)


def test_a_whale_that_is_not_mirror_symmetric_is_averaged_and_says_so():
    """One flipper's chord 1.65 m, the other's 1.5 m (the same thickness, so t/c 0.12 and
    0.12 / 1.1): figures the mean of the sides; the mismatch 0.15 / 1.575 = 0.0952 (chord,
    planform area and t/c all differ by that)."""
    left = fin(_ellipse(0.12), 1.5, 1.65, root=(4.0, 1.0, -0.5))
    right = left.copy()
    right[:, :, 0] = 4.0 + 1.1 * (right[:, :, 0] - 4.0)
    right[:, :, 1] *= -1
    p = mirrored_planform(np.r_[left, right], 0.0)
    assert p["mean_chord_m"] == pytest.approx(1.575, rel=1e-9)
    assert p["t_c"] == pytest.approx(0.5 * (0.12 + 0.12 / 1.1), rel=1e-3)
    assert p["mirror_mismatch"] == pytest.approx(0.15 / 1.575, rel=1e-2)


def test_a_fin_facing_the_flow_is_refused():
    """A fin whose plane is normal to x has no chord along the flow: a GeometryError that says
    so (the estimate of that region is then left out, with the reason)."""
    tri = fin(_ellipse(0.1), 1.0, 2.0) @ _rotation(1, 90).T
    with pytest.raises(GeometryError, match="faces the flow"):
        planform(tri)
    with pytest.raises(GeometryError, match=r"shape \(3, 3\)"):
        planform(np.zeros((3, 3)))


# --- the estimates --------------------------------------------------------------------------

def test_the_fin_estimate_is_the_hand_calculation():
    e = est.fin_estimate(10.0, 1.5, 0.12, 1.3, 1025.0, 1e-6)
    assert e["re"] == pytest.approx(1.95e6, rel=1e-12)
    assert e["cf"] == pytest.approx(0.00407511, rel=1e-6)
    assert e["form_factor"] == pytest.approx(1.2524416, rel=1e-12)
    assert e["flat_plate_N"] == pytest.approx(Q * 10 * 0.00407511, rel=1e-6)
    assert e["estimate_N"] == pytest.approx(44.2056, rel=1e-5)
    assert est.foil_form_factor(0.0) == 1.0


def test_the_regions_estimates_from_a_surface():
    """Body: van der Hoop et al. on the body region's own area (hand figure above, the body
    given as a triangle of 103.5 m2 across the mirror plane y = 0); flippers: an elliptic pair
    of c = 1.5 m, t/c = 0.12 on the pair's area, which the test sums itself."""
    body = np.array([[[0, -10, 0], [10.35, 0, 0], [0, 10, 0]]], dtype=float)   # 103.5 m2
    one = fin(_ellipse(0.12), 1.5, 1.65, root=(4.0, 1.0, -0.5), dihedral_deg=30)
    other = one[:, ::-1].copy()
    other[:, :, 1] *= -1
    flippers = np.r_[one, other]
    out = est.region_estimates({"body": body, "flippers": flippers}, 1.3, 1025.0, 1e-6,
                               15.0, 3.18)
    assert out["body"]["estimate_N"] == pytest.approx(291.452, rel=1e-5)
    assert out["body"]["wetted_area_m2"] == pytest.approx(103.5, rel=1e-12)
    f = out["flippers"]
    area = _areas(flippers).sum()
    t_c = f["t_c"]
    assert t_c == pytest.approx(0.12, rel=1e-3) and f["mean_chord_m"] == pytest.approx(1.5)
    cf = 0.075 / (np.log10(1.3 * 1.5 / 1e-6) - 2) ** 2
    hand = Q * area * cf * (1 + 2 * t_c + 60 * t_c**4)
    assert f["estimate_N"] == pytest.approx(hand, rel=1e-9)
    assert f["re"] == pytest.approx(1.95e6, rel=1e-9) and f["span_m"] == pytest.approx(1.65)


def test_a_fin_that_cannot_be_measured_gets_a_note_not_a_number():
    flat = fin(_ellipse(0.1), 1.0, 2.0, root=(4.0, 1.0, 0.0)) @ _rotation(1, 90).T
    out = est.region_estimates({"flukes": flat}, 1.3, 1025.0, 1e-6, 15.0, 3.18)
    assert "estimate_N" not in out["flukes"] and "faces the flow" in out["flukes"]["estimate_note"]


def test_ratio_band_and_the_printed_text():
    regions = {"flippers": {"gliding_drag_N": 227.0}, "flukes": {"gliding_drag_N": 60.0},
               "body": {"gliding_drag_N": 345.0, "power_W": 90.0}}
    estimates = {"flippers": {"estimate_N": 47.0}, "flukes": {"estimate_N": 54.0},
                 "body": {"estimate_N": 291.0}}
    out = est.with_estimates(regions, estimates)
    assert out["flippers"]["ratio"] == pytest.approx(227 / 47) and not out["flippers"]["in_band"]
    assert out["flukes"]["in_band"] and out["flukes"]["band"] == [0.7, 1.5]
    assert out["body"]["band"] == [0.9, 1.1] and not out["body"]["in_band"]   # 1.186
    assert est.drag_text(out["flippers"]) == "227 N (estimate 47 N, ratio 4.83; OUTSIDE 0.7-1.5)"
    assert est.drag_text(out["flukes"]) == "60 N (estimate 54 N, ratio 1.11)"
    assert est.drag_text({"gliding_drag_N": 88.0}) == "88 N"
    assert est.side_force_text(0.0355) == "3.55%; OVER 1%"
    assert est.side_force_text(0.004) == "0.40%"
    header, rows, warning = est.plausibility_table(out)
    assert header[:4] == ("region", "gliding drag", "estimate", "ratio")
    assert [r[0] for r in rows] == ["flippers", "flukes", "body"]
    assert rows[0][3] == "4.83 OUTSIDE" and rows[1][3] == "1.11"
    assert warning == ("Outside the plausible band of measured over estimated drag: "
                       "flippers (4.83), body (1.19).")


# --- in the answer, the printed rows and the report ---------------------------------------

def _summary():
    regions = est.with_estimates(
        {"body": {"gliding_drag_N": 345.0, "gliding_pressure_share": 0.42},
         "flippers": {"gliding_drag_N": 227.0, "gliding_pressure_share": 0.93},
         "flukes": {"gliding_drag_N": 60.0}},
        {"body": {"estimate_N": 291.0}, "flippers": {"estimate_N": 47.0, "t_c": 0.109},
         "flukes": {"estimate_N": 54.0}})
    return {"swimming_cost": {"gliding_drag_N": 661.0, "gliding_side_force_N": 23.4,
                              "gliding_side_force_of_drag": 0.0355, "regions": regions,
                              "van_der_hoop": {"drag_N": 354.0}}}


def test_the_printed_rows_and_the_report_show_the_estimates(tmp_path):
    from adapter.foam.report import write_report
    from adapter.foam.summary import format_summary
    from adapter.foam.swimrun import COST_ROWS

    text = format_summary(_summary(), COST_ROWS)
    lines = dict(re.split(r"\s{2,}", line.strip(), maxsplit=1) for line in text.splitlines())
    assert lines["flippers: gliding drag"] == "227 N (estimate 47 N, ratio 4.83; OUTSIDE 0.7-1.5)"
    assert lines["flukes: gliding drag"] == "60 N (estimate 54 N, ratio 1.11)"
    assert lines["flippers: pressure part"] == "93%"
    assert lines["|Fy| / gliding drag"] == "3.55%; OVER 1%"
    assert lines["van der Hoop et al. model, whole whale's area"] == "354 N"
    case = tmp_path / "case"
    case.mkdir()
    page = write_report(case, _summary(), COST_ROWS).read_text()
    assert "against an estimate from its size" in page and "4.83 OUTSIDE" in page
    assert "<th>t/c</th>" in page and "0.109" in page
    assert 'class="warning"' in page and "body (1.19), flippers (4.83)" in page


COLUMNS = ("Fx", "Fy", "Fz", "Fpx", "Fvx", "P", "A")


def _loads(case, t, groups: dict):
    """``postProcessing/loads/0/loads.dat`` with the columns of ``groups`` ({group: {column:
    value}}, constants; the rest 0)."""
    path = case / "postProcessing" / "loads" / "0" / "loads.dat"
    path.parent.mkdir(parents=True, exist_ok=True)
    head = "".join(f"\t{g}:{c}" for g in groups for c in COLUMNS)
    rows = [f"{x:.12g}" + "".join(f"\t{groups[g].get(c, 0.0):.17g}" for g in groups
                                  for c in COLUMNS) for x in t]
    path.write_text("# Time" + head + "\n" + "\n".join(rows) + "\n")


@pytest.mark.slow
def test_the_answer_holds_each_regions_estimate(tmp_path):
    """A pair with constant loads (gliding: flippers 120 N, 90 N of it pressure, Fy 2 N; body
    300 N; total Fy 3.3 N of 420 N) and a regions STL of a body and an elliptic flipper pair:
    the answer's regions carry the estimate, the ratio, the pressure share 0.75, and the side
    force 3.3 N / 420 N = 0.786 %."""
    from adapter.body.meshfile import write_region_stl
    from adapter.foam import swimrun

    case = tmp_path / "case"
    glide = case / swimrun.GLIDING
    t = 0.05 * np.arange(1, 121)                       # 3 periods of 2 s
    _loads(glide, t, {"total": {"Fx": 420.0, "Fy": 3.3, "Fpx": 200.0},
                      "whale.body": {"Fx": 300.0, "Fpx": 110.0, "Fy": 1.3},
                      "whale.flippers": {"Fx": 120.0, "Fpx": 90.0, "Fy": 2.0}})
    _loads(case, t, {"total": {"Fx": -50.0, "P": 600.0},
                     "whale.body": {"Fx": 10.0, "P": 10.0, "A": 103.5},
                     "whale.flippers": {"Fx": -60.0, "P": 590.0, "A": 10.0}})
    one = fin(_ellipse(0.12), 1.5, 1.65, root=(4.0, 1.0, -0.5), dihedral_deg=30)
    other = one[:, ::-1].copy()
    other[:, :, 1] *= -1
    body = np.array([[[0, -10, 0], [10.35, 0, 0], [0, 10, 0]]], dtype=float)
    tri = np.r_[body, one, other]
    regions = np.r_[0, np.ones(2 * len(one), int)]
    write_region_stl(case / "constant" / "triSurface" / "whale_regions.stl",
                     tri.reshape(-1, 3), np.arange(3 * len(tri)).reshape(-1, 3), regions)
    record = {"period_s": 2.0, "ramp_s": 2.0, "speed_m_s": 1.3, "length_m": 15.0,
              "body": {"volume_m3": 8.0, "length_m": 15.0, "diameter_m": 3.18,
                       "wetted_area_m2": 120.0}}
    s = swimrun.answer(case, glide, record, 420.0, 0.02, {}, {})["swimming_cost"]
    assert s["gliding_side_force_N"] == pytest.approx(3.3, rel=1e-12)
    assert s["gliding_side_force_of_drag"] == pytest.approx(3.3 / 420, rel=1e-12)
    f, b = s["regions"]["flippers"], s["regions"]["body"]
    assert f["gliding_pressure_share"] == pytest.approx(0.75, rel=1e-12)
    assert f["gliding_side_force_N"] == pytest.approx(2.0, rel=1e-12)
    assert f["t_c"] == pytest.approx(0.12, rel=1e-3)
    assert f["ratio"] == pytest.approx(120.0 / f["estimate_N"], rel=1e-12) and not f["in_band"]
    assert b["estimate_N"] == pytest.approx(291.452, rel=1e-5)
    assert b["ratio"] == pytest.approx(300 / 291.452, rel=1e-5) and b["in_band"]
