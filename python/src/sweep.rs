//! A sweep file run into HDF5 in this process, exactly as `chainsweep run` runs it (resume,
//! segments, exit codes), with progress for Python and a clean stop on Ctrl-C.
//!
//! The runner runs on a thread of its own; the calling thread waits with the GIL released and,
//! a few times a second, takes it to check Python's signals (Ctrl-C, a notebook's interrupt) and
//! to report progress to a Python callback. Ctrl-C asks the runner to stop cleanly: runs in
//! flight finish and are stored, the output is assembled with the rest pending, and the
//! `KeyboardInterrupt` is raised once the runner has returned, so the same call resumes.

use std::path::PathBuf;
use std::sync::atomic::Ordering;
use std::sync::mpsc;
use std::time::{Duration, Instant};

use pyo3::prelude::*;

use chainsweep::cli::{Cli, Command, RunArgs, STOP_REQUESTED};
use chainsweep::error::{Error, Result};

use crate::watch::Watch;

/// What `chainsweep.sweep` asks for.
#[derive(Debug, Clone)]
pub struct SweepRequest {
    /// Sweep file.
    pub file: PathBuf,
    /// Output HDF5 file.
    pub output: PathBuf,
    /// Parallel runs (`None`: every CPU).
    pub jobs: Option<usize>,
    /// `K/N`: run only that shard.
    pub shard: Option<String>,
    /// Run again the points whose earlier run failed.
    pub retry_failed: bool,
    /// Fraction of points re-run at a tighter setting.
    pub verify: Option<f64>,
    /// Seconds between refreshes of the output while the sweep runs (0: only at the end).
    pub checkpoint_interval: f64,
}

/// The package's one call into the runner for a whole sweep.
///
/// Today the runner's only entry for a sweep is its command line, so this builds the parsed
/// `chainsweep run FILE -o OUTPUT --quiet …` and dispatches it in this process (the runner's own
/// progress display stays off: [`Watch`] reports progress to Python instead, and the stop is
/// [`STOP_REQUESTED`]). When the runner offers an engine API (a plan, a schedule on an executor,
/// a progress sink, a stop flag), this function, [`request_stop`] and [`Watch`] are what to
/// re-point: the rest of the package sees only a [`SweepRequest`] in and an exit code out.
fn dispatch_run(req: &SweepRequest) -> Result<i32> {
    chainsweep::cli::dispatch(Cli {
        command: Command::Run(RunArgs {
            file: req.file.clone(),
            output: Some(req.output.clone()),
            jobs: req.jobs,
            shard: req.shard.clone(),
            dry_run: false,
            quiet: true,
            retry_failed: req.retry_failed,
            progress_interval: 10.0,
            checkpoint_interval: req.checkpoint_interval,
            overwrite: false,
            verify: req.verify,
        }),
    })
}

/// Asks the running sweep to stop cleanly (see [`dispatch_run`]).
fn request_stop(stop: bool) {
    STOP_REQUESTED.store(stop, Ordering::SeqCst);
}

/// How often Python's signals are checked while the sweep runs.
const SIGNAL_INTERVAL: Duration = Duration::from_millis(100);

/// Runs a sweep file into `output` (see the module docs). `progress`, when given, is called as
/// `progress(done, failed, total)` a few times a second and once at the end (counts of grid points
/// and verification runs, as the command line's progress bar counts them). Returns
/// `(exit_code, runs)`: the runner's exit code (0 all runs succeeded, 3 some failed or are
/// pending) and the number of runs this call made. Bad input raises `chainsweep.InputError`
/// (nothing run or written), anything else `chainsweep.SweepError`; Ctrl-C stops the sweep
/// cleanly and then raises `KeyboardInterrupt`; an exception raised by `progress` does the same
/// with that exception.
#[pyfunction]
#[pyo3(signature = (file, output, jobs=None, shard=None, retry_failed=false, verify=None, checkpoint_interval=300.0, progress=None))]
#[allow(clippy::too_many_arguments)]
pub fn run_sweep(
    py: Python<'_>,
    file: PathBuf,
    output: PathBuf,
    jobs: Option<usize>,
    shard: Option<String>,
    retry_failed: bool,
    verify: Option<f64>,
    checkpoint_interval: f64,
    progress: Option<Py<PyAny>>,
) -> PyResult<(i32, usize)> {
    let req = SweepRequest {
        file,
        output,
        jobs,
        shard,
        retry_failed,
        verify,
        checkpoint_interval,
    };
    // Before the runner starts, so that what exists already is not counted as run by this call.
    let mut watch = {
        let r = req.clone();
        py.detach(move || Watch::new(&r))
    };
    // The state before anything runs: what is done already is not counted in the rate.
    if let (Some(w), Some(cb)) = (watch.as_mut(), progress.as_ref()) {
        let p = py.detach(|| w.poll());
        cb.call1(py, (p.done, p.failed, p.total))?;
    }
    let (tx, rx) = mpsc::channel::<Result<i32>>();
    let runner_req = req.clone();
    let runner = std::thread::spawn(move || {
        let _ = tx.send(dispatch_run(&runner_req));
    });
    // (A receiver is not `Sync`; the wait below borrows it from a thread without the GIL.)
    let rx = std::sync::Mutex::new(rx);
    let mut pending_error: Option<PyErr> = None;
    let mut next_report = Instant::now() + Duration::from_millis(250);
    let outcome = loop {
        match py.detach(|| {
            rx.lock()
                .expect("only this thread locks it")
                .recv_timeout(SIGNAL_INTERVAL)
        }) {
            Ok(r) => break r,
            Err(mpsc::RecvTimeoutError::Timeout) => {}
            Err(mpsc::RecvTimeoutError::Disconnected) => {
                break Err(Error::Other(
                    "the sweep's thread ended without a result (a panic outside the runs)".into(),
                ))
            }
        }
        if pending_error.is_none() {
            if let Err(e) = py.check_signals() {
                request_stop(true);
                pending_error = Some(e);
            }
        }
        if let (Some(w), Some(cb), true) = (
            watch.as_mut(),
            progress.as_ref(),
            Instant::now() >= next_report,
        ) {
            let t0 = Instant::now();
            let p = py.detach(|| w.poll());
            // Polling reads the work directory: keep it under a few per cent of the time.
            next_report = Instant::now() + (t0.elapsed() * 30).max(Duration::from_millis(250));
            if pending_error.is_none() {
                if let Err(e) = cb.call1(py, (p.done, p.failed, p.total)) {
                    request_stop(true);
                    pending_error = Some(e);
                }
            }
        }
    };
    let _ = runner.join();
    request_stop(false);
    let mut ran = 0;
    if let Some(w) = watch.as_mut() {
        let p = py.detach(|| w.poll());
        ran = p.ran;
        if let (Some(cb), None) = (progress.as_ref(), pending_error.as_ref()) {
            cb.call1(py, (p.done, p.failed, p.total))?;
        }
    }
    if let Some(e) = pending_error {
        return Err(e);
    }
    let code = outcome.map_err(|e| crate::py_error(py, &e, "sweep"))?;
    Ok((code, ran))
}
