"""Shared helpers for the figure and paper-check scripts: chainsweep result files read through
``chainsweep.open`` (the package's reader, checksums checked), selected by axis name and value.

Every sweep file `sweeps/NAME.json` is run into `results/NAME.h5` (see the Makefile's `figures`
target). The helpers find axes by the dimension each coordinate lies on, so the scripts never
depend on the order of the axes in a sweep file, and they are NaN-aware: a failed run (status 2)
has NaN in every summary and no history.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

import chainsweep

REPO = Path(__file__).resolve().parent.parent
RESULTS = Path(os.environ.get("CHAINSWEEP_RESULTS", REPO / "results"))

# One colour per chain throughout (the paper's Figs. 15-19: 0.98 blue, 0.55 red).
COLOR_098 = "tab:blue"
COLOR_055 = "tab:red"
MU_COLORS = {0: "black", 4: "tab:green", 6: "tab:red", 10: "tab:orange", 15: "tab:purple", 100: "tab:brown"}


def mu_label(mu: float) -> str:
    """Legend text for a damping coefficient, as the paper writes it."""
    return f"μ = {mu:g} kg/s" if mu else "μ = 0"


class Sweep:
    """A chainsweep result file, read through ``chainsweep.open``, with selection of grid points
    by axis name and value (what the figure scripts need on top of the Dataset)."""

    def __init__(self, name_or_path: str | Path):
        p = Path(name_or_path)
        if p.suffix != ".h5":
            p = RESULTS / f"{p.name}.h5"
        if not p.exists():
            raise FileNotFoundError(f"{p}: run `make figures` first (it runs sweeps/{p.stem}.json)")
        self.path = p
        self.ds = chainsweep.open(p)
        self._with_histories = None  # the same with every history, read when one is asked for
        self.dims: list[str] = json.loads(self.ds.attrs["dimensions"])
        self.shape = tuple(int(n) for n in np.atleast_1d(self.ds.attrs["grid_shape"]))
        self.probes: list[str] = [str(p) for p in self.ds.probe.values] if "probe" in self.ds.coords else []
        self.base = json.loads(self.ds.attrs["base_scene"])
        self.status = self.ds.status.values
        # every coordinate over one grid dimension (zipped ones included) -> that dimension
        self._coord_dim: dict[str, int] = {
            name: self.dims.index(c.dims[0])
            for name, c in self.ds.coords.items()
            if c.ndim == 1 and c.dims[0] in self.dims
        }

    def close(self):
        self.ds.close()
        if self._with_histories is not None:
            self._with_histories.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    # ------------------------------------------------------------------ coordinates
    def coord(self, name: str) -> np.ndarray:
        """Values of a coordinate (axis) by name."""
        return self.ds[name].values

    def index(self, name: str, value) -> int:
        """Grid index of `value` along the axis that carries coordinate `name`."""
        c = self.coord(name)
        if c.dtype.kind in "OUS":
            hits = [i for i, v in enumerate(c) if v == value]
        elif c.dtype == bool:
            hits = [i for i, v in enumerate(c) if bool(v) == bool(value)]
        else:
            hits = list(np.nonzero(np.isclose(c.astype(float), float(value), rtol=1e-9, atol=1e-12))[0])
        if not hits:
            raise KeyError(f"{self.path.name}: {name} has no value {value!r} (values: {list(c)})")
        return int(hits[0])

    def _isel(self, **sel) -> dict[str, int]:
        """The grid dimensions fixed by a selection by coordinate values, as xarray's isel."""
        return {self.dims[self._coord_dim[name]]: self.index(name, value) for name, value in sel.items()}

    # ------------------------------------------------------------------ summaries
    def summary(self, dataset: str, probe: str | None = None, **sel) -> np.ndarray:
        """A grid dataset (leading_peak, record_max, t_end_s, …) at the selected grid points,
        for one probe where the dataset has a probe dimension. Failed runs give NaN."""
        v = self.ds[dataset].isel(self._isel(**sel))
        if "probe" in v.dims and probe is not None:
            v = v.sel(probe=probe)
        return v.values

    def peaks(self, probes: list[str], dataset: str = "leading_peak", **sel) -> np.ndarray:
        """Peaks of several probes at one grid point: shape (len(probes),)."""
        v = self.summary(dataset, **sel)
        return np.array([v[..., self.probes.index(p)] for p in probes], dtype=float)

    # ------------------------------------------------------------------ histories
    def history(self, **sel) -> dict[str, np.ndarray] | None:
        """Full histories of one grid point (every axis selected): {'time_s': …, probe: …,
        'min_overlap_m': …}; None when the run failed or recorded none."""
        isel = self._isel(**sel)
        if set(isel) != set(self.dims):
            raise ValueError(f"select every axis of {self.dims} for a history")
        if self.ds.status.isel(isel).item() != 1:
            return None
        if self._with_histories is None:
            self._with_histories = chainsweep.open(self.path, histories=True)
        at = self._with_histories.isel(isel)
        out: dict[str, np.ndarray] = {}
        if "history" in at:
            h = at.history.values  # (probe, time): NaN after the run's end
            t = at.time_s.values
            n = int(np.max(np.nonzero(np.isfinite(t) & np.isfinite(h).any(axis=0))[0], initial=-1)) + 1
            if n == 0:
                return None
            out["time_s"] = t[:n]
            for k, name in enumerate(self.probes):
                out[name] = h[k, :n]
        if "min_overlap_m" in at:
            m = at.min_overlap_m.values  # (contact,): NaN past this chain's contacts
            out["min_overlap_m"] = m[: int(np.max(np.nonzero(np.isfinite(m))[0], initial=-1)) + 1]
        return out or None

    def failures(self) -> list[str]:
        bad = np.argwhere(self.status == 2)
        reasons = self.ds.reason.values
        return [f"{tuple(int(i) for i in b)}: {reasons[tuple(b)]}" for b in bad]


# ---------------------------------------------------------------------- chains and masses
def sphere_mass(sw: Sweep) -> float:
    return float(sw.base["chain"]["sphere"]["mass_kg"])


def cylinder_mass(spec, m_s: float) -> float:
    """Cylinder mass, kg, from a `chain.cylinder.mass` value (dict or JSON string)."""
    if isinstance(spec, str):
        spec = json.loads(spec)
    (kind, v), = spec.items()
    if kind == "explicit":
        return float(v["mass_kg"])
    if kind == "heavy_cylinders":
        return m_s / float(v["mass_ratio"])
    if kind == "light_cylinders":
        return m_s * float(v["mass_ratio"])
    raise ValueError(f"unknown cylinder mass {spec}")


def chain_label(m_c: float, m_s: float) -> str:
    eps = min(m_c, m_s) / max(m_c, m_s)
    if abs(eps - 0.98) < 0.01:
        return "0.98"
    kind = "heavy cylinders" if m_c > m_s else "light cylinders"
    return f"{eps:.2f} ({kind})"


def chains(sw: Sweep) -> list[dict]:
    """The chains of a sweep with a zipped `cylinder_mass` axis: value, masses, label, colour."""
    m_s = sphere_mass(sw)
    out = []
    for v in sw.coord("cylinder_mass"):
        m_c = cylinder_mass(v, m_s)
        lab = chain_label(m_c, m_s)
        out.append({"value": v, "m_c": m_c, "m_s": m_s, "label": lab,
                    "color": COLOR_098 if lab == "0.98" else COLOR_055})
    return out


def mass_crossed(k: np.ndarray, m_c: float, m_s: float) -> np.ndarray:
    """Mass of chain the pulse has crossed when it peaks in cylinder k, g: spheres 2..2k and
    cylinders 1..k, M(k) = k (m_s + m_c)."""
    return np.asarray(k, dtype=float) * (m_s + m_c) * 1e3


def cylinder_numbers(probes: list[str]) -> np.ndarray:
    return np.array([int(p.removeprefix("gauge_force_cyl")) for p in probes if p.startswith("gauge_force_cyl")])


def relative_amplitudes(sw: Sweep, ref: int = 4, **sel) -> tuple[np.ndarray, np.ndarray]:
    """(cylinder numbers k, A_k/A_ref) from the leading peaks of every gauge probe of a grid point."""
    ks = cylinder_numbers(sw.probes)
    a = sw.peaks([f"gauge_force_cyl{k}" for k in ks], **sel)
    return ks, a / a[list(ks).index(ref)]


# ---------------------------------------------------------------------- signal analysis
def parabola_min(x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """Minimum of a sampled curve refined by a parabola through the lowest sample and its
    neighbours (NaNs ignored)."""
    ok = np.isfinite(y)
    x, y = x[ok], y[ok]
    i = int(np.argmin(y))
    i = min(max(i, 1), len(x) - 2)
    c = np.polyfit(x[i - 1:i + 2], y[i - 1:i + 2], 2)
    if c[0] <= 0:
        return float(x[i]), float(y[i])
    xm = -c[1] / (2 * c[0])
    return float(xm), float(np.polyval(c, xm))


def leading_window(t: np.ndarray, y: np.ndarray, arrival: float, end_fraction: float = 0.1,
                   gap_s: float | None = None) -> tuple[int, int]:
    """Index range [i0, i1) of the leading pulse of a signal (baseline already removed): from the
    first sample above `arrival` to the first sample, after the pulse's largest value so far, where
    the signal falls below `end_fraction` of it (or `gap_s` after arrival, whichever comes first)."""
    above = np.nonzero(y > arrival)[0]
    if len(above) == 0:
        return 0, 0
    i0 = int(above[0])
    peak = -np.inf
    for i in range(i0, len(y)):
        peak = max(peak, y[i])
        if y[i] < end_fraction * peak:
            return i0, i
        if gap_s is not None and t[i] - t[i0] > gap_s:
            return i0, i
    return i0, len(y)


def local_maxima(y: np.ndarray, prominence: float) -> list[int]:
    """Indices of local maxima of y that stand out by at least `prominence` above the deeper of
    the two minima separating them from their higher neighbours (a simple topographic prominence)."""
    n = len(y)
    idx = [i for i in range(1, n - 1) if y[i] > y[i - 1] and y[i] >= y[i + 1]]
    out = []
    for i in idx:
        # walk left until a higher point, tracking the minimum
        lmin = y[i]
        j = i - 1
        while j >= 0 and y[j] <= y[i]:
            lmin = min(lmin, y[j])
            j -= 1
        left = y[i] - lmin if j >= 0 else y[i] - min(lmin, y[0])
        rmin = y[i]
        j = i + 1
        while j < n and y[j] <= y[i]:
            rmin = min(rmin, y[j])
            j += 1
        right = y[i] - rmin if j < n else y[i] - min(rmin, y[-1])
        if min(left, right) >= prominence:
            out.append(i)
    return out


# Journal widths: one column (89 mm) and the full page (183 mm), the widths of the common physics
# journals' single- and double-column figures.
COLUMN_IN = 89 / 25.4
PAGE_IN = 183 / 25.4
# The smallest text a printed figure may have (at the width it is printed), and the largest that
# a figure's text is brought down to: journals ask for 6-8 pt lettering.
MIN_PT = 7.0
MAX_PT = 9.0
# Tick labels at most this (they are many and are read last).
MAX_TICK_PT = 8.0
# Pixels per inch of the PNG written beside the PDF (print resolution).
PNG_DPI = 300


def _shared_label(axes, get, set_, row_or_col) -> str | None:
    """The one label every panel of a row (x) or column (y) of panels repeats, if they do."""
    labels = {get(a) for a in axes}
    if len(axes) > 1 and len(labels) == 1 and next(iter(labels)):
        return next(iter(labels))
    return None


def _wrap(text: str, width_in: float, size_pt: float) -> str:
    """`text` broken into lines that fit `width_in` inches at `size_pt` (about 0.52 em a letter);
    math ($…$) and existing line breaks kept whole."""
    import textwrap

    import re

    per_line = max(10, int(width_in * 72 / (0.6 * size_pt)))
    out = []
    for line in text.split("\n"):
        # (Math without spaces, such as v$_0$, is one word: wrapping keeps it whole.)
        if any(" " in m for m in re.findall(r"\$[^$]*\$", line)) or len(line) <= per_line:
            out.append(line)
        else:
            lines = textwrap.wrap(line, per_line, break_long_words=False)
            # Never a word alone on the last line: the line before gives it a companion.
            if len(lines) > 1 and len(lines[-1].split()) == 1 and len(lines[-2].split()) > 1:
                head, last = lines[-2].rsplit(" ", 1)
                lines[-2:] = [head, f"{last} {lines[-1]}"]
            out.extend(lines)
    return "\n".join(out)


def _covered(ax, box) -> int:
    """How many points of `ax`'s data (its lines, densified along their segments, and its
    scatters' points), in display coordinates, lie inside the display box `box`."""
    import matplotlib.collections

    panel = ax.get_window_extent()

    def inside(d):
        # (A point the panel clips away is drawn nowhere: it cannot be covered.)
        shown = (d[:, 0] >= panel.x0) & (d[:, 0] <= panel.x1) & (d[:, 1] >= panel.y0) & (d[:, 1] <= panel.y1)
        return int((shown & (d[:, 0] >= box.x0) & (d[:, 0] <= box.x1) & (d[:, 1] >= box.y0)
                    & (d[:, 1] <= box.y1)).sum())

    n = 0
    for line in ax.get_lines():
        if not line.get_visible():
            continue
        xy = np.column_stack(line.get_data(orig=False)).astype(float)
        xy = xy[np.isfinite(xy).all(axis=1)]
        if len(xy) == 0:
            continue
        if len(xy) > 1 and line.get_linestyle() not in ("None", "", " "):
            # Eight points along each segment: a line through the box covers it.
            s = np.linspace(0, 1, 8, endpoint=False)[:, None, None]
            xy = np.vstack([(xy[:-1] + s * (xy[1:] - xy[:-1])).reshape(-1, 2), xy[-1:]])
        n += inside(ax.transData.transform(xy))
    for c in ax.collections:
        if isinstance(c, matplotlib.collections.PathCollection) and c.get_visible():
            offsets = np.asarray(c.get_offsets(), dtype=float).reshape(-1, 2)
            n += inside(c.get_offset_transform().transform(offsets))
    return n


LEGEND_PLACES = ("upper right", "upper left", "lower left", "lower right", "center right",
                 "center left", "upper center", "lower center", "center")


def place_legends(fig) -> list[str]:
    """Moves each panel's legend where it covers no data: where it stands if it covers none, else
    the first of LEGEND_PLACES that covers none, else out of the panel (under the figure when it
    is the figure's only legend, else right of its panel). Returns what it moved, in words."""
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    moved = []
    for ax in fig.axes:
        legend = ax.get_legend()
        if legend is None or not legend.get_visible():
            continue
        anchor = legend.get_bbox_to_anchor().transformed(fig.transFigure.inverted())
        if not (anchor.x0 >= -1e-9 and anchor.x1 <= 1 + 1e-9):
            continue  # placed outside by its script
        if _covered(ax, legend.get_window_extent(renderer)) == 0:
            continue
        for place in LEGEND_PLACES:
            legend.set_loc(place)
            if _covered(ax, legend.get_window_extent(renderer)) == 0:
                moved.append(f"{ax.get_title() or 'a panel'}: legend to {place}")
                break
        else:
            handles, labels = ax.get_legend_handles_labels()
            size = legend.get_texts()[0].get_fontsize() if legend.get_texts() else MIN_PT
            legend.remove()
            if sum(a.get_legend() is not None for a in fig.axes) == 0 and not fig.legends:
                # The figure's one legend: under the figure, where the layout makes room.
                # As many columns as fit the figure's width.
                for ncols in range(min(len(labels), 4), 0, -1):
                    fl = fig.legend(handles, labels, loc="outside lower center", ncols=ncols,
                                    fontsize=size, frameon=False)
                    if ncols == 1 or fl.get_window_extent(renderer).width <= 0.95 * fig.bbox.width:
                        break
                    fl.remove()
                moved.append(f"{ax.get_title() or 'a panel'}: legend under the figure")
            else:
                ax.legend(handles, labels, loc="center left", bbox_to_anchor=(1.02, 0.5), fontsize=size,
                          frameon=False)
                moved.append(f"{ax.get_title() or 'a panel'}: legend right of the panel")
    return moved


def texts_outside(fig) -> list[str]:
    """What of `fig` reaches past its edges (clipped when it is saved): each title, axis label,
    legend text or annotation that does, and "tick labels" when the drawn ticks do."""
    import matplotlib.text

    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    box = fig.bbox

    def outside(e) -> bool:
        return e.x0 < box.x0 - 1 or e.y0 < box.y0 - 1 or e.x1 > box.x1 + 1 or e.y1 > box.y1 + 1

    ticks = {id(t) for a in fig.axes for axis in (a.xaxis, a.yaxis)
             for t in axis.get_ticklabels(minor=False) + axis.get_ticklabels(minor=True)}
    out = [t.get_text() for t in fig.findobj(matplotlib.text.Text)
           if t.get_visible() and t.get_text().strip() and id(t) not in ticks
           and outside(t.get_window_extent(renderer))]
    # The ticks drawn (matplotlib's tight box holds what is drawn, in inches).
    tight = fig.get_tightbbox(renderer).transformed(fig.dpi_scale_trans)
    if not out and outside(tight):
        out.append("tick labels")
    return out


def fit_long_labels(fig) -> None:
    """Wraps an axis label longer than its side of the figure onto lines that fit it."""
    w, h = fig.get_size_inches()
    for ax in fig.axes:
        for label, room in ((ax.yaxis.label, 0.9 * h), (ax.xaxis.label, 0.9 * w)):
            text = label.get_text()
            if text and "\n" not in text:
                label.set_text(_wrap(text, room, label.get_fontsize()))


def legends_covering_data(fig) -> list[str]:
    """The panels whose legend covers a data point (none, once place_legends has run)."""
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    return [ax.get_title() or f"panel {k}" for k, ax in enumerate(fig.axes)
            if ax.get_legend() is not None and ax.get_legend().get_visible()
            and _covered(ax, ax.get_legend().get_window_extent(renderer)) > 0]


def journal_layout(fig) -> float:
    """Sets `fig` for print at a journal width: one column for a figure of one panel up to 7
    inches wide, the full page otherwise. Every text is brought to between MIN_PT and MAX_PT
    points (sizes keep their order: a title stays larger than a tick label), an x label every
    panel of a row repeats (a y label every panel of a column) is said once for the figure,
    titles are wrapped to their width, panels are kept at least 1.2 inches tall, and the figure
    is laid out again (constrained layout, which makes room for titles and legends). Returns the
    width, inches."""
    import matplotlib.text

    w, h = fig.get_size_inches()
    panels = [a for a in fig.axes if a.get_visible() and a.get_label() != "<colorbar>"]
    width = COLUMN_IN if len(panels) <= 1 and w <= 7.0 else PAGE_IN
    # Panels in rows and columns (from the subplot grid, when the figure has one).
    grid = None
    for a in panels:
        spec = a.get_subplotspec()
        if spec is not None:
            grid = spec.get_gridspec()
            break
    rows, cols = (grid.nrows, grid.ncols) if grid is not None else (1, 1)
    height = max(h * width / w, rows * 1.2 + 0.6)
    fig.set_size_inches(width, height)

    # Labels said once.
    if grid is not None and len(panels) > 1:
        bottom = [a for a in panels if a.get_subplotspec().is_last_row()]
        left = [a for a in panels if a.get_subplotspec().is_first_col()]
        xl = _shared_label(panels, lambda a: a.get_xlabel(), None, None)
        # A y label every panel repeats, or every panel of the first column (the others have
        # none), is said once.
        yl = _shared_label(panels, lambda a: a.get_ylabel(), None, None)
        if yl:
            left = panels
        elif len(left) > 1:
            yl = _shared_label(left, lambda a: a.get_ylabel(), None, None)
        if xl and cols > 1:
            # Said under the middle panel of the bottom row (where a legend under the figure
            # does not cover it, as it would a figure-wide label).
            middle = min(bottom, key=lambda a: abs(a.get_subplotspec().colspan.start - (cols - 1) / 2))
            for a in panels:
                if a is not middle:
                    a.set_xlabel("")
        elif xl:
            for a in panels:
                if a not in bottom:
                    a.set_xlabel("")
        if yl:
            for a in left:
                a.set_ylabel("")
            fig.supylabel(yl, fontsize=MAX_PT - 1)

    # Tick labels are made again at every draw, from the axes' tick parameters: they are sized
    # through those, the other texts directly.
    ticks = {id(t) for a in fig.axes for t in a.get_xticklabels() + a.get_yticklabels()}
    tick_size = {
        id(a): (a.get_xticklabels() + a.get_yticklabels() or [None])[0] for a in fig.axes
    }
    texts = [t for t in fig.findobj(matplotlib.text.Text) if t.get_text().strip() and id(t) not in ticks]
    sizes = [t.get_fontsize() for t in texts] + [
        t.get_fontsize() for t in tick_size.values() if t is not None
    ]
    lo, hi = (min(sizes), max(sizes)) if sizes else (MIN_PT, MIN_PT)

    def journal_size(size: float) -> float:
        # Linear from the smallest size to MIN_PT and the largest to MAX_PT.
        return MIN_PT + (size - lo) / (hi - lo) * (MAX_PT - MIN_PT) if hi > lo else MIN_PT + 1

    for t in texts:
        t.set_fontsize(journal_size(t.get_fontsize()))
    for a in fig.axes:
        first = tick_size[id(a)]
        a.tick_params(length=2.5, width=0.6, pad=2)
        if first is not None:
            a.tick_params(labelsize=min(journal_size(first.get_fontsize()), MAX_TICK_PT))
        a.xaxis.get_offset_text().set_fontsize(MIN_PT)
        a.yaxis.get_offset_text().set_fontsize(MIN_PT)
        for line in a.get_lines():
            line.set_linewidth(min(line.get_linewidth(), 1.2))
            # Data markers at most 3 pt; a larger marker that picks out a point (★) shrinks less.
            ms = line.get_markersize()
            line.set_markersize(min(ms, 3.0) if ms <= 6 else 0.6 * ms)
        title = a.title
        if title.get_text():
            title.set_text(_wrap(title.get_text(), width / max(cols, 1), title.get_fontsize()))
    # In a row of three panels or more, a panel's legend covers its curves: it goes under the
    # figure, in one line.
    if cols >= 3:
        for a in panels:
            legend = a.get_legend()
            if legend is not None:
                handles, labels = a.get_legend_handles_labels()
                size = legend.get_texts()[0].get_fontsize() if legend.get_texts() else MIN_PT
                legend.remove()
                fig.legend(handles, labels, loc="outside lower center", ncols=len(labels),
                           fontsize=size, frameon=False)
    if fig._suptitle is not None:
        fig._suptitle.set_text(_wrap(fig._suptitle.get_text(), width, fig._suptitle.get_fontsize()))
    try:
        fig.set_layout_engine("constrained", w_pad=0.02, h_pad=0.02)
    except RuntimeError:
        # A figure with a colorbar laid out by tight_layout keeps that engine.
        fig.tight_layout(pad=0.3)
    return width


def savefig(fig, name: str, dpi: int = PNG_DPI):
    """Writes `fig` as results/NAME.pdf (vector, fonts embedded) and results/NAME.png, both at a
    journal width (journal_layout), labels longer than the figure wrapped, every panel's legend
    where it covers no data (place_legends, checked), cropped to what is drawn, with no date or
    other volatile metadata: the same figure gives the same bytes."""
    import matplotlib
    import matplotlib.pyplot as plt

    journal_layout(fig)
    fit_long_labels(fig)
    place_legends(fig)
    covering = legends_covering_data(fig)
    assert not covering, f"{name}: a legend covers data in {covering}"
    # A figure laid out once by tight_layout (one with a colorbar) is laid out again.
    engine = fig.get_layout_engine()
    if engine is None or type(engine).__name__ == "TightLayoutEngine":
        fig.tight_layout(pad=0.3)
    out = RESULTS / f"{name}.png"
    out.parent.mkdir(parents=True, exist_ok=True)
    # Cropped to what is drawn (with a small margin): a label the layout left a hair past the
    # edge is never cut.
    tight = {"bbox_inches": "tight", "pad_inches": 0.02}
    fig.savefig(out, dpi=dpi, metadata={"Software": None}, **tight)
    # TrueType (Type 42) fonts, which journals' systems take, rather than Type 3.
    with matplotlib.rc_context({"pdf.fonttype": 42}):
        fig.savefig(out.with_suffix(".pdf"), metadata={"Creator": None, "Producer": None, "CreationDate": None},
                    **tight)
    plt.close(fig)
    for p in (out.with_suffix(".pdf"), out):
        print(f"wrote {p.relative_to(REPO) if p.is_relative_to(REPO) else p}")


def two_wave(y: np.ndarray, min_fraction: float = 0.1) -> tuple[int, float, float]:
    """Two-wave test of a force history (Fig. 7): the local maxima above `min_fraction` of the
    peak; returns (number of such maxima with a 1 % prominence, value of the second one relative
    to the first, depth of the dip between the first two relative to the peak, i.e. the
    prominence of the smaller of the two). One wave: (1, nan, 0)."""
    pk = float(np.nanmax(y))
    mx = [i for i in local_maxima(y, 0.01 * pk) if y[i] > min_fraction * pk]
    if len(mx) < 2:
        return len(mx), float("nan"), 0.0
    a, b = mx[0], mx[1]
    dip = float(np.min(y[a:b + 1]))
    return len(mx), float(y[b] / y[a]), (min(y[a], y[b]) - dip) / pk


def count_leading_peaks(t: np.ndarray, y: np.ndarray, arrival: float, end_fraction: float = 0.25,
                        prominence: float = 0.1) -> int:
    """Number of peaks in the leading pulse of a history (baseline removed): the pulse runs from
    the arrival until the signal falls below `end_fraction` of its running maximum; a peak counts
    when its prominence is at least `prominence` of the pulse's maximum."""
    i0, i1 = leading_window(t, y, arrival, end_fraction=end_fraction)
    if i1 <= i0 + 2:
        return 0
    seg = y[max(i0 - 1, 0):i1 + 1]
    return len(local_maxima(seg, prominence * float(np.max(seg))))
