"""Derived fields: a base field written `{"expr": "…"}` takes, at every grid point, its
expression of the point's axis values and the base's numbers, exactly; it is stored as a
coordinate zipped onto the dimension it follows; bad expressions exit 2 naming the field and the
position."""

from __future__ import annotations

import json
import re

import h5py
import pytest

from conftest import REPO, base_sweep, run, write_sweep


def test_the_driven_example_computes_its_durations_as_its_hand_written_list_did(tmp_path):
    """dimer-transmission.json gives each run 1020 drive periods by `1020 / frequency_hz`: the
    same runs (hashes) as the list of durations it used to spell out."""
    new = json.loads((REPO / "sweeps" / "examples" / "dimer-transmission.json").read_text())
    assert new["base"]["duration_s"] == {"expr": "1020 / frequency_hz"}
    old = json.loads(json.dumps(new))
    freqs = old["axes"][1]["values"]
    old["axes"][1] = {"zip": [old["axes"][1], {"field": "duration_s", "values": [1020 / f for f in freqs]}]}
    old["base"]["duration_s"] = 0.255
    lines = []
    for name, s in (("new", new), ("old", old)):
        r = run("run", write_sweep(tmp_path / f"{name}.json", s), "--dry-run")
        assert r.returncode == 0, r.stderr
        lines.append([l for l in r.stdout.splitlines() if re.match(r"^ +\d+ ", l)])
    assert lines[0] == lines[1] and len(lines[0]) == 3 * len(freqs)


def test_a_derived_field_is_a_coordinate_of_the_dimension_it_follows(tmp_path):
    s = base_sweep()
    s["record"]["history"] = False
    s["axes"] = [
        {"field": "physics.damping_kg_s", "values": [0, 6]},
        {"field": "striker_velocity_m_s", "values": [0.5, 1.0, 2.0]},
    ]
    # A duration shorter the faster the striker, and a base number by its path.
    s["base"]["duration_s"] = {"expr": "1e-4 + 5e-5 / striker_velocity_m_s"}
    s["base"]["physics"]["precompression_force_n"] = {"expr": "max(0, 2 * physics.gravity_m_s2 - 19)"}
    path = write_sweep(tmp_path / "d.json", s)
    out = tmp_path / "d.h5"
    r = run("run", path, "-o", out, "--quiet")
    assert r.returncode == 0, r.stderr
    with h5py.File(out) as f:
        d = f["duration_s"][()]
        assert d.shape == (3,) and list(d) == [1e-4 + 5e-5 / v for v in (0.5, 1.0, 2.0)]
        assert f["duration_s"].attrs["units"] == "s"
        # The runs end at their own durations.
        t_end = f["t_end_s"][()]
        assert (abs(t_end - d[None, :]) < 1e-12).all()


@pytest.mark.parametrize(
    "expr, says",
    [
        ("1 + ", "at position 5"),
        ("2 * (striker_velocity_m_s + 1", "at position 30: expects `)`"),
        ("cos(striker_velocity_m_s)", "`cos` is no function"),
        ("1 / velocity", "reads `velocity`, which is neither an axis"),
        ("physics.damping_kg_s * striker_velocity_m_s * mass_ratio", "reads axes of two dimensions"),
        ("1 / (striker_velocity_m_s - 1.0)", "gives inf"),
    ],
)
def test_bad_expressions_exit_2_naming_the_field_and_the_position(tmp_path, expr, says):
    s = base_sweep()
    s["axes"] = [
        {"field": "chain.cylinder.mass.heavy_cylinders.mass_ratio", "values": [0.3, 1.0]},
        {"field": "striker_velocity_m_s", "values": [0.5, 1.0]},
        {"field": "physics.damping_kg_s", "values": [0, 6]},
    ]
    s["base"]["duration_s"] = {"expr": expr}
    path = write_sweep(tmp_path / "bad.json", s)
    r = run("run", path, "-o", tmp_path / "bad.h5")
    assert r.returncode == 2 and "field `base.duration_s`" in r.stderr and says in r.stderr, r.stderr
    assert not (tmp_path / "bad.h5").exists()
    v = run("validate", path)
    assert v.returncode == 2 and says in v.stdout + v.stderr, v.stdout + v.stderr
