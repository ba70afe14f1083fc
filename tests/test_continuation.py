"""Continuation along an axis: each point of a frequency axis starts from the final state of the
point before it, upwards or downwards. Where only one branch exists (a small drive, a linear
response) the two directions settle on the same steady response at every frequency; the result is
deterministic (two runs, and shards merged, are bit for bit one run), and resumable (a point that
failed, and every point after it on its line, is run again from its predecessor's state,
recomputed, and the file comes out as if nothing had failed); bad continuation blocks exit 2."""

import copy
import json
import os

import numpy as np
import pytest
import xarray as xr

from conftest import BIN, assert_files_equal, run

BALL = {
    "sphere": {
        "diameter_m": 0.008,
        "mass_kg": 0.002085,
        "material": {"youngs_modulus_pa": 200e9, "poisson_ratio": 0.28},
    }
}
STEEL_304 = {"youngs_modulus_pa": 193e9, "poisson_ratio": 0.29}
FREQUENCIES = [3000.0, 3150.0, 3250.0, 3350.0, 3500.0]
PERIODS = 100


def sweep(direction, stroke_m=1e-10, damping=15.0):
    """8 spheres between two walls under 2 N, shaken at the top by a harmonic actuator; each
    point runs 100 whole periods of its frequency (duration zipped with it), the response read
    over the last 20."""
    return {
        "description": f"continuation {direction}",
        "base": {
            "chain": {
                "particles": {"ball": BALL},
                "sequence": [{"repeat": 8, "of": ["ball"]}],
                "wall_material": STEEL_304,
                "top_wall_material": STEEL_304,
            },
            "physics": {"gravity": False, "damping_kg_s": damping, "wall": True,
                        "precompression_force_n": 2.0},
            "excitation": {"drive": {"actuator_m": {"harmonic": {
                "amplitude": stroke_m, "frequency_hz": 3000.0}}}},
            "duration_s": PERIODS / 3000.0,
            "integrator": {"method": "dop853", "rtol": 1e-10},
        },
        "record": {
            "probes": [{"kind": "wall_force"}],
            "preload": "subtract",
            "history": True,
            "history_interval_s": 1e-5,
        },
        "axes": [
            {"zip": [
                {"field": "excitation.drive.actuator_m.harmonic.frequency_hz",
                 "name": "frequency_hz", "values": FREQUENCIES},
                {"field": "duration_s", "values": [PERIODS / f for f in FREQUENCIES]},
            ]},
        ],
        "continuation": {"axis": "frequency_hz", "direction": direction},
    }


def write(tmp_path, name, s):
    path = tmp_path / f"{name}.json"
    path.write_text(json.dumps(s))
    return path


def amplitudes(out):
    """The wall force's amplitude over the last 20 periods of each point (the largest |F| of
    the settled response: the history samples a period 30 times)."""
    with xr.open_dataset(out) as ds:
        assert (ds["status"].values == 1).all(), ds["reason"].values
        result = []
        for f in ds["frequency_hz"].values:
            h = ds["history"].sel(frequency_hz=f).values[0]
            t = ds["time_s"].values
            end = PERIODS / f
            window = (t > end - 20 / f) & (t <= end)
            result.append(np.nanmax(np.abs(h[window])))
        return np.array(result)


def test_up_and_down_agree_where_only_one_branch_exists(binary, tmp_path):
    up, down = tmp_path / "up.h5", tmp_path / "down.h5"
    for direction, out in (("up", up), ("down", down)):
        r = run("run", write(tmp_path, direction, sweep(direction)), "-o", out, "--quiet")
        assert r.returncode == 0, r.stderr
    a, b = amplitudes(up), amplitudes(down)
    assert a.max() > 3 * a.min()  # the resonance is in the range
    np.testing.assert_allclose(a, b, rtol=1e-3)
    # The same sweep without continuation: every point starts at rest, and settles on the same
    # response too; a continued point, started from a settled neighbour, is not the same run.
    plain = sweep("up")
    del plain["continuation"]
    out = tmp_path / "plain.h5"
    r = run("run", write(tmp_path, "plain", plain), "-o", out, "--quiet")
    assert r.returncode == 0, r.stderr
    np.testing.assert_allclose(amplitudes(out), a, rtol=1e-3)
    with xr.open_dataset(out) as p, xr.open_dataset(up) as u:
        first = p["history"].values[0], u["history"].values[0]
        np.testing.assert_array_equal(*first)  # the line's first point starts as any run
        assert not np.array_equal(p["history"].values[1], u["history"].values[1])


def test_continuation_is_deterministic_across_runs_and_shards(binary, tmp_path):
    s = sweep("down")
    # Two strokes: two lines along the frequency, which shards take whole.
    s["axes"].insert(0, {"field": "excitation.drive.actuator_m.harmonic.amplitude",
                         "name": "stroke_m", "values": [1e-10, 2e-10]})
    path = write(tmp_path, "down", s)
    one, two = tmp_path / "one.h5", tmp_path / "two.h5"
    for out, jobs in ((one, "1"), (two, "2")):
        r = run("run", path, "-o", out, "--jobs", jobs, "--quiet")
        assert r.returncode == 0, r.stderr
    assert_files_equal(one, two)
    parts = []
    for k in (1, 2):
        part = tmp_path / f"part{k}.h5"
        r = run("run", path, "--shard", f"{k}/2", "-o", part, "--quiet")
        assert r.returncode == 0, r.stderr
        parts.append(part)
        with xr.open_dataset(part) as ds:
            # Each shard ran one whole line (the others' points pending in its file).
            done = ds["status"].values == 1
            assert done.sum() == len(FREQUENCIES) and (done.all(axis=1) | ~done.any(axis=1)).all()
    merged = tmp_path / "merged.h5"
    r = run("merge", "-o", merged, *parts)
    assert r.returncode == 0, r.stderr
    assert_files_equal(one, merged)


def test_a_failed_point_and_those_after_it_are_run_again_from_recomputed_states(binary, tmp_path):
    path = write(tmp_path, "up", sweep("up"))
    reference = tmp_path / "reference.h5"
    r = run("run", path, "-o", reference, "--quiet")
    assert r.returncode == 0, r.stderr
    out = tmp_path / "out.h5"
    env = dict(os.environ, CHAINSWEEP_INJECT_PANIC="2")
    import subprocess

    p = subprocess.run([str(BIN), "run", str(path), "-o", str(out), "--quiet"], env=env,
                       capture_output=True, text=True)
    assert p.returncode != 0
    with xr.open_dataset(out) as ds:
        status = ds["status"].values
        reasons = ds["reason"].values
    assert list(status[:2]) == [1, 1] and not (status[2:] == 1).any(), status
    assert "injected panic" in reasons[2]
    assert all("point before it on the continuation axis" in r for r in reasons[3:]), reasons
    r = run("run", path, "-o", out, "--retry-failed", "--quiet")
    assert r.returncode == 0, r.stderr
    assert_files_equal(reference, out)


def test_bad_continuation_exits_2_naming_the_field(binary, tmp_path):
    cases = [
        ({"axis": "frequency"}, "continuation.axis"),
        ({"axis": "frequency_hz", "direction": "sideways"}, "direction"),
        ({"axis": "frequency_hz", "from": "up"}, "from"),
    ]
    for block, field in cases:
        s = copy.deepcopy(sweep("up"))
        s["continuation"] = block
        out = tmp_path / "bad.h5"
        r = run("run", write(tmp_path, "bad", s), "-o", out, "--quiet")
        assert r.returncode == 2, (block, r.stderr)
        assert field in r.stderr, (field, r.stderr)
        assert not out.exists()


def long_line(points):
    """A line of `points` runs of a few microseconds each: two spheres on a wall under 1 N,
    shaken by a tiny force, the frequency stepped along the line."""
    return {
        "description": f"a continuation line of {points} points",
        "base": {
            "chain": {"particles": {"ball": BALL}, "sequence": [{"repeat": 2, "of": ["ball"]}]},
            "physics": {"gravity": False, "damping_kg_s": 5.0, "wall": True,
                        "precompression_force_n": 1.0},
            "excitation": {"drive": {"force_n": {"harmonic": {"amplitude": 1e-3, "frequency_hz": 1e3}}}},
            "duration_s": 2e-6,
            "integrator": {"method": "dop853", "rtol": 1e-6},
        },
        "record": {"probes": [{"kind": "wall_force"}]},
        "axes": [{"field": "excitation.drive.force_n.harmonic.frequency_hz", "name": "frequency_hz",
                  "range": {"start": 1e3, "stop": 2e3, "num": points}}],
        "continuation": {"axis": "frequency_hz", "direction": "up"},
    }


# The system tier (`make test-system`): a line of 100 000 points.
@pytest.mark.system
def test_a_line_of_a_hundred_thousand_points_runs_and_resumes(binary, tmp_path):
    """No recursion along a line: 10^5 points run (a worker's stack once overflowed near 700),
    and a line killed part way resumes to the same file, every point after the cut recomputed
    from its predecessor's state, itself recomputed."""
    import signal
    import subprocess
    import time

    from conftest import segment_count

    path = write(tmp_path, "long", long_line(100_000))
    whole = tmp_path / "whole.h5"
    r = run("run", path, "-o", whole, "--quiet", "--jobs", "2", timeout=900)
    assert r.returncode == 0, r.stderr[-2000:]
    out = tmp_path / "cut.h5"
    proc = subprocess.Popen([str(BIN), "run", str(path), "-o", str(out), "--quiet"],
                            stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 600
    while segment_count(out) < 30_000:
        assert proc.poll() is None and time.monotonic() < deadline
        time.sleep(0.2)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    r = run("run", path, "-o", out, "--quiet", timeout=900)
    assert r.returncode == 0, r.stderr[-2000:]
    assert_files_equal(whole, out)


def test_a_failure_reason_does_not_grow_with_the_line(binary, tmp_path):
    """The first point fails (an injected panic): every later point fails naming the line's
    first failure, in a reason of the same few words whatever its place (each once quoted its
    predecessor's whole reason: a 1 GB reason array for 3 000 points)."""
    import subprocess

    path = write(tmp_path, "line", long_line(3000))
    out = tmp_path / "line.h5"
    env = dict(os.environ, CHAINSWEEP_INJECT_PANIC="0")
    p = subprocess.run([str(BIN), "run", str(path), "-o", str(out), "--quiet"], env=env,
                       capture_output=True, text=True, timeout=300)
    assert p.returncode == 3, p.stderr[-2000:]
    with xr.open_dataset(out) as ds:
        reasons = [str(x) for x in ds["reason"].values]
    assert "injected panic" in reasons[0]
    assert all("the line's first failure: point 0" in r and "injected panic" in r for r in reasons[1:])
    assert max(map(len, reasons)) < 500, max(map(len, reasons))
    assert out.stat().st_size < 5e6, out.stat().st_size


def test_a_line_in_damping_from_zero_carries_the_bodies_over(binary, tmp_path):
    """Along a damping axis from 0 the state's quadratures change (no dissipated work without
    damping): the bodies carry over and every point runs (each once failed: "that state has 19
    components, this chain's 20")."""
    s = long_line(4)
    s["axes"] = [{"field": "physics.damping_kg_s", "name": "damping_kg_s", "values": [0.0, 1.0, 2.0, 4.0]}]
    s["continuation"] = {"axis": "damping_kg_s", "direction": "up"}
    out = tmp_path / "damping.h5"
    r = run("run", write(tmp_path, "damping", s), "-o", out, "--quiet")
    assert r.returncode == 0, r.stderr
    with xr.open_dataset(out) as ds:
        assert (ds["status"].values == 1).all(), ds["reason"].values
