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
