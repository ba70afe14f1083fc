"""What a `chainsweep.run` call costs beyond its run (`make bench`).

The reference run of `bench_scipy.py` (the 0.55 chain, 50 cylinders, μ = 6 kg/s, 1 ms, DOP853 rtol
5e-8 with `predict_switches`) called CALLS times through `chainsweep.run(scene, as_dataset=False)`,
each call timed around it and set against the run's own `wall_time_s`; medians:

- back to back, as in a loop of calls;
- churned: each call after about 2 ms of numpy work that makes and frees 2 000 small arrays and
  sweeps a 16 MB one, as a script's own computation between calls does to the caches and the heap.

`--base-ext DIR` alternates, ROUNDS times, with another build of the package: DIR holds its
`chainsweep/` (a copy of `.venv/lib/python3.*/site-packages/chainsweep` as it was installed), run in a
process of its own with DIR first on the path.

    python scripts/bench_call.py [--calls 300] [--rounds 4] [--base-ext DIR]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent


def measure(calls: int) -> dict[str, tuple[float, float]]:
    """(median call, median over the run) in seconds, back to back and churned."""
    import numpy as np

    import chainsweep

    sys.path.insert(0, str(HERE))
    from bench_scipy import BENCHMARKED, scene

    s = scene(BENCHMARKED)
    rng = np.random.default_rng(0)

    def churn() -> float:
        small = [rng.random(200) * 2.0 for _ in range(2000)]
        big = rng.random(2_000_000)
        return float(big.sum()) + sum(float(x[0]) for x in small)

    out = {}
    for name, between in (("back to back", None), ("churned", churn)):
        walls, over = [], []
        for _ in range(calls):
            if between is not None:
                between()
            start = time.perf_counter()
            r = chainsweep.run(s, as_dataset=False)
            wall = time.perf_counter() - start
            walls.append(wall)
            over.append(wall - float(r["wall_time_s"]))
        out[name] = (statistics.median(walls), statistics.median(over))
    return out


def child(calls: int, path: str | None) -> dict[str, tuple[float, float]]:
    env = dict(os.environ)
    if path:
        env["PYTHONPATH"] = os.pathsep.join(filter(None, [path, env.get("PYTHONPATH")]))
    r = subprocess.run(
        [sys.executable, __file__, "--child", "--calls", str(calls)],
        env=env, capture_output=True, text=True, check=True,
    )
    return {k: tuple(v) for k, v in json.loads(r.stdout.strip().splitlines()[-1]).items()}


def show(label: str, m: dict[str, tuple[float, float]]) -> str:
    parts = []
    for name, (wall, over) in m.items():
        run = wall - over
        parts.append(f"{name} {wall * 1e3:.3f} ms against {run * 1e3:.3f} ms: {wall / run:.3f}× "
                     f"({over * 1e6:.0f} µs over)")
    return f"{label}: " + "; ".join(parts)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--calls", type=int, default=300)
    ap.add_argument("--rounds", type=int, default=4)
    ap.add_argument("--base-ext", help="a directory holding another build's chainsweep/ package")
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        print(json.dumps(measure(args.calls)))
        return 0
    if args.base_ext and not (Path(args.base_ext) / "chainsweep" / "__init__.py").is_file():
        print(f"--base-ext: {args.base_ext} holds no chainsweep/ package", file=sys.stderr)
        return 2
    for r in range(args.rounds if args.base_ext else 1):
        if args.base_ext:
            print(show(f"round {r + 1}, before", child(args.calls, args.base_ext)), flush=True)
        print(show(f"round {r + 1}, this build", child(args.calls, None)), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
