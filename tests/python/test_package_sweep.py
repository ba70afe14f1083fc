"""chainsweep.sweep: the CLI's `run` in-process — the same file bitwise, resume, exit codes as
results and exceptions, failures listed, progress (callback, tqdm, plain lines), Ctrl-C."""

from __future__ import annotations

import fcntl
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

import chainsweep
from chainsweep import _sweep
from conftest import assert_files_equal, segment_count, texts
from conftest import run as cli
from scenes import sweep_spec, write


def segments(out: Path) -> dict[str, int]:
    """The runs the output file holds done (a complete sweep's runs are there, not beside it),
    with their stored wall time's bits: a run computed again would change it."""
    with h5py.File(out, "r") as f:
        status = f["status"][...].ravel()
        hashes = list(texts(f["run_hash"]).ravel())
        wall = f["wall_time_s"][...].ravel()
    return {h: float(w).hex() for h, s, w in zip(hashes, status, wall) if s != 0}


def failing_spec() -> dict:
    """3 mass ratios x rtol 1e-9, 1e-5: the rtol 1e-5 runs drift by ~1e-4, over the limit 1e-6."""
    spec = sweep_spec()
    spec["axes"][1] = {"field": "integrator.rtol", "values": [1e-9, 1e-5]}
    spec["limits"] = {"energy_drift_max": 1e-6}
    return spec


def test_sweep_file_equals_the_command_line(tmp_path, binary):
    path = write(tmp_path / "s.json", sweep_spec(history=True))
    r = chainsweep.sweep(path, tmp_path / "py.h5", jobs=2, progress=False)
    assert (r.exit_code, r.n_runs, r.n_ok, r.n_failed, r.n_pending, r.ran) == (0, 6, 6, 0, 0, 6)
    assert r.complete and r.failures == [] and os.fspath(r) == str(tmp_path / "py.h5")
    c = cli("run", path, "-o", tmp_path / "cli.h5", "--jobs", "1", "--quiet")
    assert c.returncode == 0, c.stderr
    assert_files_equal(tmp_path / "py.h5", tmp_path / "cli.h5")


def test_second_call_resumes_and_runs_nothing(tmp_path):
    spec = sweep_spec()
    out = tmp_path / "s.h5"
    first = chainsweep.sweep(spec, out, progress=False)
    assert first.ran == 6 and first.complete
    before = segments(out)
    assert len(before) == 6
    second = chainsweep.sweep(spec, out, progress=False)
    assert second.ran == 0 and second.complete and second.exit_code == 0
    assert segments(out) == before
    # editing the sweep reruns exactly the new points
    spec["axes"][1]["values"].append(10)
    third = chainsweep.sweep(spec, out, progress=False)
    assert third.ran == 3 and third.n_runs == 9
    after = segments(out)
    assert {k: after[k] for k in before} == before


def test_a_shard_runs_its_share_of_the_points(tmp_path):
    out = tmp_path / "part.h5"
    r = chainsweep.sweep(sweep_spec(), out, shard=(2, 3), progress=False)
    assert (r.exit_code, r.n_runs, r.ran) == (0, 2, 2)
    with h5py.File(out, "r") as f:
        assert f.attrs["shard"] == "2/3"
        status = f["status"][()].ravel()
        assert sorted(status) == [0, 0, 0, 0, 1, 1]
    # The same points as `chainsweep run --shard 2/3` (the engine's balanced assignment).
    by_cli = tmp_path / "cli.h5"
    spec = write(tmp_path / "spec.json", sweep_spec())
    p = cli("run", spec, "--shard", "2/3", "-o", by_cli, "--quiet")
    assert p.returncode == 0, p.stderr
    with h5py.File(by_cli, "r") as f:
        assert list(f["status"][()].ravel()) == list(status)
    assert chainsweep.sweep(sweep_spec(), out, shard="2/3", progress=False).ran == 0


def test_failed_runs_are_a_partial_result(tmp_path, capsys):
    out = tmp_path / "f.h5"
    r = chainsweep.sweep(failing_spec(), out, jobs=2)
    assert r.exit_code == 3 and not r.complete
    assert r.n_failed == 3 and r.n_ok == 3
    assert len(r.failures) == r.n_failed
    with h5py.File(out, "r") as f:
        drift = f["energy_drift_max"][()]
        status = f["status"][()]
    for fl in r.failures:
        assert "exceeds the limit" in fl.reason
        assert set(fl.point) == {"mass_ratio", "rtol"}
        i, j = np.unravel_index(fl.index, (3, 2))
        assert status[i, j] == 2 and np.isnan(drift[i, j])
        assert fl.point == {"mass_ratio": [0.3, 0.55, 1.0][i], "rtol": 1e-5}
    err = capsys.readouterr().err
    assert f"chainsweep: {r.n_failed} failed run(s):" in err
    assert "exceeds the limit" in err and "chainsweep: 6/6 runs done" in err
    # they are recorded: a second call runs nothing, retry_failed runs them again
    assert chainsweep.sweep(failing_spec(), out, progress=False).ran == 0
    again = chainsweep.sweep(failing_spec(), out, retry_failed=True, progress=False)
    assert again.ran == r.n_failed and again.n_failed == r.n_failed


def test_verify(tmp_path):
    out = tmp_path / "v.h5"
    calls = []
    r = chainsweep.sweep(sweep_spec(), out, verify=0.5, progress=lambda *c: calls.append(c))
    assert r.complete and r.ran == 6 + 3
    assert calls[-1] == (9, 0, 9)
    with h5py.File(out, "r") as f:
        assert int((f["verified"][()] == 1).sum()) == 3
        assert f.attrs["verify_fraction"] == 0.5


@pytest.mark.parametrize(
    "kwargs, field",
    [
        ({"jobs": 0}, "jobs"),
        ({"jobs": 1.5}, "jobs"),
        ({"shard": (4, 3)}, "shard"),
        ({"shard": "x"}, "shard"),
        ({"verify": 2.0}, "verify"),
        ({"checkpoint_interval": -1.0}, "checkpoint_interval"),
    ],
)
def test_bad_arguments_name_the_argument(tmp_path, kwargs, field):
    with pytest.raises(chainsweep.InputError) as e:
        chainsweep.sweep(sweep_spec(), tmp_path / "x.h5", progress=False, **kwargs)
    assert e.value.field == field
    assert list(tmp_path.iterdir()) == []


def test_bad_sweep_names_the_field_and_creates_nothing(tmp_path):
    spec = sweep_spec()
    spec["axes"][0]["values"][1] = 1.5
    with pytest.raises(chainsweep.InputError) as e:
        chainsweep.sweep(spec, tmp_path / "x.h5", progress=False)
    assert e.value.field == "axes[0].values[1]"
    assert "must lie in (0, 1]" in str(e.value)
    del spec["base"]["duration_s"]
    with pytest.raises(chainsweep.InputError) as e:
        chainsweep.sweep(spec, tmp_path / "x.h5", progress=False)
    assert e.value.field == "base.duration_s"
    with pytest.raises(chainsweep.InputError) as e:
        chainsweep.sweep(sweep_spec(), tmp_path / "no-such-dir" / "x.h5", progress=False)
    assert e.value.field == "output"
    with pytest.raises(chainsweep.InputError) as e:
        chainsweep.sweep(tmp_path / "missing.json", tmp_path / "x.h5", progress=False)
    assert "cannot read the sweep file" in str(e.value)
    assert list(tmp_path.iterdir()) == []


def test_locked_output_is_a_sweep_error(tmp_path):
    out = tmp_path / "s.h5"
    work = Path(f"{out}.d")
    work.mkdir()
    with open(work / "lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        with pytest.raises(chainsweep.SweepError) as e:
            chainsweep.sweep(sweep_spec(), out, progress=False)
    assert "is working on" in str(e.value) and isinstance(e.value, RuntimeError)
    assert not out.exists()
    assert chainsweep.sweep(sweep_spec(), out, progress=False).complete


def test_progress_callback_counts_up_to_the_total(tmp_path):
    calls = []
    chainsweep.sweep(sweep_spec(), tmp_path / "s.h5", progress=lambda *c: calls.append(c))
    assert calls[0] == (0, 0, 6) and calls[-1] == (6, 0, 6)
    done = [c[0] for c in calls]
    assert done == sorted(done) and all(c[2] == 6 for c in calls)
    calls.clear()
    chainsweep.sweep(sweep_spec(), tmp_path / "s.h5", progress=lambda *c: calls.append(c))
    assert calls[0] == calls[-1] == (6, 0, 6)


def test_progress_bar_and_plain_lines(tmp_path, monkeypatch, capfd):
    # stderr is captured here: not a terminal, so plain lines as the command line prints them
    chainsweep.sweep(sweep_spec(), tmp_path / "a.h5")
    err = capfd.readouterr().err
    assert "chainsweep: 6/6 runs done, 0 failed" in err and "ETA" in err and "\r" not in err
    # in a terminal or a notebook: a tqdm bar (tqdm is in requirements.txt)
    assert _sweep._tqdm is not None
    monkeypatch.setattr(_sweep, "_interactive", lambda: True)
    chainsweep.sweep(sweep_spec(), tmp_path / "b.h5")
    err = capfd.readouterr().err
    assert "chainsweep: 100%" in err and "6/6" in err and "run/s" in err
    # without tqdm: plain lines
    monkeypatch.setattr(_sweep, "_tqdm", None)
    chainsweep.sweep(sweep_spec(), tmp_path / "c.h5")
    assert "chainsweep: 6/6 runs done, 0 failed" in capfd.readouterr().err
    chainsweep.sweep(sweep_spec(), tmp_path / "d.h5", progress=False)
    assert capfd.readouterr().err == ""


def slow_spec(duration_s: float = 1e-3) -> dict:
    """100 runs of about 10 ms each per ms of `duration_s`: long enough to be interrupted."""
    spec = sweep_spec(cylinders=50, duration_s=duration_s, probes=(4, 21))
    spec["axes"] = [
        {"field": "chain.cylinder.mass.heavy_cylinders.mass_ratio",
         "range": {"start": 0.1, "stop": 1.0, "num": 50}},
        {"field": "physics.damping_kg_s", "values": [0, 6]},
    ]
    return spec


def test_an_exception_in_the_progress_callback_stops_the_sweep_cleanly(tmp_path):
    out = tmp_path / "s.h5"

    def boom(done, failed, total):
        if done >= 3:
            raise RuntimeError("stop here")

    with pytest.raises(RuntimeError, match="stop here"):
        chainsweep.sweep(slow_spec(), out, jobs=1, progress=boom)
    with h5py.File(out, "r") as f:
        ok, pending = int(f.attrs["n_ok"]), int(f.attrs["n_pending"])
    assert ok >= 3 and pending > 0 and ok + pending == 100
    rest = chainsweep.sweep(slow_spec(), out, jobs=2, progress=False)
    assert rest.complete and rest.ran == pending


INTERRUPTED = """
import json, signal, sys
import chainsweep
# Python leaves SIGINT ignored when it starts with it ignored, as every background job of a
# non-interactive shell does (`make test &`, nohup): the test's Ctrl-C must reach it regardless.
signal.signal(signal.SIGINT, signal.default_int_handler)
try:
    chainsweep.sweep(json.loads(sys.argv[1]), sys.argv[2], jobs=1, progress=False)
except KeyboardInterrupt:
    print("KeyboardInterrupt", flush=True)
    sys.exit(130)
print("finished", flush=True)
"""


def test_ctrl_c_stops_cleanly_and_the_same_call_resumes(tmp_path):
    out = tmp_path / "s.h5"
    proc = subprocess.Popen(
        # 5 ms runs (about 5 s in all on one worker): a loaded machine still delivers the signal
        # long before the sweep could end by itself.
        [sys.executable, "-c", INTERRUPTED, json.dumps(slow_spec(5e-3)), str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    deadline = time.monotonic() + 120
    while segment_count(out) < 3:
        assert proc.poll() is None and time.monotonic() < deadline, proc.communicate()
        time.sleep(0.02)
    proc.send_signal(signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 130, (stdout, stderr)
    assert stdout.strip() == "KeyboardInterrupt"
    assert "interrupted; the runs finished so far are stored" in stderr
    with h5py.File(out, "r") as f:
        ok, pending = int(f.attrs["n_ok"]), int(f.attrs["n_pending"])
        assert int((f["status"][()] == 1).sum()) == ok
    # stopped early, nothing lost: the runs done are in the file, the rest pending
    assert ok >= 3 and pending > 0 and ok + pending == 100
    assert segment_count(out) == ok
    assert not list((Path(f"{out}.d") / "tmp").iterdir())
    rest = chainsweep.sweep(slow_spec(5e-3), out, jobs=2, progress=False)
    assert rest.complete and rest.ran == pending


def test_a_sweep_given_as_a_dict_finds_its_files_from_the_working_directory(tmp_path, monkeypatch):
    """A dict names its files (a fit's data, a recorded drive, a fit's result) relative to the
    working directory, as run() and a sweep file there do (they were looked for in the temporary
    folder the dict is written to)."""
    monkeypatch.chdir(tmp_path)
    with h5py.File("fit.h5", "w") as f:
        f.attrs["sweep"] = json.dumps(
            {"search": {"goal": "fit", "fields": [{"field": "physics.damping_kg_s", "min": 0, "max": 10}]}}
        )
        f["fit_damping_kg_s"] = np.array([0.5])
        f["fit_covariance"] = np.array([[1e-4]])
        f["fit_status"] = np.array([1], dtype=np.uint8)
        f["fit_p_value"] = np.array([0.5])
    spec = sweep_spec()
    spec.pop("axes", None)
    spec["ensemble"] = {
        "inputs": [{"from_fit": "fit.h5"}],
        "design": "monte_carlo",
        "samples": 4,
        "statistics": [{"name": "t", "of": {"summary": "t_end_s"}}],
    }
    r = chainsweep.sweep(spec, "e.h5", progress=False)
    assert r.exit_code == 0 and r.n_runs == 4, r

