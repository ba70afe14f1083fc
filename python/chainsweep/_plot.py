"""`chainsweep.plot(ds)`: the figures of `chainsweep report`, drawn with matplotlib from a dataset
that `chainsweep.open` (or xarray) read: every summary against the grid's axes (a line per curve
for one axis, a line per value of the outer axis when it has ten or fewer, a heatmap otherwise,
small multiples beyond two axes), points without a number marked; an ensemble's histograms and
Sobol' indices or Morris's measures."""

from __future__ import annotations

from typing import Any

import numpy as np

# Columns about how a run went rather than what it found (the report's "Runs").
_RUN_COLUMNS = {"wall_time_s", "verify_rel_error_max", "energy_drift_max", "energy_drift_final",
                "momentum_residual_max", "t_end_s"}
_SKIP_PREFIXES = ("verify_rel_error_", "ledger_", "history", "field_", "fit_", "summary_checksum")
_MAX_PANELS = 6
_MAX_PROBES = 8


_UNIT_SUFFIXES = ("_kg_s", "_m_s", "_n_m", "_hz", "_rad", "_kg", "_s", "_m", "_n", "_j")


def _label(da) -> str:
    """A variable's short name and unit (`leading peak time [s]`): its long_name is a sentence."""
    name = str(da.name)
    for suffix in _UNIT_SUFFIXES:
        if name.endswith(suffix) and len(name) > len(suffix):
            name = name[: -len(suffix)]
            break
    units = da.attrs.get("units")
    name = name.replace("_", " ")
    return f"{name} [{units}]" if units not in (None, "") else name


def _axis_label(ds, dim: str) -> str:
    """An axis's label: its long_name (a short human name for axes) and unit."""
    if dim in ds.coords:
        c = ds[dim]
        name = c.attrs.get("long_name") or str(dim)
        units = c.attrs.get("units")
        return f"{name} [{units}]" if units not in (None, "") else name
    return dim


def _log_x(ax, x) -> None:
    x = np.asarray(x, dtype=float) if np.issubdtype(np.asarray(x).dtype, np.number) else None
    if x is not None and x.size and np.all(x > 0) and x.max() / x.min() > 30:
        ax.set_xscale("log")


def _mark_missing(ax, x, y) -> None:
    """Points without a number: red crosses along the bottom."""
    y = np.asarray(y, dtype=float)
    bad = ~np.isfinite(y)
    if bad.any():
        floor = np.nanmin(y) if np.isfinite(y).any() else 0.0
        ax.plot(np.asarray(x)[bad], np.full(bad.sum(), floor), "x", color="C3", ms=7,
                label="no number (failed or pending)")


def _grid_dims(ds) -> tuple[str, ...]:
    if "status" in ds:
        return tuple(ds["status"].dims)
    raise ValueError("not a chainsweep dataset: it has no `status` variable over its grid")


def _summaries(ds, grid: tuple[str, ...], runs: bool) -> list[str]:
    out = []
    for name, da in ds.data_vars.items():
        if da.dtype.kind != "f" or name.startswith(_SKIP_PREFIXES):
            continue
        extra = [d for d in da.dims if d not in grid]
        if tuple(d for d in da.dims if d in grid) != grid or any(d != "probe" for d in extra):
            continue
        if (name in _RUN_COLUMNS) != runs:
            continue
        if not np.isfinite(da.values).any():
            continue
        out.append(name)
    return out


def _draw(plt, ds, da, grid: tuple[str, ...], what: str, failed) -> list[Any]:
    figs = []
    dims = [d for d in grid if d != "member"]
    if len(dims) == 0:
        return figs
    if len(dims) == 1:
        d = dims[0]
        fig, ax = plt.subplots(figsize=(6, 3.8), layout="constrained")
        x = ds[d].values if d in ds.coords else np.arange(da.sizes[d])
        y = da.values
        ax.plot(x, y, "o-", ms=3)
        _mark_missing(ax, x, y)
        if not np.isfinite(y).all():
            ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)
        _log_x(ax, x)
        ax.set_xlabel(_axis_label(ds, d))
        ax.set_ylabel(_label(da))
        ax.set_title(what, fontsize=10)
        figs.append(fig)
        return figs
    dy, dx = dims[-2], dims[-1]
    outer = dims[:-2]
    panels = [{}]
    for d in outer:
        panels = [dict(p, **{d: i}) for p in panels for i in range(da.sizes[d])]
    for p in panels[:_MAX_PANELS]:
        sub = da.isel(p) if p else da
        title = what if not p else what + " at " + ", ".join(f"{d}={ds[d].values[i]}" for d, i in p.items())
        fig, ax = plt.subplots(figsize=(6.8, 3.8), layout="constrained")
        xv = ds[dx].values if dx in ds.coords else np.arange(da.sizes[dx])
        if sub.sizes[dy] <= 10:
            for i in range(sub.sizes[dy]):
                yv = ds[dy].values[i] if dy in ds.coords else i
                ax.plot(xv, sub.isel({dy: i}).transpose(dx).values, "o-", ms=3, label=f"{dy} = {yv}")
            _mark_missing(ax, np.tile(xv, sub.sizes[dy]), sub.transpose(dy, dx).values.ravel())
            _log_x(ax, xv)
            # Outside the data, right of the axes.
            ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)
            ax.set_ylabel(_label(da))
        else:
            z = sub.transpose(dy, dx).values
            m = ax.pcolormesh(np.arange(len(xv)), np.arange(sub.sizes[dy]), np.ma.masked_invalid(z),
                              shading="nearest", cmap="viridis")
            fig.colorbar(m, ax=ax, label=_label(da))
            yv = ds[dy].values if dy in ds.coords else np.arange(sub.sizes[dy])
            step_x, step_y = max(1, len(xv) // 6), max(1, len(yv) // 6)
            ax.set_xticks(np.arange(len(xv))[::step_x], [f"{v:.4g}" if np.issubdtype(type(v), np.number) else str(v) for v in xv[::step_x]])
            ax.set_yticks(np.arange(len(yv))[::step_y], [f"{v:.4g}" if np.issubdtype(type(v), np.number) else str(v) for v in yv[::step_y]])
            ax.set_ylabel(_axis_label(ds, dy))
        ax.set_xlabel(_axis_label(ds, dx))
        ax.set_title(title, fontsize=10)
        figs.append(fig)
    return figs


def _ensemble(plt, ds) -> list[Any]:
    figs = []
    stats = sorted({n[: -len("_histogram")] for n in ds.data_vars if n.endswith("_histogram")})
    for s in stats:
        fig, ax = plt.subplots(figsize=(6, 3.8), layout="constrained")
        frac = ds[f"{s}_histogram"]
        lo, hi = ds[f"{s}_bin_lower"].values, ds[f"{s}_bin_upper"].values
        first = {d: 0 for d in frac.dims if d != f"{s}_bin"}
        f = frac.isel(first).values
        w = hi - lo
        ax.bar(lo, f / w, width=w, align="edge", alpha=0.7, label="samples")
        err = np.vstack([f - ds[f"{s}_histogram_lower"].isel(first).values,
                         ds[f"{s}_histogram_upper"].isel(first).values - f]) / w
        ax.errorbar(0.5 * (lo + hi), f / w, yerr=err, fmt="none", ecolor="k", lw=0.8)
        q = ds[f"{s}_quantile"].isel(first)
        for j, p in enumerate(ds["quantile"].values):
            ax.axvline(float(q[j]), color="C3", lw=1)
        units = ds[f"{s}_mean"].attrs.get("units", "")
        ax.set_xlabel(f"{s} [{units}]")
        ax.set_ylabel("probability density")
        ax.set_title(f"{s}: distribution, quantiles {', '.join(f'{p:g}' for p in ds['quantile'].values)}", fontsize=10)
        figs.append(fig)
        for kind in ("first_order", "total", "mu_star"):
            v = f"{s}_{kind}"
            if v not in ds:
                continue
            val = ds[v].isel({d: 0 for d in ds[v].dims if d != "input"})
            lo_ = ds[f"{v}_lower"].isel({d: 0 for d in ds[v].dims if d != "input"})
            hi_ = ds[f"{v}_upper"].isel({d: 0 for d in ds[v].dims if d != "input"})
            names = [str(n) for n in ds["input_name"].values]
            fig, ax = plt.subplots(figsize=(6, 3.2), layout="constrained")
            y = np.arange(len(names))
            ax.barh(y, val.values, xerr=np.vstack([val.values - lo_.values, hi_.values - val.values]), capsize=3)
            ax.set_yticks(y, names)
            ax.set_ylabel("input")
            ax.set_xlabel(f"{kind.replace('_', ' ')} of {s}")
            ax.set_title(f"{s}: {kind.replace('_', ' ')} (95 % intervals)", fontsize=10)
            figs.append(fig)
    return figs


def plot(ds, variables: list[str] | None = None, runs: bool = False) -> list[Any]:
    """The report's figures of `ds` (a dataset from `chainsweep.open` or xarray), one matplotlib
    figure each, returned in order: every summary (or the `variables` named) against the axes,
    per probe (at most eight); an ensemble's histograms and sensitivities. `runs=True` draws the
    run diagnostics (wall time, verified error, energy drift) instead of the results."""
    import matplotlib.pyplot as plt

    grid = _grid_dims(ds)
    figs: list[Any] = []
    if "member" in grid:
        return _ensemble(plt, ds)
    failed = ds["status"].values == 2 if "status" in ds else None
    names = variables if variables is not None else _summaries(ds, grid, runs)
    for name in names:
        da = ds[name]
        if "probe" in da.dims:
            for k in range(min(da.sizes["probe"], _MAX_PROBES)):
                probe = str(ds["probe"].values[k])
                sub = da.isel(probe=k, drop=True)
                sub.attrs = dict(da.attrs)
                # A column in its probe's unit (a force in N) takes it from `probe_units`; one
                # with its own (a time in s) keeps it.
                if "units" not in da.attrs and "probe_units" in ds:
                    sub.attrs["units"] = str(np.ravel(ds["probe_units"].values)[k])
                figs += _draw(plt, ds, sub, grid, f"{name} at {probe}", failed)
        else:
            figs += _draw(plt, ds, da, grid, name, failed)
    return figs
