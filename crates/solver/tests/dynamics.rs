//! Physics that a wrong model, a wrong integrator or a wrong probe would break, each checked
//! against a number: closed forms, conservation laws, exact scaling laws, Eq. (13).

use chainsweep_solver::chain::model::{Chain, ChainSpec, PhysicsSpec};
use chainsweep_solver::integrate::{
    Control, DenseStep, Dop853, IntegrationStats, Integrator, OdeSystem, Rk4, StepObserver,
    VelocityVerlet,
};
use chainsweep_solver::motion::system::ChainSystem;
use chainsweep_solver::observe::probes::Probe;
use chainsweep_solver::scene::solve::run;
use chainsweep_solver::scene::{IntegratorSpec, Scene};
use chainsweep_solver::{ActiveRegion, AdaptiveOptions};

fn dop(rtol: f64) -> IntegratorSpec {
    IntegratorSpec::Dop853(AdaptiveOptions::new(rtol))
}

fn free_physics() -> PhysicsSpec {
    PhysicsSpec {
        gravity: false,
        wall: false,
        ..PhysicsSpec::default()
    }
}

/// ∫₀¹ (1 − x^{5/2})^{-1/2} dx by Simpson's rule after x = 1 − s², which removes the endpoint
/// singularity.
fn hertz_duration_integral() -> f64 {
    let f = |s: f64| {
        if s == 0.0 {
            2.0 / 2.5f64.sqrt()
        } else {
            2.0 * s / (1.0 - (1.0 - s * s).powf(2.5)).sqrt()
        }
    };
    let n = 20_000;
    let h = 1.0 / n as f64;
    let mut sum = f(0.0) + f(1.0);
    for i in 1..n {
        sum += f(i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
    }
    sum * h / 3.0
}

/// Records when the striker contact closes and opens, located on the dense output by bisection.
struct ContactTimer {
    n: usize,
    last_overlap: f64,
    opened_at: Option<f64>,
    max_overlap: f64,
}

impl StepObserver for ContactTimer {
    fn on_start(&mut self, _t0: f64, y0: &[f64]) {
        self.last_overlap = y0[0] - y0[1];
    }
    fn on_step(&mut self, step: &dyn DenseStep) -> Control {
        let overlap = |t: f64| step.eval_component(t, 0) - step.eval_component(t, 1);
        let y = step.y_end();
        let now = y[0] - y[1];
        // Peak overlap: where the relative velocity changes sign.
        let rel = |t: f64| step.eval_component(t, self.n) - step.eval_component(t, self.n + 1);
        let (t0, t1) = (step.t_start(), step.t_end());
        if rel(t0) > 0.0 && rel(t1) <= 0.0 {
            let (mut a, mut b) = (t0, t1);
            for _ in 0..200 {
                let m = 0.5 * (a + b);
                if rel(m) > 0.0 {
                    a = m
                } else {
                    b = m
                }
            }
            self.max_overlap = overlap(0.5 * (a + b));
        }
        if self.last_overlap > 0.0 && now <= 0.0 && self.opened_at.is_none() {
            let (mut a, mut b) = (t0, t1);
            for _ in 0..200 {
                let m = 0.5 * (a + b);
                if overlap(m) > 0.0 {
                    a = m
                } else {
                    b = m
                }
            }
            self.opened_at = Some(0.5 * (a + b));
        }
        self.last_overlap = now;
        Control::Continue
    }
}

#[test]
fn two_body_hertz_impact_matches_closed_form() {
    // Striker on a single free sphere: no cylinders, no wall, no gravity, no damping.
    let chain = Chain::build(&ChainSpec::chain_098(0), &free_physics()).unwrap();
    assert_eq!(chain.n_particles(), 2);
    let v0 = 1.3;
    let (m1, m2, a) = (chain.mass[0], chain.mass[1], chain.stiffness[0]);
    let reduced = m1 * m2 / (m1 + m2);
    let delta_max = (5.0 * reduced * v0 * v0 / (4.0 * a)).powf(0.4);
    let force_max = a * delta_max.powf(1.5);
    let integral = hertz_duration_integral();
    // Cross-check the quadrature with (2/5) B(2/5, 1/2) = (2/5) Γ(2/5) Γ(1/2) / Γ(9/10).
    let beta_form =
        0.4 * 2.218_159_543_757_688 * std::f64::consts::PI.sqrt() / 1.068_628_702_119_319;
    assert!(
        (integral - beta_form).abs() < 1e-9,
        "{integral} vs {beta_form}"
    );
    let duration = 2.0 * delta_max / v0 * integral;

    let mut sys = ChainSystem::<false, false, false, false>::new(&chain);
    let y0 = vec![0.0, 0.0, v0, 0.0];
    let mut timer = ContactTimer {
        n: 2,
        last_overlap: 0.0,
        opened_at: None,
        max_overlap: 0.0,
    };
    let mut ig = Dop853::new(1e-13, 1e-13);
    ig.atol_scale = Some(vec![delta_max, delta_max, v0, v0]);
    let t_end = 2.0 * duration;
    ig.integrate(&mut sys, 0.0, &y0, t_end, 1_000_000, &mut timer)
        .unwrap();
    let opened = timer.opened_at.expect("contact must open");
    assert!(
        (opened / duration - 1.0).abs() < 1e-8,
        "duration {opened} vs closed form {duration}"
    );
    assert!((timer.max_overlap / delta_max - 1.0).abs() < 1e-9);

    // The same through the scene API and its peak summaries: peak force and its time (T/2).
    let mut scene = Scene::new(ChainSpec::chain_098(0), v0, t_end);
    scene.physics = free_physics();
    scene.integrator = dop(1e-12);
    scene.record.probes = vec![
        Probe::ContactForce { contact: 1 },
        Probe::Velocity { particle: 1 },
        Probe::Velocity { particle: 2 },
    ];
    let out = run(&scene).unwrap();
    let peak = out.probes[0];
    assert!(
        (peak.leading_peak / force_max - 1.0).abs() < 1e-8,
        "{} vs {force_max}",
        peak.leading_peak
    );
    assert!((peak.leading_peak_time_s / (0.5 * duration) - 1.0).abs() < 1e-6);
    // Elastic collision of equal masses: the striker stops, the sphere leaves at v0 (restitution 1).
    let e = out.final_energy;
    assert!((e.kinetic / out.impact_energy_j - 1.0).abs() < 1e-10);
    let v2 = out.probes[2].record_max;
    assert!((v2 / v0 - 1.0).abs() < 1e-9, "sphere leaves at {v2} m/s");
}

#[test]
fn gravity_loaded_chain_at_rest_stays_at_rest() {
    let chain = Chain::build(&ChainSpec::chain_055(30), &PhysicsSpec::default()).unwrap();
    let n = chain.n_particles();
    let mut sys = ChainSystem::<true, false, true, false>::new(&chain);
    // Striker held 1 mm above sphere 2 and released at rest: in 1 ms it falls 4.9 µm and never touches.
    let mut y0 = chain.equilibrium_position.clone();
    y0[0] -= 1e-3;
    y0.extend(vec![0.0; n]);
    y0.push(0.0);
    struct MaxMotion {
        n: usize,
        origin: Vec<f64>,
        max_v: f64,
        max_dx: f64,
    }
    impl StepObserver for MaxMotion {
        fn on_start(&mut self, _t0: f64, _y0: &[f64]) {}
        fn on_step(&mut self, s: &dyn DenseStep) -> Control {
            let y = s.y_end();
            for i in 1..self.n {
                self.max_v = self.max_v.max(y[self.n + i].abs());
                self.max_dx = self.max_dx.max((y[i] - self.origin[i]).abs());
            }
            Control::Continue
        }
    }
    let mut obs = MaxMotion {
        n,
        origin: chain.equilibrium_position.clone(),
        max_v: 0.0,
        max_dx: 0.0,
    };
    let stats = Dop853::new(1e-12, 1e-15)
        .integrate(&mut sys, 0.0, &y0, 1e-3, 1_000_000, &mut obs)
        .unwrap();
    assert!(stats.steps > 0);
    // Against pulse scales of ~1 m/s and ~5 µm: nothing moves beyond the integrator's tolerance.
    assert!(obs.max_v < 1e-12, "chain moved at {} m/s", obs.max_v);
    assert!(obs.max_dx < 1e-15, "chain moved by {} m", obs.max_dx);
}

#[test]
fn hertz_scaling_force_and_time_without_gravity_and_damping() {
    // Without gravity and damping the equations are invariant under x → λx, t → λ^{-1/4} t, so
    // forces scale as v0^{6/5} and times as v0^{-1/5}, exactly.
    let measure = |v0: f64| {
        let mut scene = Scene::new(ChainSpec::chain_055(20), v0, 4e-4 * (1.0f64 / v0).powf(0.2));
        scene.physics.gravity = false;
        scene.integrator = dop(1e-12);
        scene.record.probes = vec![
            Probe::GaugeForce { cylinder: 4 },
            Probe::GaugeForce { cylinder: 12 },
        ];
        run(&scene).unwrap()
    };
    let (lo, hi) = (measure(0.5), measure(2.0));
    let k: f64 = 4.0;
    for p in 0..2 {
        let force_ratio = hi.probes[p].leading_peak / lo.probes[p].leading_peak;
        let time_ratio = hi.probes[p].leading_peak_time_s / lo.probes[p].leading_peak_time_s;
        assert!(
            (force_ratio / k.powf(1.2) - 1.0).abs() < 1e-6,
            "force ratio {force_ratio}"
        );
        assert!(
            (time_ratio / k.powf(-0.2) - 1.0).abs() < 1e-6,
            "time ratio {time_ratio}"
        );
    }
}

fn ledger_scene(cylinders: usize, mu: f64, duration: f64) -> Scene {
    let mut scene = Scene::new(ChainSpec::chain_055(cylinders), 1.3, duration);
    scene.physics.damping_kg_s = mu;
    scene.integrator = dop(1e-12);
    scene
}

#[test]
fn energy_ledger_closes_with_and_without_damping() {
    // 20 cylinders, 0.6 ms: the pulse reaches the wall and comes back, contacts open and close.
    for mu in [0.0, 6.0, 100.0] {
        let out = run(&ledger_scene(20, mu, 6e-4)).unwrap();
        assert!(
            out.energy_drift_max <= 1e-9,
            "μ = {mu}: drift {:e}",
            out.energy_drift_max
        );
        assert!(
            out.momentum_residual_max <= 1e-9,
            "μ = {mu}: momentum {:e}",
            out.momentum_residual_max
        );
        if mu > 0.0 {
            // Damping takes real energy out, so the ledger is not trivially closed.
            assert!(out.final_energy.dissipated > 0.05 * out.impact_energy_j);
        } else {
            assert_eq!(out.final_energy.dissipated, 0.0);
        }
    }
}

#[test]
fn event_location_makes_the_undamped_ledger_close() {
    // μ = 0: contacts behind the pulse open and close many times; without event location the
    // error estimator is fooled at every crossing and the ledger drifts far beyond the tolerance.
    let drift = |locate_events: bool| {
        let mut scene = ledger_scene(20, 0.0, 6e-4);
        scene.integrator = IntegratorSpec::Dop853(AdaptiveOptions {
            locate_events,
            ..AdaptiveOptions::new(1e-12)
        });
        scene.record.min_overlap = true;
        let out = run(&scene).unwrap();
        let opened = out
            .min_overlap_m
            .unwrap()
            .iter()
            .filter(|&&d| d <= 0.0)
            .count();
        assert!(opened > 10, "the case must open gaps, opened {opened}");
        (out.energy_drift_max, out.stats.events)
    };
    let (with, events) = drift(true);
    let (without, none) = drift(false);
    assert_eq!(none, 0);
    assert!(events > 50, "events located: {events}");
    assert!(
        with < without / 10.0,
        "drift with events {with:e}, without {without:e}"
    );
}

#[test]
fn solitary_wave_speed_agrees_with_eq_13() {
    // 0.98 chain at μ = 0, v0 = 1.06 m/s, without gravity (Eq. 13 is the solitary wave of a chain
    // without precompression): the pulse between cylinders 15 and 30 must travel at the speed
    // Eq. (13) gives for its measured maximum particle velocity.
    let mut scene = Scene::new(ChainSpec::chain_098(50), 1.06, 7e-4);
    scene.physics.gravity = false;
    scene.integrator = dop(1e-10);
    scene.record.probes = vec![
        Probe::GaugeForce { cylinder: 15 },
        Probe::GaugeForce { cylinder: 30 },
        Probe::Velocity { particle: 2 * 22 },
        Probe::Velocity {
            particle: 2 * 22 + 1,
        },
    ];
    let out = run(&scene).unwrap();
    let chain = Chain::build(&scene.chain, &scene.physics).unwrap();
    let cell = chain.cell_length_m.unwrap();
    let speed =
        15.0 * cell / (out.probes[1].leading_peak_time_s - out.probes[0].leading_peak_time_s);
    let v_m = 0.5 * (out.probes[2].leading_peak + out.probes[3].leading_peak);
    // Eq. (14) for the uniform chain, written with the Hertz coefficient A of Eq. (4): two contacts
    // in series per cell of mass 2m̄ give c² = A (h+2R)^{5/2} / (2^{5/2} m̄), which is Eq. (14) when
    // both materials are equal.
    let m_bar = 0.5 * (chain.mass[1] + chain.mass[2]);
    let c = (chain.stiffness[1] * cell.powf(2.5) / (2f64.powf(2.5) * m_bar)).sqrt();
    let eq13 = (16.0f64 / 25.0).powf(0.2) * c.powf(0.8) * v_m.powf(0.2);
    assert!(
        (speed / eq13 - 1.0).abs() < 0.01,
        "measured {speed} m/s vs Eq. (13) {eq13} m/s (v_m = {v_m})"
    );
    // A stationary wave: the force amplitude is the same at both gauges.
    assert!((out.probes[0].leading_peak / out.probes[1].leading_peak - 1.0).abs() < 1e-3);

    // With gravity (the paper's setting) the speed between cylinders 4 and 21 is the paper's
    // 648 m/s within 1 %.
    scene.physics.gravity = true;
    scene.record.probes = vec![
        Probe::GaugeForce { cylinder: 4 },
        Probe::GaugeForce { cylinder: 21 },
    ];
    let out = run(&scene).unwrap();
    let speed =
        17.0 * cell / (out.probes[1].leading_peak_time_s - out.probes[0].leading_peak_time_s);
    assert!(
        (speed / 648.0 - 1.0).abs() < 0.01,
        "with gravity: {speed} m/s"
    );
}

/// Error at `t_end` of a two-body damped contact that stays compressed (a smooth problem).
fn smooth_case_error(ig: &dyn Integrator, reference: &[f64]) -> (f64, IntegrationStats) {
    let physics = PhysicsSpec {
        damping_kg_s: 6.0,
        ..free_physics()
    };
    let chain = Chain::build(&ChainSpec::chain_055(0), &physics).unwrap();
    let mut sys = ChainSystem::<false, true, false, false>::new(&chain);
    let y0 = smooth_initial_state();
    struct Last(Vec<f64>);
    impl StepObserver for Last {
        fn on_start(&mut self, _t0: f64, _y0: &[f64]) {}
        fn on_step(&mut self, s: &dyn DenseStep) -> Control {
            self.0.copy_from_slice(s.y_end());
            Control::Continue
        }
    }
    let mut last = Last(vec![0.0; y0.len()]);
    let stats = ig
        .integrate(&mut sys, 0.0, &y0, SMOOTH_T_END, u64::MAX, &mut last)
        .unwrap();
    let overlap_err = ((last.0[0] - last.0[1]) - (reference[0] - reference[1])).abs() / 5e-6;
    let vel_err = ((last.0[2] - last.0[3]) - (reference[2] - reference[3])).abs();
    (overlap_err.max(vel_err), stats)
}

const SMOOTH_T_END: f64 = 1e-5;

fn smooth_initial_state() -> Vec<f64> {
    // Already compressed by 2 µm and closing at 0.5 m/s: within 10 µs the contact stays closed.
    vec![2e-6, 0.0, 0.5, 0.0, 0.0]
}

#[test]
fn observed_order_of_each_integrator() {
    let physics = PhysicsSpec {
        damping_kg_s: 6.0,
        ..free_physics()
    };
    let chain = Chain::build(&ChainSpec::chain_055(0), &physics).unwrap();
    let mut sys = ChainSystem::<false, true, false, false>::new(&chain);
    struct Last(Vec<f64>, f64);
    impl StepObserver for Last {
        fn on_start(&mut self, _t0: f64, _y0: &[f64]) {}
        fn on_step(&mut self, s: &dyn DenseStep) -> Control {
            self.0.copy_from_slice(s.y_end());
            // Keep the smallest overlap seen, to prove the case stayed smooth (compressed).
            self.1 = self.1.min(self.0[0] - self.0[1]);
            Control::Continue
        }
    }
    let y0 = smooth_initial_state();
    let mut reference = Last(vec![0.0; 5], f64::INFINITY);
    let mut tight = Dop853::new(1e-15, 1e-15);
    tight.atol_scale = Some(vec![5e-6, 5e-6, 1.0, 1.0, 1e-3]);
    tight
        .integrate(&mut sys, 0.0, &y0, SMOOTH_T_END, u64::MAX, &mut reference)
        .unwrap();
    assert!(reference.1 > 1e-7, "the order test must stay in contact");
    let reference = reference.0;

    let order = |make: &dyn Fn(f64) -> Box<dyn Integrator>, h: f64| {
        let (e1, _) = smooth_case_error(make(h).as_ref(), &reference);
        let (e2, _) = smooth_case_error(make(h / 2.0).as_ref(), &reference);
        (e1 / e2).log2()
    };
    let verlet = order(&|h| Box::new(VelocityVerlet { dt: h }), SMOOTH_T_END / 64.0);
    let rk4 = order(&|h| Box::new(Rk4 { dt: h }), SMOOTH_T_END / 16.0);
    let dop853 = order(
        &|h| {
            let d = Dop853::new(1.0, 1.0).with_max_step(h).with_initial_step(h);
            Box::new(d)
        },
        SMOOTH_T_END / 4.0,
    );
    assert!(
        (1.8..2.3).contains(&verlet),
        "velocity Verlet order {verlet}"
    );
    assert!((3.7..4.4).contains(&rk4), "RK4 order {rk4}");
    assert!((7.0..9.5).contains(&dop853), "DOP853 order {dop853}");
}

#[test]
fn integrators_agree_on_the_reference_scene() {
    let base = |ig: IntegratorSpec| {
        let mut s = Scene::new(ChainSpec::chain_055(25), 1.3, 6e-4);
        s.physics.damping_kg_s = 6.0;
        s.integrator = ig;
        s.record.probes = vec![
            Probe::GaugeForce { cylinder: 4 },
            Probe::GaugeForce { cylinder: 21 },
        ];
        run(&s).unwrap()
    };
    let reference = base(dop(1e-12));
    for (ig, tol) in [
        (IntegratorSpec::Rk4 { dt_s: 2e-8 }, 1e-4),
        (IntegratorSpec::Verlet { dt_s: 5e-9 }, 1e-4),
        (dop(1e-9), 1e-6),
    ] {
        let out = base(ig);
        for p in 0..2 {
            let rel = (out.probes[p].leading_peak / reference.probes[p].leading_peak - 1.0).abs();
            assert!(rel < tol, "{:?} probe {p}: relative difference {rel:e}", ig);
        }
    }
}

#[test]
fn peak_refinement_matches_a_finely_sampled_history() {
    // The on-the-fly leading peak (sampled every 0.2 µs, located on the dense output) against the maximum
    // of a history sampled every 1 ns through the dense output.
    let mut scene = Scene::new(ChainSpec::chain_055(25), 1.3, 2.5e-4);
    scene.physics.damping_kg_s = 6.0;
    scene.integrator = dop(1e-11);
    scene.record.probes = vec![Probe::GaugeForce { cylinder: 8 }];
    scene.record.history = true;
    scene.record.history_interval_s = 1e-9;
    let out = run(&scene).unwrap();
    let h = out.history.as_ref().unwrap();
    let (imax, fmax) =
        h.values[0].iter().enumerate().fold(
            (0, f64::MIN),
            |acc, (i, &v)| if v > acc.1 { (i, v) } else { acc },
        );
    let p = out.probes[0];
    assert!(
        (p.leading_peak / fmax - 1.0).abs() < 1e-7,
        "refined {} vs sampled {fmax}",
        p.leading_peak
    );
    assert!((p.leading_peak_time_s - h.time_s[imax]).abs() < 2e-9);
    assert_eq!(h.time_s.len(), 250_001);
}

#[test]
fn stop_after_leading_pulses_gives_the_same_peaks_sooner() {
    let mut scene = Scene::new(ChainSpec::chain_098(30), 1.06, 1e-3);
    scene.physics.damping_kg_s = 6.0;
    scene.record.probes = vec![
        Probe::GaugeForce { cylinder: 4 },
        Probe::GaugeForce { cylinder: 21 },
    ];
    let full = run(&scene).unwrap();
    scene.record.stop_after_leading_pulses = true;
    let early = run(&scene).unwrap();
    assert!(
        early.t_end_s < 0.5 * full.t_end_s,
        "stopped at {}",
        early.t_end_s
    );
    for p in 0..2 {
        assert_eq!(early.probes[p].leading_peak, full.probes[p].leading_peak);
    }
}

#[test]
fn invalid_scenes_name_the_field() {
    let ok = Scene::new(ChainSpec::chain_055(10), 1.3, 1e-4);
    type Mutation = Box<dyn Fn(&mut Scene)>;
    let cases: Vec<(Mutation, &str)> = vec![
        (
            Box::new(|s| s.striker_velocity_m_s = Some(f64::NAN)),
            "striker_velocity_m_s",
        ),
        (Box::new(|s| s.duration_s = 0.0), "duration_s"),
        (
            Box::new(|s| s.physics.damping_kg_s = -1.0),
            "physics.damping_kg_s",
        ),
        (
            Box::new(|s| s.chain.dimer_mut().unwrap().sphere.mass_kg = -2e-3),
            "chain.sphere.mass_kg",
        ),
        (
            Box::new(|s| {
                s.chain.dimer_mut().unwrap().cylinder.mass =
                    chainsweep_solver::chain::model::CylinderMass::HeavyCylinders {
                        mass_ratio: 1.5,
                    }
            }),
            "chain.cylinder.mass.heavy_cylinders.mass_ratio",
        ),
        (
            Box::new(|s| s.record.probes = vec![Probe::GaugeForce { cylinder: 11 }]),
            "record.probes[0].cylinder",
        ),
        (
            Box::new(|s| s.integrator = IntegratorSpec::Rk4 { dt_s: -1.0 }),
            "integrator.dt_s",
        ),
    ];
    for (mutate, field) in cases {
        let mut s = ok.clone();
        mutate(&mut s);
        let err = s.validate().unwrap_err();
        assert_eq!(err.field, field, "{err}");
        assert!(run(&s).is_err());
    }
}

#[test]
fn disabled_physics_changes_the_state_layout_only_where_needed() {
    let spec = ChainSpec::chain_055(5);
    let plain = Chain::build(&spec, &free_physics()).unwrap();
    assert_eq!(
        OdeSystem::n_quad(&ChainSystem::<false, false, false, false>::new(&plain)),
        0
    );
    let full = Chain::build(
        &spec,
        &PhysicsSpec {
            damping_kg_s: 1.0,
            ..PhysicsSpec::default()
        },
    )
    .unwrap();
    assert_eq!(
        OdeSystem::n_quad(&ChainSystem::<true, true, true, false>::new(&full)),
        2
    );
}

#[test]
fn validity_warnings_flag_extreme_impacts_only() {
    let base = |v0: f64| {
        let mut s = Scene::new(ChainSpec::chain_055(5), v0, 1e-4);
        s.integrator = dop(1e-8);
        run(&s).unwrap()
    };
    let paper = base(1.3);
    assert!(paper.warnings.is_empty(), "{:?}", paper.warnings);
    // δ/R at 1.3 m/s: about 10 µm (the striker contact) over 4 mm.
    assert!(
        paper.max_overlap_m > 5e-6 && paper.max_overlap_m < 2e-5,
        "{}",
        paper.max_overlap_m
    );
    // 200 m/s: overlaps of ~0.2 mm (δ/R ≈ 0.05), beyond small strain.
    let fast = base(200.0);
    assert!(
        fast.warnings.iter().any(|w| w.contains("small-strain")),
        "{:?}",
        fast.warnings
    );
    // Cylinders 30 mm tall: sound needs ~5 µs to cross one, while the impact pulse (~23 µs at
    // 1.3 m/s) is set by the striker and the first sphere alone.
    let mut s = Scene::new(ChainSpec::chain_055(5), 1.3, 1e-4);
    s.chain.dimer_mut().unwrap().cylinder.height_m = Some(30e-3);
    s.integrator = dop(1e-8);
    let tall = run(&s).unwrap();
    assert_eq!(tall.warnings.len(), 1, "{:?}", tall.warnings);
    assert!(
        tall.warnings[0].contains("transit time"),
        "{:?}",
        tall.warnings
    );
}

/// The 999-cylinder 0.55 chain of `sweeps/stress/long-chain-2000.json` (μ = 6 kg/s, 1.3 m/s,
/// 1 ms), whose contacts behind the pulse graze; the whole chain integrated, as when the trap was
/// found.
fn grazing_chain() -> Scene {
    let mut s = Scene::new(ChainSpec::chain_055(999), 1.3, 1e-3);
    s.physics.damping_kg_s = 6.0;
    let dimer = s.chain.dimer_mut().expect("chain_055 is a dimer");
    dimer.cylinder.mass =
        chainsweep_solver::chain::model::CylinderMass::HeavyCylinders { mass_ratio: 0.55 };
    dimer.cylinder.height_m = None;
    s.active_region = ActiveRegion::Off;
    s
}

/// A grazing contact (overlap and its rate both near zero) must not trap the step control: in the
/// 999-cylinder 0.55 chain at rtol 1e-9 (`sweeps/stress/long-chain-2000.json`) a contact behind
/// the pulse grazes near t = 0.868 ms, where steps shortened to every predicted crossing once
/// shrank to 1e-16 s and never got past it. The run takes about 1 000 steps; the budget allows 20×.
#[test]
fn grazing_contact_does_not_trap_the_step_control() {
    let mut s = grazing_chain();
    s.integrator = dop(1e-9);
    s.record.probes = vec![Probe::GaugeForce { cylinder: 4 }];
    s.max_steps = 20_000;
    let o = run(&s).expect("the run reaches its end within the step budget");
    assert_eq!(o.t_end_s, 1e-3);
    assert!(o.energy_drift_max < 1e-6, "drift {:e}", o.energy_drift_max);
}

/// The same grazing contacts with `predict_switches` (steps shortened to predicted crossings, and
/// resumed after them from half the step before): at rtol 1e-9 and at the 1e-11 of `--verify`
/// (where a contact grazes near t = 0.478 ms) the consecutive predicted landings once halved the
/// step without end. The anti-trap rule bounds such a streak; the run must end within the same
/// budget as without prediction, with as small a ledger drift.
#[test]
fn grazing_contact_does_not_trap_predicted_switch_steps() {
    for rtol in [1e-9, 1e-11] {
        let mut s = grazing_chain();
        s.integrator = IntegratorSpec::Dop853(AdaptiveOptions {
            predict_switches: true,
            ..AdaptiveOptions::new(rtol)
        });
        s.record.probes = vec![Probe::GaugeForce { cylinder: 4 }];
        s.max_steps = 20_000;
        let o = run(&s).expect("the run reaches its end within the step budget");
        assert_eq!(o.t_end_s, 1e-3);
        assert!(
            o.energy_drift_max < 1e-6,
            "rtol {rtol:e}: drift {:e}",
            o.energy_drift_max
        );
        eprintln!("rtol {rtol:e}: {:?}", o.stats);
    }
}

/// Steps ended on predicted switches keep what event location buys: on the undamped chain with
/// gaps (contacts opening and closing many times) the ledger closes as well as with the plain event
/// location, at a fraction of its cost, and the results agree with it to the tolerance; at the
/// reference run's tolerance with damping too.
#[test]
fn predicted_switch_steps_keep_the_ledger_closed_and_agree() {
    for (mu, rtol, drift_limit) in [(0.0, 1e-12, 1e-9), (6.0, 1e-12, 1e-9), (0.0, 5e-8, 1e-5)] {
        let with = |predict_switches: bool| {
            let mut scene = ledger_scene(20, mu, 6e-4);
            scene.integrator = IntegratorSpec::Dop853(AdaptiveOptions {
                predict_switches,
                ..AdaptiveOptions::new(rtol)
            });
            scene.record.probes = vec![
                Probe::GaugeForce { cylinder: 4 },
                Probe::GaugeForce { cylinder: 15 },
            ];
            run(&scene).unwrap()
        };
        let (plain, predicted) = (with(false), with(true));
        let case = format!("μ = {mu}, rtol {rtol:e}");
        // Measured: drift 5.1e-10 / 1.4e-11 / 2.8e-6 against 3.3e-10 / 2.6e-11 / 1.9e-6 without
        // prediction, with 39 082 / 47 595 / 11 561 RHS evaluations against 43 964 / 52 993 / 21 944.
        assert!(
            predicted.energy_drift_max <= drift_limit
                && predicted.energy_drift_max <= 3.0 * plain.energy_drift_max + 1e-10,
            "{case}: drift {:e} (without prediction {:e})",
            predicted.energy_drift_max,
            plain.energy_drift_max
        );
        assert!(
            predicted.momentum_residual_max <= drift_limit,
            "{case}: momentum {:e}",
            predicted.momentum_residual_max
        );
        assert!(predicted.stats.events > 20, "{case}: {:?}", predicted.stats);
        assert!(
            predicted.stats.rhs_evals < plain.stats.rhs_evals,
            "{case}: {:?} vs {:?}",
            predicted.stats,
            plain.stats
        );
        for p in 0..2 {
            let (a, b) = (
                plain.probes[p].leading_peak,
                predicted.probes[p].leading_peak,
            );
            assert!(
                (a / b - 1.0).abs() < 100.0 * rtol.max(1e-10),
                "{case}, probe {p}: {a} vs {b}"
            );
        }
    }
}

/// The first step and the rejected attempts of a striker hitting a free sphere, with or without
/// the paper's viscous term, under DOP853 with event location (`predict_switches` or not).
fn two_body_steps(mu: f64, predict_switches: bool) -> (f64, IntegrationStats) {
    let physics = PhysicsSpec {
        damping_kg_s: mu,
        ..free_physics()
    };
    let chain = Chain::build(&ChainSpec::chain_098(0), &physics).unwrap();
    let v0 = 1.3;
    let reduced = chain.mass[0] * chain.mass[1] / (chain.mass[0] + chain.mass[1]);
    let delta_max = (5.0 * reduced * v0 * v0 / (4.0 * chain.stiffness[0])).powf(0.4);
    struct FirstStep(Option<f64>);
    impl StepObserver for FirstStep {
        fn on_start(&mut self, _t0: f64, _y0: &[f64]) {}
        fn on_step(&mut self, step: &dyn DenseStep) -> Control {
            self.0.get_or_insert(step.t_end() - step.t_start());
            Control::Continue
        }
    }
    let mut first = FirstStep(None);
    let mut ig = Dop853::with_options(AdaptiveOptions {
        predict_switches,
        ..AdaptiveOptions::new(1e-9)
    });
    ig.atol_scale = Some(vec![delta_max, delta_max, v0, v0, v0 * v0 * reduced]);
    let y0 = [0.0, 0.0, v0, 0.0, 0.0];
    let mut sys = ChainSystem::<false, true, false, false>::new(&chain);
    // Twice the undamped contact time: the contact opens inside the run.
    let stats = ig
        .integrate(
            &mut sys,
            0.0,
            &y0,
            2.0 * 3.22 * delta_max / v0,
            1_000_000,
            &mut first,
        )
        .unwrap();
    (first.0.expect("a step"), stats)
}

/// The viscous term acts only while a contact is compressed, so it jumps by `μ Δv` where the
/// contact closes or opens. A run that starts on a closing contact (the striker touching at t = 0)
/// takes its first derivative on the compressed side, which every other stage of its first step
/// sees; before, it was taken on the open side, the first step's error fell only in proportion to
/// the step, and the run began with about twenty rejected attempts, its first step shrunk a
/// billionfold. A step that lands on the opening holds the contact compressed at its last stage,
/// evaluated a hair past the crossing; before, that stage saw the open side, and the landing was
/// rejected until the step was small. Measured (rtol 1e-9, without / with `predict_switches`): the
/// damped first step is 0.99 of the undamped one (2.3e-4 of it before), with 13 / 10 rejected
/// attempts against 12 / 10 undamped (28 / 25 before).
#[test]
fn a_damped_impact_does_not_fail_on_the_viscous_jump() {
    for predict in [false, true] {
        let (undamped_first, undamped) = two_body_steps(0.0, predict);
        let (damped_first, damped) = two_body_steps(6.0, predict);
        assert!(
            damped_first > 0.3 * undamped_first,
            "predict {predict}: first step {damped_first:e} against {undamped_first:e} undamped"
        );
        assert!(
            damped.rejected <= undamped.rejected + 2,
            "predict {predict}: {damped:?} against {undamped:?} undamped"
        );
    }
}
