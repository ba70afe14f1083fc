//! The `chainsweep` command of the Python package: the console script `chainsweep`
//! (`chainsweep._cli:main`) runs the runner's own command line, [`chainsweep_cli::cli::main_from`],
//! so that a wheel installs the same command as the native binary, with nothing else to build.

use pyo3::prelude::*;
use std::ffi::OsString;
use std::io::Write;

/// Runs the `chainsweep` command line `argv` (the first element is the program's name, as in
/// `sys.argv`) exactly as the native binary runs it, and returns its exit code. The GIL is
/// released while it runs. Arguments are taken as the OS gave them (undecodable bytes included,
/// through Python's `surrogateescape`).
///
/// Signals are the caller's business: `chainsweep run` installs its own SIGINT and SIGTERM
/// handlers (stop taking runs, store the ones in flight, exit 130 or 143) on top of whatever is
/// installed, and calls it too; `chainsweep._cli.main` restores the default SIGINT action first,
/// so that Python's handler does not also raise `KeyboardInterrupt` after the command is done.
#[pyfunction]
#[pyo3(signature = (argv))]
pub fn cli_main(py: Python<'_>, argv: Vec<OsString>) -> i32 {
    py.detach(move || {
        let code = chainsweep_cli::cli::main_from(argv);
        // The native binary's stdout is flushed as its process exits; this one's process goes on
        // (into Python), so its last lines are flushed here.
        let _ = std::io::stdout().flush();
        let _ = std::io::stderr().flush();
        code
    })
}
