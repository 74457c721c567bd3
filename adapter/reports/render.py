"""Pictures of the dry-run: the key-point traces (matplotlib) and the frames (pyvista).

Both draw off screen: no display is needed (pyvista falls back to EGL or OSMesa).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np


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
                             smooth_shading=True)
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


def plot_forces(swim: dict, glide: dict, period: float, start_up: float, path: Path) -> None:
    """forces.png: Fx, Fz and power of the swimming whale against time (loads.dat columns),
    the gliding drag beside them, stroke cycles marked and the discarded start-up greyed."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = swim["Time"]
    measured = t > start_up
    fig, axes = plt.subplots(3, 1, figsize=(9, 7.5), dpi=110, sharex=True)
    rows = (("total:Fx", "Fx (N)"), ("total:Fz", "Fz (N)"), ("total:P", "power into water (W)"))
    for ax, (key, label) in zip(axes, rows, strict=True):
        ax.plot(t, swim[key], lw=1.2, color="C0", label="swimming")
        if glide and key != "total:P":
            ax.plot(glide["Time"], glide[key], lw=1.0, color="C1", ls="--", label="gliding")
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
    axes[0].legend(loc="upper right", fontsize=8)
    axes[0].set_title("Loads on the whale (grey: start-up, discarded and off scale; lines: "
                      "stroke cycles)", fontsize=10)
    axes[-1].set_xlabel("time (s)")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
