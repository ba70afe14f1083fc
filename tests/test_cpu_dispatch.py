"""Run-time CPU dispatch through the environment variable CHAINSWEEP_CPU (`portable`, `avx-fma`,
`avx2`, `avx512`): every code path this CPU supports is pinned in turn for the same sweep.

- The fused paths (hardware FMA, any vector width) write bitwise identical files.
- The portable path (separate multiply and add: what a CPU without FMA runs) rounds differently,
  so its file differs, but its peaks agree to well within the runs' tolerance.
- A path this CPU lacks, or a misspelt one, is refused with exit code 2 and a message naming the
  variable and the allowed or supported values; nothing is written.

Which paths the CPU supports is read from /proc/cpuinfo, independently of the binary's own
detection. On a machine without AVX-512 the `avx512` path is only checked to be refused; run this
test on an AVX-512 machine to compare it bit for bit too."""

import h5py
import numpy as np

from conftest import _bits, assert_files_equal, base_sweep, read_all, run, write_sweep

FUSED = ["avx-fma", "avx2", "avx512"]


def cpu_flags():
    with open("/proc/cpuinfo") as f:
        for line in f:
            if line.startswith("flags"):
                return set(line.split(":", 1)[1].split())
    raise AssertionError("/proc/cpuinfo lists no flags")


def supported(level, flags):
    need = {
        "portable": set(),
        "avx-fma": {"avx", "fma"},
        "avx2": {"avx2", "fma"},
        "avx512": {"avx512f", "avx512vl", "avx2", "fma"},
    }[level]
    return need <= flags


def sweep():
    s = base_sweep(history=True)
    s["record"]["min_overlap"] = True
    s["axes"] = [
        {"field": "chain.cylinder.mass.heavy_cylinders.mass_ratio", "values": [0.3, 1.0]},
        {"field": "physics.damping_kg_s", "values": [0, 6]},
    ]
    return s


def run_pinned(tmp_path, level):
    path = write_sweep(tmp_path / "sweep.json", sweep())
    out = tmp_path / f"{level}.h5"
    r = run("run", path, "-o", out, "--jobs", "2", "--quiet", env={"CHAINSWEEP_CPU": level})
    return r, out


def test_each_pinned_path(tmp_path, binary):
    flags = cpu_flags()
    assert "fma" in flags, "this test compares the fused paths; the CPU has no FMA"
    files = {}
    for level in ["portable"] + FUSED:
        r, out = run_pinned(tmp_path, level)
        if supported(level, flags):
            assert r.returncode == 0, f"{level}: {r.stderr}"
            files[level] = out
        else:
            assert r.returncode == 2, f"{level} is not supported here but ran: {r.stderr}"
            assert "CHAINSWEEP_CPU" in r.stderr and "supported here" in r.stderr, r.stderr
            assert not out.exists()
    fused = [level for level in FUSED if level in files]
    assert len(fused) >= 1
    print("fused paths compared:", fused)
    for level in fused[1:]:
        assert_files_equal(files[fused[0]], files[level])
    # Without FMA: not the same bits, the same physics.
    dp, _ = read_all(files["portable"])
    dq, _ = read_all(files[fused[0]])
    assert any(_bits(dp[k][1]) != _bits(dq[k][1]) for k in dq), "pinning the portable path had no effect"
    with h5py.File(files["portable"]) as p, h5py.File(files[fused[0]]) as q:
        assert np.isfinite(q["record_max"][()]).all()
        for name in ["leading_peak", "record_max"]:
            # (a leading peak is NaN where the pulse has not passed by the end: on both paths)
            np.testing.assert_allclose(p[name][()], q[name][()], rtol=1e-6, atol=0, err_msg=name)
        a, b = p["energy_drift_max"][()], q["energy_drift_max"][()]
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-6, err_msg="energy_drift_max")


def test_unknown_path_is_refused(tmp_path, binary):
    r, out = run_pinned(tmp_path, "sse9")
    assert r.returncode == 2
    assert "CHAINSWEEP_CPU=sse9" in r.stderr
    assert "portable, avx-fma, avx2, avx512" in r.stderr
    assert not out.exists()
