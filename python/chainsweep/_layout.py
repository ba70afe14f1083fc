"""Names, units and descriptions of a run's summaries, as the HDF5 files of the runner store them:
built from the runner's own table of columns, which the native module exports.

:func:`chainsweep.run` labels its Dataset with these; :func:`chainsweep.open` takes the same from
each file's own attributes.
"""

from __future__ import annotations

import numpy as np

from . import _chainsweep as _native

#: The runner's table of stored summary columns (``record::columns`` in the engine), exported by
#: the native module: every name, unit and description below comes from it.
COLUMNS: dict[str, dict] = {c["name"]: c for c in _native.COLUMNS}


def _label(c: dict) -> tuple[str | None, str]:
    """(units, long_name) of a column; units None: none, or the probes' own unit."""
    units = None if c["units"] in (None, "of_probes") else c["units"]
    return units, c["description"]


def _flag_attrs(name: str) -> dict:
    c = COLUMNS[name]
    return {
        "flag_values": np.array(c["flag_values"], dtype=np.uint8),
        "flag_meanings": c["flag_meanings"],
    }


# `status`: 0 pending, 1 ok, 2 failed (the file's flag_values / flag_meanings).
STATUS_PENDING, STATUS_OK, STATUS_FAILED = COLUMNS["status"]["flag_values"]
STATUS_ATTRS = _flag_attrs("status")

#: Per-run float summaries: name -> (units, long_name).
RUN_FLOATS: dict[str, tuple[str, str]] = {
    n: _label(c) for n, c in COLUMNS.items() if c["kind"] in ("ok_f64", "run_f64")
}

#: Per-run integer counters: name -> (units, long_name). The files store -1 where a run failed or
#: is pending; :func:`chainsweep.open` masks it (float64 with NaN, as xarray decodes a fill value).
RUN_COUNTERS: dict[str, tuple[str, str]] = {
    n: _label(c) for n, c in COLUMNS.items() if c["kind"] == "ok_count"
}

#: Per-run columns of a scene that can integrate only the moving part of its chain (a long chain
#: struck at one end): name -> (units, long_name). The files have them only where some grid point
#: can, :func:`chainsweep.run` only for such a scene; elsewhere they would repeat the chain's length.
MOVING_PART_COLUMNS: dict[str, tuple[str | None, str]] = {
    n: _label(c) for n, c in COLUMNS.items() if c["written"] == "with_moving_part"
}
#: `moving_part`: 0 failed, pending or not known, 1 the whole chain, 2 only the moving part.
MOVING_PART_ATTRS = _flag_attrs("moving_part")

#: Per-probe summaries: name -> (units, long_name); units None: the probes' own unit.
PROBE_SUMMARIES: dict[str, tuple[str | None, str]] = {
    n: _label(c) for n, c in COLUMNS.items() if c["kind"] == "probe_f64"
}

#: Per-probe flags derived from a run's summaries: name -> (long_name, flag attributes).
#: `leading_pulse`: 0 no run, 1 passed, 2 had not passed the probe by the end of the run (its
#: leading_peak and leading_peak_time_s are NaN, and this says why).
PROBE_FLAGS: dict[str, tuple[str, dict]] = {
    n: (c["description"], _flag_attrs(n)) for n, c in COLUMNS.items() if c["kind"] == "probe_flag"
}

#: Per-run strings: name -> long_name.
RUN_STRINGS: dict[str, str] = {
    n: c["description"] for n, c in COLUMNS.items() if c["dtype"] == "str" and not c["per_probe"]
}

#: Histories and minimum overlaps (per-run groups in the files).
HISTORY_LONG_NAME = "history of each probe, sampled every record.history_interval_s"
MIN_OVERLAP_LONG_NAME = "minimum overlap of each contact over the run"
CONTACT_LONG_NAME = "contact j, between particles j and j+1 (the last one: the wall)"

#: The order in which datasets list their variables (others follow, by name).
ORDER: list[str] = [
    *PROBE_SUMMARIES,
    *PROBE_FLAGS,
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
