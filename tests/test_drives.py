"""Driven chains through the command line and the file: a recorded drive read from a CSV file or
an HDF5 file (an (n, 2) array or a group) beside the sweep file gives the very run its samples
written inline give (the same numbers, bit for bit); a harmonic actuator swept over frequency is
stored over that axis, every run's ledger closed with the drive's work; a drive's bad values and
a recording that cannot be read exit 2 naming the field, writing nothing."""

import copy
import json

import h5py
import numpy as np
import xarray as xr

from conftest import run

BALL = {
    "sphere": {
        "diameter_m": 0.008,
        "mass_kg": 0.002085,
        "material": {"youngs_modulus_pa": 200e9, "poisson_ratio": 0.28},
    }
}
STEEL_304 = {"youngs_modulus_pa": 193e9, "poisson_ratio": 0.29}


def sweep(excitation, axes=None, duration_s=1e-3, top_wall=False):
    chain = {"particles": {"ball": BALL}, "sequence": [{"repeat": 20, "of": ["ball"]}]}
    chain["wall_material"] = STEEL_304
    if top_wall:
        chain["top_wall_material"] = STEEL_304
    return {
        "description": "a driven chain",
        "base": {
            "chain": chain,
            "physics": {
                "gravity": False,
                "damping_kg_s": 2.0,
                "wall": True,
                "precompression_force_n": 20.0,
            },
            "excitation": excitation,
            "duration_s": duration_s,
            "integrator": {"method": "dop853", "rtol": 1e-10},
        },
        "record": {
            "probes": [
                {"kind": "contact_force", "contact": 1},
                {"kind": "contact_force", "contact": 20},
                {"kind": "displacement", "particle": 20},
            ],
            "history": True,
            "history_interval_s": 1e-5,
        },
        "axes": axes or [{"field": "physics.damping_kg_s", "values": [1.0, 2.0]}],
    }


def recording():
    t = np.linspace(0.0, 1.2e-3, 241)
    u = 5e-8 * np.sin(2 * np.pi * 4000 * t) * (1 - np.exp(-t / 2e-4))
    return t, u


def run_sweep(tmp_path, name, s):
    path = tmp_path / f"{name}.json"
    path.write_text(json.dumps(s))
    out = tmp_path / f"{name}.h5"
    r = run("run", path, "-o", out, "--quiet")
    return r, out


def test_a_recording_in_a_file_is_the_recording_inline(binary, tmp_path):
    t, u = recording()
    excitation = {"drive": {"base_m": {"recorded": {"times_s": t.tolist(), "values": u.tolist()}}}}
    r, inline = run_sweep(tmp_path, "inline", sweep(excitation))
    assert r.returncode == 0, r.stderr

    folder = tmp_path / "drives"
    folder.mkdir()
    np.savetxt(folder / "base.csv", np.column_stack([t, u]), delimiter=",", header="time_s,u_m",
               fmt="%.17g")
    with h5py.File(folder / "base.h5", "w") as f:
        f["array"] = np.column_stack([t, u])
        f["group/times_s"] = t
        f["group/values"] = u
    files = [
        {"path": "drives/base.csv"},
        {"path": "drives/base.h5", "dataset": "array"},
        {"path": "drives/base.h5", "dataset": "group"},
    ]
    with xr.open_dataset(inline) as ds:
        want = ds["history_N"].values, ds["history_m"].values
        assert np.nanmax(np.abs(want[0][:, 1, :] - 20.0)) > 0.1  # the drive reached the far end
    for k, recorded in enumerate(files):
        r, out = run_sweep(tmp_path, f"file{k}", sweep({"drive": {"base_m": {"recorded": recorded}}}))
        assert r.returncode == 0, (recorded, r.stderr)
        with xr.open_dataset(out) as ds:
            got = ds["history_N"].values, ds["history_m"].values
            for g, w in zip(got, want):
                np.testing.assert_array_equal(g, w, err_msg=str(recorded))


def test_a_frequency_sweep_of_an_actuator_is_stored_over_its_axis(binary, tmp_path):
    excitation = {
        "drive": {
            "actuator_m": {
                "harmonic": {"amplitude": 2e-7, "frequency_hz": 2000.0, "ramp_periods": 1}
            }
        }
    }
    frequencies = [1000.0, 3000.0, 9000.0]
    axes = [{"field": "excitation.drive.actuator_m.harmonic.frequency_hz", "values": frequencies}]
    s = sweep(excitation, axes, top_wall=True)
    r, out = run_sweep(tmp_path, "actuator", s)
    assert r.returncode == 0, r.stderr
    with xr.open_dataset(out) as ds:
        assert list(ds["frequency_hz"].values) == frequencies
        assert (ds["energy_drift_max"].values < 1e-6).all(), ds["energy_drift_max"].values
        top = ds["history_N"].values[:, 0, :]  # (frequency, time): contact 1's force
        # The top contact carries the precompression plus the drive's oscillation.
        assert np.nanmin(top) > 0 and abs(np.nanmean(top) / 20.0 - 1) < 0.2
        assert all(np.nanstd(top[k]) > 0.05 for k in range(3)), [np.nanstd(x) for x in top]


def test_bad_drives_exit_2_naming_the_field(binary, tmp_path):
    cases = [
        ({"drive": {"force_n": {"harmonic": {"amplitude": 1.0, "frequency_hz": -5.0}}}},
         "base.excitation.drive.force_n.harmonic.frequency_hz"),
        ({"drive": {"force_n": {"chirp": {"amplitude": 1.0, "start_hz": 10.0, "end_hz": 0.0,
                                          "duration_s": 1e-3}}}},
         "base.excitation.drive.force_n.chirp.end_hz"),
        ({"drive": {"force_n": {"recorded": {"path": "missing.csv"}}}},
         "base.excitation.drive.force_n.recorded.path"),
        ({"drive": {"base_m": {"recorded": {"times_s": [0.0, 2e-3, 1e-3], "values": [0, 0, 0]}}}},
         "base.excitation.drive.base_m.recorded.times_s[2]"),
        ({"drive": {"force_n": {"sum": {"tones": []}}}}, "base.excitation.drive.force_n.sum.tones"),
    ]
    (tmp_path / "bad.csv").write_text("0,1\n0.5e-3,x\n")
    cases.append(({"drive": {"force_n": {"recorded": {"path": "bad.csv"}}}},
                  "base.excitation.drive.force_n.recorded.path"))
    for excitation, field in cases:
        r, out = run_sweep(tmp_path, "bad", sweep(copy.deepcopy(excitation)))
        assert r.returncode == 2, (excitation, r.stderr)
        assert field in r.stderr, (field, r.stderr)
        assert not out.exists()


def test_the_driven_sweep_up_and_down_traces_the_resonance_and_its_hysteresis(binary, tmp_path):
    """sweeps/examples/driven-sweep-up-down.json: at the smallest stroke both chirps peak within
    1 % of the chain's lowest natural frequency (record.spectrum of the same chain); at the largest
    the response collapses at a higher frequency on the way up than on the way down."""
    from conftest import REPO

    example = REPO / "sweeps" / "examples" / "driven-sweep-up-down.json"
    out = tmp_path / "updown.h5"
    r = run("run", example, "-o", out, "--jobs", "2", "--quiet")
    assert r.returncode == 0, r.stderr
    s = json.loads(example.read_text())
    s["record"] = {"spectrum": {}}
    s["axes"] = [{"field": "duration_s", "values": [1e-3]}]
    spectrum_file = tmp_path / "spectrum.json"
    spectrum_file.write_text(json.dumps(s))
    r = run("point", spectrum_file, "0")
    assert r.returncode == 0, r.stderr
    lowest = json.loads(r.stdout)["result"]["spectrum"]["lowest_frequency_hz"]
    with xr.open_dataset(out) as ds:
        t = ds["time_s"].values
        duration = t[-1]
        assert (ds["energy_drift_max"].values < 1e-6).all()

        def envelope(stroke, start):
            end = float(ds["end_hz"].sel(start_hz=start))
            force = ds["history"].sel(amplitude_m=stroke, start_hz=start).values[0]
            w = 60
            n = len(force) // w
            env = np.abs(force[: n * w]).reshape(n, w).max(axis=1)
            f = (start + (end - start) * t / duration)[: n * w].reshape(n, w).mean(axis=1)
            return f, env

        small, large = ds["amplitude_m"].values[0], ds["amplitude_m"].values[-1]
        for start in ds["start_hz"].values:
            f, env = envelope(small, start)
            peak = f[np.argmax(env)]
            assert abs(peak / lowest - 1) < 0.01, (start, peak, lowest)

        def collapse(start):
            # Where the envelope falls below half its largest value on the high side.
            f, env = envelope(large, start)
            high = f > f[np.argmax(env)]
            falls = f[high & (env < 0.5 * env.max())]
            return falls.min()

        up, down = (collapse(s) for s in sorted(ds["start_hz"].values))
        assert up > down + 10.0, (up, down)


def test_the_dimer_transmits_in_its_bands_and_not_in_its_gap(binary, tmp_path):
    """sweeps/examples/dimer-transmission.json, each run's steady state against the same run's
    linear spectrum: in the acoustic band (below 0.8 of the gap's lower edge) the settled
    transmission is of order one (median within 10 dB of 0: a standing wave's node may fall on the
    probe at some frequency); well inside the gap (its middle 60 %) it is below -60 dB; the gap's
    edges rise with the precompression as F^(1/6)."""
    from conftest import REPO

    example = REPO / "sweeps" / "examples" / "dimer-transmission.json"
    out = tmp_path / "dimer.h5"
    r = run("run", example, "-o", out, "--jobs", "2", "--quiet")
    # Deep in the gap the far end's response stays below the slowest modes' ringing: those runs
    # are unsettled (exit 3), named, and nothing else is wrong.
    assert r.returncode == 3 and "did not settle" in r.stderr and "failed run" not in r.stderr, r.stderr
    with xr.open_dataset(out) as ds:
        assert ds["steady_transmission_db"].dims == ("precompression_force_n", "frequency_hz", "probe")
        f = ds["frequency_hz"].values
        lows = []
        for force in ds["precompression_force_n"].values:
            at = ds.sel(precompression_force_n=force)
            low, high = float(at["gap_lower_hz"][0]), float(at["gap_upper_hz"][0])
            lows.append(low)
            db = at["steady_transmission_db"].values[:, 1]
            settled = at["steady_settled"].values[:, 1] == 1
            band = (f < 0.8 * low) & settled
            assert band.sum() >= 3, force
            assert abs(np.median(db[band])) < 10, (force, db[band])
            gap = (f > low + 0.2 * (high - low)) & (f < high - 0.2 * (high - low))
            assert gap.sum() >= 1 and (db[gap] < -60).all(), (force, db[gap])
            # The reference probe's own transmission is 0 dB by definition.
            assert np.allclose(at["steady_transmission_db"].values[:, 0], 0.0)
        forces = ds["precompression_force_n"].values
        np.testing.assert_allclose(np.array(lows) / lows[0], (forces / forces[0]) ** (1 / 6), rtol=1e-9)


def test_an_output_of_a_recording_by_path_needs_no_file_beside_it(binary, tmp_path):
    """The output keeps the sweep with the recording's samples in it: after the recording file is
    gone, `status` reads the output as before (the sweep file, which names it, is refused, the
    output untouched); `validate` reads a sweep file's recording from its own folder whatever
    the working directory."""
    t, u = recording()
    folder = tmp_path / "study"
    folder.mkdir()
    np.savetxt(folder / "base.csv", np.column_stack([t, u]), delimiter=",")
    path = folder / "sweep.json"
    path.write_text(json.dumps(sweep({"drive": {"base_m": {"recorded": {"path": "base.csv"}}}})))
    r = run("validate", path, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    out = tmp_path / "out.h5"
    r = run("run", path, "-o", out, "--quiet", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    (folder / "base.csv").unlink()
    r = run("status", out, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    with h5py.File(out, "r") as f:
        text = f.attrs["sweep"]
        text = text.decode() if isinstance(text, bytes) else str(text)
    assert "base.csv" not in text and "times_s" in text
    # The sweep file itself still names the recording: running it again is refused, naming the
    # field, and the output is left as it was.
    before = out.read_bytes()
    r = run("run", path, "-o", out, "--quiet", cwd=tmp_path)
    assert r.returncode == 2 and "recorded.path" in r.stderr, r.stderr
    assert out.read_bytes() == before
