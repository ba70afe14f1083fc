"""One figure per example sweep of sweeps/examples/ (docs/CHAINS.md, docs/SEARCHES.md), from
results/examples/NAME.h5 into results/examples/NAME.png, and the attenuation table of the
delta-force dimer example. Searches are drawn with every point they evaluated, and the minima and
roots they found marked with their uncertainty.

Run by `make examples` after it has run the sweeps; `python examples.py NAME…` draws only those.
"""

import json
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import chainsweep  # noqa: E402
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


def open_search(name: str):
    """The output of a search example, read by chainsweep.open (points, outcomes, statuses)."""
    return chainsweep.open(EXAMPLES / f"{name}.h5")


def objective_label(ds) -> str:
    return ds.objective.attrs.get("long_name", "objective")


def evaluated(ds, field: str, **outer):
    """The evaluated points of one search (field value, objective), sorted along the field,
    failed or pending evaluations left out."""
    sel = ds.sel(**outer) if outer else ds
    x = np.asarray(sel[field].values, dtype=float)
    y = np.asarray(sel.objective.values, dtype=float)
    keep = np.isfinite(x) & np.isfinite(y)
    order = np.argsort(x[keep])
    return x[keep][order], y[keep][order]


def dimer_minimum():
    """The minimum of the dimer's attenuation over eps, found per damping, on top of the grid."""
    with open_search("dimer-minimum") as ds:
        fig, ax = plt.subplots(figsize=(6, 4))
        for k, mu in enumerate(ds.damping_kg_s.values):
            x, y = evaluated(ds, "cylinder_mass_kg", damping_kg_s=mu)
            (line,) = ax.plot(x / SPHERE_MASS_KG, y, ".", label=f"μ = {mu:g} kg/s: {len(x)} runs")
            at = ds.sel(damping_kg_s=mu)
            for m in range(at.sizes["minimum"]):
                xm = float(at.minimum_cylinder_mass_kg[m]) / SPHERE_MASS_KG
                if not np.isfinite(xm):
                    continue
                dx = float(at.minimum_cylinder_mass_kg_uncertainty[m]) / SPHERE_MASS_KG
                ym = float(at.minimum_objective[m])
                ax.errorbar(xm, ym, xerr=dx, marker="*", ms=12, color=line.get_color(), capsize=3)
                ax.annotate(f"ε = {xm:.5f} ± {dx:.0e}\n{ym:.4f}", (xm, ym), textcoords="offset points",
                            xytext=(10, -28) if k == 0 else (10, 14), fontsize=8, color=line.get_color())
        ax.set_xlabel("mass ratio ε = m_cylinder / m_sphere")
        ax.set_ylabel("leading force, cylinder 35 / cylinder 5")
        ax.set_title("δ-force dimer: minimum attenuation located by a search (★)", fontsize=10)
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
        fig.tight_layout()
        savefig(fig, "examples/dimer-minimum")


def critical_damping_root():
    """The difference of the two chains' attenuation against damping, and its root."""
    with open_search("critical-damping-root") as ds:
        fig, ax = plt.subplots(figsize=(6, 4))
        for v in ds.striker_velocity_m_s.values:
            x, y = evaluated(ds, "damping_kg_s", striker_velocity_m_s=v)
            (line,) = ax.plot(x, y, "o-", ms=4, label=f"striker {v:g} m/s: {len(x)} evaluations ({2 * len(x)} runs)")
            at = ds.sel(striker_velocity_m_s=v)
            for r in range(at.sizes["root"]):
                xr = float(at.root_damping_kg_s[r])
                if np.isfinite(xr):
                    dx = float(at.root_damping_kg_s_uncertainty[r])
                    ax.plot(xr, 0.0, "*", ms=14, color=line.get_color())
                    ax.annotate(f"μ* = {xr:.4f} ± {dx:.0e} kg/s", (xr, 0.0), textcoords="offset points",
                                xytext=(-150, -22) if v < 1.2 else (10, 10), fontsize=8, color=line.get_color())
        ax.axhline(0.0, color="k", lw=0.7)
        ax.set_xlabel("damping μ (kg/s)")
        ax.set_ylabel("A21/A4: 0.98 chain − 0.55 chain")
        ax.set_title("Critical damping of Fig. 15: a root across the two chains (★)", fontsize=10)
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
        fig.tight_layout()
        savefig(fig, "examples/critical-damping-root")


def fig08_refined():
    """The refined Fig. 8 curves: each point the search chose, and where it put them."""
    with open_search("fig08-refined") as ds:
        fig, (ax, hist) = plt.subplots(2, 1, figsize=(6, 5.5), sharex=True, height_ratios=[3, 1])
        for mu in ds.damping_kg_s.values:
            x, y = evaluated(ds, "mass_ratio", damping_kg_s=mu)
            err = float(ds.refine_error.sel(damping_kg_s=mu))
            (line,) = ax.plot(x, y, "-", lw=1)
            ax.plot(x, y, ".", color=line.get_color(),
                    label=f"μ = {mu:g} kg/s: {len(x)} runs, interpolation error ≤ {err:.1e}")
            hist.plot(x, np.full_like(x, mu), "|", ms=12, color=line.get_color())
        ax.set_ylabel("F21 / F4")
        ax.set_title("Fig. 8 refined: points go where the curve bends or jumps", fontsize=10)
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
        hist.set_xlabel("mass ratio ε")
        hist.set_ylabel("μ (kg/s)")
        hist.set_yticks(ds.damping_kg_s.values)
        hist.set_ylim(-3, 9)
        fig.tight_layout()
        savefig(fig, "examples/fig08-refined")


def fig08_surface():
    """The refined surface over mass ratio and damping, drawn from its own interpolant, with
    the points the refinement chose."""
    with open_search("fig08-surface") as ds:
        x = np.asarray(ds.mass_ratio.values, dtype=float)
        y = np.asarray(ds.damping_kg_s.values, dtype=float)
        keep = np.isfinite(x) & np.isfinite(y)
        gx, gy = np.meshgrid(np.linspace(0.1, 1.0, 451), np.linspace(0.0, 10.0, 201), indexing="ij")
        z = chainsweep.refined_surface(ds, gx, gy)
        fig, ax = plt.subplots(figsize=(6.5, 4.5))
        c = ax.pcolormesh(gx, gy, z, shading="auto", cmap="viridis")
        ax.plot(x[keep], y[keep], "k.", ms=2)
        fig.colorbar(c, ax=ax, label="F21 / F4")
        ax.set_xlabel("mass ratio ε")
        ax.set_ylabel("damping μ (kg/s)")
        ax.set_title(f"F21/F4 refined in two dimensions: {int(keep.sum())} runs, "
                     f"interpolation error ≤ {float(ds.refine_error):.1e}", fontsize=10)
        fig.tight_layout()
        savefig(fig, "examples/fig08-surface")


def alternating_dimer_minimum():
    """The Nelder-Mead search over two cylinder masses: its points, and the optimum."""
    with open_search("alternating-dimer-minimum") as ds:
        a = np.asarray(ds.cylinder_a_mass_kg.values, dtype=float) / SPHERE_MASS_KG
        b = np.asarray(ds.cylinder_b_mass_kg.values, dtype=float) / SPHERE_MASS_KG
        z = np.asarray(ds.objective.values, dtype=float)
        keep = np.isfinite(a) & np.isfinite(b) & np.isfinite(z)
        fig, ax = plt.subplots(figsize=(6, 5))
        c = ax.scatter(a[keep], b[keep], c=z[keep], s=14, cmap="viridis_r")
        fig.colorbar(c, ax=ax, label="leading force, particle 70 / particle 10")
        for m in range(ds.sizes["minimum"]):
            am = float(ds.minimum_cylinder_a_mass_kg[m]) / SPHERE_MASS_KG
            bm = float(ds.minimum_cylinder_b_mass_kg[m]) / SPHERE_MASS_KG
            if np.isfinite(am):
                ax.plot(am, bm, "r*", ms=14)
                if m == 0:
                    ax.annotate(f"ε_A = {am:.4f}, ε_B = {bm:.4f}\n{float(ds.minimum_objective[m]):.5f}", (am, bm),
                                textcoords="offset points", xytext=(10, 10), fontsize=8, color="r")
        ax.plot([0.3, 0.9], [0.3, 0.9], color="0.6", lw=0.7, label="equal masses (the plain dimer)")
        ax.set_xlabel("ε_A = m_cylinder A / m_sphere")
        ax.set_ylabel("ε_B = m_cylinder B / m_sphere")
        ax.set_title(f"Alternating-mass dimer: Nelder–Mead over two masses, {int(keep.sum())} runs", fontsize=10)
        ax.legend(fontsize=8, loc="upper right")
        ax.set_aspect("equal")
        fig.tight_layout()
        savefig(fig, "examples/alternating-dimer-minimum")


def law_label(value) -> str:
    """A legend for a contact law as the axis holds it (JSON text, or the decoded value)."""
    import json

    law = value
    if isinstance(value, (str, bytes)):
        text = value.decode() if isinstance(value, bytes) else value
        try:
            law = json.loads(text)
        except ValueError:
            law = text
    if law == "hertz":
        return "elastic (Hertz)"
    p_y = law["thornton"]["yield_pressure_pa"]
    return f"Thornton, p_y = {p_y / 1e9:g} GPa"


def plastic_impact():
    with load("plastic-impact") as sw:
        particle, wall = sw.probes
        v = sw.coord("striker_velocity_m_s").astype(float)
        laws = sw.coord("law_striker")
        fig, axes = plt.subplots(1, 2, figsize=(9, 4))
        for ax, probe, what in [
            (axes[0], particle, "leading force, last cylinder (N)"),
            (axes[1], wall, "largest wall force (N)"),
        ]:
            dataset = "leading_peak" if probe == particle else "record_max"
            for law in laws:
                ax.loglog(v, sw.summary(dataset, probe, law_striker=law), marker="o", label=law_label(law))
            ax.set_xlabel("striker velocity (m/s)")
            ax.set_ylabel(what)
            ax.grid(alpha=0.3, which="both")
        axes[0].legend(fontsize=8)
        fig.suptitle("Dimer [sphere, cylinder] × 10 struck by a sphere: transmitted force with and without plasticity", fontsize=10)
        fig.tight_layout()
        savefig(fig, "examples/plastic-impact")


def dimer_bands():
    """The precompressed dimer's band structure from the linear spectrum (no time integration):
    the acoustic band, the gap and the optical band against the static force, for each mass of
    the small sphere."""
    with load("dimer-bands") as sw:
        force = sw.coord("precompression_force_n").astype(float)
        masses = sw.coord("small_mass_kg").astype(float)
        fig, axes = plt.subplots(1, len(masses), figsize=(3.2 * len(masses), 3.6), sharey=True)
        for ax, m in zip(np.atleast_1d(axes), masses):
            low = sw.summary("gap_lower_hz", small_mass_kg=m) / 1e3
            high = sw.summary("gap_upper_hz", small_mass_kg=m) / 1e3
            top = sw.summary("band_top_hz", small_mass_kg=m) / 1e3
            ax.fill_between(force, 0, low, color="tab:blue", alpha=0.35, label="acoustic band")
            ax.fill_between(force, low, high, color="0.9", label="band gap")
            ax.fill_between(force, high, top, color="tab:orange", alpha=0.35, label="optical band")
            ax.set_xscale("log")
            ax.set_ylim(0, None)
            ax.set_xlabel("precompression force (N)")
            ax.set_title(f"small sphere {m * 1e3:g} g", fontsize=9)
            ax.grid(alpha=0.3)
        np.atleast_1d(axes)[0].set_ylabel("frequency (kHz)")
        np.atleast_1d(axes)[0].legend(fontsize=7, loc="upper left")
        fig.suptitle("Precompressed dimer [8 mm, 5 mm spheres] × 100: bands and gap grow as F^(1/6)",
                     fontsize=10)
        fig.tight_layout()
        savefig(fig, "examples/dimer-bands")


def colliding_waves():
    """Space-time maps of the force of every contact (the run's `record.fields`): two solitary
    waves meeting head-on between two walls, equal and unequal."""
    path = EXAMPLES / "colliding-waves.h5"
    with chainsweep.open(path, histories=True) as ds:
        speeds = ds["velocity_of_particle_41_m_s"].values
        fig, axes = plt.subplots(1, len(speeds), figsize=(5 * len(speeds), 4.2), sharey=True)
        for ax, v in zip(np.atleast_1d(axes), speeds):
            field = ds["field_contact_force"].sel(velocity_of_particle_41_m_s=v)
            t = field["field_time_s"].values * 1e3
            image = ax.pcolormesh(field["contact"].values, t, field.values, shading="nearest", cmap="magma")
            ax.set_xlabel("contact (42: the top wall, 41: the wall under the chain)")
            ax.set_title(f"particle 1 at 0.5 m/s, particle 41 at {-v:g} m/s", fontsize=9)
            fig.colorbar(image, ax=ax, label="contact force (N)")
        np.atleast_1d(axes)[0].set_ylabel("time (ms)")
        fig.suptitle("Two solitary waves colliding in 41 spheres between two walls", fontsize=10)
        fig.tight_layout()
        savefig(fig, "examples/colliding-waves")


def between_walls():
    """The running time average of the kinetic energy over the total, for spheres rattling
    between two walls from random velocities, against the virial theorem's 5/9."""
    with load("between-walls") as sw:
        fig, ax = plt.subplots(figsize=(6, 4))
        for seed in sw.coord("seed"):
            h = sw.history(seed=seed)
            t = h["time_s"]
            kinetic = 0.5 * SPHERE_MASS_KG * sum(h[p] ** 2 for p in sw.probes)
            # No damping and the contacts open at the start: the total is the initial kinetic energy.
            running = np.cumsum(kinetic) / np.arange(1, len(kinetic) + 1) / kinetic[0]
            ax.plot(t * 1e3, running, label=f"seed {seed}: {running[-1]:.4f} at the end")
        ax.axhline(5 / 9, color="k", ls="--", lw=1, label="5/9 (virial theorem, degree 5/2)")
        ax.set_xscale("log")
        ax.set_xlabel("time (ms)")
        ax.set_ylabel("⟨K⟩ / E, running mean")
        ax.set_ylim(0.4, 1.02)
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3, which="both")
        ax.set_title("8 spheres between two walls, random initial velocities", fontsize=10)
        fig.tight_layout()
        savefig(fig, "examples/between-walls")


def driven_sweep_up_down():
    """The envelope of the force on the wall under a chain shaken by a slow chirp through its first
    resonance, upwards and downwards, per unit stroke of the actuator, against the chirp's
    instantaneous frequency: one panel per stroke."""
    with chainsweep.open(EXAMPLES / "driven-sweep-up-down.h5", histories=True) as ds:
        strokes = ds["amplitude_m"].values
        duration = float(ds["time_s"].values[-1])
        t = ds["time_s"].values
        fig, axes = plt.subplots(1, len(strokes), figsize=(4.2 * len(strokes), 4.2), sharey=True)
        for ax, stroke in zip(np.atleast_1d(axes), strokes):
            for start in ds["start_hz"].values:
                end = float(ds["end_hz"].sel(start_hz=start))
                force = ds["history"].sel(amplitude_m=stroke, start_hz=start).values[0]
                frequency = start + (end - start) * t / duration
                # The envelope: the largest |force| over windows of about four periods.
                w = 60
                n = len(force) // w
                envelope = np.abs(force[: n * w]).reshape(n, w).max(axis=1)
                centre = frequency[: n * w].reshape(n, w).mean(axis=1)
                label = "upwards" if end > start else "downwards"
                ax.plot(centre / 1e3, envelope / stroke / 1e6, label=label, lw=1.2)
            ax.set_xlabel("drive frequency (kHz)")
            ax.set_title(f"stroke {stroke * 1e9:g} nm", fontsize=9)
            ax.grid(alpha=0.3)
        np.atleast_1d(axes)[0].set_ylabel("wall force / stroke (N/µm)")
        np.atleast_1d(axes)[0].legend(fontsize=8)
        fig.suptitle("8 spheres between two walls under 2 N, shaken from the top by a slow chirp",
                     fontsize=10)
        fig.tight_layout()
        savefig(fig, "examples/driven-sweep-up-down")


def driven_branches():
    """The frequency response of the chain of driven-sweep-up-down as branches of periodic
    orbits (the largest wall force over an orbit, per unit stroke): stable orbits solid, unstable
    dashed, folds marked, with the slow chirps' envelopes upwards and downwards beneath (thin),
    one panel per stroke."""
    ds = chainsweep.open(EXAMPLES / "driven-branches.h5")
    chirps = EXAMPLES / "driven-sweep-up-down.h5"
    up_down = chainsweep.open(chirps, histories=True) if chirps.exists() else None
    strokes = ds["amplitude_m"].values
    fig, axes = plt.subplots(1, len(strokes), figsize=(4.2 * len(strokes), 4.2), sharey=True)
    for ax, stroke in zip(np.atleast_1d(axes), strokes):
        b = ds.sel(amplitude_m=stroke)
        n = int(b["branch_points"])
        f = b["frequency_hz"].values[:n] / 1e3
        force = b["orbit_max"].values[:n, 0] / stroke / 1e6
        stable = b["stability"].values[:n] == 1
        if up_down is not None:
            t = up_down["time_s"].values
            duration = float(t[-1])
            for start, colour in zip(up_down["start_hz"].values, ("0.55", "0.75")):
                end = float(up_down["end_hz"].sel(start_hz=start))
                chirp = up_down["history"].sel(amplitude_m=stroke, start_hz=start).values[0]
                w = 60
                k = len(chirp) // w
                envelope = np.abs(chirp[: k * w]).reshape(k, w).max(axis=1)
                centre = (start + (end - start) * t / duration)[: k * w].reshape(k, w).mean(axis=1)
                label = "slow chirp " + ("upwards" if end > start else "downwards")
                ax.plot(centre / 1e3, envelope / stroke / 1e6, color=colour, lw=0.8, label=label)
        # Runs of equal stability, each drawn solid (stable) or dashed (unstable), joined.
        edges = np.flatnonzero(np.diff(stable.astype(int))) + 1
        for lo, hi in zip(np.r_[0, edges], np.r_[edges, n]):
            seg = slice(lo, min(hi + 1, n))
            ax.plot(f[seg], force[seg], color="C0", lw=1.6, ls="-" if stable[lo] else "--",
                    label=None)
        ax.plot([], [], color="C0", lw=1.6, label="stable orbits")
        ax.plot([], [], color="C0", lw=1.6, ls="--", label="unstable orbits")
        folds = b["point_kind"].values[:n] == 4
        if folds.any():
            ax.plot(f[folds], force[folds], "o", color="C3", ms=4, label="folds")
        ax.set_xlabel("drive frequency (kHz)")
        ax.set_title(f"stroke {stroke * 1e9:g} nm", fontsize=9)
        ax.grid(alpha=0.3)
    np.atleast_1d(axes)[0].set_ylabel("largest wall force / stroke (N/µm)")
    np.atleast_1d(axes)[-1].legend(fontsize=7)
    fig.suptitle("8 spheres between two walls under 2 N, shaken harmonically from the top",
                 fontsize=10)
    fig.tight_layout()
    savefig(fig, "examples/driven-branches")


def dimer_breathers():
    """Breathers of a precompressed dimer in its gap, free orbits continued in frequency: the
    centre light sphere's fundamental amplitude against the frequency, stable orbits solid,
    unstable dashed, the optical band's edge marked; and the profiles (each particle's
    fundamental amplitude, on a log scale) of three orbits, falling from the centre by the
    linear chain's evanescent factor."""
    ds = chainsweep.open(EXAMPLES / "dimer-breathers.h5")
    base = json.loads(ds.attrs["base_scene"])
    force = base["physics"]["precompression_force_n"]
    law = base["chain"]["contacts"][0]["law"]["power_law"]["coefficient"]
    light = base["chain"]["particles"]["light"]["sphere"]["mass_kg"]
    k = 1.5 * law ** (2 / 3) * force ** (1 / 3)
    edge = np.sqrt(2 * k / light) / (2 * np.pi)
    n = int(ds["branch_points"])
    f = ds["frequency_hz"].values[:n] / 1e3
    amplitude = ds["orbit_amplitude"].values[:n, :, 0]
    stable = ds["stability"].values[:n] == 1
    centre = int(np.argmax(amplitude[0]))
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(11, 4.2))
    a = amplitude[:, centre] * 1e9
    edges = np.flatnonzero(np.diff(stable.astype(int))) + 1
    for lo, hi in zip(np.r_[0, edges], np.r_[edges, n]):
        seg = slice(lo, min(hi + 1, n))
        ax.plot(f[seg], a[seg], color="C0", lw=1.6, ls="-" if stable[lo] else "--", marker="o", ms=3)
    ax.plot([], [], color="C0", lw=1.6, label="stable orbits")
    ax.plot([], [], color="C0", lw=1.6, ls="--", label="unstable orbits")
    ax.axvline(edge / 1e3, color="C3", lw=1, label="optical band's lower edge")
    ax.set_xlabel("breather frequency (kHz)")
    ax.set_ylabel(f"particle {centre + 1}'s fundamental amplitude (nm)")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    particle = np.arange(1, amplitude.shape[1] + 1)
    for j, colour in zip((0, n // 2, n - 1), ("C0", "C1", "C2")):
        bx.semilogy(particle, amplitude[j] * 1e9, "o-", color=colour, ms=3, lw=0.8,
                    label=f"{f[j]:.2f} kHz")
    bx.set_xlabel("particle (1 at the top, light spheres even)")
    bx.set_ylabel("fundamental amplitude (nm)")
    bx.legend(fontsize=8)
    bx.grid(alpha=0.3)
    fig.suptitle("Breathers of a 20-cell steel dimer under 10 N, continued into its band gap", fontsize=10)
    fig.tight_layout()
    savefig(fig, "examples/dimer-breathers")


def dimer_transmission():
    """The transmission through a precompressed sphere–cylinder dimer from its steady state, against
    the drive frequency, one panel per precompression, with the band gap record.spectrum gives
    shaded; points whose response had not settled (in the gap: nothing arrives to settle) hollow."""
    with chainsweep.open(EXAMPLES / "dimer-transmission.h5") as ds:
        forces = ds["precompression_force_n"].values
        fig, axes = plt.subplots(1, len(forces), figsize=(4.2 * len(forces), 3.8), sharey=True)
        f = ds["frequency_hz"].values / 1e3
        for ax, force in zip(np.atleast_1d(axes), forces):
            at = ds.sel(precompression_force_n=force)
            db = at["steady_transmission_db"].values[:, 1]
            settled = at["steady_settled"].values[:, 1] == 1
            low = float(at["gap_lower_hz"].values[0]) / 1e3
            high = float(at["gap_upper_hz"].values[0]) / 1e3
            top = float(at["band_top_hz"].values[0]) / 1e3
            ax.axvspan(low, high, color="0.88", label="band gap (linear spectrum)")
            ax.axvspan(top, f[-1], color="0.95", label="above the optical band")
            ax.plot(f, db, color="tab:blue", lw=1)
            ax.plot(f[settled], db[settled], "o", color="tab:blue", ms=4, label="settled")
            ax.plot(f[~settled], db[~settled], "o", mfc="none", color="tab:blue", ms=4,
                    label="not settled")
            ax.set_xlabel("drive frequency (kHz)")
            ax.set_title(f"precompression {force:g} N", fontsize=9)
            ax.grid(alpha=0.3)
        np.atleast_1d(axes)[0].set_ylabel("transmission 58 / 2 (dB)")
        np.atleast_1d(axes)[0].legend(fontsize=7, loc="lower left")
        fig.suptitle("Sphere–cylinder dimer × 30 driven at the top: the gap moves up with the force",
                     fontsize=10)
        fig.tight_layout()
        savefig(fig, "examples/dimer-transmission")


def load_cell_impact():
    """Spheres struck onto a load cell: the energy of the pulse that crossed each contact (its
    attenuation along the chain) and each particle's largest kinetic energy, the share of the
    impact energy that reached the wall, and the load cell's force against the wall's, per damping
    (the run's `record.energy_flow` and its probes)."""
    path = EXAMPLES / "load-cell-impact.h5"
    with chainsweep.open(path) as ds:
        v = ds["striker_velocity_m_s"].values
        impact = 0.5 * SPHERE_MASS_KG * ds["striker_velocity_m_s"] ** 2
        passed = ds["energy_passed_max_j"] / impact
        kinetic = ds["max_kinetic_energy_j"] / impact
        wall = int(ds["contact"].values[-1])
        fig, axes = plt.subplots(2, 2, figsize=(9, 7))
        (a, b), (c, d) = axes
        for mu in ds["damping_kg_s"].values:
            label = f"μ = {mu:g} kg/s"
            at = {"damping_kg_s": mu, "striker_velocity_m_s": 1.0}
            line = passed.sel(**at)
            a.plot(line["contact"], line, marker="o", ms=3, label=label)
            k = kinetic.sel(**at)
            b.plot(k["particle"], k, marker="o", ms=3, label=label)
            c.semilogx(v, passed.sel(damping_kg_s=mu, contact=wall), marker="o", label=label)
            cell = ds["record_max"].sel(damping_kg_s=mu, probe="mount_force")
            base = d.loglog(v, cell, marker="o", label=label)
            d.loglog(v, ds["record_max"].sel(damping_kg_s=mu, probe="wall_force"), ls="--",
                     color=base[0].get_color(), lw=1)
        a.set_xlabel(f"contact ({wall}: the wall's)")
        a.set_ylabel("energy passed / impact energy")
        a.set_title("largest energy through each contact, 1 m/s", fontsize=9)
        b.set_xlabel("particle (1: the striker)")
        b.set_ylabel("kinetic energy / impact energy")
        b.set_title("largest kinetic energy of each particle, 1 m/s", fontsize=9)
        c.set_xlabel("striker velocity (m/s)")
        c.set_ylabel("energy at the wall / impact energy")
        c.set_title("energy that reached the wall", fontsize=9)
        d.set_xlabel("striker velocity (m/s)")
        d.set_ylabel("largest force (N)")
        d.set_title("load cell (solid) and wall contact (dashed)", fontsize=9)
        for ax in axes.flat:
            ax.grid(alpha=0.3, which="both")
        a.legend(fontsize=7)
        fig.suptitle("20 spheres struck onto a load cell (0.1 kg on 2e8 N/m and 50 kg/s)", fontsize=10)
        fig.tight_layout()
        savefig(fig, "examples/load-cell-impact")

def fit_figure(name: str):
    """A fit: the data with their error bars and the best fit's prediction (per signal, spectrum
    and the scalars), the normalised residuals beneath, and each field's profile likelihood with
    its 95 % threshold and intervals."""
    with open_search(name) as ds:
        fields = [str(f) for f in ds.fit_field_name.values]
        blocks = []
        if "scalar_datum" in ds.dims:
            labels = [str(n) for n in ds.scalar_datum_name.values]
            blocks.append(("scalar", np.arange(len(labels)), labels, "datum"))
        for v in ds.data_vars:
            if v.endswith("_data") and v != "scalar_data":
                prefix = v[: -len("_data")]
                dim = ds[v].dims[-1]
                x = np.asarray(ds[dim].values, dtype=float)
                blocks.append((prefix, x, None, dim))
        cols = len(blocks) + len(fields)
        fig, axes = plt.subplots(2, cols, figsize=(4.2 * cols, 6), squeeze=False,
                                 gridspec_kw={"height_ratios": [3, 1]})
        for k, (prefix, x, labels, dim) in enumerate(blocks):
            ax, rax = axes[0][k], axes[1][k]
            d = np.ravel(ds[f"{prefix}_data"].values)
            s = np.ravel(ds[f"{prefix}_sigma"].values)
            m = np.ravel(ds[f"{prefix}_model"].values)
            nr = np.ravel(ds[f"{prefix}_normalised_residual"].values)
            scale = 1e6 if dim.endswith("_time_s") else (1e-3 if dim.endswith("_frequency_hz") else 1)
            xs = x * scale
            if np.isfinite(s).any():
                ax.errorbar(xs, d, yerr=s, fmt="o", ms=3, capsize=2, label="data ± σ")
            else:
                ax.plot(xs, d, "o", ms=3, label="data (σ estimated)")
            ax.plot(xs, m, "-" if labels is None else "x", color="C3", label="best fit")
            units = ds[f"{prefix}_data"].attrs.get("units", "")
            ax.set_ylabel(units or "value")
            ax.set_title(ds[f"{prefix}_data"].attrs.get("long_name", prefix).split(":")[0], fontsize=9)
            ax.legend(fontsize=7, loc="upper right")
            rax.axhline(0, color="k", lw=0.5)
            rax.plot(xs, nr, "o", ms=3)
            rax.set_ylabel("residual / σ")
            if labels is not None:
                rax.set_xticks(xs, labels, rotation=20, fontsize=7)
                ax.set_xticks(xs, labels, rotation=20, fontsize=7)
            else:
                rax.set_xlabel({1e6: "time (µs)", 1e-3: "frequency (kHz)"}.get(scale, dim))
        chi_min = float(ds.fit_chi_square)
        for j, f in enumerate(fields):
            ax = axes[0][len(blocks) + j]
            axes[1][len(blocks) + j].axis("off")
            px = np.ravel(ds[f"fit_{f}_profile_value"].values)
            pc = np.ravel(ds[f"fit_{f}_profile_chi_square"].values)
            keep = np.isfinite(px) & np.isfinite(pc)
            x0 = float(np.ravel(ds[f"fit_{f}"].values)[0])
            se = float(ds[f"fit_{f}_standard_error"])
            if keep.any():
                ax.plot(px[keep], pc[keep] - chi_min, "o", label="profile (fits of the others)")
            grid = np.linspace(x0 - 3 * se, x0 + 3 * se, 101)
            ax.plot(grid, ((grid - x0) / se) ** 2, "--", color="0.5", label="linearised")
            ax.axhline(3.84, color="C3", lw=0.8, label="95 % threshold")
            for end in ("lower", "upper"):
                ax.axvline(float(ds[f"fit_{f}_profile_{end}"]), color="C2", lw=0.8)
            ax.set_xlabel(f)
            ax.set_ylabel("Δχ²")
            ax.set_ylim(0, 8)
            ax.set_title(f"{f} = {x0:.4g} ± {se:.2g}", fontsize=9)
            ax.legend(fontsize=7, loc="upper right")
        # One legend for the figure: the data panels' entries, then the profiles'.
        handles, labels = [], []
        for ax in axes[0]:
            for h, lab in zip(*ax.get_legend_handles_labels()):
                if lab not in labels:
                    handles.append(h)
                    labels.append(lab)
            if ax.get_legend() is not None:
                ax.get_legend().remove()
        fig.legend(handles, labels, loc="outside lower center", ncols=len(labels), fontsize=7, frameon=False)
        fig.suptitle(f"{name}: χ² = {chi_min:.3g} for {int(ds.fit_dof)} degrees of freedom, "
                     f"{int(ds.search_runs)} runs", fontsize=10)
        fig.tight_layout()
        savefig(fig, f"examples/{name}")


PLOTS = {
    "trimer": trimer,
    "tapered": tapered,
    "disordered": disordered,
    "precompressed": precompressed,
    "dimer-impulse": dimer_impulse,
    "dimer-minimum": dimer_minimum,
    "critical-damping-root": critical_damping_root,
    "fig08-refined": fig08_refined,
    "fig08-surface": fig08_surface,
    "alternating-dimer-minimum": alternating_dimer_minimum,
    "plastic-impact": plastic_impact,
    "dimer-bands": dimer_bands,
    "colliding-waves": colliding_waves,
    "between-walls": between_walls,
    "driven-sweep-up-down": driven_sweep_up_down,
    "driven-branches": driven_branches,
    "dimer-breathers": dimer_breathers,
    "dimer-transmission": dimer_transmission,
    "load-cell-impact": load_cell_impact,
    **{n: (lambda n=n: fit_figure(n)) for n in ("fit-damping", "fit-striker-velocity", "fit-signal", "fit-spectrum")},
    # One figure of the three ensemble sweeps.
    "ensemble-tolerance": lambda: ensemble(),
}


def ensemble():
    """The toleranced 0.55 chain: the distribution of F21/F4 with its quantiles and their
    intervals, the runs Sobol' points took against Monte Carlo for the same intervals, and the
    Sobol' indices of the three uncertainties."""
    import h5py

    def attrs(name):
        with h5py.File(EXAMPLES / f"{name}.h5") as f:
            return {k: f.attrs[k] for k in f.attrs if str(k).startswith("ensemble_")}

    ds = chainsweep.open(EXAMPLES / "ensemble-tolerance.h5")
    sens = chainsweep.open(EXAMPLES / "ensemble-sensitivity.h5")
    sobol, mc = attrs("ensemble-tolerance"), attrs("ensemble-tolerance-monte-carlo")
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(11, 4.2), gridspec_kw={"width_ratios": [3, 2]})
    lo, hi = ds.f21_f4_bin_lower.values, ds.f21_f4_bin_upper.values
    frac = ds.f21_f4_histogram.values
    width = hi - lo
    ax.bar(lo, frac / width, width=width, align="edge", color="C0", alpha=0.6, label="samples (density)")
    err = np.vstack([frac - ds.f21_f4_histogram_lower.values, ds.f21_f4_histogram_upper.values - frac]) / width
    ax.errorbar(0.5 * (lo + hi), frac / width, yerr=err, fmt="none", ecolor="C0", lw=0.8)
    for j, p in enumerate(ds["quantile"].values):
        q = float(ds.f21_f4_quantile[j])
        ql, qh = float(ds.f21_f4_quantile_lower[j]), float(ds.f21_f4_quantile_upper[j])
        ax.axvspan(ql, qh, color="C3", alpha=0.2)
        ax.axvline(q, color="C3", lw=1)
        ax.annotate(f"{p:.0%}", (q, 0.98), xycoords=("data", "axes fraction"), ha="center", va="top", fontsize=8)
    m, ml, mh = (float(ds[f"f21_f4_mean{s}"]) for s in ("", "_lower", "_upper"))
    ax.set_xlabel("F21 / F4 (leading-pulse amplitudes)")
    ax.set_ylabel("probability density")
    ax.set_title(
        f"mean {m:.4f} [{ml:.4f}, {mh:.4f}]\n"
        f"{sobol['ensemble_runs']} Sobol' runs, {mc['ensemble_runs']} Monte Carlo runs, same intervals",
        fontsize=9,
    )
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.2), fontsize=8, frameon=False)
    names = [str(n) for n in sens.input_name.values]
    labels = {"mass_factor": "cylinder masses ±1 %", "striker_velocity_m_s": "striker velocity ±2 %", "damping_kg_s": "damping 6.06 ± 0.36"}
    y = np.arange(len(names))
    for k, (kind, off) in enumerate((("first_order", -0.18), ("total", 0.18))):
        v = sens[f"f21_f4_{kind}"].values
        e = np.vstack([v - sens[f"f21_f4_{kind}_lower"].values, sens[f"f21_f4_{kind}_upper"].values - v])
        bx.barh(y + off, v, height=0.34, xerr=e, color=f"C{k + 1}", label=kind.replace("_", "-"), capsize=2)
    bx.set_yticks(y, [labels.get(n, n) for n in names])
    bx.axvline(0, color="k", lw=0.6)
    bx.set_xlabel("Sobol' index of F21/F4")
    bx.set_title("95 % bootstrap intervals", fontsize=9)
    # Below the axes, never over the bars.
    bx.legend(loc="upper center", bbox_to_anchor=(0.5, -0.2), ncol=2, fontsize=8, frameon=False)
    fig.tight_layout()
    savefig(fig, "examples/ensemble")


def main(names: list[str]):
    for name in names or PLOTS:
        PLOTS[name]()


if __name__ == "__main__":
    main(sys.argv[1:])
