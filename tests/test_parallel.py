"""run-case on several ranks (adapter.foam.parallel, docs/cluster.md): the launcher, the user's
decomposition, parallel meshing and reconstruction on request. The OpenFOAM tests run the smoke
preset on 2 ranks."""

import argparse
import os
import shutil
import stat

import pytest

from adapter.errors import CaseError
from adapter.foam import case as C
from adapter.foam import dictionaries as D
from adapter.foam import folders as F
from adapter.foam import mesh as M
from adapter.foam import parallel as P
from adapter.foam import run as R
from adapter.foam.parallel import (
    DEFAULT_LAUNCHER,
    launcher_words,
    machine_cores,
    parallel_command,
    ranks_option,
)
from adapter.scene import Scene, load_scene

from .conftest import needs_foam_and_plugin


def _decomposition(case):
    d = D.parsed_dict(case / "system" / "decomposeParDict")
    coeffs = d["coeffs"] if "coeffs" in d else {}
    n = [int(v) for v in coeffs["n"]] if "n" in coeffs else None
    return int(d["numberOfSubdomains"]), str(d["method"]), n


def _write_simple_121(case):
    d = D.parsed_dict(case / "system" / "decomposeParDict")
    d["method"] = "simple"
    d["coeffs"] = {"n": "(1 2 1)", "delta": 0.001}
    d.writeFile()


# -- the launcher ------------------------------------------------------------------------------

def test_the_default_launcher_is_this_machines_mpirun():
    assert launcher_words(None, 4) == ["mpirun", "--allow-run-as-root", "--oversubscribe",
                                       "-np", "4"]
    assert launcher_words("", 2, token=True)[-2:] == ["-x", "WHALE_ADAPTER_TOKEN"]
    assert parallel_command(["pimpleFoam"], 2)[-2:] == ["pimpleFoam", "-parallel"]
    assert "{np}" in DEFAULT_LAUNCHER


# -- how many ranks by default ----------------------------------------------------------------

def test_the_machines_cores_are_the_affinity_within_the_cgroups_quota(tmp_path, monkeypatch):
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0, 1, 2, 3})
    v2, v1 = tmp_path / "cpu.max", (tmp_path / "quota", tmp_path / "period")
    absent = (tmp_path / "no-quota", tmp_path / "no-period")
    assert machine_cores(tmp_path / "none", absent) == 4          # no cgroup files: 4 CPUs
    v2.write_text("max 100000\n")
    assert machine_cores(v2, absent) == 4                         # no limit
    v2.write_text("150000 100000\n")
    assert machine_cores(v2, absent) == 2                         # 1.5 CPUs: 2 ranks
    v2.write_text("800000 100000\n")
    assert machine_cores(v2, absent) == 4                         # more quota than CPUs
    v1[0].write_text("50000\n")
    v1[1].write_text("100000\n")
    assert machine_cores(tmp_path / "none", v1) == 1              # cgroup v1: half a CPU
    v1[0].write_text("-1\n")
    assert machine_cores(tmp_path / "none", v1) == 4              # v1 without a limit


def test_ranks_zero_and_np_auto_are_the_machines_cores(tmp_path, smoke_scene, smoke_surface,
                                                       monkeypatch):
    monkeypatch.setattr(P, "machine_cores", lambda: 3)
    assert P.resolve_ranks(0) == 3 and P.resolve_ranks(2) == 2
    params = C.prepare_case(smoke_scene.replace(case={"ranks": 0}), tmp_path / "c",
                            surface=smoke_surface)
    assert params.ranks == 3 and _decomposition(tmp_path / "c")[0] == 3
    assert ranks_option("auto") == 3 and ranks_option("2") == 2
    with pytest.raises(argparse.ArgumentTypeError, match="at least 1"):
        ranks_option("0")
    # the built-in default and the default scene are the machine's cores; smoke says 1
    assert Scene().case.ranks == 0 == load_scene(preset="default").case.ranks
    assert load_scene(preset="smoke").case.ranks == 1


def test_a_launcher_gets_np_substituted_or_appended():
    assert launcher_words("srun --mpi=pmix -n {np}", 8, token=True) == \
        ["srun", "--mpi=pmix", "-n", "8"]                      # srun passes the environment
    assert launcher_words("/opt/ompi/bin/mpirun --hostfile 'my hosts'", 3, token=True) == \
        ["/opt/ompi/bin/mpirun", "--hostfile", "my hosts", "-np", "3", "-x",
         "WHALE_ADAPTER_TOKEN"]
    with pytest.raises(CaseError, match="quote"):
        launcher_words("mpirun 'unclosed", 2)
    with pytest.raises(CaseError, match="empty"):
        launcher_words("   ", 2)


# -- the decomposition -------------------------------------------------------------------------

@pytest.mark.slow
def test_decompositions_written_and_kept(tmp_path, smoke_scene, smoke_surface):
    case = tmp_path / "case"
    C.prepare_case(smoke_scene, case, ranks=2, surface=smoke_surface)
    assert _decomposition(case) == (2, "hierarchical", [2, 1, 1])
    assert C.read_record(case)["parallel"] == {"launcher": "", "decomposition": "hierarchical",
                                               "parallel_meshing": False, "reconstruct": False}
    _write_simple_121(case)
    D.set_decomposition(case, 2, "case")                     # only numberOfSubdomains changes
    assert _decomposition(case) == (2, "simple", [1, 2, 1])
    with pytest.raises(CaseError, match=r"simple n \(1 2 1\) makes 2 subdomains, not the 3"):
        D.set_decomposition(case, 3, "case")
    D.set_decomposition(case, 3, "hierarchical")
    assert _decomposition(case) == (3, "hierarchical", [3, 1, 1])


def test_a_decomposition_file_is_copied_and_kept(tmp_path, smoke_surface):
    """case.decomposition names a file beside the scene file: copied in, recorded as "case"."""
    mine = tmp_path / "scene" / "decomposeParDict"
    mine.parent.mkdir()
    shutil.copy(C.TEMPLATE_DIR / "system" / "decomposeParDict", mine)
    d = D.parsed_dict(mine)
    d["method"] = "scotch"
    d.writeFile()
    scene_file = mine.parent / "mine.toml"
    scene_file.write_text('preset = "smoke"\n[case]\ndecomposition = "decomposeParDict"\n')
    case = tmp_path / "case"
    C.prepare_case(load_scene(scene_file), case, ranks=2, surface=smoke_surface)
    assert C.read_record(case)["parallel"]["decomposition"] == "case"
    assert _decomposition(case)[:2] == (2, "scotch")
    with pytest.raises(CaseError, match="neither one of"):
        D.choose_decomposition(case, "missing/decomposeParDict", tmp_path)


# -- OpenFOAM on 2 ranks -----------------------------------------------------------------------

@pytest.fixture(scope="module")
def serial_mesh(tmp_path_factory, smoke_scene, smoke_surface):
    case = tmp_path_factory.mktemp("parallel") / "serial"
    C.prepare_case(smoke_scene, case, ranks=2, surface=smoke_surface)
    M.mesh_case(case)
    return case


@needs_foam_and_plugin
@pytest.mark.slow
def test_two_ranks_give_the_serial_answer(tmp_path, serial_mesh):
    """The coupled smoke case on 1 and on 2 ranks (one link, the master gathering): the
    same loads to 1e-4 of their largest value at every step (measured: 2e-5; the decomposed
    pressure solve is not the serial one to the bit), the same mean drag to 1e-4."""
    from adapter.foam import loads as LD

    out = {}
    for n in (1, 2):
        case = tmp_path / f"np{n}"
        shutil.copytree(serial_mesh, case)
        out[n] = (R.run_case(case, ranks=n, progress=False, reconstruct=True),
                  LD.read_loads(case))
    (one, l1), (two, l2) = out[1], out[2]
    assert (one["ranks"], two["ranks"]) == (1, 2) and two["steps"] == one["steps"]
    assert two["drag_N"] == pytest.approx(one["drag_N"], rel=1e-4)
    assert l2["Time"] == pytest.approx(l1["Time"], rel=1e-12)
    for key in ("total:Fx", "total:Fz", "total:P"):
        scale = max(abs(v) for v in l1[key])
        assert [a - b for a, b in zip(l2[key], l1[key], strict=True)] == \
            pytest.approx([0.0] * len(l1[key]), abs=1e-4 * scale), key


@needs_foam_and_plugin
def test_parallel_meshing_gives_the_serial_mesh_within_a_few_percent(
        tmp_path, smoke_scene, smoke_surface, serial_mesh):
    case = tmp_path / "case"
    C.prepare_case(smoke_scene.replace(case={"parallel_meshing": True}), case, ranks=2,
                   surface=smoke_surface)
    info = M.mesh_case(case)
    serial = C.read_record(serial_mesh)["mesh"]
    assert info["meshed_on_ranks"] == 2 and serial["meshed_on_ranks"] == 1
    # the smoke mesh fails checkMesh's skewness check by one face, serial or parallel
    assert info["mesh_ok"] == serial["mesh_ok"] and info["whale_faces"] > 0
    assert info["max_non_orthogonality"] == pytest.approx(serial["max_non_orthogonality"],
                                                          abs=2.0)
    assert info["cells"] == pytest.approx(serial["cells"], rel=0.03)
    assert info["whale_faces"] == pytest.approx(serial["whale_faces"], rel=0.03)
    assert "snappyHexMesh" in (case / "log.snappyHexMesh").read_text() and \
        "-parallel" in (case / "log.snappyHexMesh").read_text()
    assert (case / "log.reconstructParMesh").is_file()
    assert F.processor_dirs(case) == []                 # the run decomposes the final mesh


@needs_foam_and_plugin
def test_a_launcher_and_a_user_decomposition_run_without_reconstruction(tmp_path, serial_mesh):
    case = tmp_path / "case"
    shutil.copytree(serial_mesh, case)
    record = C.read_record(case)
    record["parallel"]["decomposition"] = "case"
    C.write_json(case / C.CASE_RECORD, record)
    _write_simple_121(case)
    wrapper = tmp_path / "launch.sh"
    wrapper.write_text('#!/bin/sh\necho "$@" >> "$(dirname "$0")/launcher.log"\n'
                       'exec mpirun --allow-run-as-root --oversubscribe "$@"\n')
    wrapper.chmod(wrapper.stat().st_mode | stat.S_IXUSR)

    summary = R.run_case(case, ranks=2, progress=False, launcher=str(wrapper))
    assert summary["steps"] == record["parameters"]["n_steps"] and summary["ranks"] == 2
    called = (tmp_path / "launcher.log").read_text().split()
    assert called[:2] == ["-np", "2"] and called[2] == "pimpleFoam" and called[-1] == "-parallel"
    # the user's decomposition survived preparation and the run, and decomposePar used it
    assert _decomposition(case) == (2, "simple", [1, 2, 1])
    assert "simple" in (case / "log.decomposePar").read_text()
    # no reconstruction: the written times are in the processor folders only
    assert [t for t, _ in F.time_dirs(case)] == [0.0]
    assert not (case / "log.reconstructPar").exists()
    end = F.processor_latest(case)
    assert end == pytest.approx(summary["end_time_s"])
    # asked for, on a finished case: reconstructed, nothing run again
    again = R.run_case(case, ranks=2, progress=False, reconstruct=True)
    assert again == summary
    assert F.time_dirs(case)[-1][0] == pytest.approx(end)
    assert os.path.getsize(case / "log.reconstructPar") > 0
