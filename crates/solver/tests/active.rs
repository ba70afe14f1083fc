//! Long chains integrated only where they move (`chainsweep_solver::scene::active`): the same probes,
//! histories and ledger as the whole chain within the run's tolerance, and the whole chain
//! whenever a scene does not qualify.

use chainsweep_solver::chain::model::CylinderMass;
use chainsweep_solver::scene::active::MIN_PARTICLES;
use chainsweep_solver::scene::solve::{run, RunOutput};
use chainsweep_solver::scene::{IntegratorSpec, Scene};
use chainsweep_solver::{integrates_moving_part, ActiveRegion, AdaptiveOptions, ChainSpec, Probe};

/// The paper's 0.55 chain (μ = 6 kg/s, 1.3 m/s) lengthened to `cylinders`, 1 ms, DOP853 at
/// `rtol`, gauges in cylinders 4, 21 and 30 (reached by the pulse), 60 and 250 (not reached), the
/// wall force, and the contact forces on both sides of particle 2·60 (1 µs histories).
fn long_scene(cylinders: usize, gravity: bool, rtol: f64) -> Scene {
    let mut s = Scene::new(ChainSpec::chain_055(cylinders), 1.3, 1e-3);
    s.physics.damping_kg_s = 6.0;
    s.physics.gravity = gravity;
    s.integrator = IntegratorSpec::Dop853(AdaptiveOptions::new(rtol));
    s.record.probes = vec![
        Probe::GaugeForce { cylinder: 4 },
        Probe::GaugeForce { cylinder: 21 },
        Probe::GaugeForce { cylinder: 30 },
        Probe::GaugeForce { cylinder: 60 },
        Probe::GaugeForce { cylinder: 250 },
        Probe::ContactForce { contact: 120 },
        Probe::ContactForce { contact: 121 },
        Probe::Velocity { particle: 100 },
        Probe::WallForce,
    ];
    s.record.history = true;
    s.record.history_interval_s = 1e-6;
    s.record.min_overlap = true;
    s
}

fn with(scene: &Scene, mode: ActiveRegion) -> RunOutput {
    let mut s = scene.clone();
    s.active_region = mode;
    run(&s).unwrap()
}

/// Relative difference of two values against a scale.
fn rel(a: f64, b: f64, scale: f64) -> f64 {
    (a - b).abs() / scale
}

/// Largest difference of two runs' histories over every probe, relative to each probe's scale
/// (the leading pulse's peak for forces, the striker velocity for velocities).
fn history_error(a: &RunOutput, b: &RunOutput) -> Vec<f64> {
    let (ha, hb) = (a.history.as_ref().unwrap(), b.history.as_ref().unwrap());
    assert_eq!(ha.time_s, hb.time_s);
    ha.values
        .iter()
        .zip(&hb.values)
        .enumerate()
        .map(|(p, (x, y))| {
            let scale = if p == 7 { 1.3 } else { 110.0 };
            x.iter()
                .zip(y)
                .map(|(u, v)| rel(*u, *v, scale))
                .fold(0.0, f64::max)
        })
        .collect()
}

/// Asserts that a run of the moving part is as accurate as the run of the whole chain: both
/// against the whole chain at a tolerance a hundred times tighter (what `--verify` runs), on every
/// probe's history, peaks and the ledger; the moving part's error may exceed the whole chain's by
/// a factor `slack` (their step sequences differ) or by `floor` relative.
fn assert_as_accurate_as_the_whole_chain(scene: &Scene, slack: f64, floor: f64) -> RunOutput {
    let part = with(scene, ActiveRegion::Auto);
    let whole = with(scene, ActiveRegion::Off);
    let mut tight = scene.clone();
    tight.integrator = match scene.integrator {
        IntegratorSpec::Dop853(o) => IntegratorSpec::Dop853(AdaptiveOptions::new(o.rtol / 100.0)),
        IntegratorSpec::Ros34pw2(o) => {
            IntegratorSpec::Ros34pw2(AdaptiveOptions::new(o.rtol / 100.0))
        }
        other => other,
    };
    let reference = with(&tight, ActiveRegion::Off);
    let n = 2 * match scene.chain {
        ChainSpec::Dimer(ref d) => d.cylinders,
        _ => unreachable!("dimer chains only"),
    } + 1;
    let k = part
        .active_particles
        .expect("a long chain at rest qualifies");
    assert!(
        k < n / 2,
        "the pulse reaches about 90 particles in 1 ms; {k} of {n} were integrated"
    );
    assert_eq!(whole.active_particles, None);
    let (ep, ew) = (
        history_error(&part, &reference),
        history_error(&whole, &reference),
    );
    for p in 0..ep.len() {
        assert!(
            ep[p] <= slack * ew[p] + floor,
            "probe {p}: history error {:e} against the whole chain's {:e}",
            ep[p],
            ew[p]
        );
    }
    // The leading peaks' largest error over the gauges the pulse reaches: each run's error at one
    // gauge depends on where its steps happen to fall, the largest over several much less.
    let peak_error = |run: &RunOutput| {
        (0..3)
            .map(|p| {
                let exact = reference.probes[p].leading_peak;
                assert!(run.probes[p].leading_peak > 1.0, "probe {p} saw the pulse");
                rel(run.probes[p].leading_peak, exact, exact)
            })
            .fold(0.0, f64::max)
    };
    let (a, b) = (peak_error(&part), peak_error(&whole));
    eprintln!("leading peaks' largest error: moving part {a:e}, whole chain {b:e}");
    assert!(
        a <= slack * b + floor,
        "leading peaks' largest error {a:e} against the whole chain's {b:e}"
    );
    // Not reached: the record holds the static value only (the equilibrium's).
    let (a, b) = (part.probes[4].record_max, reference.probes[4].record_max);
    assert!(rel(a, b, 110.0) <= 1e-12, "{a} against {b}");
    let scale = part.impact_energy_j;
    let (ea, eb) = (part.final_energy.total(), reference.final_energy.total());
    // The whole chain's energy error: at the end, or over the run (its ledger's drift), the larger;
    // its value at the end alone may happen to be small (measured, 1e-9 with damping: 3.8e-9 at
    // the end against 1.4e-8 over the run, the moving part's 2.1e-8 and 2.9e-8).
    let whole_error = rel(whole.final_energy.total(), eb, scale).max(whole.energy_drift_max);
    assert!(
        rel(ea, eb, scale) <= slack * whole_error + floor,
        "{ea} against {eb} (the whole chain's error {whole_error:e})"
    );
    assert!(part.energy_drift_max <= slack * whole.energy_drift_max + floor);
    assert!(
        part.momentum_residual_max < 1e-9,
        "{}",
        part.momentum_residual_max
    );
    let (ma, mb) = (
        part.min_overlap_m.as_ref().unwrap(),
        reference.min_overlap_m.unwrap(),
    );
    assert_eq!(ma.len(), mb.len());
    for (c, (a, b)) in ma.iter().zip(&mb).enumerate() {
        assert!(
            (a - b).abs() <= (slack + floor) * part.max_overlap_m,
            "contact {c}: minimum overlap {a} against {b}"
        );
    }
    part
}

#[test]
fn long_chain_with_gravity_is_as_accurate_as_the_whole_chain() {
    let part = assert_as_accurate_as_the_whole_chain(&long_scene(300, true, 1e-9), 3.0, 1e-9);
    // The pulse reaches about 90 particles in 1 ms; the integrated part ends a watch and a block
    // beyond the front, not the chain's 601 particles.
    let k = part.active_particles.unwrap();
    assert!(k <= 120, "{k} particles integrated");
}

#[test]
fn long_chain_without_gravity_is_as_accurate_as_the_whole_chain() {
    assert_as_accurate_as_the_whole_chain(&long_scene(300, false, 1e-9), 3.0, 1e-9);
}

#[test]
fn accuracy_follows_the_tolerance() {
    assert_as_accurate_as_the_whole_chain(&long_scene(300, true, 1e-6), 3.0, 1e-6);
}

#[test]
fn the_integrated_part_does_not_depend_on_the_chain_length() {
    let a = with(&long_scene(300, true, 1e-9), ActiveRegion::Auto);
    let b = with(&long_scene(2000, true, 1e-9), ActiveRegion::Auto);
    assert_eq!(a.active_particles, b.active_particles);
    for p in 0..3 {
        let (x, y) = (a.probes[p].leading_peak, b.probes[p].leading_peak);
        assert!(rel(x, y, y) <= 1e-9, "probe {p}: {x} against {y}");
    }
}

#[test]
fn the_papers_chain_integrates_its_moving_part_as_accurately_as_the_whole_chain() {
    // The Fig. 8 chain (50 cylinders, 101 particles) under the sweep's integrator over a few of its
    // points (mass ratio × damping): the leading peaks in cylinders 4 and 21 against the whole
    // chain at a tolerance a hundred times tighter, the largest error over the points as small as
    // the whole chain's own (one point's error depends on where its steps happen to fall).
    let integrator = |rtol: f64| {
        let mut o = AdaptiveOptions::new(rtol);
        o.predict_switches = true;
        IntegratorSpec::Dop853(o)
    };
    let (mut part_error, mut whole_error) = (0.0_f64, 0.0_f64);
    let (mut part_rhs, mut whole_rhs) = (0, 0);
    for mass_ratio in [0.2, 0.55, 1.0] {
        for damping in [0.0, 6.0] {
            let mut chain = ChainSpec::chain_055(50);
            if let ChainSpec::Dimer(d) = &mut chain {
                d.cylinder.mass = CylinderMass::HeavyCylinders { mass_ratio };
            }
            let mut s = Scene::new(chain, 1.3, 6e-4);
            s.physics.damping_kg_s = damping;
            s.physics.gravity = true;
            s.record.probes = vec![
                Probe::GaugeForce { cylinder: 4 },
                Probe::GaugeForce { cylinder: 21 },
            ];
            s.integrator = integrator(1e-9);
            let part = with(&s, ActiveRegion::Auto);
            let whole = with(&s, ActiveRegion::Off);
            s.integrator = integrator(1e-11);
            let reference = with(&s, ActiveRegion::Off);
            let k = part.active_particles.expect("the paper's chain qualifies");
            assert!(k < 101, "{k} particles integrated");
            for p in 0..2 {
                let exact = reference.probes[p].leading_peak;
                part_error = part_error.max(rel(part.probes[p].leading_peak, exact, exact));
                whole_error = whole_error.max(rel(whole.probes[p].leading_peak, exact, exact));
            }
            part_rhs += part.stats.rhs_evals;
            whole_rhs += whole.stats.rhs_evals;
        }
    }
    eprintln!("largest error: moving part {part_error:e}, whole chain {whole_error:e}; right-hand sides {part_rhs} against {whole_rhs}");
    assert!(
        part_error <= 3.0 * whole_error && part_error < 1e-7,
        "largest error {part_error:e} against the whole chain's {whole_error:e}"
    );
    // Restarts at a grown part cost a right-hand side each, not a new start-up.
    assert!(
        part_rhs < whole_rhs * 11 / 10,
        "{part_rhs} against {whole_rhs}"
    );
}

#[test]
fn scenes_that_do_not_qualify_run_the_whole_chain() {
    let base = long_scene(300, true, 1e-9);
    let whole = |s: &Scene| {
        let out = run(s).unwrap();
        assert_eq!(out.active_particles, None, "{s:?}");
        assert!(!integrates_moving_part(s), "{s:?}");
    };
    // Off.
    let mut s = base.clone();
    s.active_region = ActiveRegion::Off;
    whole(&s);
    // A chain too short for the part at rest to pay for the restarts.
    let mut s = base.clone();
    s.chain = ChainSpec::chain_055(10);
    s.record.probes.truncate(1);
    const { assert!(2 * 10 + 1 < MIN_PARTICLES) };
    whole(&s);
    // No wall under gravity: the whole chain falls.
    let mut s = base.clone();
    s.physics.wall = false;
    s.record.probes.truncate(4);
    whole(&s);
    // A static force on the chain (a precompression wave runs ahead of the pulse).
    let mut s = base.clone();
    s.physics.precompression_force_n = 5.0;
    whole(&s);
    // Fixed-step methods have no tolerance to tie the margin to.
    let mut s = base.clone();
    s.integrator = IntegratorSpec::Rk4 { dt_s: 1e-8 };
    s.duration_s = 2e-5;
    whole(&s);
    // And a scene that qualifies does use it, as the run identity is told beforehand.
    assert!(run(&base).unwrap().active_particles.is_some());
    assert!(integrates_moving_part(&base));
}

#[test]
fn stiff_method_integrates_the_moving_part_too() {
    let mut s = long_scene(300, true, 1e-6);
    s.integrator = IntegratorSpec::Ros34pw2(AdaptiveOptions::new(1e-6));
    s.duration_s = 2e-4;
    let part = with(&s, ActiveRegion::Auto);
    let whole = with(&s, ActiveRegion::Off);
    s.integrator = IntegratorSpec::Ros34pw2(AdaptiveOptions::new(1e-8));
    let exact = with(&s, ActiveRegion::Off).probes[0].leading_peak;
    assert!(part.active_particles.unwrap() < 200);
    let (a, b) = (part.probes[0].leading_peak, whole.probes[0].leading_peak);
    assert!(
        rel(a, exact, exact) <= 3.0 * rel(b, exact, exact) + 1e-6,
        "{a} against {b} (reference {exact})"
    );
}

#[test]
fn serialised_scene_leaves_the_default_out() {
    let s = long_scene(300, true, 1e-9);
    let json = serde_json::to_string(&s).unwrap();
    assert!(!json.contains("active_region"), "{json}");
    let mut off = s.clone();
    off.active_region = ActiveRegion::Off;
    let json = serde_json::to_string(&off).unwrap();
    assert!(json.contains("\"active_region\":\"off\""), "{json}");
    let back: Scene = serde_json::from_str(&json).unwrap();
    assert_eq!(back, off);
    let bad = json.replace("\"off\"", "\"sometimes\"");
    let err = serde_json::from_str::<Scene>(&bad).unwrap_err().to_string();
    assert!(err.contains("auto") && err.contains("off"), "{err}");
}

#[test]
fn excited_chains_of_the_general_kernel_integrate_their_moving_part() {
    // 600 spheres without a striker, under gravity on a wall: a half-sine force pulse (the run is
    // integrated in two legs, before and after the pulse ends) and a δ-force impulse, with Hertz
    // and with a power law (the general right-hand side), against the whole chain.
    use chainsweep_solver::problems::{monodisperse, power_law};
    use chainsweep_solver::scene::Excitation;
    for law in [None, Some(power_law(1e12, 1.8))] {
        for excitation in [
            Excitation::HalfSineForce {
                amplitude_n: 40.0,
                duration_s: 5e-5,
            },
            Excitation::Impulse { velocity_m_s: 0.5 },
        ] {
            let mut s = Scene::excited(monodisperse(600, law, false), excitation.clone(), 2e-4);
            s.physics.damping_kg_s = 2.0;
            s.integrator = IntegratorSpec::Dop853(AdaptiveOptions::new(1e-10));
            s.record.probes = vec![
                Probe::ParticleForce { particle: 5 },
                Probe::ParticleForce { particle: 12 },
                Probe::ParticleForce { particle: 300 },
            ];
            let part = with(&s, ActiveRegion::Auto);
            let whole = with(&s, ActiveRegion::Off);
            let k = part.active_particles.expect("qualifies");
            assert!(k < 300, "{law:?} {excitation:?}: {k}");
            for p in 0..2 {
                let (a, b) = (part.probes[p].record_max, whole.probes[p].record_max);
                assert!(
                    a > 1.0 && rel(a, b, b) <= 1e-7,
                    "{law:?} {excitation:?} probe {p}: {a} against {b}"
                );
            }
            let (a, b) = (part.probes[2].record_max, whole.probes[2].record_max);
            assert!(rel(a, b, 40.0) <= 1e-9, "{a} against {b}");
            let scale = part.impact_energy_j;
            let (ea, eb) = (part.final_energy.total(), whole.final_energy.total());
            assert!(
                rel(ea, eb, scale) <= 1e-7,
                "{law:?} {excitation:?}: {ea} against {eb}"
            );
            assert!(part.energy_drift_max < 1e-7, "{}", part.energy_drift_max);
            assert!(
                part.momentum_residual_max < 1e-7,
                "{}",
                part.momentum_residual_max
            );
        }
    }
}
