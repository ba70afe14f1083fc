#!/usr/bin/env python3
"""Measures candidate layouts of a sweep's histories, to choose the next file layout by measurement.

The issue "Histories for overnight sweeps": the published file (layout 4) stores every run's
histories in a group of its own, `runs/run_<i>`, one dataset per probe and its own `time_s`. This
script takes such a file (or makes one with the binary: the issue's 2 511-run sweep, mass ratio
0.2-1.0 x damping 0-30 kg/s, four gauge histories at 1 us over 1 ms), reads its histories once
into memory, and writes them again with h5py in candidate layouts: one variable `history` over
(grid..., probe, time_s), NaN after a run's end (`_FillValue`), the time axis stored once, with
several chunk shapes and filters (Fletcher-32 always, as the store checks every chunk). For each it
measures, on this machine:

- the file's size and the bytes per run beyond the raw values (the HDF5 objects a run costs);
- write throughput (raw MB per second of writing the file, run by run as the store would);
- reading every history with h5py (one slice) in raw MB/s;
- one run's histories (one slice), one probe across every run, a time window across every run;
- `xr.open_dataset(path, chunks={})` then the maximum over time of every run (dask), in a fresh
  process: its time and its peak resident memory beyond the imports.

The file of the current layout is measured the same way where it applies (reading every group).

    python scripts/bench_history_layout.py [--file X.h5] [--bin target/release/chainsweep]
        [--dir DIR] [--runs 2511]

Prints a table and writes `DIR/bench_history_layout.json`.
"""

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import h5py
import numpy as np

REPO = Path(__file__).resolve().parent.parent


def sweep(n_a, n_b):
    """The issue's sweep: mass ratio x damping, four gauge histories at 1 us over 1 ms."""
    return {
        "description": "history layout benchmark",
        "base": {
            "chain": {
                "preset": "chain_055",
                "cylinders": 4,
                "cylinder": {"mass": {"heavy_cylinders": {"mass_ratio": 0.55}}, "height_m": None},
            },
            "physics": {"gravity": True, "damping_kg_s": 0.0, "wall": True},
            "striker_velocity_m_s": 1.3,
            "duration_s": 1e-3,
            "integrator": {"method": "dop853", "rtol": 1e-6},
        },
        "record": {
            "probes": [{"kind": "gauge_force", "cylinder": c} for c in (1, 2, 3, 4)],
            "history": True,
            "history_interval_s": 1e-6,
        },
        "axes": [
            {"field": "chain.cylinder.mass.heavy_cylinders.mass_ratio",
             "range": {"start": 0.2, "stop": 1.0, "num": n_a}},
            {"field": "physics.damping_kg_s", "range": {"start": 0.0, "stop": 30.0, "num": n_b}},
        ],
    }


def make_file(binary, work, n_a, n_b):
    d = Path(work)
    spec = d / "histories.json"
    spec.write_text(json.dumps(sweep(n_a, n_b)))
    out = d / "histories.h5"
    if out.exists():
        return out
    subprocess.run([str(binary), "run", str(spec), "-o", str(out), "--quiet"], check=True)
    return out


def text(d):
    return [s.decode() for s in d[()].view(f"S{d.shape[-1]}")[..., 0]]


def load(path):
    """Every run's histories of a layout-4 file: (shape, probes, time, values (runs, P, T))."""
    with h5py.File(path, "r") as f:
        shape = tuple(int(x) for x in f.attrs["grid_shape"])
        probes = text(f["probe"])
        n = int(np.prod(shape))
        runs = f["runs"]
        T = max(len(g["time_s"]) for g in runs.values())
        values = np.full((n, len(probes), T), np.nan)
        time_s = None
        for name, g in runs.items():
            i = int(name.removeprefix("run_"))
            t = g["time_s"][()]
            if time_s is None or len(t) > len(time_s):
                time_s = t
            for k, p in enumerate(probes):
                values[i, k, : len(t)] = g[p][()]
    return shape, probes, time_s, values


def read_layout4(path):
    """Seconds to read every history (and time axis) of a layout-4 file with h5py, and bytes."""
    t0 = time.perf_counter()
    n = 0
    with h5py.File(path, "r") as f:
        for g in f["runs"].values():
            for d in g.values():
                n += d[()].nbytes
    return time.perf_counter() - t0, n


def write_candidate(path, shape, probes, time_s, values, chunk, filters):
    """One variable `history` over (grid..., probe, time_s), written run by run."""
    P, T = values.shape[1:]
    t0 = time.perf_counter()
    with h5py.File(path, "w", libver=("v110", "v110"), track_order=False) as f:
        dims = []
        for k, n in enumerate(shape):
            d = f.create_dataset(f"axis{k}", data=np.arange(n, dtype=np.float64))
            d.make_scale(f"axis{k}")
            dims.append(d)
        pr = f.create_dataset("probe", data=np.arange(P, dtype=np.int64))
        pr.make_scale("probe")
        ts = f.create_dataset("time_s", data=time_s, chunks=True, fletcher32=True)
        ts.attrs["units"] = "s"
        ts.make_scale("time_s")
        h = f.create_dataset(
            "history",
            shape=(*shape, P, T),
            dtype="f8",
            chunks=(*chunk[:-2], chunk[-2], chunk[-1]),
            fillvalue=np.nan,
            fletcher32=True,
            **filters,
        )
        h.attrs["_FillValue"] = np.nan
        h.attrs["units"] = "N"
        for k, d in enumerate(dims):
            h.dims[k].attach_scale(d)
        h.dims[len(shape)].attach_scale(pr)
        h.dims[len(shape) + 1].attach_scale(ts)
        # Run by run, as the store writes them, but a chunk's runs in one write (the writer
        # gathers the runs of a chunk row before writing it).
        grid_chunk = chunk[:-2]
        flat = values.reshape(*shape, P, T)
        if all(c == 1 for c in grid_chunk):
            for i in range(values.shape[0]):
                h[np.unravel_index(i, shape)] = values[i]
        else:
            # Blocks of whole chunks along the grid axes.
            idx = [range(0, n, c) for n, c in zip(shape, grid_chunk)]
            for start in np.ndindex(*[len(r) for r in idx]):
                sl = tuple(slice(s * c, min((s + 1) * c, n))
                           for s, c, n in zip(start, grid_chunk, shape))
                h[sl] = flat[sl]
    return time.perf_counter() - t0


def reads(path, shape):
    out = {}
    with h5py.File(path, "r") as f:
        h = f["history"]
        best = float("inf")
        for _ in range(3):  # best of three: the machine is shared
            t0 = time.perf_counter()
            a = h[()]
            best = min(best, time.perf_counter() - t0)
        out["read_all_s"] = best
        out["read_all_mb_s"] = a.nbytes / 1e6 / out["read_all_s"]
        mid = tuple(n // 2 for n in shape)
        t0 = time.perf_counter()
        for _ in range(20):
            h[mid]
        out["one_run_ms"] = (time.perf_counter() - t0) / 20 * 1e3
        t0 = time.perf_counter()
        h[..., 1, :]
        out["one_probe_all_runs_s"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        h[..., 100:150]
        out["time_window_50_all_runs_s"] = time.perf_counter() - t0
    return out


LAZY = r"""
import resource, sys, time, json
import xarray as xr, dask
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
t0 = time.perf_counter()
ds = xr.open_dataset(sys.argv[1], engine="h5netcdf", chunks={})
opened = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
lazy = ds["history"].chunks is not None
with dask.config.set(scheduler="synchronous"):
    m = ds["history"].max("time_s").values
dt = time.perf_counter() - t0
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(json.dumps({"lazy": lazy, "open_peak_mib": (opened - base) / 1024,
                  "import_peak_mib": base / 1024, "peak_mib": peak / 1024,
                  "max_over_time_s": dt, "max_over_time_peak_mib": (peak - base) / 1024}))
"""


def lazy_reduction(path):
    r = subprocess.run([sys.executable, "-c", LAZY, str(path)], capture_output=True, text=True)
    if r.returncode != 0:
        return {"error": r.stderr.strip().splitlines()[-1]}
    return json.loads(r.stdout)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--file", default=None, help="a layout-4 file with histories")
    ap.add_argument("--bin", default=str(REPO / "target" / "release" / "chainsweep"))
    ap.add_argument("--dir", default=None)
    ap.add_argument("--grid", default="81x31", help="the sweep made when no --file (n_a x n_b)")
    a = ap.parse_args()
    work = Path(a.dir or tempfile.mkdtemp(prefix="bench_history_layout."))
    work.mkdir(parents=True, exist_ok=True)
    n_a, n_b = (int(x) for x in a.grid.split("x"))
    src = Path(a.file) if a.file else make_file(a.bin, work, n_a, n_b)
    shape, probes, time_s, values = load(src)
    n = values.shape[0]
    raw = values.nbytes
    print(f"{src}: {n} runs, {len(probes)} probes, {len(time_s)} samples; raw histories "
          f"{raw / 1e6:.1f} MB; file {src.stat().st_size / 1e6:.1f} MB")
    results = {"source": str(src), "runs": n, "raw_mb": raw / 1e6}
    dt, nbytes = min(read_layout4(src) for _ in range(3))  # best of three, warm page cache
    results["layout4"] = {
        "file_mb": src.stat().st_size / 1e6,
        "read_all_s": dt,
        "read_all_mb_s": raw / 1e6 / dt,
        "read_all_bytes_incl_time": nbytes,
    }
    print(f"layout 4 (groups): file {results['layout4']['file_mb']:.1f} MB; "
          f"read every history {dt:.2f} s ({raw / 1e6 / dt:.0f} MB/s of history values)")
    P, T = values.shape[1:]
    g = len(shape)
    cands = {
        # chunk over (grid..., probe, time)
        "run/none": ((*([1] * g), P, T), {}),
        "run/gzip1": ((*([1] * g), P, T), {"compression": "gzip", "compression_opts": 1}),
        "run/shuffle+gzip1": ((*([1] * g), P, T), {"shuffle": True, "compression": "gzip",
                                                   "compression_opts": 1}),
        "run/shuffle+gzip4": ((*([1] * g), P, T), {"shuffle": True, "compression": "gzip",
                                                   "compression_opts": 4}),
        "run/lzf": ((*([1] * g), P, T), {"compression": "lzf"}),
        "run/shuffle+lzf": ((*([1] * g), P, T), {"shuffle": True, "compression": "lzf"}),
        "8runs/gzip1": ((*([1] * (g - 1)), min(8, shape[-1]), P, T),
                        {"compression": "gzip", "compression_opts": 1}),
        "row/shuffle+gzip1": ((*([1] * (g - 1)), shape[-1], P, T),
                              {"shuffle": True, "compression": "gzip", "compression_opts": 1}),
        "8runs/shuffle+gzip1": ((*([1] * (g - 1)), min(8, shape[-1]), P, T),
                                {"shuffle": True, "compression": "gzip", "compression_opts": 1}),
        "run,256/shuffle+gzip1": ((*([1] * g), P, min(256, T)),
                                  {"shuffle": True, "compression": "gzip", "compression_opts": 1}),
        "8runs,256/shuffle+gzip1": ((*([1] * (g - 1)), min(8, shape[-1]), P, min(256, T)),
                                    {"shuffle": True, "compression": "gzip",
                                     "compression_opts": 1}),
    }
    print(f"{'candidate':28} {'file MB':>8} {'B/run over':>10} {'write MB/s':>10} "
          f"{'read MB/s':>9} {'1 run ms':>8} {'1 probe s':>9} {'window s':>8} "
          f"{'max/t s':>7} {'peak MiB':>8}")
    for name, (chunk, filters) in cands.items():
        path = work / f"cand_{name.replace('/', '_').replace(',', '_').replace('+', '_')}.h5"
        wt = write_candidate(path, shape, probes, time_s, values, chunk, filters)
        with h5py.File(path, "r") as f:
            stored = f["history"].id.get_storage_size()
        size = path.stat().st_size
        r = {"chunk": list(chunk), "filters": filters, "file_mb": size / 1e6,
             "stored_mb": stored / 1e6, "overhead_bytes_per_run": (size - stored) / n,
             "write_s": wt, "write_mb_s": raw / 1e6 / wt}
        r.update(reads(path, shape))
        r.update(lazy_reduction(path))
        results[name] = r
        print(f"{name:28} {r['file_mb']:8.1f} {r['overhead_bytes_per_run']:10.0f} "
              f"{r['write_mb_s']:10.0f} {r['read_all_mb_s']:9.0f} {r['one_run_ms']:8.2f} "
              f"{r['one_probe_all_runs_s']:9.2f} {r['time_window_50_all_runs_s']:8.2f} "
              f"{r.get('max_over_time_s', float('nan')):7.2f} "
              f"{r.get('max_over_time_peak_mib', float('nan')):8.0f}", flush=True)
        path.unlink()
    (work / "bench_history_layout.json").write_text(json.dumps(results, indent=2))
    print(f"results: {work / 'bench_history_layout.json'}")


if __name__ == "__main__":
    main()
