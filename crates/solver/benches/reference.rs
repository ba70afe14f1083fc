//! The reference run of the speed targets (docs/PERFORMANCE.md), shared by `benches/solver.rs` and
//! the tests (`tests/accuracy.rs`, `tests/paper_bitwise.rs`): the 0.55 chain (3.77 g cylinders,
//! 50 cylinders), μ = 6 kg/s, v0 = 1.3 m/s, 1 ms simulated, with the leading peaks in cylinders 4
//! and 21 recorded.

// The crate root's names, not module paths: the bench comparison builds this file at earlier
// revisions too, whose modules were laid out differently.
use chainsweep_solver::{AdaptiveOptions, ChainSpec, IntegratorSpec, Probe, Scene};

/// DOP853 tolerance at which the leading peak in cylinder 21 is within 1e-6 (relative) of a tight
/// reference, with and without `predict_switches`; `tests/accuracy.rs` checks it.
pub const REFERENCE_RTOL: f64 = 5e-8;

/// The reference scene under DOP853's default settings at a given tolerance.
pub fn reference_scene(rtol: f64) -> Scene {
    let mut scene = Scene::new(ChainSpec::chain_055(50), 1.3, 1e-3);
    scene.physics.damping_kg_s = 6.0;
    scene.integrator = IntegratorSpec::Dop853(AdaptiveOptions::new(rtol));
    scene.record.probes = vec![
        Probe::GaugeForce { cylinder: 4 },
        Probe::GaugeForce { cylinder: 21 },
    ];
    scene
}

/// The reference run as benchmarked: DOP853 at [`REFERENCE_RTOL`] with steps ended on predicted
/// contact switches (`predict_switches`), the fastest settings found that meet the 1e-6.
pub fn benchmark_scene() -> Scene {
    let mut scene = reference_scene(REFERENCE_RTOL);
    scene.integrator = IntegratorSpec::Dop853(AdaptiveOptions {
        predict_switches: true,
        ..AdaptiveOptions::new(REFERENCE_RTOL)
    });
    scene
}
