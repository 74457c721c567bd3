"""ParaView pictures of a coupled case or of a dry-run (run by pvbatch, not by the venv's Python).

Started by ``whale-adapter paraview`` (:mod:`adapter.reports.paraview_report`) as::

    xvfb-run -a pvbatch adapter/reports/pvscripts/report.py --input DIR --out OUT --kind case \
        --times 0.19 0.38 [--case-type Reconstructed] [--size 1600 900] [--no-animation]

``--kind case``: ParaView's OpenFOAM reader on ``DIR/case.foam`` (regions internalMesh and
patch/whale); the whale patch coloured by p (in Pa, rho p, with ``--rho``; else kinematic, m2/s2),
a slice at the mid-plane y = 0 coloured by |U|, and the adapter's ``DIR/adapter/whale.pvd`` as a
thin, faint wireframe over the patch (when present).
``--kind surface``: ``DIR/whale.pvd`` alone (a dry-run), coloured by |displacement|.

Writes into OUT: ``side_t<t>.png`` and ``angled_t<t>.png`` at each ``--times`` value (the
paper's Figures 2-5 views), ``animation/frame.NNNN.png`` (the side view at every data time),
``whale.pvsm`` (a state file for the ParaView GUI; ParaView writes its data paths absolute,
the driver rewrites them relative to OUT) and ``report.json``
(every picture with its time and camera, the colour ranges, stage timings). Colour ranges are
fixed, so pictures at different times compare: |U| and the displacement over all data times,
the whale's pressure over the pictures' times (the last stroke cycle: the start-up's
accelerating inflow lifts the whole patch's pressure, by 40 kPa on the default case, which
would leave every picture of the periodic state one colour; the animation's start-up frames
then saturate; report.json keeps the range over all times as ``data_range``). Every progress
line starts with ``report:`` and is flushed at once.
"""

import argparse
import json
import math
import os
import sys
import time

from ogg_video import write_video  # beside this script (pvbatch puts its folder on sys.path)
from paraview import simple as pvs

#: camera directions (from the focal point towards the camera) in whale lengths, as the dry-run's
#: frames.png (adapter/reports/render.py) but closer: side from -y, angled from ahead, left and
#: above
VIEWS = {
    "side": ((0.0, -2.2, 0.0), True),
    "angled": ((-0.8, -0.95, 0.65), False),
}
ANIMATION_VIEW = "side"
VIEW_ANGLE_DEG = 30.0
BLACK = [0.0, 0.0, 0.0]
WHITE = [1.0, 1.0, 1.0]


def say(msg):
    print(f"report: {msg}", flush=True)


def parse_args(argv):
    p = argparse.ArgumentParser(prog="report.py")
    p.add_argument("--input", required=True)
    p.add_argument("--out", required=True)
    p.add_argument("--kind", choices=("case", "surface"), required=True)
    p.add_argument("--times", type=float, nargs="+", required=True)
    p.add_argument("--case-type", default="Reconstructed",
                   choices=("Reconstructed", "Decomposed"))
    p.add_argument("--size", type=int, nargs=2, default=(1600, 900), metavar=("W", "H"))
    p.add_argument("--no-animation", action="store_true")
    p.add_argument("--fps", type=int, default=10, help="video frame rate")
    p.add_argument("--rho", type=float, default=None,
                   help="water density (kg/m3): p is drawn in Pa (rho p); without it kinematic")
    return p.parse_args(argv)


def union_bounds(source, times):
    """The bounding box (xmin, xmax, ymin, ymax, zmin, zmax) of ``source`` over ``times``."""
    b = [math.inf, -math.inf] * 3
    for t in times:
        source.UpdatePipeline(t)
        bt = source.GetDataInformation().GetBounds()
        for k in range(3):
            b[2 * k] = min(b[2 * k], bt[2 * k])
            b[2 * k + 1] = max(b[2 * k + 1], bt[2 * k + 1])
    return b


def array_range(source, assoc, name, component, times):
    """(min, max) of one array over ``times``; component -1 is the magnitude."""
    lo, hi = math.inf, -math.inf
    for t in times:
        source.UpdatePipeline(t)
        arrays = source.PointData if assoc == "POINTS" else source.CellData
        if name not in arrays.keys():
            continue
        r = arrays[name].GetRange(component)
        lo, hi = min(lo, r[0]), max(hi, r[1])
    if not math.isfinite(lo):
        raise SystemExit(f"report: error: no array {name!r} on {assoc} at any time")
    return lo, hi


def colour_by(display, view, name, component, rng, preset, title):
    pvs.ColorBy(display, ("POINTS", name, component))
    lut = pvs.GetColorTransferFunction(name)
    lut.ApplyPreset(preset, True)
    lut.RescaleTransferFunction(rng[0], rng[1])
    lut.AutomaticRescaleRangeMode = "Never"
    if component == "Magnitude":
        lut.VectorMode = "Magnitude"
    pvs.GetOpacityTransferFunction(name).RescaleTransferFunction(rng[0], rng[1])
    display.SetScalarBarVisibility(view, True)
    bar = pvs.GetScalarBar(lut, view)
    bar.Title = title
    bar.ComponentTitle = ""
    bar.TitleColor = BLACK
    bar.LabelColor = BLACK
    bar.TitleFontSize = 14
    bar.LabelFontSize = 12
    bar.ScalarBarLength = 0.3
    bar.RangeLabelFormat = "%-#.3g"
    return bar


def camera_for(view_name, bounds, size):
    """Camera (position, focal point, view up, parallel?, parallel scale) framing ``bounds``."""
    direction, parallel = VIEWS[view_name]
    c = [0.5 * (bounds[2 * k] + bounds[2 * k + 1]) for k in range(3)]
    ext = [bounds[2 * k + 1] - bounds[2 * k] for k in range(3)]
    length = max(ext)
    pos = [c[k] + direction[k] * length for k in range(3)]
    aspect = size[0] / size[1]
    # parallel scale: half the visible height; the whale's x extent and z extent with a margin
    scale = max(0.5 * ext[2] * 1.6, 0.5 * ext[0] / aspect * 1.15)
    # view up: +z made orthogonal to the viewing direction
    d = [-x for x in direction]
    dn = math.sqrt(sum(x * x for x in d))
    d = [x / dn for x in d]
    up = [0.0 - d[2] * d[k] for k in range(2)] + [1.0 - d[2] * d[2]]
    un = math.sqrt(sum(x * x for x in up))
    return {"position": pos, "focal_point": c, "view_up": [x / un for x in up],
            "parallel_projection": parallel, "parallel_scale": scale,
            "view_angle": VIEW_ANGLE_DEG}


def set_camera(view, cam):
    view.CameraPosition = cam["position"]
    view.CameraFocalPoint = cam["focal_point"]
    view.CameraViewUp = cam["view_up"]
    view.CameraParallelProjection = int(cam["parallel_projection"])
    view.CameraParallelScale = cam["parallel_scale"]
    view.CameraViewAngle = cam["view_angle"]


def recorded_camera(view):
    cam = view.GetActiveCamera()
    return {"position": list(cam.GetPosition()), "focal_point": list(cam.GetFocalPoint()),
            "view_up": list(cam.GetViewUp()),
            "parallel_projection": bool(cam.GetParallelProjection()),
            "parallel_scale": cam.GetParallelScale(), "view_angle": cam.GetViewAngle()}


def time_label(t):
    return f"{t:.6g}"


def build_case(args, view, meta):
    """OpenFOAM reader, whale patch by p, mid-plane slice by |U|, adapter surface wireframe."""
    foam = os.path.join(args.input, "case.foam")
    reader = pvs.OpenFOAMReader(registrationName="case.foam", FileName=foam)
    reader.CaseType = f"{args.case_type} Case"
    available = list(reader.MeshRegions.Available)
    patch = next((r for r in ("patch/whale", "whale") if r in available), None)
    if patch is None:
        raise SystemExit(f"report: error: {foam} has no whale patch; mesh regions: {available}")
    reader.MeshRegions = ["internalMesh", patch]
    reader.CellArrays = [a for a in ("p", "U") if a in reader.CellArrays.Available]
    reader.UpdatePipelineInformation()
    times = list(reader.TimestepValues)
    if not times:
        raise SystemExit(f"report: error: {foam} ({args.case_type}) has no written time "
                         "after 0 to show; run the case first")
    say(f"{foam}: {len(times)} times {time_label(times[0])} .. {time_label(times[-1])} s, "
        f"regions internalMesh + {patch}")

    whale = pvs.ExtractBlock(registrationName="whale patch", Input=reader,
                             Selectors=["/Root/boundary/whale"])
    mesh = pvs.ExtractBlock(registrationName="internalMesh", Input=reader,
                            Selectors=["/Root/internalMesh"])
    cut = pvs.Slice(registrationName="mid-plane slice y=0", Input=mesh)
    cut.SliceType = "Plane"
    cut.SliceType.Origin = [0.0, 0.0, 0.0]
    cut.SliceType.Normal = [0.0, 1.0, 0.0]

    # OpenFOAM's incompressible p is kinematic (p / rho, m2/s2): drawn in Pa when rho is known
    p_source, p_name, p_unit = whale, "p", "m2/s2"
    p_title = "p / rho (m2/s2, kinematic), whale"
    if args.rho:
        p_source = pvs.Calculator(registrationName="whale p in Pa", Input=whale)
        p_source.AttributeType = "Point Data"
        p_source.ResultArrayName = p_name = "p_Pa"
        p_source.Function = f"{args.rho!r}*p"
        p_unit, p_title = "Pa", f"p (Pa), whale (rho = {args.rho:g} kg/m3)"

    t0 = time.perf_counter()
    p_lo, p_hi = array_range(p_source, "POINTS", p_name, 0, times)
    shown_lo, shown_hi = array_range(p_source, "POINTS", p_name, 0, args.times)
    p_max = max(abs(shown_lo), abs(shown_hi)) or 1.0
    p_rng = (-p_max, p_max)
    u_rng = array_range(cut, "POINTS", "U", -1, times)
    u_rng = (0.0, u_rng[1] or 1.0)
    bounds = union_bounds(whale, times)
    say(f"colour ranges over {len(times)} times: p {p_lo:.4g} .. {p_hi:.4g} {p_unit} (shown "
        f"+-{p_max:.3g}, the range at the pictures' {len(args.times)} times), |U| 0 .. "
        f"{u_rng[1]:.4g} m/s ({time.perf_counter() - t0:.1f} s)")

    cut_display = pvs.Show(cut, view)
    colour_by(cut_display, view, "U", "Magnitude", u_rng, "Viridis (matplotlib)",
              "U magnitude (m/s), slice y = 0")
    pvs.GetScalarBar(pvs.GetColorTransferFunction("U"), view).WindowLocation = "Upper Right Corner"
    whale_display = pvs.Show(p_source, view)
    colour_by(whale_display, view, p_name, 0, p_rng, "Cool to Warm", p_title)
    pvs.GetScalarBar(pvs.GetColorTransferFunction(p_name), view).WindowLocation = \
        "Lower Right Corner"
    sources = {"reader": "case.foam", "whale": "whale patch", "slice": "mid-plane slice y=0"}
    adapter_times = draw_adapter_surface(args, view, sources)
    meta.update({"colour_ranges": {"p": list(p_rng), "U_magnitude": list(u_rng)},
                 "data_range": {"p": [p_lo, p_hi]}, "adapter_times": adapter_times,
                 "p_unit": p_unit, "p_title": p_title, "rho_kg_m3": args.rho})
    return times, bounds, sources


def draw_adapter_surface(args, view, sources):
    """The adapter's whale.pvd of the case (when there is one) as a faint wireframe over the
    patch; its times (none without it)."""
    pvd = os.path.join(args.input, "adapter", "whale.pvd")
    adapter_times = []
    if os.path.isfile(pvd):
        surf = pvs.PVDReader(registrationName="adapter whale.pvd", FileName=pvd)
        adapter_times = list(surf.TimestepValues)
        d = pvs.Show(surf, view)
        # thin, faint lines: the match with the patch shows, the pressure colours stay visible
        d.Representation = "Wireframe"
        d.AmbientColor = [0.25, 0.25, 0.25]
        d.DiffuseColor = [0.25, 0.25, 0.25]
        d.LineWidth = 1.0
        d.Opacity = 0.15
        pvs.ColorBy(d, None)
        sources["adapter"] = "adapter whale.pvd"
        # the animation follows the case's written times, not the union with the surface's
        keeper = pvs.GetTimeKeeper()
        keeper.SuppressedTimeSources = list(keeper.SuppressedTimeSources) + [surf]
        say(f"{pvd}: {len(adapter_times)} times (drawn as a wireframe over the patch)")
    else:
        say(f"no {pvd} (a static-whale case?): the adapter surface is not drawn")
    return adapter_times


def build_surface(args, view, meta):
    """The dry-run's whale.pvd alone, coloured by |displacement|."""
    pvd = os.path.join(args.input, "whale.pvd")
    surf = pvs.PVDReader(registrationName="whale.pvd", FileName=pvd)
    times = list(surf.TimestepValues)
    if not times:
        raise SystemExit(f"report: error: {pvd} lists no frame")
    say(f"{pvd}: {len(times)} frames {time_label(times[0])} .. {time_label(times[-1])} s")
    t0 = time.perf_counter()
    d_rng = array_range(surf, "POINTS", "displacement", -1, times)
    d_rng = (0.0, d_rng[1] or 1.0)
    bounds = union_bounds(surf, times)
    say(f"colour range over {len(times)} frames: |displacement| 0 .. {d_rng[1]:.4g} m "
        f"({time.perf_counter() - t0:.1f} s)")
    d = pvs.Show(surf, view)
    colour_by(d, view, "displacement", "Magnitude", d_rng, "Viridis (matplotlib)",
              "displacement magnitude (m)")
    pvs.GetScalarBar(pvs.GetColorTransferFunction("displacement"), view).WindowLocation = \
        "Upper Right Corner"
    meta["colour_ranges"] = {"displacement_magnitude": list(d_rng)}
    return times, bounds, {"reader": "whale.pvd"}


def main(argv):
    args = parse_args(argv)
    args.input = os.path.abspath(args.input)
    out = os.path.abspath(args.out)
    os.makedirs(out, exist_ok=True)
    wall = time.perf_counter()
    meta = {"input": args.input, "kind": args.kind, "size": list(args.size), "images": []}
    view = make_view(args)
    if args.kind == "case":
        times, bounds, sources = build_case(args, view, meta)
        title = "whale patch: p   slice y = 0: U magnitude   wireframe: adapter surface"
    else:
        times, bounds, sources = build_surface(args, view, meta)
        title = "whale surface (dry-run): displacement magnitude"
    meta["sources"] = sources
    meta["times"] = times
    meta["whale_bounds"] = bounds
    label(view, title)

    scene = pvs.GetAnimationScene()
    scene.UpdateAnimationUsingDataTimeSteps()
    scene.PlayMode = "Snap To TimeSteps"

    cameras = {name: camera_for(name, bounds, args.size) for name in VIEWS}
    write_pictures(args, view, scene, cameras, out, meta)
    if not args.no_animation:
        write_animation(args, view, cameras, len(times), out, meta)

    # the state opens on the angled view at the last picture's time
    scene.AnimationTime = args.times[-1]
    set_camera(view, cameras["angled"])
    state = os.path.join(out, "whale.pvsm")
    pvs.SaveState(state)
    say(f"wrote {state}")
    meta["state"] = "whale.pvsm"
    meta["timings_s"]["total"] = time.perf_counter() - wall
    with open(os.path.join(out, "report.json"), "w") as f:
        json.dump(meta, f, indent=2, allow_nan=False)   # finite: ranges, times, bounds
        f.write("\n")
    say(f"done in {meta['timings_s']['total']:.1f} s")


def make_view(args):
    """The render view: the pictures' size, the axes, a white background."""
    view = pvs.CreateView("RenderView")
    view.ViewSize = list(args.size)
    view.OrientationAxesVisibility = 1
    view.OrientationAxesLabelColor = BLACK
    if hasattr(view, "UseColorPaletteForBackground"):
        view.UseColorPaletteForBackground = 0
    view.Background = WHITE
    pvs.SetActiveView(view)
    return view


def label(view, title):
    """The time label (upper left) and the title (lower left)."""
    clock = pvs.AnnotateTime(registrationName="time label")
    clock.Format = "t = {time:.4g} s"
    clock_display = pvs.Show(clock, view)
    clock_display.Color = BLACK
    clock_display.FontSize = 16
    clock_display.WindowLocation = "Upper Left Corner"
    heading = pvs.Text(registrationName="title", Text=title)
    heading_display = pvs.Show(heading, view)
    heading_display.Color = BLACK
    heading_display.FontSize = 13
    heading_display.WindowLocation = "Lower Left Corner"


def write_pictures(args, view, scene, cameras, out, meta):
    """A picture from every view at every asked time, recorded in ``meta``."""
    t_render = time.perf_counter()
    for t in args.times:
        scene.AnimationTime = t
        for name in VIEWS:
            set_camera(view, cameras[name])
            path = os.path.join(out, f"{name}_t{time_label(t)}.png")
            t1 = time.perf_counter()
            pvs.SaveScreenshot(path, view, ImageResolution=list(args.size),
                               TransparentBackground=0)
            meta["images"].append({"file": os.path.basename(path), "view": name, "time": t,
                                   "camera": recorded_camera(view)})
            say(f"wrote {path} ({time.perf_counter() - t1:.1f} s)")
    meta["timings_s"] = {"pictures": time.perf_counter() - t_render}


def write_animation(args, view, cameras, n_times, out, meta):
    """The animation's frames (and a video when it can be made), recorded in ``meta``."""
    t1 = time.perf_counter()
    frames = os.path.join(out, "animation")
    os.makedirs(frames, exist_ok=True)
    for old in os.listdir(frames):
        if old.startswith("frame.") and old.endswith(".png"):
            os.remove(os.path.join(frames, old))
    set_camera(view, cameras[ANIMATION_VIEW])
    pvs.SaveAnimation(os.path.join(frames, "frame.png"), view,
                      ImageResolution=list(args.size), FrameWindow=[0, n_times - 1])
    pngs = sorted(os.path.join(frames, f) for f in os.listdir(frames)
                  if f.startswith("frame.") and f.endswith(".png"))
    meta["animation"] = {"folder": "animation", "pattern": "frame.%04d.png",
                         "frames": len(pngs), "view": ANIMATION_VIEW,
                         "camera": recorded_camera(view)}
    say(f"wrote {len(pngs)} animation frames into {frames} "
        f"({time.perf_counter() - t1:.1f} s)")
    video = os.path.join(out, "animation.ogv")
    try:
        write_video(pngs, video, args.fps)
    except (ImportError, RuntimeError) as exc:
        say(f"no video ({exc}); the PNG series is there")
    else:
        meta["animation"]["video"] = os.path.basename(video)
        say(f"wrote {video} ({len(pngs)} frames at {args.fps} per second)")
    meta["timings_s"]["animation"] = time.perf_counter() - t1


if __name__ == "__main__":
    main(sys.argv[1:])
