//! `chainsweep report`: what an output file holds, as one self-contained HTML page (its figures
//! inline as SVG drawn here, [`svg`]): every summary against the axes (a line per curve for one
//! axis, a heatmap for two, small multiples beyond), failed and unnumbered points marked with
//! their reasons, the health of the sweep, each search's, fit's and ensemble's answer with its
//! uncertainty, a search's evaluations and a fit's data against its best fit ([`searches`]), an
//! ensemble's histograms and Sobol' indices, the run time and verified error per point, histories
//! of chosen points ([`histories`]), and the sweep file, versions and command for provenance.
//!
//! The page is opened offline: no script, no font, no link outside it. A large sweep is thinned
//! (every k-th point of a long axis, a coarser grid of a large heatmap), and the page says where.

mod export;
mod histories;
pub mod periodic;
mod searches;
pub mod svg;

use std::fmt::Write as _;
use std::path::Path;

use crate::engine::status::{EnsembleStatus, FileStatus};
use crate::error::{Error, Result};
use crate::grid::multi_index;
use crate::record::columns::{ColumnData, Fill, COLUMNS};
use crate::record::{STATUS_FAILED, STATUS_PENDING, STATUS_UNSETTLED};
use crate::store::hdf5::FileRecords;
use crate::sweep::{human_name, Sweep};
pub use export::{FigureFormat, PNG_SCALE};
use svg::{esc, Series};

/// The most points a line of the page draws (a longer one is thinned).
pub const MAX_LINE_POINTS: usize = 2000;
/// The most cells along each side of a heatmap.
pub const MAX_HEATMAP_SIDE: usize = 160;
/// The most panels of small multiples per summary.
pub const MAX_PANELS: usize = 6;
/// The most probes drawn per summary.
pub const MAX_PROBES: usize = 8;

/// Columns about how a run went rather than what it found: drawn under "Runs".
const RUN_COLUMNS: &[(&str, &str)] = &[
    ("wall_time_s", "s"),
    ("verify_rel_error_max", "1"),
    ("energy_drift_max", "1"),
    ("momentum_residual_max", "1"),
    ("t_end_s", "s"),
];

/// A page and what it holds.
#[derive(Debug, Clone)]
pub struct Page {
    /// The HTML text.
    pub html: String,
    /// Figures on it.
    pub figures: usize,
    /// Where it thinned the data, in words (empty: nowhere).
    pub thinned: Vec<String>,
    /// Each figure alone: its caption and its SVG text, in the page's order.
    pub svgs: Vec<(String, String)>,
}

pub(crate) struct Builder {
    body: String,
    figures: usize,
    thinned: Vec<String>,
    svgs: Vec<(String, String)>,
}

impl Builder {
    pub(crate) fn figure(&mut self, svg: String, caption: &str) {
        self.svgs.push((caption.to_string(), svg.clone()));
        self.figures += 1;
        let _ = write!(
            self.body,
            "<figure class=\"plot\" id=\"figure-{}\">{svg}<figcaption>{}</figcaption></figure>",
            self.figures,
            esc(caption)
        );
    }
}

fn axis_text(v: &serde_json::Value) -> String {
    match v {
        serde_json::Value::String(s) => s.clone(),
        serde_json::Value::Number(n) => n.to_string(),
        other => other.to_string(),
    }
}

/// Which indices of `0..n` to draw: all, or every k-th (and the last).
fn thin(n: usize, most: usize) -> (Vec<usize>, usize) {
    if n <= most {
        return ((0..n).collect(), 1);
    }
    let k = n.div_ceil(most);
    let mut v: Vec<usize> = (0..n).step_by(k).collect();
    if v.last() != Some(&(n - 1)) {
        v.push(n - 1);
    }
    (v, k)
}

/// The page of the output file `path`, with `status` (from [`crate::engine::status::of_file`]);
/// `points`: the flat indices of the points whose histories it draws (empty: the first ok one).
pub fn page(path: &Path, status: &FileStatus, points: &[usize]) -> Result<Page> {
    let recs = FileRecords::open(path)?;
    let sweep =
        Sweep::parse(&recs.sweep_text).map_err(|e| e.in_file(&path.display().to_string()))?;
    let sweep = sweep.with_points(recs.len()).unwrap_or(sweep);
    let mut b = Builder {
        body: String::new(),
        figures: 0,
        thinned: Vec::new(),
        svgs: Vec::new(),
    };
    let name = path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    );
    health_section(&mut b, status);
    if let Some(e) = &status.ensemble {
        ensemble_section(&mut b, path, &sweep, e);
    }
    searches::section(&mut b, path, &sweep, status);
    if sweep.search.is_none() && sweep.ensemble.is_none() {
        summaries_section(&mut b, &sweep, &recs);
    }
    let best = histories::best_of_search(path, &sweep, &recs);
    histories::section(&mut b, &sweep, &recs, points, best);
    provenance_section(&mut b, path, &recs.sweep_text);
    Ok(finish(b, &name, &sweep.description))
}

/// The page around the sections `b` holds: its head, title (`name`, the file's) and the sweep's
/// `description`.
pub(crate) fn finish(b: Builder, name: &str, description: &str) -> Page {
    let mut html = String::new();
    let _ = write!(
        html,
        r#"<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{title}</title>
<meta name="generator" content="chainsweep {version}">
<style>
body {{ font-family: sans-serif; margin: 1.5em auto; max-width: 1200px; color: #222; }}
h1 {{ font-size: 1.4em; }} h2 {{ font-size: 1.15em; border-bottom: 1px solid #ccc; margin-top: 1.6em; }}
.plots {{ display: flex; flex-wrap: wrap; gap: 12px; }}
figure.plot {{ margin: 0; border: 1px solid #ddd; padding: 4px; }}
figcaption {{ font-size: 0.85em; color: #555; max-width: 560px; }}
table {{ border-collapse: collapse; font-size: 0.9em; }} td, th {{ border: 1px solid #ddd; padding: 2px 6px; text-align: left; }}
pre {{ background: #f6f6f6; padding: 0.6em; overflow-x: auto; font-size: 0.85em; }}
.bad {{ color: #b00; }} .note {{ color: #555; font-size: 0.9em; }}
</style></head><body>
<h1>{title}</h1>
<p class="note">{description}</p>
"#,
        title = esc(&format!("chainsweep report: {name}")),
        version = crate::ENGINE_VERSION,
        description = esc(description),
    );
    if !b.thinned.is_empty() {
        let _ = write!(
            html,
            "<p class=\"note\">Thinned for the page (the file holds every point): {}</p>",
            esc(&b.thinned.join("; "))
        );
    }
    html.push_str(&b.body);
    html.push_str("</body></html>");
    Page {
        html,
        figures: b.figures,
        thinned: b.thinned,
        svgs: b.svgs,
    }
}

/// What was found damaged in the file (its runs drawn as missing, never as numbers) and what the
/// snapshot gave back; `chainsweep run` of the sweep repairs it.
fn damage_lines(b: &mut Builder, d: &crate::engine::DamageReport) {
    for (what, why) in [
        ("the file", &d.file),
        ("its header", &d.header),
        ("its snapshot", &d.snapshot),
    ] {
        if let Some(why) = why {
            let _ = write!(b.body, "<p class=\"bad\">Damaged: {what}: {}</p>", esc(why));
        }
    }
    for (runs, says) in [
        (&d.lost, "Damaged runs (drawn as missing; running the sweep again computes them):"),
        (&d.restored, "Damaged runs the snapshot holds intact (running the sweep again restores them; drawn as missing here):"),
    ] {
        if runs.is_empty() {
            continue;
        }
        let _ = write!(b.body, "<p class=\"bad\">{says}</p><table><tr><th>point</th><th>axis values</th><th>why</th></tr>");
        for r in runs.iter().take(50) {
            let point = r.point.map_or_else(|| "-".to_string(), |p| p.to_string());
            let _ = write!(
                b.body,
                "<tr><td>{point}</td><td>{}</td><td>{}</td></tr>",
                esc(&r.label),
                esc(&r.why)
            );
        }
        b.body.push_str("</table>");
        if runs.len() > 50 {
            let _ = write!(b.body, "<p class=\"note\">… and {} more (<code>chainsweep status</code> lists them).</p>", runs.len() - 50);
        }
    }
}

fn health_section(b: &mut Builder, s: &FileStatus) {
    let c = &s.counts;
    let _ = write!(
        b.body,
        "<h2>Health</h2><table><tr><th>points</th><td>{}</td></tr><tr><th>ok</th><td>{}</td></tr><tr><th>failed</th><td class=\"{}\">{}</td></tr><tr><th>unsettled</th><td>{}</td></tr><tr><th>pending</th><td>{}</td></tr><tr><th>shape</th><td>{}</td></tr></table>",
        s.total,
        c.ok,
        if c.failed > 0 { "bad" } else { "" },
        c.failed,
        c.unsettled,
        c.pending,
        esc(&format!("{:?}", s.shape)),
    );
    if !s.failures.is_empty() {
        b.body.push_str(
            "<p>Failed runs:</p><table><tr><th>point</th><th>axis values</th><th>reason</th></tr>",
        );
        for (i, why) in s.failures.iter().take(50) {
            // The axis values `status` named the point by.
            let label = s.labels.get(i).map_or("", String::as_str);
            let _ = write!(
                b.body,
                "<tr><td>{i}</td><td>{}</td><td>{}</td></tr>",
                esc(label),
                esc(why)
            );
        }
        b.body.push_str("</table>");
        if s.failures.len() > 50 {
            let _ = write!(b.body, "<p class=\"note\">… and {} more (the file's <code>reason</code> dataset holds every one).</p>", s.failures.len() - 50);
        }
    }
    damage_lines(b, &s.damage);
    if let Some(lines) = &s.searches {
        b.body.push_str("<h2>Searches</h2><ul>");
        for l in lines {
            let at = if l.label.is_empty() {
                "search".to_string()
            } else {
                format!("search at {}", l.label)
            };
            let _ = write!(
                b.body,
                "<li>{}: {} after {} run(s){}",
                esc(&at),
                esc(&l.status),
                l.runs,
                if l.note.is_empty() {
                    String::new()
                } else {
                    format!("; {}", esc(&l.note))
                }
            );
            if !l.answers.is_empty() {
                b.body.push_str("<ul>");
                for a in &l.answers {
                    let _ = write!(b.body, "<li>{} {}</li>", esc(a.item), esc(&a.text));
                }
                b.body.push_str("</ul>");
            }
            b.body.push_str("</li>");
        }
        b.body.push_str("</ul>");
    }
}

fn ensemble_section(b: &mut Builder, path: &Path, sweep: &Sweep, e: &EnsembleStatus) {
    use crate::store::hdf5::fit::read_f64;
    let o = &e.outcome;
    let _ = write!(
        b.body,
        "<h2>Ensemble</h2><p>{} design, round {}, {} samples per point, {} runs; ended by: {}.</p>",
        esc(e.design),
        o.round,
        o.samples,
        o.runs,
        esc(o.stopped_by)
    );
    let Some(spec) = &sweep.ensemble else { return };
    for st in &e.statistics {
        b.body.push_str(
            "<table><tr><th>statistic</th><th>at</th><th>mean [95 %]</th><th>sd [95 %]</th>",
        );
        for q in &spec.quantiles {
            let _ = write!(b.body, "<th>q{} [95 %]</th>", q * 100.0);
        }
        b.body.push_str("</tr>");
        let iv = |x: &crate::uq::stats::Estimate| {
            format!(
                "{} [{}, {}]",
                svg::num(x.value),
                svg::num(x.lower),
                svg::num(x.upper)
            )
        };
        for p in &st.points {
            let _ = write!(
                b.body,
                "<tr><td>{} ({})</td><td>{}</td><td>{}</td><td>{}</td>",
                esc(&st.name),
                esc(&st.units),
                esc(&p.label),
                iv(&p.mean),
                iv(&p.sd)
            );
            for (_, x) in &p.quantiles {
                let _ = write!(b.body, "<td>{}</td>", iv(x));
            }
            b.body.push_str("</tr>");
        }
        b.body.push_str("</table>\n<div class=\"plots\">");
        let get = |v: &str| read_f64(path, &format!("{}_{v}", st.name)).unwrap_or_default();
        let (lo, hi, frac, fl, fu) = (
            get("bin_lower"),
            get("bin_upper"),
            get("histogram"),
            get("histogram_lower"),
            get("histogram_upper"),
        );
        let bins = lo.len();
        if bins > 0 && frac.len() >= bins {
            let mut edges = lo.clone();
            edges.push(*hi.last().unwrap_or(&0.0));
            let bars: Vec<(String, f64, f64, f64)> = (0..bins)
                .map(|k| {
                    let w = hi[k] - lo[k];
                    (
                        format!("{}–{}", svg::num(lo[k]), svg::num(hi[k])),
                        frac[k] / w,
                        fl.get(k).map_or(f64::NAN, |x| x / w),
                        fu.get(k).map_or(f64::NAN, |x| x / w),
                    )
                })
                .collect();
            let at = st
                .points
                .first()
                .map(|p| p.label.clone())
                .unwrap_or_default();
            let title = if at.is_empty() {
                format!("{} distribution", st.name)
            } else {
                format!("{} distribution at {at}", st.name)
            };
            b.figure(
                svg::bars(&title, &format!("{} [{}]", st.name, st.units), "probability density", &bars, Some(&edges)),
                "histogram of the ensemble's samples at the first point of the axes, with 95 % intervals of each bin's fraction",
            );
        }
        if let Some(p) = st.points.first() {
            if !p.sensitivity.is_empty() {
                let (first, second) = if e.design == "morris" {
                    ("mu*", "sigma")
                } else {
                    ("first-order", "total")
                };
                let bars: Vec<(String, f64, f64, f64)> = p
                    .sensitivity
                    .iter()
                    .map(|(i, a, _)| (i.clone(), a.value, a.lower, a.upper))
                    .collect();
                b.figure(
                    svg::bars(
                        &format!(
                            "{} of {}: {first}",
                            if e.design == "morris" {
                                "Morris"
                            } else {
                                "Sobol' indices"
                            },
                            st.name
                        ),
                        "input",
                        first,
                        &bars,
                        None,
                    ),
                    &format!("{first} of each input with 95 % bootstrap intervals"),
                );
                let bars: Vec<(String, f64, f64, f64)> = p
                    .sensitivity
                    .iter()
                    .map(|(i, _, t)| (i.clone(), t.value, t.lower, t.upper))
                    .collect();
                b.figure(
                    svg::bars(
                        &format!("{second} of {}", st.name),
                        "input",
                        second,
                        &bars,
                        None,
                    ),
                    &format!("{second} of each input"),
                );
            }
        }
        b.body.push_str("</div>");
    }
}

/// The values of column `c` at probe `p` over every point (NaN where none).
fn column_values(table: &crate::record::columns::Table, name: &str, p: usize) -> Option<Vec<f64>> {
    let c = crate::record::columns::column(name)?;
    let n = table.n;
    let data = table.get(name)?;
    let per = if c.per_probe { table.np.max(1) } else { 1 };
    let width = if c.per_harmonic {
        per * table.nh.max(1)
    } else {
        per
    };
    Some(match data {
        ColumnData::F64(v) => (0..n)
            .map(|i| {
                v.get(i * width + if c.per_probe { p * (width / per) } else { 0 })
                    .copied()
                    .unwrap_or(f64::NAN)
            })
            .collect(),
        ColumnData::I64(v) => (0..n).map(|i| v[i * width] as f64).collect(),
        _ => return None,
    })
}

fn summaries_section(b: &mut Builder, sweep: &Sweep, recs: &FileRecords) {
    let table = recs.table();
    let probes: Vec<chainsweep_solver::observe::probes::Probe> = sweep
        .base
        .get("record")
        .and_then(|r| r.get("probes"))
        .and_then(|p| serde_json::from_value(p.clone()).ok())
        .unwrap_or_default();
    let shape = sweep.shape();
    let n = recs.len();
    let why = |i: usize| -> String {
        if let Some(d) = recs.damage(i) {
            return format!("point {i}: its stored values are damaged ({d})");
        }
        match recs.status(i) {
            STATUS_FAILED => format!("point {i} failed: {}", recs.reason(i)),
            STATUS_PENDING => format!("point {i} pending"),
            STATUS_UNSETTLED => {
                format!("point {i}: its steady state did not settle (steady_settled)")
            }
            _ => format!("point {i}: the run gives no number here"),
        }
    };
    // What is not drawn as a number: a damaged point's values (never served), and a steady-state
    // column's at a point whose steady state did not settle (not a steady state).
    let drawable = |c: &crate::record::columns::Column, mut v: Vec<f64>| -> Vec<f64> {
        // (The settledness itself says how far from settled: drawn everywhere.)
        let steady = c.written == crate::record::columns::Written::WithSteadyState
            && c.name != "steady_settledness";
        for (i, x) in v.iter_mut().enumerate() {
            if recs.damage(i).is_some() || (steady && recs.status(i) == STATUS_UNSETTLED) {
                *x = f64::NAN;
            }
        }
        v
    };
    if probes.len() > MAX_PROBES {
        b.thinned.push(format!(
            "the summaries of the first {MAX_PROBES} of {} probes (the file holds every probe's)",
            probes.len()
        ));
    }
    b.body.push_str("<h2>Summaries</h2><div class=\"plots\">");
    let mut drawn = 0;
    for c in COLUMNS {
        let result = matches!(
            c.fill,
            Fill::ProbeF64 { .. }
                | Fill::SteadyF64 { .. }
                | Fill::SteadyHarmonic { .. }
                | Fill::OkF64 { .. }
        );
        let about_the_run =
            RUN_COLUMNS.iter().any(|(n, _)| *n == c.name) || c.name == "energy_drift_final";
        if !result || about_the_run || table.get(c.name).is_none() {
            continue;
        }
        // A column's own unit, or its probe's (a force probe's peaks in N, their times in s).
        let fixed = match c.units {
            crate::record::columns::Units::Fixed(u) => Some(u.to_string()),
            crate::record::columns::Units::OfProbes => None,
            crate::record::columns::Units::None => Some("1".into()),
        };
        let groups: Vec<(usize, String, String)> = if c.per_probe {
            probes
                .iter()
                .enumerate()
                .take(MAX_PROBES)
                .map(|(k, p)| {
                    (
                        k,
                        p.name(),
                        fixed.clone().unwrap_or_else(|| p.unit().to_string()),
                    )
                })
                .collect()
        } else {
            vec![(0, String::new(), fixed.unwrap_or_else(|| "1".into()))]
        };
        for (p, probe, units) in groups {
            let Some(v) = column_values(table, c.name, p).map(|v| drawable(c, v)) else {
                continue;
            };
            if !v.iter().any(|x| x.is_finite()) {
                continue;
            }
            // (A steady amplitude's or phase's first harmonic: the drive's frequency.)
            let name = if c.per_harmonic {
                format!("{} (fundamental)", c.name)
            } else {
                c.name.to_string()
            };
            let what = if probe.is_empty() {
                name
            } else {
                format!("{name} at {probe}")
            };
            plot_over_axes(b, sweep, &shape, n, &v, &what, &units, &why);
            drawn += 1;
        }
    }
    b.body.push_str("</div>");
    if drawn == 0 {
        b.body
            .push_str("<p class=\"note\">No summary holds a number yet.</p>");
    }
    b.body.push_str("<h2>Runs</h2><div class=\"plots\">");
    for &(name, units) in RUN_COLUMNS {
        let column = crate::record::columns::column(name);
        let values = column_values(table, name, 0)
            .zip(column)
            .map(|(v, c)| drawable(c, v));
        if let Some(v) = values.filter(|v| v.iter().any(|x| x.is_finite())) {
            // A verified error is missing where --verify did not sample the point, not because
            // its run gave no number.
            let verified_why = |i: usize| -> String {
                if recs.status(i) == crate::record::STATUS_OK
                    && recs.verify_info(i).status == crate::record::VERIFY_NONE
                {
                    format!("point {i}: not in --verify's sample")
                } else {
                    why(i)
                }
            };
            let why_here: &dyn Fn(usize) -> String = if name.starts_with("verify_") {
                &verified_why
            } else {
                &why
            };
            plot_over_axes(b, sweep, &shape, n, &v, name, units, why_here);
        }
    }
    b.body.push_str("</div>");
}

fn is_numeric(values: &[serde_json::Value]) -> bool {
    values.iter().all(|v| v.is_number())
}

/// Draws `v` (one value per point) against the axes: lines for one dimension (or two, the outer
/// with few values: a line per value), a heatmap for two, small multiples beyond.
#[allow(clippy::too_many_arguments)]
fn plot_over_axes(
    b: &mut Builder,
    sweep: &Sweep,
    shape: &[usize],
    n: usize,
    v: &[f64],
    what: &str,
    units: &str,
    why: &dyn Fn(usize) -> String,
) {
    let d = shape.len();
    let label_of = |dim: usize| {
        let a = &sweep.dims[dim].axes[0];
        format!("{} [{}]", human_name(&a.name), a.units)
    };
    let y_label = format!(
        "{} [{units}]",
        human_name(what.split(" at ").next().unwrap_or(what))
    );
    let line = |b: &mut Builder,
                dim: usize,
                series_of: &dyn Fn(usize) -> Vec<(String, Vec<usize>)>,
                title: &str,
                outer: usize| {
        let a = &sweep.dims[dim].axes[0];
        let numeric = is_numeric(&a.values);
        let (keep, k) = thin(a.values.len(), MAX_LINE_POINTS);
        if k > 1 {
            b.thinned.push(format!(
                "{title}: every {k}th of {} points along {}",
                a.values.len(),
                a.name
            ));
        }
        let x_of = |j: usize| {
            if numeric {
                a.values[j].as_f64().unwrap_or(f64::NAN)
            } else {
                j as f64
            }
        };
        let series: Vec<Series> = series_of(outer)
            .into_iter()
            .map(|(label, points)| Series {
                points: keep.iter().map(|&j| (x_of(j), v[points[j]])).collect(),
                missing: keep
                    .iter()
                    .filter(|&&j| !v[points[j]].is_finite())
                    .map(|&j| (x_of(j), why(points[j])))
                    .collect(),
                ..Series::line(label, Vec::new())
            })
            .collect();
        let texts: Vec<String> = a.values.iter().map(axis_text).collect();
        let svg = svg::lines(
            title,
            &label_of(dim),
            &y_label,
            &series,
            (!numeric).then_some(&texts[..]),
        );
        b.figure(
            svg,
            &format!(
                "{what} against {}; red crosses: points without a number (hover for why)",
                a.name
            ),
        );
    };
    match d {
        0 => {}
        1 => {
            let all: Vec<usize> = (0..n).collect();
            line(b, 0, &|_| vec![(what.to_string(), all.clone())], what, 0);
        }
        _ => {
            // The last two dimensions in each panel; the ones before them index the panels.
            let (dy, dx) = (d - 2, d - 1);
            let panels: usize = shape[..dy].iter().product();
            let shown = panels.min(MAX_PANELS);
            if panels > shown {
                b.thinned
                    .push(format!("{what}: the first {shown} of {panels} panels"));
            }
            let stride_y = shape[dx];
            for panel in 0..shown {
                let base = panel * shape[dy] * shape[dx];
                let prefix = if d > 2 {
                    let mi = multi_index(&shape[..dy], panel);
                    let parts: Vec<String> = (0..dy)
                        .map(|k| {
                            format!(
                                "{}={}",
                                sweep.dims[k].axes[0].name,
                                axis_text(&sweep.dims[k].axes[0].values[mi[k]])
                            )
                        })
                        .collect();
                    format!("{what} at {}", parts.join(", "))
                } else {
                    what.to_string()
                };
                if shape[dy] <= 10 {
                    let ya = &sweep.dims[dy].axes[0];
                    line(
                        b,
                        dx,
                        &|_| {
                            (0..shape[dy])
                                .map(|i| {
                                    (
                                        format!("{} = {}", ya.name, axis_text(&ya.values[i])),
                                        (0..shape[dx]).map(|j| base + i * stride_y + j).collect(),
                                    )
                                })
                                .collect()
                        },
                        &prefix,
                        panel,
                    );
                } else {
                    let (rows, ky) = thin(shape[dy], MAX_HEATMAP_SIDE);
                    let (cols, kx) = thin(shape[dx], MAX_HEATMAP_SIDE);
                    if ky > 1 || kx > 1 {
                        b.thinned.push(format!(
                            "{prefix}: every {ky}th row and {kx}th column of the heatmap"
                        ));
                    }
                    let (xa, ya) = (&sweep.dims[dx].axes[0], &sweep.dims[dy].axes[0]);
                    let z: Vec<Vec<f64>> = rows
                        .iter()
                        .map(|&i| cols.iter().map(|&j| v[base + i * stride_y + j]).collect())
                        .collect();
                    let short =
                        |v: &serde_json::Value| v.as_f64().map_or_else(|| axis_text(v), svg::num);
                    let xl: Vec<String> = cols.iter().map(|&j| short(&xa.values[j])).collect();
                    let yl: Vec<String> = rows.iter().map(|&i| short(&ya.values[i])).collect();
                    let svg = svg::heatmap(
                        &prefix,
                        &label_of(dx),
                        &label_of(dy),
                        &xl,
                        &yl,
                        &z,
                        &|i, j| Some(why(base + rows[i] * stride_y + cols[j])),
                        units,
                    );
                    b.figure(svg, &format!("{what} over {} and {}; hatched: points without a number (hover for why)", ya.name, xa.name));
                }
            }
        }
    }
}

pub(crate) fn provenance_section(b: &mut Builder, path: &Path, sweep_text: &str) {
    let names = [
        "engine_version",
        "solver_version",
        "git_revision",
        "created_utc",
        "command_line",
        "shard",
    ];
    b.body.push_str("<h2>Provenance</h2><table>");
    let _ = write!(
        b.body,
        "<tr><th>file</th><td>{}</td></tr>",
        esc(&path.display().to_string())
    );
    for n in names {
        if let Some(v) = crate::store::hdf5::fit::read_attrs(path, &[n]) {
            let _ = write!(b.body, "<tr><th>{n}</th><td>{}</td></tr>", esc(&v[0]));
        }
    }
    let _ = write!(
        b.body,
        "</table><details><summary>the sweep file</summary><pre>{}</pre></details>",
        esc(sweep_text)
    );
}

/// Writes each figure of `file`'s page alone into the folder `dir` (made if missing; it must not
/// hold anything else than such figures): `NN-words-of-its-caption.svg` (or `.png`, `.pdf` by
/// `format`), numbered in the page's order, and `captions.txt` with each file's caption.
/// Figures of an earlier report in `dir` are replaced.
pub fn write_figures(
    file: &Path,
    status: &FileStatus,
    points: &[usize],
    dir: &Path,
    format: FigureFormat,
) -> Result<Page> {
    write_figures_of(page(file, status, points)?, dir, format)
}

/// Where a page may be written: a new file, or one a report wrote (its `generator` names
/// chainsweep) that is not read-only. Never a directory, a file the user protected, or any other
/// file (a sweep file given as `-o` by mistake): an input error naming `--output`.
pub fn check_page_output(out: &Path) -> Result<()> {
    let refuse = |why: String| {
        Err(Error::input(
            "--output",
            format!("{}: {why}", out.display()),
        ))
    };
    let Ok(meta) = std::fs::metadata(out) else {
        return Ok(());
    };
    if meta.is_dir() {
        return refuse("is a directory: give the page's file name (FILE.html)".into());
    }
    if crate::engine::read_only(&meta) {
        return refuse(
            "is read-only: not replaced (make it writable, or give another file)".into(),
        );
    }
    let mut head = [0u8; 512];
    let n = std::fs::File::open(out)
        .and_then(|mut f| std::io::Read::read(&mut f, &mut head))
        .unwrap_or(0);
    // (An empty file, one `mktemp` made, holds nothing to lose.)
    if meta.len() > 0
        && !String::from_utf8_lossy(&head[..n])
            .contains("<meta name=\"generator\" content=\"chainsweep")
    {
        return refuse(
            "exists and is not a report's page: not replaced (remove it, or give another file)"
                .into(),
        );
    }
    Ok(())
}

/// [`write_figures`] of a page made already.
pub fn write_figures_of(p: Page, dir: &Path, format: FigureFormat) -> Result<Page> {
    let io = |e: std::io::Error| Error::Other(format!("{}: {e}", dir.display()));
    std::fs::create_dir_all(dir).map_err(io)?;
    for entry in std::fs::read_dir(dir).map_err(io)? {
        let path = entry.map_err(io)?.path();
        // A figure's name as written below (`NN-words.svg|png|pdf`, `NNN-…` from the 100th), or
        // the captions.
        let name = path.file_name().unwrap_or_default().to_string_lossy();
        let digits = name.bytes().take_while(u8::is_ascii_digit).count();
        let figure = digits >= 2
            && name.as_bytes().get(digits) == Some(&b'-')
            && [".svg", ".png", ".pdf"].iter().any(|x| name.ends_with(x));
        let ours = figure || name == "captions.txt";
        if !ours {
            return Err(Error::input(
                "--output",
                format!(
                    "{} holds {}, which is not a figure of a report: give an empty folder or one of figures",
                    dir.display(),
                    path.display()
                ),
            ));
        }
    }
    for entry in std::fs::read_dir(dir).map_err(io)? {
        std::fs::remove_file(entry.map_err(io)?.path()).map_err(io)?;
    }
    let mut captions = String::new();
    for (k, (caption, svg)) in p.svgs.iter().enumerate() {
        let words: String = caption
            .chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() {
                    c.to_ascii_lowercase()
                } else {
                    '-'
                }
            })
            .collect::<String>()
            .split('-')
            .filter(|w| !w.is_empty())
            .take(8)
            .collect::<Vec<_>>()
            .join("-");
        let name = format!("{:02}-{words}.{}", k + 1, format.extension());
        std::fs::write(dir.join(&name), export::encode(svg, format, caption)?).map_err(io)?;
        let _ = writeln!(captions, "{name}\t{caption}");
    }
    for note in &p.thinned {
        let _ = writeln!(captions, "# thinned (the file holds every point): {note}");
    }
    std::fs::write(dir.join("captions.txt"), captions).map_err(io)?;
    Ok(p)
}

/// Writes the page of `file` to `out` atomically (a temporary file renamed over it).
pub fn write(file: &Path, status: &FileStatus, points: &[usize], out: &Path) -> Result<Page> {
    write_page(page(file, status, points)?, out)
}

/// [`write`] of a page made already.
pub fn write_page(p: Page, out: &Path) -> Result<Page> {
    check_page_output(out)?;
    let tmp = out.with_extension("html.tmp");
    std::fs::write(&tmp, &p.html).map_err(|e| Error::Other(format!("{}: {e}", tmp.display())))?;
    std::fs::rename(&tmp, out).map_err(|e| Error::Other(format!("{}: {e}", out.display())))?;
    Ok(p)
}
