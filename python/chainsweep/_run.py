"""chainsweep.run: one scene, in this process, as a labelled Dataset."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, Literal, overload

import numpy as np
import xarray as xr

from . import _chainsweep as _native
from . import _layout as L
from ._json import dumps
from .errors import InputError, RunError

Scene = Mapping[str, Any]


def _versions() -> dict[str, Any]:
    return {
        "engine": "chainsweep",
        "engine_version": _native.ENGINE_VERSION,
        "solver_version": _native.SOLVER_VERSION,
        "numerics_version": _native.NUMERICS_VERSION,
        "git_revision": _native.GIT_REVISION,
    }


def _floats(raw: bytes) -> np.ndarray:
    """Little-endian float64 bytes (the native module's arrays) as a float64 array."""
    return np.frombuffer(raw, dtype="<f8").astype(np.float64)


def _arrays(raw: dict[str, Any]) -> dict[str, Any]:
    """The native module's answer as numpy arrays (the `as_dataset=False` form)."""
    ok = bool(raw["ok"])
    out: dict[str, Any] = {
        "probe": np.array(raw["probe"], dtype=str),
        "probe_units": np.array(raw["probe_units"], dtype=str),
    }
    # Every column as the output file fills it for this run (the engine's table).
    col = raw["columns"]
    for name in L.PROBE_SUMMARIES:
        out[name] = np.array(col[name], dtype=np.float64)
    for name in L.PROBE_FLAGS:
        out[name] = np.array(col[name], dtype=np.uint8)
    for name in L.RUN_FLOATS:
        out[name] = np.float64(col[name])
    for name in L.SPECTRUM_COLUMNS:  # where the scene records the spectrum
        if name in col:
            out[name] = np.float64(col[name])
    for name, c in L.STEADY_COLUMNS.items():  # where the scene records the steady state
        if name in col:
            dtype = np.uint8 if c["kind"] == "steady_flag" else np.float64
            out[name] = np.array(col[name], dtype=dtype)
    for name in L.LEDGER_COLUMNS:  # where the scene records the energy ledger
        if name in col:
            out[name] = np.float64(col[name])
    # Counts: None where the file stores its fill (-1; a failed run counted nothing that is
    # kept): NaN, as chainsweep.open masks it.
    def count(name: str):
        return np.float64(np.nan) if col[name] is None else np.int64(col[name])

    for name in L.RUN_COUNTERS:
        out[name] = count(name)
    if raw["moving_part_recorded"]:
        out["integrated_particles"] = count("integrated_particles")
        out["moving_part"] = np.uint8(col["moving_part"])
    out["status"] = np.uint8(col["status"])
    for name in L.RUN_STRINGS:
        out[name] = str(col[name])
    if raw["history_recorded"]:
        n = len(out["probe"])
        if raw["time_s"] is None:  # a failed run records no history
            time = np.zeros(0)
            history = np.zeros((n, 0))
        else:
            time = _floats(raw["time_s"])
            history = np.stack([_floats(s) for s in raw["history"]]) if n else np.zeros((0, len(time)))
        out["time_s"] = time
        out["history"] = history
    if raw["min_overlap_recorded"]:
        m = raw["min_overlap_m"]
        out["min_overlap_m"] = np.zeros(0) if m is None else _floats(m)
        out["contact"] = np.arange(1, len(out["min_overlap_m"]) + 1, dtype=np.int64)
    if raw["energy_flow_recorded"]:
        for name in L.ENERGY_FLOW:
            m = raw[name]  # None for a failed run
            out[name] = np.zeros(0) if m is None else _floats(m)
    if raw["fields_recorded"] is not None:
        if raw["fields"] is None:  # a failed run records no fields
            out["field_time_s"] = np.zeros(0)
            for name in raw["fields_recorded"]:
                out[f"field_{name}"] = np.zeros((0, 0))
        else:
            time = _floats(raw["field_time_s"])
            out["field_time_s"] = time
            for name, width, values in raw["fields"]:
                out[f"field_{name}"] = _floats(values).reshape(len(time), width)
    limit = raw["energy_drift_limit"]
    attrs: dict[str, Any] = {
        "scene": raw["scene"],
        "integrator": raw["integrator"],
        "run_hash": raw["run_hash"],
        "energy_drift_limit": math.nan if limit is None else float(limit),
        "probes_json": raw["probes_json"],
        **_versions(),
    }
    if raw["auto"] is not None:
        attrs["auto"] = raw["auto"]
        attrs["auto_setting"] = raw["auto_setting"]
    out["attrs"] = attrs
    return out


def _dataset(a: dict[str, Any]) -> xr.Dataset:
    """The arrays of one run as a labelled Dataset."""
    units = [str(u) for u in a["probe_units"]]
    coords: dict[str, Any] = {
        "probe": ("probe", a["probe"], {"long_name": "probe (as in the record block)"}),
        "probe_units": ("probe", a["probe_units"]),
    }
    data: dict[str, Any] = {}
    for name, (unit, long_name) in L.PROBE_SUMMARIES.items():
        if unit is not None:
            data[name] = ("probe", a[name], {"units": unit, "long_name": long_name})
        else:
            data[name] = ("probe", a[name], L.probe_attrs(units, long_name, split=name))
            data.update(L.split_by_unit(name, ("probe",), a[name], units, long_name))
    for name, (long_name, flag_attrs) in L.PROBE_FLAGS.items():
        data[name] = ("probe", a[name], {"long_name": long_name, **flag_attrs})
    for name, (unit, long_name) in {**L.RUN_FLOATS, **L.RUN_COUNTERS}.items():
        data[name] = ((), a[name], {"units": unit, "long_name": long_name})
    for name, (unit, long_name) in {**L.SPECTRUM_COLUMNS, **L.LEDGER_COLUMNS}.items():
        if name in a:
            data[name] = ((), a[name], {"units": unit, "long_name": long_name})
    for name, c in L.STEADY_COLUMNS.items():
        if name not in a:
            continue
        long_name = c["label"]
        dims = {"ok_f64": (), "steady_harmonic": ("probe", "harmonic")}.get(c["kind"], ("probe",))
        if c["kind"] == "steady_flag":
            attrs = {"long_name": long_name, **L._flag_attrs(name)}
        elif c["units"] == "of_probes":
            attrs = L.probe_attrs(units, long_name, split=name)
            # (split by unit with the probe last, as the files store it)
            values = np.moveaxis(a[name], 0, -1) if "harmonic" in dims else a[name]
            for part, (_, v, pattrs) in L.split_by_unit(name, dims, values, units, long_name).items():
                data[part] = (dims, np.moveaxis(v, -1, 0) if "harmonic" in dims else v, pattrs)
        else:
            attrs = {"units": c["units"], "long_name": long_name}
        if "harmonic" in dims:
            h = np.arange(1, a[name].shape[1] + 1, dtype=np.int64)
            coords["harmonic"] = ("harmonic", h, {"units": "1", "long_name": L.HARMONIC_LONG_NAME})
        data[name] = (dims, a[name], attrs)
    for name, (unit, long_name) in L.MOVING_PART_COLUMNS.items():
        if name in a:
            attrs = {"long_name": long_name} if unit is None else {"units": unit, "long_name": long_name}
            if name == "moving_part":
                attrs.update(L.MOVING_PART_ATTRS)
            data[name] = ((), a[name], attrs)
    data["status"] = ((), a["status"], dict(L.STATUS_ATTRS))
    for name, long_name in L.RUN_STRINGS.items():
        data[name] = ((), np.array(a[name], dtype=object), {"long_name": long_name})
    if "history" in a:
        coords["time_s"] = ("time_s", a["time_s"], {"units": "s"})
        data["history"] = (
            ("probe", "time_s"),
            a["history"],
            L.probe_attrs(units, L.HISTORY_LONG_NAME),
        )
    if "min_overlap_m" in a:
        coords["contact"] = ("contact", a["contact"], {"long_name": L.CONTACT_LONG_NAME, "comment": L.CONTACT_COMMENT})
        data["min_overlap_m"] = (
            "contact",
            a["min_overlap_m"],
            {"units": "m", "long_name": L.MIN_OVERLAP_LONG_NAME},
        )
    for name, (dim, long_name) in L.ENERGY_FLOW.items():
        if name not in a:
            continue
        long_coord = {"long_name": L.CONTACT_LONG_NAME, "comment": L.CONTACT_COMMENT} if dim == "contact" else {
            "long_name": L.PARTICLE_LONG_NAME, "comment": L.PARTICLE_COMMENT}
        width = len(a[name])
        if dim not in coords:
            coords[dim] = (dim, np.arange(1, width + 1, dtype=np.int64), long_coord)
        data[name] = (dim, a[name], {"units": "J", "long_name": long_name, "comment": L.ENERGY_FLOW_COMMENTS[name]})
    if "field_time_s" in a:
        coords["field_time_s"] = (
            "field_time_s", a["field_time_s"],
            {"units": "s", "long_name": L.FIELD_TIME_LONG_NAME, "comment": L.FIELD_TIME_COMMENT}
        )
        for name, (unit, long_name, comment) in L.FIELDS.items():
            if name not in a:
                continue
            last = "contact" if name == "field_contact_force" else "particle"
            width = a[name].shape[1]
            if last == "contact":
                coords.setdefault(
                    "contact",
                    ("contact", np.arange(1, width + 1, dtype=np.int64),
                     {"long_name": L.CONTACT_LONG_NAME, "comment": L.CONTACT_COMMENT}),
                )
            else:
                coords["particle"] = (
                    "particle", np.arange(1, width + 1, dtype=np.int64),
                    {"long_name": L.PARTICLE_LONG_NAME, "comment": L.PARTICLE_COMMENT},
                )
            data[name] = (("field_time_s", last), a[name],
                          {"units": unit, "long_name": long_name, "comment": comment})
    return xr.Dataset(data, coords=coords, attrs=a["attrs"])


@overload
def run(
    scene: Scene,
    *,
    record: Mapping[str, Any] | None = None,
    limits: Mapping[str, Any] | None = None,
    as_dataset: Literal[True] = True,
) -> xr.Dataset: ...


@overload
def run(
    scene: Scene,
    *,
    record: Mapping[str, Any] | None = None,
    limits: Mapping[str, Any] | None = None,
    as_dataset: Literal[False],
) -> dict[str, Any]: ...


def run(
    scene: Scene,
    *,
    record: Mapping[str, Any] | None = None,
    limits: Mapping[str, Any] | None = None,
    as_dataset: bool = True,
) -> xr.Dataset | dict[str, Any]:
    """Runs one scene in this process and returns what it recorded.

    ``scene`` is the JSON of a sweep file's ``base`` as a dict: a chain (a preset such as
    ``{"preset": "chain_055", "cylinders": 50}`` with overrides beside it, or every field),
    ``physics``, ``striker_velocity_m_s``, ``duration_s``, optionally ``integrator`` (default
    DOP853 at rtol 1e-9) and ``max_steps``; fields left out take the solver's defaults. The
    ``record`` block (probes, histories, …) goes either inside the scene, as the solver's scene
    JSON has it, or in the ``record`` argument, as a sweep file has it beside ``base`` — not both.
    ``limits`` is a sweep file's ``limits`` block (default ``{"energy_drift_max": 1e-3}``).

    The scene is normalised, identified and run by the runner's own code, as a one-point sweep,
    so the numbers are bitwise those of ``chainsweep point`` for the same scene. The GIL is
    released while the solver runs: threads run scenes in parallel.

    ``integrator: {"method": "auto", "target_rel_error": …}`` is resolved as ``chainsweep point``
    resolves it without ``-o``: by a pilot on this scene (a reference run at rtol 1e-12 and a
    ladder of candidates; tens of runs' worth of work). The choice is in ``attrs["integrator"]``
    (and ``attrs["auto"]``): pass it as the integrator of later calls to skip the pilot.

    Returns an ``xarray.Dataset`` with a ``probe`` dimension (coordinate: the probe names, and
    ``probe_units``); per-probe ``leading_peak``, ``leading_peak_time_s``, ``record_max``,
    ``record_max_time_s``; per-run ``t_end_s``, ``energy_drift_max``, ``energy_drift_final``,
    ``momentum_residual_max``, ``impact_energy_j``, ``wall_time_s``, ``max_overlap_m``,
    ``steps``, ``rejected_steps``, ``rhs_evals``, ``events`` (int64), for a scene that can
    integrate only the moving part of its chain (a long chain, see the solver's ``active_region``)
    ``integrated_particles`` (int64) and ``moving_part`` (uint8: 1 the whole chain, 2 only the
    moving part), ``status`` (1 ok),
    ``reason``, ``warnings`` (one per line), ``run_hash``; ``history`` over (``probe``,
    ``time_s``) when ``record.history`` is on; ``min_overlap_m`` over ``contact`` (1-based) when
    ``record.min_overlap`` is on; with ``record.fields``, ``field_contact_force`` over
    (``field_time_s``, ``contact``) and ``field_displacement``, ``field_velocity`` over
    (``field_time_s``, ``particle``), each quantity asked for. Every variable has ``units``; ``attrs`` hold the scene as run
    (JSON, defaults filled in), the integrator, the run hash and the versions. With
    ``as_dataset=False``: a dict of the same names holding numpy arrays and scalars, plus
    ``"attrs"``.

    Raises :class:`~chainsweep.InputError` (``.field``: the scene field, e.g.
    ``chain.cylinders`` or ``record.probes[0].cylinder``) for bad input, and
    :class:`~chainsweep.RunError` when the run fails (``.reason``; ``.result``: the Dataset or
    dict with ``status`` 2, ``reason``, ``wall_time_s`` and NaN elsewhere).
    """
    if not isinstance(scene, Mapping):
        raise TypeError(f"scene must be a dict (a sweep file's `base`), got {type(scene).__name__}")
    scene = dict(scene)
    if record is not None and "record" in scene:
        raise InputError(
            "record",
            "given twice: inside the scene and as the `record` argument; give it once",
        )
    if record is None:
        record = scene.pop("record", None)
    # Plain values (dicts, lists, text, numbers, bools) are read by the engine as they are; for
    # anything else (numpy values, NaN) it answers None, and the JSON text is written here, which
    # converts numpy values and names what cannot be JSON.
    raw = _native.run_scene(scene, record, limits)
    if raw is None:
        raw = _native.run_scene(
            dumps(scene, indent=None),
            None if record is None else dumps(record, "record", indent=None),
            None if limits is None else dumps(limits, "limits", indent=None),
        )
    arrays = _arrays(raw)
    result: xr.Dataset | dict[str, Any] = _dataset(arrays) if as_dataset else arrays
    if not raw["ok"]:
        raise RunError(raw["reason"], result)
    return result

