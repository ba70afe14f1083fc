//! Error of the leading peak in cylinder 21 against cost, for the reference run of `make bench`
//! (0.55 chain, 50 cylinders, μ = 6 kg/s, v0 = 1.3 m/s, 1 ms), over a ladder of settings of every
//! integrator, DOP853 and Verner's 6(5) also with `predict_switches` (`dop853+p`, `vern6+p`). Run:
//! `cargo run --release -p chainsweep-solver --example rtol_scan`.

use chainsweep_solver::chain::model::ChainSpec;
use chainsweep_solver::observe::probes::Probe;
use chainsweep_solver::scene::solve::run;
use chainsweep_solver::scene::{IntegratorSpec, Scene};
use chainsweep_solver::AdaptiveOptions;

fn scene(integrator: IntegratorSpec) -> Scene {
    let mut s = Scene::new(ChainSpec::chain_055(50), 1.3, 1e-3);
    s.physics.damping_kg_s = 6.0;
    s.integrator = integrator;
    s.record.probes = vec![
        Probe::GaugeForce { cylinder: 4 },
        Probe::GaugeForce { cylinder: 21 },
    ];
    s
}

fn time_run(s: &Scene) -> (chainsweep_solver::RunOutput, f64) {
    let mut best = f64::INFINITY;
    let mut out = None;
    for _ in 0..5 {
        let t = std::time::Instant::now();
        let o = run(s).expect("run");
        best = best.min(t.elapsed().as_secs_f64());
        out = Some(o);
    }
    (out.unwrap(), best)
}

fn main() {
    let reference = run(&scene(IntegratorSpec::Dop853(AdaptiveOptions::new(1e-13)))).unwrap();
    let f_ref = reference.probes[1].leading_peak;
    let t_ref = reference.probes[1].leading_peak_time_s;
    println!(
        "reference F21 = {f_ref:.12} N at {t_ref:.12e} s (dop853 rtol 1e-13, drift {:.1e})",
        reference.energy_drift_max
    );
    println!(
        "{:<8} {:>10} {:>12} {:>12} {:>10} {:>9} {:>10} {:>9}",
        "method",
        "setting",
        "rel err F21",
        "err t21 (s)",
        "drift",
        "steps",
        "rhs evals",
        "ms (min)"
    );
    let mut ladder: Vec<IntegratorSpec> = Vec::new();
    let dop_rtols = [
        1e-5, 3e-6, 1e-6, 5e-7, 3e-7, 2e-7, 1e-7, 5e-8, 1e-8, 1e-9, 1e-10, 1e-11,
    ];
    for rtol in dop_rtols {
        ladder.push(IntegratorSpec::Dop853(AdaptiveOptions::new(rtol)));
    }
    for rtol in dop_rtols {
        ladder.push(IntegratorSpec::Dop853(AdaptiveOptions {
            predict_switches: true,
            ..AdaptiveOptions::new(rtol)
        }));
    }
    let vern_rtols = [
        1e-5, 3e-6, 1e-6, 5e-7, 3e-7, 2e-7, 1e-7, 5e-8, 3e-8, 2e-8, 1e-8, 1e-9, 1e-10,
    ];
    for predict_switches in [false, true] {
        for rtol in vern_rtols {
            ladder.push(IntegratorSpec::Vern6(AdaptiveOptions {
                predict_switches,
                ..AdaptiveOptions::new(rtol)
            }));
        }
    }
    for dt in [4e-7, 2e-7, 1e-7, 5e-8] {
        ladder.push(IntegratorSpec::Rk4 { dt_s: dt });
    }
    for dt in [1e-7, 5e-8, 2e-8, 1e-8] {
        ladder.push(IntegratorSpec::Verlet { dt_s: dt });
    }
    for rtol in [1e-6, 1e-7, 1e-8] {
        ladder.push(IntegratorSpec::Ros34pw2(AdaptiveOptions::new(rtol)));
    }
    for ig in ladder {
        let setting = match ig {
            IntegratorSpec::Dop853(AdaptiveOptions { rtol, .. })
            | IntegratorSpec::Vern6(AdaptiveOptions { rtol, .. })
            | IntegratorSpec::Ros34pw2(AdaptiveOptions { rtol, .. }) => {
                format!("rtol {rtol:.0e}")
            }
            IntegratorSpec::Rk4 { dt_s } | IntegratorSpec::Verlet { dt_s } => {
                format!("dt {dt_s:.0e}")
            }
        };
        let predicting = ig.adaptive_options().is_some_and(|o| o.predict_switches);
        let (o, secs) = time_run(&scene(ig));
        let method = if predicting {
            format!("{}+p", o.method)
        } else {
            o.method.to_string()
        };
        let p = &o.probes[1];
        println!(
            "{:<8} {:>10} {:>12.2e} {:>12.2e} {:>10.2e} {:>9} {:>10} {:>9.3}",
            method,
            setting,
            (p.leading_peak - f_ref).abs() / f_ref,
            (p.leading_peak_time_s - t_ref).abs(),
            o.energy_drift_max,
            o.stats.steps,
            o.stats.rhs_evals,
            secs * 1e3
        );
    }
}
