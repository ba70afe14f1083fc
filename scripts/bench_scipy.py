"""chainsweep against a physicist's scipy script of the same chain, side by side (`make bench`).

The scene is the reference run: the 0.55 chain with 50 cylinders, μ = 6 kg/s, v0 = 1.3 m/s,
1 ms, gauges in cylinders 4 and 21. "Them" is `scripts/scipy_chain.py` (numpy right-hand side,
`scipy.integrate.solve_ivp`, leading peaks refined on its dense output); "us" is `chainsweep.run`
of the benchmarked settings (DOP853 rtol 5e-8 with `predict_switches`, whose leading peaks are
within 1e-6 of the reference: `crates/solver/tests/accuracy.rs`).

1. The reference: chainsweep at DOP853 rtol 1e-12; the scipy script at its tightest setting must
   agree with it (an independent implementation of docs/MODEL.md).
2. A ladder of rtol for each scipy method: the errors of both leading peaks against the reference,
   right-hand-side evaluations, wall time; the loosest setting whose error is at most 1e-6 at that
   rung and at every tighter one is the script's cost of the accuracy chainsweep's run has.
3. That setting and chainsweep's run timed alternately, ROUNDS times each; medians side by side.
4. What a `chainsweep.run` call costs beyond its run: between the scipy runs of 3 (cold caches)
   and back to back (3 × ROUNDS calls, warm), each against the run's own `wall_time_s`.

    python scripts/bench_scipy.py [--rounds N] [--methods DOP853,RK45,LSODA]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import chainsweep  # noqa: E402
from scipy_chain import PaperChain  # noqa: E402

CYLINDERS = 50
DAMPING = 6.0
DURATION = 1e-3
GAUGES = (4, 21)
TARGET = 1e-6
LADDER = [1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11]
#: A ladder stops after a run that took longer than this, s.
MAX_RUN_S = 60.0


def scene(integrator: dict) -> dict:
    """The reference scene in the form of a sweep file's base, with its record block."""
    return {
        "chain": {"preset": "chain_055", "cylinders": CYLINDERS},
        "physics": {"gravity": True, "damping_kg_s": DAMPING, "wall": True},
        "striker_velocity_m_s": 1.3,
        "duration_s": DURATION,
        "integrator": integrator,
        "record": {"probes": [{"kind": "gauge_force", "cylinder": c} for c in GAUGES]},
    }


BENCHMARKED = {"method": "dop853", "rtol": 5e-8, "predict_switches": True}


def ours(integrator: dict):
    """Leading peaks, RHS evaluations, the wall time of one `chainsweep.run` call (plain arrays:
    building an xarray Dataset adds about 0.8 ms) and the engine's own run time."""
    start = time.perf_counter()
    r = chainsweep.run(scene(integrator), as_dataset=False)
    wall = time.perf_counter() - start
    return r["leading_peak"], int(r["rhs_evals"]), wall, float(r["wall_time_s"])


def error(peaks, reference) -> float:
    return float(np.max(np.abs(peaks / reference - 1.0)))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--methods", default="DOP853,RK45,LSODA")
    args = ap.parse_args()
    chain = PaperChain(cylinders=CYLINDERS, damping_kg_s=DAMPING)

    reference = ours({"method": "dop853", "rtol": 1e-12})[0]
    print(f"reference (chainsweep DOP853 rtol 1e-12): F{GAUGES[0]} = {reference[0]:.9f} N, "
          f"F{GAUGES[1]} = {reference[1]:.9f} N")
    bench_peaks, bench_rhs, _, _ = ours(BENCHMARKED)
    print(f"chainsweep as benchmarked (DOP853 rtol 5e-8, predict_switches): error "
          f"{error(bench_peaks, reference):.2e}, {bench_rhs} RHS evaluations")

    cheapest, tightest = {}, {}
    print("\n| scipy method | rtol | error of the leading peaks | RHS evaluations | wall |\n|---|---|---|---|---|")
    for method in args.methods.split(","):
        rows = []
        for rtol in LADDER:
            r = chain.leading_peaks(DURATION, GAUGES, method=method, rtol=rtol)
            e = error(r.peaks, reference)
            rows.append((rtol, e, r))
            print(f"| {method} | {rtol:.0e} | {e:.2e} | {r.nfev} | {r.wall_s:.3f} s |", flush=True)
            if r.wall_s > MAX_RUN_S:
                break
        tightest[method] = rows[-1]
        # The loosest rung from which every tighter rung meets the target.
        for i, (rtol, e, r) in enumerate(rows):
            if all(ee <= TARGET for _, ee, _ in rows[i:]):
                cheapest[method] = (rtol, e, r)
                break
    for method, (rtol, e, _) in tightest.items():
        print(f"independent check: scipy {method} at rtol {rtol:.0e} agrees with chainsweep's reference to {e:.1e}")

    if not cheapest:
        print(f"no scipy setting reached {TARGET:g}")
        return 1
    print(f"\nside by side, {args.rounds} alternating rounds (medians):")
    print("| what | setting | error | RHS evaluations | wall (median) | vs chainsweep |\n|---|---|---|---|---|---|")
    walls = {"chainsweep": [], "engine": []}
    for r in range(args.rounds):
        for method, (rtol, _, _) in cheapest.items():
            walls.setdefault(method, []).append(
                chain.leading_peaks(DURATION, GAUGES, method=method, rtol=rtol).wall_s)
        _, _, call, engine = ours(BENCHMARKED)
        walls["chainsweep"].append(call)
        walls["engine"].append(engine)
    us = statistics.median(walls["chainsweep"])
    engine = statistics.median(walls["engine"])
    print(f"| chainsweep.run (as_dataset=False) | DOP853 rtol 5e-8, predict_switches | "
          f"{error(bench_peaks, reference):.1e} | {bench_rhs} | {us * 1e3:.2f} ms (the run itself: "
          f"{engine * 1e3:.2f} ms) | 1 |")
    for method, (rtol, e, r) in cheapest.items():
        them = statistics.median(walls[method])
        print(f"| scipy solve_ivp {method} | rtol {rtol:.0e} | {e:.1e} | {r.nfev} | {them * 1e3:.1f} ms "
              f"| {them / us:.0f}× |")
    # What a call costs beyond its run, between scipy runs (above: the caches hold scipy's data
    # and code when our call starts) and back to back (warm: what a loop of calls pays).
    back = [ours(BENCHMARKED) for _ in range(3 * args.rounds)]
    call_b = statistics.median(b[2] for b in back)
    engine_b = statistics.median(b[3] for b in back)
    print(f"\nchainsweep.run against its own run: {us / engine:.2f}× between the scipy runs "
          f"({us * 1e3:.2f} / {engine * 1e3:.2f} ms); {call_b / engine_b:.2f}× back to back "
          f"({call_b * 1e3:.2f} / {engine_b * 1e3:.2f} ms, median of {len(back)} calls)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
