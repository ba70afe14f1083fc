//! The `chainsweep` command line: `validate`, `run`, `status`, `merge`.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use clap::{Args, Parser, Subcommand};
use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::exec;
use crate::grid::{multi_index, Grid};
use crate::identity::{hex, RunHash};
use crate::numerics::{auto, verify};
use crate::progress::Progress;
use crate::record::{RunRecord, VerifyInfo, STATUS_FAILED, STATUS_OK, STATUS_PENDING};
use crate::store::hdf5::{self as hdf5file, Counts, FileRecords, Provenance};
use crate::store::{read_segment_in, scan_segments, work_dir_of, WorkDir, AUTO_CHOICE_FILE};
use crate::sweep::auto::{describe, AutoChoice};
use crate::sweep::Sweep;
use crate::{EXIT_OK, EXIT_PARTIAL};

const EXAMPLES: &str = "\
Examples:
  chainsweep validate sweeps/mass-damping.json
  chainsweep run sweeps/mass-damping.json --dry-run
  chainsweep run sweeps/mass-damping.json -o results/mass-damping.h5 --jobs 8
  chainsweep status results/mass-damping.h5
  # re-running the same command after an interruption continues where it stopped:
  chainsweep run sweeps/mass-damping.json -o results/mass-damping.h5 --jobs 8
  # on a cluster: one shard per job, then merge
  chainsweep run sweeps/mass-damping.json --shard 3/16 -o shards/part-3.h5
  chainsweep merge -o results/mass-damping.h5 shards/part-*.h5

Exit codes: 0 all runs succeeded; 1 other error (I/O, output locked by another process);
2 bad input or usage (nothing run, nothing written); 3 partial (some runs failed or are missing).";

/// Runs grids of chain simulations into HDF5, in parallel, resumably.
#[derive(Debug, Parser)]
#[command(name = "chainsweep", version, about, after_help = EXAMPLES)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// Subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Check a sweep file (syntax, fields, types, physical ranges of every grid point); run nothing.
    #[command(after_help = "Example:\n  chainsweep validate sweeps/mass-damping.json")]
    Validate {
        /// Sweep file (JSON).
        file: PathBuf,
    },
    /// Run a sweep (or continue an interrupted one) into an HDF5 file.
    #[command(
        after_help = "Examples:\n  chainsweep run sweeps/mass-damping.json --dry-run\n  chainsweep run sweeps/mass-damping.json -o out.h5 --jobs 4\n  chainsweep run sweeps/mass-damping.json --shard 2/8 -o part-2.h5"
    )]
    Run(RunArgs),
    /// Say how many runs of a sweep are done, failed and pending.
    #[command(
        after_help = "Examples:\n  chainsweep status results/mass-damping.h5\n  chainsweep status sweeps/mass-damping.json -o results/mass-damping.h5"
    )]
    Status {
        /// An output file (`.h5`) or a sweep file (then the output is `-o` or its default).
        file: PathBuf,
        /// Output file, when FILE is a sweep file.
        #[arg(short, long)]
        output: Option<PathBuf>,
        /// Shard `K/N`, when FILE is a sweep file run with `--shard`.
        #[arg(long)]
        shard: Option<String>,
    },
    /// Run one grid point in this process and print its scene and results as JSON; writes nothing.
    #[command(after_help = "Example:\n  chainsweep point sweeps/mass-damping.json 17")]
    Point {
        /// Sweep file (JSON).
        file: PathBuf,
        /// Flat index of the grid point (row-major, as `run --dry-run` lists them).
        index: usize,
        /// Print only the scene, do not run it.
        #[arg(long)]
        scene_only: bool,
        /// With `integrator: auto`: the output file whose work directory holds the choice made
        /// by `run` (`X.h5.d/auto.json`); without it (or when it holds none) the pilot is run.
        #[arg(short, long)]
        output: Option<PathBuf>,
    },
    /// Work-precision study of one scene: every integrator over a ladder of settings, errors
    /// against a confirmed reference, median wall time, RHS evaluations; written to HDF5.
    #[command(
        after_help = "Examples:\n  chainsweep accuracy sweeps/mass-damping.json -o results/work_precision_fig08.h5\n  chainsweep accuracy sweeps/mass-damping.json --point 17 --methods dop853,ros34pw2\n  python scripts/plot_work_precision.py results/work_precision_fig08.h5"
    )]
    Accuracy(AccuracyArgs),
    /// Assemble shard files into one file, identical to a single-machine run.
    #[command(
        after_help = "Example:\n  chainsweep merge -o results/sweep.h5 part-1.h5 part-2.h5 part-3.h5"
    )]
    Merge {
        /// Merged output file.
        #[arg(short, long)]
        output: PathBuf,
        /// Shard files made by `chainsweep run --shard K/N` from the same sweep file.
        #[arg(required = true)]
        shards: Vec<PathBuf>,
    },
}

/// Arguments of `chainsweep run`.
#[derive(Debug, Args)]
pub struct RunArgs {
    /// Sweep file (JSON).
    pub file: PathBuf,
    /// Output HDF5 file [default: the sweep file's name with `.h5` in the current directory,
    /// `NAME.shard-K-of-N.h5` with `--shard`].
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Parallel runs [default: the number of CPUs].
    #[arg(short, long)]
    pub jobs: Option<usize>,
    /// Run only shard K of N (every N-th grid point from the K-th), into its own file.
    #[arg(long, value_name = "K/N")]
    pub shard: Option<String>,
    /// Print the expanded grid and an estimate of the output size; run nothing.
    #[arg(long)]
    pub dry_run: bool,
    /// No progress display and no closing summary (failures are still listed).
    #[arg(short, long)]
    pub quiet: bool,
    /// Run again the points whose earlier run failed.
    #[arg(long)]
    pub retry_failed: bool,
    /// Seconds between plain progress lines when stderr is not a terminal.
    #[arg(long, default_value_t = 10.0, value_name = "SECONDS")]
    pub progress_interval: f64,
    /// Seconds between refreshes of the output file while the sweep runs (0: only at the end).
    #[arg(long, default_value_t = 300.0, value_name = "SECONDS")]
    pub checkpoint_interval: f64,
    /// Replace an existing output file that has no work directory (not made by `chainsweep run`).
    #[arg(long)]
    pub overwrite: bool,
    /// Re-run a deterministic sample of this fraction of the grid points (in [0, 1], at least one
    /// point when > 0) at a tighter setting (rtol/100, dt/4) and store the observed relative error
    /// of every summary (`verified`, `verify_rel_error_*`).
    #[arg(long, value_name = "FRACTION")]
    pub verify: Option<f64>,
}

/// Arguments of `chainsweep accuracy`.
#[derive(Debug, Args)]
pub struct AccuracyArgs {
    /// Sweep file (JSON): its base scene is studied, or grid point `--point`.
    pub file: PathBuf,
    /// Study this grid point (flat index) instead of the base scene.
    #[arg(long)]
    pub point: Option<usize>,
    /// Output HDF5 file [default: NAME.accuracy.h5 in the current directory].
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Repeats of every setting; the wall time is their median.
    #[arg(long, default_value_t = 3)]
    pub repeats: usize,
    /// Skip fixed-step settings estimated to take longer than this per run, and stop an adaptive
    /// ladder after a run that did.
    #[arg(long, default_value_t = 3.0, value_name = "SECONDS")]
    pub max_run_seconds: f64,
    /// Methods to study, comma separated.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "dop853,ros34pw2,rk4,verlet"
    )]
    pub methods: Vec<String>,
    /// No progress lines.
    #[arg(short, long)]
    pub quiet: bool,
}

/// Parses the command line, runs the command, and returns the process exit code.
pub fn main() -> i32 {
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            let code = if e.use_stderr() {
                crate::EXIT_BAD_INPUT
            } else {
                EXIT_OK
            };
            let _ = e.print();
            return code;
        }
    };
    match dispatch(cli) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("chainsweep: error: {e}");
            e.exit_code()
        }
    }
}

/// Runs a parsed command.
pub fn dispatch(cli: Cli) -> Result<i32> {
    match cli.command {
        Command::Validate { file } => cmd_validate(&file),
        Command::Run(args) => cmd_run(&args),
        Command::Status {
            file,
            output,
            shard,
        } => cmd_status(&file, output, shard.as_deref()),
        Command::Merge { output, shards } => cmd_merge(&output, &shards),
        Command::Accuracy(args) => cmd_accuracy(&args),
        Command::Point {
            file,
            index,
            scene_only,
            output,
        } => cmd_point(&file, index, scene_only, output.as_deref()),
    }
}

fn path_str(p: &Path) -> String {
    p.display().to_string()
}

fn load(file: &Path) -> Result<(Sweep, Grid)> {
    let name = path_str(file);
    let sweep = Sweep::load(&name)?;
    let grid = Grid::new(&sweep).map_err(|e| e.in_file(&name))?;
    Ok((sweep, grid))
}

fn thread_pool(jobs: usize) -> Result<rayon::ThreadPool> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(jobs)
        .build()
        .map_err(|e| Error::Other(format!("cannot start {jobs} worker threads: {e}")))
}

fn all_cpus() -> usize {
    std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1)
}

/// How `integrator: auto` was resolved.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum AutoOrigin {
    /// The sweep does not use `auto`.
    None,
    /// Taken from the cache in the output's work directory.
    Cache,
    /// Chosen by a pilot run now (to be cached by a command that holds the work directory).
    Pilot,
}

/// Resolves `integrator: auto` when the sweep asks for it: from the cache in `work_dir` when it
/// holds the choice for this sweep, else by running the pilot on `pool`; then rebuilds the grid
/// with the chosen integrator. Says what it chose on stderr (the pilot's progress unless `quiet`).
fn resolve_auto(
    sweep: &mut Sweep,
    grid: &mut Grid,
    work_dir: Option<&Path>,
    pool: &rayon::ThreadPool,
    quiet: bool,
) -> Result<AutoOrigin> {
    let Some(spec) = sweep.auto else {
        return Ok(AutoOrigin::None);
    };
    if sweep.auto_choice.is_some() {
        return Ok(AutoOrigin::Cache);
    }
    let key = auto::cache_key(grid, &spec);
    let target = spec.target_rel_error;
    let (choice, origin) = match work_dir.and_then(|d| auto::read_cache(d, &key)) {
        Some(c) => {
            eprintln!(
                "chainsweep: integrator auto, target {target:e}: {} (chosen earlier: {})",
                describe(&c.integrator),
                work_dir
                    .expect("read from it")
                    .join(AUTO_CHOICE_FILE)
                    .display()
            );
            (c, AutoOrigin::Cache)
        }
        None => {
            let c = auto::resolve(sweep, grid, &spec, pool, |l| {
                if !quiet {
                    eprintln!("chainsweep: auto: {l}");
                }
            })?;
            eprintln!(
                "chainsweep: integrator auto, target {target:e}: chose {}",
                c.summary()
            );
            (c, AutoOrigin::Pilot)
        }
    };
    sweep.apply_auto(choice);
    *grid = Grid::new(sweep)?;
    Ok(origin)
}

/// Caches the choice of `integrator: auto` in the (locked) work directory.
fn cache_auto(work: &WorkDir, sweep: &Sweep) -> Result<()> {
    if let Some(c) = &sweep.auto_choice {
        work.write_auto_choice(c)?;
    }
    Ok(())
}

fn parse_shard(s: Option<&str>) -> Result<Option<(usize, usize)>> {
    let Some(s) = s else { return Ok(None) };
    let bad = || {
        Error::input(
            "--shard",
            format!("must be K/N with 1 <= K <= N, got `{s}`"),
        )
    };
    let (k, n) = s.split_once('/').ok_or_else(bad)?;
    let k: usize = k.trim().parse().map_err(|_| bad())?;
    let n: usize = n.trim().parse().map_err(|_| bad())?;
    if k == 0 || n == 0 || k > n {
        return Err(bad());
    }
    Ok(Some((k, n)))
}

fn default_output(file: &Path, shard: Option<(usize, usize)>) -> PathBuf {
    let stem = file
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "sweep".into());
    match shard {
        None => PathBuf::from(format!("{stem}.h5")),
        Some((k, n)) => PathBuf::from(format!("{stem}.shard-{k}-of-{n}.h5")),
    }
}

fn cmd_validate(file: &Path) -> Result<i32> {
    let (sweep, grid) = load(file)?;
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
        let pilots = auto::pilot_points(&sweep, &grid, spec.pilot_points)?;
        println!(
            "  integrator auto, target relative error {:e}: chosen when the sweep runs, by a pilot on grid points {pilots:?} (DOP853 or ROS34PW2, the cheapest setting reaching {:e} there)",
            spec.target_rel_error,
            spec.target_rel_error / auto::SAFETY_FACTOR
        );
    }
    Ok(EXIT_OK)
}

fn shape_text(shape: &[usize]) -> String {
    shape
        .iter()
        .map(|x| x.to_string())
        .collect::<Vec<_>>()
        .join(" × ")
}

/// Current time as ISO 8601 UTC (`2026-01-31T23:59:59Z`).
pub fn utc_now() -> String {
    let secs = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map(|d| d.as_secs())
        .unwrap_or(0) as i64;
    let days = secs.div_euclid(86400);
    let rem = secs.rem_euclid(86400);
    // Civil date from days since 1970-01-01 (H. Hinnant's algorithm).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36524 - doe / 146_096) / 365;
    let y = yoe + era * 400;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = if m <= 2 { y + 1 } else { y };
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}Z",
        rem / 3600,
        (rem / 60) % 60,
        rem % 60
    )
}

fn command_line() -> String {
    std::env::args()
        .map(|a| {
            if a.is_empty() || a.contains(|c: char| c.is_whitespace() || c == '\'' || c == '"') {
                format!("'{}'", a.replace('\'', "'\\''"))
            } else {
                a
            }
        })
        .collect::<Vec<_>>()
        .join(" ")
}

fn provenance() -> Provenance {
    Provenance {
        created_utc: utc_now(),
        command_line: command_line(),
    }
}

/// Checks that the output can be written without clobbering a file chainsweep did not make.
fn check_output(output: &Path, overwrite: bool) -> Result<()> {
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
    if output.is_dir() {
        return Err(Error::input(
            "--output",
            format!("{} is a directory", output.display()),
        ));
    }
    if output.exists() && !work_dir_of(output).is_dir() && !overwrite {
        return Err(Error::input(
            "--output",
            format!(
                "{} exists but has no work directory {} (it was not made by `chainsweep run` or `merge`); pass --overwrite to replace it",
                output.display(),
                work_dir_of(output).display()
            ),
        ));
    }
    Ok(())
}

/// Where the verification outcome of each point comes from when a file is assembled.
struct VerifySource {
    /// The `--verify` fraction (recorded as an attribute).
    fraction: f64,
    /// Verification hash of each grid point (computed for the points of this shard).
    hashes: HashMap<usize, RunHash>,
    /// Verification segments known to exist (ok or failed), by hash.
    done: HashMap<RunHash, bool>,
    /// Outcomes taken as they are (from merged shard files), by point.
    given: HashMap<usize, VerifyInfo>,
}

impl VerifySource {
    fn empty(fraction: f64) -> Self {
        VerifySource {
            fraction,
            hashes: HashMap::new(),
            done: HashMap::new(),
            given: HashMap::new(),
        }
    }

    fn info(&self, work: &WorkDir, grid: &Grid, i: usize, rec: &RunRecord) -> Result<VerifyInfo> {
        let np = grid.probes.len();
        if let Some(v) = self.given.get(&i) {
            return Ok(v.clone());
        }
        let Some(h) = self.hashes.get(&i) else {
            return Ok(VerifyInfo::none(np));
        };
        if !self.done.contains_key(h) {
            return Ok(VerifyInfo::none(np));
        }
        let tight = work.read_segment(h)?;
        Ok(verify::compare(rec, tight.as_ref(), np))
    }
}

/// Assembles the output file from the segments of the finished runs in `done`.
#[allow(clippy::too_many_arguments)]
fn assemble(
    work: &WorkDir,
    sweep: &Sweep,
    grid: &Grid,
    points: &[usize],
    shard: Option<(usize, usize)>,
    done: &HashMap<RunHash, bool>,
    prov: &Provenance,
    vsrc: &VerifySource,
) -> Result<Counts> {
    let tmp = work.tmp_path("assemble.h5");
    let counts = hdf5file::write_file(
        &tmp,
        sweep,
        grid,
        points,
        shard,
        prov,
        vsrc.fraction,
        |i| {
            let h = grid.hashes[i];
            if done.contains_key(&h) {
                work.read_segment(&h)
            } else {
                Ok(None)
            }
        },
        |i, rec| vsrc.info(work, grid, i, rec),
    );
    let counts = match counts {
        Ok(c) => c,
        Err(e) => {
            let _ = std::fs::remove_file(&tmp);
            return Err(e);
        }
    };
    work.publish(&tmp)?;
    Ok(counts)
}

struct Finished {
    hash: RunHash,
    ok: bool,
    verification: bool,
    write: Result<()>,
}

/// One unit of work of `run`: a grid point's run or its verification run.
#[derive(Debug, Clone, Copy)]
enum Task {
    Run(usize),
    Verify(usize),
}

fn print_failures(
    sweep: &Sweep,
    grid: &Grid,
    points: &[usize],
    work_dir: &Path,
    failed: &HashMap<RunHash, bool>,
) {
    let mut shown = 0;
    let total = points
        .iter()
        .filter(|&&i| failed.get(&grid.hashes[i]) == Some(&false))
        .count();
    if total == 0 {
        return;
    }
    eprintln!("chainsweep: {total} failed run(s):");
    for &i in points {
        let h = grid.hashes[i];
        if failed.get(&h) != Some(&false) {
            continue;
        }
        if shown == 20 {
            eprintln!(
                "  … and {} more (see the `status` and `reason` datasets)",
                total - shown
            );
            break;
        }
        let reason = read_segment_in(work_dir, &h)
            .ok()
            .flatten()
            .map(|r| r.reason)
            .unwrap_or_else(|| "(reason unreadable)".into());
        eprintln!("  point {i} ({}): {reason}", grid.point_label(sweep, i));
        shown += 1;
    }
}

/// Prints the failed verification runs and, unless quiet, the largest verified errors.
fn print_verification(
    sweep: &Sweep,
    grid: &Grid,
    points: &[usize],
    work: &WorkDir,
    vsrc: &VerifySource,
    chosen: &[bool],
    quiet: bool,
) -> Result<()> {
    let mut n_ok = 0usize;
    let mut worst: Option<(f64, usize)> = None;
    let mut failed = Vec::new();
    for &i in points {
        let Some(h) = vsrc.hashes.get(&i) else {
            continue;
        };
        match vsrc.done.get(h) {
            Some(false) => failed.push(i),
            Some(true) => {
                let Some(rec) = work.read_segment(&grid.hashes[i])? else {
                    continue;
                };
                let info = vsrc.info(work, grid, i, &rec)?;
                if info.status == crate::record::VERIFY_OK {
                    n_ok += 1;
                    let e = info.max_error();
                    if !e.is_nan() && worst.map_or(true, |(w, _)| e > w) {
                        worst = Some((e, i));
                    }
                }
            }
            None => {}
        }
    }
    if !failed.is_empty() {
        eprintln!(
            "chainsweep: {} verification run(s) failed (`verified` = 2):",
            failed.len()
        );
        for &i in failed.iter().take(20) {
            let reason = work
                .read_segment(&vsrc.hashes[&i])?
                .map(|r| r.reason)
                .unwrap_or_default();
            eprintln!("  point {i} ({}): {reason}", grid.point_label(sweep, i));
        }
    }
    let requested = points.iter().filter(|&&i| chosen[i]).count();
    if !quiet && (requested > 0 || n_ok > 0) {
        match worst {
            Some((e, i)) => eprintln!(
                "chainsweep: {n_ok} point(s) verified at a tighter setting; largest relative error {e:.2e} at point {i} ({})",
                grid.point_label(sweep, i)
            ),
            None => eprintln!("chainsweep: {n_ok} point(s) verified at a tighter setting"),
        }
    }
    Ok(())
}

fn estimate_bytes(grid: &Grid) -> (f64, f64) {
    let np = grid.probes.len() as f64;
    // Summaries: 8 f64, 4 i64, 2 flag bytes, 7 f64 per probe, hash, reason and warning strings.
    let summary = 8.0 * 8.0 + 4.0 * 8.0 + 2.0 + np * 7.0 * 8.0 + 64.0 + 16.0 + 48.0;
    let mut per_run_history = 0.0;
    if grid.history || grid.min_overlap {
        per_run_history += 2500.0; // group, attributes
    }
    if grid.history {
        let s = grid.max_history_samples as f64;
        per_run_history += (np + 1.0) * (s * 8.0 + 1200.0);
    }
    if grid.min_overlap {
        per_run_history += grid.max_contacts as f64 * 8.0 + 600.0;
    }
    (summary, per_run_history)
}

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

fn dry_run(
    sweep: &Sweep,
    grid: &Grid,
    points: &[usize],
    output: &Path,
    shard: Option<(usize, usize)>,
) -> Result<i32> {
    println!(
        "grid: {} points (shape {}){}",
        grid.len(),
        shape_text(&grid.shape),
        match shard {
            Some((k, n)) => format!(", shard {k}/{n}: {} points", points.len()),
            None => String::new(),
        }
    );
    for (d, dim) in sweep.dims.iter().enumerate() {
        for a in &dim.axes {
            let vals: Vec<String> = a.values.iter().map(|v| v.to_string()).collect();
            println!(
                "  dim {d} `{}`: {} = [{}] ({})",
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
    let done = scan_segments(&work_dir_of(output))?;
    let n_ok = points
        .iter()
        .filter(|&&i| done.get(&grid.hashes[i]) == Some(&true))
        .count();
    let n_failed = points
        .iter()
        .filter(|&&i| done.get(&grid.hashes[i]) == Some(&false))
        .count();
    println!(
        "output: {} — {} done, {} failed, {} to run",
        output.display(),
        n_ok,
        n_failed,
        points.len() - n_ok - n_failed
    );
    let (summary, history) = estimate_bytes(grid);
    let n = points.len() as f64;
    println!(
        "estimated output size: {} ({} per run: {} summaries{}); histories are deflate-compressed, so usually less",
        human(n * (summary + history) + 16384.0),
        human(summary + history),
        human(summary),
        if history > 0.0 { format!(" + {} histories, uncompressed", human(history)) } else { String::new() }
    );
    println!("points (flat index, axis values, run hash):");
    let show = |i: usize| {
        let h = grid.hashes[i];
        let state = match done.get(&h) {
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
    Ok(EXIT_OK)
}

/// Asks every `run` in this process to stop cleanly: points not started yet are skipped, runs in
/// flight finish and are stored, and the output is assembled with the rest pending (exit 3), so
/// that the same command resumes it. For programs that embed the runner (the Python package's
/// Ctrl-C); the command line itself is stopped by its signal. The embedder clears it afterwards.
pub static STOP_REQUESTED: AtomicBool = AtomicBool::new(false);

fn cmd_run(args: &RunArgs) -> Result<i32> {
    let (mut sweep, mut grid) = load(&args.file)?;
    let shard = parse_shard(args.shard.as_deref())?;
    if args.jobs == Some(0) {
        return Err(Error::input("--jobs", "must be at least 1"));
    }
    if !(args.progress_interval.is_finite() && args.progress_interval > 0.0) {
        return Err(Error::input(
            "--progress-interval",
            "must be a number of seconds > 0",
        ));
    }
    if !(args.checkpoint_interval.is_finite() && args.checkpoint_interval >= 0.0) {
        return Err(Error::input(
            "--checkpoint-interval",
            "must be a number of seconds >= 0",
        ));
    }
    let fraction = args.verify.unwrap_or(0.0);
    if !(0.0..=1.0).contains(&fraction) {
        return Err(Error::input(
            "--verify",
            format!("must be a fraction in [0, 1], got {fraction}"),
        ));
    }
    let output = args
        .output
        .clone()
        .unwrap_or_else(|| default_output(&args.file, shard));
    if !args.dry_run {
        check_output(&output, args.overwrite)?;
    }
    let jobs = args.jobs.unwrap_or_else(all_cpus);
    let pool = thread_pool(jobs)?;
    exec::install_panic_hook();
    // `integrator: auto`: the cached choice, or a pilot (before the work directory is created,
    // so that a target no setting meets leaves nothing behind).
    let auto_origin = resolve_auto(
        &mut sweep,
        &mut grid,
        Some(&work_dir_of(&output)),
        &pool,
        args.quiet,
    )?;
    let points = grid.shard_points(shard);
    if args.dry_run {
        return dry_run(&sweep, &grid, &points, &output, shard);
    }

    let work = WorkDir::open(&output)?;
    if auto_origin == AutoOrigin::Pilot {
        cache_auto(&work, &sweep)?;
    }

    // What is done already: every segment of this shard's points, verified whole.
    let mut done: HashMap<RunHash, bool> = HashMap::new();
    let mut points_of: HashMap<RunHash, usize> = HashMap::new();
    let mut pending: Vec<usize> = Vec::new();
    for &i in &points {
        let h = grid.hashes[i];
        let seen = points_of.contains_key(&h);
        *points_of.entry(h).or_insert(0) += 1;
        if seen {
            continue;
        }
        match work.read_segment(&h)? {
            Some(rec) if rec.ok || !args.retry_failed => {
                done.insert(h, rec.ok);
            }
            _ => pending.push(i),
        }
    }
    // Verification: the hash of every point's verification run, those already done, and the
    // sampled points of this shard still to verify.
    let mut vsrc = VerifySource::empty(fraction);
    let seg_index = scan_segments(&work.dir)?;
    let chosen = verify::sample(&grid, fraction);
    let mut vpending: Vec<usize> = Vec::new();
    let mut vseen: std::collections::HashSet<RunHash> = std::collections::HashSet::new();
    let mut v_total = 0usize;
    let mut v_done = 0usize;
    let mut v_failed = 0usize;
    for &i in &points {
        let (_, vh) = verify::point_verification(&sweep, &grid, i);
        vsrc.hashes.insert(i, vh);
        let state = seg_index.get(&vh).copied();
        if let Some(ok) = state {
            vsrc.done.insert(vh, ok);
        }
        if !chosen[i] {
            continue;
        }
        v_total += 1;
        match state {
            Some(ok) if ok || !args.retry_failed => {
                v_done += 1;
                v_failed += (!ok) as usize;
            }
            _ => {
                if vseen.insert(vh) {
                    vpending.push(i);
                } else {
                    v_total -= 1;
                }
            }
        }
    }
    let tasks: Vec<Task> = pending
        .iter()
        .map(|&i| Task::Run(i))
        .chain(vpending.iter().map(|&i| Task::Verify(i)))
        .collect();
    let done_points = points
        .iter()
        .filter(|&&i| done.contains_key(&grid.hashes[i]))
        .count();
    let failed_points = points
        .iter()
        .filter(|&&i| done.get(&grid.hashes[i]) == Some(&false))
        .count();
    let mut progress = Progress::new(
        points.len() + v_total,
        done_points + v_done,
        failed_points + v_failed,
        args.quiet,
        Duration::from_secs_f64(args.progress_interval),
    );
    if !args.quiet && done_points > 0 {
        progress.println(&format!(
            "chainsweep: resuming {}: {done_points} of {} runs already done",
            output.display(),
            points.len()
        ));
    }

    let prov = provenance();
    let stop = AtomicBool::new(false);
    let mut write_error: Option<Error> = None;
    let checkpoint = Duration::from_secs_f64(args.checkpoint_interval);
    let mut last_checkpoint = Instant::now();
    let mut vfinished_all: Vec<(RunHash, bool)> = Vec::new();
    std::thread::scope(|s| -> Result<()> {
        let (tx, rx) = mpsc::channel::<Finished>();
        let sweep_r = &sweep;
        let grid_r = &grid;
        let work_r = &work;
        let stop_r = &stop;
        let tasks_r = &tasks;
        let pool_r = &pool;
        let vsrc_r = &vsrc;
        s.spawn(move || {
            pool_r.install(|| {
                tasks_r.par_iter().for_each_with(tx, |tx, &task| {
                    if stop_r.load(Ordering::Relaxed) || STOP_REQUESTED.load(Ordering::Relaxed) {
                        return;
                    }
                    let (rec, verification) = match task {
                        Task::Run(i) => {
                            let hash = grid_r.hashes[i];
                            let scene =
                                grid_r.build(sweep_r, i).expect("every point was validated");
                            (exec::execute(&scene, hash, &sweep_r.limits, i), false)
                        }
                        Task::Verify(i) => {
                            let (tight, vh) = verify::point_verification(sweep_r, grid_r, i);
                            debug_assert_eq!(Some(&vh), vsrc_r.hashes.get(&i));
                            (
                                exec::execute_verification(&tight, vh, &sweep_r.limits),
                                true,
                            )
                        }
                    };
                    let write = work_r.write_segment(&rec);
                    if write.is_err() {
                        stop_r.store(true, Ordering::Relaxed);
                    }
                    let _ = tx.send(Finished {
                        hash: rec.hash,
                        ok: rec.ok,
                        verification,
                        write,
                    });
                });
            });
        });
        let mut vfinished: Vec<(RunHash, bool)> = Vec::new();
        loop {
            match rx.recv_timeout(Duration::from_millis(250)) {
                Ok(f) => {
                    if let Err(e) = f.write {
                        write_error.get_or_insert(e);
                        continue;
                    }
                    if f.verification {
                        vfinished.push((f.hash, f.ok));
                        progress.finish_run(!f.ok);
                    } else {
                        done.insert(f.hash, f.ok);
                        for _ in 0..points_of[&f.hash] {
                            progress.finish_run(!f.ok);
                        }
                    }
                }
                Err(mpsc::RecvTimeoutError::Timeout) => progress.tick(),
                Err(mpsc::RecvTimeoutError::Disconnected) => break,
            }
            if !checkpoint.is_zero()
                && last_checkpoint.elapsed() >= checkpoint
                && write_error.is_none()
            {
                let mut v = VerifySource::empty(vsrc_r.fraction);
                v.hashes.clone_from(&vsrc_r.hashes);
                v.done.clone_from(&vsrc_r.done);
                v.done.extend(vfinished.iter().copied());
                assemble(&work, &sweep, &grid, &points, shard, &done, &prov, &v)?;
                last_checkpoint = Instant::now();
            }
        }
        vfinished_all = vfinished;
        Ok(())
    })?;
    progress.finish();
    if let Some(e) = write_error {
        return Err(e);
    }
    vsrc.done.extend(vfinished_all.iter().copied());
    let counts = assemble(&work, &sweep, &grid, &points, shard, &done, &prov, &vsrc)?;
    print_failures(&sweep, &grid, &points, &work.dir, &done);
    print_verification(&sweep, &grid, &points, &work, &vsrc, &chosen, args.quiet)?;
    if !args.quiet {
        eprintln!(
            "chainsweep: {} runs: {} ok, {} failed, {} pending → {}",
            points.len(),
            counts.ok,
            counts.failed,
            counts.pending,
            output.display()
        );
    }
    Ok(exit_for(&counts))
}

fn exit_for(c: &Counts) -> i32 {
    if c.failed > 0 || c.pending > 0 {
        EXIT_PARTIAL
    } else {
        EXIT_OK
    }
}

fn is_hdf5(path: &Path) -> bool {
    use std::io::Read;
    let mut magic = [0u8; 8];
    std::fs::File::open(path)
        .and_then(|mut f| f.read_exact(&mut magic))
        .map(|_| &magic == b"\x89HDF\r\n\x1a\n")
        .unwrap_or(false)
}

fn cmd_status(file: &Path, output: Option<PathBuf>, shard: Option<&str>) -> Result<i32> {
    if is_hdf5(file) {
        let recs = FileRecords::open(file).map_err(|e| Error::Input {
            file: Some(path_str(file)),
            field: String::new(),
            message: format!("not a chainsweep output file: {e}"),
        })?;
        let sweep = Sweep::parse(&recs.sweep_text).map_err(|e| e.in_file(&path_str(file)))?;
        let f = hdf5::File::open(file)?;
        let status: Vec<u8> = f.dataset("status")?.read_raw()?;
        let reason: Vec<hdf5::types::VarLenUnicode> = f.dataset("reason")?.read_raw()?;
        let shard_attr: hdf5::types::VarLenUnicode = f.attr("shard")?.read_scalar()?;
        let shard = parse_shard(Some(shard_attr.as_str()))?.filter(|&(_, n)| n > 1);
        let shape: Vec<usize> = sweep.shape();
        let n = status.len();
        let in_shard = |i: usize| match shard {
            None => true,
            Some((k, m)) => i % m == k - 1,
        };
        let total = (0..n).filter(|&i| in_shard(i)).count();
        let ok = status.iter().filter(|&&s| s == STATUS_OK).count();
        let failed = status.iter().filter(|&&s| s == STATUS_FAILED).count();
        let pending = (0..n)
            .filter(|&i| in_shard(i) && status[i] == STATUS_PENDING)
            .count();
        println!(
            "{}: {} runs (grid {}, shard {}): {} done ({} ok, {} failed), {} pending",
            file.display(),
            total,
            shape_text(&shape),
            shard_attr.as_str(),
            ok + failed,
            ok,
            failed,
            pending
        );
        // Runs finished since the file was last assembled (it is refreshed by `run`).
        let segs: std::collections::HashSet<String> =
            scan_segments(&work_dir_of(file))?.keys().map(hex).collect();
        let newer = (0..n)
            .filter(|&i| in_shard(i) && status[i] == STATUS_PENDING)
            .filter(|&i| segs.contains(recs.hash_hex(i)))
            .count();
        if newer > 0 {
            println!(
                "  {newer} more runs have finished since the file was written (a sweep is running, or was interrupted): re-run the same `chainsweep run` command to bring the file up to date"
            );
        }
        for (shown, i) in (0..n).filter(|&i| status[i] == STATUS_FAILED).enumerate() {
            if shown == 20 {
                println!("  …");
                break;
            }
            let mi: Vec<String> = multi_index(&shape, i)
                .iter()
                .map(|x| x.to_string())
                .collect();
            println!(
                "  failed: point {i} [{}]: {}",
                mi.join(", "),
                reason[i].as_str()
            );
        }
        return Ok(exit_for(&Counts {
            ok,
            failed,
            pending,
        }));
    }
    let (mut sweep, mut grid) = load(file)?;
    let shard = parse_shard(shard)?;
    let output = output.unwrap_or_else(|| default_output(file, shard));
    let points = grid.shard_points(shard);
    if let Some(spec) = sweep.auto {
        let dir = work_dir_of(&output);
        match auto::read_cache(&dir, &auto::cache_key(&grid, &spec)) {
            Some(c) => {
                println!(
                    "integrator auto, target {:e}: {}",
                    spec.target_rel_error,
                    describe(&c.integrator)
                );
                sweep.apply_auto(c);
                grid = Grid::new(&sweep)?;
            }
            None => {
                println!(
                    "{} → {}: {} runs: 0 done, {} pending (integrator auto not chosen yet: {} holds no choice for this sweep)",
                    file.display(),
                    output.display(),
                    points.len(),
                    points.len(),
                    dir.join(AUTO_CHOICE_FILE).display()
                );
                return Ok(EXIT_PARTIAL);
            }
        }
    }
    let segs = scan_segments(&work_dir_of(&output))?;
    let ok = points
        .iter()
        .filter(|&&i| segs.get(&grid.hashes[i]) == Some(&true))
        .count();
    let failed = points
        .iter()
        .filter(|&&i| segs.get(&grid.hashes[i]) == Some(&false))
        .count();
    let pending = points.len() - ok - failed;
    println!(
        "{} → {}: {} runs: {} done ({} ok, {} failed), {} pending",
        file.display(),
        output.display(),
        points.len(),
        ok + failed,
        ok,
        failed,
        pending
    );
    for &i in points
        .iter()
        .filter(|&&i| segs.get(&grid.hashes[i]) == Some(&false))
        .take(20)
    {
        let reason = read_segment_in(&work_dir_of(&output), &grid.hashes[i])?
            .map(|r| r.reason)
            .unwrap_or_default();
        println!(
            "  failed: point {i} ({}): {reason}",
            grid.point_label(&sweep, i)
        );
    }
    Ok(exit_for(&Counts {
        ok,
        failed,
        pending,
    }))
}

fn cmd_merge(output: &Path, shards: &[PathBuf]) -> Result<i32> {
    let mut text: Option<String> = None;
    for s in shards {
        let bad = |m: String| Error::Input {
            file: Some(path_str(s)),
            field: String::new(),
            message: m,
        };
        if !is_hdf5(s) {
            return Err(bad("not an HDF5 file".into()));
        }
        let t = hdf5file::read_sweep_text(s)
            .map_err(|e| bad(format!("not a chainsweep output file: {e}")))?;
        match &text {
            None => text = Some(t),
            Some(first) if *first != t => {
                return Err(bad(format!(
                    "was made from a different sweep file than {}; shards must come from the same sweep",
                    shards[0].display()
                )))
            }
            _ => {}
        }
    }
    let text = text.expect("at least one shard");
    let mut sweep = Sweep::parse(&text).map_err(|e| e.in_file(&path_str(&shards[0])))?;
    let mut grid = Grid::new(&sweep).map_err(|e| e.in_file(&path_str(&shards[0])))?;
    if let Some(spec) = sweep.auto {
        // Every shard resolved `auto` alike (the choice is deterministic): take it from them.
        let key = auto::cache_key(&grid, &spec);
        let mut choice: Option<AutoChoice> = None;
        for s in shards {
            let c = hdf5file::read_auto_choice(s)?.ok_or_else(|| {
                Error::Other(format!(
                    "{}: the sweep's integrator is `auto` but the file records no choice (`auto` attribute)",
                    s.display()
                ))
            })?;
            if c.key != key {
                return Err(Error::Other(format!(
                    "{}: its `auto` choice was made for another grid or engine version (key {}, this chainsweep computes {key})",
                    s.display(),
                    c.key
                )));
            }
            match &choice {
                None => choice = Some(c),
                Some(first) if *first != c => {
                    return Err(Error::Other(format!(
                        "{}: its `auto` choice ({}) differs from that of {} ({})",
                        s.display(),
                        describe(&c.integrator),
                        shards[0].display(),
                        describe(&first.integrator)
                    )))
                }
                _ => {}
            }
        }
        sweep.apply_auto(choice.expect("at least one shard"));
        grid = Grid::new(&sweep)?;
    }
    check_output(output, false)?;
    if shards
        .iter()
        .any(|s| s.canonicalize().ok() == output.canonicalize().ok() && output.exists())
    {
        return Err(Error::input(
            "--output",
            "must not be one of the shard files",
        ));
    }
    let work = WorkDir::open(output)?;
    cache_auto(&work, &sweep)?;
    let mut done: HashMap<RunHash, bool> = HashMap::new();
    let mut vsrc = VerifySource::empty(0.0);
    for s in shards {
        let recs = FileRecords::open(s)?;
        vsrc.fraction = vsrc.fraction.max(recs.verify_fraction);
        if recs.len() != grid.len() {
            return Err(Error::Other(format!(
                "{}: holds {} grid points, the sweep has {}",
                s.display(),
                recs.len(),
                grid.len()
            )));
        }
        for i in 0..grid.len() {
            let h = grid.hashes[i];
            if done.contains_key(&h) {
                continue;
            }
            if recs.hash_hex(i) != hex(&h) {
                return Err(Error::Other(format!(
                    "{}: point {i} has run hash {}, this chainsweep computes {}: the shard was made by a different engine version",
                    s.display(),
                    recs.hash_hex(i),
                    hex(&h)
                )));
            }
            if let Some(rec) = recs.record(i, h, &grid)? {
                if work.read_segment(&h)?.is_none() {
                    work.write_segment(&rec)?;
                }
                done.insert(h, rec.ok);
                vsrc.given.insert(i, recs.verify_info(i, grid.probes.len()));
            }
        }
    }
    // Runs already in the output's work directory count too.
    for &h in &grid.hashes {
        if let std::collections::hash_map::Entry::Vacant(slot) = done.entry(h) {
            if let Some(rec) = work.read_segment(&h)? {
                slot.insert(rec.ok);
            }
        }
    }
    let points: Vec<usize> = (0..grid.len()).collect();
    // Points whose run was already in the output's work directory: their verification runs too.
    let seg_index = scan_segments(&work.dir)?;
    for &i in &points {
        if vsrc.given.contains_key(&i) {
            continue;
        }
        let (_, vh) = verify::point_verification(&sweep, &grid, i);
        if let Some(&ok) = seg_index.get(&vh) {
            vsrc.done.insert(vh, ok);
        }
        vsrc.hashes.insert(i, vh);
    }
    let counts = assemble(
        &work,
        &sweep,
        &grid,
        &points,
        None,
        &done,
        &provenance(),
        &vsrc,
    )?;
    eprintln!(
        "chainsweep: merged {} shard file(s): {} runs: {} ok, {} failed, {} pending → {}",
        shards.len(),
        grid.len(),
        counts.ok,
        counts.failed,
        counts.pending,
        output.display()
    );
    Ok(exit_for(&counts))
}

fn cmd_point(file: &Path, index: usize, scene_only: bool, output: Option<&Path>) -> Result<i32> {
    let (mut sweep, mut grid) = load(file)?;
    if index >= grid.len() {
        return Err(Error::input(
            "INDEX",
            format!(
                "must lie in 0..{} (the grid's points), got {index}",
                grid.len()
            ),
        ));
    }
    exec::install_panic_hook();
    let work_dir = output.map(work_dir_of);
    resolve_auto(
        &mut sweep,
        &mut grid,
        work_dir.as_deref(),
        &thread_pool(all_cpus())?,
        false,
    )?;
    let scene = grid.build(&sweep, index)?;
    let hash = grid.hashes[index];
    let mut out = serde_json::json!({
        "index": index,
        "grid_index": multi_index(&grid.shape, index),
        "run_hash": hex(&hash),
        "scene": serde_json::to_value(&scene).expect("Scene serialises"),
    });
    if !scene_only {
        exec::install_panic_hook();
        let rec = exec::execute(&scene, hash, &sweep.limits, index);
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
    println!("{}", serde_json::to_string_pretty(&out).expect("json"));
    Ok(EXIT_OK)
}

fn cmd_accuracy(args: &AccuracyArgs) -> Result<i32> {
    use crate::numerics::accuracy;
    let (sweep, grid) = load(&args.file)?;
    if args.repeats == 0 {
        return Err(Error::input("--repeats", "must be at least 1"));
    }
    if !(args.max_run_seconds.is_finite() && args.max_run_seconds > 0.0) {
        return Err(Error::input(
            "--max-run-seconds",
            "must be a number of seconds > 0",
        ));
    }
    let (scene, what) = match args.point {
        Some(i) if i >= grid.len() => {
            return Err(Error::input(
                "--point",
                format!("must lie in 0..{} (the grid's points), got {i}", grid.len()),
            ))
        }
        Some(i) => (
            grid.build(&sweep, i)?,
            format!("grid point {i} ({})", grid.point_label(&sweep, i)),
        ),
        None => (
            crate::sweep::from_value_at::<chainsweep_solver::Scene>(sweep.base.clone(), "base")?,
            "base scene".to_string(),
        ),
    };
    let output = args.output.clone().unwrap_or_else(|| {
        let stem = args
            .file
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "sweep".into());
        PathBuf::from(format!("{stem}.accuracy.h5"))
    });
    let opts = accuracy::StudyOptions {
        repeats: args.repeats,
        max_run_s: args.max_run_seconds,
        methods: args.methods.clone(),
    };
    exec::install_panic_hook();
    let quiet = args.quiet;
    if !quiet {
        eprintln!("chainsweep accuracy: {} of {}", what, args.file.display());
    }
    let st = accuracy::study(&scene, &opts, |l| {
        if !quiet {
            eprintln!("  {l}");
        }
    })?;
    let probe_names: Vec<String> = scene.record.probes.iter().map(|p| p.name()).collect();
    let source = format!("{} {}", path_str(&args.file), what);
    let tmp = output.with_extension("h5.tmp");
    accuracy::write_study(&tmp, &st, &probe_names, &source)?;
    crate::error::io_ctx(std::fs::rename(&tmp, &output), || {
        format!("cannot rename {} to {}", tmp.display(), output.display())
    })?;
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
        let cell = |target: f64| match accuracy::cost_of(m, reference, target) {
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
    Ok(EXIT_OK)
}
