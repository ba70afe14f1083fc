//! `chainsweep`: runs sweeps of chain simulations into HDF5 (see `chainsweep --help`).
//!
//! SIGPIPE stays ignored (Rust's default): a reader that goes away (`chainsweep run … 2>&1 |
//! head`) must not kill a sweep; every line printed ignores write errors instead.

/// jemalloc rather than glibc's malloc, for a sweep's churn of allocations (why: the runner's
/// Cargo.toml, at its `tikv-jemallocator` dependency).
#[cfg(feature = "jemalloc")]
#[global_allocator]
static ALLOCATOR: tikv_jemallocator::Jemalloc = tikv_jemallocator::Jemalloc;

fn main() {
    std::process::exit(chainsweep_cli::cli::main());
}
