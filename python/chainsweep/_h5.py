"""The HDF5 basics of reading a sweep's file with h5py: text, attributes, fill values, the grid's
dimensions and coordinates (LAYOUT, as docs/REFERENCE.md describes it), shared by
:func:`chainsweep.open` (``_open``) and :func:`chainsweep.sweep` (``_sweep``).
"""

from __future__ import annotations

import json
import os
from typing import Any

import h5py
import numpy as np

from . import _chainsweep as _native
from .errors import DamagedFileError

# How many damaged points a DamagedFileError's message lists (`.damaged` holds them all).
_LISTED_DAMAGE = 10

_REPAIR = (
    "`chainsweep run SWEEP -o {path}` (the sweep that made it) repairs it: runs restored from the "
    "snapshot in its work directory are kept, the others computed again; "
    "chainsweep.open(path, damaged=\"mask\") serves the intact points, the damaged ones masked"
)

# HDF5 bookkeeping attributes (dimension scales, netCDF-4 markers): not data.
_INTERNAL_ATTRS = {
    "DIMENSION_LIST",
    "REFERENCE_LIST",
    "CLASS",
    "NAME",
    "DIMENSION_LABELS",
    "_Netcdf4Dimid",
    "_Netcdf4Coordinates",
    "_nc3_strict",
    "_Encoding",
    "coordinates",
}

# LAYOUT: attributes that hold the fill value of a dataset (`_FillValue` is the netCDF convention,
# used from layout version 2; `fill_value` marks the integer ones in files of layout version 1).
_FILL_ATTRS = ("_FillValue", "fill_value")

# LAYOUT: the NAME of a dimension scale that is a netCDF dimension without a variable.
_DIMENSION_ONLY = b"This is a netCDF dimension but not a netCDF variable."

PathLike = str | os.PathLike[str]


def _value(v: Any) -> Any:
    if isinstance(v, bytes):
        return v.decode("utf-8", "replace")
    if isinstance(v, np.ndarray) and v.dtype.kind in "OS":
        return np.array([_value(x) for x in v.ravel()], dtype=object).reshape(v.shape)
    if isinstance(v, np.generic):
        return v.item()
    return v


def _attrs(obj: h5py.HLObject) -> dict[str, Any]:
    return {k: _value(v) for k, v in obj.attrs.items() if k not in _INTERNAL_ATTRS}


def _is_char(ds: h5py.Dataset) -> bool:
    """LAYOUT: whether a dataset holds text as netCDF `char`s (one-byte strings, the characters
    along its last dimension)."""
    return ds.ndim >= 1 and ds.dtype == np.dtype("S1")


def _chars(values: np.ndarray) -> np.ndarray:
    """LAYOUT: the texts of a `char` array (UTF-8 bytes along the last dimension, NUL-padded) as
    `str`, over the other dimensions."""
    n = values.shape[-1]
    rows = np.ascontiguousarray(values).view(f"S{n}").reshape(values.shape[:-1])
    texts = [t.decode("utf-8", "replace") for t in rows.ravel()]
    return np.array(texts, dtype=object).reshape(rows.shape)


def _read(ds: h5py.Dataset, path: str | None = None) -> tuple[np.ndarray, dict[str, Any]]:
    """A dataset's values and attributes: text as `str`, booleans as `bool`, integer fills masked
    to NaN. With `path` (the file's, when damaged points are to be masked), a dataset whose chunk
    HDF5's Fletcher-32 check refuses is read without the check: its damaged points are masked
    after."""
    attrs = _attrs(ds)
    if h5py.check_string_dtype(ds.dtype) is not None and not _is_char(ds):
        return np.asarray(ds.asstr()[()], dtype=object), attrs
    try:
        values = np.asarray(ds[()])  # an array also for a scalar dataset
    except OSError:
        if path is None:
            raise
        data, dtype, shape = _native.read_unchecked(path, ds.name.lstrip("/"))
        values = np.frombuffer(data, dtype=np.dtype(dtype).newbyteorder("<")).reshape(shape)
    if _is_char(ds):
        return _chars(values), attrs
    if attrs.get("dtype") == "bool":  # LAYOUT: a boolean axis (bytes 0 and 1)
        del attrs["dtype"]
        return values.astype(bool), attrs
    fills = [attrs.pop(a) for a in _FILL_ATTRS if a in attrs]
    fill = fills[0] if fills else None
    if fill is not None and values.dtype.kind in "iu":
        masked = values.astype(np.float64)
        masked[values == fill] = np.nan
        return masked, attrs
    return values, attrs


def _dimension_only(ds: h5py.Dataset) -> bool:
    """LAYOUT: whether a dataset is a netCDF dimension without a variable (no data)."""
    name = ds.attrs.get("NAME")
    return isinstance(name, bytes | np.bytes_) and bytes(name).startswith(_DIMENSION_ONLY)


def _labels(values: np.ndarray) -> np.ndarray:
    """Coordinate values: strings as numpy `str` (as pandas indexes and `.sel` like them)."""
    return values.astype(str) if values.dtype == object else values


class _Grid:
    """LAYOUT: the grid of a file: dimension names and shape, coordinates, probes."""

    def __init__(self, f: h5py.File):
        self.dims: list[str] = list(json.loads(_value(f.attrs["dimensions"])))
        self.shape: tuple[int, ...] = tuple(int(n) for n in f.attrs["grid_shape"])
        self.coords: dict[str, tuple[str, np.ndarray, dict[str, Any]]] = {}
        self.coord_order: dict[str, list[str]] = {d: [] for d in self.dims}
        for name, obj in f.items():
            if isinstance(obj, h5py.Dataset) and "dimension" in obj.attrs:
                dim = _value(obj.attrs["dimension"])
                values, attrs = _read(obj)
                self.coords[name] = (dim, _labels(values), attrs)
                self.coord_order.setdefault(dim, []).append(name)
        self.probes: list[str] = [str(p) for p in _read(f["probe"])[0]] if "probe" in f else []
        if self.probes:
            values, attrs = _read(f["probe"])
            self.coords["probe"] = ("probe", _labels(values), attrs)
            units, uattrs = _read(f["probe_units"])
            self.coords["probe_units"] = ("probe", _labels(units), uattrs)
        self.probe_units: list[str] = (
            [str(u) for u in self.coords["probe_units"][1]] if self.probes else []
        )
        # The steady state's harmonics (record.steady_state), a coordinate of its amplitudes and
        # phases over (grid…, probe, harmonic).
        self.harmonics = 0
        if "harmonic" in f:
            values, attrs = _read(f["harmonic"])
            self.coords["harmonic"] = ("harmonic", values, attrs)
            self.harmonics = len(values)

    def label(self, i: int) -> str:
        """Point `i` (flat, row-major) by its coordinates' values, `name=value` each."""
        at = np.unravel_index(i, self.shape) if self.shape else ()
        parts = []
        for d, k in zip(self.dims, at):
            for name in self.coord_order.get(d, []):
                parts.append(f"{name}={_value(self.coords[name][1][k])}")
        return " ".join(parts)

    def dims_of(self, ds: h5py.Dataset) -> tuple[str, ...] | None:
        """The dimensions of a dataset, its text's characters left out: the names of the
        dimension scales attached to it (a search's tables span some of the grid's dimensions),
        else by its shape (None: not grid-shaped)."""
        ndim = ds.ndim - 1 if _is_char(ds) else ds.ndim
        shape = ds.shape[:ndim]
        if ndim == 0:  # a search's outcome when the sweep has no axes besides the search
            return ()
        names = tuple(_scale_name(d) for d in ds.dims)[:ndim]
        known = {*self.coord_order, "probe", "harmonic"}
        if len(names) == ndim and all(n in known for n in names):
            return names
        if shape == self.shape:
            return tuple(self.dims)
        if self.probes and shape == (*self.shape, len(self.probes)):
            return (*self.dims, "probe")
        if self.harmonics and shape == (*self.shape, len(self.probes), self.harmonics):
            return (*self.dims, "probe", "harmonic")
        return None


def _scale_name(dim: Any) -> str | None:
    """LAYOUT: the dimension a dataset's dimension is, as netCDF names it: after the dataset of
    the last dimension scale attached to it (None: none attached, or HDF5 cannot follow the
    attachment: the dimension is then told by the dataset's shape)."""
    try:
        if not len(dim):
            return None
        name = dim[len(dim) - 1].name
    except (RuntimeError, OSError, ValueError, KeyError):  # a damaged DIMENSION_LIST
        return None
    if not isinstance(name, str):  # (a damaged reference: to no object with a name)
        return None
    return name.rsplit("/", 1)[-1].removeprefix("_nc4_non_coord_")
