//! The engine: everything a command does between parsing its arguments and printing its result,
//! as a library. It prints nothing: results come back as values, and what happens while a sweep
//! runs goes to a [`ProgressSink`].
//!
//! - [`run`]: a sweep run or resumed into its output file ([`run::run_sweep`]), through
//!   - [`plan`]: what is done already, what to run (grid points and verification runs);
//!   - [`schedule`]: the runs on a thread pool through an [`schedule::Executor`], each stored
//!     as it finishes, with checkpoints of the output file and a stop flag;
//!   - [`assemble`]: the output file written from the stored runs;
//! - [`auto`]: `integrator: auto` resolved from the work directory's cache or a pilot;
//! - [`shard`]: which grid points a shard runs (balanced by estimated cost);
//! - [`slurm`]: `--shard slurm/N` of an array task, and the job scripts of `chainsweep slurm`;
//! - [`merge`]: shard files assembled into one;
//! - [`gc`]: records of runs an edited sweep no longer has removed from its work directory;
//! - [`status`]: what an output file or a work directory holds;
//! - [`inspect`]: a dry run, one grid point, a work-precision study.

pub mod assemble;
pub mod auto;
pub mod ensemble;
pub mod fit;
pub mod gc;
pub mod inspect;
pub mod merge;
pub mod periodic;
pub mod plan;
pub mod run;
pub mod schedule;
pub mod search;
pub mod shard;
pub mod slurm;
pub mod status;

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::grid::{Grid, Shard};
use crate::identity::RunHash;
use crate::store::published::{Damage, DamagedRun};
use crate::store::work_dir_of;
use crate::sweep::auto::AutoChoice;
use crate::sweep::Sweep;

/// How `integrator: auto` was resolved, as a [`ProgressSink`] hears of it.
#[derive(Debug, Clone, Copy)]
pub enum AutoResolution<'a> {
    /// Taken from the cache file `cache_file` of the output's work directory.
    Cached {
        /// The choice.
        choice: &'a AutoChoice,
        /// Where it was cached.
        cache_file: &'a Path,
    },
    /// Chosen now by a pilot.
    Chosen {
        /// The choice.
        choice: &'a AutoChoice,
    },
}

/// A run of an output file that cannot be read back (it is computed again by `run`).
#[derive(Debug, Clone, PartialEq)]
pub struct LostRun {
    /// Its grid point in the sweep the report is made for (`None`: a point that sweep does not
    /// have, or whose run hash is unknown).
    pub point: Option<usize>,
    /// Its axis values (`mass_ratio=0.3 damping_kg_s=6`), or which point of the file it was.
    pub label: String,
    /// Why it cannot be read back.
    pub why: String,
}

/// The damage found in an output file and its snapshot, with every damaged run named by its
/// grid point and axis values.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DamageReport {
    /// The output file.
    pub output: PathBuf,
    /// Why it cannot be read at all.
    pub file: Option<String>,
    /// What is wrong with its header.
    pub header: Option<String>,
    /// Damaged runs the snapshot gave back (nothing lost).
    pub restored: Vec<LostRun>,
    /// What is wrong with the snapshot.
    pub snapshot: Option<String>,
    /// Runs that cannot be read back.
    pub lost: Vec<LostRun>,
    /// The output file's layout carries no checksums (written by an earlier version): its values
    /// cannot be checked until it is written again.
    pub unchecked: bool,
}

impl DamageReport {
    /// The report of `damage` found in `output`, its runs labelled by the points of `grid` of
    /// `sweep` (by run hash).
    pub fn new(output: &Path, damage: &Damage, sweep: &Sweep, grid: &Grid) -> DamageReport {
        let at: HashMap<&RunHash, usize> = if damage.lost.is_empty() && damage.restored.is_empty() {
            HashMap::new()
        } else {
            grid.hashes
                .iter()
                .enumerate()
                .map(|(i, h)| (h, i))
                .collect()
        };
        let label = |d: &DamagedRun| {
            let point = d.hash.as_ref().and_then(|h| at.get(h).copied());
            LostRun {
                point,
                label: match (point, &d.hash) {
                    (Some(i), _) => format!("point {i} ({})", grid.point_label(sweep, i)),
                    (None, Some(_)) => format!(
                        "point {} of the file (a point this sweep does not have)",
                        d.point
                    ),
                    // A pending point names no run; a damaged run hash names none either.
                    (None, None) => format!(
                        "point {} of the file (which names no run: pending, or its run hash damaged)",
                        d.point
                    ),
                },
                why: d.why.clone(),
            }
        };
        DamageReport {
            output: output.to_path_buf(),
            file: damage.file.clone(),
            header: damage.header.clone(),
            restored: damage.restored.iter().map(label).collect(),
            snapshot: damage.snapshot.clone(),
            lost: damage.lost.iter().map(label).collect(),
            unchecked: false,
        }
    }

    /// Whether anything is damaged.
    pub fn any(&self) -> bool {
        self.file.is_some()
            || self.header.is_some()
            || !self.restored.is_empty()
            || self.snapshot.is_some()
            || !self.lost.is_empty()
    }
}

/// Receives what happens while the engine works: the display of a command line, a notebook
/// widget, a test's log. Every method has an empty default.
pub trait ProgressSink {
    /// A line of `integrator: auto`'s pilot, as it runs.
    fn pilot(&mut self, _line: &str) {}
    /// An adaptive ensemble starts a round: its number, samples per point and runs in all.
    fn ensemble_round(&mut self, _round: usize, _samples: usize, _runs: usize) {}
    /// The output file was found damaged when the sweep started: what the snapshot gave back,
    /// and the runs that will be computed again.
    fn damage_found(&mut self, _report: &DamageReport) {}
    /// `integrator: auto` was resolved.
    fn auto_resolved(&mut self, _resolution: AutoResolution<'_>) {}
    /// The runs start: `total` runs (verification runs included), `done` of them finished
    /// earlier (`failed` of those failed); `resumed_points` of the `points` grid points of this
    /// run were done earlier, into `output`.
    fn started(&mut self, _start: &Start<'_>) {}
    /// A run finished (`failed`: it failed).
    fn run_finished(&mut self, _failed: bool) {}
    /// Nothing finished for a while: time to refresh a display.
    fn idle(&mut self) {}
    /// The output file was refreshed with every run finished so far.
    fn checkpoint(&mut self) {}
    /// The stop flag was set: no new run starts; `in_flight` runs (at most) finish first. The
    /// output file was just written with every run finished so far.
    fn stopping(&mut self, _in_flight: usize) {}
    /// Writing the output file failed (`message` says why and what stays): no new run starts.
    /// Said at once, before the runs in flight finish.
    fn checkpoint_failed(&mut self, _message: &str) {}
    /// Every run is finished (or the sweep was stopped); the output file is written next.
    fn runs_ended(&mut self) {}
}

/// What a [`ProgressSink`] hears when the runs start.
#[derive(Debug, Clone, Copy)]
pub struct Start<'a> {
    /// Runs in all, verification runs included.
    pub total: usize,
    /// Runs finished earlier.
    pub done: usize,
    /// Runs finished earlier that failed.
    pub failed: usize,
    /// Grid points of this run (or shard).
    pub points: usize,
    /// Grid points finished earlier.
    pub resumed_points: usize,
    /// The output file.
    pub output: &'a Path,
}

/// A [`ProgressSink`] that ignores everything.
#[derive(Debug, Clone, Copy, Default)]
pub struct Silent;

impl ProgressSink for Silent {}

/// Reads, parses and expands a sweep file; errors name the file.
pub fn load(file: &Path) -> Result<(Sweep, Grid)> {
    load_showing(file, &|_, _| {})
}

/// [`load`], calling `progress(points expanded, points in all)` now and then while the grid is
/// expanded (from worker threads: a grid of ten million points takes seconds).
pub fn load_showing(
    file: &Path,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<(Sweep, Grid)> {
    let name = file.display().to_string();
    let sweep = Sweep::load(&name)?;
    sweep.check_draws().map_err(|e| e.in_file(&name))?;
    let n = sweep.n_points();
    let grid = Grid::expand(&sweep, &|done| progress(done, n)).map_err(|e| e.in_file(&name))?;
    search::check_intervals(&sweep, &grid).map_err(|e| e.in_file(&name))?;
    Ok((sweep, grid))
}

/// Every input error of the sweep file `file` that can be found in one pass (`chainsweep
/// validate`), given `first`, the error [`load`] stopped at: syntax, structure, each section's
/// values and each grid point's (distinct errors, at most
/// [`crate::sweep::diagnose::MOST_ERRORS`]); every error names the file. `first` alone when the
/// file cannot be read again.
pub fn input_errors(file: &Path, first: Error) -> Vec<Error> {
    let name = file.display().to_string();
    let Ok(text) = crate::sweep::read_sweep_text(&name) else {
        return vec![first];
    };
    // Paths the file names (recorded drives, fit data, a fit's result) are read from its
    // folder, as `load` reads them.
    let dir = file
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let mut errors = crate::sweep::diagnose::diagnose(&text, dir);
    let only_limits = errors
        .iter()
        .all(|e| matches!(e, Error::Input { field, .. } if field.starts_with("limits")));
    let sweep = match (errors.is_empty(), only_limits) {
        (true, _) => Sweep::parse_in(&text, dir).ok(),
        (false, true) => crate::sweep::diagnose::parse_without_limits(&text, dir),
        (false, false) => None,
    };
    if let Some(sweep) = sweep {
        errors.extend(Grid::point_errors(
            &sweep,
            crate::sweep::diagnose::MOST_ERRORS,
        ));
    }
    if errors.is_empty() {
        errors.push(first);
    }
    errors.into_iter().map(|e| e.in_file(&name)).collect()
}

/// The output file of a sweep file when none is given: its name with `.h5` in the current
/// directory, `NAME.shard-K-of-N.h5` for a shard.
pub fn default_output(file: &Path, shard: Option<Shard>) -> PathBuf {
    let stem = file
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "sweep".into());
    match shard {
        None => PathBuf::from(format!("{stem}.h5")),
        Some(Shard { k, n }) => PathBuf::from(format!("{stem}.shard-{k}-of-{n}.h5")),
    }
}

/// Checks that the folder `output` goes into exists (the error names `--output`).
pub fn check_output_folder(output: &Path) -> Result<()> {
    let parent = match output.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    if !parent.is_dir() {
        return Err(Error::input(
            "--output",
            format!("the directory {} does not exist", parent.display()),
        ));
    }
    Ok(())
}

/// Whether a file is read-only by its permission bits (no one may write it; root may anyway):
/// someone protected it, and no output replaces it.
pub fn read_only(meta: &std::fs::Metadata) -> bool {
    use std::os::unix::fs::PermissionsExt;
    meta.permissions().mode() & 0o222 == 0
}

/// Checks that `output` can be written without clobbering a file chainsweep did not make
/// (unless `overwrite`).
pub fn check_output(output: &Path, overwrite: bool) -> Result<()> {
    check_output_folder(output)?;
    if output.is_dir() {
        return Err(Error::input(
            "--output",
            format!("{} is a directory", output.display()),
        ));
    }
    // Read-only by its permission bits (root may write anyway): someone protected it, and
    // publishing a new file would silently replace it by a writable one.
    if let Ok(meta) = std::fs::metadata(output) {
        if meta.is_file() && read_only(&meta) {
            return Err(Error::input(
                "--output",
                format!(
                    "{} is read-only; chainsweep will not replace it (make it writable, e.g. `chmod u+w`, to continue into it, or choose another output)",
                    output.display()
                ),
            ));
        }
    }
    if output.exists() && !work_dir_of(output).is_dir() && !overwrite {
        // A chainsweep output moved or copied without its work directory still holds its runs:
        // say so, and that --overwrite continues into it keeping them, rather than invite its
        // deletion.
        let ours = crate::store::hdf5::is_hdf5(output)
            && crate::store::hdf5::FileRecords::open(output).is_ok();
        let message = if ours {
            format!(
                "{} is a chainsweep output without its work directory {} (moved or copied without it?); pass --overwrite to continue into it: every run it holds is kept, read back from it, and only what it lacks is computed",
                output.display(),
                work_dir_of(output).display()
            )
        } else {
            format!(
                "{} exists but has no work directory {} (it was not made by `chainsweep run` or `merge`); pass --overwrite to replace it",
                output.display(),
                work_dir_of(output).display()
            )
        };
        return Err(Error::input("--output", message));
    }
    Ok(())
}

/// A pool of `jobs` worker threads.
pub fn thread_pool(jobs: usize) -> Result<rayon::ThreadPool> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(jobs)
        .build()
        .map_err(|source| Error::Threads { jobs, source })
}

pub use crate::error::number_text;

/// The number of CPUs this process may use: its CPU affinity mask (what `taskset`, SLURM or a
/// container allow), as `std::thread::available_parallelism` reads it on Linux.
pub fn all_cpus() -> usize {
    std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1)
}

/// The environment variable by which SLURM says how many CPUs each task of a job has.
pub const SLURM_CPUS_PER_TASK: &str = "SLURM_CPUS_PER_TASK";

/// The default number of parallel runs: `SLURM_CPUS_PER_TASK` inside a SLURM job that sets it
/// (a positive integer), else the CPUs this process may use ([`all_cpus`]).
pub fn default_jobs() -> usize {
    std::env::var(SLURM_CPUS_PER_TASK)
        .ok()
        .and_then(|v| v.trim().parse::<usize>().ok())
        .filter(|&n| n > 0)
        .unwrap_or_else(all_cpus)
}

/// At most this many parallel runs per CPU ([`max_jobs`]): more only adds threads that wait.
pub const MAX_JOBS_PER_CPU: usize = 4;

/// The largest `--jobs` accepted: [`MAX_JOBS_PER_CPU`] times the CPUs this process may use (or
/// times `SLURM_CPUS_PER_TASK`, when that is larger).
pub fn max_jobs() -> usize {
    MAX_JOBS_PER_CPU * all_cpus().max(default_jobs())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A damaged run is labelled by the point of the sweep it belongs to; one the sweep does not
    /// have, or one whose point names no run (a pending point, a damaged run hash), by its point
    /// in the file, saying which of the two it is.
    #[test]
    fn damaged_runs_are_labelled_by_their_point_or_say_why_they_have_none() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../sweeps/examples");
        let text = std::fs::read_to_string(dir.join("trimer.json")).unwrap();
        let sweep = Sweep::parse_in(&text, &dir).unwrap();
        let grid = Grid::new(&sweep).unwrap();
        assert!(grid.len() > 2);
        let run = |point, hash| DamagedRun {
            point,
            hash,
            why: "a flipped byte".into(),
        };
        let damage = Damage {
            lost: vec![
                run(0, Some(grid.hashes[2])),
                run(1, Some([7; 32])),
                run(2, None),
            ],
            ..Damage::default()
        };
        let report = DamageReport::new(Path::new("x.h5"), &damage, &sweep, &grid);
        let labels: Vec<_> = report
            .lost
            .iter()
            .map(|l| (l.point, &l.label[..]))
            .collect();
        let own = format!("point 2 ({})", grid.point_label(&sweep, 2));
        assert_eq!(
            labels,
            [
                (Some(2), &own[..]),
                (
                    None,
                    "point 1 of the file (a point this sweep does not have)"
                ),
                (
                    None,
                    "point 2 of the file (which names no run: pending, or its run hash damaged)"
                ),
            ]
        );
    }
}
