"""``<case>/report.html``: one page a biologist can open offline, written by run-case next to
``adapter-summary.json``: the headline figures, ``forces.png`` and the ParaView pictures (when
``whale-adapter paraview`` made them), y+ and mesh quality, the scene and the versions used.
Everything on it comes from the case folder (the summary, ``adapter-case.json``, the logs); the
page itself is drawn by :mod:`adapter.reports.html_page`.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import platform
import re
import sys
from datetime import datetime, timezone
from importlib import metadata
from pathlib import Path

from adapter.errors import SceneError
from adapter.foam.case import Case
from adapter.foam.casescene import case_scene_file
from adapter.foam.estimates import plausibility_table
from adapter.foam.summary import SUMMARY, SUMMARY_ROWS, summary_rows
from adapter.reports.html_page import Section, write_page
from adapter.scene import load_scene

REPORT = "report.html"

#: the y+ rows: (label, key of summary["yplus"], format)
_YPLUS_ROWS = [
    ("share of the area with y+ <= 300, worst write", "worst_area_le_300", "{:.1%}"),
    ("share of the area with y+ in 30-300, worst write", "worst_area_30_300", "{:.1%}"),
    ("median (area-weighted, last write)", "median", "{:.0f}"),
    ("5 %", "p5", "{:.0f}"),
    ("95 %", "p95", "{:.0f}"),
    ("share of the area with prism layers", "layer_area_coverage", "{:.1%}"),
    ("last write", "time", "t = {} s"),
    ("written times", "times", "{}"),
]

_MESH_ROWS = [
    ("cells", "cells", "{:,}"),
    ("whale patch points", "whale_points", "{:,}"),
    ("largest non-orthogonality through the run",
     "worst_cell_quality/max_non_orthogonality_deg", "{:.1f} deg"),
    ("  before motion (checkMesh)", "worst_cell_quality/initial_max_non_orthogonality_deg",
     "{:.1f} deg"),
    ("largest skewness before motion", "worst_cell_quality/initial_max_skewness", "{:.2f}"),
    ("smallest cell volume through the run", "worst_cell_quality/min_cell_volume_m3",
     "{:.3g} m3"),
    ("largest Courant number", "max_courant", "{:.3g}"),
    ("largest distance of a patch point from the whale", "max_mapping_distance_m", "{:.3g} m"),
    ("stopped by the mesh watch", "stopped", "{}"),
]


def write_report(case, summary: dict | None = None, rows=None) -> Path:
    """Write ``<case>/report.html`` from the case folder; ``summary``: the run's summary (default:
    ``adapter-summary.json`` as written); ``rows``: the headline table's rows, as
    :func:`~adapter.foam.summary.format_summary` takes them (the pair passes its
    ``COST_ROWS``; default :data:`~adapter.foam.summary.SUMMARY_ROWS`). Returns the page's
    path."""
    case = Path(case)
    held = Case(case)
    if summary is None:
        summary = json.loads(held.summary_file.read_text())
    record = held.record if held.has_record else {}
    sections = [_headline(summary, rows or SUMMARY_ROWS), _plausibility(summary),
                _forces(case), _pictures(case), _yplus(summary), _mesh(summary, record),
                _scene(case, record), versions_section(case)]
    subtitle = (f"{case.resolve()} · written "
                f"{datetime.now(timezone.utc).strftime('%Y-%m-%d %H:%M UTC')} by "
                f"whale-adapter run-case · every figure: {SUMMARY}")
    return write_page(case / REPORT, f"whale-adapter: {case.name}", subtitle,
                      [s for s in sections if s is not None])


def _headline(summary: dict, rows) -> Section:
    cost = summary.get("swimming_cost")
    stopped = f"The mesh watch stopped the run: {summary['stopped']}" if summary.get(
        "stopped") else ""
    if not cost:
        return Section("The run", warning=stopped,
                       rows=tuple(summary_rows(summary, rows)))
    periodic = cost.get("periodic_change", {})
    warning = ""
    if periodic and not periodic.get("reached", True):
        warning = ("The swimming run ended before its periodic state: the last two cycles' means "
                   f"differ by more than {periodic.get('tolerance', 0):.0%}. Run the same "
                   "command again with a larger case.cycles to continue it.")
    warning = stopped or warning
    return Section(
        "What swimming costs the whale", warning=warning,
        text=("Cycle means over the last stroke cycle after the start-up. Fx is the force along "
              "the flow (+x, rostrum to tail): a negative mean Fx is net thrust (the stroke's "
              "thrust exceeds the drag; held in the channel, the whale would speed up)."),
        rows=tuple(summary_rows(summary, rows)))


def _plausibility(summary: dict) -> Section | None:
    header, rows, warning = plausibility_table(
        (summary.get("swimming_cost") or {}).get("regions") or {})
    if not rows:
        return None
    return Section("Gliding drag by region, against an estimate from its size", warning=warning,
                   header=header, rows=rows, text=(
                       "Flippers and flukes: ITTC-57 friction at the fin's chord Reynolds number "
                       "times Hoerner's foil form factor 1 + 2 t/c + 60 (t/c)^4, on its wetted "
                       "area; body: van der Hoop et al.'s model on the body region's area. "
                       "Ratio: measured over estimate; a region outside its band is marked."))


def _forces(case: Path) -> Section | None:
    png = case / "forces.png"
    if not png.is_file():
        return None
    return Section("Forces and power", images=(
        ("forces.png: Fx, Fz and the power into the water against time, swimming and gliding; "
         "the start-up (grey) is discarded", png),))


def _pictures(case: Path) -> Section:
    pngs = sorted((case / "paraview").glob("*.png"))
    if not pngs:
        return Section("Pictures", text=(
            "No ParaView pictures yet: `whale-adapter paraview CASE` (or `make paraview "
            "CASE=...`) draws them into CASE/paraview/; run-case writes this page again the "
            "next time it runs the case."))
    return Section("Pictures", images=tuple((p.stem.replace("_", " "), p) for p in pngs))


def _yplus(summary: dict) -> Section | None:
    runs = [(name, summary.get(key) or {}) for name, key in
            (("swimming", "yplus"), ("gliding", "yplus_gliding"))]
    runs = [(name, y) for name, y in runs if y]
    if not runs:
        return None
    rows = []
    for label, key, fmt in _YPLUS_ROWS:
        cells = [_fmt(y.get(key), fmt) for _, y in runs]
        if any(cells):
            rows.append((label, *cells))
    return Section("y+ on the whale", header=("", *(name for name, _ in runs)), rows=tuple(rows),
                   text=("Spalding's wall function holds from the wall up to a first-cell y+ of "
                         "about 300."))


def _mesh(summary: dict, record: dict) -> Section:
    rows = summary_rows(summary, _MESH_ROWS)
    mesh = record.get("mesh", {})
    if "whale_faces" in mesh:
        rows.insert(1, ("whale patch faces", f"{mesh['whale_faces']:,}"))
    if "mesh_ok" in mesh:
        rows.append(("checkMesh before motion", "OK" if mesh["mesh_ok"] else "failed"))
    if "max_non_orthogonality" in record:
        rows.append(("the mesh watch's non-orthogonality limit",
                     f"{record['max_non_orthogonality']:.0f} deg"))
    return Section("Mesh quality", rows=tuple(rows))


def _scene(case: Path, record: dict) -> Section | None:
    if not record:
        return None
    scene_file = record.get("scene_file")
    own = case_scene_file(case)
    source = scene_file or f"preset {record.get('preset', 'default')}"
    rows = [("scene", source)] + ([("the case's own scene", str(own))] if own else [])
    for label, key, fmt in (("stroke period", "period_s", "{:.4g} s"),
                            ("flow speed", "speed_m_s", "{:.3g} m/s"),
                            ("body length", "length_m", "{:.3g} m"),
                            ("gliding and swimming pair", "gliding", None),
                            ("static whale", "static_whale", None),
                            ("periodic tolerance", "periodic_tolerance", "{:.0%}")):
        value = record.get(key)
        if value is not None:
            rows.append((label, ("yes" if value else "no") if fmt is None else fmt.format(value)))
    try:
        if own is not None:
            scene = load_scene(own)
        elif scene_file and Path(scene_file).is_file():
            scene = load_scene(scene_file)
        else:
            scene = load_scene(preset=record.get("preset", "default"))
        values = _scene_text(scene)
    except (SceneError, OSError) as exc:
        values = f"the scene could not be loaded again: {exc}"
    return Section("Scene", rows=tuple(rows), pre=values,
                   text=("The case's set-up; below it, every value of the scene the case's "
                         "step-server loads (its own adapter-scene.toml; a case without one: "
                         "the defaults, the preset, the file)."))


def _scene_text(scene) -> str:
    lines = [f"# {scene.name}"]
    for f in dataclasses.fields(scene):
        value = getattr(scene, f.name)
        if dataclasses.is_dataclass(value) and not isinstance(value, type):
            lines.append(f"\n[{f.name}]")
            lines += [f"{k} = {json.dumps(v, allow_nan=False)}"   # scene values are finite
                      for k, v in dataclasses.asdict(value).items()]
    return "\n".join(lines)


def versions_section(case: Path | None = None) -> Section:
    """The versions used (provenance): this package, Python, numpy, the system; with a case
    folder also OpenFOAM's build line from its log and the plugin libraries it loads."""
    rows = [("whale-adapter", _dist_version("whale-adapter")),
            ("Python", platform.python_version()),
            ("numpy", _dist_version("numpy")),
            ("system", platform.platform())]
    debian = Path("/etc/debian_version")
    if debian.is_file():
        rows.append(("Debian", debian.read_text().strip()))
    log = case / "log.pimpleFoam" if case is not None else None
    if log is not None and log.is_file():
        head = log.read_text(errors="replace")[:4000]
        m = re.search(r"^Build\s*:\s*(.+)$", head, re.M)
        if m:
            rows.append(("OpenFOAM (log.pimpleFoam)", m[1].strip()))
    for lib in _plugin_libraries(case) if case is not None else []:
        rows.append(("plugin library", f"{lib} (sha256 {_sha256(lib)})" if lib.is_file()
                     else f"{lib} (not found)"))
    rows.append(("command", " ".join(Path(a).name if i == 0 else a
                                     for i, a in enumerate(sys.argv))))
    return Section("Versions (provenance)", rows=tuple(rows))


def _plugin_libraries(case: Path) -> list[Path]:
    """The libraries the case loads by path (the plugin; run-case writes its absolute path)."""
    control = case / "system" / "controlDict"
    if not control.is_file():
        return []
    names = re.findall(r"\blibs\s*\(([^)]*)\)", control.read_text())
    found = dict.fromkeys(Path(s.strip('"')) for text in names for s in text.split())
    return [p for p in found if p.is_absolute()]   # OpenFOAM's own come by name


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()[:16]


def _dist_version(name: str) -> str:
    try:
        return metadata.version(name)
    except metadata.PackageNotFoundError:
        return "unknown"


def _fmt(value, fmt: str) -> str:
    if value is None:
        return ""
    try:
        return fmt.format(value)
    except (TypeError, ValueError):
        return str(value)
