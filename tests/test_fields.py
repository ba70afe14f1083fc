"""Space–time fields (`record.fields`): every contact's force and every particle's displacement and
velocity on a coarse time grid, stored as one compressed variable per quantity over (grid…,
field_time_s, contact | particle); bitwise the histories of probes on the same contacts and
particles; read alike by h5py, xarray (both engines) and chainsweep.open (eager and lazy); sized
by `run --dry-run`; resumed and merged bitwise; bad values exit 2 naming the field."""

import json
import shutil

import h5py
import numpy as np
import pytest
import xarray as xr

import chainsweep

from conftest import assert_resume_and_merge_bitwise, base_sweep, run, write_sweep

ENGINES = ["h5netcdf", "netcdf4"]
QUANTITIES = ["contact_force", "displacement", "velocity"]
# Probes on the contacts and particles the bitwise test compares (contact 21 is the wall's in the
# 8-cylinder chain, 18 particles; contact 3 and particles 2, 5, 7, 18 exist in both chains).
CONTACTS = [1, 3, 17]
PARTICLES = [1, 5, 18]


def fields_sweep(interval=1e-6):
    """8- and 10-cylinder chains × three mass ratios, 0.2 ms, with probes on a few contacts and
    particles (histories every 1 µs) and the fields of every quantity every `interval`."""
    s = base_sweep(history=True)
    s["record"]["probes"] = (
        [{"kind": "contact_force", "contact": c} for c in CONTACTS]
        + [{"kind": "displacement", "particle": p} for p in PARTICLES]
        + [{"kind": "velocity", "particle": p} for p in PARTICLES]
    )
    s["record"]["min_overlap"] = True
    s["record"]["fields"] = {"quantities": QUANTITIES, "interval_s": interval}
    s["axes"] = [
        {"field": "chain.cylinder.mass.heavy_cylinders.mass_ratio", "values": [0.3, 0.55, 1.0]},
        {"field": "chain.cylinders", "values": [8, 10]},
    ]
    return s


@pytest.fixture(scope="module")
def swept(tmp_path_factory, binary):
    d = tmp_path_factory.mktemp("fields")
    path = write_sweep(d / "s.json", fields_sweep())
    out = d / "s.h5"
    r = run("run", path, "-o", out, "--quiet")
    assert r.returncode == 0, r.stderr
    return path, out


def test_fields_are_bitwise_the_probes_on_the_same_contacts_and_particles(swept):
    _, out = swept
    with h5py.File(out, "r") as f:
        # The probes' units differ: one history per unit, over (mass_ratio, cylinders, probe,
        # time_s), NaN at the probes of the others.
        parts = {u: f[f"history_{u}"][()] for u in ("N", "m", "m_per_s")}
        force = f["field_contact_force"][()]
        disp = f["field_displacement"][()]
        vel = f["field_velocity"][()]
        assert np.array_equal(f["field_time_s"][()], f["time_s"][()])
    k = 0
    for c in CONTACTS:
        np.testing.assert_array_equal(
            force[..., :, c - 1].view(np.uint64), parts["N"][..., k, :].view(np.uint64)
        )
        k += 1
    for field, unit in ((disp, "m"), (vel, "m_per_s")):
        for p in PARTICLES:
            np.testing.assert_array_equal(
                field[..., :, p - 1].view(np.uint64), parts[unit][..., k, :].view(np.uint64)
            )
            k += 1
    # Not a resting chain: the pulse passed contact 17 (ε = 1: a solitary wave).
    assert np.nanmax(force[2, 1, :, 16]) > 50


def test_h5py_reads_the_layout(swept):
    _, out = swept
    with h5py.File(out, "r") as f:
        force, vel = f["field_contact_force"], f["field_velocity"]
        assert force.shape == (3, 2, 201, 22) and vel.shape == (3, 2, 201, 22)
        # Time series, dense: checksummed, not compressed (inflating bounded their reading).
        assert force.compression is None and not force.shuffle and force.fletcher32
        assert force.attrs["units"] == "N" and vel.attrs["units"] == "m/s"
        assert f["field_displacement"].attrs["units"] == "m"
        assert [force.dims[k][0].name.rsplit("/", 1)[-1] for k in range(4)] == [
            "mass_ratio", "cylinders", "field_time_s", "contact"]
        assert vel.dims[3][0].name == "/particle"
        np.testing.assert_array_equal(f["field_time_s"][()], np.arange(201) * 1e-6)
        assert f["field_time_s"].attrs["units"] == "s"
        assert f["field_samples"][()].tolist() == [[201, 201]] * 3
        np.testing.assert_array_equal(f["particle"][()], np.arange(1, 23))
        # 8 cylinders: 18 particles, 18 contacts (the wall's included): NaN beyond them.
        v = vel[0, 0]
        assert np.isfinite(v[:, :18]).all() and np.isnan(v[:, 18:]).all()
        assert np.isfinite(vel[0, 1]).all()
        # The striker at the impact velocity, every other particle at rest, at t = 0.
        assert v[0, 0] == 1.3 and (v[0, 1:18] == 0).all()


@pytest.mark.parametrize("engine", ENGINES)
def test_xarray_gives_time_by_contact_and_time_by_particle(swept, engine):
    _, out = swept
    ds = xr.open_dataset(out, engine=engine)
    assert ds.field_contact_force.dims == ("mass_ratio", "cylinders", "field_time_s", "contact")
    assert ds.field_velocity.dims == ("mass_ratio", "cylinders", "field_time_s", "particle")
    assert ds.field_displacement.dims == ("mass_ratio", "cylinders", "field_time_s", "particle")
    assert ds.field_contact_force.attrs["units"] == "N"
    assert ds.field_time_s.attrs["units"] == "s"
    # The space-time map of one run, selected by label.
    m = ds.field_contact_force.sel(mass_ratio=1.0, cylinders=10)
    assert m.dims == ("field_time_s", "contact") and m.shape == (201, 22)
    arrival = m.sel(contact=[5, 15]).argmax("field_time_s").values
    assert arrival[1] > arrival[0]  # the pulse reaches contact 15 after contact 5
    lazy = xr.open_dataset(out, engine=engine, chunks={})
    with h5py.File(out, "r") as f:
        want = f["field_velocity"][()]
    assert lazy.field_velocity.values.tobytes() == want.tobytes()


@pytest.mark.parametrize("histories", [True, "lazy"])
def test_chainsweep_open_reads_the_fields(swept, histories):
    _, out = swept
    ds = chainsweep.open(out, histories=histories)
    with h5py.File(out, "r") as f:
        for name in ("field_contact_force", "field_displacement", "field_velocity"):
            v = ds[name]
            if histories == "lazy":
                assert hasattr(v.data, "dask")
            assert v.dims[-2:] == ("field_time_s", "contact" if "force" in name else "particle")
            assert v.values.tobytes() == f[name][()].tobytes()
            assert v.attrs["units"] == f[name].attrs["units"]
    assert ds.field_samples.values.tolist() == [[201, 201]] * 3
    assert ds.particle.values.tolist() == list(range(1, 23))
    # Without histories the fields (as large as histories) are not read.
    assert "field_velocity" not in chainsweep.open(out)


def test_dry_run_sizes_the_fields(swept, tmp_path):
    path, out = swept
    r = run("run", path, "--dry-run", "--json", "-o", tmp_path / "new.h5")
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)
    # 201 instants of 22 contacts + 2 × 22 particles, 8 bytes each, and the sample count.
    assert d["size_bytes"]["per_run_fields_uncompressed"] == 201 * 66 * 8 + 8
    assert d["record"]["fields"] == {
        "quantities": QUANTITIES, "interval_s": 1e-6, "max_samples": 201}
    total = d["size_bytes"]["total_estimate"]
    assert total > 6 * 201 * 66 * 8
    # The fields are stored uncompressed, the histories split by unit compressed (NaN at the
    # other units' probes): the estimate is the file's size within a tenth.
    assert 0.9 * total < out.stat().st_size < 1.1 * total, (out.stat().st_size, total)
    text = run("run", path, "--dry-run", "-o", tmp_path / "new.h5")
    assert "fields); histories and fields are not compressed" in text.stdout + text.stderr
    assert "fields of contact_force, displacement, velocity every 1e-6 s" in text.stdout + text.stderr


def test_resume_and_merge_keep_the_fields_bitwise(swept, tmp_path):
    def pending_runs_hold_no_fields(parts):
        with h5py.File(parts[0], "r") as f:
            pending = f["status"][()] == 0
            assert pending.any() and (f["field_samples"][()][pending] == -1).all()
            assert np.isnan(f["field_contact_force"][()][pending]).all()

    assert_resume_and_merge_bitwise(*swept, tmp_path, pending_runs_hold_no_fields)


def test_a_damaged_field_chunk_is_reported_never_served(swept, tmp_path):
    _, out = swept
    bad = tmp_path / "bad.h5"
    shutil.copy(out, bad)
    with h5py.File(bad, "r") as f:
        d = f["field_velocity"]
        offset = d.id.get_chunk_info(0).byte_offset
    with open(bad, "r+b") as fh:
        fh.seek(offset + 40)
        byte = fh.read(1)
        fh.seek(offset + 40)
        fh.write(bytes([byte[0] ^ 0xFF]))
    with pytest.raises(chainsweep.DamagedFileError):
        chainsweep.open(bad, histories=True)
    ds = chainsweep.open(bad, histories=True, damaged="mask")
    assert ds.damaged.values.any()
    assert np.isnan(ds.field_velocity.values[ds.damaged.values]).all()


def test_runs_without_fields_store_none(tmp_path, binary):
    s = base_sweep()
    path = write_sweep(tmp_path / "s.json", s)
    out = tmp_path / "s.h5"
    assert run("run", path, "-o", out, "--quiet").returncode == 0
    with h5py.File(out, "r") as f:
        assert not {"field_time_s", "field_samples", "particle", "field_velocity"} & set(f)


@pytest.mark.parametrize(
    "fields, field",
    [
        ({"quantities": ["velocity"], "interval_s": 0}, "record.fields.interval_s"),
        ({"quantities": ["velocity"], "interval_s": -1e-6}, "record.fields.interval_s"),
        ({"quantities": ["velocity"], "interval_s": 1e-13}, "record.fields.interval_s"),
        ({"quantities": ["pressure"], "interval_s": 1e-6}, "record.fields.quantities[0]"),
        ({"quantities": [], "interval_s": 1e-6}, "record.fields.quantities"),
        ({"quantities": ["velocity", "velocity"], "interval_s": 1e-6},
         "record.fields.quantities[1]"),
        ({"quantities": ["velocity"]}, "record.fields"),
    ],
)
def test_bad_fields_exit_2_naming_the_field(tmp_path, binary, fields, field):
    s = base_sweep()
    s["record"]["fields"] = fields
    path = write_sweep(tmp_path / "s.json", s)
    for command in (["validate", path], ["run", path, "-o", tmp_path / "s.h5"]):
        r = run(*command)
        assert r.returncode == 2, (command, r.stderr)
        assert f"`{field}`" in r.stderr, r.stderr
    assert not (tmp_path / "s.h5").exists()


def test_an_axis_over_the_field_interval_is_refused(tmp_path, binary):
    s = base_sweep()
    s["record"]["fields"] = {"quantities": ["velocity"], "interval_s": 1e-6}
    s["axes"][1] = {"field": "record.fields.interval_s", "values": [1e-6, 2e-6]}
    path = write_sweep(tmp_path / "s.json", s)
    r = run("validate", path)
    assert r.returncode == 2 and "`record`" in r.stderr and "fields" in r.stderr, r.stderr


def test_chainsweep_run_returns_the_fields():
    scene = fields_sweep()["base"]
    record = fields_sweep()["record"]
    ds = chainsweep.run(scene, record=record)
    assert ds.field_contact_force.dims == ("field_time_s", "contact")
    assert ds.field_velocity.dims == ("field_time_s", "particle")
    assert ds.field_velocity.shape == (201, 22)
    np.testing.assert_array_equal(ds.field_time_s.values, ds.time_s.values)
    k = list(ds.probe.values).index("contact_force_17")
    assert ds.field_contact_force.sel(contact=17).values.tobytes() == \
        ds.history.isel(probe=k).values.tobytes()
