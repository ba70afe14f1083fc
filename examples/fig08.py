"""Fig. 8 from Python: F21/F4 against the mass ratio ε at μ = 0 and 6 kg/s, on a coarse grid run
with chainsweep.sweep and read back with chainsweep.open.

The sweep is sweeps/fig08.json (50 cylinders, heavy cylinders m_c = m_s/ε, leading-pulse peaks,
gravity on, 1.3 m/s) with ε every 0.05 instead of every 0.01, so that it runs in about a second.
Running the script again resumes the sweep: it runs nothing and only draws.

    python examples/fig08.py                      # -> results/fig08-python.h5, .png (here)
    python examples/fig08.py --output-dir /tmp/x  # elsewhere
    python -m chainsweep.example_scripts.fig08    # the copy installed with the package
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import chainsweep  # noqa: E402


def minimum(x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """The minimum of y(x): the vertex of the parabola through the smallest sample and its
    neighbours (the sample itself at an end of the grid)."""
    i = int(np.nanargmin(y))
    if i == 0 or i == len(y) - 1:
        return float(x[i]), float(y[i])
    a, b, c = np.polyfit(x[i - 1 : i + 2], y[i - 1 : i + 2], 2)
    xm = -b / (2 * a)
    return float(xm), float(np.polyval([a, b, c], xm))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--output-dir", type=Path, default=Path("results"),
                        help="where the file and the figure go (default: results/ here)")
    parser.add_argument("--step", type=float, default=0.05, help="mass-ratio step (default 0.05)")
    args = parser.parse_args()
    args.output_dir.mkdir(parents=True, exist_ok=True)

    # The sweep file installed with the package (the repository's sweeps/fig08.json).
    spec = json.loads(chainsweep.example_path("fig08").read_text())
    spec["axes"][0]["range"] = {"start": 0.1, "stop": 1.0, "step": args.step}
    result = chainsweep.sweep(spec, args.output_dir / "fig08-python.h5", progress=False)
    print(f"sweep: {result.n_ok} runs ok, {result.n_failed} failed, {result.ran} run now "
          f"-> {result.path}")

    ds = chainsweep.open(result)
    peak = ds.leading_peak
    ratio = peak.sel(probe="gauge_force_cyl21") / peak.sel(probe="gauge_force_cyl4")

    fig, ax = plt.subplots(figsize=(6.4, 4.6))
    for mu, color in zip(ds.damping_kg_s.values, ["black", "tab:red"]):
        curve = ratio.sel(damping_kg_s=mu)
        eps = curve.mass_ratio.values
        xm, ym = minimum(eps, curve.values)
        label = f"μ = {mu:g} kg/s" if mu else "μ = 0"
        print(f"{label}: smallest F21/F4 = {ym:.3f} at ε = {xm:.3f}")
        ax.plot(eps, curve.values, "-o", ms=3, color=color, label=f"{label} (min at ε = {xm:.2f})")
        ax.plot([xm], [ym], "v", color=color, ms=8)
    ax.set_xlabel(f"mass ratio ε = m_s / m_c ({ds.mass_ratio.attrs['units']})")
    ax.set_ylabel("F$_{21}$ / F$_4$")
    ax.set_title("Fig. 8 (coarse grid, chainsweep.sweep + chainsweep.open)", fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    png = args.output_dir / "fig08-python.png"
    fig.savefig(png, dpi=110)
    print(f"figure: {png}")


if __name__ == "__main__":
    main()
