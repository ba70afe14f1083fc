"""The paper's sweeps stay exactly as they are: every grid point of every sweep file keeps its run
hash, and selected points of each give bitwise the same results (peaks, peak times, energy drift,
step counts, warnings) as the engine that produced the baseline.

The baseline (`baselines/paper_identity.json`) holds the run-hash prefixes `run --dry-run` lists
for every point (space-separated, in grid order), and the full `point` output (run hash and results) of the selected points. A
change that is MEANT to change the paper's numbers (an integrator change, with a bump of the
runner's NUMERICS_VERSION) re-captures it, after checking the differences:

    python tests/test_paper_identity.py --capture
"""

import json
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from conftest import REPO, run  # noqa: E402

BASELINE = Path(__file__).resolve().parent / "baselines" / "paper_identity.json"

# Points run in full (all but the longest runs of each paper and stress sweep; ~1 s in all).
SELECTED = {
    "sweeps/fig08.json": [0, 1, 100, 181],
    "sweeps/fig08-literal.json": [0, 181],
    "sweeps/fig08-choices.json": [0, 183],
    "sweeps/fig08-light.json": [0, 91],
    "sweeps/fig15.json": [0, 9],
    "sweeps/fig16.json": [0],
    "sweeps/fig17.json": [9],
    "sweeps/fig18.json": [0, 7],
    "sweeps/fig19.json": [7],
    "sweeps/critical-damping.json": [0, 179],
    "sweeps/text-098.json": [0, 1, 2],
    "sweeps/text-098-variants.json": [0, 7],
    "sweeps/text-055.json": [0, 1, 2],
    "sweeps/preload.json": [0, 1, 2, 3],
    "sweeps/fig07.json": [0],
    "sweeps/fig14.json": [3],
    "sweeps/mass-damping.json": [0, 199],
    "sweeps/mass-damping-histories.json": [5],
    "sweeps/velocity-zip.json": [11],
    "sweeps/stress/damping-1000.json": [0, 1],
    "sweeps/stress/damping-10000.json": [0],
    "sweeps/stress/mass-ratio-0.01.json": [0],
    "sweeps/stress/fast-striker.json": [0],
    "sweeps/stress/slow-striker.json": [0],
    "sweeps/stress/gaps-undamped-long.json": [0],
    "sweeps/stress/wall-reflections-10ms.json": [0],
    "sweeps/stress/long-chain-2000.json": [0],
    "sweeps/stress/work-precision/fig15.json": [0],
    "sweeps/stress/work-precision/stiff-1000.json": [0],
}


def sweep_files():
    """Every sweep file of the paper and the stress set, but those whose integrator is `auto`
    (their hashes hold the pilot's choice, which the auto tests cover)."""
    files = [*REPO.glob("sweeps/*.json"), *REPO.glob("sweeps/stress/*.json"),
             *REPO.glob("sweeps/stress/work-precision/*.json")]
    return sorted(p.relative_to(REPO).as_posix() for p in files if '"auto"' not in p.read_text())


def dry_run_hashes(sweep):
    r = run("run", sweep, "--dry-run", cwd=REPO)
    assert r.returncode == 0, r.stderr
    listing = r.stdout.split("points (flat index, axis values, run hash):")[1]
    return [line.split()[-1] for line in listing.strip().splitlines()]


def point(sweep, index):
    r = run("point", sweep, index, cwd=REPO)
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)
    return {"sweep": sweep, "index": index, "run_hash": d["run_hash"], "result": d["result"]}


def capture():
    hashes = {s: " ".join(dry_run_hashes(s)) for s in sweep_files()}
    points = [point(s, i) for s, idx in SELECTED.items() for i in idx]
    BASELINE.write_text(json.dumps({"hashes": hashes, "points": points}, indent=1, sort_keys=True) + "\n")


@pytest.fixture(scope="module")
def baseline():
    return json.loads(BASELINE.read_text())


def test_every_paper_sweep_is_in_the_baseline(baseline):
    assert sorted(baseline["hashes"]) == sweep_files()


@pytest.mark.parametrize("sweep", sweep_files())
def test_run_hashes_unchanged(binary, baseline, sweep):
    assert dry_run_hashes(sweep) == baseline["hashes"][sweep].split()


@pytest.mark.parametrize(
    "sweep,index", [(s, i) for s, idx in SELECTED.items() for i in idx], ids=lambda x: str(x)
)
def test_results_bitwise_unchanged(binary, baseline, sweep, index):
    want = next(p for p in baseline["points"] if p["sweep"] == sweep and p["index"] == index)
    got = point(sweep, index)
    assert got["run_hash"] == want["run_hash"]
    # JSON numbers are printed with the shortest representation that round-trips, so equal text
    # is equal bits.
    assert json.dumps(got["result"], sort_keys=True) == json.dumps(want["result"], sort_keys=True)


if __name__ == "__main__":
    if sys.argv[1:] != ["--capture"]:
        sys.exit(__doc__)
    capture()
