"""docs/cluster.md's SLURM batch script, run for real: a one-node SLURM cluster from Debian's
packages (scripts/install_slurm.sh: slurmctld, slurmd, munge; started here when they are not
running, stopped again after), the script taken from the doc as it stands, the smoke case
submitted with 2 tasks through sbatch (srun --mpi=pmix launches the ranks), and its figures
compared with the same case run directly on 2 ranks with this machine's mpirun."""

import json
import os
import re
import subprocess
import sys
import time
from pathlib import Path

import pytest

from .conftest import needs_foam_and_plugin

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "cluster.md"
INSTALL = ROOT / "scripts" / "install_slurm.sh"
#: the daemons install_slurm.sh starts, by their pid files
PID_FILES = [Path("/run/slurmd.pid"), Path("/run/slurmctld.pid"), Path("/run/munge/munged.pid")]
#: summary entries that are timings or the case's path, not figures of the flow
NOT_FIGURES = {"case", "step_s", "cpu_s_per_step", "flow_s_per_step", "adapter_s_per_step",
               "flow_wall_s", "wall_s"}
JOB_LIMIT_S = 900

def batch_script(doc=DOC):
    """The ```bash block of the doc's SLURM section, as the doc shows it."""
    text = doc.read_text()
    section = text[text.index("\n## SLURM"):]
    block = re.search(r"```bash\n(.*?)```", section, re.S)
    assert block, f"{doc}: no ```bash block in the SLURM section"
    return block.group(1)


def test_the_doc_has_one_batch_script_with_site_settings():
    script = batch_script()
    assert script.startswith("#!/bin/bash\n#SBATCH")
    assert "exec whale-adapter run-case" in script and '--np "$SLURM_NTASKS"' in script
    for name in ("WHALE_OPENFOAM", "WHALE_VENV", "WHALE_SCENE", "WHALE_CASE",
                 "WHALE_DECOMPOSITION", "WHALE_LAUNCHER", "WHALE_TOKEN_FILE"):
        assert f'"${{{name}:=' in script, name
    # bash keeps the {np} of the launcher's default (a brace inside ${...:=} would end it)
    out = subprocess.run(["bash", "-c", _settings(script) + 'printf %s "$WHALE_LAUNCHER"'],
                         capture_output=True, text=True, check=True,
                         env={"PATH": os.environ["PATH"], "HOME": "/nonexistent",
                              "SLURM_SUBMIT_DIR": "/x"})
    assert out.stdout == "srun --mpi=pmix -n {np}"


def _settings(script):
    """The script's lines up to its first command (the settings), for the check above."""
    return script[:script.index("eval ")]


def _alive(pid_file):
    """The pid file names a running process (a zombie is not: this init may not reap)."""
    try:
        status = Path(f"/proc/{int(pid_file.read_text())}/status").read_text()
    except (OSError, ValueError):
        return False
    return not re.search(r"^State:\s*Z", status, re.M)


@pytest.fixture(scope="module")
def slurm_cluster():
    """A one-node cluster taking jobs; the daemons this fixture started are stopped after."""
    before = {f for f in PID_FILES if _alive(f)}
    done = subprocess.run(["bash", str(INSTALL)], capture_output=True, text=True, timeout=900)
    if done.returncode != 0:
        reason = (done.stderr.strip().splitlines() or ["no message"])[-1]
        pytest.skip(f"no SLURM cluster here: {reason}")
    yield
    for f in PID_FILES:                      # slurmd, slurmctld, munged: the reverse of start
        if f not in before and _alive(f):
            os.kill(int(f.read_text()), 15)


def _job_state(job):
    out = subprocess.run(["scontrol", "-o", "show", "job", job], capture_output=True, text=True)
    fields = dict(w.split("=", 1) for w in out.stdout.split() if "=" in w)
    return fields.get("JobState", "UNKNOWN"), fields.get("ExitCode", "?")


def _submit_and_wait(script, workdir, env):
    job = subprocess.run(["sbatch", "--parsable", "--nodes=1", "--ntasks=2",
                          "--ntasks-per-node=2", "--time=15", f"--chdir={workdir}", str(script)],
                         capture_output=True, text=True, env=env, check=True).stdout.strip()
    job = job.split(";")[0]
    deadline = time.monotonic() + JOB_LIMIT_S
    while time.monotonic() < deadline:
        state, code = _job_state(job)
        if state not in ("PENDING", "CONFIGURING", "RUNNING", "COMPLETING"):
            return job, state, code
        time.sleep(1)
    subprocess.run(["scancel", job])
    pytest.fail(f"job {job} did not end within {JOB_LIMIT_S} s")



@needs_foam_and_plugin
def test_the_docs_batch_script_runs_the_smoke_case_as_run_directly(tmp_path, slurm_cluster):
    venv = Path(sys.prefix)
    if not (venv / "bin" / "activate").is_file():
        pytest.skip(f"the tests do not run from a venv ({venv}): the script sources one")
    script = tmp_path / "whale.sbatch"
    script.write_text(batch_script())
    token = tmp_path / "token"
    token.write_text(os.urandom(32).hex() + "\n")
    token.chmod(0o600)
    env = dict(os.environ,
               WHALE_OPENFOAM="export WM_PROJECT_DIR=/usr/share/openfoam",  # Debian's binaries
               WHALE_VENV=str(venv), WHALE_SCENE="smoke", WHALE_CASE=str(tmp_path / "batch"),
               WHALE_DECOMPOSITION="hierarchical",     # Debian's scotch is a stub
               WHALE_TOKEN_FILE=str(token))
    for name in ("WHALE_LAUNCHER", "WHALE_ADAPTER_TOKEN"):
        env.pop(name, None)                    # the script's own srun launcher; the file's token

    job, state, code = _submit_and_wait(script, tmp_path, env)
    log = tmp_path / f"whale-{job}.log"
    text = log.read_text() if log.is_file() else "(no job log)"
    assert (state, code) == ("COMPLETED", "0:0"), f"job {job}: {state} {code}\n{text[-3000:]}"
    batch = tmp_path / "batch"
    record = json.loads((batch / "adapter-case.json").read_text())
    assert record["parallel"]["launcher"] == "srun --mpi=pmix -n {np}"
    assert record["parallel"]["parallel_meshing"] is True
    assert "nProcs : 2" in (batch / "log.pimpleFoam").read_text()

    direct = tmp_path / "direct"
    subprocess.run([str(venv / "bin" / "whale-adapter"), "run-case", "--preset", "smoke",
                    "--case", str(direct), "--np", "2", "--decomposition", "hierarchical",
                    "--parallel-mesh", "--host", "0.0.0.0", "--token-file", str(token)],
                   check=True, capture_output=True, env={k: v for k, v in env.items()
                                                         if not k.startswith("WHALE_")})

    ran = json.loads((batch / "adapter-summary.json").read_text())
    wanted = json.loads((direct / "adapter-summary.json").read_text())
    assert ran["ranks"] == 2 and ran["steps"] == wanted["steps"] > 0
    figures = {k: v for k, v in ran.items() if k not in NOT_FIGURES}
    assert figures == {k: v for k, v in wanted.items() if k not in NOT_FIGURES}
