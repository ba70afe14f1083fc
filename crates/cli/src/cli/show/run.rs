//! `run`: what a sweep (or a search) did, its failures, and a run stopped by a signal.

use std::path::Path;

use super::{ensemble_lines, health_text, unpassed_text, unsettled_lines};
use chainsweep::engine::run::{Failure, RunReport};
use chainsweep::engine::search::{self, SearchReport};
use chainsweep::grid::Grid;
use chainsweep::sweep::Sweep;

/// The end of `run`: failed runs (always), failed verification runs (always), the largest
/// verified error and the counts (unless `quiet`).
pub fn run_report(sweep: &Sweep, grid: &Grid, r: &RunReport, output: &Path, quiet: bool) {
    if let Some(s) = &r.search {
        search_report(sweep, grid, s, output, quiet);
        return;
    }
    if r.nothing_to_do && !quiet {
        errln!(
            "chainsweep: nothing to do: {} already holds every run of this sweep; it was left as it is",
            output.display()
        );
    }
    if r.failed > 0 {
        errln!("chainsweep: {} failed run(s):", r.failed);
        list_failures(sweep, grid, &r.failures, "(reason unreadable)");
        if r.failed > r.failures.len() {
            errln!(
                "  … and {} more (see the `status` and `reason` datasets)",
                r.failed - r.failures.len()
            );
        }
    }
    let v = &r.verification;
    if v.failed > 0 {
        errln!(
            "chainsweep: {} verification run(s) failed (`verified` = 2):",
            v.failed
        );
        list_failures(sweep, grid, &v.failures, "");
    }
    if !quiet && (v.requested > 0 || v.verified > 0) {
        match v.worst {
            Some((e, i)) => errln!(
                "chainsweep: {} point(s) verified at a tighter setting; largest relative error {e:.2e} at point {i} ({})",
                v.verified,
                grid.point_label(sweep, i)
            ),
            None => errln!(
                "chainsweep: {} point(s) verified at a tighter setting",
                v.verified
            ),
        }
        for (what, why) in &v.not_verified {
            errln!("chainsweep: not verified: {what} ({why})");
        }
    }
    if !r.unsettled.is_empty() {
        for line in unsettled_lines(&r.unsettled, |i| grid.point_label(sweep, i)) {
            errln!("chainsweep: {line}");
        }
    }
    if !quiet {
        if let Some(&i) = r.unpassed.first() {
            let first = format!("point {i} ({})", grid.point_label(sweep, i));
            errln!("chainsweep: {}", unpassed_text(r.unpassed.len(), &first));
        }
        errln!(
            "chainsweep: {} runs: {}, {} pending → {}",
            r.points,
            r.counts.finished_text(),
            r.counts.pending,
            output.display()
        );
        errln!(
            "chainsweep: {}",
            health_text(&r.health, |i| grid.point_label(sweep, i))
        );
    }
    // An ensemble's answer is its statistics: always shown.
    if let Some(e) = chainsweep::engine::status::ensemble_of(output, sweep) {
        for line in ensemble_lines(&e) {
            errln!("chainsweep: {line}");
        }
    }
}

/// The end of a search sweep: every search's outcome (always: it is the answer), the counts
/// (unless `quiet`).
fn search_report(sweep: &Sweep, grid: &Grid, r: &SearchReport, output: &Path, quiet: bool) {
    let driver = search::Driver::new(sweep, grid);
    let spec = driver.spec;
    errln!("chainsweep: {}", spec.describe());
    for s in &r.searches {
        let label = search::outer_label(sweep, &driver.layout, s.outer);
        let at = if label.is_empty() {
            String::new()
        } else {
            format!("{label}: ")
        };
        if spec.goal == chainsweep::sweep::search::Goal::Fit {
            // A fit's answer, its statistics and each warning on a line of its own.
            errln!(
                "  {at}{} after {} run(s):",
                s.outcome.status.name(),
                s.runs()
            );
            for part in s.outcome.note.split("; ") {
                errln!("    {part}");
            }
            continue;
        }
        errln!(
            "  {at}{} after {} run(s): {}",
            s.outcome.status.name(),
            s.runs(),
            s.outcome.note
        );
        for it in &s.outcome.items {
            errln!(
                "    {} {}",
                spec.goal.item(),
                search::describe_item(spec, it)
            );
        }
        if spec.goal == chainsweep::sweep::search::Goal::Refine && !s.outcome.refine_error.is_nan()
        {
            errln!(
                "    largest estimated interpolation error {:.3e} (tolerance {:e})",
                s.outcome.refine_error,
                spec.objective_tolerance
            );
        }
    }
    if let (n, Some(e)) = r.verified {
        errln!("chainsweep: {n} evaluation point(s) verified at a tighter setting; largest relative error {e:.2e}");
    }
    if !quiet {
        errln!(
            "chainsweep: {} search(es), {} run(s) computed now ({} failed) → {}",
            r.searches.len(),
            r.ran,
            r.failed,
            output.display()
        );
    }
}

fn list_failures(sweep: &Sweep, grid: &Grid, failures: &[Failure], unreadable: &str) {
    for f in failures {
        errln!(
            "  point {} ({}): {}",
            f.point,
            grid.point_label(sweep, f.point),
            f.reason.as_deref().unwrap_or(unreadable)
        );
    }
}

/// `run` stopped by a signal: what the output holds and how to go on.
pub fn stopped(signal: &str, r: &RunReport, output: &Path) {
    errln!(
        "chainsweep: stopped by {signal}: {} holds every finished run ({}), {} pending; run the same command to resume",
        output.display(),
        r.counts.finished_text(),
        r.counts.pending
    );
}
