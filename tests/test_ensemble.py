"""Ensembles: scene fields drawn from distributions, the statistics of the runs with their
intervals, global sensitivities, and the adaptive rule, checked against closed forms.

The scene with a closed form: five equal masses `m` on linear springs `k` (a power law of
exponent 1, each contact and the wall's) under a static force, its lowest frequency from
`record.spectrum` (no time integration): `f = (1/π) sin(π / 22) √(k/m)`. With `k` and `m`
log-uniform over a factor 4 each, `ln f` is `ln C + ½ ln k − ½ ln m`, the sum of two independent
uniforms: the mean and variance of `f`, its quantiles (a triangular `ln f`) and the Sobol'
indices of `k` and `m` follow exactly.

(a) mean, sd and quantiles of `f` within their reported intervals, and Sobol' indices (Saltelli,
    Jansen) within theirs;
(b) a field the frequency does not depend on (the damping) gets a total index whose interval
    holds 0;
(c) the adaptive rule stops at a width within its tolerance, and over 100 seeds the 95 % interval
    of the mean covers the exact mean in 88-99 % of them;
(d) Sobol' points reach a given error of the mean in fewer runs than Monte Carlo (both printed);
(e) bad distributions exit 2 naming the field, nothing written;
and the ensemble as runs: kill -9 and resume, --jobs, shards and merge all bitwise; xarray and
chainsweep.open read it as labelled; a fit's result as a multivariate normal; every cylinder's
mass toleranced in one line.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import h5py
import numpy as np
import pytest
import xarray as xr

import chainsweep
from conftest import REPO, assert_files_equal, assert_resume_and_merge_bitwise, kill_at, run, write_sweep

K_RANGE = (5e5, 2e6)
M_RANGE = (1e-3, 4e-3)
N_MASSES = 5
C = math.sin(math.pi / (2 * (2 * N_MASSES + 1))) / math.pi


def linear_chain(ensemble: dict) -> dict:
    law = {"power_law": {"coefficient": 1e6, "exponent": 1.0}}
    return {
        "description": "five masses on linear springs on a wall, precompressed",
        "base": {
            "chain": {
                "particles": {
                    "ball": {
                        "sphere": {
                            "diameter_m": 0.008,
                            "mass_kg": 0.002,
                            "material": {"youngs_modulus_pa": 2e11, "poisson_ratio": 0.3},
                        }
                    }
                },
                "sequence": [{"repeat": N_MASSES, "of": ["ball"]}],
                "contacts": [
                    {"between": ["ball", "ball"], "law": law},
                    {"between": ["ball", "wall"], "law": law},
                ],
            },
            "physics": {"gravity": False, "damping_kg_s": 0.0, "wall": True, "precompression_force_n": 10.0},
            "excitation": {"impulse": {"velocity_m_s": 0.01}},
            "duration_s": 0.001,
        },
        "record": {"spectrum": {}},
        "ensemble": ensemble,
    }


STIFFNESS = {
    "field": ["chain.contacts[0].law.power_law.coefficient", "chain.contacts[1].law.power_law.coefficient"],
    "name": "stiffness",
    "log_uniform": {"min": K_RANGE[0], "max": K_RANGE[1]},
}
MASS = {"field": "chain.particles.ball.sphere.mass_kg", "log_uniform": {"min": M_RANGE[0], "max": M_RANGE[1]}}
DAMPING = {"field": "physics.damping_kg_s", "uniform": {"min": 0.0, "max": 1.0}}
F1 = {"name": "f1", "of": {"summary": "lowest_frequency_hz"}}


def log_uniform_moment(alpha: float, lo: float, hi: float) -> float:
    """E[x^alpha] for x log-uniform on [lo, hi]."""
    a, b = math.log(lo), math.log(hi)
    return (math.exp(alpha * b) - math.exp(alpha * a)) / (alpha * (b - a))


def exact():
    """The exact mean, sd, quantile function and Sobol' indices of f."""
    ex, ex2 = log_uniform_moment(0.5, *K_RANGE), log_uniform_moment(1.0, *K_RANGE)
    ey, ey2 = log_uniform_moment(-0.5, *M_RANGE), log_uniform_moment(-1.0, *M_RANGE)
    mean = C * ex * ey
    var = C * C * (ex2 * ey2 - (ex * ey) ** 2)
    v = ex2 * ey2 - (ex * ey) ** 2
    indices = {
        "stiffness": (ey**2 * (ex2 - ex**2) / v, ey2 * (ex2 - ex**2) / v),
        "mass_kg": (ex**2 * (ey2 - ey**2) / v, ex2 * (ey2 - ey**2) / v),
        "damping_kg_s": (0.0, 0.0),
    }
    # ln f = mu + T, T triangular on [-w, w] (the difference of two uniforms of width w = ln 2).
    mu = math.log(C) + 0.25 * sum(map(math.log, K_RANGE)) - 0.25 * sum(map(math.log, M_RANGE))
    w = 0.5 * math.log(K_RANGE[1] / K_RANGE[0])

    def quantile(p):
        t = -w + w * math.sqrt(2 * p) if p < 0.5 else w - w * math.sqrt(2 * (1 - p))
        return math.exp(mu + t)

    return mean, math.sqrt(var), quantile, indices


def ensemble_run(tmp_path, name, ensemble, *args):
    path = write_sweep(tmp_path / f"{name}.json", linear_chain(ensemble))
    out = tmp_path / f"{name}.h5"
    r = run("run", path, "-o", out, "--quiet", *args)
    assert r.returncode == 0, r.stderr
    return path, out


def test_statistics_match_the_closed_forms_within_their_intervals(tmp_path):
    mean, sd, quantile, _ = exact()
    _, out = ensemble_run(
        tmp_path, "a", {"inputs": [STIFFNESS, MASS], "samples": 128, "replicates": 8, "seed": 3, "statistics": [F1]}
    )
    with h5py.File(out) as f:
        assert f.attrs["ensemble_stopped_by"] == "fixed"
        assert f["member"].shape == (1024,)
        # Every sampled run is the closed form at its sampled k and m.
        k, m, f1 = f["stiffness"][()], f["mass_kg"][()], f["lowest_frequency_hz"][()]
        np.testing.assert_allclose(f1, C * np.sqrt(k / m), rtol=1e-12)
        assert np.array_equal(f["stiffness_2"][()], k)
        checks = [("mean", mean), ("sd", sd)]
        for name, truth in checks:
            v, lo, hi = (float(f[f"f1_{name}{s}"][()]) for s in ("", "_lower", "_upper"))
            print(f"{name}: {v:.4f} [{lo:.4f}, {hi:.4f}], exact {truth:.4f}")
            assert lo <= truth <= hi, (name, v, lo, hi, truth)
            assert hi - lo < 0.02 * truth  # a quasi-Monte Carlo interval, far below 1/sqrt(N)
        for j, p in enumerate(f["quantile"][()]):
            v, lo, hi = (float(f[f"f1_quantile{s}"][j]) for s in ("", "_lower", "_upper"))
            truth = quantile(p)
            print(f"q{p}: {v:.3f} [{lo:.3f}, {hi:.3f}], exact {truth:.3f}")
            assert lo <= truth <= hi, (p, v, lo, hi, truth)
        # The histogram's fractions sum to one.
        assert abs(f["f1_histogram"][()].sum() - 1.0) < 1e-12


def test_sobol_indices_match_their_closed_forms_and_an_idle_field_gets_zero(tmp_path):
    _, _, _, indices = exact()
    _, out = ensemble_run(
        tmp_path,
        "s",
        {"inputs": [STIFFNESS, MASS, DAMPING], "design": "saltelli", "samples": 1024, "seed": 1, "statistics": [F1]},
    )
    with h5py.File(out) as f:
        names = [b"".join(row).decode() for row in f["input_name"][()]]
        assert names == ["stiffness", "mass_kg", "damping_kg_s"]
        assert f["member"].shape == (1024 * 5,)
        for g, name in enumerate(names):
            for kind, truth in zip(("first_order", "total"), indices[name]):
                v, lo, hi = (float(f[f"f1_{kind}{s}"][g]) for s in ("", "_lower", "_upper"))
                print(f"{name} {kind}: {v:.4f} [{lo:.4f}, {hi:.4f}], exact {truth:.4f}")
                assert lo <= truth <= hi, (name, kind, v, lo, hi)
                assert abs(v - truth) < 0.05
        # (b): the damping does not enter the frequency: its total index is 0 and so is its
        # interval's lower end.
        lo, hi = f["f1_total_lower"][2], f["f1_total_upper"][2]
        assert lo <= 0.0 <= hi


def test_morris_screens_the_idle_field_out(tmp_path):
    _, out = ensemble_run(
        tmp_path,
        "m",
        {"inputs": [STIFFNESS, MASS, DAMPING], "design": "morris", "samples": 20, "seed": 2, "statistics": [F1]},
    )
    with h5py.File(out) as f:
        mu_star = f["f1_mu_star"][()]
        assert mu_star[0] > 100 and mu_star[1] > 100 and mu_star[2] == 0.0
        # f grows with k and falls with m.
        assert f["f1_mu"][0] > 0 > f["f1_mu"][1]
        assert "f1_mean" not in f  # a Morris design screens; its points are no sample


def test_the_adaptive_rule_stops_within_its_tolerance_and_its_intervals_cover(tmp_path):
    mean, _, _, _ = exact()
    tolerance = 2.0  # Hz, the width of the mean's 95 % interval
    covered, runs = 0, []
    seeds = 100
    for seed in range(seeds):
        ens = {
            "inputs": [STIFFNESS, MASS],
            "samples": 8,
            "replicates": 8,
            "seed": seed,
            "statistics": [dict(F1, tolerance={"mean": tolerance})],
        }
        _, out = ensemble_run(tmp_path, f"c{seed}", ens)
        with h5py.File(out) as f:
            assert f.attrs["ensemble_stopped_by"] == "tolerance"
            lo, hi = float(f["f1_mean_lower"][()]), float(f["f1_mean_upper"][()])
            assert hi - lo <= tolerance
            covered += lo <= mean <= hi
            runs.append(int(f.attrs["ensemble_runs"]))
            # The samples of a round are its predecessor's and as many more: every run kept.
            assert int(f.attrs["ensemble_round"]) >= 1
        for p in Path(tmp_path).glob(f"c{seed}.*"):
            if p.is_file():
                p.unlink()
    print(f"adaptive rule: the interval covers the exact mean in {covered} of {seeds} seeds; runs {min(runs)}-{max(runs)}")
    assert 88 <= covered <= 99


def rms_error_of_the_mean(tmp_path, design: str, n: int, seeds=range(8)) -> float:
    mean, _, _, _ = exact()
    errors = []
    for seed in seeds:
        ens = {"inputs": [STIFFNESS, MASS], "design": design, "samples": n, "replicates": 1, "seed": seed, "statistics": [F1]}
        _, out = ensemble_run(tmp_path, f"d-{design}-{n}-{seed}", ens)
        with h5py.File(out) as f:
            errors.append(float(f["f1_mean"][()]) - mean)
    return float(np.sqrt(np.mean(np.square(errors))))


def test_sobol_points_need_fewer_runs_than_monte_carlo(tmp_path):
    sobol = {n: rms_error_of_the_mean(tmp_path, "sobol", n) for n in (64, 256)}
    mc = {n: rms_error_of_the_mean(tmp_path, "monte_carlo", n) for n in (64, 256, 4096)}
    print(f"rms error of the mean (Hz): Sobol' {sobol}, Monte Carlo {mc}")
    # 64 Sobol' points do better than 4096 Monte Carlo ones.
    assert sobol[64] < mc[4096] < mc[256]


@pytest.mark.parametrize(
    "inputs, extra, field",
    [
        ([{"field": "physics.damping_kg_s", "normal": {"mean": 1.0, "sd": 0.0}}], {}, "ensemble.inputs[0].normal.sd"),
        ([{"field": "physics.damping_kg_s", "normal": {"mean": 1.0, "sd": -1.0}}], {}, "ensemble.inputs[0].normal.sd"),
        ([{"field": "physics.damping_kg_s", "uniform": {"min": 2.0, "max": 1.0}}], {}, "ensemble.inputs[0].uniform"),
        ([{"field": "physics.damping_kg_s", "triangular": {"min": 0.0, "mode": 3.0, "max": 1.0}}], {}, "ensemble.inputs[0].triangular.mode"),
        ([{"field": "physics.damping_kg_s", "discrete": {"values": [1, 2], "weights": [1]}}], {}, "ensemble.inputs[0].discrete.weights"),
        ([{"field": "physics.no_such_field", "uniform": {"min": 0.0, "max": 1.0}}], {}, "ensemble.inputs[0].field"),
        ([{"field": "physics.damping_kg_s", "uniform": {"min": -2.0, "max": -1.0}}], {}, "ensemble.inputs[0]"),
        ([{"field": "physics.damping_kg_s", "gamma": {"k": 1.0}}], {}, "ensemble.inputs[0].gamma"),
        (
            [STIFFNESS, MASS],
            {"correlation": {"inputs": ["stiffness", "mass_kg"], "matrix": [[1.0, 1.5], [1.5, 1.0]]}},
            "ensemble.correlation.matrix[0][1]",
        ),
        (
            [STIFFNESS, MASS, DAMPING],
            {
                "correlation": {
                    "inputs": ["stiffness", "mass_kg", "damping_kg_s"],
                    "matrix": [[1.0, 0.9, -0.9], [0.9, 1.0, 0.9], [-0.9, 0.9, 1.0]],
                }
            },
            "ensemble.correlation.matrix",
        ),
        # 30 % of the mass: positive at ±3 sd, negative at the −8.3 sd a design can draw (a
        # later round of an adaptive ensemble did, and the sweep could never end).
        ([{"field": "chain.particles.ball.sphere.mass_kg", "normal": {"mean": 0.002, "sd": 0.0006}}], {},
         "ensemble.inputs[0]"),
        # The base scene's damping is 0: a fraction of it is no spread.
        ([{"field": "physics.damping_kg_s", "normal": {"relative_sd": 0.1}}], {}, "ensemble.inputs[0].normal.relative_sd"),
        ([STIFFNESS], {"samples": 100}, "ensemble.samples"),
        ([STIFFNESS], {"design": "halton"}, "ensemble.design"),
        # Sobol' indices and elementary effects assume independent inputs.
        *[
            (
                [STIFFNESS, MASS],
                {"design": design, "correlation": {"inputs": ["stiffness", "mass_kg"], "matrix": [[1.0, 0.5], [0.5, 1.0]]}},
                "ensemble.correlation",
            )
            for design in ("saltelli", "morris")
        ],
    ],
)
def test_bad_distributions_exit_2_naming_the_field(tmp_path, inputs, extra, field):
    spec = linear_chain(dict({"inputs": inputs, "statistics": [F1]}, **extra))
    path = write_sweep(tmp_path / "bad.json", spec)
    out = tmp_path / "bad.h5"
    r = run("run", path, "-o", out)
    assert r.returncode == 2, r.stderr
    assert f"field `{field}`" in r.stderr, r.stderr
    assert not out.exists() and not Path(f"{out}.d").exists()
    v = run("validate", path)
    assert v.returncode == 2 and f"`{field}`" in v.stdout + v.stderr


def fake_fit_file(path: Path, covariance, status=1, p_value=0.5):
    """A fit's result as the engine writes it: `status` its fit_status (1 converged, 3 at a
    bound), `p_value` its fit_p_value."""
    sweep = {"search": {"goal": "fit", "fields": [{"field": "physics.damping_kg_s", "min": 0, "max": 10}]}}
    with h5py.File(path, "w") as f:
        f.attrs["sweep"] = json.dumps(sweep)
        f["fit_damping_kg_s"] = np.array([0.5])
        f["fit_status"] = np.array([status], dtype=np.uint8)
        f["fit_p_value"] = np.array([p_value])
        if covariance is not None:
            f["fit_covariance"] = np.array(covariance, dtype=float)


@pytest.mark.parametrize(
    "covariance, status, p_value, says",
    [
        (None, 1, 0.5, "fit_covariance"),
        ([[np.inf]], 1, 0.5, "no covariance"),
        # A fit at a bound of its interval, or one that misses its data far beyond their
        # sigma: its covariance does not describe the field's uncertainty.
        ([[0.01]], 3, 0.5, "ended at_bound"),
        ([[0.01]], 4, 0.5, "ended stalled"),
        ([[0.01]], 1, 1e-9, "poor fit"),
    ],
    ids=["no covariance", "infinite covariance", "at a bound", "stalled", "poor fit"],
)
def test_a_fit_file_without_a_usable_covariance_exits_2(tmp_path, covariance, status, p_value, says):
    fake_fit_file(tmp_path / "fit.h5", covariance, status, p_value)
    spec = linear_chain({"inputs": [STIFFNESS, {"from_fit": "fit.h5"}], "statistics": [F1]})
    path = write_sweep(tmp_path / "e.json", spec)
    r = run("run", path, "-o", tmp_path / "e.h5")
    assert r.returncode == 2 and "ensemble.inputs[1].from_fit" in r.stderr and says in r.stderr, r.stderr
    assert not (tmp_path / "e.h5").exists()


def test_a_fits_result_is_sampled_as_its_multivariate_normal(tmp_path):
    fake_fit_file(tmp_path / "fit.h5", [[0.01]])
    spec = linear_chain(
        {"inputs": [STIFFNESS, {"from_fit": "fit.h5"}], "samples": 256, "replicates": 4, "statistics": [F1]}
    )
    path = write_sweep(tmp_path / "e.json", spec)
    out = tmp_path / "e.h5"
    assert run("run", path, "-o", out, "--quiet").returncode == 0
    with h5py.File(out) as f:
        d = f["damping_kg_s"][()]
        assert abs(d.mean() - 0.5) < 0.005 and abs(d.std() - 0.1) < 0.005
        # The fit's numbers are part of the sweep's text: a later change of the fit's file
        # changes nothing of this ensemble.
        assert '"multivariate_normal"' in f.attrs["sweep"] and '"from_fit"' not in f.attrs["sweep"]


def test_an_adaptive_ensemble_with_failed_samples_stops_saying_so(tmp_path):
    """Samples that fail (here: the heavier chains run out of steps) leave statistics over the
    others, biased where failing depends on the inputs: no tolerance vouches for them, and more
    rounds would only add failures. The ensemble stops after the round, `failed`, and its
    `_missing` counts them."""
    spec = linear_chain(
        {
            "inputs": [MASS],
            "samples": 8,
            "replicates": 8,
            "statistics": [{"name": "ov", "of": {"summary": "max_overlap_m"}, "tolerance": {"mean": 1.0}}],
        }
    )
    spec["base"].update(duration_s=0.005, max_steps=341)
    del spec["record"]
    path = write_sweep(tmp_path / "f.json", spec)
    out = tmp_path / "f.h5"
    r = run("run", path, "-o", out, "--quiet")
    assert r.returncode == 3, r.stderr
    with h5py.File(out) as f:
        assert f.attrs["ensemble_stopped_by"] == "failed"
        assert int(f.attrs["ensemble_round"]) == 0
        missing = int(np.ravel(f["ov_missing"][()])[0])
        assert 0 < missing < 64
        # A tolerance of 1 m: every interval is within it, which once ended it `tolerance`.
        width = np.ravel(f["ov_mean_upper"][()])[0] - np.ravel(f["ov_mean_lower"][()])[0]
        assert width < 1.0
    status = run("status", out)
    assert "failed" in status.stdout + status.stderr


def test_a_gaussian_copula_gives_the_stated_correlation(tmp_path):
    spec = {
        "inputs": [STIFFNESS, MASS],
        "correlation": {"inputs": ["stiffness", "mass_kg"], "matrix": [[1.0, 0.8], [0.8, 1.0]]},
        "samples": 512,
        "replicates": 2,
        "statistics": [F1],
    }
    _, out = ensemble_run(tmp_path, "cop", spec)
    with h5py.File(out) as f:
        # Normal scores of the two log-uniform fields are correlated as stated.
        from statistics import NormalDist

        def scores(x, lo, hi):
            u = (np.log(x) - math.log(lo)) / (math.log(hi) - math.log(lo))
            return np.array([NormalDist().inv_cdf(v) for v in u])

        zk = scores(f["stiffness"][()], *K_RANGE)
        zm = scores(f["mass_kg"][()], *M_RANGE)
        assert abs(np.corrcoef(zk, zm)[0, 1] - 0.8) < 0.03


def tolerance_sweep() -> dict:
    """The 0.55 chain's F5/F2 with every cylinder's mass toleranced and the striker's velocity."""
    return {
        "description": "toleranced 0.55 chain",
        "base": {
            "chain": {"preset": "chain_055", "cylinders": 6},
            "physics": {"gravity": False, "damping_kg_s": 6.0, "wall": True},
            "striker_velocity_m_s": 1.06,
            "duration_s": 3e-4,
            "integrator": {"method": "dop853", "rtol": 1e-9},
        },
        "record": {
            "probes": [{"kind": "gauge_force", "cylinder": c} for c in (2, 5)],
            "stop_after_leading_pulses": True,
        },
        "axes": [{"field": "physics.damping_kg_s", "values": [0.0, 6.0]}],
        "ensemble": {
            "inputs": [
                {"mass_factors": "cylinders", "normal": {"sd": 0.01}},
                {"field": "striker_velocity_m_s", "normal": {"relative_sd": 0.02}},
            ],
            "samples": 8,
            "replicates": 4,
            "seed": 5,
            "statistics": [
                {
                    "name": "f5_f2",
                    "of": {
                        "ratio": [
                            {"summary": "leading_peak", "probe": "gauge_force_cyl5"},
                            {"summary": "leading_peak", "probe": "gauge_force_cyl2"},
                        ]
                    },
                    "exceed": [0.9],
                }
            ],
        },
    }


def test_every_cylinders_mass_is_toleranced_in_one_line_and_read_as_labelled(tmp_path):
    path = write_sweep(tmp_path / "t.json", tolerance_sweep())
    out = tmp_path / "t.h5"
    r = run("run", path, "-o", out, "--jobs", "2")
    assert r.returncode == 0, r.stderr
    assert "ensemble (sobol design)" in r.stderr and "f5_f2 at damping_kg_s=6.0" in r.stderr
    ds = xr.open_dataset(out, engine="h5netcdf")
    # The cylinders are particles 3, 5, …, 13 of the 14: one coordinate each along `member`.
    factors = [f"mass_factor_{p}" for p in range(3, 14, 2)]
    for name in factors:
        assert ds[name].dims == ("member",) and ds[name].attrs["units"] == "1"
        assert abs(float(ds[name].mean()) - 1.0) < 0.01
    assert "mass_factor_2" not in ds
    assert ds["leading_peak"].dims[:2] == ("damping_kg_s", "member")
    assert ds["f5_f2_mean"].dims == ("damping_kg_s",)
    assert ds["f5_f2_quantile"].dims == ("damping_kg_s", "quantile")
    assert ds["f5_f2_exceed"].dims == ("damping_kg_s", "f5_f2_level")
    # The statistic is the ratio of the stored peaks, member by member.
    ratio = ds["leading_peak"].sel(probe="gauge_force_cyl5") / ds["leading_peak"].sel(probe="gauge_force_cyl2")
    np.testing.assert_allclose(ds["f5_f2_mean"].values, ratio.mean("member").values, rtol=1e-12)
    # Damping shrinks the transmitted ratio.
    assert float(ds["f5_f2_mean"][1]) < float(ds["f5_f2_mean"][0])
    opened = chainsweep.open(out)
    np.testing.assert_array_equal(opened["f5_f2_mean"].values, ds["f5_f2_mean"].values)
    # status shows the statistics, in text and in JSON.
    s = run("status", out, "--json")
    st = json.loads(s.stdout)["ensemble"]
    assert st["design"] == "sobol" and st["stopped_by"] == "fixed" and st["samples"] == 32
    point = st["statistics"][0]["points"][1]
    assert point["at"] == "damping_kg_s=6.0"
    assert point["mean"]["lower"] <= point["mean"]["value"] <= point["mean"]["upper"]


def test_every_spheres_size_is_toleranced_and_each_run_has_its_scaled_chain(tmp_path):
    """`size_factors` scale each sphere's diameter, its mass with the cube and its Hertz laws:
    every sample's lowest frequency is that of the linearised chain of its own scaled spheres,
    computed here from Hertz's law and the masses alone."""
    steel = {"youngs_modulus_pa": 2e11, "poisson_ratio": 0.3}
    wall = {"youngs_modulus_pa": 1.93e11, "poisson_ratio": 0.29}
    d0, m0, force = 8e-3, 2.085e-3, 10.0
    sweep = {
        "description": "three spheres on a wall, each diameter toleranced",
        "base": {
            "chain": {
                "particles": {"ball": {"sphere": {"diameter_m": d0, "mass_kg": m0, "material": steel}}},
                "sequence": [{"repeat": 3, "of": ["ball"]}],
                "wall_material": wall,
            },
            "physics": {"gravity": False, "damping_kg_s": 0.0, "wall": True, "precompression_force_n": force},
            "excitation": {"impulse": {"velocity_m_s": 0.01}},
            "duration_s": 0.001,
        },
        "record": {"spectrum": {}},
        "ensemble": {
            "inputs": [{"size_factors": "chain", "log_normal": {"median": 1.0, "sigma_ln": 0.05}}],
            "samples": 16,
            "replicates": 2,
            "seed": 9,
            "statistics": [F1],
        },
    }
    path = write_sweep(tmp_path / "s.json", sweep)
    out = tmp_path / "s.h5"
    r = run("run", path, "-o", out, "--quiet")
    assert r.returncode == 0, r.stderr
    ds = xr.open_dataset(out, engine="h5netcdf")
    factors = np.stack([ds[f"size_factor_{p}"].values for p in (1, 2, 3)], axis=1)
    assert ds["size_factor_1"].attrs["units"] == "1" and factors.shape == (32, 3)
    assert factors.std() > 0.02  # the diameters really vary

    def e_star(a, b):
        return 1.0 / sum((1 - m["poisson_ratio"] ** 2) / m["youngs_modulus_pa"] for m in (a, b))

    def lowest_hz(f):
        r = 0.5 * d0 * f
        coeff = [
            4 / 3 * e_star(steel, steel) * math.sqrt(r[0] * r[1] / (r[0] + r[1])),
            4 / 3 * e_star(steel, steel) * math.sqrt(r[1] * r[2] / (r[1] + r[2])),
            4 / 3 * e_star(steel, wall) * math.sqrt(r[2]),
        ]
        # Every contact carries the precompression; F = A δ^{3/2} linearised there.
        k = [1.5 * a ** (2 / 3) * force ** (1 / 3) for a in coeff]
        stiffness = np.array([[k[0], -k[0], 0], [-k[0], k[0] + k[1], -k[1]], [0, -k[1], k[1] + k[2]]])
        m_half = np.diag((m0 * f**3) ** -0.5)
        return math.sqrt(np.linalg.eigvalsh(m_half @ stiffness @ m_half)[0]) / (2 * math.pi)

    expected = np.array([lowest_hz(f) for f in factors])
    np.testing.assert_allclose(ds["lowest_frequency_hz"].values, expected, rtol=1e-10)
    # The statistic is of those runs.
    np.testing.assert_allclose(float(ds["f1_mean"]), expected.mean(), rtol=1e-12)
    # A factor that can reach zero is refused naming the input.
    sweep["ensemble"]["inputs"][0] = {"size_factors": "chain", "normal": {"mean": 1.0, "sd": 0.5}}
    path = write_sweep(tmp_path / "bad.json", sweep)
    r = run("validate", path)
    assert r.returncode == 2 and "ensemble.inputs[0]" in r.stderr and "size factor" in r.stderr, r.stderr


def test_an_ensemble_resumes_after_kill_and_runs_the_same_with_any_jobs(tmp_path):
    path = write_sweep(tmp_path / "t.json", tolerance_sweep())
    ref = tmp_path / "ref.h5"
    assert run("run", path, "-o", ref, "--jobs", "1", "--quiet").returncode == 0
    out = tmp_path / "killed.h5"
    kill_at(path, out, (1, 10, 30, 50))
    assert run("run", path, "-o", out, "--jobs", "2", "--quiet").returncode == 0
    assert_files_equal(ref, out)
    # Run again without its snapshot, and as two shards merged: bitwise the same.
    assert_resume_and_merge_bitwise(path, ref, tmp_path)


def adaptive_ensemble(**extra) -> dict:
    """Sobol' 8 × 8 over stiffness and mass, adaptive: the lowest frequency's mean within 1 Hz."""
    return {
        "inputs": [STIFFNESS, MASS],
        "samples": 8,
        "replicates": 8,
        "seed": 4,
        "statistics": [dict(F1, tolerance={"mean": 1.0})],
        **extra,
    }


def test_an_adaptive_ensemble_resumes_round_by_round(tmp_path):
    ens = adaptive_ensemble()
    path, ref = ensemble_run(tmp_path, "ad", ens)
    with h5py.File(ref) as f:
        rounds = int(f.attrs["ensemble_round"])
        assert rounds >= 2 and f.attrs["ensemble_stopped_by"] == "tolerance"
    # A killed adaptive ensemble goes on from its stored runs to the same answer.
    out = tmp_path / "killed.h5"
    kill_at(path, out, (5, 200))
    # gc keeps the later rounds' runs (it took round 0's for all the sweep needs, and removed
    # the rest as "no longer" the sweep's).
    g = run("gc", path, "-o", out)
    assert g.returncode == 0 and "removed 0 run" in g.stdout, g.stdout + g.stderr
    assert run("run", path, "-o", out, "--quiet").returncode == 0
    assert_files_equal(ref, out)
    r = run("status", path, "-o", out)
    assert "ended by every interval within its tolerance" in r.stdout, r.stdout
    # --dry-run states the runs of round 0 (8 samples × 8 replicates) and the rule.
    d = run("run", path, "--dry-run", "-o", tmp_path / "fresh.h5")
    assert d.returncode == 0, d.stderr
    assert "adaptive: 64 runs in round 0 (64 samples at each of 1 point(s)), doubling" in d.stdout, d.stdout
    assert "budget of 65536 runs" in d.stdout, d.stdout
    # A budget ends it where its next round would pass it, and says so.
    ens["max_runs"] = 256
    _, out = ensemble_run(tmp_path, "budget", ens)
    with h5py.File(out) as f:
        assert f.attrs["ensemble_stopped_by"] == "budget"
        assert int(f.attrs["ensemble_runs"]) <= 256


def test_an_adaptive_ensemble_runs_in_shards_round_by_round_to_the_single_machine_s_answer(tmp_path):
    """Each shard runs one round (`--ensemble-round`); the merge of every shard's file of that
    round decides, as one machine does, whether another is due; the last merge is bitwise the
    single machine's file."""
    ens = adaptive_ensemble()
    path, ref = ensemble_run(tmp_path, "ad", ens)
    with h5py.File(ref) as f:
        last = int(f.attrs["ensemble_round"])
        assert last >= 2 and f.attrs["ensemble_stopped_by"] == "tolerance"
    n = 3
    shards = [tmp_path / f"s{k}.h5" for k in range(1, n + 1)]
    merged = tmp_path / "merged.h5"
    stopped_by, rounds = "running", []
    while stopped_by == "running":
        k = len(rounds)
        assert k <= last, f"the shards went past the single machine's last round {last}"
        for i, s in enumerate(shards, 1):
            r = run("run", path, "--shard", f"{i}/{n}", "--ensemble-round", k, "-o", s, "--quiet")
            assert r.returncode == 0, r.stderr
            with h5py.File(s) as f:
                # A shard holds its part of the round: the round's statistics are not its own.
                assert int(f.attrs["ensemble_round"]) == k
                assert f.attrs["ensemble_stopped_by"] == "incomplete"
        m = run("merge", "-o", merged, *shards)
        assert m.returncode == 0, m.stdout + m.stderr
        with h5py.File(merged) as f:
            assert int(f.attrs["ensemble_round"]) == k
            stopped_by = f.attrs["ensemble_stopped_by"]
            rounds.append(int(f.attrs["ensemble_runs"]))
    assert len(rounds) == last + 1 and stopped_by == "tolerance", (rounds, stopped_by)
    assert rounds == [64 * 2**k for k in range(last + 1)], rounds
    assert_files_equal(ref, merged)

    # A shard left a round behind is named, with the round to run it at; nothing is merged.
    behind = tmp_path / "behind"
    behind.mkdir()
    for i, s in enumerate(shards, 1):
        k = 1 if i < n else 0
        assert run("run", path, "--shard", f"{i}/{n}", "--ensemble-round", k, "-o", behind / s.name, "--quiet").returncode == 0
    m = run("merge", "-o", tmp_path / "mixed.h5", *[behind / s.name for s in shards])
    assert m.returncode == 1, m.stdout + m.stderr
    assert f"{behind / shards[-1].name} (round 0; shard 3/3, SLURM array task 2)" in m.stderr, m.stderr
    assert "--ensemble-round 1" in m.stderr, m.stderr
    assert not (tmp_path / "mixed.h5").exists()

    # The dry run of a shard states its round's runs.
    d = run("run", path, "--shard", "2/3", "--ensemble-round", 2, "--dry-run", "-o", tmp_path / "d.h5")
    assert d.returncode == 0, d.stderr
    assert "adaptive: 256 runs in round 2 (256 samples at each of 1 point(s))" in d.stdout, d.stdout


@pytest.mark.parametrize(
    "args, says",
    [
        (["--ensemble-round", "1"], "give it with --shard"),
        (["--shard", "1/2", "--ensemble-round", "3"], "round 3 would take 512 runs, over the ensemble's budget of 256"),
    ],
)
def test_a_round_without_a_shard_or_past_the_budget_exits_2_naming_the_option(tmp_path, args, says):
    ens = adaptive_ensemble(max_runs=256)
    path = write_sweep(tmp_path / "ad.json", linear_chain(ens))
    r = run("run", path, "-o", tmp_path / "o.h5", *args)
    assert r.returncode == 2 and "--ensemble-round" in r.stderr and says in r.stderr, r.stderr
    assert not (tmp_path / "o.h5").exists()
    # A fixed-size ensemble has no rounds.
    fixed_ens = {k: v for k, v in ens.items() if k != "max_runs"}
    fixed = write_sweep(tmp_path / "fixed.json", linear_chain({**fixed_ens, "statistics": [F1]}))
    r = run("run", fixed, "--shard", "1/2", "--ensemble-round", "0", "-o", tmp_path / "f.h5")
    assert r.returncode == 2 and "--ensemble-round" in r.stderr, r.stderr
    # Nor has a search or a periodic block, in a run or a dry run.
    for example in ("dimer-minimum.json", "driven-branches.json"):
        for dry in ([], ["--dry-run"]):
            r = run("run", REPO / "sweeps" / "examples" / example, "--ensemble-round", "0", "-o", tmp_path / "x.h5", *dry)
            assert r.returncode == 2 and "--ensemble-round" in r.stderr, (example, dry, r.stderr)
            assert not (tmp_path / "x.h5").exists()


def test_chainsweep_sweep_runs_a_shard_s_round_as_the_command_line_does(tmp_path):
    ens = adaptive_ensemble()
    path = write_sweep(tmp_path / "ad.json", linear_chain(ens))
    cli = tmp_path / "cli.h5"
    r = run("run", path, "--shard", "1/2", "--ensemble-round", "1", "-o", cli, "--quiet")
    assert r.returncode == 0, r.stderr
    # Round 0, then round 1 into the same file: a sample keeps its shard as the samples double
    # (in 3 shards too, though 3 divides no round's samples), so round 1 runs only the shard's
    # new samples.
    res = chainsweep.sweep(path, tmp_path / "py.h5", shard=(1, 2), ensemble_round=0, progress=False)
    assert (res.exit_code, res.n_runs, res.ran) == (0, 32, 32), res
    res = chainsweep.sweep(path, tmp_path / "py.h5", shard=(1, 2), ensemble_round=1, progress=False)
    assert (res.exit_code, res.n_runs, res.ran) == (0, 64, 32), res
    assert_files_equal(cli, tmp_path / "py.h5")
    for k in (1, 2, 3):
        out = tmp_path / f"three-{k}.h5"
        r0 = chainsweep.sweep(path, out, shard=(k, 3), ensemble_round=0, progress=False)
        r1 = chainsweep.sweep(path, out, shard=(k, 3), ensemble_round=1, progress=False)
        assert r1.ran == r1.n_runs - r0.n_runs and r0.n_runs in (21, 22), (k, r0, r1)
    with pytest.raises(chainsweep.InputError) as e:
        chainsweep.sweep(path, tmp_path / "no.h5", ensemble_round=1, progress=False)
    assert e.value.field == "ensemble_round", e.value
    assert not (tmp_path / "no.h5").exists()


def test_next_round_submits_nothing_when_the_last_round_s_tasks_wrote_no_shard_or_for_another_sweep(tmp_path):
    """`chainsweep slurm --next-round` (what an adaptive ensemble's merge job runs) without SLURM:
    what it decides before it would submit."""
    ens = adaptive_ensemble()
    path = write_sweep(tmp_path / "ad.json", linear_chain(ens))
    out = tmp_path / "ad.h5"
    r = run("slurm", path, "-o", out, "--shards", "2")
    assert r.returncode == 0, r.stderr
    job = tmp_path / "ad.h5.slurm"
    assert (job / "ensemble-round").read_text() == "0\n"
    shards = [job / "shards" / f"ad.shard-{k}-of-2.h5" for k in (1, 2)]
    for k, s in enumerate(shards, 1):
        assert run("run", path, "--shard", f"{k}/2", "-o", s, "--quiet").returncode == 0
    assert run("merge", "-o", out, *shards).returncode == 0
    with h5py.File(out) as f:
        assert f.attrs["ensemble_stopped_by"] == "running"
    # The folder says round 1 was given, but the shards hold round 0: the tasks of round 1 wrote
    # nothing. Submitting round 1 again would loop; it says so, with the re-submit command.
    (job / "ensemble-round").write_text("1\n")
    r = run("slurm", path, "-o", out, "--shards", "2", "--next-round")
    assert r.returncode == 3, r.stdout + r.stderr
    assert "the job folder's round is 1 but" in r.stdout and "holds round 0" in r.stdout, r.stdout
    assert "sbatch --parsable --array=0,1 " in r.stdout, r.stdout
    # Written again, the job starts at round 0 (its tasks resume their stored runs).
    assert run("slurm", path, "-o", out, "--shards", "2").returncode == 0
    assert (job / "ensemble-round").read_text() == "0\n"
    # A sweep without an adaptive ensemble has no next round.
    fixed = write_sweep(tmp_path / "fixed.json", linear_chain({**ens, "statistics": [F1]}))
    r = run("slurm", fixed, "-o", tmp_path / "f.h5", "--shards", "2", "--next-round")
    assert r.returncode == 2 and "--next-round" in r.stderr, r.stderr
