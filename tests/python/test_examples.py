"""The examples (examples/*.py) run as a user runs them, and say what the paper's figures say."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

from scenes import REPO

NUMBER = r"([-+0-9.e]+)"


def example(name: str, *args: str) -> str:
    r = subprocess.run(
        [sys.executable, str(REPO / "examples" / name), *args],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert r.returncode == 0, r.stderr
    return r.stdout


def test_critical_damping_with_brentq():
    out = example("critical_damping.py")
    at = {}
    for mu, a098, a055 in re.findall(
        rf"A21/A4 at μ = {NUMBER} kg/s: 0.98 chain {NUMBER}, 0.55 chain {NUMBER}", out
    ):
        at[float(mu)] = (float(a098), float(a055))
    # below the critical damping the 0.55 chain attenuates more, above it the 0.98 chain
    assert at[5.0][0] > at[5.0][1] and at[15.0][0] < at[15.0][1]
    m = re.search(
        rf"critical damping: μ = {NUMBER} kg/s \(A21/A4 = {NUMBER} for the 0.98 chain, "
        rf"{NUMBER} for the 0.55 chain\)",
        out,
    )
    assert m, out
    mu, a098, a055 = map(float, m.groups())
    # results/REPRODUCTION.md: 9.72 kg/s at 1.3 m/s (the sweep's 0.25 kg/s grid, interpolated)
    assert 9.6 < mu < 9.85
    assert abs(a098 - a055) < 5e-4 and 0.45 < a098 < 0.55


def test_fig08_from_sweep_and_open(tmp_path):
    out = example("fig08.py", "--output-dir", str(tmp_path))
    assert "sweep: 38 runs ok, 0 failed, 38 run now" in out
    minima = {
        float(mu or 0): (float(value), float(eps))
        for mu, value, eps in re.findall(
            rf"μ = (?:{NUMBER} kg/s|0): smallest F21/F4 = {NUMBER} at ε = {NUMBER}", out
        )
    }
    # Fig. 8 (results/REPRODUCTION.md, on the fine grid): minima 0.592 at ε = 0.555 (μ = 0) and
    # 0.506 at ε = 0.596 (μ = 6); damping lowers the curve and moves its minimum to heavier ε
    assert set(minima) == {0.0, 6.0}
    assert abs(minima[0.0][0] - 0.592) < 0.01 and abs(minima[0.0][1] - 0.555) < 0.03
    assert abs(minima[6.0][0] - 0.506) < 0.01 and abs(minima[6.0][1] - 0.596) < 0.03
    png = tmp_path / "fig08-python.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10_000
    # running it again resumes the sweep: nothing is run, the same figure is drawn
    again = example("fig08.py", "--output-dir", str(tmp_path))
    assert "38 runs ok, 0 failed, 0 run now" in again
    assert again.split("\n", 1)[1] == out.split("\n", 1)[1]


def test_the_installed_scripts_run_anywhere_and_find_their_sweeps_in_the_package(tmp_path):
    """The package carries the example scripts: run as modules from an empty folder (no source
    tree), they find their sweep files through chainsweep.example_path and write into the folder
    they run in."""
    import chainsweep.example_scripts as scripts

    assert sorted(p.name for p in Path(scripts.__file__).parent.glob("*.py") if p.name != "__init__.py") == sorted(
        p.name for p in (REPO / "examples").glob("*.py")
    )
    r = subprocess.run(
        [sys.executable, "-m", "chainsweep.example_scripts.fig08"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert r.returncode == 0, r.stderr
    assert "sweep: 38 runs ok, 0 failed, 38 run now" in r.stdout
    assert (tmp_path / "results" / "fig08-python.png").stat().st_size > 10_000
