"""Fig. 8: F21/F4 against mass ratio at μ = 0 and 6 kg/s (results/fig08.png), and the effect of the
choices the paper left open (results/fig08-choices.png).

Inputs: results/fig08.h5 (50 cylinders, leading peaks: the default reading), fig08-literal.h5
(21 cylinders), fig08-choices.h5 (gravity on/off, record maximum), fig08-light.h5 (light cylinders).
"""

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from chainplot import MU_COLORS, Sweep, mu_label, parabola_min, savefig  # noqa: E402

EPS = "mass_ratio"


def ratio(sw, dataset="leading_peak", num="gauge_force_cyl21", den="gauge_force_cyl4", **sel):
    v = sw.summary(dataset, **sel)
    return v[..., sw.probes.index(num)] / v[..., sw.probes.index(den)]


def main():
    with Sweep("fig08") as sw:
        eps = sw.coord(EPS)
        mus = sw.coord("damping_kg_s")
        main_curves = {mu: ratio(sw, damping_kg_s=mu) for mu in mus}
    fig, ax = plt.subplots(figsize=(6.4, 4.6))
    for mu in mus:
        c = MU_COLORS.get(int(mu), None)
        y = main_curves[mu]
        xm, ym = parabola_min(eps, y)
        ax.plot(eps, y, "-o", ms=2.5, color=c, label=f"{mu_label(mu)} (min at ε = {xm:.3f})")
        ax.plot([xm], [ym], "v", color=c, ms=8)
    ax.set_xlabel("mass ratio ε = m_s / m_c (heavy cylinders)")
    ax.set_ylabel("F$_{21}$ / F$_4$")
    ax.set_xlim(0.1, 1.0)
    ax.set_title("Fig. 8: force in cylinder 21 / force in cylinder 4\n"
                 "50 cylinders, leading-pulse peaks, v$_0$ = 1.3 m/s, gravity on\n"
                 "(the literal 21-cylinder chain and other choices: fig08-choices.png)", fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=9, loc="upper center")
    fig.tight_layout()
    savefig(fig, "fig08")

    # -------------------------------------------------------------- the choices
    fig, axs = plt.subplots(1, 2, figsize=(11, 4.4), sharey=True)
    with Sweep("fig08-choices") as ch, Sweep("fig08-light") as li, Sweep("fig08-literal") as sw21:
        for ax, mu in zip(axs, mus):
            c = MU_COLORS.get(int(mu))
            ax.plot(eps, main_curves[mu], "-", color=c, lw=2, label="default: 50 cyl., leading peak, gravity, heavy cyl.")
            e2 = ch.coord(EPS)
            ax.plot(e2, ratio(ch, "record_max", gravity=True, damping_kg_s=mu), ":", color="k",
                    label="50 cyl., record maximum (1.5 ms)")
            ax.plot(e2, ratio(ch, gravity=False, damping_kg_s=mu), "-.", color="tab:green", label="50 cyl., no gravity")
            ax.plot(sw21.coord(EPS), ratio(sw21, damping_kg_s=mu), "--", color="tab:gray",
                    label="21 cyl. (literal), leading peak")
            ax.plot(sw21.coord(EPS), ratio(sw21, "record_max", damping_kg_s=mu), "--", color="tab:orange",
                    label="21 cyl. (literal), record maximum")
            ax.plot(li.coord(EPS), ratio(li, damping_kg_s=mu), "-", color="tab:cyan",
                    label="light cylinders, m_c = ε m_s")
            ax.set_title(f"{mu_label(mu)}", fontsize=10)
            ax.set_xlabel("mass ratio ε")
            ax.grid(alpha=0.3)
        axs[0].set_ylabel("F$_{21}$ / F$_4$")
        axs[0].legend(fontsize=7)
    fig.suptitle("Fig. 8 under the choices the paper left open", fontsize=11)
    fig.tight_layout()
    savefig(fig, "fig08-choices")


if __name__ == "__main__":
    main()
