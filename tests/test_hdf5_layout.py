"""The HDF5 file as h5py users see it: names, shapes, dtypes, `str` attributes, dimension scales,
histories, failed runs — and values equal to what the Rust side computes for each point."""

import json
import math

import h5py
import numpy as np
import pytest

from conftest import base_sweep, run, texts, write_sweep

SUMMARY_GRID = [
    "t_end_s",
    "energy_drift_max",
    "energy_drift_final",
    "momentum_residual_max",
    "impact_energy_j",
    "wall_time_s",
    "max_overlap_m",
]
INT_GRID = ["steps", "rejected_steps", "rhs_evals", "events"]
# The linear spectrum's columns (record.spectrum): only in files of sweeps that record it.
SPECTRUM_GRID = [
    "lowest_frequency_hz",
    "highest_frequency_hz",
    "gap_lower_hz",
    "gap_upper_hz",
    "band_top_hz",
]
PROBE_GRID = ["leading_peak", "leading_peak_time_s", "record_max", "record_max_time_s"]
# The layout's probes measure in N (two gauges) and m/s (a velocity): the peaks and maxima are
# stored once per unit (a variable has one unit), each NaN at the probes of the other.
UNITS = ["N", "N", "m/s"]
SPLIT = {"leading_peak": ["leading_peak_N", "leading_peak_m_per_s"],
         "record_max": ["record_max_N", "record_max_m_per_s"]}
PROBE_STORED = [n for name in PROBE_GRID for n in SPLIT.get(name, [name])]
TEXT = ["reason", "warnings", "run_hash"]


def probe_values(f, name):
    """Per-probe column `name` over every probe, from the datasets of each unit where split."""
    if name not in SPLIT:
        return f[name][...]
    n, ms = (f[part][...] for part in SPLIT[name])
    return np.where(np.array(UNITS) == "N", n, ms)
# Numerics version 2: verification by `run --verify` (NaN / 0 when not requested).
# Numerics version 8: the record maximum's time, the largest overlap and (with histories) the
# energy flow too.
VERIFY_GRID = ["verify_rel_error_max", "verify_rel_error_max_overlap", "verify_rel_error_energy_flow"]
VERIFY_PROBE_GRID = [
    "verify_rel_error_leading_peak",
    "verify_rel_error_leading_peak_time",
    "verify_rel_error_record_max",
    "verify_rel_error_record_max_time",
]


@pytest.fixture(scope="module")
def produced(tmp_path_factory, binary):
    d = tmp_path_factory.mktemp("layout")
    sweep = base_sweep(history=True)
    sweep["record"]["probes"].append({"kind": "velocity", "particle": 5})
    sweep["record"]["min_overlap"] = True
    path = write_sweep(d / "layout.json", sweep)
    out = d / "layout.h5"
    r = run("run", path, "-o", out, "--jobs", "2")
    assert r.returncode == 0, r.stderr
    return sweep, path, out


def test_root_attributes_are_str(produced):
    sweep, path, out = produced
    with h5py.File(out, "r") as f:
        for name in [
            "sweep",
            "description",
            "base_scene",
            "engine",
            "engine_version",
            "solver_version",
            "git_revision",
            "created_utc",
            "command_line",
            "shard",
            "dimensions",
        ]:
            assert isinstance(f.attrs[name], str), name
        assert json.loads(f.attrs["sweep"]) == sweep
        assert f.attrs["sweep"] == path.read_text()
        assert json.loads(f.attrs["dimensions"]) == ["mass_ratio", "damping_kg_s"]
        assert f.attrs["shard"] == "1/1"
        assert f.attrs["created_utc"].endswith("Z")
        assert "run" in f.attrs["command_line"]
        assert int(f.attrs["numerics_version"]) >= 1
        assert list(f.attrs["grid_shape"]) == [3, 2]
        assert int(f.attrs["n_ok"]) == 6 and int(f.attrs["n_failed"]) == 0
        base = json.loads(f.attrs["base_scene"])
        assert base["chain"]["cylinders"] == 10


def test_names_shapes_dtypes(produced):
    _, _, out = produced
    with h5py.File(out, "r") as f:
        assert not set(SPECTRUM_GRID) & set(f)  # not recorded: not on disk
        expected = set(SUMMARY_GRID + INT_GRID + PROBE_STORED + VERIFY_GRID + VERIFY_PROBE_GRID) | {
            "leading_pulse",
            "warnings",
            "verified",
            "mass_ratio",
            "damping_kg_s",
            "probe",
            "probe_units",
            "status",
            "reason",
            "run_hash",
            # the runs' arrays: histories (one per unit), their time axis and lengths, minimum
            # overlaps on their contacts
            "history_N",
            "history_m_per_s",
            "history_samples",
            "time_s",
            "min_overlap_m",
            "contact",
            "summary_checksum",
            "history_checksum",
            # the dimensions of the texts' characters (netCDF `char`)
            "reason_strlen",
            "warnings_strlen",
            "run_hash_strlen",
            "probe_strlen",
            "probe_units_strlen",
        }
        assert set(f.keys()) == expected
        assert f.attrs["Conventions"] == "CF-1.8"
        assert f["mass_ratio"].shape == (3,) and f["mass_ratio"].dtype == np.float64
        assert f["damping_kg_s"].shape == (2,) and f["damping_kg_s"].dtype == np.int64
        np.testing.assert_array_equal(f["mass_ratio"][:], [0.3, 0.55, 1.0])
        np.testing.assert_array_equal(f["damping_kg_s"][:], [0, 6])
        assert f["damping_kg_s"].attrs["units"] == "kg/s"
        assert f["mass_ratio"].attrs["units"] == "1"
        assert f["mass_ratio"].attrs["field"] == "chain.cylinder.mass.heavy_cylinders.mass_ratio"
        assert list(texts(f["probe"])) == ["gauge_force_cyl2", "gauge_force_cyl8", "velocity_p5"]
        assert list(texts(f["probe_units"])) == UNITS
        for name in SUMMARY_GRID:
            assert f[name].shape == (3, 2) and f[name].dtype == np.float64, name
            assert isinstance(f[name].attrs["units"], str)
        for name in INT_GRID:
            assert f[name].shape == (3, 2) and f[name].dtype == np.int64, name
        # the missing-value marker, netCDF's way: HDF5 fill value and `_FillValue` of the
        # dataset's own type (-1 in counts, NaN in floats); flags and text have none
        for name in INT_GRID:
            fill = f[name].attrs["_FillValue"]
            assert fill == -1 and fill.dtype == np.int64 and f[name].fillvalue == -1, name
            assert "fill_value" not in f[name].attrs
        for name in SUMMARY_GRID + PROBE_STORED + VERIFY_GRID + VERIFY_PROBE_GRID:
            fill = f[name].attrs["_FillValue"]
            assert np.isnan(fill) and fill.dtype == np.float64 and np.isnan(f[name].fillvalue), name
        for name in ["status", "verified", "leading_pulse", "reason", "warnings", "run_hash"]:
            assert "_FillValue" not in f[name].attrs, name
        for name in PROBE_STORED:
            assert f[name].shape == (3, 2, 3) and f[name].dtype == np.float64, name
        assert "leading_peak" not in f and "record_max" not in f
        for name in ["leading_peak", "record_max"]:
            for part, unit in zip(SPLIT[name], ["N", "m/s"]):
                assert f[part].attrs["units"] == unit, part
                others = np.array(UNITS) != unit
                assert np.isnan(f[part][...][..., others]).all(), part
                if name == "record_max":  # (a leading pulse may not pass a far probe in time)
                    assert np.isfinite(f[part][...][..., ~others]).all(), part
        assert f["leading_peak_time_s"].attrs["units"] == "s"
        assert f["status"].dtype == np.uint8
        assert list(f["status"].attrs["flag_values"]) == [0, 1, 2, 3]
        assert f["status"].attrs["flag_meanings"] == "pending ok failed unsettled"
        # text: netCDF `char`s, the UTF-8 bytes along a last dimension <name>_strlen
        for name in TEXT + ["probe", "probe_units"]:
            assert f[name].dtype == np.dtype("S1") and f[name].attrs["_Encoding"] == "utf-8", name
            assert f[name].fletcher32, name
            # Free text is deflated; run hashes and labels are not (hex digits barely pay).
            free = name in ("reason", "warnings")
            assert f[name].compression == ("gzip" if free else None), name
        assert f["run_hash"].shape == (3, 2, 64)
        assert all(len(h) == 64 for h in texts(f["run_hash"]).ravel())
        assert (f["status"][...] == 1).all()
        assert f["reason"].shape == (3, 2, 1) and (texts(f["reason"]) == "").all()
        assert texts(f["warnings"]).shape == (3, 2)
        assert all(isinstance(w, str) for w in texts(f["warnings"]).ravel())
        assert f["max_overlap_m"].attrs["units"] == "m"
        assert (f["max_overlap_m"][...] > 0).all()
        assert (f["events"][...] >= 0).all()
        # Per probe: 1 where the leading pulse passed, 2 where it had not by t_end (its
        # leading_peak NaN): exactly where the peak is NaN.
        lp = f["leading_pulse"]
        assert lp.shape == (3, 2, 3) and lp.dtype == np.uint8
        assert lp.attrs["flag_meanings"] == "no_run passed not_passed_by_t_end"
        np.testing.assert_array_equal(lp[...], np.where(np.isnan(probe_values(f, "leading_peak")), 2, 1))
        assert f["verified"].dtype == np.uint8 and (f["verified"][...] == 0).all()
        assert f["verified"].attrs["flag_meanings"] == "not_verified verified verification_failed"
        for name in VERIFY_PROBE_GRID:
            assert f[name].shape == (3, 2, 3) and np.isnan(f[name][...]).all(), name
        assert np.isnan(f["verify_rel_error_max"][...]).all()
        assert float(f.attrs["verify_fraction"]) == 0.0 and int(f.attrs["n_verified"]) == 0
        # Nothing was verified and nothing failed: those columns cost their headers only, no
        # chunk written (HDF5 gives their fill value back, read above), while a column of values
        # has its chunk.
        for name in ["verified", "verify_rel_error_max", "reason", *VERIFY_PROBE_GRID]:
            assert f[name].id.get_num_chunks() == 0, name
        assert f["steps"].id.get_num_chunks() == 1 and f["run_hash"].id.get_num_chunks() == 1
        assert isinstance(f.attrs["verify_tightening"], str)


def test_dimension_scales(produced):
    _, _, out = produced
    with h5py.File(out, "r") as f:
        for name in ["mass_ratio", "damping_kg_s", "probe"]:
            assert h5py.h5ds.is_scale(f[name].id), name
        # a dimension is named after its scale (netCDF's way); no labels (DIMENSION_LABELS)
        for name in SUMMARY_GRID + INT_GRID + VERIFY_GRID + ["status", "verified"] + TEXT:
            ds = f[name]
            scales = [d[0].name for d in ds.dims]
            strlen = [f"/{name}_strlen"] if name in TEXT else []
            assert scales == ["/mass_ratio", "/damping_kg_s"] + strlen, name
            assert "DIMENSION_LABELS" not in ds.attrs, name
        for name in PROBE_STORED + VERIFY_PROBE_GRID:
            ds = f[name]
            assert [d[0].name for d in ds.dims] == ["/mass_ratio", "/damping_kg_s", "/probe"]
            assert "DIMENSION_LABELS" not in ds.attrs, name
            np.testing.assert_array_equal(ds.dims[0][0][:], [0.3, 0.55, 1.0])
        # netCDF's numbering of the dimensions, by which it reads the two-dimensional `probe`
        ids = {n: int(d.attrs["_Netcdf4Dimid"]) for n, d in f.items()
               if isinstance(d, h5py.Dataset) and h5py.h5ds.is_scale(d.id)}
        assert sorted(ids.values()) == list(range(len(ids)))
        assert list(f["probe"].attrs["_Netcdf4Coordinates"]) == [ids["probe"], ids["probe_strlen"]]


def test_histories(produced):
    """Layout 5: every run's histories in one dataset per unit over (grid, probe, time_s), the
    time axis stored once, NaN where a run has none; minimum overlaps over (grid, contact)."""
    _, _, out = produced
    with h5py.File(out, "r") as f:
        assert "runs" not in f  # no group per run
        assert int(f.attrs["layout_version"]) == 6
        t = f["time_s"]
        assert t.attrs["units"] == "s" and h5py.h5ds.is_scale(t.id)
        assert t.shape == (201,)
        np.testing.assert_array_equal(t[:], np.arange(201) * 1e-6)  # k × the interval, exactly
        probes = [p.decode() for p in f["probe"][()].view("S%d" % f["probe"].shape[1]).ravel()]
        assert probes == ["gauge_force_cyl2", "gauge_force_cyl8", "velocity_p5"]
        # the probes' units differ: one dataset per unit, NaN at the others' probes
        assert "history" not in f
        for name, unit, mine in [("history_N", "N", [0, 1]), ("history_m_per_s", "m/s", [2])]:
            ds = f[name]
            assert ds.shape == (3, 2, 3, 201) and ds.dtype == np.float64
            assert ds.attrs["units"] == unit
            assert ds.compression == "gzip" and ds.shuffle and ds.fletcher32
            assert ds.chunks[-2:] == (3, 201) and ds.chunks[1] == 2  # whole runs, both of a row
            assert np.isnan(ds.attrs["_FillValue"])
            assert [d[0].name for d in ds.dims] == ["/mass_ratio", "/damping_kg_s", "/probe", "/time_s"]
            assert "DIMENSION_LABELS" not in ds.attrs
            v = ds[()]
            others = [k for k in range(3) if k not in mine]
            assert np.isfinite(v[:, :, mine]).all() and np.isnan(v[:, :, others]).all()
        np.testing.assert_array_equal(f["history_samples"][()], np.full((3, 2), 201))
        for i in range(6):
            mi = np.unravel_index(i, (3, 2))
            # The history's maximum agrees with the refined record maximum.
            peak = f["record_max_N"][mi + (0,)]
            h = f["history_N"][mi + (0,)]
            assert h.max() <= peak * (1 + 1e-9) and h.max() >= 0.9 * peak
        m = f["min_overlap_m"]
        assert m.shape == (3, 2, 22) and np.isfinite(m[()]).all()
        # contacts 1…22 as the overlaps' dimension scale
        assert h5py.h5ds.is_scale(f["contact"].id)
        assert list(f["contact"][:]) == list(range(1, 23))
        assert [d[0].name for d in m.dims] == ["/mass_ratio", "/damping_kg_s", "/contact"]


def test_values_match_rust(produced):
    """Every stored number equals, bit for bit, what `chainsweep point` computes for that point."""
    _, path, out = produced
    with h5py.File(out, "r") as f:
        hashes, warnings = texts(f["run_hash"]), texts(f["warnings"])
        for i in range(6):
            r = run("point", path, i)
            assert r.returncode == 0, r.stderr
            p = json.loads(r.stdout)
            res = p["result"]
            mi = tuple(p["grid_index"])
            assert hashes[mi] == p["run_hash"]
            assert res["ok"]
            for name in [n for n in SUMMARY_GRID if n != "wall_time_s"]:
                assert f[name][mi] == res[name], name
            for name in INT_GRID:
                assert f[name][mi] == res[name], name
            assert "\n".join(res["warnings"]) == warnings[mi]
            for k, pr in enumerate(res["probes"]):
                for name in PROBE_GRID:
                    v = pr[name]
                    stored = probe_values(f, name)[mi + (k,)]
                    if v is None:
                        assert np.isnan(stored)
                    else:
                        assert stored == v, (name, k)
            assert res["history_samples"] == f["history_samples"][mi]
            scene = p["scene"]
            assert scene["physics"]["damping_kg_s"] == f["damping_kg_s"][mi[1]]
            assert scene["chain"]["cylinder"]["mass"]["heavy_cylinders"]["mass_ratio"] == f["mass_ratio"][mi[0]]


def test_summaries_only_writes_no_runs_arrays(tmp_path, binary):
    path = write_sweep(tmp_path / "s.json", base_sweep(history=False))
    out = tmp_path / "s.h5"
    r = run("run", path, "-o", out, "--quiet")
    assert r.returncode == 0, r.stderr
    with h5py.File(out, "r") as f:
        assert not {"runs", "history", "history_samples", "time_s", "min_overlap_m"} & set(f)


def failing_sweep():
    s = base_sweep(history=True)
    s["axes"] = [
        {
            "field": "integrator",
            "values": [
                {"method": "dop853", "rtol": 1e-9},
                {"method": "dop853", "rtol": 1e-8},
                {"method": "rk4", "dt_s": 2e-6},
                {"method": "verlet", "dt_s": 1e-5},
            ],
        },
        {"field": "max_steps", "values": [100000000, 20]},
    ]
    s["limits"] = {"energy_drift_max": 1e-5}
    return s


def test_failed_runs_are_isolated_and_recorded(tmp_path, binary):
    path = write_sweep(tmp_path / "fail.json", failing_sweep())
    out = tmp_path / "fail.h5"
    # Point 0 panics on purpose (testing aid), 2 is fine, 4 drifts, 6 and 7 blow up, 1, 3, 5 run
    # out of steps.
    r = run("run", path, "-o", out, "--jobs", "2", env={"CHAINSWEEP_INJECT_PANIC": "0"})
    assert r.returncode == 3, r.stderr
    assert "7 failed run(s)" in r.stderr
    assert "point 0" in r.stderr and "panic" in r.stderr
    with h5py.File(out, "r") as f:
        status = f["status"][...]
        reason = texts(f["reason"])
        assert status.shape == (4, 2)
        expected = np.full((4, 2), 2, dtype=np.uint8)
        expected[1, 0] = 1
        np.testing.assert_array_equal(status, expected)
        assert "panic" in reason[0, 0]
        assert reason[1, 0] == ""
        assert "energy drift" in reason[2, 0] and "limit" in reason[2, 0]
        assert "NaN or infinite" in reason[3, 0]
        for k in range(3):
            assert "step budget" in reason[k, 1]
        assert "NaN or infinite" in reason[3, 1]  # 20 Verlet steps reach the end
        failed = status == 2
        for name in PROBE_GRID:
            assert np.isnan(f[name][...][failed]).all()
            assert np.isfinite(f[name][1, 0, :2]).all()
        for name in [n for n in SUMMARY_GRID if n != "wall_time_s"]:
            assert np.isnan(f[name][...][failed]).all()
        assert np.isfinite(f["wall_time_s"][...]).all()
        assert (f["steps"][...][failed] == -1).all()
        assert f["steps"][1, 0] > 0
        # Only the successful run has a history; the others are NaN (the fill value).
        np.testing.assert_array_equal(f["history_samples"][()] > 0, status == 1)
        h = f["history"][()]
        assert np.isfinite(h[1, 0, :2]).all() and np.isnan(h[status != 1]).all()
        assert int(f.attrs["n_failed"]) == 7
    r = run("status", out)
    assert r.returncode == 3
    assert "7 failed" in r.stdout and "panic" in r.stdout

    # Resuming keeps recorded failures; --retry-failed runs them again (the panic is gone now).
    r = run("run", path, "-o", out, "--quiet")
    assert r.returncode == 3
    with h5py.File(out, "r") as f:
        assert f["status"][0, 0] == 2
    r = run("run", path, "-o", out, "--quiet", "--retry-failed")
    assert r.returncode == 3
    with h5py.File(out, "r") as f:
        assert f["status"][0, 0] == 1
        assert int(f.attrs["n_failed"]) == 6
        assert sorted(np.flatnonzero(f["history_samples"][()].ravel() > 0)) == [0, 2]
