//! What a run records: observables sampled through the integrators' dense output, leading-pulse
//! and record peaks, histories, and the energy ledger's bookkeeping along the run ([`probes`]); steady-state amplitudes, phases
//! and transmissions over a window of whole periods ([`steady`]); the energy through every contact
//! and each particle's largest kinetic energy ([`flow`]).

pub mod flow;
mod peaks;
pub use peaks::brent_max;
pub mod probes;
pub mod steady;

/// Instant `j` of the sampling grid that starts at `t0` with `interval` between instants: the one
/// expression every sampling loop, count and test places an instant with (the observers, and the
/// store checking and writing a run's time axes from 0), so that an instant is the same bits
/// wherever it is computed.
#[inline(always)]
pub fn grid_instant(t0: f64, j: u64, interval: f64) -> f64 {
    t0 + j as f64 * interval
}
