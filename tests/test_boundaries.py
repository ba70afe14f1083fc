"""Chains between two walls, rings and initial states through the command line and the file: the
example of two equal solitary waves colliding between two walls (sweeps/examples/colliding-waves.json)
comes back from HDF5 through xarray mirror-symmetric, the top wall's force the image of the
wall's; the example of spheres rattling between two walls (sweeps/examples/between-walls.json)
keeps 5/9 of its energy kinetic on average for every seed (the virial theorem); bad boundaries and
initial states exit 2 naming the field, writing nothing."""

import copy
import json

import numpy as np
import xarray as xr

from conftest import REPO, run

EXAMPLES = REPO / "sweeps" / "examples"
SPHERE_MASS_KG = 0.002085


def test_equal_solitary_waves_collide_mirror_symmetrically_between_two_walls(binary, tmp_path):
    out = tmp_path / "colliding.h5"
    r = run("run", EXAMPLES / "colliding-waves.json", "-o", out, "--jobs", "2", "--quiet")
    assert r.returncode == 0, r.stderr
    with xr.open_dataset(out) as ds:
        field = ds["field_contact_force"]
        assert field.dims[-2:] == ("field_time_s", "contact")
        n = 41
        assert list(ds["contact"].values) == list(range(1, n + 2))
        forces = field.sel(velocity_of_particle_41_m_s=-0.5).values.T  # (contact, time)
        peak = np.nanmax(forces)
        assert peak > 10.0
        # Contact j between particles j and j+1 mirrors contact n - j; the top wall (n + 1)
        # mirrors the wall under the chain (n).
        mirror = [n - 2 - k for k in range(n - 1)] + [n, n - 1]
        worst = np.nanmax(np.abs(forces - forces[mirror]))
        assert worst <= 1e-9 * peak, worst / peak
        # The waves reached both walls, which the probes saw as the field did.
        assert np.nanmax(forces[n]) > 0.5 * peak and np.nanmax(forces[n - 1]) > 0.5 * peak
        wall, top = (
            ds["record_max"].sel(velocity_of_particle_41_m_s=-0.5).values[k] for k in range(2)
        )
        assert abs(wall / top - 1) < 1e-9
        assert abs(wall / np.nanmax(forces[n - 1]) - 1) < 1e-3
        unequal = field.sel(velocity_of_particle_41_m_s=-0.15).values.T
        assert np.nanmax(np.abs(unequal - unequal[mirror])) > 0.1 * peak


def test_spheres_between_two_walls_keep_five_ninths_of_their_energy_kinetic(binary, tmp_path):
    out = tmp_path / "walls.h5"
    r = run("run", EXAMPLES / "between-walls.json", "-o", out, "--jobs", "2", "--quiet")
    assert r.returncode == 0, r.stderr
    with xr.open_dataset(out) as ds:
        assert list(ds.seed.values) == [1, 2, 3]
        for seed in ds.seed.values:
            v = ds["history"].sel(seed=seed).values  # (particle, time)
            kinetic = 0.5 * SPHERE_MASS_KG * np.sum(v**2, axis=0)
            # The contacts start open: the total is the initial kinetic energy, and the random
            # velocities differ from seed to seed.
            ratio = np.mean(kinetic) / kinetic[0]
            assert abs(ratio - 5 / 9) < 0.01 * 5 / 9, (seed, ratio)
        first = ds["history"].sel(seed=1).values[:, 0]
        assert not np.allclose(first, ds["history"].sel(seed=2).values[:, 0])


def test_bad_boundaries_and_initial_states_exit_2_naming_the_field(binary, tmp_path):
    base = json.loads((EXAMPLES / "between-walls.json").read_text())
    cases = []

    ring = copy.deepcopy(base)
    del ring["base"]["chain"]["top_wall_material"]
    ring["base"]["chain"]["ring"] = True
    ring["base"]["chain"]["sequence"] = [{"repeat": 2, "of": ["ball"]}]
    ring["base"]["physics"]["wall"] = False
    ring["record"] = {}
    ring["axes"] = [{"field": "duration_s", "values": [1e-4]}]
    cases.append((ring, "base.chain.ring", "at least 3 particles"))

    walled_ring = copy.deepcopy(ring)
    walled_ring["base"]["chain"]["sequence"] = [{"repeat": 5, "of": ["ball"]}]
    walled_ring["base"]["physics"]["wall"] = True
    cases.append((walled_ring, "base.physics.wall", "must be false for a ring"))

    out_of_range = copy.deepcopy(base)
    out_of_range["base"]["excitation"] = {
        "initial_state": {"particles": [{"particle": 9, "velocity_m_s": 1.0}]}
    }
    out_of_range["axes"] = [{"field": "duration_s", "values": [1e-4]}]
    cases.append(
        (out_of_range, "base.excitation.initial_state.particles[0].particle", "must be from 1 to 8")
    )

    no_rms = copy.deepcopy(base)
    no_rms["axes"] = [
        {"field": "excitation.initial_state.random_velocity.rms_m_s", "values": [0.1, -0.1]}
    ]
    cases.append((no_rms, "excitation.initial_state.random_velocity.rms_m_s", "> 0"))

    nothing = copy.deepcopy(base)
    nothing["base"]["excitation"] = {"initial_state": {}}
    nothing["axes"] = [{"field": "duration_s", "values": [1e-4]}]
    cases.append((nothing, "base.excitation.initial_state", "sets nothing in motion"))

    for k, (sweep, field, message) in enumerate(cases):
        path = tmp_path / f"bad{k}.json"
        path.write_text(json.dumps(sweep))
        out = tmp_path / f"bad{k}.h5"
        r = run("run", path, "-o", out, "--quiet")
        assert r.returncode == 2, (field, r.stderr)
        assert field in r.stderr and message in r.stderr, (field, r.stderr)
        assert not out.exists()
