//! `chainsweep`: runs sweeps of chain simulations into HDF5 (see `chainsweep --help`).
//!
//! SIGPIPE stays ignored (Rust's default): a reader that goes away (`chainsweep run … 2>&1 |
//! head`) must not kill a sweep; every line printed ignores write errors instead.

fn main() {
    std::process::exit(chainsweep::cli::main());
}
