"""Damping from a coefficient of restitution through the command line: the example sweep of
sweeps/examples/restitution.json (a striker sphere on one free sphere, Tsuji's damping, tensile
forces clipped) restitutes the e of each grid point at 0.1, 1 and 10 m/s, reading e back from the
struck sphere's velocity, which ends at v0 (1 + e)/2; the sweep runs into HDF5; bad values of e
are refused with exit code 2 naming the field (the malformed corpus holds more)."""

import json

from conftest import REPO, run

EXAMPLE = REPO / "sweeps" / "examples" / "restitution.json"


def point(path, index):
    r = run("point", path, str(index))
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout)


def test_example_restitutes_e_at_every_velocity(binary):
    sweep = json.loads(EXAMPLE.read_text())
    restitutions = sweep["axes"][0]["values"]
    velocities = sweep["axes"][1]["values"]
    assert restitutions == [0.3, 0.7, 0.95] and velocities == [0.1, 1.0, 10.0]
    for i, e in enumerate(restitutions):
        measured = []
        for j, v in enumerate(velocities):
            p = point(EXAMPLE, i * len(velocities) + j)
            assert p["scene"]["physics"]["dissipation"] == {"tsuji": {"restitution": e}}
            assert p["scene"]["striker_velocity_m_s"] == v
            res = p["result"]
            assert res["ok"], res["reason"]
            assert res["energy_drift_max"] < 1e-9
            (probe,) = res["probes"]
            got = 2.0 * probe["record_max"] / v - 1.0
            assert abs(got - e) < 1e-6, (e, v, got)
            measured.append(got)
        assert max(measured) - min(measured) < 1e-6, (e, measured)


def test_example_sweep_runs(binary, tmp_path):
    out = tmp_path / "restitution.h5"
    r = run("run", EXAMPLE, "-o", out, "--jobs", "2", "--quiet")
    assert r.returncode == 0, r.stderr
    r = run("status", out)
    assert r.returncode == 0, r.stderr


def test_bad_restitution_exits_2_naming_the_field(binary, tmp_path):
    sweep = json.loads(EXAMPLE.read_text())
    for bad in ["0", "1.2", "NaN", "-0.3"]:
        s = json.loads(json.dumps(sweep))
        s["axes"] = [s["axes"][1]]
        s["base"]["physics"]["dissipation"]["tsuji"]["restitution"] = 0.123456
        path = tmp_path / "bad.json"
        path.write_text(json.dumps(s, indent=2).replace("0.123456", bad))
        r = run("validate", path)
        assert r.returncode == 2, (bad, r.stderr)
        field = "restitution" if bad == "NaN" else "base.physics.dissipation.tsuji.restitution"
        assert f"field `{field}`" in r.stderr, (bad, r.stderr)
        if bad != "NaN":
            assert "must lie in (0, 1]" in r.stderr
        r = run("run", path, "-o", tmp_path / "out.h5", "--quiet")
        assert r.returncode == 2, (bad, r.stderr)
        assert not (tmp_path / "out.h5").exists()
