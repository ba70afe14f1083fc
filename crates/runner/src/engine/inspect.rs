//! Commands that look at a sweep without running it into a file: a dry run's estimate, one grid
//! point run in this process, a work-precision study.

use std::path::{Path, PathBuf};

use chainsweep_solver::Scene;

use crate::error::{Error, Result};
use crate::exec;
use crate::grid::Grid;
use crate::identity::RunHash;
use crate::numerics::accuracy::{self, Study, StudyOptions};
use crate::record::RunRecord;
use crate::store::published::Check;
use crate::store::{work_dir_of, SegmentIndex, Stored};
use crate::sweep::{from_value_at, Sweep};

use super::auto;
use super::{all_cpus, thread_pool, ProgressSink};

/// Estimated bytes of the output per run: summaries, and histories (with minimum overlaps)
/// before compression.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SizeEstimate {
    /// Summaries per run (the steady state's included).
    pub summary: f64,
    /// Histories and minimum overlaps per run, uncompressed (0 without).
    pub history: f64,
    /// Space–time fields per run, uncompressed (0 without): every quantity's values at every
    /// instant of the longest run, and its sample count.
    pub fields: f64,
}

impl SizeEstimate {
    /// The estimate for `grid`'s runs.
    pub fn of(grid: &Grid) -> SizeEstimate {
        let np = grid.probes.len() as f64;
        // Summaries: 8 f64, 4 i64, 2 flag bytes, 7 f64 per probe, hash, reason and warning strings.
        let mut summary = 8.0 * 8.0 + 4.0 * 8.0 + 2.0 + np * 7.0 * 8.0 + 64.0 + 16.0 + 48.0;
        // The steady state: its frequency; per probe mean, RMS, settledness, transmission and
        // the settled flag, and an amplitude and a phase per harmonic.
        if grid.steady_harmonics > 0 {
            let h = grid.steady_harmonics as f64;
            summary += 8.0 + np * (4.0 * 8.0 + 1.0 + 2.0 * h * 8.0);
        }
        // The runs' arrays, uncompressed: each run's rows of the histories (and of its own time
        // samples where the runs' intervals differ), its sample count, its minimum overlaps.
        let mut history = 0.0;
        if grid.history {
            let s = grid.max_history_samples as f64;
            let own_time = if grid.history_interval_s.is_some() {
                0.0
            } else {
                1.0
            };
            history += (np + own_time) * s * 8.0 + 8.0;
        }
        if grid.min_overlap {
            history += grid.max_contacts as f64 * 8.0;
        }
        if grid.energy_flow {
            // Two energies per contact, one per particle.
            history += (2 * grid.max_contacts + grid.max_particles) as f64 * 8.0;
        }
        let fields = match &grid.fields {
            Some(spec) => {
                let per_sample = spec.values_per_sample(grid.max_particles, grid.max_contacts);
                (per_sample * grid.max_field_samples) as f64 * 8.0 + 8.0
            }
            None => 0.0,
        };
        SizeEstimate {
            summary,
            history,
            fields,
        }
    }

    /// The estimated output size of `runs` runs.
    pub fn total(&self, runs: usize) -> f64 {
        runs as f64 * (self.summary + self.history + self.fields) + 16384.0
    }
}

/// What a dry run reports beside the grid itself.
#[derive(Debug, Clone)]
pub struct DryRun {
    /// Runs stored in the output's work directory, by hash (`true`: ok).
    pub stored: SegmentIndex,
    /// Points of this run already done.
    pub ok: usize,
    /// Points of this run that failed.
    pub failed: usize,
    /// The size estimate.
    pub size: SizeEstimate,
    /// The cost estimate of the points still to run (`None`: none is left).
    pub cost: Option<CostEstimate>,
}

/// Most runs a dry run's pilot runs to estimate the cost.
pub const PILOT_RUNS: usize = 3;

/// A pilot run shorter than this, s, is repeated until its repeats take this long (the estimate
/// is their mean).
pub const PILOT_MIN_SECONDS: f64 = 0.05;

/// Most repeats of a short pilot run.
pub const PILOT_MAX_REPEATS: u32 = 1000;

/// Longest a pilot run runs, s: a longer run is stopped there and its cost extrapolated from the
/// simulated time it reached.
pub const PILOT_SECONDS_PER_RUN: f64 = 1.0;

/// The stated accuracy of a cost estimate from pilot runs that all ran in full: the cost of a run
/// varies across a grid (damping, masses and velocities change the number of steps) by more than
/// the measurement noise of a run.
pub const COST_ACCURACY: f64 = 0.5;

/// What a sweep will cost, from a pilot of a few of its runs.
#[derive(Debug, Clone, PartialEq)]
pub struct CostEstimate {
    /// CPU seconds of all the runs still to run.
    pub cpu_seconds: f64,
    /// CPU seconds of each pilot run.
    pub per_run: Vec<f64>,
    /// The pilot points.
    pub pilot_points: Vec<usize>,
    /// Runs still to run.
    pub runs: usize,
    /// Relative accuracy stated for the estimate (0.5: ±50 %).
    pub accuracy: f64,
    /// Pilot runs stopped at [`PILOT_SECONDS_PER_RUN`], their cost extrapolated.
    pub extrapolated: usize,
}

impl CostEstimate {
    /// The estimate from pilot runs of up to [`PILOT_RUNS`] of `to_run` (first, middle, last),
    /// each measured in thread CPU time.
    pub fn pilot(sweep: &Sweep, grid: &Grid, to_run: &[usize]) -> Result<Option<CostEstimate>> {
        if to_run.is_empty() {
            return Ok(None);
        }
        let k = PILOT_RUNS.min(to_run.len());
        let mut pilot_points: Vec<usize> = (0..k)
            .map(|j| {
                to_run[if k == 1 {
                    0
                } else {
                    j * (to_run.len() - 1) / (k - 1)
                }]
            })
            .collect();
        pilot_points.dedup();
        let mut per_run = Vec::new();
        let mut extrapolated = 0;
        for &i in &pilot_points {
            let scene = grid.build(sweep, i)?;
            let limit = PILOT_SECONDS_PER_RUN.min(sweep.limits.max_run_seconds);
            // A short run is repeated until the repeats take PILOT_MIN_SECONDS: its cost is then
            // their mean, above the clock's resolution and the noise of one run.
            let mut cpu_total = 0.0;
            let mut repeats = 0u32;
            let began = std::time::Instant::now();
            let cost = loop {
                let start_cpu = thread_cpu_seconds();
                let start = std::time::Instant::now();
                let deadline = start + std::time::Duration::from_secs_f64(limit);
                let result = exec::guarded(|| chainsweep_solver::run_until(&scene, Some(deadline)));
                let cpu = match (start_cpu, thread_cpu_seconds()) {
                    (Some(a), Some(b)) => b - a,
                    _ => start.elapsed().as_secs_f64(),
                };
                if let Ok(Err(chainsweep_solver::RunError::Deadline { t_s, .. })) = result {
                    if t_s > 0.0 {
                        extrapolated += 1;
                        break cpu * scene.duration_s / t_s;
                    }
                }
                // A run that ran in full (or stopped at once, or failed early) costs what it cost.
                cpu_total += cpu;
                repeats += 1;
                if began.elapsed().as_secs_f64() >= PILOT_MIN_SECONDS
                    || repeats >= PILOT_MAX_REPEATS
                {
                    break cpu_total / f64::from(repeats);
                }
            };
            per_run.push(cost);
        }
        let mean = per_run.iter().sum::<f64>() / per_run.len() as f64;
        let lo = per_run.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = per_run.iter().copied().fold(0.0, f64::max);
        // At least the stated accuracy; wider when the pilot runs themselves differ more (half
        // their range against their mean), and far wider for extrapolated runs.
        let spread = if mean > 0.0 {
            0.5 * (hi - lo) / mean
        } else {
            0.0
        };
        let spread = if extrapolated > 0 {
            spread.max(9.0)
        } else {
            spread
        };
        Ok(Some(CostEstimate {
            cpu_seconds: mean * to_run.len() as f64,
            per_run,
            pilot_points,
            runs: to_run.len(),
            accuracy: COST_ACCURACY.max(spread),
            extrapolated,
        }))
    }
}

/// CPU time of the calling thread so far, s (`clock_gettime(CLOCK_THREAD_CPUTIME_ID)`: exact to
/// the nanosecond on Linux, even for a thread that has not been descheduled since).
fn thread_cpu_seconds() -> Option<f64> {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid, writable timespec for the duration of the call; the clock id is a
    // constant the C library defines.
    let r = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    (r == 0).then_some(ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9)
}

/// A dry run of `points` of `grid` into `output`: what is stored already, and the size estimate;
/// an input error when the estimate does not fit in the space free where the output goes.
pub fn dry_run(sweep: &Sweep, grid: &Grid, points: &[usize], output: &Path) -> Result<DryRun> {
    let stored = Stored::scan(
        &work_dir_of(output),
        Some(output),
        Some(grid),
        Check::Summaries,
    )?
    .index();
    let state = |i: usize| stored.get(&grid.hashes[i]).copied();
    let size = SizeEstimate::of(grid);
    check_fits(grid, size.total(points.len()), output)?;
    // (Nothing stored: every point is to run, and no second list of them is made.)
    let to_run: std::borrow::Cow<[usize]> = if stored.is_empty() {
        points.into()
    } else {
        points
            .iter()
            .copied()
            .filter(|&i| state(i).is_none())
            .collect::<Vec<_>>()
            .into()
    };
    let cost = CostEstimate::pilot(sweep, grid, &to_run)?;
    Ok(DryRun {
        cost,
        ok: points.iter().filter(|&&i| state(i) == Some(true)).count(),
        failed: points.iter().filter(|&&i| state(i) == Some(false)).count(),
        stored,
        size,
    })
}

/// What a dry run of a sweep with a search says: the budget, what is stored, the cost.
#[derive(Debug, Clone)]
pub struct SearchDryRun {
    /// Searches of this run (or shard).
    pub searches: usize,
    /// Most runs they may take (their budgets).
    pub most_runs: usize,
    /// Runs their first scans take.
    pub first_scan_runs: usize,
    /// Runs they have used so far (stored).
    pub stored_runs: usize,
    /// Searches already ended.
    pub finished: usize,
    /// The cost of a run, from a pilot at the searched fields' midpoints (`None`: nothing left).
    pub cost: Option<CostEstimate>,
}

/// A dry run of the searches of `sweep` (of `shard`'s outer points) into `output`.
pub fn dry_run_search(
    sweep: &Sweep,
    grid: &Grid,
    shard: Option<crate::grid::Shard>,
    output: &Path,
) -> Result<SearchDryRun> {
    let driver = super::search::Driver::new(sweep, grid);
    let spec = driver.spec;
    let outer = super::search::outer_points(&driver.layout, shard);
    let stored = Stored::scan(&work_dir_of(output), Some(output), None, Check::Summaries)?;
    let replayed = driver.replay_stored(&outer, &stored)?;
    let stored_runs: usize = replayed.iter().map(|s| s.runs()).sum();
    let finished = replayed.iter().filter(|s| s.finished).count();
    // Pilot runs: each outer point's first run with the searched fields at their midpoints.
    let mid: Vec<f64> = spec.fields.iter().map(|f| 0.5 * (f.min + f.max)).collect();
    let mut pilot = grid.clone();
    pilot.searched = Some(crate::grid::Searched {
        fields: spec.fields.iter().map(|f| f.field.clone()).collect(),
        names: spec.fields.iter().map(|f| f.name.clone()).collect(),
        points: (0..grid.len()).map(|i| (i, mid.clone())).collect(),
    });
    let unfinished: Vec<usize> = replayed
        .iter()
        .filter(|s| !s.finished)
        .map(|s| driver.layout.own_points(s.outer)[0])
        .collect();
    let cost = CostEstimate::pilot(sweep, &pilot, &unfinished)?;
    let most_runs = spec.budget * outer.len();
    Ok(SearchDryRun {
        searches: outer.len(),
        most_runs,
        first_scan_runs: spec.scan_evaluations() * spec.runs_per_evaluation() * outer.len(),
        stored_runs,
        finished,
        cost: cost.map(|mut c| {
            // At most the budgets' runs still to run.
            c.runs = most_runs.saturating_sub(stored_runs);
            c.cpu_seconds = c.per_run.iter().sum::<f64>() / c.per_run.len() as f64 * c.runs as f64;
            c
        }),
    })
}

/// Refuses an estimated output of `bytes` larger than the space free on the file system that
/// will hold `output`, naming what to change: the history interval, or the grid.
fn check_fits(grid: &Grid, bytes: f64, output: &Path) -> Result<()> {
    let dir = match output.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    // A directory that does not exist is refused later, by `run`, with its own message.
    let Ok(free) = fs4::available_space(dir) else {
        return Ok(());
    };
    if bytes <= free as f64 {
        return Ok(());
    }
    let gib = |b: f64| format!("{:.3} GiB", b / (1u64 << 30) as f64);
    let (field, what) = if grid.fields.is_some() {
        (
            "record.fields.interval_s",
            "a longer field interval, fewer quantities or fewer points",
        )
    } else if grid.history {
        (
            "record.history_interval_s",
            "a longer history interval, fewer probes or fewer points",
        )
    } else {
        ("axes", "fewer points, or a shard per file system")
    };
    Err(Error::input(
        field,
        format!(
            "the sweep's output is estimated at {} (histories uncompressed), more than the {} free in {}: it cannot fit; take {what}",
            gib(bytes),
            gib(free as f64),
            dir.display()
        ),
    ))
}

/// One grid point: its scene, hash and, when run, its record.
#[derive(Debug, Clone)]
pub struct Point {
    /// Its scene.
    pub scene: Scene,
    /// Its run hash.
    pub hash: RunHash,
    /// Its record, when it was run.
    pub record: Option<RunRecord>,
}

/// Grid point `index` of `sweep`, run in this process when `run` (nothing is written).
/// `integrator: auto` is taken from `output`'s work directory or resolved by a pilot.
pub fn point(
    sweep: &mut Sweep,
    grid: &mut Grid,
    index: usize,
    output: Option<&Path>,
    run: bool,
    sink: &mut dyn ProgressSink,
) -> Result<Point> {
    if index >= grid.len() {
        return Err(Error::input(
            "INDEX",
            format!(
                "must lie in 0..{} (the grid's points), got {index}",
                grid.len()
            ),
        ));
    }
    let work_dir = output.map(work_dir_of);
    let pool = thread_pool(all_cpus())?;
    auto::resolve(sweep, grid, work_dir.as_deref(), &pool, sink)?;
    let scene = grid.build(sweep, index)?;
    let hash = grid.hashes[index];
    let record = run.then(|| exec::execute(&scene, hash, &sweep.limits, index));
    Ok(Point {
        scene,
        hash,
        record,
    })
}

/// The scene a work-precision study of `sweep` looks at: grid point `point`, or the base scene;
/// and its description.
pub fn study_scene(sweep: &Sweep, grid: &Grid, point: Option<usize>) -> Result<(Scene, String)> {
    match point {
        Some(i) if i >= grid.len() => Err(Error::input(
            "--point",
            format!("must lie in 0..{} (the grid's points), got {i}", grid.len()),
        )),
        Some(i) => Ok((
            grid.build(sweep, i)?,
            format!("grid point {i} ({})", grid.point_label(sweep, i)),
        )),
        None => Ok((
            from_value_at::<Scene>(sweep.base.clone(), "base")?,
            "base scene".to_string(),
        )),
    }
}

/// The output file of a work-precision study of sweep file `file` when none is given.
pub fn default_study_output(file: &Path) -> PathBuf {
    let stem = file
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "sweep".into());
    PathBuf::from(format!("{stem}.accuracy.h5"))
}

/// Checks the options of a study; an input error naming the option.
pub fn check_study_options(repeats: usize, max_run_seconds: f64) -> Result<()> {
    if repeats == 0 {
        return Err(Error::input("--repeats", "must be at least 1"));
    }
    if !(max_run_seconds.is_finite() && max_run_seconds > 0.0) {
        return Err(Error::input(
            "--max-run-seconds",
            "must be a number of seconds > 0",
        ));
    }
    Ok(())
}

/// Runs a work-precision study of `scene` and writes it to `output` (atomically); `source` says
/// what was studied; `log` receives progress lines.
pub fn study(
    scene: &Scene,
    opts: &StudyOptions,
    output: &Path,
    source: &str,
    log: impl FnMut(&str),
) -> Result<Study> {
    let st = accuracy::study(scene, opts, log)?;
    let probe_names: Vec<String> = scene.record.probes.iter().map(|p| p.name()).collect();
    let tmp = output.with_extension("h5.tmp");
    accuracy::write_study(&tmp, &st, &probe_names, source)?;
    std::fs::rename(&tmp, output).map_err(Error::rename(&tmp, output))?;
    Ok(st)
}
