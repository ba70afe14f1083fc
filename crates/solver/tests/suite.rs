//! The solver's integration tests as one test binary: each file beside this one is a module here.
//!
//! One binary rather than one per file: every test binary links the whole crate graph, so one
//! binary links it once rather than twenty times. `dispatch.rs` stays a binary of its own: it
//! forces the CPU code path process-wide, which would change the bits the other tests' runs
//! compute under them.

// The benchmark's reference run, which `accuracy` and `paper_bitwise` check.
#[path = "../benches/reference.rs"]
mod reference;

mod accuracy;
mod active;
mod boundaries;
mod chains;
mod drives;
mod dynamics;
mod energy_flow;
mod equations;
mod fields;
mod limits;
mod max_overlap;
mod mount;
mod paper_bitwise;
mod peaks;
mod periodic;
mod serialisation;
mod single;
mod spectrum;
mod static_state;
mod steady_state;
mod stiff;
mod thornton;
mod tsuji;
