"""`chainsweep.plot(ds)`: the figures of `chainsweep report`, drawn with matplotlib from a dataset
that `chainsweep.open` (or xarray) read: every summary against the grid's axes (a line per curve
for one axis, a line per value of the outer axis when it has ten or fewer, a heatmap otherwise,
small multiples beyond two axes), points without a number marked; an ensemble's histograms and
Sobol' indices or Morris's measures; a search's evaluations; a fit's data (±σ) against its best
fit with the normalised residuals, and each field's profile χ²; branches of periodic orbits,
stable solid and unstable dashed, with their special points."""

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


def _searched_fields(ds) -> list[str]:
    """The coordinates a search evaluated (over `evaluation`, besides the axes)."""
    return [str(c) for c, v in ds.coords.items()
            if "evaluation" in v.dims and c != "evaluation" and v.dtype.kind == "f"]


def _search(plt, ds) -> list[Any]:
    """The objective at every evaluation against each searched field, a series per point of the
    outer axes (at most ten)."""
    figs = []
    obj = ds["objective"]
    outer = [d for d in obj.dims if d != "evaluation"]
    points = [{}]
    for d in outer:
        points = [dict(p, **{d: i}) for p in points for i in range(obj.sizes[d])]
    for field in _searched_fields(ds):
        fig, ax = plt.subplots(figsize=(6.4, 3.8), layout="constrained")
        for p in points[:10]:
            x = ds[field].isel(p).values if p else ds[field].values
            y = obj.isel(p).values if p else obj.values
            label = ", ".join(f"{d} = {ds[d].values[i]}" for d, i in p.items()) or "evaluations"
            ax.plot(x, y, "o", ms=4, alpha=0.8, label=label)
        _log_x(ax, ds[field].values.ravel())
        if len(points) > 1:
            ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)
        ax.set_xlabel(_axis_label(ds, field))
        ax.set_ylabel(_axis_label(ds, "objective"))
        ax.set_title(f"objective at each evaluation against {field}", fontsize=10)
        figs.append(fig)
    return figs


def _fit(plt, ds) -> list[Any]:
    """A fit's data (±σ) against its best fit, with the normalised residuals below; each fitted
    field's profile χ² with its intervals."""
    figs = []
    stems = sorted(n[: -len("_data")] for n in ds.data_vars
                   if n.endswith("_data") and f"{n[: -len('_data')]}_model" in ds)
    for stem in stems:
        data, model = ds[f"{stem}_data"], ds[f"{stem}_model"]
        if data.ndim != 1:
            continue
        dim = data.dims[0]
        names = ds.get(f"{dim}_name") if stem == "scalar" else None
        x = np.arange(data.size) if names is not None or dim not in ds.coords else ds[dim].values
        # A recorded signal's own time, in ms (its instants are a few ms at most).
        in_time = names is None and str(dim).endswith("_time_s")
        if in_time:
            x = x * 1e3
        fig, (ax, axr) = plt.subplots(2, 1, figsize=(6.4, 4.8), sharex=True, height_ratios=[3, 1],
                                      layout="constrained")
        sigma = ds[f"{stem}_sigma"].values if f"{stem}_sigma" in ds else None
        if sigma is not None and not np.isfinite(sigma).any():
            sigma = None
        ax.errorbar(x, data.values, yerr=sigma, fmt="o", ms=3, color="k", lw=0.8, label="measured (±σ)")
        ax.plot(x, model.values, "-" if names is None else "s", color="C3", ms=5, label="best fit")
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)
        units = data.attrs.get("units")
        if names is not None:
            # Measured scalars, each in its own unit (a ratio in 1, a peak in N).
            per = {str(u) for u in np.ravel(ds[f"{dim}_units"].values)} if f"{dim}_units" in ds else set()
            units = per.pop() if len(per) == 1 else None
        what = "measured value" if names is not None else stem.replace("_", " ")
        ax.set_ylabel(f"{what} [{units}]" if units not in (None, "") else what)
        resid = ds.get(f"{stem}_normalised_residual")
        if resid is not None:
            axr.axhline(0.0, color="0.5", lw=0.8)
            axr.plot(x, resid.values, "o", ms=3, color="C0")
            axr.set_ylabel("residual / σ")
        if names is not None:
            axr.set_xticks(x, [str(n) for n in np.ravel(names.values)], rotation=30, ha="right", fontsize=8)
            axr.set_xlabel("measured scalar")
        elif in_time:
            axr.set_xlabel("time of the recording [ms]")
        else:
            axr.set_xlabel(_axis_label(ds, dim))
        ax.set_title(f"{'measured scalars' if names is not None else stem.replace('_', ' ')}: measured and the best fit",
                     fontsize=10)
        figs.append(fig)
    if "fit_field_name" in ds:
        for name in (str(n) for n in np.ravel(ds["fit_field_name"].values)):
            value, chi2 = f"fit_{name}_profile_value", f"fit_{name}_profile_chi_square"
            if value not in ds or chi2 not in ds:
                continue
            v, c = ds[value].values, ds[chi2].values
            order = np.argsort(v)
            fig, ax = plt.subplots(figsize=(6.4, 3.6), layout="constrained")
            ax.plot(v[order], c[order] - float(ds["fit_chi_square"]), "o-", ms=3, label="profile")
            for end, style in (("profile_lower", "-"), ("profile_upper", "-"), ("lower", ":"), ("upper", ":")):
                if f"fit_{name}_{end}" in ds:
                    ax.axvline(float(ds[f"fit_{name}_{end}"]), color="C3", ls=style, lw=0.9)
            ax.axvline(float(np.ravel(ds[f"fit_{name}"].values)[0]), color="k", lw=0.9)
            units = ds[value].attrs.get("units")
            ax.set_xlabel(f"{name} [{units}]" if units not in (None, "") else name)
            ax.set_ylabel("χ² − its minimum")
            ax.set_title(f"{name}: profile χ², 95 % intervals (solid: profile, dotted: linearised)", fontsize=10)
            figs.append(fig)
    return figs


def _branches(plt, ds) -> list[Any]:
    """Each probe's fundamental amplitude along the branches against the continued field, stable
    solid, unstable dashed, special points marked; a panel per point of the axes (at most six)."""
    figs = []
    field = ds.attrs.get("periodic_field", "")
    xname = next((str(c) for c, v in ds.coords.items() if v.attrs.get("field") == field
                  and "branch_point" in v.dims), None)
    if xname is None or "orbit_amplitude" not in ds:
        return figs
    amp = ds["orbit_amplitude"].isel(harmonic=0)
    outer = [d for d in ds[xname].dims if d != "branch_point"]
    points = [{}]
    for d in outer:
        points = [dict(p, **{d: i}) for p in points for i in range(ds.sizes[d])]
    meanings = str(ds["point_kind"].attrs.get("flag_meanings", "")).split()
    for k in range(min(ds.sizes.get("probe", 1), _MAX_PROBES)):
        fig, ax = plt.subplots(figsize=(6.8, 4.0), layout="constrained")
        for j, p in enumerate(points[:_MAX_PANELS]):
            n = int(ds["branch_points"].isel(p).values) if "branch_points" in ds else ds.sizes["branch_point"]
            x = ds[xname].isel(p).values[:n]
            y = amp.isel(p).isel(probe=k).values[:n] if "probe" in amp.dims else amp.isel(p).values[:n]
            stable = ds["stability"].isel(p).values[:n] == 1
            label = ", ".join(f"{d} = {ds[d].values[i]:g}" for d, i in p.items()) or "branch"
            color = f"C{j}"
            ax.plot(np.where(stable, x, np.nan), np.where(stable, y, np.nan), "-", color=color, label=label)
            ax.plot(np.where(~stable, x, np.nan), np.where(~stable, y, np.nan), "--", color=color)
            kinds = ds["point_kind"].isel(p).values[:n]
            special = kinds >= 4
            ax.plot(x[special], y[special], "o", ms=5, mfc="none", color=color)
            for i in np.flatnonzero(special):
                if kinds[i] < len(meanings):
                    ax.annotate(meanings[kinds[i]].replace("_", " "), (x[i], y[i]), fontsize=7,
                                xytext=(3, 3), textcoords="offset points")
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False,
                  title="solid: stable, dashed: unstable", title_fontsize=8)
        probe = str(ds["probe"].values[k]) if "probe" in ds.coords else "orbit"
        units = str(np.ravel(ds["probe_units"].values)[k]) if "probe_units" in ds else ""
        ax.set_xlabel(_axis_label(ds, xname))
        ax.set_ylabel(f"fundamental amplitude [{units}]" if units else "fundamental amplitude")
        ax.set_title(f"branches of periodic orbits at {probe}", fontsize=10)
        figs.append(fig)
    return figs


def plot(ds, variables: list[str] | None = None, runs: bool = False) -> list[Any]:
    """The report's figures of `ds` (a dataset from `chainsweep.open` or xarray), one matplotlib
    figure each, returned in order: every summary (or the `variables` named) against the axes,
    per probe (at most eight); an ensemble's histograms and sensitivities; a search's evaluations
    and a fit's data, best fit, residuals and profiles; branches of periodic orbits. `runs=True`
    draws the run diagnostics (wall time, verified error, energy drift) instead of the results."""
    import matplotlib.pyplot as plt

    if "branch_point" in ds.dims:
        return _branches(plt, ds)
    if "evaluation" in ds.dims and "objective" in ds and variables is None and not runs:
        return _search(plt, ds) + _fit(plt, ds)
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
