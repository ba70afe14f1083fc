//! # chainsweep-sweep — what a sweep is
//!
//! The sweep-file model and everything that is a pure function of it: parsing and validating a
//! sweep file, its JSON Schema, the grid of scenes with their run hashes, the searches' and fits'
//! proposers, the designs and statistics of ensembles, and what a finished run leaves behind
//! ([`record::RunRecord`], the table of its columns). No files are written and no HDF5 library is
//! linked: the HDF5 files a sweep file may name (recorded drives, fit data, a fit's result) are
//! read through the reader the front end registers ([`sweep::data_files::set_hdf5_reader`], the
//! store crate's).
//!
//! The modules form layers, each importing only those listed before it (see `ARCHITECTURE.md`,
//! kept true by the engine's `tests/layers.rs`):
//!
//! - [`error`]: the errors of the engine and the exit codes they map to;
//! - [`identity`]: run hashes and verification hashes (the identity of a run);
//! - [`record`]: what a finished run leaves behind ([`record::RunRecord`]), status codes, the
//!   table of stored columns;
//! - [`uq`]: distributions, designs, statistics and sensitivities, as pure functions;
//! - [`sweep`]: parse and validate a sweep file (base scene, record block, axes, limits, the
//!   `integrator: auto` request and choice as data);
//! - [`grid`]: expand the axes into grid points, each a complete [`chainsweep_solver::Scene`] with
//!   its run hash;
//! - [`search`]: the methods of searches and fits, pure functions of the values found.
#![warn(missing_docs)]

pub mod error;
pub mod grid;
pub mod identity;
pub mod record;
pub mod search;
pub mod sweep;
pub mod uq;

/// Every run finished successfully.
pub const EXIT_OK: i32 = 0;
/// Something other than the input went wrong (I/O, a second process holding the lock, …).
pub const EXIT_ERROR: i32 = 1;
/// Bad input or usage: nothing was run, nothing was created or modified.
pub const EXIT_BAD_INPUT: i32 = 2;
/// The sweep is partial: some runs failed (or, after a merge, some grid points are missing).
pub const EXIT_PARTIAL: i32 = 3;

/// Version of the runner's numerics: bump it whenever a change in the runner or the solver changes
/// the numbers a scene produces (or what a run records), so that resumed sweeps recompute every run.
/// Its history: CHANGELOG.md, "Numerics versions".
pub const NUMERICS_VERSION: u32 = 10;

/// Version of the engine (the workspace's version, which every crate of it shares).
pub const ENGINE_VERSION: &str = env!("CARGO_PKG_VERSION");

/// Version of the solver crate this engine is built against (part of every run's identity).
pub const SOLVER_VERSION: &str = env!("CHAINSWEEP_SOLVER_VERSION");

/// The git revision of the program running this library, as its front end (the command line, the
/// Python package) was built from it and set it with [`set_git_revision`]; `unknown` until set.
/// A value the front end gives rather than a constant of this crate: a new commit then rebuilds
/// the thin front end only, not this crate and everything above it.
pub fn git_revision() -> &'static str {
    GIT_REVISION.get().copied().unwrap_or("unknown")
}

/// Sets [`git_revision`] (once; later calls are ignored).
pub fn set_git_revision(revision: &'static str) {
    let _ = GIT_REVISION.set(revision);
}

static GIT_REVISION: std::sync::OnceLock<&'static str> = std::sync::OnceLock::new();
