"""Two `chainsweep` binaries side by side, alternating ROUNDS times: one-point sweeps of the
reference scene (0.55 chain, mu = 6 kg/s, 1.3 m/s, 1 ms, DOP853 rtol 1e-9) with 50, 1 000 and
5 000 cylinders (the run's own wall time, `wall_time_s`), and the wall time of the Fig. 8 sweep
(`run sweeps/fig08.json --jobs 2`); medians. No build needed: give two built binaries. Each side
runs its own Fig. 8 sweep file: AFTER the working tree's, BEFORE the file at the git revision
BEFORE_REV it was built from (default the tag before-switch-prediction, the build before switch
prediction and the moving part), which its binary understands.

    [BEFORE_REV=REV] python scripts/bench_scaling.py BEFORE_BIN AFTER_BIN [ROUNDS] [nofig8]
"""
import json, os, subprocess, time, statistics, shutil, sys, tempfile, h5py
from pathlib import Path
REPO = Path(__file__).resolve().parent.parent
BIN = {"before": sys.argv[1], "after": sys.argv[2]}
ROUNDS = int(sys.argv[3]) if len(sys.argv) > 3 else 5
here = Path(tempfile.mkdtemp(prefix="chainsweep-scaling-"))
BEFORE_REV = os.environ.get("BEFORE_REV", "before-switch-prediction")
FIG8 = {"before": here / "fig08-before.json", "after": REPO / "sweeps" / "fig08.json"}
FIG8["before"].write_bytes(subprocess.run(["git", "show", f"{BEFORE_REV}:sweeps/fig08.json"], cwd=REPO,
                                           check=True, capture_output=True).stdout)
def scene(n):
    return {"description": "scaling", "base": {"chain": {"preset": "chain_055", "cylinders": n},
        "physics": {"gravity": True, "damping_kg_s": 6.0, "wall": True}, "striker_velocity_m_s": 1.3,
        "duration_s": 0.001, "integrator": {"method": "dop853", "rtol": 1e-9}},
        "record": {"probes": [{"kind": "gauge_force", "cylinder": 4}, {"kind": "gauge_force", "cylinder": 21}]},
        "axes": [{"field": "duration_s", "values": [0.001]}]}
res = {}
for r in range(ROUNDS):
    for side, b in BIN.items():
        for n in (50, 1000, 5000):
            p = here / f"s{n}.json"; p.write_text(json.dumps(scene(n)))
            out = here / f"{side}-{n}.h5"; shutil.rmtree(str(out) + ".d", ignore_errors=True); out.unlink(missing_ok=True)
            subprocess.run([b, "run", str(p), "-o", str(out), "--quiet"], check=True)
            with h5py.File(out) as f:
                res.setdefault((side, f"{n} cylinders, 1 ms (run wall)"), []).append(float(f["wall_time_s"][0]))
                res.setdefault((side, f"{n} peak F21"), []).append(float(f["leading_peak"][0][1]))
        if len(sys.argv) > 4: continue
        out = here / f"{side}-f8.h5"; shutil.rmtree(str(out) + ".d", ignore_errors=True); out.unlink(missing_ok=True)
        t = time.perf_counter()
        subprocess.run([b, "run", str(FIG8[side]), "-o", str(out), "--jobs", "2", "--quiet"], check=True)
        res.setdefault((side, "Fig. 8 sweep, 182 runs, --jobs 2 (wall)"), []).append(time.perf_counter() - t)
        with h5py.File(out) as f:
            res.setdefault((side, "Fig. 8: sum of run walls"), []).append(float(f["wall_time_s"][...].sum()))
        # Like with like: the after binary on BEFORE_REV's sweep file too (its integrator settings).
        if side == "after":
            out = here / "after-f8-old.h5"; shutil.rmtree(str(out) + ".d", ignore_errors=True); out.unlink(missing_ok=True)
            t = time.perf_counter()
            subprocess.run([b, "run", str(FIG8["before"]), "-o", str(out), "--jobs", "2", "--quiet"], check=True)
            old_wall = time.perf_counter() - t
        else:
            old_wall = res[(side, "Fig. 8 sweep, 182 runs, --jobs 2 (wall)")][-1]
        res.setdefault((side, f"Fig. 8 sweep file of {BEFORE_REV} in both (wall)"), []).append(old_wall)
keys = []
for (s, k) in res:
    if k not in keys: keys.append(k)
print(f"medians of {ROUNDS} alternating rounds; before = {BIN['before']}, after = {BIN['after']}")
print(f"| what | before ({BEFORE_REV}) | after | after/before |\n|---|---|---|---|")
for k in keys:
    b, a = statistics.median(res[("before", k)]), statistics.median(res[("after", k)])
    print(f"| {k} | {b:.4g} | {a:.4g} | {a/b:.3f} |")
shutil.rmtree(here, ignore_errors=True)
