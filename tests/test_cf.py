"""Result files follow the CF conventions: cfchecker (4.1, with UDUNITS-2) finds no error and no
warning in a file of any kind — a plain grid, zipped axes (one named after none of them),
histories and minimum overlaps, failed runs, pending runs (a shard), probes of mixed units, text
and boolean axes, a search — and every variable has a `long_name`, every number but a flag a
`units` that UDUNITS parses, every flag CF's `flag_values` (typed like it) and `flag_meanings`,
the file its `Conventions`. Both xarray engines and `ncdump` read what cfchecker accepts: text
(netCDF `char`s) as strings, `probe` as a string coordinate, no `DIMENSION_LABELS` among the
attributes. A file of the layout before (3: variable-length strings, "see probe_units") stays
readable and resumes into a CF file.

cfchecker and cfunits come from requirements.txt, UDUNITS-2 from Debian (`make udunits`): a
missing checker is a failure here, never a skip. cfchecker validates `standard_name`, `area_type`
and region names against tables it fetches from the web by default; the tests run offline with
empty tables, so that a file giving any of those attributes fails here until its table is given.
"""

import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import h5py
import netCDF4
import numpy as np
import pytest
import xarray as xr
from cfunits import Units

from conftest import REPO, base_sweep, run, write_sweep

chainsweep = pytest.importorskip("chainsweep")

CONVENTIONS = "CF-1.8"  # the newest CF version cfchecker 4.1 checks against
CFCHECKS = Path(sys.executable).parent / "cfchecks"
ENGINES = ["h5netcdf", "netcdf4"]

# Variables whose `units` may be missing: none. (A search's objective carries the unit its
# summaries combine to: "1" for a ratio, the force's for a difference of forces.)
SEARCH_OBJECTIVES: set[str] = set()


def zipped(name=None):
    """Striker velocity and chain length zipped (one dimension), against damping."""
    s = base_sweep()
    s["record"]["stop_after_leading_pulses"] = True
    group = {"zip": [
        {"field": "striker_velocity_m_s", "name": "velocity_m_s", "values": [1.06, 1.3, 1.45]},
        {"field": "chain.cylinders", "values": [10, 12, 14]},
    ]}
    if name:
        group["name"] = name
    s["axes"] = [group, {"field": "physics.damping_kg_s", "values": [0, 6]}]
    return s


def histories():
    s = base_sweep(history=True)
    s["record"]["min_overlap"] = True
    return s


def failing():
    """The rtol 1e-5 runs drift by ~1e-4 of the impact energy, over the limit 1e-6, and fail."""
    s = histories()
    s["axes"] = [
        {"field": "chain.cylinder.mass.heavy_cylinders.mass_ratio", "values": [0.3, 0.55, 1.0]},
        {"field": "integrator.rtol", "values": [1e-9, 1e-5]},
    ]
    s["limits"] = {"energy_drift_max": 1e-6}
    return s


def mixed_units():
    """A force, a velocity and an overlap probe: N, m/s and m in one file."""
    s = histories()
    s["record"]["probes"] = [
        {"kind": "gauge_force", "cylinder": 2},
        {"kind": "velocity", "particle": 5},
        {"kind": "overlap", "contact": 3},
    ]
    return s


def fields():
    """Space-time fields of every quantity beside the histories and minimum overlaps: contact
    forces over (grid…, field_time_s, contact), displacements and velocities over (grid…,
    field_time_s, particle)."""
    s = histories()
    s["record"]["fields"] = {
        "quantities": ["contact_force", "displacement", "velocity"], "interval_s": 2e-6}
    return s


def text_and_boolean_axes():
    """Gravity on and off (booleans) against two masses given as objects (text coordinates)."""
    s = base_sweep()
    s["axes"] = [
        {"field": "physics.gravity", "values": [True, False]},
        {"field": "chain.cylinder.mass", "name": "cylinder_mass",
         "values": [{"explicit": {"mass_kg": 0.002043}}, {"heavy_cylinders": {"mass_ratio": 0.55}}]},
    ]
    return s


def ensemble(design: str):
    """An ensemble over the damping axis: every cylinder's mass and the striker's velocity drawn,
    with a statistic's quantiles, exceedance and histogram (and Sobol' indices or Morris's
    effects over the input dimension)."""
    s = base_sweep()
    s["axes"] = [s["axes"][1]]
    s["ensemble"] = {
        "inputs": [
            {"mass_factors": "cylinders", "normal": {"sd": 0.01}},
            {"field": "striker_velocity_m_s", "normal": {"relative_sd": 0.02}},
        ],
        "design": design,
        "samples": 4,
        "statistics": [{"of": {"summary": "leading_peak", "probe": "gauge_force_cyl8"}, "exceed": [50.0]}],
    }
    if design == "sobol":
        s["ensemble"]["replicates"] = 2
    return s


KINDS = {
    # name: (sweep, extra arguments, exit code)
    "plain": (base_sweep, [], 0),
    "zip": (zipped, [], 0),
    "zip-named": (lambda: zipped("impact"), [], 0),
    "histories": (histories, [], 0),
    "failed": (failing, [], 3),
    "pending": (zipped, ["--shard", "1/2"], 0),
    "mixed-units": (mixed_units, [], 0),
    "fields": (fields, [], 0),
    "text-axes": (text_and_boolean_axes, [], 0),
    "search": (None, [], 0),
    # Fits: their statistics, profiles, data and prediction over dimensions of their own.
    "fit": (REPO / "sweeps" / "examples" / "fit-damping.json", [], 0),
    "fit-signal": (REPO / "sweeps" / "examples" / "fit-signal.json", [], 0),
    # Ensembles: statistics over the axes and their own dimensions, indices over the inputs.
    "ensemble": (lambda: ensemble("sobol"), [], 0),
    "ensemble-saltelli": (lambda: ensemble("saltelli"), [], 0),
    "ensemble-morris": (lambda: ensemble("morris"), [], 0),
}


@pytest.fixture(scope="module")
def files(tmp_path_factory, binary):
    d = tmp_path_factory.mktemp("cf")
    out = {}
    for name, (make, extra, rc) in KINDS.items():
        if make is None:
            path = REPO / "sweeps" / "examples" / "critical-damping-root.json"
        elif isinstance(make, Path):
            path = make
        else:
            path = write_sweep(d / f"{name}.json", make())
        out[name] = d / f"{name}.h5"
        r = run("run", path, "-o", out[name], "--quiet", *extra)
        assert r.returncode == rc, r.stderr
    return out


@pytest.fixture(scope="module")
def tables(tmp_path_factory):
    """Empty standard-name, area-type and region tables (no attribute of ours names one)."""
    d = tmp_path_factory.mktemp("cf-tables")
    for name, root, date in [("standard-names", "standard_name_table", "last_modified"),
                             ("area-types", "area_type_table", "date"),
                             ("regions", "standardized_region_list", "date")]:
        (d / f"{name}.xml").write_text(
            f'<?xml version="1.0"?>\n<{root}><version_number>0</version_number>'
            f"<{date}>none</{date}></{root}>\n")
    return d


def cfchecks(path, tables, tmp_path):
    """cfchecker's report on `path` (its command, as a user runs it; it wants a `.nc` name)."""
    assert CFCHECKS.exists(), f"cfchecks not found at {CFCHECKS}: `make test` installs it (requirements.txt)"
    nc = tmp_path / (path.stem + ".nc")
    nc.symlink_to(path)
    r = subprocess.run(
        [str(CFCHECKS), "-v", "auto", "-s", str(tables / "standard-names.xml"),
         "-a", str(tables / "area-types.xml"), "-r", str(tables / "regions.xml"), str(nc)],
        capture_output=True, text=True, timeout=300)
    return r


def messages(report, category):
    """The (variable, message) pairs of one category (ERROR, WARN, INFO) of a cfchecks report."""
    out, var = [], None
    for line in report.splitlines():
        if line.startswith("Checking variable: "):
            var = line.split(": ", 1)[1]
        elif line.startswith(category + ":"):
            out.append((var, line))
    return out


def test_the_documented_cfchecker_command_runs_offline_and_finds_nothing(files, tmp_path):
    """docs/REFERENCE.md's commands for checking a file with cfchecker, run verbatim (offline,
    with the tables they write) on a plain grid's file: no error, no warning."""
    import os

    text = (REPO / "docs" / "REFERENCE.md").read_text()
    block = next(b for b in re.findall(r"```sh\n(.*?)```", text, re.S) if "cfchecks -v auto" in b)
    (tmp_path / "results").mkdir()
    shutil.copy(files[next(iter(KINDS))], tmp_path / "results" / "mass-damping.h5")
    env = dict(os.environ, PATH=f"{CFCHECKS.parent}:{os.environ['PATH']}")
    r = subprocess.run(["sh", "-ec", block], cwd=tmp_path, capture_output=True, text=True, env=env, timeout=300)
    report = r.stdout + r.stderr
    assert r.returncode == 0, report
    assert "ERRORS detected: 0" in report and "WARNINGS given: 0" in report, report


@pytest.mark.parametrize("kind", list(KINDS))
def test_cfchecker_finds_no_error_and_no_warning(files, tables, tmp_path, kind):
    r = cfchecks(files[kind], tables, tmp_path)
    report = r.stdout + r.stderr
    assert "Traceback" not in report, report
    assert f"Checking against CF Version {CONVENTIONS}" in report, report
    assert "ERRORS detected: 0" in report and "WARNINGS given: 0" in report, report
    assert not messages(report, "ERROR") and not messages(report, "WARN"), report
    assert r.returncode == 0, report
    infos = messages(report, "INFO")
    if kind in ("search", "fit", "fit-signal"):
        assert {v for v, _ in infos} <= SEARCH_OBJECTIVES, report
    else:
        assert not infos, report


def variables(path):
    """Every variable of the file, its groups' included: (path, netCDF4 variable)."""
    with netCDF4.Dataset(path) as nc:
        def walk(g):
            for name, v in g.variables.items():
                v.set_auto_mask(False)
                yield f"{g.path.rstrip('/')}/{name}", v
            for sub in g.groups.values():
                yield from walk(sub)
        yield from walk(nc)


FLAG_WORD = re.compile(r"^[A-Za-z0-9_.+\-@]+$")


@pytest.mark.parametrize("kind", list(KINDS))
def test_every_variable_is_labelled_with_parseable_units(files, kind):
    path = files[kind]
    with h5py.File(path, "r") as f:
        assert f.attrs["Conventions"] == CONVENTIONS
        assert int(f.attrs["layout_version"]) == 6
    seen = 0
    for name, v in variables(path):
        seen += 1
        attrs = {k: v.getncattr(k) for k in v.ncattrs()}
        text = v.dtype == np.dtype("S1")
        assert isinstance(attrs.get("long_name"), str) and attrs["long_name"].strip(), name
        if "units" in attrs:
            # never a sentence: what UDUNITS (cfunits, as cfchecker) parses
            assert Units(attrs["units"]).isvalid, (name, attrs["units"])
        if "flag_values" in attrs:
            values = np.atleast_1d(attrs["flag_values"])
            assert values.dtype == v.dtype, (name, values.dtype, v.dtype)
            words = attrs["flag_meanings"].split(" ")
            assert len(words) == len(values) == len(set(values.tolist())), name
            assert all(FLAG_WORD.match(w) for w in words), (name, words)
        elif not text and name.split("/")[-1] not in SEARCH_OBJECTIVES:
            # every number but a flag (whose values are codes) has units
            assert "units" in attrs, name
        if text:
            assert attrs.get("_Encoding") == "utf-8", name
    assert seen > 20


@pytest.mark.parametrize("kind", list(KINDS))
@pytest.mark.parametrize("engine", ENGINES)
def test_xarray_reads_text_as_strings_and_shows_no_hdf5_bookkeeping(files, kind, engine):
    ds = xr.open_dataset(files[kind], engine=engine).load()
    assert ds.attrs["Conventions"] == CONVENTIONS
    for name, v in ds.variables.items():
        assert "DIMENSION_LABELS" not in v.attrs, name
        assert not any(d.endswith("_strlen") for d in v.dims), (name, v.dims)
        assert "units" not in v.attrs or Units(v.attrs["units"]).isvalid, name
    probe = ds.indexes["probe"]
    assert all(isinstance(p, str) for p in probe), probe
    assert ds.probe_units.dims == ("probe",) and all(isinstance(u, str) for u in ds.probe_units.values)
    for name in ("reason", "warnings", "run_hash"):
        assert ds[name].dims == ds.status.dims, name
        assert all(isinstance(t, str) for t in ds[name].values.ravel()), name
    ok = (ds.status == 1).values
    assert all(len(h) == 64 for h in ds.run_hash.values[ok])
    # the same as chainsweep.open serves
    ours = chainsweep.open(files[kind])
    assert list(ours.probe.values) == list(probe)
    for name in ("reason", "warnings", "run_hash"):
        assert ours[name].values.tolist() == ds[name].values.tolist(), name


def test_failed_runs_keep_their_reason(files):
    with h5py.File(files["failed"], "r") as f:
        status = f["status"][()]
    for engine in ENGINES:
        ds = xr.open_dataset(files["failed"], engine=engine).load()
        reasons = ds.reason.values[status == 2]
        assert len(reasons) == 3 and all("exceeds the limit" in r for r in reasons)
        assert (ds.reason.values[status != 2] == "").all()


def test_mixed_units_are_split_by_unit(files):
    path = files["mixed-units"]
    probes = ["gauge_force_cyl2", "velocity_p5", "overlap_3"]
    units = {"gauge_force_cyl2": "N", "velocity_p5": "m/s", "overlap_3": "m"}
    for engine in ENGINES:
        ds = xr.open_dataset(path, engine=engine).load()
        assert list(ds.probe.values) == probes
        assert list(ds.probe_units.values) == [units[p] for p in probes]
        assert "leading_peak" not in ds and "record_max" not in ds
        for column in ("leading_peak", "record_max"):
            for p, u in units.items():
                v = ds[chainsweep._layout.split_name(column, u)]
                assert v.attrs["units"] == u and v.dims == ("mass_ratio", "damping_kg_s", "probe")
                assert np.isfinite(v.sel(probe=p).values).all(), (column, p)
                others = [q for q in probes if units[q] != u]
                assert np.isnan(v.sel(probe=others).values).all(), (column, p)
        assert ds.leading_peak_time_s.attrs["units"] == "s"  # times are in s whatever the probe
    # chainsweep.open: the same, and one variable over every probe, without a units
    ds = chainsweep.open(path, histories=True)
    assert "units" not in ds.leading_peak.attrs and "probe_units" in ds.leading_peak.attrs["comment"]
    assert "units" not in ds.history.attrs
    for p, u in units.items():
        part = ds[chainsweep._layout.split_name("leading_peak", u)].sel(probe=p)
        assert part.values.tobytes() == ds.leading_peak.sel(probe=p).values.tobytes(), p
    with h5py.File(path, "r") as f:  # the histories: one variable per unit, NaN at the others
        for u in set(units.values()):
            h = f[chainsweep._layout.split_name("history", u)]
            assert h.attrs["units"] == u
            mine = [k for k, p in enumerate(probes) if units[p] == u]
            others = [k for k, p in enumerate(probes) if units[p] != u]
            assert np.isnan(h[..., others, :]).all() and not np.isnan(h[..., mine, 0]).any()
    np.testing.assert_array_equal(
        ds.history.sel(probe=probes[0]).values,
        xr.open_dataset(path)[chainsweep._layout.split_name("history", units[probes[0]])]
        .sel(probe=probes[0]).values)


def test_ncdump_shows_every_variable_and_char_text(files):
    exe = shutil.which("ncdump")
    assert exe, "ncdump not found: `make test` installs it (Debian package netcdf-bin)"
    for kind in ("text-axes", "mixed-units", "zip-named"):
        r = subprocess.run([exe, "-h", str(files[kind])], capture_output=True, text=True, timeout=60)
        assert r.returncode == 0, r.stderr
        assert "\tchar probe(probe, probe_strlen) ;" in r.stdout
        assert re.search(r"\tchar reason\(.*, reason_strlen\) ;", r.stdout)
        assert "DIMENSION_LABELS" not in r.stdout and 'Conventions = "CF-1.8"' in r.stdout
    out = subprocess.run([exe, "-h", str(files["text-axes"])], capture_output=True, text=True).stdout
    # a boolean axis is bytes (HDF5's boolean enumeration was invisible to netCDF)
    assert "\tbyte gravity(gravity) ;" in out and "\tchar cylinder_mass(cylinder_mass, cylinder_mass_strlen) ;" in out
    ds = chainsweep.open(files["text-axes"])
    assert ds.gravity.dtype == bool and list(ds.gravity.values) == [True, False]
    assert ds.sel(gravity=False, cylinder_mass='{"explicit":{"mass_kg":0.002043}}').steps.item() > 0


FIXTURE = Path(__file__).resolve().parent / "fixtures"


def test_a_file_of_layout_3_and_older_numerics_is_read_refused_by_merge_and_resumed_into_a_cf_file(
    tmp_path, tables, binary
):
    """tests/fixtures/layout3.h5: shard 1 of 2 of fixtures/layout3.json as layout 3 wrote it
    (variable-length strings, `leading_peak` in "see probe_units", labelled dimensions), at
    numerics version 3: chainsweep.open and `status` read it; `merge` refuses its runs, made by
    other numerics, naming them; `run` computes them again into a file of the current layout that
    cfchecker accepts, with the same steps (an undamped scene, which numerics version 4 left
    bitwise as it was) and the same peaks within 1e-8 (located on the dense output since
    numerics version 8), under the current run hashes."""
    old = tmp_path / "layout3.h5"
    shutil.copyfile(FIXTURE / "layout3.h5", old)
    sweep = tmp_path / "layout3.json"
    shutil.copyfile(FIXTURE / "layout3.json", sweep)
    with h5py.File(old, "r") as f:
        assert int(f.attrs["layout_version"]) == 3 and "Conventions" not in f.attrs
        assert f["leading_peak"].attrs["units"] == "see probe_units"
        assert h5py.check_string_dtype(f["reason"].dtype).length is None  # variable-length
        assert int(f.attrs["numerics_version"]) == 3
    ds = chainsweep.open(old, histories=True)
    assert list(ds.probe.values) == ["gauge_force_cyl2", "velocity_p5"]
    assert "units" not in ds.leading_peak.attrs  # the sentence dropped
    assert ds.leading_peak_m_per_s.attrs["units"] == "m/s"
    assert set(ds.data_vars) >= {"leading_peak_N", "record_max_N", "record_max_m_per_s"}
    failed = ds.status.values == 2
    assert failed.sum() == 1 and "step budget" in ds.reason.values[failed][0]
    r = run("status", old)
    assert r.returncode == 3 and "damaged" not in r.stdout + r.stderr, r.stdout + r.stderr
    kept = ds.status.values == 1

    # Merged with the other shard, computed now: refused, the runs being of other numerics.
    part = tmp_path / "part2.h5"
    assert run("run", sweep, "--shard", "2/2", "-o", part, "--quiet").returncode == 3
    with h5py.File(part, "r") as f:
        numerics = int(f.attrs["numerics_version"])
    assert numerics > 3
    merged = tmp_path / "merged.h5"
    r = run("merge", "-o", merged, old, part)
    assert r.returncode == 1 and "point 0 has run hash" in r.stderr, r.stderr
    assert "made by a different engine version" in r.stderr and not merged.exists()
    # Resumed: its runs computed again, the other shard's computed. (The fixture keeps no work
    # directory: git keeps no empty folder, and a finished sweep's work directory holds no run.)
    (tmp_path / "layout3.h5.d").mkdir()
    r = run("run", sweep, "-o", old)
    assert r.returncode == 3 and "already done" not in r.stderr, r.stderr
    new = chainsweep.open(old)
    assert (new.status.values != 0).all()
    # The same steps; the peaks, located on the dense output since numerics version 8 rather
    # than refined through samples, within 1e-8.
    for p in ds.probe.values:
        np.testing.assert_allclose(new.leading_peak.sel(probe=p).values[kept],
                                   ds.leading_peak.sel(probe=p).values[kept], rtol=1e-8, err_msg=p)
    assert np.array_equal(new.steps.values[kept], ds.steps.values[kept])
    assert not set(new.run_hash.values.ravel()) & set(ds.run_hash.values.ravel())
    with h5py.File(old, "r") as f:
        assert int(f.attrs["layout_version"]) == 6
        assert int(f.attrs["numerics_version"]) == numerics
    report = cfchecks(old, tables, tmp_path)
    assert report.returncode == 0, report.stdout
