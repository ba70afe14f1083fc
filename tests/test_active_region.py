"""Long chains integrated only where they move (the solver's `active_region`): a sweep
file may switch it off, the default leaves run hashes as they were, and `--verify` (the runner's
re-run at a hundred times tighter tolerance) passes with it on, with errors like the whole chain's."""

import copy
import hashlib
import json
import signal
import subprocess
import time

import chainsweep
import h5py
import numpy as np
import pytest
import xarray as xr

from conftest import BIN, base_sweep, log_records, log_segments, run, texts, with_axes, write_sweep


def long_sweep():
    """The 0.55 chain with 300 cylinders (602 particles: long enough to qualify), mu = 6 kg/s,
    0.5 ms, rtol 1e-7, the moving part against the whole chain."""
    s = base_sweep(cylinders=300, duration_s=5e-4, probes=(4, 21))
    s["base"]["physics"]["damping_kg_s"] = 6.0
    s["base"]["integrator"]["rtol"] = 1e-7
    return with_axes(s, [{"field": "active_region", "values": ["auto", "off"]}])


def test_verify_passes_with_the_moving_part_only(tmp_path):
    path = write_sweep(tmp_path / "long.json", long_sweep())
    out = tmp_path / "long.h5"
    r = run("run", path, "-o", out, "--verify", "1", "--jobs", "2")
    assert r.returncode == 0, r.stderr
    with h5py.File(out, "r") as f:
        assert list(f["status"][...]) == [1, 1]
        assert list(f["verified"][...]) == [1, 1]
        err = f["verify_rel_error_max"][...]
        peaks = f["leading_peak"][...]
    auto, off = err
    # The moving part is as accurate as the whole chain against the tighter re-run.
    assert auto <= 3 * off + 1e-7, (auto, off)
    assert off < 1e-4
    np.testing.assert_allclose(peaks[0], peaks[1], rtol=1e-5)


def test_default_leaves_the_run_hash_and_off_changes_it(tmp_path):
    s = long_sweep()
    plain = copy.deepcopy(s)
    plain["axes"] = [{"field": "duration_s", "values": [5e-4]}]
    explicit = copy.deepcopy(plain)
    explicit["base"]["active_region"] = "auto"
    off = copy.deepcopy(plain)
    off["base"]["active_region"] = "off"
    hashes = []
    for name, sweep in (("plain", plain), ("explicit", explicit), ("off", off)):
        r = run("run", write_sweep(tmp_path / f"{name}.json", sweep), "--dry-run")
        assert r.returncode == 0, r.stderr
        hashes.append(r.stdout.strip().splitlines()[-1].split()[-1])
    assert hashes[0] == hashes[1]
    assert hashes[2] != hashes[0]


def test_bad_value_names_the_field_and_the_allowed_values(tmp_path):
    s = long_sweep()
    s["base"]["active_region"] = "sometimes"
    s["axes"] = [{"field": "duration_s", "values": [5e-4]}]
    r = run("validate", write_sweep(tmp_path / "bad.json", s))
    assert r.returncode == 2
    assert "active_region" in r.stderr and "auto" in r.stderr and "off" in r.stderr, r.stderr


# What the store keeps of each run: `integrated_particles` (particles integrated at the end) and the
# `moving_part` flag (0 failed, pending or not known, 1 the whole chain, 2 only the moving part).

LONG_PARTICLES = 2 * 300 + 2  # 300 cylinders, their tall neighbours and the striker
INITIAL = 16  # the solver's integrated prefix at the start
BLOCK = 8  # and its growth step
DAMPINGS = [0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 8.0, 10.0, 20.0]
STORED = ("integrated_particles", "moving_part")


def store_sweep():
    """The long chain with the moving part on and off over ten dampings: 20 short runs, enough of
    them for a kill to land in the middle of the sweep."""
    return with_axes(
        long_sweep(),
        [
            {"field": "active_region", "values": ["auto", "off"]},
            {"field": "physics.damping_kg_s", "values": DAMPINGS},
        ],
    )


def stored(out):
    with h5py.File(out, "r") as f:
        return {name: f[name][...] for name in (*STORED, "status")}


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    d = tmp_path_factory.mktemp("integrated")
    path = write_sweep(d / "store.json", store_sweep())
    out = d / "ref.h5"
    r = run("run", path, "-o", out, "--jobs", "2", "--quiet")
    assert r.returncode == 0, r.stderr
    return path, out


def test_the_store_says_how_much_of_each_chain_was_integrated(tmp_path):
    s = with_axes(
        long_sweep(),
        [
            {"field": "active_region", "values": ["auto", "off"]},
            {"field": "max_steps", "values": [100000000, 3]},
        ],
    )
    out = tmp_path / "long.h5"
    r = run("run", write_sweep(tmp_path / "long.json", s), "-o", out, "--jobs", "2")
    # The runs stopped by their step budget fail (exit 3: some runs failed), and keep no
    # integrated part.
    assert r.returncode == 3, r.stderr
    with h5py.File(out, "r") as f:
        n = f["integrated_particles"]
        assert n.dtype == np.int64
        assert [d[0].name for d in n.dims] == ["/active_region", "/max_steps"]
        assert n.dims[0][0].name == "/active_region"
        assert n.attrs["units"] == "1"
        assert n.attrs["long_name"] == "integrated particles"
        assert n.attrs["comment"].startswith("particles integrated at the end of the run")
        assert n.attrs["_FillValue"] == -1
        flag = f["moving_part"]
        assert flag.dtype == np.uint8
        assert [d[0].name for d in flag.dims] == ["/active_region", "/max_steps"]
        assert list(flag.attrs["flag_values"]) == [0, 1, 2]
        assert flag.attrs["flag_meanings"] == "not_known whole_chain moving_part"
        assert f["status"][...].tolist() == [[1, 2], [1, 2]]
        (auto, auto_failed), (off, off_failed) = n[...].tolist()
        assert flag[...].tolist() == [[2, 0], [1, 0]]
    # auto: a prefix that grew from its initial part by whole blocks, short of the chain (the pulse
    # reaches a few dozen cylinders in 0.5 ms); off: the whole chain.
    assert INITIAL <= auto < LONG_PARTICLES and (auto - INITIAL) % BLOCK == 0, auto
    assert off == LONG_PARTICLES
    assert auto_failed == off_failed == -1

    # xarray reads them labelled by the sweep's axes, the failed runs masked.
    for engine in ("h5netcdf", "netcdf4"):
        ds = xr.open_dataset(out, engine=engine).load()
        n = ds["integrated_particles"]
        assert n.dims == ("active_region", "max_steps")
        assert n.attrs["units"] == "1"
        assert n.sel(active_region="off", max_steps=100000000).item() == LONG_PARTICLES
        assert n.sel(active_region="auto", max_steps=100000000).item() == auto
        assert np.isnan(n.sel(max_steps=3)).all()
        m = ds["moving_part"]
        assert m.dims == ("active_region", "max_steps")
        assert m.sel(max_steps=100000000).values.tolist() == [2, 1]
    # So does the project's reader.
    ds = chainsweep.open(out)
    assert ds["integrated_particles"].dims == ("active_region", "max_steps")
    assert ds["integrated_particles"].sel(active_region="auto", max_steps=100000000) == auto
    assert ds["moving_part"].sel(active_region="off", max_steps=100000000) == 1

    # `point` prints the same of a run.
    r = run("point", tmp_path / "long.json", 0, "-o", out)
    assert r.returncode == 0, r.stderr
    res = json.loads(r.stdout)["result"]
    assert (res["integrated_particles"], res["moving_part"]) == (auto, True)


def test_short_chains_store_nothing_of_it(tmp_path):
    """No point can integrate only its moving part: every run integrates its whole chain, and the
    file leaves the columns out (they would only repeat the chain's length)."""
    s = with_axes(base_sweep(), [{"field": "active_region", "values": ["auto", "off"]}])
    path = write_sweep(tmp_path / "short.json", s)
    out = tmp_path / "short.h5"
    r = run("run", path, "-o", out, "--quiet")
    assert r.returncode == 0, r.stderr
    with h5py.File(out, "r") as f:
        assert f["status"][...].tolist() == [1, 1]
        assert not any(name in f for name in STORED), list(f)
    ds = xr.open_dataset(out, engine="h5netcdf")
    assert not any(name in ds for name in STORED)
    # The run itself still knows: the whole 22-particle chain.
    r = run("point", path, 0, "-o", out)
    res = json.loads(r.stdout)["result"]
    assert (res["integrated_particles"], res["moving_part"]) == (2 * 10 + 2, False)
    # Resuming keeps the file as it was: nothing recomputed, still no columns.
    r = run("run", path, "-o", out)
    assert r.returncode == 0 and "nothing to do" in r.stderr, r.stderr
    with h5py.File(out, "r") as f:
        assert not any(name in f for name in STORED)


def test_the_reference_integrates_what_active_region_says(reference):
    _, out = reference
    got = stored(out)
    assert (got["status"] == 1).all()
    assert (got["moving_part"][0] == 2).all() and (got["moving_part"][1] == 1).all()
    assert (got["integrated_particles"][1] == LONG_PARTICLES).all()
    part = got["integrated_particles"][0]
    assert ((part >= INITIAL) & (part < LONG_PARTICLES) & ((part - INITIAL) % BLOCK == 0)).all(), part


def _records(out):
    """Every stored record of the work directory's logs: run hash (hex) -> record bytes."""
    return {seg[8:40].hex(): seg for _, seg in log_segments(out)}


def _integrated_of(rec):
    """(moving part, particles) of a format-4 record (the part before its last flag byte, which
    says no spectrum was recorded, and its checksum: a flag byte, then for a successful run the
    moving-part byte and the count), or None for a failed one."""
    body = rec[:-32]
    assert body[:8] == b"CSWSEG\x00\x04", body[:8]
    assert body[-1] == 0  # no spectrum
    body = body[:-1]
    if rec[40] != 1:  # failed: nothing kept
        assert body[-1] == 0
        return None
    assert body[-10] == 1 and body[-9] in (0, 1), body[-10:]
    return bool(body[-9]), int.from_bytes(body[-8:], "little")


def _as_format_2(rec):
    """A format-4 record as earlier versions wrote it (format 2: without the integrated part and
    the spectrum's flag)."""
    body = rec[:-32]
    tail = 1 + (1 + 1 + 8 if _integrated_of(rec) is not None else 1)
    old = b"CSWSEG\x00\x02" + body[8:-tail]
    return old + hashlib.sha256(old).digest()


def _kill_mid_sweep(path, out, at_least):
    """Starts the sweep and kills it (SIGKILL) once `at_least` runs are stored in its log."""
    p = subprocess.Popen(
        [str(BIN), "run", path, "-o", out, "--jobs", "1", "--quiet"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    deadline = time.monotonic() + 120
    while len(log_records(out)) < at_least:
        assert p.poll() is None, "the sweep ended before it could be interrupted"
        assert time.monotonic() < deadline
        time.sleep(0.002)
    p.send_signal(signal.SIGKILL)
    p.wait()
    stored_runs = _records(out)
    assert at_least <= len(stored_runs) < 20, len(stored_runs)
    return stored_runs


def _hashes(out):
    with h5py.File(out, "r") as f:
        return list(texts(f["run_hash"]).ravel())


def test_resume_after_a_kill_keeps_what_each_run_integrated(reference, tmp_path):
    path, ref = reference
    out = tmp_path / "killed.h5"
    before = _kill_mid_sweep(path, out, at_least=3)
    # The records in the log carry what each run integrated, as the finished file has it.
    want = stored(ref)
    hashes = _hashes(ref)
    flat = {k: v.ravel() for k, v in want.items()}
    for h, rec in before.items():
        i = hashes.index(h)
        moving, n = _integrated_of(rec)
        assert (moving, n) == (flat["moving_part"][i] == 2, flat["integrated_particles"][i])
    r = run("run", path, "-o", out, "--jobs", "2")
    assert r.returncode == 0, r.stderr
    assert f"{len(before)} of 20 runs already done" in r.stderr, r.stderr
    got = stored(out)
    for name in (*STORED, "status"):
        np.testing.assert_array_equal(got[name], want[name], err_msg=name)


def test_records_of_earlier_versions_resume_with_the_integrated_part_not_known(reference, tmp_path):
    """A work directory of a version that did not keep the integrated part (record format 2): its
    runs are reused, not recomputed, and the file says it does not know what they integrated."""
    path, ref = reference
    out = tmp_path / "old.h5"
    before = _kill_mid_sweep(path, out, at_least=3)
    logs = out.parent / (out.name + ".d") / "logs"
    for log in logs.glob("*.log"):
        log.unlink()
    frames = b"".join(
        len(old).to_bytes(8, "little") + old for old in map(_as_format_2, before.values())
    )
    (logs / "00000001.log").write_bytes(frames)
    if out.exists():
        out.unlink()  # an output published before the kill holds the new records
    r = run("run", path, "-o", out, "--jobs", "2")
    assert r.returncode == 0, r.stderr
    assert f"{len(before)} of 20 runs already done" in r.stderr, r.stderr
    got = {k: v.ravel() for k, v in stored(out).items()}
    want = {k: v.ravel() for k, v in stored(ref).items()}
    old = np.array([h in before for h in _hashes(out)])
    assert (got["status"] == 1).all()
    assert (got["integrated_particles"][old] == -1).all()
    assert (got["moving_part"][old] == 0).all()
    for name in STORED:
        np.testing.assert_array_equal(got[name][~old], want[name][~old], err_msg=name)
    # The old records stay readable beside the file (merge and status read the file).
    r = run("status", out)
    assert r.returncode == 0, r.stdout + r.stderr


def test_merge_keeps_what_each_run_integrated(reference, tmp_path):
    path, ref = reference
    parts = []
    for k in (1, 2):
        part = tmp_path / f"part-{k}.h5"
        r = run("run", path, "--shard", f"{k}/2", "-o", part, "--quiet")
        assert r.returncode == 0, r.stderr
        with h5py.File(part, "r") as f:
            # A shard's pending points hold the fills.
            pending = f["status"][...] == 0
            assert pending.any()
            assert (f["integrated_particles"][...][pending] == -1).all()
            assert (f["moving_part"][...][pending] == 0).all()
        parts.append(part)
    merged = tmp_path / "merged.h5"
    r = run("merge", "-o", merged, *parts)
    assert r.returncode == 0, r.stderr
    got, want = stored(merged), stored(ref)
    for name in (*STORED, "status"):
        np.testing.assert_array_equal(got[name], want[name], err_msg=name)
    ds = xr.open_dataset(merged, engine="h5netcdf")
    assert ds["integrated_particles"].dims == ("active_region", "damping_kg_s")
    assert (ds["integrated_particles"].sel(active_region="off") == LONG_PARTICLES).all()


def test_chainsweep_run_says_how_much_of_its_chain_it_integrated(reference):
    """chainsweep.run keeps the two as a file does: for a scene that can integrate only its moving
    part, with the file's values and labels; not for a scene that cannot (a short chain, or the
    long one with `active_region: off`), where they would repeat the chain's length."""
    _, out = reference
    spec = store_sweep()
    ds = chainsweep.open(out)
    scene = copy.deepcopy(spec["base"])
    scene["physics"]["damping_kg_s"] = 6.0
    one = chainsweep.run(scene, record=spec["record"])
    want = ds.sel(active_region="auto", damping_kg_s=6.0)
    assert one.integrated_particles.dtype == np.int64
    assert one.integrated_particles.item() == want.integrated_particles.item()
    assert INITIAL <= one.integrated_particles.item() < LONG_PARTICLES
    assert one.moving_part.item() == want.moving_part.item() == 2
    for name in STORED:
        for key in ("units", "long_name", "flag_meanings"):
            assert one[name].attrs.get(key) == want[name].attrs.get(key), (name, key)
    assert list(one.moving_part.attrs["flag_values"]) == [0, 1, 2]
    plain = chainsweep.run(scene, record=spec["record"], as_dataset=False)
    assert (plain["integrated_particles"], plain["moving_part"]) == (one.integrated_particles.item(), 2)
    scene["active_region"] = "off"
    short = base_sweep()
    for other in (chainsweep.run(scene, record=spec["record"]),
                  chainsweep.run(dict(short["base"], record=short["record"]))):
        assert not any(name in other for name in STORED), list(other.data_vars)
