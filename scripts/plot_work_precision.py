#!/usr/bin/env python3
"""Work-precision diagrams from `chainsweep accuracy` files (SciML style): error against wall
time, log-log, one line per method; panels for the leading-peak force, its time, and the
energy-ledger drift.

    python scripts/plot_work_precision.py results/work_precision_fig08.h5 [more.h5 ...] [-o out.png]

Each input X.h5 gives X.png unless -o is given (one input only).
"""

import argparse
import json
from pathlib import Path

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from chainplot import PNG_DPI, journal_layout  # noqa: E402

STYLE = {
    "dop853": dict(color="tab:blue", marker="o"),
    "dop853-predict": dict(color="tab:cyan", marker="D"),
    "vern6": dict(color="tab:orange", marker="P"),
    "ros34pw2": dict(color="tab:red", marker="s"),
    "rk4": dict(color="tab:green", marker="^"),
    "verlet": dict(color="tab:purple", marker="v"),
}


def label(setting, name):
    return f"{setting:.0e}" if name == "rtol" else f"{setting:.1e} s"


def plot(path, out):
    with h5py.File(path, "r") as f:
        scene = json.loads(f.attrs["scene"])
        title = f.attrs["source"]
        ref = f"{f.attrs['reference']}, confirmed by {f.attrs['confirmation']} to {f.attrs['reference_agreement']:.1e}"
        mu = scene["physics"]["damping_kg_s"]
        # Three panels in a 2 x 2 grid, the fourth holding the legend: at the page's width a
        # row of three leaves each panel too narrow for its settings' labels.
        fig, grid = plt.subplots(2, 2, figsize=(10, 8))
        axes, key = [grid[0, 0], grid[0, 1], grid[1, 0]], grid[1, 1]
        panels = [
            ("error", "leading-peak force: max relative error"),
            ("error_leading_peak_time", "leading-peak time: max relative error"),
            ("energy_drift", "energy-ledger drift / impact energy"),
        ]
        for ax, (name, ylabel) in zip(axes, panels):
            for method in STYLE:
                if method not in f:
                    continue
                g = f[method]
                ok = g["ok"][:] == 1
                if not ok.any():
                    continue
                y = g[name][:]
                if y.ndim == 2:
                    y = np.array([np.nanmax(r) if np.isfinite(r).any() else np.nan for r in y])
                x = g["wall_time"][:]
                # Errors above 1 are unstable runs (shown in the HDF5 file, not drawn).
                keep = ok & np.isfinite(y) & (y > 0) & (g["error"][:] <= 1)
                ax.loglog(x[keep], y[keep], label=method, **STYLE[method])
                if name == "error":
                    s = g["setting"][:]
                    for xi, yi, si in zip(x[keep], y[keep], s[keep]):
                        ax.annotate(label(si, g.attrs["setting_name"]), (xi, yi), fontsize=6,
                                    xytext=(3, 3), textcoords="offset points", color=STYLE[method]["color"])
            if name != "energy_drift":
                ax.axhline(1e-6, color="gray", lw=0.8, ls=":")
            ax.set_xlabel("wall time per run, s (median of repeats)")
            ax.set_ylabel(ylabel)
            ax.grid(True, which="both", alpha=0.3)
        key.axis("off")
        key.legend(*axes[0].get_legend_handles_labels(), loc="center")
        fig.suptitle(f"{title}\nmu = {mu} kg/s; reference {ref}", fontsize=9)
        # At a journal width, as PDF and PNG (the same layout as every other figure).
        journal_layout(fig)
        fig.savefig(out, dpi=PNG_DPI, metadata={"Software": None})
        with matplotlib.rc_context({"pdf.fonttype": 42}):
            fig.savefig(out.with_suffix(".pdf"), metadata={"Creator": None, "Producer": None, "CreationDate": None})
        plt.close(fig)
    print(f"wrote {out.with_suffix('.pdf')}")
    print(f"wrote {out}")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("files", nargs="+", type=Path)
    ap.add_argument("-o", "--output", type=Path)
    a = ap.parse_args()
    if a.output and len(a.files) != 1:
        ap.error("-o takes one input file")
    for p in a.files:
        plot(p, a.output or p.with_suffix(".png"))


if __name__ == "__main__":
    main()
