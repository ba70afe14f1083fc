"""How the moving part of the Fig. 8 chains falls apart at open contacts (docs/PERFORMANCE.md).

A contact that is open carries no force: the particles on either side of it move independently
until it closes again. So the moving part of a chain is, at each instant, a row of clusters
separated by open contacts, and one of them holds the leading pulse's front. An integration that
gave each cluster its own steps would pay, for the steps the front's error allows, only the
front cluster's right-hand sides, and no cluster's step would be cut short by a switch in
another. This script measures how large that front cluster is against the whole moving part:
every grid point of `sweeps/fig08.json` (its scene as the runner expands it, `chainsweep point …
--scene-only`, through `bench_numba_lsoda.scenes`) is run through `chainsweep.run` (DOP853 at RTOL with
`predict_switches`, stopped after its leading pulses as the sweep is) with the contact forces as a
space-time field every 0.2 us (the probes' sampling interval), and at each sample

- the moving part is every contact up to the farthest whose force has left its static value by
  more than 1e-6 of the run's largest force, so far in the run (what has been reached stays moving);
- a contact is open where its force is zero (a damped contact whose viscous pull would exceed
  its elastic push is held at zero too, and counted open: it couples nothing at that instant);
- the front cluster runs from the contact after the last open one inside the moving part up to
  the moving part's end.

Printed per damping: the mean size of the moving part and of the front cluster (contacts, over
every sample of every run), their ratio (the share of the moving part's right-hand-side cost the
front cluster would carry), and the mean number of clusters.

    python scripts/open_contact_clusters.py [RTOL]
"""

import json
import sys
from pathlib import Path

import numpy as np

import chainsweep
from bench_numba_lsoda import scenes

REPO = Path(__file__).resolve().parent.parent
RTOL = float(sys.argv[1]) if len(sys.argv) > 1 else 1e-8
FIELD_INTERVAL_S = 2e-7
MOVED = 1e-6


def clusters(force):
    """Per sample: contacts in the moving part, in the front cluster, and the number of clusters."""
    static = force[0]
    peak = np.abs(force).max()
    moved = np.abs(force - static) > MOVED * peak
    farthest = np.where(moved.any(axis=1), moved.shape[1] - 1 - np.argmax(moved[:, ::-1], axis=1), 0)
    reach = np.maximum.accumulate(farthest) + 1
    moving, front, count = [], [], []
    for row, m in zip(force, reach):
        open_ = np.flatnonzero(row[:m] <= 0.0)
        start = open_[-1] + 1 if open_.size else 0
        moving.append(m)
        front.append(m - start)
        count.append(open_.size + 1)
    return np.array(moving), np.array(front), np.array(count)


def main():
    sweep_file = REPO / "sweeps" / "fig08.json"
    probes = json.loads(sweep_file.read_text())["record"]["probes"]
    print(f"Fig. 8 grid, DOP853 rtol {RTOL:g} with predict_switches, contact forces every "
          f"{FIELD_INTERVAL_S * 1e6:g} us")
    print("| damping | runs | moving part, mean contacts | front cluster, mean contacts | front / moving | clusters, mean |")
    print("|---|---|---|---|---|---|")
    by_damping: dict[float, list] = {}
    for scene in scenes(sweep_file):
        scene["integrator"] = {"method": "dop853", "rtol": RTOL, "predict_switches": True}
        scene["record"] = {
            "probes": probes,
            "stop_after_leading_pulses": True,
            "fields": {"quantities": ["contact_force"], "interval_s": FIELD_INTERVAL_S},
        }
        ds = chainsweep.run(scene)
        by_damping.setdefault(scene["physics"]["damping_kg_s"], []).append(
            clusters(np.asarray(ds["field_contact_force"])))
    for mu, runs in sorted(by_damping.items()):
        moving, front, count = (np.concatenate(q).mean() for q in zip(*runs))
        print(f"| {mu:g} kg/s | {len(runs)} | {moving:.1f} | {front:.1f} | {front / moving:.2f} | {count:.1f} |")

if __name__ == "__main__":
    main()
