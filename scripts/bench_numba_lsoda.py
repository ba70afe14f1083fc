"""chainsweep against numba + numbalsoda LSODA on the Fig. 8 sweep, side by side (`make bench`).

"Them" is what a physicist who knows numba writes for the Fig. 8 sweep (`sweeps/fig08.json`: 182
runs of the 50-cylinder chain, ε = 0.10 … 1.00 heavy cylinders × μ = 0, 6 kg/s): the chain's
right-hand side written from docs/MODEL.md as a numba `cfunc` (one loop over the contacts: Hertz
δ^{3/2} plus the viscous term while compressed, gravity, the wall, the striker's sphere–sphere
contact), integrated by LSODA through numbalsoda, the 182 runs over a `multiprocessing` pool of
two processes. "Us" is `chainsweep run SWEEP --jobs 2` of the same sweep file with its integrator
block set per rung (DOP853 with `predict_switches`, the sweep's own setting).

The peer, in detail (every choice here is one in its favour, or the one a user would make):

- The state is scaled, positions by the two-body peak overlap δ_m and velocities by v0, because
  numbalsoda takes one scalar `atol`: `atol = rtol` then means what chainsweep's default `atol`
  means (rtol × δ_m on positions, rtol × v0 on velocities).
- Each scene (masses, Hertz coefficients, damping, gravity, wall, striker velocity, probes, leading-
  pulse fractions, sampling interval) is read from `chainsweep point SWEEP I --scene-only`, and the
  script refuses a scene with physics it does not implement.
- The observable is chainsweep's (crates/solver/src/observe/probes/, ported line by line): the
  gauge force in cylinder k (the mean of its two contacts' elastic + viscous forces, the static
  preload included) sampled every `summary_interval_s` (0.2 µs) on LSODA's own interpolant (its
  Nordsieck history: LSODA steps past each output time and interpolates back), the leading pulse's
  arrival at 1 % of the two-body impact force above the initial value, its passing once the signal
  falls below half its peak (from the second sample after the peak), and the peak refined by the
  quartic through the five samples around the largest one. Both sides therefore compute the same
  number from the same definition; the error of each is its integrator's.
- A run stops once both leading pulses have passed, as the sweep's `stop_after_leading_pulses`
  does: numbalsoda's `lsoda` integrates over a given array of output times and has no events, so
  the peer integrates in chunks of CHUNK_US µs of output times, restarting LSODA from the last
  output state, and stops after the chunk in which both pulses passed. (25–50 µs chunks were the
  fastest of 10 … 200 µs; integrating to the sweep's 3 ms would cost it about 4× more;
  `--chunk-us` changes the chunk.)
- The driver (chunks, gauges, peak trackers) is `@njit` too, compiled once in the parent before
  the pool forks, so the workers run compiled code only; tasks are handed out one at a time
  (`imap_unordered`, chunksize 1), which balances the uneven runs (ε = 0.1 takes 2–3× ε = 1).
  The cfunc is compiled with `fastmath` (its RHS: 0.2 µs for the 102 contacts, 0.27 µs without).
  numba's import and JIT compile time is reported apart from the sweep's wall time.

What is measured (all in one run, the two sides alternating, so both see the same machine load):

1. RHS check: the peer's gauge histories (1 µs) against `chainsweep.run` of the same scene (DOP853
   rtol 1e-12) at three grid points, both at tight tolerances: the largest difference relative to
   the two-body impact force must be below 1e-7 (it is about 1e-10), else the script stops.
2. The reference: chainsweep DOP853 rtol 1e-12 (without switch prediction) over the 182 points,
   confirmed by the peer at its tightest rtol.
3. Both ladders: for each rtol, the max and median relative error of F21/F4 over the 182 points
   against the reference, the total RHS evaluations (the peer's counted inside its cfunc, LSODA's
   finite-difference Jacobians included), the sweep's wall time (median of REPEATS).
4. The speed ratio at equal accuracy: for each chainsweep rung, the peer's time at the same max
   error, interpolated log-log between its bracketing rungs (and, without interpolation, its
   cheapest rung at least as accurate).
5. The fixed costs of each side, in the same rounds: the sweep with every point run for one summary
   interval (the scene's `summary_interval_s`, 0.2 µs in fig08.json). The peer's are its pool's
   start and end and its drivers' set-up; chainsweep's are its start (the sweep read, its scenes
   built, checked and named), each run's set-up, and its output file written while the first runs
   compute, written again at the end, checksummed and read back twice before the logs it makes
   redundant are removed: the peer writes nothing. The ratio of the runs alone (each sweep's wall
   less its side's fixed costs) says how much of the end-to-end ratio the fixed costs, the output
   file among them, account for. It is an upper estimate of chainsweep's lead where its fixed
   costs overlap its runs (the first file is written while the first runs compute; in the short
   sweep it is all in the wall).

    python scripts/bench_numba_lsoda.py [--repeats 5] [--chunk-us 50] [--rtols 1e-6,...] [--ours-rtols 1e-6,...]

Prints the tables and writes target/bench/numba_lsoda.json.
"""

from __future__ import annotations

import argparse
import json
import math
import multiprocessing
import os
import platform
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
SWEEP = REPO / "sweeps" / "fig08.json"
OUT_JSON = Path(os.environ.get("CARGO_TARGET_DIR", REPO / "target")) / "bench" / "numba_lsoda.json"
PEER_RTOLS = [1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11]
OURS_RTOLS = [1e-6, 1e-7, 1e-8, 1e-9, 1e-10]
REFERENCE = {"method": "dop853", "rtol": 1e-12}
PEER_CHECK_RTOL = 1e-12
CHUNK_US = 50.0
JOBS = 2
# The rtol of the fixed-cost sweeps (their runs end after one summary interval: it hardly matters).
FIXED_RTOL = 1e-8
#: Largest allowed difference of the peer's gauge histories from chainsweep's, relative to the
#: two-body impact force (the RHS check).
RHS_CHECK_MAX = 1e-7
RHS_CHECK_POINTS = (1, 90, 181)
#: The layout of the parameter block the cfunc reads (numbalsoda passes one double
#: array): header, then A (n), μ (n), 1/m (n).
HDR = 8
H_N, H_G, H_WALL, H_X, H_V, H_CLIP, H_COUNT = range(7)


# ---------------------------------------------------------------------------------- the scenes
def chainsweep_bin() -> Path:
    default = Path(os.environ.get("CARGO_TARGET_DIR", REPO / "target")) / "release" / "chainsweep"
    return Path(os.environ.get("CHAINSWEEP_BIN", default))


def scenes(sweep: Path) -> list[dict]:
    """Every grid point's scene as the runner expands it (`chainsweep point … --scene-only`)."""
    exe = chainsweep_bin()
    dry = json.loads(subprocess.run([str(exe), "run", str(sweep), "--dry-run", "--json"], check=True,
                                    stdout=subprocess.PIPE, text=True).stdout)
    n = int(dry["cost"]["runs"])
    out = []
    for i in range(n):
        p = json.loads(subprocess.run([str(exe), "point", str(sweep), str(i), "--scene-only"], check=True,
                                      stdout=subprocess.PIPE, text=True).stdout)
        assert p["index"] == i
        out.append(p["scene"])
    return out


def hertz(e1, nu1, e2, nu2, r_eff):
    """Eqs. (1), (4), (5): 4 E1 E2 √R / (3 [E1(1−ν2²) + E2(1−ν1²)])."""
    return 4 * e1 * e2 * math.sqrt(r_eff) / (3 * (e1 * (1 - nu2**2) + e2 * (1 - nu1**2)))


class Point:
    """One grid point, in the peer's form: the parameter block of its cfunc, the scaled initial
    state, the probes and the leading-pulse settings; built from the scene's JSON and docs/MODEL.md
    alone. Refuses physics the peer does not implement."""

    def __init__(self, scene: dict):
        ch, ph, rec = scene["chain"], scene["physics"], scene["record"]
        known_chain = {"cylinder", "cylinders", "sphere", "striker", "wall_material"}
        if set(ch) - known_chain:
            raise ValueError(f"chain fields the peer does not implement: {sorted(set(ch) - known_chain)}")
        known_top = {"chain", "duration_s", "integrator", "max_steps", "physics", "record", "striker_velocity_m_s"}
        if set(scene) - known_top:
            raise ValueError(f"scene fields the peer does not implement: {sorted(set(scene) - known_top)}")
        if ph.get("clip_tensile"):
            raise ValueError("the peer implements clip_tensile: false")
        if rec.get("preload", "include") != "include":
            raise ValueError("the peer implements gauge forces with the preload included")
        known_phys = {"clip_tensile", "damping_kg_s", "gravity", "gravity_m_s2", "striker_damping_kg_s", "wall"}
        if set(ph) - known_phys:
            raise ValueError(f"physics fields the peer does not implement: {sorted(set(ph) - known_phys)}")
        sph, cyl, stk = ch["sphere"], ch["cylinder"], ch["striker"]
        m_s = float(sph["mass_kg"])
        mass = cyl["mass"]
        if "heavy_cylinders" in mass:
            m_c = m_s / float(mass["heavy_cylinders"]["mass_ratio"])
        elif "light_cylinders" in mass:
            m_c = m_s * float(mass["light_cylinders"]["mass_ratio"])
        elif "mass_kg" in mass:
            m_c = float(mass["mass_kg"])
        else:
            raise ValueError(f"cylinder mass {mass!r}")
        n_cyl = int(ch["cylinders"])
        n = 2 * n_cyl + 2
        self.n = n
        m = np.full(n, m_s)
        m[0] = float(stk["mass_kg"])
        m[2::2] = m_c  # cylinders: 0-based particles 2, 4, …, 2·n_cyl (cylinder k is particle 2k)
        es, nus = sph["material"]["youngs_modulus_pa"], sph["material"]["poisson_ratio"]
        ec, nuc = cyl["material"]["youngs_modulus_pa"], cyl["material"]["poisson_ratio"]
        ei, nui = stk["material"]["youngs_modulus_pa"], stk["material"]["poisson_ratio"]
        ew, nuw = ch["wall_material"]["youngs_modulus_pa"], ch["wall_material"]["poisson_ratio"]
        r_s, r_i = sph["diameter_m"] / 2, stk["diameter_m"] / 2
        a = np.full(n, hertz(es, nus, ec, nuc, r_s))  # sphere–cylinder, Eq. (4)
        a[0] = hertz(ei, nui, es, nus, 1 / (1 / r_s + 1 / r_i))  # striker–sphere, Eq. (5)
        wall = bool(ph["wall"])
        a[-1] = hertz(es, nus, ew, nuw, r_s) if wall else 0.0  # the wall, Eq. (7)
        mu = float(ph["damping_kg_s"])
        mus = np.full(n, mu)
        sd = ph.get("striker_damping_kg_s")
        mus[0] = mu if sd is None else float(sd)
        g = float(ph.get("gravity_m_s2", 9.81)) if ph["gravity"] else 0.0
        v0 = float(scene["striker_velocity_m_s"])
        # The two-body impact: peak overlap (the position scale) and force (the probes' scale).
        m_r = m[0] * m[1] / (m[0] + m[1])
        delta_m = (5 * m_r * v0**2 / (4 * a[0])) ** 0.4
        self.force_scale = a[0] * delta_m**1.5
        # Static equilibrium with the wall and gravity: contact j ≥ 1 carries particles 1..j.
        x = np.zeros(n)
        if wall and g > 0:
            overlap = np.zeros(n)
            overlap[1:] = (g * np.cumsum(m[1:]) / a[1:]) ** (2 / 3)
            x[-1] = overlap[-1]
            for j in range(n - 2, -1, -1):
                x[j] = x[j + 1] + overlap[j]
        v = np.zeros(n)
        v[0] = v0
        self.y0 = np.concatenate([x / delta_m, v / v0])
        self.data = np.concatenate([[n, g, 1.0 if wall else 0.0, delta_m, v0, 0.0, 0.0, 0.0], a, mus, 1 / m])
        probes = rec["probes"]
        if any(p["kind"] != "gauge_force" for p in probes):
            raise ValueError("the peer implements gauge_force probes only")
        self.cylinders = np.array([int(p["cylinder"]) for p in probes], dtype=np.int64)
        lp = rec["leading_pulse"]
        self.arrival = float(lp["arrival_fraction"]) * self.force_scale
        self.release = float(lp["release_fraction"])
        self.dt = float(rec["summary_interval_s"])
        self.duration = float(scene["duration_s"])
        if not rec.get("stop_after_leading_pulses"):
            raise ValueError("the Fig. 8 sweep stops after the leading pulses; the peer does too")
        self.mass_ratio = float(mass.get("heavy_cylinders", mass.get("light_cylinders", {})).get("mass_ratio", math.nan))
        self.damping = mu


# ---------------------------------------------------------------------------------- the peer
def build_peer():
    """Imports numba and numbalsoda and compiles the right-hand side (cfunc) and the driver (njit).
    Returns (the cfunc's address, the driver, the gauge function, import seconds)."""
    t0 = time.perf_counter()
    import numba as nb
    from numbalsoda import lsoda, lsoda_sig
    t_import = time.perf_counter() - t0

    @nb.cfunc(lsoda_sig, boundscheck=False, fastmath=True, error_model="numpy")
    def rhs(t, u, du, p_):
        hdr = nb.carray(p_, (HDR,))
        n = int(hdr[H_N])
        p = nb.carray(p_, (HDR + 3 * n,))
        hdr[H_COUNT] += 1.0
        y = nb.carray(u, (2 * n,))
        dy = nb.carray(du, (2 * n,))
        g, wall, xs, vs = p[H_G], p[H_WALL] != 0.0, p[H_X], p[H_V]
        vx = vs / xs
        f_prev = 0.0
        for i in range(n):
            f = 0.0
            if i + 1 < n:
                d = xs * (y[i] - y[i + 1])
                if d > 0.0:
                    f = p[HDR + i] * d * math.sqrt(d) + p[HDR + n + i] * vs * (y[n + i] - y[n + i + 1])
            elif wall:
                d = xs * y[i]
                if d > 0.0:
                    f = p[HDR + i] * d * math.sqrt(d) + p[HDR + n + i] * vs * y[n + i]
            dy[i] = vx * y[n + i]
            dy[n + i] = (g + (f_prev - f) * p[HDR + 2 * n + i]) / vs
            f_prev = f
        return

    @nb.njit(cache=False)
    def contact_force(y, p, n, c):
        """Net force of contact c (0-based: particles c and c+1, the last one the wall), N."""
        xs, vs = p[H_X], p[H_V]
        if c + 1 < n:
            d = xs * (y[c] - y[c + 1])
            rel = vs * (y[n + c] - y[n + c + 1])
        else:
            if p[H_WALL] == 0.0:
                return 0.0
            d = xs * y[c]
            rel = vs * y[n + c]
        if d > 0.0:
            return p[HDR + c] * d * math.sqrt(d) + p[HDR + n + c] * rel
        return 0.0

    @nb.njit(cache=False)
    def gauge(y, p, n, k):
        """Gauge force in cylinder k (particle 2k, 0-based): the mean of contacts 2k−1 and 2k, N."""
        return 0.5 * (contact_force(y, p, n, 2 * k - 1) + contact_force(y, p, n, 2 * k))

    # Tracker state per probe (chainsweep's PeakTracker + PeakWindow): baseline, arrival, phase
    # (0 waiting, 1 in pulse, 2 passed), values[5], time, after, before, prev[2], n_prev.
    B, AR, PH, V0, TM, AF, BF, P0, P1, NP = 0, 1, 2, 3, 8, 9, 10, 11, 12, 13

    @nb.njit(cache=False)
    def offer(st, t, s):
        if s > st[V0 + 2]:
            st[V0 + 0] = st[P0]
            st[V0 + 1] = st[P1]
            st[V0 + 2] = s
            st[V0 + 3] = np.nan
            st[V0 + 4] = np.nan
            st[TM] = t
            st[AF] = 0.0
            st[BF] = min(st[NP], 2.0)
        elif st[AF] < 2.0 and np.isfinite(st[TM]):
            st[V0 + 3 + int(st[AF])] = s
            st[AF] += 1.0

    @nb.njit(cache=False)
    def sample(st, t, s, release):
        if st[PH] == 0.0:
            if s - st[B] > st[AR]:
                st[PH] = 1.0
                offer(st, t, s)
        elif st[PH] == 1.0:
            offer(st, t, s)
            peak = st[V0 + 2] - st[B]
            if s - st[B] < release * peak and st[AF] >= 2.0:
                st[PH] = 2.0
        st[P0] = st[P1]
        st[P1] = s
        st[NP] += 1.0

    @nb.njit(cache=False)
    def refined(st, dt):
        """The leading peak (value, time): chainsweep's PeakWindow::refined."""
        if st[AF] < 1.0 or not np.isfinite(st[TM]):
            return np.nan, np.nan
        v = st[V0:V0 + 5]
        if st[BF] == 2.0 and st[AF] == 2.0:
            c0 = v[2]
            c1 = (v[0] - 8.0 * v[1] + 8.0 * v[3] - v[4]) / 12.0
            c2 = (-v[0] + 16.0 * v[1] - 30.0 * v[2] + 16.0 * v[3] - v[4]) / 24.0
            c3 = (-v[0] + 2.0 * v[1] - 2.0 * v[3] + v[4]) / 12.0
            c4 = (v[0] - 4.0 * v[1] + 6.0 * v[2] - 4.0 * v[3] + v[4]) / 24.0
            u = 0.0
            for _ in range(20):
                h = 2.0 * c2 + u * (6.0 * c3 + u * 12.0 * c4)
                if h >= 0.0:
                    break
                step = (c1 + u * (2.0 * c2 + u * (3.0 * c3 + u * 4.0 * c4))) / h
                u = min(max(u - step, -1.0), 1.0)
                if abs(step) < 1e-14:
                    break
            pu = c0 + u * (c1 + u * (c2 + u * (c3 + u * c4)))
            ddp = 2.0 * c2 + u * (6.0 * c3 + u * 12.0 * c4)
            d0 = v[0] - 2.0 * v[1] + v[2]
            d1 = v[1] - 2.0 * v[2] + v[3]
            d2 = v[2] - 2.0 * v[3] + v[4]
            lo = min(d0, min(d1, d2))
            hi = max(d0, max(d1, d2))
            smooth = hi < 0.0 and lo >= 3.0 * hi
            if np.isfinite(pu) and pu >= v[2] and ddp < 0.0 and smooth:
                return pu, st[TM] + u * dt
            return v[2], st[TM]
        if st[BF] >= 1.0 and st[AF] >= 1.0:
            a, b, c = v[1], v[2], v[3]
            den = a - 2.0 * b + c
            if den < 0.0:
                u = min(max(0.5 * (a - c) / den, -1.0), 1.0)
                val = b - 0.25 * (a - c) * u
                return max(val, b), st[TM] + u * dt
            return b, st[TM]
        return v[2], st[TM]

    @nb.njit(cache=False)
    def run_point(funcptr, y0, p, cylinders, arrival, release, dt, duration, rtol, chunk):
        """One grid point: LSODA in chunks of `chunk` output times until both leading pulses have
        passed. Returns (leading peaks, their times, RHS evaluations, end time, ok)."""
        n = int(p[H_N])
        n_pr = len(cylinders)
        st = np.zeros((n_pr, 14))
        y = y0.copy()
        for k in range(n_pr):
            st[k, B] = gauge(y, p, n, cylinders[k])
            st[k, AR] = arrival
            for j in range(5):
                st[k, V0 + j] = -np.inf
            st[k, TM] = np.nan
            st[k, P0] = np.nan
            st[k, P1] = np.nan
            sample(st[k], 0.0, st[k, B], release)
        p[H_COUNT] = 0.0
        j_max = int(math.floor(duration / dt + 1e-9))
        j0 = 0
        ok = True
        while j0 < j_max:
            j1 = min(j0 + chunk, j_max)
            t_eval = np.arange(j0, j1 + 1) * dt
            usol, success = lsoda(funcptr, y, t_eval, data=p, rtol=rtol, atol=rtol, mxstep=100000)
            if not success:
                ok = False
                break
            for r in range(1, j1 - j0 + 1):
                for k in range(n_pr):
                    sample(st[k], t_eval[r], gauge(usol[r], p, n, cylinders[k]), release)
            y = usol[j1 - j0].copy()
            j0 = j1
            done = True
            for k in range(n_pr):
                if st[k, PH] != 2.0:
                    done = False
            if done:
                break
        peaks = np.empty(n_pr)
        times = np.empty(n_pr)
        for k in range(n_pr):
            peaks[k], times[k] = refined(st[k], dt)
        return peaks, times, p[H_COUNT], j0 * dt, ok

    @nb.njit(cache=False)
    def history(funcptr, y0, p, cylinders, times, rtol):
        """Gauge forces at `times` in one LSODA call (the RHS check)."""
        n = int(p[H_N])
        usol, success = lsoda(funcptr, y0.copy(), times, data=p, rtol=rtol, atol=rtol, mxstep=1000000)
        out = np.empty((len(cylinders), len(times)))
        for r in range(len(times)):
            for k in range(len(cylinders)):
                out[k, r] = gauge(usol[r], p, n, cylinders[k])
        return out, success

    return rhs.address, run_point, history, t_import


# The pool's workers read these (set in the parent before it forks).
_PEER: dict = {}


def _peer_task(args):
    i, rtol, duration = args
    pt: Point = _PEER["points"][i]
    peaks, times, nfev, t_end, ok = _PEER["run_point"](
        _PEER["funcptr"], pt.y0, pt.data.copy(), pt.cylinders, pt.arrival, pt.release, pt.dt,
        pt.duration if duration is None else duration, rtol, _PEER["chunk"])
    return i, peaks, int(nfev), t_end, ok


def peer_sweep(n_points: int, rtol: float, duration: float | None = None):
    """The 182 runs over a pool of JOBS processes (forked: they inherit the compiled code), each to
    its scene's end (or `duration`, s). Returns (F21/F4 per point, total RHS evaluations, wall
    seconds including the pool's start and end, the leading peaks)."""
    start = time.perf_counter()
    ctx = multiprocessing.get_context("fork")
    with ctx.Pool(JOBS) as pool:
        results = list(pool.imap_unordered(_peer_task, [(i, rtol, duration) for i in range(n_points)],
                                           chunksize=1))
    wall = time.perf_counter() - start
    peaks = np.full((n_points, 2), np.nan)
    nfev = 0
    for i, pk, fe, _, ok in results:
        if ok:
            peaks[i] = pk
        nfev += fe
    return peaks[:, 1] / peaks[:, 0], nfev, wall, peaks


# ---------------------------------------------------------------------------------- chainsweep
def ours_sweep(tmp: Path, integrator: dict, tag: str, binary: Path | None = None,
               duration_s: float | None = None):
    """`chainsweep run` of fig08.json with its integrator block replaced (and its runs' duration,
    when given), --jobs 2, into a fresh file, by `binary` (default: this tree's). Returns (F21/F4
    per point in grid order, total RHS evaluations, wall seconds, ε and μ per point, the leading
    peaks)."""
    import chainsweep

    spec = json.loads(SWEEP.read_text())
    spec["base"]["integrator"] = integrator
    if duration_s is not None:
        spec["base"]["duration_s"] = duration_s
    d = Path(tempfile.mkdtemp(dir=tmp, prefix=f"ours-{tag}-"))
    sweep = d / "fig08.json"
    sweep.write_text(json.dumps(spec))
    start = time.perf_counter()
    subprocess.run([str(binary or chainsweep_bin()), "run", str(sweep), "-o", str(d / "out.h5"), "--jobs", str(JOBS), "-q"],
                   check=True, stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - start
    ds = chainsweep.open(d / "out.h5")
    try:
        probes = [str(p) for p in ds.probe.values]
        lp = ds.leading_peak.transpose("mass_ratio", "damping_kg_s", "probe").values
        ratio = (lp[..., probes.index("gauge_force_cyl21")] / lp[..., probes.index("gauge_force_cyl4")]).reshape(-1)
        nfev = int(ds.rhs_evals.values.sum())
        eps = np.repeat(ds.mass_ratio.values, ds.sizes["damping_kg_s"])
        mu = np.tile(ds.damping_kg_s.values, ds.sizes["mass_ratio"])
    finally:
        ds.close()
    shutil.rmtree(d, ignore_errors=True)
    return ratio, nfev, wall, eps, mu, lp.reshape(-1, len(probes))


# ---------------------------------------------------------------------------------- comparison
def errors(ratio, reference):
    e = np.abs(ratio / reference - 1.0)
    if not np.all(np.isfinite(e)):
        return math.inf, math.inf
    return float(np.max(e)), float(np.median(e))


def frontier(rows):
    """(max error, wall) pairs sorted by error, keeping only those that no cheaper rung beats."""
    pts = sorted((r["max_error"], r["wall_s"]) for r in rows if math.isfinite(r["max_error"]))
    out = []
    for e, t in pts:
        if not out or t < out[-1][1]:
            out.append((e, t))
    return out


def time_at(rows, err):
    """The peer's wall at max error `err`: log-log interpolation between the bracketing rungs of
    its frontier (None outside its range), and its cheapest rung with an error ≤ err."""
    fr = frontier(rows)
    ok = [t for e, t in fr if e <= err]
    cheapest = min(ok) if ok else None
    interp = None
    for (e1, t1), (e2, t2) in zip(fr, fr[1:]):
        if e1 <= err <= e2:
            w = (math.log(err) - math.log(e1)) / (math.log(e2) - math.log(e1))
            interp = math.exp(math.log(t1) + w * (math.log(t2) - math.log(t1)))
            break
    if interp is None and fr and err == fr[0][0]:
        interp = fr[0][1]
    return interp, cheapest


def lscpu_model() -> str:
    try:
        out = subprocess.run(["lscpu"], check=True, stdout=subprocess.PIPE, text=True).stdout
        for line in out.splitlines():
            if line.startswith("Model name:"):
                return line.split(":", 1)[1].strip()
    except (OSError, subprocess.CalledProcessError):
        pass
    return platform.processor() or "unknown"


def rhs_check(points, scenes_, funcptr, history) -> float:
    """The peer's gauge histories against chainsweep's at a few grid points, both tight."""
    import chainsweep

    worst = 0.0
    for i in RHS_CHECK_POINTS:
        if i >= len(points):
            continue
        scene = json.loads(json.dumps(scenes_[i]))
        scene["integrator"] = dict(REFERENCE)
        scene["record"]["history"] = True
        scene["record"]["history_interval_s"] = 1e-6
        r = chainsweep.run(scene, as_dataset=False)
        pt = points[i]
        ts = np.asarray(r["time_s"], dtype=float)
        ours = np.asarray(r["history"], dtype=float)
        theirs, ok = history(funcptr, pt.y0, pt.data.copy(), pt.cylinders, ts, PEER_CHECK_RTOL)
        assert ok, f"LSODA failed on point {i}"
        d = float(np.max(np.abs(theirs - ours))) / pt.force_scale
        print(f"  point {i} (ε = {pt.mass_ratio:.2f}, μ = {pt.damping:g} kg/s): {len(ts)} samples of "
              f"{len(pt.cylinders)} gauges over {ts[-1] * 1e3:.3f} ms, preload {ours[0, 0]:.4f} / {ours[1, 0]:.4f} N "
              f"(peer {theirs[0, 0]:.4f} / {theirs[1, 0]:.4f}); largest difference {d:.1e} of the impact force "
              f"{pt.force_scale:.1f} N")
        worst = max(worst, d)
    return worst


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5, help="timed sweeps per rung and side (median)")
    ap.add_argument("--rtols", default=",".join(f"{r:g}" for r in PEER_RTOLS), help="the peer's ladder")
    ap.add_argument("--ours-rtols", default=",".join(f"{r:g}" for r in OURS_RTOLS), help="chainsweep's ladder")
    ap.add_argument("--chunk-us", type=float, default=CHUNK_US, help="the peer's chunk of output times, µs")
    ap.add_argument("--output", type=Path, default=OUT_JSON)
    ap.add_argument("--base-bin", type=Path, default=None,
                    help="a chainsweep binary from before a change: its ladder is timed in the same rounds, "
                         "alternating with this tree's and the peer's, and reported beside them")
    args = ap.parse_args()
    peer_rtols = [float(x) for x in args.rtols.split(",")]
    ours_rtols = [float(x) for x in args.ours_rtols.split(",")]

    print(f"Fig. 8 sweep ({SWEEP.relative_to(REPO)}): chainsweep against numba + numbalsoda LSODA, "
          f"{JOBS} processes each; {lscpu_model()}, {os.cpu_count()} CPUs")
    scenes_ = scenes(SWEEP)
    points = [Point(s) for s in scenes_]
    n = len(points)
    print(f"{n} grid points; {points[0].n} particles (striker included), a state of {2 * points[0].n}")

    t0 = time.perf_counter()
    funcptr, run_point, history, t_import = build_peer()
    # Compile the driver: one short point at a loose rtol (JIT happens on first call).
    pt = points[-1]
    run_point(funcptr, pt.y0, pt.data.copy(), pt.cylinders, pt.arrival, pt.release, pt.dt, 2e-5, 1e-6,
              int(round(args.chunk_us * 1e-6 / pt.dt)))
    history(funcptr, pt.y0, pt.data.copy(), pt.cylinders, np.array([0.0, 1e-6]), 1e-6)
    t_jit = time.perf_counter() - t0 - t_import
    import numba
    import numbalsoda  # noqa: F401  (version below)
    from importlib.metadata import version
    print(f"peer: numba {numba.__version__}, numbalsoda {version('numbalsoda')}: import {t_import:.2f} s, "
          f"JIT compile {t_jit:.2f} s (once per process that imports it; not in the sweep times below)")
    _PEER.update(points=points, funcptr=funcptr, run_point=run_point,
                 chunk=int(round(args.chunk_us * 1e-6 / points[0].dt)))

    print("\n1. RHS check: gauge histories (1 µs), peer LSODA rtol "
          f"{PEER_CHECK_RTOL:g} against chainsweep DOP853 rtol {REFERENCE['rtol']:g}")
    worst = rhs_check(points, scenes_, funcptr, history)
    if worst > RHS_CHECK_MAX:
        print(f"RHS check failed: {worst:.1e} > {RHS_CHECK_MAX:g}")
        return 1

    tmp = Path(tempfile.mkdtemp(prefix="bench-numba-lsoda-"))
    try:
        ref, ref_nfev, ref_wall, eps, mu, ref_peaks = ours_sweep(tmp, REFERENCE, "ref")
        for i, p in enumerate(points):
            assert abs(eps[i] - p.mass_ratio) < 1e-12 and abs(mu[i] - p.damping) < 1e-12, (i, eps[i], mu[i])
        chk, chk_nfev, chk_wall, chk_peaks = peer_sweep(n, PEER_CHECK_RTOL)
        e_chk = errors(chk, ref)
        e_f4 = errors(chk_peaks[:, 0], ref_peaks[:, 0])
        e_f21 = errors(chk_peaks[:, 1], ref_peaks[:, 1])
        print(f"\n2. reference: chainsweep DOP853 rtol {REFERENCE['rtol']:g} ({ref_nfev:,} RHS, {ref_wall:.2f} s); "
              f"the peer at rtol {PEER_CHECK_RTOL:g} ({chk_nfev:,} RHS, {chk_wall:.2f} s) agrees with it to "
              f"{e_chk[0]:.1e} max, {e_chk[1]:.1e} median (F21/F4 over {n} points; F4 {e_f4[0]:.1e}, F21 {e_f21[0]:.1e} max)")

        ours_rows = {r: {"rtol": r, "walls": []} for r in ours_rtols}
        base_rows = {r: {"rtol": r, "walls": []} for r in ours_rtols} if args.base_bin else {}
        peer_rows = {r: {"rtol": r, "walls": []} for r in peer_rtols}
        # The fixed costs (item 5 above): every point run for one summary interval.
        fixed: dict[str, list[float]] = {"chainsweep": [], "before": [], "peer": []}
        fixed_s = points[0].dt
        fixed_integ = {"method": "dop853", "rtol": FIXED_RTOL, "predict_switches": True}
        print(f"\n3. ladders, {args.repeats} alternating rounds:", flush=True)
        for rep in range(args.repeats):
            for k in range(max(len(ours_rtols), len(peer_rtols))):
                if k < len(ours_rtols):
                    r = ours_rtols[k]
                    integ = {"method": "dop853", "rtol": r, "predict_switches": True}
                    ratio, nfev, wall, _, _, _ = ours_sweep(tmp, integ, f"{r:g}")
                    row = ours_rows[r]
                    row["walls"].append(wall)
                    row["rhs_evals"] = nfev
                    row["max_error"], row["median_error"] = errors(ratio, ref)
                    row["errors"] = [float(f"{x:.3g}") for x in np.abs(ratio / ref - 1.0)]
                    if args.base_bin:
                        ratio, nfev, wall, _, _, _ = ours_sweep(tmp, integ, f"base-{r:g}", args.base_bin)
                        row = base_rows[r]
                        row["walls"].append(wall)
                        row["rhs_evals"] = nfev
                        row["max_error"], row["median_error"] = errors(ratio, ref)
                if k < len(peer_rtols):
                    r = peer_rtols[k]
                    ratio, nfev, wall, _ = peer_sweep(n, r)
                    row = peer_rows[r]
                    row["walls"].append(wall)
                    row["rhs_evals"] = nfev
                    row["max_error"], row["median_error"] = errors(ratio, ref)
                    row["errors"] = [float(f"{x:.3g}") for x in np.abs(ratio / ref - 1.0)]
            fixed["chainsweep"].append(ours_sweep(tmp, fixed_integ, "fixed", duration_s=fixed_s)[2])
            if args.base_bin:
                fixed["before"].append(ours_sweep(tmp, fixed_integ, "base-fixed", args.base_bin, fixed_s)[2])
            fixed["peer"].append(peer_sweep(n, FIXED_RTOL, fixed_s)[2])
            print(f"  round {rep + 1}: chainsweep " + ", ".join(f"{ours_rows[r]['walls'][-1]:.2f}" for r in ours_rtols)
                  + (" s; before " + ", ".join(f"{base_rows[r]['walls'][-1]:.2f}" for r in ours_rtols) if base_rows else "")
                  + " s; peer " + ", ".join(f"{peer_rows[r]['walls'][-1]:.2f}" for r in peer_rtols) + " s"
                  + f"; fixed costs {fixed['chainsweep'][-1]:.3f}"
                  + (f" (before {fixed['before'][-1]:.3f})" if args.base_bin else "")
                  + f", peer {fixed['peer'][-1]:.3f} s", flush=True)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    for rows in (ours_rows, base_rows, peer_rows):
        for row in rows.values():
            row["wall_s"] = statistics.median(row["walls"])

    print(f"\n| side | rtol | F21/F4 error, max | median | RHS evaluations | sweep wall, median of {args.repeats} |")
    print("|---|---|---|---|---|---|")
    sides = [("chainsweep DOP853 + predict_switches", ours_rows)]
    if base_rows:
        sides.append((f"the same, before ({args.base_bin})", base_rows))
    sides.append(("numba + numbalsoda LSODA", peer_rows))
    for name, rows in sides:
        for row in rows.values():
            print(f"| {name} | {row['rtol']:.0e} | {row['max_error']:.1e} | {row['median_error']:.1e} | "
                  f"{row['rhs_evals']:,} | {row['wall_s']:.3f} s |")

    print("\n4. at equal accuracy (the peer's wall at chainsweep's max error):")
    print("| chainsweep rtol | max error | chainsweep wall | peer wall, interpolated | × | peer's cheapest rung as accurate | × |")
    print("|---|---|---|---|---|---|---|")
    ratios = []
    for label, rows in (("", ours_rows), (" (before)", base_rows)):
        for row in rows.values():
            interp, cheapest = time_at(list(peer_rows.values()), row["max_error"])
            row["peer_wall_interpolated_s"], row["peer_wall_cheapest_rung_s"] = interp, cheapest
            row["speedup_interpolated"] = interp / row["wall_s"] if interp else None
            row["speedup_cheapest_rung"] = cheapest / row["wall_s"] if cheapest else None
            f = lambda x: f"{x:.3f} s" if x else "—"  # noqa: E731
            g = lambda x: f"**{x:.1f}×**" if x else "—"  # noqa: E731
            print(f"| {row['rtol']:.0e}{label} | {row['max_error']:.1e} | {row['wall_s']:.3f} s | {f(interp)} | "
                  f"{g(row['speedup_interpolated'])} | {f(cheapest)} | {g(row['speedup_cheapest_rung'])} |")
            if rows is ours_rows and row["speedup_interpolated"]:
                ratios.append(row["speedup_interpolated"])
    if ratios:
        print(f"speed ratio at equal accuracy (interpolated), over chainsweep's rungs the peer's ladder spans: "
              f"{min(ratios):.1f}× … {max(ratios):.1f}×")

    fixed_med = {k: statistics.median(v) for k, v in fixed.items() if v}
    print(f"\n5. the fixed costs (all {n} points run for {fixed_s * 1e6:g} µs, median of {args.repeats}): "
          f"chainsweep {fixed_med['chainsweep']:.3f} s"
          + (f" (before {fixed_med['before']:.3f} s)" if "before" in fixed_med else "")
          + f", the peer {fixed_med['peer']:.3f} s; and the ratio of the runs alone (each side's sweep wall "
          "less its fixed costs, the peer's interpolated at equal accuracy as above):")
    print("| chainsweep rtol | chainsweep runs alone | peer runs alone, interpolated | × |")
    print("|---|---|---|---|")
    # (A rung no slower than the fixed costs has no runs-alone time to interpolate through.)
    peer_alone = [{"max_error": r["max_error"], "wall_s": r["wall_s"] - fixed_med["peer"]}
                  for r in peer_rows.values() if r["wall_s"] > fixed_med["peer"]]
    for label, rows, key in (("", ours_rows, "chainsweep"), (" (before)", base_rows, "before")):
        for row in rows.values():
            alone = row["wall_s"] - fixed_med[key]
            interp, _ = time_at(peer_alone, row["max_error"])
            row["runs_alone_s"] = alone
            speedup = interp / alone if interp and alone > 0 else None
            row["runs_alone_speedup_interpolated"] = speedup
            mine = f"{alone:.3f} s" if alone > 0 else "— (no slower than the fixed costs)"
            print(f"| {row['rtol']:.0e}{label} | {mine} | {f'{interp:.3f} s' if interp else '—'} | "
                  + (f"**{speedup:.1f}×** |" if speedup else "— |"))

    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(json.dumps({
        "date": time.strftime("%Y-%m-%d"),
        "machine": {"cpu": lscpu_model(), "cpus": os.cpu_count(), "load_average": os.getloadavg()},
        "sweep": str(SWEEP.relative_to(REPO)), "points": n, "jobs": JOBS, "repeats": args.repeats,
        "mass_ratio": eps.tolist(), "damping_kg_s": mu.tolist(),
        "reference": {"integrator": REFERENCE, "rhs_evals": ref_nfev, "wall_s": ref_wall, "f21_over_f4": ref.tolist(),
                      "peer_check": {"rtol": PEER_CHECK_RTOL, "max_error": e_chk[0], "median_error": e_chk[1],
                                     "f4_max_error": e_f4[0], "f21_max_error": e_f21[0],
                                     "rhs_evals": chk_nfev, "wall_s": chk_wall}},
        "rhs_check_max_relative_difference": worst,
        "peer": {"numba": numba.__version__, "numbalsoda": version("numbalsoda"), "import_s": t_import,
                 "jit_s": t_jit, "chunk_us": args.chunk_us, "ladder": list(peer_rows.values())},
        "fixed_costs": {"duration_s": fixed_s, "rtol": FIXED_RTOL, "walls_s": fixed, "median_s": fixed_med},
        "chainsweep": {"ladder": list(ours_rows.values())},
        "chainsweep_before": ({"binary": str(args.base_bin), "ladder": list(base_rows.values())}
                              if base_rows else None),
    }, indent=1))
    print(f"\nwritten: {args.output}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
