"""A sweep file's `periodic` block: at every point of the axes a branch of periodic orbits of the
driven chain, continued in the drive's frequency. The branch of a tiny stroke is the linear
resonance (its peak at the linear spectrum's first frequency); a large stroke folds twice, the
orbits between the folds unstable, each orbit periodic (its two periods agree); the file reads
in xarray and `chainsweep.open` exactly as labelled; a killed run resumes bitwise from its last
orbit, a damaged
journal line is never read (the branch goes on from the orbit before it) and a damaged output
is written again, never served; `status` and
`run --dry-run` say where it stands; bad blocks exit 2 naming the field."""

import copy
import json
import shutil
import signal
import subprocess
import time

import h5py
import numpy as np
import pytest
import xarray as xr

import chainsweep
from conftest import BIN, REPO, assert_files_equal, run

EXAMPLE = REPO / "sweeps" / "examples" / "driven-branches.json"


def example(strokes=(1e-10, 6e-8)):
    s = json.loads(EXAMPLE.read_text())
    s["axes"][0]["values"] = list(strokes)
    return s


def write(path, sweep):
    path.write_text(json.dumps(sweep, indent=2))
    return path


def kill_once_journaled(path, out, lines):
    """Runs `path` into `out` and kills it (SIGKILL) once a branch's journal holds more than
    `lines` lines, before the run ends."""
    journals = out.parent / f"{out.name}.d" / "periodic"
    p = subprocess.Popen([str(BIN), "run", str(path), "-o", str(out), "--jobs", "1", "--quiet"])
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and p.poll() is None:
        logs = list(journals.glob("*.log")) if journals.exists() else []
        if any(len(f.read_bytes().splitlines()) > lines for f in logs):
            break
        time.sleep(0.002)
    assert p.poll() is None, "the run ended before it could be killed"
    p.send_signal(signal.SIGKILL)
    p.wait()


@pytest.fixture(scope="module")
def branches(tmp_path_factory):
    d = tmp_path_factory.mktemp("periodic")
    path = write(d / "branches.json", example())
    out = d / "branches.h5"
    r = run("run", path, "-o", out, "--quiet")
    assert r.returncode == 0, r.stderr
    return path, out


def test_the_file_reads_in_xarray_as_labelled(branches):
    _, out = branches
    ds = xr.open_dataset(out, engine="h5netcdf")
    assert ds["frequency_hz"].dims == ("amplitude_m", "branch_point")
    assert ds["frequency_hz"].attrs["units"] == "Hz"
    assert ds["frequency_hz"].attrs["field"] == "excitation.drive.actuator_m.harmonic.frequency_hz"
    assert ds["orbit_amplitude"].dims == ("amplitude_m", "branch_point", "probe", "harmonic")
    assert ds["orbit_amplitude"].attrs["units"] == "N"
    assert list(ds["harmonic"].values) == [1, 2, 3]
    assert ds["multiplier_real"].sizes["multiplier"] == 16  # 8 particles: positions, velocities
    assert ds["point_kind"].attrs["flag_meanings"].split()[4] == "fold"
    assert ds["stability"].attrs["flag_meanings"] == "none stable unstable"
    assert [str(x) for x in ds["probe"].values] == ["wall_force"]
    opened = chainsweep.open(out)
    for name in ds.data_vars:
        np.testing.assert_array_equal(opened[name].values, ds[name].values)


def test_a_tiny_stroke_s_branch_peaks_at_the_linear_first_frequency(branches):
    path, out = branches
    ds = chainsweep.open(out).sel(amplitude_m=1e-10)
    n = int(ds["branch_points"])
    f = ds["frequency_hz"].values[:n]
    amplitude = ds["orbit_amplitude"].values[:n, 0, 0]
    # The continuation moves the frequency forwards only: no fold in a linear response.
    assert np.all(np.diff(f) > 0)
    assert f[0] == 2900.0 and f[-1] == 3500.0
    assert not np.any(ds["point_kind"].values[:n] >= 4)
    assert np.all(ds["stability"].values[:n] == 1)
    base = json.loads(path.read_text())["base"]
    linear = chainsweep.spectrum(base)["frequency_hz"][0]
    # The peak of the discrete curve lies within a step of the damped resonance, which the light
    # damping (3 kg/s) puts within 0.1 % of the undamped first frequency.
    peak = f[np.argmax(amplitude)]
    steps = np.diff(f)[max(np.argmax(amplitude) - 1, 0):np.argmax(amplitude) + 1].max()
    assert abs(peak - linear) <= steps + 1e-3 * linear, (peak, linear, steps)


def test_a_large_stroke_folds_twice_unstable_between_and_every_orbit_is_periodic(branches):
    _, out = branches
    ds = chainsweep.open(out).sel(amplitude_m=6e-8)
    n = int(ds["branch_points"])
    kind = ds["point_kind"].values[:n]
    f = ds["frequency_hz"].values[:n]
    folds = np.flatnonzero(kind == 4)
    assert len(folds) == 2, kind
    upper, lower = f[folds]
    # A stiffening resonance: the branch turns back at the upper fold and forward at the lower.
    assert upper > lower
    assert np.all(np.diff(f[: folds[0] + 1]) > 0) and np.all(np.diff(f[folds[0]: folds[1] + 1]) < 0)
    stable = ds["stability"].values[:n]
    regular = (kind == 1)
    between = np.zeros(n, bool)
    between[folds[0] + 1: folds[1]] = True
    assert np.all(stable[regular & between] == 2)
    assert np.all(stable[regular & ~between] == 1)
    # At a fold a multiplier is 1.
    assert np.allclose(ds["largest_multiplier"].values[:n][folds], 1.0, atol=1e-2)
    # The two periods of each orbit's run agree: periodic to the tolerance.
    assert np.nanmax(ds["orbit_settledness"].values[:n]) < 1e-6
    assert (ds["branch_end"].values == "reached the end of the range at 3500").all()


def test_status_and_dry_run_say_where_it_stands(branches, tmp_path):
    path, out = branches
    r = run("status", out)
    assert r.returncode == 0, r.stderr
    assert "2 branch(es) of periodic orbits: 2 ended, 0 failed, 0 pending" in r.stdout
    assert "fold at 3357.08" in r.stdout
    r = run("status", out, "--json")
    s = json.loads(r.stdout)
    assert s["kind"] == "status_periodic" and s["counts"]["ok"] == 2
    assert [k["kind"] for k in s["branches"][1]["special"]] == ["fold", "fold"]
    r = run("run", path, "-o", tmp_path / "new.h5", "--dry-run")
    assert r.returncode == 0, r.stderr
    assert "branches: 2 (one per grid point), 0 ended already" in r.stdout
    assert "with its monodromy (variational)" in r.stdout
    assert not (tmp_path / "new.h5").exists()
    r = run("status", path, "-o", tmp_path / "new.h5")
    assert r.returncode == 3 and "not run yet" in r.stdout


def test_report_draws_the_branches_with_their_unstable_parts_dashed(branches, tmp_path):
    _, out = branches
    page = tmp_path / "page.html"
    r = run("report", out, "-o", page)
    assert r.returncode == 0, r.stderr
    assert "2 figure(s)" in r.stderr
    html = page.read_text()
    assert "2 branch(es) of periodic orbits: 2 ended" in html
    assert "fold at 3357" in html and "fold at 3354" in html
    # The unstable orbits between the folds: a dashed part of the 60 nm curve.
    assert 'stroke-dasharray="5,3"' in html
    assert "http://" not in html.replace("http://www.w3.org/2000/svg", "")
    r = run("report", out, "--format", "svg", "-o", tmp_path / "figures")
    assert r.returncode == 0, r.stderr
    assert len(list((tmp_path / "figures").glob("*.svg"))) == 2


def test_a_killed_run_resumes_bitwise_from_its_last_orbit_and_past_a_damaged_journal_line(
    branches, tmp_path
):
    path, reference = branches
    out = tmp_path / "killed.h5"
    journals = tmp_path / "killed.h5.d" / "periodic"
    # Killed once the first branch's journal holds a few orbits, before the end.
    kill_once_journaled(path, out, 5)
    assert not out.exists()
    killed = {f.name: f.read_bytes().splitlines()[:5] for f in journals.glob("*.log")}
    r = run("run", path, "-o", out, "--quiet")
    assert r.returncode == 0, r.stderr
    assert_files_equal(reference, out)
    # It went on from the orbits the journals held, which it kept as they were.
    for name, lines in killed.items():
        assert (journals / name).read_bytes().splitlines()[: len(lines)] == lines
    # A flipped byte in the middle of an ended journal: that branch goes on from the last orbit
    # before the damaged line, the output the same bits.
    log = journals / "1.log"
    data = bytearray(log.read_bytes())
    data[len(data) // 2] ^= 0x20
    log.write_bytes(bytes(data))
    r = run("run", path, "-o", out)
    assert r.returncode == 0, r.stderr
    assert "1 of 2 runs already done" in r.stderr
    assert_files_equal(reference, out)


def test_an_end_point_whose_end_line_was_lost_is_stepped_to_again_not_repeated(branches, tmp_path):
    """Killed between the journal's end point and its `end` line (or that line torn or damaged):
    the branch goes on from the orbit before the end point, which gives the end point again,
    and the file is the uninterrupted run's (the end point has no step to go on with: resumed
    from it the branch repeated it up to max_points)."""
    path, reference = branches
    out = tmp_path / "torn.h5"
    shutil.copy(reference, out)
    shutil.copytree(reference.parent / f"{reference.name}.d", tmp_path / "torn.h5.d")
    for cut in (None, 20):
        for log in (tmp_path / "torn.h5.d" / "periodic").glob("*.log"):
            lines = log.read_bytes().splitlines(keepends=True)
            assert b' {"end":' in lines[-1], lines[-1][:80]
            kept = b"".join(lines[:-1])
            log.write_bytes(kept if cut is None else kept[:-cut])
        r = run("run", path, "-o", out, "--quiet")
        assert r.returncode == 0, r.stderr
        assert_files_equal(reference, out)


def test_an_undamped_chain_s_orbits_are_neutrally_stable_and_pass_no_bifurcation(tmp_path):
    """Without dissipation every multiplier lies on the unit circle, to rounding: each orbit is
    stable (perturbations do not grow), none is unstable by the last bit, and a linear
    response passes no Neimark–Sacker point."""
    s = example(strokes=(1e-10,))
    s["base"]["physics"]["damping_kg_s"] = 0.0
    s["periodic"].update(to=3100.0, step=10.0)
    path = write(tmp_path / "undamped.json", s)
    out = tmp_path / "undamped.h5"
    r = run("run", path, "-o", out, "--quiet")
    assert r.returncode == 0, r.stderr
    with h5py.File(out) as f:
        kinds = dict(zip(f["point_kind"].attrs["flag_meanings"].split(), f["point_kind"].attrs["flag_values"]))
        kind = f["point_kind"][()]
        real = kind > 0
        assert real.sum() > 10
        assert np.abs(f["largest_multiplier"][()][real] - 1.0).max() < 1e-9
        assert (f["stability"][()][real] == 1).all(), f["stability"][()]
        assert not (kind == kinds["neimark_sacker"]).any()


def test_a_wall_on_a_spring_keeps_its_state_out_of_the_particles(tmp_path):
    """The orbit's state of a chain on a mounted wall holds the wall's displacement and velocity
    after the particles': `particle` counts the particles, their positions and velocities are
    theirs (the wall's is its probe's)."""
    s = example(strokes=(1.5e-9,))
    s["base"]["chain"]["sequence"] = [{"repeat": 3, "of": ["ball"]}]
    s["base"]["chain"]["wall_mount"] = {"mass_kg": 0.1, "stiffness_n_m": 2e8, "damping_kg_s": 50}
    s["record"]["probes"].append({"kind": "mount_displacement"})
    s["periodic"].update(to=3000.0, step=20.0, max_points=4)
    path = write(tmp_path / "mount.json", s)
    out = tmp_path / "mount.h5"
    r = run("run", path, "-o", out, "--quiet")
    assert r.returncode == 0, r.stderr
    ds = chainsweep.open(out)
    assert ds.sizes["particle"] == 3
    assert np.isfinite(ds.orbit_velocity_m_s.where(ds.point_kind > 0, 0.0)).all()


def test_a_damaged_output_is_reported_never_served_and_written_again(branches, tmp_path):
    path, reference = branches
    out = tmp_path / "damaged.h5"
    assert run("run", path, "-o", out, "--quiet").returncode == 0
    with h5py.File(out, "r") as f:
        offset = f["largest_multiplier"].id.get_offset()
        assert offset is None or offset > 0
        chunk = f["largest_multiplier"].id.get_chunk_info(0)
    data = bytearray(out.read_bytes())
    data[chunk.byte_offset + 5] ^= 0x01
    out.write_bytes(bytes(data))
    with pytest.raises(chainsweep.DamagedFileError, match="largest_multiplier"):
        chainsweep.open(out)
    r = run("status", out)
    assert r.returncode == 3 and "damaged" in r.stdout, r.stdout
    r = run("run", path, "-o", out, "--quiet")
    assert r.returncode == 0, r.stderr
    assert_files_equal(reference, out)


def chirp(s):
    """The drive a chirp (no single period), its start frequency continued."""
    s["base"]["excitation"]["drive"]["actuator_m"] = {
        "chirp": {"amplitude": 1e-9, "start_hz": 2900.0, "end_hz": 3000.0, "duration_s": 0.02}
    }
    s["periodic"]["field"] = "excitation.drive.actuator_m.chirp.start_hz"


def test_a_far_end_is_checked_as_the_continuation_builds_its_scene(tmp_path):
    """The far end's scene is the continuation's (its own record and duration): 60 Hz, whose
    steady-state window would not fit the base scene's duration, is a branch's end all the same."""
    s = example()
    s["periodic"]["to"] = 60.0
    r = run("validate", write(tmp_path / "far.json", s))
    assert r.returncode == 0, r.stdout + r.stderr


@pytest.mark.parametrize(
    "change, field",
    [
        (lambda s: s["periodic"].update(to=2900.0), "periodic.to"),
        (lambda s: s["periodic"].update(periods=0), "periodic.periods"),
        (lambda s: s["periodic"].update(field="physics.no_such_field"), "periodic.field"),
        (lambda s: s["periodic"].update(bogus=1), "periodic"),
        (lambda s: s["axes"].append({"field": s["periodic"]["field"], "values": [3000.0]}),
         "periodic.field"),
        (lambda s: s.update(continuation={"axis": "amplitude_m"}), "periodic"),
        (lambda s: chirp(s), "base.excitation.drive.actuator_m"),
        (lambda s: s["periodic"].update({"from": 2900.0}), "periodic.from"),
        (lambda s: s["periodic"].pop("field"), "periodic.field"),
        # A far end the scene refuses (no negative frequency), caught before a branch walks
        # towards it for minutes.
        (lambda s: s["periodic"].update(to=-100.0), "periodic.to"),
        (lambda s: s["periodic"].update(settle_periods=0), "periodic.settle_periods"),
    ],
)
def test_bad_periodic_blocks_exit_2_naming_the_field(tmp_path, change, field):
    s = copy.deepcopy(example())
    change(s)
    path = write(tmp_path / "bad.json", s)
    r = run("validate", path)
    assert r.returncode == 2, r.stdout + r.stderr
    assert f"`{field}" in r.stderr, r.stderr
    r = run("run", path, "-o", tmp_path / "bad.h5", "--quiet")
    assert r.returncode == 2 and not (tmp_path / "bad.h5").exists()


def test_the_python_package_runs_a_periodic_sweep_and_counts_its_branches(tmp_path):
    r = chainsweep.sweep(example(strokes=(6e-8,)), tmp_path / "py.h5", progress=False)
    assert (r.exit_code, r.n_runs, r.n_ok, r.n_failed, r.n_pending) == (0, 1, 1, 0, 0)
    assert r.complete and r.failures == []
    ds = r.open()
    assert int((ds["point_kind"] == 4).sum()) == 2


def test_shards_are_refused(tmp_path):
    path = write(tmp_path / "s.json", example())
    r = run("run", path, "-o", tmp_path / "s.h5", "--shard", "1/2", "--quiet")
    assert r.returncode == 2 and "--shard" in r.stderr, r.stderr


def shaken_sphere(switch: bool, start_f0: float, to_f0: float) -> dict:
    """A steel sphere pressed on a wall by 10 N, lightly damped, shaken by a 6 N force near twice
    its natural frequency f0: a parametric resonance whose tongue (about 1.96 to 2.03 f0) the
    branch of single-period orbits crosses, unstable inside it between two period doublings."""
    steel = {"youngs_modulus_pa": 2e11, "poisson_ratio": 0.28}
    base = {
        "chain": {
            "particles": {"ball": {"sphere": {"diameter_m": 0.008, "mass_kg": 0.002085, "material": steel}}},
            "sequence": [{"repeat": 1, "of": ["ball"]}],
            "wall_material": steel,
        },
        "physics": {"gravity": False, "damping_kg_s": 0.5, "wall": True, "precompression_force_n": 10.0},
        "excitation": {"drive": {"force_n": {"harmonic": {"amplitude": 6.0, "frequency_hz": 1.0, "ramp_periods": 5}}}},
        "duration_s": 1.0,
        "integrator": {"method": "dop853", "rtol": 1e-11},
    }
    f0 = chainsweep.spectrum(base)["frequency_hz"][0]
    base["excitation"]["drive"]["force_n"]["harmonic"]["frequency_hz"] = start_f0 * f0
    periodic = {
        "field": "excitation.drive.force_n.harmonic.frequency_hz",
        "to": to_f0 * f0,
        "settle_periods": 200,
        "tolerance": 1e-9,
        "max_points": 60,
    }
    if switch:
        periodic["switch"] = "period_doubling"
    return {
        "description": "a shaken sphere's period doubling",
        "base": base,
        "record": {"probes": [{"kind": "wall_force"}], "preload": "subtract",
                   "steady_state": {"window_periods": 2, "harmonics": 2}},
        "periodic": periodic,
    }, f0


def test_switch_at_a_period_doubling_stores_the_doubled_branch_and_resumes_bitwise(tmp_path):
    """`switch: period_doubling` stores, instead of the point's branch, the branch of twice the
    period that starts at its first period doubling: it starts where the point's own branch
    locates the doubling, bends into the tongue where the single-period orbits are unstable, and
    is stable there (a supercritical doubling); its orbits repeat after two drive periods. A
    killed run resumes bitwise; a range without a doubling fails the branch naming the switch."""
    single, f0 = shaken_sphere(False, 2.2, 1.8)
    out1 = tmp_path / "single.h5"
    assert run("run", write(tmp_path / "single.json", single), "-o", out1, "--quiet").returncode == 0
    one = chainsweep.open(out1)
    n1 = int(one["branch_points"])
    kind1, f1 = one["point_kind"].values[:n1], one["frequency_hz"].values[:n1]
    doubling_code = one["point_kind"].attrs["flag_meanings"].split().index("period_doubling")
    doublings = np.sort(f1[kind1 == doubling_code])[::-1]
    assert len(doublings) >= 2, kind1
    upper = doublings[0]

    doubled, _ = shaken_sphere(True, 2.2, 1.8)
    path = write(tmp_path / "doubled.json", doubled)
    out = tmp_path / "doubled.h5"
    r = run("run", path, "-o", out)
    assert r.returncode == 0, r.stderr
    ds = chainsweep.open(out)
    n = int(ds["branch_points"])
    f = ds["frequency_hz"].values[:n]
    kind = ds["point_kind"].values[:n]
    stable = ds["stability"].values[:n]
    assert n > 10, ds["branch_end"].values
    assert "2 drive periods per orbit" in ds.attrs["periodic"] and "period doubling" in ds.attrs["periodic"]
    # It starts at the doubling the single-period branch locates (within its first step), and
    # goes into the tongue, below the upper doubling, where it is stable.
    assert abs(f[0] - upper) < 0.36 * f0 / 50 + 1e-6 * f0, (f[0] / f0, upper / f0)
    inside = (f < upper - 1e-4 * f0) & (kind == 1)
    assert inside.sum() > 5
    assert np.all(stable[inside] == 1), stable
    # The single-period orbits at those frequencies are unstable.
    regular1 = kind1 == 1
    tongue1 = regular1 & (f1 < upper) & (f1 > doublings[1])
    assert np.all(one["stability"].values[:n1][tongue1] == 2)
    # Its orbits repeat after their two drive periods.
    assert np.nanmax(ds["orbit_settledness"].values[:n]) < 1e-6

    # Killed during the run, then run again: the same file, bit for bit.
    killed = tmp_path / "killed.h5"
    kill_once_journaled(path, killed, 6)
    assert run("run", path, "-o", killed, "--quiet").returncode == 0
    assert_files_equal(out, killed)

    # Above the tongue there is no doubling to switch at: the branch fails, saying why.
    none, _ = shaken_sphere(True, 2.5, 2.2)
    r = run("run", write(tmp_path / "none.json", none), "-o", tmp_path / "none.h5")
    assert r.returncode == 3, r.stderr
    assert "no period doubling to switch at" in r.stderr, r.stderr


STEEL = {"youngs_modulus_pa": 2e11, "poisson_ratio": 0.28}
BREATHERS = REPO / "sweeps" / "examples" / "dimer-breathers.json"


def pressed_sphere(displacement_m: float, periodic: dict) -> dict:
    """A steel sphere pressed on a wall by 10 N, no gravity, no damping, displaced from its
    static position by `displacement_m` towards the wall: free orbits of every amplitude."""
    return {
        "description": "a pressed sphere's backbone",
        "base": {
            "chain": {
                "particles": {"ball": {"sphere": {"diameter_m": 0.008, "mass_kg": 0.002085, "material": STEEL}}},
                "sequence": ["ball"],
                "wall_material": STEEL,
            },
            "physics": {"gravity": False, "damping_kg_s": 0.0, "wall": True, "precompression_force_n": 10.0},
            "excitation": {"initial_state": {"particles": [{"particle": 1, "displacement_m": displacement_m}]}},
            "duration_s": 1.0,
            "integrator": {"method": "dop853", "rtol": 1e-12},
        },
        "record": {"probes": [{"kind": "displacement", "particle": 1}, {"kind": "wall_force"}],
                   "preload": "subtract"},
        "periodic": {"autonomous": True, "tolerance": 1e-10, "max_iterations": 30, **periodic},
    }


def test_a_pressed_sphere_s_free_orbits_follow_the_weakly_nonlinear_backbone(tmp_path):
    """`autonomous`: the free orbits of a sphere pressed on a wall, continued in their frequency
    from about a fifth of the static overlap down towards the linear frequency. Each orbit's
    frequency shift against its fundamental amplitude `a` is that of the weakly nonlinear
    oscillator the Hertz force gives about the static overlap δ₀ (Lindstedt–Poincaré,
    `ω − ω₀ = −ω₀ a²/(24 δ₀²)`, the test of the solver's backbone), to the order it holds: the
    relative error within ε² = (a/δ₀)² and falling with it; every orbit periodic, stable, the
    frequencies those asked for."""
    base = pressed_sphere(1e-9, {})["base"]
    f0 = chainsweep.spectrum(base)["frequency_hz"][0]
    w0 = 2 * np.pi * f0
    # K = m ω₀² = (3/2) F/δ₀ for a Hertz contact under F.
    delta0 = 1.5 * 10.0 / (0.002085 * w0**2)
    sweep = pressed_sphere(0.2 * delta0, {"from": 13084.0, "to": 13105.0, "step": 1.0})
    out = tmp_path / "backbone.h5"
    r = run("run", write(tmp_path / "backbone.json", sweep), "-o", out)
    assert r.returncode == 0, r.stderr
    ds = chainsweep.open(out)
    n = int(ds["branch_points"])
    f = ds["frequency_hz"].values[:n]
    assert n == 22 and np.allclose(f, np.arange(13084.0, 13105.5, 1.0), rtol=1e-14, atol=0)
    assert str(ds["branch_end"].values) == "reached the end of the range at 13105 Hz"
    kinds = ds["point_kind"].attrs["flag_meanings"].split()
    assert [kinds[k] for k in ds["point_kind"].values[:n][[0, 1, -1]]] == ["start", "regular", "end"]
    assert np.all(ds["stability"].values[:n] == 1)
    # One particle: only the pair at +1, which `largest_multiplier` leaves out.
    assert np.all(ds["largest_multiplier"].values[:n] == 0)
    assert np.nanmax(ds["orbit_settledness"].values[:n, 0]) < 1e-8
    a = ds["orbit_amplitude_m"].values[:n, 0, 0]
    eps = a / delta0
    shift = 2 * np.pi * f - w0
    error = (shift + w0 * a**2 / (24 * delta0**2)) / shift
    assert eps[0] > 0.18 and eps[-1] < 0.04, eps
    assert np.all(np.abs(error) < eps**2), np.c_[eps, error]
    # It falls with the amplitude: a tenth of ε², a tenth of the error (within a factor 2).
    assert abs(error[-1]) < 0.2 * abs(error[0]) * (eps[-1] / eps[0]) ** 2 * 10
    # The stored turning point is the static position plus the orbit's peak, about a - a²/(12δ₀).
    peak = ds["orbit_position_m"].values[:n, 0] - delta0
    assert np.all(np.abs(peak / a - 1) < eps / 10 + 1e-3), peak / a


@pytest.mark.parametrize(
    "displacement_m, from_hz, what",
    [(2e-8, 9000.0, "static state"), (2.1e-7, 13084.0 / 3, "fraction of the period")],
)
def test_shooting_onto_the_static_state_or_a_faster_orbit_ends_the_family_saying_so(
    tmp_path, displacement_m, from_hz, what
):
    """Two solutions of `v(T/2) = 0` are not free orbits of frequency 1/T: the static state, an
    orbit of every period (a small displacement at 9 kHz, far from any orbit there: the sphere's
    runs at 13.1 kHz), and an orbit of period T/3, which turns at T/2 too (the 13 084 Hz orbit
    of a fifth of the static overlap, shot at a third of its frequency). Each is refused, not
    stored as an orbit: no first orbit, the family fails naming why."""
    sweep = pressed_sphere(displacement_m, {"from": from_hz, "to": from_hz - 200.0})
    out = tmp_path / "refused.h5"
    r = run("run", write(tmp_path / "refused.json", sweep), "-o", out)
    assert r.returncode == 3, r.stderr
    assert "no first orbit" in r.stderr and what in r.stderr, r.stderr
    ds = chainsweep.open(out)
    assert int(ds["branch_points"]) == 0 and int(ds["branch_status"]) == 2


def breathers(to_hz: float) -> dict:
    s = json.loads(BREATHERS.read_text())
    s["periodic"]["to"] = to_hz
    return s


@pytest.fixture(scope="module")
def breather_family(tmp_path_factory):
    d = tmp_path_factory.mktemp("breathers")
    path = write(d / "breathers.json", breathers(34030.0))
    out = d / "breathers.h5"
    r = run("run", path, "-o", out, "--quiet")
    assert r.returncode == 0, r.stderr
    return path, out


def test_a_dimer_s_breathers_are_localised_on_their_sphere_and_grow_into_the_gap(breather_family):
    """The example's breathers of a precompressed dimer (20 cells of an 8 mm and a 5 mm steel
    sphere under 10 N), from 35.83 kHz, just below the optical band's edge √(2K/m), into the gap
    by 200 Hz: each in the gap, centred on the middle cell's light sphere (particle 22),
    symmetric about it, its amplitude growing as the frequency moves into the gap and its tails
    falling faster; far from the centre the light spheres' amplitudes fall from cell to cell by
    the linear dimer's evanescent factor exp(−κ) at the breather's frequency (its dispersion
    relation at q = π + iκ)."""
    _, out = breather_family
    ds = chainsweep.open(out)
    n = int(ds["branch_points"])
    f = ds["frequency_hz"].values[:n]
    assert n == 10 and f[0] == 35830.0 and f[-1] == 34030.0
    k = 1.5 * 8e9 ** (2 / 3) * 10.0 ** (1 / 3)
    m_heavy, m_light = 2.085e-3, 0.5e-3
    w = 2 * np.pi * f
    assert np.all((w > np.sqrt(2 * k / m_heavy)) & (w < np.sqrt(2 * k / m_light)))
    amplitude = ds["orbit_amplitude"].values[:n, :, 0]
    assert np.all(np.argmax(amplitude, axis=1) == 21)
    # Symmetric about it, but for the chain's ends, a wall below and a free top above: nearest
    # the band edge the breather spreads to them (its two sides differ by a percent there), and
    # it detaches from them as it localises deeper in the gap.
    asymmetry = np.abs(np.array([amplitude[:, 21 - d] / amplitude[:, 21 + d] - 1 for d in (2, 4, 6, 8)]))
    assert np.all(asymmetry[:, 0] < 3e-2) and np.all(asymmetry[:2, 1:] < 1e-3), asymmetry
    assert np.all(np.diff(asymmetry, axis=1) < 0), asymmetry
    centre = amplitude[:, 21]
    assert np.all(np.diff(centre) > 0), centre
    assert np.all(np.diff(amplitude[:, 29] / centre) < 0)
    # The linear dimer in its gap: ω² = K(1/m + 1/M) ± K √((1/m + 1/M)² − 4 sin²(q/2)/(mM)),
    # sin²(q/2) = cosh²(κ/2) at q = π + iκ.
    s = 1 / m_light + 1 / m_heavy
    cosh2 = m_light * m_heavy / (4 * k**2) * (k**2 * s**2 - (w**2 - k * s) ** 2)
    decay = np.exp(-2 * np.arccosh(np.sqrt(cosh2)))
    # Five and six cells from the centre (particles 32 and 34), four from the free top: the
    # tail's nonlinear part and what the end reflects fall as the breather localises, so the
    # ratio approaches the linear chain's from a few percent near the edge to below 1e-3 at
    # 34 kHz.
    deviation = np.abs(amplitude[:, 33] / amplitude[:, 31] / decay - 1)
    assert deviation[0] < 5e-2 and deviation[-1] < 1e-3, deviation
    assert np.all(np.diff(deviation) < 0), deviation
    assert np.all(ds["orbit_settledness"].values[:n] < 1e-3)


def test_a_killed_breather_family_resumes_bitwise(breather_family, tmp_path):
    path, reference = breather_family
    out = tmp_path / "killed.h5"
    kill_once_journaled(path, out, 4)
    assert not out.exists()
    r = run("run", path, "-o", out, "--quiet")
    assert r.returncode == 0, r.stderr
    assert_files_equal(reference, out)
    r = run("status", out)
    assert r.returncode == 0 and "10 point(s)" in r.stdout, r.stdout
    r = run("run", path, "-o", tmp_path / "dry.h5", "--dry-run")
    assert r.returncode == 0 and "10 orbits" in r.stdout, r.stdout


def drive(s):
    s["base"]["excitation"] = {"drive": {"force_n": {"harmonic": {"amplitude": 1.0, "frequency_hz": 30000.0}}}}


@pytest.mark.parametrize(
    "change, field",
    [
        (lambda s: s["periodic"].update(field="physics.precompression_force_n"), "periodic.field"),
        (lambda s: s["periodic"].pop("from"), "periodic.from"),
        (lambda s: s["periodic"].update(switch="period_doubling"), "periodic.switch"),
        (lambda s: s["periodic"].update(settle_periods=10), "periodic.settle_periods"),
        (lambda s: s["periodic"].update(step=5000.0), "periodic.step"),
        (lambda s: s["periodic"].update(max_points=5), "periodic.step"),
        (lambda s: s["periodic"].update(max_points=1), "periodic.max_points"),
        (lambda s: s["periodic"].update(step=1e-18), "periodic.step"),
        (lambda s: s["periodic"].update(to=0.01, step=5000.0), "periodic.to"),
        (lambda s: s["periodic"].update(to=35830.0), "periodic.to"),
        (lambda s: s["base"]["physics"].update(damping_kg_s=1.0), "base.physics.damping_kg_s"),
        (lambda s: drive(s), "base.excitation"),
    ],
)
def test_bad_autonomous_blocks_exit_2_naming_the_field(tmp_path, change, field):
    s = breathers(34030.0)
    change(s)
    path = write(tmp_path / "bad.json", s)
    r = run("validate", path)
    assert r.returncode == 2, r.stdout + r.stderr
    assert f"`{field}" in r.stderr, r.stderr
