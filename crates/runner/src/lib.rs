//! # chainsweep — the sweep runner
//!
//! Runs grids of [`chainsweep_solver`] scenes described by a sweep file, in parallel, into an HDF5
//! file that h5py and xarray read, and resumes after any interruption.
//!
//! The modules form layers, each importing only those listed before it (see `ARCHITECTURE.md`,
//! kept true by `tests/layers.rs`):
//!
//! - [`error`]: the runner's errors and the exit codes they map to;
//! - [`identity`]: run hashes and verification hashes (the identity of a run);
//! - [`record`]: what a finished run leaves behind ([`record::RunRecord`]), status codes;
//! - [`sweep`]: parse and validate a sweep file (base scene, record block, axes, limits, the
//!   `integrator: auto` request and choice as data);
//! - [`grid`]: expand the axes into grid points, each a complete [`chainsweep_solver::Scene`] with
//!   its run hash;
//! - [`search`]: the methods of searches (minima, roots, refined curves), pure functions of the
//!   values found;
//! - [`exec`]: run one scene under `catch_unwind` and turn its output into a run record;
//! - [`store`]: crash-safe append-only logs of finished runs, the lock on the work directory,
//!   and the HDF5 file assembled from the stored runs in grid order;
//! - [`numerics`]: `run --verify`, `integrator: auto` and work-precision studies;
//! - [`engine`]: planning, scheduling with checkpoints, assembling, merging, status: what the
//!   commands do, as a library that prints nothing;
//! - [`report`]: an output file as one self-contained HTML page.
//!
//! The `chainsweep` command line and its progress display are the `chainsweep-cli` crate, a thin
//! front end over this one.
//!
//! Exit codes: [`EXIT_OK`], [`EXIT_ERROR`], [`EXIT_BAD_INPUT`], [`EXIT_PARTIAL`].
#![warn(missing_docs)]

pub mod engine;
pub mod error;
pub mod exec;
pub mod grid;
pub mod identity;
pub mod numerics;
pub mod record;
pub mod report;
pub mod search;
pub mod store;
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
pub const NUMERICS_VERSION: u32 = 9;

/// Version of this crate.
pub const ENGINE_VERSION: &str = env!("CARGO_PKG_VERSION");

/// Version of the solver crate this runner is built against (part of every run's identity).
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
