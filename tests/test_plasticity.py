"""Thornton's elastic-perfectly-plastic contacts through the command line: a striker sphere on one
free sphere restitutes Thornton's closed form (read back from the struck sphere's velocity, which
ends at v0 (1 + e)/2) at 2, 5, 20 and 100 times the yield velocity, and 1 below it, with the yield
velocity swept as an axis; the example sweep of sweeps/examples/plastic-impact.json (a dimer chain
struck at 0.1 to 10 m/s, elastic or plastic at 3 and 1.5 GPa) runs into HDF5 and shows plasticity
capping the transmitted force; bad values exit 2 naming the field."""

import json
import math

import numpy as np

from conftest import REPO, run

EXAMPLE = REPO / "sweeps" / "examples" / "plastic-impact.json"
YIELD_VELOCITY = 0.1
MULTIPLES = [0.5, 2.0, 5.0, 20.0, 100.0]


def thornton(r):
    """Thornton's closed-form restitution for r = V_y/V_i (1 below yield)."""
    if r >= 1.0:
        return 1.0
    return (
        math.sqrt(6 * math.sqrt(3) / 5)
        * math.sqrt(1 - r * r / 6)
        * (r / (r + 2 * math.sqrt(6 / 5 - r * r / 5))) ** 0.25
    )


def two_spheres():
    """A striker sphere on one free sphere, the pair plastic; velocity axis in multiples of V_y."""
    ball = {
        "sphere": {
            "diameter_m": 0.008,
            "mass_kg": 0.002085,
            "material": {"youngs_modulus_pa": 2e11, "poisson_ratio": 0.28},
        }
    }
    return {
        "description": "two spheres, Thornton's law",
        "base": {
            "chain": {
                "particles": {"ball": ball},
                "sequence": ["ball"],
                "striker": "ball",
                "contacts": [
                    {
                        "between": ["ball", "ball"],
                        "law": {"thornton": {"yield_velocity_m_s": YIELD_VELOCITY}},
                    }
                ],
            },
            "physics": {"gravity": False, "damping_kg_s": 0.0, "wall": False},
            "striker_velocity_m_s": 1.0,
            "duration_s": 0.0005,
            "integrator": {"method": "dop853", "rtol": 1e-11},
        },
        "record": {"probes": [{"kind": "velocity", "particle": 2}]},
        "axes": [
            {
                "field": "chain.contacts[0].law.thornton.yield_velocity_m_s",
                "values": [YIELD_VELOCITY, 2 * YIELD_VELOCITY],
            },
            {
                "field": "striker_velocity_m_s",
                "values": [k * YIELD_VELOCITY for k in MULTIPLES],
            },
        ],
    }


def point(path, index):
    r = run("point", path, str(index))
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout)


def test_two_spheres_restitute_thorntons_closed_form(binary, tmp_path):
    sweep = two_spheres()
    path = tmp_path / "two.json"
    path.write_text(json.dumps(sweep))
    yields = sweep["axes"][0]["values"]
    velocities = sweep["axes"][1]["values"]
    worst = 0.0
    for i, v_y in enumerate(yields):
        for j, v in enumerate(velocities):
            p = point(path, i * len(velocities) + j)
            law = p["scene"]["chain"]["contacts"][0]["law"]
            assert law == {"thornton": {"yield_velocity_m_s": v_y}}
            res = p["result"]
            assert res["ok"], res["reason"]
            assert res["energy_drift_max"] < 1e-9
            (probe,) = res["probes"]
            e = 2.0 * probe["record_max"] / v - 1.0
            expected = thornton(v_y / v)
            assert abs(e - expected) < 1e-6, (v_y, v, e, expected)
            worst = max(worst, abs(e - expected))
    print(f"largest restitution error {worst:.2e}")


def test_example_sweep_runs_and_plasticity_caps_the_transmitted_force(binary, tmp_path):
    sweep = json.loads(EXAMPLE.read_text())
    laws = sweep["axes"][0]["zip"][0]["values"]
    velocities = sweep["axes"][1]["values"]
    assert laws[0] == "hertz" and [v["thornton"]["yield_pressure_pa"] for v in laws[1:]] == [3e9, 1.5e9]
    out = tmp_path / "plastic.h5"
    r = run("run", EXAMPLE, "-o", out, "--jobs", "2", "--quiet")
    assert r.returncode == 0, r.stderr
    r = run("status", out)
    assert r.returncode == 0, r.stderr
    # The wall force (record maximum) of each law at each velocity, through `point`.
    wall = np.zeros((len(laws), len(velocities)))
    for i in range(len(laws)):
        for j, v in enumerate(velocities):
            res = point(EXAMPLE, i * len(velocities) + j)["result"]
            assert res["ok"], res["reason"]
            assert res["energy_drift_max"] < 1e-5
            wall[i, j] = res["probes"][1]["record_max"]
    # Lower yield pressure, lower transmitted force; at 0.1 m/s the 3 GPa chain never yields.
    assert np.all(wall[1] <= wall[0] * (1 + 1e-6)) and np.all(wall[2] <= wall[1] * (1 + 1e-6))
    assert abs(wall[1, 0] / wall[0, 0] - 1) < 1e-6
    # The elastic chain transmits a force growing as v^{6/5}; plasticity caps it: at 10 m/s the
    # 1.5 GPa chain passes a tenth of it.
    slope = np.log(wall[0, -1] / wall[0, 0]) / np.log(velocities[-1] / velocities[0])
    assert abs(slope - 1.2) < 0.02, slope
    assert wall[2, -1] < 0.15 * wall[0, -1], wall[:, -1]


def test_bad_yield_values_exit_2_naming_the_field(binary, tmp_path):
    cases = [
        ({"yield_pressure_pa": 0.0}, "law.thornton.yield_pressure_pa", "must be a finite number > 0"),
        ({"yield_pressure_pa": -1e9}, "law.thornton.yield_pressure_pa", "must be a finite number > 0"),
        ({"yield_velocity_m_s": 0.0}, "law.thornton.yield_velocity_m_s", "must be a finite number > 0"),
        ({}, "law.thornton", "give exactly one of"),
        ({"yield_pressure_pa": 1e9, "yield_velocity_m_s": 0.1}, "law.thornton", "give exactly one of"),
    ]
    for law, field, message in cases:
        sweep = two_spheres()
        sweep["axes"] = [sweep["axes"][1]]
        sweep["base"]["chain"]["contacts"][0]["law"] = {"thornton": law}
        path = tmp_path / "bad.json"
        path.write_text(json.dumps(sweep))
        r = run("validate", path)
        assert r.returncode == 2, (law, r.stderr)
        assert f"field `base.chain.contacts[0].{field}`: {message}" in r.stderr, (law, r.stderr)
        r = run("run", path, "-o", tmp_path / "out.h5", "--quiet")
        assert r.returncode == 2, (law, r.stderr)
        assert not (tmp_path / "out.h5").exists()
    # A misspelt field is refused by name too.
    sweep = two_spheres()
    sweep["base"]["chain"]["contacts"][0]["law"] = {"thornton": {"yield_pressure": 1e9}}
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(sweep))
    r = run("validate", path)
    assert r.returncode == 2 and "yield_pressure" in r.stderr, r.stderr
