//! The report of a periodic sweep's file: how each branch ended with its special points, each
//! probe's fundamental amplitude over the orbits against the continued field (a curve per branch,
//! stable orbits solid, unstable dashed, special points marked), and the largest Floquet
//! multiplier along each branch.

use std::fmt::Write as _;
use std::path::Path;

use super::svg::{self, esc, Series};
use super::{finish, provenance_section, Builder, Page, MAX_PROBES};
use crate::engine::periodic::PeriodicStatus;
use crate::error::Result;
use crate::grid::Grid;
use crate::store::hdf5::periodic::{read_tables, BranchTables};
use crate::sweep::{human_name, Sweep};

/// The page of the periodic sweep's output file `path`, with its `status`.
pub fn page(path: &Path, status: &PeriodicStatus) -> Result<Page> {
    let t = read_tables(path)?;
    let sweep = Sweep::parse(&t.sweep_text).map_err(|e| e.in_file(&path.display().to_string()))?;
    let grid = Grid::new(&sweep)?;
    let name = path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    );
    let mut b = Builder {
        body: String::new(),
        figures: 0,
        thinned: Vec::new(),
        svgs: Vec::new(),
    };
    let labels: Vec<String> = (0..t.branches)
        .map(|i| {
            let l = grid.point_label(&sweep, i);
            if l.is_empty() {
                "branch".to_string()
            } else {
                l
            }
        })
        .collect();
    branches_section(&mut b, status, &labels);
    curves_section(&mut b, &t, &labels);
    provenance_section(&mut b, path, &t.sweep_text);
    Ok(finish(b, &name, &sweep.description))
}

fn branches_section(b: &mut Builder, s: &PeriodicStatus, labels: &[String]) {
    let c = &s.counts;
    let _ = write!(
        b.body,
        "<h2>Branches</h2><p>{} branch(es) of periodic orbits: {} ended, <span class=\"{}\">{} failed</span>, {} pending.</p>",
        s.branches.len(),
        c.ok,
        if c.failed > 0 { "bad" } else { "" },
        c.failed,
        c.pending
    );
    if let Some(d) = &s.damage {
        let _ = write!(b.body, "<p class=\"bad\">Damaged: {}</p>", esc(d));
    }
    b.body.push_str(
        "<table><tr><th>branch</th><th>state</th><th>points</th><th>special points</th><th>why it ended</th></tr>",
    );
    for (i, br) in s.branches.iter().enumerate() {
        let special: Vec<String> = br
            .special
            .iter()
            .map(|(k, at)| format!("{k} at {}", svg::num(*at)))
            .collect();
        let _ = write!(
            b.body,
            "<tr><td>{}</td><td class=\"{}\">{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            esc(labels.get(i).map_or("", String::as_str)),
            if br.state == "failed" { "bad" } else { "" },
            br.state,
            br.points.max(0),
            esc(&special.join(", ")),
            esc(&br.end)
        );
    }
    b.body.push_str("</table>");
}

/// A branch's curve as series: its stable orbits (solid, labelled) and its unstable ones
/// (dashed), each a break where the other is; `value(k)` the quantity at point `k`.
fn curve(
    t: &BranchTables,
    branch: usize,
    label: &str,
    value: &dyn Fn(usize) -> f64,
) -> Vec<Series> {
    let at = |k: usize| branch * t.per_branch + k;
    let n = (0..t.per_branch)
        .take_while(|&k| t.kind[at(k)] != 0)
        .count();
    let part = |stable: bool| -> Vec<(f64, f64)> {
        (0..n)
            .map(|k| {
                // A point where stability changes belongs to both parts, so the curve is joined.
                let s = |k: usize| t.stability[at(k)] == 1;
                let here = s(k) == stable
                    || (k > 0 && s(k - 1) == stable)
                    || (k + 1 < n && s(k + 1) == stable);
                (t.parameter[at(k)], if here { value(k) } else { f64::NAN })
            })
            .collect()
    };
    let special: Vec<(f64, f64)> = (0..n)
        .filter(|&k| t.kind[at(k)] >= 4)
        .map(|k| (t.parameter[at(k)], value(k)))
        .collect();
    let mut out = vec![Series {
        colour: Some(branch),
        ..Series::line(label, part(true))
    }];
    if (0..n).any(|k| t.stability[at(k)] == 2) {
        out.push(Series {
            colour: Some(branch),
            dashed: true,
            ..Series::line("", part(false))
        });
    }
    if !special.is_empty() {
        // Marked points only: a path of its own would join them.
        out.push(Series {
            colour: Some(branch),
            ..Series::line(
                "",
                special
                    .into_iter()
                    .flat_map(|p| [p, (p.0, f64::NAN)])
                    .collect(),
            )
        });
    }
    out
}

fn curves_section(b: &mut Builder, t: &BranchTables, labels: &[String]) {
    let x_label = format!("{} [{}]", human_name(&t.name), t.units);
    let np = t.probes.len();
    if np > MAX_PROBES {
        b.thinned.push(format!(
            "the curves of the first {MAX_PROBES} of {np} probes (the file holds every probe's)"
        ));
    }
    b.body
        .push_str("<h2>Frequency response</h2><div class=\"plots\">");
    for (p, (probe, unit)) in t.probes.iter().enumerate().take(MAX_PROBES) {
        let series: Vec<Series> = (0..t.branches)
            .flat_map(|br| {
                curve(t, br, &labels[br], &|k| {
                    t.amplitude[(br * t.per_branch + k) * np + p]
                })
            })
            .collect();
        b.figure(
            svg::lines(
                &format!("{probe}: amplitude over the orbit"),
                &x_label,
                &format!("fundamental amplitude [{unit}]"),
                &series,
                None,
            ),
            &format!(
                "the fundamental amplitude of {probe} over each orbit against {}: stable orbits solid, unstable dashed, folds and bifurcations marked (see the table)",
                t.name
            ),
        );
    }
    let series: Vec<Series> = (0..t.branches)
        .flat_map(|br| {
            curve(t, br, &labels[br], &|k| {
                t.largest_multiplier[br * t.per_branch + k]
            })
        })
        .collect();
    b.figure(
        svg::lines(
            "largest Floquet multiplier",
            &x_label,
            "largest |multiplier|",
            &series,
            None,
        ),
        "the largest modulus of each orbit's Floquet multipliers: above 1, unstable",
    );
    b.body.push_str("</div>");
}
