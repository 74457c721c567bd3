"""What the flow study shows: the accuracy-against-cost chart, the short table printed at its
end and ``<study>/report.html`` (the two and a table of the cases on one offline page), all from
study.json's content (:mod:`adapter.studies.study_analysis`).

They stay with the studies rather than in :mod:`adapter.reports` because they read the
layout of study.json, which the study's analysis defines.
"""

from __future__ import annotations

from datetime import datetime, timezone
from pathlib import Path

from adapter.errors import AdapterError

REPORT = "report.html"

#: the case table of the page: (header, key of a case in study.json, format)
_CASE_COLUMNS = [
    ("cells", "cells", "{:,}"),
    ("background cell", "background_cell_m", "{:.3g} m"),
    ("flow step", "delta_t_s", "{:.4g} s"),
    ("speed", "speed_m_s", "{:.3g} m/s"),
    ("gliding drag", "gliding_drag", "{:.0f} N"),
    ("mean Fx swimming", "swimming_fx", "{:.0f} N"),
    ("mean power", "swimming_power", "{:.0f} W"),
    ("Froude eff.", "froude_efficiency", "{:.2f}"),
    ("y+ <= 300 (worst)", "yplus_area_le_300", "{:.1%}"),
    ("periodic", "periodic_reached", "{}"),
    ("wall s per cycle", "wall_s_per_cycle", "{:.0f}"),
]


def plot_accuracy_vs_cost(study: dict, path: Path) -> None:
    """Each figure's difference from its reference (the extrapolated value, or the finest mesh's
    when the three do not converge monotonically; % of its scale) against the wall time per
    swimming cycle of each mesh; hollow markers at mesh 1: its GCI, or its band (half the
    oscillation, the spread of a divergence) when there is no GCI."""
    ms = study.get("meshes")
    if not ms or not ms.get("figures"):
        raise AdapterError("the three meshes have not all finished: nothing to chart")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cost = {k: (study["cases"][f"mesh-{k}/case"] or {}).get("wall_s_per_cycle") for k in
            (1, 2, 3)}
    fig, ax = plt.subplots(figsize=(7.5, 4.8), dpi=110)
    for n, g in enumerate(ms["figures"].values()):
        colour = f"C{n}"
        pts = [(cost[k], 100 * g["difference"][str(k)]) for k in (1, 2, 3)
               if cost[k] and g["difference"][str(k)] > 0]
        if pts:
            x, y = zip(*sorted(pts), strict=True)
            ref = "f_ext" if g.get("reference") == "extrapolated" else "f(mesh 1)"
            ax.plot(x, y, "o-", color=colour, label=f"{g['label']}: |f - {ref}| / scale")
            for k in (1, 2, 3) if n == 0 else ():
                if cost[k] and g["difference"][str(k)] > 0:
                    ax.annotate(f"mesh {k}", (cost[k], 100 * g["difference"][str(k)]),
                                textcoords="offset points", xytext=(4, 4), fontsize=7)
        if g.get("gci_fine_of_scale") and cost[1]:
            ax.plot([cost[1]], [100 * g["gci_fine_of_scale"]], "o", mfc="none", ms=10,
                    color=colour, label=f"{g['label']}: GCI of mesh 1 ({g['convergence']})")
        elif g.get("band_mesh2_abs") and g.get("scale") and cost[1]:
            # no convergence: the band (half the oscillation, or the spread) at mesh 1
            ax.plot([cost[1]], [100 * g["band_mesh2_abs"] / g["scale"]], "s", mfc="none",
                    ms=9, color=colour, label=f"{g['label']}: band of mesh 1 "
                    f"({g['convergence']}{', at least' if g.get('band_is_lower_bound') else ''})")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("wall time per stroke cycle, swimming (s)")
    ax.set_ylabel("error estimate (% of the figure; Fx: of the gliding drag)")
    ax.set_title(f"Accuracy against cost: {study.get('scene')}, refinement ratio "
                 f"{study.get('ratio')}", fontsize=10)
    ax.grid(True, which="both", color="0.9")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


#: the regions' figures in the study's table: (key in study.json's meshes.regions, heading)
REGION_FIGURES = (("gliding_drag", "gliding drag by region (N)"),
                  ("swimming_fx", "mean swimming Fx by region (N), the same cycle"))


def _order_note(g: dict) -> str:
    """What the observed order says of figure ``g``: "; observed order ..., above the formal
    ..." when held to the formal order, "; observed order ...: too slow to extrapolate" when
    below the slowest, else ""."""
    if g.get("order_capped"):
        return f"; observed order {g['p_observed']:.2f}, above the formal {g['p']:g}"
    if g["convergence"] == "too slow":
        return f"; observed order {g['p_observed']:.2f}: too slow to extrapolate"
    return ""


def _region_lines(regions: dict) -> list:
    """The regions' figures on meshes 1 / 2 / 3, each with its convergence and GCI."""
    lines = []
    for figure, heading in REGION_FIGURES:
        if regions.get(figure):
            lines.append(f"  {heading}, meshes 1 / 2 / 3:")
        for name, g in (regions.get(figure) or {}).items():
            if g.get("gci_fine_of_value") is not None:
                note = (f"p {g['p']:.2f}  GCI(mesh 1) {g['gci_fine_of_value']:.2%} "
                        f"({g['gci_fine_abs']:.1f} N){_order_note(g)}")
            elif g.get("band_abs") is not None:
                note = f"band +-{g['band_abs']:.1f} N (half the range)"
            elif g["convergence"] == "too slow":
                note = _order_note(g)[2:] + ", no GCI"
            elif g["convergence"] == "divergent":
                note = "the differences grow with the cells: no GCI"
            else:
                note = "no GCI"
            f1, f2, f3 = g["values"]
            lines.append(f"    {name:<10}{f1:>8.1f} /{f2:>7.1f} /{f3:>7.1f}  "
                         f"{g['convergence']:<11} {note}")
    return lines


def format_study(study: dict) -> str:
    """The short table printed at the end."""
    lines = []
    ms = study.get("meshes")
    rows = [(f"mesh-{k}", study["cases"].get(f"mesh-{k}/case")) for k in (1, 2, 3)]
    if any(r for _, r in rows):
        lines.append(f"{'mesh':<8}{'cells':>10}{'cell (m)':>10}{'drag (N)':>11}{'Fx (N)':>10}"
                     f"{'power (W)':>11}{'s/cycle':>9}")
        # with the meshes' analysis: Fx and power over the cycle it compared on every mesh
        figs = ms["figures"] if ms and ms.get("cycle_start_s") is not None else {}
        for k, (name, r) in enumerate(rows):
            if r:
                fx, power = (figs[key]["values"][k] if key in figs else r[key]
                             for key in ("swimming_fx", "swimming_power"))
                lines.append(f"{name:<8}{r['cells'] or 0:>10,}{r['background_cell_m']:>10.3g}"
                             f"{r['gliding_drag']:>11.1f}{fx:>10.1f}"
                             f"{power:>11.1f}{r['wall_s_per_cycle'] or 0:>9.0f}")
    if ms:
        lines.append(f"refinement ratios r21 {ms['r21']:.3f}, r32 {ms['r32']:.3f}"
                     + (f"; Fx and power over the cycle from {ms['cycle_start_s']:.2f} s on "
                        "every mesh" if ms.get("cycle_start_s") is not None else ""))
        for g in ms["figures"].values():
            used = g.get("reference") == "extrapolated"
            ext = f"{g['extrapolated']:.1f}" if used else "-"
            p = f"{g['p']:.2f}" if used and g["p"] is not None else "-"
            gf = "-" if g.get("gci_fine_of_scale") is None else f"{g['gci_fine_of_scale']:.2%}"
            band = g.get("band_mesh2_abs")
            note = ("" if band is None or used else
                    f"  band +-{band:.3g}{' (at least)' if g.get('band_is_lower_bound') else ''}")
            if g["convergence"] == "oscillatory" and g.get("gci_fine") is not None:
                # Celik et al.'s procedure takes p from |R| for an oscillating sequence
                note += f"; Celik's GCI from |R| {g['gci_fine']:.2%} (p {g['p']:.2f})"
            note += _order_note(g)
            lines.append(f"  {g['label']:<22} {g['convergence']:<11} p {p:>5}  extrapolated "
                         f"{ext:>9}  GCI(mesh 1) {gf}{note}")
    if ms and ms.get("regions"):
        lines += _region_lines(ms["regions"])
    ts = study.get("time_step")
    if ts:
        lines.append(f"time step {ts['delta_t_s'][0]:.4g} -> {ts['delta_t_s'][1]:.4g} s: drag "
                     f"{ts['gliding_drag_change']:.2%}, Fx {ts['swimming_fx_change_of_drag']:.2%}"
                     f" of drag, power {ts['swimming_power_change']:.2%}"
                     + (f" (the cycle from {ts['cycle_start_s']:.2f} s in both)"
                        if ts.get("cycle_start_s") is not None else ""))
    sp = study.get("self_propelled")
    if sp and sp.get("speed_m_s") is not None:
        unc = (f" +- {sp['speed_uncertainty_m_s']:.2g}" if sp.get("speed_uncertainty_m_s")
               is not None else "")
        cot = sp.get("cost_of_transport_J_kg_m")
        lines.append(f"self-propelled speed {sp['speed_m_s']:.3g}{unc} m/s ({sp['status']}, "
                     f"{sp['fit']}), power {sp['power_W']:.0f} W"
                     + (f", cost of transport {cot:.3g} J/(kg m)" if cot else ""))
    elif sp:
        lines.append(f"self-propelled speed: {sp.get('status')}")
    if study.get("not_finished"):
        lines.append("not finished: " + ", ".join(study["not_finished"]))
    return "\n".join(lines)


def write_study_report(out, study: dict, chart: Path | None = None) -> Path:
    """``<out>/report.html``: the study's table (:func:`format_study`), the accuracy-against-cost
    chart when it was drawn, one row per case and the versions used. Returns its path."""
    from adapter.foam.report import versions_section
    from adapter.reports.html_page import Section, write_page

    out = Path(out)
    problems = [f"{name}: failed: {why}" for name, why in (study.get("failed") or {}).items()]
    if study.get("not_finished"):
        problems.append("not finished: " + ", ".join(study["not_finished"])
                        + " (run the same command again to continue)")
    rows = []
    for name, case in study.get("cases", {}).items():
        cells = [name]
        for _, key, fmt in _CASE_COLUMNS:
            value = (case or {}).get(key)
            cells.append("" if value is None else fmt.format(value) if not isinstance(
                value, bool) else ("yes" if value else "no"))
        rows.append(tuple(cells))
    sections = [
        Section("The flow study", warning="; ".join(problems),
                text=("Three meshes refined by one ratio (Richardson extrapolation and the GCI "
                      "of gliding drag, mean swimming Fx and mean power, and of each region's "
                      "gliding drag and mean Fx), mesh 2 with the flow "
                      "step halved, and mesh 2 at other speeds (the self-propelled speed). A "
                      "negative mean Fx is net thrust."),
                pre=format_study(study)),
        Section("Cases", header=("case", *(h for h, _, _ in _CASE_COLUMNS)), rows=tuple(rows)),
    ]
    if chart is not None and Path(chart).is_file():
        sections.append(Section("Accuracy against cost", images=((
            "each figure's difference from its extrapolated value (% of its scale) against "
            "the wall time per swimming stroke cycle of each mesh", Path(chart)),)))
    sections.append(versions_section())
    subtitle = (f"{out.resolve()} · scene {study.get('scene')} · ratio {study.get('ratio')} · "
                f"written {datetime.now(timezone.utc).strftime('%Y-%m-%d %H:%M UTC')} by "
                "whale-adapter study · every figure: study.json; each case's own report.html "
                "is in its folder")
    return write_page(out / REPORT, f"whale-adapter flow study: {out.name}", subtitle, sections)
