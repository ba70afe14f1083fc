//! `status`: what an output file holds, or what the work directory of a sweep's output holds.
//!
//! A file's status is here; a sweep's is `sweep`'s, a set of shard files' `shards`', and the
//! damage check of a file (`status --check`) `check`'s.

use std::collections::HashMap;
use std::path::Path;

use crate::error::{Error, Result};
use crate::grid::Shard;
use crate::identity::RunHash;
use crate::store::hdf5::Counts;
use crate::store::published::{Check, PublishedFile};
use crate::store::{scan_segments, work_dir_of, writer_of};
use crate::sweep::Sweep;
use crate::uq::stats::Estimate;

use super::shard::Assignment;
use super::{search, DamageReport};
use crate::search::SEARCH_FLAGS;

mod check;
mod shards;
mod sweep;

pub use check::{check_file, FileCheck};
pub use shards::{
    of_shard_set, of_unstarted_shards, shard_files, ShardEntry, ShardSetStatus, ShardState,
};
pub use sweep::{of_sweep, SweepStatus};

/// The status of an output file.
#[derive(Debug, Clone)]
pub struct FileStatus {
    /// Grid points of the file's shard (all of them when not sharded).
    pub total: usize,
    /// The grid's shape.
    pub shape: Vec<usize>,
    /// The file's `shard` attribute (`K/N`).
    pub shard: String,
    /// Successful, failed and pending points of its shard (damaged runs count as pending: they
    /// are computed again).
    pub counts: Counts,
    /// Points of other shards the file holds too (a shard run into an output that held them).
    pub other_shards: usize,
    /// Points whose run the file holds under another run hash (made by another version of the
    /// engine or of its numerics): pending here, computed again by `run`.
    pub other_engine: usize,
    /// Points pending in the file whose run has finished since (a sweep is running, or was
    /// interrupted).
    pub newer: usize,
    /// The process writing the file now, as its work directory's lock names it (`None`: no live
    /// process holds it: finished runs the file lacks were left by an interrupted sweep).
    pub writer: Option<String>,
    /// Every failed point with its reason, in grid order.
    pub failures: Vec<(usize, String)>,
    /// Points of the shard whose run succeeded but left a probe's leading peak NaN (the leading
    /// pulse had not passed it by the end of the run; none for a driven sweep).
    pub unpassed: Vec<usize>,
    /// Points of the shard whose run finished but whose steady state did not settle.
    pub unsettled: Vec<usize>,
    /// Its health at a glance.
    pub health: super::run::Health,
    /// What was found damaged in the file and its snapshot.
    pub damage: DamageReport,
    /// A search's output: each search by its outer axis values, how it ended, its runs, why.
    pub searches: Option<Vec<SearchLine>>,
    /// An ensemble's output: how it stands and its statistics.
    pub ensemble: Option<EnsembleStatus>,
    /// The axis values of the points it lists (failed, unsettled, unpassed, the worst verified),
    /// as `run` names them (`mass_ratio=0.3 rtol=0.00001`).
    pub labels: HashMap<usize, String>,
}

/// The most points of each kind whose axis values `status` gives.
pub const LABELLED_POINTS: usize = 100;

/// An ensemble's output, as `status` gives it.
#[derive(Debug, Clone)]
pub struct EnsembleStatus {
    /// Its design's name.
    pub design: &'static str,
    /// Its round, size and whether it has ended.
    pub outcome: super::ensemble::Outcome,
    /// Each statistic.
    pub statistics: Vec<StatisticStatus>,
}

/// One statistic of an ensemble at the points of its ordinary axes (as many as
/// [`SHOWN_POINTS`]).
#[derive(Debug, Clone)]
pub struct StatisticStatus {
    /// Its name.
    pub name: String,
    /// Its unit.
    pub units: String,
    /// Per point: its label (the ordinary axes' values), mean, sd, quantiles (probability,
    /// estimate) and sensitivities (input, first-order or μ*, total or σ; NaN: none).
    pub points: Vec<StatisticPoint>,
}

/// A statistic at one point of the ordinary axes.
#[derive(Debug, Clone)]
pub struct StatisticPoint {
    /// The point's axis values (empty without axes).
    pub label: String,
    /// Samples that gave a number.
    pub n: i64,
    /// Mean.
    pub mean: Estimate,
    /// Standard deviation.
    pub sd: Estimate,
    /// Quantiles: (probability, estimate).
    pub quantiles: Vec<(f64, Estimate)>,
    /// Sobol' indices (input, first order, total) or Morris (input, μ*, σ as its value).
    pub sensitivity: Vec<(String, Estimate, Estimate)>,
}

/// Points of the ordinary axes whose statistics `status` lists.
pub const SHOWN_POINTS: usize = 12;

/// The ensemble's outcome and statistics as its output file `file` holds them (`None`: `sweep`
/// has no ensemble, or the file none of its tables).
pub fn ensemble_of(file: &Path, sweep: &Sweep) -> Option<EnsembleStatus> {
    use crate::store::hdf5::fit::read_f64;
    sweep.ensemble.as_ref()?;
    let outcome = super::ensemble::outcome_of(file)?;
    let sweep = &sweep.at_ensemble_round(outcome.round);
    let e = sweep.ensemble.as_ref()?;
    let ordinary = &sweep.dims[..sweep.dims.len() - 1];
    let shape: Vec<usize> = ordinary.iter().map(|d| d.len()).collect();
    let outer = e.outer_points.max(1);
    let label = |o: usize| -> String {
        let mi = crate::grid::multi_index(&shape, o);
        ordinary
            .iter()
            .zip(&mi)
            .map(|(d, &k)| {
                let a = &d.axes[0];
                format!("{}={}", a.name, a.values[k])
            })
            .collect::<Vec<_>>()
            .join(", ")
    };
    let inputs: Vec<String> = e.inputs.iter().map(|i| i.name.clone()).collect();
    let statistics = e
        .statistics
        .iter()
        .map(|st| {
            let get = |v: &str| read_f64(file, &format!("{}_{v}", st.name)).unwrap_or_default();
            let est = |v: &str| -> Vec<Estimate> {
                let (a, l, u) = (
                    get(v),
                    get(&format!("{v}_lower")),
                    get(&format!("{v}_upper")),
                );
                a.iter()
                    .enumerate()
                    .map(|(k, &x)| Estimate {
                        value: x,
                        lower: l.get(k).copied().unwrap_or(f64::NAN),
                        upper: u.get(k).copied().unwrap_or(f64::NAN),
                    })
                    .collect()
            };
            let n = get("n");
            let (mean, sd, q) = (est("mean"), est("sd"), est("quantile"));
            let nq = e.quantiles.len();
            let (first, second) = match e.design {
                crate::sweep::ensemble::Design::Saltelli => (est("first_order"), est("total")),
                crate::sweep::ensemble::Design::Morris { .. } => (
                    est("mu_star"),
                    get("sigma")
                        .into_iter()
                        .map(|x| Estimate {
                            value: x,
                            lower: f64::NAN,
                            upper: f64::NAN,
                        })
                        .collect(),
                ),
                _ => (Vec::new(), Vec::new()),
            };
            let g = inputs.len();
            let points = (0..outer.min(SHOWN_POINTS))
                .map(|o| StatisticPoint {
                    label: label(o),
                    n: n.get(o).map_or(0, |&x| x as i64),
                    mean: mean.get(o).copied().unwrap_or(Estimate::NONE),
                    sd: sd.get(o).copied().unwrap_or(Estimate::NONE),
                    quantiles: e
                        .quantiles
                        .iter()
                        .enumerate()
                        .map(|(j, &p)| (p, q.get(o * nq + j).copied().unwrap_or(Estimate::NONE)))
                        .collect(),
                    sensitivity: if first.is_empty() {
                        Vec::new()
                    } else {
                        (0..g)
                            .map(|k| {
                                (
                                    inputs[k].clone(),
                                    first.get(o * g + k).copied().unwrap_or(Estimate::NONE),
                                    second.get(o * g + k).copied().unwrap_or(Estimate::NONE),
                                )
                            })
                            .collect()
                    },
                })
                .collect();
            StatisticStatus {
                name: st.name.clone(),
                units: st.units.clone(),
                points,
            }
        })
        .collect();
    Some(EnsembleStatus {
        design: e.design.name(),
        outcome,
        statistics,
    })
}

/// One search of a sweep with a search, as `status` says it.
#[derive(Debug, Clone)]
pub struct SearchLine {
    /// Its outer axis values.
    pub label: String,
    /// How it stands (`converged`, `running`, …; `pending` when it has not started).
    pub status: String,
    /// Runs it used.
    pub runs: i64,
    /// Where it stands or why it ended.
    pub note: String,
    /// What it found (minima, maxima, roots), each with its uncertainty: its answer.
    pub answers: Vec<Answer>,
}

/// An item a search found, as `status` gives it.
#[derive(Debug, Clone)]
pub struct Answer {
    /// What it is (`minimum`, `maximum`, `root`).
    pub item: &'static str,
    /// Each searched field: its name, its value there and how far the true one may be.
    pub fields: Vec<(String, f64, f64)>,
    /// The objective there (`None`: no number).
    pub objective: Option<f64>,
    /// How it stands (`converged`, `at_bound`, …).
    pub status: &'static str,
    /// The whole in words, as `run` prints it.
    pub text: String,
    /// A fit's 95 % intervals per field: linearised and profile-likelihood (`[lower, upper]`
    /// each; NaN where not computed). Empty for other goals.
    pub intervals: Vec<[[f64; 2]; 2]>,
}

impl Answer {
    /// The answer of item `it` of the search `spec`.
    fn of(spec: &crate::sweep::search::SearchSpec, it: &crate::search::Item) -> Answer {
        Answer {
            item: spec.goal.item(),
            fields: spec
                .fields
                .iter()
                .zip(it.x.iter().zip(&it.uncertainty))
                .map(|(f, (&x, &u))| (f.name.clone(), x, u))
                .collect(),
            objective: it.value,
            status: it.status.name(),
            text: super::search::describe_item(spec, it),
            intervals: Vec::new(),
        }
    }

    /// The answer of a fit, its intervals with it.
    fn of_fit(
        spec: &crate::sweep::search::SearchSpec,
        it: &crate::search::Item,
        intervals: Vec<[[f64; 2]; 2]>,
    ) -> Answer {
        Answer {
            intervals,
            ..Answer::of(spec, it)
        }
    }
}

/// The status of the output file `file`, every value checked (a damaged file's state from what
/// can be read back, its snapshot included).
pub fn of_file(file: &Path) -> Result<FileStatus> {
    let name = file.display().to_string();
    let ours = work_dir_of(file).is_dir();
    let not_ours = |m: String| Error::Input {
        file: Some(name.clone()),
        field: String::new(),
        message: format!("not a chainsweep output file: {m}"),
    };
    let Some(p) = PublishedFile::open(file, None, Check::Everything) else {
        return Err(not_ours("it does not exist".into()));
    };
    let header = match (p.file(), p.snapshot()) {
        (Some(r), _) if r.header_damage.is_none() => Some((r.sweep_text.clone(), r.shard.clone())),
        (_, Some(s)) => Some((s.header.sweep.clone(), s.header.shard.clone())),
        _ => None,
    };
    let (Some((text, shard_text)), Some(grid)) = (header, p.grid()) else {
        let why = p
            .damage
            .file
            .clone()
            .or_else(|| p.damage.header.clone())
            .unwrap_or_else(|| "its sweep cannot be read".into());
        if !ours && p.file().is_none() {
            return Err(not_ours(why));
        }
        return Err(Error::Other(format!(
            "{name} is damaged: {why}; {} holds no usable snapshot of it{}, so what it held cannot be told",
            work_dir_of(file).display(),
            p.damage
                .snapshot
                .as_ref()
                .map(|s| format!(" ({s})"))
                .unwrap_or_default()
        )));
    };
    let sweep = Sweep::parse(&text).map_err(|e| e.in_file(&name))?;
    // An adaptive ensemble's file holds its last round.
    let sweep = sweep.with_points(grid.len()).unwrap_or(sweep);
    let shard = Some(Shard::parse(&shard_text, "--shard")?).filter(|s| s.n > 1);
    let assignment = Assignment::new(&sweep, grid, shard);
    let mut counts = Counts::default();
    let mut other_shards = 0;
    let mut total = 0;
    let mut failures = Vec::new();
    let mut held: HashMap<&RunHash, (usize, bool)> = HashMap::new();
    for (h, i, ok) in p.runs() {
        held.insert(h, (i, ok));
    }
    // A search file's grid has a slot per evaluation a search could have made; the slots it
    // did not make (hash zero) are no runs.
    let is_run = |i: usize| grid.hashes[i] != [0; 32];
    for i in (0..grid.len()).filter(|&i| is_run(i)) {
        let in_shard = assignment.contains(shard, i);
        total += usize::from(in_shard);
        match held.get(&grid.hashes[i]) {
            Some(&(_, ok)) if in_shard => {
                if !ok {
                    counts.failed += 1;
                } else if p.unsettled(&grid.hashes[i]) {
                    counts.unsettled += 1;
                } else {
                    counts.ok += 1;
                }
            }
            Some(_) => other_shards += 1,
            None if in_shard => counts.pending += 1,
            None => {}
        }
    }
    for i in (0..grid.len()).filter(|&i| is_run(i)) {
        if held.get(&grid.hashes[i]).is_some_and(|&(_, ok)| !ok) {
            let reason = p
                .read(&grid.hashes[i])
                .map(|r| r.reason)
                .unwrap_or_default();
            failures.push((i, reason));
        }
    }
    // Runs finished since the file was last assembled (it is refreshed by `run`). A search's file
    // has slots only for the evaluations it had made: every stored run it does not hold is newer.
    let segs = scan_segments(&work_dir_of(file))?;
    let newer = if sweep.search.is_some() {
        segs.keys().filter(|h| !held.contains_key(h)).count()
    } else {
        (0..grid.len())
            .filter(|&i| is_run(i) && assignment.contains(shard, i))
            .filter(|&i| !held.contains_key(&grid.hashes[i]))
            .filter(|&i| segs.contains_key(&grid.hashes[i]))
            .count()
    };
    let searches = match &sweep.search {
        None => None,
        Some(spec) => {
            let layout = search::Layout::new(&sweep, spec);
            let outcomes = crate::store::hdf5::search::read_outcomes(file).map_err(|e| {
                Error::Other(format!("{name}: its search's outcome cannot be read: {e}"))
            })?;
            let names: Vec<&str> = spec.fields.iter().map(|f| f.name.as_str()).collect();
            let found = crate::store::hdf5::search::read_items(file, spec.goal.item(), &names)
                .map_err(|e| {
                    Error::Other(format!("{name}: its search's answers cannot be read: {e}"))
                })?
                .unwrap_or_default();
            let intervals = match spec.goal {
                crate::sweep::search::Goal::Fit => {
                    crate::store::hdf5::search::read_fit_intervals(file, &names).map_err(|e| {
                        Error::Other(format!("{name}: its fit's intervals cannot be read: {e}"))
                    })?
                }
                _ => Vec::new(),
            };
            let answers = |k: usize| -> Vec<Answer> {
                found.get(k).map_or_else(Vec::new, |items| {
                    items
                        .iter()
                        .filter_map(|(x, u, objective, code)| {
                            let it = crate::search::Item {
                                x: x.clone(),
                                uncertainty: u.clone(),
                                value: (!objective.is_nan()).then_some(*objective),
                                status: crate::search::ItemStatus::from_code(*code)?,
                            };
                            Some(match intervals.get(k) {
                                Some(iv) => Answer::of_fit(spec, &it, iv.clone()),
                                None => Answer::of(spec, &it),
                            })
                        })
                        .collect()
                })
            };
            outcomes.map(|o| {
                o.into_iter()
                    .enumerate()
                    .map(|(k, (status, runs, note))| SearchLine {
                        answers: answers(k),
                        label: search::outer_label(&sweep, &layout, k),
                        status: SEARCH_FLAGS
                            .1
                            .split(' ')
                            .nth(status as usize)
                            .unwrap_or("unknown")
                            .to_string(),
                        runs,
                        note,
                    })
                    .collect()
            })
        }
    };
    let mut damage = DamageReport::new(file, &p.damage, &sweep, grid);
    damage.unchecked = p.file().is_some_and(|f| !f.checked());
    if let (Some(f), None) = (p.file(), &damage.header) {
        // Coordinates and probes are functions of the (checked) sweep.
        let coords = f.coordinate_damage(&sweep, grid);
        if !coords.is_empty() {
            damage.header = Some(coords.join("; "));
        }
    }
    let in_shard: Vec<usize> = (0..grid.len())
        .filter(|&i| is_run(i) && assignment.contains(shard, i))
        .collect();
    // (A damaged point's values say nothing: it is counted as pending, not flagged.)
    let (unpassed, unsettled) = p
        .file()
        .map(|f| {
            let intact: Vec<usize> = in_shard
                .iter()
                .copied()
                .filter(|&i| f.damage(i).is_none())
                .collect();
            super::run::flagged(f.table(), &intact, grid)
        })
        .unwrap_or_default();
    let (verified, worst_verified) = p
        .file()
        .map(|f| f.table().verification(&in_shard))
        .unwrap_or_default();
    let health = super::run::Health {
        failed: counts.failed,
        over_limit: failures
            .iter()
            .filter(|(i, r)| assignment.contains(shard, *i) && super::run::Health::is_limit(r))
            .count(),
        unsettled: unsettled.len(),
        nan_leading: unpassed.len(),
        verified,
        worst_verified,
    };
    let other_engine = p.file().map_or(0, |f| {
        (0..grid.len().min(f.len()))
            .filter(|&i| is_run(i) && assignment.contains(shard, i))
            .filter(|&i| {
                let held = f.hash_hex(i);
                !held.is_empty() && held != crate::identity::hex(&grid.hashes[i])
            })
            .count()
    });
    // A search file's points are its evaluations: labelled by index, as before.
    let labels: HashMap<usize, String> = if sweep.search.is_none() {
        failures
            .iter()
            .map(|(i, _)| *i)
            .take(LABELLED_POINTS)
            .chain(unpassed.iter().copied().take(LABELLED_POINTS))
            .chain(unsettled.iter().copied().take(LABELLED_POINTS))
            .chain(health.worst_verified.map(|(_, i)| i))
            .filter(|&i| i < grid.len())
            .map(|i| (i, grid.point_label(&sweep, i)))
            .collect()
    } else {
        HashMap::new()
    };
    Ok(FileStatus {
        labels,
        total,
        shape: sweep.shape(),
        shard: shard_text,
        counts,
        health,
        other_engine,
        unpassed,
        unsettled,
        other_shards,
        newer,
        writer: writer_of(file),
        failures,
        damage,
        searches,
        ensemble: ensemble_of(file, &sweep),
    })
}
