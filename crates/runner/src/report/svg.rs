//! Figures as SVG text: line charts, heatmaps and bar charts with labelled axes, drawn here so
//! that a report is one self-contained file (no script, no font, no network when it is viewed)
//! and a few kilobytes per figure.

use std::fmt::Write as _;

/// Width and height of a figure, px.
pub const W: f64 = 560.0;
/// Height of a figure, px.
pub const H: f64 = 340.0;
const LEFT: f64 = 74.0;
const RIGHT: f64 = 16.0;
const TOP: f64 = 30.0;
const BOTTOM: f64 = 52.0;

/// A series of a line chart: its label and points (NaN `y`: a point without a number, marked).
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend text.
    pub label: String,
    /// x, y.
    pub points: Vec<(f64, f64)>,
    /// Where a point has no number: x and why (a failed run's reason).
    pub missing: Vec<(f64, String)>,
    /// Per point, the lower and upper ends of an interval (empty: none).
    pub band: Vec<(f64, f64)>,
    /// The colour's index ([`colour`]; `None`: the series' own place), so that two series can
    /// be parts of one curve.
    pub colour: Option<usize>,
    /// Drawn dashed (an unstable part of a curve).
    pub dashed: bool,
}

impl Series {
    /// A plain line: `points`, nothing missing, no interval.
    pub fn line(label: impl Into<String>, points: Vec<(f64, f64)>) -> Series {
        Series {
            label: label.into(),
            points,
            missing: Vec::new(),
            band: Vec::new(),
            colour: None,
            dashed: false,
        }
    }
}

/// Escapes text for XML.
pub fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// Round tick values covering `[lo, hi]` (about five).
pub fn ticks(lo: f64, hi: f64) -> Vec<f64> {
    if !(lo.is_finite() && hi.is_finite()) || hi <= lo {
        return vec![lo];
    }
    let raw = (hi - lo) / 5.0;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 2.5, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * mag);
    let start = (lo / step).ceil() * step;
    let mut out = Vec::new();
    let mut t = start;
    while t <= hi + 1e-9 * step && out.len() < 12 {
        out.push(if t.abs() < 1e-12 * step { 0.0 } else { t });
        t += step;
    }
    out
}

/// A number as a tick label: short, exact enough.
pub fn num(x: f64) -> String {
    num_digits(x, 4)
}

/// `x` to `digits` significant digits, trailing zeros dropped (scientific outside 1e-3..1e5).
fn num_digits(x: f64, digits: usize) -> String {
    let a = x.abs();
    if x == 0.0 {
        "0".into()
    } else if (1e-3..1e5).contains(&a) {
        let decimals = (digits as i32 - 1 - a.log10().floor() as i32).clamp(0, 16) as usize;
        let s = format!("{x:.decimals$}");
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    } else {
        format!("{x:.prec$e}", prec = digits - 1)
    }
}

/// Labels of the ticks `ts`, in as few significant digits (from four) as tell every one apart:
/// an axis from 1.0 to 1.0003 reads 1, 1.0001, …, not "1" five times.
pub fn tick_labels(ts: &[f64]) -> Vec<String> {
    for digits in 4..=16 {
        let labels: Vec<String> = ts.iter().map(|&t| num_digits(t, digits)).collect();
        if labels.windows(2).all(|w| w[0] != w[1]) {
            return labels;
        }
    }
    ts.iter().map(|&t| num_digits(t, 17)).collect()
}

/// Ticks over `[lo, hi]` with their labels.
fn labelled_ticks(lo: f64, hi: f64) -> Vec<(f64, String)> {
    let ts = ticks(lo, hi);
    let labels = tick_labels(&ts);
    ts.into_iter().zip(labels).collect()
}

const PALETTE: [&str; 10] = [
    "#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f",
    "#bcbd22", "#17becf",
];

/// The colour of series `k`.
pub fn colour(k: usize) -> &'static str {
    PALETTE[k % PALETTE.len()]
}

fn range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    if !lo.is_finite() {
        (0.0, 1.0)
    } else if hi > lo {
        let pad = 0.04 * (hi - lo);
        (lo - pad, hi + pad)
    } else {
        let d = if lo == 0.0 { 1.0 } else { 0.05 * lo.abs() };
        (lo - d, hi + d)
    }
}

struct Frame {
    x0: f64,
    x1: f64,
    y0: f64,
    y1: f64,
    log_x: bool,
    /// The right margin: wider where a legend stands beside the data.
    right: f64,
}

impl Frame {
    fn px(&self, x: f64) -> f64 {
        let (x, a, b) = if self.log_x {
            (x.log10(), self.x0.log10(), self.x1.log10())
        } else {
            (x, self.x0, self.x1)
        };
        LEFT + (x - a) / (b - a) * (W - LEFT - self.right)
    }
    fn py(&self, y: f64) -> f64 {
        H - BOTTOM - (y - self.y0) / (self.y1 - self.y0) * (H - TOP - BOTTOM)
    }
}

fn axes(
    out: &mut String,
    f: &Frame,
    title: &str,
    x_label: &str,
    y_label: &str,
    x_ticks: &[(f64, String)],
) {
    let _ = write!(
        out,
        r##"<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 {W} {H}" width="{W}" height="{H}" font-family="sans-serif" font-size="11"><rect width="{W}" height="{H}" fill="#fff"/>"##
    );
    let _ = write!(
        out,
        r##"<text x="{}" y="18" text-anchor="middle" font-size="13">{}</text>"##,
        W / 2.0,
        esc(title)
    );
    let (l, r, t, b) = (LEFT, W - f.right, TOP, H - BOTTOM);
    let _ = write!(
        out,
        r##"<rect x="{l}" y="{t}" width="{}" height="{}" fill="none" stroke="#444"/>"##,
        r - l,
        b - t
    );
    for (x, text) in x_ticks {
        let px = f.px(*x);
        let _ = write!(
            out,
            r##"<line x1="{px:.1}" y1="{b}" x2="{px:.1}" y2="{}" stroke="#444"/><text x="{px:.1}" y="{}" text-anchor="middle">{}</text>"##,
            b + 4.0,
            b + 16.0,
            esc(text)
        );
    }
    for (y, label) in labelled_ticks(f.y0, f.y1) {
        let py = f.py(y);
        let _ = write!(
            out,
            r##"<line x1="{}" y1="{py:.1}" x2="{l}" y2="{py:.1}" stroke="#444"/><line x1="{l}" y1="{py:.1}" x2="{r}" y2="{py:.1}" stroke="#eee"/><text x="{}" y="{:.1}" text-anchor="end">{}</text>"##,
            l - 4.0,
            l - 6.0,
            py + 4.0,
            label
        );
    }
    let _ = write!(
        out,
        r##"<text x="{}" y="{}" text-anchor="middle">{}</text><text transform="translate(14 {}) rotate(-90)" text-anchor="middle">{}</text>"##,
        (l + r) / 2.0,
        H - 12.0,
        esc(x_label),
        (t + b) / 2.0,
        esc(y_label)
    );
}

/// A line chart of `series` against a numeric x (`log_x`: a logarithmic x, when every x > 0 and
/// they span more than a decade); `text_x`: the x tick labels when x is an index of text values.
pub fn lines(
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
    text_x: Option<&[String]>,
) -> String {
    let xs = || series.iter().flat_map(|s| s.points.iter().map(|p| p.0));
    let (xmin, xmax) = xs().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
        (a.min(x), b.max(x))
    });
    let log_x = text_x.is_none() && xmin > 0.0 && xmax / xmin > 30.0;
    let (x0, x1) = if log_x {
        (xmin / 1.1, xmax * 1.1)
    } else {
        range(xs())
    };
    let ys = series.iter().flat_map(|s| {
        s.points
            .iter()
            .map(|p| p.1)
            .chain(s.band.iter().flat_map(|b| [b.0, b.1]))
    });
    let (y0, y1) = range(ys);
    // A legend stands right of the data, never over it; it lists the series with a label.
    let labelled: Vec<(usize, &Series)> = series
        .iter()
        .enumerate()
        .filter(|(_, s)| !s.label.is_empty())
        .collect();
    let legend_w = if labelled.len() > 1 {
        30.0 + 6.0
            * series
                .iter()
                .take(12)
                .map(|s| s.label.chars().count().min(24))
                .max()
                .unwrap_or(4) as f64
    } else {
        0.0
    };
    let f = Frame {
        x0,
        x1,
        y0,
        y1,
        log_x,
        right: RIGHT + legend_w,
    };
    let x_ticks: Vec<(f64, String)> = match text_x {
        Some(labels) => {
            let every = labels.len().div_ceil(8).max(1);
            labels
                .iter()
                .enumerate()
                .filter(|(i, _)| i % every == 0)
                .map(|(i, l)| (i as f64, l.chars().take(14).collect()))
                .collect()
        }
        None if log_x => {
            let (a, b) = (x0.log10().ceil() as i32, x1.log10().floor() as i32);
            (a..=b).map(|e| (10f64.powi(e), format!("1e{e}"))).collect()
        }
        None => labelled_ticks(x0, x1),
    };
    let mut out = String::new();
    axes(&mut out, &f, title, x_label, y_label, &x_ticks);
    for (k, s) in series.iter().enumerate() {
        let c = colour(s.colour.unwrap_or(k));
        let dash = if s.dashed {
            r#" stroke-dasharray="5,3""#
        } else {
            ""
        };
        if !s.band.is_empty() {
            let mut d = String::new();
            for (i, (p, b)) in s.points.iter().zip(&s.band).enumerate() {
                if b.1.is_finite() {
                    let _ = write!(
                        d,
                        "{}{:.1},{:.1}",
                        if i == 0 { "M" } else { "L" },
                        f.px(p.0),
                        f.py(b.1)
                    );
                }
            }
            for (p, b) in s.points.iter().zip(&s.band).rev() {
                if b.0.is_finite() {
                    let _ = write!(d, "L{:.1},{:.1}", f.px(p.0), f.py(b.0));
                }
            }
            let _ = write!(
                out,
                r##"<path d="{d}Z" fill="{c}" fill-opacity="0.18" stroke="none"/>"##
            );
        }
        let mut d = String::new();
        let mut pen = false;
        for p in &s.points {
            if p.1.is_finite() {
                let _ = write!(
                    d,
                    "{}{:.1},{:.1}",
                    if pen { "L" } else { "M" },
                    f.px(p.0),
                    f.py(p.1)
                );
                pen = true;
            } else {
                pen = false;
            }
        }
        let _ = write!(
            out,
            r##"<path d="{d}" fill="none" stroke="{c}" stroke-width="1.5"{dash}/>"##
        );
        if s.points.len() <= 200 {
            for p in s.points.iter().filter(|p| p.1.is_finite()) {
                let _ = write!(
                    out,
                    r##"<circle cx="{:.1}" cy="{:.1}" r="2.2" fill="{c}"/>"##,
                    f.px(p.0),
                    f.py(p.1)
                );
            }
        }
        for (x, why) in &s.missing {
            let (px, py) = (f.px(*x), H - BOTTOM - 6.0);
            let _ = write!(
                out,
                r##"<g class="missing"><title>{}</title><path d="M{:.1},{:.1}l6,6m0,-6l-6,6" stroke="#d62728" stroke-width="1.6"/></g>"##,
                esc(why),
                px - 3.0,
                py - 3.0
            );
        }
    }
    // The legend: a column right of the frame.
    if labelled.len() > 1 {
        let shown = labelled.len().min(12);
        let x = W - legend_w - RIGHT + 10.0;
        for (row, (k, s)) in labelled.iter().take(shown).enumerate() {
            let y = TOP + 10.0 + 14.0 * row as f64;
            let label: String = s.label.chars().take(24).collect();
            let dash = if s.dashed {
                r#" stroke-dasharray="5,3""#
            } else {
                ""
            };
            let _ = write!(
                out,
                r##"<line x1="{x:.1}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}" stroke="{}" stroke-width="2"{dash}/><text x="{:.1}" y="{:.1}" font-size="10">{}</text>"##,
                x + 14.0,
                colour(s.colour.unwrap_or(*k)),
                x + 18.0,
                y + 4.0,
                esc(&label)
            );
        }
        if labelled.len() > shown {
            let _ = write!(
                out,
                r##"<text x="{x:.1}" y="{:.1}" font-size="10">… {} more</text>"##,
                TOP + 14.0 + 14.0 * shown as f64,
                labelled.len() - shown
            );
        }
    }
    out.push_str("</svg>");
    out
}

/// Viridis at `t` in [0, 1] (five stops, linear between).
pub fn viridis(t: f64) -> String {
    const STOPS: [(f64, f64, f64); 5] = [
        (68.0, 1.0, 84.0),
        (59.0, 82.0, 139.0),
        (33.0, 145.0, 140.0),
        (94.0, 201.0, 98.0),
        (253.0, 231.0, 37.0),
    ];
    let t = t.clamp(0.0, 1.0) * 4.0;
    let i = (t.floor() as usize).min(3);
    let u = t - i as f64;
    let (a, b) = (STOPS[i], STOPS[i + 1]);
    format!(
        "rgb({},{},{})",
        (a.0 + u * (b.0 - a.0)).round(),
        (a.1 + u * (b.1 - a.1)).round(),
        (a.2 + u * (b.2 - a.2)).round()
    )
}

// (The figure's texts, its grid and values, and the reason of a cell without one.)
#[allow(clippy::too_many_arguments)]
/// A heatmap: `z[i][j]` at row `i` (y label `y_labels[i]`) and column `j`; NaN cells hatched
/// with their reason as a tooltip (`why`).
pub fn heatmap(
    title: &str,
    x_label: &str,
    y_label: &str,
    x_labels: &[String],
    y_labels: &[String],
    z: &[Vec<f64>],
    why: &dyn Fn(usize, usize) -> Option<String>,
    units: &str,
) -> String {
    let (nx, ny) = (x_labels.len().max(1), y_labels.len().max(1));
    let (lo, hi) = z
        .iter()
        .flatten()
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    let plot_w = W - LEFT - RIGHT - 70.0;
    let mut out = String::new();
    let _ = write!(
        out,
        r##"<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 {W} {H}" width="{W}" height="{H}" font-family="sans-serif" font-size="11"><rect width="{W}" height="{H}" fill="#fff"/><text x="{}" y="18" text-anchor="middle" font-size="13">{}</text>"##,
        W / 2.0,
        esc(title)
    );
    let cw = plot_w / nx as f64;
    let ch = (H - TOP - BOTTOM) / ny as f64;
    out.push_str(r##"<defs><pattern id="hatch" width="6" height="6" patternUnits="userSpaceOnUse"><path d="M0,6l6,-6" stroke="#d62728" stroke-width="1"/></pattern></defs>"##);
    // Cells edge to edge without anti-aliased seams between them, in a browser and drawn as PNG.
    out.push_str(r##"<g shape-rendering="crispEdges">"##);
    for (i, row) in z.iter().enumerate() {
        for (j, &v) in row.iter().enumerate() {
            let (x, y) = (LEFT + j as f64 * cw, H - BOTTOM - (i + 1) as f64 * ch);
            let fill = if v.is_finite() {
                viridis(if hi > lo { (v - lo) / (hi - lo) } else { 0.5 })
            } else {
                "url(#hatch)".to_string()
            };
            let tip = if v.is_finite() {
                format!(
                    "{} = {}, {} = {}: {} {units}",
                    x_label,
                    x_labels[j],
                    y_label,
                    y_labels[i],
                    num(v)
                )
            } else {
                why(i, j).unwrap_or_else(|| "no number".into())
            };
            let _ = write!(
                out,
                r##"<rect x="{x:.2}" y="{y:.2}" width="{:.2}" height="{:.2}" fill="{fill}"><title>{}</title></rect>"##,
                cw + 0.3,
                ch + 0.3,
                esc(&tip)
            );
        }
    }
    out.push_str("</g>");
    let every_x = nx.div_ceil(8).max(1);
    for (j, l) in x_labels
        .iter()
        .enumerate()
        .filter(|(j, _)| j % every_x == 0)
    {
        let x = LEFT + (j as f64 + 0.5) * cw;
        let _ = write!(
            out,
            r##"<text x="{x:.1}" y="{}" text-anchor="middle">{}</text>"##,
            H - BOTTOM + 14.0,
            esc(&l.chars().take(12).collect::<String>())
        );
    }
    let every_y = ny.div_ceil(10).max(1);
    for (i, l) in y_labels
        .iter()
        .enumerate()
        .filter(|(i, _)| i % every_y == 0)
    {
        let y = H - BOTTOM - (i as f64 + 0.5) * ch;
        let _ = write!(
            out,
            r##"<text x="{}" y="{:.1}" text-anchor="end">{}</text>"##,
            LEFT - 4.0,
            y + 4.0,
            esc(&l.chars().take(12).collect::<String>())
        );
    }
    let _ = write!(
        out,
        r##"<text x="{}" y="{}" text-anchor="middle">{}</text><text transform="translate(14 {}) rotate(-90)" text-anchor="middle">{}</text>"##,
        LEFT + plot_w / 2.0,
        H - 12.0,
        esc(x_label),
        (TOP + H - BOTTOM) / 2.0,
        esc(y_label)
    );
    // The colour bar.
    let bx = LEFT + plot_w + 16.0;
    out.push_str(r##"<g shape-rendering="crispEdges">"##);
    for k in 0..50 {
        let t = k as f64 / 49.0;
        let y = H - BOTTOM - (k + 1) as f64 * (H - TOP - BOTTOM) / 50.0;
        let _ = write!(
            out,
            r##"<rect x="{bx}" y="{y:.1}" width="12" height="{:.1}" fill="{}"/>"##,
            (H - TOP - BOTTOM) / 50.0 + 0.3,
            viridis(t)
        );
    }
    out.push_str("</g>");
    if lo.is_finite() {
        let _ = write!(
            out,
            r##"<text x="{}" y="{}">{}</text><text x="{}" y="{}">{}</text><text x="{}" y="{}" font-size="10">{}</text>"##,
            bx + 14.0,
            H - BOTTOM,
            num(lo),
            bx + 14.0,
            TOP + 8.0,
            num(hi),
            bx - 4.0,
            TOP - 4.0,
            esc(units)
        );
    }
    out.push_str("</svg>");
    out
}

/// A bar chart: one bar per `(label, value, lower, upper)` (NaN ends: no error bar), or a
/// histogram when `edges` are given (bars from edge to edge).
pub fn bars(
    title: &str,
    x_label: &str,
    y_label: &str,
    bars: &[(String, f64, f64, f64)],
    edges: Option<&[f64]>,
) -> String {
    let (y0, y1) = range(bars.iter().flat_map(|b| [0.0, b.1, b.2, b.3]));
    let (x0, x1) = match edges {
        Some(e) => (e[0], e[e.len() - 1]),
        None => (-0.5, bars.len() as f64 - 0.5),
    };
    let f = Frame {
        x0,
        x1,
        y0: y0.min(0.0),
        y1,
        log_x: false,
        right: RIGHT,
    };
    let x_ticks: Vec<(f64, String)> = match edges {
        Some(_) => labelled_ticks(x0, x1),
        None => bars
            .iter()
            .enumerate()
            .map(|(i, b)| (i as f64, b.0.chars().take(16).collect()))
            .collect(),
    };
    let mut out = String::new();
    axes(&mut out, &f, title, x_label, y_label, &x_ticks);
    for (i, b) in bars.iter().enumerate() {
        let (l, r) = match edges {
            Some(e) => (e[i], e[i + 1]),
            None => (i as f64 - 0.35, i as f64 + 0.35),
        };
        let (pl, pr) = (f.px(l), f.px(r));
        let (top, base) = (f.py(b.1.max(0.0)), f.py(b.1.min(0.0)));
        let _ = write!(
            out,
            r##"<rect x="{pl:.1}" y="{top:.1}" width="{:.1}" height="{:.1}" fill="{}" fill-opacity="0.7"><title>{}: {}</title></rect>"##,
            (pr - pl - 0.5).max(0.5),
            (base - top).max(0.0),
            colour(0),
            esc(&b.0),
            num(b.1)
        );
        if b.2.is_finite() && b.3.is_finite() {
            let cx = (pl + pr) / 2.0;
            let _ = write!(
                out,
                r##"<path d="M{cx:.1},{:.1}V{:.1}M{:.1},{:.1}h6M{:.1},{:.1}h6" stroke="#222" stroke-width="1"/>"##,
                f.py(b.2),
                f.py(b.3),
                cx - 3.0,
                f.py(b.2),
                cx - 3.0,
                f.py(b.3)
            );
        }
    }
    out.push_str("</svg>");
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tick_labels_tell_every_tick_apart() {
        let ts = ticks(1.0, 1.0003);
        let labels = tick_labels(&ts);
        assert_eq!(labels, ["1", "1.0001", "1.0002", "1.0003"]);
        let ts = ticks(5.2536e-5, 5.2544e-5);
        let labels = tick_labels(&ts);
        assert!(labels.windows(2).all(|w| w[0] != w[1]), "{labels:?}");
        // Coarse ticks keep their short labels.
        assert_eq!(
            tick_labels(&ticks(0.0, 10.0)),
            ["0", "2", "4", "6", "8", "10"]
        );
    }
}
