"""Bitwise identity: `--jobs 1` vs `--jobs 2`, and sharded-then-merged vs a single run.

Compared: every dataset bit for bit and every attribute, except `wall_time_s` (measured) and the
root attributes `created_utc` and `command_line`."""

import h5py
import numpy as np
import pytest

from conftest import assert_files_equal, base_sweep, run, write_sweep


def sweep():
    s = base_sweep(history=True)
    s["axes"] = [
        {"field": "chain.cylinder.mass.heavy_cylinders.mass_ratio", "range": {"start": 0.2, "stop": 1.0, "num": 5}},
        {
            "zip": [
                {"field": "physics.damping_kg_s", "values": [0, 6, 15]},
                {"field": "striker_velocity_m_s", "name": "velocity_m_s", "values": [1.06, 1.3, 1.45]},
            ]
        },
    ]
    return s


@pytest.fixture(scope="module")
def single(tmp_path_factory, binary):
    d = tmp_path_factory.mktemp("single")
    path = write_sweep(d / "grid.json", sweep())
    out = d / "jobs1.h5"
    r = run("run", path, "-o", out, "--jobs", "1", "--quiet")
    assert r.returncode == 0, r.stderr
    return path, out


def test_jobs_1_vs_jobs_2(single, tmp_path):
    path, ref = single
    out = tmp_path / "jobs2.h5"
    r = run("run", path, "-o", out, "--jobs", "2", "--quiet")
    assert r.returncode == 0, r.stderr
    assert_files_equal(ref, out)


def test_zip_axes_share_a_dimension(single):
    _, ref = single
    with h5py.File(ref, "r") as f:
        assert f["leading_peak"].shape == (5, 3, 2)
        # one scale per dimension (netCDF-4 takes the last one attached as the dimension): the
        # axis named like it; the zipped velocity is a coordinate on it
        scales = [s.name for s in f["leading_peak"].dims[1].values()]
        assert scales == ["/damping_kg_s"]
        assert [s.name for s in f["velocity_m_s"].dims[0].values()] == ["/damping_kg_s"]
        assert not h5py.h5ds.is_scale(f["velocity_m_s"].id)
        assert f["leading_peak"].attrs["coordinates"] == "velocity_m_s probe probe_units"
        assert f["steps"].attrs["coordinates"] == "velocity_m_s"
        np.testing.assert_array_equal(f["velocity_m_s"][:], [1.06, 1.3, 1.45])
        assert f["velocity_m_s"].attrs["units"] == "m/s"
        assert f["velocity_m_s"].attrs["dimension"] == "damping_kg_s"


def test_shards_then_merge_equals_single(single, tmp_path):
    path, ref = single
    parts = []
    owner = None
    for k in (1, 2, 3):
        part = tmp_path / f"part-{k}.h5"
        r = run("run", path, "--shard", f"{k}/3", "-o", part, "--jobs", "2", "--quiet")
        assert r.returncode == 0, r.stderr
        with h5py.File(part, "r") as f:
            assert f.attrs["shard"] == f"{k}/3"
            status = f["status"][...].ravel()
            owner = np.zeros(status.size, dtype=int) if owner is None else owner
            # A shard runs its own points only: the shards partition the grid.
            assert ((status == 1) | (status == 0)).all()
            assert (owner[status == 1] == 0).all()
            owner[status == 1] = k
        r = run("status", part)
        assert r.returncode == 0, r.stdout
        parts.append(part)
    assert (owner > 0).all()

    # A merge of some of the shards is partial (exit 3) and says what is pending.
    partial = tmp_path / "partial.h5"
    r = run("merge", "-o", partial, parts[0], parts[2])
    assert r.returncode == 3, r.stderr
    assert f"{(owner == 2).sum()} pending" in r.stderr
    # The merge names the missing shard and how to run only it again (array task = shard - 1).
    assert "shard 2/3 (SLURM array task 1) is missing" in r.stderr, r.stderr
    assert "sbatch --array=1 " in r.stderr, r.stderr
    # `status` over the shard files says per shard done or missing.
    r = run("status", parts[0], parts[2])
    assert r.returncode == 3, r.stdout + r.stderr
    assert "shard 1/3 (array task 0): done" in r.stdout, r.stdout
    assert "shard 2/3 (array task 1): missing" in r.stdout, r.stdout
    assert "3 shards: 2 done, 0 failed, 0 running, 0 pending, 1 missing" in r.stdout, r.stdout

    merged = tmp_path / "merged.h5"
    r = run("merge", "-o", merged, *reversed(parts))
    assert r.returncode == 0, r.stderr
    assert_files_equal(ref, merged)
    # Wall times travel with the runs from the shards.
    with h5py.File(merged, "r") as m:
        wall = m["wall_time_s"][...].ravel()
        for k, part in enumerate(parts, start=1):
            with h5py.File(part, "r") as f:
                w = f["wall_time_s"][...].ravel()
                sel = owner == k
                assert w[sel].tobytes() == wall[sel].tobytes()
    # The merged file is resumable like any run's output: nothing is left to run.
    r = run("run", path, "-o", merged, "--jobs", "2")
    assert r.returncode == 0, r.stderr
    assert "nothing to do" in r.stderr
    assert_files_equal(ref, merged)


def test_merge_refuses_shards_of_different_sweeps(single, tmp_path):
    path, ref = single
    other = base_sweep()
    other_path = write_sweep(tmp_path / "other.json", other)
    other_out = tmp_path / "other.h5"
    assert run("run", other_path, "-o", other_out, "--quiet").returncode == 0
    out = tmp_path / "m.h5"
    r = run("merge", "-o", out, ref, other_out)
    assert r.returncode == 2
    assert "different sweep" in r.stderr
    assert not out.exists()


def test_status_of_shards_names_a_running_task_and_leaves_it_out_of_the_resubmit(tmp_path, binary):
    """A shard whose task is writing it now (it holds the shard's work directory) is `running`,
    not pending or missing, and the re-submit command leaves it out: submitting it again would
    only meet its lock."""
    import subprocess
    import time

    from conftest import BIN, interruptible_sweep

    path = write_sweep(tmp_path / "grid.json", interruptible_sweep())
    shards = tmp_path / "shards"
    shards.mkdir()
    part = lambda k: shards / f"grid.shard-{k}-of-3.h5"
    r = run("run", path, "--shard", "1/3", "-o", part(1), "--quiet")
    assert r.returncode == 0, r.stderr
    for k in (2, 3):
        writer = subprocess.Popen(
            [str(BIN), "run", str(path), "--shard", f"{k}/3", "-o", str(part(k)), "--quiet",
             "--checkpoint-interval", "0.05"],
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
        )
        try:
            deadline = time.monotonic() + 60
            while time.monotonic() < deadline:
                r = run("status", shards)
                if f"shard {k}/3 (array task {k - 1}): running" in r.stdout:
                    break
                assert writer.poll() is None, "the shard finished before it was seen running"
                time.sleep(0.02)
            assert f"process {writer.pid} is writing it now" in r.stdout, r.stdout
            assert r.returncode == 3
            assert "1 running" in r.stdout, r.stdout
            if k == 2:
                # Shard 3 has no file and no writer: only it is to run again.
                assert "shard 3/3 (array task 2): missing" in r.stdout, r.stdout
                assert "--array=2 " in r.stderr and "--array=1" not in r.stderr, r.stderr
        finally:
            writer.kill()
            writer.wait()
        # Killed, its lock goes with it: pending (or missing, before its first file), to run again.
        r = run("status", shards)
        assert "running" not in r.stdout.split("shards:")[0], r.stdout
        assert f"array task {k - 1}):" in r.stdout
        assert f"{k - 1}" in r.stderr.split("--array=")[1].split()[0], r.stderr
