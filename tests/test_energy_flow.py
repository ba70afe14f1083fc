"""The energy flow (`record.energy_flow`: the energy that has passed into every contact from the
struck end, its largest value and its value at the end, the wall's contact being the energy that
reached the wall, and each particle's largest kinetic energy) and a wall on a spring and a dashpot
(`chain.wall_mount`, a load cell), through the sweep runner: stored over (grid…, contact) and
(grid…, particle), NaN beyond a shorter chain's, read alike by h5py, xarray and chainsweep.open,
bitwise what chainsweep.run gives; sized by `--dry-run`; resumed and merged bitwise; a changed
value is damage, reported and never served; the physics: the impact energy passes the striker's
contact whole, and a load cell takes what a rigid wall gives back."""

import json
import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest
import xarray as xr

import chainsweep

from conftest import assert_resume_and_merge_bitwise, run, write_sweep

FLOW = ["energy_passed_max_j", "energy_passed_final_j", "max_kinetic_energy_j"]
BALL = {"sphere": {"diameter_m": 0.008, "mass_kg": 0.002085,
                   "material": {"youngs_modulus_pa": 2.0e11, "poisson_ratio": 0.28}}}


def flow_sweep():
    """Sphere chains of 6 and 8 behind a striker on a load cell (with a dashpot), two impact
    velocities and two mount stiffnesses, 0.2 ms."""
    return {
        "description": "sphere chains struck onto a load cell",
        "base": {
            "chain": {
                "particles": {"ball": BALL},
                "sequence": [{"repeat": 8, "of": ["ball"]}],
                "striker": "ball",
                "wall_mount": {"mass_kg": 0.05, "stiffness_n_m": 1.0e8, "damping_kg_s": 20.0},
            },
            "physics": {"gravity": True, "damping_kg_s": 0.0, "wall": True},
            "striker_velocity_m_s": 1.0,
            "duration_s": 2e-4,
            "integrator": {"method": "dop853", "rtol": 1e-10},
        },
        "record": {
            "probes": [{"kind": "mount_force"}, {"kind": "wall_force"}],
            "energy_flow": True,
        },
        "axes": [
            {"field": "striker_velocity_m_s", "values": [0.5, 1.0]},
            {"field": "chain.sequence[0].repeat", "values": [6, 8]},
            {"field": "chain.wall_mount.stiffness_n_m", "values": [1.0e8, 1.0e10]},
        ],
    }


@pytest.fixture(scope="module")
def swept(tmp_path_factory, binary):
    d = tmp_path_factory.mktemp("flow")
    path = write_sweep(d / "s.json", flow_sweep())
    out = d / "s.h5"
    r = run("run", path, "-o", out, "--quiet")
    assert r.returncode == 0, r.stderr
    return path, out


def test_h5py_and_xarray_read_the_flow_over_contacts_and_particles(swept):
    _, out = swept
    with h5py.File(out, "r") as f:
        # 9 particles (striker included) and 9 contacts (the wall's the last) in the longer chain.
        assert f["energy_passed_max_j"].shape == (2, 2, 2, 9)
        assert f["max_kinetic_energy_j"].shape == (2, 2, 2, 9)
        assert f["contact"][()].tolist() == list(range(1, 10))
        assert f["particle"][()].tolist() == list(range(1, 10))
        passed = f["energy_passed_max_j"][()]
        # The 6-sphere chain has 7 contacts: NaN beyond them.
        assert np.isnan(passed[:, 0, :, 7:]).all() and np.isfinite(passed[:, 0, :, :7]).all()
        assert np.isfinite(passed[:, 1]).all()
        assert f["energy_passed_max_j"].attrs["units"] == b"J" or \
            f["energy_passed_max_j"].attrs["units"] == "J"
    ds = xr.open_dataset(out, engine="h5netcdf")
    assert ds.energy_passed_max_j.dims == ("striker_velocity_m_s", "repeat", "stiffness_n_m", "contact")
    assert ds.max_kinetic_energy_j.dims == ("striker_velocity_m_s", "repeat", "stiffness_n_m", "particle")
    # Energy reaching the wall (contact N + 1 of the 8-sphere chain) against impact velocity.
    wall = ds.energy_passed_max_j.sel(repeat=8, contact=9)
    assert (wall > 0).all()
    opened = chainsweep.open(out)
    for name in FLOW:
        assert opened[name].values.tobytes() == ds[name].values.tobytes()
        assert opened[name].attrs["units"] == "J"


def test_the_flow_is_bitwise_what_chainsweep_run_gives(swept):
    path, out = swept
    sweep = json.loads(Path(path).read_text())
    scene = sweep["base"]
    scene["striker_velocity_m_s"] = 1.0
    scene["chain"]["wall_mount"]["stiffness_n_m"] = 1.0e10
    ds = chainsweep.run(scene, record=sweep["record"])
    stored = chainsweep.open(out).sel(striker_velocity_m_s=1.0, repeat=8, stiffness_n_m=1.0e10)
    for name in FLOW:
        assert ds[name].values.tobytes() == stored[name].values.tobytes(), name
    assert ds.energy_passed_max_j.dims == ("contact",)
    assert ds.max_kinetic_energy_j.dims == ("particle",)


def test_the_impact_energy_passes_the_strikers_contact(swept):
    """The striker gives its energy to the chain through contact 1 (its largest kinetic energy is
    the impact's, and the energy through its contact nearly all of it, both up to the little work
    gravity adds); the energy reaching the wall is less than the impact energy, and a soft load
    cell keeps more of it at the end than a stiff one (which gives it back to the chain) and reads
    less than the force on the wall."""
    _, out = swept
    ds = chainsweep.open(out)
    impact = 0.5 * 0.002085 * ds.striker_velocity_m_s**2
    k1 = ds.max_kinetic_energy_j.sel(particle=1)
    # At least the impact's: gravity speeds the striker up a little while the contact is soft.
    assert ((k1 >= impact) & (k1 < impact * (1 + 1e-5))).all()
    through = ds.energy_passed_max_j.sel(contact=1)
    # (Gravity does m g × the striker's travel while in contact, a few 1e-4 of the impact.)
    assert ((through < impact * (1 + 2e-3)) & (through > 0.95 * impact)).all()
    wall = ds.energy_passed_max_j.sel(repeat=8, contact=9)
    assert (wall < impact.broadcast_like(wall)).all()
    # Net energy left at the wall (dashpot, spring) by the end: more in the soft mount.
    net = ds.energy_passed_final_j.sel(repeat=8, contact=9)
    assert (net.sel(stiffness_n_m=1e8) > net.sel(stiffness_n_m=1e10)).all()
    # A soft load cell reads less than the wall force's peak; a stiff one comes within a fifth of
    # it (its own mass rings on the stiff spring).
    cell = ds.record_max.sel(probe="mount_force", repeat=8)
    wall_peak = ds.record_max.sel(probe="wall_force", repeat=8)
    assert (cell.sel(stiffness_n_m=1e8) < wall_peak.sel(stiffness_n_m=1e8)).all()
    ratio = cell.sel(stiffness_n_m=1e10) / wall_peak.sel(stiffness_n_m=1e10)
    assert ((ratio > 0.8) & (ratio < 1.2)).all(), ratio.values


def test_dry_run_sizes_the_flow(swept, tmp_path):
    path, _ = swept
    r = run("run", path, "--dry-run", "--json", "-o", tmp_path / "new.h5")
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)
    assert d["record"]["energy_flow"] is True
    # Two energies per contact and one per particle, 9 of each in the longest chain.
    assert d["size_bytes"]["per_run_histories_uncompressed"] == 3 * 9 * 8


def test_resume_and_merge_keep_the_flow_bitwise(swept, tmp_path):
    assert_resume_and_merge_bitwise(*swept, tmp_path)


def test_a_changed_flow_value_is_damage(swept, tmp_path):
    _, out = swept
    bad = tmp_path / "bad.h5"
    shutil.copy(out, bad)
    with h5py.File(bad, "r+") as f:
        d = f["max_kinetic_energy_j"]
        v = d[1, 1, 0]
        v[3] *= 1 + 1e-12
        d[1, 1, 0] = v
    r = run("status", bad)
    assert r.returncode != 0 or "damaged" in (r.stdout + r.stderr), r.stdout + r.stderr
    with pytest.raises(chainsweep.DamagedFileError):
        chainsweep.open(bad)
    ds = chainsweep.open(bad, damaged="mask")
    assert ds.damaged.values.sum() == 1
    assert np.isnan(ds.max_kinetic_energy_j.values[ds.damaged.values]).all()


def test_runs_without_the_flow_store_none(tmp_path, binary):
    s = flow_sweep()
    s["record"]["energy_flow"] = False
    path = write_sweep(tmp_path / "s.json", s)
    out = tmp_path / "s.h5"
    assert run("run", path, "-o", out, "--quiet").returncode == 0
    with h5py.File(out, "r") as f:
        assert not set(FLOW) & set(f)
        assert "contact" not in f and "particle" not in f
