"""chainsweep.plot: the report's figures with matplotlib, from what chainsweep.open reads: a
figure per summary and probe, lines for few outer values, a heatmap for many, failed points
marked, labels a reader can use (names and units, never a leftover coordinate in a title); an
ensemble's histogram and indices. The figures are saved to results/plot/ for a look."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import chainsweep  # noqa: E402
from conftest import run as cli  # noqa: E402
from scenes import sweep_spec, write  # noqa: E402

SHOTS = Path(__file__).resolve().parents[2] / "results" / "plot"


def check(figs, name):
    SHOTS.mkdir(parents=True, exist_ok=True)
    for k, fig in enumerate(figs):
        ax = fig.axes[0]
        assert ax.get_xlabel() and (ax.get_ylabel() or fig.axes[-1].get_ylabel())
        assert "probe_units" not in ax.get_title() and "=" not in ax.get_title().split(" at ")[0]
        assert ax.lines or ax.collections or ax.patches, ax.get_title()
        fig.savefig(SHOTS / f"{name}-{k}.png", dpi=80)
        plt.close(fig)


def test_a_sweep_is_plotted_per_summary_and_probe_with_failures_marked(tmp_path):
    spec = sweep_spec(history=False)
    spec["axes"][1] = {"field": "integrator.rtol", "values": [1e-9, 1e-5]}
    spec["limits"] = {"energy_drift_max": 1e-6}
    path = write(tmp_path / "f.json", spec)
    out = tmp_path / "f.h5"
    assert cli("run", path, "-o", out, "--quiet").returncode == 3
    ds = chainsweep.open(out)
    figs = chainsweep.plot(ds)
    probes = ds.sizes["probe"]
    titles = [f.axes[0].get_title() for f in figs]
    assert any(t.startswith("leading_peak at ") for t in titles)
    assert sum(t.startswith("leading_peak at ") for t in titles) == probes
    # The leading peak's unit is the probe's (N), its time's the second.
    peak = next(f for f in figs if f.axes[0].get_title().startswith("leading_peak at "))
    assert peak.axes[0].get_ylabel().endswith("[N]")
    time_fig = next(f for f in figs if f.axes[0].get_title().startswith("leading_peak_time_s at "))
    assert time_fig.axes[0].get_ylabel().endswith("[s]")
    # Run diagnostics on request only.
    assert not any(t.startswith("wall_time_s") for t in titles)
    runs = chainsweep.plot(ds, runs=True)
    assert any(f.axes[0].get_title().startswith("energy_drift_max") for f in runs)
    check(figs + runs, "failing")


def test_an_ensemble_is_plotted_as_its_histogram_and_indices(tmp_path):
    spec = sweep_spec(history=False)
    spec.pop("axes")
    spec["record"]["stop_after_leading_pulses"] = True
    spec["ensemble"] = {
        "inputs": [{"field": "striker_velocity_m_s", "normal": {"relative_sd": 0.05}},
                   {"field": "physics.damping_kg_s", "uniform": {"min": 0, "max": 4}}],
        "design": "saltelli", "samples": 16,
        "statistics": [{"name": "peak", "of": {"summary": "leading_peak", "probe": spec_probe(spec)}}],
    }
    path = write(tmp_path / "e.json", spec)
    out = tmp_path / "e.h5"
    r = cli("run", path, "-o", out, "--quiet")
    assert r.returncode == 0, r.stderr
    figs = chainsweep.plot(chainsweep.open(out))
    titles = [f.axes[0].get_title() for f in figs]
    assert titles[0].startswith("peak: distribution") and any("first order" in t for t in titles)
    check(figs, "ensemble")


def spec_probe(spec) -> str:
    p = spec["record"]["probes"][0]
    return f"{p['kind']}_cyl{p['cylinder']}"


def test_searches_fits_and_branches_are_plotted_with_labels_inside_the_figure(tmp_path):
    """A search's evaluations; a fit's data (±σ) against its best fit with the normalised
    residuals, and each field's profile χ²; branches of periodic orbits, stable solid and
    unstable dashed: every figure drawn, labelled without a dotted path or the file's
    bookkeeping, and no text past its edges (the shipped figures' own check)."""
    import json
    import re
    import sys

    from scenes import REPO

    sys.path.insert(0, str(REPO / "scripts"))
    import chainplot

    branches = json.loads(chainsweep.example_path("examples/driven-branches").read_text())
    branches["axes"][0]["values"] = [1e-10, 6e-8]
    cases = {
        "fit-signal": (chainsweep.example_path("examples/fit-signal"), 4),
        "fit-damping": (chainsweep.example_path("examples/fit-damping"), 3),
        "dimer-minimum": (chainsweep.example_path("examples/dimer-minimum"), 1),
        "driven-branches": (write(tmp_path / "branches.json", branches), 1),
    }
    for name, (path, expected) in cases.items():
        out = tmp_path / f"{name}.h5"
        assert cli("run", path, "-o", out, "--quiet").returncode == 0, name
        figs = chainsweep.plot(chainsweep.open(out))
        assert len(figs) == expected, (name, [f.axes[0].get_title() for f in figs])
        SHOTS.mkdir(parents=True, exist_ok=True)
        for k, fig in enumerate(figs):
            texts = [t for ax in fig.axes for t in (ax.get_xlabel(), ax.get_ylabel(), ax.get_title())]
            assert any(ax.get_xlabel() for ax in fig.axes), (name, texts)
            for t in texts:
                assert not re.search(r"[a-z_]+\.[a-z_]+\.[a-z_]", t) and "probe_units" not in t, (name, t)
            assert all(ax.lines or ax.collections or ax.patches for ax in fig.axes), (name, texts)
            assert chainplot.texts_outside(fig) == [], (name, chainplot.texts_outside(fig))
            fig.savefig(SHOTS / f"{name}-{k}.png", dpi=80)
            plt.close(fig)
    # The branches' figure: the large stroke's unstable part dashed between its two folds.
    ds = chainsweep.open(tmp_path / "driven-branches.h5")
    fig = chainsweep.plot(ds)[0]
    styles = {line.get_linestyle() for line in fig.axes[0].lines}
    assert {"-", "--"} <= styles, styles
    plt.close(fig)
