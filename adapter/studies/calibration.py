"""Calibration: the velocity scale that gives the target fluke-tip amplitude.

In the paper's method the stroke's timing is set by the schedule: velocities are negated at
the top and bottom, a quarter period T / 4 after each start, so the tail-beat frequency is
met by construction (the dry-run measures it back from the traces). What is left to fit is
the amplitude: :func:`calibrate` solves ``stroke.velocity_scale`` by the secant method so
that the fluke tips' peak-to-peak amplitude over a full cycle (after the start-up cycle)
matches ``calibration.fluke_amplitude * L``.

The spring stiffness scale is reported, not fitted: with the paper's edge-only quad network
a vertical translation of one ring against the next is a zero-energy (shear) motion, so the
springs hardly slow the stroke and cannot set its timing; raising the stiffness by 16 changes
the amplitude by about 14 % and divides the stable step by 16 (docs/stroke.md).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from adapter.errors import AdapterError
from adapter.jsonfiles import write_json
from adapter.options import in_file, out_file


def fluke_amplitude(scene, cycles: int = 2) -> dict:
    """Dry-run ``cycles`` cycles without writing files; the summary (last cycle measured)."""
    from adapter.motion.dryrun import run

    return run(scene, Path("."), cycles=cycles, progress=False, write_files=False)


def calibrate(scene, max_iter: int = 8, log=print) -> tuple[object, dict]:
    """Solve ``stroke.velocity_scale`` for the amplitude target; (calibrated scene, report)."""
    target = scene.calibration.fluke_amplitude * _length(scene)
    tol = scene.calibration.tolerance
    x0 = scene.stroke.velocity_scale
    history = []

    def amplitude(x):
        s = fluke_amplitude(scene.replace(stroke={"velocity_scale": x}))
        a = s["peak_to_peak_m"]["fluke_tip"]
        history.append({"velocity_scale": x, "fluke_tip_m": a})
        log(f"  velocity_scale {x:.5f}: fluke tip {a:.4f} m peak to peak (target {target:.4f})")
        return a, s

    a0, summary = amplitude(x0)
    x1 = x0 * target / a0  # amplitude is near proportional to the initial velocities
    for _ in range(max_iter):
        a1, summary = amplitude(x1)
        if abs(a1 / target - 1) <= tol:
            break
        slope = (a1 - a0) / (x1 - x0) if x1 != x0 else a1 / x1
        if slope <= 0:
            raise AdapterError("the fluke amplitude does not grow with the velocity scale; "
                               "check the stroke profile parameters")
        x0, a0, x1 = x1, a1, x1 + (target - a1) / slope
    else:
        raise AdapterError(f"calibration did not reach {tol:.1%} in {max_iter} iterations")
    report = {
        "velocity_scale": x1,
        "stiffness_scale": scene.springs.stiffness_scale,
        "target_fluke_tip_m": target,
        "achieved_fluke_tip_m": a1,
        "target_frequency_hz": scene.stroke.frequency_hz,
        "measured_frequency_hz": 1.0 / summary["measured_period_s"],
        "iterations": history,
    }
    return scene.replace(stroke={"velocity_scale": x1}), report


def _length(scene) -> float:
    from adapter.body.geometry import build_surface

    if scene.geometry.source == "procedural":
        return scene.geometry.length_m
    return build_surface(scene).length


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "calibrate", help="fit the velocity scale to the target amplitude",
        description="Solve stroke.velocity_scale (secant method) so that the fluke tips' "
        "peak-to-peak amplitude over a stroke cycle, after the start-up cycle, matches "
        "calibration.fluke_amplitude * L; prints the value to put in the scene file "
        "(docs/stroke.md).")
    p.add_argument("--scene", type=in_file, help="scene TOML file (default: built-in default)")
    p.add_argument("--preset", help="built-in preset: default, smoke, fine")
    p.add_argument("--report", "--out", dest="report", type=out_file,
                   help="write the calibration report (JSON) here (--out: the same)")
    p.set_defaults(func=_cmd_calibrate)


def _cmd_calibrate(args: argparse.Namespace) -> int:
    from adapter.scene import load_scene

    scene = load_scene(args.scene, preset=args.preset)
    print(f"calibrating {scene.name}: fluke tip {scene.calibration.fluke_amplitude:g} L peak to "
          f"peak at {scene.stroke.frequency_hz:g} Hz")
    _, report = calibrate(scene)
    print(f"achieved {report['achieved_fluke_tip_m']:.4f} m (target "
          f"{report['target_fluke_tip_m']:.4f} m), measured frequency "
          f"{report['measured_frequency_hz']:.4f} Hz (target {report['target_frequency_hz']:g})")
    print("put this in the scene file:\n\n[stroke]\n"
          f"velocity_scale = {report['velocity_scale']:.5f}\n")
    if args.report:
        write_json(args.report, report)
    return 0
