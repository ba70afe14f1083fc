"""`chainsweep report`: one self-contained page per output file, loaded in a real headless
browser (Debian's Chromium, installed by `make test`): no console error, every figure the
command reports present and drawn, nothing fetched from outside, a screenshot of plausible size;
failed points marked with their reasons; a 100 000-point sweep's page in seconds and under a few
MB. The screenshots stay in results/report/ for a look.
"""

from __future__ import annotations

import re
import shutil
import struct
import subprocess
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

from conftest import BIN, REPO, base_sweep, run, write_sweep

CHROMIUM = shutil.which("chromium") or "/usr/bin/chromium"
SHOTS = REPO / "results" / "report"


def browser(page: Path, *args: str) -> subprocess.CompletedProcess:
    assert Path(CHROMIUM).exists(), "chromium not found: `make test` installs it (Debian's chromium)"
    return subprocess.run(
        [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
         "--enable-logging=stderr", "--v=0", "--no-first-run", *args, page.resolve().as_uri()],
        capture_output=True, text=True, timeout=120)


def png_size(path: Path) -> tuple[int, int]:
    head = path.read_bytes()[:24]
    assert head[:8] == b"\x89PNG\r\n\x1a\n"
    return struct.unpack(">II", head[16:24])


def check_page(page: Path, figures: int, shot: Path):
    html = page.read_text()
    # Self-contained: nothing to fetch (the SVG namespace is a name, not a link).
    assert not re.search(r"""(src|href)\s*=\s*["'](?!#)""", html), "the page links outside itself"
    assert "<script" not in html
    dom = browser(page, "--dump-dom")
    assert dom.returncode == 0, dom.stderr
    console = [l for l in dom.stderr.splitlines() if "CONSOLE" in l or "Uncaught" in l]
    assert not console, console
    # Every figure the command counted is in the page and drawn (marks, not just a frame).
    svgs = re.findall(r"<svg.*?</svg>", dom.stdout, flags=re.S)
    assert len(svgs) == figures > 0, (len(svgs), figures)
    for s in svgs:
        marks = len(re.findall(r"<(path|circle|rect)\b", s))
        assert marks >= 3, s[:300]
    SHOTS.mkdir(parents=True, exist_ok=True)
    r = browser(page, f"--screenshot={shot}", "--window-size=1280,2000")
    assert r.returncode == 0 and shot.exists(), r.stderr
    w, h = png_size(shot)
    assert (w, h) == (1280, 2000)
    assert shot.stat().st_size > 20_000, "the screenshot is nearly blank"


def report(out: Path, page: Path) -> int:
    r = run("report", out, "-o", page)
    assert r.returncode == 0, r.stderr
    m = re.search(r"(\d+) figure", r.stderr)
    assert m, r.stderr
    return int(m.group(1))


def failing():
    """Three mass ratios at two tolerances: the rtol 1e-5 runs drift by about 1e-4 of the impact
    energy, over the limit 1e-6, and fail with that reason."""
    s = base_sweep()
    s["axes"] = [
        {"field": "chain.cylinder.mass.heavy_cylinders.mass_ratio", "values": [0.3, 0.55, 1.0]},
        {"field": "integrator.rtol", "values": [1e-9, 1e-5]},
    ]
    s["limits"] = {"energy_drift_max": 1e-6}
    s["record"]["history"] = False
    return s


@pytest.mark.parametrize("kind", ["lines", "failed", "heatmap", "ensemble"])
def test_a_report_loads_in_a_browser_with_every_figure_drawn(tmp_path, kind):
    if kind == "lines":
        s = base_sweep()
        s["record"]["history"] = False
    elif kind == "failed":
        s = failing()
    elif kind == "heatmap":
        s = base_sweep(cylinders=4, duration_s=1e-4, probes=(2, 4))
        s["record"]["history"] = False
        s["axes"] = [
            {"field": "striker_velocity_m_s", "range": {"start": 0.5, "stop": 2.0, "num": 12}},
            {"field": "physics.damping_kg_s", "range": {"start": 0, "stop": 10, "num": 12}},
        ]
    else:
        s = base_sweep(cylinders=4, duration_s=1e-4)
        s["record"] = {"probes": [{"kind": "gauge_force", "cylinder": 3}], "stop_after_leading_pulses": True}
        s.pop("axes")
        s["ensemble"] = {
            "inputs": [{"field": "striker_velocity_m_s", "normal": {"relative_sd": 0.05}},
                       {"field": "physics.damping_kg_s", "uniform": {"min": 0, "max": 4}}],
            "design": "saltelli", "samples": 16,
            "statistics": [{"name": "peak", "of": {"summary": "leading_peak", "probe": "gauge_force_cyl3"}}],
        }
    path = write_sweep(tmp_path / f"{kind}.json", s)
    out = tmp_path / f"{kind}.h5"
    r = run("run", path, "-o", out, "--quiet")
    assert r.returncode in (0, 3), r.stderr
    page = tmp_path / f"{kind}.html"
    figures = report(out, page)
    check_page(page, figures, SHOTS / f"{kind}.png")
    html = page.read_text()
    if kind == "failed":
        # The failed points are listed with their axis values and reason, and marked in the
        # figures with the reason as a tooltip.
        assert "Failed runs" in html and "rtol=0.00001" in html and "energy drift" in html
        assert 'class="missing"' in html
    if kind == "heatmap":
        assert html.count("<rect") > 144
    if kind == "ensemble":
        assert "Sobol&#x27; indices" in html or "Sobol' indices" in html
        assert "ended by: fixed" in html


@pytest.mark.parametrize("example", ["fit-signal", "fit-damping", "dimer-minimum"])
def test_searches_and_fits_are_drawn_with_their_data(tmp_path, example):
    """A search's every evaluation against its field, with the answers; a fit's data (±σ) against
    its best fit, the residuals over σ, and each field's profile χ²."""
    shutil.copytree(REPO / "sweeps" / "examples", tmp_path / "examples")
    out = tmp_path / f"{example}.h5"
    r = run("run", tmp_path / "examples" / f"{example}.json", "-o", out, "--quiet", timeout=600)
    assert r.returncode == 0, r.stderr
    page = tmp_path / f"{example}.html"
    figures = report(out, page)
    check_page(page, figures, SHOTS / f"{example}.png")
    html = page.read_text()
    assert "<h2>Evaluations</h2>" in html and "every point the search evaluated" in html
    if example == "dimer-minimum":
        # One curve per search (a point of the damping axis), each answer in the caption.
        assert "damping_kg_s=0" in html and "damping_kg_s=5" in html
        assert html.count("found: minimum") == 1 and html.count("minimum 0.001") == 2
        return
    assert "<h2>Fit: data and best fit</h2>" in html
    assert "measured ± σ" in html and "best fit" in html and "residuals" in html
    assert "profile of damping_kg_s" in html and "95 % profile interval" in html
    if example == "fit-signal":
        for signal in ("signal_gauge_force_cyl5", "signal_gauge_force_cyl21"):
            assert f"{signal} (gauge_force_" in html
        # The fit records histories: the best evaluation's are drawn (the smallest χ² of the
        # ok runs), not the first's.
        with h5py.File(out, "r") as f:
            objective = f["objective"][()].ravel()
            ok = f["status"][()].ravel() == 1
        best = int(np.nanargmin(np.where(ok, objective, np.nan)))
        assert best != 0
        assert "<h2>Histories</h2>" in html and f"history at point {best}" in html
        assert "The evaluation with the best objective" in html
    else:
        # The three measured ratios, each named on the axis, drawn against their measured values
        # (scalars of any units and sizes on one axis).
        assert "measured scalars" in html
        for name in ("A5_over_A4", "A15_over_A4", "A21_over_A4"):
            assert name in html
        assert "relative to the measured value" in html


def three_spheres_driven(settle_periods: int) -> dict:
    """Three spheres between two walls shaken by the top wall at five frequencies, their steady
    state recorded after `settle_periods` drive periods (5, within the drive's ramp of 20: not
    settled; 200: settled)."""
    ball = {"sphere": {"diameter_m": 0.008, "mass_kg": 0.002085,
                       "material": {"youngs_modulus_pa": 2e11, "poisson_ratio": 0.28}}}
    steel = {"youngs_modulus_pa": 1.93e11, "poisson_ratio": 0.29}
    return {
        "description": "three spheres shaken between two walls",
        "base": {
            "chain": {"particles": {"ball": ball}, "sequence": [{"repeat": 3, "of": ["ball"]}],
                      "wall_material": steel, "top_wall_material": steel},
            "physics": {"gravity": False, "damping_kg_s": 3.0, "wall": True, "precompression_force_n": 2.0},
            "excitation": {"drive": {"actuator_m": {"harmonic": {"amplitude": 1.5e-9, "frequency_hz": 2900.0,
                                                                 "ramp_periods": 20}}}},
            "duration_s": 0.2,
            "integrator": {"method": "dop853", "rtol": 1e-9},
        },
        "record": {"probes": [{"kind": "wall_force"}], "preload": "subtract", "history": True,
                   "history_interval_s": 1e-5,
                   "steady_state": {"settle_periods": settle_periods, "window_periods": 4, "harmonics": 2}},
        "axes": [{"field": "excitation.drive.actuator_m.harmonic.frequency_hz",
                  "values": [2000.0, 2500.0, 3000.0, 3500.0, 4000.0]}],
    }


def test_steady_states_are_drawn_as_their_fundamental_and_unsettled_ones_never_as_numbers(tmp_path):
    """A settled sweep's page draws the steady amplitude (its fundamental) against the drive's
    frequency; an unsettled sweep's steady values are marked missing with the reason, never drawn
    as numbers, while its histories (which show why) are still drawn."""
    pages = {}
    for settle in (200, 5):
        s = three_spheres_driven(settle)
        path = write_sweep(tmp_path / f"d{settle}.json", s)
        out = tmp_path / f"d{settle}.h5"
        r = run("run", path, "-o", out, "--quiet")
        assert r.returncode == (0 if settle == 200 else 3), r.stderr
        page = tmp_path / f"d{settle}.html"
        r = run("report", out, "-o", page, "--point", "2")
        assert r.returncode == 0, r.stderr
        pages[settle] = page.read_text()
    assert "steady_amplitude (fundamental) at wall_force" in pages[200]
    assert "did not settle" not in pages[200]
    unsettled = pages[5]
    assert "steady_amplitude" not in unsettled and "steady_rms" not in unsettled
    # How far from settled is itself drawn.
    assert "steady_settledness at wall_force" in unsettled
    assert "no history" not in unsettled and "history at point 2" in unsettled


def test_a_damaged_point_is_listed_and_never_drawn(tmp_path):
    """A summary changed in the file (its checksum no longer matches): the page lists the point
    under Health as damaged and marks it missing in every figure, never drawing its value."""
    s = base_sweep()
    s["record"]["history"] = False
    path = write_sweep(tmp_path / "d.json", s)
    out = tmp_path / "d.h5"
    assert run("run", path, "-o", out, "--quiet").returncode == 0
    with h5py.File(out, "r+") as f:
        energy = f["impact_energy_j"][()]
        energy.flat[2] = 123.0
        f["impact_energy_j"][...] = energy
    page = tmp_path / "d.html"
    assert run("report", out, "-o", page).returncode == 0
    html = page.read_text()
    assert "Damaged runs" in html
    assert "point 2: its stored values are damaged" in html
    # The impact energy's figure spans the intact points' millijoules, not the 123 J put there.
    figure = next(f for f in html.split("<figure")[1:] if "impact_energy_j against" in f)
    ticks = [float(x) for x in re.findall(r'text-anchor="end">(-?[0-9.]+(?:e[-+]?[0-9]+)?)</text>', figure)]
    assert ticks and max(ticks) < 1.0, ticks


def test_points_verify_did_not_sample_are_said_to_be_so(tmp_path):
    """The verified error's figure marks the points --verify did not sample as such, not as
    runs that gave no number."""
    s = base_sweep()
    s["record"]["history"] = False
    path = write_sweep(tmp_path / "v.json", s)
    out = tmp_path / "v.h5"
    assert run("run", path, "-o", out, "--quiet", "--verify", "0.4").returncode == 0
    page = tmp_path / "v.html"
    assert run("report", out, "-o", page).returncode == 0
    figure = next(f for f in page.read_text().split("<figure")[1:] if "verify_rel_error_max against" in f)
    assert re.search(r"not in --verify(&#x27;|')s sample", figure), figure[:2000]
    assert "gives no number" not in figure


def test_histories_of_chosen_points(tmp_path):
    path = write_sweep(tmp_path / "h.json", base_sweep(history=True))
    out = tmp_path / "h.h5"
    assert run("run", path, "-o", out, "--quiet").returncode == 0
    page = tmp_path / "h.html"
    r = run("report", out, "-o", page, "--point", "1", "--point", "4")
    assert r.returncode == 0, r.stderr
    html = page.read_text()
    assert "history at point 1" in html and "history at point 4" in html
    assert "history at point 0" not in html
    figures = int(re.search(r"(\d+) figure", r.stderr).group(1))
    check_page(page, figures, SHOTS / "histories.png")
    # A point the file does not have is refused naming the option, and nothing is written.
    page.unlink()
    r = run("report", out, "-o", page, "--point", "6")
    assert r.returncode == 2 and "--point" in r.stderr and "0 to 5" in r.stderr, r.stderr
    assert not page.exists()
    # A shard's file holds every point of the grid: --point takes any of them (its own runs
    # are a third of them).
    shard = tmp_path / "h.shard.h5"
    assert run("run", path, "-o", shard, "--shard", "2/3", "--quiet").returncode == 0
    r = run("report", shard, "-o", page, "--point", "5")
    assert r.returncode == 0, r.stderr


def test_figures_alone_as_svg_files(tmp_path):
    """--format svg: each figure of the page alone, a well-formed SVG document, with its caption;
    a folder holding anything else is refused naming --output, and nothing is written."""
    import xml.etree.ElementTree as ET
    path = write_sweep(tmp_path / "s.json", base_sweep(history=True))
    out = tmp_path / "s.h5"
    assert run("run", path, "-o", out, "--quiet").returncode == 0
    page = tmp_path / "s.html"
    figures = report(out, page)
    r = run("report", out, "--format", "svg")
    assert r.returncode == 0, r.stderr
    folder = tmp_path / "s-figures"
    svgs = sorted(folder.glob("*.svg"))
    assert len(svgs) == figures
    captions = (folder / "captions.txt").read_text().splitlines()
    assert [c.split("\t")[0] for c in captions] == [p.name for p in svgs]
    html = page.read_text()
    for p in svgs:
        root = ET.parse(p).getroot()
        assert root.tag == "{http://www.w3.org/2000/svg}svg"
        assert len(list(root.iter())) > 20
        assert ET.tostring(root, encoding="unicode").count("<") > 20
    assert all(c.split("\t")[1] in html for c in captions)
    # Again: the figures replaced, nothing left over; a folder with other files refused.
    assert run("report", out, "--format", "svg").returncode == 0
    assert sorted(folder.glob("*.svg")) == svgs
    # Past 99 figures the names take three digits, and are still the report's own.
    (folder / "100-a-figure.svg").write_text("<svg/>")
    assert run("report", out, "--format", "svg").returncode == 0
    assert not (folder / "100-a-figure.svg").exists()
    other = tmp_path / "other"
    other.mkdir()
    (other / "notes.txt").write_text("mine")
    r = run("report", out, "--format", "svg", "-o", other)
    assert r.returncode == 2 and "--output" in r.stderr, r.stderr
    assert [p.name for p in other.iterdir()] == ["notes.txt"]


def test_figures_alone_as_png_and_pdf(tmp_path):
    """--format png|pdf: each figure drawn from its SVG with the embedded font: a PNG twice the
    figure's size with its title's text inked, a one-page PDF of the figure's size with the font
    embedded; a user's own PDF in the folder is never taken for a figure (refused, kept)."""
    import xml.etree.ElementTree as ET

    import numpy as np
    from PIL import Image

    path = write_sweep(tmp_path / "s.json", base_sweep(history=True))
    out = tmp_path / "s.h5"
    assert run("run", path, "-o", out, "--quiet").returncode == 0
    assert run("report", out, "--format", "svg", "-o", tmp_path / "svg").returncode == 0
    svgs = sorted((tmp_path / "svg").glob("*.svg"))
    sizes = [tuple(int(ET.parse(p).getroot().get(k)) for k in ("width", "height")) for p in svgs]
    for fmt in ("png", "pdf"):
        r = run("report", out, "--format", fmt, "-o", tmp_path / fmt)
        assert r.returncode == 0, r.stderr
        files = sorted((tmp_path / fmt).glob(f"*.{fmt}"))
        assert [p.stem for p in files] == [p.stem for p in svgs]
        captions = (tmp_path / fmt / "captions.txt").read_text().splitlines()
        assert [c.split("\t")[0] for c in captions] == [p.name for p in files]
        for p, (w, h) in zip(files, sizes):
            if fmt == "png":
                assert png_size(p) == (2 * w, 2 * h), p
                ink = np.asarray(Image.open(p).convert("L")) < 100
                # The title (drawn at y = 18 px, 13 px high) is text, which needs the font.
                assert ink[2 * 4 : 2 * 24].sum() > 100, f"{p.name}: no title drawn"
                assert 0.002 < ink.mean() < 0.5, f"{p.name}: {ink.mean():.4f} of the image inked"
            else:
                pdf = p.read_bytes()
                assert pdf.startswith(b"%PDF-") and pdf.count(b"/Type /Page\n") + pdf.count(b"/Type /Page ") + pdf.count(b"/Type /Page/") >= 1
                box = re.search(rb"/MediaBox \[\s*0 0 ([0-9.]+) ([0-9.]+)\s*\]", pdf)
                assert box and (float(box[1]), float(box[2])) == (w * 0.75, h * 0.75), (p.name, box)
                assert b"/FontFile2" in pdf, f"{p.name}: its font is not embedded"
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "paper.pdf").write_bytes(b"%PDF-1.7 mine")
    r = run("report", out, "--format", "pdf", "-o", mine)
    assert r.returncode == 2 and "--output" in r.stderr, r.stderr
    assert (mine / "paper.pdf").read_bytes() == b"%PDF-1.7 mine" and len(list(mine.iterdir())) == 1


def test_a_100000_point_sweep_reports_in_seconds_and_small(tmp_path):
    law = {"power_law": {"coefficient": 1e6, "exponent": 1.0}}
    s = {
        "description": "a linear chain's lowest frequency over 100 000 precompressions",
        "base": {
            "chain": {
                "particles": {"ball": {"sphere": {"diameter_m": 0.008, "mass_kg": 0.002,
                                                  "material": {"youngs_modulus_pa": 2e11, "poisson_ratio": 0.3}}}},
                "sequence": [{"repeat": 3, "of": ["ball"]}],
                "contacts": [{"between": ["ball", "ball"], "law": law}, {"between": ["ball", "wall"], "law": law}],
            },
            "physics": {"gravity": False, "damping_kg_s": 0.0, "wall": True, "precompression_force_n": 1.0},
            "excitation": {"impulse": {"velocity_m_s": 0.01}},
            "duration_s": 0.001,
        },
        "record": {"spectrum": {}},
        "axes": [{"field": "physics.precompression_force_n", "range": {"start": 1.0, "stop": 100000.0, "num": 100000}}],
    }
    path = write_sweep(tmp_path / "big.json", s)
    out = tmp_path / "big.h5"
    assert run("run", path, "-o", out, "--quiet", timeout=600).returncode == 0
    page = tmp_path / "big.html"
    t = time.perf_counter()
    figures = report(out, page)
    elapsed = time.perf_counter() - t
    size = page.stat().st_size
    print(f"100 000-point report: {elapsed:.2f} s, {size / 1e6:.2f} MB, {figures} figures")
    assert elapsed < 20 and size < 3e6
    html = page.read_text()
    assert "Thinned for the page" in html and "every 50th of 100000 points" in html
    check_page(page, figures, SHOTS / "big.png")


def test_bad_report_requests_exit_2_and_write_nothing(tmp_path):
    sweep = write_sweep(tmp_path / "s.json", base_sweep())
    r = run("report", sweep, "-o", tmp_path / "p.html")
    assert r.returncode == 2 and "not a chainsweep output file" in r.stderr, r.stderr
    assert not (tmp_path / "p.html").exists()
    r = run("report", tmp_path / "missing.h5")
    assert r.returncode == 2, r.stderr
    out = tmp_path / "s.h5"
    assert run("run", sweep, "-o", out, "--quiet").returncode == 0
    r = run("report", out, "-o", tmp_path / "no-such-dir" / "p.html")
    assert r.returncode == 2 and "--output" in r.stderr, r.stderr
    r = run("report", out, "-o", out)
    assert r.returncode == 2 and "--output" in r.stderr, r.stderr
    assert run("status", out).returncode == 0  # the output file is untouched
    # Never over a file the report did not write (the sweep file given by mistake), a read-only
    # page, or a directory: --output named, the file as it was, no temporary left.
    text = sweep.read_text()
    r = run("report", out, "-o", sweep)
    assert r.returncode == 2 and "--output" in r.stderr and "not a report" in r.stderr, r.stderr
    assert sweep.read_text() == text
    page = tmp_path / "p.html"
    page.write_text("")  # an empty file (mktemp's) holds nothing to lose
    assert run("report", out, "-o", page).returncode == 0
    assert run("report", out, "-o", page).returncode == 0  # its own page: replaced
    page.chmod(0o444)
    r = run("report", out, "-o", page)
    assert r.returncode == 2 and "read-only" in r.stderr, r.stderr
    folder = tmp_path / "figs"
    folder.mkdir()
    r = run("report", out, "-o", folder)
    assert r.returncode == 2 and "--output" in r.stderr and "directory" in r.stderr, r.stderr
    assert not list(tmp_path.glob("*.tmp"))
    # --watch of a file no sweep writes yet says it waits (it waited silently).
    p = subprocess.Popen([str(BIN), "report", str(tmp_path / "later.h5"), "--watch"],
                         stderr=subprocess.PIPE, text=True)
    time.sleep(1.0)
    p.terminate()
    assert "waiting for" in p.communicate()[1]


def test_watch_refreshes_the_page_until_the_sweep_ends(tmp_path):
    s = base_sweep(cylinders=40, duration_s=0.1)
    s["record"]["history"] = False
    path = write_sweep(tmp_path / "w.json", s)
    out = tmp_path / "w.h5"
    page = tmp_path / "w.html"
    runner = subprocess.Popen([str(BIN), "run", str(path), "-o", str(out),
                               "--quiet", "--jobs", "1", "--checkpoint-interval", "0.2"])
    deadline = time.monotonic() + 60
    while not out.exists() and time.monotonic() < deadline:
        time.sleep(0.01)
    watcher = subprocess.Popen([str(BIN), "report", str(out), "-o", str(page),
                                "--watch", "--interval", "0.3"], stderr=subprocess.PIPE, text=True)
    assert runner.wait(timeout=300) == 0
    _, err = watcher.communicate(timeout=60)
    assert watcher.returncode == 0, err
    # It wrote the page while the sweep ran, and once more after it had ended: all six ok.
    assert err.count("figure") >= 2, err
    assert "<th>ok</th><td>6</td>" in page.read_text()
