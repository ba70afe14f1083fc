"""One figure per example sweep of sweeps/examples/ (docs/CHAINS.md), from results/examples/NAME.h5
into results/examples/NAME.png, and the attenuation table of the delta-force dimer example.

Run by `make examples` after it has run the sweeps; `python examples.py NAME…` draws only those.
"""

import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from chainplot import RESULTS, Sweep, savefig  # noqa: E402

EXAMPLES = RESULTS / "examples"
SPHERE_MASS_KG = 0.002085


def load(name: str) -> Sweep:
    return Sweep(EXAMPLES / f"{name}.h5")


def damping_lines(ax, sw: Sweep, x_name: str, y_of, xscale: float = 1.0, marker: str = "o"):
    """One line of `y_of(sw, damping=mu)` against the coordinate `x_name` per damping value."""
    x = sw.coord(x_name).astype(float) * xscale
    for mu in sw.coord("damping_kg_s"):
        ax.plot(x, y_of(sw, mu), marker=marker, label=f"μ = {mu:g} kg/s")
    ax.legend(fontsize=8)


def trimer():
    with load("trimer") as sw:
        fig, ax = plt.subplots(figsize=(6, 4))
        near, far = sw.probes
        damping_lines(
            ax, sw, "small_diameter_m",
            lambda s, mu: s.summary("leading_peak", far, damping_kg_s=mu)
            / s.summary("leading_peak", near, damping_kg_s=mu),
            xscale=1e3,
        )
        ax.set_xlabel("diameter of the two small spheres of each cell (mm)")
        ax.set_ylabel("leading force, cell 18 / cell 5")
        ax.set_title("Trimer [8 mm, d, d] × 20, striker 0.5 m/s", fontsize=10)
        ax.grid(alpha=0.3)
        fig.tight_layout()
        savefig(fig, "examples/trimer")


def tapered():
    with load("tapered") as sw:
        fig, ax = plt.subplots(figsize=(6, 4))
        damping_lines(
            ax, sw, "taper_ratio",
            lambda s, mu: s.summary("leading_peak", "wall_force", damping_kg_s=mu)
            / s.summary("leading_peak", s.probes[0], damping_kg_s=mu),
        )
        ax.set_xlabel("taper ratio (size of a sphere / size of the one above)")
        ax.set_ylabel("leading force on the wall / at sphere 5")
        ax.set_title("Tapered chain of 30 spheres, striker 0.5 m/s", fontsize=10)
        ax.invert_xaxis()
        ax.grid(alpha=0.3)
        fig.tight_layout()
        savefig(fig, "examples/tapered")


def disordered():
    with load("disordered") as sw:
        near, far = sw.probes
        levels = sw.coord("disorder_level").astype(float)
        ratio = np.array(
            [sw.summary("leading_peak", far, disorder_level=lv) / sw.summary("leading_peak", near, disorder_level=lv)
             for lv in levels]
        )  # (level, seed)
        fig, ax = plt.subplots(figsize=(6, 4))
        for k in range(ratio.shape[1]):
            ax.plot(levels, ratio[:, k], ".", color="0.6")
        ax.errorbar(levels, np.nanmean(ratio, axis=1), yerr=np.nanstd(ratio, axis=1), color="k", marker="o",
                    capsize=3, label=f"ensemble mean ± std ({ratio.shape[1]} seeds)")
        ax.set_xlabel("mass disorder level (masses × (1 + level·u), u ∈ [−1, 1))")
        ax.set_ylabel("leading force, sphere 36 / sphere 6")
        ax.set_title("Disordered chain of 40 spheres, striker 0.5 m/s", fontsize=10)
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
        fig.tight_layout()
        savefig(fig, "examples/disordered")


def precompressed():
    with load("precompressed") as sw:
        near, far = sw.probes
        d = float(sw.base["chain"]["particles"]["ball"]["sphere"]["diameter_m"])
        v = sw.coord("striker_velocity_m_s").astype(float)
        fig, ax = plt.subplots(figsize=(6, 4))
        for f in sw.coord("precompression_force_n"):
            t = sw.summary("leading_peak_time_s", far, precompression_force_n=f) - sw.summary(
                "leading_peak_time_s", near, precompression_force_n=f
            )
            ax.loglog(v, 20 * d / t, marker="o", label=f"precompression {f:g} N")
        ax.set_xlabel("striker velocity (m/s)")
        ax.set_ylabel("speed of the leading pulse, contacts 11→31 (m/s)")
        ax.set_title("Precompressed chain of 40 spheres", fontsize=10)
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3, which="both")
        fig.tight_layout()
        savefig(fig, "examples/precompressed")


def dimer_attenuation(sw: Sweep) -> tuple[np.ndarray, dict[float, np.ndarray]]:
    """Mass ratio and, per damping, the leading force at cylinder 35 over that at cylinder 5."""
    near, far = sw.probes
    eps = sw.coord("cylinder_mass_kg").astype(float) / SPHERE_MASS_KG
    att = {
        float(mu): sw.summary("leading_peak", far, damping_kg_s=mu) / sw.summary("leading_peak", near, damping_kg_s=mu)
        for mu in sw.coord("damping_kg_s")
    }
    return eps, att


def dimer_impulse():
    with load("dimer-impulse") as sw:
        eps, att = dimer_attenuation(sw)
        fig, ax = plt.subplots(figsize=(6, 4))
        for mu, a in att.items():
            ax.plot(eps, a, marker="o", label=f"μ = {mu:g} kg/s")
        ax.set_xlabel("mass ratio ε = m_cylinder / m_sphere")
        ax.set_ylabel("leading force, cylinder 35 / cylinder 5")
        ax.set_title("Dimer [sphere, cylinder] × 40, δ-force impulse 0.5 m/s", fontsize=10)
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
        fig.tight_layout()
        savefig(fig, "examples/dimer-impulse")
        print("delta-force dimer: leading force at cylinder 35 / at cylinder 5")
        print("| ε | " + " | ".join(f"μ = {mu:g} kg/s" for mu in att) + " |")
        print("|---|" + "---|" * len(att))
        for i, e in enumerate(eps):
            print(f"| {e:.3f} | " + " | ".join(f"{a[i]:.4f}" for a in att.values()) + " |")


PLOTS = {
    "trimer": trimer,
    "tapered": tapered,
    "disordered": disordered,
    "precompressed": precompressed,
    "dimer-impulse": dimer_impulse,
}


def main(names: list[str]):
    for name in names or PLOTS:
        PLOTS[name]()


if __name__ == "__main__":
    main(sys.argv[1:])
