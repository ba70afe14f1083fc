"""Shared helpers for the chainsweep Python tests.

The binary is `target/release/chainsweep` (built by `make build`), or `$CHAINSWEEP_BIN`.
"""

import copy
import hashlib
import json
import os
import subprocess
import zlib
from pathlib import Path

import h5py
import numpy as np
import pytest

REPO = Path(__file__).resolve().parent.parent
BIN = Path(os.environ.get("CHAINSWEEP_BIN", REPO / "target" / "release" / "chainsweep")).resolve()

# Root attributes and datasets that legitimately differ between two runs of the same sweep.
# (`header_checksum` covers every text attribute, `created_utc` and `command_line` included.)
VOLATILE_ATTRS = {"created_utc", "command_line", "header_checksum"}
# (`summary_checksum` covers every value of its point, the measured `wall_time_s` included.)
VOLATILE_DATASETS = {"wall_time_s", "summary_checksum"}
# HDF5 bookkeeping attributes holding object references (compared through the scale names).
REFERENCE_ATTRS = {"DIMENSION_LIST", "REFERENCE_LIST"}


def base_sweep(cylinders=10, duration_s=2e-4, history=False, probes=(2, 8)):
    """A small, fast sweep: 10-cylinder 0.55 chain, 0.2 ms, gauge forces."""
    return {
        "description": "test sweep",
        "base": {
            "chain": {
                "preset": "chain_055",
                "cylinders": cylinders,
                "cylinder": {"mass": {"heavy_cylinders": {"mass_ratio": 0.55}}, "height_m": None},
            },
            "physics": {"gravity": True, "damping_kg_s": 0.0, "wall": True},
            "striker_velocity_m_s": 1.3,
            "duration_s": duration_s,
            "integrator": {"method": "dop853", "rtol": 1e-9},
        },
        "record": {
            "probes": [{"kind": "gauge_force", "cylinder": c} for c in probes],
            "history": history,
            "history_interval_s": 1e-6,
        },
        "axes": [
            {"field": "chain.cylinder.mass.heavy_cylinders.mass_ratio", "values": [0.3, 0.55, 1.0]},
            {"field": "physics.damping_kg_s", "values": [0, 6]},
        ],
    }



def interruptible_sweep():
    """A 10 × 10 sweep with histories whose runs take long enough in all for signals and kills to
    land mid-sweep (and mid-write, with frequent checkpoints)."""
    s = base_sweep(cylinders=20, duration_s=1e-3, history=True, probes=(2, 10, 18))
    s["axes"] = [
        {"field": "chain.cylinder.mass.heavy_cylinders.mass_ratio", "range": {"start": 0.1, "stop": 1.0, "num": 10}},
        {"field": "physics.damping_kg_s", "values": [0, 2, 4, 6, 8, 10, 15, 20, 50, 100]},
    ]
    return s


PACKED = 1 << 63
PACK_MAX = 1024  # segment bytes up to which a record may be packed, and a plain frame a key
PACKED_SUM = 8  # bytes of its SHA-256 a packed record keeps


def log_frames(data):
    """The frames of a log's bytes, in order, up to a torn tail: (start, payload length, packed,
    segment bytes or None where they cannot be had). A frame is `u64 length | payload`; a plain
    frame's payload is the segment (a run record ending in its SHA-256); a packed frame (bit 63 of
    its length set) holds `u32 back | raw deflate of the segment with only the first PACKED_SUM
    bytes of its SHA-256`, with the segment of its key, the plain frame of at most PACK_MAX bytes
    starting `back` bytes before it, as the deflate dictionary. A packed record's segment is given
    with the rest of its SHA-256 computed from its body, so it is whole exactly when the bytes kept
    match.
    As chainsweep does, a packed frame is read against the last such plain frame that is whole or
    the last that is not, whichever starts there (a key is only a dictionary: the packed record
    is checked by its own SHA-256). This reads the format independently of chainsweep, with
    Python's own zlib."""
    frames, at = [], 0
    keys = {True: None, False: None}  # whole or not -> (start, bytes)
    while at + 8 <= len(data):
        head = int.from_bytes(data[at : at + 8], "little")
        n, packed = head & ~PACKED, bool(head & PACKED)
        if n > len(data) - at - 8:
            break
        payload = bytes(data[at + 8 : at + 8 + n])
        seg = None
        if not packed:
            seg = payload
            if n <= PACK_MAX:
                keys[whole_record(payload)] = (at, payload)
        elif n >= 4:
            start = at - int.from_bytes(payload[:4], "little")
            key = next((k for s, k in filter(None, keys.values()) if s == start), None)
            if key is not None:
                d = zlib.decompressobj(wbits=-15, zdict=key)
                try:
                    seg = d.decompress(payload[4:], PACK_MAX + 1)
                    seg = seg if d.eof and not d.unused_data and len(seg) <= PACK_MAX else None
                    if seg is not None and len(seg) >= PACKED_SUM:
                        body = seg[:-PACKED_SUM]
                        seg = seg + hashlib.sha256(body).digest()[PACKED_SUM:]
                except zlib.error:
                    seg = None
        frames.append((at, n, packed, seg))
        at += 8 + n
    return frames


def damage_frame(data, index, skip, mask):
    """Flips a byte (XOR `mask`) of frame `index` of the log bytes `data` (a bytearray), from
    `skip` bytes into its payload on, until its record no longer reads whole. (A flipped bit of a
    packed record's deflate stream can decode to the same bytes, as when a match's distance moves
    between two equal runs: such a record is rightly whole, so the flip moves on.)"""
    at, n, _, _ = log_frames(data)[index]
    for k in range(skip, n):
        data[at + 8 + k] ^= mask
        if not whole_record(log_frames(data)[index][3] or b""):
            return
        data[at + 8 + k] ^= mask
    raise AssertionError(f"no flipped byte damages frame {index}")


def log_records(out):
    """Every whole, checksummed run record in the logs of the work directory of output `out`
    (`X.h5.d/logs/<n>.log`, see `log_frames`), as (log name, run hash hex, ok) in the order
    written; a torn tail or corrupt record is left out, as chainsweep leaves it out."""
    return [(name, seg[8:40].hex(), seg[40] == 1) for name, seg in log_segments(out)]


def log_segments(out):
    """Every whole, checksummed record (its segment bytes) in the logs of the work directory of
    output `out`, as (log name, segment bytes) in the order written."""
    d = out.parent / (out.name + ".d") / "logs"
    found = []
    if not d.is_dir():
        return found
    for log in sorted(p for p in d.glob("*.log") if p.is_file()):
        try:
            data = log.read_bytes()
        except FileNotFoundError:  # compacted away meanwhile
            continue
        for _, _, _, seg in log_frames(data):
            if seg is not None and whole_record(seg):
                found.append((log.name, seg))
    return found


def texts(ds):
    """The texts of a text dataset as `str` (an object array over its dimensions): netCDF `char`s
    (layout 4: the UTF-8 bytes of each text along the last dimension, NUL-padded) or
    variable-length strings (earlier layouts, and the accuracy files)."""
    if ds.dtype == np.dtype("S1") and ds.ndim >= 1:
        raw = np.ascontiguousarray(ds[()])
        rows = raw.view(f"S{raw.shape[-1]}").reshape(raw.shape[:-1])
        return np.array([t.decode("utf-8") for t in rows.ravel()], dtype=object).reshape(rows.shape)
    return np.asarray(ds.asstr()[()], dtype=object)


def file_runs(out):
    """Run hashes (hex) of the points the output file `out` holds done (ok or failed); none when
    `out` is not a file (missing, or a directory a fault-injection test put in its place)."""
    if not out.is_file():
        return set()
    with h5py.File(out, "r") as f:
        status = f["status"][...].ravel()
        hashes = texts(f["run_hash"]).ravel()
    return {h for h, s in zip(hashes, status) if s != 0}


# Record formats chainsweep reads: 3 (this one), and 2 (without what the run integrated).
SEGMENT_MAGICS = (b"CSWSEG\x00\x04", b"CSWSEG\x00\x03", b"CSWSEG\x00\x02")


def whole_record(rec):
    """Whether `rec` is a whole run record of a format chainsweep reads, its SHA-256 holding."""
    return (
        len(rec) > 73
        and rec[:8] in SEGMENT_MAGICS
        and hashlib.sha256(rec[:-32]).digest() == rec[-32:]
    )


def old_segments(out):
    """Run hashes (hex) of the whole one-file segments `segments/<hash>.seg` of earlier versions."""
    d = out.parent / (out.name + ".d") / "segments"
    if not d.is_dir():
        return set()
    return {p.stem for p in d.glob("*.seg") if p.is_file() and whole_record(p.read_bytes())}


def segment_count(out):
    """How many distinct runs are stored for output `out`: in the logs of its work directory (or
    its one-file segments of earlier versions), or in the output file itself (where a complete
    sweep's runs are once its logs are compacted)."""
    return len({h for _, h, _ in log_records(out)} | old_segments(out) | file_runs(out))


def work_dir_files(out):
    """Every regular file in the work directory of output `out` (recursively)."""
    d = out.parent / (out.name + ".d")
    return [p for p in d.rglob("*") if p.is_file()]


def with_axes(sweep, axes):
    s = copy.deepcopy(sweep)
    s["axes"] = axes
    return s


def kill_at(path, out, goals, jobs=2):
    """Runs `chainsweep run PATH -o OUT` once per goal and SIGKILLs it once OUT's runs (segments)
    reach that goal; the number of runs actually killed (those that had not finished)."""
    import signal
    import time

    kills = 0
    for goal in goals:
        p = subprocess.Popen([str(BIN), "run", str(path), "-o", str(out), "--jobs", str(jobs), "--quiet"],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        deadline = time.monotonic() + 120
        while segment_count(out) < goal and p.poll() is None and time.monotonic() < deadline:
            time.sleep(0.002)
        if p.poll() is None:
            p.send_signal(signal.SIGKILL)
            kills += 1
        p.communicate()
    return kills


def write_sweep(path, sweep):
    path = Path(path)
    path.write_text(json.dumps(sweep, indent=2))
    return path


def run(*args, cwd=None, env=None, timeout=300):
    """Runs the binary; returns the CompletedProcess (text mode)."""
    full_env = dict(os.environ)
    full_env.pop(
        "CHAINSWEEP_INJECT_PANIC", None
    )
    if env:
        full_env.update(env)
    return subprocess.run(
        [str(BIN), *map(str, args)],
        cwd=cwd,
        env=full_env,
        capture_output=True,
        text=True,
        timeout=timeout,
    )


def read_all(path):
    """Every dataset (name -> numpy array) and attribute ((object, name) -> value) of a file."""
    data, attrs = {}, {}
    with h5py.File(path, "r") as f:
        for k, v in f.attrs.items():
            attrs[("/", k)] = v

        def visit(name, obj):
            for k, v in obj.attrs.items():
                if k in REFERENCE_ATTRS:
                    continue
                attrs[(name, k)] = v
            if isinstance(obj, h5py.Dataset):
                data[name] = (obj.dtype, obj[()])
                for i, dim in enumerate(obj.dims):
                    attrs[(name, f"dim{i}_scales")] = tuple(s.name for s in dim.values())

        f.visititems(visit)
    return data, attrs


def _bits(a):
    a = np.ascontiguousarray(a)
    if a.dtype.kind == "O":
        return [x.decode() if isinstance(x, bytes) else x for x in a.ravel().tolist()]
    return a.tobytes()


def assert_files_equal(a, b, skip_datasets=VOLATILE_DATASETS, skip_attrs=VOLATILE_ATTRS):
    """Asserts two chainsweep files hold bitwise-equal datasets and equal attributes."""
    da, aa = read_all(a)
    db, ab = read_all(b)
    assert sorted(da) == sorted(db), "dataset names differ"
    for name in da:
        if name.split("/")[-1] in skip_datasets and "/" not in name:
            continue
        (ta, va), (tb, vb) = da[name], db[name]
        assert ta == tb, f"{name}: dtype {ta} != {tb}"
        assert np.shape(va) == np.shape(vb), f"{name}: shape differs"
        assert _bits(va) == _bits(vb), f"{name}: values differ"
    keys_a = {k for k in aa if not (k[0] == "/" and k[1] in skip_attrs)}
    keys_b = {k for k in ab if not (k[0] == "/" and k[1] in skip_attrs)}
    assert keys_a == keys_b, f"attributes differ: {keys_a ^ keys_b}"
    for k in keys_a:
        va, vb = aa[k], ab[k]
        if isinstance(va, np.ndarray):
            assert _bits(va) == _bits(vb), f"attribute {k} differs"
        elif isinstance(va, float) and np.isnan(va):
            assert np.isnan(vb), f"attribute {k} differs"
        else:
            assert va == vb, f"attribute {k} differs: {va!r} != {vb!r}"


def assert_resume_and_merge_bitwise(path, out, tmp_path, between_shards=None, exit_code=0):
    """Asserts that the finished output `out` of the sweep file `path` stays bitwise what it is
    when it is run again without its snapshot (every run read back from the file: "already done")
    and when two shards of it are run apart and merged; `between_shards(parts)` may check the
    shards' own files first. `exit_code`: the whole sweep's (3 where some run failed or did not
    settle; a shard then exits 0 or 3 as its own runs are)."""
    import shutil

    again = tmp_path / "again.h5"
    shutil.copy(out, again)
    shutil.copytree(f"{out}.d", f"{again}.d")
    Path(f"{again}.d", "snapshot").unlink()
    r = run("run", path, "-o", again)
    assert r.returncode == exit_code and "already done" in r.stderr, r.stderr
    assert_files_equal(out, again)
    parts = []
    for k in (1, 2):
        part = tmp_path / f"part-{k}.h5"
        assert run("run", path, "--shard", f"{k}/2", "-o", part, "--quiet").returncode in (0, exit_code)
        parts.append(part)
    if between_shards is not None:
        between_shards(parts)
    merged = tmp_path / "merged.h5"
    assert run("merge", "-o", merged, *parts).returncode == exit_code
    assert_files_equal(out, merged)


@pytest.fixture(scope="session")
def binary():
    assert BIN.exists(), f"chainsweep binary not found at {BIN}; run `make build` or set CHAINSWEEP_BIN"
    return BIN


def to_layout_4(path):
    """Rewrites a file of the current layout (5: the runs' arrays as datasets over the grid) as
    layout 4 stored them: a group per successful run under ``runs/`` (``run_<flat index>``, with
    ``flat_index``, ``grid_index`` and ``run_hash``), each with its own ``time_s`` (a dimension
    scale), one dataset per probe named like it, and ``min_overlap_m`` on its own ``contact``;
    the same values, so that their checksums hold. For tests of the readers of earlier layouts."""
    with h5py.File(path, "r+") as f:
        shape = tuple(int(n) for n in f.attrs["grid_shape"])
        probes = list(texts(f["probe"])) if "probe" in f else []
        units = list(texts(f["probe_units"])) if "probe" in f else []
        hashes = texts(f["run_hash"]).ravel()
        status = f["status"][()].ravel()
        samples = f["history_samples"][()].ravel() if "history_samples" in f else None
        if samples is not None:
            common = f["time_s"].ndim == 1
            parts = {}
            for u in dict.fromkeys(units):
                name = "history" if len(set(units)) == 1 else f"history_{u.replace('/', '_per_')}"
                parts[u] = f[name][()].reshape(-1, len(probes), f[name].shape[-1])
            times = f["time_s"][()] if common else f["time_s"][()].reshape(-1, f["time_s"].shape[-1])
        overlaps = (
            f["min_overlap_m"][()].reshape(-1, f["min_overlap_m"].shape[-1])
            if "min_overlap_m" in f else None
        )
        runs = f.create_group("runs")
        for i in np.flatnonzero(status == 1):
            g = runs.create_group(f"run_{i}")
            g.attrs["run_hash"] = hashes[i]
            g.attrs["flat_index"] = np.int64(i)
            g.attrs["grid_index"] = np.array(np.unravel_index(i, shape), dtype=np.int64)
            if samples is not None:
                m = int(samples[i])
                t = g.create_dataset("time_s", data=(times if common else times[i])[:m])
                t.attrs["units"] = "s"
                t.make_scale("time_s")
                for k, (p, u) in enumerate(zip(probes, units)):
                    d = g.create_dataset(p, data=parts[u][i, k, :m])
                    d.attrs["units"] = u
                    d.dims[0].attach_scale(t)
            if overlaps is not None:
                m = overlaps[i][~np.isnan(overlaps[i])]
                c = g.create_dataset("contact", data=np.arange(1, len(m) + 1, dtype=np.int64))
                c.make_scale("contact")
                d = g.create_dataset("min_overlap_m", data=m)
                d.dims[0].attach_scale(c)
        for name in ("history", "history_N", "history_m", "history_m_per_s", "history_samples",
                     "time_s", "sample", "min_overlap_m", "contact"):
            if name in f:
                del f[name]
        f.attrs["layout_version"] = np.int64(4)


def pytest_configure(config):
    # Two tiers: `make test` runs what a change needs (-m "not system"), `make test-system` the
    # tests that build the wheel, start a cluster, mount a disk or write large files (-m system).
    # .ci/run runs both, so no test is left out of CI.
    config.addinivalue_line(
        "markers", "system: the system tier (make test-system): wheel, SLURM, tmpfs, large files")
