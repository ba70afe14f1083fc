//! `validate` and `run --dry-run`: the grid, its dimensions and what a run would do, and the
//! grid's implausible scenes.

use std::path::Path;

use chainsweep::engine::periodic::PeriodicDryRun;

use super::{human, shape_text};
use chainsweep::engine::inspect::{DryRun, SearchDryRun};
use chainsweep::engine::search;
use chainsweep::grid::{Grid, Shard};
use chainsweep::identity::hex;
use chainsweep::numerics::auto::{pilot_points, SAFETY_FACTOR};
use chainsweep::sweep::Sweep;

/// How many values at each end of a long axis a dry run lists.
const LISTED_AXIS_VALUES: usize = 5;

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
    if let Some(p) = &sweep.periodic {
        outln!("  periodic: {}", p.describe());
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

/// `run --dry-run` of a sweep with a `periodic` block: its branches, what has ended, the cost.
pub fn dry_run_periodic(sweep: &Sweep, output: &Path, d: &PeriodicDryRun) {
    use chainsweep::error::number_text as num;
    let spec = sweep.periodic.as_ref().expect("a periodic sweep");
    outln!("periodic: {}", spec.describe());
    outln!(
        "branches: {} (one per grid point), {} ended already → {}",
        d.branches,
        d.ended,
        output.display()
    );
    if spec.autonomous.is_some() {
        outln!(
            "pilot at {} = {} Hz from the first guess: the first orbit shot in {:.3e} s, its two periods run in {:.3e} s",
            spec.name,
            num(d.from),
            d.seconds_per_map.0,
            d.seconds_per_map.1
        );
        outln!(
            "estimated cost: about {:.3e} CPU-seconds for the {} famil{} left, each of {} orbits at the first one's cost (an orbit's cost changes along a family with its amplitude; a family ends early where shooting fails)",
            d.most_cpu_seconds,
            d.branches - d.ended,
            if d.branches - d.ended == 1 { "y" } else { "ies" },
            d.max_points
        );
        return;
    }
    outln!(
        "pilot at {} = {} {}: settling the first guess {:.3e} s, a period map {:.3e} s with its monodromy ({}), {:.3e} s without",
        spec.name,
        num(d.from),
        spec.units,
        d.settle_seconds,
        d.seconds_per_map.0,
        d.monodromy,
        d.seconds_per_map.1
    );
    outln!(
        "estimated cost: at most {:.3e} CPU-seconds for the {} branch(es) left, were each to take its {} points (a branch usually ends sooner, at {} {})",
        d.most_cpu_seconds,
        d.branches - d.ended,
        d.max_points,
        num(d.to),
        spec.units
    );
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
        // A shard's sweep is at the round it runs (`--ensemble-round`); a whole run starts at 0.
        let k = sweep.ensemble_round;
        let size = match e.max_runs {
            Some(m) => format!(
                "adaptive: {} runs in round {k} ({} samples at each of {} point(s)), doubling until every statistic's interval is within its tolerance or the next round would pass the budget of {m} runs",
                e.round_runs(k),
                e.round_samples(k),
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
        "estimated output size: {} ({} per run: {} summaries{}{}){}",
        human(d.size.total(points.len())),
        human(summary + history + fields),
        human(summary),
        if history > 0.0 {
            format!(" + {} histories", human(history))
        } else {
            String::new()
        },
        if fields > 0.0 {
            format!(" + {} fields", human(fields))
        } else {
            String::new()
        },
        // Histories and fields are stored as they are (checksummed, not compressed); only
        // histories split by unit (probes of mixed units) are deflated, their NaN runs to little.
        if history + fields > 0.0 {
            "; histories and fields are not compressed (split by unit: deflated, so less)"
        } else {
            ""
        }
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
