"""The SLURM path on a real SLURM: a private single-node cluster (scripts/slurm_local.py installs
SLURM and munge from Debian's packages when missing, starts munged, slurmctld and slurmd, and
stops them by their pids at the end). No skipping: when SLURM cannot be started, the test fails
and says why.

`chainsweep slurm` writes the array and merge scripts of a small sweep in 3 shards and submits
them; array task 1 is cancelled mid-run (`scancel JOB_1`: SIGTERM, chainsweep stores what it
finished and exits 143); the merge, run after the array whatever its outcome, names the missing
shard and the command that re-submits only its task; that command is run, and the merged file
is bitwise equal (datasets; attributes but `created_utc`, `command_line`) to a single-machine run.
"""

import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import h5py
import pytest

from conftest import REPO, assert_files_equal, base_sweep, run, segment_count, write_sweep

sys.path.insert(0, str(REPO / "scripts"))
import slurm_local  # noqa: E402

# The system tier (`make test-system`): a real SLURM cluster started on this machine.
pytestmark = pytest.mark.system


@pytest.fixture(scope="module")
def slurm():
    d = Path(tempfile.mkdtemp(prefix="cs-slurm-"))
    t0 = time.time()
    try:
        env = slurm_local.start(d)
    except slurm_local.SlurmError as e:
        pytest.fail(f"SLURM could not be started: {e}")
    print(f"SLURM started in {time.time() - t0:.1f} s ({d})")
    yield env
    stopped = slurm_local.stop(d)
    assert len(stopped) == 3, f"stopped {stopped}: expected munged, slurmctld and slurmd"


def slurm_sweep():
    # About 25 CPU-s in all: each shard runs for seconds, long enough to be cancelled mid-run.
    s = base_sweep(cylinders=40, duration_s=4e-3)
    s["axes"] = [
        {"field": "chain.cylinder.mass.heavy_cylinders.mass_ratio", "range": {"start": 0.1, "stop": 1.0, "num": 10}},
        {"field": "physics.damping_kg_s", "range": {"start": 0, "stop": 29, "step": 1}},
    ]
    return s


def sh(args, env, check=True):
    r = subprocess.run(args, capture_output=True, text=True, env=env, timeout=60)
    if check:
        assert r.returncode == 0, f"{args}: {r.stdout}{r.stderr}"
    return r


def job_field(job, field, env):
    r = sh(["scontrol", "show", "job", job], env, check=False)
    m = re.search(rf"\b{field}=(\S+)", r.stdout)
    return m.group(1) if m else None


def wait_done(env, timeout=120):
    """Waits until no job of the private cluster is pending or running."""
    deadline = time.time() + timeout
    while time.time() < deadline:
        r = sh(["squeue", "-h", "-o", "%i %T"], env, check=False)
        if r.returncode == 0 and not r.stdout.strip():
            return
        time.sleep(0.3)
    raise AssertionError(f"jobs still queued after {timeout} s: {r.stdout}")


def test_array_cancel_resubmit_merge_is_bitwise_a_single_run(slurm, tmp_path, binary):
    env = slurm
    t0 = time.time()
    path = write_sweep(tmp_path / "sw.json", slurm_sweep())
    out = tmp_path / "results" / "sw.h5"  # its folder does not exist yet: `slurm` creates it
    r = run("slurm", path, "-o", out, "--shards", "3", "--cpus-per-task", "1", "--time", "0:10:00",
            "--submit", env=env)
    assert r.returncode == 0, r.stderr
    m = re.search(r"submitted array job (\d+) and merge job (\d+)", r.stdout)
    assert m, r.stdout
    array, merge = m.groups()
    job = out.parent / "sw.h5.slurm"
    assert "#SBATCH --array=0-2" in (job / "array.sh").read_text()

    # Cancel task 1 once it has stored some runs.
    shard_out = job / "shards" / "sw.shard-2-of-3.h5"
    deadline = time.time() + 90
    while segment_count(shard_out) < 5:
        assert time.time() < deadline, "array task 1 stored no runs"
        assert job_field(f"{array}_1", "JobState", env) in ("PENDING", "RUNNING", None), "task 1 ended early"
        time.sleep(0.05)
    sh(["scancel", f"{array}_1"], env)
    wait_done(env)
    assert job_field(f"{array}_1", "JobState", env) == "CANCELLED"
    # SIGTERM: the task kept what it finished, in a readable shard file.
    with h5py.File(job / "shards" / "sw.shard-2-of-3.h5", "r") as f:
        assert f.attrs["shard"] == "2/3"
    log1 = next((job / "logs").glob(f"array-{array}_1.out")).read_text()
    assert "stopped by SIGTERM" in log1, log1

    # The merge ran after the array anyway, and says what to re-submit.
    merge_log = (job / "logs" / f"merge-{merge}.out").read_text()
    assert job_field(merge, "ExitCode", env) == "3:0", merge_log
    assert "shard 2/3 (SLURM array task 1) is pending" in merge_log, merge_log
    resubmit = next(l.strip() for l in merge_log.splitlines() if l.strip().startswith("jid=$(sbatch"))
    assert "--array=1 " in resubmit, resubmit
    r = sh(["bash", "-c", resubmit], env)
    again_merge = r.stdout.split()[-1].split(";")[0]
    wait_done(env)
    assert job_field(again_merge, "ExitCode", env) == "0:0", (job / "logs" / f"merge-{again_merge}.out").read_text()
    logs = [p for p in (job / "logs").glob("array-*_*.out") if not p.name.startswith(f"array-{array}_")]
    assert [p.name.split("_")[1] for p in logs] == ["1.out"], logs  # only task 1 ran again
    log = logs[0].read_text()
    assert "resuming" in log, log

    r = run("status", job)
    assert r.returncode == 0, r.stdout + r.stderr
    assert r.stdout.count(": done") == 3, r.stdout

    single = tmp_path / "single.h5"
    r = run("run", path, "-o", single, "--quiet")
    assert r.returncode == 0, r.stderr
    assert_files_equal(single, out)
    print(f"SLURM test: {time.time() - t0:.1f} s")


def test_an_adaptive_ensemble_s_rounds_follow_each_other_to_the_single_machine_s_answer(slurm, tmp_path, binary):
    """An adaptive ensemble on SLURM: every array task runs the round its job folder names, and
    each merge job, once its round is merged, submits the next round while the statistics are not
    within their tolerances; the last merged file is bitwise the single machine's."""
    from test_ensemble import adaptive_ensemble, linear_chain

    env = slurm
    ens = adaptive_ensemble()
    path = write_sweep(tmp_path / "ad.json", linear_chain(ens))
    out = tmp_path / "results" / "ad.h5"
    r = run("slurm", path, "-o", out, "--shards", "2", "--cpus-per-task", "1", "--time", "0:10:00",
            "--submit", env=env)
    assert r.returncode == 0, r.stderr
    job = out.parent / "ad.h5.slurm"
    assert "--ensemble-round" in (job / "array.sh").read_text()
    # Each merge job submits the next round before it ends: the queue empties only at the end.
    wait_done(env, timeout=300)
    with h5py.File(out) as f:
        last = int(f.attrs["ensemble_round"])
        assert f.attrs["ensemble_stopped_by"] == "tolerance"
    assert last >= 2, last
    assert (job / "ensemble-round").read_text() == f"{last}\n"
    merges = sorted((job / "logs").glob("merge-*.out"), key=lambda p: int(p.stem.split("-")[1]))
    assert len(merges) == last + 1, [p.name for p in merges]
    for k, log in enumerate(merges[:-1]):
        assert f"round {k + 1} submitted" in log.read_text(), log.read_text()
    assert f"the ensemble ended after round {last}" in merges[-1].read_text(), merges[-1].read_text()
    assert len(list((job / "logs").glob("array-*_*.out"))) == 2 * (last + 1)

    single = tmp_path / "single.h5"
    r = run("run", path, "-o", single, "--quiet")
    assert r.returncode == 0, r.stderr
    assert_files_equal(single, out)
    # Asked again, the folder says how the ensemble ended and submits nothing.
    r = run("slurm", path, "-o", out, "--shards", "2", "--next-round", env=env)
    assert r.returncode == 0 and f"ended after round {last}" in r.stdout, r.stdout + r.stderr
