#!/usr/bin/env python3
"""Reading a sweep's histories with stock h5py and xarray, under each filter set the store could use.

The sweep: `sweeps/mass-damping-histories.json` (the 50-cylinder chain, four gauge histories at
1 us over 1 ms) over mass ratio 0.2-1.0 step 0.01 x damping 0-30 kg/s step 1 (2 511 runs, 80 MB of
history values). The binary runs it once; its `history` variable is then written again with h5py,
the same chunks, under each candidate filter set (Fletcher-32 in every one but `none`, since the
store checks every chunk), and each file is read in one slice:

- h5py: `f["history"][()]`, best of `--rounds`, in raw MB/s (uncompressed bytes over the time);
- xarray: `xr.open_dataset(path)["history"].values` with the netCDF4 and the h5netcdf engines, the
  slice's read apart from the opening (which reads the file's other variables' metadata; its time
  is reported for the store's file).

The binary's own file is measured the same way (the row `store`): the filters it writes today.

    python scripts/bench_history_filters.py [--bin target/release/chainsweep] [--dir DIR]
        [--rounds 5] [--scale 1.0]

Prints a table and writes `DIR/bench_history_filters.json`.
"""

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import h5py
import numpy as np

REPO = Path(__file__).resolve().parent.parent

CANDIDATES = [
    ("none", {}),
    ("fletcher32", dict(fletcher32=True)),
    ("shuffle+fletcher32", dict(shuffle=True, fletcher32=True)),
    ("shuffle+deflate1+fletcher32", dict(shuffle=True, compression="gzip", compression_opts=1,
                                         fletcher32=True)),
    ("deflate1+fletcher32", dict(compression="gzip", compression_opts=1, fletcher32=True)),
    ("shuffle+deflate4+fletcher32", dict(shuffle=True, compression="gzip", compression_opts=4,
                                         fletcher32=True)),
    ("shuffle+lzf+fletcher32", dict(shuffle=True, compression="lzf", fletcher32=True)),
]

XARRAY_READ = r"""
import json, sys, time
import xarray as xr
best = opened = None
for _ in range(int(sys.argv[3])):
    t0 = time.perf_counter()
    with xr.open_dataset(sys.argv[1], engine=sys.argv[2]) as ds:
        t1 = time.perf_counter()
        a = ds["history"].values
        t2 = time.perf_counter()
    best = t2 - t1 if best is None else min(best, t2 - t1)
    opened = t1 - t0 if opened is None else min(opened, t1 - t0)
print(json.dumps({"read_s": best, "open_s": opened, "bytes": a.nbytes}))
"""


def sweep_file(scale):
    spec = json.loads((REPO / "sweeps" / "mass-damping-histories.json").read_text())
    spec["description"] = "history filter benchmark: 50 cylinders, mass ratio x damping"
    spec["axes"][0]["range"] = {"start": 0.2, "stop": 1.0, "num": max(2, round(81 * scale))}
    spec["axes"][1] = {"field": "physics.damping_kg_s",
                       "range": {"start": 0.0, "stop": 30.0, "num": max(2, round(31 * scale))}}
    return spec


def cpu_name():
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor()


def h5py_read(path, rounds):
    best = None
    for _ in range(rounds):
        t0 = time.perf_counter()
        with h5py.File(path, "r") as f:
            a = f["history"][()]
        dt = time.perf_counter() - t0
        best = dt if best is None else min(best, dt)
    return a.nbytes / 1e6 / best


def xarray_read(path, engine, rounds):
    r = subprocess.run([sys.executable, "-c", XARRAY_READ, str(path), engine, str(rounds)],
                       capture_output=True, text=True)
    if r.returncode != 0:
        return None, None
    o = json.loads(r.stdout)
    return o["bytes"] / 1e6 / o["read_s"], o["open_s"]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bin", default=str(REPO / "target" / "release" / "chainsweep"))
    ap.add_argument("--dir", default=None)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--scale", type=float, default=1.0, help="fraction of each axis (1: 81 x 31)")
    args = ap.parse_args()
    work = Path(args.dir or tempfile.mkdtemp(prefix="bench_history_filters_"))
    work.mkdir(parents=True, exist_ok=True)
    spec = work / "histories.json"
    spec.write_text(json.dumps(sweep_file(args.scale), indent=1))
    store = work / "histories.h5"
    if not store.exists():
        r = subprocess.run([args.bin, "run", str(spec), "-o", str(store), "--jobs", "2", "--quiet"])
        if r.returncode != 0:
            sys.exit(f"chainsweep run exited {r.returncode}")
    with h5py.File(store, "r") as f:
        d = f["history"]
        data, chunks = d[()], d.chunks
        stored = {"compression": d.compression, "shuffle": d.shuffle, "fletcher32": d.fletcher32}
    rows = []
    files = [("store", store, stored)]
    for name, kw in CANDIDATES:
        p = work / f"history-{name}.h5"
        with h5py.File(p, "w") as f:
            f.create_dataset("history", data=data, chunks=chunks, **kw)
        files.append((name, p, kw))
    for name, p, kw in files:
        row = {
            "filters": name,
            "file_mb": round(os.path.getsize(p) / 1e6, 1),
            "h5py_mb_s": round(h5py_read(p, args.rounds)),
        }
        for engine in ("netcdf4", "h5netcdf"):
            v, opened = xarray_read(p, engine, args.rounds)
            row[f"xarray_{engine}_mb_s"] = None if v is None else round(v)
            row[f"xarray_{engine}_open_s"] = None if opened is None else round(opened, 3)
        rows.append(row)
        print(f"{name:30s} {row['file_mb']:7.1f} MB  h5py {row['h5py_mb_s']:6d} MB/s  xarray netCDF4 "
              f"{row['xarray_netcdf4_mb_s']} MB/s (opened in {row['xarray_netcdf4_open_s']} s), "
              f"h5netcdf {row['xarray_h5netcdf_mb_s']} MB/s ({row['xarray_h5netcdf_open_s']} s)",
              flush=True)
    out = {
        "cpu": cpu_name(),
        "h5py": h5py.__version__,
        "hdf5": h5py.version.hdf5_version,
        "history_values_mb": round(data.nbytes / 1e6, 1),
        "chunks": list(chunks),
        "store_filters": stored,
        "rows": rows,
    }
    (work / "bench_history_filters.json").write_text(json.dumps(out, indent=1))
    print(f"{out['cpu']}; h5py {out['h5py']}, HDF5 {out['hdf5']}; {out['history_values_mb']} MB of "
          f"history values, chunks {tuple(chunks)}; results: {work / 'bench_history_filters.json'}")


if __name__ == "__main__":
    main()
