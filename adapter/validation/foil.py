"""The 2D NACA 0012 foil of the validation cases (naca0012, flapping): its profile, a C-grid
around it written as a blockMeshDict, the case folder set up from the whale's template, and
the closed STL of the mesh's own wall points for the step-server.

The profile is the sharp-trailing-edge NACA 0012 of NASA's Turbulence Modeling Resource (TMR,
https://turbmodels.larc.nasa.gov/naca0012_val.html): the exact NACA 0012 formula run to
x = 1.008930411365, where it closes, and scaled back to a unit chord; 11.894 % thick.

The C-grid (one cell thick in z, ``frontAndBack`` empty) has six blocks: on each side of the
foil a front block (leading edge to ``x_split``), a rear block (to the trailing edge) and a wake
block (trailing edge to ``wake`` chords behind it); the outer boundary, patch ``farfield``, is a
half circle of radius ``radius`` chords about (x_split, 0) joined to straight lines at
y = +-radius. The wall patch is ``foil``. Cells are graded geometrically away from the wall (the
first cell ``first_cell`` chords high), towards the leading and trailing edges along the foil
and away from the trailing edge along the wake.
"""

from __future__ import annotations

import math
import shutil
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from adapter.errors import CaseError
from adapter.foam.case import TEMPLATE_DIR
from adapter.foam.dictionaries import parsed_dict, plugin_lib, set_decomposition
from adapter.foam.logs import parse_check_mesh
from adapter.foam.parallel import parallel_command
from adapter.foam.tools import check_foam, run_utility

#: TMR's sharp-trailing-edge rescaling of the NACA 0012 (the formula closes at this x)
TMR_CLOSING_X = 1.008930411365
#: the NACA 0012 half-thickness polynomial (x in its own chord): 0.6 * sum(a_k x^k) + sqrt term
NACA_COEFFS = (0.2969, -0.1260, -0.3516, 0.2843, -0.1015)
WALL = "foil"
#: the first cell off the wake cut at the outlet, per chord of wake (the foil's is first_cell)
WAKE_CUT_CELL = 0.002
FARFIELD = "farfield"


def half_thickness(x) -> np.ndarray:
    """Half thickness y(x) of the sharp-edged TMR NACA 0012, unit chord; x in [0, 1]."""
    xs = np.clip(np.asarray(x, dtype=float), 0.0, 1.0) * TMR_CLOSING_X
    a0, a1, a2, a3, a4 = NACA_COEFFS
    y = 0.6 * (a0 * np.sqrt(xs) + a1 * xs + a2 * xs**2 + a3 * xs**3 + a4 * xs**4)
    return np.maximum(y, 0.0) / TMR_CLOSING_X


@dataclass(frozen=True)
class FoilMesh:
    """The C-grid's numbers (lengths in chords; cell counts per block and side).

    ``le_cell`` and ``te_cell`` are the cell lengths along the foil at the leading and trailing
    edges (the grading of the front and rear blocks and the wake's first cell); ``span`` the
    one cell's thickness in z.
    """

    n_front: int
    n_rear: int
    n_wake: int
    n_normal: int
    first_cell: float
    radius: float = 40.0
    wake: float = 40.0
    x_split: float = 0.3
    le_cell: float = 0.004
    te_cell: float = 0.004
    span: float = 0.1
    chord: float = 1.0

    @property
    def cells(self) -> int:
        return 2 * (self.n_front + self.n_rear + self.n_wake) * self.n_normal


def expansion_ratio(first: float, length: float, n: int) -> float:
    """blockMesh's expansion ratio (last cell / first cell) of ``n`` cells growing
    geometrically over ``length`` from a first cell ``first``; 1 for a uniform edge.
    Raises :class:`~adapter.errors.CaseError` when ``first`` cannot be met."""
    if n < 1 or first <= 0 or length <= 0:
        raise CaseError(f"edge of {length:g} with {n} cells from {first:g}: give positive "
                        "lengths and at least one cell")
    if n == 1 or abs(first * n - length) < 1e-12 * length:
        return 1.0
    lo, hi = (1e-9, 1.0) if first * n > length else (1.0, 10.0)

    def total(r):
        return first * n if r == 1.0 else first * (r**n - 1) / (r - 1)

    if (total(lo) - length) * (total(hi) - length) > 0:
        raise CaseError(f"no geometric grading puts a first cell of {first:g} on an edge of "
                        f"{length:g} with {n} cells; change the cell count or first cell")
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if (total(mid) - length) * (total(lo) - length) > 0:
            lo = mid
        else:
            hi = mid
    return (0.5 * (lo + hi)) ** (n - 1)


def _arc_length(x: np.ndarray) -> float:
    p = np.column_stack([x, half_thickness(x)])
    return float(np.linalg.norm(np.diff(p, axis=0), axis=1).sum())


def _spline(x0: float, x1: float, sign: float, c: float, n: int = 48) -> list:
    """Interior points of the profile between x0 and x1 (cosine-spaced), on side ``sign``."""
    s = 0.5 * (1 - np.cos(np.linspace(0.0, math.pi, n + 2)[1:-1]))
    x = x0 + (x1 - x0) * s
    return [[float(c * xi), float(sign * c * half_thickness(xi))] for xi in x]


def block_mesh_entries(m: FoilMesh) -> dict:
    """The blockMeshDict entries (vertices, blocks, edges, boundary) of the C-grid, as the
    lists PyFoam writes."""
    c, R, xs = m.chord, m.radius * m.chord, m.x_split * m.chord
    ys = c * float(half_thickness(m.x_split))
    xw = c + m.wake * c
    xy = [(0, 0), (xs, ys), (c, 0), (xw, 0), (xs - R, 0), (xs, R), (c, R), (xw, R),
          (xs, -ys), (xs, -R), (c, -R), (xw, -R)]
    vertices = [f"({x!r} {y!r} 0.0)" for x, y in xy] + \
               [f"({x!r} {y!r} {m.span * c!r})" for x, y in xy]
    nv = len(xy)
    front = _arc_length(np.linspace(0, m.x_split, 400)) * c
    rear = _arc_length(np.linspace(m.x_split, 1, 400)) * c
    g_front = expansion_ratio(m.le_cell * c, front, m.n_front) if m.n_front > 1 else 1.0
    # the rear block's cells shrink towards the trailing edge: its first cell is its largest
    g_rear = 1.0 / expansion_ratio(m.te_cell * c, rear, m.n_rear) if m.n_rear > 1 else 1.0
    g_wake = expansion_ratio(m.te_cell * c, m.wake * c, m.n_wake)
    g_norm = expansion_ratio(m.first_cell * c, R, m.n_normal)

    # at the outlet the wake cut's cells need not be as thin as at the foil (aspect ratio)
    g_out = expansion_ratio(WAKE_CUT_CELL * m.wake * c, R, m.n_normal)

    def hexa(q, n1, n2, g1, g2):
        """A block and its 12 edges' gradings, x1 (0-1, 3-2, 7-6, 4-5), then x2, x3."""
        labels = " ".join(str(v) for v in (*q, *(v + nv for v in q)))
        g = " ".join(repr(v) for v in (*g1, *g2, 1, 1, 1, 1))
        return (q, f"hex ({labels}) ({n1} {n2} 1) edgeGrading ({g})")

    nn, gn, go = m.n_normal, (g_norm,) * 4, g_out
    blocks = [hexa((0, 1, 5, 4), m.n_front, nn, (g_front,) * 4, gn),       # upper front
              hexa((1, 2, 6, 5), m.n_rear, nn, (g_rear,) * 4, gn),         # upper rear
              hexa((2, 3, 7, 6), m.n_wake, nn, (g_wake,) * 4,              # upper wake
                   (g_norm, go, go, g_norm)),
              hexa((0, 4, 9, 8), nn, m.n_front, gn, (g_front,) * 4),       # lower front
              hexa((8, 9, 10, 2), nn, m.n_rear, gn, (g_rear,) * 4),        # lower rear
              hexa((2, 10, 11, 3), nn, m.n_wake, (g_norm, go, go, g_norm),  # lower wake
                   (g_wake,) * 4)]
    edges = []
    for k, z in ((0, 0.0), (nv, m.span * c)):
        for a, b, x0, x1, sign in ((0, 1, 0, m.x_split, 1), (1, 2, m.x_split, 1, 1),
                                   (0, 8, 0, m.x_split, -1), (8, 2, m.x_split, 1, -1)):
            pts = " ".join(f"({x!r} {y!r} {z!r})" for x, y in _spline(x0, x1, sign, c))
            edges.append(f"spline {a + k} {b + k} ({pts})")
        for a, b, sign in ((4, 5, 1), (4, 9, -1)):
            r = R / math.sqrt(2)
            edges.append(f"arc {a + k} {b + k} ({xs - r!r} {sign * r!r} {z!r})")

    def quads(pairs):
        return [[a, b, b + nv, a + nv] for a, b in pairs]

    sides = [list(q) for q, _ in blocks]
    boundary = [
        WALL, {"type": "wall", "faces": quads([(0, 1), (1, 2), (0, 8), (8, 2)])},
        FARFIELD, {"type": "patch", "faces": quads([(4, 5), (5, 6), (6, 7), (7, 3), (3, 11),
                                                    (11, 10), (10, 9), (9, 4)])},
        "frontAndBack", {"type": "empty",
                         "faces": sides + [[v + nv for v in q[::-1]] for q in sides]},
    ]
    return {"vertices": _listing(vertices), "blocks": _listing(b for _, b in blocks),
            "edges": _listing(edges), "boundary": boundary}


def _listing(items) -> str:
    """An OpenFOAM list of entries, one a line, as PyFoam writes a string: as it is (a list
    of mixed words PyFoam would prefix with a count OpenFOAM reads as the entries')."""
    return "(\n" + "\n".join(items) + "\n)"


def write_block_mesh(case: Path, m: FoilMesh) -> None:
    """system/blockMeshDict of the C-grid (the template's file, its entries replaced)."""
    d = parsed_dict(case / "system" / "blockMeshDict")
    for key in list(d.content.keys()):
        if key not in ("FoamFile", "scale"):
            del d[key]
    d["scale"] = 1
    for key, value in block_mesh_entries(m).items():
        d[key] = value
    d["mergePatchPairs"] = []
    d.writeFile()


def prepare_foil_case(case: Path, m: FoilMesh, *, speed: float, nu: float, rho: float,
                      alpha_deg: float, turbulence: bool, ranks: int = 1) -> None:
    """A case folder from the whale's template for the foil: its solver, schemes, solution
    settings, wall treatment and function objects (whaleLoads, yPlus) on patch
    ``foil``, the free stream at ``alpha_deg`` on ``farfield``, laminar or kOmegaSST.

    A foil case already in ``case`` (an earlier ``validate`` run's: it has the C-grid's
    ``system/blockMeshDict`` with the ``foil`` patch) is removed first, so that a rerun starts
    afresh; any other case there is refused (:class:`~adapter.errors.CaseError`).
    """
    old = case / "system" / "blockMeshDict"
    if (case / "system" / "controlDict").exists():
        if not (old.is_file() and f"{WALL}\n" in old.read_text() and FARFIELD in old.read_text()):
            raise CaseError(f"{case} holds a case that is not a validation foil's; remove it "
                            "or give another --out")
        shutil.rmtree(case)
    check_foam()
    case.mkdir(parents=True, exist_ok=True)
    shutil.copytree(TEMPLATE_DIR, case, dirs_exist_ok=True)
    for name in ("Allrun", "Allclean", "system/snappyHexMeshDict", "system/meshQualityDict"):
        (case / name).unlink(missing_ok=True)
    write_block_mesh(case, m)
    set_decomposition(case, ranks)
    a = math.radians(alpha_deg)
    u = (speed * math.cos(a), speed * math.sin(a), 0.0)
    d = parsed_dict(case / "constant" / "transportProperties")
    d["nu"] = nu
    d.writeFile()
    d = parsed_dict(case / "constant" / "turbulenceProperties")
    d["simulationType"] = "RAS" if turbulence else "laminar"
    d.writeFile()
    _set_control(case, rho)
    _set_fields(case, u, speed, nu)
    d = parsed_dict(case / "constant" / "dynamicMeshDict")
    d["dynamicFvMesh"] = "staticFvMesh"      # the moving cases set it (set_motion)
    d["whaleBlendedDisplacementCoeffs"]["patch"] = WALL
    d["displacementLaplacianCoeffs"]["diffusivity"] = f"quadratic inverseDistance ({WALL})"
    d.writeFile()


def _set_control(case: Path, rho: float) -> None:
    d = parsed_dict(case / "system" / "controlDict")
    lib = f'"{plugin_lib()}"'
    d["libs"] = [lib]
    fo = d["functions"]
    fo["loads"]["patches"] = [WALL]
    fo["loads"]["libs"] = [lib]
    fo["loads"]["rhoInf"] = rho
    del fo["loads"]["regions"]
    d.writeFile()


def _set_fields(case: Path, u: tuple, speed: float, nu: float) -> None:
    """0.orig: the template's wall entries on ``foil``, the free stream on ``farfield``."""
    from adapter.foam.parameters import EDDY_VISCOSITY_RATIO, TURBULENCE_INTENSITY

    k = 1.5 * (TURBULENCE_INTENSITY * speed) ** 2
    values = {"U": "uniform (" + " ".join(repr(v) for v in u) + ")", "p": "uniform 0",
              "k": f"uniform {k!r}", "omega": f"uniform {k / (EDDY_VISCOSITY_RATIO * nu)!r}",
              "nut": "uniform 0"}
    far = {"U": {"type": "freestreamVelocity", "freestreamValue": values["U"]},
           "p": {"type": "freestreamPressure", "freestreamValue": values["p"]},
           "nut": {"type": "calculated"}}
    for name, value in values.items():
        d = parsed_dict(case / "0.orig" / name)
        for key in ("Uinlet", "kInlet", "omegaInlet"):
            if key in d:
                del d[key]
        wall = dict(d["boundaryField"]["whale"])
        if "value" in wall:
            wall["value"] = "uniform (0 0 0)" if name == "U" else value
        entry = far.get(name, {"type": "inletOutlet", "inletValue": value})
        d["internalField"] = value
        d["boundaryField"] = {WALL: wall, FARFIELD: {**entry, "value": value},
                              "frontAndBack": {"type": "empty"}}
        d.writeFile()
    d = parsed_dict(case / "0.orig" / "pointDisplacement")
    d["boundaryField"] = {WALL: {"type": "fixedValue", "value": "uniform (0 0 0)"},
                          FARFIELD: {"type": "fixedValue", "value": "uniform (0 0 0)"},
                          "frontAndBack": {"type": "empty"}}
    d.writeFile()


def mesh_foil(case: Path) -> dict:
    """blockMesh and checkMesh; 0 from 0.orig. Returns checkMesh's figures (cells, worst
    non-orthogonality and skewness). Raises :class:`~adapter.errors.SolverRunError` when a
    tool fails, :class:`~adapter.errors.CaseError` when checkMesh finds the mesh bad."""
    run_utility(case, ["blockMesh"])
    log = run_utility(case, ["checkMesh"])
    text = log.read_text()
    info = parse_check_mesh(text)
    # the far field's cells above the foil are tall and narrow (the foil's spacing carried out
    # to the outer boundary), which checkMesh flags; any other failed check is an error
    failed = [line.strip() for line in text.splitlines() if line.lstrip().startswith("***")
              and "aspect ratio" not in line]
    if failed:
        raise CaseError(f"checkMesh fails the foil's C-grid ({failed[0]}); see {log}")
    shutil.rmtree(case / "0", ignore_errors=True)
    shutil.copytree(case / "0.orig", case / "0")
    return info


def run_solver(case: Path, ranks: int = 1) -> Path:
    """pimpleFoam in the case (serial, or decomposed on ``ranks`` and reconstructed); the
    log is ``log.pimpleFoam``."""
    if ranks <= 1:
        return run_utility(case, ["pimpleFoam"])
    run_utility(case, ["decomposePar", "-force"])
    log = run_utility(case, parallel_command(["pimpleFoam"], ranks), log_name="pimpleFoam")
    run_utility(case, ["reconstructPar", "-newTimes"])
    return log


def wall_loads(case: Path) -> dict:
    """whaleLoads' columns of the case (:func:`~adapter.foam.loads.read_loads`); raises
    :class:`~adapter.errors.CaseError` when the foil's are missing (the run wrote none)."""
    from adapter.foam.loads import read_loads

    loads = read_loads(case)
    if not loads or f"{WALL}:Fx" not in loads:
        raise CaseError(f"{case}: no loads of patch {WALL} in postProcessing/loads; see "
                        f"{case / 'log.pimpleFoam'}")
    return loads


def force_scale(m: FoilMesh, rho: float, speed: float) -> float:
    """0.5 rho U^2 c s (N): the force of a coefficient of one on the one-cell span."""
    return 0.5 * rho * speed**2 * m.chord * m.span * m.chord


def plain_floats(rows: list) -> list:
    """The checks with their measured figures as Python floats (numpy's are not JSON's)."""
    for c in rows:
        c.measured = float(c.measured)
    return rows


def wall_surface(case: Path) -> tuple:
    """The foil patch's points (P, 3) and the closed surface's triangles (T, 3) made of them:
    each wall quad split in two and the two end caps fanned from the leading edge; outward."""
    from adapter.foam.foamascii import read_boundary, read_faces, read_points

    mesh = case / "constant" / "polyMesh"
    patch = read_boundary(mesh / "boundary")[WALL]
    faces = read_faces(mesh / "faces")
    start = patch["startFace"]
    quads = np.array([faces[i] for i in range(start, start + patch["nFaces"])])
    points = read_points(mesh / "points")
    used, inverse = np.unique(quads, return_inverse=True)
    quads = inverse.reshape(quads.shape)
    pts = points[used]
    # OpenFOAM's boundary faces point out of the fluid, into the foil: reversed, outward
    tris = [quads[:, [2, 1, 0]], quads[:, [3, 2, 0]]]
    z0 = pts[:, 2].min()
    for low in (True, False):
        on = np.flatnonzero(np.isclose(pts[:, 2], z0) == low)
        loop = on[np.argsort(np.arctan2(pts[on, 1], pts[on, 0] - 0.5 * np.ptp(pts[on, 0])))]
        lead = int(np.argmin(pts[loop, 0]))
        loop = np.roll(loop, -lead)
        fan = np.column_stack([np.full(len(loop) - 2, loop[0]), loop[1:-1], loop[2:]])
        # the angle-sorted loop runs anticlockwise seen from +z: the high cap faces +z
        tris.append(fan if not low else fan[:, ::-1])
    return pts, np.concatenate(tris)


def write_wall_stl(case: Path, path: Path) -> Path:
    """The foil's closed STL of the mesh's wall points (see :func:`wall_surface`)."""
    from adapter.body.meshfile import write_surface

    pts, tris = wall_surface(case)
    write_surface(path, pts, [tris])
    return path
