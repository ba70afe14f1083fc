//! The text the command line prints for each report of the engine.

use std::path::Path;

use crate::progress::damage_lines;
use chainsweep::engine::gc::GcReport;
use chainsweep::engine::inspect::{DryRun, Point, SearchDryRun};
use chainsweep::engine::merge::MergeReport;
use chainsweep::engine::run::{Failure, RunReport};
use chainsweep::engine::search::{self, SearchReport};
use chainsweep::engine::slurm::{self, JobFiles, JobRequest};
use chainsweep::engine::status::{FileStatus, ShardSetStatus, ShardState, SweepStatus};
use chainsweep::engine::DamageReport;
use chainsweep::grid::{multi_index, Grid, Shard};
use chainsweep::identity::hex;
use chainsweep::numerics::accuracy::{cost_of, Study};
use chainsweep::numerics::auto::{pilot_points, SAFETY_FACTOR};
use chainsweep::sweep::auto::describe;
use chainsweep::sweep::Sweep;

/// How many values at each end of a long axis a dry run lists.
const LISTED_AXIS_VALUES: usize = 5;

/// How many failed points `status` of an output file lists.
const LISTED_IN_STATUS: usize = 20;

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

/// `validate`: the grid, its dimensions and, for `integrator: auto`, the pilot points.
/// The grid's physically absurd scenes, on stderr: counted, the first ones listed.
fn plausibility(sweep: &Sweep, grid: &Grid) {
    if grid.warned_points == 0 {
        return;
    }
    errln!(
        "chainsweep: warning: {} of {} grid points look physically absurd (estimates before running; they will run, but check them):",
        grid.warned_points,
        grid.len()
    );
    for (i, warnings) in &grid.warnings {
        for w in warnings {
            errln!("  point {i} ({}): {w}", grid.point_label(sweep, *i));
        }
    }
    if grid.warned_points > grid.warnings.len() {
        errln!(
            "  … and {} more points",
            grid.warned_points - grid.warnings.len()
        );
    }
}

pub fn validated(file: &Path, sweep: &Sweep, grid: &Grid) -> chainsweep::error::Result<()> {
    outln!(
        "{}: valid — {} grid points (shape {}), {} probes, {}",
        file.display(),
        grid.len(),
        shape_text(&grid.shape),
        grid.probes.len(),
        if grid.history {
            "full histories"
        } else {
            "summaries only"
        }
    );
    for d in &sweep.dims {
        let names: Vec<String> = d
            .axes
            .iter()
            .map(|a| format!("{} ({})", a.name, a.field))
            .collect();
        outln!("  {} × {}", d.len(), names.join(" zipped with "));
    }
    plausibility(sweep, grid);
    if let Some(spec) = sweep.auto {
        let pilots = pilot_points(sweep, grid, spec.pilot_points)?;
        outln!(
            "  integrator auto, target relative error {:e}: chosen when the sweep runs, by a pilot on grid points {pilots:?} (DOP853 or ROS34PW2, the cheapest setting reaching {:e} there)",
            spec.target_rel_error,
            spec.target_rel_error / SAFETY_FACTOR
        );
    }
    Ok(())
}

/// `run --dry-run` of a sweep with a search: the search, its budget, what is stored, the cost.
pub fn dry_run_search(sweep: &Sweep, grid: &Grid, output: &Path, d: &SearchDryRun) {
    let driver = search::Driver::new(sweep, grid);
    outln!("search: {}", driver.spec.describe());
    let outer: Vec<&str> = driver
        .layout
        .outer_dims
        .iter()
        .map(|&k| sweep.dims[k].name.as_str())
        .collect();
    outln!(
        "searches: {}{}",
        d.searches,
        if outer.is_empty() {
            String::new()
        } else {
            format!(" (one per point of {})", outer.join(" × "))
        }
    );
    outln!(
        "runs: at most {} (their budgets; the first scans take {}); {} stored, {} of {} searches ended → {}",
        d.most_runs,
        d.first_scan_runs,
        d.stored_runs,
        d.finished,
        d.searches,
        output.display()
    );
    if let Some(c) = &d.cost {
        outln!(
            "estimated cost: at most {:.3e} CPU-seconds for the {} runs left of the budgets (±{:.0} %, {:.3e} s per run from a pilot of {} run(s) at the searched fields' midpoints)",
            c.cpu_seconds,
            c.runs,
            100.0 * c.accuracy,
            c.per_run.iter().sum::<f64>() / c.per_run.len() as f64,
            c.per_run.len()
        );
    }
}

/// `run --dry-run`: the grid, the record block, what is done, the size estimate, every point.
pub fn dry_run(
    sweep: &Sweep,
    grid: &Grid,
    points: &[usize],
    output: &Path,
    shard: Option<Shard>,
    d: &DryRun,
) {
    outln!(
        "grid: {} points (shape {}){}",
        grid.len(),
        shape_text(&grid.shape),
        match shard {
            Some(s) => format!(", shard {s}: {} points", points.len()),
            None => String::new(),
        }
    );
    for (k, dim) in sweep.dims.iter().enumerate() {
        for a in &dim.axes {
            // A long axis shows its ends (the count says how many there are).
            let n = a.values.len();
            let text = |v: &[serde_json::Value]| -> Vec<String> {
                v.iter().map(|x| x.to_string()).collect()
            };
            let vals = if n > 2 * LISTED_AXIS_VALUES {
                format!(
                    "{}, … ({} values), {}",
                    text(&a.values[..LISTED_AXIS_VALUES]).join(", "),
                    n,
                    text(&a.values[n - LISTED_AXIS_VALUES..]).join(", ")
                )
            } else {
                text(&a.values).join(", ")
            };
            // (An index axis sets no field: its name says what it counts.)
            outln!(
                "  dim {k} `{}`: {} = [{vals}] ({})",
                dim.name,
                if a.field.is_empty() {
                    &a.name
                } else {
                    &a.field
                },
                a.units
            );
        }
    }
    if let Some(e) = &sweep.ensemble {
        let size = match e.max_runs {
            Some(m) => format!(
                "adaptive: {} runs in round 0 ({} samples at each of {} point(s)), doubling until every statistic's interval is within its tolerance or the next round would pass the budget of {m} runs",
                e.round_runs(0),
                e.round_samples(0),
                e.outer_points
            ),
            None => format!(
                "{} runs ({} samples at each of {} point(s))",
                e.round_runs(0),
                e.round_samples(0),
                e.outer_points
            ),
        };
        outln!(
            "ensemble: {} design, {} input(s) ({} sampled fields), seed {}; {size}",
            e.design.name(),
            e.inputs.len(),
            e.columns.len(),
            e.seed
        );
    }
    if let Some(c) = &sweep.auto_choice {
        outln!(
            "integrator: auto, target {:e}: {}",
            c.target_rel_error,
            c.summary()
        );
    }
    plausibility(sweep, grid);
    let probe_names: Vec<String> = grid.probes.iter().map(|p| p.name()).collect();
    outln!(
        "record: probes [{}]; {}{}{}{}",
        probe_names.join(", "),
        if grid.history {
            format!(
                "full histories, up to {} samples per probe per run",
                grid.max_history_samples
            )
        } else {
            "summaries only".to_string()
        },
        if grid.min_overlap {
            "; minimum overlaps"
        } else {
            ""
        },
        if grid.energy_flow {
            "; energy flow"
        } else {
            ""
        },
        match &grid.fields {
            Some(f) => format!(
                "; fields of {} every {:e} s, up to {} samples per run",
                f.quantities
                    .iter()
                    .map(|q| q.name())
                    .collect::<Vec<_>>()
                    .join(", "),
                f.interval_s,
                grid.max_field_samples
            ),
            None => String::new(),
        }
    );
    outln!(
        "output: {} — {} done, {} failed, {} to run",
        output.display(),
        d.ok,
        d.failed,
        points.len() - d.ok - d.failed
    );
    let (summary, history, fields) = (d.size.summary, d.size.history, d.size.fields);
    outln!(
        "estimated output size: {} ({} per run: {} summaries{}{}); histories and fields are deflate-compressed, so usually less",
        human(d.size.total(points.len())),
        human(summary + history + fields),
        human(summary),
        if history > 0.0 { format!(" + {} histories, uncompressed", human(history)) } else { String::new() },
        if fields > 0.0 { format!(" + {} fields, uncompressed", human(fields)) } else { String::new() }
    );
    if let Some(c) = &d.cost {
        let how = if c.extrapolated > 0 {
            format!(
                "{} of them stopped after {} s and extrapolated from the simulated time they reached, so an order of magnitude at best",
                c.extrapolated,
                chainsweep::engine::inspect::PILOT_SECONDS_PER_RUN
            )
        } else {
            "run in full".to_string()
        };
        outln!(
            "estimated cost: {:.3e} CPU-seconds for {} runs (±{:.0} %, from a pilot of {} runs on points {:?}, {how}; {:.3e} s per run)",
            c.cpu_seconds,
            c.runs,
            100.0 * c.accuracy,
            c.per_run.len(),
            c.pilot_points,
            c.cpu_seconds / c.runs as f64,
        );
        let per_run_max = c.per_run.iter().copied().fold(0.0, f64::max);
        if per_run_max > sweep.limits.max_run_seconds {
            errln!(
                "chainsweep: warning: a pilot run is estimated at {per_run_max:.3e} s, more than limits.max_run_seconds = {} s: such runs will fail at the wall-time limit",
                sweep.limits.max_run_seconds
            );
        }
    }
    outln!("points (flat index, axis values, run hash):");
    let show = |i: usize| {
        let h = grid.hashes[i];
        let state = match d.stored.get(&h) {
            Some(true) => " [done]",
            Some(false) => " [failed]",
            None => "",
        };
        outln!(
            "  {i:>6}  {}  {}{state}",
            grid.point_label(sweep, i),
            &hex(&h)[..12]
        );
    };
    if points.len() <= 2000 {
        points.iter().for_each(|&i| show(i));
    } else {
        points[..1000].iter().for_each(|&i| show(i));
        outln!("  … {} more …", points.len() - 1010);
        points[points.len() - 10..].iter().for_each(|&i| show(i));
    }
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
    let label = |i: usize| {
        s.labels
            .get(&i)
            .cloned()
            .unwrap_or_else(|| index_text(&s.shape, i))
    };
    for (shown, (i, reason)) in s.failures.iter().enumerate() {
        if shown == LISTED_IN_STATUS {
            outln!("  …");
            break;
        }
        outln!("  failed: point {i} ({}): {reason}", label(*i));
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
    } else {
        outln!("  {}", health_text(&s.health, label));
    }
    if let Some(e) = &s.ensemble {
        for line in ensemble_lines(e) {
            outln!("  {line}");
        }
    }
    damage_status(&s.damage);
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

/// Point `i` of a grid of shape `shape` by its indices: `[2, 0]`.
fn index_text(shape: &[usize], i: usize) -> String {
    let mi: Vec<String> = multi_index(shape, i)
        .iter()
        .map(|x| x.to_string())
        .collect();
    format!("[{}]", mi.join(", "))
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

/// The end of `merge`: the counts, and the shards to run again (with the command that
/// re-submits only them, when the output's SLURM job `scripts` (array, merge) exist).
pub fn merged(r: &MergeReport, output: &Path, scripts: Option<(&Path, &Path)>) {
    if r.searches {
        // (The counts of a search sweep are of its searches, as `status` gives them.)
        errln!(
            "chainsweep: merged {} shard file(s): {} search(es): {} ended, {} failed, {} unfinished → {}",
            r.shards,
            r.points,
            r.counts.ok,
            r.counts.failed,
            r.counts.pending,
            output.display()
        );
    } else {
        errln!(
            "chainsweep: merged {} shard file(s): {} runs: {}, {} pending → {}",
            r.shards,
            r.points,
            r.counts.finished_text(),
            r.counts.pending,
            output.display()
        );
    }
    for a in &r.absent {
        errln!("chainsweep: shard file not found: {}", a.display());
    }
    for d in &r.damage {
        for l in damage_lines(d) {
            errln!("chainsweep: {l}");
        }
        if !d.lost.is_empty() && d.output != output {
            errln!(
                "chainsweep: its damaged runs are pending in {}: run the command that made {} again (it computes them), then merge again",
                output.display(),
                d.output.display()
            );
        }
    }
    if let Some(set) = &r.shard_set {
        shards_to_run(set, scripts);
    }
}

/// The shards of `set` to run again: which, why, and how (SLURM array tasks count from 0).
fn shards_to_run(set: &ShardSetStatus, scripts: Option<(&Path, &Path)>) {
    let to_run = set.to_run();
    if to_run.is_empty() {
        return;
    }
    for e in set.shards.iter().filter(|e| to_run.contains(&e.k)) {
        let why = match (&e.counts, e.state) {
            (Some(c), ShardState::Pending) => format!("{} of its runs pending", c.pending),
            _ => "no shard file".to_string(),
        };
        errln!(
            "chainsweep: shard {}/{} (SLURM array task {}) is {}: {why}",
            e.k,
            set.n,
            e.k - 1,
            e.state.name()
        );
    }
    let tasks: Vec<usize> = to_run.iter().map(|k| k - 1).collect();
    let list: Vec<String> = tasks.iter().map(|t| t.to_string()).collect();
    match scripts {
        Some((array, merge)) => errln!(
            "chainsweep: to run only those array tasks again (each resumes where it stopped), then the merge:\n  {}",
            slurm::resubmit_command(&tasks, array, merge)
        ),
        None => errln!(
            "chainsweep: to run only those array tasks again (each resumes where it stopped): sbatch --array={} ARRAY_SCRIPT, then merge again; or `chainsweep run SWEEP --shard K/{}` for each shard K above",
            list.join(","),
            set.n
        ),
    }
}

/// `status` of a shard set: one line per shard.
pub fn shard_set_status(set: &ShardSetStatus, scripts: Option<(&Path, &Path)>) {
    for e in &set.shards {
        let mut detail = match (&e.counts, &e.file) {
            (Some(c), Some(f)) => format!(
                "{} runs: {}, {} pending ({})",
                c.done() + c.pending,
                c.finished_text(),
                c.pending,
                f.display()
            ),
            _ => "no shard file".to_string(),
        };
        if let Some(pid) = &e.writer {
            detail.push_str(&if pid.is_empty() {
                "; a process is writing it now".to_string()
            } else {
                format!("; process {pid} is writing it now")
            });
        }
        outln!(
            "shard {}/{} (array task {}): {:<7} {detail}",
            e.k,
            set.n,
            e.k - 1,
            e.state.name()
        );
    }
    let count = |st: ShardState| set.shards.iter().filter(|e| e.state == st).count();
    outln!(
        "{} shards: {} done, {} failed, {} running, {} pending, {} missing",
        set.n,
        count(ShardState::Done),
        count(ShardState::Failed),
        count(ShardState::Running),
        count(ShardState::Pending),
        count(ShardState::Missing)
    );
    shards_to_run(set, scripts);
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

/// `slurm`: the job files written, and how to submit them.
pub fn slurm_job(r: &JobRequest, f: &JobFiles) {
    outln!(
        "array job ({} tasks, task T runs shard T+1 of {}): {}",
        r.shards,
        r.shards,
        f.array_script.display()
    );
    outln!("merge job: {}", f.merge_script.display());
    outln!("shard files: {}/", f.shards_dir.display());
    outln!("logs: {}/", f.logs.display());
    outln!(
        "submit: jid=$(sbatch --parsable {}) && sbatch --dependency=afterany:${{jid%%;*}} {}",
        slurm::shell_quote(&f.array_script.to_string_lossy()),
        slurm::shell_quote(&f.merge_script.to_string_lossy())
    );
    outln!("status: chainsweep status {}", f.dir.display());
}

/// `slurm --submit`: the job ids.
pub fn submitted(array: &str, merge: &str, f: &JobFiles) {
    outln!(
        "submitted array job {array} and merge job {merge} (after the array, whatever its outcome)"
    );
    outln!(
        "cancel one task: scancel {array}_T; status: chainsweep status {}",
        f.dir.display()
    );
}

/// `point`: the scene and, when run, the results, as JSON.
pub fn point(grid: &Grid, index: usize, p: &Point) -> String {
    let mut out = serde_json::json!({
        "index": index,
        "grid_index": multi_index(&grid.shape, index),
        "run_hash": hex(&p.hash),
        "scene": serde_json::to_value(&p.scene).expect("Scene serialises"),
    });
    if let Some(rec) = &p.record {
        let num = |x: f64| {
            if x.is_finite() {
                serde_json::json!(x)
            } else {
                serde_json::Value::Null
            }
        };
        let probes: Vec<serde_json::Value> = rec
            .probes
            .iter()
            .zip(&grid.probes)
            .map(|(s, p)| {
                serde_json::json!({
                    "probe": p.name(),
                    "leading_peak": num(s.leading_peak),
                    "leading_peak_time_s": num(s.leading_peak_time_s),
                    "record_max": num(s.record_max),
                    "record_max_time_s": num(s.record_max_time_s),
                })
            })
            .collect();
        out["result"] = serde_json::json!({
            "ok": rec.ok,
            "reason": rec.reason,
            "steps": rec.steps,
            "rejected_steps": rec.rejected,
            "rhs_evals": rec.rhs_evals,
            "events": rec.events,
            "max_overlap_m": num(rec.max_overlap_m),
            "integrated_particles": rec.integrated_particles,
            "moving_part": rec.moving_part,
            "warnings": rec.warnings.lines().collect::<Vec<_>>(),
            "t_end_s": num(rec.t_end_s),
            "energy_drift_max": num(rec.energy_drift_max),
            "energy_drift_final": num(rec.energy_drift_final),
            "momentum_residual_max": num(rec.momentum_residual_max),
            "impact_energy_j": num(rec.impact_energy_j),
            "probes": probes,
            "history_samples": rec.history.as_ref().map(|h| h.time_s.len()),
        });
        // Only where fields are recorded, so that the result of every other run reads as it did.
        if let Some(f) = &rec.fields {
            out["result"]["field_samples"] = f.time_s.len().into();
        }
        if let Some(s) = &rec.spectrum {
            out["result"]["spectrum"] = serde_json::json!({
                "lowest_frequency_hz": num(s.lowest_frequency_hz),
                "highest_frequency_hz": num(s.highest_frequency_hz),
                "gap_lower_hz": num(s.gap_lower_hz),
                "gap_upper_hz": num(s.gap_upper_hz),
                "band_top_hz": num(s.band_top_hz),
            });
        }
        if let Some(st) = &rec.steady_state {
            let nums = |v: &[f64]| v.iter().map(|&x| num(x)).collect::<Vec<_>>();
            let probes: Vec<serde_json::Value> = st
                .probes
                .iter()
                .zip(&grid.probes)
                .map(|(s, p)| {
                    serde_json::json!({
                        "probe": p.name(),
                        "mean": num(s.mean),
                        "rms": num(s.rms),
                        "amplitude": nums(&s.amplitude),
                        "phase_rad": nums(&s.phase_rad),
                        "settledness": num(s.settledness),
                        "settled": s.settled,
                        "transmission_db": num(s.transmission_db),
                    })
                })
                .collect();
            out["result"]["steady_state"] = serde_json::json!({
                "frequency_hz": num(st.frequency_hz),
                "probes": probes,
            });
        }
    }
    serde_json::to_string_pretty(&out).expect("json")
}

/// The end of `accuracy`: the cost of each error level per method.
pub fn study(st: &Study, output: &Path) {
    let reference = st.reference.out.as_ref().expect("reference ran");
    let confirmation = if st.confirmation.out.is_some() {
        format!(
            "confirmed by {} to {:.1e}",
            st.confirmation.spec.method_name(),
            st.agreement
        )
    } else {
        format!(
            "not confirmed: the {} run failed",
            st.confirmation.spec.method_name()
        )
    };
    outln!(
        "reference {} ({confirmation}); cost of a leading-peak relative error:",
        st.reference.spec.method_name(),
    );
    outln!(
        "{:<14} {:>22} {:>22} {:>22}",
        "method",
        "<= 1e-4",
        "<= 1e-6",
        "<= 1e-8"
    );
    for m in &st.methods {
        let cell = |target: f64| match cost_of(m, reference, target) {
            Some((w, e, x)) => format!("{:.2} ms/{}@{x:.0e}", w * 1e3, e),
            None => "not reached".to_string(),
        };
        outln!(
            "{:<14} {:>22} {:>22} {:>22}",
            m.method,
            cell(1e-4),
            cell(1e-6),
            cell(1e-8)
        );
    }
    outln!(
        "(wall time per run / RHS evaluations @ setting) → {}",
        output.display()
    );
}
