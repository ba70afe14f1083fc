"""`chainsweep accuracy`: the work-precision study, with DOP853 and with steps ended on predicted
contact switches (`dop853-predict`) on the same ladder of tolerances."""

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
