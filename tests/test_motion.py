"""The whaleBlendedDisplacement motion solver, in real pimpleFoam runs, against truths from outside.

A 2D channel (blockMesh, 888 cells) with a 0.5 m square hole whose four sides are ONE patch
``whale``; the cells next to the hole are thin (graded blocks: about 0.01 m normal to the wall
against 0.0625 m along it, like prism layers). The whale's ``pointDisplacement`` is one of
OpenFOAM's own rigid motions (no step-server needed): ``oscillatingDisplacement`` (a translation
``A sin(w t)``) or ``angularOscillatingDisplacement`` (a rotation by ``a sin(w t)`` about z through
the square's centre); the rest of the mesh is moved by ``whaleBlendedDisplacement`` from the
plugin library. Checked:

- a rigidly translated wall moves every point within ``innerDistance`` of it by exactly the
  translation (so the layer cells keep their shape and volume), points beyond
  ``outerDistance`` not at all, and the points between by ``phi(r) A sin(w t)``, ``phi`` the
  quintic smoothstep of the distance to the nearest wall point (computed here from the points);
- a rigidly rotated wall (``rotation yes``) moves every point within ``innerDistance`` by
  exactly that rotation, and the layer cells keep their volume; without ``rotation`` they do not
  (the cells shear); with ``rotationInner`` the rigid turn reaches only that far, and
  ``rotationInner`` at or beyond ``rotationDistance``, or a rotation fitted to fewer than 3
  points (``rotationNeighbours``), is refused;
- a restart from an odd written step (``startFrom latestTime``) reproduces the points and U of
  an uninterrupted run to 1e-9, serially and on two MPI ranks; the two ranks' mesh equals the
  serial one (the motion does not depend on the decomposition);
- the motion check (``checkMotion``, on by default): a translation large enough to invert cells
  at a known step (without the check OpenFOAM's own mesh check, ``-debug-switch polyMesh=1`` as
  run-case uses it, reports the first invalid mesh there) stops the run with a FatalError at
  that step, before the mesh moves, serially and on two ranks alike; the last written time is
  the step before and its mesh passes checkMesh.

Skipped without pimpleFoam or without the built library (scripts/build_plugin.sh).
"""

from __future__ import annotations

import re
import shutil

import numpy as np
import pytest

from adapter.errors import SolverRunError
from adapter.foam import case as C
from adapter.foam import logs as LG
from adapter.foam import tools as T
from adapter.foam.foamascii import read_boundary, read_faces, read_points

from .channel_case import (
    FV_SCHEMES,
    HEADER,
    flow_files,
    fv_solution,
    side_quad,
    vertex,
    write_files,
)
from .conftest import NEEDS_FOAM_AND_PLUGIN

pytestmark = [
    *NEEDS_FOAM_AND_PLUGIN,
]

DT = 1 / 64                  # a binary fraction: restart times are exact
N_STEPS = 7
RESTART_STEP = 3             # odd
AMPLITUDE = (0.12, 0.07, 0.0)        # m, oscillatingDisplacement
ANGLE = 0.4                          # rad, angularOscillatingDisplacement amplitude
OMEGA = 12.0                         # rad/s, both
INNER, OUTER, ROT = 0.06, 1.0, 0.4   # innerDistance, outerDistance, rotationDistance (m)
#: a translation that inverts cells: 0.37 m at step 2 is fine, 0.53 m at step 3 folds the cells
#: between the wall and outerDistance (measured: 15 cells of negative volume)
INVERTING = (0.0, 1.0, 0.0)
INVERTED_STEP = 3

_XS, _NX, _GX = (-1.5, -0.25, 0.25, 3.0), (10, 8, 16), (0.03, 1, 30)
_YS, _NY, _GY = (-1.5, -0.25, 0.25, 1.5), (10, 8, 10), (0.03, 1, 30)


def _block_mesh_dict() -> str:
    verts = " ".join(f"({x} {y} {z})" for z in (0, 0.1) for y in _YS for x in _XS)
    blocks, planes = [], []
    for j in range(3):
        for i in range(3):
            if (i, j) == (1, 1):
                continue
            c = [vertex(i, j, 0), vertex(i + 1, j, 0), vertex(i + 1, j + 1, 0), vertex(i, j + 1, 0)]
            blocks.append(f"hex ({' '.join(map(str, c + [n + 16 for n in c]))}) "
                          f"({_NX[i]} {_NY[j]} 1) simpleGrading ({_GX[i]} {_GY[j]} 1)")
            planes += [f"({' '.join(map(str, c[::-1]))})", f"({' '.join(str(n + 16) for n in c)})"]
    side = {
        "inlet": ("patch", [side_quad((0, j), (0, j + 1)) for j in range(3)]),
        "outlet": ("patch", [side_quad((3, j), (3, j + 1)) for j in range(3)]),
        "walls": ("patch", [side_quad((i, 0), (i + 1, 0)) for i in range(3)]
                  + [side_quad((i, 3), (i + 1, 3)) for i in range(3)]),
        "whale": ("wall", [side_quad((1, 1), (1, 2)), side_quad((2, 1), (2, 2)),
                           side_quad((1, 1), (2, 1)), side_quad((1, 2), (2, 2))]),
        "frontAndBack": ("empty", planes),
    }
    boundary = "\n".join(f"{name} {{ type {kind}; faces ({' '.join(faces)}); }}"
                         for name, (kind, faces) in side.items())
    return (HEADER.format(cls="dictionary", obj="blockMeshDict")
            + f"convertToMeters 1;\nvertices ({verts});\nblocks ({' '.join(blocks)});\n"
            + f"edges ();\nboundary (\n{boundary}\n);\nmergePatchPairs ();\n")


def _whale_bc(motion: str, amplitude=AMPLITUDE) -> str:
    if motion == "translate":
        return ("type oscillatingDisplacement; amplitude ({} {} {}); omega {};"
                " value uniform (0 0 0);".format(*amplitude, OMEGA))
    return (f"type angularOscillatingDisplacement; axis (0 0 1); origin (0 0 0); angle0 0;"
            f" amplitude {ANGLE}; omega {OMEGA}; value uniform (0 0 0);")


def _files(motion: str, rotation: bool, lib, amplitude=AMPLITUDE, check: str = "") -> dict:
    return {
        "system/controlDict": ("dictionary", f"""
libs ("{lib}" "libfvMotionSolvers.so");
application pimpleFoam; startFrom latestTime; startTime 0; stopAt endTime;
endTime {N_STEPS * DT}; deltaT {DT}; writeControl timeStep; writeInterval 1;
writeFormat ascii; writePrecision 17; timeFormat general; timePrecision 12;
runTimeModifiable false;
"""),
        "system/fvSchemes": ("dictionary", FV_SCHEMES),
        "system/fvSolution": ("dictionary", fv_solution(1e-10, 0)),
        "system/decomposeParDict": ("dictionary",
                                    "numberOfSubdomains 2; method hierarchical;"
                                    " coeffs { n (1 2 1); }   // the square split\n"),
        "constant/dynamicMeshDict": ("dictionary", f"""
dynamicFvMesh dynamicMotionSolverFvMesh;
motionSolverLibs ("{lib}");
motionSolver whaleBlendedDisplacement;
whaleBlendedDisplacementCoeffs
{{
    patch whale; nNeighbours 8; power 3;
    innerDistance {INNER}; outerDistance {OUTER};
    rotation {'yes' if rotation else 'no'}; rotationDistance {ROT}; {check}
}}
"""),
        **flow_files("whale"),
        "0/pointDisplacement": ("pointVectorField", f"""
dimensions [0 1 0 0 0 0 0]; internalField uniform (0 0 0);
boundaryField
{{
    inlet {{ type fixedValue; value uniform (0 0 0); }}
    outlet {{ type fixedValue; value uniform (0 0 0); }}
    walls {{ type slip; }}
    whale {{ {_whale_bc(motion, amplitude)} }}
    frontAndBack {{ type empty; }}
}}
"""),
    }


def make_case(case, motion: str, rotation: bool, lib=C.PLUGIN_LIB, amplitude=AMPLITUDE,
              check: str = "") -> None:
    """The channel case; ``check`` an extra entry of the motion solver's coefficients (e.g.
    ``checkMotion no;``)."""
    write_files(case, _files(motion, rotation, lib, amplitude, check))
    (case / "system" / "blockMeshDict").write_text(_block_mesh_dict())


def _set_end(case, steps: int) -> None:
    cd = case / "system" / "controlDict"
    text = cd.read_text().replace(f"endTime {N_STEPS * DT};", f"endTime {steps * DT};")
    cd.write_text(text)


def _pimple(case, ranks: int, log: str) -> None:
    if ranks == 1:
        T.run_utility(case, ["pimpleFoam"], log_name=log)
    else:
        T.run_utility(case, ["mpirun", "--allow-run-as-root", "--oversubscribe", "-np", "2",
                             "pimpleFoam", "-parallel"], log_name=log)


def run(tmp_path_factory, motion: str, rotation: bool, ranks: int = 1, restart: bool = False):
    """Make and run a case (with ``restart``: stop at RESTART_STEP, then continue); its folder."""
    case = tmp_path_factory.mktemp(f"motion-{motion}-{int(rotation)}-{ranks}-{int(restart)}")
    make_case(case, motion, rotation)
    T.run_utility(case, ["blockMesh"])
    if ranks > 1:
        T.run_utility(case, ["decomposePar"])
    if restart:
        _set_end(case, RESTART_STEP)
        _pimple(case, ranks, "pimpleFoam-first")
        cd = case / "system" / "controlDict"
        cd.write_text(cd.read_text().replace(f"endTime {RESTART_STEP * DT};",
                                             f"endTime {N_STEPS * DT};"))
        for proc in [case] if ranks == 1 else sorted(case.glob("processor*")):
            assert (proc / _tname(RESTART_STEP)).is_dir()
            assert not (proc / _tname(RESTART_STEP + 1)).exists()
    _pimple(case, ranks, "pimpleFoam")
    return case


def read_vector_field(path) -> np.ndarray:
    """(N, 3) internalField of a volVectorField file (nonuniform)."""
    text = path.read_text()
    i = text.index("internalField")
    head, _, rest = text[i:].partition("(")
    n = int(head.split()[-1])
    body = rest[:rest.index("\n)")]
    v = np.array(body.replace("(", " ").replace(")", " ").split(), dtype=float)
    assert v.size == 3 * n, path
    return v.reshape(n, 3)


def _tname(step: int) -> str:
    return f"{step * DT:.12g}"


def points0_and_wall(case):
    """Undeformed points and the whale's point labels (from the blockMesh faces)."""
    mesh = case / "constant" / "polyMesh"
    p0 = read_points(mesh / "points")
    faces = read_faces(mesh / "faces")
    b = read_boundary(mesh / "boundary")["whale"]
    wall = np.unique(np.concatenate(faces[b["startFace"]:b["startFace"] + b["nFaces"]]))
    return p0, wall


def _phi(r):
    s = np.clip((OUTER - r) / (OUTER - INNER), 0.0, 1.0)
    return s**3 * (10 - 15 * s + 6 * s * s)


@pytest.mark.parametrize("rotation", [False, True])
def test_translated_wall_moves_the_layer_rigidly(tmp_path_factory, rotation):
    case = run(tmp_path_factory, "translate", rotation)
    p0, wall = points0_and_wall(case)
    r = np.min(np.linalg.norm(p0[:, None, :] - p0[wall][None, :, :], axis=2), axis=1)
    for step in range(1, N_STEPS + 1):
        t = step * DT
        shift = np.array(AMPLITUDE) * np.sin(OMEGA * t)
        d = read_points(case / _tname(step) / "polyMesh" / "points") - p0
        near = r < INNER
        assert near.sum() > 2 * len(wall)          # the wall and the layer above it
        np.testing.assert_allclose(d[near], np.broadcast_to(shift, d[near].shape),
                                   rtol=0, atol=1e-12)
        # (2D: twoDPointCorrector re-snaps the points to the planes, round-off only)
        np.testing.assert_allclose(d[r >= OUTER], 0.0, rtol=0, atol=1e-12)
        np.testing.assert_allclose(d, _phi(r)[:, None] * shift, rtol=0, atol=1e-12)


def _rotated(p0, angle):
    c, s = np.cos(angle), np.sin(angle)
    return np.stack([c * p0[:, 0] - s * p0[:, 1], s * p0[:, 0] + c * p0[:, 1], p0[:, 2]], axis=1)


@pytest.mark.parametrize("rotation", [True, False])
def test_rotated_wall_turns_the_layer_with_it(tmp_path_factory, rotation):
    case = run(tmp_path_factory, "rotate", rotation)
    p0, wall = points0_and_wall(case)
    r = np.min(np.linalg.norm(p0[:, None, :] - p0[wall][None, :, :], axis=2), axis=1)
    near = r < INNER
    worst = 0.0
    for step in range(1, N_STEPS + 1):
        angle = ANGLE * np.sin(OMEGA * step * DT)
        pts = read_points(case / _tname(step) / "polyMesh" / "points")
        np.testing.assert_allclose(pts[wall], _rotated(p0[wall], angle), rtol=0, atol=1e-12)
        worst = max(worst, np.abs(pts[near] - _rotated(p0[near], angle)).max())
        np.testing.assert_allclose(pts[r >= OUTER], p0[r >= OUTER], rtol=0, atol=1e-12)
    if rotation:
        assert worst < 1e-9
    else:
        # displacement blending translates the layer's outer points with their wall point:
        # the layer shears by the angle (here up to 0.4 rad * 0.06 m ~ 1 cm off)
        assert worst > 1e-3



#: ``rotationInner``: the rotation in full only this close to the wall (the first rows of the
#: layer, about 0.01 m each), still blended out by ROT
ROT_INNER = 0.02


def test_rotation_inner_limits_the_rigid_turn(tmp_path_factory):
    """With ``rotationInner`` below innerDistance the points within it turn rigidly with the
    wall, those between it and innerDistance do not (psi < 1 there: they shear part way)."""
    case = tmp_path_factory.mktemp("motion-rotation-inner")
    make_case(case, "rotate", True, check=f"rotationInner {ROT_INNER};")
    T.run_utility(case, ["blockMesh"])
    _pimple(case, 1, "pimpleFoam")
    p0, wall = points0_and_wall(case)
    r = np.min(np.linalg.norm(p0[:, None, :] - p0[wall][None, :, :], axis=2), axis=1)
    inside = (r > 0) & (r < ROT_INNER)
    band = (r > ROT_INNER + 0.005) & (r < INNER)
    assert inside.sum() > len(wall) and band.sum() > len(wall)
    rigid, band_off = 0.0, 0.0
    for step in range(1, N_STEPS + 1):
        angle = ANGLE * np.sin(OMEGA * step * DT)
        pts = read_points(case / _tname(step) / "polyMesh" / "points")
        rigid = max(rigid, np.abs(pts[inside] - _rotated(p0[inside], angle)).max())
        band_off = max(band_off, np.abs(pts[band] - _rotated(p0[band], angle)).max())
    assert rigid < 1e-9
    assert band_off > 1e-4


@pytest.mark.parametrize("entry, says", [
    (f"rotationInner {ROT + 0.1};", "rotationInner < rotationDistance"),
    ("rotationNeighbours 2;", "rotationNeighbours >= 3"),
])
def test_bad_rotation_coefficients_are_refused(tmp_path, entry, says):
    case = tmp_path / "bad"
    make_case(case, "rotate", True, check=entry)
    T.run_utility(case, ["blockMesh"])
    with pytest.raises(SolverRunError):
        T.run_utility(case, ["pimpleFoam"], log_name="pimpleFoam")
    assert says in (case / "log.pimpleFoam").read_text()


#: ``shell``: the area-weighted blend within (1 + SHELL) times the distance to the wall
SHELL = 0.5


def _run_shell(tmp_path_factory, ranks: int):
    case = tmp_path_factory.mktemp(f"motion-shell-{ranks}")
    make_case(case, "rotate", False, check=f"shell {SHELL};")
    T.run_utility(case, ["blockMesh"])
    if ranks > 1:
        T.run_utility(case, ["decomposePar"])
    _pimple(case, ranks, "pimpleFoam")
    if ranks > 1:
        T.run_utility(case, ["reconstructPar", "-latestTime"])
    return case


@pytest.mark.parametrize("ranks", [1, 2])
def test_a_shell_moves_a_point_near_the_wall_with_its_foot_point_alone(tmp_path_factory,
                                                                         ranks):
    """With ``shell``, a point within innerDistance whose second-nearest wall point lies beyond
    (1 + shell) times its nearest follows that nearest wall point exactly: the layer above a
    rotating wall takes each wall point's own displacement (without the shell it takes a
    blend of its K nearest, above). On two ranks, where the square is split and the wall
    points on the cut get their area from both ranks, the mesh is the serial one."""
    if ranks > 1 and shutil.which("mpirun") is None:
        pytest.skip("mpirun is not on PATH")
    case = _run_shell(tmp_path_factory, ranks)
    p0, wall = points0_and_wall(case)
    dist = np.linalg.norm(p0[:, None, :] - p0[wall][None, :, :], axis=2)
    order = np.argsort(dist, axis=1)
    r1 = np.take_along_axis(dist, order[:, :1], axis=1)[:, 0]
    r2 = np.take_along_axis(dist, order[:, 1:2], axis=1)[:, 0]
    # off the wall, phi = 1, the foot point alone in the shell (the 2D mesh's two planes:
    # the foot point is the wall point in the same plane)
    alone = (r1 > 0) & (r1 < INNER) & (r2 > (1 + SHELL) * r1 * (1 + 1e-9))
    assert alone.sum() > len(wall) // 2
    foot = wall[order[alone, 0]]
    t = _tname(N_STEPS)
    d = read_points(case / t / "polyMesh" / "points") - p0
    np.testing.assert_allclose(d[alone], d[foot], rtol=0, atol=1e-12)
    if ranks > 1:
        serial = _run_shell(tmp_path_factory, 1)
        np.testing.assert_allclose(read_points(case / t / "polyMesh" / "points"),
                                   read_points(serial / t / "polyMesh" / "points"),
                                   rtol=0, atol=1e-12)


@pytest.mark.parametrize("ranks", [1, 2])
def test_restart_from_an_odd_step_reproduces_the_mesh_and_flow(tmp_path_factory, ranks):
    if ranks > 1 and shutil.which("mpirun") is None:
        pytest.skip("mpirun is not on PATH")
    straight = run(tmp_path_factory, "rotate", True, ranks)
    resumed = run(tmp_path_factory, "rotate", True, ranks, restart=True)
    procs = [""] if ranks == 1 else ["processor0", "processor1"]
    for proc in procs:
        for step in range(RESTART_STEP + 1, N_STEPS + 1):
            t = _tname(step)
            a, b = straight / proc / t, resumed / proc / t
            np.testing.assert_allclose(read_points(b / "polyMesh" / "points"),
                                       read_points(a / "polyMesh" / "points"), rtol=0, atol=1e-9)
            np.testing.assert_allclose(read_vector_field(b / "U"), read_vector_field(a / "U"),
                                       rtol=0, atol=1e-9)
    if ranks > 1:
        # the two ranks' mesh is the serial one
        serial = run(tmp_path_factory, "rotate", True, 1)
        T.run_utility(straight, ["reconstructPar", "-latestTime"])
        t = _tname(N_STEPS)
        np.testing.assert_allclose(read_points(straight / t / "polyMesh" / "points"),
                                   read_points(serial / t / "polyMesh" / "points"),
                                   rtol=0, atol=1e-12)


def _first_invalid_time(log_text: str) -> str | None:
    """The first ``Time =`` whose moved mesh OpenFOAM's own check (polyMesh debug) found
    invalid."""
    t = None
    for line in log_text.splitlines():
        if line.startswith("Time = "):
            t = line.split()[-1]
        elif "***" in line:
            return t
    return None


@pytest.mark.parametrize("ranks", [1, 2])
def test_the_motion_check_stops_the_run_before_the_mesh_inverts(tmp_path, ranks):
    if ranks > 1 and shutil.which("mpirun") is None:
        pytest.skip("mpirun is not on PATH")
    solver = ["pimpleFoam", "-debug-switch", "polyMesh=1"]         # as run-case runs it
    # without the check: the first step with an invalid mesh, moved into and computed on
    off = tmp_path / "off"
    make_case(off, "translate", False, amplitude=INVERTING, check="checkMotion no;")
    T.run_utility(off, ["blockMesh"])
    T.run_utility(off, solver, log_name="pimpleFoam")
    invalid = _first_invalid_time((off / "log.pimpleFoam").read_text())
    assert invalid == _tname(INVERTED_STEP)
    assert (off / invalid / "polyMesh" / "points").is_file()

    # with the check (the default): stopped at that step's mesh update, before moving
    on = tmp_path / "on"
    make_case(on, "translate", False, amplitude=INVERTING)
    T.run_utility(on, ["blockMesh"])
    if ranks > 1:
        T.run_utility(on, ["decomposePar"])
        solver = ["mpirun", "--allow-run-as-root", "--oversubscribe", "-np", "2", *solver,
                  "-parallel"]
    with pytest.raises(SolverRunError, match="failed"):
        T.run_utility(on, solver, log_name="pimpleFoam")
    log = (on / "log.pimpleFoam").read_text()
    assert "***" not in log                                        # never moved into it
    fatal = LG.fatal_error(log)
    stop = LG.motion_check_stop(fatal)
    assert stop is not None, fatal
    t, what = stop.time, stop.reason
    assert t == float(invalid)
    # what OpenFOAM's own check says of that mesh, counted alike (over both ranks)
    assert "cell volumes: 15 cells of zero or negative volume" in what
    assert "face pyramids: 91 faces incorrectly oriented" in what
    written = _tname(INVERTED_STEP - 1)
    assert f"The mesh of the latest written time, t = {written} s, is valid" in fatal
    assert "centre at (" in fatal and "What to do:" in fatal
    folders = [on] if ranks == 1 else sorted(on.glob("processor*"))
    for folder in folders:
        times = sorted(float(d.name) for d in folder.iterdir() if _is_time(d.name))
        assert times[-1] == float(written) < t
    if ranks > 1:
        T.run_utility(on, ["reconstructPar", "-latestTime"])
    T.run_utility(on, ["checkMesh", "-time", written])
    assert "Mesh OK." in (on / "log.checkMesh").read_text()


def _is_time(name: str) -> bool:
    try:
        float(name)
    except ValueError:
        return False
    return True


_PLUGIN_FIGURES = re.compile(r"the new mesh: Min volume = (\S+)\. Total volume = (\S+)\. Mesh "
                             r"non-orthogonality Max: (\S+) average: (\S+) \((\d+) of (\d+) "
                             r"cells moved\)")


@pytest.mark.parametrize("ranks", [1, 2])
def test_the_motion_check_prints_the_figures_of_openfoams_own_check(tmp_path, ranks):
    """The check computes only the cells that move (and their faces), yet prints the smallest
    cell volume and the largest non-orthogonality of the whole new mesh: the figures OpenFOAM's
    own check (polyMesh debug, after the move) prints for the same mesh, every step; so run-case
    can leave that second check out. The total volume and the mean non-orthogonality, sums over
    every cell and face, also agree: a cell or face of the moving part left out would keep its
    old value and change them."""
    if ranks > 1 and shutil.which("mpirun") is None:
        pytest.skip("mpirun is not on PATH")
    case = tmp_path / "case"
    make_case(case, "translate", False)
    T.run_utility(case, ["blockMesh"])
    solver = ["pimpleFoam", "-debug-switch", "polyMesh=1"]
    if ranks > 1:
        T.run_utility(case, ["decomposePar"])
        solver = ["mpirun", "--allow-run-as-root", "--oversubscribe", "-np", "2", *solver,
                  "-parallel"]
    T.run_utility(case, solver, log_name="pimpleFoam")
    log = (case / "log.pimpleFoam").read_text()
    ours = [(float(v), float(t), float(a), float(m), int(n), int(c))
            for v, t, a, m, n, c in _PLUGIN_FIGURES.findall(log)]
    vols = re.findall(r"^\s*Min volume = (\S+?)\. .*Total volume = (\S+?)\.\s", log, re.M)
    angles = re.findall(r"^\s*Mesh non-orthogonality Max: (\S+) average: (\S+)", log, re.M)
    theirs = [v + a for v, a in zip(vols, angles, strict=True)]
    assert len(ours) == N_STEPS == len(theirs)
    for (*figures, moved, cells), other in zip(ours, theirs, strict=True):
        assert 0 < moved < cells == 888                   # a part of the mesh, not all of it
        assert figures == pytest.approx([float(x) for x in other], rel=1e-9)
    assert len({a for _, _, a, _, _, _ in ours}) > 1    # the figures follow the motion
    # and the log watch reads them (one line holds both)
    watch = LG.LogWatch(case / "log.pimpleFoam")
    for line in (f"whaleBlendedDisplacement: {m.group(0)}" for m in _PLUGIN_FIGURES.finditer(log)):
        watch.feed(line)
    assert watch.min_volume == min(f[0] for f in ours)
    assert watch.max_non_orth == max(f[2] for f in ours)
