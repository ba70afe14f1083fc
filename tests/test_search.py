"""Sweeps that search: minima, roots, refined curves and surfaces, and minimisation over two fields,
each checked against a dense grid of the same scene run by the same engine; kill-and-resume and
--jobs identity; bad search blocks refused naming the field; a level never crossed recorded as
not found. The example sweeps of sweeps/examples/ are the scenes (docs/SEARCHES.md)."""

from __future__ import annotations

import copy
import json
import signal
import subprocess
import time
from pathlib import Path

import h5py
import numpy as np
import pytest
import xarray as xr

import chainsweep
from conftest import BIN, REPO, assert_files_equal, kill_at, run, segment_count, write_sweep

EXAMPLES = REPO / "sweeps" / "examples"
SPHERE_MASS_KG = 0.002085  # the δ-force dimer's sphere: ε = m_cylinder / SPHERE_MASS_KG
# search_status / item status codes (flag_values of the output file)
SEARCH_STATUS = "pending running converged budget not_found failed_run stalled unidentifiable".split()
ITEM_STATUS = "none converged open at_bound stalled failed_run unidentifiable".split()


def example(name: str) -> dict:
    return json.loads((EXAMPLES / f"{name}.json").read_text())


def run_ok(spec: dict, out: Path, *extra, expect=0) -> xr.Dataset:
    path = write_sweep(out.with_suffix(".json"), spec)
    r = run("run", path, "-o", out, "--jobs", "2", "--quiet", *extra)
    assert r.returncode == expect, r.stdout + r.stderr
    return chainsweep.open(out)


def as_grid(spec: dict, axes: list[dict]) -> dict:
    """The sweep `spec` without its search, over `axes` (its own outer axes kept before them)."""
    g = copy.deepcopy(spec)
    g.pop("search")
    g["axes"] = [*g["axes"], *axes]
    return g


def ratio(ds: xr.Dataset, far: str, near: str) -> xr.DataArray:
    return ds.leading_peak.sel(probe=far) / ds.leading_peak.sel(probe=near)


def parabola_vertex(x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """The vertex of the parabola through the 5 points around the lowest of (x, y), and its
    curvature (half the second derivative)."""
    i = int(np.argmin(y))
    lo = max(0, min(i - 2, len(x) - 5))
    a, b, _ = np.polyfit(x[lo : lo + 5], y[lo : lo + 5], 2)
    return -b / (2 * a), a


# (a) ----------------------------------------------------------------------------------------------


def test_dimer_minimum_to_1e4_in_eps_with_a_fraction_of_a_grid(tmp_path):
    """The δ-force dimer's strongest attenuation over ε (near 0.575 without damping), located to
    ±1e-4 in ε at μ = 0 and 5 kg/s, against a dense grid (step 1e-4 in ε) around it; with fewer
    than a tenth of the runs of a uniform grid of that resolution over the interval."""
    spec = example("dimer-minimum")
    ds = run_ok(spec, tmp_path / "min.h5")
    field = spec["search"]["fields"][0]
    grid_runs = round((field["max"] - field["min"]) / field["tolerance"]) + 1  # 4001 per damping
    found = {}
    for mu in (0, 5):
        at = ds.sel(damping_kg_s=mu)
        assert SEARCH_STATUS[int(at.search_status)] == "converged", str(at.search_reason.values)
        assert int(at.search_runs) <= grid_runs / 10
        ok = np.asarray(at.minimum_status) == ITEM_STATUS.index("converged")
        assert ok.sum() == 1, "one minimum of the attenuation in [0.4, 0.8]"
        eps = float(at.minimum_cylinder_mass_kg[ok][0]) / SPHERE_MASS_KG
        assert float(at.minimum_cylinder_mass_kg_uncertainty[ok][0]) <= field["tolerance"]
        found[mu] = (eps, float(at.minimum_objective[ok][0]), int(at.search_runs))
    # The docs' table (step 0.025) puts the minimum near 0.575 at μ = 0 and 0.625 at μ = 5.
    assert abs(found[0][0] - 0.575) < 0.0125 and abs(found[5][0] - 0.625) < 0.025
    # Dense reference: ε at steps of 1e-4 over ±0.002 around each minimum found.
    for mu, (eps, value, runs) in found.items():
        dense = np.round(np.arange(eps - 0.002, eps + 0.002 + 1e-9, 1e-4), 6)
        g = as_grid(spec, [])
        g["axes"] = [
            {"field": "physics.damping_kg_s", "values": [mu]},
            {"field": field["field"], "name": "cylinder_mass_kg", "values": list(dense * SPHERE_MASS_KG)},
        ]
        ref = run_ok(g, tmp_path / f"dense{mu}.h5")
        y = ratio(ref, "particle_force_p70", "particle_force_p10").values.ravel()
        assert np.isfinite(y).all()
        x_ref, curvature = parabola_vertex(dense, y)
        assert abs(eps - x_ref) <= 1e-4, (mu, eps, x_ref)
        # No grid point lies below the search's value by more than the parabola rises over
        # the tolerance.
        assert value <= y.min() + curvature * 1e-4**2, (mu, value, y.min())
        print(f"dimer minimum μ={mu}: ε = {eps:.5f} (dense grid {x_ref:.5f}) in {runs} runs; "
              f"a uniform grid of step 1e-4 takes {grid_runs}")


# (b) ----------------------------------------------------------------------------------------------


def test_critical_damping_root_to_1e3_in_at_most_30_runs(tmp_path):
    """The damping at which the 0.98 and 0.55 chains attenuate equally (A21/A4), at 1.3 m/s:
    9.717 kg/s (examples/critical_damping.py's brentq over chainsweep.run), to ±0.001 kg/s in
    at most 30 runs; the difference changes sign across the root's uncertainty interval."""
    spec = example("critical-damping-root")
    ds = run_ok(spec, tmp_path / "root.h5")
    at = ds.sel(striker_velocity_m_s=1.3)
    assert SEARCH_STATUS[int(at.search_status)] == "converged", str(at.search_reason.values)
    assert int(at.search_runs) <= 30  # both chains' runs counted
    ok = np.asarray(at.root_status) == ITEM_STATUS.index("converged")
    assert ok.sum() == 1
    root = float(at.root_damping_kg_s[ok][0])
    dx = float(at.root_damping_kg_s_uncertainty[ok][0])
    assert dx <= 0.001
    assert abs(root - 9.717) <= 0.001, root
    # Independently: the two chains at root ± uncertainty, as an ordinary grid.
    g = as_grid(spec, [{"field": "physics.damping_kg_s", "values": [root - dx, root + dx]}])
    g["axes"][1]["values"] = [1.3]
    ref = run_ok(g, tmp_path / "bracket.h5")
    a = ratio(ref, "gauge_force_cyl21", "gauge_force_cyl4").squeeze()
    diff = (a.isel(cylinder_mass=0) - a.isel(cylinder_mass=1)).values
    assert diff[0] > 0 > diff[1], diff


# (c) ----------------------------------------------------------------------------------------------


def interpolation_error(x, y, x_ref, y_ref) -> float:
    o = np.argsort(x)
    return float(np.max(np.abs(np.interp(x_ref, x[o], y[o]) - y_ref)))


def test_refined_fig8_curve_beats_the_91_point_grid_with_fewer_runs(tmp_path):
    """Fig. 8's F21/F4 over ε = 0.1..1 at μ = 0 and 6 kg/s, refined to 0.005: against a dense
    reference (step 0.001), the refined curves' largest interpolation error is no worse than
    that of the 91-point grid (sweeps/fig08.json), curve by curve, with far fewer runs."""
    spec = example("fig08-refined")
    ds = run_ok(spec, tmp_path / "refined.h5")
    grid = json.loads((REPO / "sweeps" / "fig08.json").read_text())
    dense_x = np.round(np.arange(0.1, 1.0 + 1e-9, 0.001), 6)
    g = copy.deepcopy(grid)
    g["axes"][0] = {"field": g["axes"][0]["field"], "name": "mass_ratio", "values": list(dense_x)}
    ref = run_ok(g, tmp_path / "dense.h5")
    ref_y = ratio(ref, "gauge_force_cyl21", "gauge_force_cyl4")
    grid_x = np.round(np.arange(0.1, 1.0 + 1e-9, 0.01), 6)
    on_grid = np.isin(dense_x, grid_x)
    assert on_grid.sum() == 91
    runs = 0
    for mu in (0, 6):
        at = ds.sel(damping_kg_s=mu)
        assert SEARCH_STATUS[int(at.search_status)] == "converged", str(at.search_reason.values)
        y_ref = ref_y.sel(damping_kg_s=mu).values
        assert np.isfinite(y_ref).all()
        grid_err = interpolation_error(dense_x[on_grid], y_ref[on_grid], dense_x, y_ref)
        x, y = at.mass_ratio.values, at.objective.values
        keep = np.isfinite(x)
        err = interpolation_error(x[keep], y[keep], dense_x, y_ref)
        assert err <= grid_err, (mu, err, grid_err)
        assert float(at.refine_error) <= spec["search"]["objective_tolerance"]
        runs += int(at.search_runs)
        print(f"Fig. 8 refined μ={mu}: {int(at.search_runs)} runs, error {err:.2e} (91-point grid: {grid_err:.2e})")
    assert runs <= 0.6 * 182, runs  # 101 of the grid's 182 (57 at μ = 0, 44 at μ = 6)


# (d) ----------------------------------------------------------------------------------------------


def test_refined_surface_is_within_its_tolerance_with_fewer_runs_than_a_grid(tmp_path):
    """F21/F4 over mass ratio × damping refined in 2-D to 0.01 (the example's settings on a part
    of its domain): its own interpolant (bilinear on its cells) is within the tolerance of a
    dense 91 × 21 grid everywhere, and every uniform grid as accurate (taken from the dense
    one, the best spacing in each field included) needs more runs; points go where the surface
    bends, never along the damping, in which it is nearly linear."""
    spec = example("fig08-surface")
    s = spec["search"]
    fx, fy = s["fields"]
    fx.update(min=0.1, max=0.55)
    fy.update(min=0.0, max=5.0)
    s["scan"] = [6, 3]  # the example's spacings (0.09 in ε, 2.5 kg/s)
    ds = run_ok(spec, tmp_path / "surface.h5")
    assert SEARCH_STATUS[int(ds.search_status)] == "converged", str(ds.search_reason.values)
    tol = s["objective_tolerance"]
    assert float(ds.refine_error) <= tol
    runs = int(ds.search_runs)
    ex = np.round(np.linspace(0.1, 0.55, 91), 6)
    ey = np.round(np.linspace(0.0, 5.0, 21), 6)
    g = as_grid(spec, [
        {"field": fx["field"], "name": "mass_ratio", "values": list(ex)},
        {"field": fy["field"], "name": "damping_kg_s", "values": list(ey)},
    ])
    ref = run_ok(g, tmp_path / "dense.h5")
    zr = ratio(ref, "gauge_force_cyl21", "gauge_force_cyl4").values
    assert np.isfinite(zr).all()
    X, Y = np.meshgrid(ex, ey, indexing="ij")
    zi = chainsweep.refined_surface(ds, X, Y)
    assert np.isfinite(zi).all()
    # The interpolant passes through every sample.
    xs, ys, zs = (np.asarray(ds[v].values, float) for v in ("mass_ratio", "damping_kg_s", "objective"))
    np.testing.assert_allclose(chainsweep.refined_surface(ds, xs, ys), zs, rtol=1e-12, atol=0)
    err = float(np.max(np.abs(zi - zr)))
    assert err <= tol, err
    # Uniform grids taken from the dense one (every kx-th ε, every ky-th μ): the cheapest as
    # accurate as the refined surface.
    from scipy.interpolate import RegularGridInterpolator
    cheapest = None
    for kx in (1, 2, 3, 5, 6, 9, 10, 15, 18):
        for ky in (1, 2, 4, 5, 10, 20):
            f = RegularGridInterpolator((ex[::kx], ey[::ky]), zr[::kx, ::ky])
            e = np.max(np.abs(f(np.c_[X.ravel(), Y.ravel()]) - zr.ravel()))
            n = len(ex[::kx]) * len(ey[::ky])
            if e <= err and (cheapest is None or n < cheapest):
                cheapest = n
    assert cheapest is not None and runs < cheapest, (runs, cheapest)
    x = np.asarray(ds.mass_ratio.values, float)
    y = np.asarray(ds.damping_kg_s.values, float)
    assert len(np.unique(y[np.isfinite(y)])) == 3  # the scan's dampings only
    trough = ((x > 0.45) & (x < 0.55)).sum()
    shoulder = ((x > 0.2) & (x < 0.3)).sum()
    assert trough > shoulder, (trough, shoulder)
    print(f"surface: {runs} runs, largest error {err:.3e} (tolerance {tol}); "
          f"the cheapest uniform grid as accurate takes {cheapest}")


# (e) ----------------------------------------------------------------------------------------------


def test_two_field_minimum_matches_a_brute_force_grid(tmp_path):
    """The alternating-mass dimer minimised over both cylinder masses by Nelder–Mead with
    restarts: no point of a brute-force grid around the optimum lies lower, and the grid's lowest
    point lies within a few steps of it; far fewer runs than a grid of the search's tolerance."""
    spec = example("alternating-dimer-minimum")
    ds = run_ok(spec, tmp_path / "nm.h5")
    assert SEARCH_STATUS[int(ds.search_status)] == "converged", str(ds.search_reason.values)
    best = int(np.nanargmin(ds.minimum_objective.values))
    a = float(ds.minimum_cylinder_a_mass_kg[best]) / SPHERE_MASS_KG
    b = float(ds.minimum_cylinder_b_mass_kg[best]) / SPHERE_MASS_KG
    value = float(ds.minimum_objective[best])
    runs = int(ds.search_runs)
    f = spec["search"]["fields"]
    tol = f[0]["tolerance"] / SPHERE_MASS_KG
    grid_runs = (round((f[0]["max"] - f[0]["min"]) / f[0]["tolerance"]) + 1) ** 2
    assert runs <= grid_runs / 100
    step = 0.0075
    e = np.round(np.arange(0.5, 0.65 + 1e-9, step), 6)
    g = as_grid(spec, [
        {"field": f[0]["field"], "name": "a", "values": list(e * SPHERE_MASS_KG)},
        {"field": f[1]["field"], "name": "b", "values": list(e * SPHERE_MASS_KG)},
    ])
    ref = run_ok(g, tmp_path / "brute.h5")
    z = ratio(ref, "particle_force_p70", "particle_force_p10").values
    assert np.isfinite(z).all()
    i, j = np.unravel_index(np.argmin(z), z.shape)
    assert value <= z.min() + 1e-9, (value, z.min())
    assert abs(a - e[i]) <= 2 * step + tol and abs(b - e[j]) <= 2 * step + tol, ((a, b), (e[i], e[j]))
    # And the search's point evaluated as an ordinary run gives the value it reports.
    one = as_grid(spec, [
        {"field": f[0]["field"], "name": "a", "values": [float(ds.minimum_cylinder_a_mass_kg[best])]},
        {"field": f[1]["field"], "name": "b", "values": [float(ds.minimum_cylinder_b_mass_kg[best])]},
    ])
    again = run_ok(one, tmp_path / "again.h5")
    assert float(ratio(again, "particle_force_p70", "particle_force_p10").squeeze()) == value
    print(f"two-field minimum: ε_A = {a:.4f}, ε_B = {b:.4f}, {value:.6f} in {runs} runs "
          f"(grid {z.min():.6f} at {e[i]}, {e[j]}); a grid of the search's tolerance takes {grid_runs}")


# (f) ----------------------------------------------------------------------------------------------


def slow_search() -> dict:
    """The two-field minimisation with runs long enough (the whole 3 ms, no early stop) for kills
    to land mid-search: about 150 runs of ~20 ms."""
    spec = example("alternating-dimer-minimum")
    spec["record"]["stop_after_leading_pulses"] = False
    spec["search"]["scan"] = 5
    spec["search"]["budget"] = 150
    return spec


def test_search_kill_and_resume_is_bitwise_and_jobs_do_not_matter(tmp_path):
    spec = slow_search()
    path = write_sweep(tmp_path / "s.json", spec)
    ref1 = tmp_path / "jobs1.h5"
    r = run("run", path, "-o", ref1, "--jobs", "1", "--quiet")
    assert r.returncode in (0, 3), r.stderr
    ref2 = tmp_path / "jobs2.h5"
    r2 = run("run", path, "-o", ref2, "--jobs", "2", "--quiet")
    assert r2.returncode == r.returncode, r2.stderr
    assert_files_equal(ref1, ref2)
    total = segment_count(ref2)
    assert total > 60
    out = tmp_path / "killed.h5"
    kills = kill_at(path, out, (1, 10, 40, 90))
    assert kills >= 2, "the kills landed after the search had finished"
    r = run("run", path, "-o", out, "--jobs", "2", "--quiet")
    assert r.returncode == r2.returncode, r.stderr
    assert_files_equal(ref2, out)
    # Nothing runs again once it is complete.
    again = run("run", path, "-o", out, "--jobs", "2")
    assert again.returncode == r2.returncode
    assert segment_count(out) == total


# (g) ----------------------------------------------------------------------------------------------


BAD_SEARCHES = [
    ("empty interval", lambda s: s["search"]["fields"][0].update(max=s["search"]["fields"][0]["min"]),
     "search.fields[0].max", "empty"),
    ("reversed interval", lambda s: s["search"]["fields"][0].update(min=0.002, max=0.001),
     "search.fields[0].max", "empty"),
    ("a list", lambda s: s["search"]["fields"][0].update(field="chain.sequence"),
     "search.fields[0].field", "continuous"),
    ("a flag", lambda s: s["search"]["fields"][0].update(field="physics.wall"),
     "search.fields[0].field", "continuous"),
    ("no such field", lambda s: s["search"]["fields"][0].update(field="physics.dampnig_kg_s"),
     "search.fields[0].field", "dampnig"),
    ("budget 0", lambda s: s["search"].update(budget=0), "search.budget", "1 to"),
    ("tolerance 0", lambda s: s["search"]["fields"][0].update(tolerance=0), "search.fields[0].tolerance", "> 0"),
    ("unknown goal", lambda s: s["search"].update(goal="optimise"), "search.goal", "minimise"),
    ("unknown probe", lambda s: s["search"]["objective"]["ratio"][0].update(probe="gauge_force_cyl99"),
     "search.objective.ratio[0].probe", "particle_force_p10"),
    ("searched and swept", lambda s: s["search"]["fields"][0].update(field="physics.damping_kg_s"),
     "search.fields[0].field", "not both"),
    ("root without level needs one field", lambda s: s["search"].update(
        goal="root", fields=s["search"]["fields"] * 2), "search.fields", "1 to 1"),
    ("refine without objective_tolerance", lambda s: s["search"].update(goal="refine"),
     "search.objective_tolerance", ""),
    # An interval reaching values the scene refuses: refused before it runs (it once passed, its
    # refused points became failed runs, and the valid point beside them was reported converged).
    ("an end the scene refuses", lambda s: s["search"]["fields"][0].update(min=-0.001),
     "search.fields[0].min", "must be a finite number > 0"),
    *[(f"the reserved name {n}", (lambda n: lambda s: s["search"]["fields"][0].update(name=n))(n),
       "search.fields[0].name", "reserved")
      for n in ("status", "probe", "t_end_s", "run_hash", "objective", "evaluation",
                "search_status", "evaluation_round")],
]


@pytest.mark.parametrize("what,edit,field,words", BAD_SEARCHES, ids=[b[0] for b in BAD_SEARCHES])
def test_bad_search_blocks_exit_2_naming_the_field(tmp_path, what, edit, field, words):
    spec = example("dimer-minimum")
    edit(spec)
    path = write_sweep(tmp_path / "bad.json", spec)
    out = tmp_path / "bad.h5"
    for cmd in (("validate", path), ("run", path, "-o", out, "--quiet"), ("run", path, "-o", out, "--dry-run")):
        r = run(*cmd, timeout=60)
        assert r.returncode == 2, (cmd, r.stdout, r.stderr)
        assert f"`{field}`" in r.stderr and words in r.stderr, r.stderr
    assert not out.exists() and not Path(str(out) + ".d").exists()


def test_integer_field_is_not_continuous(tmp_path):
    spec = example("critical-damping-root")
    spec["search"]["fields"][0] = {"field": "chain.cylinders", "min": 20, "max": 60, "tolerance": 1}
    path = write_sweep(tmp_path / "bad.json", spec)
    r = run("validate", path)
    assert r.returncode == 2 and "search.fields[0]" in r.stderr and "continuous" in r.stderr, r.stderr


def test_level_never_crossed_is_recorded_not_found(tmp_path):
    """A root of a level the objective never reaches ends at once, recorded as not found with
    the range the objective spans: never a hang, never a made-up root."""
    spec = example("dimer-minimum")
    spec["search"].update(goal="root", level=5.0, budget=40)
    ds = run_ok(spec, tmp_path / "nf.h5")
    for mu in (0, 5):
        at = ds.sel(damping_kg_s=mu)
        assert SEARCH_STATUS[int(at.search_status)] == "not_found"
        assert int(at.search_runs) == spec["search"]["scan"]
        assert "does not cross 5" in str(at.search_reason.values)
        assert not np.isfinite(at.root_cylinder_mass_kg.values).any()
    st = run("status", tmp_path / "nf.h5")
    assert st.returncode == 0 and "not_found" in st.stdout, st.stdout


def test_budget_stops_a_search_as_unfinished_and_a_larger_budget_continues_it(tmp_path):
    """A budget too small ends the search with what it reached (status budget, exit 3, the
    uncertainty it got to); raising the budget continues from the stored runs, recomputing none,
    and ends where a search with the larger budget from the start ends."""
    spec = example("dimer-minimum")
    spec["axes"][0]["values"] = [0]
    small = copy.deepcopy(spec)
    small["search"]["budget"] = 9
    out = tmp_path / "b.h5"
    ds = run_ok(small, out, expect=3).isel(damping_kg_s=0)
    assert SEARCH_STATUS[int(ds.search_status)] == "budget"
    assert int(ds.search_runs) <= 9
    unc = float(ds.minimum_cylinder_mass_kg_uncertainty[0])
    assert unc > spec["search"]["fields"][0]["tolerance"]
    st = run("status", out)
    assert st.returncode == 3 and "budget" in st.stdout
    before = segment_count(out)
    ds = run_ok(spec, out).isel(damping_kg_s=0)
    assert SEARCH_STATUS[int(ds.search_status)] == "converged"
    full = run_ok(spec, tmp_path / "full.h5").isel(damping_kg_s=0)
    assert float(ds.minimum_cylinder_mass_kg[0]) == float(full.minimum_cylinder_mass_kg[0])
    assert segment_count(out) == int(full.search_runs)


# Files and readers -------------------------------------------------------------------------------


def test_search_file_reads_in_xarray_h5py_and_chainsweep_open(tmp_path):
    """The evaluated points as an unstructured dimension with every searched field a coordinate,
    the answers per outer point, labelled alike by xarray (both engines) and chainsweep.open."""
    spec = example("dimer-minimum")
    out = tmp_path / "r.h5"
    ours = run_ok(spec, out)
    for engine in ("h5netcdf", "netcdf4"):
        with xr.open_dataset(out, engine=engine) as ds:
            assert ds.objective.dims == ("damping_kg_s", "evaluation")
            assert ds.cylinder_mass_kg.dims == ("damping_kg_s", "evaluation")
            assert ds.cylinder_mass_kg.attrs["units"] == "kg"
            assert ds.leading_peak.dims == ("damping_kg_s", "evaluation", "probe")
            assert ds.minimum_cylinder_mass_kg.dims == ("damping_kg_s", "minimum")
            np.testing.assert_array_equal(ds.objective.values, ours.objective.values)
            np.testing.assert_array_equal(ds.minimum_objective.values, ours.minimum_objective.values)
    with h5py.File(out, "r") as f:
        obj = f["objective"][()]
        lp = f["leading_peak"][()]
        n = int(f["search_runs"][0])
        # The objective is the ratio of the stored summaries, evaluation by evaluation.
        np.testing.assert_array_equal(obj[0, :n], lp[0, :n, 1] / lp[0, :n, 0])
        assert f["search_status"].attrs["flag_meanings"].split() == SEARCH_STATUS


def test_python_sweep_runs_a_search_as_the_cli_does(tmp_path):
    path = EXAMPLES / "critical-damping-root.json"
    a, b = tmp_path / "py.h5", tmp_path / "cli.h5"
    calls = []
    res = chainsweep.sweep(path, a, jobs=2, progress=lambda *c: calls.append(c))
    assert res.exit_code == 0
    # Progress counts the searches' runs against their budgets (2 searches of at most 30 runs),
    # and once they have ended, the runs they made.
    assert calls[0] == (0, 0, 60) and calls[-1] == (28, 0, 28), calls
    assert [c[0] for c in calls] == sorted(c[0] for c in calls)
    r = run("run", path, "-o", b, "--jobs", "1", "--quiet")
    assert r.returncode == 0, r.stderr
    assert_files_equal(a, b)
    # A dict runs the same searches (only the stored sweep text differs).
    c = tmp_path / "dict.h5"
    assert chainsweep.sweep(example("critical-damping-root"), c, progress=False).exit_code == 0
    with h5py.File(b) as fb, h5py.File(c) as fc:
        for name in ("root_damping_kg_s", "objective", "leading_peak", "run_hash"):
            np.testing.assert_array_equal(fb[name][()], fc[name][()])


def test_dry_run_states_the_budget(tmp_path):
    path = write_sweep(tmp_path / "s.json", example("fig08-refined"))
    r = run("run", path, "-o", tmp_path / "x.h5", "--dry-run")
    assert r.returncode == 0, r.stderr
    assert "at most 400 (their budgets; the first scans take 22)" in r.stdout, r.stdout
    assert not (tmp_path / "x.h5").exists()


def test_searches_shard_by_outer_point_and_merge_to_the_single_file(tmp_path):
    """Under SLURM each array task runs the searches of its outer points; merging the shards
    gives the file of a single run, bitwise; a merge missing a shard is partial."""
    path = EXAMPLES / "dimer-minimum.json"
    single = tmp_path / "single.h5"
    assert run("run", path, "-o", single, "--jobs", "2", "--quiet").returncode == 0
    parts = []
    for k in (1, 2):
        part = tmp_path / f"part{k}.h5"
        r = run("run", path, "-o", part, "--shard", f"{k}/2", "--jobs", "1", "--quiet")
        assert r.returncode == 0, r.stderr
        with h5py.File(part) as f:  # one search per shard, the other pending
            assert sorted(f["search_status"][()].tolist()) == [0, SEARCH_STATUS.index("converged")]
        parts.append(part)
    partial = tmp_path / "partial.h5"
    r = run("merge", "-o", partial, parts[0])
    assert r.returncode == 3, r.stdout + r.stderr
    merged = tmp_path / "merged.h5"
    r = run("merge", "-o", merged, *reversed(parts))
    assert r.returncode == 0, r.stdout + r.stderr
    assert_files_equal(single, merged, skip_attrs={"created_utc", "command_line", "header_checksum", "shard"})


def test_status_gives_each_search_s_answer_and_a_round_under_way(tmp_path):
    """`status` of a finished search (its file, and the sweep file with -o; text and --json)
    gives every answer with its uncertainty, as `run` printed it; of a search interrupted in
    its first scan, the runs that round has finished (they count once it is whole)."""
    spec = example("dimer-minimum")
    out = tmp_path / "m.h5"
    run_ok(spec, out)
    for args in (["status", out], ["status", write_sweep(tmp_path / "m.json", spec), "-o", out]):
        r = run(*args)
        assert r.returncode == 0, r.stderr
        answers = [l for l in r.stdout.splitlines() if l.strip().startswith("minimum cylinder_mass_kg = ")]
        assert len(answers) == 2 and all(" ± " in l and "converged" in l for l in answers), r.stdout
        j = json.loads(run(*args, "--json").stdout)
        for s in j["searches"]:
            (a,) = s["answers"]
            f = a["fields"]["cylinder_mass_kg"]
            assert a["item"] == "minimum" and a["status"] == "converged"
            assert 0.000834 < f["value"] < 0.001668 and 0 < f["uncertainty"] < 1e-6
    # Interrupted while its first scan runs: what that round has is said.
    slow = slow_search()
    path = write_sweep(tmp_path / "slow.json", slow)
    out = tmp_path / "slow.h5"
    proc = subprocess.Popen([str(BIN), "run", str(path), "-o", str(out), "--jobs", "1", "--quiet"],
                            stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    while segment_count(out) < 2:
        assert proc.poll() is None and time.monotonic() < deadline
        time.sleep(0.02)
    proc.send_signal(signal.SIGINT)
    proc.communicate(timeout=120)
    r = run("status", path, "-o", out)
    assert "its next round of" in r.stdout and "finished (they count once the round is whole)" in r.stdout, r.stdout
    r = run("status", out)
    assert "more run(s) have finished since the file was written" in r.stdout, r.stdout
    # The sweep stopped: no process writes the file, and status says it was interrupted.
    assert "the sweep was interrupted" in r.stdout, r.stdout


def test_a_search_with_failed_runs_exits_3_from_run_as_status_does(tmp_path):
    """A search whose runs fail (every run over an energy-drift limit no run can meet) is not a
    success: `run` exits 3, as `status` does on the same file, and each search says why it ended."""
    spec = example("dimer-minimum")
    spec["limits"] = {"energy_drift_max": 1e-30}
    path = write_sweep(tmp_path / "fail.json", spec)
    out = tmp_path / "fail.h5"
    r = run("run", path, "-o", out)
    assert r.returncode == 3, r.stderr
    assert "no run of the scan gave a number" in r.stderr, r.stderr
    st = run("status", out)
    assert st.returncode == 3
    # Its text names the failed runs as the file indexes them (evaluations, not points of the
    # outer grid) and ends with the health line, as a grid's does.
    assert "  failed: evaluation 0: energy drift" in st.stdout, st.stdout
    assert "health: 14 failed (14 over a limit);" in st.stdout, st.stdout
