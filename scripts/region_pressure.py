"""Where a gliding whale's pressure drag sits: by region, and along the flippers' chord.

For one written time of a reconstructed case (run-case's ``<case>/gliding``), the whale
patch's face pressure (the owner cell's kinematic ``p`` times ``--rho``: the patch is
zeroGradient) and each face's region (the nearest triangle centre of
``constant/triSurface/whale_regions.stl``). Prints per region the pressure force along x, the
prism layers' coverage (``0/nSurfaceLayers``, where snappyHexMesh wrote it: the case's own, or
its parent's for a pair's ``gliding``) and y+;
then one flipper's pressure force along x in four span strips and six chord bands, with the
band's area-weighted Cp, and the flukes' the same in strips of |y| (the span from the body's
axis; both blades when the case is the full domain). A chord band is a share of the strip's x
extent, 0 its most forward point. The forces are the half domain's when the case is one.

    .venv/bin/python scripts/region_pressure.py runs/default/gliding 23.5537109375
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from adapter.body.meshfile import read_stl_solids  # noqa: E402
from adapter.foam.foamascii import (  # noqa: E402
    _body,
    _list_start,
    _matching,
    _numbers,
    face_area_vectors,
    mesh_file,
    read_boundary,
    read_faces,
    read_foam_text,
    read_patch_field,
    read_points,
)

#: the procedural flipper's growth direction (adapter/body/procedural.py, ``_flipper``)
FLIPPER_DIRECTION = np.array([0.45, 0.75, -0.48])
CHORD_BANDS = [0.1, 0.3, 0.5, 0.7, 0.9]
#: the flukes' strips, |y| from the body's axis (m; the default whale's blade reaches 2.4)
FLUKE_STRIPS = [0.0, 0.3, 0.6, 1.0, 1.5, 2.0, 2.6]


def read_list(path) -> np.ndarray:
    """The numbers of an ASCII list file (``owner``) or of a field's internalField."""
    text = _body(read_foam_text(path))
    if "internalField" in text:
        text = text[text.index("internalField"):]
        text = text[text.index("List<scalar>") + len("List<scalar>"):]
    _, start = _list_start(text)
    return _numbers(text[start:_matching(text, start - 1)])


def patch_pressure(case, time: str, rho: float, patch: str = "whale") -> tuple:
    """(face area vectors out of the fluid, face centres, pressure in Pa) on ``patch`` at a
    written time of a reconstructed case, on the mesh of constant/polyMesh (a gliding case's
    static mesh); the face pressure is the owner cell's (the patch is zeroGradient)."""
    b = read_boundary(mesh_file(case, None, "boundary"))[patch]
    s0, n = b["startFace"], b["nFaces"]
    faces = read_faces(mesh_file(case, None, "faces"))[s0:s0 + n]
    owner = read_list(mesh_file(case, None, "owner")).astype(int)[s0:s0 + n]
    pts = read_points(mesh_file(case, None, "points"))
    centre = np.array([pts[f].mean(axis=0) for f in faces])
    return face_area_vectors(pts, faces), centre, read_list(f"{case}/{time}/p")[owner] * rho


def print_strips(faces, span, edges, centre, fx, p, area, q, label=False) -> None:
    """For the ``faces`` in each strip ``edges[i] <= span < edges[i + 1]``: the pressure force
    along x in :data:`CHORD_BANDS` (shares of the strip's x extent) and the bands' Cp."""
    for lo, hi in zip(edges[:-1], edges[1:], strict=True):
        m = faces[(span >= lo) & (span < hi)]
        if not len(m):
            continue
        x = centre[m, 0]
        band = np.digitize((x - x.min()) / max(np.ptp(x), 1e-12), CHORD_BANDS)
        force = [fx[m][band == k].sum() for k in range(len(CHORD_BANDS) + 1)]
        cp = [(p[m][band == k] * area[m][band == k]).sum() / area[m][band == k].sum() / q
              if (band == k).any() else float("nan") for k in range(len(CHORD_BANDS) + 1)]
        where = f"|y| {lo:.1f}-{hi:.1f} m, " if label else ""
        print(f"    {where}chord {np.ptp(x):.2f} m: " + " ".join(f"{v:+6.1f}" for v in force)
              + f"  sum {sum(force):+6.1f}   Cp " + " ".join(f"{v:+.2f}" for v in cp))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("case", help="a reconstructed case (run-case's <case>/gliding)")
    ap.add_argument("time", help="a written time folder's name")
    ap.add_argument("--rho", type=float, default=1025.0, help="density (kg/m3)")
    ap.add_argument("--speed", type=float, default=1.3, help="flow speed for Cp (m/s)")
    args = ap.parse_args(argv)
    case, time = args.case, args.time
    sf, centre, p = patch_pressure(case, time, args.rho)
    n = len(p)
    area = np.linalg.norm(sf, axis=1)
    q = 0.5 * args.rho * args.speed ** 2
    fx = p * sf[:, 0]          # Sf points out of the fluid, into the whale

    solids = {name: tri.mean(axis=1) for name, tri in
              read_stl_solids(f"{case}/constant/triSurface/whale_regions.stl").items()}
    names = list(solids)
    label = np.concatenate([[i] * len(solids[k]) for i, k in enumerate(names)])
    region = label[cKDTree(np.vstack([solids[k] for k in names])).query(centre)[1]]
    own = Path(case) / "0" / "nSurfaceLayers"
    layers = read_patch_field(own if own.is_file() else Path(case).parent / "0" / "nSurfaceLayers",
                              "whale", n)
    yplus = read_patch_field(f"{case}/{time}/yPlus", "whale", n)
    print(f"{case} at {time}: {n} whale faces")
    for i, k in enumerate(names):
        m = region == i
        w = area[m] / area[m].sum()
        print(f"  {k:9s} pressure force x {fx[m].sum():7.1f} N on {area[m].sum():6.2f} m2; "
              f"layers on {w[layers[m] >= 1].sum():.1%} (mean {(w * layers[m]).sum():.2f}); "
              f"y+ median {np.median(yplus[m]):.0f}, > 300 on {w[yplus[m] > 300].sum():.1%}, "
              f"< 30 on {w[yplus[m] < 30].sum():.1%}")

    fins = np.flatnonzero(region == names.index("flippers"))
    d = FLIPPER_DIRECTION / np.linalg.norm(FLIPPER_DIRECTION)
    span = (centre[fins] - centre[fins].mean(axis=0)) @ d
    print("  flipper: pressure force x (N) in chord bands 0-0.1-0.3-0.5-0.7-0.9-1 "
          "(0 the leading edge), and Cp, root strip first")
    print_strips(fins, span, np.linspace(span.min(), span.max() + 1e-9, 5), centre, fx, p,
                 area, q)
    if "flukes" in names:
        flukes = np.flatnonzero(region == names.index("flukes"))
        print("  flukes: the same in strips of |y| (m from the axis), the root strip first")
        print_strips(flukes, np.abs(centre[flukes, 1]), FLUKE_STRIPS, centre, fx, p, area, q,
                     label=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
