"""Graceful stops and output that never ends a sweep.

- SIGTERM (SLURM's time limit, scancel) and SIGINT (Ctrl-C) mid-run: no new runs, the output
  written with every finished run, exit 143 / 130, and the same command resumes to a file
  bitwise equal (datasets; attributes but `created_utc`, `command_line`) to an uninterrupted run.
- A run killed (SIGKILL) before its first checkpoint still leaves a readable output file.
- `run … 2>&1 | head -n 2`: the closed pipe does not end the sweep.
- Options refused before anything is created: absurd intervals, `--jobs` beyond 4 per CPU; and
  never more worker threads than grid points.
"""

import os
import signal
import subprocess
import time

import h5py
import numpy as np
import pytest

from conftest import (
    BIN,
    assert_files_equal,
    base_sweep,
    interruptible_sweep,
    read_all,
    run,
    segment_count,
    write_sweep,
)



def start(path, out, *extra, **popen):
    popen.setdefault("stdout", subprocess.PIPE)
    popen.setdefault("stderr", subprocess.PIPE)
    return subprocess.Popen(
        [str(BIN), "run", str(path), "-o", str(out), "--jobs", "2", *extra], text=True, **popen
    )


def wait_for_segments(out, n, proc, timeout=60):
    deadline = time.time() + timeout
    while segment_count(out) < n:
        assert proc.poll() is None, "the sweep ended before it could be interrupted"
        assert time.time() < deadline, "the sweep made no progress"
        time.sleep(0.005)


@pytest.fixture(scope="module")
def reference(tmp_path_factory, binary):
    d = tmp_path_factory.mktemp("ref")
    path = write_sweep(d / "stop.json", interruptible_sweep())
    out = d / "ref.h5"
    r = run("run", path, "-o", out, "--jobs", "2", "--quiet")
    assert r.returncode == 0, r.stderr
    return out


@pytest.mark.parametrize("sig,code,name", [(signal.SIGTERM, 143, "SIGTERM"), (signal.SIGINT, 130, "SIGINT")])
def test_a_signal_stops_the_sweep_with_its_output_written_and_it_resumes(reference, tmp_path, sig, code, name):
    path = write_sweep(tmp_path / "stop.json", interruptible_sweep())
    out = tmp_path / "out.h5"
    # No checkpoint before the end: only the stop writes the finished runs.
    p = start(path, out, "--checkpoint-interval", "0")
    wait_for_segments(out, 10, p)
    p.send_signal(sig)
    _, err = p.communicate(timeout=60)
    assert p.returncode == code, err
    assert f"stopped by {name}" in err and "run the same command to resume" in err, err
    stored = segment_count(out)
    with h5py.File(out, "r") as f:
        status = f["status"][...]
        finished = int((status == 1).sum())
        # Every finished run is in the file, and the sweep did stop early.
        assert finished == stored, (finished, stored)
        assert 10 <= finished < status.size
        assert int(f.attrs["n_ok"]) == finished
        ref = h5py.File(reference, "r")
        done = status == 1
        for name_ in ("leading_peak", "record_max"):
            if name_ in f:
                assert f[name_][...][done].tobytes() == ref[name_][...][done].tobytes()
        ref.close()
    r = run("run", path, "-o", out, "--jobs", "2", "--quiet")
    assert r.returncode == 0, r.stderr
    assert_files_equal(reference, out)


def test_a_run_killed_before_its_first_checkpoint_leaves_a_readable_file(tmp_path):
    path = write_sweep(tmp_path / "stop.json", interruptible_sweep())
    out = tmp_path / "out.h5"
    p = start(path, out)  # default checkpoint interval: 300 s
    wait_for_segments(out, 1, p)
    p.kill()
    p.communicate()
    assert out.exists()
    data, _ = read_all(out)
    assert data["status"][1].shape == (10, 10)
    r = run("status", out)
    assert r.returncode == 3, r.stdout + r.stderr
    assert "100 runs" in r.stdout and "pending" in r.stdout


def test_a_closed_pipe_does_not_end_the_sweep(tmp_path):
    """`chainsweep run … 2>&1 | head -n 2`: progress lines go on failing, the sweep goes on."""
    path = write_sweep(tmp_path / "stop.json", interruptible_sweep())
    out = tmp_path / "out.h5"
    p = start(path, out, "--progress-interval", "0.001", stderr=subprocess.STDOUT)
    lines = [p.stdout.readline() for _ in range(2)]
    assert all(l.startswith("chainsweep:") for l in lines), lines
    p.stdout.close()  # what `head` does after two lines
    assert p.wait(timeout=120) == 0
    with h5py.File(out, "r") as f:
        assert (f["status"][...] == 1).all()


@pytest.mark.parametrize(
    "option,value,allowed",
    [
        ("--checkpoint-interval", "1e20", "[0, 604800]"),
        ("--checkpoint-interval", "-1", "[0, 604800]"),
        ("--progress-interval", "1e308", "(0, 86400]"),
        ("--progress-interval", "0", "(0, 86400]"),
        ("--jobs", "100000", "4 per CPU"),
    ],
)
def test_absurd_options_are_refused_before_anything_is_created(tmp_path, option, value, allowed):
    path = write_sweep(tmp_path / "s.json", base_sweep())
    out = tmp_path / "out.h5"
    r = run("run", path, "-o", out, f"{option}={value}")
    assert r.returncode == 2, r.stderr
    assert option in r.stderr and allowed in r.stderr, r.stderr
    assert "panicked" not in r.stderr
    assert not out.exists() and not (tmp_path / "out.h5.d").exists()


def test_never_more_worker_threads_than_grid_points(tmp_path):
    s = base_sweep(cylinders=40, duration_s=2e-2)
    s["axes"] = [{"field": "physics.damping_kg_s", "values": [0, 6]}]
    path = write_sweep(tmp_path / "two.json", s)
    out = tmp_path / "out.h5"
    jobs = 4 * len(os.sched_getaffinity(0))  # the most accepted
    p = subprocess.Popen(
        [str(BIN), "run", str(path), "-o", str(out), "--jobs", str(jobs), "--quiet"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    most = 0
    while p.poll() is None:
        try:
            with open(f"/proc/{p.pid}/status") as f:
                for line in f:
                    if line.startswith("Threads:"):
                        most = max(most, int(line.split()[1]))
        except (FileNotFoundError, ProcessLookupError):
            break
        time.sleep(0.002)
    _, err = p.communicate()
    assert p.returncode == 0, err
    # 2 workers, the coordinator's helper and the main thread.
    assert 0 < most <= 2 + 2, most
