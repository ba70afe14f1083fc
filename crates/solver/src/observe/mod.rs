//! What a run records: observables sampled through the integrators' dense output, leading-pulse
//! and record peaks, histories, and the energy ledger's bookkeeping along the run ([`probes`]); steady-state amplitudes, phases
//! and transmissions over a window of whole periods ([`steady`]).

pub mod probes;
pub mod steady;
