"""No NaN without a reason: a run that succeeds but ends before its leading pulse has passed a
probe leaves that probe's leading_peak NaN, and says so — per probe in the file (`leading_pulse`,
a CF flag), in `run`'s final summary, in `status` of the file and of the sweep, and in the
Datasets of `chainsweep.open` and `chainsweep.run`."""

import h5py
import numpy as np

import chainsweep
from conftest import base_sweep, run, write_sweep

NOT_PASSED = "ok run(s) have a NaN leading_peak: the leading pulse had not passed a probe"


def short_sweep():
    # 60 µs: the pulse passes cylinder 2 but has not passed cylinder 8 when the runs end.
    return base_sweep(duration_s=6e-5, probes=(2, 8))


def test_a_nan_leading_peak_carries_its_reason_per_probe(binary, tmp_path):
    path = write_sweep(tmp_path / "s.json", short_sweep())
    out = tmp_path / "a.h5"
    # Half the grid first: the other half pending, flagged "no run".
    r = run("run", path, "-o", out, "--shard", "1/2")
    assert r.returncode == 0, r.stderr
    with h5py.File(out) as f:
        status = f["status"][...]
        flags = f["leading_pulse"][...]
        assert (flags[status == 0] == 0).all()
        assert (status == 0).any()
    r = run("run", path, "-o", out)
    assert r.returncode == 0, r.stderr
    assert f"6 {NOT_PASSED}" in r.stderr
    with h5py.File(out) as f:
        peaks = f["leading_peak"][...]
        flags = f["leading_pulse"][...]
        assert (f["status"][...] == 1).all()
        meanings = f["leading_pulse"].attrs["flag_meanings"]
        assert meanings.split() == ["no_run", "passed", "not_passed_by_t_end"]
        assert list(f["leading_pulse"].attrs["flag_values"]) == [0, 1, 2]
    # Exactly the NaN peaks are flagged, and only at the far probe.
    assert np.isnan(peaks[..., 1]).all() and np.isfinite(peaks[..., 0]).all()
    np.testing.assert_array_equal(flags, np.where(np.isnan(peaks), 2, 1))

    # Run again: nothing to do, and the summary still says it (from the file as published).
    r = run("run", path, "-o", out)
    assert r.returncode == 0 and f"6 {NOT_PASSED}" in r.stderr, r.stderr
    for args in (("status", out), ("status", path, "-o", out)):
        r = run(*args)
        assert r.returncode == 0, r.stdout
        assert f"6 {NOT_PASSED}" in r.stdout, r.stdout

    ds = chainsweep.open(out)
    np.testing.assert_array_equal(ds["leading_pulse"].values, flags)
    assert ds["leading_pulse"].attrs["flag_meanings"] == "no_run passed not_passed_by_t_end"


def test_a_long_enough_run_says_nothing_and_flags_every_probe_passed(binary, tmp_path):
    # Probes the pulse passes well before the run ends (0.2 ms).
    path = write_sweep(tmp_path / "s.json", base_sweep(probes=(2, 4)))
    out = tmp_path / "a.h5"
    r = run("run", path, "-o", out)
    assert r.returncode == 0, r.stderr
    assert "NaN leading_peak" not in r.stderr
    with h5py.File(out) as f:
        assert (f["leading_pulse"][...] == 1).all()
    assert "NaN leading_peak" not in run("status", out).stdout


def test_chainsweep_run_flags_the_probe_it_could_not_measure(tmp_path):
    s = short_sweep()
    scene = dict(s["base"], record=s["record"])
    ds = chainsweep.run(scene)
    assert list(ds["leading_pulse"].values) == [1, 2]
    assert np.isnan(ds["leading_peak"].values[1])
    assert ds["leading_pulse"].attrs["flag_meanings"] == "no_run passed not_passed_by_t_end"
