//! The text the command line prints for each report of the engine.

use std::path::Path;

use crate::engine::inspect::{DryRun, Point};
use crate::engine::merge::MergeReport;
use crate::engine::run::{Failure, RunReport};
use crate::engine::status::{FileStatus, SweepStatus};
use crate::grid::{multi_index, Grid, Shard};
use crate::identity::hex;
use crate::numerics::accuracy::{cost_of, Study};
use crate::numerics::auto::{pilot_points, SAFETY_FACTOR};
use crate::sweep::auto::describe;
use crate::sweep::Sweep;

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
fn human(bytes: f64) -> String {
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
pub fn validated(file: &Path, sweep: &Sweep, grid: &Grid) -> crate::error::Result<()> {
    println!(
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
        println!("  {} × {}", d.len(), names.join(" zipped with "));
    }
    if let Some(spec) = sweep.auto {
        let pilots = pilot_points(sweep, grid, spec.pilot_points)?;
        println!(
            "  integrator auto, target relative error {:e}: chosen when the sweep runs, by a pilot on grid points {pilots:?} (DOP853 or ROS34PW2, the cheapest setting reaching {:e} there)",
            spec.target_rel_error,
            spec.target_rel_error / SAFETY_FACTOR
        );
    }
    Ok(())
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
    println!(
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
            let vals: Vec<String> = a.values.iter().map(|v| v.to_string()).collect();
            println!(
                "  dim {k} `{}`: {} = [{}] ({})",
                dim.name,
                a.field,
                vals.join(", "),
                a.units
            );
        }
    }
    if let Some(c) = &sweep.auto_choice {
        println!(
            "integrator: auto, target {:e}: {}",
            c.target_rel_error,
            c.summary()
        );
    }
    let probe_names: Vec<String> = grid.probes.iter().map(|p| p.name()).collect();
    println!(
        "record: probes [{}]; {}{}",
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
        }
    );
    println!(
        "output: {} — {} done, {} failed, {} to run",
        output.display(),
        d.ok,
        d.failed,
        points.len() - d.ok - d.failed
    );
    let (summary, history) = (d.size.summary, d.size.history);
    println!(
        "estimated output size: {} ({} per run: {} summaries{}); histories are deflate-compressed, so usually less",
        human(d.size.total(points.len())),
        human(summary + history),
        human(summary),
        if history > 0.0 { format!(" + {} histories, uncompressed", human(history)) } else { String::new() }
    );
    println!("points (flat index, axis values, run hash):");
    let show = |i: usize| {
        let h = grid.hashes[i];
        let state = match d.stored.get(&h) {
            Some(true) => " [done]",
            Some(false) => " [failed]",
            None => "",
        };
        println!(
            "  {i:>6}  {}  {}{state}",
            grid.point_label(sweep, i),
            &hex(&h)[..12]
        );
    };
    if points.len() <= 2000 {
        points.iter().for_each(|&i| show(i));
    } else {
        points[..1000].iter().for_each(|&i| show(i));
        println!("  … {} more …", points.len() - 1010);
        points[points.len() - 10..].iter().for_each(|&i| show(i));
    }
}

/// The end of `run`: failed runs (always), failed verification runs (always), the largest
/// verified error and the counts (unless `quiet`).
pub fn run_report(sweep: &Sweep, grid: &Grid, r: &RunReport, output: &Path, quiet: bool) {
    if r.failed > 0 {
        eprintln!("chainsweep: {} failed run(s):", r.failed);
        list_failures(sweep, grid, &r.failures, "(reason unreadable)");
        if r.failed > r.failures.len() {
            eprintln!(
                "  … and {} more (see the `status` and `reason` datasets)",
                r.failed - r.failures.len()
            );
        }
    }
    let v = &r.verification;
    if v.failed > 0 {
        eprintln!(
            "chainsweep: {} verification run(s) failed (`verified` = 2):",
            v.failed
        );
        list_failures(sweep, grid, &v.failures, "");
    }
    if !quiet && (v.requested > 0 || v.verified > 0) {
        match v.worst {
            Some((e, i)) => eprintln!(
                "chainsweep: {} point(s) verified at a tighter setting; largest relative error {e:.2e} at point {i} ({})",
                v.verified,
                grid.point_label(sweep, i)
            ),
            None => eprintln!(
                "chainsweep: {} point(s) verified at a tighter setting",
                v.verified
            ),
        }
    }
    if !quiet {
        eprintln!(
            "chainsweep: {} runs: {} ok, {} failed, {} pending → {}",
            r.points,
            r.counts.ok,
            r.counts.failed,
            r.counts.pending,
            output.display()
        );
    }
}

fn list_failures(sweep: &Sweep, grid: &Grid, failures: &[Failure], unreadable: &str) {
    for f in failures {
        eprintln!(
            "  point {} ({}): {}",
            f.point,
            grid.point_label(sweep, f.point),
            f.reason.as_deref().unwrap_or(unreadable)
        );
    }
}

/// `status` of an output file.
pub fn file_status(file: &Path, s: &FileStatus) {
    println!(
        "{}: {} runs (grid {}, shard {}): {} done ({} ok, {} failed), {} pending",
        file.display(),
        s.total,
        shape_text(&s.shape),
        s.shard,
        s.counts.ok + s.counts.failed,
        s.counts.ok,
        s.counts.failed,
        s.counts.pending
    );
    if s.newer > 0 {
        println!(
            "  {} more runs have finished since the file was written (a sweep is running, or was interrupted): re-run the same `chainsweep run` command to bring the file up to date",
            s.newer
        );
    }
    for (shown, (i, reason)) in s.failures.iter().enumerate() {
        if shown == LISTED_IN_STATUS {
            println!("  …");
            break;
        }
        let mi: Vec<String> = multi_index(&s.shape, *i)
            .iter()
            .map(|x| x.to_string())
            .collect();
        println!("  failed: point {i} [{}]: {reason}", mi.join(", "));
    }
}

/// `status` of a sweep file's output.
pub fn sweep_status(file: &Path, sweep: &Sweep, grid: &Grid, s: &SweepStatus) {
    if let (Some(spec), Some(c)) = (sweep.auto, &s.auto) {
        println!(
            "integrator auto, target {:e}: {}",
            spec.target_rel_error,
            describe(&c.integrator)
        );
    }
    let Some(counts) = s.counts else {
        println!(
            "{} → {}: {} runs: 0 done, {} pending (integrator auto not chosen yet: {} holds no choice for this sweep)",
            file.display(),
            s.output.display(),
            s.points,
            s.points,
            s.auto_cache.as_deref().unwrap_or(Path::new("")).display()
        );
        return;
    };
    println!(
        "{} → {}: {} runs: {} done ({} ok, {} failed), {} pending",
        file.display(),
        s.output.display(),
        s.points,
        counts.ok + counts.failed,
        counts.ok,
        counts.failed,
        counts.pending
    );
    for f in &s.failures {
        println!(
            "  failed: point {} ({}): {}",
            f.point,
            grid.point_label(sweep, f.point),
            f.reason.as_deref().unwrap_or("")
        );
    }
}

/// The end of `merge`.
pub fn merged(r: &MergeReport, output: &Path) {
    eprintln!(
        "chainsweep: merged {} shard file(s): {} runs: {} ok, {} failed, {} pending → {}",
        r.shards,
        r.points,
        r.counts.ok,
        r.counts.failed,
        r.counts.pending,
        output.display()
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
            "warnings": rec.warnings.lines().collect::<Vec<_>>(),
            "t_end_s": num(rec.t_end_s),
            "energy_drift_max": num(rec.energy_drift_max),
            "energy_drift_final": num(rec.energy_drift_final),
            "momentum_residual_max": num(rec.momentum_residual_max),
            "impact_energy_j": num(rec.impact_energy_j),
            "probes": probes,
            "history_samples": rec.history.as_ref().map(|h| h.time_s.len()),
        });
    }
    serde_json::to_string_pretty(&out).expect("json")
}

/// The end of `accuracy`: the cost of each error level per method.
pub fn study(st: &Study, output: &Path) {
    let reference = st.reference.out.as_ref().expect("reference ran");
    println!(
        "reference {} (confirmed by {} to {:.1e}); cost of a leading-peak relative error:",
        st.reference.spec.method_name(),
        st.confirmation.spec.method_name(),
        st.agreement
    );
    println!(
        "{:<9} {:>22} {:>22} {:>22}",
        "method", "<= 1e-4", "<= 1e-6", "<= 1e-8"
    );
    for m in &st.methods {
        let cell = |target: f64| match cost_of(m, reference, target) {
            Some((w, e, x)) => format!("{:.2} ms/{}@{x:.0e}", w * 1e3, e),
            None => "not reached".to_string(),
        };
        println!(
            "{:<9} {:>22} {:>22} {:>22}",
            m.method,
            cell(1e-4),
            cell(1e-6),
            cell(1e-8)
        );
    }
    println!(
        "(wall time per run / RHS evaluations @ setting) → {}",
        output.display()
    );
}
