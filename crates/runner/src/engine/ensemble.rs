//! What an ensemble adds to its output file: the statistics of every requested quantity at each
//! point of the ordinary axes with their intervals, Saltelli's Sobol' indices or Morris's
//! elementary effects, and whether the adaptive rule has ended ([`tables`]); and the rounds of an
//! adaptive ensemble ([`run_rounds`]), each an ordinary sweep whose samples double its
//! predecessor's, so that a resumed ensemble replays its stored runs round by round and asks for
//! the same new ones.

use std::sync::atomic::{AtomicBool, Ordering};

use crate::error::{Error, Result};
use crate::grid::Grid;
use crate::record::RunRecord;
use crate::store::hdf5::fit::{EnsembleTables, FitData, FitTables};
use crate::sweep::ensemble::{Design, Layout};
use crate::sweep::Sweep;
use crate::uq::design::MORRIS_STEP;
use crate::uq::sensitivity::{morris, sobol_indices};
use crate::uq::stats::{edges, summarise, Estimate, Request, Summary};

use super::run::{RunOptions, RunReport};
use super::ProgressSink;

/// How an ensemble stands.
#[derive(Debug, Clone, PartialEq)]
pub struct Outcome {
    /// The round its file holds.
    pub round: usize,
    /// Samples per point of the ordinary axes.
    pub samples: usize,
    /// Runs of the round over all points.
    pub runs: usize,
    /// `fixed` (no tolerance asked), `tolerance` (every interval within it), `budget` (the
    /// next round would pass `max_runs`), `failed` (samples failed or gave no number: no
    /// tolerance vouches for statistics over the others), `running` (another round is due) or
    /// `incomplete` (runs of this round are missing).
    pub stopped_by: &'static str,
    /// The largest ratio of an interval's width to its tolerance (NaN: no tolerance, or no
    /// interval yet).
    pub worst_ratio: f64,
}

impl Outcome {
    /// Whether no further round is due.
    pub fn done(&self) -> bool {
        matches!(self.stopped_by, "fixed" | "tolerance" | "budget" | "failed")
    }
}

fn est_vars(
    t: &mut FitTables,
    name: &str,
    dims: &[usize],
    e: &[Estimate],
    units: &str,
    what: &str,
) {
    let v = |f: fn(&Estimate) -> f64| FitData::F64(e.iter().map(f).collect());
    t.var(name, true, dims, v(|e| e.value), Some(units), what);
    t.var(
        &format!("{name}_lower"),
        true,
        dims,
        v(|e| e.lower),
        Some(units),
        &format!("lower end of the 95 % confidence interval of the {what}"),
    );
    t.var(
        &format!("{name}_upper"),
        true,
        dims,
        v(|e| e.upper),
        Some(units),
        &format!("upper end of the 95 % confidence interval of the {what}"),
    );
}

/// The ensemble's tables for the file of `sweep` (at its round), from the values `value(point)`
/// of each statistic (`values[s][point]`, NaN where a run failed, gave no number or is pending).
pub fn tables(sweep: &Sweep, values: &[Vec<f64>], pending: usize) -> (EnsembleTables, Outcome) {
    let e = sweep.ensemble.as_ref().expect("an ensemble");
    let k = sweep.ensemble_round;
    let samples = e.round_samples(k);
    let outer = e.outer_points.max(1);
    let layout = e.layout(k);
    let mut t = FitTables::default();
    let q_dim = t.dim(
        "quantile",
        e.quantiles.clone(),
        "1",
        "probability of the quantile",
    );
    let input_dim = match e.design {
        Design::Saltelli | Design::Morris { .. } => {
            let d = t.index_dim(
                "input",
                e.inputs.len(),
                "index of a sampled input (input_name)",
            );
            t.var(
                "input_name",
                false,
                &[d],
                FitData::Text(e.inputs.iter().map(|i| i.name.clone()).collect()),
                None,
                "sampled input (a field, a group of mass factors, a fit's fields)",
            );
            Some(d)
        }
        Design::Sample(_) => None,
    };
    let mut worst = f64::NAN;
    let mut all_within = true;
    // Samples without a number (failed runs, summaries without a value) at some point.
    let mut any_missing = false;
    for (s, stat) in e.statistics.iter().enumerate() {
        let vals = &values[s];
        let name = &stat.name;
        let u = stat.units.as_str();
        let for_stats = |o: usize| -> (Vec<f64>, usize) {
            let row = &vals[o * samples..(o + 1) * samples];
            match &layout {
                Layout::Replicates { replicates, .. } => (row.to_vec(), *replicates),
                Layout::Saltelli { n } => (row[..2 * n].to_vec(), 1),
                Layout::Morris(steps) => (
                    row.iter()
                        .zip(steps)
                        .filter(|(_, st)| st.step == 0)
                        .map(|(v, _)| *v)
                        .collect(),
                    1,
                ),
            }
        };
        let all: Vec<f64> = (0..outer).flat_map(|o| for_stats(o).0).collect();
        let bin_edges = edges(&all, e.bins);
        let req = Request {
            quantiles: e.quantiles.clone(),
            exceed: stat.exceed.clone(),
            edges: bin_edges.clone(),
        };
        let sums: Vec<Summary> = (0..outer)
            .map(|o| {
                let (v, r) = for_stats(o);
                summarise(&v, r, &req)
            })
            .collect();
        let what = name.to_string();
        // A Morris design's points lie on a grid, not drawn from the distributions: it screens
        // and has no statistics.
        let morris_design = matches!(layout, Layout::Morris(_));
        if !morris_design {
            t.var(
                &format!("{name}_n"),
                true,
                &[],
                FitData::I64(sums.iter().map(|x| x.n as i64).collect()),
                Some("1"),
                &format!("samples of {what} that are numbers"),
            );
            t.var(&format!("{name}_missing"), true, &[], FitData::I64(sums.iter().map(|x| x.missing as i64).collect()), Some("1"), &format!("samples of {what} without a number (failed or pending runs, summaries without a value)"));
            est_vars(
                &mut t,
                &format!("{name}_mean"),
                &[],
                &sums.iter().map(|x| x.mean).collect::<Vec<_>>(),
                u,
                &format!("mean of {what}"),
            );
            est_vars(
                &mut t,
                &format!("{name}_sd"),
                &[],
                &sums.iter().map(|x| x.sd).collect::<Vec<_>>(),
                u,
                &format!("standard deviation of {what}"),
            );
            est_vars(
                &mut t,
                &format!("{name}_quantile"),
                &[q_dim],
                &sums
                    .iter()
                    .flat_map(|x| x.quantiles.clone())
                    .collect::<Vec<_>>(),
                u,
                &format!("quantile of {what}"),
            );
            if !stat.exceed.is_empty() {
                let d = t.dim(
                    &format!("{name}_level"),
                    stat.exceed.clone(),
                    u,
                    &format!("level of {what}"),
                );
                est_vars(
                    &mut t,
                    &format!("{name}_exceed"),
                    &[d],
                    &sums
                        .iter()
                        .flat_map(|x| x.exceed.clone())
                        .collect::<Vec<_>>(),
                    "1",
                    &format!("probability that {what} exceeds the level"),
                );
            }
            if bin_edges.len() >= 2 {
                let centres: Vec<f64> = bin_edges.windows(2).map(|w| 0.5 * (w[0] + w[1])).collect();
                let d = t.dim(
                    &format!("{name}_bin"),
                    centres,
                    u,
                    &format!("centre of a histogram bin of {what}"),
                );
                t.var(
                    &format!("{name}_bin_lower"),
                    false,
                    &[d],
                    FitData::F64(bin_edges[..bin_edges.len() - 1].to_vec()),
                    Some(u),
                    &format!("lower edge of a histogram bin of {what}"),
                );
                t.var(
                    &format!("{name}_bin_upper"),
                    false,
                    &[d],
                    FitData::F64(bin_edges[1..].to_vec()),
                    Some(u),
                    &format!("upper edge of a histogram bin of {what}"),
                );
                est_vars(
                    &mut t,
                    &format!("{name}_histogram"),
                    &[d],
                    &sums
                        .iter()
                        .flat_map(|x| x.histogram.clone())
                        .collect::<Vec<_>>(),
                    "1",
                    &format!("fraction of samples of {what} in the bin"),
                );
            }
        }
        // The adaptive rule: every asked width, at every point.
        let tol = stat.tolerance;
        any_missing |= sums.iter().any(|sm| sm.missing > 0);
        for sm in &sums {
            let mut check = |w: f64, t: Option<f64>| {
                if let Some(t) = t {
                    // A width that is no number (too few samples) is never within.
                    let r = if w.is_nan() { f64::INFINITY } else { w / t };
                    if r > 1.0 {
                        all_within = false;
                    }
                    worst = if worst.is_nan() { r } else { worst.max(r) };
                }
            };
            check(sm.mean.width(), tol.mean);
            check(sm.sd.width(), tol.sd);
            for q in &sm.quantiles {
                check(q.width(), tol.quantiles);
            }
            for x in &sm.exceed {
                check(x.width(), tol.exceed);
            }
        }
        match (&layout, input_dim) {
            (Layout::Saltelli { n }, Some(d)) => {
                let n = *n;
                let mut first = Vec::new();
                let mut total = Vec::new();
                for o in 0..outer {
                    let row = &vals[o * samples..(o + 1) * samples];
                    let fab: Vec<&[f64]> = (0..e.inputs.len())
                        .map(|g| &row[(2 + g) * n..(3 + g) * n])
                        .collect();
                    let idx = sobol_indices(&row[..n], &row[n..2 * n], &fab, e.seed ^ (o as u64));
                    first.extend(idx.iter().map(|i| i.first));
                    total.extend(idx.iter().map(|i| i.total));
                }
                est_vars(
                    &mut t,
                    &format!("{name}_first_order"),
                    &[d],
                    &first,
                    "1",
                    &format!("first-order Sobol' index of {what} (Jansen)"),
                );
                est_vars(
                    &mut t,
                    &format!("{name}_total"),
                    &[d],
                    &total,
                    "1",
                    &format!("total Sobol' index of {what} (Jansen)"),
                );
            }
            (Layout::Morris(steps), Some(d)) => {
                let trajectories = steps.iter().map(|s| s.trajectory + 1).max().unwrap_or(0);
                let g = e.inputs.len();
                let (mut mu, mut mu_star, mut sigma) = (Vec::new(), Vec::new(), Vec::new());
                for o in 0..outer {
                    let row = &vals[o * samples..(o + 1) * samples];
                    let mut effects = vec![vec![f64::NAN; g]; trajectories];
                    for (k, st) in steps.iter().enumerate() {
                        if let Some(m) = st.moved {
                            effects[st.trajectory][m] = (row[k] - row[k - 1]) / MORRIS_STEP;
                        }
                    }
                    for m in morris(&effects, g, e.seed ^ (o as u64)) {
                        mu.push(m.mu);
                        mu_star.push(m.mu_star);
                        sigma.push(m.sigma);
                    }
                }
                let per = format!("{u} per unit of the input's cumulative probability");
                est_vars(
                    &mut t,
                    &format!("{name}_mu_star"),
                    &[d],
                    &mu_star,
                    u,
                    &format!("Morris's mean absolute elementary effect on {what} ({per})"),
                );
                t.var(
                    &format!("{name}_mu"),
                    true,
                    &[d],
                    FitData::F64(mu),
                    Some(u),
                    &format!("Morris's mean elementary effect on {what} ({per})"),
                );
                t.var(
                    &format!("{name}_sigma"),
                    true,
                    &[d],
                    FitData::F64(sigma),
                    Some(u),
                    &format!("standard deviation of Morris's elementary effects on {what} ({per})"),
                );
            }
            _ => {}
        }
    }
    // An adaptive ensemble with samples that failed or gave no number stops there: its statistics
    // are over the samples that have one (biased where failing depends on the inputs), which no
    // tolerance may vouch for and more rounds would not mend (and where every run fails, each
    // round would only double the failures up to the budget).
    let stopped_by = if pending > 0 {
        "incomplete"
    } else if !e.adaptive() {
        "fixed"
    } else if any_missing {
        "failed"
    } else if all_within {
        "tolerance"
    } else if e.round_runs(k + 1) > e.max_runs.unwrap_or(0) {
        "budget"
    } else {
        "running"
    };
    let outcome = Outcome {
        round: k,
        samples,
        runs: e.round_runs(k),
        stopped_by,
        worst_ratio: worst,
    };
    let attrs = vec![
        ("ensemble_design", e.design.name().to_string()),
        ("ensemble_round", k.to_string()),
        ("ensemble_samples", samples.to_string()),
        ("ensemble_runs", outcome.runs.to_string()),
        ("ensemble_stopped_by", stopped_by.to_string()),
        ("ensemble_worst_ratio", worst.to_string()),
        (
            "ensemble_max_runs",
            e.max_runs.map_or("none".into(), |m| m.to_string()),
        ),
    ];
    (EnsembleTables { tables: t, attrs }, outcome)
}

/// The values of every statistic at every point of a grid (NaN where a point has no stored run,
/// the run failed or gives no number), gathered run by run, and how many points have none.
pub struct Values {
    /// `values[s][point]`.
    pub values: Vec<Vec<f64>>,
    /// Points without a run.
    pub pending: usize,
}

impl Values {
    /// Every value missing, over `grid`'s points.
    pub fn new(sweep: &Sweep, grid: &Grid) -> Values {
        let e = sweep.ensemble.as_ref().expect("an ensemble");
        Values {
            values: vec![vec![f64::NAN; grid.len()]; e.statistics.len()],
            pending: 0,
        }
    }

    /// Takes point `i`'s run (`None`: it has none).
    pub fn take(&mut self, sweep: &Sweep, i: usize, rec: Option<&RunRecord>) {
        let e = sweep.ensemble.as_ref().expect("an ensemble");
        match rec {
            None => self.pending += 1,
            Some(rec) => {
                for (column, st) in self.values.iter_mut().zip(&e.statistics) {
                    column[i] = st.of.of(rec).unwrap_or(f64::NAN);
                }
            }
        }
    }
}

/// Runs an adaptive ensemble round by round: each round is `sweep` at that round, run (or
/// resumed: its stored runs are taken as they are) into the same output; after a complete round
/// its file says whether the statistics are within their tolerances, the budget is spent, or
/// another round is due. Returns the last round's report and outcome.
pub fn run_rounds(
    sweep: &mut Sweep,
    opts: &RunOptions,
    sink: &mut dyn ProgressSink,
    stop: &AtomicBool,
    run: impl Fn(
        &mut Sweep,
        &mut Grid,
        &RunOptions,
        &mut dyn ProgressSink,
        &AtomicBool,
    ) -> Result<RunReport>,
) -> Result<(RunReport, Outcome)> {
    let e = sweep.ensemble.clone().expect("an ensemble");
    let mut k = 0;
    loop {
        let mut round = sweep.at_ensemble_round(k);
        let mut grid = Grid::new(&round)?;
        sink.ensemble_round(k, e.round_samples(k), e.round_runs(k));
        let report = run(&mut round, &mut grid, opts, sink, stop)?;
        let outcome = outcome_of(&opts.output).ok_or_else(|| {
            Error::Other(format!(
                "{}: the ensemble's file was not written",
                opts.output.display()
            ))
        })?;
        if report.stopped
            || stop.load(Ordering::Relaxed)
            || outcome.done()
            || outcome.stopped_by == "incomplete"
        {
            *sweep = round;
            return Ok((report, outcome));
        }
        k += 1;
    }
}

/// The round of an adaptive ensemble that a shard runs (`--shard` with `--ensemble-round`, round 0
/// without it): whether another round is due depends on every shard's samples, so a shard runs
/// one round and the merge of every shard's file decides (see [`Outcome`]). `None` where the run
/// is not a shard of an adaptive ensemble; an input error naming `--ensemble-round` where it is
/// given to any other run or names a round past the budget.
pub fn shard_round(sweep: &Sweep, opts: &RunOptions) -> Result<Option<usize>> {
    let (Some(e), Some(_)) = (sweep.adaptive_ensemble(), opts.shard) else {
        return match opts.ensemble_round {
            None => Ok(None),
            Some(_) => Err(Error::input(
                "--ensemble-round",
                "names the round of an adaptive ensemble (an ensemble with a tolerance) that a shard runs: give it with --shard, to such an ensemble only",
            )),
        };
    };
    let k = opts.ensemble_round.unwrap_or(0);
    let budget = e.max_runs.unwrap_or(0);
    if k > 0 && e.round_runs(k) > budget {
        let last = (0..k)
            .rev()
            .find(|&r| r == 0 || e.round_runs(r) <= budget)
            .unwrap_or(0);
        return Err(Error::input(
            "--ensemble-round",
            format!(
                "round {k} would take {} runs, over the ensemble's budget of {budget} (ensemble.max_runs): its rounds are 0 to {last}",
                e.round_runs(k)
            ),
        ));
    }
    Ok(Some(k))
}

/// The round of an adaptive ensemble that shard files hold, when they all hold the same one; an
/// error naming the files of each round otherwise (the tasks behind are to be run again at the
/// latest round). `None` for shards of any other sweep.
pub fn round_of_shards(sweep: &Sweep, shards: &[std::path::PathBuf]) -> Result<Option<usize>> {
    if sweep.adaptive_ensemble().is_none() {
        return Ok(None);
    }
    let mut rounds: Vec<(usize, &std::path::PathBuf)> = Vec::new();
    for s in shards {
        let round = outcome_of(s).map(|o| o.round).ok_or_else(|| {
            Error::Other(format!(
                "{}: a shard file of an adaptive ensemble that does not record its round (ensemble_round): run its shard again",
                s.display()
            ))
        })?;
        rounds.push((round, s));
    }
    let latest = rounds.iter().map(|r| r.0).max().unwrap_or(0);
    let behind: Vec<String> = rounds
        .iter()
        .filter(|r| r.0 != latest)
        .map(|(r, s)| {
            // Its shard and the SLURM array task that runs it (tasks count from 0).
            let shard = crate::store::hdf5::fit::read_attrs(s, &["shard"])
                .and_then(|a| crate::grid::Shard::parse(&a[0], "shard").ok())
                .map_or(String::new(), |sh| {
                    format!("; shard {sh}, SLURM array task {}", sh.k - 1)
                });
            format!("{} (round {r}{shard})", s.display())
        })
        .collect();
    if !behind.is_empty() {
        return Err(Error::Other(format!(
            "the shard files hold different rounds of the adaptive ensemble: the latest is round {latest}, and {} {} behind it; run {} again with --ensemble-round {latest} (under `chainsweep slurm`, whose tasks run the round its job folder's {} file names: re-submit {}), then merge",
            behind.join(", "),
            if behind.len() == 1 { "is" } else { "are" },
            if behind.len() == 1 { "its shard" } else { "their shards" },
            super::slurm::ROUND_FILE,
            if behind.len() == 1 { "its array task" } else { "their array tasks" },
        )));
    }
    Ok(Some(latest))
}

/// The outcome an ensemble's output file records (`None`: not an ensemble's file, or unreadable).
pub fn outcome_of(path: &std::path::Path) -> Option<Outcome> {
    let a = crate::store::hdf5::fit::read_attrs(
        path,
        &[
            "ensemble_round",
            "ensemble_samples",
            "ensemble_runs",
            "ensemble_stopped_by",
            "ensemble_worst_ratio",
        ],
    )?;
    let stopped_by = [
        "fixed",
        "tolerance",
        "budget",
        "failed",
        "running",
        "incomplete",
    ]
    .into_iter()
    .find(|s| *s == a[3])?;
    Some(Outcome {
        round: a[0].parse().ok()?,
        samples: a[1].parse().ok()?,
        runs: a[2].parse().ok()?,
        stopped_by,
        worst_ratio: a[4].parse().unwrap_or(f64::NAN),
    })
}
