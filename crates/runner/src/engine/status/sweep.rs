//! The status of a sweep: what the work directory of its output (and the output file) holds of
//! its grid, its searches or its ensemble.

use std::path::PathBuf;

use crate::error::Result;
use crate::grid::{Grid, Shard};
use crate::store::hdf5::Counts;
use crate::store::published::Check;
use crate::store::{work_dir_of, writer_of, Stored};
use crate::sweep::auto::AutoChoice;
use crate::sweep::Sweep;

use super::super::auto::{apply_cached, CachedChoice};
use super::super::run::{Failure, LISTED_FAILURES};
use super::super::shard;
use super::super::{search, DamageReport};
use super::{ensemble_of, Answer, EnsembleStatus, SearchLine};
use crate::search::SearchStatus;

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
    pub health: super::super::run::Health,
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
        .and(super::super::ensemble::outcome_of(&output))
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
        health: super::super::run::Health::default(),
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
        .map(|f| super::super::run::flagged(f.table(), &points, &grid).0)
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
        over_limit += super::super::run::Health::is_limit(&reason) as usize;
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
    status.health = super::super::run::Health {
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
