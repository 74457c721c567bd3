"""The flippers' drag as the towing tank measures an appendage's: the whale with them less the
whale without them, and the share of it the body's pressure field explains.

Two gliding runs of run-case's pair on the same scene but ``geometry.flippers``: ``--with``
(the default whale) and ``--without`` (``[geometry] flippers = false``: the flank closed by the
body's own quads, no flipper refinement). Printed per region (adapter-summary.json's
``swimming_cost/regions``, the last period's mean) and for the whole whale, and the
difference of the two: the flippers' drag increment, the flippers' own drag and what their
presence changes on the body.

The body's pressure falls along the flank ahead of its widest girth, so a flipper there is
pushed downstream by the body's own field: on a volume V in a pressure gradient the force is
-V dp/dx (horizontal buoyancy, Glauert's correction of a model in a wind tunnel's falling
pressure), which an isolated foil's estimate lacks. Computed here from the run without
flippers: -rho sum(V_c dp/dx_c) over its cells whose centres lie inside the flippered whale's
surface (the flippers' volume, and the thin sliver where the foil root moved the flank);
dp/dx by VTK's gradient of the cell values (pimpleFoam's p is kinematic: x rho).

Beside the isolated foil's estimate (ITTC-57 x Hoerner's form factor, the tool's), the
junctions': Hoerner's wing-body junction interference (Fluid-Dynamic Drag, 1965, ch. 8),
Delta D = q t^2 (0.75 t/c - 0.0003 / (t/c)^2) per junction, t and t/c the root section's.

    .venv/bin/python scripts/flipper_increment.py --with runs/default \
        --without runs/noflip/case [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from adapter.foam.summary import finite  # noqa: E402
from adapter.jsonfiles import write_json  # noqa: E402

REGIONS = ("body", "flippers", "flukes")


def junction_drag(speed: float, rho: float) -> float:
    """Hoerner's junction interference of the two flippers' roots (N), the default whale's
    root section (:func:`adapter.body.procedural.flipper_fin`)."""
    from adapter.body.procedural import flipper_fin

    fin = flipper_fin()
    t_c = float(fin.thickness_ratio(0.0))
    t = t_c * float(fin.chord(0.0))
    return 2 * 0.5 * rho * speed**2 * t**2 * (0.75 * t_c - 0.0003 / t_c**2)


def gliding(case: Path) -> dict:
    """Total and per region gliding drag (N) and their pressure parts from a pair's summary."""
    cost = json.loads((case / "adapter-summary.json").read_text())["swimming_cost"]
    out = {"total": {"drag": cost["gliding_drag_N"], "pressure": cost["gliding_drag_pressure_N"]}}
    for name in REGIONS:
        r = cost["regions"][name]
        out[name] = {"drag": r["gliding_drag_N"], "pressure": r["gliding_pressure_N"],
                     "estimate": r.get("estimate_N")}
    return out


def last_time(case: Path) -> str:
    times = [p.name for p in case.iterdir() if p.is_dir() and _is_number(p.name)]
    if not times:
        raise SystemExit(f"{case} has no written time: run run-case on it first")
    return max(times, key=float)


def _is_number(text: str) -> bool:
    try:
        return float(text) > 0
    except ValueError:
        return False


def horizontal_buoyancy(without: Path, whale_stl: Path, rho: float) -> dict:
    """-rho sum(V dp/dx) over the cells of the flipperless gliding flow inside the flippered
    whale's surface ``whale_stl`` and outside its own (the snapped cells' centres a few mm
    inside the faceted body are the body's): N, both flippers (a half domain's doubled);
    their volume (m3) and mean dp/dx (Pa/m)."""
    import pyvista as pv

    from adapter.foam.parallel import reconstruct_latest_time

    glide = without / "gliding"
    reconstruct_latest_time(glide)    # a parallel run's last time, when not yet reconstructed
    foam = glide / "case.foam"
    foam.touch()
    reader = pv.OpenFOAMReader(str(foam))
    reader.set_active_time_value(float(last_time(glide)))
    reader.enable_all_cell_arrays()
    mesh = reader.read()["internalMesh"]
    mesh = mesh.compute_derivative(scalars="p", gradient="gradp", preference="cell")
    centres = mesh.cell_centers()

    def inside(stl: Path) -> np.ndarray:
        surface = pv.read(str(stl)).triangulate().clean()
        return np.asarray(centres.select_interior_points(surface, check_surface=False)
                          ["selected_points"], dtype=bool)

    mask = inside(whale_stl) & ~inside(glide / "constant" / "triSurface" / "whale.stl")
    vol = np.asarray(mesh.compute_cell_sizes(length=False, area=False)["Volume"])[mask]
    dpdx = rho * np.asarray(mesh.cell_data["gradp"])[mask, 0]
    # a half domain's cells are one flipper's (the summary's forces are the whole whale's)
    sides = 2.0 if json.loads((glide / "adapter-case.json").read_text()).get("symmetry_plane") \
        else 1.0
    return {"force_N": float(-(vol * dpdx).sum()) * sides, "volume_m3": float(vol.sum()) * sides,
            "mean_dpdx_Pa_m": float((vol * dpdx).sum() / vol.sum()), "cells": int(mask.sum())}


def table(on: dict, off: dict, buoy: dict, junction: float) -> str:
    rows = [f"{'gliding drag (N)':<24}{'with':>9}{'without':>9}{'difference':>12}"]
    for name in ("total", *REGIONS):
        a, b = on[name]["drag"], off[name]["drag"]
        rows.append(f"{name:<24}{a:9.1f}{b:9.1f}{a - b:12.1f}")
        a, b = on[name]["pressure"], off[name]["pressure"]
        rows.append(f"{'  pressure part':<24}{a:9.1f}{b:9.1f}{a - b:12.1f}")
    est = on["flippers"]["estimate"]
    increment = on["total"]["drag"] - off["total"]["drag"]
    rows.append(f"the flippers' increment (with - without): {increment:.1f} N; "
                f"their estimate (ITTC-57 x Hoerner): {est:.1f} N (ratio {increment / est:.2f}); "
                f"with Hoerner's junction interference, {junction:.1f} N: {est + junction:.1f} N "
                f"(ratio {increment / (est + junction):.2f})")
    rows.append(f"horizontal buoyancy in the flipperless flow: {buoy['force_N']:.1f} N "
                f"(volume {buoy['volume_m3']:.3f} m3, {buoy['cells']} cells, mean dp/dx "
                f"{buoy['mean_dpdx_Pa_m']:.1f} Pa/m)")
    return "\n".join(rows)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--with", dest="on", type=Path, default=ROOT / "runs" / "default")
    ap.add_argument("--without", dest="off", type=Path, default=ROOT / "runs" / "noflip" / "case")
    ap.add_argument("--json", type=Path, help="write the figures here (strict JSON)")
    args = ap.parse_args(argv)
    for case in (args.on, args.off):
        if not (case / "adapter-summary.json").is_file():
            ap.error(f"{case} has no adapter-summary.json: run run-case on it first")
    record = json.loads((args.on / "adapter-case.json").read_text())
    rho = float(record.get("rho_kg_m3", 1025.0))
    junction = junction_drag(float(record["speed_m_s"]), rho)
    on, off = gliding(args.on), gliding(args.off)
    buoy = horizontal_buoyancy(args.off, args.on / "constant" / "triSurface" / "whale.stl", rho)
    print(table(on, off, buoy, junction))
    if args.json:
        write_json(args.json, finite({"with": on, "without": off, "horizontal_buoyancy": buoy,
                                      "junction_N": junction}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
