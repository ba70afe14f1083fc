//! The text the command line prints for each report of the engine.
//!
//! What several reports share is here; each command's text is in the file named for it:
//! `validate` (and `run --dry-run`), `run`, `status`, `shards` (`merge`, `slurm`, the status of
//! shard files), `inspect`; `gc`'s is here.

use std::path::Path;

use crate::progress::damage_lines;
use chainsweep::engine::gc::GcReport;
use chainsweep::engine::DamageReport;
use chainsweep::identity::hex;

mod inspect;
mod run;
mod shards;
mod status;
mod validate;

pub use inspect::{point, study};
pub use run::{run_report, stopped};
pub use shards::{merged, shard_set_status, slurm_job, submitted};
pub use status::{file_status, periodic_status, sweep_status};
pub use validate::{dry_run, dry_run_periodic, dry_run_search, validated};

/// `3 × 2`.
fn shape_text(shape: &[usize]) -> String {
    shape
        .iter()
        .map(|x| x.to_string())
        .collect::<Vec<_>>()
        .join(" × ")
}

/// `1.5 MiB`.
pub fn human(bytes: f64) -> String {
    let units = ["B", "KiB", "MiB", "GiB", "TiB"];
    let mut b = bytes;
    let mut u = 0;
    while b >= 1024.0 && u + 1 < units.len() {
        b /= 1024.0;
        u += 1;
    }
    format!("{b:.1} {}", units[u])
}

/// What status found damaged, on stdout, each line indented.
fn damage_status(d: &DamageReport) {
    if d.unchecked {
        outln!(
            "  this file carries no checksums (written by an earlier chainsweep): its values cannot be checked; running its sweep again rewrites it with them"
        );
    }
    for l in damage_lines(d) {
        outln!("  {l}");
    }
    if d.any() {
        outln!(
            "  `chainsweep run` of its sweep into {} repairs it: runs restored from the snapshot are kept, the others computed again",
            d.output.display()
        );
    }
}

/// The health line: what is not right, then how well the rest was verified (`label` names a
/// point).
fn health_text(h: &chainsweep::engine::run::Health, label: impl Fn(usize) -> String) -> String {
    let mut wrong = Vec::new();
    if h.failed > 0 {
        wrong.push(if h.over_limit > 0 {
            format!("{} failed ({} over a limit)", h.failed, h.over_limit)
        } else {
            format!("{} failed", h.failed)
        });
    }
    if h.unsettled > 0 {
        wrong.push(format!("{} unsettled", h.unsettled));
    }
    if h.nan_leading > 0 {
        wrong.push(format!("{} with a NaN leading peak", h.nan_leading));
    }
    let first = if wrong.is_empty() {
        "every finished run ok".to_string()
    } else {
        wrong.join(", ")
    };
    let verified = match (h.verified, h.worst_verified) {
        (0, _) => {
            "none verified (`run --verify FRACTION` bounds the errors of a sample)".to_string()
        }
        (n, Some((e, i))) => format!(
            "{n} verified at a tighter setting, largest error bound {e:.2e} at point {i} ({})",
            label(i)
        ),
        (n, None) => format!("{n} verified at a tighter setting"),
    };
    format!("health: {first}; {verified}")
}

/// How many runs did not settle, which (the first [`chainsweep::engine::run::LISTED_FAILURES`] by `label`), and what to
/// do: one line, then one per point.
fn unsettled_lines(points: &[usize], label: impl Fn(usize) -> String) -> Vec<String> {
    let mut lines = vec![format!(
        "{} run(s) did not settle (`status` = 3, unsettled): their steady state still changed over the window by more than record.steady_state.settled_tolerance (`steady_settledness`), so their amplitudes and phases are not the steady state's; lengthen record.steady_state.settle_periods (runs with the new value are new runs; the others stay)",
        points.len()
    )];
    for &i in points.iter().take(chainsweep::engine::run::LISTED_FAILURES) {
        lines.push(format!("  unsettled: point {i} ({})", label(i)));
    }
    if points.len() > chainsweep::engine::run::LISTED_FAILURES {
        lines.push(format!(
            "  … and {} more (the `status` dataset)",
            points.len() - chainsweep::engine::run::LISTED_FAILURES
        ));
    }
    lines
}

/// How many succeeded runs left a leading peak NaN, and why, with the first of them (at `first`).
fn unpassed_text(count: usize, first: &str) -> String {
    format!(
        "{count} ok run(s) have a NaN leading_peak: the leading pulse had not passed a probe by the end of the run (`leading_pulse` = 2; first at {first}); lengthen duration_s to measure it"
    )
}

/// An ensemble's outcome and statistics, a line each (as `status` and the end of `run` give them).
pub fn ensemble_lines(e: &chainsweep::engine::status::EnsembleStatus) -> Vec<String> {
    let o = &e.outcome;
    let why = match o.stopped_by {
        "fixed" => "a fixed size".to_string(),
        "tolerance" => format!(
            "every interval within its tolerance (widest {:.2} of it)",
            o.worst_ratio
        ),
        "budget" => format!(
            "the budget: the next round would pass max_runs (widest interval {:.2} × its tolerance)",
            o.worst_ratio
        ),
        "running" => "another round is due (`run` goes on)".to_string(),
        "failed" => "samples that failed or whose statistic has no value: the statistics are over the others only, which no tolerance vouches for (`<statistic>_missing` counts them; failed runs: fix their cause, then `run --retry-failed`; a statistic without a value at some samples, a leading peak that had not passed, is no adaptive ensemble's)".to_string(),
        _ => "runs of this round are missing (`run` goes on)".to_string(),
    };
    let mut out = vec![format!(
        "ensemble ({} design): round {}, {} samples per point, {} runs; ended by {why}",
        e.design, o.round, o.samples, o.runs
    )];
    // Six significant digits, in fixed notation where that reads well.
    let g = |x: f64| {
        let a = x.abs();
        if x == 0.0 || (1e-3..1e6).contains(&a) {
            let decimals = (5 - a.log10().floor() as i32).clamp(0, 8) as usize;
            format!("{x:.decimals$}")
        } else {
            format!("{x:.5e}")
        }
    };
    let iv = |x: &chainsweep::uq::stats::Estimate| {
        if x.lower.is_nan() {
            g(x.value)
        } else {
            format!("{} [{}, {}]", g(x.value), g(x.lower), g(x.upper))
        }
    };
    for st in &e.statistics {
        for p in &st.points {
            let at = if p.label.is_empty() {
                String::new()
            } else {
                format!(" at {}", p.label)
            };
            out.push(format!(
                "  {}{at} ({} samples; {}; 95 % intervals):",
                st.name, p.n, st.units
            ));
            if e.design != "morris" {
                out.push(format!("    mean {}", iv(&p.mean)));
                out.push(format!("    sd   {}", iv(&p.sd)));
                for (q, x) in &p.quantiles {
                    out.push(format!("    q{:<4} {}", q * 100.0, iv(x)));
                }
            }
            for (input, a, b) in &p.sensitivity {
                let (first, second) = if e.design == "morris" {
                    ("mu*", "sigma")
                } else {
                    ("first-order", "total")
                };
                out.push(format!(
                    "    {input}: {first} {}, {second} {}",
                    iv(a),
                    iv(b)
                ));
            }
        }
    }
    out
}

/// Each search of a sweep with a search, a line each.
fn search_lines(lines: &[chainsweep::engine::status::SearchLine]) {
    for l in lines {
        let at = if l.label.is_empty() {
            "search".to_string()
        } else {
            format!("search at {}", l.label)
        };
        if l.note.is_empty() {
            outln!("  {at}: {} after {} run(s)", l.status, l.runs);
        } else {
            outln!("  {at}: {} after {} run(s); {}", l.status, l.runs, l.note);
        }
        for a in &l.answers {
            outln!("    {} {}", a.item, a.text);
        }
    }
}

/// What `gc` removed (or would remove): every run, by hash, and every damaged file.
pub fn gc(output: &Path, r: &GcReport) {
    let verb = if r.dry_run { "would remove" } else { "removed" };
    let c = &r.compaction;
    for (h, ok) in &c.removed_runs {
        outln!(
            "{verb}: run {} ({}), of a point the sweep no longer has",
            hex(h),
            if *ok { "ok" } else { "failed" }
        );
    }
    for f in &r.damaged_files {
        outln!("{verb}: damaged output file kept aside: {}", f.display());
    }
    outln!(
        "{}: {verb} {} run(s) the sweep no longer has and {} damaged file(s); kept {} run(s) beside the output file{}",
        chainsweep::store::work_dir_of(output).display(),
        c.removed,
        r.damaged_files.len(),
        c.kept,
        if r.dry_run {
            " (dry run: nothing removed; run again without --dry-run to remove them)".to_string()
        } else {
            format!(" ({} file(s) removed)", c.files_removed)
        }
    );
    for l in damage_lines(&r.damage) {
        outln!("  {l}");
    }
}
