//! `status`: what an output file holds, or what the work directory of a sweep's output holds.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::grid::{Grid, Shard};
use crate::identity::RunHash;
use crate::record::{STATUS_FAILED, STATUS_OK, STATUS_PENDING, STATUS_UNSETTLED};
use crate::store::hdf5::{Counts, FileRecords};
use crate::store::published::{Check, PublishedFile};
use crate::store::{scan_segments, work_dir_of, writer_of, Stored};
use crate::sweep::auto::AutoChoice;
use crate::sweep::Sweep;
use crate::uq::stats::Estimate;

use super::auto::{apply_cached, CachedChoice};
use super::run::{Failure, LISTED_FAILURES};
use super::shard::{self, Assignment};
use super::{search, DamageReport};
use crate::search::{SearchStatus, SEARCH_FLAGS};

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

/// What a reader of an output file (h5py, xarray) would be served: which of its points hold
/// values that do not match their checksums, read as the file stands (no snapshot).
#[derive(Debug, Clone, Default)]
pub struct FileCheck {
    /// Whether the file carries checksums (layout 3 and later).
    pub checked: bool,
    /// Why it cannot be read at all.
    pub file: Option<String>,
    /// What is wrong with its header, coordinates or probes.
    pub header: Option<String>,
    /// Damaged points: flat index, axis values (when the file's sweep can be read), why.
    pub damaged: Vec<(usize, String, String)>,
    /// Summary columns HDF5 cannot read: name, why, and whether it holds a value per probe.
    pub unreadable: Vec<(String, String, bool)>,
}

/// Checks every value of the output file `path` as it stands (its histories too with
/// `histories`), for a reader that takes the file as it is (`chainsweep.open`).
pub fn check_file(path: &Path, histories: bool) -> FileCheck {
    let mut c = FileCheck::default();
    if !crate::store::hdf5::is_hdf5(path) {
        c.file = Some("it does not start with the HDF5 signature".into());
        return c;
    }
    let recs = match FileRecords::open(path) {
        Ok(r) => r,
        Err(e) => {
            c.file = Some(format!("HDF5 cannot read it: {e}"));
            return c;
        }
    };
    c.checked = recs.checked();
    c.header = recs.header_damage.clone();
    c.unreadable = recs
        .unreadable()
        .iter()
        .map(|(n, e)| {
            let per_probe = crate::record::columns::column(n).is_some_and(|c| c.per_probe);
            (n.to_string(), e.clone(), per_probe)
        })
        .collect();
    // The file's own sweep and grid (from its checked header) label its points.
    let labelled = c
        .header
        .is_none()
        .then(|| crate::store::published::own_sweep_and_grid(&recs));
    let labelled = labelled.flatten();
    if let Some((sweep, grid)) = &labelled {
        let coords = recs.coordinate_damage(sweep, grid);
        if !coords.is_empty() {
            c.header = Some(coords.join("; "));
        }
    } else if c.header.is_none() {
        c.header = Some("its sweep cannot be expanded into a grid of its points".into());
    }
    let label = |i: usize| match &labelled {
        Some((sweep, grid)) if grid.searched.is_some() || sweep.search.is_none() => {
            grid.point_label(sweep, i)
        }
        _ => String::new(),
    };
    for i in 0..recs.len() {
        let why = match recs.damage(i) {
            Some(why) => Some(why.to_string()),
            None => match &labelled {
                Some((_, grid))
                    if histories && grid.has_run_arrays() && recs.status(i) == STATUS_OK =>
                {
                    match recs.record(i, grid.hashes[i], grid) {
                        crate::store::hdf5::read::PointRead::Damaged(why) => Some(why),
                        _ => None,
                    }
                }
                _ => None,
            },
        };
        if let Some(why) = why {
            c.damaged.push((i, label(i), why));
        }
    }
    c
}

/// The status of a sweep file's output, from its work directory.
#[derive(Debug, Clone)]
pub struct SweepStatus {
    /// The output file.
    pub output: PathBuf,
    /// Grid points of this output (or shard).
    pub points: usize,
    /// `integrator: auto`'s choice, when the sweep uses it and it is made.
    pub auto: Option<AutoChoice>,
    /// Counts of finished and pending points; `None` when `integrator: auto` is not chosen yet
    /// (nothing can have run).
    pub counts: Option<Counts>,
    /// The cache file that holds no choice, when `integrator: auto` is not chosen yet.
    pub auto_cache: Option<PathBuf>,
    /// The first [`LISTED_FAILURES`] failed points, with their reasons.
    pub failures: Vec<Failure>,
    /// What the work directory holds that is not a regular file where a log or segment is
    /// expected (left out).
    pub ignored: Vec<PathBuf>,
    /// Points of this run whose run succeeded but left a probe's leading peak NaN (the leading
    /// pulse had not passed it by the end of the run), as the output file holds them.
    pub unpassed: Vec<usize>,
    /// Points of this run whose run finished but whose steady state did not settle.
    pub unsettled: Vec<usize>,
    /// Its health at a glance (the runs counted so far; verification from the output file).
    pub health: super::run::Health,
    /// What was found damaged in the output file and its snapshot.
    pub damage: DamageReport,
    /// A sweep with a search: each search of this output, replayed through the stored runs.
    pub searches: Option<Vec<SearchLine>>,
    /// The process running the sweep into this output now, as its work directory's lock names
    /// it (`None`: none is).
    pub writer: Option<String>,
    /// An ensemble's output: how it stands and its statistics, from its output file.
    pub ensemble: Option<EnsembleStatus>,
}

/// The status of `sweep`'s output `output` (its work directory), for `shard`.
pub fn of_sweep(
    mut sweep: Sweep,
    mut grid: Grid,
    output: PathBuf,
    shard: Option<Shard>,
) -> Result<(SweepStatus, Sweep, Grid)> {
    let dir = work_dir_of(&output);
    // An adaptive ensemble: the round its output holds.
    if let Some(o) = sweep
        .ensemble
        .as_ref()
        .and(super::ensemble::outcome_of(&output))
    {
        if o.round != sweep.ensemble_round {
            sweep = sweep.at_ensemble_round(o.round);
            grid = Grid::new(&sweep)?;
        }
    }
    let points = shard::points(&sweep, &grid, shard);
    let mut status = SweepStatus {
        writer: writer_of(&output),
        output,
        points: points.len(),
        auto: None,
        counts: None,
        auto_cache: None,
        failures: Vec::new(),
        ignored: Vec::new(),
        unpassed: Vec::new(),
        unsettled: Vec::new(),
        health: super::run::Health::default(),
        damage: DamageReport::default(),
        searches: None,
        ensemble: None,
    };
    match apply_cached(&mut sweep, &mut grid, &dir)? {
        CachedChoice::NotAuto => {}
        CachedChoice::Chosen(c) => status.auto = Some(*c),
        CachedChoice::NotChosen(cache) => {
            status.auto_cache = Some(cache);
            return Ok((status, sweep, grid));
        }
    }
    // Only whole, checksummed records count: the runs `run` finds done.
    if sweep.search.is_some() {
        let stored = Stored::scan(&dir, Some(&status.output), None, Check::Everything)?;
        status.damage = DamageReport::new(&status.output, stored.damage(), &sweep, &grid);
        let driver = search::Driver::new(&sweep, &grid);
        let outer = search::outer_points(&driver.layout, shard);
        let replayed = driver.replay_stored(&outer, &stored)?;
        let mut counts = Counts::default();
        let mut lines = Vec::new();
        for s in &replayed {
            let started = !s.evals.is_empty();
            match s.outcome.status {
                SearchStatus::Running | SearchStatus::Budget if !s.finished => counts.pending += 1,
                SearchStatus::Budget => counts.pending += 1,
                SearchStatus::Failed => counts.failed += 1,
                _ => counts.ok += 1,
            }
            let rel = s.outcome.relative_uncertainty(driver.spec);
            let (in_round, round) = s.round_in_flight(&stored)?;
            let mut note = if s.finished {
                s.outcome.note.clone()
            } else if rel.is_finite() {
                format!("largest uncertainty {rel:.3} × its tolerance so far")
            } else {
                String::new()
            };
            if !s.finished && in_round > 0 {
                if !note.is_empty() {
                    note.push_str("; ");
                }
                note.push_str(&format!(
                    "its next round of {round} run(s) has {in_round} finished (they count once the round is whole)"
                ));
            }
            lines.push(SearchLine {
                label: search::outer_label(&sweep, &driver.layout, s.outer),
                status: if started || s.finished {
                    s.outcome.status.name().to_string()
                } else {
                    "pending".to_string()
                },
                runs: s.runs() as i64,
                note,
                answers: s
                    .outcome
                    .items
                    .iter()
                    .map(|it| match &s.outcome.fit {
                        Some(f) => Answer::of_fit(
                            driver.spec,
                            it,
                            (0..f.x.len())
                                .map(|k| {
                                    let p = f.profile.get(k);
                                    [
                                        f.linear[k],
                                        [
                                            p.map_or(f64::NAN, |p| p.lower),
                                            p.map_or(f64::NAN, |p| p.upper),
                                        ],
                                    ]
                                })
                                .collect(),
                        ),
                        None => Answer::of(driver.spec, it),
                    })
                    .collect(),
            });
        }
        status.points = outer.len();
        status.counts = Some(counts);
        status.searches = Some(lines);
        return Ok((status, sweep, grid));
    }
    let stored = Stored::scan(&dir, Some(&status.output), Some(&grid), Check::Everything)?;
    status.damage = DamageReport::new(&status.output, stored.damage(), &sweep, &grid);
    status.damage.unchecked = stored
        .published()
        .and_then(|p| p.file())
        .is_some_and(|f| !f.checked());
    let state = |i: usize| stored.get(&grid.hashes[i]);
    let done = points.iter().filter(|&&i| state(i) == Some(true)).count();
    let failed = points.iter().filter(|&&i| state(i) == Some(false)).count();
    // A finished run's steady state: from the published file where it holds the run, else from
    // the run's record (runs finished since the file was written).
    let mut unsettled = Vec::new();
    if grid.steady_harmonics > 0 {
        for &i in points.iter().filter(|&&i| state(i) == Some(true)) {
            let h = &grid.hashes[i];
            let flag = match stored.published().filter(|p| p.holds(h)) {
                Some(p) => p.unsettled(h),
                None => stored.read(h)?.is_some_and(|r| r.unsettled()),
            };
            if flag {
                unsettled.push(i);
            }
        }
    }
    status.ignored = stored.ignored().to_vec();
    status.counts = Some(Counts {
        ok: done - unsettled.len(),
        failed,
        pending: points.len() - done - failed,
        unsettled: unsettled.len(),
    });
    status.unpassed = stored
        .published()
        .and_then(|p| p.file())
        .map(|f| super::run::flagged(f.table(), &points, &grid).0)
        .unwrap_or_default();
    status.unsettled = unsettled;
    let mut over_limit = 0;
    for (k, &point) in points
        .iter()
        .filter(|&&i| state(i) == Some(false))
        .enumerate()
    {
        let reason = stored
            .read(&grid.hashes[point])?
            .map(|r| r.reason)
            .unwrap_or_default();
        over_limit += super::run::Health::is_limit(&reason) as usize;
        if k < LISTED_FAILURES {
            status.failures.push(Failure {
                point,
                reason: Some(reason),
            });
        }
    }
    let (verified, worst_verified) = stored
        .published()
        .and_then(|p| p.file())
        .map(|f| f.table().verification(&points))
        .unwrap_or_default();
    status.health = super::run::Health {
        failed,
        over_limit,
        unsettled: status.unsettled.len(),
        nan_leading: status.unpassed.len(),
        verified,
        worst_verified,
    };
    status.ensemble = ensemble_of(&status.output, &sweep);
    Ok((status, sweep, grid))
}

/// The state of one shard of a shard set.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ShardState {
    /// Every point of the shard ran successfully.
    Done,
    /// Every point ran, some failed (`run --retry-failed` runs them again).
    Failed,
    /// Points pending and no process writing the shard (its task was stopped or killed, or has
    /// not started).
    Pending,
    /// A process is writing the shard now (it holds its work directory): not to be run again.
    Running,
    /// No file of this shard, and none being written.
    Missing,
}

impl ShardState {
    /// `done`, `failed`, `pending`, `running`, `missing`.
    pub fn name(self) -> &'static str {
        match self {
            ShardState::Done => "done",
            ShardState::Failed => "failed",
            ShardState::Pending => "pending",
            ShardState::Running => "running",
            ShardState::Missing => "missing",
        }
    }
}

/// One shard of a shard set.
#[derive(Debug, Clone)]
pub struct ShardEntry {
    /// The shard, from 1.
    pub k: usize,
    /// Its file, when there is one.
    pub file: Option<PathBuf>,
    /// Its state.
    pub state: ShardState,
    /// The state of its points (none when missing).
    pub counts: Option<Counts>,
    /// The pid of the process writing it now, as its lock file names it (`Running`).
    pub writer: Option<String>,
}

/// The status of the shard files of one sweep in `n` shards.
#[derive(Debug, Clone)]
pub struct ShardSetStatus {
    /// Number of shards.
    pub n: usize,
    /// Every shard, 1 to `n`.
    pub shards: Vec<ShardEntry>,
}

impl ShardSetStatus {
    /// The shards (from 1) that are missing or have points pending, and that no process is
    /// writing: those to run (again).
    pub fn to_run(&self) -> Vec<usize> {
        self.shards
            .iter()
            .filter(|s| matches!(s.state, ShardState::Missing | ShardState::Pending))
            .map(|s| s.k)
            .collect()
    }
}

/// The shard files among `files` (those that exist; others are ignored): the sweep text and
/// `K/N` of each; an input error naming a file that is no shard file of the same sweep and `N`
/// as the first.
pub fn shard_files(files: &[PathBuf]) -> Result<Vec<(PathBuf, String, Shard)>> {
    let mut out: Vec<(PathBuf, String, Shard)> = Vec::new();
    for f in files.iter().filter(|f| f.exists()) {
        let bad = |m: String| Error::Input {
            file: Some(f.display().to_string()),
            field: String::new(),
            message: m,
        };
        let recs =
            FileRecords::open(f).map_err(|e| bad(format!("not a chainsweep output file: {e}")))?;
        let shard = Shard::parse(&recs.shard, "shard")
            .map_err(|_| bad(format!("records shard `{}`, not K/N", recs.shard)))?;
        if let Some((first, text, s0)) = out.first() {
            if *text != recs.sweep_text || s0.n != shard.n {
                return Err(bad(format!(
                    "is shard {shard} of {}, not of the sweep and shard count of {} (shard {s0})",
                    if *text == recs.sweep_text {
                        "the same sweep"
                    } else {
                        "another sweep"
                    },
                    first.display()
                )));
            }
        }
        out.push((f.clone(), recs.sweep_text.clone(), shard));
    }
    Ok(out)
}

/// The status of a shard set none of whose `files` (every shard's, in order) has been published
/// yet: each is being written (its work directory locked by a live process) or missing.
pub fn of_unstarted_shards(files: &[PathBuf]) -> ShardSetStatus {
    ShardSetStatus {
        n: files.len(),
        shards: files
            .iter()
            .enumerate()
            .map(|(i, p)| ShardEntry::unpublished(i + 1, Some(p)))
            .collect(),
    }
}

impl ShardEntry {
    /// Shard `k`, which has no published file: being written when a live process holds the
    /// work directory of its file `path` (named), else missing.
    fn unpublished(k: usize, path: Option<&Path>) -> ShardEntry {
        let writer = path.and_then(writer_of);
        ShardEntry {
            k,
            file: None,
            state: if writer.is_some() {
                ShardState::Running
            } else {
                ShardState::Missing
            },
            counts: None,
            writer,
        }
    }
}

/// The status of a shard set: `files` (those that exist) hold shards of one sweep in `N` shards;
/// every shard from 1 to `N` is done, failed, pending or missing.
pub fn of_shard_set(files: &[PathBuf]) -> Result<ShardSetStatus> {
    let found = shard_files(files)?;
    let Some((first, text, s0)) = found.first() else {
        return Err(Error::input(
            "FILE",
            format!("none of the {} shard file(s) given exists", files.len()),
        ));
    };
    let name = first.display().to_string();
    let sweep = Sweep::parse(text).map_err(|e| e.in_file(&name))?;
    let grid = Grid::new(&sweep).map_err(|e| e.in_file(&name))?;
    let n = s0.n;
    let assignment = Assignment::new(&sweep, &grid, Some(*s0));
    // Where a shard without a file would be written, by the naming of `run --shard` and
    // `chainsweep slurm` (beside the first shard file): a task that started but has not
    // published its file yet holds that path's work directory.
    let first_name = first.file_name().map(|f| f.to_string_lossy().into_owned());
    let suffix = format!(".shard-{}-of-{n}.h5", s0.k);
    let sibling = |k: usize| {
        let stem = first_name.as_deref()?.strip_suffix(&suffix)?;
        Some(first.with_file_name(format!("{stem}.shard-{k}-of-{n}.h5")))
    };
    let mut shards = Vec::with_capacity(n);
    for k in 1..=n {
        let Some((path, _, shard)) = found.iter().find(|(_, _, s)| s.k == k) else {
            shards.push(ShardEntry::unpublished(k, sibling(k).as_deref()));
            continue;
        };
        let recs = FileRecords::open(path)?;
        let points = assignment.points(Some(*shard), grid.len());
        let status = |i: usize| {
            if i < recs.len() {
                recs.status(i)
            } else {
                STATUS_PENDING
            }
        };
        let counts = Counts {
            ok: points.iter().filter(|&&i| status(i) == STATUS_OK).count(),
            failed: points
                .iter()
                .filter(|&&i| status(i) == STATUS_FAILED)
                .count(),
            pending: points
                .iter()
                .filter(|&&i| status(i) == STATUS_PENDING)
                .count(),
            unsettled: points
                .iter()
                .filter(|&&i| status(i) == STATUS_UNSETTLED)
                .count(),
        };
        let writer = writer_of(path);
        let state = if writer.is_some() {
            ShardState::Running
        } else if counts.pending > 0 {
            ShardState::Pending
        } else if counts.failed > 0 {
            ShardState::Failed
        } else {
            ShardState::Done
        };
        shards.push(ShardEntry {
            k,
            file: Some(path.clone()),
            state,
            counts: Some(counts),
            writer,
        });
    }
    Ok(ShardSetStatus { n, shards })
}
