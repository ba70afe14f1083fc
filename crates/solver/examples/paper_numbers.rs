//! The leading peaks in cylinders 4, 5 and 21, the pulse speeds and A21/A4 for the paper's 0.98
//! chain (v0 = 1.06 m/s) and 0.55 chain (v0 = 1.3 m/s) at μ = 0, 4, 6 kg/s, beside the paper's
//! values from docs/MODEL.md. 50 cylinders (no wall reflection reaches cylinder 21 in 1 ms), gravity on,
//! gauge forces with the static preload included, leading-pulse peaks.
//!
//! Run: `cargo run --release -p chainsweep-solver --example paper_numbers`.

use chainsweep_solver::chain::model::{Chain, ChainSpec};
use chainsweep_solver::observe::probes::Probe;
use chainsweep_solver::scene::solve::run;
use chainsweep_solver::scene::{IntegratorSpec, Scene};
use chainsweep_solver::AdaptiveOptions;

fn main() {
    let cases: [(&str, ChainSpec, f64, [&str; 3]); 2] = [
        (
            "0.98",
            ChainSpec::chain_098(50),
            1.06,
            [
                "paper: speed 648 m/s, v_max 0.74 m/s, F4 ~110 N (tuned to experiment)",
                "paper: (no number)",
                "paper: A21/A4 decreases ~40 %",
            ],
        ),
        (
            "0.55",
            ChainSpec::chain_055(50),
            1.3,
            [
                "paper: F4 111 N -> F5 107 N, speed 733 m/s (4-5), A21/A4 ~0.6",
                "paper: F21 109 -> 59 N",
                "paper: F21 109 -> 57 N (~50 %)",
            ],
        ),
    ];
    println!(
        "{:<5} {:>3} {:>8} {:>8} {:>8} {:>7} {:>9} {:>9} {:>8} {:>9}",
        "chain",
        "mu",
        "F4 (N)",
        "F5 (N)",
        "F21 (N)",
        "A21/A4",
        "c45 (m/s)",
        "c4_21",
        "vmax",
        "drift"
    );
    for (name, spec, v0, paper) in cases {
        for (k, mu) in [0.0, 4.0, 6.0].into_iter().enumerate() {
            let mut scene = Scene::new(spec.clone(), v0, 1e-3);
            scene.physics.damping_kg_s = mu;
            scene.integrator = IntegratorSpec::Dop853(AdaptiveOptions::new(1e-10));
            scene.record.probes = vec![
                Probe::GaugeForce { cylinder: 4 },
                Probe::GaugeForce { cylinder: 5 },
                Probe::GaugeForce { cylinder: 21 },
                Probe::Velocity { particle: 2 * 21 },
                Probe::Velocity {
                    particle: 2 * 21 + 1,
                },
            ];
            let out = run(&scene).expect("run");
            let cell = Chain::build(&scene.chain, &scene.physics)
                .unwrap()
                .cell_length_m
                .expect("the paper's dimer chain");
            let p = &out.probes;
            let c45 = cell / (p[1].leading_peak_time_s - p[0].leading_peak_time_s);
            let c421 = 17.0 * cell / (p[2].leading_peak_time_s - p[0].leading_peak_time_s);
            let vmax = p[3].leading_peak.max(p[4].leading_peak);
            println!(
                "{:<5} {:>3} {:>8.2} {:>8.2} {:>8.2} {:>7.3} {:>9.1} {:>9.1} {:>8.3} {:>9.1e}   {}",
                name,
                mu,
                p[0].leading_peak,
                p[1].leading_peak,
                p[2].leading_peak,
                p[2].leading_peak / p[0].leading_peak,
                c45,
                c421,
                vmax,
                out.energy_drift_max,
                paper[k]
            );
        }
    }
}
