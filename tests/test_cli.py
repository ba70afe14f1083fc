"""The command line: help with examples, validate, dry run, progress output, quiet, status,
usage errors (exit 2, nothing written)."""

import json

from conftest import base_sweep, run, write_sweep


def test_help_has_examples(binary):
    r = run("--help")
    assert r.returncode == 0
    assert "Examples:" in r.stdout and "chainsweep run" in r.stdout and "merge" in r.stdout
    assert "Exit codes" in r.stdout
    for sub in ("run", "validate", "status", "merge", "point"):
        r = run(sub, "--help")
        assert r.returncode == 0, sub
        assert "Example" in r.stdout, sub


def test_usage_errors_exit_2(binary, tmp_path):
    path = write_sweep(tmp_path / "s.json", base_sweep())
    for args in (
        ["run", path, "--jobs", "0"],
        ["run", path, "--shard", "4/3"],
        ["run", path, "--shard", "x"],
        ["run", path, "--no-such-flag"],
        ["run", path, "-o", tmp_path / "missing-dir" / "x.h5"],
        ["frobnicate"],
    ):
        r = run(*args, cwd=tmp_path)
        assert r.returncode == 2, (args, r.stderr)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.json"]


def test_validate(binary, tmp_path):
    path = write_sweep(tmp_path / "s.json", base_sweep())
    r = run("validate", path)
    assert r.returncode == 0, r.stderr
    assert "6 grid points" in r.stdout
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.json"]


def test_dry_run_prints_grid_and_estimate(binary, tmp_path):
    path = write_sweep(tmp_path / "s.json", base_sweep(history=True))
    r = run("run", path, "--dry-run", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert "grid: 6 points (shape 3 × 2)" in r.stdout
    assert "estimated output size" in r.stdout
    assert "mass_ratio=0.55 damping_kg_s=6" in r.stdout
    assert "201 samples" in r.stdout
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.json"]


def test_plain_progress_when_not_a_terminal_and_quiet(binary, tmp_path):
    s = base_sweep()
    path = write_sweep(tmp_path / "s.json", s)
    r = run("run", path, "-o", tmp_path / "a.h5", "--jobs", "2", "--progress-interval", "0.01")
    assert r.returncode == 0
    assert "chainsweep: 6/6 runs done, 0 failed" in r.stderr
    assert "runs/s" in r.stderr and "ETA" in r.stderr
    assert "6 runs: 6 ok, 0 failed, 0 pending" in r.stderr
    r = run("run", path, "-o", tmp_path / "b.h5", "--quiet")
    assert r.returncode == 0
    assert r.stderr == "" and r.stdout == ""


def test_default_output_and_status(binary, tmp_path):
    path = write_sweep(tmp_path / "mysweep.json", base_sweep())
    r = run("status", path, cwd=tmp_path)
    assert r.returncode == 3
    assert "6 runs: 0 done (0 ok, 0 failed), 6 pending" in r.stdout
    r = run("run", path, "--quiet", cwd=tmp_path)
    assert r.returncode == 0
    assert (tmp_path / "mysweep.h5").exists()
    r = run("status", path, cwd=tmp_path)
    assert r.returncode == 0
    assert "6 done (6 ok, 0 failed), 0 pending" in r.stdout
    r = run("status", tmp_path / "mysweep.h5")
    assert r.returncode == 0
    assert "6 done (6 ok, 0 failed), 0 pending" in r.stdout


def test_foreign_output_is_not_overwritten(binary, tmp_path):
    path = write_sweep(tmp_path / "s.json", base_sweep())
    out = tmp_path / "precious.h5"
    out.write_bytes(b"not ours")
    r = run("run", path, "-o", out)
    assert r.returncode == 2
    assert "--overwrite" in r.stderr
    assert out.read_bytes() == b"not ours"
    r = run("run", path, "-o", out, "--overwrite", "--quiet")
    assert r.returncode == 0


def test_point_prints_scene_and_result(binary, tmp_path):
    path = write_sweep(tmp_path / "s.json", base_sweep())
    r = run("point", path, 3)
    assert r.returncode == 0
    p = json.loads(r.stdout)
    assert p["grid_index"] == [1, 1]
    assert p["scene"]["physics"]["damping_kg_s"] == 6
    assert p["result"]["ok"] is True
    r = run("point", path, 6)
    assert r.returncode == 2
