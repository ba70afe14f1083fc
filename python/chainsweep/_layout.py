"""Names, units and descriptions of a run's summaries, as the HDF5 files of the runner store them.

:func:`chainsweep.run` labels its Dataset with these; :func:`chainsweep.open` takes the same from
each file's own attributes. ``test_units_of_run_and_open_agree`` (``tests/python/test_package_open.py``)
and ``test_chainsweep_run_says_how_much_of_its_chain_it_integrated`` (``tests/test_active_region.py``)
check that the two agree.
"""

from __future__ import annotations

import numpy as np

# `status`: 0 pending, 1 ok, 2 failed (the file's flag_values / flag_meanings).
STATUS_PENDING = 0
STATUS_OK = 1
STATUS_FAILED = 2
STATUS_ATTRS = {
    "flag_values": np.array([STATUS_PENDING, STATUS_OK, STATUS_FAILED], dtype=np.uint8),
    "flag_meanings": "pending ok failed",
}

#: Per-run float summaries: name -> (units, long_name).
RUN_FLOATS: dict[str, tuple[str, str]] = {
    "t_end_s": ("s", "time the run reached"),
    "energy_drift_max": ("1", "largest |E(t) - E(0)| over the run, relative to the impact energy"),
    "energy_drift_final": ("1", "|E(t_end) - E(0)| relative to the impact energy"),
    "momentum_residual_max": (
        "1",
        "largest momentum-balance residual, relative to the striker momentum",
    ),
    "impact_energy_j": ("J", "striker kinetic energy"),
    "wall_time_s": ("s", "wall-clock time of the run (kept for failed runs)"),
    "max_overlap_m": ("m", "largest contact overlap over the run (at step ends)"),
}

#: Per-run integer counters: name -> (units, long_name). The files store -1 where a run failed or
#: is pending; :func:`chainsweep.open` masks it (float64 with NaN, as xarray decodes a fill value).
RUN_COUNTERS: dict[str, tuple[str, str]] = {
    "steps": ("1", "accepted integrator steps"),
    "rejected_steps": ("1", "rejected step attempts"),
    "rhs_evals": ("1", "right-hand-side evaluations"),
    "events": ("1", "steps retaken to end on a contact opening or closing (located events)"),
}

#: Per-run columns of a scene that can integrate only the moving part of its chain (a long chain
#: struck at one end): name -> (units, long_name). The files have them only where some grid point
#: can, :func:`chainsweep.run` only for such a scene; elsewhere they would repeat the chain's length.
MOVING_PART_COLUMNS: dict[str, tuple[str | None, str]] = {
    "integrated_particles": (
        "1",
        "particles integrated at the end of the run (striker included): the chain's count when the "
        "whole chain was integrated, the final length of the growing prefix when only its moving "
        "part was",
    ),
    "moving_part": (None, "whether the run integrated only the moving part of its chain"),
}
#: `moving_part`: 0 failed, pending or not known, 1 the whole chain, 2 only the moving part.
MOVING_PART_ATTRS = {
    "flag_values": np.array([0, 1, 2], dtype=np.uint8),
    "flag_meanings": "not_known whole_chain moving_part",
}

#: Per-probe summaries: name -> (units, long_name); units None: the probes' own unit.
PROBE_SUMMARIES: dict[str, tuple[str | None, str]] = {
    "leading_peak": (None, "peak of the leading pulse (first excursion), refined between samples"),
    "leading_peak_time_s": ("s", "time of the leading peak"),
    "record_max": (None, "maximum over the whole record, refined between samples"),
    "record_max_time_s": ("s", "time of the record maximum"),
}

#: Per-run strings: name -> long_name.
RUN_STRINGS: dict[str, str] = {
    "reason": "why the run failed (empty unless status == 2)",
    "warnings": "physical-validity warnings of the run, one per line (empty when none)",
    "run_hash": "SHA-256 identity of the run: numerics version, solver version, limits, full scene",
}

#: Histories and minimum overlaps (per-run groups in the files).
HISTORY_LONG_NAME = "history of each probe, sampled every record.history_interval_s"
MIN_OVERLAP_LONG_NAME = "minimum overlap of each contact over the run"
CONTACT_LONG_NAME = "contact j, between particles j and j+1 (the last one: the wall)"

#: The order in which datasets list their variables (others follow, by name).
ORDER: list[str] = [
    *PROBE_SUMMARIES,
    *RUN_FLOATS,
    *RUN_COUNTERS,
    *MOVING_PART_COLUMNS,
    "status",
    "reason",
    "warnings",
    "verified",
    "verify_rel_error_max",
    "verify_rel_error_leading_peak",
    "verify_rel_error_leading_peak_time",
    "verify_rel_error_record_max",
    "run_hash",
    "history",
    "min_overlap_m",
]


def ordered(names):
    """`names` in the order of ORDER, the others after them by name."""
    rank = {n: i for i, n in enumerate(ORDER)}
    return sorted(names, key=lambda n: (rank.get(n, len(rank)), n))


#: Units of a quantity measured by probes of mixed units.
MIXED_UNITS = "see probe_units"


def probe_units(units: list[str]) -> str:
    """The `units` attribute of a per-probe variable: the probes' common unit, or MIXED_UNITS."""
    return units[0] if units and all(u == units[0] for u in units) else MIXED_UNITS
