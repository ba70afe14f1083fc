"""The figures' layout (scripts/chainplot.py): a journal width, lettering readable there, vector
PDF with TrueType fonts beside the PNG, and the same bytes for the same figure."""

import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import matplotlib.text  # noqa: E402

from conftest import REPO  # noqa: E402

sys.path.insert(0, str(REPO / "scripts"))
import chainplot  # noqa: E402


def wide_figure():
    """Three panels 15 inches wide with 6 pt labels: 2.6 pt if shrunk to a page's width."""
    fig, axes = plt.subplots(1, 3, figsize=(15, 5))
    for k, ax in enumerate(axes):
        ax.plot([0, 1, 2], [k, k + 1, k * k], label=f"curve {k}", lw=2.5, marker="o", ms=9)
        ax.text(1, k, f"label {k}", fontsize=6)
        ax.set_xlabel("time, ms")
        ax.set_title(f"panel {k}", fontsize=12)
        ax.legend(fontsize=8)
    return fig


def test_journal_layout_makes_every_text_readable_at_its_printed_width():
    fig = wide_figure()
    width = chainplot.journal_layout(fig)
    assert width == chainplot.PAGE_IN and abs(fig.get_size_inches()[0] - chainplot.PAGE_IN) < 1e-9
    fig.canvas.draw()  # tick labels as they are drawn
    sizes = {t.get_text(): t.get_fontsize() for t in fig.findobj(matplotlib.text.Text) if t.get_text().strip()}
    assert "0.0" in sizes or "0" in sizes  # tick labels are among them
    assert min(sizes.values()) >= chainplot.MIN_PT and max(sizes.values()) <= chainplot.MAX_PT
    # Larger stays larger: a title over a label over an annotation.
    assert sizes["panel 0"] > sizes["time, ms"] >= sizes["label 0"]
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(6, 4))
    ax.plot([0, 1], [0, 1])
    assert chainplot.journal_layout(fig) == chainplot.COLUMN_IN
    plt.close(fig)


def test_savefig_writes_pdf_and_png_with_the_same_bytes_each_time(tmp_path, monkeypatch):
    monkeypatch.setattr(chainplot, "RESULTS", tmp_path)
    chainplot.savefig(wide_figure(), "a")
    chainplot.savefig(wide_figure(), "b")
    for ext in ("pdf", "png"):
        a, b = (tmp_path / f"a.{ext}").read_bytes(), (tmp_path / f"b.{ext}").read_bytes()
        assert a == b, ext
    pdf = (tmp_path / "a.pdf").read_bytes()
    assert pdf.startswith(b"%PDF") and b"/FontFile2" in pdf  # TrueType embedded, not Type 3
    assert b"/Type3" not in pdf and b"CreationDate" not in pdf
    png = (tmp_path / "a.png").read_bytes()
    from PIL import Image

    with Image.open(tmp_path / "a.png") as im:
        assert abs(im.size[0] - chainplot.PAGE_IN * chainplot.PNG_DPI) <= 2
    assert png.startswith(b"\x89PNG")


def covered_figure(where: str):
    """A panel whose data fill the upper right corner (where == "corner") or every corner and
    side (where == "everywhere"), with a legend asked for at the upper right."""
    import numpy as np
    fig, ax = plt.subplots(figsize=(4, 3))
    x = np.linspace(0, 1, 200)
    if where == "corner":
        ax.plot(x, x ** 4, label="rising")
    else:
        for k, y in enumerate(np.linspace(0, 1, 9)):
            ax.plot(x, np.full_like(x, y), label=f"level {k}" if k < 2 else None)
        ax.plot(np.full(50, 0.5), np.linspace(0, 1, 50))
        for xx in (0.0, 0.1, 0.2, 0.3, 0.7, 0.8, 0.9, 1.0):
            ax.plot(np.full(50, xx), np.linspace(0, 1, 50))
    ax.set_title("data")
    ax.legend(loc="upper right")
    return fig


def test_a_legend_over_data_moves_to_an_empty_corner_or_out_of_the_panel(tmp_path, monkeypatch):
    monkeypatch.setattr(chainplot, "RESULTS", tmp_path)
    fig = covered_figure("corner")
    assert chainplot.legends_covering_data(fig) == ["data"]  # as asked, it covers the curve
    moved = chainplot.place_legends(fig)
    assert moved and "upper right" not in moved[0]
    assert chainplot.legends_covering_data(fig) == []
    plt.close(fig)
    fig = covered_figure("everywhere")
    assert chainplot.place_legends(fig) == ["data: legend under the figure"]
    assert chainplot.legends_covering_data(fig) == [] and len(fig.legends) == 1
    plt.close(fig)
    # savefig places and checks every legend of what it writes.
    chainplot.savefig(covered_figure("corner"), "covered")
    assert (tmp_path / "covered.png").stat().st_size > 1000


def test_a_wrapped_title_never_leaves_a_word_alone():
    title = "Leading pulse attenuation of the strongly nonlinear dissipative chain at every damping"
    for width in (1.5, 2.0, 2.5, 3.0, 3.5):
        lines = chainplot._wrap(title, width, 9).split("\n")
        assert len(lines) > 1 and all(len(line.split()) > 1 for line in lines), (width, lines)
        assert " ".join(lines) == title


def test_a_label_longer_than_the_figure_is_wrapped_not_clipped(tmp_path, monkeypatch):
    monkeypatch.setattr(chainplot, "RESULTS", tmp_path)
    fig, ax = plt.subplots(figsize=(4, 2))
    ax.plot([0, 1], [0, 1])
    ax.set_ylabel("speed of the leading pulse between contacts 11 and 31 of the chain (m/s)", fontsize=14)
    chainplot.journal_layout(fig)
    assert chainplot.texts_outside(fig)  # as asked, the label is taller than the figure
    chainplot.fit_long_labels(fig)
    assert "\n" in ax.get_ylabel() and chainplot.texts_outside(fig) == []
    plt.close(fig)
