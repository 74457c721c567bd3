"""whaleBlendedDisplacement's clusters (``clusters f``) in real pimpleFoam runs, against the blend
the motion solver's documentation defines, computed here from the mesh's points alone.

The channel of tests/test_motion.py, its square's left and right sides meshed six times finer
than its top and bottom (48 faces against 8), rotated about its centre. The blend's definition
(patchBlendWeights.H): a point at distance r_1 from the wall takes the area-weighted mean of the
wall's displacement with weights 1/r^p - 1/R^p over every wall point within R = (1 + shell) r_1,
times phi(r_1). With its K = 32 nearest wall points, a point off a corner reaches only the finely
meshed side, a sliver of that shell; with clusters (f = 1/8) its sources are groups of wall
points about r_1 / 8 across and span it. Checked: with clusters the points between 0.06 and
0.9 m from the wall (the wall points themselves, then every cluster level) move as the
definition says to within 2.5 % of the displacement there (measured: 1.7 %); without them,
up to 70 % off; on two ranks the mesh is the serial one; a cluster fraction without a shell is
refused.
"""

from __future__ import annotations

import shutil

import numpy as np
import pytest

from adapter.errors import SolverRunError
from adapter.foam import tools as T
from adapter.foam.foamascii import read_boundary, read_faces, read_points

from . import test_motion as TM
from .conftest import NEEDS_FOAM_AND_PLUGIN

pytestmark = [*NEEDS_FOAM_AND_PLUGIN]

SHELL, POWER, FRACTION, K = 0.5, 3.0, 0.125, 32
#: the square's left and right sides in 48 faces, its top and bottom in 8
FINE_SIDES = (10, 48, 10)


def _run(tmp_path_factory, monkeypatch, clusters: float, ranks: int = 1):
    case = tmp_path_factory.mktemp(f"clusters-{clusters}-{ranks}")
    monkeypatch.setattr(TM, "_NY", FINE_SIDES)
    entries = f"shell {SHELL}; nNeighbours {K};" + (f" clusters {clusters};" if clusters else "")
    TM.make_case(case, "rotate", False, check=entries)
    T.run_utility(case, ["blockMesh"])
    if ranks > 1:
        T.run_utility(case, ["decomposePar"])
    TM._pimple(case, ranks, "pimpleFoam")
    if ranks > 1:
        T.run_utility(case, ["reconstructPar", "-latestTime"])
    return case


def _defined_blend(case):
    """(points, r_1, the displacement the definition gives, the one the run gave) at the last
    step, for every point off the wall."""
    mesh = case / "constant" / "polyMesh"
    p0 = read_points(mesh / "points")
    faces = read_faces(mesh / "faces")
    b = read_boundary(mesh / "boundary")["whale"]
    wall_faces = faces[b["startFace"]:b["startFace"] + b["nFaces"]]
    wall = np.unique(np.concatenate(wall_faces))
    slot = {g: i for i, g in enumerate(wall)}
    area = np.zeros(len(wall))
    for f in wall_faces:               # each wall point: a share of every face around it
        c = p0[f].mean(axis=0)
        a = 0.5 * np.linalg.norm(sum(np.cross(p0[f[k]] - c, p0[f[(k + 1) % len(f)]] - c)
                                     for k in range(len(f))))
        for g in f:
            area[slot[g]] += a / len(f)
    d = read_points(case / TM._tname(TM.N_STEPS) / "polyMesh" / "points") - p0
    off = np.setdiff1d(np.arange(len(p0)), wall)
    r = np.linalg.norm(p0[off, None, :] - p0[wall][None, :, :], axis=2)
    r1 = r.min(axis=1)
    R = (1 + SHELL) * r1[:, None]
    w = np.clip(r ** -POWER - R ** -POWER, 0, None) * area[None, :]
    defined = TM._phi(r1)[:, None] * (w @ d[wall]) / w.sum(axis=1)[:, None]
    return p0[off], r1, defined, d[off]


@pytest.fixture(scope="module")
def monkeymodule():
    with pytest.MonkeyPatch.context() as mp:
        yield mp


@pytest.fixture(scope="module")
def with_clusters(tmp_path_factory, monkeymodule):
    return _run(tmp_path_factory, monkeymodule, FRACTION)


def test_clusters_give_the_defined_blend_where_the_wall_is_meshed_unevenly(
        tmp_path_factory, monkeymodule, with_clusters):
    errors = {}
    for name, case in (("clusters", with_clusters),
                       ("points", _run(tmp_path_factory, monkeymodule, 0.0))):
        _, r1, defined, got = _defined_blend(case)
        far = (r1 > 0.06) & (r1 < 0.9)
        assert far.sum() > 100
        scale = np.linalg.norm(defined[far], axis=1)
        errors[name] = np.max(np.linalg.norm(got[far] - defined[far], axis=1) / scale)
    assert errors["clusters"] < 0.025, errors
    assert errors["points"] > 10 * errors["clusters"], errors


def test_clusters_on_two_ranks_move_the_mesh_as_on_one(tmp_path_factory, monkeymodule,
                                                       with_clusters):
    if shutil.which("mpirun") is None:
        pytest.skip("mpirun is not on PATH")
    two = _run(tmp_path_factory, monkeymodule, FRACTION, ranks=2)
    t = TM._tname(TM.N_STEPS)
    np.testing.assert_allclose(read_points(two / t / "polyMesh" / "points"),
                               read_points(with_clusters / t / "polyMesh" / "points"),
                               rtol=0, atol=1e-12)


def test_clusters_without_a_shell_are_refused(tmp_path):
    TM.make_case(tmp_path, "rotate", False, check="clusters 0.25;")
    T.run_utility(tmp_path, ["blockMesh"])
    with pytest.raises(SolverRunError):
        T.run_utility(tmp_path, ["pimpleFoam"], log_name="pimpleFoam")
    assert "clusters >= 0 (> 0 only with a shell > 0)" in (tmp_path / "log.pimpleFoam").read_text()
