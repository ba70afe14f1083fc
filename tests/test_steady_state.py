"""Steady-state observables (`record.steady_state`) end to end: five equal masses on linear
springs between two walls, precompressed, started in one normal mode of the fixed–fixed chain,
oscillate at exactly the mode's frequency, so the stored mean, RMS, amplitude and phase of each
probe have closed forms (1e-8); a sweep over the amplitude of a second mode started beside the
first leaves the window's halves different (not settled, flagged, warned); the columns read back
exactly labelled through h5py, both xarray engines, chainsweep.open and chainsweep.run, and a
changed value is reported as damage;
`--dry-run` counts their bytes; resume and shard merge give the file bit for bit; bad values exit
2 naming the field."""

import json
import math
import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest
import xarray as xr

import chainsweep

from conftest import REPO, assert_resume_and_merge_bitwise, run, write_sweep

N = 5
MASS_KG = 0.004
K_N_PER_M = 1e6
PRELOAD_N = 10.0
D_M = 2e-6  # a fifth of the static overlap: no contact opens
HARMONICS = 3


def omega(mode):
    return 2 * math.sqrt(K_N_PER_M / MASS_KG) * math.sin(mode * math.pi / (2 * (N + 1)))


def shape(mode, i):
    return math.sin(mode * i * math.pi / (N + 1))


F1_HZ = omega(1) / (2 * math.pi)
PROBES = [
    {"kind": "displacement", "particle": 2},
    {"kind": "velocity", "particle": 3},
    {"kind": "contact_force", "contact": 1},
    {"kind": "wall_force"},
]


def sweep(second=(0.0, 0.5)):
    """The chain in mode 1 (amplitude D_M) plus mode 2 at `second` × D_M (an axis over the
    displacement of each particle, zipped), analysed at mode 1 over 10 periods after 2."""
    linear = {"power_law": {"coefficient": K_N_PER_M, "exponent": 1.0}}
    steel = {"youngs_modulus_pa": 2e11, "poisson_ratio": 0.3}

    def state(b):
        return [D_M * (shape(1, i) + b * shape(2, i)) for i in range(1, N + 1)]

    return {
        "description": "steady state of a linear chain between two walls",
        "base": {
            "chain": {
                "particles": {"ball": {"sphere": {"diameter_m": 0.01, "mass_kg": MASS_KG,
                                                  "material": steel}}},
                "sequence": [{"repeat": N, "of": ["ball"]}],
                "top_wall_material": steel,
                "contacts": [
                    {"between": ["ball", "ball"], "law": linear},
                    {"between": ["ball", "wall"], "law": linear},
                    {"between": ["ball", "top_wall"], "law": linear},
                ],
            },
            "physics": {"gravity": False, "damping_kg_s": 0.0, "wall": True,
                        "precompression_force_n": PRELOAD_N},
            "excitation": {"initial_state": {"particles": [
                {"particle": i, "displacement_m": d} for i, d in enumerate(state(0.0), 1)]}},
            "duration_s": 12 / F1_HZ,
            "integrator": {"method": "dop853", "rtol": 1e-13},
        },
        "record": {
            "probes": PROBES,
            "steady_state": {"frequency_hz": F1_HZ, "settle_periods": 2, "window_periods": 10,
                             "harmonics": HARMONICS, "reference_probe": 1},
        },
        "axes": [{
            "name": "second_mode",
            "zip": [{"field": f"excitation.initial_state.particles[{i - 1}].displacement_m",
                     "name": f"displacement_{i}_m",
                     "values": [state(b)[i - 1] for b in second]} for i in range(1, N + 1)],
        }],
    }


def closed_form():
    """(mean, amplitude, phase) of each probe in mode 1 alone."""
    w, a = omega(1), (lambda i: D_M * shape(1, i))
    return [
        (0.0, a(2), 0.0),
        (0.0, a(3) * w, math.pi / 2),
        (PRELOAD_N, K_N_PER_M * (a(2) - a(1)), math.pi),
        (PRELOAD_N, K_N_PER_M * a(N), 0.0),
    ]


def wrapped(x):
    return (np.asarray(x) + math.pi) % (2 * math.pi) - math.pi


@pytest.fixture(scope="module")
def swept(tmp_path_factory, binary):
    d = tmp_path_factory.mktemp("steady")
    path = write_sweep(d / "s.json", sweep())
    out = d / "s.h5"
    r = run("run", path, "-o", out, "--quiet")
    # The second point did not settle: not ok, counted apart, named with the remedy.
    assert r.returncode == 3, r.stderr
    assert "1 run(s) did not settle" in r.stderr and "settle_periods" in r.stderr, r.stderr
    assert "unsettled: point 1 (displacement_1_m=" in r.stderr, r.stderr
    # (The leading pulse is no question a steady-state sweep asks: no hint about it.)
    assert "leading_peak" not in r.stderr, r.stderr
    return path, out


def check_mode_one(mean, rms, amp, phase, settled, transmission):
    """The first point (mode 1 alone) against the closed forms."""
    for p, (m, a, ph) in enumerate(closed_form()):
        assert abs(amp[p][0] - a) < 1e-8 * a, (p, amp[p][0], a)
        assert abs(rms[p] - math.sqrt(m * m + a * a / 2)) < 1e-8 * math.sqrt(m * m + a * a / 2)
        assert abs(mean[p] - m) < 1e-8 * a, (p, mean[p], m)
        assert abs(wrapped(phase[p][0] - ph)) < 1e-8, (p, phase[p][0], ph)
        assert (np.abs(amp[p][1:]) < 1e-8 * a).all(), amp[p]
        assert settled[p] == 1
    forms = closed_form()
    db = 20 * math.log10(forms[3][1] / forms[1][1])
    assert transmission[1] == 0.0
    assert abs(transmission[3] - db) < 1e-7


def test_h5py_reads_the_closed_forms_and_the_layout(swept):
    _, out = swept
    with h5py.File(out, "r") as f:
        # The probes' units differ: one variable per unit, NaN at the probes of the others.
        assert "steady_amplitude" not in f
        amp = f["steady_amplitude_m"]
        assert amp.shape == (2, 4, HARMONICS)
        assert [d[0].name for d in amp.dims] == ["/second_mode", "/probe", "/harmonic"]
        assert f["harmonic"][()].tolist() == [1, 2, 3]
        assert f["steady_phase_rad"].attrs["units"] == "rad"
        assert f["steady_frequency_hz"].attrs["units"] == "Hz"
        assert f["steady_settledness"].attrs["units"] == "1"
        assert f["steady_settled"].attrs["flag_meanings"] == "no_run settled not_settled"
        assert f["steady_amplitude_m_per_s"].attrs["units"] == "m/s"
        assert np.isnan(f["steady_amplitude_m_per_s"][0, 0]).all()
        np.testing.assert_array_equal(f["steady_frequency_hz"][()], [F1_HZ, F1_HZ])
        amp_by_probe = np.stack([f[f"steady_amplitude_{u}"][0, p] for p, u in
                                 enumerate(["m", "m_per_s", "N", "N"])])
        mean = [f[f"steady_mean_{u}"][0, p] for p, u in enumerate(["m", "m_per_s", "N", "N"])]
        rms = [f[f"steady_rms_{u}"][0, p] for p, u in enumerate(["m", "m_per_s", "N", "N"])]
        check_mode_one(mean, rms, amp_by_probe, f["steady_phase_rad"][0],
                       f["steady_settled"][0], f["steady_transmission_db"][0])
        # Mode 2 beside it: the window's halves differ, the flag says so, the warning too;
        # particle 3 is a node of mode 2 (sin(2·3π/6) = 0) and contact 1 does not strain in it
        # (sin(2π/6) = sin(4π/6)): their probes read mode 1 alone, and have settled.
        moving, still = [0, 3], [1, 2]
        assert f["steady_settled"][1].tolist() == [2, 1, 1, 2]
        assert (f["steady_settledness"][1][moving] > 1e-2).all(), f["steady_settledness"][1]
        assert (f["steady_settledness"][1][still] < 1e-10).all(), f["steady_settledness"][1]
        warnings = f["warnings"][1].tobytes().decode().rstrip("\0")
        assert "record.steady_state: not settled" in warnings, warnings
        assert "velocity_p3" not in warnings and "contact_force_1" not in warnings, warnings
        assert "displacement_p2" in warnings and "wall_force" in warnings, warnings
        assert "record.steady_state" not in f["warnings"][0].tobytes().decode()
        assert f["status"][()].tolist() == [1, 3]
        assert f["status"].attrs["flag_meanings"] == "pending ok failed unsettled"
        assert (int(f.attrs["n_ok"]), int(f.attrs["n_unsettled"])) == (1, 1)


def test_an_unsettled_run_is_counted_apart_everywhere(swept, tmp_path):
    """`status` (text and --json), chainsweep.sweep and chainsweep.open count the run whose
    steady state did not settle apart from the ok ones, and a driven-free hint about leading
    peaks is not printed for it."""
    path, out = swept
    r = run("status", out)
    assert r.returncode == 3, r.stdout + r.stderr
    assert "(1 ok, 1 unsettled, 0 failed)" in r.stdout, r.stdout
    assert "lengthen record.steady_state.settle_periods" in r.stdout, r.stdout
    j = json.loads(run("status", out, "--json").stdout)
    assert j["counts"] == {"ok": 1, "unsettled": 1, "failed": 0, "pending": 0}, j["counts"]
    assert j["unsettled"] == {"runs": 1, "points": [1]}, j["unsettled"]
    res = chainsweep.sweep(path, out, progress=False)
    assert (res.exit_code, res.n_ok, res.n_unsettled, res.unsettled) == (3, 1, 1, [1])
    assert not res.complete
    ds = chainsweep.open(out)
    assert ds.status.values.tolist() == [1, 3]
    assert ds.status.attrs["flag_meanings"] == "pending ok failed unsettled"


def test_lengthening_the_settling_as_the_message_says_gives_a_settled_run_in_the_same_file(tmp_path):
    """The remedy the message gives works: the damped, driven chain of driven-branches.json
    measured after 3 periods has not settled (exit 3); after 150, in the same output file, the
    run is new and ok (exit 0), and nothing else is counted."""
    s = json.loads((REPO / "sweeps" / "examples" / "driven-branches.json").read_text())
    del s["periodic"]
    s["axes"][0]["values"] = [1e-10]
    out = tmp_path / "out.h5"
    for settle, code in ((3, 3), (150, 0)):
        s["record"]["steady_state"] = {"window_periods": 2, "harmonics": 3, "settle_periods": settle}
        s["base"]["duration_s"] = (settle + 22) / 2900.0 * 1.0001
        r = run("run", write_sweep(tmp_path / f"s{settle}.json", s), "-o", out)
        assert r.returncode == code, r.stderr
        if code:
            assert "lengthen record.steady_state.settle_periods" in r.stderr, r.stderr
            assert "health: 1 unsettled;" in r.stderr, r.stderr
    assert "1 runs: 1 ok, 0 failed" in r.stderr, r.stderr
    with h5py.File(out) as f:
        assert f["status"][()].tolist() == [1] and int(f["steady_settled"][()].min()) == 1


@pytest.mark.parametrize("engine", ["h5netcdf", "netcdf4"])
def test_xarray_labels_the_steady_state(swept, engine):
    _, out = swept
    with xr.open_dataset(out, engine=engine) as ds:
        assert ds.steady_phase_rad.dims == ("second_mode", "probe", "harmonic")
        assert ds.steady_phase_rad.attrs["units"] == "rad"
        assert ds.harmonic.values.tolist() == [1, 2, 3]
        assert ds.steady_settledness.dims == ("second_mode", "probe")
        v = ds.steady_amplitude_m_per_s.sel(probe="velocity_p3", harmonic=1).values[0]
        assert abs(v - closed_form()[1][1]) < 1e-8 * closed_form()[1][1]


def test_chainsweep_open_and_run_give_the_same_numbers(swept):
    path, out = swept
    ds = chainsweep.open(out)
    assert ds.steady_amplitude.dims == ("second_mode", "probe", "harmonic")
    first = ds.isel(second_mode=0)
    check_mode_one(first.steady_mean.values, first.steady_rms.values,
                   first.steady_amplitude.values, first.steady_phase_rad.values,
                   first.steady_settled.values, first.steady_transmission_db.values)
    s = json.loads(Path(path).read_text())
    r = chainsweep.run(s["base"], record=s["record"])
    assert r.steady_amplitude.dims == ("probe", "harmonic")
    assert r.steady_phase_rad.attrs["units"] == "rad"
    for name in ("steady_mean", "steady_rms", "steady_amplitude", "steady_phase_rad",
                 "steady_settledness", "steady_transmission_db", "steady_settled"):
        np.testing.assert_array_equal(r[name].values, first[name].values, err_msg=name)
    assert float(r.steady_frequency_hz) == F1_HZ


def test_chainsweep_point_prints_the_steady_state(swept):
    path, _ = swept
    r = run("point", path, "1")
    assert r.returncode == 0, r.stderr
    st = json.loads(r.stdout)["result"]["steady_state"]
    assert st["frequency_hz"] == F1_HZ
    assert [p["settled"] for p in st["probes"]] == [False, True, True, False]
    assert len(st["probes"][0]["amplitude"]) == HARMONICS


def test_dry_run_counts_the_steady_state_bytes(swept, tmp_path):
    path, _ = swept
    plain = json.loads(Path(path).read_text())
    del plain["record"]["steady_state"]
    plain_path = write_sweep(tmp_path / "plain.json", plain)
    sizes = []
    for p in (path, plain_path):
        r = run("run", p, "--dry-run", "--json", "-o", tmp_path / "new.h5")
        assert r.returncode == 0, r.stderr
        sizes.append(json.loads(r.stdout)["size_bytes"]["per_run_summaries"])
    # The frequency, and per probe four numbers, a flag and an amplitude and a phase per harmonic.
    assert sizes[0] - sizes[1] == 8 + 4 * (4 * 8 + 1 + 2 * HARMONICS * 8)


def test_resume_and_merge_keep_the_steady_state_bitwise(swept, tmp_path):
    assert_resume_and_merge_bitwise(*swept, tmp_path, exit_code=3)


def test_runs_without_the_steady_state_store_none(tmp_path, binary):
    s = sweep()
    del s["record"]["steady_state"]
    path = write_sweep(tmp_path / "s.json", s)
    out = tmp_path / "s.h5"
    assert run("run", path, "-o", out, "--quiet").returncode == 0
    with h5py.File(out, "r") as f:
        assert not [n for n in f if n.startswith("steady_") or n == "harmonic"]
    r = run("point", path, "0")
    assert "steady_state" not in json.loads(r.stdout)["result"]


@pytest.mark.parametrize(
    "edit, field",
    [
        ({"frequency_hz": None}, "record.steady_state.frequency_hz"),
        ({"frequency_hz": 0}, "record.steady_state.frequency_hz"),
        ({"frequency_hz": -5.0}, "record.steady_state.frequency_hz"),
        ({"window_periods": 1}, "record.steady_state.window_periods"),
        ({"window_periods": 11}, "record.steady_state.window_periods"),
        ({"window_periods": 10**12}, "record.steady_state.window_periods"),
        ({"harmonics": 0}, "record.steady_state.harmonics"),
        ({"harmonics": 65}, "record.steady_state.harmonics"),
        ({"samples_per_period": 6}, "record.steady_state.samples_per_period"),
        ({"settled_tolerance": 0}, "record.steady_state.settled_tolerance"),
        ({"reference_probe": 4}, "record.steady_state.reference_probe"),
        ({"spectral": True}, "record.steady_state"),
    ],
)
def test_bad_values_exit_2_naming_the_field(tmp_path, binary, edit, field):
    s = sweep()
    st = s["record"]["steady_state"]
    for key, value in edit.items():
        if value is None:
            del st[key]
        else:
            st[key] = value
    path = write_sweep(tmp_path / "s.json", s)
    for command in (["validate", path], ["run", path, "-o", tmp_path / "s.h5"]):
        r = run(*command)
        assert r.returncode == 2, (command, r.stderr)
        assert f"`{field}" in r.stderr, r.stderr
    assert not (tmp_path / "s.h5").exists()


def test_a_changed_steady_state_value_is_damage_never_served(swept, tmp_path):
    _, out = swept
    bad = tmp_path / "bad.h5"
    shutil.copy(out, bad)
    with h5py.File(bad, "r+") as f:
        d = f["steady_phase_rad"]
        values = d[()]
        values[1, 2, 0] += 1e-9
        d[...] = values
    with pytest.raises(chainsweep.DamagedFileError):
        chainsweep.open(bad)
    ds = chainsweep.open(bad, damaged="mask")
    assert ds.damaged.values.tolist() == [False, True]
    assert np.isnan(ds.steady_phase_rad.values[1]).all()
    assert not np.isnan(ds.steady_phase_rad.values[0]).any()
