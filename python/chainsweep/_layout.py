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
    """(units, long_name) of a column; units None: none, or the probes' own unit. The long_name
    is the column's short label (what a plot labels it by); the files hold its description as
    the `comment`."""
    units = None if c["units"] in (None, "of_probes") else c["units"]
    return units, c["label"]


def _flag_attrs(name: str) -> dict:
    c = COLUMNS[name]
    return {
        "flag_values": np.array(c["flag_values"], dtype=np.uint8),
        "flag_meanings": c["flag_meanings"],
    }


# `status`: 0 pending, 1 ok, 2 failed, 3 unsettled (the file's long_name, flag_values / flag_meanings).
STATUS_PENDING, STATUS_OK, STATUS_FAILED, STATUS_UNSETTLED = COLUMNS["status"]["flag_values"]
STATUS_ATTRS = {"long_name": COLUMNS["status"]["label"], **_flag_attrs("status")}

# The energy ledger's terms (`record.energy_ledger`), at the start and at the end: name → (units,
# long_name), from the engine's table.
LEDGER_COLUMNS: dict[str, tuple[str, str]] = {
    n: (c["units"], c["label"]) for n, c in COLUMNS.items() if c["kind"] == "ledger"
}

#: Per-run float summaries: name -> (units, long_name) (the linear spectrum's apart).
RUN_FLOATS: dict[str, tuple[str, str]] = {
    n: _label(c)
    for n, c in COLUMNS.items()
    if c["kind"] in ("ok_f64", "run_f64")
    and c["written"] not in ("with_spectrum", "with_steady_state")
}

#: The steady state's columns (record.steady_state): name -> the engine's column (``kind``:
#: ``ok_f64`` per run, ``steady_f64`` and ``steady_flag`` per probe, ``steady_harmonic`` per probe
#: and harmonic). The files have them only where the sweep records the steady state,
#: :func:`chainsweep.run` only for such a scene.
STEADY_COLUMNS: dict[str, dict] = {
    n: c for n, c in COLUMNS.items() if c["written"] == "with_steady_state"
}
HARMONIC_LONG_NAME = _native.ARRAYS["harmonic"]["long_name"]

#: The linear spectrum's columns (record.spectrum): name -> (units, long_name). The files have
#: them only where the sweep records the spectrum, :func:`chainsweep.run` only for such a scene.
SPECTRUM_COLUMNS: dict[str, tuple[str, str]] = {
    n: _label(c) for n, c in COLUMNS.items() if c["written"] == "with_spectrum"
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

#: The per-probe summaries in the probes' own unit (peaks and maxima; their times are in s).
PROBE_UNIT_COLUMNS: list[str] = [n for n, c in COLUMNS.items() if c["units"] == "of_probes"]

#: Per-probe flags derived from a run's summaries: name -> (long_name, flag attributes).
#: `leading_pulse`: 0 no run, 1 passed, 2 had not passed the probe by the end of the run (its
#: leading_peak and leading_peak_time_s are NaN, and this says why).
PROBE_FLAGS: dict[str, tuple[str, dict]] = {
    n: (c["label"], _flag_attrs(n)) for n, c in COLUMNS.items() if c["kind"] == "probe_flag"
}

#: Per-run strings: name -> long_name.
RUN_STRINGS: dict[str, str] = {
    n: c["label"] for n, c in COLUMNS.items() if c["dtype"] == "str" and not c["per_probe"]
}

#: The runs' arrays (histories, minimum overlaps, fields, energy flow) and their coordinates, as
#: the store writes them: name -> {long_name, comment, units, over}, exported by the native module
#: (the store's one definition of their labels).
ARRAYS: dict[str, dict] = dict(_native.ARRAYS)

HISTORY_LONG_NAME = ARRAYS["history"]["long_name"]
MIN_OVERLAP_LONG_NAME = ARRAYS["min_overlap_m"]["long_name"]
CONTACT_LONG_NAME = ARRAYS["contact"]["long_name"]
CONTACT_COMMENT = ARRAYS["contact"]["comment"]
PARTICLE_LONG_NAME = ARRAYS["particle"]["long_name"]
PARTICLE_COMMENT = ARRAYS["particle"]["comment"]
#: The energy flow (record.energy_flow): variable -> (the coordinate it is over, long name).
ENERGY_FLOW = {
    n: (ARRAYS[n]["over"], ARRAYS[n]["long_name"])
    for n in ("energy_passed_max_j", "energy_passed_final_j", "max_kinetic_energy_j")
}
#: What each energy-flow variable is (its ``comment``).
ENERGY_FLOW_COMMENTS = {n: ARRAYS[n]["comment"] for n in ENERGY_FLOW}
FIELD_TIME_LONG_NAME = ARRAYS["field_time_s"]["long_name"]
FIELD_TIME_COMMENT = ARRAYS["field_time_s"]["comment"]
#: Space-time fields (record.fields): variable -> (units, long_name, comment).
FIELDS: dict[str, tuple[str, str, str]] = {
    n: (ARRAYS[n]["units"], ARRAYS[n]["long_name"], ARRAYS[n]["comment"])
    for n in ("field_contact_force", "field_displacement", "field_velocity")
}

#: The order in which datasets list their variables (others follow, by name).
ORDER: list[str] = [
    *PROBE_SUMMARIES,
    *PROBE_FLAGS,
    *RUN_FLOATS,
    *RUN_COUNTERS,
    *MOVING_PART_COLUMNS,
    *SPECTRUM_COLUMNS,
    *STEADY_COLUMNS,
    "status",
    "reason",
    "warnings",
    "verified",
    "verify_rel_error_max",
    "verify_rel_error_leading_peak",
    "verify_rel_error_leading_peak_time",
    "verify_rel_error_record_max",
    "verify_rel_error_record_max_time",
    "verify_rel_error_steady",
    "verify_rel_error_max_overlap",
    "verify_rel_error_energy_flow",
    "run_hash",
    *[f"ledger_{t}{s}" for s in ("_start_j", "_j") for t in
      ("kinetic", "elastic", "gravitational", "dissipated", "plastic", "external", "mount")],
    "history",
    "min_overlap_m",
    *ENERGY_FLOW,
]


def ordered(names):
    """`names` in the order of ORDER (a column split by unit right after its column), the others
    after them by name."""
    rank = {n: i for i, n in enumerate(ORDER)}
    for c in PROBE_UNIT_COLUMNS:
        for n in names:
            if n not in rank and n.startswith(c + "_") and n[len(c) + 1 :] in _SUFFIXES:
                rank[n] = rank[c] + 0.5
    return sorted(names, key=lambda n: (rank.get(n, len(ORDER)), n))


def unit_suffix(unit: str) -> str:
    """The part of a variable's name that stands for a unit (`N`, `m`, `m_per_s`): as the
    runner's ``record::columns::unit_suffix``."""
    return "_per_".join(
        "".join(c if c.isascii() and c.isalnum() else "_" for c in part) for part in unit.split("/")
    )


def split_name(column: str, unit: str) -> str:
    """LAYOUT: the variable holding per-probe `column` (one of PROBE_UNIT_COLUMNS) for the probes
    measured in `unit`, in a file whose probes' units differ (``leading_peak_N``,
    ``leading_peak_m_per_s``): over every probe, NaN at the probes of other units."""
    return f"{column}_{unit_suffix(unit)}"


# The suffixes of the units probes measure in (for `ordered`).
_SUFFIXES = {unit_suffix(u) for u in ("N", "m", "m/s")}

#: What a per-probe variable over probes of different units says instead of one `units`.
MIXED_UNITS_COMMENT = "the probes measure in different units: each probe's unit is its probe_units"

#: The `units` of a per-probe summary over probes of different units in files of layout 3 and
#: earlier (a sentence no units parser reads; chainsweep.open drops it).
OLD_MIXED_UNITS = "see probe_units"


def probe_units(units: list[str]) -> str | None:
    """The probes' common unit; None where they differ (no one `units` fits a variable over
    them all)."""
    return units[0] if units and all(u == units[0] for u in units) else None


def probe_attrs(units: list[str], long_name: str, split: str | None = None) -> dict[str, str]:
    """The attributes of a variable in the probes' own unit over probes of `units`: its `units`
    where they share one; where they differ no `units` (never a sentence there: CF readers parse
    it) but a `comment` pointing at `probe_units` (and, for a summary `split` stored once per unit,
    at those variables)."""
    u = probe_units(units)
    if u is not None:
        return {"units": u, "long_name": long_name}
    comment = MIXED_UNITS_COMMENT
    if split is not None:
        names = ", ".join(split_name(split, x) for x in dict.fromkeys(units))
        comment += f"; {names} hold its values in one unit each"
    return {"long_name": long_name, "comment": comment}


def split_by_unit(
    name: str, dims: tuple[str, ...], values: np.ndarray, units: list[str], long_name: str
) -> dict[str, tuple]:
    """Variable `name` in the probes' own unit (probe last of `dims`) as the files store it where
    the probes' units differ: one variable per unit (split_name), in that unit, NaN at the probes
    of the others. Empty where the probes share one unit."""
    if probe_units(units) is not None:
        return {}
    out = {}
    for u in dict.fromkeys(units):
        part = np.array(values, dtype=np.float64, copy=True)
        part[..., [k for k, x in enumerate(units) if x != u]] = np.nan
        attrs = {
            "units": u,
            "long_name": long_name,
            "comment": f"the probes measured in {u}; NaN at the others",
        }
        out[split_name(name, u)] = (dims, part, attrs)
    return out
