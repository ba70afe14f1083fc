//! The `chainsweep` command line: parses the arguments, calls the [`chainsweep::engine`], prints.
//! `validate`, `run`, `status`, `point`, `accuracy`, `merge`, `slurm`.

mod examples;
mod json;
mod show;

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::Duration;

use clap::{Args, Parser, Subcommand};

use crate::progress::Terminal;
use chainsweep::engine::{self, inspect, merge, run, shard, slurm, status};
use chainsweep::error::{Error, Result};
use chainsweep::grid::Shard;
use chainsweep::numerics::accuracy::StudyOptions;
use chainsweep::store::hdf5::{is_hdf5, Counts, Provenance};
use chainsweep::{EXIT_OK, EXIT_PARTIAL};

const EXAMPLES: &str = "\
Examples:
  chainsweep examples copy mass-damping .   # an example sweep file, here (`chainsweep examples` lists them)
  chainsweep validate mass-damping.json
  chainsweep run mass-damping.json --dry-run
  chainsweep run mass-damping.json -o results/mass-damping.h5 --jobs 8
  chainsweep status results/mass-damping.h5
  # re-running the same command after an interruption continues where it stopped:
  chainsweep run mass-damping.json -o results/mass-damping.h5 --jobs 8
  # on a SLURM cluster: an array job of 16 shards and a merge job after it
  chainsweep slurm mass-damping.json -o results/mass-damping.h5 --shards 16 --time 2:00:00 --submit
  chainsweep status results/mass-damping.h5.slurm
  # by hand: one shard per machine (K from 1), then merge
  chainsweep run mass-damping.json --shard 3/16 -o shards/part-3.h5
  chainsweep merge -o results/mass-damping.h5 shards/part-*.h5

Exit codes: 0 all runs succeeded; 1 other error (I/O, output locked by another process);
2 bad input or usage (nothing run, nothing written); 3 partial (some runs failed or are missing);
130 / 143 `run` stopped by SIGINT (Ctrl-C) / SIGTERM: the output holds every finished run, and the
same command resumes (a second signal ends the process at once).";

/// `--version`: the release and the revision it was built from (as the result files record it).
const VERSION: &str = concat!(
    env!("CARGO_PKG_VERSION"),
    " (revision ",
    env!("CHAINSWEEP_GIT_REVISION"),
    ")"
);

/// Runs grids of chain simulations into HDF5, in parallel, resumably.
#[derive(Debug, Parser)]
#[command(name = "chainsweep", version = VERSION, about, after_help = EXAMPLES)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// What `chainsweep examples` does.
#[derive(Debug, Subcommand)]
pub enum ExamplesAction {
    /// Copy an example (with the data files it reads), or `all` of them, into a folder; an
    /// existing file is never overwritten.
    Copy {
        /// The example's name as `chainsweep examples` lists it (`mass-damping`,
        /// `examples/trimer` or `trimer`), or `all`.
        name: String,
        /// The folder (created if missing; default: the current one).
        dir: Option<PathBuf>,
    },
}

/// Subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// List the example sweep files shipped with chainsweep, or copy one (or all) into a folder.
    #[command(
        after_help = "Examples:\n  chainsweep examples\n  chainsweep examples copy mass-damping .     # mass-damping.json, here\n  chainsweep examples copy fit-signal fits   # the fit and the recordings it reads\n  chainsweep examples copy all my-examples"
    )]
    Examples {
        /// What to do (default: list them).
        #[command(subcommand)]
        action: Option<ExamplesAction>,
    },
    /// Check a sweep file (syntax, fields, types, physical ranges of every grid point); run nothing.
    #[command(after_help = "Example:\n  chainsweep validate mass-damping.json")]
    Validate {
        /// Sweep file (JSON).
        file: PathBuf,
        /// Print the result as one JSON object on stdout (valid or not, every error found).
        #[arg(long)]
        json: bool,
    },
    /// Print the JSON Schema of sweep files (for editors and validators; a sweep file may name it
    /// with `"$schema"`).
    #[command(
        after_help = "Examples:\n  chainsweep schema > chainsweep-sweep.schema.json\n  # then, in a sweep file: \"$schema\": \"./chainsweep-sweep.schema.json\""
    )]
    Schema,
    /// Print a shell completion script (bash, zsh, fish, elvish, powershell).
    #[command(
        after_help = "Examples:\n  chainsweep completions bash > ~/.local/share/bash-completion/completions/chainsweep\n  chainsweep completions zsh > ~/.zfunc/_chainsweep      # with fpath+=(~/.zfunc) in ~/.zshrc\n  chainsweep completions fish > ~/.config/fish/completions/chainsweep.fish"
    )]
    Completions {
        /// The shell.
        shell: clap_complete::Shell,
    },
    /// Write the manual pages (chainsweep.1 and one per command, chainsweep-run.1, …) into a
    /// folder.
    #[command(
        after_help = "Examples:\n  chainsweep man ~/.local/share/man/man1 && man chainsweep-run\n  chainsweep man /tmp/m && man -l /tmp/m/chainsweep.1"
    )]
    Man {
        /// The folder (created if missing); existing pages of the same names are replaced.
        dir: PathBuf,
    },
    /// Run a sweep (or continue an interrupted one) into an HDF5 file.
    #[command(
        after_help = "Examples:\n  chainsweep run mass-damping.json --dry-run\n  chainsweep run mass-damping.json -o out.h5 --jobs 4\n  chainsweep run mass-damping.json --shard 2/8 -o part-2.h5"
    )]
    Run(RunArgs),
    /// Say how many runs of a sweep are done, failed and pending; of a shard set, which shards
    /// are done, failed, pending or missing.
    #[command(
        after_help = "Examples:\n  chainsweep status results/mass-damping.h5\n  chainsweep status mass-damping.json -o results/mass-damping.h5\n  chainsweep status results/mass-damping.h5.slurm        # the shards of `chainsweep slurm`\n  chainsweep status shards/part-*.h5"
    )]
    Status {
        /// An output file (`.h5`), a sweep file (then the output is `-o` or its default), several
        /// shard files of one sweep, or a folder of shard files (`OUT.h5.slurm` of `chainsweep
        /// slurm`, or a folder of `.h5` shard files).
        #[arg(required = true, num_args = 1.., value_name = "FILE")]
        files: Vec<PathBuf>,
        /// Output file, when FILE is a sweep file.
        #[arg(short, long)]
        output: Option<PathBuf>,
        /// Shard `K/N` (or `slurm/N`), when FILE is a sweep file run with `--shard`.
        #[arg(long)]
        shard: Option<String>,
        /// Print the status as one JSON object on stdout.
        #[arg(long)]
        json: bool,
    },
    /// Write one self-contained HTML page of what an output file holds: every summary against
    /// the axes, failed points with their reasons, searches', fits' and ensembles' answers, run
    /// times and verified errors, and the sweep file for provenance. Opens offline.
    #[command(
        after_help = "Examples:\n  chainsweep report results/mass-damping.h5                 # results/mass-damping.html\n  chainsweep report results/mass-damping.h5 -o morning.html\n  chainsweep report results/mass-damping.h5 --watch         # refreshed while the sweep runs"
    )]
    Report {
        /// An output file (`.h5`).
        file: PathBuf,
        /// The page to write (default: FILE with `.html`).
        #[arg(short, long)]
        output: Option<PathBuf>,
        /// Write the page again every `--interval` seconds while a sweep writes into FILE (its
        /// lock names a live process), and once more when it has ended.
        #[arg(long)]
        watch: bool,
        /// Seconds between pages with `--watch`.
        #[arg(long, default_value_t = 10.0, value_name = "SECONDS")]
        interval: f64,
        /// Draw the histories of point N (its flat index, as `chainsweep point` takes it;
        /// repeatable). Default: the first point whose run is ok, when the sweep records
        /// histories.
        #[arg(long = "point", value_name = "N")]
        points: Vec<usize>,
        /// `html`: one page; `svg`: each figure alone as an SVG file in a folder (default: FILE
        /// without `.h5`, with `-figures`), with `captions.txt`, for a paper or a slide.
        #[arg(long, value_enum, default_value_t = ReportFormat::Html)]
        format: ReportFormat,
    },
    /// Write SLURM job scripts for a sweep: an array job of N shards and a merge job after it
    /// (whatever the array's outcome), in `OUT.h5.slurm/`; submit them with `--submit`.
    #[command(
        after_help = "Examples:\n  chainsweep slurm mass-damping.json -o results/mass-damping.h5 --shards 16 \\\n      --time 2:00:00 --cpus-per-task 8 --partition short --sbatch-arg=--mem=4G --submit\n  chainsweep status results/mass-damping.h5.slurm\n\nArray task T (SLURM_ARRAY_TASK_ID, from 0) runs shard T+1 of N (`run --shard slurm/N`) into\nOUT.h5.slurm/shards/; a task stopped by SIGTERM (time limit, scancel) keeps every finished run\nand resumes when submitted again. The merge names the missing shards and the command that\nre-submits only those tasks."
    )]
    Slurm(SlurmArgs),
    /// Run one grid point in this process and print its scene and results as JSON; writes nothing.
    #[command(after_help = "Example:\n  chainsweep point mass-damping.json 17")]
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
        after_help = "Examples:\n  chainsweep accuracy mass-damping.json -o results/work_precision_fig08.h5\n  chainsweep accuracy mass-damping.json --point 17 --methods dop853,ros34pw2\n  python scripts/plot_work_precision.py results/work_precision_fig08.h5"
    )]
    Accuracy(AccuracyArgs),
    /// Remove from an output's work directory the runs the sweep file no longer has (after
    /// editing its axes) and the damaged output files kept there; never a run the sweep needs.
    /// Lists every run and file it removes. The output file is left as it is. The only command
    /// that removes finished runs: try it with `--dry-run` first.
    #[command(
        after_help = "Examples:\n  chainsweep gc mass-damping.json -o results/mass-damping.h5 --dry-run\n  chainsweep gc mass-damping.json -o results/mass-damping.h5"
    )]
    Gc {
        /// Sweep file (JSON).
        file: PathBuf,
        /// Output file [default: the sweep file's name with `.h5` in the current directory].
        #[arg(short, long)]
        output: Option<PathBuf>,
        /// List what would be removed; remove nothing.
        #[arg(long)]
        dry_run: bool,
    },
    /// Assemble shard files into one file, identical to a single-machine run.
    #[command(
        after_help = "Example:\n  chainsweep merge -o results/sweep.h5 part-1.h5 part-2.h5 part-3.h5"
    )]
    Merge {
        /// Merged output file.
        #[arg(short, long)]
        output: PathBuf,
        /// Shard files made by `chainsweep run --shard K/N` from the same sweep file (files that
        /// do not exist are missing shards: the merge names them and is partial).
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
    /// Parallel runs, at most 4 per CPU [default: SLURM_CPUS_PER_TASK inside a SLURM job, else
    /// the CPUs this process may use (its CPU affinity)].
    #[arg(short, long)]
    pub jobs: Option<usize>,
    /// Run only shard K of N (K from 1; shards are balanced by estimated cost), into its own
    /// file; `slurm/N`: shard SLURM_ARRAY_TASK_ID + 1 of N (array tasks count from 0).
    #[arg(long, value_name = "K/N|slurm/N")]
    pub shard: Option<String>,
    /// Print the expanded grid and an estimate of the output size; run nothing.
    #[arg(long)]
    pub dry_run: bool,
    /// With `--dry-run`: print it as one JSON object on stdout.
    #[arg(long, requires = "dry_run")]
    pub json: bool,
    /// No progress display and no closing summary (failures are still listed).
    #[arg(short, long)]
    pub quiet: bool,
    /// Run again the points whose earlier run failed.
    #[arg(long)]
    pub retry_failed: bool,
    /// Seconds between plain progress lines when stderr is not a terminal.
    #[arg(long, default_value_t = run::DEFAULT_PROGRESS_INTERVAL_S, value_name = "SECONDS")]
    pub progress_interval: f64,
    /// Seconds between refreshes of the output file while the sweep runs (0: only at the end).
    #[arg(long, default_value_t = run::DEFAULT_CHECKPOINT_INTERVAL_S, value_name = "SECONDS")]
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

/// Arguments of `chainsweep slurm`.
#[derive(Debug, Args)]
pub struct SlurmArgs {
    /// Sweep file (JSON).
    pub file: PathBuf,
    /// The merged output file; the job files go to `OUT.h5.slurm/`.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Number of shards (array tasks).
    #[arg(long)]
    pub shards: usize,
    /// Time limit of each job (sbatch `--time`, e.g. `2:00:00`).
    #[arg(long)]
    pub time: Option<String>,
    /// Partition (sbatch `--partition`).
    #[arg(long)]
    pub partition: Option<String>,
    /// CPUs of each array task (sbatch `--cpus-per-task`): its parallel runs.
    #[arg(long)]
    pub cpus_per_task: Option<usize>,
    /// Account (sbatch `--account`).
    #[arg(long)]
    pub account: Option<String>,
    /// A further sbatch option for both jobs, as written (`--sbatch-arg=--mem=4G`); repeatable.
    #[arg(long, value_name = "OPTION", allow_hyphen_values = true)]
    pub sbatch_arg: Vec<String>,
    /// Submit the array job, then the merge job after it (`sbatch`, which must be on PATH).
    #[arg(long)]
    pub submit: bool,
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
    /// Skip fixed-step settings estimated to take longer than this per run, stop any run of a
    /// ladder that reaches it (recorded as failed), and end the ladder there. The reference run
    /// and its confirmation are bounded by the sweep file's `limits.max_run_seconds`.
    #[arg(long, default_value_t = 3.0, value_name = "SECONDS")]
    pub max_run_seconds: f64,
    /// Methods to study, comma separated: dop853, dop853-predict (DOP853 with
    /// `predict_switches`), vern6, ros34pw2, rk4, verlet.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "dop853,dop853-predict,vern6,ros34pw2,rk4,verlet"
    )]
    pub methods: Vec<String>,
    /// No progress lines.
    #[arg(short, long)]
    pub quiet: bool,
}

/// Parses the command line, runs the command, and returns the process exit code.
pub fn main() -> i32 {
    main_from(std::env::args_os())
}

/// [`main`] on the given arguments (the first is the program's name): the entry point of the
/// `chainsweep` command that the Python package installs.
pub fn main_from<I, T>(args: I) -> i32
where
    I: IntoIterator<Item = T>,
    T: Into<std::ffi::OsString> + Clone,
{
    chainsweep::set_git_revision(crate::GIT_REVISION);
    let cli = match Cli::try_parse_from(args) {
        Ok(c) => c,
        Err(e) => {
            let code = if e.use_stderr() {
                chainsweep::EXIT_BAD_INPUT
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
        return chainsweep::EXIT_BAD_INPUT;
    }
    match dispatch(cli) {
        Ok(code) => code,
        Err(e) => {
            errln!("chainsweep: error: {e}");
            e.exit_code()
        }
    }
}

/// Runs a parsed command.
pub fn dispatch(cli: Cli) -> Result<i32> {
    match cli.command {
        Command::Examples { action } => cmd_examples(action),
        Command::Validate { file, json } => cmd_validate(&file, json),
        Command::Schema => cmd_schema(),
        Command::Completions { shell } => cmd_completions(shell),
        Command::Man { dir } => cmd_man(&dir),
        Command::Run(args) => cmd_run(&args),
        Command::Status {
            files,
            output,
            shard,
            json,
        } => cmd_status(&files, output, shard.as_deref(), json),
        Command::Slurm(args) => cmd_slurm(&args),
        Command::Report {
            file,
            output,
            watch,
            interval,
            points,
            format,
        } => cmd_report(&file, output, watch, interval, &points, format),
        Command::Merge { output, shards } => cmd_merge(&output, &shards),
        Command::Gc {
            file,
            output,
            dry_run,
        } => cmd_gc(&file, output, dry_run),
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
    c.exit_code()
}

fn parse_shard(s: Option<&str>) -> Result<Option<Shard>> {
    s.map(|s| slurm::parse_shard_env(s, "--shard")).transpose()
}

/// The longest `--progress-interval`, s (a day).
const MAX_PROGRESS_INTERVAL_S: f64 = 24.0 * 3600.0;

/// [`engine::load`], showing the progress of a large grid's expansion on stderr.
fn load(file: &Path, quiet: bool) -> Result<(chainsweep::sweep::Sweep, chainsweep::grid::Grid)> {
    let shown = crate::progress::GridProgress::new(quiet);
    engine::load_showing(file, &|done, total| shown.show(done, total))
}

fn cmd_completions(shell: clap_complete::Shell) -> Result<i32> {
    use clap::CommandFactory;
    let mut out = Vec::new();
    clap_complete::generate(shell, &mut Cli::command(), "chainsweep", &mut out);
    outln!("{}", String::from_utf8_lossy(&out).trim_end());
    Ok(EXIT_OK)
}

fn cmd_man(dir: &Path) -> Result<i32> {
    use clap::CommandFactory;
    std::fs::create_dir_all(dir).map_err(Error::io("create", dir))?;
    let written = man_pages(dir, Cli::command(), "chainsweep")?;
    for p in &written {
        outln!("{}", p.display());
    }
    Ok(EXIT_OK)
}

/// Writes the page of `cmd` (named `name`) and of each of its subcommands into `dir`.
fn man_pages(dir: &Path, cmd: clap::Command, name: &str) -> Result<Vec<PathBuf>> {
    let cmd = cmd
        .name(name.to_string())
        .bin_name(name.replace('-', " "))
        .version(VERSION);
    let mut bytes = Vec::new();
    clap_mangen::Man::new(cmd.clone())
        .render(&mut bytes)
        .map_err(|e| Error::Other(format!("cannot render the manual page of {name}: {e}")))?;
    let path = dir.join(format!("{name}.1"));
    std::fs::write(&path, bytes).map_err(Error::io("write", &path))?;
    let mut written = vec![path];
    for sub in cmd.get_subcommands().filter(|s| s.get_name() != "help") {
        let sub_name = format!("{name}-{}", sub.get_name());
        written.extend(man_pages(dir, sub.clone(), &sub_name)?);
    }
    Ok(written)
}

fn cmd_examples(action: Option<ExamplesAction>) -> Result<i32> {
    match action {
        None => {
            let list = examples::list();
            let width = list.iter().map(|(n, _)| n.len()).max().unwrap_or(0);
            for (name, description) in list {
                outln!("{name:width$}  {description}");
            }
        }
        Some(ExamplesAction::Copy { name, dir }) => {
            let dir = dir.unwrap_or_else(|| PathBuf::from("."));
            for p in examples::copy(&name, &dir)? {
                outln!("{}", p.display());
            }
        }
    }
    Ok(EXIT_OK)
}

fn cmd_schema() -> Result<i32> {
    let schema = chainsweep::sweep::schema::sweep_file_schema();
    outln!(
        "{}",
        serde_json::to_string_pretty(&schema).expect("a schema serialises")
    );
    Ok(EXIT_OK)
}

fn cmd_validate(file: &Path, as_json: bool) -> Result<i32> {
    let (sweep, grid) = match load(file, as_json) {
        Ok(loaded) => loaded,
        Err(first @ Error::Input { .. }) => {
            let errors = engine::input_errors(file, first);
            if as_json {
                json::print(&json::invalid(file, &errors));
                return Ok(chainsweep::EXIT_BAD_INPUT);
            }
            for e in &errors {
                errln!("chainsweep: error: {e}");
            }
            if errors.len() > 1 {
                errln!(
                    "chainsweep: {} errors in {}{}; nothing was run",
                    errors.len(),
                    file.display(),
                    if errors.len() >= chainsweep::sweep::diagnose::MOST_ERRORS {
                        " (the first ones)"
                    } else {
                        ""
                    }
                );
            }
            return Ok(chainsweep::EXIT_BAD_INPUT);
        }
        Err(other) => return Err(other),
    };
    if as_json {
        let pilots = sweep
            .auto
            .map(|spec| chainsweep::numerics::auto::pilot_points(&sweep, &grid, spec.pilot_points))
            .transpose()?;
        json::print(&json::validated(file, &sweep, &grid, pilots));
    } else {
        show::validated(file, &sweep, &grid)?;
    }
    Ok(EXIT_OK)
}

fn cmd_run(args: &RunArgs) -> Result<i32> {
    let (mut sweep, mut grid) = load(&args.file, args.quiet)?;
    let opts = run::RunRequest {
        file: args.file.clone(),
        output: args.output.clone(),
        jobs: args.jobs,
        shard: args.shard.clone(),
        retry_failed: args.retry_failed,
        verify: args.verify,
        checkpoint_interval_s: args.checkpoint_interval,
        overwrite: args.overwrite,
    }
    .options()?;
    let p = args.progress_interval;
    if !(p > 0.0 && p <= MAX_PROGRESS_INTERVAL_S) {
        return Err(Error::input(
            "--progress-interval",
            format!("must be a number of seconds in (0, {MAX_PROGRESS_INTERVAL_S}] (at most a day), got {}", engine::number_text(p)),
        ));
    }
    let (output, shard) = (&opts.output, opts.shard);
    let mut sink = Terminal::new(args.quiet, Duration::from_secs_f64(args.progress_interval));
    if args.dry_run {
        let pool = engine::thread_pool(opts.jobs)?;
        let work_dir = chainsweep::store::work_dir_of(output);
        engine::auto::resolve(&mut sweep, &mut grid, Some(&work_dir), &pool, &mut sink)?;
        if sweep.periodic.is_some() {
            let d = engine::periodic::dry_run(&sweep, &grid, output)?;
            if args.json {
                json::print(&json::dry_run_periodic(&sweep, output, &d));
            } else {
                show::dry_run_periodic(&sweep, output, &d);
            }
            return Ok(EXIT_OK);
        }
        if sweep.search.is_some() {
            let d = inspect::dry_run_search(&sweep, &grid, shard, output)?;
            if args.json {
                json::print(&json::dry_run_search(&sweep, &grid, output, &d));
            } else {
                show::dry_run_search(&sweep, &grid, output, &d);
            }
            return Ok(EXIT_OK);
        }
        let points = shard::points(&sweep, &grid, shard);
        let d = inspect::dry_run(&sweep, &grid, &points, output)?;
        if args.json {
            json::print(&json::dry_run(&sweep, &grid, &points, output, shard, &d));
        } else {
            show::dry_run(&sweep, &grid, &points, output, shard, &d);
        }
        return Ok(EXIT_OK);
    }
    let stop = StopOnSignal::install()?;
    let report = run::run_sweep(&mut sweep, &mut grid, &opts, &mut sink, &stop.flag)?;
    show::run_report(&sweep, &grid, &report, &opts.output, args.quiet);
    match stop.signal() {
        Some((name, code)) if report.stopped => {
            show::stopped(name, &report, &opts.output);
            Ok(code)
        }
        _ => Ok(report.exit_code()),
    }
}

/// The engine's stop flag, set by SIGINT or SIGTERM: the sweep takes no new run, stores the runs
/// in flight and writes its output. A second signal ends the process at once (the default
/// action), for a user who does not want to wait for the runs in flight.
struct StopOnSignal {
    flag: Arc<AtomicBool>,
    signal: Arc<AtomicUsize>,
}

impl StopOnSignal {
    fn install() -> Result<StopOnSignal> {
        use signal_hook::consts::{SIGINT, SIGTERM};
        let flag = Arc::new(AtomicBool::new(false));
        let signal = Arc::new(AtomicUsize::new(0));
        for sig in [SIGINT, SIGTERM] {
            let failed =
                |e: std::io::Error| Error::Other(format!("cannot handle signal {sig}: {e}"));
            // Registered first, so that it sees the flag as the previous signal left it.
            signal_hook::flag::register_conditional_default(sig, Arc::clone(&flag))
                .map_err(failed)?;
            signal_hook::flag::register_usize(sig, Arc::clone(&signal), sig as usize)
                .map_err(failed)?;
            signal_hook::flag::register(sig, Arc::clone(&flag)).map_err(failed)?;
        }
        Ok(StopOnSignal { flag, signal })
    }

    /// The signal that stopped the sweep, if any, and the exit code it calls for (128 + signal).
    fn signal(&self) -> Option<(&'static str, i32)> {
        use signal_hook::consts::{SIGINT, SIGTERM};
        match self.signal.load(Ordering::SeqCst) as i32 {
            0 => None,
            SIGINT => Some(("SIGINT", 128 + SIGINT)),
            SIGTERM => Some(("SIGTERM", 128 + SIGTERM)),
            other => Some(("a signal", 128 + other)),
        }
    }
}

fn cmd_slurm(args: &SlurmArgs) -> Result<i32> {
    // The scripts run on other machines, from another folder: every path absolute, and the sweep
    // file checked here.
    engine::load(&args.file)?;
    let absolute = |p: &Path, what: &str| -> Result<PathBuf> {
        std::path::absolute(p).map_err(|e| Error::input(what, format!("{}: {e}", p.display())))
    };
    // The command the job scripts run: this binary, or the command that started it when it runs
    // inside another program (the Python package's `chainsweep` command sets CHAINSWEEP_EXE to
    // itself: this process is then the Python interpreter).
    let binary = match std::env::var_os("CHAINSWEEP_EXE").filter(|p| !p.is_empty()) {
        Some(exe) => {
            let exe = PathBuf::from(exe);
            if !exe.is_file() {
                return Err(Error::input(
                    "CHAINSWEEP_EXE",
                    format!(
                        "names {}, which is not a file: it must be the chainsweep command the job scripts run",
                        exe.display()
                    ),
                ));
            }
            exe.canonicalize()
                .map_err(|e| Error::input("CHAINSWEEP_EXE", e.to_string()))?
        }
        None => std::env::current_exe()
            .and_then(|p| p.canonicalize())
            .map_err(|e| Error::Other(format!("cannot find the chainsweep binary's path: {e}")))?,
    };
    let req = slurm::JobRequest {
        sweep: absolute(&args.file, "FILE")?,
        output: absolute(&args.output, "--output")?,
        shards: args.shards,
        time: args.time.clone(),
        partition: args.partition.clone(),
        cpus_per_task: args.cpus_per_task,
        account: args.account.clone(),
        sbatch_args: args.sbatch_arg.clone(),
        binary,
    };
    let files = slurm::write_job(&req)?;
    show::slurm_job(&req, &files);
    if args.submit {
        let (array, merge) = slurm::submit(&files)?;
        show::submitted(&array, &merge, &files);
    }
    Ok(EXIT_OK)
}

fn cmd_status(
    files: &[PathBuf],
    output: Option<PathBuf>,
    shard: Option<&str>,
    as_json: bool,
) -> Result<i32> {
    if files.len() > 1 || files[0].is_dir() {
        return cmd_shard_set_status(files, as_json);
    }
    let file = &files[0];
    if is_hdf5(file) {
        if let Some(s) = engine::periodic::status_of_file(file)? {
            return Ok(periodic_status(file, &s, as_json));
        }
    }
    if is_hdf5(file) || looks_like_output(file) {
        let s = status::of_file(file)?;
        // A search sweep is partial while a search is unfinished (stopped by its budget, or
        // not run to its end) or stopped by a failed run, as `status SWEEP` counts it.
        let searches_unfinished = s.searches.as_ref().is_some_and(|lines| {
            lines.iter().any(|l| {
                matches!(
                    l.status.as_str(),
                    "pending" | "running" | "budget" | "failed_run"
                )
            })
        });
        let code = if s.damage.any() || searches_unfinished {
            EXIT_PARTIAL
        } else {
            exit_for(&s.counts)
        };
        if as_json {
            json::print(&json::file_status(file, &s, code));
        } else {
            show::file_status(file, &s);
        }
        return Ok(code);
    }
    let (sweep, grid) = load(file, as_json)?;
    let shard = parse_shard(shard)?;
    let output = output.unwrap_or_else(|| engine::default_output(file, shard));
    if sweep.periodic.is_some() {
        return match is_hdf5(&output)
            .then(|| engine::periodic::status_of_file(&output))
            .transpose()?
            .flatten()
        {
            Some(s) => Ok(periodic_status(&output, &s, as_json)),
            None => {
                if as_json {
                    json::print(
                        &serde_json::json!({"kind": "status_periodic", "file": output.display().to_string(), "started": false, "exit_code": EXIT_PARTIAL}),
                    );
                } else {
                    outln!(
                        "{}: not run yet ({} branch(es) to compute; `chainsweep run {}` computes them)",
                        output.display(),
                        grid.len(),
                        file.display()
                    );
                }
                Ok(EXIT_PARTIAL)
            }
        };
    }
    let (s, sweep, grid) = status::of_sweep(sweep, grid, output, shard)?;
    let code = match &s.counts {
        Some(c) if !s.damage.any() => exit_for(c),
        _ => EXIT_PARTIAL,
    };
    if as_json {
        json::print(&json::sweep_status(file, &sweep, &grid, &s, code));
    } else {
        show::sweep_status(file, &sweep, &grid, &s);
    }
    Ok(code)
}

/// Prints the status of a periodic sweep's output file; its exit code: 0 when every branch
/// ended and nothing is damaged, else partial.
fn periodic_status(file: &Path, s: &engine::periodic::PeriodicStatus, as_json: bool) -> i32 {
    let code = if s.damage.is_some() || s.counts.failed > 0 || s.counts.pending > 0 {
        EXIT_PARTIAL
    } else {
        EXIT_OK
    };
    if as_json {
        json::print(&json::periodic_status(file, s, code));
    } else {
        show::periodic_status(file, s);
    }
    code
}

/// Whether `file`, which does not start with the HDF5 signature, is meant as an output file: it
/// has a work directory beside it (a damaged output) or an HDF5 file's extension. `status` then
/// says what is wrong with it rather than reading it as a sweep file.
fn looks_like_output(file: &Path) -> bool {
    chainsweep::store::work_dir_of(file).is_dir()
        || file
            .extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| ["h5", "hdf5", "he5", "nc"].contains(&e.to_ascii_lowercase().as_str()))
}

/// What `chainsweep report` writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum ReportFormat {
    /// One self-contained HTML page.
    Html,
    /// Each figure alone, as SVG files in a folder.
    Svg,
}

fn cmd_report(
    file: &Path,
    output: Option<PathBuf>,
    watch: bool,
    interval: f64,
    points: &[usize],
    format: ReportFormat,
) -> Result<i32> {
    if !(interval.is_finite() && interval > 0.0 && interval <= 86_400.0) {
        return Err(Error::input(
            "--interval",
            format!("must be a number of seconds in (0, 86400], got {interval}"),
        ));
    }
    let out = output.unwrap_or_else(|| match format {
        ReportFormat::Html => file.with_extension("html"),
        ReportFormat::Svg => {
            let stem = file.file_stem().unwrap_or_default().to_string_lossy();
            file.with_file_name(format!("{stem}-figures"))
        }
    });
    engine::check_output_folder(&out)?;
    if out
        .canonicalize()
        .ok()
        .is_some_and(|o| Some(o) == file.canonicalize().ok())
        || chainsweep::store::hdf5::is_hdf5(&out)
    {
        return Err(Error::input(
            "--output",
            format!(
                "{} is an HDF5 file: the page is written beside it, never over it",
                out.display()
            ),
        ));
    }
    let write_page = || -> Result<()> {
        let t = std::time::Instant::now();
        let periodic = chainsweep::store::hdf5::is_hdf5(file)
            .then(|| engine::periodic::status_of_file(file))
            .transpose()?
            .flatten();
        let p = if let Some(s) = periodic {
            // A periodic sweep's branches: a page of their curves (no histories to choose).
            let page = chainsweep::report::periodic::page(file, &s)?;
            match format {
                ReportFormat::Html => chainsweep::report::write_page(page, &out)?,
                ReportFormat::Svg => chainsweep::report::write_figures_of(page, &out)?,
            }
        } else {
            let s = status::of_file(file)?;
            if let Some(&n) = points.iter().find(|&&n| n >= s.total) {
                return Err(Error::input(
                    "--point",
                    format!(
                        "point {n} is not in the file: its points are 0 to {}",
                        s.total.saturating_sub(1)
                    ),
                ));
            }
            match format {
                ReportFormat::Html => chainsweep::report::write(file, &s, points, &out)?,
                ReportFormat::Svg => chainsweep::report::write_figures(file, &s, points, &out)?,
            }
        };
        let size = match format {
            ReportFormat::Html => p.html.len(),
            ReportFormat::Svg => p.svgs.iter().map(|(_, s)| s.len()).sum(),
        };
        errln!(
            "chainsweep: report: {} figure(s) in {:.2} s, {} → {}{}",
            p.figures,
            t.elapsed().as_secs_f64(),
            show::human(size as f64),
            out.display(),
            if p.thinned.is_empty() {
                String::new()
            } else {
                match format {
                    ReportFormat::Html => " (thinned where large; the page says where)",
                    ReportFormat::Svg => " (thinned where large; captions.txt says where)",
                }
                .to_string()
            }
        );
        Ok(())
    };
    if !watch {
        write_page()?;
        return Ok(EXIT_OK);
    }
    // Until the sweep writing into FILE has ended: a page every interval, then the last one.
    loop {
        let live = chainsweep::store::writer_of(file).is_some();
        if file.exists() {
            write_page()?;
        }
        if !live && file.exists() {
            return Ok(EXIT_OK);
        }
        std::thread::sleep(std::time::Duration::from_secs_f64(interval));
    }
}

fn cmd_gc(file: &Path, output: Option<PathBuf>, dry_run: bool) -> Result<i32> {
    let (sweep, grid) = load(file, false)?;
    let output = output.unwrap_or_else(|| engine::default_output(file, None));
    let r = engine::gc::collect(sweep, grid, &output, dry_run)?;
    show::gc(&output, &r);
    Ok(EXIT_OK)
}

/// `status` of shard files, or of a folder of them (`OUT.h5.slurm`, its `shards/`, any folder).
fn cmd_shard_set_status(files: &[PathBuf], as_json: bool) -> Result<i32> {
    let mut list: Vec<PathBuf> = Vec::new();
    for f in files {
        if !f.is_dir() {
            list.push(f.clone());
            continue;
        }
        let dir = if f.join("shards").is_dir() {
            f.join("shards")
        } else {
            f.clone()
        };
        let mut found: Vec<PathBuf> = std::fs::read_dir(&dir)
            .map_err(Error::io("list", &dir))?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|x| x == "h5") && p.is_file())
            .collect();
        if found.is_empty() {
            // A job folder before any task has published: every shard its list names is
            // missing (or being written).
            if let Some(expected) = slurm::expected_shards(f).filter(|e| !e.is_empty()) {
                let set = status::of_unstarted_shards(&expected);
                let array = f.join("array.sh");
                let merge = f.join("merge.sh");
                if as_json {
                    let tasks: Vec<usize> = set.to_run().iter().map(|k| k - 1).collect();
                    let resubmit = (!tasks.is_empty())
                        .then(|| slurm::resubmit_command(&tasks, &array, &merge));
                    json::print(&json::shard_set(&set, resubmit, EXIT_PARTIAL));
                } else {
                    show::shard_set_status(&set, Some((array.as_path(), merge.as_path())));
                }
                return Ok(EXIT_PARTIAL);
            }
            return Err(Error::input(
                "FILE",
                format!("{} holds no shard files (*.h5)", dir.display()),
            ));
        }
        found.sort();
        list.extend(found);
    }
    let set = status::of_shard_set(&list)?;
    let script = files
        .iter()
        .find(|f| f.join("array.sh").is_file())
        .map(|d| (d.join("array.sh"), d.join("merge.sh")));
    let all_done = set
        .shards
        .iter()
        .all(|s| s.state == status::ShardState::Done);
    let code = if all_done { EXIT_OK } else { EXIT_PARTIAL };
    if as_json {
        let tasks: Vec<usize> = set.to_run().iter().map(|k| k - 1).collect();
        let resubmit = script
            .as_ref()
            .filter(|_| !tasks.is_empty())
            .map(|(a, m)| slurm::resubmit_command(&tasks, a, m));
        json::print(&json::shard_set(&set, resubmit, code));
    } else {
        show::shard_set_status(
            &set,
            script.as_ref().map(|(a, m)| (a.as_path(), m.as_path())),
        );
    }
    Ok(code)
}

fn cmd_merge(output: &Path, shards: &[PathBuf]) -> Result<i32> {
    let r = merge::merge(output, shards, &Provenance::of_this_process())?;
    let job = slurm::job_dir_of(output);
    let scripts = (job.join("array.sh"), job.join("merge.sh"));
    let scripts = scripts
        .0
        .is_file()
        .then_some((scripts.0.as_path(), scripts.1.as_path()));
    show::merged(&r, output, scripts);
    Ok(exit_for(&r.counts))
}

fn cmd_point(file: &Path, index: usize, scene_only: bool, output: Option<&Path>) -> Result<i32> {
    let (mut sweep, mut grid) = engine::load(file)?;
    let mut sink = Terminal::new(
        false,
        Duration::from_secs_f64(run::DEFAULT_PROGRESS_INTERVAL_S),
    );
    let p = inspect::point(&mut sweep, &mut grid, index, output, !scene_only, &mut sink)?;
    outln!("{}", show::point(&grid, index, &p));
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
        reference_limit_s: sweep.limits.max_run_seconds,
        methods: args.methods.clone(),
    };
    let quiet = args.quiet;
    if !quiet {
        errln!("chainsweep accuracy: {} of {}", what, args.file.display());
    }
    let source = format!("{} {}", args.file.display(), what);
    let st = inspect::study(&scene, &opts, &output, &source, |l| {
        if !quiet {
            errln!("  {l}");
        }
    })?;
    show::study(&st, &output);
    Ok(EXIT_OK)
}
