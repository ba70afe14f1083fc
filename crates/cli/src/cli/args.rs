//! The command line's arguments: the `clap` definition of every command and its options (what
//! `--help`, the man pages and the shell completions are made from).

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand};

use chainsweep::engine::run;

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
pub(super) const VERSION: &str = concat!(
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
        after_help = "Examples:\n  chainsweep report results/mass-damping.h5                 # results/mass-damping.html\n  chainsweep report results/mass-damping.h5 -o morning.html\n  chainsweep report results/mass-damping.h5 --watch         # refreshed while the sweep runs\n  chainsweep report results/mass-damping.h5 --format pdf    # results/mass-damping-figures/*.pdf"
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
        /// `html`: one page; `svg`, `pdf` (vector, its font embedded) or `png` (twice the
        /// figure's size in pixels): each figure alone as a file in a folder (default: FILE
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
    /// With --shard, the round of an adaptive ensemble (a statistic with a tolerance) to run:
    /// its rounds depend on every shard's samples, so each shard runs one round and `merge` of
    /// all the shards' files says whether another is due [default: 0].
    #[arg(long, value_name = "ROUND")]
    pub ensemble_round: Option<usize>,
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
    /// Of an adaptive ensemble whose round OUT holds (merged): submit the array and merge jobs of
    /// the next round when the statistics are not yet within their tolerances and the budget
    /// allows it, else say how the ensemble ended. The merge job of such an ensemble runs this
    /// itself, so that the rounds follow each other until the ensemble ends. Writes no scripts.
    #[arg(long, conflicts_with = "submit")]
    pub next_round: bool,
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

/// What `chainsweep report` writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum ReportFormat {
    /// One self-contained HTML page.
    Html,
    /// Each figure alone, as SVG files in a folder.
    Svg,
    /// Each figure alone, as vector PDF files (one page each) in a folder.
    Pdf,
    /// Each figure alone, as PNG images in a folder.
    Png,
}

impl ReportFormat {
    /// The format of each figure's file; `None` for `Html`, which writes one page.
    pub fn of_figures(self) -> Option<chainsweep::report::FigureFormat> {
        use chainsweep::report::FigureFormat;
        match self {
            ReportFormat::Html => None,
            ReportFormat::Svg => Some(FigureFormat::Svg),
            ReportFormat::Pdf => Some(FigureFormat::Pdf),
            ReportFormat::Png => Some(FigureFormat::Png),
        }
    }
}
