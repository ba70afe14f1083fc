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
use crate::store::{work_dir_of, SegmentIndex, Stored};
use crate::sweep::{from_value_at, Sweep};

use super::auto;
use super::{all_cpus, thread_pool, ProgressSink};

/// Estimated bytes of the output per run: summaries, and histories (with minimum overlaps)
/// before compression.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SizeEstimate {
    /// Summaries per run.
    pub summary: f64,
    /// Histories and minimum overlaps per run, uncompressed (0 without).
    pub history: f64,
}

impl SizeEstimate {
    /// The estimate for `grid`'s runs.
    pub fn of(grid: &Grid) -> SizeEstimate {
        let np = grid.probes.len() as f64;
        // Summaries: 8 f64, 4 i64, 2 flag bytes, 7 f64 per probe, hash, reason and warning strings.
        let summary = 8.0 * 8.0 + 4.0 * 8.0 + 2.0 + np * 7.0 * 8.0 + 64.0 + 16.0 + 48.0;
        let mut history = 0.0;
        if grid.history || grid.min_overlap {
            history += 2500.0; // group, attributes
        }
        if grid.history {
            let s = grid.max_history_samples as f64;
            history += (np + 1.0) * (s * 8.0 + 1200.0);
        }
        if grid.min_overlap {
            history += grid.max_contacts as f64 * 8.0 + 600.0;
        }
        SizeEstimate { summary, history }
    }

    /// The estimated output size of `runs` runs.
    pub fn total(&self, runs: usize) -> f64 {
        runs as f64 * (self.summary + self.history) + 16384.0
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
}

/// A dry run of `points` of `grid` into `output`: what is stored already, and the size estimate.
pub fn dry_run(grid: &Grid, points: &[usize], output: &Path) -> Result<DryRun> {
    let stored = Stored::scan(&work_dir_of(output), Some(output))?.index();
    let state = |i: usize| stored.get(&grid.hashes[i]).copied();
    Ok(DryRun {
        ok: points.iter().filter(|&&i| state(i) == Some(true)).count(),
        failed: points.iter().filter(|&&i| state(i) == Some(false)).count(),
        stored,
        size: SizeEstimate::of(grid),
    })
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
