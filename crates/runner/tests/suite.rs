//! The runner's integration tests as one test binary: each file beside this one is a module here.
//!
//! One binary rather than one per file: every test binary links the whole crate graph (the HDF5
//! library included), so one binary links it once rather than seven times.

mod axes_absent_fields;
mod columns;
mod engine;
mod layers;
mod malformed_corpus;
mod shards;
mod store;
