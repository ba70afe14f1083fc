"""A fit inside the engine against the same fit done with scipy's least_squares calling the
engine from Python (chainsweep.run per evaluation): runs, wall time and answer, side by side in
one process, the same data; and the engine's time per fit evaluation beyond its runs.

The problem: the damping and the striker velocity of the 0.98 chain (14 cylinders) from the
leading peaks at four gauges, 2 % noise (tests/test_fit.py's). Medians of --repeat repetitions.

    python scripts/bench_fit.py [--repeat 5]
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import xarray as xr
from scipy.optimize import least_squares

import chainsweep

REPO = Path(__file__).resolve().parent.parent
BIN = REPO / "target" / "release" / "chainsweep"
GAUGES = (2, 5, 9, 12)
TRUTH = (6.0, 1.06)


def base(damping: float, velocity: float) -> dict:
    return {
        "chain": {"preset": "chain_098", "cylinders": 14},
        "physics": {"gravity": False, "damping_kg_s": damping, "wall": True},
        "striker_velocity_m_s": velocity,
        "duration_s": DURATION_S,
        "integrator": {"method": "dop853", "rtol": 1e-9},
    }


RECORD = {"probes": [{"kind": "gauge_force", "cylinder": c} for c in GAUGES], "stop_after_leading_pulses": True}
#: Seconds each run integrates (the whole duration with --whole-runs: runs of a few ms, as the
#: paper's, where the engine's own time per evaluation is measured against them).
DURATION_S = 4e-4


def peaks(damping: float, velocity: float) -> np.ndarray:
    return chainsweep.run(base(damping, velocity), record=RECORD).leading_peak.values


def engine_fit(data: np.ndarray, sigma: np.ndarray, profile: bool, jobs: int) -> dict:
    spec = {
        "description": "bench: two fields from four gauges",
        "base": base(1.0, 1.0),
        "record": RECORD,
        "search": {
            "goal": "fit",
            "fields": [{"field": "physics.damping_kg_s", "min": 1.0, "max": 15.0},
                       {"field": "striker_velocity_m_s", "min": 0.5, "max": 2.0}],
            "data": [{"summary": "leading_peak", "probe": f"gauge_force_cyl{c}", "value": float(v), "sigma": float(s)}
                     for c, v, s in zip(GAUGES, data, sigma)],
            "profile": profile,
        },
    }
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "fit.json"
        path.write_text(json.dumps(spec))
        out = Path(d) / "fit.h5"
        t0 = time.perf_counter()
        r = subprocess.run([str(BIN), "run", str(path), "-o", str(out), "--quiet", "--jobs", str(jobs)],
                           capture_output=True, text=True)
        wall = time.perf_counter() - t0
        assert r.returncode == 0, r.stderr
        # The same command again runs nothing: it reads the sweep, replays the fit through the
        # stored runs and writes the file, what the first paid once besides its evaluations.
        t0 = time.perf_counter()
        r = subprocess.run([str(BIN), "run", str(path), "-o", str(out), "--quiet", "--jobs", str(jobs)],
                           capture_output=True, text=True)
        once = time.perf_counter() - t0
        assert r.returncode == 0, r.stderr
        ds = xr.open_dataset(out)
        run_time = float(np.nansum(ds.wall_time_s.values))
        answer = (float(ds.fit_damping_kg_s.values.ravel()[0]), float(ds.fit_striker_velocity_m_s.values.ravel()[0]))
        se = (float(ds.fit_damping_kg_s_standard_error), float(ds.fit_striker_velocity_m_s_standard_error))
        runs = int(ds.search_runs)
        ds.close()
    return {"wall": wall, "runs": runs, "answer": answer, "se": se, "run_time": run_time, "once": once}


def scipy_fit(data: np.ndarray, sigma: np.ndarray) -> dict:
    calls = 0

    def residuals(x):
        nonlocal calls
        calls += 1
        return (peaks(x[0], x[1]) - data) / sigma

    t0 = time.perf_counter()
    r = least_squares(residuals, x0=[8.0, 1.25], bounds=([1.0, 0.5], [15.0, 2.0]), x_scale=[14.0, 1.5],
                      diff_step=1e-3)
    wall = time.perf_counter() - t0
    cov = np.linalg.inv(r.jac.T @ r.jac)
    return {"wall": wall, "runs": calls, "answer": tuple(r.x), "se": tuple(np.sqrt(np.diag(cov)))}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--whole-runs", action="store_true",
                    help="runs integrate 3 ms whole (no stop after the leading pulses)")
    args = ap.parse_args()
    global DURATION_S
    if args.whole_runs:
        DURATION_S = 3e-3
        RECORD["stop_after_leading_pulses"] = False
    truth = peaks(*TRUTH)
    sigma = 0.02 * truth
    data = truth + sigma * np.random.default_rng(7).standard_normal(len(truth))
    rows = {"engine, --jobs 1, no profiles": [], "engine, --jobs 2, no profiles": [],
            "engine, --jobs 2, with profiles": [], "scipy least_squares over chainsweep.run": []}
    for _ in range(args.repeat):
        rows["engine, --jobs 1, no profiles"].append(engine_fit(data, sigma, False, 1))
        rows["engine, --jobs 2, no profiles"].append(engine_fit(data, sigma, False, 2))
        rows["engine, --jobs 2, with profiles"].append(engine_fit(data, sigma, True, 2))
        rows["scipy least_squares over chainsweep.run"].append(scipy_fit(data, sigma))
    print(f"two-field fit (damping, striker velocity) to four gauges; truth {TRUTH}; runs of {DURATION_S * 1e3:g} ms"
          f"{'' if args.whole_runs else ' (stopped after the leading pulses)'}; medians of {args.repeat}")
    print(f"{'':42s} {'runs':>5s} {'wall s':>8s}  damping ± se          velocity ± se")
    for name, rs in rows.items():
        wall = statistics.median(r["wall"] for r in rs)
        a, s = rs[0]["answer"], rs[0]["se"]
        print(f"{name:42s} {rs[0]['runs']:5d} {wall:8.3f}  {a[0]:.5f} ± {s[0]:.4f}   {a[1]:.6f} ± {s[1]:.5f}")
    one = rows["engine, --jobs 1, no profiles"]
    fixed = statistics.median(r["once"] for r in one)
    over = statistics.median((r["wall"] - r["run_time"]) / r["run_time"] for r in one)
    per_eval = statistics.median((r["wall"] - r["once"] - r["run_time"]) / r["runs"] for r in one)
    run_time = statistics.median(r["run_time"] / r["runs"] for r in one)
    print(f"engine beyond its runs, --jobs 1: {100 * over:.1f} % of the runs' time in all; of which the process, "
          f"the replay and the output file, once per command (the same command again, nothing to run): {1e3 * fixed:.1f} ms; per evaluation: {1e3 * per_eval:.3f} ms "
          f"= {100 * per_eval / run_time:.1f} % of a run ({1e3 * run_time:.2f} ms)")
    sys.stdout.flush()


if __name__ == "__main__":
    main()
