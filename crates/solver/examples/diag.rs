use chainsweep_solver::model::ChainSpec;
use chainsweep_solver::probes::Probe;
use chainsweep_solver::scene::{run, IntegratorSpec, Scene};
fn main() {
    for gravity in [true, false] {
        let mut scene = Scene::new(ChainSpec::chain_098(50), 1.06, 7e-4);
        scene.physics.gravity = gravity;
        scene.integrator = IntegratorSpec::Dop853 {
            rtol: 1e-10,
            atol: None,
            max_step_s: None,
            locate_events: true,
        };
        scene.record.probes = vec![
            Probe::GaugeForce { cylinder: 4 },
            Probe::GaugeForce { cylinder: 15 },
            Probe::GaugeForce { cylinder: 30 },
            Probe::Velocity { particle: 44 },
            Probe::Velocity { particle: 45 },
        ];
        let o = run(&scene).unwrap();
        let cell = 13.3e-3;
        let t: Vec<f64> = o.probes.iter().map(|p| p.leading_peak_time_s).collect();
        println!("gravity {gravity}: c4-15 {:.1} c15-30 {:.1} vmax sphere {:.4} cyl {:.4} F15 {:.2} F30 {:.2}", 11.0*cell/(t[1]-t[0]), 15.0*cell/(t[2]-t[1]), o.probes[3].leading_peak, o.probes[4].leading_peak, o.probes[1].leading_peak, o.probes[2].leading_peak);
    }
    for rtol in [1e-9, 1e-10, 1e-11, 1e-12, 1e-13] {
        let mut scene = Scene::new(ChainSpec::chain_055(20), 1.3, 6e-4);
        scene.integrator = IntegratorSpec::Dop853 {
            rtol,
            atol: None,
            max_step_s: None,
            locate_events: true,
        };
        scene.record.min_overlap = true;
        let o = run(&scene).unwrap();
        let gaps = o
            .min_overlap_m
            .unwrap()
            .iter()
            .filter(|&&d| d <= 0.0)
            .count();
        println!(
            "mu0 rtol {rtol:e}: drift {:.2e} steps {} rejected {} events {} evals {} opened {gaps}",
            o.energy_drift_max, o.stats.steps, o.stats.rejected, o.stats.events, o.stats.rhs_evals
        );
    }
}
