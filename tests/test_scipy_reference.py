"""An independent implementation of docs/MODEL.md agrees with chainsweep: `scripts/scipy_chain.py`
(numpy and scipy's solve_ivp, no code shared with the solver) and `chainsweep.run` give the same
leading peaks and peak times to 1e-6, undamped, damped and without gravity."""

import sys
from pathlib import Path

import chainsweep
import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
from scipy_chain import PaperChain  # noqa: E402

CYLINDERS = 12
GAUGES = (4, 10)
DURATION = 4e-4


@pytest.mark.parametrize("damping, gravity", [(0.0, True), (6.0, True), (20.0, False)])
def test_an_independent_scipy_implementation_gives_the_same_leading_peaks(damping, gravity):
    theirs = PaperChain(cylinders=CYLINDERS, damping_kg_s=damping, gravity=gravity).leading_peaks(
        DURATION, GAUGES, method="DOP853", rtol=1e-10)
    ours = chainsweep.run({
        "chain": {"preset": "chain_055", "cylinders": CYLINDERS},
        "physics": {"gravity": gravity, "damping_kg_s": damping, "wall": True},
        "striker_velocity_m_s": 1.3,
        "duration_s": DURATION,
        "integrator": {"method": "dop853", "rtol": 1e-12},
        "record": {"probes": [{"kind": "gauge_force", "cylinder": c} for c in GAUGES]},
    })
    peaks, times = ours.leading_peak.values, ours.leading_peak_time_s.values
    assert np.isfinite(peaks).all() and np.isfinite(theirs.peaks).all(), (peaks, theirs.peaks)
    np.testing.assert_allclose(theirs.peaks, peaks, rtol=1e-6, atol=0)
    np.testing.assert_allclose(theirs.times, times, rtol=1e-6, atol=0)
    # The pulse is real: it weakens along the chain, more so with damping.
    assert peaks[1] < peaks[0]
