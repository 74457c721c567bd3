"""Pictures of the dry-run: the key-point traces (matplotlib) and the frames (pyvista); the
coupled case's forces.png (matplotlib).

Both draw off screen: no display is needed (pyvista falls back to EGL or OSMesa).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from pyvista.plotting._typing import ScalarBarArgs


def plot_keypoints(kp: np.ndarray, names, period: float, path: Path) -> None:
    """The vertical displacement of each key point against time, as in the paper's Figure 1."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(9, 4.2), dpi=110)
    for k, name in enumerate(names):
        ax.plot(kp[:, 0], kp[:, k + 1], label=name.replace("_", " "), lw=1.6)
    for c in np.arange(0, kp[-1, 0] + 1e-9, period / 4):
        ax.axvline(c, color="0.85", lw=0.8, zorder=0)
    ax.axhline(0, color="0.6", lw=0.8)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("vertical displacement (m)")
    ax.set_title("Key points through the stroke (grey lines: quarter strokes)")
    ax.legend(loc="upper right", ncol=4, fontsize=8)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


#: the colour bar of frames.png (in its viewport's coordinates): the tick labels at a fixed
#: size and two decimals; its title is drawn as a text above the bar's box (render_frames)
_BAR: ScalarBarArgs = {
    "title": "displacement (m)", "vertical": False, "position_x": 0.08, "position_y": 0.03,
    "width": 0.84, "height": 0.14, "label_font_size": 13, "n_labels": 4, "fmt": "%.2f"}


def render_frames(surf, states: dict, path: Path, size=(1800, 820)) -> None:
    """Side and angled views of the whale at each labelled state, one column per state."""
    import pyvista as pv

    pv.OFF_SCREEN = True
    labels = list(states)
    plotter = pv.Plotter(shape=(2, len(labels)), window_size=size, off_screen=True)
    flat = np.concatenate(
        [np.column_stack([np.full(len(f), f.shape[1]), f]).ravel() for f in surf.faces]
    )
    L = surf.length
    centre = surf.points.mean(axis=0)
    for col, label in enumerate(labels):
        X = states[label]
        d = np.linalg.norm(X - surf.points, axis=1)
        mesh = pv.PolyData(X, flat)
        mesh.point_data["displacement (m)"] = d
        for row, view in enumerate(("side", "angled")):
            plotter.subplot(row, col)
            plotter.add_mesh(mesh.copy(), scalars="displacement (m)", cmap="viridis",
                             clim=(0, 0.12 * L), show_scalar_bar=(row == 1 and col == 0),
                             scalar_bar_args=_BAR, smooth_shading=True)
            if row == 1 and col == 0:
                # VTK's horizontal bar draws its title on the tick labels, whatever its
                # height and separation: the title is a text of its own, above the bar's box
                plotter.scalar_bars[_BAR["title"]].SetTitle("")
                plotter.add_text(_BAR["title"], position=(
                    _BAR["position_x"], _BAR["position_y"] + _BAR["height"] + 0.01),
                    viewport=True, font_size=9)
            plotter.add_text(f"{label} ({view})", font_size=9)
            if view == "side":
                plotter.camera_position = [
                    (centre[0], centre[1] - 2.2 * L, centre[2]), tuple(centre), (0, 0, 1)]
            else:
                plotter.camera_position = [
                    (centre[0] - 1.1 * L, centre[1] - 1.3 * L, centre[2] + 0.9 * L),
                    tuple(centre), (0, 0, 1)]
    plotter.screenshot(str(path))
    plotter.close()


def forces_headline(figures: dict) -> str:
    """forces.png's headline: gliding drag, mean Fx (negative: net thrust), mean power and
    Froude efficiency from the ``swimming_cost`` figures (N, W); a figure not there is left out.
    """
    parts = []
    fx = figures.get("swimming_mean_fx_N")
    for key, text in (("gliding_drag_N", "gliding drag {:,.0f} N"),
                      ("swimming_mean_fx_N", "swimming mean Fx {:,.0f} N (net "
                       + ("thrust)" if fx is not None and fx < 0 else "drag)")),
                      ("swimming_mean_power_W", "mean power {:,.0f} W"),
                      ("froude_efficiency", "Froude efficiency {:.2f}")):
        if figures.get(key) is not None:
            parts.append(text.format(figures[key]))
    return "   ".join(parts)


def forces_figure(swim: dict, glide: dict, period: float, start_up: float,
                  figures: dict | None = None):
    """The matplotlib figure of forces.png: Fx, Fz and power of the swimming whale against time
    (loads.dat columns), the gliding drag beside them, stroke cycles marked, the discarded
    start-up greyed; with ``figures`` (``swimming_cost`` of adapter-summary.json) the cycle
    means of Fx and power as a black segment over each cycle, the gliding drag as a level line
    and the headline numbers (:func:`forces_headline`) above."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figures = figures or {}
    means = figures.get("cycle_means") or {}
    t = swim["Time"]
    measured = t > start_up
    fig, axes = plt.subplots(3, 1, figsize=(9, 8), dpi=110, sharex=True)
    rows = (("total:Fx", "Fx (N)\nnegative: net thrust", "fx_N"), ("total:Fz", "Fz (N)", None),
            ("total:P", "power into water (W)", "power_W"))
    for ax, (key, label, mean_key) in zip(axes, rows, strict=True):
        ax.plot(t, swim[key], lw=1.2, color="C0", label="swimming")
        if glide and key != "total:P":
            ax.plot(glide["Time"], glide[key], lw=1.0, color="C1", ls="--", label="gliding")
        if mean_key and means.get(mean_key):
            for k, (a, m) in enumerate(zip(means["start_s"], means[mean_key], strict=True)):
                ax.plot([a, a + period], [m, m], color="k", lw=2.2,
                        label="cycle mean" if k == 0 else None)
            unit = "N" if mean_key == "fx_N" else "W"
            ax.annotate(f"last cycle mean {means[mean_key][-1]:,.0f} {unit}",
                        (means["start_s"][-1] + period, means[mean_key][-1]),
                        xytext=(-4, 5), textcoords="offset points", ha="right", fontsize=8)
        if key == "total:Fx" and figures.get("gliding_drag_N") is not None:
            ax.axhline(figures["gliding_drag_N"], color="C1", lw=1.0, ls=":",
                       label=f"gliding drag {figures['gliding_drag_N']:,.0f} N")
        ax.axvspan(0, start_up, color="0.88", zorder=0)
        for c in np.arange(start_up, t[-1] + 1e-9, period):
            ax.axvline(c, color="0.6", lw=0.8, zorder=0)
        ax.axhline(0, color="0.7", lw=0.6)
        ax.set_ylabel(label)
        if measured.any():
            # scaled to the measured cycles: the start-up (the inflow's ramp) may run off it
            lo, hi = float(swim[key][measured].min()), float(swim[key][measured].max())
            if glide and key != "total:P":
                lo, hi = min(lo, float(glide[key][-1])), max(hi, float(glide[key][-1]))
            pad = 0.15 * max(hi - lo, 1e-9)
            ax.set_ylim(min(lo - pad, 0.0) if key == "total:P" else lo - pad, hi + pad)
    axes[0].legend(loc="upper right", fontsize=8, ncol=2)
    axes[2].legend(loc="upper right", fontsize=8)
    title = ("Loads on the whale (grey: start-up, discarded and off scale; lines: stroke "
             "cycles)")
    headline = forces_headline(figures)
    axes[0].set_title(title + ("\n" + headline if headline else ""), fontsize=10)
    axes[-1].set_xlabel("time (s)")
    fig.tight_layout()
    return fig


def plot_forces(swim: dict, glide: dict, period: float, start_up: float, path: Path,
                figures: dict | None = None) -> None:
    """forces.png (:func:`forces_figure`)."""
    import matplotlib.pyplot as plt

    fig = forces_figure(swim, glide, period, start_up, figures)
    fig.savefig(path)
    plt.close(fig)


def free_figure(frame: dict, loads: dict, period: float, figures: dict):
    """free.png: the free whale's forward speed (the frame log's Ux) and Fx against time, the
    stretch before the measured cycles greyed (the approach and the running mean's first
    period), the stroke cycles measured, and U_sp with the last cycle's means."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (top, low) = plt.subplots(2, 1, figsize=(9, 5.5), dpi=110, sharex=True)
    t = frame["Time"]
    measured = figures.get("measured_from_s", figures["release_s"])
    top.plot(t, frame["Ux"], color="C0", lw=1.2, label="forward speed U (the inflow)")
    low.plot(loads["Time"], loads["total:Fx"], color="C0", lw=1.0, label="Fx")
    start, end = figures["window_s"]
    top.plot([start, end], [figures["speed_m_s"]] * 2, color="k", lw=2.2,
             label=f"U_sp {figures['speed_m_s']:.3f} m/s (last cycle)")
    low.plot([start, end], [figures["mean_fx_N"]] * 2, color="k", lw=2.2,
             label=f"last cycle mean {figures['mean_fx_N']:+.1f} N")
    for ax in (top, low):
        ax.axvspan(t[0], measured, color="0.88", zorder=0)
        for c in np.arange(measured, t[-1] + 1e-9, period):
            ax.axvline(c, color="0.6", lw=0.8, zorder=0)
        ax.legend(loc="lower right", fontsize=8)
    low.axhline(0, color="0.7", lw=0.6)
    top.set_ylabel("U (m/s)")
    low.set_ylabel("Fx (N)")
    low.set_xlabel("time (s); grey, not measured: the approach and the running mean's first "
                   "period; lines: the cycles measured")
    top.set_title(f"the free whale: U_sp {figures['speed_m_s']:.3f} m/s, "
                  f"{figures['mean_power_W']:,.0f} W, QPC "
                  f"{figures['quasi_propulsive_efficiency']:.2f}", fontsize=10)
    fig.tight_layout()
    return fig


def plot_free(frame: dict, loads: dict, period: float, figures: dict, path: Path) -> None:
    """free.png (:func:`free_figure`)."""
    import matplotlib.pyplot as plt

    fig = free_figure(frame, loads, period, figures)
    fig.savefig(path)
    plt.close(fig)
