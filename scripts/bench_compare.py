"""Side-by-side benchmark of the solver before and after a change, in one run (`make bench`).

Builds the criterion bench `crates/solver/benches/solver.rs` at a base revision (default: main) in
a temporary git worktree and at the working tree, then runs the two binaries alternately, ROUNDS
times each, on the benchmarks they share (the paper's right-hand side per contact and the
reference run), so that both see the same machine load; reports the median over rounds of
criterion's point estimates, and the ratio after/before. The benchmarks only the working tree has
(the general kernel under each contact law and dissipation model) are run in the same rounds.

In the same rounds: the scaling bench `crates/solver/benches/scaling.rs` (the reference scene with
50, 1 000 and 5 000 cylinders; it uses only the solver's long-standing interface, so the working
tree's file is built at the base too when the base has none), and the wall time of the Fig. 8
sweep (`chainsweep run sweeps/fig08.json --jobs 2`) with each side's `chainsweep` binary and each
side's own sweep file: the sweep as each tree ships it (the base's binary may not know an integrator
option the working tree's file uses, such as `predict_switches`).

    python scripts/bench_compare.py [--base REV] [--rounds N] [--measurement-time S]
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
UNITS = {"ps": 1e-3, "ns": 1.0, "µs": 1e3, "us": 1e3, "ms": 1e6, "s": 1e9}
TIME = re.compile(r"^(?:(\S+)\s+)?time:\s+\[\S+ \S+ (\S+) (\S+) \S+ \S+\]")
THRPT = re.compile(r"^thrpt:\s+\[\S+ \S+ (\S+) (\S*)elem/s")
PREFIX = {"": 1.0, "K": 1e3, "M": 1e6, "G": 1e9}


def bench_executable(root: Path, target_dir: Path, bench: str = "solver") -> Path:
    """Builds the solver bench `bench` at `root` into `target_dir` and returns the executable's path."""
    env = dict(os.environ, CARGO_TARGET_DIR=str(target_dir))
    # The benches need the solver's `bench` feature (criterion), where the tree has one: earlier
    # revisions had criterion as a dev-dependency and no such feature.
    manifest = (root / "crates/solver/Cargo.toml").read_text()
    features = ["--features", "bench"] if re.search(r"^bench = ", manifest, re.M) else []
    out = subprocess.run(
        ["cargo", "bench", "-p", "chainsweep-solver", *features, "--bench", bench, "--no-run",
         "--message-format=json"],
        cwd=root, env=env, check=True, stdout=subprocess.PIPE, text=True,
    ).stdout
    for line in out.splitlines():
        msg = json.loads(line)
        if msg.get("reason") == "compiler-artifact" and msg.get("executable") and msg["target"]["name"] == bench:
            return Path(msg["executable"])
    raise RuntimeError(f"no bench executable built at {root}")


def with_scaling_bench(root: Path) -> None:
    """Gives the tree at `root` the working tree's scaling bench when it has none."""
    bench = root / "crates/solver/benches/scaling.rs"
    if bench.exists():
        return
    shutil.copy(REPO / "crates/solver/benches/scaling.rs", bench)
    manifest = root / "crates/solver/Cargo.toml"
    manifest.write_text(manifest.read_text() + '\n[[bench]]\nname = "scaling"\nharness = false\n')


def runner_executable(root: Path, target_dir: Path) -> Path:
    """Builds the `chainsweep` binary at `root` into `target_dir` and returns its path."""
    env = dict(os.environ, CARGO_TARGET_DIR=str(target_dir))
    # The binary is the command line's crate's (crates/cli), or in earlier trees the engine's.
    package = "chainsweep-cli" if (root / "crates" / "cli" / "Cargo.toml").exists() else "chainsweep"
    subprocess.run(["cargo", "build", "--release", "-p", package, "--bin", "chainsweep"], cwd=root, env=env,
                   check=True)
    return target_dir / "release" / "chainsweep"


def sweep_wall_s(exe: Path, sweep: Path, out_dir: Path) -> float:
    """Wall time of `chainsweep run SWEEP --jobs 2` into a fresh output file, s."""
    out_dir.mkdir(parents=True, exist_ok=True)
    output = Path(tempfile.mkdtemp(dir=out_dir)) / "out.h5"
    start = time.perf_counter()
    subprocess.run([str(exe), "run", str(sweep), "-o", str(output), "--jobs", "2"], check=True,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    wall = time.perf_counter() - start
    shutil.rmtree(output.parent, ignore_errors=True)
    return wall


def run_once(exe: Path, home: Path, filter_: str, measurement_s: float) -> dict[str, float]:
    """One criterion run; returns {benchmark: point estimate in ns}, and for benchmarks with a
    throughput (the right-hand sides, in contacts) {benchmark + "/per element": ns per contact}."""
    env = dict(os.environ, CRITERION_HOME=str(home))
    out = subprocess.run(
        [str(exe), "--bench", filter_, "--warm-up-time", "1", "--measurement-time", str(measurement_s), "--noplot"],
        env=env, check=True, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
    ).stdout
    times, name = {}, None
    for line in out.splitlines():
        m = TIME.match(line.strip())
        if m:
            name = m.group(1) or name
            times[name] = float(m.group(2)) * UNITS[m.group(3)]
            continue
        m = THRPT.match(line.strip())
        if m and name:
            times[name + "/per element"] = 1e9 / (float(m.group(1)) * PREFIX[m.group(2)])
        elif line and not line[0].isspace() and "/" in line.split()[0]:
            name = line.split()[0]
    return times


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--base", default=os.environ.get("BENCH_BASE", "main"), help="revision before the change")
    ap.add_argument("--rounds", type=int, default=int(os.environ.get("BENCH_ROUNDS", "5")))
    ap.add_argument("--measurement-time", type=float, default=3.0, help="criterion seconds per benchmark")
    ap.add_argument("--base-target-dir", type=Path, help="cargo target directory of the base (default: target/bench-base)")
    ap.add_argument("--parts", default="solver,scaling,sweep",
                    help="comma-separated: solver (rhs, run, general_rhs), scaling, sweep (Fig. 8 wall time)")
    args = ap.parse_args()
    parts = set(args.parts.split(","))

    rev = subprocess.run(["git", "rev-parse", "--short", args.base], cwd=REPO, check=True, stdout=subprocess.PIPE,
                         text=True).stdout.strip()
    tmp = Path(tempfile.mkdtemp(prefix="chainsweep-bench-"))
    base_tree = tmp / "base"
    subprocess.run(["git", "worktree", "add", "--detach", "--quiet", str(base_tree), rev], cwd=REPO, check=True)
    try:
        print(f"building the bench at {args.base} ({rev}) and at the working tree …", flush=True)
        head_target = Path(os.environ.get("CARGO_TARGET_DIR", REPO / "target"))
        # The base's build is kept (target/bench-base) so that the next comparison is incremental.
        base_target = args.base_target_dir or head_target / "bench-base"
        if "solver" in parts:
            base_exe = bench_executable(base_tree, base_target)
            head_exe = bench_executable(REPO, head_target)
        if "scaling" in parts:
            with_scaling_bench(base_tree)
            scaling = {"before": bench_executable(base_tree, base_target, "scaling"),
                       "after": bench_executable(REPO, head_target, "scaling")}
        if "sweep" in parts:
            runner = {"before": runner_executable(base_tree, base_target),
                      "after": runner_executable(REPO, head_target)}
        fig08 = {"before": base_tree / "sweeps" / "fig08.json", "after": REPO / "sweeps" / "fig08.json"}
        shared = "^(rhs|run)/"
        samples: dict[str, dict[str, list[float]]] = {"before": {}, "after": {}}
        for r in range(args.rounds):
            print(f"round {r + 1}/{args.rounds}", flush=True)
            for side, filt in (("before", shared), ("after", ".")):
                if "solver" in parts:
                    exe = base_exe if side == "before" else head_exe
                    for k, v in run_once(exe, tmp / f"criterion-{side}", filt, args.measurement_time).items():
                        samples[side].setdefault(k, []).append(v)
                if "scaling" in parts:
                    for k, v in run_once(scaling[side], tmp / f"criterion-{side}", ".", args.measurement_time).items():
                        samples[side].setdefault(k, []).append(v)
                if "sweep" in parts:
                    wall = sweep_wall_s(runner[side], fig08[side], tmp / f"sweeps-{side}")
                    samples[side].setdefault("sweep/fig08_182_runs_jobs2", []).append(wall * 1e9)
    finally:
        subprocess.run(["git", "worktree", "remove", "--force", str(base_tree)], cwd=REPO, check=False)
        shutil.rmtree(tmp, ignore_errors=True)

    med = {side: {k: statistics.median(v) for k, v in s.items()} for side, s in samples.items()}
    per = "/per element"
    print(f"\nmedians of {args.rounds} alternating rounds; before = {args.base} ({rev}), after = working tree")
    print("| benchmark | before | after | after/before |\n|---|---|---|---|")
    for k in sorted(x for x in med["before"] if not x.endswith(per)):
        key, fmt = (k + per, "{:.3f} ns/contact") if k + per in med["before"] else (k, "{:.0f} ns")
        if k.startswith(("run/", "scaling/", "sweep/")):
            fmt, scale = "{:.3f} ms", 1e-6
        else:
            scale = 1.0
        b, a = med["before"][key], med["after"].get(key, float("nan"))
        print(f"| {k} | {fmt.format(b * scale)} | {fmt.format(a * scale)} | {a / b:.3f} |")
    # Runs only the working tree has (the reference run under other settings), against the base's
    # reference run: the same scene and accuracy target.
    ref_run = "run/chain055_50cyl_mu6_1ms"
    extra = sorted(k for k in med["after"] if k.startswith("run/") and k not in med["before"])
    if extra and ref_run in med["before"]:
        print(f"\n| working tree only | after | vs before's {ref_run} |\n|---|---|---|")
        for k in extra:
            a = med["after"][k]
            print(f"| {k} | {a * 1e-6:.3f} ms | {a / med['before'][ref_run]:.3f} |")
    print("\n| general kernel (working tree) | RHS cost | vs the paper's kernel (rhs/full_physics) |\n|---|---|---|")
    ref = med["after"].get("rhs/full_physics" + per, float("nan"))
    for k in sorted(x for x in med["after"] if x.startswith("general_rhs/") and x.endswith(per)):
        t = med["after"][k]
        print(f"| {k.removeprefix('general_rhs/').removesuffix(per)} | {t:.3f} ns/contact | {t / ref:.2f}× |")
    small = med["after"].get("scaling/chain055_50cyl_mu6_1ms")
    for n in (1000, 5000):
        big = med["after"].get(f"scaling/chain055_{n}cyl_mu6_1ms")
        if small and big:
            print(f"{n} cylinders cost {big / small:.2f}× the 50-cylinder run (working tree)")
    spread = max(
        (max(v) / min(v) for s in samples.values() for v in s.values() if min(v) > 0), default=1.0
    )
    print(f"\nlargest max/min spread of one benchmark over the rounds: {spread:.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
