"""Figs. 15, 17, 18, 19: relative amplitude A_k/A_4 of the 0.98 chain and a 0.55 dimer across damping,
at the same contact number (Figs. 15, 18) or the same mass of chain crossed (Figs. 17, 19).

    python scripts/fig_compare.py fig15 [fig17 fig18 fig19]

reads results/figNN.h5 (sweeps/figNN.json) and writes results/figNN.png. The abscissa is the cylinder
number k (equal number of contacts crossed) or the mass crossed M(k) = k (m_s + m_c), along which
the points are joined linearly, as the paper interpolates between cylinders.
"""

import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from chainplot import Sweep, chains, mass_crossed, mu_label, relative_amplitudes, savefig  # noqa: E402

FIGURES = {
    "fig15": ("contacts", "Fig. 15: same contact number, heavy cylinders (0.55 chain: 3.77 g cylinders)"),
    "fig17": ("mass", "Fig. 17: same mass crossed, heavy cylinders (0.55 chain: 3.77 g cylinders)"),
    "fig18": ("contacts", "Fig. 18: same contact number, light cylinders (m_c = 0.55 m_s = 1.15 g)"),
    "fig19": ("mass", "Fig. 19: same mass crossed, light cylinders (m_c = 0.55 m_s = 1.15 g)"),
}


def draw(name: str):
    xkind, title = FIGURES[name]
    with Sweep(name) as sw:
        mus = sw.coord("damping_kg_s")
        ch = chains(sw)
        v0 = sw.base["striker_velocity_m_s"]
        fig, axs = plt.subplots(1, len(mus), figsize=(3.0 * len(mus) + 0.6, 3.6), sharey=True)
        xmax = None
        if xkind == "mass":
            # show the mass range both chains cover
            ks = np.array([int(p.removeprefix("gauge_force_cyl")) for p in sw.probes])
            xmax = min(mass_crossed(ks.max(), c["m_c"], c["m_s"]) for c in ch)
        for ax, mu in zip(np.atleast_1d(axs), mus):
            for c in ch:
                k, a = relative_amplitudes(sw, cylinder_mass=c["value"], damping_kg_s=mu)
                x = k if xkind == "contacts" else mass_crossed(k, c["m_c"], c["m_s"])
                if xkind == "contacts":
                    keep = k <= 40
                else:
                    keep = x <= xmax * 1.0001
                ax.plot(x[keep], a[keep], "-o", ms=2.5, lw=1.2, color=c["color"],
                        mfc="none" if c["label"] == "0.98" else c["color"],
                        label=f"mass ratio {c['label']}")
            if xkind == "contacts":
                ax.axvline(21, color="0.7", lw=0.8, ls=":")
                ax.set_xlabel("contact number (cylinder k)")
            else:
                ax.set_xlabel("mass of chain crossed (g)")
            ax.set_title(f"({'abcde'[list(mus).index(mu)]}) {mu_label(mu)}", fontsize=10)
            ax.grid(alpha=0.3)
            ax.set_ylim(0, 1.1)
        axs[0].set_ylabel("relative amplitude A$_k$ / A$_4$")
        axs[0].legend(fontsize=8, loc="lower left")
        fig.suptitle(f"{title}; v$_0$ = {v0:g} m/s, 50+ cylinders, leading peaks", fontsize=10)
        fig.tight_layout()
        savefig(fig, name)


if __name__ == "__main__":
    for n in sys.argv[1:] or list(FIGURES):
        draw(n)
