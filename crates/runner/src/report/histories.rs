//! The report's histories: each probe's recorded signal over time at chosen points (by default
//! the first point whose run is ok), read checked from the file as `status` and `open` read them.

use super::svg::{self, Series};
use super::{thin, Builder, MAX_LINE_POINTS, MAX_PROBES};
use crate::record::STATUS_OK;
use crate::store::hdf5::FileRecords;
use crate::sweep::Sweep;

/// The most points whose histories a page draws.
pub const MAX_HISTORY_POINTS: usize = 12;

/// Whether the sweep records histories.
pub(super) fn recorded(sweep: &Sweep) -> bool {
    sweep
        .base
        .get("record")
        .and_then(|r| r.get("history"))
        .and_then(serde_json::Value::as_bool)
        .unwrap_or(false)
}

/// The histories of `points` (flat indices; empty: the first ok point), a figure per point and
/// unit of its probes.
pub(super) fn section(b: &mut Builder, sweep: &Sweep, recs: &FileRecords, points: &[usize]) {
    if !recorded(sweep) {
        return;
    }
    let Some((sweep, grid)) = crate::store::published::own_sweep_and_grid(recs) else {
        return;
    };
    let sweep = &sweep;
    let chosen: Vec<usize> = if points.is_empty() {
        (0..recs.len())
            .find(|&i| recs.status(i) == STATUS_OK)
            .into_iter()
            .collect()
    } else {
        points.to_vec()
    };
    if chosen.is_empty() {
        return;
    }
    b.body.push_str("<h2>Histories</h2>");
    if points.is_empty() {
        b.body.push_str("<p class=\"note\">The first point whose run is ok; <code>chainsweep report FILE --point N</code> (repeatable) draws others.</p>");
    }
    b.body.push_str("<div class=\"plots\">");
    for &i in chosen.iter().take(MAX_HISTORY_POINTS) {
        let label = grid.point_label(sweep, i);
        if recs.status(i) != STATUS_OK {
            let _ = std::fmt::Write::write_fmt(
                &mut b.body,
                format_args!(
                    "<p class=\"bad\">point {i} ({}): no history, its run is not ok</p>",
                    svg::esc(&label)
                ),
            );
            continue;
        }
        let checksum = recs.table().checksum_at("history_checksum", i);
        let history = match recs.read_group(i, &grid, checksum) {
            Ok((Some(h), ..)) => h,
            Ok((None, ..)) => continue,
            Err(why) => {
                let _ = std::fmt::Write::write_fmt(
                    &mut b.body,
                    format_args!(
                        "<p class=\"bad\">point {i} ({}): {}</p>",
                        svg::esc(&label),
                        svg::esc(&why)
                    ),
                );
                continue;
            }
        };
        let (keep, k) = thin(history.time_s.len(), MAX_LINE_POINTS);
        if k > 1 {
            b.thinned.push(format!(
                "the history at point {i}: every {k}-th of its {} samples",
                history.time_s.len()
            ));
        }
        // One figure per unit: forces with forces, velocities with velocities.
        let mut units: Vec<&str> = grid.probes.iter().map(|p| p.unit()).collect();
        units.dedup();
        units.sort_unstable();
        units.dedup();
        for unit in units {
            let series: Vec<Series> = grid
                .probes
                .iter()
                .enumerate()
                .filter(|(_, p)| p.unit() == unit)
                .take(MAX_PROBES)
                .filter_map(|(k, p)| {
                    let v = history.values.get(k)?;
                    let points = keep
                        .iter()
                        .filter_map(|&j| Some((*history.time_s.get(j)?, *v.get(j)?)))
                        .collect();
                    Some(Series::line(p.name(), points))
                })
                .collect();
            if series.iter().all(|s| s.points.is_empty()) {
                continue;
            }
            b.figure(
                svg::lines(
                    &format!("history at point {i}"),
                    "time [s]",
                    &format!("[{unit}]"),
                    &series,
                    None,
                ),
                &format!("each probe's history at point {i}: {label}"),
            );
        }
    }
    b.body.push_str("</div>");
}
