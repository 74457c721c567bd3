"""The dry-run: animate the whale without fluid and without OpenFOAM, and write what it did.

``whale-adapter dry-run --out DIR`` writes into DIR:

- ``whale.pvd`` and one ``whale_NNNN.vtp`` per frame (displacement and velocity as point data);
- ``keypoints.csv``: ``t,rostrum,flipper,tail_base,fluke_tip``, the vertical displacement (m)
  of each key point (flipper and fluke tip: the mean of the left and right tips);
- ``summary.json``: counts, period, amplitudes, phases, closure error, volume change,
  momentum, steps, wall time (see :func:`summarise`);
- ``keypoints.png`` and ``frames.png`` (side and angled views, like the paper's Figures 2-5).

Everything is computed in one forward march of the animator: no step is stored.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from adapter import vtkfiles
from adapter.body.springs import momentum_rate
from adapter.jsonfiles import write_json
from adapter.motion.animator import Animator
from adapter.options import count, in_file, out_folder

KEYPOINTS = ("rostrum", "flipper", "tail_base", "fluke_tip")
#: bins along the body for the amplitude envelope (amplitude_min_at)
ENVELOPE_BINS = 60


def keypoint_nodes(landmarks: dict) -> dict:
    """Key point -> node indices whose mean vertical displacement is the key point's."""
    return {
        "rostrum": [landmarks["rostrum"]],
        "flipper": [landmarks["flipper_left"], landmarks["flipper_right"]],
        "tail_base": [landmarks["tail_base"]],
        "fluke_tip": [landmarks["fluke_tip_left"], landmarks["fluke_tip_right"]],
    }


def figure_times(period: float, cycles: int) -> dict:
    """The paper's Figures 2-5 in the last cycle: equilibrium, top of upstroke, mid
    downstroke (tail back at equilibrium), bottom of downstroke."""
    c = (cycles - 1) * period
    return {"equilibrium": c, "top of upstroke": c + period / 4,
            "mid downstroke": c + period / 2, "bottom of downstroke": c + 3 * period / 4}


def _fundamental_phase(t: np.ndarray, y: np.ndarray, period: float) -> tuple[float, float]:
    """(amplitude, phase in rad) of the stroke-frequency component of y(t) over whole cycles."""
    w = 2 * np.pi / period
    c = np.trapezoid(y * np.exp(-1j * w * t), t) * 2 / (t[-1] - t[0])
    return float(np.abs(c)), float(np.angle(c))


def _measured_period(t: np.ndarray, y: np.ndarray) -> float:
    """Twice the mean interval between zero crossings of y - mean(y) (NaN with fewer than two)."""
    y = y - y.mean()
    k = np.flatnonzero(np.sign(y[:-1]) * np.sign(y[1:]) < 0)
    if len(k) < 2:
        return float("nan")
    tc = t[k] - y[k] * (t[k + 1] - t[k]) / (y[k + 1] - y[k])
    return float(2 * np.diff(tc).mean())


def run(scene, out: Path, cycles: int | None = None, progress: bool = True,
        animator: Animator | None = None, write_files: bool = True) -> dict:
    """Animate ``cycles`` stroke cycles, write the dry-run files into ``out``; the summary."""
    t_wall = time.perf_counter()
    a = animator if animator is not None else Animator(scene)
    cycles = cycles or scene.output.cycles
    surf, period = a.surface, a.period
    end = cycles * period
    samples = np.linspace(0.0, end, cycles * scene.output.samples_per_cycle + 1)
    n_frames = cycles * scene.output.frames_per_cycle
    frames = np.linspace(0.0, end, n_frames + 1)
    figs = figure_times(period, cycles)
    cycle_ends = period * np.arange(1, cycles + 1)
    times = np.unique(np.concatenate([samples, frames, list(figs.values()), cycle_ends]))

    kp_nodes = keypoint_nodes(surf.landmarks)
    s = surf.s
    body = a.dynamic & _midline_nodes(surf)
    bins = np.linspace(s[body].min(), s[body].max(), ENVELOPE_BINS + 1)
    which = np.clip(np.digitize(s[body], bins) - 1, 0, ENVELOPE_BINS - 1)
    counts = np.bincount(which, minlength=ENVELOPE_BINS)
    body_idx = np.flatnonzero(body)

    volume0 = surf.volume()
    kp_rows, env_rows, vol, mom_rate, closure, rest_offset, aoa = [], [], [], [], [], [], []
    last_cycle_end = surf.points
    frame_files, fig_states = [], {}
    if write_files:
        out.mkdir(parents=True, exist_ok=True)
    bar = _progress(len(times), progress)
    sample_set = set(np.round(samples, 12))
    frame_index = {round(float(t), 12): k for k, t in enumerate(frames)}
    for t in times:
        X = a.positions(t)
        d = X - surf.points
        key = round(float(t), 12)
        if key in sample_set:
            kp_rows.append([t] + [float(d[kp_nodes[k], 2].mean()) for k in KEYPOINTS])
            env_rows.append(np.bincount(which, weights=d[body_idx, 2], minlength=ENVELOPE_BINS)
                            / np.maximum(counts, 1))
            vol.append(surf.volume(X))
            V = a.velocity(t)
            mom_rate.append(np.linalg.norm(momentum_rate(a.network, X, V)))
            aoa.append(fluke_angle_of_attack(a, t, scene.flow.speed_m_s))
        if write_files and key in frame_index:
            name = f"whale_{frame_index[key]:04d}.vtp"
            surf_write(surf, out / name, X, d, a.velocity(t))
            frame_files.append((float(t), name))
        for label, tf in figs.items():
            if abs(tf - t) < 1e-12:
                fig_states[label] = X
        if any(abs(te - t) < 1e-12 for te in cycle_ends):
            # closure: how far every node is from where it was one cycle before; the offset
            # from rest of the body (the fluke, pitched at phase 0 by design, rides on it)
            closure.append(float(np.linalg.norm(X - last_cycle_end, axis=1).max()))
            rest_offset.append(float(np.linalg.norm(d[a.dynamic], axis=1).max()))
            last_cycle_end = X
        bar.update(1)
    bar.close()

    kp = np.array(kp_rows)
    env = np.array(env_rows)
    summary = summarise(scene, a, kp, env, bins, np.array(vol), volume0, np.array(mom_rate),
                        closure, time.perf_counter() - t_wall)
    summary.update(stroke_figures(a, kp, np.array(aoa), summary["start_s"]))
    summary["rest_offset_m"] = rest_offset
    if write_files:
        vtkfiles.write_pvd(out / "whale.pvd", frame_files)
        header = "t," + ",".join(KEYPOINTS)
        np.savetxt(out / "keypoints.csv", kp, delimiter=",", header=header, comments="",
                   fmt="%.9g")
        write_json(out / "summary.json", summary)
        from adapter.reports.render import plot_keypoints, render_frames

        plot_keypoints(kp, KEYPOINTS, period, out / "keypoints.png")
        render_frames(surf, fig_states, out / "frames.png")
    return summary


def summarise(scene, a, kp, env, bins, vol, volume0, mom_rate, closure, wall) -> dict:
    """The summary.json figures from the sampled traces.

    ``phase_deg`` is the phase of each key point's stroke-frequency component relative to
    the fluke tip's (positive: leads). ``amplitude_min_at`` is the centre of the bin along the
    body's midline (fluke and flippers left out) whose mean vertical displacement varies least.
    """
    t = kp[:, 0]
    period = a.period
    # whole cycles only, starting after the fluke's start-up ramp
    start = np.ceil(a.ramp_s / period - 1e-9) * period if t[-1] - period >= 0 else 0.0
    if t[-1] - start < period - 1e-9:
        start = 0.0
    sel = t >= start - 1e-9
    ptp, phase = {}, {}
    comps = {}
    for k, name in enumerate(KEYPOINTS):
        y = kp[sel, k + 1]
        ptp[name] = float(np.ptp(y))
        comps[name] = _fundamental_phase(t[sel], y, period)
    ref = comps["fluke_tip"][1]
    for name in KEYPOINTS:
        ph = np.degrees(comps[name][1] - ref)
        phase[name] = float((ph + 180.0) % 360.0 - 180.0)
    env_ptp = np.ptp(env[sel], axis=0)
    env_ptp[np.all(env[sel] == 0, axis=0)] = np.nan  # bins without midline nodes
    centres = 0.5 * (bins[1:] + bins[:-1])
    L = a.surface.length
    target_ptp = scene.calibration.fluke_amplitude * L
    return {
        "scene": scene.name,
        "nodes": int(a.surface.n_nodes),
        "edges": int(len(a.network.i)),
        "integrator": scene.integrator.method,
        "dt_s": a.dt,
        "stable_dt_s": a.stable_dt,
        "period_s": float(period),
        "measured_period_s": _measured_period(t[sel], kp[sel, KEYPOINTS.index("tail_base") + 1]),
        "cycles": int(round(t[-1] / period)),
        "peak_to_peak_m": ptp,
        "phase_deg": phase,
        "amplitude_min_at": float(centres[np.nanargmin(env_ptp)]),
        "fluke_tip_target_m": target_ptp,
        "fluke_tip_error": ptp["fluke_tip"] / target_ptp - 1.0,
        "start_s": float(start),
        "closure_error_m": float(closure[-1]) if closure else float("nan"),
        "closure_error_per_cycle_m": closure,
        "volume_change": float(np.abs(vol / volume0 - 1.0).max()),
        "spring_form": scene.springs.form,
        "momentum_rate_max": float(mom_rate.max()),
        "steps": int(a.step_index),
        "wall_s": float(wall),
    }


def fluke_angle_of_attack(a: Animator, t: float, speed: float) -> float:
    """Effective angle of attack of the flukes (deg) at t: the gate's pitch plus the angle of
    the water's velocity relative to the hinge, ``theta + atan(w_hinge / U)`` (the usual
    definition for a heaving and pitching foil, taken at its pitch axis; positive: the water
    meets the fluke's lower side)."""
    theta = a.fluke_angle(t)[0]
    w = float(a.hinge_velocity(t)[2])
    return float(np.degrees(theta + np.arctan2(w, speed)))


def stroke_figures(a: Animator, kp: np.ndarray, aoa: np.ndarray, start: float) -> dict:
    """Symmetry of the stroke and the flukes' angle of attack over the measured cycles."""
    t = kp[:, 0]
    sel = t >= start - 1e-9
    tail = kp[sel, KEYPOINTS.index("tail_base") + 1]
    up, down = float(tail.max()), float(-tail.min())
    a_sel = aoa[sel]
    return {
        "stroke_reversal": a.reversal,
        "tail_base_up_m": up,
        "tail_base_down_m": down,
        "stroke_asymmetry": abs(up / down - 1.0) if down > 0 else float("nan"),
        "fluke_aoa_deg": {"max_abs": float(np.abs(a_sel).max()),
                          "at_top": float(a_sel[np.argmax(tail)]),
                          "at_bottom": float(a_sel[np.argmin(tail)])},
    }


def _midline_nodes(surf, width: float = 0.02) -> np.ndarray:
    """Nodes on the sagittal plane (dorsal and ventral midlines): the body's axis, without
    the flippers and flukes that stick out sideways."""
    return np.abs(surf.points[:, 1] - surf.origin[1]) < width * surf.length


def surf_write(surf, path: Path, X: np.ndarray, d: np.ndarray, v: np.ndarray) -> None:
    """One frame: the deformed surface with displacement and velocity as point data."""
    vtkfiles.write_vtp(path, X, surf.faces, point_data={"displacement": d, "velocity": v})


def _progress(total: int, enabled: bool):
    from tqdm import tqdm

    return tqdm(total=total, desc="dry-run", unit="sample", disable=not enabled, leave=False)


def register(subparsers) -> None:
    p = subparsers.add_parser("dry-run",
                              help="animate the whale without fluid; write VTP, CSV, PNG",
                              description="Animate the spring-mass whale without fluid (no "
                              "OpenFOAM needed) and write whale.pvd (a .vtp surface per frame), "
                              "keypoints.csv, summary.json, keypoints.png and frames.png into "
                              "--out (docs/dry-run.md).")
    p.add_argument("--scene", type=in_file, help="scene TOML file (default: built-in default)")
    p.add_argument("--preset", help="built-in preset: default, smoke, fine")
    p.add_argument("--cycles", type=count, help="stroke cycles (default: scene output.cycles)")
    p.add_argument("--out", required=True, type=out_folder, help="output folder")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--quiet", "-q", action="store_true",
                   help="no progress and no report on stdout, only warnings and errors on stderr")
    p.set_defaults(func=_cmd_dry_run)


def _cmd_dry_run(args: argparse.Namespace) -> int:
    from adapter.scene import load_scene

    scene = load_scene(args.scene, preset=args.preset)
    summary = run(scene, Path(args.out), cycles=args.cycles,
                  progress=not (args.no_progress or args.quiet))
    ptp, ph = summary["peak_to_peak_m"], summary["phase_deg"]
    print(f"dry-run {summary['scene']}: {summary['nodes']} nodes, {summary['edges']} edges, "
          f"{summary['steps']} steps of {summary['dt_s']:.3g} s in {summary['wall_s']:.1f} s")
    print(f"  period {summary['period_s']:.3f} s; fluke tip {ptp['fluke_tip']:.3f} m peak to "
          f"peak (target {summary['fluke_tip_target_m']:.3f} m)")
    print("  phase vs fluke tip: " + ", ".join(f"{k} {v:+.0f} deg" for k, v in ph.items()))
    print(f"  smallest amplitude at {summary['amplitude_min_at']:.2f} L; closure error "
          f"{summary['closure_error_m']:.3g} m; volume change {summary['volume_change']:.2%}")
    aoa = summary["fluke_aoa_deg"]
    print(f"  stroke ({summary['stroke_reversal']}): tail base up "
          f"{summary['tail_base_up_m']:.3f} m, down {summary['tail_base_down_m']:.3f} m; "
          "fluke angle of attack: largest "
          f"{aoa['max_abs']:.1f} deg, {aoa['at_top']:+.1f} at the top, {aoa['at_bottom']:+.1f} "
          "at the bottom")
    print(f"  wrote {args.out}/whale.pvd, keypoints.csv, summary.json, keypoints.png, frames.png")
    return 0
