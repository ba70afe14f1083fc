//! What a run records: observables sampled through the integrators' dense output, leading-pulse
//! and record peaks, histories, and the energy ledger's bookkeeping along the run ([`probes`]); steady-state amplitudes, phases
//! and transmissions over a window of whole periods ([`steady`]); the energy through every contact
//! and each particle's largest kinetic energy ([`flow`]).

pub mod flow;
pub mod probes;
pub mod steady;
