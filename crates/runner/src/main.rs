//! `chainsweep`: runs sweeps of chain simulations into HDF5 (see `chainsweep --help`).

fn main() {
    // Behave like other command-line tools when the reader of stdout goes away (`| head`).
    #[cfg(unix)]
    // SAFETY: restoring the default disposition of SIGPIPE installs no handler (no code runs
    // in signal context), and it happens first thing in `main`, before any other thread exists.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    std::process::exit(chainsweep::cli::main());
}
