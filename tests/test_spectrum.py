"""The linear spectrum at the static state through the command line: the example sweep
sweeps/examples/dimer-bands.json (a precompressed dimer, `record.spectrum` with a cell of two
particles, no time integration) records band edges that follow K ∝ F^(1/3), so ω ∝ F^(1/6), and
match the diatomic closed forms; a chain with no static compression and a cell that does not
repeat are refused with exit code 2 naming the field."""

import copy
import json

import h5py
import numpy as np

from conftest import REPO, run

EXAMPLE = REPO / "sweeps" / "examples" / "dimer-bands.json"


def test_band_edges_follow_the_sixth_root_of_the_force(binary, tmp_path):
    sweep = json.loads(EXAMPLE.read_text())
    out = tmp_path / "bands.h5"
    r = run("run", EXAMPLE, "-o", out)
    assert r.returncode == 0, r.stderr
    forces = np.array(sweep["axes"][0]["values"], dtype=float)
    small = np.array(sweep["axes"][1]["values"], dtype=float)
    large = sweep["base"]["chain"]["particles"]["large"]["sphere"]["mass_kg"]
    a = sweep["base"]["chain"]["contacts"][0]["law"]["power_law"]["coefficient"]
    k = 1.5 * a ** (2 / 3) * forces[:, None] ** (1 / 3)
    hz = 1 / (2 * np.pi)
    with h5py.File(out) as f:
        assert (f["status"][()] == 1).all()
        # Not integrated in time.
        assert (f["t_end_s"][()] == 0).all() and (f["steps"][()] == 0).all()
        for name in ("lowest_frequency_hz", "gap_lower_hz", "gap_upper_hz", "band_top_hz"):
            assert f[name].attrs["units"] in (b"Hz", "Hz")
        lower, upper = f["gap_lower_hz"][()], f["gap_upper_hz"][()]
        top, lowest = f["band_top_hz"][()], f["lowest_frequency_hz"][()]
        highest = f["highest_frequency_hz"][()]
    np.testing.assert_allclose(lower, np.broadcast_to(hz * np.sqrt(2 * k / large), lower.shape), rtol=1e-8)
    np.testing.assert_allclose(upper, hz * np.sqrt(2 * k / small[None, :]), rtol=1e-8)
    np.testing.assert_allclose(top, hz * np.sqrt(2 * k * (1 / large + 1 / small[None, :])), rtol=1e-8)
    # Every frequency ∝ F^(1/6): the ratio between consecutive forces (× 10) is 10^(1/6).
    for col in (lower, upper, top, lowest, highest):
        np.testing.assert_allclose(col[1:] / col[:-1], 10 ** (1 / 6), rtol=1e-9)
    # The finite chain's spectrum lies within the bands.
    assert (lowest < lower).all() and (highest <= top * (1 + 1e-12)).all()


def refused(tmp_path, sweep, field):
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(sweep))
    r = run("validate", path)
    assert r.returncode == 2, (r.returncode, r.stdout, r.stderr)
    assert field in r.stderr, r.stderr
    return r.stderr


def test_bad_spectra_are_refused_naming_the_field(binary, tmp_path):
    sweep = json.loads(EXAMPLE.read_text())
    # No static compression: no precompression, gravity off.
    s = copy.deepcopy(sweep)
    s["axes"] = [s["axes"][1]]
    s["base"]["physics"]["precompression_force_n"] = 0
    assert "zero mode" in refused(tmp_path, s, "physics.precompression_force_n")
    # A cell that does not repeat along the chain.
    s = copy.deepcopy(sweep)
    s["record"]["spectrum"]["cell_particles"] = 3
    assert "not periodic" in refused(tmp_path, s, "record.spectrum.cell_particles")
    # Gravity loads the contacts unequally: the dimer is not periodic in its stiffnesses.
    s = copy.deepcopy(sweep)
    s["base"]["physics"]["gravity"] = True
    assert "stiffness" in refused(tmp_path, s, "record.spectrum.cell_particles")


def test_point_prints_the_spectrum(binary):
    r = run("point", EXAMPLE, "4")
    assert r.returncode == 0, r.stderr
    res = json.loads(r.stdout)["result"]
    assert res["ok"] and res["steps"] == 0
    assert res["spectrum"]["gap_lower_hz"] < res["spectrum"]["gap_upper_hz"]

