"""`chainsweep run --verify FRACTION`: a deterministic sample of grid points re-run at a tighter
setting, the observed relative errors stored per point, resumable, and identical through shards."""

import json

import h5py
import numpy as np

from conftest import assert_files_equal, base_sweep, damage_frame, log_records, run, segment_count, write_sweep

VERIFY_PROBE = [
    "verify_rel_error_leading_peak",
    "verify_rel_error_leading_peak_time",
    "verify_rel_error_record_max",
]

def n_segments(out):
    """Runs stored: the grid runs (in the output file once complete) and the verification runs
    (kept in the work directory's log, since the file holds only their outcome)."""
    return segment_count(out)

def test_sample_is_deterministic_and_errors_are_stored(tmp_path, binary):
    sweep = base_sweep()
    outs = []
    for k in range(2):
        path = write_sweep(tmp_path / f"v{k}.json", sweep)
        out = tmp_path / f"v{k}.h5"
        r = run("run", path, "-o", out, "--verify", "0.5", "--jobs", "2")
        assert r.returncode == 0, r.stderr
        assert "verified at a tighter setting" in r.stderr
        # The health line ends the run, and status gives it too (text and --json).
        # (Two runs end before their far probe's pulse has passed: a NaN leading peak each.)
        assert "health: 2 with a NaN leading peak; 3 verified at a tighter setting, largest error bound" in r.stderr, r.stderr
        st = run("status", out)
        assert "health: 2 with a NaN leading peak; 3 verified" in st.stdout, st.stdout
        health = json.loads(run("status", out, "--json").stdout)["health"]
        assert health["verified"] == 3 and health["failed"] == 0 and health["unsettled"] == 0
        assert health["nan_leading_peak"] == 2
        assert 0 < health["largest_verified_error"]["bound"] < 1e-6
        outs.append(out)
    with h5py.File(outs[0], "r") as f, h5py.File(outs[1], "r") as g:
        v = f["verified"][...]
        assert v.shape == (3, 2) and v.dtype == np.uint8
        assert (v == 1).sum() == 3  # ceil(0.5 * 6)
        np.testing.assert_array_equal(v, g["verified"][...])
        assert float(f.attrs["verify_fraction"]) == 0.5
        assert int(f.attrs["n_verified"]) == 3
        for name in VERIFY_PROBE:
            e = f[name][...]
            assert e.shape == (3, 2, 2)
            assert np.isnan(e[v == 0]).all(), name
            ok = e[v == 1]
            # DOP853 at rtol 1e-9 against rtol 1e-11: errors far below 1e-6 where defined.
            assert (ok[np.isfinite(ok)] < 1e-6).all(), (name, ok)
        emax = f["verify_rel_error_max"][...]
        assert np.isfinite(emax[v == 1]).all() and np.isnan(emax[v == 0]).all()
        assert (emax[v == 1] > 0).all()
        assert [d[0].name for d in f["verify_rel_error_leading_peak"].dims] == [
            "/mass_ratio",
            "/damping_kg_s",
            "/probe",
        ]
    assert n_segments(outs[0]) == 6 + 3

def test_verification_resumes_and_stays(tmp_path, binary):
    path = write_sweep(tmp_path / "r.json", base_sweep())
    out = tmp_path / "r.h5"
    assert run("run", path, "-o", out, "--verify", "0.5", "--quiet").returncode == 0
    with h5py.File(out, "r") as f:
        first = f["verified"][...].copy()
        e_first = f["verify_rel_error_max"][...].copy()
    # Raising the fraction runs only the missing verifications.
    r = run("run", path, "-o", out, "--verify", "1", "--jobs", "2")
    assert r.returncode == 0, r.stderr
    assert "resuming" in r.stderr
    assert n_segments(out) == 12
    with h5py.File(out, "r") as f:
        assert (f["verified"][...] == 1).all()
        e = f["verify_rel_error_max"][...]
        np.testing.assert_array_equal(e[first == 1], e_first[first == 1])
    # Without --verify the verifications already made stay in the file: it holds every run
    # already, and is left as it is.
    r = run("run", path, "-o", out)
    assert r.returncode == 0 and "nothing to do" in r.stderr, r.stderr
    with h5py.File(out, "r") as f:
        assert (f["verified"][...] == 1).all()
        assert float(f.attrs["verify_fraction"]) == 1.0

def test_shards_and_merge_equal_single_run(tmp_path, binary):
    path = write_sweep(tmp_path / "m.json", base_sweep())
    single = tmp_path / "single.h5"
    assert run("run", path, "-o", single, "--verify", "0.5", "--quiet").returncode == 0
    parts = []
    for k in (1, 2):
        part = tmp_path / f"part-{k}.h5"
        r = run("run", path, "--shard", f"{k}/2", "-o", part, "--verify", "0.5", "--quiet")
        assert r.returncode == 0, r.stderr
        parts.append(part)
    merged = tmp_path / "merged.h5"
    r = run("merge", "-o", merged, *parts)
    assert r.returncode == 0, r.stderr
    assert_files_equal(single, merged)

def test_fixed_step_verification_sees_the_step_error(tmp_path, binary):
    sweep = base_sweep()
    sweep["axes"] = [
        {"field": "integrator", "values": [{"method": "verlet", "dt_s": 1e-7}, {"method": "dop853", "rtol": 1e-9}]}
    ]
    path = write_sweep(tmp_path / "rk.json", sweep)
    out = tmp_path / "rk.h5"
    r = run("run", path, "-o", out, "--verify", "1", "--quiet")
    assert r.returncode == 0, r.stderr
    with h5py.File(out, "r") as f:
        e = f["verify_rel_error_max"][...]
        assert (f["verified"][...] == 1).all()
        # Verlet at 0.1 us against 25 ns (second order): ~1e-5, far above DOP853's ~2e-8.
        assert e[0] > 100 * e[1], e

def test_bad_fraction_is_refused(tmp_path, binary):
    path = write_sweep(tmp_path / "b.json", base_sweep())
    for bad in ["1.5", "2", "nan"]:
        r = run("run", path, "-o", tmp_path / "b.h5", "--verify", bad)
        assert r.returncode == 2, (bad, r.stderr)
        assert "--verify" in r.stderr
    assert not (tmp_path / "b.h5").exists()


def test_a_corrupt_verification_record_is_recomputed(tmp_path, binary):
    """A verification record whose bytes were damaged is not counted as done;
    the next run computes it again and the point stays verified."""
    path = write_sweep(tmp_path / "c.json", base_sweep())
    out = tmp_path / "c.h5"
    assert run("run", path, "-o", out, "--verify", "0.5", "--quiet").returncode == 0
    with h5py.File(out, "r") as f:
        verified = f["verified"][...].copy()
        e_first = f["verify_rel_error_max"][...].copy()
    # After a complete run only the 3 verification records stay in the log: damage the second.
    recs = log_records(out)
    assert len(recs) == 3
    log = out.parent / (out.name + ".d") / "logs" / recs[0][0]
    data = bytearray(log.read_bytes())
    damage_frame(data, 1, 60, 0x10)
    log.write_bytes(bytes(data))
    assert len(log_records(out)) == 2
    r = run("run", path, "-o", out, "--verify", "0.5", "--jobs", "2")
    assert r.returncode == 0, r.stderr
    # Before the fix the damaged record counted as done and the point dropped to unverified.
    assert "3 point(s) verified" in r.stderr
    with h5py.File(out, "r") as f:
        np.testing.assert_array_equal(f["verified"][...], verified)
        np.testing.assert_array_equal(f["verify_rel_error_max"][...], e_first)
    assert len(log_records(out)) == 3


def thornton_sweep(rtol):
    """Ten spheres with Thornton's plastic contacts struck at 1 and 2 m/s: force probes whose peaks
    have a kink at their top, the energy flow and a history."""
    ball = {"sphere": {"diameter_m": 0.008, "mass_kg": 0.002085,
                       "material": {"youngs_modulus_pa": 2e11, "poisson_ratio": 0.28}}}
    plastic = {"thornton": {"yield_velocity_m_s": 0.05}}
    return {
        "description": "plastic chain",
        "base": {
            "chain": {"particles": {"ball": ball}, "sequence": [{"repeat": 10, "of": ["ball"]}],
                      "striker": "ball",
                      "contacts": [{"between": ["ball", "ball"], "law": plastic},
                                   {"between": ["ball", "wall"], "law": plastic}]},
            "physics": {"gravity": False, "damping_kg_s": 0.0, "wall": True},
            "striker_velocity_m_s": 1.0,
            "duration_s": 2e-4,
            "integrator": {"method": "dop853", "rtol": rtol},
        },
        "record": {"probes": [{"kind": "contact_force", "contact": c} for c in (1, 5, 11)],
                   "energy_flow": True, "history": True, "history_interval_s": 1e-6},
        "axes": [{"field": "striker_velocity_m_s", "values": [1.0, 2.0]}],
    }


def driven_sweep(rtol):
    """Six spheres on 5 N, damped, driven by a 3 kHz force: the steady state of three probes."""
    ball = {"sphere": {"diameter_m": 0.008, "mass_kg": 0.002085,
                       "material": {"youngs_modulus_pa": 2e11, "poisson_ratio": 0.28}}}
    return {
        "description": "driven chain",
        "base": {
            "chain": {"particles": {"ball": ball}, "sequence": [{"repeat": 6, "of": ["ball"]}]},
            "physics": {"gravity": False, "damping_kg_s": 5.0, "wall": True,
                        "precompression_force_n": 5.0},
            "excitation": {"drive": {"force_n": {"harmonic": {"amplitude": 1.0, "frequency_hz": 3000.0}}}},
            "duration_s": 0.03,
            "integrator": {"method": "dop853", "rtol": rtol},
        },
        "record": {"probes": [{"kind": "contact_force", "contact": 1}, {"kind": "contact_force", "contact": 3},
                              {"kind": "wall_force"}],
                   "steady_state": {"settle_periods": 60, "window_periods": 20, "harmonics": 3}},
        "axes": [{"field": "excitation.drive.force_n.harmonic.amplitude", "values": [0.5, 2.0]}],
    }


def true_relative_errors(f, g, name):
    """|f − g| / |g| of a summary column, g from a far tighter run."""
    a, b = f[name][...], g[name][...]
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(a == b, 0.0, np.abs(a - b) / np.abs(b))


def test_verify_bounds_the_true_error_of_every_summary_it_lists(tmp_path, binary):
    """At rtol 1e-7, `--verify 1` (the same sweep at rtol 1e-9) reports for every summary an error
    at least as large as its true error (against rtol 1e-12), and within a few times of it where
    that is above rounding: the peaks of plastic contacts (kinks), their times, the largest overlap,
    the energy flow, the steady state. What it does not compare is named."""
    pairs = [
        ("verify_rel_error_leading_peak", "leading_peak"),
        ("verify_rel_error_leading_peak_time", "leading_peak_time_s"),
        ("verify_rel_error_record_max", "record_max"),
        ("verify_rel_error_record_max_time", "record_max_time_s"),
        ("verify_rel_error_max_overlap", "max_overlap_m"),
    ]
    for make in (thornton_sweep, driven_sweep):
        outs = {}
        for rtol in (1e-7, 1e-12):
            path = write_sweep(tmp_path / f"{make.__name__}-{rtol}.json", make(rtol))
            out = tmp_path / f"{make.__name__}-{rtol}.h5"
            args = ["run", path, "-o", out] + (["--verify", "1"] if rtol == 1e-7 else [])
            r = run(*args)
            # (The driven chain's slowest modes may still ring: its runs may be unsettled.)
            assert r.returncode in (0, 3) and "failed" not in r.stderr.replace("0 failed", ""), r.stderr
            outs[rtol] = (out, r.stderr)
        out, stderr = outs[1e-7]
        with h5py.File(out, "r") as f, h5py.File(outs[1e-12][0], "r") as g:
            assert (f["verified"][...] == 1).all()
            checked = 0
            for column, summary in pairs:
                reported, true = f[column][...], true_relative_errors(f, g, summary)
                assert np.isfinite(reported).all(), column
                assert (reported >= true).all(), (column, reported, true)
                checked += reported.size
            if "steady_amplitude" in f:
                # The steady state's error: each harmonic's complex amplitude against the
                # fundamental's, mean and RMS against the RMS.
                amp_f, amp_g = f["steady_amplitude"][...], g["steady_amplitude"][...]
                ph_f, ph_g = f["steady_phase_rad"][...], g["steady_phase_rad"][...]
                z = np.abs(amp_f * np.exp(1j * ph_f) - amp_g * np.exp(1j * ph_g)).max(axis=-1)
                scale = np.maximum(amp_g[..., 0], g["steady_rms"][...])
                true = np.maximum(z, np.abs(f["steady_rms"][...] - g["steady_rms"][...])) / scale
                true = np.maximum(true, np.abs(f["steady_mean"][...] - g["steady_mean"][...]) / scale)
                reported = f["verify_rel_error_steady"][...]
                assert (reported >= true).all(), (reported, true)
                checked += reported.size
            if "energy_passed_max_j" in f:
                values = lambda h: np.concatenate(
                    [h[n][...].reshape(2, -1) for n in
                     ("energy_passed_max_j", "energy_passed_final_j", "max_kinetic_energy_j")], axis=1)
                a, b = values(f), values(g)
                true = np.nanmax(np.abs(a - b), axis=1) / np.nanmax(np.abs(b), axis=1)
                reported = f["verify_rel_error_energy_flow"][...]
                assert (reported >= true).all(), (reported, true)
                checked += reported.size
            assert checked > 0
            emax = f["verify_rel_error_max"][...]
            assert (emax > 1e-9).all() and (emax < 1e-3).all(), emax
        if make is thornton_sweep:
            assert "not verified: histories (not recorded by verification runs)" in stderr, stderr
        else:
            assert "not verified" not in stderr, stderr


def test_a_search_is_verified_at_its_evaluation_points(tmp_path, binary):
    """The evaluation points of a search (the sweep's axes and `evaluation`) are verified like
    grid points: their scenes are the sweep's with the searched values set, including a point
    whose scene the search could not build (stored failed, not verified)."""
    sweep = base_sweep()
    sweep["axes"] = [{"field": "striker_velocity_m_s", "values": [1.0, 1.3]}]
    sweep["search"] = {
        "goal": "minimise",
        "fields": [{"field": "physics.damping_kg_s", "min": 0.0, "max": 10.0, "tolerance": 0.05}],
        "objective": {"summary": "leading_peak", "probe": "gauge_force_cyl8"},
        "scan": 4,
        "budget": 12,
    }
    path = write_sweep(tmp_path / "s.json", sweep)
    out = tmp_path / "s.h5"
    r = run("run", path, "-o", out, "--verify", "1", "--jobs", "2")
    assert r.returncode == 0, r.stderr
    assert "panicked" not in r.stderr
    with h5py.File(out, "r") as f:
        v = f["verified"][...]
        st = f["status"][...]
        # Every stored evaluation run is verified, and its error is small at rtol 1e-9.
        assert ((v == 1) == (st == 1)).all(), (v, st)
        assert (v == 1).sum() >= 8
        e = f["verify_rel_error_max"][...]
        assert (e[v == 1] < 1e-6).all() and (e[v == 1] > 0).all()
