"""Fig. 7: two-wave structure (solitary wave followed by a shock-like wave) in the one-mass (0.98)
chain struck at 1.45 m/s: gauge forces at increasing depth, offset by 10 N each, at μ = 6, 10, 15
and 100 kg/s (results/fig07.png; input results/fig07.h5)."""

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from chainplot import Sweep, cylinder_numbers, mu_label, savefig  # noqa: E402

OFFSET_N = 10.0


def main():
    with Sweep("fig07") as sw:
        mus = sw.coord("damping_kg_s")
        ks = [k for k in cylinder_numbers(sw.probes) if k % 10 == 0]
        fig, axs = plt.subplots(1, len(mus), figsize=(3.2 * len(mus), 6.0))
        cmap = plt.get_cmap("viridis")
        for ax, mu in zip(axs, mus):
            h = sw.history(damping_kg_s=mu)
            if h is None:
                ax.set_title(f"{mu_label(mu)}: run failed")
                continue
            t = h["time_s"] * 1e3
            for j, k in enumerate(ks):
                F = h[f"gauge_force_cyl{k}"]
                ax.plot(t, F + OFFSET_N * j, lw=0.8, color=cmap(j / max(len(ks) - 1, 1)))
                ax.text(t[-1], OFFSET_N * j + 1, f"{k}", fontsize=6, ha="right", va="bottom")
            ax.set_title(mu_label(mu), fontsize=10)
            ax.set_xlabel("time (ms)")
            ax.set_ylim(-5, None)
        axs[0].set_ylabel(f"gauge force (N), cylinder k offset by {OFFSET_N:g} N per curve")
        fig.suptitle("Fig. 7: one-mass chain (0.98), v$_0$ = 1.45 m/s: forces in cylinders 10, 20, …, 100 "
                     "(label = k; preload subtracted)", fontsize=10)
        fig.tight_layout()
        savefig(fig, "fig07")


if __name__ == "__main__":
    main()
