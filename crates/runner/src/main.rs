//! `chainsweep`: runs sweeps of chain simulations into HDF5 (see `chainsweep --help`).
//!
//! SIGPIPE stays ignored (Rust's default): a reader that goes away (`chainsweep run … 2>&1 |
//! head`) must not kill a sweep; every line printed ignores write errors instead.

/// jemalloc rather than glibc's malloc: runs allocate and free their chains, scenes and work spaces
/// by the hundred thousand in a sweep, and glibc's malloc made that 5 % of the Fig. 8 sweep's wall
/// (the runner's `jemalloc` feature, on by default).
#[cfg(feature = "jemalloc")]
#[global_allocator]
static ALLOCATOR: tikv_jemallocator::Jemalloc = tikv_jemallocator::Jemalloc;

fn main() {
    std::process::exit(chainsweep::cli::main());
}
