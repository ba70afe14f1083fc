"""Long chains integrated only where they move (the solver's `active_region`, issue 13): a sweep
file may switch it off, the default leaves run hashes as they were, and `--verify` (the runner's
re-run at a hundred times tighter tolerance) passes with it on, with errors like the whole chain's."""

import copy

import h5py
import numpy as np

from conftest import base_sweep, run, with_axes, write_sweep


def long_sweep():
    """The 0.55 chain with 300 cylinders (601 particles: long enough to qualify), mu = 6 kg/s,
    0.5 ms, rtol 1e-7, the moving part against the whole chain."""
    s = base_sweep(cylinders=300, duration_s=5e-4, probes=(4, 21))
    s["base"]["physics"]["damping_kg_s"] = 6.0
    s["base"]["integrator"]["rtol"] = 1e-7
    return with_axes(s, [{"field": "active_region", "values": ["auto", "off"]}])


def test_verify_passes_with_the_moving_part_only(tmp_path):
    path = write_sweep(tmp_path / "long.json", long_sweep())
    out = tmp_path / "long.h5"
    r = run("run", path, "-o", out, "--verify", "1", "--jobs", "2")
    assert r.returncode == 0, r.stderr
    with h5py.File(out, "r") as f:
        assert list(f["status"][...]) == [1, 1]
        assert list(f["verified"][...]) == [1, 1]
        err = f["verify_rel_error_max"][...]
        peaks = f["leading_peak"][...]
    auto, off = err
    # The moving part is as accurate as the whole chain against the tighter re-run.
    assert auto <= 3 * off + 1e-7, (auto, off)
    assert off < 1e-4
    np.testing.assert_allclose(peaks[0], peaks[1], rtol=1e-5)


def test_default_leaves_the_run_hash_and_off_changes_it(tmp_path):
    s = long_sweep()
    plain = copy.deepcopy(s)
    plain["axes"] = [{"field": "duration_s", "values": [5e-4]}]
    explicit = copy.deepcopy(plain)
    explicit["base"]["active_region"] = "auto"
    off = copy.deepcopy(plain)
    off["base"]["active_region"] = "off"
    hashes = []
    for name, sweep in (("plain", plain), ("explicit", explicit), ("off", off)):
        r = run("run", write_sweep(tmp_path / f"{name}.json", sweep), "--dry-run")
        assert r.returncode == 0, r.stderr
        hashes.append(r.stdout.strip().splitlines()[-1].split()[-1])
    assert hashes[0] == hashes[1]
    assert hashes[2] != hashes[0]


def test_bad_value_names_the_field_and_the_allowed_values(tmp_path):
    s = long_sweep()
    s["base"]["active_region"] = "sometimes"
    s["axes"] = [{"field": "duration_s", "values": [5e-4]}]
    r = run("validate", write_sweep(tmp_path / "bad.json", s))
    assert r.returncode == 2
    assert "active_region" in r.stderr and "auto" in r.stderr and "off" in r.stderr, r.stderr
