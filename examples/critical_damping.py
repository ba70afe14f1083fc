"""The critical damping of Fig. 15: the damping at which the 0.98 chain and the 0.55 chain
attenuate a pulse equally, found with scipy.optimize.brentq over chainsweep.run.

Attenuation is A21/A4, the leading-pulse force in cylinder 21 over that in cylinder 4. Below the
critical damping the 0.55 chain (heavier, taller cylinders) attenuates more; above it, the 0.98
chain does. The paper puts the crossing between 10 and 15 kg/s; our model finds it just below
10 kg/s (results/REPRODUCTION.md, claim `critical-10-15`).

The scene is that of sweeps/critical-damping.json: its base, record block and limits, and the two
chains of its zipped axis (cylinder mass and height), at the base's 1.3 m/s.

The same root is found inside the engine by a search, with its runs stored, resumable and run in
parallel like any sweep's: `chainsweep run sweeps/examples/critical-damping-root.json -o X.h5`
(docs/SEARCHES.md). This script shows the loop a search replaces.

    python examples/critical_damping.py
    python -m chainsweep.example_scripts.critical_damping   # the copy installed with the package
"""

from __future__ import annotations

import copy
import json
import time

from scipy.optimize import brentq

import chainsweep

# The sweep file installed with the package (the repository's sweeps/critical-damping.json).
SWEEP = chainsweep.example_path("critical-damping")


def load_chains() -> tuple[dict, dict, dict, dict]:
    """The base scene, record block and limits of the sweep file, and its two chains."""
    spec = json.loads(SWEEP.read_text())
    zipped = spec["axes"][0]["zip"]
    masses = next(a for a in zipped if a["field"] == "chain.cylinder.mass")["values"]
    heights = next(a for a in zipped if a["field"] == "chain.cylinder.height_m")["values"]
    chains = {}
    for mass, height in zip(masses, heights):
        m = mass["explicit"]["mass_kg"]
        chains[m] = {"mass": mass, "height_m": height}
    # The lighter (shorter) cylinder is the 0.98 chain's, the heavier (taller) one the 0.55 chain's.
    light, heavy = (chains[m] for m in sorted(chains))
    return spec["base"], spec["record"], spec["limits"], {"0.98": light, "0.55": heavy}


BASE, RECORD, LIMITS, CHAINS = load_chains()
calls = 0


def attenuation(chain: str, damping_kg_s: float) -> float:
    """A21/A4 of `chain` ("0.98" or "0.55") at damping μ."""
    global calls
    calls += 1
    scene = copy.deepcopy(BASE)
    scene["chain"]["cylinder"] = CHAINS[chain]
    scene["physics"]["damping_kg_s"] = damping_kg_s
    ds = chainsweep.run(scene, record=RECORD, limits=LIMITS)
    peak = ds.leading_peak
    return float(peak.sel(probe="gauge_force_cyl21") / peak.sel(probe="gauge_force_cyl4"))


def gap(damping_kg_s: float) -> float:
    """A21/A4 of the 0.98 chain minus that of the 0.55 chain: zero at the critical damping."""
    return attenuation("0.98", damping_kg_s) - attenuation("0.55", damping_kg_s)


def main() -> None:
    start = time.perf_counter()
    lo, hi = 5.0, 15.0
    print(f"A21/A4 at μ = {lo:g} kg/s: 0.98 chain {attenuation('0.98', lo):.4f}, "
          f"0.55 chain {attenuation('0.55', lo):.4f}")
    print(f"A21/A4 at μ = {hi:g} kg/s: 0.98 chain {attenuation('0.98', hi):.4f}, "
          f"0.55 chain {attenuation('0.55', hi):.4f}")
    mu = brentq(gap, lo, hi, xtol=1e-4)
    a098, a055 = attenuation("0.98", mu), attenuation("0.55", mu)
    print(f"critical damping: μ = {mu:.3f} kg/s (A21/A4 = {a098:.4f} for the 0.98 chain, "
          f"{a055:.4f} for the 0.55 chain)")
    print(f"{calls} runs of chainsweep.run in {time.perf_counter() - start:.2f} s; "
          "the paper: between 10 and 15 kg/s")


if __name__ == "__main__":
    main()
