"""Fig. 16: particle-velocity profiles of the 0.98 chain (blue, open circles) and the 0.55 chain
(heavy cylinders; red, solid circles) at the moment the leading pulse peaks at cylinder 21, at
μ = 0, 6, 10, 15, 100 kg/s, striker 1.45 m/s (results/fig16.png; input results/fig16.h5).

Particles are numbered as in docs/MODEL.md (striker = 1, cylinder k = particle 2k+1); the paper's caption
counts without the striker, so its "42nd particle" is our particle 43."""

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from chainplot import Sweep, chains, mu_label, savefig  # noqa: E402

PEAK_PARTICLE = 43  # cylinder 21


def snapshot(sw, chain, mu):
    """(particle numbers, velocities) at the leading-peak time of particle 43's velocity."""
    h = sw.history(cylinder_mass=chain["value"], damping_kg_s=mu)
    if h is None:
        return None, None
    t_pk = float(sw.summary("leading_peak_time_s", probe=f"velocity_p{PEAK_PARTICLE}",
                            cylinder_mass=chain["value"], damping_kg_s=mu))
    ps = sorted(int(p.removeprefix("velocity_p")) for p in sw.probes)
    v = np.array([np.interp(t_pk, h["time_s"], h[f"velocity_p{p}"]) for p in ps])
    return np.array(ps), v


def main():
    with Sweep("fig16") as sw:
        mus = sw.coord("damping_kg_s")
        fig, axs = plt.subplots(1, len(mus), figsize=(3.1 * len(mus), 3.6))
        for ax, mu in zip(axs, mus):
            for c in chains(sw):
                p, v = snapshot(sw, c, mu)
                if p is None:
                    continue
                ax.plot(p, v, "-o", ms=3.5, lw=0.8, color=c["color"],
                        mfc="none" if c["label"] == "0.98" else c["color"], label=f"mass ratio {c['label']}")
            ax.axvline(PEAK_PARTICLE, color="0.7", lw=0.8, ls=":")
            ax.set_xlim(20, 50)
            ax.set_title(f"({'abcde'[list(mus).index(mu)]}) {mu_label(mu)}", fontsize=10)
            ax.set_xlabel("particle number (cyl. 21 = 43)")
            ax.grid(alpha=0.3)
        axs[0].set_ylabel("particle velocity (m/s)")
        axs[0].legend(fontsize=7, loc="upper left")
        fig.suptitle("Fig. 16: velocity profiles when the pulse peaks at cylinder 21, v$_0$ = 1.45 m/s",
                     fontsize=10)
        fig.tight_layout()
        savefig(fig, "fig16")


if __name__ == "__main__":
    main()
