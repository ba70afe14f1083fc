"""Each fit example of sweeps/examples/ done by the engine (`chainsweep run`, --jobs 2) and the
same fit done with scipy's least_squares calling the engine from Python (chainsweep.run per
run, from the sweep's base value of each field, bounded to the same interval): runs, wall time,
answer ± standard error, side by side in one process.

    python scripts/bench_fit_examples.py
"""

from __future__ import annotations

import copy
import json
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np
import xarray as xr
from scipy.interpolate import CubicSpline
from scipy.optimize import least_squares

import chainsweep

REPO = Path(__file__).resolve().parent.parent
BIN = REPO / "target" / "release" / "chainsweep"
EXAMPLES = REPO / "sweeps" / "examples"


def setp(d: dict, path: str, value) -> None:
    keys = path.split(".")
    for k in keys[:-1]:
        d = d[k]
    d[keys[-1]] = value


def getp(d: dict, path: str):
    for k in path.split("."):
        d = d[k]
    return d


def engine(name: str) -> dict:
    with tempfile.TemporaryDirectory() as d:
        out = Path(d) / "fit.h5"
        t0 = time.perf_counter()
        r = subprocess.run([str(BIN), "run", str(EXAMPLES / f"{name}.json"), "-o", str(out), "--quiet",
                            "--jobs", "2"], capture_output=True, text=True)
        wall = time.perf_counter() - t0
        assert r.returncode == 0, r.stderr
        with xr.open_dataset(out) as ds:
            field = str(ds.fit_field_name.values[0])
            return {
                "runs": int(ds.search_runs), "wall": wall,
                "x": float(ds[f"fit_{field}"].values.ravel()[0]),
                "se": float(ds[f"fit_{field}_standard_error"]),
                "interval": (float(ds[f"fit_{field}_profile_lower"]), float(ds[f"fit_{field}_profile_upper"])),
            }


def scipy_fit(spec: dict, residuals, x0: list[float], lo: list[float], hi: list[float]) -> dict:
    calls = [0]

    def f(x):
        return residuals(x, calls)

    t0 = time.perf_counter()
    r = least_squares(f, x0=x0, bounds=(lo, hi), x_scale=[h - l for l, h in zip(lo, hi)], diff_step=1e-3)
    wall = time.perf_counter() - t0
    cov = np.linalg.pinv(r.jac.T @ r.jac)
    return {"runs": calls[0], "wall": wall, "x": float(r.x[0]), "se": float(np.sqrt(cov[0, 0]))}


def scalars(spec: dict):
    """Residuals of a fit to scalar data (leading peaks and their ratios)."""
    field = spec["search"]["fields"][0]["field"]
    data = spec["search"]["data"]

    def peak(ds, probe):
        return float(ds.leading_peak.sel(probe=probe))

    def res(x, calls):
        scene = copy.deepcopy(spec["base"])
        setp(scene, field, float(x[0]))
        calls[0] += 1
        ds = chainsweep.run(scene, record=spec["record"])
        out = []
        for d in data:
            if "ratio" in d:
                a, b = d["ratio"]
                model = peak(ds, a["probe"]) / peak(ds, b["probe"])
                sigma = d["relative_sigma"] * abs(d["value"])
            else:
                model = peak(ds, d["probe"])
                sigma = d["sigma"]
            out.append((model - d["value"]) / sigma)
        return np.array(out)
    return res


def signals(spec: dict):
    """Residuals of the signal fit: the damping, and each recording's shift and gain."""
    data = []
    for d in spec["search"]["data"]:
        s = d["signal"]
        t, v = np.loadtxt(EXAMPLES / s["path"], delimiter=",", skiprows=1, unpack=True)
        data.append((s["probe"], t, v, s["sigma"]))

    def res(x, calls):
        scene = copy.deepcopy(spec["base"])
        scene["physics"]["damping_kg_s"] = float(x[0])
        calls[0] += 1
        ds = chainsweep.run(scene, record=spec["record"])
        out = []
        for k, (probe, t, v, sigma) in enumerate(data):
            spline = CubicSpline(ds.time_s.values, ds.history.sel(probe=probe).values)
            shift, gain = x[1 + 2 * k], x[2 + 2 * k]
            out.append((gain * spline(t + shift) - v) / sigma)
        return np.concatenate(out)
    return res


def spectrum(spec: dict):
    """Residuals of the spectrum fit: transmission (dB) and phase at every frequency."""
    sp = spec["search"]["data"][0]["spectrum"]
    path = "excitation.drive.force_n.harmonic.frequency_hz"

    def res(x, calls):
        out_db, out_ph = [], []
        for f, db, ph in zip(sp["frequency_hz"], sp["transmission_db"], sp["phase_rad"]):
            scene = copy.deepcopy(spec["base"])
            scene["physics"]["damping_kg_s"] = float(x[0])
            setp(scene, path, f)
            calls[0] += 1
            ds = chainsweep.run(scene, record=spec["record"])
            probe = sp["probe"]
            out_db.append((float(ds.steady_transmission_db.sel(probe=probe)) - db) / sp["sigma"])
            rel = float(ds.steady_phase_rad.sel(probe=probe).values.ravel()[0]
                        - ds.steady_phase_rad.isel(probe=0).values.ravel()[0])
            out_ph.append(np.angle(np.exp(1j * (rel - ph))) / sp["phase_sigma_rad"])
        return np.array(out_db + out_ph)
    return res


def main() -> None:
    rows = []
    for name in ("fit-damping", "fit-striker-velocity", "fit-signal", "fit-spectrum"):
        spec = json.loads((EXAMPLES / f"{name}.json").read_text())
        f = spec["search"]["fields"][0]
        x0 = [float(getp(spec["base"], f["field"]))]
        lo, hi = [f["min"]], [f["max"]]
        if name == "fit-signal":
            res = signals(spec)
            for d in spec["search"]["data"]:
                sh = d["signal"]["time_shift_s"]
                x0 += [0.5 * (sh["min"] + sh["max"]), 1.0]
                lo += [sh["min"], 0.5]
                hi += [sh["max"], 1.5]
        elif name == "fit-spectrum":
            res = spectrum(spec)
        else:
            res = scalars(spec)
        e = engine(name)
        s = scipy_fit(spec, res, x0, lo, hi)
        rows.append((name, f["field"], e, s))
    print(f"{'example':22s} {'':7s} {'runs':>5s} {'wall s':>7s}  answer ± se (engine: 95 % profile interval)")
    for name, field, e, s in rows:
        print(f"{name:22s} engine  {e['runs']:5d} {e['wall']:7.2f}  {e['x']:.5f} ± {e['se']:.4f}  "
              f"[{e['interval'][0]:.4f}, {e['interval'][1]:.4f}]")
        print(f"{'':22s} scipy   {s['runs']:5d} {s['wall']:7.2f}  {s['x']:.5f} ± {s['se']:.4f}")


if __name__ == "__main__":
    main()
