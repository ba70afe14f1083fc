//! `status` of an output file and of a sweep.

use std::path::Path;

use super::{
    damage_status, ensemble_lines, health_text, search_lines, shape_text, unpassed_text,
    unsettled_lines,
};
use chainsweep::engine::periodic::PeriodicStatus;
use chainsweep::engine::status::{FileStatus, SweepStatus};
use chainsweep::grid::{multi_index, Grid};
use chainsweep::sweep::auto::describe;
use chainsweep::sweep::Sweep;

/// How many failed points `status` of an output file lists.
const LISTED_IN_STATUS: usize = 20;

/// `status` of a periodic sweep's output file: its branches, each with its special points.
pub fn periodic_status(file: &Path, s: &PeriodicStatus) {
    use chainsweep::error::number_text as num;
    outln!(
        "{}: {} branch(es) of periodic orbits: {} ended, {} failed, {} pending",
        file.display(),
        s.branches.len(),
        s.counts.ok,
        s.counts.failed,
        s.counts.pending
    );
    for (i, b) in s.branches.iter().enumerate() {
        let special: Vec<String> = b
            .special
            .iter()
            .map(|(kind, at)| format!("{kind} at {}", num(*at)))
            .collect();
        outln!(
            "  branch {i}: {}, {} point(s){}: {}",
            b.state,
            b.points.max(0),
            if special.is_empty() {
                String::new()
            } else {
                format!(" ({})", special.join(", "))
            },
            b.end
        );
    }
    if let Some(d) = &s.damage {
        outln!("  damaged: {d}; re-run the same `chainsweep run` command to write it again from its journals");
    }
}

/// `status` of an output file.
pub fn file_status(file: &Path, s: &FileStatus) {
    match &s.searches {
        // A search's runs are what its searches chose to evaluate: none is pending.
        Some(lines) => outln!(
            "{}: {} search(es) ({}shard {}), {} runs ({} ok, {} failed)",
            file.display(),
            lines.len(),
            if s.shape.is_empty() {
                String::new()
            } else {
                format!("outer grid {}, ", shape_text(&s.shape))
            },
            s.shard,
            s.counts.ok + s.counts.failed,
            s.counts.ok,
            s.counts.failed,
        ),
        None => outln!(
            "{}: {} runs (grid {}, shard {}): {} done ({}), {} pending",
            file.display(),
            s.total,
            shape_text(&s.shape),
            s.shard,
            s.counts.done(),
            s.counts.finished_text(),
            s.counts.pending
        ),
    }
    match (&s.writer, s.newer) {
        (Some(pid), 0) => outln!("  a sweep is writing this file now (process {pid})"),
        (Some(pid), newer) => outln!(
            "  a sweep is writing this file now (process {pid}): {newer} more run(s) have finished since it was last written, and appear at its next checkpoint"
        ),
        (None, 0) => {}
        (None, newer) => outln!(
            "  {newer} more run(s) have finished since the file was written, and no process is writing it: the sweep was interrupted; re-run the same `chainsweep run` command to bring the file up to date"
        ),
    }
    if s.other_shards > 0 {
        outln!(
            "  it also holds {} run(s) of other shards (kept from the output it was run into)",
            s.other_shards
        );
    }
    if s.other_engine > 0 {
        outln!(
            "  {} of its pending points hold runs made by another version of the engine or of its numerics (this one's numerics version is {}): `chainsweep run` computes them again",
            s.other_engine,
            chainsweep::NUMERICS_VERSION
        );
    }
    // Points by their axis values, as `run` names them (by their indices where none was kept).
    let label = |i: usize| match (&s.searches, s.labels.get(&i)) {
        (Some(_), _) => format!("evaluation {i}"),
        (None, Some(l)) => l.clone(),
        (None, None) => index_text(&s.shape, i),
    };
    for (shown, (i, reason)) in s.failures.iter().enumerate() {
        if shown == LISTED_IN_STATUS {
            outln!("  …");
            break;
        }
        if s.searches.is_some() {
            // A search file's points are its evaluations (the file's `evaluation` index), not
            // points of the outer grid.
            outln!("  failed: evaluation {i}: {reason}");
        } else {
            outln!("  failed: point {i} ({}): {reason}", label(*i));
        }
    }
    if let Some(&i) = s.unpassed.first() {
        let first = format!("point {i} ({})", label(i));
        outln!("  {}", unpassed_text(s.unpassed.len(), &first));
    }
    if !s.unsettled.is_empty() {
        for line in unsettled_lines(&s.unsettled, label) {
            outln!("  {line}");
        }
    }
    if let Some(lines) = &s.searches {
        search_lines(lines);
    }
    outln!("  {}", health_text(&s.health, label));
    if let Some(e) = &s.ensemble {
        for line in ensemble_lines(e) {
            outln!("  {line}");
        }
    }
    damage_status(&s.damage);
}

/// Point `i` of a grid of shape `shape` by its indices: `[2, 0]`.
fn index_text(shape: &[usize], i: usize) -> String {
    let mi: Vec<String> = multi_index(shape, i)
        .iter()
        .map(|x| x.to_string())
        .collect();
    format!("[{}]", mi.join(", "))
}

/// `status` of a sweep file's output.
pub fn sweep_status(file: &Path, sweep: &Sweep, grid: &Grid, s: &SweepStatus) {
    if let (Some(spec), Some(c)) = (sweep.auto, &s.auto) {
        outln!(
            "integrator auto, target {:e}: {}",
            spec.target_rel_error,
            describe(&c.integrator)
        );
    }
    let Some(counts) = s.counts else {
        outln!(
            "{} → {}: {} runs: 0 done, {} pending (integrator auto not chosen yet: {} holds no choice for this sweep)",
            file.display(),
            s.output.display(),
            s.points,
            s.points,
            s.auto_cache.as_deref().unwrap_or(Path::new("")).display()
        );
        return;
    };
    if s.searches.is_some() {
        // The counts of a search sweep are of its searches (ok: ended; pending: running or
        // stopped by its budget; failed: stopped by a failed run).
        outln!(
            "{} → {}: {} search(es): {} ended, {} failed, {} unfinished",
            file.display(),
            s.output.display(),
            s.points,
            counts.ok,
            counts.failed,
            counts.pending
        );
    } else {
        outln!(
            "{} → {}: {} runs: {} done ({}), {} pending",
            file.display(),
            s.output.display(),
            s.points,
            counts.done(),
            counts.finished_text(),
            counts.pending
        );
    }
    if let Some(pid) = &s.writer {
        outln!("  a sweep is running into this output now (process {pid})");
    }
    for p in &s.ignored {
        outln!(
            "  ignored (not a regular file where a run log is expected; remove it): {}",
            p.display()
        );
    }
    for f in &s.failures {
        outln!(
            "  failed: point {} ({}): {}",
            f.point,
            grid.point_label(sweep, f.point),
            f.reason.as_deref().unwrap_or("")
        );
    }
    if let Some(&i) = s.unpassed.first() {
        let first = format!("point {i} ({})", grid.point_label(sweep, i));
        outln!("  {}", unpassed_text(s.unpassed.len(), &first));
    }
    if !s.unsettled.is_empty() {
        for line in unsettled_lines(&s.unsettled, |i| grid.point_label(sweep, i)) {
            outln!("  {line}");
        }
    }
    if let Some(lines) = &s.searches {
        search_lines(lines);
    } else if s.counts.is_some() {
        outln!(
            "  {}",
            health_text(&s.health, |i| grid.point_label(sweep, i))
        );
    }
    if let Some(e) = &s.ensemble {
        for line in ensemble_lines(e) {
            outln!("  {line}");
        }
    }
    damage_status(&s.damage);
}
