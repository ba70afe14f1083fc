//! The `chainsweep` command line: parses the arguments, calls the [`chainsweep::engine`], prints.
//! `validate`, `run`, `status`, `point`, `accuracy`, `merge`, `slurm`.

mod args;
mod examples;
mod json;
mod show;

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::Duration;

use clap::Parser;

use args::*;

use crate::progress::Terminal;
use chainsweep::engine::{self, inspect, merge, run, shard, slurm, status};
use chainsweep::error::{Error, Result};
use chainsweep::grid::Shard;
use chainsweep::numerics::accuracy::StudyOptions;
use chainsweep::store::hdf5::{is_hdf5, Counts, Provenance};
use chainsweep::{EXIT_OK, EXIT_PARTIAL};

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
    chainsweep::init(crate::GIT_REVISION);
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
        ensemble_round: args.ensemble_round,
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
        // A shard of an adaptive ensemble runs one round: the dry run states that round's runs
        // (and `--ensemble-round` anywhere else is refused, as the run refuses it).
        if let Some(k) = engine::ensemble::shard_round(&sweep, &opts)? {
            sweep = sweep.at_ensemble_round(k);
            grid = chainsweep::grid::Grid::new(&sweep)?;
        }
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
    let (sweep, _) = engine::load(&args.file)?;
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
        adaptive: sweep.adaptive_ensemble().is_some(),
    };
    if args.next_round {
        return cmd_slurm_next_round(&req, &sweep);
    }
    let files = slurm::write_job(&req)?;
    show::slurm_job(&req, &files);
    if args.submit {
        let (array, merge) = slurm::submit(&files)?;
        show::submitted(&array, &merge, &files);
    }
    Ok(EXIT_OK)
}

/// `slurm --next-round`: the next round of an adaptive ensemble, when its merged file says one is
/// due.
fn cmd_slurm_next_round(req: &slurm::JobRequest, sweep: &chainsweep::sweep::Sweep) -> Result<i32> {
    if !req.adaptive {
        return Err(Error::input(
            "--next-round",
            "submits the next round of an adaptive ensemble (an ensemble with a tolerance); this sweep has none",
        ));
    }
    let outcome = engine::ensemble::outcome_of(&req.output).ok_or_else(|| {
        Error::Other(format!(
            "{} holds no merged round of the ensemble: merge its shard files first (merge.sh)",
            req.output.display()
        ))
    })?;
    let files = slurm::job_files(&req.sweep, &req.output, req.shards);
    // The round the tasks were last given: when the merged file holds an earlier one, the tasks
    // of that round wrote no shard file of it (killed before their first checkpoint, refused by a
    // sweep file edited since), and submitting again would loop.
    let given = slurm::folder_round(&files);
    if given > outcome.round {
        let tasks: Vec<usize> = (0..req.shards).collect();
        println!(
            "the job folder's round is {given} but {} holds round {}: the array tasks of round {given} wrote no shard file of it (see their logs in {}); nothing submitted. To run them again, then the merge:\n  {}",
            req.output.display(),
            outcome.round,
            files.logs.display(),
            slurm::resubmit_command(&tasks, &files.array_script, &files.merge_script)
        );
        return Ok(EXIT_PARTIAL);
    }
    match outcome.stopped_by {
        "running" => {
            let next = outcome.round + 1;
            slurm::set_round(&files, next)?;
            let (array, merge) = slurm::submit(&files)?;
            println!(
                "round {} of the ensemble ended with an interval {:.3} times its tolerance: round {next} submitted",
                outcome.round,
                outcome.worst_ratio
            );
            show::submitted(&array, &merge, &files);
            Ok(EXIT_OK)
        }
        "incomplete" => {
            println!(
                "round {} of the ensemble is incomplete in {}: merge its shards again once their tasks have run",
                outcome.round,
                req.output.display()
            );
            Ok(EXIT_PARTIAL)
        }
        _ => {
            // How it ended, and its statistics, as `status` of the file gives them.
            println!(
                "the ensemble ended after round {}: {} holds its statistics",
                outcome.round,
                req.output.display()
            );
            let at_round = sweep.at_ensemble_round(outcome.round);
            if let Some(e) = engine::status::ensemble_of(&req.output, &at_round) {
                for line in show::ensemble_lines(&e) {
                    println!("{line}");
                }
            }
            Ok(EXIT_OK)
        }
    }
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

/// Bytes of the files in the folder `dir` (a report's figures).
fn figure_bytes(dir: &Path) -> usize {
    std::fs::read_dir(dir)
        .into_iter()
        .flatten()
        .filter_map(|e| e.ok()?.metadata().ok())
        .map(|m| m.len() as usize)
        .sum()
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
        ReportFormat::Svg | ReportFormat::Png | ReportFormat::Pdf => {
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
            match format.of_figures() {
                None => chainsweep::report::write_page(page, &out)?,
                Some(figures) => chainsweep::report::write_figures_of(page, &out, figures)?,
            }
        } else {
            let s = status::of_file(file)?;
            // Every point of the grid (a shard's file holds them all, its own runs among them).
            let points_in_file: usize = s.shape.iter().product();
            if let Some(&n) = points.iter().find(|&&n| n >= points_in_file) {
                return Err(Error::input(
                    "--point",
                    format!(
                        "point {n} is not in the file: its points are 0 to {}",
                        points_in_file.saturating_sub(1)
                    ),
                ));
            }
            match format.of_figures() {
                None => chainsweep::report::write(file, &s, points, &out)?,
                Some(figures) => {
                    chainsweep::report::write_figures(file, &s, points, &out, figures)?
                }
            }
        };
        let size = match format {
            ReportFormat::Html => p.html.len(),
            _ => figure_bytes(&out),
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
                    _ => " (thinned where large; captions.txt says where)",
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
    // (A page is checked before the first wait, so that a bad --output is said at once.)
    if matches!(format, ReportFormat::Html) {
        chainsweep::report::check_page_output(&out)?;
    }
    let mut said = false;
    loop {
        let live = chainsweep::store::writer_of(file).is_some();
        if file.exists() {
            write_page()?;
        } else if !said {
            errln!(
                "chainsweep: report: waiting for {} to be written{} (Ctrl-C stops)",
                file.display(),
                if live { "" } else { ": no sweep writes it yet" }
            );
            said = true;
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
