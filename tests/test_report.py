"""``<case>/report.html`` (adapter/foam/report.py, adapter/reports/html_page.py): written from a
case folder's files, self-contained (every picture inline, nothing to fetch), read back; and
opened in Debian's real headless chromium, which must draw every picture (naturalWidth > 0) with
no console message. The browser test is skipped, with its reason, when chromium is absent
(``scripts/install_chromium.sh``, part of ``make setup``).

The case folder here is made from files alone (a summary, a case record, the pictures of
docs/img/), so no OpenFOAM is needed; tests/test_swimrun.py checks that run-case writes the page.
"""

from __future__ import annotations

import base64
import html
import json
import re
import shutil
import subprocess
from pathlib import Path

import pytest

from adapter.foam.report import REPORT, write_report
from adapter.foam.swimrun import COST_ROWS
from adapter.reports.html_page import CSP
from adapter.studies.study_report import write_study_report

REPO = Path(__file__).resolve().parent.parent
IMG = REPO / "docs" / "img"

#: a summary of the shape run-case writes for the gliding + swimming pair (the default case's
#: headline figures, docs/results/2026-12-01-default-case.md)
SUMMARY = {
    "case": "runs/default", "preset": "default", "static_whale": False, "cells": 95229,
    "steps": 711, "ranks": 1, "step_s": 1.01, "whale_points": 9703,
    "max_mapping_distance_m": 0.05, "max_courant": 12.5,
    "worst_cell_quality": {"max_non_orthogonality_deg": 79.8, "min_cell_volume_m3": 2.7e-6,
                           "initial_max_non_orthogonality_deg": 75.0,
                           "initial_max_skewness": 3.1},
    "stopped_because": "periodic: cycle mean Fx changed 1.2% of the gliding drag",
    "swimming_cost": {
        "gliding_drag_N": 661.0, "gliding_drag_pressure_N": 424.0,
        "gliding_drag_viscous_N": 236.0, "swimming_mean_fx_N": -835.0,
        "swimming_mean_power_W": 4149.0, "froude_efficiency": 0.47,
        "cost_of_transport_J_kg_m": 0.045, "mass_kg": 70400.0, "cycles_measured": 3,
        "van_der_hoop": {"drag_N": 354.0},
        "periodic_change": {"fx_of_gliding_drag": 0.012, "power": 0.004, "tolerance": 0.02,
                            "reached": True},
        "regions": {"flukes": {"gliding_drag_N": 88.0, "power_W": 4055.0}},
    },
    "yplus": {"times": 17, "worst_area_le_300": 0.970, "worst_area_30_300": 0.95,
              "median": 161.0, "p5": 89.0, "p95": 227.0, "time": "24.86"},
    "yplus_gliding": {"times": 12, "worst_area_le_300": 0.967, "median": 160.0},
}

RECORD = {"scene_file": None, "preset": "smoke", "period_s": 7.6923, "speed_m_s": 1.3,
          "length_m": 15.0, "gliding": True, "static_whale": False, "periodic_tolerance": 0.02,
          "max_non_orthogonality": 80.0,
          "mesh": {"cells": 95229, "whale_faces": 8506, "whale_points": 9703, "mesh_ok": True}}


def make_case(folder: Path, summary=SUMMARY, pictures: bool = True) -> Path:
    case = folder / "case"
    case.mkdir()
    (case / "adapter-summary.json").write_text(json.dumps(summary))
    (case / "adapter-case.json").write_text(json.dumps(RECORD))
    shutil.copy(IMG / "forces-default.png", case / "forces.png")
    if pictures:
        (case / "paraview").mkdir()
        shutil.copy(IMG / "paraview-default.png", case / "paraview" / "side_t24.86.png")
    (case / "log.pimpleFoam").write_text("Build  : OPENFOAM=1912 patch=200626\nExec   : x\n")
    return case


def images(page: str) -> list[str]:
    return re.findall(r'<img [^>]*src="([^"]*)"', page)


def test_the_report_is_self_contained_and_holds_the_figures(tmp_path):
    case = make_case(tmp_path)
    page = write_report(case, rows=COST_ROWS).read_text()
    assert (case / REPORT).is_file()
    # every picture inline, byte for byte (round trip); nothing the page would fetch
    srcs = images(page)
    assert len(srcs) == 2
    inline = [base64.b64decode(s.removeprefix("data:image/png;base64,")) for s in srcs]
    assert inline == [(IMG / "forces-default.png").read_bytes(),
                      (IMG / "paraview-default.png").read_bytes()]
    assert not re.search(r'(?:src|href)="(?!data:)', page)
    assert "http://" not in page and "https://" not in page and "<script" not in page
    assert CSP in page
    # the headline figures, y+, mesh quality, scene and versions
    for text in ("661 N", "-835 N", "4149 W", "0.47", "negative mean Fx is net thrust",
                 "97.0%", "79.8 deg", "8,506", "the mesh watch&#x27;s non-orthogonality limit",
                 "[stroke]", "OPENFOAM=1912 patch=200626", "whale-adapter"):
        assert text in page, text
    assert 'class="warning"' not in page


def test_a_run_that_never_became_periodic_says_so(tmp_path):
    summary = json.loads(json.dumps(SUMMARY))
    summary["swimming_cost"]["periodic_change"]["reached"] = False
    case = make_case(tmp_path, summary, pictures=False)
    page = write_report(case, rows=COST_ROWS).read_text()
    assert 'class="warning"' in page and "ended before its periodic state" in page
    assert "No ParaView pictures yet" in page and len(images(page)) == 1


def test_a_single_run_gets_its_summary_table(tmp_path):
    summary = {k: v for k, v in SUMMARY.items() if k not in ("swimming_cost", "yplus_gliding")}
    summary["drag_N"] = 650.0
    page = write_report(make_case(tmp_path, summary)).read_text()
    assert "The run" in page and "650 N" in page and "What swimming costs" not in page


def test_text_is_escaped(tmp_path):
    summary = dict(SUMMARY, stopped_because="<b>periodic</b> & done")
    page = write_report(make_case(tmp_path, summary), rows=COST_ROWS).read_text()
    assert "&lt;b&gt;periodic&lt;/b&gt; &amp; done" in page and "<b>" not in page


#: a study.json's content as the study's analysis writes it, two cases of three finished (the
#: flow study's record, docs/results/2026-12-01-flow-study.md)
STUDY = {
    "scene": "default", "ratio": 1.3, "finest": "scene",
    "cases": {
        "mesh-1/case": {"cells": 95229, "background_cell_m": 2.02, "delta_t_s": 0.0435,
                        "speed_m_s": 1.3, "gliding_drag": 661.0, "swimming_fx": -835.0,
                        "swimming_power": 4149.0, "froude_efficiency": 0.47,
                        "yplus_area_le_300": 0.970, "periodic_reached": True,
                        "wall_s_per_cycle": 164.0},
        "mesh-2/case": {"cells": 64440, "background_cell_m": 2.63, "delta_t_s": 0.0435,
                        "speed_m_s": 1.3, "gliding_drag": 690.0, "swimming_fx": -724.0,
                        "swimming_power": 4044.0, "froude_efficiency": 0.46,
                        "yplus_area_le_300": 0.946, "periodic_reached": True,
                        "wall_s_per_cycle": 105.0},
        "mesh-3/case": None},
    "failed": {}, "not_finished": ["mesh-3/case"],
}


def test_the_study_page_holds_its_cases_and_chart(tmp_path):
    page = write_study_report(tmp_path, STUDY, IMG / "accuracy-vs-cost.png").read_text()
    assert (tmp_path / "report.html").is_file()
    for text in ("95,229", "-835 N", "4044 W", "97.0%", "not finished: mesh-3/case", "mesh-1 "):
        assert text in page, text
    assert len(images(page)) == 1 and CSP in page and "<script" not in page


# -- in a real browser --------------------------------------------------------------------------

CHROMIUM = shutil.which("chromium")

#: what the test adds to a copy of the page to read it back: console and error hooks first, the
#: pictures' sizes once the page has loaded; the page's policy is widened by inline scripts alone
_HOOKS = """<script>
window.__problems = [];
for (const level of ["error", "warn"]) {
  console[level] = (...a) => window.__problems.push(level + ": " + a.join(" "));
}
window.addEventListener("error", e => window.__problems.push("error: " + e.message), true);
document.addEventListener("securitypolicyviolation",
  e => window.__problems.push("blocked: " + e.blockedURI));
</script>"""
_PROBE = """<script>
window.addEventListener("load", () => document.body.setAttribute("data-probe", JSON.stringify({
  images: [...document.images].map(i => [i.alt, i.complete, i.naturalWidth, i.naturalHeight]),
  problems: window.__problems})));
</script>"""


def open_in_chromium(page: Path, tmp_path: Path) -> dict:
    """The page opened in headless chromium: ``images`` ([alt, complete, naturalWidth,
    naturalHeight] each), ``problems`` (console errors and warnings, script errors, blocked
    loads) and ``console`` (every console line chromium logged)."""
    text = page.read_text()
    text = text.replace(CSP, CSP + "; script-src 'unsafe-inline'")
    text = text.replace("<head>", "<head>\n" + _HOOKS, 1).replace("</body>", _PROBE + "</body>")
    probe = tmp_path / "probe.html"
    probe.write_text(text)
    profile = tmp_path / "chromium-profile"
    cmd = [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
           "--disable-background-networking", "--disable-component-update", "--disable-sync",
           f"--user-data-dir={profile}", "--host-resolver-rules=MAP * ~NOTFOUND",
           "--enable-logging=stderr", "--v=0", "--virtual-time-budget=10000", "--dump-dom",
           probe.as_uri()]
    out = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr[-3000:]
    m = re.search(r'<body data-probe="([^"]*)"', out.stdout)
    assert m, f"the probe did not run:\n{out.stdout[:2000]}\n{out.stderr[-2000:]}"
    result = json.loads(html.unescape(m[1]))
    result["console"] = re.findall(r":CONSOLE[^\]]*\] (.*)", out.stderr)
    return result


@pytest.mark.browser
def test_the_probe_sees_a_broken_picture_and_a_console_error(tmp_path):
    """The harness itself: a picture that does not decode and a page script's errors."""
    page = tmp_path / "bad.html"
    page.write_text(f'<!DOCTYPE html><html><head><meta http-equiv="Content-Security-Policy" '
                    f'content="{CSP}"></head><body><img alt="bad" src="data:image/png;base64,'
                    'AAAA"><img alt="net" src="https://example.org/x.png"><script>'
                    'console.error("boom"); undefinedName;</script></body></html>')
    seen = open_in_chromium(page, tmp_path)
    assert [(alt, width) for alt, _, width, _ in seen["images"]] == [("bad", 0), ("net", 0)]
    assert "error: boom" in seen["problems"]
    assert any("undefinedName" in p for p in seen["problems"])
    assert any(p.startswith("blocked: https://example.org") for p in seen["problems"])


@pytest.mark.browser
def test_the_report_renders_its_pictures_in_chromium(tmp_path):
    page = write_report(make_case(tmp_path), rows=COST_ROWS)
    seen = open_in_chromium(page, tmp_path)
    assert len(seen["images"]) == 2
    for alt, complete, width, height in seen["images"]:
        assert complete and width > 0 and height > 0, f"{alt}: not drawn ({width} x {height})"
    assert seen["problems"] == [] and seen["console"] == []


@pytest.mark.browser
def test_the_study_page_renders_in_chromium(tmp_path):
    page = write_study_report(tmp_path, STUDY, IMG / "accuracy-vs-cost.png")
    seen = open_in_chromium(page, tmp_path)
    assert [w > 0 for _, _, w, _ in seen["images"]] == [True]
    assert seen["problems"] == [] and seen["console"] == []
