"""chainsweep.run: one scene in-process, bitwise equal to `chainsweep point`; labelled Dataset and
plain arrays; bad input naming the field; failed runs; integrator auto; the GIL released."""

from __future__ import annotations

import copy
import signal
import subprocess
import sys
import json
import threading
import time

import h5py
import numpy as np
import pytest
import xarray as xr

import chainsweep
from conftest import run as cli
from scenes import point_scene, scene, set_path, sweep_spec, write


def bits(x) -> bytes:
    return np.float64(x).tobytes()


def same_float(ours, theirs) -> bool:
    """`chainsweep point` prints non-finite numbers as null."""
    if theirs is None:
        return not np.isfinite(ours)
    return bits(ours) == bits(theirs)


@pytest.fixture(scope="module")
def rich(tmp_path_factory, binary):
    """A sweep over damping and striker velocity (30 m/s: validity warnings) recording six kinds
    of probes, histories and minimum overlaps; run by the binary into HDF5."""
    d = tmp_path_factory.mktemp("rich")
    spec = sweep_spec(history=True)
    spec["record"]["probes"] += [
        {"kind": "velocity", "particle": 5},
        {"kind": "contact_force", "contact": 3},
        {"kind": "overlap", "contact": 4},
        {"kind": "displacement", "particle": 7},
        {"kind": "wall_force"},
    ]
    spec["record"]["min_overlap"] = True
    spec["axes"] = [
        {"field": "physics.damping_kg_s", "values": [0, 6]},
        {"field": "striker_velocity_m_s", "values": [1.3, 30.0]},
    ]
    path = write(d / "rich.json", spec)
    out = d / "rich.h5"
    r = cli("run", path, "-o", out, "--jobs", "2", "--quiet")
    assert r.returncode == 0, r.stderr
    return spec, path, out


@pytest.mark.parametrize("index", [0, 1, 2, 3])
def test_run_equals_point_bitwise(rich, index):
    spec, path, _ = rich
    r = cli("point", path, index)
    assert r.returncode == 0, r.stderr
    point = json.loads(r.stdout)
    ds = chainsweep.run(point_scene(spec, index), record=spec["record"])
    res = point["result"]
    assert res["ok"] and ds.status.item() == 1 and ds.reason.item() == ""
    assert ds.run_hash.item() == point["run_hash"] == ds.attrs["run_hash"]
    assert json.loads(ds.attrs["scene"]) == point["scene"]
    for name in ("steps", "rejected_steps", "rhs_evals", "events"):
        assert ds[name].dtype == np.int64 and ds[name].item() == res[name], name
    for name in ("t_end_s", "energy_drift_max", "energy_drift_final", "momentum_residual_max",
                 "impact_energy_j", "max_overlap_m"):
        assert same_float(ds[name].item(), res[name]), name
    assert ds.warnings.item().splitlines() == res["warnings"]
    assert list(ds.probe.values) == [p["probe"] for p in res["probes"]]
    for k, p in enumerate(res["probes"]):
        for name in ("leading_peak", "leading_peak_time_s", "record_max", "record_max_time_s"):
            assert same_float(ds[name].values[k], p[name]), (name, p["probe"])
    assert ds.sizes["time_s"] == res["history_samples"]
    # the warnings of the 30 m/s points are real
    assert bool(res["warnings"]) == (point_scene(spec, index)["striker_velocity_m_s"] == 30.0)


def test_histories_and_min_overlaps_equal_the_files(rich):
    spec, _, out = rich
    with h5py.File(out, "r") as f:
        samples = f["history_samples"][()].ravel()
        overlaps = f["min_overlap_m"][()].reshape(len(samples), -1)
        assert (samples > 0).all() and len(samples) == 4
        for index in range(4):
            ds = chainsweep.run(point_scene(spec, index), record=spec["record"])
            m = int(samples[index])
            assert ds.time_s.values.tobytes() == f["time_s"][:m].tobytes()
            for k, p in enumerate(ds.probe.values):
                unit = ds.probe_units.sel(probe=p).item()
                stored = f[chainsweep._layout.split_name("history", unit)]
                row = stored[()].reshape(4, *stored.shape[-2:])[index, k, :m]
                assert ds.history.sel(probe=p).values.tobytes() == row.tobytes(), p
                assert "units" not in ds.history.attrs  # N and m/s: each probe's in probe_units
                assert stored.attrs["units"] == unit
            c = ds.sizes["contact"]
            assert ds.min_overlap_m.values.tobytes() == overlaps[index, :c].tobytes()
            assert np.isnan(overlaps[index, c:]).all()
            assert list(ds.contact.values) == list(range(1, ds.sizes["contact"] + 1))
            # gaps open (negative overlap) and the wall contact is the last one
            assert ds.sizes["contact"] == 2 * 10 + 2


def test_dataset_is_labelled():
    ds = chainsweep.run(scene())
    assert isinstance(ds, xr.Dataset)
    assert list(ds.probe.values) == ["gauge_force_cyl2", "gauge_force_cyl8"]
    assert list(ds.probe_units.values) == ["N", "N"]
    assert ds.leading_peak.dims == ("probe",) and ds.leading_peak.attrs["units"] == "N"
    assert ds.leading_peak_time_s.attrs["units"] == "s"
    for name in ("t_end_s", "energy_drift_max", "momentum_residual_max", "impact_energy_j",
                 "wall_time_s", "max_overlap_m", "steps", "rhs_evals", "events"):
        assert ds[name].dims == () and "units" in ds[name].attrs, name
    assert "history" not in ds and "time_s" not in ds.coords and "contact" not in ds.coords
    # physics: the pulse reaches cylinder 8 after cylinder 2, the ledger closes
    t = ds.leading_peak_time_s
    assert t.sel(probe="gauge_force_cyl8") > t.sel(probe="gauge_force_cyl2") > 0
    assert ds.energy_drift_max.item() < 1e-6
    striker = json.loads(ds.attrs["scene"])["chain"]["striker"]["mass_kg"]
    assert ds.impact_energy_j.item() == 0.5 * striker * 1.3 * 1.3
    assert ds.attrs["numerics_version"] >= 3 and ds.attrs["engine"] == "chainsweep"
    assert json.loads(ds.attrs["integrator"]) == {
        "method": "dop853", "rtol": 1e-9, "atol": None, "max_step_s": None, "locate_events": True}


def test_record_inside_or_beside_the_scene_is_the_same_run():
    s = scene()
    inside = chainsweep.run(s)
    record = s.pop("record")
    beside = chainsweep.run(s, record=record)
    assert inside.run_hash.item() == beside.run_hash.item()
    assert inside.leading_peak.values.tobytes() == beside.leading_peak.values.tobytes()
    with pytest.raises(chainsweep.InputError) as e:
        chainsweep.run(scene(), record=record)
    assert e.value.field == "record"


def test_plain_arrays():
    d = chainsweep.run(scene(history=True), as_dataset=False)
    ds = chainsweep.run(scene(history=True))
    assert isinstance(d, dict)
    assert isinstance(d["leading_peak"], np.ndarray) and d["leading_peak"].shape == (2,)
    assert d["history"].shape == (2, ds.sizes["time_s"])
    assert isinstance(d["steps"], np.int64) and d["steps"] == ds.steps.item()
    assert d["leading_peak"].tobytes() == ds.leading_peak.values.tobytes()
    assert d["history"].tobytes() == ds.history.values.tobytes()
    assert d["attrs"]["run_hash"] == ds.attrs["run_hash"]
    # a Dataset's own plain form works too
    assert ds.to_dict()["data_vars"]["steps"]["data"] == d["steps"]


def test_numpy_values_in_the_scene_are_accepted():
    s = scene()
    s["physics"]["damping_kg_s"] = np.float64(6.0)
    s["chain"]["cylinders"] = np.int64(10)
    t = scene()
    t["physics"]["damping_kg_s"] = 6.0
    assert chainsweep.run(s).run_hash.item() == chainsweep.run(t).run_hash.item()


def test_plain_values_are_read_as_their_json_text():
    """The engine reads a scene of plain values as the JSON text of it would read (bitwise the same
    run), and declines, running nothing, whatever that text would not give back exactly: the
    caller then writes the text, which converts numpy values and names what cannot be JSON."""
    from chainsweep import _chainsweep as native

    s = scene(history=True)
    s["physics"]["damping_kg_s"] = 6  # an int where the field is a float
    s["striker_velocity_m_s"] = np.float64(1.3)  # a float subclass: its float value
    s["physics"]["gravity"] = True
    s["record"]["probes"] = tuple(s["record"]["probes"])  # a JSON list
    record = s.pop("record")
    plain = native.run_scene(s, record)
    text = native.run_scene(json.dumps(s), json.dumps(record))
    assert plain is not None and plain["ok"]
    assert plain["run_hash"] == text["run_hash"] and plain["scene"] == text["scene"]
    for name in ("leading_peak", "record_max", "t_end_s", "steps", "rhs_evals"):
        assert plain["columns"][name] == text["columns"][name], name
    assert plain["history"] == text["history"]

    # Not plain: declined, whatever else the argument holds.
    for path, value in [
        ("physics.damping_kg_s", np.int64(6)),
        ("physics.damping_kg_s", float("nan")),
        ("physics.damping_kg_s", float("inf")),
        ("chain.cylinders", 2**70),
        ("chain.cylinders", object()),
    ]:
        t = copy.deepcopy(s)
        set_path(t, path, value)
        assert native.run_scene(t, record) is None, (path, value)
    assert native.run_scene(s, {**record, 3: 4}) is None
    assert native.run_scene(s, record, {"energy_drift_max": np.float32(1e-3)}) is None
    deep: dict = {}
    for _ in range(200):
        deep = {"x": deep}
    assert native.run_scene({**s, "extra": deep}, record) is None
    # Through chainsweep.run they take the written path: the same run, or the named field.
    t = copy.deepcopy(s)
    t["physics"]["damping_kg_s"] = np.int64(6)
    assert chainsweep.run({**t, "record": record}).run_hash.item() == plain["run_hash"]


@pytest.mark.parametrize(
    "path, value, field",
    [
        ("chain.cylinders", -1, "chain.cylinders"),
        ("chain.cylinders", "ten", "chain.cylinders"),
        ("chain.preset", "chain_077", "chain.preset"),
        ("chain.cylinder.mass.heavy_cylinders.mass_ratio", 1.5,
         "chain.cylinder.mass.heavy_cylinders.mass_ratio"),
        ("physics.damping_kg_s", -1.0, "physics.damping_kg_s"),
        ("physics.damping_kg_s", float("nan"), "physics.damping_kg_s"),
        ("physics.gravity", "yes", "physics.gravity"),
        ("striker_velocity_m_s", 0.0, "striker_velocity_m_s"),
        ("integrator", {"method": "euler"}, "integrator.method"),
        ("integrator.rtol", 1.0, "integrator.rtol"),
        ("integrator", {"method": "auto", "target_rel_error": 1e-12}, "integrator.target_rel_error"),
        ("max_steps", 0, "max_steps"),
        ("record.probes[1].cylinder", 99, "record.probes[1].cylinder"),
        ("record.history_interval_s", 0.0, "record.history_interval_s"),
        ("bogus", 1, "bogus"),
    ],
)
def test_bad_input_names_the_field(path, value, field):
    s = scene()
    set_path(s, path, value)
    with pytest.raises(chainsweep.InputError) as e:
        chainsweep.run(s)
    assert e.value.field == field
    assert isinstance(e.value, ValueError) and isinstance(e.value, chainsweep.Error)
    assert f"field `{field}`" in str(e.value)


def test_missing_field_and_bad_limits():
    s = scene()
    del s["duration_s"]
    with pytest.raises(chainsweep.InputError) as e:
        chainsweep.run(s)
    assert e.value.field == "duration_s"
    with pytest.raises(chainsweep.InputError) as e:
        chainsweep.run(scene(), limits={"energy_drift_max": -1})
    assert e.value.field == "limits.energy_drift_max"
    with pytest.raises(TypeError):
        chainsweep.run([scene()])


def test_failed_run_raises_with_its_record(tmp_path, binary):
    s = scene()
    s["max_steps"] = 20
    with pytest.raises(chainsweep.RunError) as e:
        chainsweep.run(s)
    err = e.value
    assert isinstance(err, RuntimeError) and "step budget of 20 steps exhausted" in err.reason
    ds = err.result
    assert ds.status.item() == 2 and ds.reason.item() == err.reason
    assert np.isnan(ds.leading_peak.values).all() and np.isnan(ds.energy_drift_max.item())
    assert np.isnan(ds.steps.item()) and ds.wall_time_s.item() > 0
    # the same reason as `chainsweep point` gives for the same scene
    spec = sweep_spec()
    spec["base"]["max_steps"] = 20
    spec["axes"] = [{"field": "duration_s", "values": [spec["base"]["duration_s"]]}]
    r = cli("point", write(tmp_path / "s.json", spec), 0)
    assert json.loads(r.stdout)["result"]["reason"] == err.reason
    with pytest.raises(chainsweep.RunError) as e:
        chainsweep.run(s, as_dataset=False)
    assert e.value.result["status"] == 2


def test_energy_drift_over_the_limit_fails_the_run():
    s = scene()
    s["integrator"] = {"method": "dop853", "rtol": 1e-5}
    with pytest.raises(chainsweep.RunError) as e:
        chainsweep.run(s, limits={"energy_drift_max": 1e-6})
    assert "exceeds the limit" in e.value.reason
    ds = chainsweep.run(s, limits={"energy_drift_max": None})
    assert ds.energy_drift_max.item() > 1e-6 and np.isnan(ds.attrs["energy_drift_limit"])


def test_a_panic_is_a_failed_run(monkeypatch):
    # The runner's testing aid: grid point 0 (run's only point) panics on purpose.
    monkeypatch.setenv("CHAINSWEEP_INJECT_PANIC", "0")
    with pytest.raises(chainsweep.RunError) as e:
        chainsweep.run(scene())
    assert e.value.reason.startswith("panic") and "injected panic" in e.value.reason
    monkeypatch.delenv("CHAINSWEEP_INJECT_PANIC")
    assert chainsweep.run(scene()).status.item() == 1


def test_integrator_auto_runs_the_pilot_as_point_does(tmp_path, binary):
    s = scene()
    s["integrator"] = {"method": "auto", "target_rel_error": 1e-4, "pilot_points": 1}
    ds = chainsweep.run(s)
    chosen = json.loads(ds.attrs["auto_setting"])
    assert chosen["method"] in ("dop853", "ros34pw2")
    assert json.loads(ds.attrs["integrator"]) == chosen
    assert json.loads(ds.attrs["auto"])["target_rel_error"] == 1e-4
    spec = sweep_spec()
    spec["base"]["integrator"] = s["integrator"]
    spec["axes"] = [{"field": "duration_s", "values": [spec["base"]["duration_s"]]}]
    r = cli("point", write(tmp_path / "auto.json", spec), 0)
    point = json.loads(r.stdout)
    assert point["scene"]["integrator"] == chosen
    assert point["run_hash"] == ds.run_hash.item()
    assert [p["leading_peak"] for p in point["result"]["probes"]] == list(ds.leading_peak.values)
    # the chosen setting, given explicitly, is the same run without the pilot
    s["integrator"] = chosen
    assert chainsweep.run(s).run_hash.item() == ds.run_hash.item()


def slow_scene() -> dict:
    """A run of 0.2–0.4 s (50 cylinders, 12 ms, rtol 1e-11): well above the 0.05 s the GIL test
    needs on a fast machine (3 ms took 0.0498 s on an Intel Xeon with AVX-512)."""
    s = scene(cylinders=50, duration_s=1.2e-2, probes=(4, 21))
    s["integrator"] = {"method": "dop853", "rtol": 1e-11}
    return s


def test_the_gil_is_released_while_the_solver_runs():
    # How fast this thread counts when nothing else runs...
    n, t0 = 0, time.perf_counter()
    while time.perf_counter() - t0 < 0.1:
        n += 1
    rate = n / (time.perf_counter() - t0)
    # ...and how far it counts while another thread runs a scene.
    out: list = []
    worker = threading.Thread(target=lambda: out.append(chainsweep.run(slow_scene())))
    counted = 0
    worker.start()
    while worker.is_alive():
        counted += 1
    worker.join()
    wall = out[0].wall_time_s.item()
    assert wall > 0.05
    # With the GIL held for the whole run this thread would count only while the worker runs
    # Python (a few ms); released, it counts through the run (at half speed on a shared core).
    assert counted > 0.1 * rate * wall, (counted, rate, wall)


def test_two_threads_run_scenes_at_once():
    scenes = [slow_scene(), slow_scene()]
    scenes[1]["physics"]["damping_kg_s"] = 6.0
    alone = [chainsweep.run(s) for s in scenes]
    results: dict = {}
    barrier = threading.Barrier(2)

    def work(k):
        barrier.wait()
        results[k] = chainsweep.run(copy.deepcopy(scenes[k]))

    threads = [threading.Thread(target=work, args=(k,)) for k in range(2)]
    start = time.perf_counter()
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    elapsed = time.perf_counter() - start
    walls = [results[k].wall_time_s.item() for k in range(2)]
    # Serialised runs would take at least the sum of their own wall times; overlapping ones less.
    assert elapsed < 0.9 * sum(walls), (elapsed, walls)
    for k in range(2):
        for name in ("leading_peak", "leading_peak_time_s", "record_max", "energy_drift_max",
                     "steps", "rhs_evals"):
            assert results[k][name].values.tobytes() == alone[k][name].values.tobytes(), name


RUN_INTERRUPTED = """
import json, signal, sys, time
import chainsweep
signal.signal(signal.SIGINT, signal.default_int_handler)
print("started", flush=True)
try:
    chainsweep.run(json.loads(sys.argv[1]), limits={"max_run_seconds": 600})
except KeyboardInterrupt:
    print(f"KeyboardInterrupt {time.monotonic()!r}", flush=True)
    sys.exit(130)
print("finished", flush=True)
"""


def test_ctrl_c_stops_a_run_within_a_second():
    """A long run (3 000 cylinders over 0.5 s: minutes) stops within a second of SIGINT and raises
    KeyboardInterrupt, as a notebook's interrupt needs (before, it ran on to its
    max_run_seconds)."""
    s = scene(cylinders=3000, duration_s=0.5, probes=(4, 21))
    proc = subprocess.Popen(
        [sys.executable, "-c", RUN_INTERRUPTED, json.dumps(s)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )
    assert proc.stdout.readline().strip() == "started"
    time.sleep(2.0)  # the run is under way
    assert proc.poll() is None
    sent = time.monotonic()
    proc.send_signal(signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 130, (stdout, stderr)
    word, at = stdout.split()
    assert word == "KeyboardInterrupt"
    assert float(at) - sent < 1.0, float(at) - sent
