"""The scene's whale surface: :func:`build_surface` (the procedural right whale or the scene's
mesh file, checked and oriented, with its landmarks) and the ``geometry`` command.

The parts are one module each: :mod:`~adapter.body.surface` (the :class:`WhaleSurface` type),
:mod:`~adapter.body.procedural` (the procedural whale), :mod:`~adapter.body.meshfile` (mesh
files in and out), :mod:`~adapter.body.checks` (mesh checks), :mod:`~adapter.body.landmarks`
(:data:`LANDMARKS`), :mod:`~adapter.body.regions` (body, flippers, flukes).
"""

from __future__ import annotations

import argparse

import numpy as np

from adapter.body.checks import validate_surface
from adapter.body.landmarks import landmarks_from_scene
from adapter.body.meshfile import FORMATS, read_surface, writable
from adapter.body.procedural import procedural_whale
from adapter.body.surface import WhaleSurface
from adapter.errors import GeometryError, UsageError
from adapter.options import in_file, out_file


def build_surface(scene) -> WhaleSurface:
    """The scene's whale surface, checked (closed, manifold, oriented outward)."""
    g = scene.geometry
    if g.source == "procedural":
        points, faces, landmarks, face_regions = procedural_whale(
            g.length_m, g.nodes, g.fluke_span, with_regions=True, sections=g.fin_sections,
            flipper_root=g.flipper_root, fluke_root=g.fluke_root, flippers=g.flippers)
        length = g.length_m
        origin = np.zeros(3)
        # orientation flips rows in place: the regions stay parallel to the faces
        faces = validate_surface(points, faces, length)
    else:
        try:
            points, faces, landmarks, length, origin = _mesh_file(scene)
        except GeometryError as exc:    # which key of the scene names the file
            raise GeometryError(f"geometry.source = {g.source!r}: {exc}") from None
        face_regions = None
    return WhaleSurface(points, faces, landmarks, length, origin, face_regions)


def _mesh_file(scene):
    """The scene's mesh file read, checked and oriented; its landmarks, length and origin."""
    g = scene.geometry
    points, faces = read_surface(scene.resolve(g.source))
    extent = float(np.ptp(points[:, 0]))
    faces = validate_surface(points, faces, max(extent, 1e-12))
    if scene.rigid.enabled and not g.landmarks:
        # a rigid body needs none of the whale's landmarks: its nose is its smallest x
        landmarks = {}
        origin = points[int(np.argmin(points[:, 0]))].copy()
    else:
        landmarks = landmarks_from_scene(points, g.landmarks, extent, g.landmark_tolerance)
        origin = points[landmarks["rostrum"]].copy()
    length = float(points[:, 0].max() - origin[0])
    if length <= 0:
        raise GeometryError("the mesh must lie along +x from its rostrum (x grows toward the tail)")
    return points, faces, landmarks, length, origin


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "geometry", help="write the scene's whale surface (STL, OBJ, VTK)",
        description="Build the scene's whale surface (the procedural right whale or the "
        "scene's mesh file), check it (closed, manifold, outward) and write it to each --out "
        "file, the format by suffix (docs/geometry.md).")
    p.add_argument("--scene", type=in_file, help="scene TOML file (default: built-in default)")
    p.add_argument("--preset", help="built-in preset: default, smoke, fine")
    p.add_argument("--out", required=True, nargs="+", type=out_file,
                   help="output file(s); format by suffix")
    p.set_defaults(func=_cmd_geometry)


def _cmd_geometry(args: argparse.Namespace) -> int:
    from adapter.scene import load_scene

    scene = load_scene(args.scene, preset=args.preset)
    unknown = [str(out) for out in args.out if not writable(out)]
    if unknown:     # before the surface is built
        raise UsageError(f"--out {' '.join(unknown)}: unknown surface format; give {FORMATS}")
    surface = build_surface(scene)
    for out in args.out:
        surface.write(out)
        print(f"wrote {out}: {surface.n_nodes} nodes, {len(surface.edges)} edges")
    return 0
