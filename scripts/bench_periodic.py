"""A frequency-response curve across a fold two ways, side by side in one run: by continuation of
periodic orbits (a `periodic` block) and by time integration up and down a frequency axis (a
`continuation` block, each point settled from the state the one before it left), for a chain of
20 spheres between two walls shaken from the top hard enough that its first resonance folds.

Prints the wall time, the drive periods integrated and the period maps of each, and how far the
time-integration sweeps' steady amplitudes lie from the branch's stable orbits at the same
frequencies (the amplitude accuracy that many settling periods buy). Writes
results/bench/periodic.json.

    python scripts/bench_periodic.py [--periods 300] [--step-hz 2] [--jobs 2]
"""

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import chainsweep

REPO = Path(__file__).resolve().parent.parent
BIN = REPO / "target" / "release" / "chainsweep"
EXAMPLE = REPO / "sweeps" / "examples" / "driven-branches.json"
STROKE_M = 1e-7


def chain():
    """The example's chain with 20 spheres, its base scene and first natural frequency."""
    sweep = json.loads(EXAMPLE.read_text())
    sweep["base"]["chain"]["sequence"] = [{"repeat": 20, "of": ["ball"]}]
    f1 = float(chainsweep.spectrum(sweep["base"])["frequency_hz"][0])
    return sweep, f1


def timed(args):
    """Wall seconds of a `chainsweep` command (exit 0, or 3 where some steady states did not
    settle: counted from the file)."""
    start = time.perf_counter()
    r = subprocess.run([str(BIN), *map(str, args)], capture_output=True, text=True)
    if r.returncode not in (0, 3):
        sys.exit(f"{args}: exit {r.returncode}: {r.stderr}")
    return time.perf_counter() - start


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--periods", type=int, default=300, help="drive periods per time-integration point")
    ap.add_argument("--step-hz", type=float, default=2.0, help="frequency step of the sweeps")
    ap.add_argument("--jobs", type=int, default=2)
    args = ap.parse_args()
    sweep, f1 = chain()
    lo, hi = round(0.9 * f1), round(1.1 * f1)
    tmp = Path(tempfile.mkdtemp())

    # Continuation of periodic orbits.
    branch = json.loads(json.dumps(sweep))
    branch["axes"] = []
    drive = branch["base"]["excitation"]["drive"]["actuator_m"]["harmonic"]
    drive.update(amplitude=STROKE_M, frequency_hz=float(lo))
    branch["periodic"].update(to=float(hi), step=5.0)
    (tmp / "branch.json").write_text(json.dumps(branch))
    wall_branch = timed(["run", tmp / "branch.json", "-o", tmp / "branch.h5", "--jobs", args.jobs, "-q"])
    b = chainsweep.open(tmp / "branch.h5")
    n = int(b["branch_points"])
    maps = int(b["branch_period_maps"])
    f_branch = b["frequency_hz"].values[:n]
    amp_branch = b["orbit_amplitude"].values[:n, 0, 0]
    stable = b["stability"].values[:n] == 1
    folds = f_branch[b["point_kind"].values[:n] == 4]

    # Time integration up and down, each point `periods` drive periods (the last 10 analysed)
    # from the state the point before it left.
    freqs = np.arange(lo, hi + 1e-9, args.step_hz)
    seconds = {}
    amps = {}
    unsettled = {}
    for direction in ("up", "down"):
        s = json.loads(json.dumps(sweep))
        s.pop("periodic")
        s["base"]["excitation"]["drive"]["actuator_m"]["harmonic"]["amplitude"] = STROKE_M
        s["base"]["excitation"]["drive"]["actuator_m"]["harmonic"]["ramp_periods"] = 20
        s["record"]["steady_state"] = {
            "settle_periods": args.periods - 10, "window_periods": 10, "harmonics": 3}
        s["axes"] = [{"zip": [
            {"field": "excitation.drive.actuator_m.harmonic.frequency_hz", "name": "frequency_hz",
             "values": freqs.tolist()},
            {"field": "duration_s", "name": "duration_s",
             "values": (args.periods / freqs).tolist()},
        ]}]
        s["continuation"] = {"axis": "frequency_hz", "direction": direction}
        path = tmp / f"{direction}.json"
        path.write_text(json.dumps(s))
        seconds[direction] = timed(["run", path, "-o", tmp / f"{direction}.h5", "--jobs", args.jobs, "-q"])
        ds = chainsweep.open(tmp / f"{direction}.h5")
        amps[direction] = ds["steady_amplitude"].values[:, 0, 0]
        unsettled[direction] = int((ds["status"].values == 3).sum())

    # Each swept point against the branch's stable orbit(s) at its frequency: the nearest in
    # amplitude (where two stable orbits coexist, the one the sweep settled on).
    def nearest(f, a):
        best = np.inf
        for k in range(n - 1):
            if not (stable[k] and stable[k + 1]):
                continue
            f0, f1_ = f_branch[k], f_branch[k + 1]
            if min(f0, f1_) <= f <= max(f0, f1_) and f0 != f1_:
                t = (f - f0) / (f1_ - f0)
                best = min(best, abs(amp_branch[k] + t * (amp_branch[k + 1] - amp_branch[k]) - a) / a)
        return best

    errors = [nearest(f, a) for d in amps for f, a in zip(freqs, amps[d])]
    errors = [e for e in errors if np.isfinite(e)]
    # The branch's own steps are a polygon: compare where it is fine enough (its median
    # interpolation error is what the largest error shows otherwise).
    result = {
        "particles": 20,
        "stroke_m": STROKE_M,
        "range_hz": [lo, hi],
        "folds_hz": folds.tolist(),
        "continuation": {"wall_s": wall_branch, "points": n, "period_maps": maps},
        "time_integration": {
            "wall_s": seconds["up"] + seconds["down"],
            "points": 2 * len(freqs),
            "periods_per_point": args.periods,
            "drive_periods": 2 * len(freqs) * args.periods,
            "step_hz": args.step_hz,
            "unsettled_points": unsettled["up"] + unsettled["down"],
            "relative_amplitude_error_vs_branch": {
                "median": float(np.median(errors)), "max": float(np.max(errors))},
        },
    }
    out = REPO / "results" / "bench" / "periodic.json"
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(result, indent=2))
    print(f"20 spheres, stroke {STROKE_M * 1e9:g} nm, {lo}–{hi} Hz, folds at {np.round(folds, 2).tolist()} Hz")
    print(f"{'':28} {'wall s':>8} {'points':>7} {'periods':>9}")
    print(f"{'continuation (periodic)':28} {wall_branch:8.1f} {n:7d} {maps:9d}  (period maps)")
    ti = result["time_integration"]
    print(f"{'time integration up + down':28} {ti['wall_s']:8.1f} {ti['points']:7d} {ti['drive_periods']:9d}"
          f"  (amplitude vs branch: median {ti['relative_amplitude_error_vs_branch']['median']:.1e},"
          f" max {ti['relative_amplitude_error_vs_branch']['max']:.1e};"
          f" {ti['unsettled_points']} points not settled to 1e-3)")
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
