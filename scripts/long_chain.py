"""Long chains (Sec. IV.B): leading pulses of the 0.55 chain (heavy cylinders), 1000 particles,
μ = 0, v0 = 1.3 m/s, without and with gravity: dynamic forces in cylinders (gauge) and spheres (mean
of the two contact forces) near particles 500 and 900 (results/long-chain.png; input
results/long-chain.h5)."""

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from chainplot import Sweep, count_leading_peaks, savefig  # noqa: E402

WINDOW_S = 4e-4


def signals(h):
    """Named dynamic force histories: (label, particle number, values)."""
    return [
        ("cylinder 10", 21, h["gauge_force_cyl10"]),
        ("cylinder 200", 401, h["gauge_force_cyl200"]),
        ("cylinder 249", 499, h["gauge_force_cyl249"]),
        ("sphere", 500, 0.5 * (h["contact_force_499"] + h["contact_force_500"])),
        ("cylinder 449", 899, h["gauge_force_cyl449"]),
        ("sphere", 900, 0.5 * (h["contact_force_899"] + h["contact_force_900"])),
    ]


def main():
    with Sweep("long-chain") as sw:
        # A column per condition, a row per particle: six rows of two panels print at a page's
        # width with room for their titles.
        fig, axs = plt.subplots(6, 2, figsize=(7.2, 9.0), sharex=True)
        axs = axs.T
        for row, g in enumerate((False, True)):
            h = sw.history(gravity=g)
            if h is None:
                continue
            t = h["time_s"]
            for ax, (lab, p, F) in zip(axs[row], signals(h)):
                i0 = int(np.nonzero(F > 1.0)[0][0])
                w = (t >= t[i0] - 2e-5) & (t <= t[i0] + WINDOW_S)
                n = count_leading_peaks(t, F, 1.0)
                ax.plot((t[w] - t[i0]) * 1e6, F[w], lw=0.9, color="tab:red" if "cyl" in lab else "tab:blue")
                ax.set_title(f"{'gravity' if g else 'no gravity'}: particle {p} ({lab})\n"
                             f"leading pulse: {n} peak{'s' if n != 1 else ''}", fontsize=8.5)
                ax.set_xlabel("time after arrival (µs)", fontsize=8)
                ax.grid(alpha=0.3)
            for ax in axs[row]:
                ax.set_ylabel("dynamic force (N)")
        fig.suptitle("Long 0.55 chain (heavy cylinders), 1000 particles, μ = 0, v$_0$ = 1.3 m/s", fontsize=10)
        fig.tight_layout()
        savefig(fig, "long-chain")


if __name__ == "__main__":
    main()
