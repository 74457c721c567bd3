"""Is a region's gliding drag plausible? An estimate per body region, from its own size.

- **Flippers, flukes**: the ITTC-57 friction line at the fin's own Reynolds number
  ``Re = U c / nu`` (``c`` its mean chord), times Hoerner's form factor for a streamlined
  section, ``1 + 2 t/c + 60 (t/c)^4``, on its wetted area: ``D = 0.5 rho U^2 S Cf k``. Span,
  mean chord and t/c are measured from the surface (:mod:`adapter.body.planform`).
- **Body**: van der Hoop et al.'s model (:func:`adapter.foam.loads.van_der_hoop_drag`: ITTC-57
  at ``Re = U L / nu`` times ``1 + 1.5 (d/L)^1.5 + 7 (d/L)^3``) on the body region's own wetted
  area (``swimming_cost/van_der_hoop`` keeps the whole whale's).

The surface is the case's ``constant/triSurface/whale_regions.stl``, the triangles the loads
function object split the whale by (so a whale from a mesh file is measured too). Each region's
``ratio`` is its measured gliding drag over the estimate; :data:`BANDS` are issue 23's targets
(an appendage within 0.7-1.5 times its estimate, the body within 10 % of the model): a region
outside its band is marked, the run does not fail. See docs/case.md.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from adapter.body.meshfile import read_stl_solids
from adapter.body.planform import mirrored_planform, triangle_areas
from adapter.errors import GeometryError
from adapter.foam.case import REGIONS_STL
from adapter.foam.loads import ittc57, van_der_hoop_drag

#: the plausible band of measured / estimate, per region (issue 23's targets)
BANDS = {"body": (0.9, 1.1), "flippers": (0.7, 1.5), "flukes": (0.7, 1.5)}
#: the fins: regions estimated as streamlined sections
FINS = ("flippers", "flukes")
#: the target for the gliding side force: |Fy| under 1 % of the gliding drag
SIDE_FORCE_LIMIT = 0.01


def foil_form_factor(t_c: float) -> float:
    """Hoerner's form factor of a streamlined section, 1 + 2 t/c + 60 (t/c)^4."""
    return 1.0 + 2.0 * t_c + 60.0 * t_c**4


def fin_estimate(wetted_area: float, mean_chord: float, t_c: float, speed: float, rho: float,
                 nu: float) -> dict:
    """The drag estimate of a fin (N) and its inputs: ITTC-57 Cf at U c / nu times
    :func:`foil_form_factor`, times 0.5 rho U^2 S."""
    re = speed * mean_chord / nu
    cf = ittc57(re)
    form = foil_form_factor(t_c)
    flat = 0.5 * rho * speed**2 * wetted_area * cf
    return {"re": re, "cf": cf, "form_factor": form, "flat_plate_N": flat,
            "estimate_N": flat * form}


def region_estimates(solids: dict, speed: float, rho: float, nu: float, length: float,
                     diameter: float) -> dict:
    """Per region of ``solids`` (``{name: (T, 3, 3) triangles}``, the regions STL's solids): the
    estimate and its inputs. The mirror plane is the middle of the body region's y extent (of
    the whole surface's without one: a flipper longer on one side does not move it); a fin
    that cannot be measured gets ``estimate_note`` instead."""
    trunk = solids.get("body")
    if trunk is None or not len(trunk):
        trunk = np.concatenate([t for t in solids.values() if len(t)])
    y0 = 0.5 * (trunk[:, :, 1].min() + trunk[:, :, 1].max())
    out = {}
    for name, tri in solids.items():
        if not len(tri):
            continue
        area = float(triangle_areas(tri).sum())
        if name == "body":
            ref = van_der_hoop_drag(speed, length, diameter, area, rho, nu)
            out[name] = {"estimate_N": ref["drag_N"], "re": ref["reynolds"],
                         "cf": ref["cf_ittc57"], "form_factor": ref["form_factor"],
                         "wetted_area_m2": area, "length_m": length, "diameter_m": diameter,
                         "model": "van der Hoop et al. on the body region's area"}
        elif name in FINS:
            try:
                p = mirrored_planform(tri, y0)
            except GeometryError as exc:
                out[name] = {"estimate_note": str(exc)}
                continue
            out[name] = {**fin_estimate(area, p["mean_chord_m"], p["t_c"], speed, rho, nu),
                         "wetted_area_m2": area, "t_c": p["t_c"],
                         "mean_chord_m": p["mean_chord_m"], "span_m": p["span_m"],
                         "sides": p["sides"], "mirror_mismatch": p["mirror_mismatch"],
                         "model": "ITTC-57 x Hoerner's foil form factor"}
    return out


def case_estimates(case, record: dict) -> dict:
    """:func:`region_estimates` for a case folder, from its regions STL and its record
    (``adapter-case.json``: speed, density, viscosity, the body's length and diameter); ``{}``
    when the case has no regions STL."""
    path = Path(case) / "constant" / "triSurface" / REGIONS_STL
    if not path.is_file():
        return {}
    body = record.get("body", {})
    return region_estimates(read_stl_solids(path), float(record["speed_m_s"]),
                            float(record.get("rho_kg_m3", 1025.0)),
                            float(record.get("nu_m2_s", 1e-6)),
                            float(body.get("length_m", record.get("length_m", float("nan")))),
                            float(body.get("diameter_m", float("nan"))))


def with_estimates(regions: dict, estimates: dict) -> dict:
    """``regions`` (:func:`adapter.foam.loads.region_figures`) with each region's estimate, its
    ``ratio`` (measured gliding drag / estimate), ``band`` and ``in_band``."""
    out = {}
    for name, entry in regions.items():
        entry = {**entry, **estimates.get(name, {})}
        if "estimate_N" in entry and "gliding_drag_N" in entry:
            lo, hi = BANDS.get(name, BANDS["flippers"])
            ratio = entry["gliding_drag_N"] / entry["estimate_N"]
            entry.update(ratio=ratio, band=[lo, hi], in_band=bool(lo <= ratio <= hi))
        out[name] = entry
    return out


def drag_text(region: dict) -> str:
    """A region's gliding drag for the printed rows and the report: ``227 N (estimate 47 N,
    ratio 4.85; OUTSIDE 0.7-1.5)``."""
    if "gliding_drag_N" not in region:
        return "no gliding run"
    text = f"{region['gliding_drag_N']:.0f} N"
    if "ratio" not in region:
        return text
    lo, hi = region["band"]
    mark = "" if region["in_band"] else f"; OUTSIDE {lo:g}-{hi:g}"
    return f"{text} (estimate {region['estimate_N']:.0f} N, ratio {region['ratio']:.2f}{mark})"


def side_force_text(share: float) -> str:
    """|Fy| over the gliding drag, marked above :data:`SIDE_FORCE_LIMIT`."""
    mark = "" if share <= SIDE_FORCE_LIMIT else f"; OVER {SIDE_FORCE_LIMIT:.0%}"
    return f"{share:.2%}{mark}"


#: the report's table of the regions against their estimates: (column, key, format)
TABLE = (("gliding drag", "gliding_drag_N", "{:.0f} N"), ("estimate", "estimate_N", "{:.0f} N"),
         ("ratio", "ratio", "{:.2f}"), ("band", "band", lambda b: f"{b[0]:g}-{b[1]:g}"),
         ("pressure part", "gliding_pressure_share", "{:.0%}"),
         ("wetted area", "wetted_area_m2", "{:.2f} m2"), ("Re", "re", "{:.3g}"),
         ("Cf (ITTC-57)", "cf", "{:.5f}"), ("form factor", "form_factor", "{:.3f}"),
         ("t/c", "t_c", "{:.3f}"), ("mean chord", "mean_chord_m", "{:.2f} m"),
         ("span (one side)", "span_m", "{:.2f} m"))


def plausibility_table(regions: dict) -> tuple[tuple, tuple, str]:
    """(header, rows, warning) of the report's table: one row per region with an estimate; the
    warning names the regions outside their band (empty when none is)."""
    rows, outside = [], []
    for name, r in regions.items():
        if "estimate_N" not in r:
            continue
        cells = [name]
        for _, key, fmt in TABLE:
            value = r.get(key)
            cells.append("" if value is None else fmt(value) if callable(fmt)
                         else fmt.format(value))
        if not r.get("in_band", True):
            cells[3] += " OUTSIDE"
            outside.append(f"{name} ({r['ratio']:.2f})")
        rows.append(tuple(cells))
    warning = ("Outside the plausible band of measured over estimated drag: "
               + ", ".join(outside) + ".") if outside else ""
    return ("region", *(c for c, _, _ in TABLE)), tuple(rows), warning
