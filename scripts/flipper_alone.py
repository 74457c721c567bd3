"""The procedural whale's flipper on its own: a wing in a uniform stream, run-case's pipeline.

Is the on-body flipper's drag (85.5 N per flipper gliding at 1.3 m/s, 2.8 times its estimate)
the body's interference, or does the flipper alone, meshed and solved the same way, have it
too? The wing is the default whale's left flipper (:func:`adapter.body.procedural.flipper_fin`:
its chord and thickness laws, 0.11 L long, the sections of :func:`adapter.body.fins.fin_layers`,
NACA four-digit foils turning into ellipses over the outer 20 % of the span, a rounded tip)
and its mirror image about y = 0, joined at their roots on the plane y = 0, which contains the
stream: run-case meshes the half y >= 0 with a symmetry plane there, so the half's force is
one flipper's. Chord along x, thickness along z, span along y:

- ``swept``: the flipper's sweep, a sheared wing: the section at span station t (0 root,
  1 tip) lies in the plane y = t l cos(sweep) (l = 1.65 m), its centre at
  x = t l sin(sweep), sin(sweep) = 0.451, the x share of the flipper's growth direction
  (26.8 deg); the chord along x is the flipper's c(t) / cos(sweep), the thickness its own, so
  that the section normal to the span is the flipper's section and the planform area the
  flipper's;
- ``unswept``: span along y, the section at y = t l the flipper's section itself;
- ``swept-fine``: ``swept`` with the wing's cells one level finer (6 instead of 5);
- ``swept-faceted``: ``swept`` with the surface at the procedural flipper's own resolution
  (20 nodes around a section, 17 sections), the facets the on-body flipper's STL has;
- ``unswept-fine``: ``unswept`` with the wing's cells one level finer.

The tip: the last section (an ellipse) closed by half an ellipsoid reaching
0.5 min(c, 3 t) beyond it, the extent of :func:`~adapter.body.fins.fin_layers`' tip cap.

The case is the default scene's (1.3 m/s, nu 1e-6, rho 1025, kOmegaSST with wall functions, 3
prism layers from 7 mm growing by 1.5, 2 m background cells, surface levels (2 4), dt 0.0869 s,
the domain the whale's in metres: 22.5 m ahead, 45 m behind, 22.5 m to the side, above and
below); the wing is a mesh file without the whale's landmarks, which run-case meshes without
the flippers' refinement, so the script puts the flippers' rule back into the prepared
snappyHexMeshDict: the cells within one cell of level 5 (0.061 m) of the wing at that level,
and the near-body box at level 1 grown by the whale's 0.1 L (1.5 m) around the wing. Held
still (run-case's ``--static-whale``: staticFvMesh, the whale patch fixedValue), from still
water with the inflow ramped in over 3.85 s, until the mean drag over a period of 7.69 s (the
whale's stroke period) changes by less than 2 % from one period to the next: the gliding run's
stop rule. The scene has ``[rigid]`` enabled with zero amplitudes only so that a mesh file
without landmarks is accepted; nothing moves.

    nice -n 19 .venv/bin/python scripts/flipper_alone.py [--wings swept unswept ...] \
        [--out runs/flipper-alone] [--np 2]

(all the wings by default; the plugin library must be built, ``make plugin``, or named by
``WHALE_PLUGIN_LIB``: without it the case has no ``loads`` for the stop rule). Each wing's
case is ``<out>/<wing>/case`` (a case that has run is read again, not rerun); its figures go to
``<out>/<wing>/figures.json`` and a table is printed. Forces are one flipper's (the half
domain's own); ``span`` is the force along the wing's span direction (outward, y > 0),
``normal`` along z. Beside another run on this 2-core machine give ``--np 1``: two niced ranks
wait on each other.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "scripts"))

from adapter.body.fins import fin_section  # noqa: E402
from adapter.body.procedural import flipper_fin  # noqa: E402
from adapter.foam.summary import finite  # noqa: E402
from adapter.jsonfiles import write_json  # noqa: E402

#: the wing's surface: (nodes around a section, sections root to tip, rings of the tip cap,
#: sections spaced evenly in t or denser toward the tip)
SMOOTH = (160, 64, 12, False)
#: ... at the procedural flipper's own resolution: 20 nodes around (its patch loop), 17
#: sections evenly in t (its 16 extrusion layers and the root)
FACETED = (20, 17, 3, True)
#: the wings: name -> (swept, the wing's refinement level, its surface's resolution)
WINGS = {"swept": (True, 5, SMOOTH), "unswept": (False, 5, SMOOTH),
         "swept-fine": (True, 6, SMOOTH), "swept-faceted": (True, 5, FACETED),
         "unswept-fine": (False, 6, SMOOTH)}
#: the default whale (scene default.toml): length, gliding speed, stroke period
WHALE_LENGTH_M = 15.0
SPEED = 1.3
PERIOD_S = 1 / 0.13
#: the whale's domain in metres (1.5 L ahead, 3 L behind, 1.5 L to each side) and its
#: near-body box margin (0.1 L)
AHEAD_M, BEHIND_M, SIDE_M, NEAR_M = 22.5, 45.0, 22.5, 1.5
#: the on-body flipper's gliding figures on the default (runs/default/gliding, one flipper)
ON_BODY = {"drag_N": 85.5, "pressure_N": 72.8, "viscous_N": 12.6,
           "force_N": (85.5, 91.8, -39.1), "estimate_N": 30.7}


def section(fin, t: float, alpha: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(chord fraction, signed half-thickness over chord) of the flipper's section at span
    station ``t`` for the angles ``alpha`` around it: the whale's own
    (:func:`adapter.body.fins.fin_section`), its upper side positive."""
    xc, half = fin_section(fin, t, alpha)
    return xc, np.sign(np.round(np.sin(alpha), 12)) * half


def wing_surface(fin, swept: bool, around: int = 160, stations: int = 64,
                 cap_rings: int = 12, even: bool = False) -> tuple[np.ndarray, list]:
    """The closed wing: points (N, 3) and faces [triangles (T, 3), quads (Q, 4)].

    ``around`` nodes per section, ``stations`` sections from root to tip (evenly in t when
    ``even``, else denser toward the tip, where the chord closes), ``cap_rings`` rings of the
    tip cap; the half y >= 0 mirrored exactly, the root section on y = 0."""
    d = fin.direction / np.linalg.norm(fin.direction)
    sin_s = float(d[0]) if swept else 0.0
    cos_s = math.sqrt(1 - sin_s**2)
    alpha = np.pi + 2 * np.pi * np.arange(around) / around
    rings = []

    def ring(t, xc, zc, chord, along):
        # along: the distance from the root along the span direction (m)
        x = along * sin_s + chord * (xc - 0.5) / cos_s
        return np.column_stack([x, np.full(around, along * cos_s), zc * chord])

    for u in np.linspace(0.0, 1.0, stations):
        t = u if even else math.sin(0.5 * math.pi * u)
        xc, zc = section(fin, t, alpha)
        rings.append(ring(t, xc, zc, fin.chord(t), t * fin.length))
    xc, zc = section(fin, 1.0, alpha)
    c1 = fin.chord(1.0)
    reach = 0.5 * min(c1, 3 * fin.thickness_ratio(1.0) * c1)
    for j in range(1, cap_rings):
        phi = 0.5 * math.pi * j / cap_rings
        # the tip section shrunk about its chord's middle: half an ellipsoid
        rings.append(ring(1.0, 0.5 + (xc - 0.5) * math.cos(phi), zc * math.cos(phi), c1,
                          fin.length + reach * math.sin(phi)))
    half = np.array(rings)                                     # (R, around, 3), y >= 0
    tip = np.array([fin.length * sin_s + reach * sin_s, (fin.length + reach) * cos_s, 0.0])
    mirror = np.array([1.0, -1.0, 1.0])
    stack = np.concatenate([half[:0:-1] * mirror, half])       # tip (y < 0) .. tip (y > 0)
    n_r = len(stack)
    points = np.concatenate([stack.reshape(-1, 3), [tip * mirror, tip]])
    i = np.arange(n_r - 1)[:, None] * around
    j = np.arange(around)[None, :]
    jn = (j + 1) % around
    quads = np.stack([i + j, i + jn, i + around + jn, i + around + j], axis=-1).reshape(-1, 4)
    left, right = n_r * around, n_r * around + 1
    last = (n_r - 1) * around
    tris = np.concatenate([
        np.column_stack([np.full(around, left), jn.ravel(), j.ravel()]),
        np.column_stack([np.full(around, right), last + j.ravel(), last + jn.ravel()])])
    return points, [tris.astype(np.int64), quads.astype(np.int64)]


def scene_text(stl: Path, length: float) -> str:
    """The scene: the default's flow, mesh and case settings on the wing's mesh file."""
    return f"""# the flipper alone as a wing (scripts/flipper_alone.py)
[geometry]
source = "{stl.name}"
length_m = {length!r}

[rigid]
# enabled with zero amplitudes only so that a mesh file without the whale's landmarks is
# taken as a body (the run holds it still: --static-whale); its period is the whale's stroke's,
# the window of the gliding stop rule
enabled = true
frequency_hz = 0.13
translation_m = [0.0, 0.0, 0.0]

[case]
upstream = {AHEAD_M / length!r}
downstream = {BEHIND_M / length!r}
half_width = {SIDE_M / length!r}
background_cell = {2.0 / length!r}
gliding = false
"""


def prepare(wing: str, out: Path, ranks: int) -> Path:
    """Write the wing's STL and scene and prepare its case (kept when it exists)."""
    from adapter.body.meshfile import write_surface
    from adapter.foam.case import Case, prepare_case
    from adapter.foam.dictionaries import parsed_dict
    from adapter.scene import load_scene

    swept, level, resolution = WINGS[wing]
    folder = out / wing
    case = folder / "case"
    if (case / "system" / "controlDict").exists():
        return case
    folder.mkdir(parents=True, exist_ok=True)
    points, faces = wing_surface(flipper_fin(WHALE_LENGTH_M), swept, *resolution)
    stl = folder / "wing.stl"
    write_surface(stl, points, faces)
    size = np.ptp(points, axis=0)
    scene_file = folder / "wing.toml"
    scene_file.write_text(scene_text(stl, float(size[0])))
    scene = load_scene(scene_file)
    prepare_case(scene, case, ranks=ranks, scene_file=scene_file, static_whale=True)
    # the flippers' refinement (case.flipper_level), which run-case leaves out for a body
    # without the whale's landmarks: the whole wing is the flippers' surface
    tri = case / "constant" / "triSurface"
    (tri / "flippers.stl").write_bytes((tri / "whale.stl").read_bytes())
    par = Case(case).record["parameters"]
    cell = float(min(par["cell_size"])) / 2**level
    d = parsed_dict(case / "system" / "snappyHexMeshDict")
    d["geometry"]["flippers.stl"] = {"type": "triSurfaceMesh", "name": "flippers"}
    regions = d["castellatedMeshControls"]["refinementRegions"]
    regions["flippers"] = {"mode": "distance", "levels": f"(({cell!r} {level}))"}
    lo, hi = points.min(axis=0) - NEAR_M, points.max(axis=0) + NEAR_M
    d["geometry"]["nearWhale"]["min"] = f"({float(lo[0])!r} 0 {float(lo[2])!r})"
    d["geometry"]["nearWhale"]["max"] = "({!r} {!r} {!r})".format(*map(float, hi))
    d.writeFile()
    return case


def run(case: Path, ranks: int) -> float | None:
    """Mesh and run the case until the gliding stop rule holds; the wall time (s) spent, None
    when the case had run already (it is only read again)."""
    from adapter.foam.case import Case
    from adapter.foam.freerun import steady_gliding
    from adapter.foam.mesh import mesh_case
    from adapter.foam.run import run_case

    held = Case(case)
    rule = steady_gliding(PERIOD_S, float(held.record["periodic_tolerance"]), PERIOD_S)
    if (case / "constant" / "polyMesh" / "owner").exists() and held.has_summary and rule(case):
        return None
    t0 = time.perf_counter()
    if not (case / "constant" / "polyMesh" / "owner").exists():
        mesh_case(case, ranks=1)
    run_case(case, ranks=ranks, stop_when=rule, progress=False)
    return time.perf_counter() - t0


def figures(wing: str, case: Path, wall_s: float) -> dict:
    """One wing's figures: one flipper's forces over the gliding window (the last whole
    period after the first), y+, the mesh, the estimate."""
    from adapter.body.meshfile import read_stl_solids
    from adapter.body.planform import mirrored_planform, triangle_areas
    from adapter.foam.case import Case
    from adapter.foam.estimates import fin_estimate
    from adapter.foam.loads import cycle_stats, read_loads
    from adapter.foam.parallel import reconstruct_latest_time
    from adapter.foam.yplus import yplus_stats

    swept, level, _ = WINGS[wing]
    data = read_loads(case, whole=False)      # one flipper: the half's own columns
    t = data["Time"]
    st = cycle_stats(t, data["total:Fx"], data["total:P"], PERIOD_S, PERIOD_S)
    a = st.starts[-1]
    window = (t > a + 1e-9) & (t <= a + PERIOD_S + 1e-9)

    def mean(col):
        return float(data[f"total:{col}"][window].mean())

    force = np.array([mean("Fx"), mean("Fy"), mean("Fz")])
    fin = flipper_fin(WHALE_LENGTH_M)
    d = fin.direction / np.linalg.norm(fin.direction)
    span = np.array([d[0], math.sqrt(1 - d[0] ** 2), 0.0]) if swept else np.array([0, 1.0, 0])
    record = Case(case).record
    reconstruct_latest_time(case)          # the strips read the last time's p
    yp = yplus_stats(case)
    tri = read_stl_solids(case / "constant" / "triSurface" / "whale_regions.stl")["body"]
    plan = mirrored_planform(tri, 0.0)
    area = float(triangle_areas(tri).sum()) / 2
    est = fin_estimate(area, plan["mean_chord_m"], plan["t_c"], SPEED, 1025.0, 1e-6)
    summary = Case(case).summary
    mesh = record["mesh"]
    return {
        "wing": wing, "swept": swept, "level": level,
        "cell_m": float(min(record["parameters"]["cell_size"])) / 2**level,
        "window_s": [a, a + PERIOD_S], "end_time_s": float(t[-1]),
        "stopped_because": summary.get("stopped_because"),
        "drag_N": force[0], "pressure_N": mean("Fpx"), "viscous_N": mean("Fvx"),
        "force_N": force.tolist(), "span_direction": span.tolist(),
        "span_N": float(force @ span), "normal_N": force[2],
        "period_change": float(abs(st.mean_fx[-1] - st.mean_fx[-2]) / abs(st.mean_fx[-1])),
        "cells": mesh["cells"], "wing_faces": mesh["whale_faces"],
        "layers": {k: mesh["layers"].get(k) for k in
                   ("face_coverage", "area_with_layers", "area_full_thickness", "mean_layers",
                    "thickness_m")},
        "max_non_orthogonality": mesh["max_non_orthogonality"],
        "yplus": {k: yp.get(k) for k in ("median", "p5", "p95", "area_le_300", "area_30_300",
                                          "area_below_30", "time")},
        "wetted_area_m2": area, "mean_chord_m": plan["mean_chord_m"], "t_c": plan["t_c"],
        "span_m": plan["span_m"], "estimate": est, "ratio": force[0] / est["estimate_N"],
        "steps": summary.get("steps"), "flow_wall_s": summary.get("flow_wall_s"),
        "wall_s": wall_s,
        "strips": pressure_strips(case, yp["time"], span),
    }


def pressure_strips(case: Path, time: str, span: np.ndarray, strips: int = 4) -> list[dict]:
    """One flipper's pressure force by span strip (root first, strips of equal distance from
    the root along the span), as scripts/region_pressure.py splits the on-body flipper: per
    strip its pressure force (N, x and along ``span``), its x extent and the area-weighted Cp
    of the chord bands 0-0.1-0.3-0.5-0.7-0.9-1 (0 the leading edge)."""
    from region_pressure import CHORD_BANDS, patch_pressure

    sf, centre, p = patch_pressure(case, time, 1025.0)      # sf: out of the fluid
    area = np.linalg.norm(sf, axis=1)
    q = 0.5 * 1025.0 * SPEED**2
    force = p[:, None] * sf
    along = centre[:, 1] / span[1]             # the span station's distance from the root
    edges = np.linspace(along.min(), along.max() + 1e-9, strips + 1)
    out = []
    for lo, hi in zip(edges[:-1], edges[1:], strict=True):
        m = (along >= lo) & (along < hi)
        x = centre[m, 0]
        band = np.digitize((x - x.min()) / np.ptp(x), CHORD_BANDS)
        cp = [float((p[m][band == k] * area[m][band == k]).sum() / area[m][band == k].sum()
                    / q) if (band == k).any() else float("nan")
              for k in range(len(CHORD_BANDS) + 1)]
        out.append({"span_m": [float(lo), float(hi)], "chord_m": float(np.ptp(x)),
                    "pressure_x_N": float(force[m, 0].sum()),
                    "pressure_span_N": float((force[m] @ span).sum()), "cp_bands": cp})
    return out


def table(rows: list[dict]) -> str:
    """The figures side by side with the on-body flipper's."""
    lines = ["| | " + " | ".join(r["wing"] for r in rows) + " | on the body |",
             "|---" * (len(rows) + 2) + "|"]

    def line(label, get, fmt, on_body=""):
        cells = [fmt.format(get(r)) if get(r) is not None else "" for r in rows]
        lines.append(f"| {label} | " + " | ".join(cells) + f" | {on_body} |")

    line("drag, one flipper (N)", lambda r: r["drag_N"], "{:.1f}", f"{ON_BODY['drag_N']}")
    line("  pressure (N)", lambda r: r["pressure_N"], "{:.1f}", f"{ON_BODY['pressure_N']}")
    line("  viscous (N)", lambda r: r["viscous_N"], "{:.1f}", f"{ON_BODY['viscous_N']}")
    line("force (Fx, Fy, Fz) (N)", lambda r: "({:.1f}, {:.1f}, {:.1f})".format(*r["force_N"]),
         "{}", "({:.1f}, {:.1f}, {:.1f})".format(*ON_BODY["force_N"]))
    line("along the span (N)", lambda r: r["span_N"], "{:.1f}", "~128")
    line("normal, Fz (N)", lambda r: r["normal_N"], "{:.1f}")
    line("estimate (N)", lambda r: r["estimate"]["estimate_N"], "{:.1f}",
         str(ON_BODY["estimate_N"]))
    line("drag / estimate", lambda r: r["ratio"], "{:.2f}", "2.78")
    line("wetted area, one flipper (m2)", lambda r: r["wetted_area_m2"], "{:.2f}", "5.62")
    line("mean chord along x (m), Re", lambda r: "{:.2f}, {:.2g}".format(
        r["mean_chord_m"], r["estimate"]["re"]), "{}", "1.62, 2.1e+06")
    line("t/c", lambda r: r["t_c"], "{:.3f}", "0.219")
    line("cells", lambda r: r["cells"], "{:,}", "48,598 (whole whale)")
    line("wing faces", lambda r: r["wing_faces"], "{:,}")
    line("wing cell (m)", lambda r: r["cell_m"], "{:.4f}", "0.0619")
    line("layers: area covered", lambda r: r["layers"]["area_with_layers"], "{:.1%}")
    line("y+ median (5-95 %)", lambda r: "{:.0f} ({:.0f}-{:.0f})".format(
        r["yplus"]["median"], r["yplus"]["p5"], r["yplus"]["p95"]), "{}")
    line("area with y+ <= 300", lambda r: r["yplus"]["area_le_300"], "{:.1%}")
    line("period-to-period change", lambda r: r["period_change"], "{:.2%}")
    line("window (s)", lambda r: "{:.2f}-{:.2f}".format(*r["window_s"]), "{}")
    line("steps, pimpleFoam wall (s)", lambda r: None if r["flow_wall_s"] is None
         else f"{r['steps']}, {r['flow_wall_s']:.0f}", "{}")
    line("wall, mesh + run (s)", lambda r: None if math.isnan(r["wall_s"]) else r["wall_s"],
         "{:.0f}")
    return "\n".join(lines)


def strips_text(row: dict) -> str:
    """A wing's pressure force by span strip (:func:`pressure_strips`), one line a strip."""
    lines = [f"{row['wing']}: pressure force by span strip, root first; Cp in chord bands "
             "0-0.1-0.3-0.5-0.7-0.9-1 (0 the leading edge)"]
    for st in row.get("strips", []):
        lines.append(f"  {st['span_m'][0]:.2f}-{st['span_m'][1]:.2f} m, x extent "
                     f"{st['chord_m']:.2f} m: x {st['pressure_x_N']:+6.1f} N, along the span "
                     f"{st['pressure_span_N']:+6.1f} N; Cp "
                     + " ".join(f"{v:+.2f}" for v in st["cp_bands"]))
    return "\n".join(lines)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--wings", nargs="+", choices=list(WINGS), default=list(WINGS))
    p.add_argument("--out", type=Path, default=ROOT / "runs" / "flipper-alone")
    p.add_argument("--np", type=int, default=2, dest="ranks",
                   help="MPI ranks (1 beside another run: 2 niced ranks wait on each other)")
    p.add_argument("--prepare-only", action="store_true")
    args = p.parse_args(argv)
    from adapter.foam.dictionaries import plugin_lib

    if not plugin_lib().is_file():
        # without the plugin a flow-only case gets OpenFOAM's forces, not the loads the stop
        # rule and the figures read: it would run to its end time and have no figures
        p.error(f"the plugin library {plugin_lib()} is missing: build it (make plugin) or set "
                "WHALE_PLUGIN_LIB to a built libstepServerDisplacement.so")
    rows = []
    for wing in args.wings:
        case = prepare(wing, args.out, args.ranks)
        if args.prepare_only:
            continue
        wall = run(case, args.ranks)
        saved = args.out / wing / "figures.json"
        if wall is None:        # read again: the wall time of the run that made it
            wall = json.loads(saved.read_text())["wall_s"] if saved.is_file() else math.nan
        result = figures(wing, case, wall)
        write_json(saved, finite(result))
        rows.append(result)
        print(table(rows), flush=True)
        print(strips_text(result), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
