#!/usr/bin/env python3
"""Benchmark of the results store: what a large sweep costs on disk and in memory.

Two sweeps of small, fast scenes (4 cylinders, 0.1 ms, so that the store, not the solver, is
what is measured):

- `history`: 20 000 runs recording histories (about 100 samples of 3 series each);
- `summary`: 100 000 runs recording summaries only;
- `histories`: the 2 511-run sweep of the issue "Histories for overnight sweeps" (81 mass ratios
  0.2-1.0 x 31 dampings 0-30 kg/s, four gauge histories at 1 us over 1 ms: 80 MB of history
  values), scaled like the others.

For `histories` also: reading every history with h5py (raw MB/s of history values, best of
three), `chainsweep.open(path, histories=True)` in a fresh process (its time and its peak resident
memory, and that peak beyond the imports), `chainsweep status` (the engine reading every run back,
checked: its time and peak memory), and the file's bytes per run beyond the stored (compressed)
history values: what the HDF5 objects of a run cost.

For each: wall time; bytes the `chainsweep run` process wrote (`wchar` of /proc/self/io: the
kernel adds a reaped child's I/O counts to its parent, so the difference around the run is the
child's, every write() and pwrite() counted, whatever the file system does with them) and
`write_bytes` (what reached the block layer, 0 on tmpfs); its peak resident memory (from
wait4's rusage); the final file's size; the files and bytes left in the work directory; and
for histories the write throughput (final file size over the wall time of re-assembling the
complete file from itself, which reads every run back and writes it compressed again).

    python scripts/bench_store.py [--bin target/release/chainsweep] [--base-bin OLD] [--dir DIR]
        [--scale 1.0] [--only history|summary|histories]

`--scale 0.1` runs sweeps ten times smaller (a quick check). With `--base-bin` (the binary before a
change; `make bench` gives the one it built at BENCH_BASE), every case runs with both binaries,
the base first, on the same machine load, and both are printed side by side. Prints a table and
writes `DIR/bench_store.json`.
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

REPO = Path(__file__).resolve().parent.parent


def sweep(n_a, n_b, history, probes=(1, 3), duration_s=1e-4, damping=20.0, mass=(0.1, 1.0)):
    return {
        "description": "store benchmark",
        "base": {
            "chain": {
                "preset": "chain_055",
                "cylinders": 4,
                "cylinder": {"mass": {"heavy_cylinders": {"mass_ratio": 0.55}}, "height_m": None},
            },
            "physics": {"gravity": True, "damping_kg_s": 0.0, "wall": True},
            "striker_velocity_m_s": 1.3,
            "duration_s": duration_s,
            "integrator": {"method": "dop853", "rtol": 1e-6},
        },
        "record": {
            "probes": [{"kind": "gauge_force", "cylinder": c} for c in probes],
            "history": history,
            "history_interval_s": 1e-6,
        },
        "axes": [
            {"field": "chain.cylinder.mass.heavy_cylinders.mass_ratio", "range": {"start": mass[0], "stop": mass[1], "num": n_a}},
            {"field": "physics.damping_kg_s", "range": {"start": 0.0, "stop": damping, "num": n_b}},
        ],
    }


def io_counts():
    out = {}
    with open("/proc/self/io") as f:
        for line in f:
            k, v = line.split(":")
            out[k.strip()] = int(v)
    return out


def run_measured(args):
    """Runs a command; returns (wall s, wchar, write_bytes, peak RSS MiB, returncode, stderr)."""
    before = io_counts()
    t0 = time.perf_counter()
    p = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    err_chunks = []
    # (stderr read to the end first, so the child never blocks on a full pipe)
    err_chunks.append(p.stderr.read())
    _, status, usage = os.wait4(p.pid, 0)
    wall = time.perf_counter() - t0
    after = io_counts()
    p.returncode = os.waitstatus_to_exitcode(status)
    return {
        "wall_s": wall,
        "wchar": after["wchar"] - before["wchar"],
        "write_bytes": after["write_bytes"] - before["write_bytes"],
        "peak_rss_mib": usage.ru_maxrss / 1024,
        "rc": p.returncode,
        "stderr": "".join(err_chunks),
    }


def dir_usage(d):
    files = [p for p in Path(d).rglob("*") if p.is_file()]
    return len(files), sum(p.stat().st_size for p in files)


READ_ALL = r"""
import json, sys, time
import h5py, numpy as np

def every_history(f):
    # Every history value of a file, whatever its layout: one variable (one per unit where the
    # probes' units differ), or a group per run.
    names = [n for n in ("history", "history_N", "history_m", "history_m_per_s") if n in f]
    if names:
        for n in names:
            yield f[n][()]
        return
    probes = [s.decode() for s in f["probe"][()].view(f"S{f['probe'].shape[-1]}")[..., 0]]
    for g in f["runs"].values():
        for p in probes:
            if p in g:
                yield g[p][()]

best = None
for _ in range(3):
    t0 = time.perf_counter()
    with h5py.File(sys.argv[1], "r") as f:
        n = sum(int(np.count_nonzero(~np.isnan(a))) * 8 for a in every_history(f))
    dt = time.perf_counter() - t0
    best = dt if best is None else min(best, dt)
print(json.dumps({"read_s": best, "values_bytes": n}))
"""

OPEN = r"""
import json, resource, sys, time
import h5py, numpy, xarray
import chainsweep
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
t0 = time.perf_counter()
ds = chainsweep.open(sys.argv[1], histories=True)
float(ds["history"].max())
dt = time.perf_counter() - t0
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(json.dumps({"open_s": dt, "peak_rss_mib": peak / 1024, "over_imports_mib": (peak - base) / 1024}))
"""

STORED = r"""
import json, sys
import h5py
stored = 0
def visit(name, obj):
    global stored
    if isinstance(obj, h5py.Dataset) and (name.startswith("history") or name.startswith("runs/")):
        stored += obj.id.get_storage_size()
with h5py.File(sys.argv[1], "r") as f:
    f.visititems(visit)
print(json.dumps({"history_stored_bytes": stored}))
"""


def py_json(script, path):
    r = subprocess.run([sys.executable, "-c", script, str(path)], capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"measuring {path}: {r.stderr[-2000:]}")
    return json.loads(r.stdout)


def history_reads(res, out, runs, binary):
    """The read side of a file with histories (see the module's docstring)."""
    size = out.stat().st_size
    # The engine's own check of every stored value (every run's histories read back): its time
    # and peak memory, which should not grow with the file.
    st = run_measured([str(binary), "status", str(out)])
    res["status_s"] = round(st["wall_s"], 2)
    res["status_peak_rss_mib"] = round(st["peak_rss_mib"], 1)
    r = py_json(READ_ALL, out)
    res["history_values_mb"] = round(r["values_bytes"] / 1e6, 2)
    res["h5py_read_all_s"] = round(r["read_s"], 3)
    res["h5py_read_all_mb_s"] = round(r["values_bytes"] / 1e6 / r["read_s"], 1)
    o = py_json(OPEN, out)
    res["open_histories_s"] = round(o["open_s"], 2)
    res["open_histories_peak_rss_mib"] = round(o["peak_rss_mib"], 1)
    res["open_histories_over_imports_mib"] = round(o["over_imports_mib"], 1)
    st = py_json(STORED, out)
    res["overhead_bytes_per_run"] = round((size - st["history_stored_bytes"]) / runs)
    res["write_mb_s_of_values"] = round(r["values_bytes"] / 1e6 / res["reassemble_s"], 1)


def bench(binary, work, name, spec, jobs, checkpoint):
    d = Path(work) / name
    shutil.rmtree(d, ignore_errors=True)
    d.mkdir(parents=True)
    path = d / f"{name}.json"
    path.write_text(json.dumps(spec))
    out = d / f"{name}.h5"
    m = run_measured([str(binary), "run", str(path), "-o", str(out), "--jobs", str(jobs),
                      "--checkpoint-interval", str(checkpoint), "--progress-interval", "60"])
    if m["rc"] != 0:
        sys.exit(f"{name}: chainsweep exited {m['rc']}:\n{m['stderr'][-2000:]}")
    size = out.stat().st_size
    files, used = dir_usage(str(out) + ".d")
    runs = spec["axes"][0]["range"]["num"] * spec["axes"][1]["range"]["num"]
    res = {
        "runs": runs,
        "wall_s": round(m["wall_s"], 2),
        "final_file_mb": round(size / 1e6, 3),
        "written_mb": round(m["wchar"] / 1e6, 3),
        "written_over_final": round(m["wchar"] / size, 2),
        # Per run, the measure that a smaller final file cannot flatter.
        "written_per_run_b": round(m["wchar"] / runs),
        "block_written_mb": round(m["write_bytes"] / 1e6, 3),
        "peak_rss_mib": round(m["peak_rss_mib"], 1),
        "work_dir_files": files,
        "work_dir_bytes": used,
    }
    # Resuming the complete sweep: nothing to do (its bytes checked against the snapshot's digest;
    # the file left as it is). Median of three.
    walls = []
    for _ in range(3):
        noop = run_measured([str(binary), "run", str(path), "-o", str(out), "--jobs", str(jobs), "--quiet"])
        if noop["rc"] != 0:
            sys.exit(f"{name} (resume): chainsweep exited {noop['rc']}:\n{noop['stderr'][-2000:]}")
        walls.append(noop["wall_s"])
    res["resume_nothing_to_do_s"] = round(sorted(walls)[1], 3)
    # Re-assembling the complete file from itself: every run read back (checked) and written
    # again. (Without the snapshot the file is not known to be as published, so it is rewritten;
    # versions without a snapshot always rewrite it.)
    snapshot = Path(str(out) + ".d", "snapshot")
    if snapshot.exists():
        snapshot.unlink()
    again = run_measured([str(binary), "run", str(path), "-o", str(out), "--jobs", str(jobs), "--quiet"])
    if again["rc"] != 0:
        sys.exit(f"{name} (again): chainsweep exited {again['rc']}:\n{again['stderr'][-2000:]}")
    res["reassemble_s"] = round(again["wall_s"], 2)
    res["reassemble_mb_s"] = round(size / 1e6 / again["wall_s"], 1)
    res["reassemble_peak_rss_mib"] = round(again["peak_rss_mib"], 1)
    if spec["record"]["history"] and len(spec["record"]["probes"]) == 4:
        history_reads(res, out, runs, binary)
    return res


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bin", default=str(REPO / "target" / "release" / "chainsweep"))
    ap.add_argument("--dir", default=None, help="where to run (default: a temporary folder)")
    ap.add_argument("--scale", type=float, default=1.0, help="fraction of the default sweep sizes")
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 2)
    ap.add_argument("--checkpoint-interval", type=float, default=1.0)
    ap.add_argument("--only", default=None, help="one case: history, summary or histories")
    ap.add_argument("--base-bin", default=None,
                    help="the binary before a change: every case runs with it too, side by side")
    a = ap.parse_args()
    work = a.dir or tempfile.mkdtemp(prefix="bench_store.")
    k = a.scale ** 0.5
    cases = {
        "history": sweep(max(2, round(200 * k)), max(2, round(100 * k)), True),
        "summary": sweep(max(2, round(400 * k)), max(2, round(250 * k)), False),
        "histories": sweep(max(2, round(81 * k)), max(2, round(31 * k)), True, probes=(1, 2, 3, 4),
                           duration_s=1e-3, damping=30.0, mass=(0.2, 1.0)),
    }
    results = {}
    sides = [("before", a.base_bin), ("after", a.bin)] if a.base_bin else [("", a.bin)]
    for name, spec in cases.items():
        if a.only and name != a.only:
            continue
        for side, binary in sides:
            key = f"{name} {side}".strip()
            results[key] = bench(binary, work, name, spec, a.jobs, a.checkpoint_interval)
            report(key, results[key])
    if a.base_bin:
        side_by_side(results)
    Path(work, "bench_store.json").write_text(json.dumps(results, indent=2))
    print(f"results: {Path(work, 'bench_store.json')}")


def side_by_side(results):
    """Prints the main figures of every case run with both binaries as a table: before, after."""
    rows = [
        ("sweep wall, s", "wall_s"),
        ("final file, MB", "final_file_mb"),
        ("bytes written, MB (every write() of the process)", "written_mb"),
        ("bytes written / final file", "written_over_final"),
        ("bytes written per run", "written_per_run_b"),
        ("peak RSS, MiB", "peak_rss_mib"),
        ("`run` again with nothing to do, s (median of 3)", "resume_nothing_to_do_s"),
    ]
    for case in sorted({k.rsplit(" ", 1)[0] for k in results}):
        before, after = results.get(f"{case} before"), results.get(f"{case} after")
        if not (before and after):
            continue
        print(f"\n{case} ({after['runs']} runs) | before | after")
        print("|---|---|---|")
        for label, key in rows:
            print(f"| {label} | {before[key]} | {after[key]} |")


def report(name, r):
    """Prints one case's measurements."""
    if r:
        print(f"{name}: {r['runs']} runs in {r['wall_s']} s; final file {r['final_file_mb']} MB; "
              f"written {r['written_mb']} MB ({r['written_over_final']}x the final file, "
              f"{r['written_per_run_b']} B a run; "
              f"{r['block_written_mb']} MB to the block layer); peak RSS {r['peak_rss_mib']} MiB; "
              f"work dir after: {r['work_dir_files']} files, {r['work_dir_bytes']} bytes; "
              f"resume with nothing to do {r['resume_nothing_to_do_s']} s; "
              f"re-assembly {r['reassemble_mb_s']} MB/s ({r['reassemble_s']} s)", flush=True)
        if "h5py_read_all_s" in r:
            print(f"{name}: {r['history_values_mb']} MB of history values; h5py reads them all in "
                  f"{r['h5py_read_all_s']} s ({r['h5py_read_all_mb_s']} MB/s); "
                  f"chainsweep.open(histories=True) {r['open_histories_s']} s, peak RSS "
                  f"{r['open_histories_peak_rss_mib']} MiB ({r['open_histories_over_imports_mib']} "
                  f"MiB beyond the imports); written at {r['write_mb_s_of_values']} MB/s of values "
                  f"(re-assembly); {r['overhead_bytes_per_run']} bytes per run beyond the stored "
                  f"histories; `chainsweep status` (every value checked) {r['status_s']} s, peak RSS "
                  f"{r['status_peak_rss_mib']} MiB", flush=True)


if __name__ == "__main__":
    main()
