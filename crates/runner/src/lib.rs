//! # chainsweep — the engine
//!
//! Runs grids of [`chainsweep_solver`] scenes described by a sweep file, in parallel, into an HDF5
//! file that h5py and xarray read, and resumes after any interruption; searches, fits, ensembles
//! and periodic branches over the same runs.
//!
//! The engine sits over two crates whose modules it re-exports under their usual names (see
//! `ARCHITECTURE.md`):
//!
//! - `chainsweep-sweep` (what a sweep is): [`error`], [`identity`], [`record`], [`uq`], [`sweep`],
//!   [`grid`], [`search`];
//! - `chainsweep-store` (the only crate that links HDF5): [`store`], the run logs, the work
//!   directory and the HDF5 file.
//!
//! Its own modules form layers, each importing only those listed before it (kept true by
//! `tests/layers.rs`):
//!
//! - [`exec`]: run one scene under `catch_unwind` and turn its output into a run record;
//! - [`numerics`]: `run --verify`, `integrator: auto` and work-precision studies;
//! - [`engine`]: planning, scheduling with checkpoints, assembling, merging, status: what the
//!   commands do, as a library that prints nothing;
//! - [`report`]: an output file as one self-contained HTML page.
//!
//! The `chainsweep` command line and its progress display are the `chainsweep-cli` crate, a thin
//! front end over this one. A front end calls [`init`] once at start.
//!
//! Exit codes: [`EXIT_OK`], [`EXIT_ERROR`], [`EXIT_BAD_INPUT`], [`EXIT_PARTIAL`].
#![warn(missing_docs)]

pub mod engine;
pub mod exec;
pub mod numerics;
pub mod report;

pub use chainsweep_store as store;
pub use chainsweep_sweep::{error, grid, identity, record, search, sweep, uq};
pub use chainsweep_sweep::{
    git_revision, set_git_revision, ENGINE_VERSION, EXIT_BAD_INPUT, EXIT_ERROR, EXIT_OK,
    EXIT_PARTIAL, NUMERICS_VERSION, SOLVER_VERSION,
};

/// What a front end does once at start: records the git revision it was built from (stored in
/// every file it writes, [`git_revision`]) and registers the store's HDF5 reader for the HDF5
/// files a sweep file may name (recorded drives, fit data, a fit's result), which the sweep crate
/// reads without linking HDF5 itself.
pub fn init(revision: &'static str) {
    set_git_revision(revision);
    store::hdf5::input::register();
}
