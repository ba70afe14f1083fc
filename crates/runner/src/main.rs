//! `chainsweep`: runs sweeps of chain simulations into HDF5 (see `chainsweep --help`).

fn main() {
    // Behave like other command-line tools when the reader of stdout goes away (`| head`).
    #[cfg(unix)]
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    std::process::exit(chainsweep::cli::main());
}
