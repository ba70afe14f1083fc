//! The runner's integration tests as one test binary: each file beside this one is a module here.
//!
//! One binary rather than one per file because every test binary links the whole crate graph (the
//! HDF5 library included) optimised by the release profile, which made linking seven of them a
//! large part of `make test`'s build.

mod axes_absent_fields;
mod columns;
mod engine;
mod layers;
mod malformed_corpus;
mod shards;
mod store;
