"""What a step of the Fig. 8 sweep costs per particle and what it costs whatever the particles
(docs/PERFORMANCE.md), in instructions counted by valgrind's callgrind: repeatable for the same
binary and inputs whatever else the machine is doing, unlike seconds on a shared machine.

Five variants of `sweeps/fig08.json` at DOP853 RTOL with `predict_switches` (the peer table's
setting at rtol 1e-8), each run once, `--jobs 1`, under callgrind:

- `moving part, 50`: the sweep as shipped (only the moving part of each chain is integrated);
- `moving part, 70`: 70 cylinders instead of 50 (the pulse never reaches the 20 more: what a
  particle at rest beyond the moving part costs);
- `whole chain, 50` and `whole chain, 70`: `active_region: off`, every particle integrated at
  every step. The steps are the same to a percent (the pulse and its switches are), so the
  difference is the cost of 40 particles over the same steps: the cost per particle, and from it
  the part of every attempt that does not depend on how many particles the step carries;
- `fixed`: every run integrated for 0.1 us only, the process, the scenes and the output file.

Printed: each variant's instructions, attempts (accepted + rejected steps) and right-hand sides;
the cost per particle per attempt; the attempts' cost that no particle count changes, per
attempt; the mean number of particles the moving part carries, as its instructions give it; and,
for the sweep as shipped, the inclusive share of the run observer (the probes' samples and the
energy ledger) and of the right-hand side.

    python scripts/cost_per_particle.py [RTOL]

Needs valgrind (`apt-get install valgrind`) and the release binary (`make bin`); about 3 minutes.
"""

import copy
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import h5py

REPO = Path(__file__).resolve().parent.parent
TARGET = Path(os.environ.get("CARGO_TARGET_DIR", REPO / "target"))
BIN = Path(os.environ.get("CHAINSWEEP_BIN", TARGET / "release" / "chainsweep"))
RTOL = float(sys.argv[1]) if len(sys.argv) > 1 else 1e-8
SHORT_S = 1e-7
MORE_CYLINDERS = 20


def variants(base):
    """(name, sweep) for every variant measured."""
    base = copy.deepcopy(base)
    base["base"]["integrator"] = {"method": "dop853", "rtol": RTOL, "predict_switches": True}

    def edit(cylinders=None, whole=False, short=False):
        s = copy.deepcopy(base)
        if cylinders is not None:
            s["base"]["chain"]["cylinders"] = cylinders
        if whole:
            s["base"]["active_region"] = "off"
        if short:
            s["base"]["duration_s"] = SHORT_S
        return s

    n = base["base"]["chain"]["cylinders"]
    m = n + MORE_CYLINDERS
    return n, m, [
        (f"moving part, {n}", edit()),
        (f"moving part, {m}", edit(cylinders=m)),
        (f"whole chain, {n}", edit(whole=True)),
        (f"whole chain, {m}", edit(cylinders=m, whole=True)),
        ("fixed", edit(short=True)),
    ]


def measure(work, name, sweep):
    """Instructions, attempts, right-hand sides, and the callgrind output file of one variant."""
    tag = re.sub(r"[^a-z0-9]+", "-", name)
    path = work / f"{tag}.json"
    path.write_text(json.dumps(sweep))
    out = work / f"{tag}.h5"
    profile = work / f"{tag}.callgrind"
    run = subprocess.run(
        [
            "valgrind",
            "--tool=callgrind",
            f"--callgrind-out-file={profile}",
            str(BIN),
            "run",
            str(path),
            "--jobs",
            "1",
            "-q",
            "-o",
            str(out),
        ],
        capture_output=True,
        text=True,
        check=True,
    )
    found = re.search(r"Collected : (\d+)", run.stderr)
    if not found:
        sys.exit(f"{name}: no instruction count in valgrind's output:\n{run.stderr}")
    with h5py.File(out, "r") as f:
        attempts = int(f["steps"][...].sum() + f["rejected_steps"][...].sum())
        rhs = int(f["rhs_evals"][...].sum())
    return int(found.group(1)), attempts, rhs, profile


def inclusive_share(profile, patterns):
    """The largest inclusive share of the functions whose names match each pattern."""
    text = subprocess.run(
        ["callgrind_annotate", "--inclusive=yes", str(profile)],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    total = None
    shares = {}
    for line in text.splitlines():
        m = re.match(r"\s*([\d,]+)\s+(?:\([^)]*\)\s+)?(.*)$", line)
        if not m:
            continue
        count, what = int(m.group(1).replace(",", "")), m.group(2)
        if "PROGRAM TOTALS" in what:
            total = count
            continue
        for label, pattern in patterns.items():
            if re.search(pattern, what):
                shares[label] = max(shares.get(label, 0), count)
    return {k: v / total for k, v in shares.items()} if total else {}


def main():
    if not shutil.which("valgrind"):
        sys.exit("needs valgrind (apt-get install valgrind)")
    if not BIN.is_file():
        sys.exit(f"no binary at {BIN}: run `make bin` first (or set CHAINSWEEP_BIN)")
    base = json.loads((REPO / "sweeps" / "fig08.json").read_text())
    n, m, runs = variants(base)
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        got = {}
        for name, sweep in runs:
            got[name] = measure(work, name, sweep)
            ins, att, rhs, _ = got[name]
            print(f"{name:18s} {ins / 1e6:9.1f} M instructions  {att:7d} attempts  {rhs:8d} RHS")
        shares = inclusive_share(
            got[f"moving part, {n}"][3],
            {
                "run observer (probes' samples, ledger)": r"RunObserver as \S*StepObserver>::on_step(\s|$)",
                "right-hand side": r"ChainSystem<\S*> as \S*OdeSystem>::rhs(\s|$)",
            },
        )
    particles = lambda cylinders: 2 * cylinders + 2  # noqa: E731 (striker, cylinders, spheres)
    i_wn, a_wn, _, _ = got[f"whole chain, {n}"]
    i_wm, a_wm, _, _ = got[f"whole chain, {m}"]
    i_mp, a_mp, _, _ = got[f"moving part, {n}"]
    i_mm, _, _, _ = got[f"moving part, {m}"]
    fixed = got["fixed"][0]
    attempts = (a_wn + a_wm) / 2
    per_particle = (i_wm - i_wn) / (particles(m) - particles(n)) / attempts
    independent = (i_wn - fixed) / a_wn - per_particle * particles(n)
    carried = ((i_mp - fixed) / a_mp - independent) / per_particle
    print()
    print(f"per particle per attempt:            {per_particle:8.0f} instructions")
    print(f"per attempt, whatever the particles: {independent:8.0f} instructions")
    print(f"fixed (process, scenes, file):       {fixed / 1e6:8.1f} M instructions")
    print(
        f"the sweep as shipped: {100 * fixed / i_mp:.0f} % fixed, "
        f"{100 * independent * a_mp / i_mp:.0f} % per attempt whatever the particles, "
        f"{100 * per_particle * carried * a_mp / i_mp:.0f} % per particle; "
        f"its moving part carries {carried:.1f} particles on average"
    )
    print(
        f"{MORE_CYLINDERS} more cylinders at rest beyond it: "
        f"{100 * (i_mm - i_mp) / i_mp:+.2f} % instructions"
    )
    for label, share in shares.items():
        print(f"inclusive share, {label}: {100 * share:.1f} %")


if __name__ == "__main__":
    main()
