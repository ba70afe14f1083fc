"""The store at scale and its hardening: append-only,
checksummed run logs in the work directory, compacted into the output file once a sweep is
complete.

- kill storms: many SIGKILLs at random moments, with checkpoints every 10 ms so that kills land
  in the middle of appending to a log and of publishing the output, with and without histories;
  the resumed result is bitwise an uninterrupted run's;
- a full disk (a small tmpfs): a clear error, nothing stored is lost, the same command resumes
  once space is freed;
- few files and no double storage: a 2 000-run sweep leaves a handful of files, and after a
  complete run the work directory is at most 20 % of the output file;
- a torn or corrupt record is computed again, and `status` counts exactly the runs `run` finds;
- a directory where a log or segment is expected is left out with a note, never a failure;
- one-file segments of earlier versions are read and moved into one log;
- `gc` removes the runs an edited sweep no longer has, never one it needs.
"""

import os
import random
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
    damage_frame,
    interruptible_sweep,
    log_frames,
    log_records,
    log_segments,
    run,
    segment_count,
    work_dir_files,
    write_sweep,
)


def start(path, out, *extra, checkpoint="0.01"):
    return subprocess.Popen(
        [str(BIN), "run", str(path), "-o", str(out), "--jobs", "2", "--checkpoint-interval", checkpoint,
         "--progress-interval", "0.02", *extra],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def wait_stored(out, n, p, timeout=120):
    deadline = time.time() + timeout
    while len({h for _, h, _ in log_records(out)}) < n:
        assert p.poll() is None, "the sweep ended before it could be interrupted"
        assert time.time() < deadline, "the sweep made no progress"
        time.sleep(0.002)


def killed_partway(path, out, n):
    """Starts the sweep with no checkpoint and SIGKILLs it once `n` runs are in its log: those
    runs are then stored in the log only (the output file holds none of them)."""
    p = start(path, out, checkpoint="0")
    wait_stored(out, n, p)
    p.send_signal(signal.SIGKILL)
    p.communicate()


def already_done(stderr):
    m = re.search(r"(\d+) of (\d+) runs already done", stderr)
    return int(m.group(1)) if m else 0


def status_done(path, out):
    r = run("status", path, "-o", out)
    m = re.search(r"(\d+) runs: (\d+) done", r.stdout)
    assert m, r.stdout + r.stderr
    return int(m.group(2)), r.stdout


def no_history():
    s = interruptible_sweep()
    s["record"]["history"] = False
    return s


@pytest.fixture(scope="module")
def references(tmp_path_factory, binary):
    d = tmp_path_factory.mktemp("ref")
    refs = {}
    for name, sweep in (("history", interruptible_sweep()), ("summary", no_history())):
        path = write_sweep(d / f"{name}.json", sweep)
        out = d / f"{name}.h5"
        r = run("run", path, "-o", out, "--jobs", "2", "--quiet")
        assert r.returncode == 0, r.stderr
        refs[name] = out
    return refs


@pytest.mark.parametrize("kind", ["history", "summary"])
def test_kill_storm_resumes_bitwise(references, tmp_path, kind):
    sweep = interruptible_sweep() if kind == "history" else no_history()
    path = write_sweep(tmp_path / "storm.json", sweep)
    out = tmp_path / "storm.h5"
    rng = random.Random(11 if kind == "history" else 14)
    kills = 0
    finished_early = 0
    while kills < 24:
        before = segment_count(out)
        p = start(path, out)
        time.sleep(rng.uniform(0.002, 0.12))
        if p.poll() is not None:
            # Finished before the kill: start over from scratch in a new output.
            finished_early += 1
            assert p.returncode == 0, p.communicate()[1]
            out = tmp_path / f"storm{finished_early}.h5"
            continue
        p.send_signal(signal.SIGKILL)
        _, err = p.communicate()
        kills += 1
        # Nothing stored is lost; what a process says is stored, is.
        after = segment_count(out)
        assert after >= before
        reported = [int(m) for m in re.findall(r"chainsweep: (\d+)/\d+ runs done", err)]
        assert after >= max(reported, default=0)
        if before:
            assert already_done(err) == before or "already done" not in err, (before, err)
        # Few files whatever the number of processes: each leaves at most one log.
        logs = [f for f in work_dir_files(out) if f.suffix == ".log"]
        assert len(logs) <= 17, logs
    r = run("run", path, "-o", out, "--jobs", "2", "--checkpoint-interval", "0.01")
    assert r.returncode == 0, r.stderr
    assert_files_equal(references[kind], out)
    # Complete: every run is in the output file; beside it only its snapshot (its summaries).
    assert log_records(out) == []
    assert [f.name for f in work_dir_files(out)] == ["lock", "snapshot"]
    print(f"{kind}: {kills} kills, {finished_early} runs finished before their kill")


def large_summary_sweep():
    """20 000 runs of a 4-cylinder chain over 0.1 ms, summaries only: the store, not the solver,
    is what such a sweep costs, and every summary column spans several chunks."""
    s = base_sweep(cylinders=4, duration_s=1e-4, probes=(1, 3))
    s["base"]["integrator"]["rtol"] = 1e-6
    s["axes"] = [
        {"field": "chain.cylinder.mass.heavy_cylinders.mass_ratio", "range": {"start": 0.1, "stop": 1.0, "num": 200}},
        {"field": "physics.damping_kg_s", "range": {"start": 0.0, "stop": 20.0, "num": 100}},
    ]
    return s


def test_a_partial_output_costs_what_it_holds(tmp_path, binary):
    """The output published while a sweep runs holds the chunks of its finished points only: a
    file of few finished runs is small (refreshing it costs what it holds, not the whole grid),
    reads the same (a pending point reads as pending wherever it lies), and the sweep resumes
    from it to the file an uninterrupted run writes."""
    path = write_sweep(tmp_path / "big.json", large_summary_sweep())
    ref = tmp_path / "ref.h5"
    r = run("run", path, "-o", ref, "--jobs", "2", "--quiet")
    assert r.returncode == 0, r.stderr
    complete = ref.stat().st_size
    out = tmp_path / "out.h5"
    # Killed once its first run is stored: the output is the one written before any run, which
    # holds the headers only: a pending point names no run and its checksum is 0, the fill, so
    # not one chunk of a summary is written.
    killed_partway(path, out, 1)
    first = out.stat().st_size
    with h5py.File(ref, "r") as g:
        naming = sum(g[n].id.get_storage_size() for n in ("run_hash", "summary_checksum"))
    assert first < 0.1 * naming, (first, naming, complete)
    with h5py.File(out, "r") as f:
        assert (f["status"][()] == 0).all()
        assert np.isnan(f["leading_peak"][()]).all()
        assert (f["events"][()] == -1).all() and (f["warnings"][()] == b"").all()
        assert (f["run_hash"][()] == b"").all() and (f["summary_checksum"][()] == 0).all()
        for name, d in f.items():
            if isinstance(d, h5py.Dataset) and d.shape[:2] == f["status"].shape:
                assert d.id.get_num_chunks() == 0, name
    st = run("status", out)
    assert st.returncode == 3 and "damaged" not in st.stdout + st.stderr, st.stdout + st.stderr
    # Stopped (SIGTERM) after a tenth of its runs: the output holds every finished run.
    p = start(path, out, checkpoint="0")
    wait_stored(out, 2000, p)
    p.send_signal(signal.SIGTERM)
    _, err = p.communicate()
    assert p.returncode == 128 + signal.SIGTERM, err
    # What the partial file may hold: every chunk of what names every point, and of every other
    # column the chunks (a share of the complete file's) that hold a finished point.
    allowed = 0
    with h5py.File(out, "r") as f, h5py.File(ref, "r") as g:
        status = f["status"][()]
        done = status != 0
        n_done = int(done.sum())
        assert n_done >= 2000 and int(f.attrs["n_ok"]) == int((status == 1).sum())
        for name, d in f.items():
            if not isinstance(d, h5py.Dataset) or d.shape[:2] != status.shape:
                continue
            c = d.chunks
            across = int(np.prod([-(-n // k) for n, k in zip(d.shape[2:], c[2:])]))
            grid_chunks = -(-status.shape[0] // c[0]) * -(-status.shape[1] // c[1])
            touched = len({(i // c[0], j // c[1]) for i, j in zip(*np.nonzero(done))}) * across
            assert d.id.get_num_chunks() <= touched, (name, d.id.get_num_chunks(), touched)
            allowed += g[name].id.get_storage_size() * touched / (grid_chunks * across)
            a, b = d[()], g[name][()]
            if a.dtype == np.dtype("S1"):
                # Text: as wide as the longest in the file.
                a, b = (np.array(x.view(f"S{x.shape[-1]}")[..., 0].tolist(), dtype=object) for x in (a, b))
            if name in ("wall_time_s", "summary_checksum"):
                continue
            if a.dtype == object:
                assert a[done].tolist() == b[done].tolist(), name
                pending = a[~done].tolist()
            else:
                assert a[done].tobytes() == b[done].tobytes(), name
                pending = [x.tobytes() for x in a[~done]]
            # Every pending point reads the same, in a chunk written or not.
            assert len(set(pending)) <= 1, name
    # Beyond the chunks: the objects' headers, attributes and scales, the same in both files.
    assert out.stat().st_size < allowed + 0.1 * complete, (out.stat().st_size, allowed, complete)
    assert allowed < 0.75 * complete, (allowed, complete)
    st = run("status", out)
    assert st.returncode == 3 and f"{n_done} done" in st.stdout, st.stdout
    r = run("run", path, "-o", out, "--jobs", "2", "--quiet")
    assert r.returncode == 0, r.stderr
    assert_files_equal(ref, out)
    assert out.stat().st_size == complete


# The system tier (`make test-system`): a tmpfs mounted as root.
@pytest.mark.system
def test_full_disk_is_a_clear_error_and_resumes(references, tmp_path):
    disk = tmp_path / "disk"
    disk.mkdir()
    subprocess.run(["mount", "-t", "tmpfs", "-o", "size=2m", "tmpfs", str(disk)], check=True)
    try:
        path = write_sweep(tmp_path / "full.json", interruptible_sweep())
        out = disk / "full.h5"
        r = run("run", path, "-o", out, "--jobs", "2", "--checkpoint-interval", "0.01")
        assert r.returncode not in (0, 3), r.stderr
        assert "No space left on device" in r.stderr, r.stderr
        stored = segment_count(out)
        assert 0 < stored < 100
        # Nothing stored was lost: the same command, once space is freed, resumes from there.
        subprocess.run(["mount", "-o", "remount,size=64m", str(disk)], check=True)
        r = run("run", path, "-o", out, "--jobs", "2")
        assert r.returncode == 0, r.stderr
        assert already_done(r.stderr) >= stored - 2, (stored, r.stderr)
        assert_files_equal(references["history"], out)
        assert not list((disk / "full.h5.d" / "tmp").iterdir())
    finally:
        subprocess.run(["umount", str(disk)], check=True)


# The system tier (`make test-system`): strace, which it installs, fails one write.
@pytest.mark.system
def test_a_write_that_fails_unseen_is_never_published(references, tmp_path):
    """One write of the file fails (ENOSPC on the 25th pwrite64, as a failing disk would): HDF5
    does not report a chunk it writes out when its dataset closes, and the file held fill values
    where the runs' are, published with a snapshot that vouched for it ("10 ok", `run` nothing to
    do, the logs compacted away). It is read back before it is published: the run exits with the
    error, nothing damaged is published, and the same command writes the file whole."""
    path = write_sweep(tmp_path / "w.json", no_history())
    out = tmp_path / "w.h5"
    r = subprocess.run(["strace", "-f", "-o", "/dev/null", "-e", "inject=pwrite64:error=ENOSPC:when=25",
                        str(BIN), "run", str(path), "-o", str(out), "--quiet"], capture_output=True, text=True)
    assert r.returncode == 1 and "does not read back whole" in r.stderr, r.stderr
    r = run("run", path, "-o", out, "--quiet")
    assert r.returncode == 0, r.stderr
    assert_files_equal(references["summary"], out)


def test_few_files_and_a_small_work_directory(tmp_path, binary):
    s = base_sweep(cylinders=4, duration_s=4e-5, history=True, probes=(1, 3))
    s["axes"] = [
        {"field": "chain.cylinder.mass.heavy_cylinders.mass_ratio", "range": {"start": 0.2, "stop": 1.0, "num": 40}},
        {"field": "physics.damping_kg_s", "range": {"start": 0.0, "stop": 10.0, "num": 50}},
    ]
    path = write_sweep(tmp_path / "many.json", s)
    out = tmp_path / "many.h5"
    # Interrupted twice, then completed: three processes, never one file per run. What a killed
    # process leaves: the lock, the snapshot, at most the two temporaries of a publish it was
    # killed in (the next process removes them), and logs: each process adds at most two, its
    # own and, once the sweep is complete and published, the one the kept (verification)
    # records are compacted into. (A process killed between that log's rename and the removal
    # of the older ones leaves them all; on a fast machine the second process gets that far.)
    for processes, delay in ((1, 0.3), (2, 0.6)):
        p = start(path, out, "--verify", "0.02", checkpoint="0.05")
        time.sleep(delay)
        p.send_signal(signal.SIGKILL)
        p.communicate()
        files = work_dir_files(out)
        kinds = {}
        for f in files:
            kind = f.parent.name if f.parent.name in ("logs", "tmp") else f.name
            kinds[kind] = kinds.get(kind, 0) + 1
        assert set(kinds) <= {"lock", "snapshot", "logs", "tmp"}, files
        assert kinds.get("logs", 0) <= 2 * processes and kinds.get("tmp", 0) <= 2, files
    r = run("run", path, "-o", out, "--jobs", "2", "--verify", "0.02")
    assert r.returncode == 0, r.stderr
    assert "2000 runs: 2000 ok" in r.stderr
    files = work_dir_files(out)
    assert len(files) <= 3, files
    used = sum(f.stat().st_size for f in files)
    assert used <= 0.2 * out.stat().st_size, (used, out.stat().st_size)
    # The verification runs (the file holds only their outcome) are what stays.
    assert len(log_records(out)) == 40
    assert status_done(path, out)[0] == 2000
    # Resuming the complete sweep reads its runs back from the file: nothing runs again, and
    # the file is left as it is.
    before = out.stat().st_mtime_ns
    r = run("run", path, "-o", out, "--jobs", "2", "--verify", "0.02")
    assert r.returncode == 0 and "nothing to do" in r.stderr, r.stderr
    assert "2000 runs: 2000 ok" in r.stderr
    assert out.stat().st_mtime_ns == before


def test_torn_and_corrupt_records_are_recomputed_and_status_agrees(references, tmp_path):
    path = write_sweep(tmp_path / "c.json", no_history())
    out = tmp_path / "c.h5"
    killed_partway(path, out, 12)
    recs = log_records(out)
    assert len(recs) >= 12
    log = out.parent / (out.name + ".d") / "logs" / recs[0][0]
    data = bytearray(log.read_bytes())
    # Flip a byte inside the third record (packed against the first, which it does not touch),
    # and tear the last one in half.
    starts = [(at, n) for at, n, _, _ in log_frames(data)]
    assert log_frames(data)[2][2], "the third record is packed"
    damage_frame(data, 2, starts[2][1] // 2, 0x01)
    last, nl = starts[-1]
    data = data[: last + 8 + nl // 2]
    log.write_bytes(bytes(data))
    valid = len({h for _, h, _ in log_records(out)})
    assert valid == len(starts) - 2
    # `status` counts only whole, checksummed records: exactly what `run` finds done.
    done, _ = status_done(path, out)
    assert done == valid
    r = run("run", path, "-o", out, "--jobs", "2")
    assert r.returncode == 0, r.stderr
    assert already_done(r.stderr) == valid
    assert_files_equal(references["summary"], out)


def test_a_directory_named_like_a_log_or_segment_is_left_out(references, tmp_path):
    path = write_sweep(tmp_path / "d.json", no_history())
    out = tmp_path / "d.h5"
    work = tmp_path / "d.h5.d"
    (work / "logs" / "00000001.log").mkdir(parents=True)
    (work / "segments" / ("ab" * 32 + ".seg")).mkdir(parents=True)
    done, text = status_done(path, out)
    assert done == 0 and "ignored" in text and "00000001.log" in text
    killed_partway(path, out, 5)
    done, text = status_done(path, out)
    assert done >= 5 and "00000001.log" in text and "ab" * 32 + ".seg" in text
    r = run("run", path, "-o", out, "--jobs", "2")
    assert r.returncode == 0, r.stderr
    assert already_done(r.stderr) == done
    assert_files_equal(references["summary"], out)


def test_one_file_segments_of_earlier_versions_resume(references, tmp_path):
    path = write_sweep(tmp_path / "old.json", no_history())
    out = tmp_path / "old.h5"
    killed_partway(path, out, 10)
    # Rewrite the work directory as an earlier version left it: one segment file per run.
    work = tmp_path / "old.h5.d"
    seg = work / "segments"
    seg.mkdir()
    n = 0
    for _, rec in log_segments(out):
        (seg / (rec[8:40].hex() + ".seg")).write_bytes(rec)
        n += 1
    for log in sorted((work / "logs").glob("*.log")):
        log.unlink()
    stored = segment_count(out)
    assert stored >= 10
    assert status_done(path, out)[0] == stored
    r = run("run", path, "-o", out, "--jobs", "2")
    assert r.returncode == 0, r.stderr
    assert already_done(r.stderr) == stored
    assert not seg.exists()
    assert_files_equal(references["summary"], out)


def test_runs_retried_but_not_yet_published_reach_the_file_on_the_next_run(tmp_path, binary):
    """`run --retry-failed` killed after some retried runs were stored but before the file was
    published again: the next `run` writes them into the file. (It took the file, which held
    every point with its old failure, for done: "nothing to do", exit 0, the failures kept.)"""
    path = write_sweep(tmp_path / "r.json", no_history())
    out = tmp_path / "r.h5"
    failing = list(range(0, 40, 2))
    env = dict(os.environ, CHAINSWEEP_INJECT_PANIC=",".join(map(str, failing)))
    r = subprocess.run([str(BIN), "run", str(path), "-o", str(out), "--quiet"], env=env,
                       capture_output=True, text=True)
    assert r.returncode == 3, r.stderr
    before = {h for _, h, _ in log_records(out)}
    p = start(path, out, "--retry-failed", checkpoint="0")
    wait_stored(out, len(before) + 5, p)
    p.send_signal(signal.SIGKILL)
    p.communicate()
    with h5py.File(out, "r") as f:
        assert int((f["status"][()] == 2).sum()) == len(failing)
    r = run("run", path, "-o", out)
    assert r.returncode == 3, r.stderr
    assert "nothing to do" not in r.stderr, r.stderr
    retried = {h for _, h, ok in log_records(out) if ok} - before
    with h5py.File(out, "r") as f:
        still_failed = int((f["status"][()] == 2).sum())
    assert 0 < still_failed <= len(failing) - 5, (still_failed, len(retried))
    status = run("status", path, "-o", out)
    assert f"{still_failed} failed" in status.stdout, status.stdout


def test_gc_removes_orphans_and_never_a_needed_run(tmp_path, binary):
    s = no_history()
    path = write_sweep(tmp_path / "g.json", s)
    out = tmp_path / "g.h5"
    killed_partway(path, out, 40)
    before = {h for _, h, _ in log_records(out)}
    # Edit the sweep: half of the damping values change, so their points' runs become orphans.
    s["axes"][1]["values"] = [0, 2, 4, 6, 8, 11, 16, 21, 51, 101]
    write_sweep(path, s)
    needed, _ = status_done(path, out)
    assert 0 < needed < len(before)
    r = run("gc", path, "-o", out)
    assert r.returncode == 0, r.stderr
    removed = int(re.search(r"removed (\d+) run", r.stdout).group(1))
    after = {h for _, h, _ in log_records(out)}
    assert removed == len(before) - needed == len(before - after)
    assert after <= before
    # Every run the edited sweep needs is still there, and it resumes from them.
    assert status_done(path, out)[0] == needed
    r = run("run", path, "-o", out, "--jobs", "2")
    assert r.returncode == 0, r.stderr
    assert already_done(r.stderr) == needed
    fresh = tmp_path / "fresh.h5"
    assert run("run", path, "-o", fresh, "--jobs", "2", "--quiet").returncode == 0
    assert_files_equal(fresh, out)
    # A second gc finds nothing to remove.
    r = run("gc", path, "-o", out)
    assert r.returncode == 0 and "removed 0 run" in r.stdout, r.stdout
    # A `damaged` folder that is a link is never emptied through it (it emptied the folder it
    # pointed to).
    victim = tmp_path / "victim"
    victim.mkdir()
    (victim / "keep.txt").write_text("mine")
    (tmp_path / "g.h5.d" / "damaged").symlink_to(victim)
    r = run("gc", path, "-o", out)
    assert r.returncode != 0 and "symbolic link" in r.stderr, r.stdout + r.stderr
    assert (victim / "keep.txt").read_text() == "mine"
