//! The `chainsweep` command line: parses the arguments, calls the [`crate::engine`], prints.
//! `validate`, `run`, `status`, `point`, `accuracy`, `merge`.

mod show;

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::time::Duration;

use clap::{Args, Parser, Subcommand};

use crate::engine::{self, inspect, merge, run, shard, status};
use crate::error::{Error, Result};
use crate::grid::Shard;
use crate::numerics::accuracy::StudyOptions;
use crate::progress::Terminal;
use crate::store::hdf5::{is_hdf5, Counts, Provenance};
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
    // A pinned code path this CPU cannot run (or a misspelt one) is bad input, refused before any
    // work, never an illegal instruction or a panic inside a run.
    if let Err(e) = chainsweep_solver::cpu::level_from_env() {
        eprintln!("chainsweep: error: {e}");
        return crate::EXIT_BAD_INPUT;
    }
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

/// The exit code of a sweep whose points are in the state `c`.
fn exit_for(c: &Counts) -> i32 {
    if c.failed > 0 || c.pending > 0 {
        EXIT_PARTIAL
    } else {
        EXIT_OK
    }
}

fn parse_shard(s: Option<&str>) -> Result<Option<Shard>> {
    s.map(|s| Shard::parse(s, "--shard")).transpose()
}

fn cmd_validate(file: &Path) -> Result<i32> {
    let (sweep, grid) = engine::load(file)?;
    show::validated(file, &sweep, &grid)?;
    Ok(EXIT_OK)
}

fn cmd_run(args: &RunArgs) -> Result<i32> {
    let (mut sweep, mut grid) = engine::load(&args.file)?;
    let shard = parse_shard(args.shard.as_deref())?;
    let fraction = args.verify.unwrap_or(0.0);
    let jobs = args.jobs.unwrap_or_else(engine::all_cpus);
    run::RunOptions::check(jobs, args.checkpoint_interval, fraction)?;
    if !(args.progress_interval.is_finite() && args.progress_interval > 0.0) {
        return Err(Error::input(
            "--progress-interval",
            "must be a number of seconds > 0",
        ));
    }
    let output = args
        .output
        .clone()
        .unwrap_or_else(|| engine::default_output(&args.file, shard));
    let mut sink = Terminal::new(args.quiet, Duration::from_secs_f64(args.progress_interval));
    if args.dry_run {
        let pool = engine::thread_pool(jobs)?;
        let work_dir = crate::store::work_dir_of(&output);
        engine::auto::resolve(&mut sweep, &mut grid, Some(&work_dir), &pool, &mut sink)?;
        let points = shard::points(grid.len(), shard);
        let d = inspect::dry_run(&grid, &points, &output)?;
        show::dry_run(&sweep, &grid, &points, &output, shard, &d);
        return Ok(EXIT_OK);
    }
    let opts = run::RunOptions {
        output,
        jobs,
        shard,
        retry_failed: args.retry_failed,
        checkpoint_interval: Duration::from_secs_f64(args.checkpoint_interval),
        verify_fraction: fraction,
        overwrite: args.overwrite,
        provenance: Provenance::of_this_process(),
    };
    let stop = AtomicBool::new(false);
    let report = run::run_sweep(&mut sweep, &mut grid, &opts, &mut sink, &stop)?;
    show::run_report(&sweep, &grid, &report, &opts.output, args.quiet);
    Ok(exit_for(&report.counts))
}

fn cmd_status(file: &Path, output: Option<PathBuf>, shard: Option<&str>) -> Result<i32> {
    if is_hdf5(file) {
        let s = status::of_file(file)?;
        show::file_status(file, &s);
        return Ok(exit_for(&s.counts));
    }
    let (sweep, grid) = engine::load(file)?;
    let shard = parse_shard(shard)?;
    let output = output.unwrap_or_else(|| engine::default_output(file, shard));
    let (s, sweep, grid) = status::of_sweep(sweep, grid, output, shard)?;
    show::sweep_status(file, &sweep, &grid, &s);
    Ok(s.counts.as_ref().map_or(EXIT_PARTIAL, exit_for))
}

fn cmd_merge(output: &Path, shards: &[PathBuf]) -> Result<i32> {
    let r = merge::merge(output, shards, &Provenance::of_this_process())?;
    show::merged(&r, output);
    Ok(exit_for(&r.counts))
}

fn cmd_point(file: &Path, index: usize, scene_only: bool, output: Option<&Path>) -> Result<i32> {
    let (mut sweep, mut grid) = engine::load(file)?;
    let mut sink = Terminal::new(false, Duration::from_secs(10));
    let p = inspect::point(&mut sweep, &mut grid, index, output, !scene_only, &mut sink)?;
    println!("{}", show::point(&grid, index, &p));
    Ok(EXIT_OK)
}

fn cmd_accuracy(args: &AccuracyArgs) -> Result<i32> {
    let (sweep, grid) = engine::load(&args.file)?;
    inspect::check_study_options(args.repeats, args.max_run_seconds)?;
    let (scene, what) = inspect::study_scene(&sweep, &grid, args.point)?;
    let output = args
        .output
        .clone()
        .unwrap_or_else(|| inspect::default_study_output(&args.file));
    let opts = StudyOptions {
        repeats: args.repeats,
        max_run_s: args.max_run_seconds,
        methods: args.methods.clone(),
    };
    let quiet = args.quiet;
    if !quiet {
        eprintln!("chainsweep accuracy: {} of {}", what, args.file.display());
    }
    let source = format!("{} {}", args.file.display(), what);
    let st = inspect::study(&scene, &opts, &output, &source, |l| {
        if !quiet {
            eprintln!("  {l}");
        }
    })?;
    show::study(&st, &output);
    Ok(EXIT_OK)
}
