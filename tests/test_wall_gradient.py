"""The viscous force from grad(U) of the wall's cells only (the plugin's class wallGradient)
against OpenFOAM's own fvc::grad(U) of the whole mesh, in a real pimpleFoam run.

A 3D channel (630 cells, blockMesh: two blocks of different cell sizes, graded towards the
wall, so the interpolation weights are not 1/2) whose lower wall is two patches in the group
``whale``: ``still`` (at rest) upstream and ``sliding`` (moving at -1 m/s against the 1 m/s
inflow) downstream, a sharp jump of the wall's velocity in the middle; the side planes are
``symmetryPlane``. grad(U) is ``cellLimited Gauss linear 1`` and the limiter is active (fv's
debug line gives its smallest value). Two whaleLoads function objects run side by side on the
same patches: ``cells`` (the default, the wall cells' gradient) and ``whole`` (``gradient
whole;``: fvc::grad of the whole mesh, as devReff computes it). Their viscous forces, total
and per patch, are equal at every step, to the bit, serial and on 2 ranks (the ranks' split
crosses the wall, so wall cells have processor faces: the neighbour values across them come
from U's processor patches, with no communication). A grad(U) scheme the wall cells do not
reproduce stops the run with a message naming the two it does.

Skipped without pimpleFoam or without the built library (scripts/build_plugin.sh).
"""

from __future__ import annotations

import re
import shutil

import numpy as np
import pytest

from adapter.errors import SolverRunError
from adapter.foam import case as C
from adapter.foam import tools as T

from .channel_case import FV_SCHEMES, HEADER, fv_solution, write_files
from .conftest import NEEDS_FOAM_AND_PLUGIN

pytestmark = [*NEEDS_FOAM_AND_PLUGIN]

DT = 0.01
N_STEPS = 10
PATCHES = ["still", "sliding"]
GRAD_U = "cellLimited Gauss linear 1"

# x: two blocks of 12 and 9 cells (0.5 and 2 grading: unequal cells at x = 1), y: 10 cells
# graded 4 away from the wall, z: 3 cells
_VERTS = [(x, y, z) for z in (0, 0.2) for y in (0, 0.5) for x in (0, 1, 2)]


def _v(i: int, j: int, k: int) -> int:
    return k * 6 + j * 3 + i


def _quad(*corners) -> str:
    return "(" + " ".join(str(_v(*c)) for c in corners) + ")"


def _block_mesh() -> str:
    blocks = []
    for i, (n, grading) in enumerate(((12, 0.5), (9, 2.0))):
        c = [_v(i, 0, 0), _v(i + 1, 0, 0), _v(i + 1, 1, 0), _v(i, 1, 0)]
        blocks.append(f"hex ({' '.join(map(str, c + [v + 6 for v in c]))}) ({n} 10 3) "
                      f"simpleGrading ({grading} 4 1)")
    wall = [_quad((i, 0, 0), (i + 1, 0, 0), (i + 1, 0, 1), (i, 0, 1)) for i in (0, 1)]
    patches = {
        "inlet": ("patch", "", [_quad((0, 0, 0), (0, 0, 1), (0, 1, 1), (0, 1, 0))]),
        "outlet": ("patch", "", [_quad((2, 0, 0), (2, 1, 0), (2, 1, 1), (2, 0, 1))]),
        "top": ("patch", "", [_quad((i, 1, 0), (i, 1, 1), (i + 1, 1, 1), (i + 1, 1, 0))
                              for i in (0, 1)]),
        "still": ("wall", "inGroups (whale);", [wall[0]]),
        "sliding": ("wall", "inGroups (whale);", [wall[1]]),
        "back": ("symmetryPlane", "", [_quad((i, 0, 0), (i, 1, 0), (i + 1, 1, 0), (i + 1, 0, 0))
                                       for i in (0, 1)]),
        "front": ("symmetryPlane", "", [_quad((i, 0, 1), (i + 1, 0, 1), (i + 1, 1, 1),
                                               (i, 1, 1)) for i in (0, 1)]),
    }
    boundary = "\n".join(f"{name} {{ type {kind}; {extra} faces ({' '.join(faces)}); }}"
                         for name, (kind, extra, faces) in patches.items())
    verts = " ".join(f"({x} {y} {z})" for x, y, z in _VERTS)
    return (HEADER.format(cls="dictionary", obj="blockMeshDict")
            + f"convertToMeters 1;\nvertices ({verts});\nblocks ({' '.join(blocks)});\n"
            + f"edges ();\nboundary (\n{boundary}\n);\nmergePatchPairs ();\n")


def _loads(name: str, extra: str, lib) -> str:
    return f"""
    {name}
    {{
        type whaleLoads; libs ("{lib}"); patches (whale); rhoInf 1025;
        writeControl timeStep; writeInterval 1; writePrecision 17; log false; {extra}
    }}"""


def _control(lib) -> str:
    return (HEADER.format(cls="dictionary", obj="controlDict") + f"""
application pimpleFoam; startFrom startTime; startTime 0; stopAt endTime;
endTime {N_STEPS * DT}; deltaT {DT}; writeControl timeStep; writeInterval {N_STEPS};
writeFormat ascii; writePrecision 16; timeFormat general; timePrecision 6;
runTimeModifiable false;
DebugSwitches {{ fv 1; }}   // cellLimitedGrad's line: the limiter's extremes
functions
{{{_loads("cells", "", lib)}{_loads("whole", "gradient whole;", lib)}
}}
""")


_FIELDS = {
    "0/U": ("volVectorField", """
dimensions [0 1 -1 0 0 0 0]; internalField uniform (1 0 0);
boundaryField
{
    inlet { type fixedValue; value uniform (1 0 0); }
    outlet { type inletOutlet; inletValue uniform (0 0 0); value uniform (1 0 0); }
    top { type slip; }
    still { type movingWallVelocity; value uniform (0 0 0); }
    sliding { type fixedValue; value uniform (-1 0 0); }
    "(back|front)" { type symmetryPlane; }
}
"""),
    "0/p": ("volScalarField", """
dimensions [0 2 -2 0 0 0 0]; internalField uniform 0;
boundaryField
{
    outlet { type fixedValue; value uniform 0; }
    "(inlet|top|still|sliding)" { type zeroGradient; }
    "(back|front)" { type symmetryPlane; }
}
"""),
    "constant/transportProperties": ("dictionary", "transportModel Newtonian; nu 0.01;\n"),
    "constant/turbulenceProperties": ("dictionary", "simulationType laminar;\n"),
    "system/fvSolution": ("dictionary", fv_solution(1e-8, 0.01)),
    "system/decomposeParDict": ("dictionary",
                                "numberOfSubdomains 2; method simple;\n"
                                "coeffs { n (2 1 1); }   // the split crosses the wall\n"),
}


def _schemes(grad_u: str) -> str:
    return FV_SCHEMES.replace("gradSchemes { default Gauss linear; }",
                              f"gradSchemes {{ default Gauss linear; grad(U) {grad_u}; }}")


def make_channel(case, grad_u: str = GRAD_U, lib=C.PLUGIN_LIB) -> None:
    write_files(case, {**_FIELDS, "system/fvSchemes": ("dictionary", _schemes(grad_u))})
    (case / "system" / "blockMeshDict").write_text(_block_mesh())
    (case / "system" / "controlDict").write_text(_control(lib))


def run_channel(case, ranks: int = 1) -> str:
    """Mesh and run; the solver's log."""
    T.run_utility(case, ["blockMesh"])
    if ranks == 1:
        return T.run_utility(case, ["pimpleFoam"]).read_text()
    T.run_utility(case, ["decomposePar"])
    return T.run_utility(case, ["mpirun", "--allow-run-as-root", "--oversubscribe", "-np",
                                str(ranks), "pimpleFoam", "-parallel"],
                         log_name="pimpleFoam").read_text()


def read_loads(case, name: str) -> tuple[list, np.ndarray]:
    """The column names and rows of postProcessing/<name>/0/loads.dat."""
    lines = (case / "postProcessing" / name / "0" / "loads.dat").read_text().splitlines()
    names = [s for s in lines if s.startswith("#")][-1][1:].split()
    rows = np.array([[float(v) for v in s.split()] for s in lines if s and s[0] != "#"])
    return names, rows


@pytest.fixture(scope="module", params=[1, 2], ids=["serial", "2-ranks"])
def channel(request, tmp_path_factory):
    if request.param > 1 and shutil.which("mpirun") is None:
        pytest.skip("mpirun is not on PATH")
    case = tmp_path_factory.mktemp(f"wall-gradient-{request.param}")
    make_channel(case)
    log = run_channel(case, request.param)
    return log, read_loads(case, "cells"), read_loads(case, "whole")


def test_the_limiter_is_active(channel):
    log, _, _ = channel
    # cellLimitedGrad's extremes of its limiter, one per component of U
    found = re.findall(r"gradient limiter for: U max = \([^)]*\) min = \(([^)]*)\)", log)
    assert len(found) >= N_STEPS
    assert min(float(v) for m in found for v in m.split()) < 0.5    # measured 0


def test_the_wall_cells_gradient_gives_the_whole_mesh_viscous_force(channel):
    log, (names, rows), (names_w, rows_w) = channel
    assert names == names_w
    assert rows.shape == (N_STEPS, len(names))
    assert "grad(U) of the patch cells" in log and "grad(U) of the whole mesh" in log
    for group in ["total"] + PATCHES:
        fv = rows[:, [names.index(f"{group}:Fv{a}") for a in "xy"]]
        fv_whole = rows_w[:, [names.index(f"{group}:Fv{a}") for a in "xy"]]
        assert np.abs(fv_whole[:, 0]).min() > 1.0, group         # N: a real shear force
        # the same operations in the same order: equal to the bit
        np.testing.assert_array_equal(fv, fv_whole, err_msg=group)
    # the pressure parts and the areas never depended on grad(U)
    np.testing.assert_array_equal(rows, rows_w)


def test_a_scheme_the_wall_cells_do_not_reproduce_is_refused(tmp_path):
    make_channel(tmp_path, grad_u="cellLimited Gauss linear 0.5")
    with pytest.raises(SolverRunError):
        run_channel(tmp_path)
    log = (tmp_path / "log.pimpleFoam").read_text()
    assert ("reproduces the gradSchemes grad(U) 'cellLimited Gauss linear 1' and 'Gauss "
            "linear' only, not 'cellLimited Gauss linear 0.5'") in log
