//! Prints the leading peaks in cylinders 4, 5 and 21, the pulse speeds and A21/A4 for the paper's
//! 0.98 chain (v0 = 1.06 m/s) and 0.55 chain (v0 = 1.3 m/s) at μ = 0, 4, 6 kg/s, beside the
//! paper's values (MODEL.md). Run: `cargo run --release -p chainsweep-solver --example paper_numbers`.

use chainsweep_solver::model::ChainSpec;
use chainsweep_solver::probes::Probe;
use chainsweep_solver::scene::{run, IntegratorSpec, Scene};

fn main() {
    let cases: [(&str, ChainSpec, f64); 2] = [
        ("0.98 chain", ChainSpec::chain_098(50), 1.06),
        ("0.55 chain", ChainSpec::chain_055(50), 1.3),
    ];
    println!(
        "{:<11} {:>4} {:>9} {:>9} {:>9} {:>8} {:>10} {:>10} {:>9} {:>11}",
        "chain",
        "mu",
        "F4 (N)",
        "F5 (N)",
        "F21 (N)",
        "A21/A4",
        "c4-5 (m/s)",
        "c4-21(m/s)",
        "vmax(m/s)",
        "drift"
    );
    for (name, spec, v0) in cases {
        for mu in [0.0, 4.0, 6.0] {
            let mut scene = Scene::new(spec.clone(), v0, 1e-3);
            scene.physics.damping_kg_s = mu;
            scene.integrator = IntegratorSpec::Dop853 {
                rtol: 1e-10,
                atol: None,
                max_step_s: None,
                locate_events: true,
            };
            scene.record.probes = vec![
                Probe::GaugeForce { cylinder: 4 },
                Probe::GaugeForce { cylinder: 5 },
                Probe::GaugeForce { cylinder: 21 },
                Probe::Velocity {
                    particle: 2 * 21 + 1,
                },
            ];
            let t = std::time::Instant::now();
            let out = run(&scene).expect("run");
            let el = t.elapsed();
            let (f4, f5, f21) = (&out.probes[0], &out.probes[1], &out.probes[2]);
            let cell = scene.chain.cylinder.height_m.unwrap() + scene.chain.sphere.diameter_m;
            let c45 = cell / (f5.leading_peak_time_s - f4.leading_peak_time_s);
            let c421 = 17.0 * cell / (f21.leading_peak_time_s - f4.leading_peak_time_s);
            println!(
                "{:<11} {:>4} {:>9.3} {:>9.3} {:>9.3} {:>8.4} {:>10.1} {:>10.1} {:>9.4} {:>11.2e}  ({} steps, {:.1} ms)",
                name, mu, f4.leading_peak, f5.leading_peak, f21.leading_peak,
                f21.leading_peak / f4.leading_peak, c45, c421, out.probes[3].leading_peak, out.energy_drift_max,
                out.stats.steps, el.as_secs_f64() * 1e3
            );
        }
    }
}
