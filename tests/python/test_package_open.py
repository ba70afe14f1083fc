"""chainsweep.open: every summary of a result file labelled by the grid's axes and the probes,
values bitwise those h5py reads; zipped axes; histories stacked over (grid…, probe, time) with
NaN where a run failed or is pending; partial files; the Dataset written and read back by xarray."""

from __future__ import annotations

import json
import subprocess
import sys
import os
import shutil

import h5py
import numpy as np
import pytest
import xarray as xr

import chainsweep
from chainsweep.errors import DamagedFileError, InputError
from conftest import run as cli
from conftest import texts
from scenes import sweep_spec, write

FLOATS = ["t_end_s", "energy_drift_max", "energy_drift_final", "momentum_residual_max",
          "impact_energy_j", "wall_time_s", "max_overlap_m", "verify_rel_error_max"]
PROBE_FLOATS = ["leading_peak", "leading_peak_time_s", "record_max", "record_max_time_s",
                "verify_rel_error_leading_peak", "verify_rel_error_leading_peak_time",
                "verify_rel_error_record_max"]
COUNTERS = ["steps", "rejected_steps", "rhs_evals", "events"]
STRINGS = ["reason", "warnings", "run_hash"]


def failing(history: bool = True) -> dict:
    """3 mass ratios x rtol 1e-9, 1e-5: the rtol 1e-5 runs drift by ~1e-4, over the limit 1e-6."""
    spec = sweep_spec(history=history)
    spec["record"]["min_overlap"] = history
    spec["axes"][1] = {"field": "integrator.rtol", "values": [1e-9, 1e-5]}
    spec["limits"] = {"energy_drift_max": 1e-6}
    return spec


@pytest.fixture(scope="module")
def files(tmp_path_factory, binary):
    """Result files made by the binary: complete with histories and verification; summaries
    only; with failed runs; one shard of two (half the points pending)."""
    d = tmp_path_factory.mktemp("open")
    out = {}
    full = sweep_spec(history=True)
    full["record"]["min_overlap"] = True
    full["record"]["probes"].append({"kind": "velocity", "particle": 5})
    for name, spec, extra in [
        ("full", full, ["--verify", "0.5"]),
        ("summaries", sweep_spec(), []),
        ("failed", failing(), []),
        ("shard", sweep_spec(history=True), ["--shard", "1/2"]),
    ]:
        path = write(d / f"{name}.json", spec)
        out[name] = d / f"{name}.h5"
        r = cli("run", path, "-o", out[name], "--quiet", *extra)
        assert r.returncode in (0, 3), r.stderr
    return out


def test_every_summary_labelled_and_equal_to_h5py(files):
    ds = chainsweep.open(files["full"])
    assert ds.leading_peak.dims == ("mass_ratio", "damping_kg_s", "probe")
    assert ds.steps.dims == ("mass_ratio", "damping_kg_s")
    assert list(ds.mass_ratio.values) == [0.3, 0.55, 1.0]
    assert list(ds.damping_kg_s.values) == [0, 6]
    assert ds.damping_kg_s.attrs["units"] == "kg/s" and ds.mass_ratio.attrs["units"] == "1"
    assert ds.damping_kg_s.attrs["field"] == "physics.damping_kg_s"
    assert list(ds.probe.values) == ["gauge_force_cyl2", "gauge_force_cyl8", "velocity_p5"]
    assert list(ds.probe_units.values) == ["N", "N", "m/s"]
    # N and m/s: no one unit for the peaks and maxima; the file stores them once per unit
    assert "units" not in ds.leading_peak.attrs and "probe_units" in ds.leading_peak.attrs["comment"]
    assert ds.leading_peak_N.attrs["units"] == "N" and ds.leading_peak_m_per_s.attrs["units"] == "m/s"
    with h5py.File(files["full"], "r") as f:
        for name in FLOATS + PROBE_FLOATS:
            if name in ("leading_peak", "record_max"):
                n, ms = f[f"{name}_N"][()], f[f"{name}_m_per_s"][()]
                joined = np.where(np.array(["N", "N", "m/s"]) == "N", n, ms)
                assert ds[name].values.tobytes() == joined.tobytes(), name
                for part in (f"{name}_N", f"{name}_m_per_s"):
                    assert ds[part].values.tobytes() == f[part][()].tobytes(), part
                    assert ds[part].attrs["units"] == f[part].attrs["units"], part
                continue
            assert ds[name].values.tobytes() == f[name][()].tobytes(), name
            assert ds[name].attrs["units"] == f[name].attrs["units"], name
        for name in COUNTERS:
            assert ds[name].dtype == np.float64
            assert np.array_equal(ds[name].values, f[name][()].astype(float)), name
            assert "fill_value" not in ds[name].attrs and "_FillValue" not in ds[name].attrs
        for name in ds.data_vars:
            # the file's netCDF bookkeeping is not data: xarray would refuse to write it back
            assert not {"_FillValue", "coordinates"} & set(ds[name].attrs), name
        for name in STRINGS:
            assert list(ds[name].values.ravel()) == list(texts(f[name]).ravel()), name
        assert ds.status.values.tobytes() == f["status"][()].tobytes()
        assert ds.status.attrs["flag_meanings"] == "pending ok failed unsettled"
        assert ds.verified.values.tobytes() == f["verified"][()].tobytes()
        assert int((ds.verified == 1).sum()) == 3
        for k, v in f.attrs.items():
            if k not in ("grid_shape",):
                assert ds.attrs[k] == (v.decode() if isinstance(v, bytes) else v), k
    # labelled selection: F8/F2 at μ = 6 against the mass ratio
    ratio = ds.leading_peak.sel(probe="gauge_force_cyl8") / ds.leading_peak.sel(probe="gauge_force_cyl2")
    assert ratio.sel(damping_kg_s=6).dims == ("mass_ratio",)
    assert json.loads(ds.attrs["dimensions"]) == ["mass_ratio", "damping_kg_s"]


def test_lazy_histories_read_nothing_until_computed_and_equal_the_stacked_ones(files, tmp_path):
    """histories="lazy": a dask array over the same variable, read block by block when computed."""
    eager = chainsweep.open(files["full"], histories=True)
    lazy = chainsweep.open(files["full"], histories="lazy")
    assert lazy.history.chunks is not None  # dask: nothing read yet
    assert lazy.history.dims == eager.history.dims
    assert lazy.history.attrs == eager.history.attrs
    assert lazy.time_s.values.tobytes() == eager.time_s.values.tobytes()
    assert lazy.history.values.tobytes() == eager.history.values.tobytes()
    assert lazy.history.max("time_s").values.tobytes() == eager.history.max("time_s").values.tobytes()
    # A block raises rather than serve a file published again since it was checked.
    copy = tmp_path / "copy.h5"
    shutil.copyfile(files["full"], copy)
    ds = chainsweep.open(copy, histories="lazy")
    shutil.copyfile(files["full"], tmp_path / "next.h5")
    os.replace(tmp_path / "next.h5", copy)
    with pytest.raises(DamagedFileError, match="was replaced"):
        ds.history.values
    with pytest.raises(InputError):
        chainsweep.open(files["full"], histories="yes")
    # Opened by a relative path, read after the working directory changed: the same file
    # (the blocks reopened the path as given, and found none, or another).
    here = os.getcwd()
    try:
        os.chdir(tmp_path)
        ds = chainsweep.open("copy.h5", histories="lazy")
        elsewhere = tmp_path / "elsewhere"
        elsewhere.mkdir()
        shutil.copyfile(files["full"], elsewhere / "copy.h5")
        os.chdir(elsewhere)
        assert ds.history.values.tobytes() == eager.history.values.tobytes()
    finally:
        os.chdir(here)


WITHOUT_DASK = """
import sys
# An interpreter where dask is not installed: `import dask` raises, find_spec finds nothing.
sys.modules["dask"] = sys.modules["dask.array"] = None
import chainsweep
try:
    chainsweep.open(sys.argv[1], histories="lazy")
except chainsweep.InputError as e:
    print(e.field, "|", e, flush=True)
    sys.exit(0)
print("served", flush=True)
sys.exit(1)
"""


def test_lazy_histories_without_dask_name_the_package_and_read_nothing(files):
    """Without dask, histories="lazy" raises naming it and the extra that brings it, with the
    memory a whole read would take, rather than read every history into memory unasked."""
    r = subprocess.run([sys.executable, "-c", WITHOUT_DASK, str(files["full"])],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stdout + r.stderr
    field, message = r.stdout.split(" | ", 1)
    assert field == "histories"
    assert "needs dask" in message and "chainsweep[xarray]" in message and " MB " in message


def test_units_of_run_and_open_agree(files):
    """chainsweep.run labels with the package's table; the files carry the runner's own."""
    ds = chainsweep.open(files["full"])
    spec = sweep_spec(history=True)
    scene = dict(spec["base"], record=spec["record"])
    scene["record"]["min_overlap"] = True
    scene["record"]["probes"].append({"kind": "velocity", "particle": 5})
    one = chainsweep.run(scene)
    shared = set(one.data_vars) & set(ds.data_vars)
    assert shared >= set(FLOATS[:-1] + PROBE_FLOATS[:4] + COUNTERS + STRINGS + ["status"])
    for name in shared:
        for key in ("units", "long_name", "flag_meanings"):
            assert one[name].attrs.get(key) == ds[name].attrs.get(key), (name, key)


def test_histories_stacked_over_the_grid(files):
    ds = chainsweep.open(files["full"], histories=True)
    h = ds.history
    assert h.dims == ("mass_ratio", "damping_kg_s", "probe", "time_s")
    assert "units" not in h.attrs and ds.time_s.attrs["units"] == "s"
    with h5py.File(files["full"], "r") as f:
        # the file's one time axis; its histories one variable per unit (N and m/s here)
        assert ds.time_s.values.tobytes() == f["time_s"][()].tobytes()
        units = list(ds.probe_units.values)
        for k, u in enumerate(units):
            stored = f[chainsweep._layout.split_name("history", u)][:, :, k, :]
            assert h.values[:, :, k, :].tobytes() == stored.tobytes(), u
        assert ds.min_overlap_m.values.tobytes() == f["min_overlap_m"][()].tobytes()
        assert ds.history_samples.values.tolist() == f["history_samples"][()].tolist()
    assert ds.min_overlap_m.dims == ("mass_ratio", "damping_kg_s", "contact")
    assert list(ds.contact.values) == list(range(1, 23))
    # physics through the labels: the pulse reaches cylinder 8 after cylinder 2
    f2 = h.sel(probe="gauge_force_cyl2", mass_ratio=0.55, damping_kg_s=0)
    f8 = h.sel(probe="gauge_force_cyl8", mass_ratio=0.55, damping_kg_s=0)
    assert f8.idxmax("time_s") > f2.idxmax("time_s")
    # without histories: no history, no error
    assert "history" not in chainsweep.open(files["full"])
    assert "history" not in chainsweep.open(files["summaries"], histories=True)
    assert "contact" not in chainsweep.open(files["summaries"]).dims


def test_failed_runs_are_nan_with_their_reason(files):
    ds = chainsweep.open(files["failed"], histories=True)
    failed = ds.status == 2
    assert list(ds.rtol.values) == [1e-9, 1e-5]
    assert bool((ds.status.sel(rtol=1e-5) == 2).all()) and bool((ds.status.sel(rtol=1e-9) == 1).all())
    for name in FLOATS[:-1] + ["steps", "rhs_evals"]:
        if name != "wall_time_s":
            assert bool(ds[name].where(failed).isnull().all()), name
            assert bool(ds[name].where(~failed).notnull().sum() == 3), name
    assert bool(ds.wall_time_s.notnull().all())
    assert all("exceeds the limit" in r for r in ds.reason.sel(rtol=1e-5).values)
    assert all(r == "" for r in ds.reason.sel(rtol=1e-9).values)
    assert bool(ds.history.sel(rtol=1e-5).isnull().all())
    assert bool(ds.history.sel(rtol=1e-9).isel(time_s=0).notnull().all())
    assert bool(ds.min_overlap_m.sel(rtol=1e-5).isnull().all())
    assert bool(ds.min_overlap_m.sel(rtol=1e-9).notnull().all())


def test_pending_points_of_a_shard_are_nan(files):
    ds = chainsweep.open(files["shard"], histories=True)
    assert ds.attrs["shard"] == "1/2"
    pending = (ds.status == 0).values
    # The engine's balanced assignment gives each of the two shards half the points.
    assert pending.sum() == 3
    assert np.isnan(ds.leading_peak.values[pending]).all()
    assert np.isnan(ds.steps.values[pending]).all()
    assert not np.isnan(ds.steps.values[~pending]).any()
    assert np.isnan(ds.history.values[pending]).all()
    assert not np.isnan(ds.history.values[~pending][..., 0]).any()


def test_zipped_axes_are_one_dimension(tmp_path, binary):
    spec = sweep_spec()
    spec["record"]["stop_after_leading_pulses"] = True
    spec["axes"] = [
        {"zip": [
            {"field": "striker_velocity_m_s", "name": "velocity_m_s", "values": [1.06, 1.3, 1.45]},
            {"field": "chain.cylinders", "values": [10, 12, 14]},
        ]},
        {"field": "physics.damping_kg_s", "values": [0, 6]},
    ]
    for name in (None, "impact"):
        if name:
            spec["axes"][0]["name"] = name
        path = write(tmp_path / f"zip-{name}.json", spec)
        out = tmp_path / f"zip-{name}.h5"
        assert cli("run", path, "-o", out, "--quiet").returncode == 0
        ds = chainsweep.open(out, histories=True)
        dim = name or "velocity_m_s"
        assert ds.leading_peak.dims == (dim, "damping_kg_s", "probe")
        assert ds.cylinders.dims == (dim,) and ds.velocity_m_s.dims == (dim,)
        assert ds.velocity_m_s.attrs["units"] == "m/s" and ds.cylinders.attrs["units"] == "1"
        point = ds.sel(velocity_m_s=1.3, damping_kg_s=6)
        assert point.cylinders.item() == 12
        assert point.steps.item() > 0
        # every zipped field indexes the dimension
        assert {"velocity_m_s", "cylinders"} <= set(ds.indexes)
        by_length = ds.sel(cylinders=12, damping_kg_s=6)
        assert by_length.velocity_m_s.item() == 1.3
        assert by_length.leading_peak.values.tobytes() == point.leading_peak.values.tobytes()
        assert dim not in ds.data_vars
        # a faster striker makes a larger pulse, whatever the chain length
        lp = ds.leading_peak.sel(probe="gauge_force_cyl2", damping_kg_s=0)
        assert bool((lp.diff(dim) > 0).all())


def test_a_zipped_dimension_of_its_own_name_is_no_variable(tmp_path, binary):
    """A one-dimensional grid whose zipped group has a name of its own: the file's dimension-only
    dataset of that name has the grid's shape, and is still no variable."""
    spec = sweep_spec()
    spec["record"]["stop_after_leading_pulses"] = True
    spec["axes"] = [{"name": "impact", "zip": [
        {"field": "striker_velocity_m_s", "name": "velocity_m_s", "values": [1.06, 1.3]},
        {"field": "chain.cylinders", "values": [10, 12]},
    ]}]
    path = write(tmp_path / "zip1.json", spec)
    out = tmp_path / "zip1.h5"
    assert cli("run", path, "-o", out, "--quiet").returncode == 0
    ds = chainsweep.open(out)
    assert "impact" not in ds.variables and ds.steps.dims == ("impact",)
    assert ds.sel(cylinders=12).velocity_m_s.item() == 1.3


def test_histories_of_different_instants_get_a_sample_dimension(tmp_path, binary):
    spec = sweep_spec(history=True)
    spec["axes"] = [{"field": "record.history_interval_s", "values": [1e-6, 2e-6]}]
    path = write(tmp_path / "h.json", spec)
    out = tmp_path / "h.h5"
    assert cli("run", path, "-o", out, "--quiet").returncode == 0
    ds = chainsweep.open(out, histories=True)
    assert ds.history.dims == ("history_interval_s", "probe", "sample")
    assert ds.time_s.dims == ("history_interval_s", "sample")
    t = ds.time_s.values
    assert np.isnan(t[1]).sum() == 100 and t[1, 100] == pytest.approx(2e-4)
    assert t[0, -1] == pytest.approx(2e-4)


def test_written_and_read_back_by_xarray(files, tmp_path):
    ds = chainsweep.open(files["failed"], histories=True)
    path = tmp_path / "copy.nc"
    ds.to_netcdf(path, engine="h5netcdf")
    back = xr.open_dataset(path, engine="h5netcdf").load()
    xr.testing.assert_identical(ds.drop_vars(STRINGS), back.drop_vars(STRINGS))
    for name in STRINGS:
        assert list(back[name].values.ravel()) == list(ds[name].values.ravel())


def test_a_file_chainsweep_did_not_make_is_refused(tmp_path):
    path = tmp_path / "other.h5"
    with h5py.File(path, "w") as f:
        f["x"] = np.arange(3)
    with pytest.raises(chainsweep.InputError) as e:
        chainsweep.open(path)
    assert e.value.field == "path" and "not a chainsweep result file" in str(e.value)
