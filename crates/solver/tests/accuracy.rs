//! The accuracy the benchmark's reference run claims: its leading peaks are within 1e-6 of a
//! tight reference computed by a different method, which in turn agrees with DOP853 at a tight
//! tolerance.

use crate::reference::{benchmark_scene, reference_scene, REFERENCE_RTOL};
use chainsweep_solver::scene::solve::run;
use chainsweep_solver::scene::IntegratorSpec;

#[test]
fn reference_run_meets_1e6_relative_on_leading_peaks() {
    let tight = run(&reference_scene(1e-12)).unwrap();
    // Confirm the tight solution with a different method: RK4 at a small fixed step.
    let mut rk4 = reference_scene(1e-12);
    rk4.integrator = IntegratorSpec::Rk4 { dt_s: 1e-8 };
    let rk4 = run(&rk4).unwrap();
    // The benchmarked settings (predict_switches) and DOP853's defaults at the same tolerance.
    let bench = run(&benchmark_scene()).unwrap();
    let plain = run(&reference_scene(REFERENCE_RTOL)).unwrap();
    for p in 0..2 {
        let exact = tight.probes[p].leading_peak;
        assert!(
            (rk4.probes[p].leading_peak / exact - 1.0).abs() < 2e-5,
            "RK4 disagrees on probe {p}"
        );
        for (what, out) in [("benchmark", &bench), ("default", &plain)] {
            let err = (out.probes[p].leading_peak / exact - 1.0).abs();
            assert!(
                err <= 1e-6,
                "{what} settings, probe {p}: relative error {err:e} at rtol {REFERENCE_RTOL:e}"
            );
        }
    }
    assert!(bench.energy_drift_max < 1e-5 && plain.energy_drift_max < 1e-5);
    // Prediction is what makes the benchmark fast: it must keep saving most of the work.
    assert!(
        3 * bench.stats.rhs_evals < 2 * plain.stats.rhs_evals,
        "{:?} vs {:?}",
        bench.stats,
        plain.stats
    );
    // The peak in cylinder 21 is the paper's "109 -> 57 N" case (docs/MODEL.md): about 56.4 N here.
    assert!(
        (tight.probes[1].leading_peak - 56.38).abs() < 0.01,
        "{}",
        tight.probes[1].leading_peak
    );
}
