//! A sweep with a `periodic` block: at every point of its axes, the branch of periodic orbits of
//! the driven scene continued in one field ([`chainsweep_solver::periodic::continue_branch`]),
//! the branches in parallel.
//!
//! Each branch keeps a journal in the work directory, `periodic/<point>.log`: a line naming what
//! it is the branch of (the sweep's text, the point's scene and the engine's versions, hashed),
//! then a line per orbit as the continuation accepts it (the orbit, its Floquet multipliers, where
//! the continuation stood, the run of two orbit periods that gives each probe's amplitudes), then a
//! line for how it ended; every line carries the first 16 hex digits of its SHA-256. A line whose
//! checksum fails or a torn last line is never read, nor anything after it; a journal of another
//! sweep is set aside. A branch whose journal has not ended goes on from the last orbit the
//! continuation stepped to that the journal holds ([`resume_branch`]): the continuation from an
//! orbit is a function of that orbit and the options alone, so the points it gives are bitwise
//! those an uninterrupted run gives. The stop flag stops each branch after the orbit it is
//! computing. The output file is written from the journals, to a temporary file renamed over it.
//!
//! A block with `autonomous` journals the free orbits of its family the same way, one line per
//! orbit ([`Entry::Free`]); it goes on after the last two the journal holds
//! ([`resume_autonomous`]), whose guess for the next orbit is made from them alone.

use std::fs::{self, OpenOptions};
use std::io::Write;
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};

use rayon::prelude::*;

use chainsweep_solver::observe::steady::SteadyProbe;
use chainsweep_solver::periodic::{
    continue_branch_stoppable, continue_period_doubled_stoppable, resume_branch,
    resume_period_doubled, BranchPoint, Monodromy, PeriodMap, PointKind,
};
use chainsweep_solver::spec::SpecError;
use chainsweep_solver::RunOutput;

use super::run::{Failure, Health, RunOptions, RunReport, VerificationReport};
use super::{check_output, thread_pool, DamageReport, ProgressSink, Start};
use crate::error::{Error, Result};
use crate::grid::Grid;
use crate::store::hdf5::periodic::{
    read_summary, write_file, PeriodicTables, StoredBranch, StoredPoint, BRANCH_FAILED, BRANCH_OK,
    BRANCH_PENDING,
};
use crate::store::hdf5::{Counts, Provenance};
use crate::store::lock_work_dir;
use crate::sweep::periodic::{PeriodicSpec, Switch};
use crate::sweep::Sweep;

mod free;
mod journal;

use free::{dry_run_free, free_family, stored_free_point};
use journal::{identity, line_of, read_journal, Entry, Journal};

/// The journals' folder in the work directory.
const JOURNALS: &str = "periodic";

/// Computes branch `index` into its journal at `path`, going on from the last orbit the
/// continuation accepted that the journal holds (`journal`, read back; its lines after that
/// orbit dropped) or from the start; returns the journal, without an end when `stop` stopped it.
#[allow(clippy::too_many_arguments)]
fn compute(
    sweep: &Sweep,
    grid: &Grid,
    spec: &PeriodicSpec,
    index: usize,
    path: &Path,
    identity: &str,
    journal: Option<Journal>,
    stop: &AtomicBool,
) -> Result<Journal> {
    let io = |e: std::io::Error| Error::Other(format!("{}: {e}", path.display()));
    // What is kept: the points up to the last one the continuation stepped to (a special point
    // located after it is located again, the same). Not an end point whose end line was lost
    // (killed between the two, a torn or damaged last line): it has no step to go on with, and
    // the step before it gives it again, the same.
    let mut journal = journal.unwrap_or_default();
    let keep = journal
        .points
        .iter()
        .rposition(|e| match e {
            Entry::Point { point, .. } => !point.kind.is_special() && point.kind != PointKind::End,
            Entry::Free { .. } => true,
            _ => false,
        })
        .map_or(0, |k| k + 1);
    journal.points.truncate(keep);
    journal.end = None;
    // Written afresh (identity and the points kept) beside the journal, then renamed over it.
    let fresh = path.with_extension("log.tmp");
    let mut file = OpenOptions::new()
        .create(true)
        .write(true)
        .truncate(true)
        .open(&fresh)
        .map_err(io)?;
    let mut text = line_of(&Entry::Identity {
        hash: identity.to_string(),
    });
    if let Some(parameter) = journal.doubling {
        text.push_str(&line_of(&Entry::Doubling { parameter }));
    }
    for e in &journal.points {
        text.push_str(&line_of(e));
    }
    file.write_all(text.as_bytes()).map_err(io)?;
    file.sync_data().map_err(io)?;
    fs::rename(&fresh, path).map_err(io)?;
    let mut write = |entry: &Entry| -> Result<()> {
        file.write_all(line_of(entry).as_bytes()).map_err(io)?;
        file.sync_data().map_err(io)
    };
    let point = grid.point_value(sweep, index);
    if let Some(frequencies) = &spec.autonomous {
        let Some(end) = free_family(spec, &point, frequencies, &mut journal, &mut write, stop)?
        else {
            return Ok(journal);
        };
        write(&end)?;
        journal.end = Some(end);
        return Ok(journal);
    }
    let from = spec.start(&point)?;
    let scene_at = |p: f64| {
        spec.scene_at(&point, p).map_err(|e| match e {
            Error::Input { field, message, .. } => {
                chainsweep_solver::spec::spec_err(&field, message)
            }
            other => chainsweep_solver::spec::spec_err("periodic", other.to_string()),
        })
    };
    let last = journal.points.last().and_then(|e| match e {
        Entry::Point { point, .. } => Some(point.as_ref().clone()),
        _ => None,
    });
    // The switch's period doubling, located on the point's branch unless the branch resumes
    // from a journaled point of its own.
    let mut doubling: Option<std::result::Result<BranchPoint, SpecError>> = None;
    if spec.switch == Some(Switch::PeriodDoubling) && last.is_none() {
        match first_doubling(spec, &scene_at, from, stop) {
            Ok(Some(d)) => {
                if journal.doubling.is_none() {
                    write(&Entry::Doubling {
                        parameter: d.parameter,
                    })?;
                    journal.doubling = Some(d.parameter);
                }
                doubling = Some(Ok(d));
            }
            // Stopped while following the point's branch: nothing of the switched branch yet.
            Ok(None) => return Ok(journal),
            Err(e) => doubling = Some(Err(e)),
        }
    }
    let journal_doubling = journal.doubling;
    let mut failure: Option<Error> = None;
    let mut on_point = |p: &BranchPoint| {
        if failure.is_some() {
            return;
        }
        let entry = orbit_entry(spec, &point, p);
        if let Err(e) = write(&entry) {
            failure = Some(e);
        }
        journal.points.push(entry);
    };
    let outcome = match (spec.switch, &last) {
        (None, Some(last)) => resume_branch(
            &scene_at,
            from,
            &spec.orbit,
            &spec.branch,
            last,
            Some(stop),
            &mut on_point,
        ),
        (None, None) => continue_branch_stoppable(
            &scene_at,
            from,
            &spec.orbit,
            &spec.branch,
            Some(stop),
            &mut on_point,
        ),
        (Some(Switch::PeriodDoubling), Some(last)) => match journal_doubling {
            Some(at) => resume_period_doubled(
                &scene_at,
                at,
                &spec.orbit,
                &spec.branch,
                last,
                Some(stop),
                &mut on_point,
            ),
            None => Err(chainsweep_solver::spec::spec_err(
                "periodic.switch",
                "the journal holds orbits of the switched branch but not where it switched",
            )),
        },
        (Some(Switch::PeriodDoubling), None) => match doubling.expect("located above") {
            Ok(d) => continue_period_doubled_stoppable(
                &scene_at,
                &d,
                &spec.orbit,
                &spec.branch,
                Some(stop),
                &mut on_point,
            ),
            Err(e) => Err(e),
        },
    };
    if let Some(e) = failure {
        return Err(e);
    }
    let end = match outcome {
        Ok(branch) if branch.stopped => return Ok(journal),
        Ok(branch) => Entry::End {
            end: branch.end,
            // Every warning of the branch, from its points (the same whether or not it was
            // resumed).
            warnings: journal
                .points
                .iter()
                .flat_map(|e| match e {
                    Entry::Point { point, .. } => point.progress.warnings.clone(),
                    _ => Vec::new(),
                })
                .collect(),
            maps: branch.maps,
        },
        Err(e) => Entry::Failed {
            reason: e.to_string(),
        },
    };
    write(&end)?;
    journal.end = Some(end);
    Ok(journal)
}

/// The first period doubling of the branch from `from` towards `to` (with its monodromy and
/// tangent, as the switch needs them); `Ok(None)` when `stop` stopped the search. The branch's
/// own points are not kept: they are not the stored branch's.
fn first_doubling(
    spec: &PeriodicSpec,
    scene_at: &dyn Fn(f64) -> std::result::Result<chainsweep_solver::Scene, SpecError>,
    from: f64,
    stop: &AtomicBool,
) -> std::result::Result<Option<BranchPoint>, SpecError> {
    let found = AtomicBool::new(false);
    let mut doubling: Option<BranchPoint> = None;
    let parent = continue_branch_stoppable(
        scene_at,
        from,
        &spec.orbit,
        &spec.branch,
        Some(&found),
        &mut |p| {
            if p.kind == PointKind::PeriodDoubling && doubling.is_none() {
                doubling = Some(p.clone());
            }
            if doubling.is_some() || stop.load(Ordering::Relaxed) {
                found.store(true, Ordering::Relaxed);
            }
        },
    )?;
    match doubling {
        Some(d) => Ok(Some(d)),
        None if parent.stopped => Ok(None),
        None => Err(chainsweep_solver::spec::spec_err(
            "periodic.switch",
            format!(
                "the branch from {from} towards {} has no period doubling to switch at: it ended ({}) after {} points, none with a multiplier through -1",
                spec.branch.to,
                parent.end,
                parent.points.len()
            ),
        )),
    }
}

/// The journal entry of an accepted orbit: the point and the run of two orbit periods from it.
fn orbit_entry(spec: &PeriodicSpec, point: &serde_json::Value, p: &BranchPoint) -> Entry {
    // What is journaled of an orbit: not its monodromy matrix ((2N)² numbers).
    let mut kept = p.clone();
    kept.orbit.monodromy = Vec::new();
    let run = spec
        .scene_at(point, p.parameter)
        .map_err(|e| e.to_string())
        .and_then(|scene| {
            let map = PeriodMap::new(&scene, &spec.stored_orbit()).map_err(|e| e.to_string())?;
            map.orbit_run(&scene, &p.orbit.state)
                .map_err(|e| e.to_string())
        });
    let (probes, max, run_error) = run_parts(run);
    Entry::Point {
        point: Box::new(kept),
        probes,
        max,
        run_error,
    }
}

/// What an orbit's run of two periods leaves in its journal line: each probe's steady state and
/// largest value, or why the run failed.
pub(super) fn run_parts(
    run: std::result::Result<RunOutput, String>,
) -> (Option<Vec<SteadyProbe>>, Option<Vec<f64>>, Option<String>) {
    match run {
        Ok(out) => (
            out.steady_state.map(|s| s.probes),
            Some(out.probes.iter().map(|s| s.record_max).collect()),
            None,
        ),
        Err(e) => (None, None, Some(e)),
    }
}

/// Runs (or resumes) `sweep`'s branches into `opts.output`.
pub fn run_periodic(
    sweep: &Sweep,
    grid: &Grid,
    opts: &RunOptions,
    sink: &mut dyn ProgressSink,
    stop: &AtomicBool,
) -> Result<RunReport> {
    let spec = sweep.periodic.as_ref().expect("a periodic sweep");
    check_output(&opts.output, opts.overwrite)?;
    if opts.shard.is_some() {
        return Err(Error::input(
            "--shard",
            "a sweep with a `periodic` block runs its branches on one machine (each is sequential); leave out --shard",
        ));
    }
    let (_lock, dir) = lock_work_dir(&opts.output, JOURNALS)?;
    let n = grid.len();
    let identities: Vec<String> = (0..n).map(|i| identity(sweep, grid, i)).collect();
    let path = |i: usize| dir.join(format!("{i}.log"));
    let mut journals: Vec<Option<Journal>> = (0..n)
        .map(|i| read_journal(&path(i), &identities[i]))
        .collect();
    let ended = |j: &Option<Journal>| j.as_ref().is_some_and(|j| j.end.is_some());
    let done = journals.iter().filter(|j| ended(j)).count();
    let failed_before = journals
        .iter()
        .filter(|j| {
            matches!(
                j,
                Some(Journal {
                    end: Some(Entry::Failed { .. }),
                    ..
                })
            )
        })
        .count();
    sink.started(&Start {
        total: n,
        done,
        failed: failed_before,
        points: n,
        resumed_points: done,
        output: &opts.output,
    });
    let open: Vec<usize> = (0..n).filter(|&i| !ended(&journals[i])).collect();
    let todo: Vec<(usize, Option<Journal>)> =
        open.iter().map(|&i| (i, journals[i].take())).collect();
    let pool = thread_pool(opts.jobs.min(todo.len()).max(1))?;
    // The branches run on the pool; their progress comes back here, to the sink.
    let (tx, rx) = std::sync::mpsc::channel::<bool>();
    let (pool_ref, path_ref, ids) = (&pool, &path, &identities);
    let computed: Vec<(usize, Result<Journal>)> = std::thread::scope(|scope| {
        let worker = scope.spawn(move || {
            let (pool, path, identities) = (pool_ref, path_ref, ids);
            pool.install(|| {
                todo.into_par_iter()
                    .filter_map(|(i, journal)| {
                        if stop.load(Ordering::Relaxed) {
                            return None;
                        }
                        let r = compute(
                            sweep,
                            grid,
                            spec,
                            i,
                            &path(i),
                            &identities[i],
                            journal,
                            stop,
                        );
                        // A branch the stop flag stopped is neither: it goes on next time.
                        match &r {
                            Ok(Journal { end: None, .. }) => {}
                            Ok(Journal {
                                end: Some(Entry::End { .. }),
                                ..
                            }) => {
                                let _ = tx.send(false);
                            }
                            _ => {
                                let _ = tx.send(true);
                            }
                        }
                        Some((i, r))
                    })
                    .collect()
            })
        });
        for failed in rx {
            sink.run_finished(failed);
        }
        worker.join().expect("the branches' thread")
    });
    let ran = computed.len();
    for (i, r) in computed {
        journals[i] = Some(r?);
    }
    sink.runs_ended();
    let stopped = journals.iter().any(|j| !ended(j));
    let harmonics = sweep_harmonics(sweep);
    let branches: Vec<StoredBranch> = journals
        .iter()
        .enumerate()
        .map(|(i, j)| {
            let particles = particles_at(sweep, grid, spec, i);
            stored_branch(spec, j.as_ref(), grid.probes.len(), harmonics, particles)
        })
        .collect();
    let particles = branches
        .iter()
        .flat_map(|b| b.points.first())
        .map(|p| p.position_m.len())
        .max()
        .unwrap_or(0);
    let multipliers = branches
        .iter()
        .flat_map(|b| b.points.first())
        .map(|p| p.multipliers.len())
        .max()
        .unwrap_or(0);
    let description = spec.describe();
    let tables = PeriodicTables {
        name: &spec.name,
        field: &spec.field,
        units: &spec.units,
        description,
        particles: particles.max(1),
        multipliers,
        harmonics,
        branches: &branches,
    };
    // Left as it is when nothing was computed and it reads back as this sweep's; else written
    // whole, to a temporary file renamed over it.
    let intact = ran == 0
        && read_summary(&opts.output).is_ok_and(|s| s.is_some_and(|s| s.len() == n))
        && crate::store::hdf5::periodic::check_every_dataset(&opts.output).is_ok()
        && crate::store::hdf5::read_sweep_text(&opts.output).is_ok_and(|t| t == sweep.text);
    if !intact {
        let tmp = dir.join("output.h5.tmp");
        let _ = fs::remove_file(&tmp);
        write_file(&tmp, sweep, grid, &Provenance::of_this_process(), &tables)?;
        fs::rename(&tmp, &opts.output)
            .map_err(|e| Error::Other(format!("{}: {e}", opts.output.display())))?;
    }

    let mut counts = Counts::default();
    let mut failures = Vec::new();
    for (i, b) in branches.iter().enumerate() {
        match b.status {
            BRANCH_OK => counts.ok += 1,
            BRANCH_FAILED => {
                counts.failed += 1;
                failures.push(Failure {
                    point: i,
                    reason: Some(b.end.clone()),
                });
            }
            _ => counts.pending += 1,
        }
    }
    Ok(RunReport {
        points: n,
        counts,
        failed: counts.failed,
        failures,
        verification: VerificationReport::default(),
        stopped,
        ran,
        damage: DamageReport {
            output: opts.output.clone(),
            ..DamageReport::default()
        },
        unpassed: Vec::new(),
        unsettled: Vec::new(),
        health: Health {
            failed: counts.failed,
            ..Health::default()
        },
        nothing_to_do: intact,
        search: None,
    })
}

/// Harmonics analysed per probe: the record block's `steady_state.harmonics`, else its default.
fn sweep_harmonics(sweep: &Sweep) -> usize {
    sweep
        .base
        .pointer("/record/steady_state/harmonics")
        .and_then(serde_json::Value::as_u64)
        .unwrap_or(3) as usize
}

/// The particles of the chain of branch `index` (`None`: its scene is refused; the branch then
/// holds no orbit).
fn particles_at(sweep: &Sweep, grid: &Grid, spec: &PeriodicSpec, index: usize) -> Option<usize> {
    let point = grid.point_value(sweep, index);
    let scene = spec.scene_at(&point, spec.start(&point).ok()?).ok()?;
    scene.validate().ok().map(|chain| chain.n_particles())
}

/// A journal as stored (`None`: pending); `particles`: its chain's.
fn stored_branch(
    spec: &PeriodicSpec,
    j: Option<&Journal>,
    probes: usize,
    harmonics: usize,
    particles: Option<usize>,
) -> StoredBranch {
    let Some(j) = j else {
        return StoredBranch {
            status: BRANCH_PENDING,
            end: "not computed yet (the run was stopped)".to_string(),
            maps: -1,
            points: Vec::new(),
        };
    };
    // A free orbit's place in its family (its kind: the first one `start`, the last `end`).
    let mut free = 0..;
    let points = j
        .points
        .iter()
        .filter_map(|e| match e {
            Entry::Point {
                point,
                probes: steady,
                max,
                ..
            } => Some(stored_point(
                point,
                steady.as_deref(),
                max.as_deref(),
                probes,
                harmonics,
                particles,
            )),
            Entry::Free {
                orbit,
                probes: steady,
                max,
                ..
            } => Some(stored_free_point(
                spec,
                free.next().expect("an endless count"),
                orbit,
                steady.as_deref(),
                max.as_deref(),
                probes,
                harmonics,
            )),
            _ => None,
        })
        .collect();
    let (status, end, maps) = match &j.end {
        Some(Entry::End {
            end,
            warnings,
            maps,
        }) => {
            let end = if warnings.is_empty() {
                end.clone()
            } else {
                format!("{end} ({})", warnings.join("; "))
            };
            (BRANCH_OK, end, *maps as i64)
        }
        Some(Entry::Failed { reason }) => (BRANCH_FAILED, reason.clone(), -1),
        _ => (
            BRANCH_PENDING,
            "stopped: the same command goes on from its last orbit".to_string(),
            -1,
        ),
    };
    StoredBranch {
        status,
        end,
        maps,
        points,
    }
}

fn stored_point(
    p: &BranchPoint,
    steady: Option<&[SteadyProbe]>,
    max: Option<&[f64]>,
    probes: usize,
    harmonics: usize,
    particles: Option<usize>,
) -> StoredPoint {
    let o = &p.orbit;
    // The orbit's components: the particles' positions and velocities, then (a wall on a
    // spring) the wall's displacement and velocity, which are not the particles'.
    let n = particles
        .filter(|&n| 2 * n <= o.state.len())
        .unwrap_or(o.state.len() / 2);
    StoredPoint {
        parameter: p.parameter,
        kind: 1 + p.kind.code(),
        stability: if o.stable() { 1 } else { 2 },
        largest_multiplier: o.largest_multiplier(),
        multipliers: o.multipliers.clone(),
        position_m: o.state[..n].to_vec(),
        velocity_m_s: o.state[n..2 * n].to_vec(),
        arclength: p.arclength,
        iterations: i64::from(o.iterations),
        maps: i64::from(o.maps),
        method: match o.method {
            Monodromy::FiniteDifference => 2,
            _ => 1,
        },
        residual: o.residual,
        ..probe_values(steady, max, probes, harmonics)
    }
}

/// A stored point holding only what the orbit's run gives: each probe's harmonics, mean, RMS,
/// largest value and settledness (NaN where the run failed or gave none).
pub(super) fn probe_values(
    steady: Option<&[SteadyProbe]>,
    max: Option<&[f64]>,
    probes: usize,
    harmonics: usize,
) -> StoredPoint {
    let mut s = StoredPoint {
        amplitude: vec![f64::NAN; probes * harmonics],
        phase_rad: vec![f64::NAN; probes * harmonics],
        mean: vec![f64::NAN; probes],
        rms: vec![f64::NAN; probes],
        max: max.map_or(vec![f64::NAN; probes], <[f64]>::to_vec),
        settledness: vec![f64::NAN; probes],
        ..StoredPoint::default()
    };
    if let Some(steady) = steady {
        for (i, q) in steady.iter().enumerate().take(probes) {
            for k in 0..harmonics.min(q.amplitude.len()) {
                s.amplitude[i * harmonics + k] = q.amplitude[k];
                s.phase_rad[i * harmonics + k] = q.phase_rad[k];
            }
            s.mean[i] = q.mean;
            s.rms[i] = q.rms;
            s.settledness[i] = q.settledness;
        }
    }
    s
}

/// What `run --dry-run` says of a periodic sweep before anything runs.
#[derive(Debug, Clone, PartialEq)]
pub struct PeriodicDryRun {
    /// Branches in all (grid points).
    pub branches: usize,
    /// Of them, those whose journal has ended (not computed again).
    pub ended: usize,
    /// Most points of a branch.
    pub max_points: u32,
    /// The first branch's start and the end of every branch.
    pub from: f64,
    /// The end of the range.
    pub to: f64,
    /// How the first orbit's monodromy was computed.
    pub monodromy: &'static str,
    /// CPU seconds of one period map with its monodromy and of one without, at the first
    /// branch's start (a pilot).
    pub seconds_per_map: (f64, f64),
    /// CPU seconds of settling the first guess (`settle_periods` drive periods).
    pub settle_seconds: f64,
    /// At most this many CPU seconds for the branches still to compute, were each to reach
    /// `max_points` (a branch usually ends with far fewer: at the end of its range).
    pub most_cpu_seconds: f64,
}

/// Period maps a point of a branch costs with its monodromy and without: two Newton iterations
/// (each a map with the monodromy and one at the shifted parameter) and the two orbit periods
/// of its run.
const MAPS_PER_POINT: (f64, f64) = (2.0, 4.0);

/// The budget of `sweep`'s branches into `output`, from a pilot at the first branch's start.
pub fn dry_run(sweep: &Sweep, grid: &Grid, output: &Path) -> Result<PeriodicDryRun> {
    let spec = sweep.periodic.as_ref().expect("a periodic sweep");
    let n = grid.len();
    let dir = crate::store::work_dir_of(output).join(JOURNALS);
    let ended = (0..n)
        .filter(|&i| {
            read_journal(&dir.join(format!("{i}.log")), &identity(sweep, grid, i))
                .is_some_and(|j| j.end.is_some())
        })
        .count();
    let point = grid.point_value(sweep, 0);
    if let Some(frequencies) = &spec.autonomous {
        return dry_run_free(spec, &point, frequencies, n, ended);
    }
    let from = spec.start(&point)?;
    let scene = spec.scene_at(&point, from)?;
    let map = PeriodMap::new(&scene, &spec.orbit).map_err(|e| Error::input(e.field, e.message))?;
    let started = std::time::Instant::now();
    let settled =
        PeriodMap::settle(&scene, map.drive_hz(), spec.orbit.settle_periods).map_err(|e| {
            Error::input(
                "periodic",
                format!("settling the first orbit at {from}: {e}"),
            )
        })?;
    let settle_seconds = started.elapsed().as_secs_f64();
    let started = std::time::Instant::now();
    let with = map
        .map(&settled, true)
        .map_err(|e| Error::input("periodic", format!("the first period map at {from}: {e}")))?;
    let mono = started.elapsed().as_secs_f64();
    let started = std::time::Instant::now();
    map.map(&settled, false)
        .map_err(|e| Error::input("periodic", format!("the first period map at {from}: {e}")))?;
    let plain = started.elapsed().as_secs_f64();
    let per_point = MAPS_PER_POINT.0 * mono + MAPS_PER_POINT.1 * plain;
    // A switched branch: the point's branch up to its doubling, then orbits of twice the period,
    // each map twice as long.
    let branches = match spec.switch {
        None => 1.0,
        Some(Switch::PeriodDoubling) => 3.0,
    };
    let most = (n - ended) as f64
        * (settle_seconds + branches * f64::from(spec.branch.max_points) * per_point);
    Ok(PeriodicDryRun {
        branches: n,
        ended,
        max_points: spec.branch.max_points,
        from,
        to: spec.branch.to,
        monodromy: with.method.name(),
        seconds_per_map: (mono, plain),
        settle_seconds,
        most_cpu_seconds: most,
    })
}

/// What `status` says of a periodic sweep's output file.
#[derive(Debug, Clone, PartialEq)]
pub struct PeriodicStatus {
    /// Per branch (grid point): its state (`pending`, `ended`, `failed`), its points, its special
    /// points `(kind, value of the continued field)`, and why it ended.
    pub branches: Vec<BranchLine>,
    /// Ended, failed and pending branches.
    pub counts: Counts,
    /// What is damaged in the file, if anything (a dataset failing its checksum).
    pub damage: Option<String>,
}

/// One branch as `status` lists it.
#[derive(Debug, Clone, PartialEq)]
pub struct BranchLine {
    /// `pending`, `ended` or `failed`.
    pub state: &'static str,
    /// Points of the branch.
    pub points: i64,
    /// Its special points: `(kind, value of the continued field)`.
    pub special: Vec<(&'static str, f64)>,
    /// Why it ended.
    pub end: String,
}

/// The status of the periodic sweep's output file `path`; `None` for a file of another kind.
pub fn status_of_file(path: &Path) -> Result<Option<PeriodicStatus>> {
    let summary = match read_summary(path) {
        Ok(Some(summary)) => summary,
        Ok(None) => return Ok(None),
        // Its tables cannot be read back: damaged, said so.
        Err(e) => {
            return Ok(Some(PeriodicStatus {
                branches: Vec::new(),
                counts: Counts::default(),
                damage: Some(e.to_string()),
            }))
        }
    };
    let damage = crate::store::hdf5::periodic::check_every_dataset(path)
        .err()
        .map(|e| e.to_string());
    let values = crate::store::hdf5::periodic::read_parameter(path).unwrap_or_default();
    let mut counts = Counts::default();
    let per = if summary.is_empty() {
        0
    } else {
        values.len() / summary.len()
    };
    let branches = summary
        .into_iter()
        .enumerate()
        .map(|(b, (status, points, kinds, end))| {
            let state = match status {
                BRANCH_OK => {
                    counts.ok += 1;
                    "ended"
                }
                BRANCH_FAILED => {
                    counts.failed += 1;
                    "failed"
                }
                _ => {
                    counts.pending += 1;
                    "pending"
                }
            };
            let special = kinds
                .iter()
                .enumerate()
                .filter(|(_, &k)| k >= 4)
                .map(|(k, &flag)| {
                    (
                        crate::store::hdf5::periodic::kind_name(flag),
                        values.get(b * per + k).copied().unwrap_or(f64::NAN),
                    )
                })
                .collect();
            BranchLine {
                state,
                points,
                special,
                end,
            }
        })
        .collect();
    Ok(Some(PeriodicStatus {
        branches,
        counts,
        damage,
    }))
}
