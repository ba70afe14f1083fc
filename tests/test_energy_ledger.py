"""The energy ledger's terms (`record.energy_ledger`): kinetic, elastic, gravitational,
dissipated, plastic, external and a mounted wall's, at the start and at the end of every run,
stored as `ledger_<term>_start_j` and `ledger_<term>_j` (J) so that where the energy went can be
read term by term: their sum at the end equals their sum at the start within the run's own drift
(a damped chain on a load cell, a plastic chain, a chain under a force pulse, with gravity), the
dissipated, plastic and mount terms are where the physics puts energy, `chainsweep.open` and
`chainsweep.run` give them bitwise as stored, resume and merge keep them bitwise, and a sweep
without the option stores none."""

import copy

import h5py
import numpy as np
import pytest

import chainsweep

from conftest import assert_resume_and_merge_bitwise, run, write_sweep

TERMS = ["kinetic", "elastic", "gravitational", "dissipated", "plastic", "external", "mount"]
BALL = {"sphere": {"diameter_m": 0.008, "mass_kg": 0.002085,
                   "material": {"youngs_modulus_pa": 2.0e11, "poisson_ratio": 0.28}}}
PLASTIC = {"thornton": {"yield_velocity_m_s": 0.05}}


def ledger_sweep():
    """Eight spheres behind a striker on a damped load cell, with gravity: damped (Hunt-Crossley
    is not needed: viscous), and plastic (Thornton's law, no damping), at two velocities."""
    return {
        "description": "where the energy goes",
        "base": {
            "chain": {
                "particles": {"ball": BALL},
                "sequence": [{"repeat": 8, "of": ["ball"]}],
                "striker": "ball",
                "wall_mount": {"mass_kg": 0.05, "stiffness_n_m": 1.0e8, "damping_kg_s": 20.0},
            },
            "physics": {"gravity": True, "damping_kg_s": 3.0, "wall": True},
            "striker_velocity_m_s": 0.5,
            "duration_s": 3e-4,
            "integrator": {"method": "dop853", "rtol": 1e-10},
        },
        "record": {"probes": [{"kind": "wall_force"}], "energy_ledger": True},
        "axes": [{"field": "striker_velocity_m_s", "values": [0.5, 1.0]}],
    }


def plastic_sweep():
    s = ledger_sweep()
    s["base"]["physics"]["damping_kg_s"] = 0.0
    s["base"]["chain"]["contacts"] = [{"between": ["ball", "ball"], "law": PLASTIC},
                                      {"between": ["ball", "wall"], "law": PLASTIC}]
    return s


@pytest.fixture(scope="module")
def swept(tmp_path_factory, binary):
    d = tmp_path_factory.mktemp("ledger")
    out = {}
    for name, make in [("damped", ledger_sweep), ("plastic", plastic_sweep)]:
        path = write_sweep(d / f"{name}.json", make())
        h5 = d / f"{name}.h5"
        r = run("run", path, "-o", h5, "--quiet")
        assert r.returncode == 0, r.stderr
        out[name] = (path, h5)
    return out


def terms(f, end):
    suffix = "_j" if end else "_start_j"
    return np.stack([f[f"ledger_{t}{suffix}"][...] for t in TERMS], axis=-1)


def test_the_terms_sum_to_the_same_total_and_fall_where_the_physics_puts_them(swept):
    for name, (_, h5) in swept.items():
        with h5py.File(h5, "r") as f:
            for t in TERMS:
                for suffix in ("_j", "_start_j"):
                    d = f[f"ledger_{t}{suffix}"]
                    assert d.attrs["units"] == "J" and d.shape == (2,), (t, suffix)
            start, end = terms(f, False), terms(f, True)
            impact = f["impact_energy_j"][...]
            drift = f["energy_drift_max"][...]
            # Conserved: the end's total is the start's within the run's drift.
            gap = np.abs(end.sum(axis=-1) - start.sum(axis=-1)) / impact
            assert (gap <= drift * (1 + 1e-9) + 1e-15).all(), (name, gap, drift)
            # At the start: the striker's kinetic energy, nothing dissipated, no plastic work.
            np.testing.assert_allclose(start[:, 0], impact, rtol=1e-12)
            assert (start[:, 3] == 0).all() and (start[:, 4] == 0).all()
            if name == "damped":
                # The contacts' and the load cell's dashpots took energy; nothing yielded.
                assert (end[:, 3] > 0.05 * impact).all(), end[:, 3] / impact
                assert (end[:, 4] == 0).all()
            else:
                assert (end[:, 4] > 0.05 * impact).all(), end[:, 4] / impact
                # (The load cell's dashpot still dissipates.)
                assert (end[:, 3] > 0).all()
            # The load cell moved.
            assert (np.abs(end[:, 6]) > 0).all()


def test_open_and_run_give_the_terms_bitwise(swept):
    path, h5 = swept["damped"]
    ds = chainsweep.open(h5)
    with h5py.File(h5, "r") as f:
        for t in TERMS:
            assert ds[f"ledger_{t}_j"].values.tobytes() == f[f"ledger_{t}_j"][...].tobytes(), t
            assert ds[f"ledger_{t}_j"].attrs["units"] == "J"
    scene = copy.deepcopy(ledger_sweep()["base"])
    scene["record"] = ledger_sweep()["record"]
    one = chainsweep.run(scene)
    with h5py.File(h5, "r") as f:
        for t in TERMS:
            assert one[f"ledger_{t}_j"].values.tobytes() == f[f"ledger_{t}_j"][0].tobytes(), t


def test_resume_and_merge_keep_the_terms_bitwise(swept, tmp_path):
    assert_resume_and_merge_bitwise(*swept["plastic"], tmp_path)


def test_a_sweep_without_the_option_stores_none(tmp_path, binary):
    s = ledger_sweep()
    del s["record"]["energy_ledger"]
    path = write_sweep(tmp_path / "none.json", s)
    out = tmp_path / "none.h5"
    assert run("run", path, "-o", out, "--quiet").returncode == 0
    with h5py.File(out, "r") as f:
        assert not [n for n in f if n.startswith("ledger_")]
