"""Bounded inputs, bounded runs and prompt failures.

Every test here failed before the change it covers: an unbounded read of `/dev/zero`, a run
without end, a checkpoint failure reported only when the sweep ended, a read-only output
replaced silently.
"""

import json
import re
import os
import resource
import subprocess
import time

import h5py
import pytest

from conftest import BIN, base_sweep, run, texts, write_sweep

# The limit on sweep files, as the error and the docs state it.
MAX_SWEEP_FILE_BYTES = 16 * 1024 * 1024
# Address space allowed to a command reading a bad sweep file: far below what an unbounded read
# of /dev/zero would take, ample for the binary and its threads.
MEMORY_LIMIT_BYTES = 1 << 30


def run_bounded(*args, timeout=30):
    """Runs the binary under an address-space limit; the CompletedProcess and its wall time."""

    def limit():
        resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT_BYTES, MEMORY_LIMIT_BYTES))

    start = time.monotonic()
    p = subprocess.run(
        [str(BIN), *map(str, args)],
        capture_output=True,
        text=True,
        timeout=timeout,
        preexec_fn=limit,
    )
    return p, time.monotonic() - start


def bad_sweep_files(tmp_path):
    """Paths that are not sweep files, with the words their error must contain."""
    fifo = tmp_path / "fifo.json"
    os.mkfifo(fifo)
    huge = tmp_path / "huge.json"
    with open(huge, "wb") as f:
        f.truncate(4 * MAX_SWEEP_FILE_BYTES)  # sparse: no disk used
    just_over = tmp_path / "just_over.json"
    with open(just_over, "wb") as f:
        f.truncate(MAX_SWEEP_FILE_BYTES + 1)
    directory = tmp_path / "dir.json"
    directory.mkdir()
    return [
        ("/dev/zero", "character device"),
        (fifo, "FIFO"),
        (directory, "directory"),
        (huge, f"limit of {MAX_SWEEP_FILE_BYTES} bytes"),
        (just_over, f"limit of {MAX_SWEEP_FILE_BYTES} bytes"),
    ]


@pytest.mark.parametrize(
    "command",
    [
        ["validate", "{}"],
        ["run", "{}", "--dry-run"],
        ["run", "{}", "-o", "{out}"],
        ["status", "{}"],
        ["slurm", "{}", "-o", "{out}", "--shards", "2"],
        ["point", "{}", "0"],
        ["accuracy", "{}", "-o", "{out}"],
    ],
    ids=lambda c: "-".join(a for a in c if "{" not in a),
)
def test_sweep_file_not_regular_or_too_large_is_refused_quickly(binary, tmp_path, command):
    out = tmp_path / "out.h5"
    for path, words in bad_sweep_files(tmp_path):
        if command[0] == "status" and os.path.isdir(path):
            continue  # `status DIR` reads a folder of shard files: another meaning
        cmd = [str(path) if a == "{}" else a.replace("{out}", str(out)) for a in command]
        p, wall = run_bounded(*cmd)
        assert p.returncode == 2, (cmd, p.returncode, p.stderr)
        assert words in p.stderr, (cmd, p.stderr)
        assert str(path) in p.stderr, p.stderr
        assert wall < 10, (cmd, wall)
    assert list(tmp_path.glob("out.h5*")) == []


def test_sweep_file_at_the_limit_is_read(binary, tmp_path):
    # A valid sweep padded with spaces to exactly the limit: read and validated.
    text = json.dumps(base_sweep())
    path = tmp_path / "padded.json"
    path.write_text(text + " " * (MAX_SWEEP_FILE_BYTES - len(text)))
    assert path.stat().st_size == MAX_SWEEP_FILE_BYTES
    p, _ = run_bounded("validate", path)
    assert p.returncode == 0, p.stderr


def runaway_sweep(max_run_seconds):
    """Two points: a sound run, and the runaway scene (a 1000 m/s striker into a chain
    damped at 1e9 kg/s, whose explicit steps are held near m/μ)."""
    s = base_sweep()
    s["axes"] = [
        {
            "zip": [
                {"field": "striker_velocity_m_s", "values": [1.3, 1000]},
                {"field": "physics.damping_kg_s", "values": [0, 1e9]},
            ]
        }
    ]
    if max_run_seconds is not None:
        s["limits"] = {"max_run_seconds": max_run_seconds}
    return s


def test_runaway_run_ends_with_a_recorded_failure_within_its_limit(binary, tmp_path):
    path = write_sweep(tmp_path / "runaway.json", runaway_sweep(2))
    out = tmp_path / "runaway.h5"
    start = time.monotonic()
    r = run("run", path, "-o", out, "--quiet", "--jobs", "2", timeout=120)
    wall = time.monotonic() - start
    assert r.returncode == 3, r.stderr  # partial: one run failed, the sweep went on
    assert wall < 2 + 8, wall
    with h5py.File(out, "r") as f:
        status = f["status"][...]
        reasons = texts(f["reason"])
        wall_times = f["wall_time_s"][...]
    assert list(status) == [1, 2], (status, reasons)
    assert reasons[1].startswith("wall-time limit 2 s reached at t = "), reasons[1]
    assert "limits.max_run_seconds" in reasons[1]
    assert 2 <= wall_times[1] < 4, wall_times
    assert "wall-time limit 2 s" in r.stdout + r.stderr


def test_wall_time_limit_is_not_part_of_the_run_identity(binary, tmp_path):
    """Setting the limit (to its default or not) changes no run hash: a run that finished is the
    same run whatever the limit, and sweeps run before the limit existed resume as they were."""
    hashes = []
    for limit in (None, 600, 30):
        path = write_sweep(tmp_path / f"s{limit}.json", runaway_sweep(limit))
        r = run("point", path, "0", "--scene-only")
        assert r.returncode == 0, r.stderr
        hashes.append(json.loads(r.stdout)["run_hash"])
    assert hashes[0] == hashes[1] == hashes[2]


@pytest.mark.parametrize("with_overwrite", [False, True])
def test_read_only_output_is_not_replaced(binary, tmp_path, with_overwrite):
    """A read-only X.h5 (finished, its work directory still there, or a foreign file with
    --overwrite) is refused with exit 2, and stays as it was, read-only."""
    path = write_sweep(tmp_path / "s.json", base_sweep())
    out = tmp_path / "s.h5"
    r = run("run", path, "-o", out, "--quiet")
    assert r.returncode == 0, r.stderr
    if with_overwrite:
        import shutil

        shutil.rmtree(tmp_path / "s.h5.d")
    before = out.read_bytes()
    os.chmod(out, 0o444)
    extra = ["--overwrite"] if with_overwrite else []
    r = run("run", path, "-o", out, "--quiet", "--retry-failed", *extra)
    assert r.returncode == 2, r.stderr
    assert "is read-only; chainsweep will not replace it" in r.stderr
    assert "--output" in r.stderr
    assert out.read_bytes() == before
    assert out.stat().st_mode & 0o777 == 0o444


def interval_sweep(field, value, history=True):
    s = base_sweep(history=history)
    s["record"][field] = value
    return s


@pytest.mark.parametrize("field", ["history_interval_s", "summary_interval_s"])
def test_intervals_below_their_bound_are_refused(binary, tmp_path, field):
    # duration 2e-4 s: at most 1e6 history samples (2e-10 s) and 1e7 summary samples (2e-11 s).
    smallest = {"history_interval_s": 2e-10, "summary_interval_s": 2e-11}[field]
    most = {"history_interval_s": 1000000, "summary_interval_s": 10000000}[field]
    path = write_sweep(tmp_path / "s.json", interval_sweep(field, 1e-15))
    for cmd in (["validate", path], ["run", path, "--dry-run"], ["run", path, "-o", tmp_path / "o.h5"]):
        start = time.monotonic()
        r = run(*cmd, timeout=60)
        assert r.returncode == 2, (cmd, r.stderr)
        assert f"record.{field}" in r.stderr
        assert "must lie in [2" in r.stderr and f"at most {most} " in r.stderr, r.stderr
        assert time.monotonic() - start < 10
    assert not (tmp_path / "o.h5").exists()
    # At the bound it is accepted.
    path = write_sweep(tmp_path / "ok.json", interval_sweep(field, smallest * 1.0000001))
    r = run("validate", path)
    assert r.returncode == 0, r.stderr


def test_history_interval_is_free_without_histories(binary, tmp_path):
    path = write_sweep(tmp_path / "s.json", interval_sweep("history_interval_s", 1e-15, history=False))
    r = run("validate", path)
    assert r.returncode == 0, r.stderr


def test_dry_run_refuses_an_output_that_cannot_fit(binary, tmp_path):
    # 5e4 points with histories at their finest (1e6 samples of 4 probes and the time): 2 TB
    # uncompressed.
    s = interval_sweep("history_interval_s", 2e-10 * 1.0000001)
    s["record"]["probes"] = [{"kind": "gauge_force", "cylinder": c} for c in (2, 4, 6, 8)]
    s["axes"] = [{"field": "striker_velocity_m_s", "range": {"start": 1.0, "stop": 2.0, "num": 50000}}]
    path = write_sweep(tmp_path / "big.json", s)
    free = os.statvfs(tmp_path).f_bavail * os.statvfs(tmp_path).f_frsize
    assert free < 1.9e12, "the test needs a file system with less than 1.9 TB free"
    r = run("run", path, "--dry-run", "-o", tmp_path / "big.h5", timeout=120)
    assert r.returncode == 2, r.stderr
    assert "record.history_interval_s" in r.stderr
    assert "cannot fit" in r.stderr
    assert not (tmp_path / "big.h5").exists()


def test_checkpoint_failure_is_reported_at_once_and_stops_the_sweep(binary, tmp_path):
    """Fault injection: once the sweep runs, its output path is taken by a non-empty directory,
    so publishing a checkpoint fails (as a read-only parent or a work directory on another file
    system would make it fail; permission bits do not stop root, a directory does). The error
    comes at once, the sweep stops (well before its 400 runs of ~60 ms would end), the finished
    runs stay stored, and the message says how to resume."""
    from conftest import segment_count

    s = base_sweep(cylinders=40, duration_s=2e-3, history=True, probes=(2, 20, 38))
    s["axes"] = [{"field": "physics.damping_kg_s", "range": {"start": 0, "stop": 10, "num": 400}}]
    path = write_sweep(tmp_path / "long.json", s)
    out = tmp_path / "long.h5"
    p = subprocess.Popen(
        [str(BIN), "run", path, "-o", out, "--jobs", "1", "--checkpoint-interval", "0.2", "--quiet"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        deadline = time.monotonic() + 60
        while segment_count(out) < 5 and time.monotonic() < deadline:
            time.sleep(0.02)
        assert segment_count(out) >= 5
        for _ in range(100):
            try:
                out.unlink()
                out.mkdir()
                break
            except (FileNotFoundError, FileExistsError):
                continue  # a checkpoint published in between: try again
        (out / "blocker").write_text("not the output")
        fault = time.monotonic()
        _, stderr = p.communicate(timeout=120)
        after = time.monotonic() - fault
    finally:
        if p.poll() is None:
            p.kill()
            p.wait()
    assert p.returncode == 1, stderr
    assert after < 5, (after, stderr)
    assert "The sweep stops now: no new run starts" in stderr, stderr
    assert "run the same command again to resume" in stderr
    assert f"{out}.d" in stderr
    stored = segment_count(out)
    assert 5 <= stored < 300, stored


def test_validate_and_dry_run_warn_about_absurd_scenes(binary, tmp_path):
    path = write_sweep(tmp_path / "runaway.json", runaway_sweep(600))
    for cmd in (["validate", path], ["run", path, "--dry-run", "-o", tmp_path / "r.h5"]):
        r = run(*cmd, timeout=60)
        assert r.returncode == 0, r.stderr
        assert "1 of 2 grid points look physically absurd" in r.stderr, r.stderr
        # Point 1: 1000 m/s into a chain damped at 1e9 kg/s.
        assert "point 1 (striker_velocity_m_s=1000" in r.stderr
        assert "two-body overlap estimate" in r.stderr and "of the sphere radius" in r.stderr
        assert "damping holds dop853's steps near m/μ" in r.stderr
        assert "more than the step budget" in r.stderr
        assert "point 0" not in r.stderr
    # A sound sweep draws no warning.
    r = run("validate", write_sweep(tmp_path / "sound.json", base_sweep()))
    assert r.returncode == 0 and "absurd" not in r.stderr, r.stderr
    # ROS34PW2 is not held by damping: only the overlap is absurd then.
    s = runaway_sweep(600)
    s["base"]["integrator"] = {"method": "ros34pw2", "rtol": 1e-6}
    r = run("validate", write_sweep(tmp_path / "ros.json", s))
    assert "two-body overlap estimate" in r.stderr and "m/μ" not in r.stderr, r.stderr


def test_dry_run_cost_estimate_is_within_its_stated_accuracy(binary, tmp_path):
    s = base_sweep(cylinders=40, duration_s=3e-3, probes=(2, 20, 38))
    s["axes"] = [{"field": "physics.damping_kg_s", "range": {"start": 0, "stop": 20, "num": 12}}]
    path = write_sweep(tmp_path / "cost.json", s)
    out = tmp_path / "cost.h5"
    r = run("run", path, "--dry-run", "-o", out)
    assert r.returncode == 0, r.stderr
    m = re.search(r"estimated cost: (\S+) CPU-seconds for 12 runs \(±(\d+) %, from a pilot of 3 runs", r.stdout)
    assert m, r.stdout
    estimate, accuracy = float(m.group(1)), int(m.group(2)) / 100
    assert accuracy <= 1.0, accuracy
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    r = run("run", path, "-o", out, "--jobs", "1", "--quiet")
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    assert r.returncode == 0, r.stderr
    # The sweep's CPU time (its process, I/O and start-up included).
    actual = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    assert abs(estimate - actual) <= accuracy * actual, (estimate, actual, accuracy)
    # A second dry run: everything is done, nothing is estimated.
    r = run("run", path, "--dry-run", "-o", out)
    assert "estimated cost" not in r.stdout


def test_dry_run_says_when_runs_will_meet_the_wall_time_limit(binary, tmp_path):
    path = write_sweep(tmp_path / "runaway.json", runaway_sweep(5))
    start = time.monotonic()
    r = run("run", path, "--dry-run", "-o", tmp_path / "r.h5", timeout=60)
    assert time.monotonic() - start < 10
    assert r.returncode == 0, r.stderr
    assert "extrapolated from the simulated time they reached" in r.stdout
    assert "more than limits.max_run_seconds = 5 s" in r.stderr, r.stderr


def test_history_bound_counts_every_probe(binary, tmp_path):
    # 40 probes: at most 1e7 / 40 = 250 000 samples per probe over 2e-4 s, so 1e-9 s is refused
    # (200 001 samples are fine for 2 probes).
    s = interval_sweep("history_interval_s", 5e-10)
    s["base"]["chain"]["cylinders"] = 50
    s["record"]["probes"] = [{"kind": "gauge_force", "cylinder": c} for c in range(1, 41)]
    r = run("validate", write_sweep(tmp_path / "many.json", s))
    assert r.returncode == 2, r.stderr
    assert "record.history_interval_s" in r.stderr and "at most 250000 history samples per probe" in r.stderr
    s["record"]["history_interval_s"] = 1e-9
    r = run("validate", write_sweep(tmp_path / "ok.json", s))
    assert r.returncode == 0, r.stderr
