"""Result files as xarray reads them, through both netCDF-4 readers (h5netcdf and netCDF4, i.e.
netCDF-C), and as `ncdump -h` shows them: dimensions named as the file records them (zipped ones
too, with every zipped field a coordinate on its dimension), failed and pending runs masked by
`_FillValue`, history groups with valid names. Plain grids, zipped axes (named after their first
field or with a name of their own), histories and failed runs, all from the real binary."""

import json
import shutil
import subprocess

import h5py
import numpy as np
import pytest
import xarray as xr

import chainsweep

from conftest import assert_files_equal, base_sweep, run, to_layout_4, write_sweep

ENGINES = ["h5netcdf", "netcdf4"]
COUNTERS = ["steps", "rejected_steps", "rhs_evals", "events"]
FLOATS = ["t_end_s", "energy_drift_max", "energy_drift_final", "momentum_residual_max",
          "impact_energy_j", "max_overlap_m"]
PROBE_FLOATS = ["leading_peak", "leading_peak_time_s", "record_max", "record_max_time_s"]


def failing_grid():
    """3 mass ratios x rtol 1e-9, 1e-5, histories and minimum overlaps: the rtol 1e-5 runs drift
    by ~1e-4 of the impact energy, over the limit 1e-6, and fail."""
    s = base_sweep(history=True)
    s["record"]["min_overlap"] = True
    s["axes"] = [
        {"field": "chain.cylinder.mass.heavy_cylinders.mass_ratio", "values": [0.3, 0.55, 1.0]},
        {"field": "integrator.rtol", "values": [1e-9, 1e-5]},
    ]
    s["limits"] = {"energy_drift_max": 1e-6}
    return s


def zipped(name=None):
    """Striker velocity and chain length zipped (one dimension), against damping."""
    s = base_sweep()
    s["record"]["stop_after_leading_pulses"] = True
    group = {"zip": [
        {"field": "striker_velocity_m_s", "name": "velocity_m_s", "values": [1.06, 1.3, 1.45]},
        {"field": "chain.cylinders", "values": [10, 12, 14]},
    ]}
    if name:
        group["name"] = name
    s["axes"] = [group, {"field": "physics.damping_kg_s", "values": [0, 6]}]
    return s


@pytest.fixture(scope="module")
def files(tmp_path_factory, binary):
    d = tmp_path_factory.mktemp("xarray")
    out = {}
    for name, spec, extra, rc in [
        ("failed", failing_grid(), [], 3),
        ("zip", zipped(), [], 0),
        ("zip-named", zipped("impact"), [], 0),
        ("zip-shard", zipped(), ["--shard", "1/2"], 0),
    ]:
        path = write_sweep(d / f"{name}.json", spec)
        out[name] = d / f"{name}.h5"
        r = run("run", path, "-o", out[name], "--quiet", *extra)
        assert r.returncode == rc, r.stderr
    return out


def open_ds(path, engine, **kw):
    return xr.open_dataset(path, engine=engine, **kw).load()


@pytest.mark.parametrize("engine", ENGINES)
def test_plain_grid_is_labelled(files, engine):
    ds = open_ds(files["failed"], engine)
    # (and the runs' arrays': their time axis and contacts)
    assert dict(ds.sizes) == {"mass_ratio": 3, "rtol": 2, "probe": 2, "time_s": 201, "contact": 22}
    assert set(ds.indexes) == {"mass_ratio", "rtol", "probe", "time_s", "contact"}
    assert set(ds.coords) == {"mass_ratio", "rtol", "probe", "probe_units", "time_s", "contact"}
    assert ds.leading_peak.dims == ("mass_ratio", "rtol", "probe")
    assert ds.steps.dims == ds.status.dims == ds.reason.dims == ("mass_ratio", "rtol")
    assert list(ds.mass_ratio.values) == [0.3, 0.55, 1.0] and list(ds.rtol.values) == [1e-9, 1e-5]
    assert list(ds.probe.values) == ["gauge_force_cyl2", "gauge_force_cyl8"]
    assert ds.probe_units.dims == ("probe",) and list(ds.probe_units.values) == ["N", "N"]
    assert ds.mass_ratio.attrs["units"] == "1" and ds.leading_peak.attrs["units"] == "N"
    # An axis is labelled in words (a plot's label), its field kept beside.
    assert ds.mass_ratio.attrs["long_name"] == "mass ratio"
    assert ds.mass_ratio.attrs["field"] == "chain.cylinder.mass.heavy_cylinders.mass_ratio"
    assert json.loads(ds.attrs["dimensions"]) == ["mass_ratio", "rtol"]
    with h5py.File(files["failed"], "r") as f:
        for name in FLOATS + PROBE_FLOATS:
            assert ds[name].values.tobytes() == f[name][()].tobytes(), name
    # the pulse reaches cylinder 8 later than cylinder 2
    t = ds.leading_peak_time_s.sel(mass_ratio=0.55, rtol=1e-9)
    assert t.sel(probe="gauge_force_cyl8") > t.sel(probe="gauge_force_cyl2")


@pytest.mark.parametrize("engine", ENGINES)
def test_failed_runs_are_masked(files, engine):
    ds = open_ds(files["failed"], engine)
    failed = (ds.status == 2).values
    assert failed.tolist() == [[False, True]] * 3
    assert all("exceeds the limit" in r for r in ds.reason.values[failed])
    for name in COUNTERS:
        # -1 in the file, NaN through `_FillValue`
        assert ds[name].dtype == np.float64 and ds[name].encoding["_FillValue"] == -1, name
        assert np.isnan(ds[name].values[failed]).all(), name
        assert (ds[name].values[~failed] >= 0).all(), name
    assert (ds.steps.values[~failed] > 0).all()
    for name in FLOATS + PROBE_FLOATS:
        assert np.isnan(ds[name].values[failed]).all(), name
    for name in FLOATS:
        assert np.isfinite(ds[name].values[~failed]).all(), name
    # (a probe may see no pulse in a successful run: NaN there is a value, not a failure)
    assert np.isfinite(ds.leading_peak.sel(probe="gauge_force_cyl2").values[~failed]).all()
    assert np.isfinite(ds.wall_time_s.values).all()  # measured for failed runs too
    # masking is by value: the raw file holds -1 where xarray shows NaN
    raw = xr.open_dataset(files["failed"], engine=engine, mask_and_scale=False).load()
    assert (raw.steps.values[failed] == -1).all() and raw.steps.dtype == np.int64
    # flags are not masked: every point has a status
    assert ds.status.dtype == np.uint8


@pytest.mark.parametrize("engine", ENGINES)
def test_pending_points_are_masked(files, engine):
    ds = open_ds(files["zip-shard"], engine)
    pending = (ds.status == 0).values
    # shard 1 of 2 holds half of the 3 × 2 grid (the balanced assignment decides which half)
    assert pending.sum() == 3
    for name in COUNTERS + FLOATS + PROBE_FLOATS:
        assert np.isnan(ds[name].values[pending]).all(), name
    for name in COUNTERS + FLOATS:
        assert not np.isnan(ds[name].values[~pending]).any(), name
    assert not np.isnan(ds.leading_peak.sel(probe="gauge_force_cyl2").values[~pending]).any()


@pytest.mark.parametrize("engine", ENGINES)
def test_zipped_dimension_named_as_recorded(files, engine):
    ds = open_ds(files["zip"], engine)
    assert json.loads(ds.attrs["dimensions"]) == ["velocity_m_s", "damping_kg_s"]
    assert dict(ds.sizes) == {"velocity_m_s": 3, "damping_kg_s": 2, "probe": 2}
    assert ds.leading_peak.dims == ("velocity_m_s", "damping_kg_s", "probe")
    # every zipped field a coordinate on the dimension; the one named like it indexes it
    assert ds.cylinders.dims == ("velocity_m_s",) and "cylinders" in ds.coords
    assert "cylinders" not in ds.data_vars and "cylinders" not in ds.indexes
    assert list(ds.cylinders.values) == [10, 12, 14] and ds.cylinders.attrs["units"] == "1"
    assert ds.velocity_m_s.attrs["units"] == "m/s"
    point = ds.sel(velocity_m_s=1.3, damping_kg_s=6)
    assert point.cylinders.item() == 12 and point.steps.item() > 0
    # `.sel` by the other zipped field once it is an index too: the same point
    by_length = ds.set_xindex("cylinders").sel(cylinders=12, damping_kg_s=6)
    assert by_length.velocity_m_s.item() == 1.3
    assert by_length.leading_peak.values.tobytes() == point.leading_peak.values.tobytes()
    # a faster striker makes a larger pulse
    lp = ds.leading_peak.sel(probe="gauge_force_cyl2", damping_kg_s=0)
    assert bool((lp.diff("velocity_m_s") > 0).all())


@pytest.mark.parametrize("engine", ENGINES)
def test_zipped_dimension_with_a_name_of_its_own(files, engine):
    ds = open_ds(files["zip-named"], engine)
    assert json.loads(ds.attrs["dimensions"]) == ["impact", "damping_kg_s"]
    assert dict(ds.sizes) == {"impact": 3, "damping_kg_s": 2, "probe": 2}
    assert ds.steps.dims == ("impact", "damping_kg_s")
    # a dimension without a variable: no `impact` variable, both fields coordinates on it
    assert "impact" not in ds.variables
    assert ds.velocity_m_s.dims == ds.cylinders.dims == ("impact",)
    assert {"velocity_m_s", "cylinders"} <= set(ds.coords)
    zipped_ref = open_ds(files["zip"], engine)
    indexed = ds.set_xindex("velocity_m_s").set_xindex("cylinders")
    for field, value in [("velocity_m_s", 1.45), ("cylinders", 14)]:
        p = indexed.sel({field: value, "damping_kg_s": 0})
        assert (p.velocity_m_s.item(), p.cylinders.item()) == (1.45, 14), field
        # the same runs as the file whose dimension is named after the velocity
        ref = zipped_ref.sel(velocity_m_s=1.45, damping_kg_s=0)
        assert p.leading_peak.values.tobytes() == ref.leading_peak.values.tobytes(), field


@pytest.mark.parametrize("engine", ENGINES)
def test_history_arrays(files, engine):
    """The histories as one variable over (grid, probe, time_s), lazily with chunks={}: NaN for
    the failed runs; the time axis stored once; minimum overlaps over (grid, contact)."""
    path = files["failed"]
    with h5py.File(path, "r") as f:
        status = f["status"][()]
        assert "runs" not in f
    ok = status == 1
    ds = xr.open_dataset(path, engine=engine, chunks={})
    h = ds["history"]
    assert h.chunks is not None  # lazy (dask)
    assert h.dims == (*ds.status.dims, "probe", "time_s") and h.attrs["units"] == "N"
    assert list(h.probe.values) == ["gauge_force_cyl2", "gauge_force_cyl8"]
    assert ds.time_s.attrs["units"] == "s" and ds.time_s.dims == ("time_s",)
    values = h.values
    assert np.isnan(values[~ok]).all()
    assert ds.history_samples.values[ok].min() > 0
    for i in zip(*np.nonzero(ok)):
        m = int(ds.history_samples.values[i])
        run = values[i]
        assert np.isfinite(run[:, :m]).all() and np.isnan(run[:, m:]).all()
        # the pulse reaches cylinder 8 after cylinder 2
        assert run[1, :m].argmax() > run[0, :m].argmax()
    mo = ds.min_overlap_m
    assert mo.dims == (*ds.status.dims, "contact") and mo.attrs["units"] == "m"
    assert list(ds.contact.values) == list(range(1, ds.sizes["contact"] + 1))
    assert np.isfinite(mo.values[ok]).all() and np.isnan(mo.values[~ok]).all()
    # chainsweep.open gives the same, eagerly and lazily
    for how in (True, "lazy"):
        c = chainsweep.open(path, histories=how)
        assert c.history.values.tobytes() == values.tobytes(), how
        assert c.min_overlap_m.values.tobytes() == mo.values.tobytes(), how


def ncdump(path):
    exe = shutil.which("ncdump")
    assert exe, "ncdump not found: `make test` installs it (Debian package netcdf-bin)"
    r = subprocess.run([exe, "-h", str(path)], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    return r.stdout


def test_ncdump_zipped(files):
    out = ncdump(files["zip"])
    dims = out.split("dimensions:", 1)[1].split("variables:", 1)[0]
    lines = [line.strip() for line in dims.strip().splitlines()]
    # (and the dimensions of the texts' characters: `char` arrays)
    assert sorted(x for x in lines if "_strlen" not in x) == [
        "damping_kg_s = 2 ;", "probe = 2 ;", "velocity_m_s = 3 ;"]
    assert "run_hash_strlen = 64 ;" in lines and "\tchar run_hash(velocity_m_s, damping_kg_s, run_hash_strlen) ;" in out
    assert "\tint64 cylinders(velocity_m_s) ;" in out
    assert "\tdouble velocity_m_s(velocity_m_s) ;" in out
    assert "\tdouble leading_peak(velocity_m_s, damping_kg_s, probe) ;" in out
    assert 'leading_peak:coordinates = "cylinders probe probe_units" ;' in out
    assert 'steps:coordinates = "cylinders" ;' in out
    assert "steps:_FillValue = -1LL ;" in out and "leading_peak:_FillValue = NaN ;" in out
    named = ncdump(files["zip-named"])
    assert "\timpact = 3 ;" in named and "cylinders(impact)" in named
    assert "velocity_m_s(impact)" in named and "double impact(" not in named


def test_ncdump_history_arrays(files):
    out = ncdump(files["failed"])
    assert "group:" not in out
    assert "\tdouble history(" in out and ", probe, time_s) ;" in out
    assert "\tdouble time_s(time_s) ;" in out and "\tint64 history_samples(" in out
    assert "\tdouble min_overlap_m(" in out and ", contact) ;" in out
    assert "history:_FillValue = NaN ;" in out


def test_an_old_layout_resumes_into_the_new_one(tmp_path, binary):
    """A file of layout version 1 (run groups `runs/<padded flat index>`, no `layout_version`)
    is rewritten in the current layout when its sweep resumes: the file is assembled from the
    work directory's stored runs, never read."""
    path = write_sweep(tmp_path / "s.json", failing_grid())
    out = tmp_path / "s.h5"
    assert run("run", path, "-o", out, "--quiet").returncode == 3
    fresh = tmp_path / "fresh.h5"
    assert run("run", path, "-o", fresh, "--quiet").returncode == 3
    to_layout_4(out)
    to_layout_1(out)
    # the old file is read as it stands
    old = chainsweep.open(out, histories=True)
    new = chainsweep.open(fresh, histories=True)
    assert old.history.values.tobytes() == new.history.values.tobytes()
    r = run("run", path, "-o", out)
    assert r.returncode == 3 and "6 of 6 runs already done" in r.stderr, r.stderr
    with h5py.File(out, "r") as f:
        assert int(f.attrs["layout_version"]) == 6 and "runs" not in f
    assert_files_equal(fresh, out)


def to_layout_1(path):
    """Rewrites a file's run groups as layout version 1 names them."""
    with h5py.File(path, "r+") as f:
        n = int(np.prod(f.attrs["grid_shape"]))
        width = len(str(n - 1))
        for name in list(f["runs"]):
            i = int(f["runs"][name].attrs["flat_index"])
            f["runs"].move(name, f"{i:0{width}d}")
        del f.attrs["layout_version"]


def test_shards_of_the_old_layout_merge(tmp_path, binary):
    """`merge` reads shards of layout version 1 (their run groups by the old names) and of the
    current one alike; the merged file is the single run's, in the current layout."""
    path = write_sweep(tmp_path / "s.json", failing_grid())
    single = tmp_path / "single.h5"
    assert run("run", path, "-o", single, "--quiet").returncode == 3
    parts = []
    for k in (1, 2):
        part = tmp_path / f"part-{k}.h5"
        assert run("run", path, "--shard", f"{k}/2", "-o", part, "--quiet").returncode in (0, 3)
        parts.append(part)
    to_layout_4(parts[0])
    to_layout_1(parts[0])
    with h5py.File(parts[0], "r") as f:
        names = sorted(f["runs"])
        assert names and all(name.isdigit() for name in names)
        assert [int(f["runs"][name].attrs["flat_index"]) for name in names] == [
            int(name) for name in names
        ]
    merged = tmp_path / "merged.h5"
    r = run("merge", "-o", merged, *parts)
    assert r.returncode == 3, r.stderr
    assert_files_equal(single, merged)


def test_a_newer_layout_is_refused(tmp_path, binary):
    path = write_sweep(tmp_path / "s.json", zipped())
    out = tmp_path / "s.h5"
    assert run("run", path, "-o", out, "--quiet").returncode == 0
    with h5py.File(out, "r+") as f:
        f.attrs["layout_version"] = np.int64(7)
    r = run("status", out)
    assert r.returncode != 0
    assert "layout version 7" in r.stderr + r.stdout and "newer chainsweep" in r.stderr + r.stdout
