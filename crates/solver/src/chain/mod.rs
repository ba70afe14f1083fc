//! What a chain is made of, from the specification as written to the built chain: materials,
//! shapes and particle kinds ([`parts`]), chains as sequences of named particle types with taper
//! and disorder ([`sequence`]), and the chain as configured, with the paper's dimer presets, built
//! into per-particle and per-contact arrays ([`model`]); the boundary drives and their waveforms
//! ([`drive`]); a wall on a spring and a dashpot ([`mount`]).

pub mod drive;
pub mod model;
pub mod mount;
pub mod parts;
pub mod sequence;
