"""Ensembles against grids, and the cost of their statistics (docs/PERFORMANCE.md, "Ensembles").

1. An ensemble of RUNS short runs (the 0.55 chain of 6 cylinders, stopped after the leading
   pulse; the striker's velocity and the damping drawn by Monte Carlo) against the very same runs
   as a grid sweep (one zipped axis of the drawn values, read back from the ensemble's file):
   both timed side by side, alternating, ROUNDS times each, into fresh outputs; medians quoted.
   The ensemble's file also holds its statistics, computed from its runs as it is written.
2. The statistics of 2^20 stored samples as the engine computes them
   (`cargo run --release --example ensemble_statistics`).

`python scripts/bench_ensemble.py [--runs 100000] [--rounds 3] [--jobs N]`; run by `make bench`.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import h5py

ROOT = Path(__file__).resolve().parent.parent
BIN = Path(os.environ.get("CHAINSWEEP_BIN", ROOT / "target" / "release" / "chainsweep"))


def base() -> dict:
    return {
        "chain": {"preset": "chain_055", "cylinders": 6},
        "physics": {"gravity": False, "damping_kg_s": 4.0, "wall": True},
        "striker_velocity_m_s": 1.0,
        "duration_s": 3e-4,
        "integrator": {"method": "dop853", "rtol": 1e-8},
    }


RECORD = {"probes": [{"kind": "gauge_force", "cylinder": 5}], "stop_after_leading_pulses": True}


def timed(args: list[str]) -> float:
    t = time.perf_counter()
    r = subprocess.run([str(BIN), *args], capture_output=True, text=True)
    elapsed = time.perf_counter() - t
    if r.returncode != 0:
        sys.exit(f"{' '.join(args)} failed: {r.stderr}")
    return elapsed


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=100_000)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 2)
    a = ap.parse_args()
    work = Path(tempfile.mkdtemp(prefix="bench-ensemble-"))
    try:
        ens = {
            "description": "bench: an ensemble of short runs",
            "base": base(),
            "record": RECORD,
            "ensemble": {
                "inputs": [
                    {"field": "striker_velocity_m_s", "uniform": {"min": 0.8, "max": 1.2}},
                    {"field": "physics.damping_kg_s", "uniform": {"min": 2.0, "max": 6.0}},
                ],
                "design": "monte_carlo",
                "samples": a.runs,
                "statistics": [{"name": "peak", "of": {"summary": "leading_peak", "probe": "gauge_force_cyl5"}}],
            },
        }
        (work / "ensemble.json").write_text(json.dumps(ens))
        # The same runs as a grid: the drawn values, zipped, from a first ensemble run.
        first = work / "first.h5"
        timed(["run", str(work / "ensemble.json"), "-o", str(first), "--quiet", "--jobs", str(a.jobs)])
        with h5py.File(first) as f:
            v = [float(x) for x in f["striker_velocity_m_s"][()]]
            d = [float(x) for x in f["damping_kg_s"][()]]
        grid = {
            "description": "bench: the same runs as a grid",
            "base": base(),
            "record": RECORD,
            "axes": [{"zip": [{"field": "striker_velocity_m_s", "values": v}, {"field": "physics.damping_kg_s", "values": d}]}],
        }
        (work / "grid.json").write_text(json.dumps(grid))
        times = {"ensemble": [], "grid": []}
        for k in range(a.rounds):
            for name in ("ensemble", "grid"):
                out = work / f"{name}-{k}.h5"
                times[name].append(timed(["run", str(work / f"{name}.json"), "-o", str(out), "--quiet", "--jobs", str(a.jobs)]))
                shutil.rmtree(f"{out}.d", ignore_errors=True)
                out.unlink(missing_ok=True)
        med = {n: statistics.median(t) for n, t in times.items()}
        print(f"{a.runs} runs, --jobs {a.jobs}, {a.rounds} rounds each (medians):")
        for n in ("grid", "ensemble"):
            print(f"  {n:8s} {med[n]:7.2f} s  ({a.runs / med[n]:,.0f} runs/s; all: {', '.join(f'{t:.2f}' for t in times[n])})")
        print(f"  ensemble / grid: {med['ensemble'] / med['grid']:.3f}")
        r = subprocess.run(
            ["cargo", "run", "--quiet", "--release", "-p", "chainsweep", "--example", "ensemble_statistics", "5"],
            cwd=ROOT, capture_output=True, text=True,
        )
        if r.returncode != 0:
            sys.exit(r.stderr)
        s = json.loads(r.stdout)
        print(f"statistics of {s['samples']} samples (mean, sd, 3 quantiles, 2 levels, 20 bins, with intervals): median {s['median_s']:.3f} s")
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
