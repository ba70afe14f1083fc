"""Fig. 14: gaps on both sides of cylinder 21 of the 0.55 chain (heavy cylinders) struck at 1.45 m/s:
the gauge force in cylinder 21 and the displacements of its neighbouring spheres (particles 42 and
44), with the moments a contact is open shaded, at μ = 0, 6, 10, 15 kg/s (results/fig14.png;
input results/fig14.h5)."""

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from chainplot import Sweep, mu_label, savefig  # noqa: E402


def main():
    with Sweep("fig14") as sw:
        mus = sw.coord("damping_kg_s")
        fig, axs = plt.subplots(len(mus), 1, figsize=(8, 2.3 * len(mus)), sharex=True)
        for ax, mu in zip(axs, mus):
            h = sw.history(damping_kg_s=mu)
            t = h["time_s"] * 1e6
            F = h["gauge_force_cyl21"]
            win = (t > 380) & (t < 900)
            ax.plot(t[win], F[win], color="k", lw=1, label="force in cylinder 21")
            ax.set_ylabel("force (N)")
            open_ = (h["overlap_42"] <= 0) | (h["overlap_43"] <= 0)
            if open_[win].any():
                ax.fill_between(t[win], 0, 1, where=open_[win], transform=ax.get_xaxis_transform(),
                                color="tab:orange", alpha=0.3, lw=0, label="gap open (contact 42 or 43)")
            ax2 = ax.twinx()
            for p, c in ((42, "tab:blue"), (44, "tab:red")):
                ax2.plot(t[win], h[f"displacement_p{p}"][win] * 1e6, color=c, lw=0.9, ls="--",
                         label=f"displacement of sphere {p}")
            ax2.set_ylabel("displacement (µm)")
            n_gaps = int((h["min_overlap_m"][41:43] <= 0).sum())
            ax.set_title(f"{mu_label(mu)}: {'gaps open on ' + str(n_gaps) + ' side(s) of cylinder 21' if n_gaps else 'no gaps'}",
                         fontsize=9)
            if mu == mus[0]:
                l1, n1 = ax.get_legend_handles_labels()
                l2, n2 = ax2.get_legend_handles_labels()
                ax.legend(l1 + l2, n1 + n2, fontsize=7, loc="upper right")
        axs[-1].set_xlabel("time after impact (µs)")
        fig.suptitle("Fig. 14: 0.55 chain (heavy cylinders), v$_0$ = 1.45 m/s", fontsize=10)
        fig.tight_layout()
        savefig(fig, "fig14")


if __name__ == "__main__":
    main()
