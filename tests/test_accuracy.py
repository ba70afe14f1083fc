"""`chainsweep accuracy`: the work-precision study, with DOP853 and with steps ended on predicted
contact switches (`dop853-predict`) on the same ladder of tolerances."""

import time

import h5py
import numpy as np

from conftest import base_sweep, run, write_sweep


def small_scene(tmp_path):
    s = base_sweep(cylinders=12, duration_s=3e-4, probes=(4, 8))
    s["base"]["physics"]["damping_kg_s"] = 6.0
    s["axes"] = [{"field": "duration_s", "values": [3e-4]}]
    return write_sweep(tmp_path / "scene.json", s)


def test_prediction_is_a_line_of_the_study_and_costs_less_for_the_same_error(binary, tmp_path):
    out = tmp_path / "study.h5"
    p = run("accuracy", small_scene(tmp_path), "-o", out, "--methods", "dop853,dop853-predict",
            "--repeats", "1")
    assert p.returncode == 0, p.stderr
    assert "dop853-predict" in p.stdout, p.stdout
    with h5py.File(out) as f:
        assert f.attrs["reference"].startswith("dop853 rtol 1e-12")
        plain, pred = f["dop853"], f["dop853-predict"]
        assert pred.attrs["setting_name"] == "rtol"
        np.testing.assert_array_equal(plain["setting"][:], pred["setting"][:])
        rtol = pred["setting"][:]
        assert (plain["ok"][:] == 1).all() and (pred["ok"][:] == 1).all()
        tight = rtol <= 1e-7
        # Below 1e-7 the leading-peak error follows the tolerance for both (within 50x) and
        # reaches 1e-9 at the tightest rung: prediction does not give up accuracy.
        for g in (plain, pred):
            err = g["error"][:]
            assert (err[tight] <= 50 * rtol[tight]).all(), (g.name, err, rtol)
            assert err[-1] < 1e-9, (g.name, err)
        # ... and needs fewer right-hand sides at every rung from 1e-6 down.
        sel = rtol <= 1e-6
        assert (pred["rhs_evals"][:][sel] < plain["rhs_evals"][:][sel]).all(), (
            pred["rhs_evals"][:], plain["rhs_evals"][:])


def test_unknown_method_is_refused_before_any_run(binary, tmp_path):
    out = tmp_path / "study.h5"
    p = run("accuracy", small_scene(tmp_path), "-o", out, "--methods", "dop853,dop853_predict")
    assert p.returncode == 2, (p.returncode, p.stderr)
    assert "--methods" in p.stderr and "dop853_predict" in p.stderr, p.stderr
    assert "allowed: dop853, dop853-predict, vern6, ros34pw2, rk4, verlet" in p.stderr, p.stderr
    assert "rtol" not in p.stdout + p.stderr  # no ladder ran
    assert not out.exists()


def test_a_ladder_run_is_stopped_at_max_run_seconds_and_ends_its_ladder(binary, tmp_path):
    """Every run of a ladder is bounded by --max-run-seconds: one that reaches it is stopped there,
    recorded as failed with how far it got, and the ladder ends; the study is still written."""
    s = base_sweep(cylinders=50, duration_s=1e-3, probes=(4, 21))
    s["base"]["physics"]["damping_kg_s"] = 6.0
    s["axes"] = [{"field": "duration_s", "values": [1e-3]}]
    out = tmp_path / "study.h5"
    # 10 µs: less than the first 64 steps of any rung take (the clock is read every 64 steps).
    p = run("accuracy", write_sweep(tmp_path / "scene.json", s), "-o", out, "--methods", "dop853",
            "--repeats", "1", "--max-run-seconds", "1e-5")
    assert p.returncode == 0, p.stderr
    with h5py.File(out) as f:
        g = f["dop853"]
        assert list(g["ok"][:]) == [0], g["ok"][:]
        assert list(g["setting"][:]) == [1e-4]
        reason = g["reason"].asstr()[0]
        assert reason.startswith("wall-time limit 0.00001 s reached at t = "), reason
        assert " of 1.000e-3 s after " in reason and reason.endswith(" (--max-run-seconds)"), reason
        assert f.attrs["reference"].startswith("dop853 rtol 1e-12")
    assert "stopping the ladder" in p.stderr, p.stderr


def test_a_runaway_scene_ends_its_study_within_the_limits(binary, tmp_path):
    """The runaway scene (a 1000 m/s striker into a chain damped at 1e9 kg/s): its
    reference (ROS34PW2, damping-dominated) is quick, but DOP853's steps are held near m/μ, so its
    confirmation (DOP853 rtol 1e-12) and its first rung would run for minutes to hours. They stop
    at limits.max_run_seconds and --max-run-seconds, and the study ends."""
    s = base_sweep(cylinders=10, duration_s=2e-4)
    s["base"]["striker_velocity_m_s"] = 1000
    s["base"]["physics"]["damping_kg_s"] = 1e9
    s["axes"] = [{"field": "duration_s", "values": [2e-4]}]
    s["limits"] = {"max_run_seconds": 2}
    out = tmp_path / "study.h5"
    start = time.monotonic()
    p = run("accuracy", write_sweep(tmp_path / "runaway.json", s), "-o", out, "--methods", "dop853",
            "--repeats", "1", "--max-run-seconds", "1", timeout=120)
    wall = time.monotonic() - start
    assert p.returncode == 0, (p.returncode, p.stderr)
    assert wall < 2 + 1 + 10, wall
    assert "confirmation failed: wall-time limit 2 s reached at t = " in p.stderr, p.stderr
    assert "(limits.max_run_seconds)" in p.stderr, p.stderr
    assert "reference ros34pw2 (not confirmed: the dop853 run failed)" in p.stdout, p.stdout
    with h5py.File(out) as f:
        assert f.attrs["reference"].startswith("ros34pw2")
        assert np.isnan(f.attrs["reference_agreement"])
        g = f["dop853"]
        assert list(g["ok"][:]) == [0], g["ok"][:]
        reason = g["reason"].asstr()[0]
        assert reason.startswith("wall-time limit 1 s reached at t = "), reason
        assert reason.endswith(" (--max-run-seconds)"), reason
        assert 1 <= g["wall_time"][0] < 3, g["wall_time"][:]


def test_the_reference_run_is_bounded_by_the_sweeps_wall_time_limit(binary, tmp_path):
    """A second of simulated time at DOP853 rtol 1e-12 (the reference of a scene that is not
    damping-dominated) takes minutes: the reference stops at limits.max_run_seconds, and the study
    fails with the reason, writing nothing."""
    s = base_sweep(cylinders=50, duration_s=1.0, probes=(4, 21))
    s["axes"] = [{"field": "duration_s", "values": [1.0]}]
    s["limits"] = {"max_run_seconds": 2}
    out = tmp_path / "study.h5"
    start = time.monotonic()
    p = run("accuracy", write_sweep(tmp_path / "long.json", s), "-o", out, "--methods", "dop853",
            "--repeats", "1", timeout=120)
    wall = time.monotonic() - start
    assert p.returncode == 1, (p.returncode, p.stderr)
    assert wall < 2 + 8, wall
    assert "the reference run failed: wall-time limit 2 s reached at t = " in p.stderr, p.stderr
    assert "(limits.max_run_seconds)" in p.stderr, p.stderr
    assert not out.exists()
