//! The report's histories: each probe's recorded signal over time at chosen points (by default
//! the evaluation of a search with the best objective, else the first point whose run is ok),
//! read checked from the file as `status` and `open` read them.

use super::svg::{self, Series};
use super::{thin, Builder, MAX_LINE_POINTS, MAX_PROBES};
use crate::record::{STATUS_OK, STATUS_UNSETTLED};
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

/// The point a search's page draws by default: the evaluation whose run is ok with the best
/// objective (the smallest for a fit or a minimum, the largest for a maximum, the nearest to the
/// level for a root), where the file holds one run per evaluation (no `across` axis); `None`
/// otherwise.
pub(super) fn best_of_search(
    path: &std::path::Path,
    sweep: &Sweep,
    recs: &FileRecords,
) -> Option<usize> {
    use crate::sweep::search::Goal;
    let spec = sweep.search.as_ref()?;
    let objective = crate::store::hdf5::fit::read_f64(path, "objective")?;
    if spec.across.is_some() || objective.len() != recs.len() {
        return None;
    }
    // A refinement samples a curve: no evaluation is better than another.
    if matches!(spec.goal, Goal::Refine) {
        return None;
    }
    let score = |i: usize| -> Option<f64> {
        let v = objective[i];
        (v.is_finite() && recs.status(i) == STATUS_OK).then(|| match spec.goal {
            Goal::Maximise => -v,
            Goal::Root => (v - spec.level).abs(),
            _ => v,
        })
    };
    (0..recs.len())
        .filter_map(|i| score(i).map(|s| (i, s)))
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(i, _)| i)
}

/// The histories of `points` (flat indices; empty: `default`, else the first ok point), a figure
/// per point and unit of its probes.
pub(super) fn section(
    b: &mut Builder,
    sweep: &Sweep,
    recs: &FileRecords,
    points: &[usize],
    default: Option<usize>,
) {
    // A run whose steady state did not settle recorded its history as any ok run does (the
    // history shows why it did not settle); a damaged point's values are not served.
    let has_history = |recs: &FileRecords, i: usize| {
        matches!(recs.status(i), STATUS_OK | STATUS_UNSETTLED) && recs.damage(i).is_none()
    };
    if !recorded(sweep) {
        return;
    }
    let Some((sweep, grid)) = crate::store::published::own_sweep_and_grid(recs) else {
        return;
    };
    let sweep = &sweep;
    let chosen: Vec<usize> = if points.is_empty() {
        default
            .or_else(|| (0..recs.len()).find(|&i| has_history(recs, i)))
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
        let which = if default.is_some() {
            "The evaluation with the best objective"
        } else {
            "The first point whose run is ok"
        };
        let _ = std::fmt::Write::write_fmt(
            &mut b.body,
            format_args!("<p class=\"note\">{which}; <code>chainsweep report FILE --point N</code> (repeatable) draws others.</p>"),
        );
    }
    b.body.push_str("<div class=\"plots\">");
    for &i in chosen.iter().take(MAX_HISTORY_POINTS) {
        let label = grid.point_label(sweep, i);
        if !has_history(recs, i) {
            let why = recs.damage(i).map_or_else(
                || "its run is not ok".to_string(),
                |d| format!("its stored values are damaged ({d})"),
            );
            let _ = std::fmt::Write::write_fmt(
                &mut b.body,
                format_args!(
                    "<p class=\"bad\">point {i} ({}): no history, {}</p>",
                    svg::esc(&label),
                    svg::esc(&why)
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
        for unit in &units {
            let of_unit = grid.probes.iter().filter(|p| p.unit() == *unit).count();
            let note = format!(
                "histories in {unit}: the first {MAX_PROBES} of {of_unit} probes (the file holds every probe's)"
            );
            if of_unit > MAX_PROBES && !b.thinned.contains(&note) {
                b.thinned.push(note);
            }
        }
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
