"""The whale's frame and the loads' moments in real pimpleFoam runs (protocol version 3).

Two small 2D cases, each served by a real step-server in a thread (the body held still: the
scene's ``[rigid]`` motion with no amplitude, its surface a box on the whale patch):

- **The frame.** A straight channel, length L = 2 m, slip walls; the lower wall is the whale
  patch. The server's frame is U_f(t) = (U0 + A t, 0, 0), a_f = (A, 0, 0), and the case is
  switched to it by ``use_frame_inflow`` (inlet ``whaleFrameInletVelocity``, the
  ``whaleFrameAcceleration`` fvOption). Closed forms: the inlet's U at every written time is
  U_f(t); uniform flow accelerating uniformly at A needs no pressure gradient when the body
  force A acts (p = 0 everywhere), and without the fvOption the pressure drives it,
  dp/dx = -A (kinematic p): p(x) = A (L - x) with p = 0 at the outlet.
- **The moments.** The channel with a square hole off the origin (its four sides the whale
  patch), laminar flow past it. Every REQUEST's forces and moments about the origin equal what
  OpenFOAM's own ``forces`` function object (CofR (0 0 0)) wrote for the step before.

Skipped without pimpleFoam or without the built library (scripts/build_plugin.sh).
"""

from __future__ import annotations

import numpy as np
import pytest

from adapter.body.geometry import build_surface
from adapter.body.meshfile import write_surface
from adapter.coupling.frame import FixedFrame, FrameState
from adapter.foam import dictionaries as D
from adapter.foam import tools as T
from adapter.foam.foamascii import read_foam_text
from adapter.motion.rigid import RigidMotion
from adapter.scene import load_scene

from .channel_case import FV_SCHEMES, HEADER, flow_files, fv_solution, write_files
from .conftest import NEEDS_FOAM_AND_PLUGIN
from .wire_client import finished, server_starter

pytestmark = [*NEEDS_FOAM_AND_PLUGIN]

DT = 1 / 64                 # a binary fraction: the times are exact
N_STEPS = 4
U0, A = 1.0, 0.5            # m/s, m/s2: the frame's inflow and acceleration
LENGTH, HEIGHT, NX = 2.0, 0.5, 16
#: where the square of the moments' case sits: off the origin, so that r x F is not the moment
#: about its centre
SHIFT = np.array([0.6, 0.35, 0.0])


class RampFrame:
    """U_f = (U0 + A t, 0, 0), a_f = (A, 0, 0)."""

    def answer(self, time, request):
        return FrameState((U0 + A * time, 0.0, 0.0), (A, 0.0, 0.0))

    def state(self):
        return {}

    def restore(self, state):
        pass


class RecordingFrame(FixedFrame):
    """The tethered frame, keeping every REQUEST it is answered for."""

    def __init__(self, velocity):
        super().__init__(velocity)
        self.requests: list = []

    def answer(self, time, request):
        self.requests.append(request)
        return super().answer(time, request)


def _box_scene(folder, lo, hi):
    """A scene whose body is the box from ``lo`` to ``hi``, held still ([rigid], no amplitude),
    and its surface."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    corners = np.array([[(lo, hi)[i][0], (lo, hi)[j][1], (lo, hi)[k][2]]
                        for k in (0, 1) for j in (0, 1) for i in (0, 1)])
    quads = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    tris = np.array([t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))])
    write_surface(folder / "box.stl", corners, [tris])
    (folder / "box.toml").write_text(
        f'[geometry]\nsource = "box.stl"\nlength_m = {hi[0] - lo[0]}\n[rigid]\nenabled = true\n')
    scene = load_scene(folder / "box.toml")
    return scene, build_surface(scene)


def _control(lib, functions: str = "") -> str:
    return f"""
libs ("{lib}");
application pimpleFoam; startFrom startTime; startTime 0; stopAt endTime;
endTime {N_STEPS * DT}; deltaT {DT}; writeControl timeStep; writeInterval 1;
writeFormat ascii; writePrecision 17; timeFormat general; timePrecision 12;
runTimeModifiable false;
functions {{ {functions} }}
"""


def _dynamic_mesh(lib) -> str:
    return f"""
dynamicFvMesh dynamicMotionSolverFvMesh;
motionSolverLibs ("{lib}");
motionSolver whaleBlendedDisplacement;
whaleBlendedDisplacementCoeffs {{ patch whale; innerDistance 0.05; outerDistance 0.3; }}
"""


def _point_displacement(others: dict) -> str:
    value = {"empty": ""}
    rest = " ".join(f"{name} {{ type {kind}; {value.get(kind, 'value uniform (0 0 0);')} }}"
                    for name, kind in others.items())
    return f"""
dimensions [0 1 0 0 0 0 0]; internalField uniform (0 0 0);
boundaryField
{{
    whale {{ type stepServerDisplacement; rhoInf 1025; value uniform (0 0 0); }}
    {rest}
}}
"""


def _channel_block_mesh() -> str:
    verts = [(x, y, z) for z in (0, 0.1) for x, y in ((0, 0), (LENGTH, 0), (LENGTH, HEIGHT),
                                                       (0, HEIGHT))]
    return (HEADER.format(cls="dictionary", obj="blockMeshDict") + "convertToMeters 1;\n"
            + "vertices (" + " ".join(f"({x} {y} {z})" for x, y, z in verts) + ");\n"
            + f"blocks (hex (0 1 2 3 4 5 6 7) ({NX} 4 1) simpleGrading (1 1 1));\n"
            + "edges ();\nboundary (\n"
            + "inlet { type patch; faces ((0 4 7 3)); }\n"
            + "outlet { type patch; faces ((1 2 6 5)); }\n"
            + "whale { type wall; faces ((0 1 5 4)); }\n"
            + "walls { type patch; faces ((3 7 6 2)); }\n"
            + "frontAndBack { type empty; faces ((0 3 2 1) (4 5 6 7)); }\n"
            + ");\nmergePatchPairs ();\n")


def _channel_case(case, lib) -> None:
    u = U0
    fields = {
        "constant/transportProperties": ("dictionary", "transportModel Newtonian; nu 0.01;\n"),
        "constant/turbulenceProperties": ("dictionary", "simulationType laminar;\n"),
        "constant/dynamicMeshDict": ("dictionary", _dynamic_mesh(lib)),
        "system/controlDict": ("dictionary", _control(lib)),
        # upwind convection: linearUpwind's explicit correction sees the inlet's jump from
        # U_f(t_n) to U_f(t_(n+1)) as a gradient in the first cells (measured: p up to 2e-3 A L
        # there), which a uniformly accelerating flow does not have
        "system/fvSchemes": ("dictionary", FV_SCHEMES.replace("Gauss linearUpwind grad(U)",
                                                               "Gauss upwind")),
        # three outer correctors: with one, the convection of the first cells lags the inlet's
        # new velocity by the step (measured: p up to 3.2e-4 A L next to the inlet; 4e-9 with
        # three)
        "system/fvSolution": ("dictionary", fv_solution(1e-12, 0).replace(
            "nOuterCorrectors 1", "nOuterCorrectors 3")),
        "0/U": ("volVectorField", f"""
dimensions [0 1 -1 0 0 0 0]; internalField uniform ({u} 0 0);
boundaryField
{{
    inlet {{ type fixedValue; value uniform ({u} 0 0); }}
    outlet {{ type inletOutlet; inletValue uniform (0 0 0); value uniform ({u} 0 0); }}
    whale {{ type slip; }} walls {{ type slip; }} frontAndBack {{ type empty; }}
}}
"""),
        "0/p": ("volScalarField", """
dimensions [0 2 -2 0 0 0 0]; internalField uniform 0;
boundaryField
{
    inlet { type zeroGradient; } outlet { type fixedValue; value uniform 0; }
    whale { type zeroGradient; } walls { type zeroGradient; } frontAndBack { type empty; }
}
"""),
        "0/pointDisplacement": ("pointVectorField", _point_displacement(
            {"inlet": "fixedValue", "outlet": "fixedValue", "walls": "fixedValue",
             "frontAndBack": "empty"})),
    }
    write_files(case, fields)
    (case / "system" / "blockMeshDict").write_text(_channel_block_mesh())


def _run(case, scene, surface, frame):
    """blockMesh, then pimpleFoam served by a step-server with ``frame``."""
    T.run_utility(case, ["blockMesh"])
    start, stop_all = server_starter(scene, RigidMotion(scene, surface), first_client_timeout=60)
    try:
        srv = start(case, frame=frame)
        T.run_utility(case, ["pimpleFoam"])
        assert finished(srv) == 0
    finally:
        stop_all()


def _internal(path) -> np.ndarray:
    """The values of a written field's internalField (uniform or nonuniform), flat."""
    text = read_foam_text(path)
    i = text.index("internalField")
    head = text[i:i + 200]
    if "nonuniform" not in head:
        return np.array([float(head.split()[2].rstrip(";"))])
    start = text.index("(", text.index(">", i)) + 1
    body = text[start:text.index("\n)", start)]
    return np.array(body.replace("(", " ").replace(")", " ").split(), float)


def _patch_value(path, patch: str) -> np.ndarray:
    """The uniform value of a vector field's patch."""
    text = read_foam_text(path)
    block = text[text.index(patch, text.index("boundaryField")):]
    block = block[:block.index("}")]
    value = block[block.index("value"):]
    assert "nonuniform" not in value, value
    inner = value[value.index("(") + 1:value.index(")")]
    return np.array(inner.split(), float)


@pytest.fixture(scope="module")
def channel(tmp_path_factory):
    """The frame's channel run twice: {with the body force: case, without: case}."""
    runs = {}
    for force in (True, False):
        folder = tmp_path_factory.mktemp(f"frame-{'force' if force else 'noforce'}")
        scene, surface = _box_scene(folder, (0.0, -0.2, 0.0), (LENGTH, 0.0, 0.1))
        case = folder / "case"
        _channel_case(case, D.plugin_lib())
        D.use_frame_inflow(case)
        if not force:
            (case / "system" / "fvOptions").unlink()
        _run(case, scene, surface, RampFrame())
        runs[force] = case
    return runs


def _times(case) -> list:
    return [N * DT for N in range(1, N_STEPS + 1)
            if (case / format(N * DT, ".12g")).is_dir()]


def test_the_inlet_follows_the_frame_velocity(channel):
    for case in channel.values():
        times = _times(case)
        assert len(times) == N_STEPS
        for t in times:
            got = _patch_value(case / format(t, ".12g") / "U", "inlet")
            np.testing.assert_allclose(got, [U0 + A * t, 0, 0], rtol=1e-14, atol=1e-15)


def test_the_body_force_accelerates_the_flow_without_a_pressure_gradient(channel):
    """p = 0 with the body force (to 1e-7 A L); without it p(x) = A (L - x) at the cell
    centres: to 1e-6 A L in the downstream half, and to 2 % of A L next to the inlet, where the
    first cells' velocity, corrected by a one-sided pressure gradient (p zeroGradient at the
    inlet), lags the face fluxes (measured: 1.3e-2 A L in the first cell after 4 steps, 5e-7
    A L from the middle on). A body force of the wrong sign gives p = 2 A (L - x)."""
    x = (np.arange(NX) + 0.5) * LENGTH / NX
    half = x > LENGTH / 2
    for t in _times(channel[True]):
        folder = format(t, ".12g")
        with_force = _internal(channel[True] / folder / "p")
        np.testing.assert_allclose(with_force, 0.0, rtol=0, atol=1e-7 * A * LENGTH)
        without = _internal(channel[False] / folder / "p").reshape(4, NX)  # rows of NX cells
        closed = np.tile(A * (LENGTH - x), (4, 1))
        np.testing.assert_allclose(without[:, half], closed[:, half], rtol=0,
                                   atol=1e-6 * A * LENGTH)
        np.testing.assert_allclose(without, closed, rtol=0, atol=2e-2 * A * LENGTH)
        # and the whole flow moves at U_f (measured: 1.3e-9 m/s off after 4 steps)
        u = _internal(channel[True] / folder / "U").reshape(-1, 3)
        np.testing.assert_allclose(u, np.tile([U0 + A * t, 0, 0], (len(u), 1)), rtol=0,
                                   atol=1e-8 * U0)


# --- the moments ------------------------------------------------------------------------------

def _square_block_mesh() -> str:
    """The channel with the 0.5 m square hole, shifted by SHIFT; its four sides: ``whale``."""
    xs = np.array((-1.5, -0.25, 0.25, 3.0)) + SHIFT[0]
    ys = np.array((-1.5, -0.25, 0.25, 1.5)) + SHIFT[1]
    nx, ny = (10, 8, 16), (10, 8, 10)

    def v(i, j, k):
        return k * 16 + j * 4 + i

    def side(a, b):
        return f"({v(*a, 0)} {v(*b, 0)} {v(*b, 1)} {v(*a, 1)})"

    verts = " ".join(f"({x} {y} {z})" for z in (0, 0.1) for y in ys for x in xs)
    blocks, planes = [], []
    for j in range(3):
        for i in range(3):
            if (i, j) == (1, 1):
                continue
            c = [v(i, j, 0), v(i + 1, j, 0), v(i + 1, j + 1, 0), v(i, j + 1, 0)]
            blocks.append(f"hex ({' '.join(map(str, c + [n + 16 for n in c]))}) "
                          f"({nx[i]} {ny[j]} 1) simpleGrading (1 1 1)")
            planes += [f"({' '.join(map(str, c[::-1]))})", f"({' '.join(str(n + 16) for n in c)})"]
    patches = {
        "inlet": ("patch", [side((0, j), (0, j + 1)) for j in range(3)]),
        "outlet": ("patch", [side((3, j), (3, j + 1)) for j in range(3)]),
        "walls": ("patch", [side((i, 0), (i + 1, 0)) for i in range(3)]
                  + [side((i, 3), (i + 1, 3)) for i in range(3)]),
        "whale": ("wall", [side((1, 1), (1, 2)), side((2, 1), (2, 2)), side((1, 1), (2, 1)),
                           side((1, 2), (2, 2))]),
        "frontAndBack": ("empty", planes),
    }
    boundary = "\n".join(f"{n} {{ type {k}; faces ({' '.join(f)}); }}"
                         for n, (k, f) in patches.items())
    return (HEADER.format(cls="dictionary", obj="blockMeshDict")
            + f"convertToMeters 1;\nvertices ({verts});\nblocks ({' '.join(blocks)});\n"
            + f"edges ();\nboundary (\n{boundary}\n);\nmergePatchPairs ();\n")


FORCES = """
forces
{
    type forces; libs ("libforces.so"); patches (whale); rho rhoInf; rhoInf 1025;
    CofR (0 0 0); writeControl timeStep; writeInterval 1; log false;
}
"""


def _read_vectors(path) -> np.ndarray:
    """(T, 10) time, total, pressure, viscous vectors of a ``forces`` .dat file."""
    rows = [[float(v) for v in line.replace("(", " ").replace(")", " ").split()]
            for line in path.read_text().splitlines() if line and not line.startswith("#")]
    return np.array(rows)


@pytest.fixture(scope="module")
def square(tmp_path_factory):
    folder = tmp_path_factory.mktemp("frame-moments")
    lo, hi = SHIFT + (-0.25, -0.25, 0.0), SHIFT + (0.25, 0.25, 0.1)
    scene, surface = _box_scene(folder, lo, hi)
    case = folder / "case"
    lib = D.plugin_lib()
    write_files(case, {
        **flow_files("whale"),
        "constant/dynamicMeshDict": ("dictionary", _dynamic_mesh(lib)),
        "system/controlDict": ("dictionary", _control(lib, FORCES)),
        "system/fvSchemes": ("dictionary", FV_SCHEMES),
        "system/fvSolution": ("dictionary", fv_solution(1e-10, 0)),
        "0/pointDisplacement": ("pointVectorField", _point_displacement(
            {"inlet": "fixedValue", "outlet": "fixedValue", "walls": "slip",
             "frontAndBack": "empty"})),
    })
    (case / "system" / "blockMeshDict").write_text(_square_block_mesh())
    frame = RecordingFrame((1.0, 0.0, 0.0))
    _run(case, scene, surface, frame)
    post = case / "postProcessing" / "forces" / "0"
    return frame.requests, _read_vectors(post / "force.dat"), _read_vectors(post / "moment.dat")


def test_each_request_carries_the_forces_and_moments_openfoam_computed(square):
    """REQUEST(t_(n+1)) carries the loads of the fields at t_n: the forces function object's
    row of t_n, forces and moments about the origin, pressure and viscous parts apart."""
    requests, force, moment = square
    assert [r.time for r in requests] == [DT * n for n in range(1, N_STEPS + 1)]
    assert not requests[0].known()                       # a connection's first: NaN
    np.testing.assert_allclose(force[:, 0], [r.time for r in requests], rtol=1e-12)
    for r, f, m in zip(requests[1:], force[:-1], moment[:-1], strict=True):
        assert r.known()
        for got, want in ((r.pressure_force, f[4:7]), (r.viscous_force, f[7:10]),
                          (r.pressure_moment, m[4:7]), (r.viscous_moment, m[7:10])):
            scale = np.abs(f[1:4]).max() * np.abs(SHIFT).max()
            np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12 * scale)
        # the moment about the origin is not the one about the square's centre
        about_centre = m[1:4] - np.cross(SHIFT, f[1:4])
        assert np.abs(about_centre - m[1:4]).max() > 1e-3 * np.abs(m[1:4]).max()
        assert np.abs(r.viscous_force).max() > 1e-6 * np.abs(r.pressure_force).max()
