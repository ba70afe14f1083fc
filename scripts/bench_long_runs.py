#!/usr/bin/env python3
"""The long runs a step size of one's own for each part of the chain (multirate) is measured on:
today's single-rate integrator, two builds side by side.

Three one-point sweeps, each run by every binary given, alternating, `ROUNDS` times:

- `reference`: the reference run (0.55 chain, 50 cylinders, mu = 6 kg/s, v0 = 1.3 m/s, 1 ms, DOP853
  rtol 1e-9 with `predict_switches`);
- `1000 cylinders, 5 ms`: the same chain of 1 000 cylinders over 5 ms, long enough that the pulse
  front and the rattling chain it leaves behind are both present;
- `driven 100 spheres, 200 periods`: 100 steel spheres of 8 mm between two walls under 2 N, damped
  (3 kg/s), the top wall shaken at 2 kHz with 1.5 nm (20 periods of ramp), 0.1 s: many regions move
  at once and the far end barely moves.

For each: the run's own wall (`wall_time_s`, the median over the rounds), its accepted steps, its
rejected steps, its right-hand sides, the steps that ended on a contact switch (`events`), the
particles integrated, and the result (a leading peak, or the wall force's record maximum) with the
largest difference between the binaries (the same numerics version gives the same bits).

    python scripts/bench_long_runs.py [--bin AFTER] [--base-bin BEFORE] [--rounds 5]

Writes `target/bench/long_runs.json`.
"""

import argparse
import json
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

import h5py

REPO = Path(__file__).resolve().parent.parent


def chain_055(cylinders, duration_s):
    return {
        "chain": {"preset": "chain_055", "cylinders": cylinders},
        "physics": {"gravity": True, "damping_kg_s": 6.0, "wall": True},
        "striker_velocity_m_s": 1.3,
        "duration_s": duration_s,
        "integrator": {"method": "dop853", "rtol": 1e-9, "predict_switches": True},
    }


def driven(spheres, frequency_hz, periods):
    steel = {"youngs_modulus_pa": 193e9, "poisson_ratio": 0.29}
    return {
        "chain": {
            "particles": {"ball": {"sphere": {"diameter_m": 0.008, "mass_kg": 0.002085,
                                              "material": {"youngs_modulus_pa": 200e9,
                                                           "poisson_ratio": 0.28}}}},
            "sequence": [{"repeat": spheres, "of": ["ball"]}],
            "wall_material": steel,
            "top_wall_material": steel,
        },
        "physics": {"gravity": False, "damping_kg_s": 3.0, "wall": True,
                    "precompression_force_n": 2.0},
        "excitation": {"drive": {"actuator_m": {"harmonic": {
            "amplitude": 1.5e-9, "frequency_hz": frequency_hz, "ramp_periods": 20}}}},
        "duration_s": periods / frequency_hz,
        "integrator": {"method": "dop853", "rtol": 1e-9, "predict_switches": True},
    }


CASES = {
    "reference": (chain_055(50, 1e-3),
                  [{"kind": "gauge_force", "cylinder": 4}, {"kind": "gauge_force", "cylinder": 21}]),
    "1000 cylinders, 5 ms": (chain_055(1000, 5e-3),
                             [{"kind": "gauge_force", "cylinder": 4},
                              {"kind": "gauge_force", "cylinder": 150}]),
    "driven 100 spheres, 200 periods": (driven(100, 2000.0, 200),
                                        [{"kind": "wall_force"}]),
}


def sweep(base, probes):
    return {"description": "long-run benchmark", "base": base, "record": {"probes": probes},
            "axes": [{"field": "duration_s", "values": [base["duration_s"]]}]}


def run_once(binary, path, out):
    shutil.rmtree(str(out) + ".d", ignore_errors=True)
    out.unlink(missing_ok=True)
    r = subprocess.run([binary, "run", str(path), "-o", str(out), "--quiet"], capture_output=True,
                       text=True)
    if r.returncode != 0:
        sys.exit(f"{binary} {path}: exit {r.returncode}\n{r.stderr[-2000:]}")
    with h5py.File(out, "r") as f:
        row = {k: float(f[k][()].ravel()[0]) for k in
               ("wall_time_s", "steps", "rejected_steps", "rhs_evals", "events",
                "integrated_particles") if k in f}
        value = f["leading_peak"][()].ravel() if "leading_peak" in f else f["record_max"][()].ravel()
        row["result"] = [float(v) for v in value]
    return row


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bin", default=str(REPO / "target" / "release" / "chainsweep"))
    ap.add_argument("--base-bin", default=None)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--output", type=Path, default=REPO / "target" / "bench" / "long_runs.json")
    args = ap.parse_args()
    sides = {"after": args.bin}
    if args.base_bin:
        sides["before"] = args.base_bin
    work = Path(tempfile.mkdtemp(prefix="chainsweep-long-runs-"))
    files = {}
    for name, (base, probes) in CASES.items():
        p = work / (name.replace(" ", "-").replace(",", "") + ".json")
        p.write_text(json.dumps(sweep(base, probes)))
        files[name] = p
    rows = {}
    for _ in range(args.rounds):
        for name, path in files.items():
            for side, binary in sides.items():
                rows.setdefault((name, side), []).append(run_once(binary, path, work / f"{side}.h5"))
    out = []
    print("| case | build | run wall, median | steps | rejected | RHS | steps ending on a switch | "
          "particles | result |")
    print("|---|---|---|---|---|---|---|---|---|")
    for (name, side), runs in rows.items():
        last = runs[-1]
        wall = statistics.median(r["wall_time_s"] for r in runs)
        rec = {"case": name, "build": side, "wall_s_median": wall,
               **{k: last.get(k) for k in ("steps", "rejected_steps", "rhs_evals", "events",
                                           "integrated_particles", "result")}}
        out.append(rec)
        print(f"| {name} | {side} | {wall * 1e3:.1f} ms | {last.get('steps', 0):.0f} | "
              f"{last.get('rejected_steps', 0):.0f} | {last.get('rhs_evals', 0):.0f} | "
              f"{last.get('events', 0):.0f} | {last.get('integrated_particles', 0):.0f} | "
              f"{', '.join(f'{v:.10g}' for v in last['result'])} |")
    if "before" in sides:
        for name in CASES:
            a, b = rows[(name, "after")][-1]["result"], rows[(name, "before")][-1]["result"]
            d = max(abs(x - y) / max(abs(y), 1e-300) for x, y in zip(a, b))
            print(f"{name}: after / before wall {statistics.median(r['wall_time_s'] for r in rows[(name, 'after')]) / statistics.median(r['wall_time_s'] for r in rows[(name, 'before')]):.3f}; "
                  f"results differ by {d:.1e} at most")
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(json.dumps(out, indent=1))
    print(f"written: {args.output}")


if __name__ == "__main__":
    main()
