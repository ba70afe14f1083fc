"""Results that cannot be silently wrong or lost: damage to a finished output file is reported run
by run (never served, never copied into a new file), repaired from the snapshot or by computing
the damaged runs again, and no command discards a finished run it was not asked to.

Each test damages a real file the way a bad day would: a flipped byte in a summary, a history
chunk, the superblock or an object header, a truncation, a symlink in the work directory; or
misuses the commands: a shard run into a complete output, an edited sweep reverted. The last test
flips single bytes of complete small results of every kind, one at a time, and counts what became of each
(a sample of 16 per kind on every `make test`, 120 per kind in `make test-system`).
"""

import collections
import fcntl
import json
import os
import random
import re
import shutil
import subprocess
import sys

import h5py
import numpy as np
import pytest
import xarray as xr

from conftest import BIN, REPO, assert_files_equal, base_sweep, log_records, run, texts, write_sweep

chainsweep = pytest.importorskip("chainsweep")


def sweep_2x3(history=False):
    """A 3 x 2 grid of 10-cylinder chains, 0.2 ms: 6 runs, two gauges."""
    return base_sweep(history=history)


def complete(tmp_path, sweep, name="x"):
    """Runs `sweep` to completion into `tmp_path/name.h5`; the sweep file and the output."""
    path = write_sweep(tmp_path / f"{name}.json", sweep)
    out = tmp_path / f"{name}.h5"
    r = run("run", path, "-o", out, "--quiet")
    assert r.returncode in (0, 3), r.stderr
    return path, out


def copy_output(out, dest):
    """Copies an output file and its work directory to `dest` (its snapshot included)."""
    shutil.copyfile(out, dest)
    shutil.copytree(out.parent / (out.name + ".d"), dest.parent / (dest.name + ".d"),
                    ignore=shutil.ignore_patterns("lock"))
    return dest


def flip(path, offset, mask=0x01):
    data = bytearray(path.read_bytes())
    data[offset] ^= mask
    path.write_bytes(bytes(data))


def value_offset(out, name, flat):
    """File offset of element `flat` (C order) of the chunked numeric dataset `name`."""
    with h5py.File(out, "r") as f:
        ds = f[name]
        assert ds.chunks == ds.shape, "one chunk: the element's offset is computable"
        info = ds.id.get_chunk_info(0)
        return info.byte_offset + flat * ds.dtype.itemsize


def point_index(out, **axes):
    """The flat index of the point whose coordinates are `axes`."""
    with h5py.File(out, "r") as f:
        dims = json.loads(f.attrs["dimensions"])
        shape = tuple(f.attrs["grid_shape"])
        idx = [int(np.flatnonzero(f[d][()] == axes[d])[0]) for d in dims]
    return int(np.ravel_multi_index(idx, shape))


def damaged_points(stdout):
    """The points `status` lists as damaged: a line each, `  point N (axis values): why`."""
    return sorted(int(m) for m in re.findall(r"^\s+point (\d+) \(", stdout, flags=re.M))


# 1. A shard run into a complete output does nothing; a shard into another shard's output keeps it.

def test_a_shard_into_a_complete_output_does_nothing_and_loses_nothing(tmp_path, binary):
    s = sweep_2x3()
    s["axes"][1]["values"] = [0, 2, 4, 6]  # 12 points
    path, out = complete(tmp_path, s)
    before = out.read_bytes()
    for shard in ("1/2", "2/2"):
        r = run("run", path, "--shard", shard, "-o", out)
        assert r.returncode == 0, r.stderr
        assert "nothing to do" in r.stderr
    assert out.read_bytes() == before
    r = run("status", out)
    assert r.returncode == 0 and "12 done (12 ok, 0 failed), 0 pending" in r.stdout, r.stdout

    # Shard 2/2 into the output of shard 1/2: both shards' runs end up in it.
    out2 = tmp_path / "shards.h5"
    assert run("run", path, "--shard", "1/2", "-o", out2, "--quiet").returncode == 0
    with h5py.File(out2, "r") as f:
        first = {h for h, st in zip(texts(f["run_hash"]).ravel(), f["status"][()].ravel()) if st}
    r = run("run", path, "--shard", "2/2", "-o", out2)
    assert r.returncode == 0, r.stderr
    with h5py.File(out2, "r") as f:
        held = {h for h, st in zip(texts(f["run_hash"]).ravel(), f["status"][()].ravel()) if st}
    assert first < held and len(held) == 12
    r = run("status", out2)
    assert "also holds 6 run(s) of other shards" in r.stdout, r.stdout
    # The unsharded sweep into it: nothing runs again.
    r = run("run", path, "-o", out2)
    assert r.returncode == 0 and "nothing to do" in r.stderr, r.stderr
    fresh = tmp_path / "fresh.h5"
    assert run("run", path, "-o", fresh, "--quiet").returncode == 0
    for f in (out2, fresh):
        with h5py.File(f, "r") as h:
            assert h.attrs["shard"] in ("1/1", "2/2")
    np.testing.assert_array_equal(xr.open_dataset(out2).leading_peak, xr.open_dataset(fresh).leading_peak)


# 2. One damaged history chunk costs its runs, and only its runs.

def history_chunk(out, flat):
    """The chunk of `history` holding point `flat`: its byte offset and size, and every point
    it holds (the runs along the grid's last axis that share it)."""
    with h5py.File(out, "r") as f:
        d = f["history"]
        grid = d.shape[:-2]
        c = d.chunks[:-2]
        mi = np.unravel_index(flat, grid)
        # The chunks in row-major order of the chunk grid (every probe and the whole time axis
        # in one). (HDF5 1.10 reports the offsets of a growable dataset's chunks wrongly, but
        # lists them in that order.)
        chunk_grid = [-(-n // k) for n, k in zip(grid, c)]
        assert d.id.get_num_chunks() == np.prod(chunk_grid)
        info = d.id.get_chunk_info(int(np.ravel_multi_index([int(m) // k for m, k in zip(mi, c)], chunk_grid)))
        held = [
            i
            for i in range(int(np.prod(grid)))
            if all(int(a) // n == int(b) // n for a, b, n in zip(np.unravel_index(i, grid), mi, c))
        ]
    return info.byte_offset, info.size, held


def test_a_damaged_history_chunk_is_reported_and_only_its_runs_recomputed(tmp_path, binary):
    path, out = complete(tmp_path, sweep_2x3(history=True))
    reference = copy_output(out, tmp_path / "reference.h5")
    k = point_index(out, mass_ratio=0.55, damping_kg_s=6)
    offset, size, held = history_chunk(out, k)
    assert k in held and len(held) < 6  # a chunk holds a few runs, not the file
    flip(out, offset + size // 2)
    with h5py.File(out, "r") as f, pytest.raises(OSError):
        f["history"][()]
    r = run("status", out)
    assert r.returncode == 3, r.stdout
    assert damaged_points(r.stdout) == held, r.stdout
    assert "histories or minimum overlaps cannot be read" in r.stdout, r.stdout
    with pytest.raises(chainsweep.DamagedFileError) as e:
        chainsweep.open(out, histories=True)
    assert [p[0] for p in e.value.damaged] == held
    # Their summaries are intact: open without histories serves them; masked, the other runs'
    # histories are served and the damaged ones NaN.
    chainsweep.open(out)
    ds = chainsweep.open(out, histories=True, damaged="mask")
    flat = ds.history.values.reshape(6, *ds.history.shape[2:])
    good = [i for i in range(6) if i not in held]
    assert np.isnan(flat[held]).all() and not np.isnan(flat[good][..., 0]).any()
    r = run("run", path, "-o", out)
    assert r.returncode == 0, r.stderr
    assert f"{len(held)} run(s) cannot be read back and will be computed again" in r.stderr
    assert f"point {k} (mass_ratio=0.55 damping_kg_s=6)" in r.stderr
    assert f"{6 - len(held)} of 6 runs already done" in r.stderr
    assert_files_equal(reference, out)
    assert run("status", out).returncode == 0


@pytest.mark.parametrize("name", ["min_overlap_m", "energy_passed_max_j"])
def test_a_damaged_per_run_array_of_a_history_sweep_is_reported_never_served_as_nan(tmp_path, binary, name):
    """In a sweep recording histories, minimum overlaps and the energy flow, a flipped byte in a
    chunk of the minimum overlaps or of the energy flow: `chainsweep.open` without the histories
    refuses, naming the damage (it once served NaN for every run of the chunk, which reads as
    "beyond the run's contacts"), or masks exactly the damaged runs when asked; `status` says so
    (exit 3); `run` gives the file back bitwise."""
    sweep = sweep_2x3(history=True)
    sweep["record"]["min_overlap"] = True
    sweep["record"]["energy_flow"] = True
    path, out = complete(tmp_path, sweep)
    reference = copy_output(out, tmp_path / "reference.h5")
    pristine = chainsweep.open(reference)
    with h5py.File(out, "r") as f:
        d = f[name]
        assert d.id.get_num_chunks() >= 1
        info = d.id.get_chunk_info(0)
    flip(out, info.byte_offset + info.size // 2)
    with pytest.raises(chainsweep.DamagedFileError) as e:
        chainsweep.open(out)
    held = sorted({p[0] for p in e.value.damaged})
    assert held, e.value
    masked = chainsweep.open(out, damaged="mask")
    flat = masked[name].values.reshape(6, -1)
    good = [i for i in range(6) if i not in held]
    assert np.isnan(flat[held]).all()
    np.testing.assert_array_equal(flat[good], pristine[name].values.reshape(6, -1)[good])
    r = run("status", out)
    assert r.returncode == 3 and "damaged" in r.stdout + r.stderr, r.stdout
    r = run("run", path, "-o", out)
    assert r.returncode == 0, r.stderr
    assert_files_equal(reference, out)


def test_merge_leaves_a_damaged_run_of_a_shard_pending_and_names_it(tmp_path, binary):
    path = write_sweep(tmp_path / "m.json", sweep_2x3(history=True))
    parts = []
    for k in (1, 2):
        part = tmp_path / f"part-{k}.h5"
        assert run("run", path, "--shard", f"{k}/2", "-o", part, "--quiet").returncode == 0
        parts.append(part)
    with h5py.File(parts[0], "r") as f:
        done = [i for i, st in enumerate(f["status"][()].ravel()) if st == 1]
        k = done[0]
    offset, _, held = history_chunk(parts[0], k)
    held = [i for i in held if i in done]
    flip(parts[0], offset + 3)
    merged = tmp_path / "merged.h5"
    r = run("merge", "-o", merged, *parts)
    assert r.returncode == 3, r.stderr
    assert all(f"point {i} (" in r.stderr for i in held), r.stderr
    assert "cannot be read back" in r.stderr, r.stderr
    assert "sbatch" not in r.stderr and "array" not in r.stderr
    with h5py.File(merged, "r") as f:
        st = f["status"][()].ravel()
    assert (st[held] == 0).all() and (np.delete(st, held) == 1).all()
    # Running the shard again computes the damaged run; the merge is then complete.
    r = run("run", path, "--shard", "1/2", "-o", parts[0])
    assert r.returncode == 0 and "will be computed again" in r.stderr, r.stderr
    assert run("merge", "-o", tmp_path / "merged2.h5", *parts).returncode == 0


# 3. A flipped byte in a summary: reported by every reader, restored, never copied.

def test_a_flipped_summary_byte_is_never_served_and_never_republished(tmp_path, binary):
    path, out = complete(tmp_path, sweep_2x3())
    reference = copy_output(out, tmp_path / "reference.h5")
    k = point_index(out, mass_ratio=1.0, damping_kg_s=0)
    # The high byte of leading_peak of probe 1 at point k: the value would double or halve.
    flip(out, value_offset(out, "leading_peak", 2 * k + 1) + 7, 0x10)
    with h5py.File(out, "r") as f, pytest.raises(OSError, match="filter"):
        f["leading_peak"][()]
    for engine in ("h5netcdf", "netcdf4"):
        with pytest.raises(Exception):
            xr.open_dataset(out, engine=engine).leading_peak.values
    with pytest.raises(chainsweep.DamagedFileError) as e:
        chainsweep.open(out)
    assert [p[0] for p in e.value.damaged] == [k]
    assert "mass_ratio=1.0 damping_kg_s=0" in str(e.value)
    masked = chainsweep.open(out, damaged="mask")
    good = chainsweep.open(reference)
    assert bool(masked.damaged.values.ravel()[k]) and int(masked.damaged.sum()) == 1
    lp, ref = masked.leading_peak.values.reshape(6, 2), good.leading_peak.values.reshape(6, 2)
    assert np.isnan(lp[k]).all()
    np.testing.assert_array_equal(np.delete(lp, k, axis=0), np.delete(ref, k, axis=0))
    r = run("status", path, "-o", out)
    assert r.returncode == 3 and "restored from its snapshot" in r.stdout, r.stdout
    # A run restores it from the snapshot: nothing computed, the file as it was.
    r = run("run", path, "-o", out)
    assert r.returncode == 0 and "6 of 6 runs already done" in r.stderr, r.stderr
    assert "1 damaged run(s) restored from its snapshot" in r.stderr
    assert_files_equal(reference, out)
    # Without a snapshot the damaged run is computed again: the same numbers, never the flipped.
    flip(out, value_offset(out, "leading_peak", 2 * k + 1) + 7, 0x10)
    (out.parent / (out.name + ".d") / "snapshot").unlink()
    r = run("run", path, "-o", out)
    assert r.returncode == 0 and "5 of 6 runs already done" in r.stderr, r.stderr
    assert_files_equal(reference, out)


def test_merge_takes_a_damaged_shard_run_from_its_snapshot_never_as_stored(tmp_path, binary):
    path = write_sweep(tmp_path / "m.json", sweep_2x3())
    single = tmp_path / "single.h5"
    assert run("run", path, "-o", single, "--quiet").returncode == 0
    parts = [tmp_path / f"part-{k}.h5" for k in (1, 2)]
    for k, part in enumerate(parts, start=1):
        assert run("run", path, "--shard", f"{k}/2", "-o", part, "--quiet").returncode == 0
    with h5py.File(parts[1], "r") as f:
        k = [i for i, st in enumerate(f["status"][()].ravel()) if st == 1][-1]
    flip(parts[1], value_offset(parts[1], "t_end_s", k) + 6, 0x40)
    merged = tmp_path / "merged.h5"
    r = run("merge", "-o", merged, *parts)
    assert r.returncode == 0 and "restored from its snapshot" in r.stderr, r.stderr
    assert_files_equal(single, merged)


# 4. Superblock, truncation and metadata damage: reported, restored, never a silent recompute.

@pytest.mark.parametrize("damage", ["superblock", "truncation"])
def test_a_file_hdf5_cannot_read_is_restored_from_its_snapshot(tmp_path, binary, damage):
    path, out = complete(tmp_path, sweep_2x3())
    reference = copy_output(out, tmp_path / "reference.h5")
    data = out.read_bytes()
    if damage == "superblock":
        out.write_bytes(b"\0" * 8 + data[8:])
        why = "does not start with the HDF5 signature"
    else:
        out.write_bytes(data[: len(data) // 2])
        why = "HDF5 cannot read it"
    r = run("status", out)
    assert r.returncode == 3, r.stdout + r.stderr
    assert why in r.stdout and "6 done (6 ok" in r.stdout and "restored" in r.stdout, r.stdout
    r = run("status", path, "-o", out)
    assert r.returncode == 3 and why in r.stdout, r.stdout
    with pytest.raises(chainsweep.DamagedFileError, match=why):
        chainsweep.open(out)
    r = run("run", path, "-o", out)
    assert r.returncode == 0, r.stderr
    assert why in r.stderr and "6 damaged run(s) restored from its snapshot" in r.stderr, r.stderr
    assert "6 of 6 runs already done" in r.stderr
    assert_files_equal(reference, out)
    kept = list((out.parent / (out.name + ".d") / "damaged").iterdir())
    assert len(kept) == 1 and kept[0].read_bytes() != reference.read_bytes()


def test_an_unreadable_history_file_says_what_is_lost_and_computes_it_again(tmp_path, binary):
    path, out = complete(tmp_path, sweep_2x3(history=True))
    reference = copy_output(out, tmp_path / "reference.h5")
    out.write_bytes(b"\0" * 8 + out.read_bytes()[8:])
    r = run("status", path, "-o", out)
    assert r.returncode == 3 and "its histories were only in the file" in r.stdout, r.stdout
    r = run("run", path, "-o", out)
    assert r.returncode == 0, r.stderr
    assert "6 run(s) cannot be read back and will be computed again" in r.stderr, r.stderr
    assert_files_equal(reference, out)


def test_a_damaged_object_header_is_reported_not_dropped(tmp_path, binary):
    path, out = complete(tmp_path, sweep_2x3())
    reference = copy_output(out, tmp_path / "reference.h5")
    with h5py.File(out, "r") as f:
        addr = h5py.h5o.get_info(f["leading_peak"].id).addr
    flip(out, addr + 2)
    with pytest.raises(chainsweep.DamagedFileError) as e:
        chainsweep.open(out)
    assert len(e.value.damaged) == 6 and "leading_peak" in str(e.value)
    masked = chainsweep.open(out, damaged="mask")
    assert "leading_peak" in masked and masked.leading_peak.isnull().all()
    assert bool(masked.damaged.all())
    r = run("run", path, "-o", out)
    assert r.returncode == 0 and "6 damaged run(s) restored" in r.stderr, r.stderr
    assert_files_equal(reference, out)


@pytest.mark.parametrize("where", ["probe_strlen header", "root attribute name"])
def test_damage_a_reader_needs_is_reported_by_status_and_open(tmp_path, binary, where):
    """Structures every reader needs, which no dataset checksum covers: the object header of
    `probe_strlen` (a netCDF dimension without a variable; damaged, both xarray engines fail) and
    the root's attributes beside `header_checksum` (damaged, a file once read as an old layout
    without checksums). `status` and `chainsweep.open` report the damage, never a bare error or
    "no checksums"; `run` gives the file back bitwise."""
    path, out = complete(tmp_path, sweep_2x3())
    reference = copy_output(out, tmp_path / "reference.h5")
    if where == "probe_strlen header":
        with h5py.File(out, "r") as f:
            offset = h5py.h5o.get_info(f["probe_strlen"].id).addr + 2
    else:
        offset = out.read_bytes().index(b"header_checksum") + 4
    flip(out, offset)
    r = run("status", out)
    said = r.stdout + r.stderr
    assert r.returncode in (1, 3) and ("damaged" in said or "cannot be read" in said), said
    assert "no checksums" not in said, said
    with pytest.raises(chainsweep.DamagedFileError):
        chainsweep.open(out)
    r = run("run", path, "-o", out)
    assert r.returncode == 0, r.stderr
    assert_files_equal(reference, out)


def test_a_damaged_dimension_list_is_reported_not_left_to_a_reader(tmp_path, binary):
    """The scales that label a dataset's dimensions (its DIMENSION_LIST) lie in the file's global
    heap, which no HDF5 checksum covers, nor the file's own. A flipped byte there (a reference to
    a scale, or the index of the heap object that holds it) is damage that `status` and
    `chainsweep.open` report, rather than xarray failing on it or labelling the data wrongly."""
    path, out = complete(tmp_path, base_sweep(history=True))
    data = out.read_bytes()
    with h5py.File(out, "r") as f:
        scale = h5py.h5o.get_info(f["mass_ratio"].id).addr
    # Each list of a dimension's scales is one heap object: 16 bytes of header (its index first),
    # then the references. Those naming `mass_ratio` (every column's first dimension):
    heaps = [m.start() for m in re.finditer(b"GCOL", data)]
    in_heap = [(g, g + int.from_bytes(data[g + 8:g + 16], "little")) for g in heaps]
    spots = [m.start() for m in re.finditer(re.escape(scale.to_bytes(8, "little")), data)
             if any(a <= m.start() < b for a, b in in_heap)]
    assert len(spots) >= 10, spots
    for n, (offset, mask) in enumerate([(spots[0], 0x08), (spots[-1], 0x40),
                                        (spots[1] - 16, 0x01), (spots[-2] - 16, 0x02)]):
        work = tmp_path / f"flip{n}"
        work.mkdir()
        damaged = copy_output(out, work / "x.h5")
        flip(damaged, offset, mask)
        st = run("status", damaged)
        assert st.returncode == 1, st.stderr
        assert "is damaged: the dimension scales of" in st.stderr, st.stderr
        with pytest.raises(chainsweep.DamagedFileError, match="dimension scales"):
            chainsweep.open(damaged)
    # The file as written reads clean.
    assert run("status", out).returncode == 0


def test_status_of_a_damaged_file_names_the_damage_not_utf8(tmp_path, binary):
    stray = tmp_path / "notes.h5"
    stray.write_bytes(b"\x89HDX\r\n\x1a\n" + bytes(range(256)) * 4)
    r = run("status", stray)
    assert r.returncode == 2, r.stderr
    assert "does not start with the HDF5 signature" in r.stderr and "UTF-8" not in r.stderr


# 5. A range of more points than a sweep may have is refused at its field.

def test_a_tiny_range_step_is_refused_at_its_field(tmp_path, binary):
    s = sweep_2x3()
    s["axes"][1] = {"field": "physics.damping_kg_s", "range": {"start": 0, "stop": 1, "step": 1e-20}}
    path = write_sweep(tmp_path / "tiny.json", s)
    for cmd in (("validate", path), ("run", path, "-o", tmp_path / "tiny.h5")):
        r = run(*cmd)
        assert r.returncode == 2, r.stderr
        assert "axes[1].range.step" in r.stderr and "at most 10000000" in r.stderr, r.stderr
    assert not (tmp_path / "tiny.h5").exists()


# 6. The work directory's own paths are never followed through a symlink.

@pytest.mark.parametrize("which", ["tmp", "logs"])
def test_a_symlink_in_the_work_directory_is_refused_and_never_followed(tmp_path, binary, which):
    path = write_sweep(tmp_path / "s.json", sweep_2x3())
    out = tmp_path / "s.h5"
    elsewhere = tmp_path / "precious"
    elsewhere.mkdir()
    (elsewhere / "thesis.tex").write_text("years of work")
    work = tmp_path / "s.h5.d"
    work.mkdir()
    os.symlink(elsewhere, work / which)
    r = run("run", path, "-o", out)
    assert r.returncode == 1, r.stderr
    assert f"s.h5.d/{which} is a symbolic link" in r.stderr, r.stderr
    assert (elsewhere / "thesis.tex").read_text() == "years of work"
    assert list(elsewhere.iterdir()) == [elsewhere / "thesis.tex"]


# 7 is test_a_damaged_object_header_is_reported_not_dropped above.

# 8. Editing a sweep and reverting the edit loses nothing; only gc removes runs, listing them.

def test_an_edit_and_its_revert_lose_no_run_and_gc_lists_what_it_removes(tmp_path, binary):
    s = sweep_2x3()
    s["axes"][1]["values"] = [0, 2, 4, 6]  # 12 points
    path, out = complete(tmp_path, s)
    edited = json.loads(json.dumps(s))
    edited["axes"][1]["values"] = [0, 2]
    write_sweep(path, edited)
    r = run("run", path, "-o", out)
    assert r.returncode == 0, r.stderr
    assert len(log_records(out)) == 6  # the 6 points the edit dropped, kept beside the file
    write_sweep(path, s)
    r = run("run", path, "-o", out)
    assert r.returncode == 0, r.stderr
    assert "12 of 12 runs already done" in r.stderr, r.stderr
    # Edited again: gc --dry-run lists the orphans and removes nothing; gc removes and lists them.
    write_sweep(path, edited)
    assert run("run", path, "-o", out, "--quiet").returncode == 0
    orphans = {h for _, h, _ in log_records(out)}
    assert len(orphans) == 6
    r = run("gc", path, "-o", out, "--dry-run")
    assert r.returncode == 0, r.stderr
    listed = set(re.findall(r"would remove: run ([0-9a-f]{64})", r.stdout))
    assert listed == orphans and "nothing removed" in r.stdout, r.stdout
    assert {h for _, h, _ in log_records(out)} == orphans
    r = run("gc", path, "-o", out)
    assert r.returncode == 0
    assert set(re.findall(r"removed: run ([0-9a-f]{64})", r.stdout)) == orphans, r.stdout
    assert log_records(out) == []


def test_overwrite_never_discards_a_chainsweep_files_runs(tmp_path, binary):
    """`--overwrite` replaces a file chainsweep did not make; a chainsweep result whose work
    directory was deleted keeps its runs (they are taken over, as by a resume)."""
    path, out = complete(tmp_path, sweep_2x3())
    shutil.rmtree(out.parent / (out.name + ".d"))
    r = run("run", path, "-o", out)
    assert r.returncode == 2 and "--overwrite" in r.stderr
    r = run("run", path, "-o", out, "--overwrite")
    assert r.returncode == 0 and "6 of 6 runs already done" in r.stderr, r.stderr


# 9. A dry run's cost is measured, never 0 for runs that cost time.

def test_a_dry_run_of_a_thousand_short_runs_costs_more_than_nothing(tmp_path, binary):
    s = base_sweep(cylinders=2, duration_s=1e-6, probes=())
    s["axes"] = [{"field": "physics.damping_kg_s", "range": {"start": 0, "stop": 10, "num": 1000}}]
    path = write_sweep(tmp_path / "short.json", s)
    r = run("run", path, "--dry-run", "-o", tmp_path / "short.h5")
    assert r.returncode == 0, r.stderr
    m = re.search(r"estimated cost: ([0-9.e+-]+) CPU-seconds for 1000 runs", r.stdout)
    assert m and float(m.group(1)) > 0, r.stdout


# 10. Strings decoded checked, status codes checked, bounded lock reads, large grids.

def test_invalid_utf8_and_unknown_status_codes_are_damage_not_undefined(tmp_path, binary):
    s = base_sweep()
    s["axes"][1] = {"field": "max_steps", "values": [1000000, 5]}  # the 5-step runs fail
    path, out = complete(tmp_path, s)
    reference = copy_output(out, tmp_path / "reference.h5")
    # A byte of a reason made 0xFF, which no UTF-8 string holds (written through HDF5,
    # as `reason` is deflated: its chunk checksum made good, the point's own checksum not).
    with h5py.File(out, "r+") as f:
        reason = f["reason"][()]
        rows = reason.reshape(-1, reason.shape[-1])
        row = next(i for i, r in enumerate(rows) if b"step budget" in r.tobytes())
        rows[row, rows[row].tobytes().find(b"step budget")] = b"\xff"
        f["reason"][...] = rows.reshape(reason.shape)
    r = run("status", out)
    assert r.returncode == 3 and "summary_checksum" in r.stdout, r.stdout + r.stderr
    assert "panicked" not in r.stderr
    r = run("run", path, "-o", out)
    assert r.returncode == 3, r.stderr
    assert_files_equal(reference, out)
    # A status code of 7 (written through HDF5, its chunk checksum made good).
    with h5py.File(out, "r+") as f:
        st = f["status"][()]
        st.ravel()[0] = 7
        f["status"][...] = st
    r = run("status", out)
    assert r.returncode == 3 and "status code 7 is none of" in r.stdout, r.stdout


def test_a_pending_point_names_no_run_and_a_value_in_it_is_damage(tmp_path, binary):
    """A pending point holds nothing: no run hash, checksum 0, every value its fill (so that a
    block of pending points is never written). Anything written into one is reported as damage,
    never served, and the next run computes the point as it would have."""
    path = write_sweep(tmp_path / "x.json", sweep_2x3())
    out = tmp_path / "x.h5"
    assert run("run", path, "--shard", "1/2", "-o", out, "--quiet").returncode == 0
    with h5py.File(out, "r") as f:
        status = f["status"][()].ravel()
        hashes = texts(f["run_hash"]).ravel()
        sums = f["summary_checksum"][()].ravel()
    pending = np.flatnonzero(status == 0)
    assert len(pending) == 3 and all(hashes[i] == "" for i in pending), hashes
    assert (sums[pending] == 0).all()
    assert all(len(hashes[i]) == 64 and sums[i] != 0 for i in np.flatnonzero(status != 0))
    r = run("status", out)
    assert r.returncode == 0 and "3 done" in r.stdout and "damage" not in r.stdout, r.stdout
    ds = chainsweep.open(out)  # nothing damaged: it opens
    assert int((ds.status.values == 0).sum()) == 3 and set(ds.run_hash.values.ravel()[pending]) == {""}
    # A number in one pending point, a run hash in another (written through HDF5, which makes
    # the chunks' checksums good; the points' own checks are what is left).
    a, b = (int(i) for i in pending[:2])
    with h5py.File(out, "r+") as f:
        lp = f["leading_peak"][()]
        lp.reshape(-1, lp.shape[-1])[a, 0] = 1.0
        f["leading_peak"][...] = lp
        rh = f["run_hash"][()]
        rows = rh.reshape(-1, rh.shape[-1])
        rows[b, :64] = np.frombuffer(b"ab" * 32, dtype="S1")
        f["run_hash"][...] = rows.reshape(rh.shape)
    r = run("status", out)
    assert r.returncode == 3 and damaged_points(r.stdout) == sorted([a, b]), r.stdout
    with pytest.raises(chainsweep.DamagedFileError) as e:
        chainsweep.open(out)
    assert sorted(p[0] for p in e.value.damaged) == sorted([a, b])
    # The whole sweep into it: every point computed or kept, the file an uninterrupted run writes.
    assert run("run", path, "-o", out, "--quiet").returncode == 0
    fresh = tmp_path / "fresh.h5"
    assert run("run", path, "-o", fresh, "--quiet").returncode == 0
    np.testing.assert_array_equal(xr.open_dataset(out).leading_peak, xr.open_dataset(fresh).leading_peak)
    with h5py.File(out, "r") as f:
        assert all(len(h) == 64 for h in texts(f["run_hash"]).ravel())


def test_a_finished_run_wiped_to_a_pending_point_is_restored_from_the_snapshot(tmp_path, binary):
    """A finished point rewritten to exactly what a pending point holds (status 0, no run hash,
    checksum 0, every value its fill) passes its own check, as a pending point must; the snapshot,
    which holds its run there, reports it, and the run is restored, not computed again."""
    path, out = complete(tmp_path, sweep_2x3())
    reference = copy_output(out, tmp_path / "reference.h5")
    k = point_index(out, mass_ratio=1.0, damping_kg_s=0)
    with h5py.File(out, "r+") as f:
        grid = f["status"].shape
        for name, d in f.items():
            if isinstance(d, h5py.Dataset) and d.shape[: len(grid)] == grid:
                a = d[()]
                a.reshape((-1,) + a.shape[len(grid):])[k] = d.fillvalue
                d[...] = a
        assert texts(f["run_hash"]).ravel()[k] == "" and f["status"][()].ravel()[k] == 0
    r = run("status", path, "-o", out)
    assert r.returncode == 3 and "restored from its snapshot" in r.stdout, r.stdout
    assert "reads as pending, but its snapshot holds its run" in r.stdout, r.stdout
    r = run("run", path, "-o", out)
    assert r.returncode == 0 and "6 of 6 runs already done" in r.stderr, r.stderr
    assert "1 damaged run(s) restored from its snapshot" in r.stderr
    assert_files_equal(reference, out)


def locked_run_rss(path, out, lock_bytes):
    """Peak memory (KiB) of a `run` refused because another process holds the lock, whose lock
    file has `lock_bytes` bytes; and what it said."""
    lock = out.parent / (out.name + ".d") / "lock"
    lock.parent.mkdir(exist_ok=True)
    with open(lock, "wb") as f:
        f.write(b"4242 " + b"x" * 1000)
        f.truncate(lock_bytes)
    with open(lock, "r+b") as held:
        fcntl.flock(held, fcntl.LOCK_EX)
        p = subprocess.Popen([str(BIN), "run", str(path), "-o", str(out)],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        err = p.stderr.read()
        _, status, usage = os.wait4(p.pid, 0)
    assert os.waitstatus_to_exitcode(status) == 1 and "4242" in err, err
    return usage.ru_maxrss


def test_a_huge_lock_file_is_read_bounded(tmp_path, binary):
    path = write_sweep(tmp_path / "s.json", sweep_2x3())
    # (A child's peak memory counts what it shared with this process before it became
    # chainsweep: compared with the same refusal over a small lock file.)
    small = locked_run_rss(path, tmp_path / "small.h5", 2000)
    huge = locked_run_rss(path, tmp_path / "huge.h5", 300 * 1024 * 1024)
    assert huge < small + 20 * 1024, (small, huge)  # KiB: far below the lock file's 300 MB


def test_a_large_grid_shows_its_expansion_and_a_larger_one_is_refused_early(tmp_path, binary):
    s = base_sweep(cylinders=4, duration_s=1e-4, probes=(1, 3))
    s["axes"] = [
        {"field": "chain.cylinder.mass.heavy_cylinders.mass_ratio", "range": {"start": 0.1, "stop": 1.0, "num": 500}},
        {"field": "physics.damping_kg_s", "range": {"start": 0, "stop": 20, "num": 1000}},
    ]
    path = write_sweep(tmp_path / "large.json", s)
    r = run("validate", path)
    assert r.returncode == 0, r.stderr
    assert "500000 grid points" in r.stdout
    assert re.search(r"expanding the grid: \d+ of 500000 points", r.stderr), r.stderr
    s["axes"][1]["range"]["num"] = 100000
    path = write_sweep(tmp_path / "huge.json", s)
    r = run("validate", path)
    assert r.returncode == 2 and "more than 10000000 points" in r.stderr, r.stderr
    assert "expanding" not in r.stderr


# The randomised damage test: single-byte flips over complete small results of every kind.

FLIPS = 120  # per kind of file


def served(out, histories=True):
    """What chainsweep.open serves of `out` (`histories`: False, True or "lazy", the lazy arrays
    computed): a dict of every variable's and coordinate's bits and the attributes, or the
    exception it raised."""
    try:
        ds = chainsweep.open(out, histories=histories)
        return {
            "vars": {k: np.asarray(v.values).tobytes() if v.dtype != object else list(v.values.ravel())
                     for k, v in ds.variables.items() if k not in ("wall_time_s", "summary_checksum")},
            "attrs": {k: str(v) for k, v in ds.attrs.items()
                      if k not in ("created_utc", "command_line", "header_checksum")},
        }
    except (chainsweep.Error, OSError, ValueError, KeyError) as e:
        return e


BALL = {"sphere": {"diameter_m": 0.008, "mass_kg": 0.002085,
                   "material": {"youngs_modulus_pa": 2e11, "poisson_ratio": 0.28}}}


def damage_sweeps():
    """The kinds of result the flips go over: a grid recording histories, minimum overlaps and the
    energy flow (some runs failing), a search, and a continuation line with histories."""
    grid = base_sweep(history=True, probes=(2, 8))
    grid["record"]["min_overlap"] = True
    grid["record"]["energy_flow"] = True
    grid["axes"] = [
        {"field": "chain.cylinder.mass.heavy_cylinders.mass_ratio", "values": [0.3, 0.55, 1.0]},
        {"field": "max_steps", "values": [1000000, 5]},  # the 5-step runs fail
    ]
    search = json.loads((REPO / "sweeps" / "examples" / "dimer-minimum.json").read_text())
    search["base"]["chain"]["sequence"][0]["repeat"] = 12
    search["record"]["probes"][1]["particle"] = 22
    search["search"]["objective"]["ratio"][0]["probe"] = "particle_force_p22"
    search["search"]["budget"] = 40
    line = {
        "description": "a short continuation line",
        "base": {
            "chain": {"particles": {"ball": BALL}, "sequence": [{"repeat": 3, "of": ["ball"]}]},
            "physics": {"gravity": False, "damping_kg_s": 5.0, "wall": True,
                        "precompression_force_n": 1.0},
            "excitation": {"drive": {"force_n": {"harmonic": {"amplitude": 1e-2, "frequency_hz": 5e3}}}},
            "duration_s": 4e-4,
            "integrator": {"method": "dop853", "rtol": 1e-8},
        },
        "record": {"probes": [{"kind": "wall_force"}], "history": True, "history_interval_s": 2e-5,
                   "min_overlap": True},
        "axes": [{"field": "excitation.drive.force_n.harmonic.frequency_hz", "name": "frequency_hz",
                  "range": {"start": 5e3, "stop": 6e3, "num": 5}}],
        "continuation": {"axis": "frequency_hz", "direction": "up"},
    }
    return {"grid": grid, "search": search, "continuation": line}


MODES = (False, True, "lazy")


# The everyday tier (`make test`): a standing sample of flips of every kind of file, seeds of its
# own; the system tier (`make test-system`): hundreds, each file checked.
EVERYDAY_FLIPS = 16


@pytest.mark.parametrize("kind", ["grid", "search", "continuation"])
def test_a_sample_of_single_byte_flips_are_reported_or_harmless_never_served(tmp_path, binary, kind):
    """The campaign below with a few flips of each kind of file, on every `make test`."""
    flip_campaign(tmp_path, kind, EVERYDAY_FLIPS, {"grid": 32, "search": 33, "continuation": 34}[kind])


@pytest.mark.system
@pytest.mark.parametrize("kind", ["grid", "search", "continuation"])
def test_random_single_byte_flips_are_reported_or_harmless_never_served(tmp_path, binary, kind):
    """For every flip: `status` and `chainsweep.open` (every `histories` mode) refuse, naming
    the damage, or serve exactly what the pristine file serves (never a changed value, never NaN
    for a number); the same `run` command then gives the pristine file back bitwise."""
    flip_campaign(tmp_path, kind, FLIPS, {"grid": 22, "search": 23, "continuation": 24}[kind])


def flip_campaign(tmp_path, kind, flips, seed):
    """`flips` single-byte flips (from random seed `seed`) over a complete result of `kind`, each
    checked as the tests above say; the counts printed and kept beside the test's folder."""
    path, pristine = complete(tmp_path, damage_sweeps()[kind], "pristine")
    truth = {mode: served(pristine, mode) for mode in MODES}
    assert all(isinstance(t, dict) for t in truth.values()), truth
    pristine_status = run("status", pristine).returncode
    size = pristine.stat().st_size
    rng = random.Random(seed)
    counts = collections.Counter()
    for n in range(flips):
        work = tmp_path / f"flip{n % 4}"
        shutil.rmtree(work, ignore_errors=True)
        work.mkdir()
        out = copy_output(pristine, work / "pristine.h5")
        offset = rng.randrange(size)
        flip(out, offset, 1 << rng.randrange(8))
        refused = False
        for mode in MODES:
            got = served(out, mode)
            if isinstance(got, Exception):
                refused = True
                counts[f"open (histories={mode}): refused, naming the damage"] += 1
            else:
                assert got == truth[mode], (
                    f"flip at byte {offset}: chainsweep.open(histories={mode}) served changed values")
                counts[f"open (histories={mode}): served unchanged"] += 1
        st = run("status", out)
        assert "panicked" not in st.stderr
        said = st.stdout + st.stderr
        if "damaged" in said or "cannot be read" in said:
            counts["status: damage reported"] += 1
            assert st.returncode in (1, 2, 3), said
        else:
            assert not refused, f"flip at byte {offset}: open refused, status said nothing: {said}"
            assert st.returncode == pristine_status, said
        # Re-published: the same command repairs the file; its values are the pristine ones.
        r = run("run", path, "-o", out)
        assert r.returncode in (0, 3), f"flip at byte {offset}: {r.stderr}"
        if "restored from its snapshot" in r.stderr:
            counts["run: damaged runs restored from the snapshot"] += 1
        if "damaged" not in r.stderr and "cannot be read" not in r.stderr:
            counts["run: no damage found, the file written again (unchanged in meaning)"] += 1
        assert_files_equal(pristine, out)
        assert served(out, False) == truth[False]
    report = "\n".join(f"  {k}: {v}" for k, v in sorted(counts.items()))
    print(f"\n{flips} single-byte flips over a {size}-byte {kind} result:\n{report}")
    (tmp_path.parent / f"damage_counts_{kind}_{flips}.txt").write_text(report)


def test_an_output_moved_without_its_work_directory_is_said_to_keep_its_runs(tmp_path, binary):
    """An output moved without its work directory is named as chainsweep's, and `--overwrite`
    is said, truly, to keep every run it holds: nothing is computed again (the message once said
    the file was not chainsweep's and invited replacing it)."""
    path, out = complete(tmp_path, sweep_2x3(), "x")
    moved = tmp_path / "moved"
    moved.mkdir()
    shutil.copyfile(out, moved / "x.h5")
    r = run("run", path, "-o", moved / "x.h5")
    assert r.returncode == 2, r.stderr
    assert "is a chainsweep output without its work directory" in r.stderr, r.stderr
    assert "every run it holds is kept" in r.stderr and "not made by" not in r.stderr, r.stderr
    r = run("run", path, "-o", moved / "x.h5", "--overwrite")
    assert r.returncode == 0, r.stderr
    # (A run computed again would have another wall time.)
    with h5py.File(out, "r") as a, h5py.File(moved / "x.h5", "r") as b:
        for name in ("leading_peak", "status", "run_hash", "wall_time_s"):
            assert a[name][()].tobytes() == b[name][()].tobytes(), name
