//! One reference run (0.55 chain, 50 cylinders, μ = 6 kg/s, v0 = 1.3 m/s, 1 ms) repeated, for
//! profiling: `cargo run --release -p chainsweep-solver --example refrun -- RTOL REPEATS [predict|plain]
//! [dop853|vern6]` (`predict`: with `predict_switches`; the method, DOP853 by default).
use chainsweep_solver::chain::model::ChainSpec;
use chainsweep_solver::observe::probes::Probe;
use chainsweep_solver::scene::solve::run;
use chainsweep_solver::scene::{IntegratorSpec, Scene};
use chainsweep_solver::AdaptiveOptions;
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let rtol: f64 = args.get(1).map_or(1e-6, |s| s.parse().unwrap());
    let repeats: usize = args.get(2).map_or(20, |s| s.parse().unwrap());
    let mut s = Scene::new(ChainSpec::chain_055(50), 1.3, 1e-3);
    s.physics.damping_kg_s = 6.0;
    let options = AdaptiveOptions {
        predict_switches: args.get(3).is_some_and(|a| a == "predict"),
        atol: std::env::var("CS_ATOL").ok().map(|v| v.parse().unwrap()),
        ..AdaptiveOptions::new(rtol)
    };
    s.integrator = match args.get(4).map_or("dop853", String::as_str) {
        "dop853" => IntegratorSpec::Dop853(options),
        "vern6" => IntegratorSpec::Vern6(options),
        other => panic!("unknown method `{other}`; allowed: dop853, vern6"),
    };
    s.record.probes = vec![
        Probe::GaugeForce { cylinder: 4 },
        Probe::GaugeForce { cylinder: 21 },
    ];
    let mut times = Vec::new();
    let mut out = None;
    for _ in 0..repeats {
        let t = std::time::Instant::now();
        out = Some(run(&s).unwrap());
        times.push(t.elapsed().as_secs_f64() * 1e3);
    }
    times.sort_by(|a, b| a.partial_cmp(b).unwrap());
    let o = out.unwrap();
    println!(
        "{} rtol {rtol:e}: median {:.3} ms, min {:.3} ms; {:?}; F21 {:.9}",
        o.method,
        times[times.len() / 2],
        times[0],
        o.stats,
        o.probes[1].leading_peak
    );
    println!(
        "F4 {:.9} drift {:.3e}",
        o.probes[0].leading_peak, o.energy_drift_max
    );
}
