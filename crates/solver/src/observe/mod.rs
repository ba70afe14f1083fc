//! What a run records: observables sampled through the integrators' dense output, leading-pulse
//! and record peaks, histories, and the energy ledger's bookkeeping along the run ([`probes`]).

pub mod probes;
