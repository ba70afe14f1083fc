"""`--json` of `validate`, `status` and `run --dry-run`: one JSON object on stdout, of the shape
docs/REFERENCE.md documents, saying what the text output says (same counts, same exit codes)."""

import json

import h5py
import numpy as np

from conftest import base_sweep, run, write_sweep


def as_json(*args):
    r = run(*args, "--json")
    doc = json.loads(r.stdout)  # stdout holds the one object and nothing else
    assert doc["chainsweep"] == 1
    return r, doc


def test_validate_json_of_a_valid_and_an_invalid_file(tmp_path, binary):
    path = write_sweep(tmp_path / "s.json", base_sweep())
    r, d = as_json("validate", path)
    assert r.returncode == 0
    assert d["kind"] == "validate" and d["valid"] is True and d["errors"] == []
    assert d["points"] == 6 and d["shape"] == [3, 2]
    assert [dim["name"] for dim in d["dims"]] == ["mass_ratio", "damping_kg_s"]
    assert d["dims"][1]["axes"][0] == {
        "name": "damping_kg_s", "field": "physics.damping_kg_s", "units": "kg/s", "values": [0, 6]}
    assert d["record"]["probes"] == ["gauge_force_cyl2", "gauge_force_cyl8"]

    bad = base_sweep()
    bad["base"]["physics"]["dampng"] = 1
    bad["limits"] = {"energy_drift_max": -1}
    path = write_sweep(tmp_path / "bad.json", bad)
    r, d = as_json("validate", path)
    assert r.returncode == 2 and d["valid"] is False
    fields = sorted(e["field"] for e in d["errors"])
    assert fields == ["base.physics.dampng", "limits.energy_drift_max"], d
    assert r.stderr == ""


def test_status_and_dry_run_json_agree_with_the_file(tmp_path, binary):
    sweep = base_sweep()
    # A step budget of 50 fails its runs at once, with a reason.
    sweep["axes"][1] = {"field": "max_steps", "values": [100000000, 50, 200000000]}
    path = write_sweep(tmp_path / "s.json", sweep)
    out = tmp_path / "out.h5"
    r, d = as_json("run", path, "-o", out, "--dry-run")
    assert r.returncode == 0 and d["kind"] == "dry_run"
    assert d["runs"] == {"done": 0, "failed": 0, "to_run": 9}
    assert d["points_listed"] == 9 and [p["point"] for p in d["list"]] == list(range(9))
    assert d["list"][4]["values"] == {"mass_ratio": 0.55, "max_steps": 50}
    assert all(p["stored"] is None for p in d["list"])
    assert d["size_bytes"]["total_estimate"] > 0

    r = run("run", path, "-o", out, "--quiet")
    code = r.returncode
    r, f = as_json("status", out)
    assert r.returncode == code and f["exit_code"] == code
    with h5py.File(out, "r") as h:
        status = h["status"][...].ravel()
    assert code == 3 and (status == 2).sum() == 3
    assert f["counts"] == {
        "ok": int((status == 1).sum()), "failed": int((status == 2).sum()), "pending": int((status == 0).sum()),
        "unsettled": int((status == 3).sum())}
    assert sorted(x["point"] for x in f["failures"]) == list(np.flatnonzero(status == 2))
    assert all(x["reason"] for x in f["failures"])

    r, s = as_json("status", path, "-o", out)
    assert s["kind"] == "status_sweep" and s["counts"] == f["counts"] and s["exit_code"] == code
    for x in s["failures"]:
        assert x["values"]["max_steps"] == 50

    r, d = as_json("run", path, "-o", out, "--dry-run")
    assert d["runs"]["to_run"] == 0
    assert [p["stored"] for p in d["list"]] == [{1: "ok", 2: "failed"}[int(x)] for x in status]
    r, p = run("point", path, "4", "--scene-only"), None
    assert json.loads(r.stdout)["run_hash"] == d["list"][4]["run_hash"]


def test_status_json_of_shard_files(tmp_path, binary):
    path = write_sweep(tmp_path / "s.json", base_sweep())
    parts = [tmp_path / f"s.shard-{k}-of-3.h5" for k in (1, 2, 3)]
    for k in (1, 3):
        r = run("run", path, "--shard", f"{k}/3", "-o", parts[k - 1], "--quiet")
        assert r.returncode == 0, r.stderr
    r, d = as_json("status", parts[0], parts[2])
    assert r.returncode == 3 and d["kind"] == "status_shards" and d["shards"] == 3
    assert [e["state"] for e in d["list"]] == ["done", "missing", "done"]
    assert d["list"][1]["file"] is None and d["list"][1]["counts"] is None
    assert d["to_run"]["shards"] == [2] and d["to_run"]["array_tasks"] == [1]


def test_json_needs_dry_run(tmp_path, binary):
    path = write_sweep(tmp_path / "s.json", base_sweep())
    r = run("run", path, "--json")
    assert r.returncode == 2 and "--dry-run" in r.stderr
    assert list(tmp_path.iterdir()) == [path]
