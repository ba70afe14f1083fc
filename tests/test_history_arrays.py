"""The runs' histories as one chunked variable over the grid (file layout 5): runs of different
lengths, failed and pending runs, runs sampled at different intervals, read back bitwise by the
engine (re-assembly, merge), by h5py, by xarray (lazily) and by chainsweep.open; and a reduction
over every history of a large file in memory bounded by the chunks, not by the file."""

import json
import shutil
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest
import xarray as xr

import chainsweep
import chainsweep._open

from conftest import assert_files_equal, base_sweep, run, write_sweep

ENGINES = ["h5netcdf", "netcdf4"]


def stopping_sweep():
    """Runs that stop once the leading pulse has passed every probe: histories of different
    lengths (the heavier the chain, the later)."""
    s = base_sweep(history=True, duration_s=1e-3)
    s["record"]["stop_after_leading_pulses"] = True
    s["record"]["min_overlap"] = True
    return s


def reassembled(out, again, sweep):
    """`out` (complete, with its work directory) copied to `again` and written again by
    `chainsweep run` from its own runs: a complete sweep's logs are compacted away, so every run
    is read back from the file; without the snapshot the file is not known to be as published,
    so it is rewritten."""
    shutil.copy(out, again)
    shutil.copytree(f"{out}.d", f"{again}.d")
    Path(f"{again}.d", "snapshot").unlink()
    r = run("run", sweep, "-o", again)
    assert r.returncode == 0 and "already done" in r.stderr, r.stderr
    return again


@pytest.fixture(scope="module")
def stopped(tmp_path_factory, binary):
    d = tmp_path_factory.mktemp("stopped")
    path = write_sweep(d / "s.json", stopping_sweep())
    out = d / "s.h5"
    r = run("run", path, "-o", out, "--quiet")
    assert r.returncode == 0, r.stderr
    return path, out


def test_histories_of_different_lengths_end_in_fill(stopped):
    _, out = stopped
    with h5py.File(out, "r") as f:
        n = f["history_samples"][()]
        h = f["history"][()]
        t = f["time_s"][()]
        status = f["status"][()]
        # One unit: the time series are checksummed, not compressed (inflating bounded their
        # reading), the per-run minimum overlaps compressed.
        d = f["history"]
        assert d.fletcher32 and d.compression is None and not d.shuffle
        m = f["min_overlap_m"]
        assert m.fletcher32 and m.compression == "gzip" and m.shuffle
    assert (status == 1).all()
    assert len(np.unique(n)) > 1, n  # the runs stopped at different times
    assert t.shape == (h.shape[-1],) and h.shape[-1] >= n.max()
    for i in np.ndindex(n.shape):
        m = int(n[i])
        assert np.isfinite(h[i][:, :m]).all() and np.isnan(h[i][:, m:]).all(), i
    ds = chainsweep.open(out, histories=True)
    assert ds.history.values.tobytes() == h.tobytes()
    assert ds.history_samples.values.tolist() == n.tolist()


def test_the_engine_reads_the_arrays_back_bitwise(stopped, tmp_path):
    """A complete output re-assembled from itself (every run read back from the arrays and
    written again), and shards merged, give the same file as the single run."""
    path, out = stopped
    again = reassembled(out, tmp_path / "again.h5", path)
    assert_files_equal(out, again)
    parts = []
    for k in (1, 2):
        part = tmp_path / f"part-{k}.h5"
        assert run("run", path, "--shard", f"{k}/2", "-o", part, "--quiet").returncode == 0
        parts.append(part)
    # A shard's pending runs: NaN histories, no samples.
    with h5py.File(parts[0], "r") as f:
        pending = f["status"][()] == 0
        assert pending.any() and (f["history_samples"][()][pending] == -1).all()
        assert np.isnan(f["history"][()][pending]).all()
        assert np.isnan(f["min_overlap_m"][()][pending]).all()
    merged = tmp_path / "merged.h5"
    assert run("merge", "-o", merged, *parts).returncode == 0
    assert_files_equal(out, merged)


@pytest.mark.parametrize("engine", ENGINES)
def test_runs_sampled_at_different_intervals(tmp_path, binary, engine):
    """The interval an axis: no one time axis; the dimension `sample` and every run's instants
    in `time_s` over (grid, sample), NaN after its end."""
    s = base_sweep(history=True)
    s["axes"][1] = {"field": "record.history_interval_s", "values": [1e-6, 2.5e-6]}
    path = write_sweep(tmp_path / "s.json", s)
    out = tmp_path / "s.h5"
    assert run("run", path, "-o", out, "--quiet").returncode == 0
    ds = xr.open_dataset(out, engine=engine, chunks={})
    assert ds.history.dims == ("mass_ratio", "history_interval_s", "probe", "sample")
    assert ds.time_s.dims == ("mass_ratio", "history_interval_s", "sample")
    for j, dt in enumerate([1e-6, 2.5e-6]):
        n = ds.history_samples.values[:, j].astype(int)  # (masked where none: float)
        t = ds.time_s.values[:, j]
        m = int(n[0])
        assert (n == m).all()
        np.testing.assert_array_equal(t[:, :m], np.broadcast_to(np.arange(m) * dt, t[:, :m].shape))
        assert np.isnan(t[:, m:]).all() and np.isnan(ds.history.values[:, j, :, m:]).all()
    c = chainsweep.open(out, histories=True)
    assert c.time_s.dims == ("mass_ratio", "history_interval_s", "sample")
    assert c.history.values.tobytes() == ds.history.values.tobytes()
    assert_files_equal(out, reassembled(out, tmp_path / "again.h5", path))


def test_lazy_open_reads_nothing_until_asked(stopped, monkeypatch):
    _, out = stopped
    calls = []
    real = chainsweep._open._array_histories

    def counting(*args, **kwargs):
        calls.append(args[2] if len(args) > 2 else kwargs.get("sel"))
        return real(*args, **kwargs)

    monkeypatch.setattr(chainsweep._open, "_array_histories", counting)
    ds = chainsweep.open(out, histories="lazy")
    assert hasattr(ds.history.data, "dask") and calls == []
    peak = ds.history.max("time_s").values
    assert calls, "computing read the blocks"
    with h5py.File(out, "r") as f:
        np.testing.assert_array_equal(peak, np.nanmax(f["history"][()], axis=-1))


# A reduction over every history of a large file, in a fresh process: its peak resident memory
# beyond the imports, against the size of the history values.
REDUCE = r"""
import json, resource, sys
import numpy, xarray, h5py, dask.array
import chainsweep
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
how = sys.argv[2]
if how == "xarray":
    ds = xarray.open_dataset(sys.argv[1], engine="h5netcdf", chunks={})
else:
    ds = chainsweep.open(sys.argv[1], histories="lazy")
peak = ds.history.max("time_s").values
over = (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - base) / 1024
print(json.dumps({"over_imports_mib": over, "peak": peak.tolist()}))
"""


# The system tier (`make test-system`): a 290 MB file read in a fresh process.
@pytest.mark.system
def test_a_reduction_over_every_history_of_a_large_file_holds_chunks_not_the_file(tmp_path, binary):
    s = base_sweep(history=True, duration_s=1e-4, probes=(1, 2, 3, 4))
    s["record"]["history_interval_s"] = 1e-9  # 100 001 samples of 4 probes: 3.2 MB a run
    s["axes"] = [
        {"field": "chain.cylinder.mass.heavy_cylinders.mass_ratio",
         "range": {"start": 0.3, "stop": 1.0, "num": 12}},
        {"field": "physics.damping_kg_s", "range": {"start": 0.0, "stop": 20.0, "num": 8}},
    ]
    path = write_sweep(tmp_path / "big.json", s)
    out = tmp_path / "big.h5"
    r = run("run", path, "-o", out, "--quiet", timeout=600)
    assert r.returncode == 0, r.stderr
    with h5py.File(out, "r") as f:
        d = f["history"]
        values_mib = d.size * 8 / 2**20
        assert values_mib > 280, values_mib  # 96 runs x 4 probes x 100 001 samples
        chunk_mib = np.prod(d.chunks) * 8 / 2**20
        # the reference, one run at a time
        want = np.stack([np.nanmax(d[i], axis=-1) for i in range(d.shape[0])])
    for how in ("chainsweep", "xarray"):
        r = subprocess.run([sys.executable, "-c", REDUCE, str(out), how], capture_output=True,
                           text=True, timeout=600)
        assert r.returncode == 0, r.stderr
        res = json.loads(r.stdout)
        np.testing.assert_array_equal(np.array(res["peak"]), want)
        # Bounded by the blocks in use (a few chunks per thread, 8 MB blocks), not by the file.
        assert res["over_imports_mib"] < values_mib / 5, (how, res["over_imports_mib"], values_mib, chunk_mib)
