"""chainsweep.open: a sweep's HDF5 file as a labelled Dataset, read with h5py.

What this module knows of the file's layout (docs/REFERENCE.md) is kept in the
functions marked LAYOUT, so that a change of layout is followed there:

- the grid: root attributes ``dimensions`` (JSON list of names) and ``grid_shape``;
- coordinates: root datasets with a ``dimension`` attribute (zipped axes share one dimension;
  boolean axes are bytes with ``dtype = "bool"`` from layout 4); the ``probe`` dataset and
  ``probe_units`` on it; a zipped dimension named after none of its axes is also an empty
  dataset marked as a netCDF dimension without a variable (not data), and so is the dimension of
  the characters of each text (``<name>_strlen``);
- text: netCDF ``char`` arrays from layout 4 (the UTF-8 bytes of each text along a last
  dimension, NUL-padded), variable-length strings before;
- summaries: every other root dataset shaped like the grid, or like the grid and the probes;
  numeric ones mark missing values with a fill attribute (``_FillValue``); a dimension is named
  after the dataset of the dimension scale attached to it; where the probes' units differ, a
  summary in the probes' unit is one dataset per unit (``leading_peak_N``, … from layout 4:
  ``_layout.split_name``), one dataset with ``units = "see probe_units"`` before;
- the runs' arrays, from layout 5: ``history`` over (grid…, probe, time_s) (one dataset per unit
  where the probes' units differ: ``history_N``, …), NaN after a run's end and where it has none,
  with ``time_s`` the one time axis, or, where the runs' intervals differ, the dimension
  ``sample`` and ``time_s`` a variable over (grid…, sample); ``history_samples`` over the grid;
  ``min_overlap_m`` over (grid…, contact) on the coordinate ``contact``;
- before layout 5, per-run groups (histories, minimum overlaps) under ``runs/``
  (``run_<flat index>``; older files: the zero-padded index), each with a ``flat_index``
  attribute, read by that attribute; a history dataset per probe, named like it, on the group's
  ``time_s``.
"""

from __future__ import annotations

import itertools
import os
import threading
from collections.abc import Iterator
from typing import Any

import h5py
import numpy as np
import xarray as xr

from . import _chainsweep as _native
from . import _layout as L
from .errors import DamagedFileError, Error, InputError

from ._h5 import (  # noqa: F401 (re-exported for _sweep)
    PathLike,
    _DIMENSION_ONLY,
    _FILL_ATTRS,
    _Grid,
    _INTERNAL_ATTRS,
    _LISTED_DAMAGE,
    _REPAIR,
    _attrs,
    _chars,
    _dimension_only,
    _is_char,
    _labels,
    _read,
    _scale_name,
    _value,
)

# LAYOUT: the first layout whose runs' arrays are datasets over the grid (not run groups), and
# the names of those arrays at the root.
_ARRAYS_LAYOUT = 5
_ARRAY_NAMES = {
    "history", "history_N", "history_m", "history_m_per_s", "time_s", "sample", "min_overlap_m",
    "contact",
}
# LAYOUT: the space–time fields (record.fields), read with the histories: one variable per
# quantity over (grid…, field_time_s, contact | particle), and their coordinates and counts.
_FIELD_NAMES = ("field_contact_force", "field_displacement", "field_velocity")
_FIELD_COORDS = ("field_time_s", "field_samples", "particle")
_ARRAY_NAMES |= {*_FIELD_NAMES, *_FIELD_COORDS, *L.ENERGY_FLOW}


def _has_arrays(f: h5py.File) -> bool:
    """LAYOUT: whether the file stores its runs' arrays as datasets over the grid (layout 5)."""
    return int(f.attrs.get("layout_version", 1)) >= _ARRAYS_LAYOUT


def _history_parts(grid: "_Grid") -> list[tuple[str, list[int]]]:
    """LAYOUT: the history datasets of a layout-5 file, each with the probes it holds: one
    ``history``, or one per unit where the probes' units differ (``history_N``, …)."""
    units = grid.probe_units
    if L.probe_units(units) is not None:
        return [("history", list(range(len(units))))]
    return [
        (L.split_name("history", u), [k for k, x in enumerate(units) if x == u])
        for u in dict.fromkeys(units)
    ]


class _ChunkDamage:
    """The grid points whose values lie in a chunk HDF5 could not read (its Fletcher-32 check
    failed) while `chainsweep.open` read the file: damage, whatever the engine's check covered,
    reported or masked like the points the check found, never served as NaN."""

    def __init__(self, shape: tuple[int, ...]):
        self.shape = tuple(shape)
        self.points: dict[int, str] = {}

    def note(self, name: str, chunk: tuple) -> None:
        nd = len(self.shape)
        ranges = [range(*c.indices(n)) for c, n in zip(chunk[:nd], self.shape)]
        for at in itertools.product(*ranges):
            i = int(np.ravel_multi_index(at, self.shape)) if nd else 0
            self.points.setdefault(i, f"a chunk of `{name}` fails its HDF5 checksum (Fletcher-32)")


# The damage noted while `chainsweep.open` reads a file (this thread's; None elsewhere).
_READING = threading.local()


def _read_masked(ds: h5py.Dataset, sel: tuple = ()) -> np.ndarray:
    """`ds[sel]` as float64, a chunk whose Fletcher-32 check fails read as NaN and its points
    noted as damaged (reported or masked by open, as `damaged` says; a lazy block's points were
    found by the check before)."""
    sel = tuple(sel) + (slice(None),) * (ds.ndim - len(sel))
    try:
        return np.asarray(ds[sel], dtype=np.float64)
    except OSError:
        pass
    box = [s.indices(n) for s, n in zip(sel, ds.shape)]
    out = np.full([len(range(*b)) for b in box], np.nan)
    sink = getattr(_READING, "damage", None)
    for chunk in ds.iter_chunks(tuple(slice(*b) for b in box)):
        try:
            part = ds[chunk]
        except OSError:
            if sink is not None:
                sink.note(ds.name.lstrip("/"), chunk)
            continue
        out[tuple(slice(c.start - b[0], c.stop - b[0]) for c, b in zip(chunk, box))] = part
    return out


def _array_histories(
    f: h5py.File, grid: "_Grid", sel: tuple = ()
) -> np.ndarray:
    """LAYOUT: the histories of layout 5 over (grid…, probe, time) (the grid's points `sel`), one
    array over every probe whatever their units."""
    parts = _history_parts(grid)
    if len(parts) == 1:
        return _read_masked(f[parts[0][0]], sel)
    out = None
    for name, probes in parts:
        part = _read_masked(f[name], sel)
        if out is None:
            out = np.full(part.shape, np.nan)
        out[..., probes, :] = part[..., probes, :]
    return out


def _array_time(f: h5py.File, grid: "_Grid") -> tuple[str, dict[str, Any]]:
    """LAYOUT: the last dimension of the histories of layout 5 and its time coordinate."""
    t = f["time_s"]
    attrs = {"units": "s", "long_name": _value(t.attrs.get("long_name", "time"))}
    if t.ndim == 1:
        return "time_s", {"time_s": ("time_s", _read_masked(t), attrs)}
    return "sample", {"time_s": ((*grid.dims, "sample"), _read_masked(t), attrs)}


def _run_groups(f: h5py.File) -> Iterator[tuple[int, h5py.Group]]:
    """LAYOUT: every per-run group with its flat (row-major) grid index."""
    runs = f.get("runs")
    if runs is None:
        return
    for g in runs.values():
        if isinstance(g, h5py.Group) and "flat_index" in g.attrs:
            yield int(g.attrs["flat_index"]), g


def _min_overlap_of(g: h5py.Group) -> np.ndarray | None:
    """LAYOUT: one run's minimum overlap of every contact."""
    try:
        return g["min_overlap_m"][()] if "min_overlap_m" in g else None
    except OSError:  # damaged (masked by open's damaged="mask")
        return None


def _stack_histories(
    f: h5py.File, grid: _Grid
) -> tuple[dict[str, Any], dict[str, Any]] | None:
    """All histories as one array over (grid…, probe, time_s), NaN where a run has none.

    Layout 5: the file's own array(s), read with one slice each. Before: each run's series is
    read straight into its place of the one array (allocated once the longest run is known from
    the datasets' shapes), so the memory needed is that array and the runs' time samples, not a
    copy of every history besides."""
    if _has_arrays(f):
        if "time_s" not in f:
            return None
        last, coords = _array_time(f, grid)
        if not grid.probes:
            return {}, coords
        values = _array_histories(f, grid)
        attrs = L.probe_attrs(grid.probe_units, L.HISTORY_LONG_NAME)
        return {"history": ((*grid.dims, "probe", last), values, attrs)}, coords
    lengths: dict[int, tuple[h5py.Group, int]] = {}
    for i, g in _run_groups(f):
        t = g.get("time_s")
        if isinstance(t, h5py.Dataset) and t.ndim == 1:
            lengths[i] = (g, t.shape[0])
    times: dict[int, np.ndarray] = {}
    for i, (g, _) in lengths.items():
        try:
            times[i] = g["time_s"][()]
        except OSError:  # damaged (a run masked by open's damaged="mask")
            pass
    if not times:
        return None
    n = int(np.prod(grid.shape))
    longest = max(times.values(), key=len)
    width = len(longest)
    values = np.full((n, len(grid.probes), width), np.nan)
    for i, t in times.items():
        g = lengths[i][0]
        m = len(t)
        for k, p in enumerate(grid.probes):
            d = g.get(p)
            if not isinstance(d, h5py.Dataset) or d.shape != (m,) or m == 0:
                continue
            try:
                d.read_direct(values, np.s_[:], np.s_[i, k, :m])
            except OSError:  # damaged: masked
                values[i, k, :m] = np.nan
    values = values.reshape(*grid.shape, len(grid.probes), width)
    attrs = L.probe_attrs(grid.probe_units, L.HISTORY_LONG_NAME)
    shared = all(np.array_equal(t, longest[: len(t)]) for t in times.values())
    coords: dict[str, Any]
    return _history_of_groups(grid, values, attrs, longest if shared else None, times)


def _history_of_groups(
    grid: "_Grid", values: Any, attrs: dict[str, Any], longest: np.ndarray | None,
    times: dict[int, np.ndarray],
) -> tuple[dict[str, Any], dict[str, Any]]:
    """LAYOUT (run groups): the `history` variable and its time coordinate: over `time_s` (the
    `longest` run's instants, which every run shares: shorter runs stopped earlier), else (runs
    sampled at different instants: the interval or the duration an axis) over a `sample`
    dimension, with each run's own instants (`times`) as a coordinate over the grid."""
    if longest is not None:
        coords = {"time_s": ("time_s", longest, {"units": "s"})}
        return {"history": ((*grid.dims, "probe", "time_s"), values, attrs)}, coords
    width = values.shape[-1]
    all_times = np.full((int(np.prod(grid.shape)), width), np.nan)
    for i, t in times.items():
        all_times[i, : len(t)] = t
    coords = {
        "time_s": ((*grid.dims, "sample"), all_times.reshape(*grid.shape, width), {"units": "s"})
    }
    return {"history": ((*grid.dims, "probe", "sample"), values, attrs)}, coords


# Runs per block of the lazy `history` (along the grid's last axis): blocks of about this many
# bytes, so that a reduction over every history holds a few blocks at a time, whatever the file.
_LAZY_BLOCK_BYTES = 8 << 20
# Run groups read per opening of the file while the time samples are gathered: HDF5 keeps what it
# read of every group (about 30 KB a run) until the file is closed.
_GROUPS_PER_OPEN = 512
_BLOCK_LOCK = threading.Lock()


def _array_bytes(f: h5py.File) -> int:
    """Bytes of the runs' histories and fields as stored uncompressed (what reading them whole
    takes): the datasets of layout 5 and later, or every dataset under ``runs/`` of earlier
    layouts."""
    sizes = [f[name].size * f[name].dtype.itemsize
             for name in ("history", "history_N", "history_m", "history_m_per_s", *_FIELD_NAMES)
             if isinstance(f.get(name), h5py.Dataset)]
    if isinstance(f.get("runs"), h5py.Group):
        f["runs"].visititems(
            lambda _, o: sizes.append(o.size * o.dtype.itemsize) if isinstance(o, h5py.Dataset) else None
        )
    return sum(sizes)


def _has_dask() -> bool:
    try:
        import dask.array  # noqa: F401
    except ImportError:
        return False
    return True


def _identity(path: str) -> tuple[int, int, int, int]:
    st = os.stat(path)
    return st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns


def _same_file(path: str, identity: tuple[int, int, int, int]) -> None:
    """Raises unless `path` is still the file chainsweep.open checked (a lazy block reads it
    long after: a sweep may have published it again since)."""
    if _identity(path) != identity:
        raise DamagedFileError(
            path,
            f"{path} was replaced since chainsweep.open checked it (a sweep published it again): "
            "open it again",
            [],
        )


def _lazy_histories(
    path: str, grid: _Grid, masked: set[int], identity: tuple[int, int, int, int] | None = None
) -> tuple[dict[str, Any], dict[str, Any]] | None:
    """LAYOUT: every run's history as one dask array over (grid…, probe, time_s), read from the
    file block by block only when computed (a block: runs along the grid's last axis, about
    `_LAZY_BLOCK_BYTES`), NaN where a run has none and at the `masked` (damaged) points; None
    without dask (then the histories are stacked in memory) or without histories.

    Only the time samples are read now, one run at a time, to find the one time axis (or, where
    the runs' instants differ, the per-run time coordinate). Each block opens the file anew and
    closes it (HDF5 keeps what it read of every run group until the file is closed, so one open
    file would grow by every group read); a block raises when the file is no longer the one
    checked (a sweep re-published it since): open it again."""
    try:
        import dask.array as da
    except ImportError:
        return None
    identity = identity or _identity(path)
    with h5py.File(path, "r") as f:
        if _has_arrays(f):
            return _lazy_arrays(path, f, grid, masked, identity)
        runs = {}
        for i, g in _run_groups(f):
            t = g.get("time_s")
            if isinstance(t, h5py.Dataset) and t.ndim == 1:
                runs[i] = (g.name, t.shape[0])
    order = sorted(runs)
    def each_time(indices: list[int]) -> Iterator[tuple[int, np.ndarray]]:
        """The time samples of runs `indices` that can be read, a few hundred per opening."""
        for s in range(0, len(indices), _GROUPS_PER_OPEN):
            with h5py.File(path, "r") as f:
                for i in indices[s : s + _GROUPS_PER_OPEN]:
                    try:
                        yield i, f[runs[i][0]]["time_s"][()]
                    except OSError:  # damaged: that run masked
                        continue

    # The longest run that can be read (by length, longest first).
    longest: np.ndarray | None = None
    for _, t in each_time(sorted(runs, key=lambda i: -runs[i][1])):
        longest = t
        break
    if longest is None:
        return None
    readable: dict[int, tuple[str, int]] = {}
    shared = True
    for i, t in each_time(sorted(runs)):
        readable[i] = runs[i]
        shared = shared and np.array_equal(t, longest[: len(t)])
    times: dict[int, np.ndarray] = {}
    if not shared:  # every run's own instants, for the time coordinate over the grid
        times = dict(each_time(sorted(readable)))
    width = len(longest)
    n_probes = len(grid.probes)
    nd = len(grid.shape)
    per_run = max(1, n_probes * width * 8)
    chunks: tuple[tuple[int, ...], ...] = tuple((1,) * n for n in grid.shape[:-1])
    if nd:
        last = grid.shape[-1]
        along = max(1, min(last, _LAZY_BLOCK_BYTES // per_run))
        chunks += (tuple(min(along, last - s) for s in range(0, last, along)),)
    chunks += ((n_probes,), (width,))
    probes = list(grid.probes)

    def block(block_info: Any = None) -> np.ndarray:
        loc = block_info[None]["array-location"][:nd]
        lo = [r[0] for r in loc]
        out = np.full((*[r[1] - r[0] for r in loc], n_probes, width), np.nan)
        # (One block at a time: HDF5 reads one at a time anyway, and two threads opening the
        # same file at once can deadlock in h5py.)
        with _BLOCK_LOCK, h5py.File(path, "r") as f:
            _same_file(path, identity)
            for local in np.ndindex(*out.shape[:nd]):
                i = int(np.ravel_multi_index(tuple(x + k for x, k in zip(lo, local)), grid.shape))
                if i in masked or i not in readable:
                    continue
                name, m = readable[i]
                if m == 0:
                    continue
                g = f[name]
                for k, p in enumerate(probes):
                    d = g.get(p)
                    if not isinstance(d, h5py.Dataset) or d.shape != (m,):
                        continue
                    try:
                        d.read_direct(out, np.s_[:], np.s_[(*local, k, slice(0, m))])
                    except OSError:  # damaged: masked
                        out[(*local, k, slice(0, m))] = np.nan
        return out

    token = f"history-{os.path.abspath(path)}-{identity}-{sorted(masked)[:8]}-{len(masked)}"
    values = da.map_blocks(
        block, chunks=chunks, dtype=np.float64, meta=np.empty((0,) * (nd + 2)), name=token
    )
    attrs = L.probe_attrs(grid.probe_units, L.HISTORY_LONG_NAME)
    coords: dict[str, Any]
    return _history_of_groups(grid, values, attrs, longest if shared else None, times)


def _lazy_arrays(
    path: str,
    f: h5py.File,
    grid: "_Grid",
    masked: set[int],
    identity: tuple[int, int, int, int],
) -> tuple[dict[str, Any], dict[str, Any]] | None:
    """LAYOUT: the histories of a layout-5 file as one dask array over (grid…, probe, time),
    read a block of the file's own chunks at a time (runs along the grid's last axis, about
    `_LAZY_BLOCK_BYTES`), the `masked` (damaged) points NaN. Each block opens the file anew and
    raises when it is no longer the one checked."""
    import dask.array as da

    if "time_s" not in f or not grid.probes:
        return None
    last, coords = _array_time(f, grid)
    first = f[_history_parts(grid)[0][0]]
    shape = first.shape
    nd = len(grid.shape)
    chunk = first.chunks or shape
    per_run = max(1, int(np.prod(shape[nd:])) * 8)
    chunks: tuple[tuple[int, ...], ...] = tuple((1,) * n for n in grid.shape[:-1])
    if nd:
        n_last = grid.shape[-1]
        step = max(1, chunk[nd - 1])
        along = max(step, (_LAZY_BLOCK_BYTES // per_run) // step * step)
        along = min(along, n_last)
        chunks += (tuple(min(along, n_last - s) for s in range(0, n_last, along)),)
    chunks += ((shape[nd],), (shape[nd + 1],))

    def block(block_info: Any = None) -> np.ndarray:
        loc = block_info[None]["array-location"][:nd]
        sel = tuple(slice(a, b) for a, b in loc)
        with _BLOCK_LOCK, h5py.File(path, "r") as g:
            _same_file(path, identity)
            out = _array_histories(g, grid, sel)
        for local in np.ndindex(*out.shape[:nd]):
            i = int(np.ravel_multi_index(tuple(s.start + k for s, k in zip(sel, local)), grid.shape))
            if i in masked:
                out[local] = np.nan
        return out

    token = f"history-{os.path.abspath(path)}-{identity}-{sorted(masked)[:8]}-{len(masked)}"
    values = da.map_blocks(
        block, chunks=chunks, dtype=np.float64, meta=np.empty((0,) * (nd + 2)), name=token
    )
    attrs = L.probe_attrs(grid.probe_units, L.HISTORY_LONG_NAME)
    return {"history": ((*grid.dims, "probe", last), values, attrs)}, coords


def _stack_min_overlaps(
    f: h5py.File, grid: _Grid
) -> tuple[dict[str, Any], dict[str, Any]] | None:
    """Minimum overlaps over (grid…, contact), NaN where a run has none (or fewer contacts)."""
    if _has_arrays(f):
        if "min_overlap_m" not in f:
            return None
        d = f["min_overlap_m"]
        coords = {"contact": ("contact", f["contact"][()], {"long_name": L.CONTACT_LONG_NAME, "comment": L.CONTACT_COMMENT})}
        attrs = {"units": "m", "long_name": L.MIN_OVERLAP_LONG_NAME}
        return {"min_overlap_m": ((*grid.dims, "contact"), _read_masked(d), attrs)}, coords
    runs = {i: m for i, g in _run_groups(f) if (m := _min_overlap_of(g)) is not None}
    if not runs:
        return None
    n = int(np.prod(grid.shape))
    width = max(len(m) for m in runs.values())
    values = np.full((n, width), np.nan)
    for i, m in runs.items():
        values[i, : len(m)] = m
    coords = {
        "contact": (
            "contact",
            np.arange(1, width + 1, dtype=np.int64),
            {"long_name": L.CONTACT_LONG_NAME, "comment": L.CONTACT_COMMENT},
        )
    }
    attrs = {"units": "m", "long_name": L.MIN_OVERLAP_LONG_NAME}
    data = {"min_overlap_m": ((*grid.dims, "contact"), values.reshape(*grid.shape, width), attrs)}
    return data, coords


def _stack_energy_flow(
    f: h5py.File, grid: _Grid
) -> tuple[dict[str, Any], dict[str, Any]] | None:
    """The energy flow (record.energy_flow) over (grid…, contact) and (grid…, particle), NaN
    where a run has none (or fewer contacts or particles)."""
    names = [n for n in L.ENERGY_FLOW if n in f]
    if not _has_arrays(f) or not names:
        return None
    data: dict[str, Any] = {}
    coords: dict[str, Any] = {}
    for name in names:
        dim, long_name = L.ENERGY_FLOW[name]
        long_coord = {"long_name": L.CONTACT_LONG_NAME, "comment": L.CONTACT_COMMENT} if dim == "contact" else {
            "long_name": L.PARTICLE_LONG_NAME, "comment": L.PARTICLE_COMMENT}
        coords[dim] = (dim, f[dim][()], long_coord)
        data[name] = ((*grid.dims, dim), _read_masked(f[name]),
                      {"units": "J", "long_name": long_name, "comment": L.ENERGY_FLOW_COMMENTS[name]})
    return data, coords


def _field_coords(f: h5py.File) -> dict[str, Any]:
    """LAYOUT: the coordinates of the fields of a layout-5 file: their time axis and the
    contacts and particles they are over."""
    coords: dict[str, Any] = {}
    for name in ("field_time_s", "contact", "particle"):
        if name in f:
            d = f[name]
            attrs = {k: _value(d.attrs[k]) for k in ("units", "long_name") if k in d.attrs}
            coords[name] = (name, d[()], attrs)
    return coords


def _field_vars(f: h5py.File) -> list[tuple[str, tuple[str, str], dict[str, Any]]]:
    """LAYOUT: each field variable of the file with its last two dimensions and attributes."""
    out = []
    for name in _FIELD_NAMES:
        if name in f:
            d = f[name]
            last = "contact" if name == "field_contact_force" else "particle"
            attrs = {k: _value(d.attrs[k]) for k in ("units", "long_name") if k in d.attrs}
            out.append((name, ("field_time_s", last), attrs))
    return out


def _field_samples(f: h5py.File, grid: "_Grid") -> dict[str, Any]:
    """LAYOUT: how many field samples each run recorded (NaN where none)."""
    d = f["field_samples"]
    values = d[()].astype(np.float64)
    values[values == -1] = np.nan
    attrs = {k: _value(d.attrs[k]) for k in ("units", "long_name") if k in d.attrs}
    return {"field_samples": (tuple(grid.dims), values, attrs)}


def _stack_fields(
    f: h5py.File, grid: "_Grid"
) -> tuple[dict[str, Any], dict[str, Any]] | None:
    """The space–time fields over (grid…, field_time_s, contact | particle), read into memory,
    NaN after a run's end, beyond its contacts or particles and where it has none."""
    if not _has_arrays(f) or "field_samples" not in f:
        return None
    data = _field_samples(f, grid)
    for name, last, attrs in _field_vars(f):
        data[name] = ((*grid.dims, *last), _read_masked(f[name]), attrs)
    return data, _field_coords(f)


def _lazy_fields(
    path: str, grid: "_Grid", masked: set[int], identity: tuple[int, int, int, int] | None = None
) -> tuple[dict[str, Any], dict[str, Any]] | None:
    """The space–time fields as dask arrays read from the file block by block only when
    computed (runs along the grid's last axis, about `_LAZY_BLOCK_BYTES`, whole chunks of the
    file), NaN at the `masked` (damaged) points; each block opens the file anew and raises when
    it is no longer the one checked."""
    import dask.array as da

    identity = identity or _identity(path)
    with h5py.File(path, "r") as f:
        if not _has_arrays(f) or "field_samples" not in f:
            return None
        data = _field_samples(f, grid)
        coords = _field_coords(f)
        variables = [(name, last, attrs, f[name].shape, f[name].chunks)
                     for name, last, attrs in _field_vars(f)]
    nd = len(grid.shape)
    for name, last, attrs, shape, chunk in variables:
        chunks: tuple[tuple[int, ...], ...] = tuple((1,) * n for n in grid.shape[:-1])
        if nd:
            per_run = max(1, int(np.prod(shape[nd:])) * 8)
            n_last = grid.shape[-1]
            step = max(1, (chunk or shape)[nd - 1])
            along = min(max(step, (_LAZY_BLOCK_BYTES // per_run) // step * step), n_last)
            chunks += (tuple(min(along, n_last - s) for s in range(0, n_last, along)),)
        chunks += ((shape[nd],), (shape[nd + 1],))

        def block(block_info: Any = None, name: str = name) -> np.ndarray:
            loc = block_info[None]["array-location"][:nd]
            sel = tuple(slice(a, b) for a, b in loc)
            with _BLOCK_LOCK, h5py.File(path, "r") as g:
                _same_file(path, identity)
                out = _read_masked(g[name], sel)
            for local in np.ndindex(*out.shape[:nd]):
                at = tuple(s.start + k for s, k in zip(sel, local))
                if int(np.ravel_multi_index(at, grid.shape)) in masked:
                    out[local] = np.nan
            return out

        token = f"{name}-{os.path.abspath(path)}-{identity}-{sorted(masked)[:8]}-{len(masked)}"
        values = da.map_blocks(
            block, chunks=chunks, dtype=np.float64, meta=np.empty((0,) * (nd + 2)), name=token
        )
        data[name] = ((*grid.dims, *last), values, attrs)
    return data, coords


def _check(
    path: str, histories: bool, damaged: str
) -> tuple[list[tuple[int, str, str]], list[tuple[str, str, bool]]]:
    """The engine's check of every stored value (its histories too with `histories`): the
    damaged points, or a DamagedFileError when they cannot be served (`damaged="raise"`, or a
    file, header or coordinate that is damaged), and the summary datasets HDF5 cannot read."""
    if damaged not in ("raise", "mask"):
        raise InputError("damaged", f"must be \"raise\" or \"mask\", got {damaged!r}")
    if not os.path.isfile(path):
        raise InputError("path", f"{path} is not a file")
    try:
        with h5py.File(path, "r") as f:
            ours = "dimensions" in f.attrs and "grid_shape" in f.attrs
    except Exception:  # noqa: BLE001 (unreadable: the engine's check says what is wrong)
        ours = True
    if not ours:
        raise InputError("path", f"{path} is not a chainsweep result file (no grid attributes)")
    c = _native.check_file(path, histories)
    repair = _REPAIR.format(path=path)
    if c["file"]:
        raise DamagedFileError(path, f"{path} is damaged: {c['file']}. {repair}", [])
    if c["header"]:
        raise DamagedFileError(path, f"{path} is damaged: {c['header']}. {repair}", [])
    points = [tuple(p) for p in c["damaged"]]
    if points and damaged == "raise":
        listed = "; ".join(
            f"point {i} ({label}): {why}" if label else f"point {i}: {why}"
            for i, label, why in points[:_LISTED_DAMAGE]
        )
        more = f" and {len(points) - _LISTED_DAMAGE} more" if len(points) > _LISTED_DAMAGE else ""
        raise DamagedFileError(
            path,
            f"{path}: {len(points)} point(s) hold values that do not match their checksums: "
            f"{listed}{more}. {repair}",
            points,
        )
    return points, [tuple(u) for u in c["unreadable"]]


def _mask(data: dict[str, Any], grid: "_Grid", points: list[tuple[int, str, str]]) -> None:
    """Masks the damaged points of every variable over the grid: numbers NaN, strings empty,
    `status` pending; adds `damaged` (True where masked)."""
    n = int(np.prod(grid.shape))
    flags = np.zeros(n, dtype=bool)
    flags[[i for i, _, _ in points]] = True
    flags = flags.reshape(grid.shape)
    for name, (dims, values, attrs) in list(data.items()):
        if tuple(dims[: len(grid.dims)]) != tuple(grid.dims):
            continue
        if not isinstance(values, np.ndarray) and hasattr(values, "dask"):
            continue  # a lazy history: its damaged points are masked as it is read
        values = np.array(values)
        if name == "status":
            values[flags] = L.STATUS_PENDING
        elif values.dtype == object:
            values[flags] = ""
        elif values.dtype.kind == "f":
            values[flags] = np.nan
        else:
            values = values.astype(np.float64)
            values[flags] = np.nan
        data[name] = (dims, values, attrs)
    data["damaged"] = (
        tuple(grid.dims),
        flags,
        {"long_name": "whether the point's stored values were damaged (masked here)"},
    )


def _join_units(data: dict[str, Any], grid: "_Grid") -> None:
    """LAYOUT: where the probes' units differ, a summary in the probes' unit both once per unit
    (as layout 4 stores it) and as one variable over every probe (as layout 3 stored it), from a
    file of either: the one variable without `units` (each probe's is its probe_units; layout 3's
    "see probe_units" dropped), so that a probe is selected alike in any file."""
    if L.probe_units(grid.probe_units) is not None:
        return
    for name in L.PROBE_UNIT_COLUMNS:
        long_name = L.COLUMNS[name]["label"]
        parts = [L.split_name(name, u) for u in grid.probe_units]
        if name in data:  # layout 3
            dims, values, attrs = data[name]
            if attrs.get("units") == L.OLD_MIXED_UNITS:
                del attrs["units"]
            attrs.update(L.probe_attrs(grid.probe_units, attrs.get("long_name", long_name), name))
            for part, var in L.split_by_unit(name, dims, values, grid.probe_units, long_name).items():
                data.setdefault(part, var)
        elif parts and all(p in data for p in parts):
            dims = data[parts[0]][0]
            values = np.full(np.shape(data[parts[0]][1]), np.nan)
            # (probe last, or before the harmonic in the steady state's amplitudes)
            at = (Ellipsis, slice(None)) if L.COLUMNS[name].get("per_harmonic") else (Ellipsis,)
            for k, part in enumerate(parts):
                values[(*at[:1], k, *at[1:])] = data[part][1][(*at[:1], k, *at[1:])]
            data[name] = (dims, values, L.probe_attrs(grid.probe_units, long_name, name))


def _is_periodic(path: str) -> bool:
    """LAYOUT: whether the file is a periodic sweep's (its root attribute ``periodic``)."""
    try:
        with h5py.File(path, "r") as f:
            return "periodic" in f.attrs
    except Exception:  # noqa: BLE001 (unreadable: the engine's check says what is wrong)
        return False


def _open_periodic(path: str) -> xr.Dataset:
    """A periodic sweep's file, every dataset read with HDF5's checks on, then by xarray."""
    with h5py.File(path, "r") as f:
        for name, obj in f.items():
            if isinstance(obj, h5py.Dataset) and obj.size and not _dimension_only(obj):
                try:
                    obj[()]
                except OSError as e:
                    raise DamagedFileError(
                        path,
                        f"{path}: {name} fails its checksum ({e}). " + _REPAIR.format(path=path),
                        [],
                    ) from e
    with xr.open_dataset(path, engine="h5netcdf") as ds:
        return ds.load()


class _Replaced(Exception):
    """The file was published again while `chainsweep.open` read it (a running sweep's
    checkpoint): read again."""


# Reads of a file that a running sweep keeps publishing again before one is whole.
_READ_ATTEMPTS = 5


def open(  # noqa: A001 (chainsweep.open)
    path: PathLike, histories: bool | str = False, damaged: str = "raise"
) -> xr.Dataset:
    try:
        for _ in range(_READ_ATTEMPTS):
            try:
                return _open_file(path, histories, damaged)
            except _Replaced:
                continue
        fspath = os.fspath(path)
        raise DamagedFileError(
            fspath,
            f"{fspath} was published again while it was read, {_READ_ATTEMPTS} times: a sweep "
            "is checkpointing it; open it again, or after the sweep",
            [],
        )
    except Error:
        raise
    except (OSError, RuntimeError, KeyError, ValueError, TypeError, IndexError) as e:
        # What the engine's check found whole but HDF5 then cannot read (a damaged object
        # header, attribute heap or chunk index): damage, said as such, never a bare error.
        fspath = os.fspath(path)
        raise DamagedFileError(
            fspath, f"{fspath} cannot be read back: {e}. " + _REPAIR.format(path=fspath), []
        ) from e
    finally:
        _READING.damage = None


def _open_file(
    path: PathLike, histories: bool | str = False, damaged: str = "raise"
) -> xr.Dataset:
    """Opens a sweep's result file (made by :func:`chainsweep.sweep` or ``chainsweep run``).

    Returns an ``xarray.Dataset`` read into memory (the file is closed again) whose dimensions are
    the grid's axes, outermost first, with their values and units as coordinates — a zipped group
    of axes is one dimension and every field of the group is a coordinate on it that indexes it
    (``ds.sel(velocity_m_s=1.3)``, ``ds.sel(cylinders=60)``) — and ``probe`` (the probe names;
    ``probe_units`` on it).
    Every summary of the file is a variable over the grid (and ``probe``) with its ``units`` and
    ``long_name``: peaks and times, ledger errors, counters (``steps``, … as float64 with NaN where
    a run failed or is pending, the file's fill value masked), ``status`` (0 pending, 1 ok,
    2 failed), ``reason``, ``warnings``, ``run_hash`` (empty where pending), and the verification columns
    (``verified``, ``verify_rel_error_*``). Pending and failed points hold NaN. The file's root
    attributes (the sweep, the base scene, versions, counts) are the Dataset's ``attrs``.
    Where the probes measure in different units (a force and a velocity), the peaks and maxima are
    also there once per unit, as the file stores them (``leading_peak_N``,
    ``leading_peak_m_per_s``: each in its one unit, NaN at the probes of the others); then
    ``leading_peak`` and ``record_max`` (and ``history``) have no ``units``: each probe's is its
    ``probe_units``.
    ``min_overlap_m`` over (grid…, ``contact``) is there when the sweep recorded it.
    The steady state (``record.steady_state``), when the sweep recorded it: ``steady_frequency_hz``
    over the grid, ``steady_mean``, ``steady_rms``, ``steady_settledness``, ``steady_settled`` and
    ``steady_transmission_db`` over (grid…, ``probe``), ``steady_amplitude`` and
    ``steady_phase_rad`` over (grid…, ``probe``, ``harmonic``).

    Space–time fields (``record.fields``) are read with the histories (``histories=True`` or
    ``"lazy"``): ``field_contact_force`` over (grid…, ``field_time_s``, ``contact``),
    ``field_displacement`` and ``field_velocity`` over (grid…, ``field_time_s``, ``particle``),
    NaN after a run's end and beyond its contacts or particles, and ``field_samples`` (how many
    instants each run recorded).

    With ``histories=True``, every run's history is read into ``history`` over (grid…,
    ``probe``, ``time_s``), NaN where a run failed, is pending or stopped earlier. When the runs
    were sampled at different instants (the history interval an axis), the last dimension is
    ``sample`` and ``time_s`` a coordinate over (grid…, ``sample``).

    With ``histories="lazy"`` (dask installed: else :class:`InputError` says so, rather than
    read a multi-gigabyte file into memory), ``history`` is the same variable as a dask
    array read from the file only when computed, in blocks of runs along the grid's last axis
    (about 8 MB each, whole chunks of the file): a reduction over every history
    (``ds.history.max("time_s")``) holds a few blocks at a time, not the file. Each block opens
    the file anew and raises when the file was replaced since it was checked. (With files of
    layout 4 and earlier, a group per run: do not compute it while iterating an h5py group, ``for
    g in f["runs"].values()``, whose lock the threads that read the blocks wait for.)

    The file of a sweep with a ``periodic`` block (branches of periodic orbits) is read as it is
    stored: over the axes and ``branch_point``, the continued field (a coordinate named as the
    block names it), ``point_kind``, ``stability``, ``largest_multiplier``, the multipliers (over
    ``multiplier``), the orbit's state (over ``particle``) and each probe's ``orbit_amplitude``,
    ``orbit_phase_rad`` (over ``harmonic``), ``orbit_mean``, ``orbit_rms``, ``orbit_max``,
    ``orbit_settledness``; over the axes ``branch_status``, ``branch_points``, ``branch_end``
    (docs/PERIODIC.md). Every chunk is checked (Fletcher-32) as it is read: a damaged one raises
    :class:`DamagedFileError` whatever ``damaged`` says (``chainsweep run`` writes the file again
    from its journals).

    Every value is first checked against the checksums the file stores (histories too with
    ``histories=True``; the minimum overlaps and the energy flow, which share the histories'
    checksum, always where the file holds no histories or fields). A damaged point raises :class:`DamagedFileError`, naming each damaged
    point by its index and axis values; with ``damaged="mask"`` the intact points are served and
    the damaged ones masked (NaN, empty strings, ``status`` pending), with a boolean ``damaged``
    variable saying which. A file whose header or coordinates are damaged always raises. Files of
    earlier versions carry no checksums and are served as they stand.
    """
    # Absolute: a lazy block reopens the file long after, wherever the working directory is then.
    fspath = os.path.abspath(os.fspath(path))
    path = fspath
    if histories not in (True, False, "lazy"):
        raise InputError("histories", f'must be True, False or "lazy", got {histories!r}')
    if _is_periodic(fspath):
        return _open_periodic(fspath)
    # The minimum overlaps and the energy flow, read whatever `histories` says, share the runs'
    # arrays' checksum: it is checked for them too where that reads no histories or fields (a
    # few numbers per run; checking them beside histories would read every history).
    try:
        with h5py.File(fspath, "r") as f:
            names = set(f)
    except Exception:  # noqa: BLE001 (unreadable: the engine's check says what is wrong)
        names = set()
    heavy = {"history", "history_N", "history_m", "history_m_per_s", *_FIELD_NAMES}
    small_arrays = bool(names & {"min_overlap_m", *L.ENERGY_FLOW}) and not names & heavy
    # The file as checked: a sweep publishing it again while it is read (its checkpoints) would
    # otherwise give summaries of one version and lazy histories of the next.
    try:
        identity = _identity(fspath)
    except OSError:
        identity = None
    points, unreadable = _check(fspath, bool(histories) or small_arrays, damaged)
    unchecked = fspath if points else None
    _READING.damage = None
    with h5py.File(path, "r") as f:
        if "dimensions" not in f.attrs or "grid_shape" not in f.attrs:
            raise InputError(
                "path", f"{os.fspath(path)} is not a chainsweep result file (no grid attributes)"
            )
        grid = _Grid(f)
        _READING.damage = _ChunkDamage(grid.shape)
        data: dict[str, Any] = {}
        # Coordinates that are no dimension's scale (a search's fields over its evaluations).
        auxiliary: set[str] = set()
        arrays = _has_arrays(f)
        for name, obj in f.items():
            if not isinstance(obj, h5py.Dataset) or name in grid.coords or _dimension_only(obj):
                continue
            if arrays and name in _ARRAY_NAMES:  # read below, as asked
                continue
            dims = grid.dims_of(obj)
            if dims is None:
                continue
            auxiliary.update(_value(obj.attrs.get("coordinates", "")).split())
            values, attrs = _read(obj, unchecked)
            data[name] = (dims, values, attrs)
        coords: dict[str, Any] = dict(grid.coords)
        for name in auxiliary & set(data):
            coords[name] = data.pop(name)
        extras = [_stack_min_overlaps(f, grid), _stack_energy_flow(f, grid)]
        lazy = histories == "lazy" and ("runs" in f or arrays)
        if lazy and not _has_dask():
            raise InputError(
                "histories",
                '"lazy" needs dask, which is not installed (pip install dask, or the extra: '
                "pip install 'chainsweep[xarray]'); without it the histories would be read into "
                f"memory whole ({_array_bytes(f) / 1e6:.0f} MB in this file): pass histories=True "
                "to read them so",
            )
        if histories and not lazy:
            extras.append(_stack_histories(f, grid))
            extras.append(_stack_fields(f, grid))
        for extra in extras:
            if extra is not None:
                data.update(extra[0])
                coords.update(extra[1])
        attrs = _attrs(f)
    if identity is not None and _identity(fspath) != identity:
        raise _Replaced()
    if lazy:
        # (After the file is closed: HDF5 frees what it read of the run groups only then.)
        extras.append(_lazy_histories(fspath, grid, {i for i, _, _ in points}, identity))
        extras.append(_lazy_fields(fspath, grid, {i for i, _, _ in points}, identity))
    for extra in extras[-2:] if lazy else []:
        if extra is not None:
            data.update(extra[0])
            coords.update(extra[1])
    for name, why, per_probe in unreadable:
        # A dataset HDF5 cannot read at all: every point of it masked (they are damaged), never
        # left out.
        harmonic = per_probe and L.COLUMNS.get(name, {}).get("per_harmonic", False)
        dims = (*grid.dims, "probe") if per_probe else tuple(grid.dims)
        shape = (*grid.shape, len(grid.probes)) if per_probe else grid.shape
        if harmonic:
            dims, shape = (*dims, "harmonic"), (*shape, grid.harmonics)
        data[name] = (dims, np.full(shape, np.nan), {"long_name": f"unreadable: {why}"})
    _join_units(data, grid)
    noted, _READING.damage = _READING.damage, None
    known = {i for i, _, _ in points}
    # A chunk that fails its checksum spans several points: those with values in it are damaged,
    # not a failed or pending point beside them, which has none there (its status and reason are
    # intact).
    status = np.ravel(data["status"][1]) if "status" in data else None
    holds = (lambda i: status is None or status[i] not in (L.STATUS_PENDING, L.STATUS_FAILED))
    found = [(i, grid.label(i), why) for i, why in sorted(noted.points.items())
             if i not in known and holds(i)]
    if found:
        if damaged == "raise":
            listed = "; ".join(f"point {i} ({label}): {why}" for i, label, why in found[:_LISTED_DAMAGE])
            more = f" and {len(found) - _LISTED_DAMAGE} more" if len(found) > _LISTED_DAMAGE else ""
            raise DamagedFileError(
                fspath,
                f"{fspath}: {len(found)} point(s) hold values that cannot be read back: {listed}{more}. "
                + _REPAIR.format(path=fspath),
                found,
            )
        points = [*points, *found]
    if points:
        _mask(data, grid, points)
    data = {name: data[name] for name in L.ordered(data)}
    ds = xr.Dataset(data, coords=coords, attrs=attrs)
    # Every field of a zipped dimension indexes it (the one named like the dimension already
    # does), so that `.sel` takes any of them.
    for names in grid.coord_order.values():
        for name in names:
            if name not in ds.indexes:
                ds = ds.set_xindex(name)
    return ds


open.__doc__ = _open_file.__doc__
