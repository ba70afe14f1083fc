"""Crash safety and resume: SIGKILL at several points of a sweep (mid-run, mid-write), resume with
the same command, and compare every dataset with an uninterrupted run, bit for bit (all datasets
but `wall_time_s`; all attributes but `created_utc` and `command_line`). Also: the lock against a
second process, and editing the sweep file recomputes exactly the changed points."""

import os
import re
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
    log_records,
    segment_count,
    write_sweep,
)



def start(path, out, *extra):
    # Refresh the output file every 10 ms so that kills also land in the middle of writing it.
    return subprocess.Popen(
        [str(BIN), "run", str(path), "-o", str(out), "--jobs", "2", "--checkpoint-interval", "0.01",
         "--progress-interval", "0.02", *extra],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def check_readable(out):
    """The output file, when present, is a complete, readable file."""
    if not out.exists():
        return 0
    data, _ = read_all(out)
    with h5py.File(out, "r") as f:
        status = f["status"][...]
        assert int(f.attrs["n_ok"]) == int((status == 1).sum())
        samples = f["history_samples"][()]
        assert (samples[status == 1] == 1001).all() and (samples[status != 1] == -1).all()
        assert f["time_s"].shape == (1001,)
        return int((status == 1).sum())


def last_reported_done(stderr):
    done = [int(m) for m in re.findall(r"chainsweep: (\d+)/\d+ runs done", stderr)]
    return max(done) if done else 0


@pytest.fixture(scope="module")
def reference(tmp_path_factory, binary):
    d = tmp_path_factory.mktemp("ref")
    path = write_sweep(d / "kill.json", interruptible_sweep())
    out = d / "ref.h5"
    r = run("run", path, "-o", out, "--jobs", "2", "--quiet")
    assert r.returncode == 0, r.stderr
    return out


def test_kill_and_resume_is_bitwise_identical(reference, tmp_path):
    path = write_sweep(tmp_path / "kill.json", interruptible_sweep())
    out = tmp_path / "out.h5"
    kills = []
    # Kill right at start, then after increasing numbers of finished runs.
    for target in (0, 1, 10, 35, 70, 95):
        before = segment_count(out)
        p = start(path, out)
        if target == 0:
            time.sleep(0.005)
        else:
            # At least one run finishes in this process, even if the previous kill came late.
            goal = max(target, before + 1)
            while segment_count(out) < goal and p.poll() is None:
                time.sleep(0.001)
        p.send_signal(signal.SIGKILL)
        _, err = p.communicate()
        assert p.returncode in (-signal.SIGKILL, 0, 3), err
        after = segment_count(out)
        # Nothing finished is lost: every run reported done has its segment.
        assert after >= last_reported_done(err)
        assert after >= before
        if before > 0:
            assert f"{before} of 100 runs already done" in err or p.returncode == 0, (before, after, err)
        # Whatever the moment of the kill, the output is absent or a complete readable file.
        in_file = check_readable(out)
        assert in_file <= after
        if out.exists():
            st = run("status", out)
            assert st.returncode == 3
            assert f"{in_file} done ({in_file} ok, 0 failed)" in st.stdout
            if after > in_file:
                assert f"{after - in_file} more run(s) have finished" in st.stdout
                assert "the sweep was interrupted" in st.stdout, st.stdout
        kills.append((target, before, after, in_file))
    # Random moments, so that some kills land in the middle of writing the output file.
    for delay in (0.003, 0.011, 0.023, 0.037):
        p = start(path, out)
        time.sleep(delay)
        p.send_signal(signal.SIGKILL)
        p.communicate()
        check_readable(out)
    # Resume to the end with the same command.
    r = run("run", path, "-o", out, "--jobs", "2", "--checkpoint-interval", "0.01")
    assert r.returncode == 0, r.stderr
    assert segment_count(out) == 100
    assert_files_equal(reference, out)
    tmp = tmp_path / "out.h5.d" / "tmp"
    assert list(tmp.iterdir()) == []
    print("kills (target, segments before, segments after, runs in file):", kills)


def test_second_process_is_refused(tmp_path, binary):
    path = write_sweep(tmp_path / "kill.json", interruptible_sweep())
    out = tmp_path / "out.h5"
    p = start(path, out)
    try:
        while segment_count(out) < 1 and p.poll() is None:
            time.sleep(0.001)
        assert p.poll() is None, "first process finished too early"
        r = run("run", path, "-o", out, "--jobs", "1")
        assert r.returncode == 1
        assert "another chainsweep process" in r.stderr
        assert f"pid {p.pid}" in r.stderr
    finally:
        p.send_signal(signal.SIGKILL)
        p.communicate()
    # Once the holder is gone, the lock is free again.
    r = run("run", path, "-o", out, "--jobs", "2", "--quiet")
    assert r.returncode == 0, r.stderr


def test_editing_the_sweep_recomputes_only_changed_points(tmp_path, binary):
    s = base_sweep()
    path = write_sweep(tmp_path / "edit.json", s)
    out = tmp_path / "edit.h5"
    assert run("run", path, "-o", out, "--quiet").returncode == 0
    # A complete run leaves its runs in the output file, not beside it.
    assert segment_count(out) == 6 and log_records(out) == []

    # Change one damping value and add a mass ratio: 2 of the 6 old points change, 2 are new.
    s["axes"][1]["values"] = [0, 10]
    s["axes"][0]["values"] = [0.3, 0.55, 1.0, 0.8]
    write_sweep(path, s)
    r = run("status", path, "-o", out)
    assert r.returncode == 3
    assert "8 runs: 3 done" in r.stdout and "5 pending" in r.stdout
    r = run("run", path, "-o", out)
    assert r.returncode == 0, r.stderr
    assert "3 of 8 runs already done" in r.stderr
    # Exactly the 5 changed or new points ran; the 3 orphans of the old sweep are kept beside the
    # new file (only `gc` removes finished runs).
    assert "8/8 runs done" in r.stderr
    assert segment_count(out) == 11 and len(log_records(out)) == 3

    # The result equals a fresh run of the edited sweep.
    fresh = tmp_path / "fresh.h5"
    assert run("run", path, "-o", fresh, "--quiet").returncode == 0
    assert_files_equal(fresh, out)
    r = run("status", out)
    assert r.returncode == 0 and "8 done (8 ok, 0 failed), 0 pending" in r.stdout
