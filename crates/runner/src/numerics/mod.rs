//! The numerics of the runner: how results are checked and how integrator settings are chosen.
//!
//! - [`verify`]: `run --verify`: a sample of grid points re-run at a tighter setting, and the
//!   observed relative error of every summary;
//! - [`auto`]: `integrator: auto`, resolved to the cheapest setting that meets a target error by
//!   a pilot on a few grid points;
//! - [`accuracy`]: work-precision studies (`chainsweep accuracy`).

pub mod accuracy;
pub mod auto;
pub mod verify;
