//! General chains against numbers: two-body impacts under power laws and Hertz's law for unequal
//! spheres against their closed forms, the coefficients of restitution of the Kuwabara–Kono and
//! Hunt–Crossley models against their published relations, Nesterenko's solitary-wave speed for
//! several exponents, the sound speed of a precompressed chain, the energy ledger for every law
//! and model, and the paper's chain written as a sequence.

use chainsweep_solver::chain::model::{hertz_coefficient, Chain, Material, PhysicsSpec};
use chainsweep_solver::chain::sequence::SequenceSpec;
use chainsweep_solver::contact::{hunt_crossley_alpha, hunt_crossley_restitution, DissipationSpec};
use chainsweep_solver::integrate::{Dop853, Integrator};
use chainsweep_solver::observe::probes::Probe;
use chainsweep_solver::problems::{
    chain, kuwabara_kono_restitution, monodisperse, nesterenko_speed, power_law, repeat, rule,
    sound_speed, sphere, ContactTimer, PowerLawImpact, STEEL,
};
use chainsweep_solver::scene::solve::run;
use chainsweep_solver::scene::{Excitation, IntegratorSpec, Scene};
use chainsweep_solver::ChainSpec;

fn dop(rtol: f64) -> IntegratorSpec {
    IntegratorSpec::Dop853(chainsweep_solver::AdaptiveOptions::new(rtol))
}

fn free() -> PhysicsSpec {
    PhysicsSpec {
        gravity: false,
        wall: false,
        ..PhysicsSpec::default()
    }
}

/// Striker (particle 1) on one free particle: the contact timer's record of the impact.
fn two_body(spec: &SequenceSpec, physics: &PhysicsSpec, v0: f64, scale: f64) -> ContactTimer {
    let chain = Chain::build(&ChainSpec::Sequence(spec.clone()), physics).unwrap();
    assert_eq!(chain.n_particles(), 2);
    let mut timer = ContactTimer::new(2);
    let y0 = chain.initial_state(v0);
    let mut ig = Dop853::new(1e-13, 1e-13);
    let mut atol = vec![scale, scale, v0, v0];
    atol.resize(y0.len(), 1.0);
    ig.atol_scale = Some(atol);
    let t_end = 1e-2;
    chainsweep_solver::dispatch_chain_system!(&chain, |sys| ig
        .integrate(&mut sys, 0.0, &y0, t_end, 10_000_000, &mut timer)
        .unwrap());
    timer
}

#[test]
fn two_body_power_law_impacts_match_the_closed_form() {
    let (m1, m2, v0) = (2.085e-3, 3.1e-3, 0.7);
    // Coefficients that give overlaps of a few µm at 0.7 m/s, as Hertz does for steel.
    for (n, a) in [
        (1.0, 2.0e7),
        (1.25, 3.0e8),
        (1.5, 9.0e9),
        (2.0, 5.0e12),
        (2.5, 4.0e15),
    ] {
        let spec = chain(
            &[
                ("s", sphere(STEEL, 8e-3, m1)),
                ("t", sphere(STEEL, 8e-3, m2)),
            ],
            vec![repeat(1, "t")],
            Some("s"),
            vec![rule("s", "t", Some(power_law(a, n)), None)],
        );
        let exact = PowerLawImpact::new(m1, m2, a, n, v0);
        let timer = two_body(&spec, &free(), v0, exact.peak_overlap_m);
        let duration = timer.opened_at.expect("the contact opens");
        assert!(
            (duration / exact.duration_s - 1.0).abs() < 1e-8,
            "n = {n}: duration {duration} vs {}",
            exact.duration_s
        );
        assert!(
            (timer.peak_overlap / exact.peak_overlap_m - 1.0).abs() < 1e-9,
            "n = {n}: peak overlap"
        );
        // Elastic: momentum and energy give the textbook exit velocities.
        let (u1, u2) = timer.velocities_at_opening;
        assert!(
            (u1 - (m1 - m2) / (m1 + m2) * v0).abs() < 1e-9 * v0,
            "n = {n}"
        );
        assert!(
            (u2 - 2.0 * m1 / (m1 + m2) * v0).abs() < 1e-9 * v0,
            "n = {n}"
        );

        // The peak force through the scene API and its probe.
        let mut scene = Scene::new(spec, v0, 2.0 * exact.duration_s);
        scene.physics = free();
        scene.integrator = dop(1e-12);
        scene.record.probes = vec![Probe::ContactForce { contact: 1 }];
        scene.record.summary_interval_s = exact.duration_s / 200.0;
        let out = run(&scene).unwrap();
        let peak = out.probes[0].leading_peak;
        assert!(
            (peak / exact.peak_force_n - 1.0).abs() < 1e-8,
            "n = {n}: peak force {peak} vs {}",
            exact.peak_force_n
        );
        assert!((out.probes[0].leading_peak_time_s / (0.5 * exact.duration_s) - 1.0).abs() < 1e-6);
    }
}

#[test]
fn vern6_two_body_impacts_match_the_closed_form() {
    // Verner's 6(5) through the scene API: peak force and its time (located on its 6th-order
    // dense output), and the ledger of an elastic impact, against the closed forms.
    let (m1, m2, v0) = (2.085e-3, 3.1e-3, 0.7);
    for (n, a) in [(1.0, 2.0e7), (1.5, 9.0e9), (2.5, 4.0e15)] {
        let spec = chain(
            &[
                ("s", sphere(STEEL, 8e-3, m1)),
                ("t", sphere(STEEL, 8e-3, m2)),
            ],
            vec![repeat(1, "t")],
            Some("s"),
            vec![rule("s", "t", Some(power_law(a, n)), None)],
        );
        let exact = PowerLawImpact::new(m1, m2, a, n, v0);
        let mut scene = Scene::new(spec, v0, 2.0 * exact.duration_s);
        scene.physics = free();
        scene.integrator = IntegratorSpec::Vern6(chainsweep_solver::AdaptiveOptions::new(1e-11));
        scene.record.probes = vec![Probe::ContactForce { contact: 1 }];
        scene.record.summary_interval_s = exact.duration_s / 200.0;
        let out = run(&scene).unwrap();
        assert_eq!(out.method, "vern6");
        let peak = out.probes[0].leading_peak;
        assert!(
            (peak / exact.peak_force_n - 1.0).abs() < 1e-8,
            "n = {n}: peak force {peak} vs {}",
            exact.peak_force_n
        );
        assert!((out.probes[0].leading_peak_time_s / (0.5 * exact.duration_s) - 1.0).abs() < 1e-6);
        assert!(
            out.energy_drift_max < 1e-9,
            "n = {n}: drift {:e}",
            out.energy_drift_max
        );
    }
}

#[test]
fn hertz_impact_of_unequal_spheres_of_different_materials() {
    // A 12 mm steel sphere on a 5 mm glass sphere: Eq. (1) with R* = R1R2/(R1+R2) and
    // 1/E* = (1−ν1²)/E1 + (1−ν2²)/E2, F = (4/3) E* √R* δ^{3/2}.
    let glass = Material {
        youngs_modulus_pa: 63e9,
        poisson_ratio: 0.22,
    };
    let (d1, d2) = (12e-3, 5e-3);
    let (m1, m2) = (7.06e-3, 0.164e-3);
    let spec = chain(
        &[
            ("big", sphere(STEEL, d1, m1)),
            ("small", sphere(glass, d2, m2)),
        ],
        vec![repeat(1, "small")],
        Some("big"),
        vec![],
    );
    let (r1, r2) = (0.5 * d1, 0.5 * d2);
    let r_star = r1 * r2 / (r1 + r2);
    let e_star = 1.0 / ((1.0 - 0.28f64.powi(2)) / 200e9 + (1.0 - 0.22f64.powi(2)) / 63e9);
    let a = 4.0 / 3.0 * e_star * r_star.sqrt();
    let chain_built = Chain::build(&ChainSpec::Sequence(spec.clone()), &free()).unwrap();
    assert!((chain_built.stiffness[0] / a - 1.0).abs() < 1e-14);
    assert_eq!(
        chain_built.stiffness[0],
        hertz_coefficient(STEEL, Some(r1), glass, Some(r2))
    );
    let v0 = 0.4;
    let exact = PowerLawImpact::new(m1, m2, a, 1.5, v0);
    // The textbook form of the Hertz impact duration: 2.9432 (5μ/(4A))^{2/5} v^{-1/5}.
    let mu = m1 * m2 / (m1 + m2);
    let textbook = 2.9432 * (1.25 * mu / a).powf(0.4) * v0.powf(-0.2);
    assert!((exact.duration_s / textbook - 1.0).abs() < 3e-5);
    let timer = two_body(&spec, &free(), v0, exact.peak_overlap_m);
    let duration = timer.opened_at.unwrap();
    assert!(
        (duration / exact.duration_s - 1.0).abs() < 1e-8,
        "{duration} vs {}",
        exact.duration_s
    );
    assert!((timer.peak_overlap / exact.peak_overlap_m - 1.0).abs() < 1e-9);
}

/// Restitution of a two-body impact of equal spheres (reduced mass m/2) at `v0` under `model`.
fn restitution(model: DissipationSpec, v0: f64) -> f64 {
    let spec = monodisperse(1, None, true);
    let physics = PhysicsSpec {
        dissipation: Some(model),
        ..free()
    };
    let timer = two_body(&spec, &physics, v0, 5e-6);
    let (u1, u2) = timer.velocities_at_opening;
    (u2 - u1) / v0
}

#[test]
fn kuwabara_kono_restitution_matches_the_viscoelastic_series() {
    let spec = monodisperse(1, None, true);
    let chain = Chain::build(&ChainSpec::Sequence(spec), &free()).unwrap();
    let (a, m) = (chain.stiffness[0], 0.5 * chain.mass[0]);
    // β from 0.004 to 0.08. The series is known in closed form to second order; the third-order
    // remainder is bounded by 0.6 β³ (it is about 0.52 β³), far below the second-order term
    // 0.8 β², so the test resolves both published coefficients.
    for (tau, v0) in [(2e-8, 1.0), (1e-7, 0.3), (2e-7, 2.0), (4e-7, 1.0)] {
        let e = restitution(
            DissipationSpec::KuwabaraKono {
                relaxation_time_s: tau,
            },
            v0,
        );
        let series = kuwabara_kono_restitution(tau, a, m, v0);
        let beta = 1.5 * tau * (a / m).powf(0.4) * v0.powf(0.2);
        let tolerance = 1e-8 + 0.6 * beta.powi(3);
        assert!(
            (e - series).abs() < tolerance,
            "τ = {tau}, v = {v0}: simulated {e}, series {series} (β = {beta})"
        );
        let first_order = 1.0 - 1.153_447 * beta;
        assert!(
            (e - first_order).abs() > 10.0 * tolerance || beta < 0.01,
            "the second-order term must be resolved"
        );
    }
    // The restitution of the viscoelastic model falls with the impact velocity as v^{1/5}.
    let model = DissipationSpec::KuwabaraKono {
        relaxation_time_s: 5e-8,
    };
    let (slow, fast) = (restitution(model, 0.1), restitution(model, 3.2));
    assert!(((1.0 - fast) / (1.0 - slow) / 2.0 - 1.0).abs() < 0.02);
}

#[test]
fn hunt_crossley_relation_reduces_to_the_published_limits() {
    // The exact two-body relation behind `hunt_crossley_alpha` tends to Hunt & Crossley's own
    // α v = 3(1 − e)/2 as e → 1 (measured excess: 1.01 (1 − e) … 1.05 (1 − e) for e ≥ 0.95), where
    // Lankarani & Nikravesh's 3(1 − e²)/4 agrees too; Flores et al.'s 8(1 − e)/(5e) stays 6 %
    // above it (1.6 instead of 1.5), which is why the engine solves the exact relation instead.
    for e in [0.999, 0.99, 0.95] {
        let v = 0.7;
        let z = hunt_crossley_alpha(e, v) * v;
        let hunt_crossley = 1.5 * (1.0 - e);
        let ratio = z / hunt_crossley;
        assert!(
            ratio > 1.0 && ratio - 1.0 < 1.2 * (1.0 - e),
            "e = {e}: α v = {z}, Hunt–Crossley {hunt_crossley}"
        );
        let lankarani = 0.75 * (1.0 - e * e);
        assert!((z / lankarani - 1.0).abs() < 2.0 * (1.0 - e), "e = {e}");
        let flores = 1.6 * (1.0 - e) / e;
        assert!(
            (z / flores - 0.9375).abs() < 0.01,
            "e = {e}: {}",
            z / flores
        );
        // α is a material constant: it scales as 1/v for a given restitution at v.
        assert!((hunt_crossley_alpha(e, 2.0 * v) * 2.0 * v / z - 1.0).abs() < 1e-12);
    }
}

#[test]
fn hunt_crossley_restitution_matches_its_exact_relation() {
    for e in [0.95, 0.7, 0.3] {
        let v_ref = 0.8;
        let model = DissipationSpec::HuntCrossley {
            restitution: e,
            impact_velocity_m_s: v_ref,
        };
        // At the reference velocity the impact has the restitution asked for…
        let got = restitution(model, v_ref);
        assert!((got - e).abs() < 1e-8, "e = {e}: simulated {got}");
        // …and at another velocity the one the same relation gives for α v.
        let alpha = hunt_crossley_alpha(e, v_ref);
        let v = 2.5;
        let got = restitution(model, v);
        let expected = hunt_crossley_restitution(alpha, v);
        assert!(
            (got - expected).abs() < 1e-8,
            "e = {e} at {v} m/s: simulated {got}, relation {expected}"
        );
        assert!(expected < e, "faster impacts dissipate more");
    }
}

#[test]
fn linear_viscous_restitution_of_a_linear_spring_is_exponential() {
    // n = 1 with a constant damper: a damped half-oscillation, e = exp(−ζπ/√(1−ζ²)), the
    // textbook result the model must reproduce exactly (the damper jumps on at contact).
    let (m, a, mu) = (2.085e-3, 3.0e7, 2.0);
    let spec = chain(
        &[("ball", sphere(STEEL, 8e-3, m))],
        vec![repeat(1, "ball")],
        Some("ball"),
        vec![rule(
            "ball",
            "ball",
            Some(power_law(a, 1.0)),
            Some(DissipationSpec::LinearViscous { damping_kg_s: mu }),
        )],
    );
    let timer = two_body(&spec, &free(), 1.0, 1e-5);
    let (u1, u2) = timer.velocities_at_opening;
    let reduced = 0.5 * m;
    let zeta = mu / (2.0 * (a * reduced).sqrt());
    let exact = (-zeta * std::f64::consts::PI / (1.0 - zeta * zeta).sqrt()).exp();
    assert!(((u2 - u1) - exact).abs() < 1e-9, "{} vs {exact}", u2 - u1);
}

#[test]
fn impulse_and_pulse_excitations_need_no_striker() {
    // The same chain excited three ways: each runs, and its ledger closes.
    let spec = monodisperse(30, None, false);
    for excitation in [
        Excitation::Impulse { velocity_m_s: 0.5 },
        Excitation::HalfSineForce {
            amplitude_n: 40.0,
            duration_s: 5e-5,
        },
    ] {
        let mut scene = Scene::excited(spec.clone(), excitation.clone(), 2e-4);
        scene.integrator = dop(1e-11);
        scene.record.probes = vec![Probe::ParticleForce { particle: 10 }];
        let out = run(&scene).unwrap();
        assert!(out.probes[0].leading_peak > 1.0, "{excitation:?}");
        assert!(
            out.energy_drift_max < 1e-8,
            "{excitation:?}: {}",
            out.energy_drift_max
        );
        assert!(out.momentum_residual_max < 1e-8, "{excitation:?}");
    }
}

/// The leading solitary wave of a monodisperse chain of 150 spheres under `F = A δ^n` struck by
/// one more at `v0`: its speed between contacts 60 and 120 (single contacts: the mean force of a
/// particle's two contacts is double-humped when a wave is two particles wide), its maximum
/// particle velocity at particle 90, and the ratio of its force at the two contacts.
fn solitary_wave(a: f64, n: f64, v0: f64) -> (f64, f64, f64) {
    let d = 8e-3;
    let spec = monodisperse(150, Some(power_law(a, n)), true);
    let mut scene = Scene::new(spec, v0, 5e-3);
    scene.physics = free();
    scene.integrator = dop(1e-10);
    scene.record.probes = vec![
        Probe::ContactForce { contact: 60 },
        Probe::ContactForce { contact: 120 },
        Probe::Velocity { particle: 90 },
    ];
    scene.record.stop_after_leading_pulses = true;
    let out = run(&scene).unwrap();
    let p = &out.probes;
    let speed = 60.0 * d / (p[1].leading_peak_time_s - p[0].leading_peak_time_s);
    (
        speed,
        p[2].leading_peak,
        p[0].leading_peak / p[1].leading_peak,
    )
}

#[test]
fn solitary_wave_speed_agrees_with_nesterenko_for_several_exponents() {
    let (m, d) = (2.085e-3, 8e-3);
    // Coefficients giving overlaps of a few µm at 1 m/s. The long-wave approximation holds to
    // 1 % for the gentler laws (measured: −0.24 % for n = 1.25, −0.78 % for Hertz, the discrete
    // wave's known 0.8 % below Eq. 13)…
    for (n, a) in [(1.25, 3.0e8), (1.5, 9.0e9)] {
        let (speed, v_m, ratio) = solitary_wave(a, n, 1.0);
        let long_wave = nesterenko_speed(a, n, d, m, v_m);
        assert!(
            (speed / long_wave - 1.0).abs() < 0.01,
            "n = {n}: measured {speed} m/s, long-wave {long_wave} m/s (v_m = {v_m})"
        );
        // A stationary wave: the same force at both gauges.
        assert!((ratio - 1.0).abs() < 1e-6, "n = {n}: {ratio}");
    }
    // …while steeper laws make waves only two or three particles wide, which the long-wave
    // approximation misses by more (measured: −2.1, −3.3, −4.3 % for n = 2, 2.5, 3). The discrete
    // equations still scale exactly (x → λx, t → λ^{−(n−1)/2} t), so the speed goes as
    // v_m^{(n−1)/(n+1)} to the integrator's accuracy.
    let mut last_deviation: f64 = 0.0;
    for (n, a) in [(2.0, 5.0e12), (2.5, 4.0e15), (3.0, 3.0e18)] {
        let (speed, v_m, ratio) = solitary_wave(a, n, 1.0);
        let (speed2, v_m2, _) = solitary_wave(a, n, 4.0);
        assert!((ratio - 1.0).abs() < 1e-6, "n = {n}: {ratio}");
        let scaling = (v_m2 / v_m).powf((n - 1.0) / (n + 1.0));
        assert!(
            (speed2 / speed / scaling - 1.0).abs() < 1e-6,
            "n = {n}: {speed2}/{speed} vs {scaling}"
        );
        let deviation = 1.0 - speed / nesterenko_speed(a, n, d, m, v_m);
        assert!(
            deviation > last_deviation.max(0.01) && deviation < 0.05,
            "n = {n}: {deviation}"
        );
        last_deviation = deviation;
    }
}

/// Arrival time of a pulse at a gauge: the centroid `∫ t f dt / ∫ f dt` of its history. For a
/// linear chain it travels exactly at the long-wave sound speed (the slowness `dk/dω` at `ω = 0`),
/// whatever the dispersion does to the pulse's shape and peak.
fn centroid(time: &[f64], values: &[f64]) -> f64 {
    let (s0, s1) = time
        .iter()
        .zip(values)
        .fold((0.0, 0.0), |(s0, s1), (&t, &f)| (s0 + f, s1 + f * t));
    s1 / s0
}

#[test]
fn small_amplitude_sound_speed_of_a_precompressed_chain() {
    // 400 spheres on a wall under a static force, no gravity: a weak half-sine push (a thousandth
    // of the preload, 40 transit times long) travels at the linearised sound speed
    // c0 = a √(n A δ0^{n−1}/m), measured between contacts 40 and 140 before the wall's echo.
    let (m, d, n_particles) = (2.085e-3, 8e-3, 400);
    for (law, f_p) in [(None, 50.0), (Some(power_law(5.0e12, 2.0)), 20.0)] {
        let spec = monodisperse(n_particles, law, false);
        let physics = PhysicsSpec {
            gravity: false,
            precompression_force_n: f_p,
            ..PhysicsSpec::default()
        };
        let chain0 = Chain::build(&ChainSpec::Sequence(spec.clone()), &physics).unwrap();
        let (a, n, delta0) = (
            chain0.stiffness[1],
            chain0.exponent[1],
            chain0.static_overlap[1],
        );
        // Every contact carries the precompression exactly.
        for c in 0..chain0.n_contacts() {
            assert!((chain0.static_force(c) / f_p - 1.0).abs() < 1e-12);
        }
        let c0 = sound_speed(a, n, delta0, d, m);
        let transit = d / c0;
        let mut scene = Scene::excited(
            spec,
            Excitation::HalfSineForce {
                amplitude_n: 1e-3 * f_p,
                duration_s: 40.0 * transit,
            },
            300.0 * transit,
        );
        scene.physics = physics;
        scene.integrator = dop(1e-10);
        scene.record.preload = chainsweep_solver::observe::probes::Preload::Subtract;
        scene.record.history = true;
        scene.record.history_interval_s = transit / 10.0;
        scene.record.probes = vec![
            Probe::ContactForce { contact: 40 },
            Probe::ContactForce { contact: 140 },
        ];
        let out = run(&scene).unwrap();
        let h = out.history.as_ref().unwrap();
        let delay = centroid(&h.time_s, &h.values[1]) - centroid(&h.time_s, &h.values[0]);
        let speed = 100.0 * d / delay;
        assert!(
            (speed / c0 - 1.0).abs() < 5e-4,
            "n = {n}: measured {speed} m/s, linearised {c0} m/s"
        );
        println!("n = {n}: {speed:.4} m/s vs {c0:.4} m/s");
        assert!(out.energy_drift_max < 1e-7, "{}", out.energy_drift_max);
    }
}

/// A mixed chain of 24 particles: 8 mm and 4 mm spheres and pairs of tall flat-ended cylinders in a
/// repeated block, `F = A δ^n` on the sphere–sphere pairs (Hertz where `exponent` is `None`),
/// Hertz's sphere–flat law, and linear springs between the flat faces and on the wall.
fn mixed_chain(exponent: Option<f64>, striker: bool) -> SequenceSpec {
    use chainsweep_solver::chain::sequence::{
        CylinderType, ParticleType, RepeatBlock, SequenceItem,
    };
    let tall = ParticleType::Cylinder(CylinderType {
        material: Material::STEEL_SS304,
        diameter_m: 8e-3,
        height_m: 9.6e-3,
        mass_kg: None,
        density_kg_m3: Some(7813.0),
    });
    // Coefficients that give overlaps of a few µm at ~1 m/s for every exponent.
    let law = exponent.map(|n| power_law(9e9 * 1e-6f64.powf(1.5 - n), n));
    let spring = Some(power_law(2.0e7, 1.0));
    let mut contacts = vec![
        rule("tall", "tall", spring, None),
        rule("tall", "wall", spring, None),
    ];
    if let Some(l) = law {
        contacts.push(rule("ball", "small", Some(l), None));
        contacts.push(rule("ball", "ball", Some(l), None));
    }
    chain(
        &[
            ("ball", sphere(STEEL, 8e-3, 2.085e-3)),
            ("small", sphere(STEEL, 4e-3, 0.26e-3)),
            ("tall", tall),
        ],
        vec![SequenceItem::Repeat(RepeatBlock {
            repeat: 6,
            of: vec![
                SequenceItem::Type("ball".into()),
                SequenceItem::Type("small".into()),
                SequenceItem::Type("tall".into()),
                SequenceItem::Type("tall".into()),
            ],
        })],
        striker.then_some("ball"),
        contacts,
    )
}

#[test]
fn energy_ledger_closes_for_every_law_model_and_excitation() {
    // Every law (Hertz, power laws n = 1 and 2.5 on the sphere pairs, a linear spring on the
    // flat–flat pairs throughout) × every dissipation model (none, linear viscous,
    // Kuwabara–Kono, Hunt–Crossley) × every excitation (striker, impulse, half-sine force), with
    // gravity, the wall and a static precompression: the energy E = kinetic + elastic +
    // gravitational + dissipated − external work stays at its initial value to the
    // integrator's tolerance, while the dissipated share is many orders of magnitude larger.
    let models = [
        None,
        Some(DissipationSpec::LinearViscous { damping_kg_s: 5.0 }),
        Some(DissipationSpec::KuwabaraKono {
            relaxation_time_s: 2e-7,
        }),
        Some(DissipationSpec::HuntCrossley {
            restitution: 0.6,
            impact_velocity_m_s: 0.5,
        }),
    ];
    // The mixed chains run on the per-contact power-law kernel; the monodisperse ones on the
    // Hertz and linear kernels.
    type Build = fn(bool) -> SequenceSpec;
    let chains: [(&str, Build); 4] = [
        ("mixed, Hertz spheres", |s| mixed_chain(None, s)),
        ("mixed, n = 2.5 spheres", |s| mixed_chain(Some(2.5), s)),
        ("monodisperse Hertz", |s| monodisperse(24, None, s)),
        ("monodisperse linear", |s| {
            monodisperse(24, Some(power_law(2.0e7, 1.0)), s)
        }),
    ];
    for (name, build) in chains {
        for model in models {
            for excitation in [
                None,
                Some(Excitation::Impulse { velocity_m_s: 0.8 }),
                Some(Excitation::HalfSineForce {
                    amplitude_n: 30.0,
                    duration_s: 3e-5,
                }),
            ] {
                let spec = build(excitation.is_none());
                let mut scene = match &excitation {
                    None => Scene::new(spec, 0.8, 6e-4),
                    Some(e) => Scene::excited(spec, e.clone(), 6e-4),
                };
                scene.physics = PhysicsSpec {
                    precompression_force_n: 2.0,
                    dissipation: model,
                    ..PhysicsSpec::default()
                };
                scene.integrator = dop(1e-11);
                scene.record.probes = vec![Probe::ContactForce { contact: 12 }];
                let what = format!("{name}, model {model:?}, excitation {excitation:?}");
                let out = run(&scene).unwrap_or_else(|e| panic!("{what}: {e}"));
                assert!(
                    out.energy_drift_max < 1e-8,
                    "{what}: drift {:e}",
                    out.energy_drift_max
                );
                assert!(
                    out.probes[0].leading_peak > 0.5,
                    "{what}: the pulse arrives"
                );
                let dissipated = out.final_energy.dissipated / out.impact_energy_j;
                if model.is_some() {
                    assert!(dissipated > 1e-3, "{what}: dissipated share {dissipated:e}");
                } else {
                    assert_eq!(out.final_energy.dissipated, 0.0, "{what}");
                }
            }
        }
    }
}

#[test]
fn bad_values_are_refused_with_the_field_named() {
    use chainsweep_solver::chain::sequence::{CylinderType, ParticleType, SequenceItem, TaperSpec};
    let field_of = |scene: &Scene| scene.validate().map(|_| ()).unwrap_err().field;
    let striker = |spec: SequenceSpec| Scene::new(spec, 0.5, 1e-4);

    // An exponent below 1.
    let spec = monodisperse(10, Some(power_law(1e9, 0.8)), true);
    assert_eq!(
        field_of(&striker(spec)),
        "chain.contacts[0].law.power_law.exponent"
    );
    // A negative static force, and a negative force pulse.
    let mut scene = striker(monodisperse(10, None, true));
    scene.physics.precompression_force_n = -1.0;
    assert_eq!(field_of(&scene), "physics.precompression_force_n");
    let pulse = |amplitude_n, duration_s| {
        Scene::excited(
            monodisperse(10, None, false),
            Excitation::HalfSineForce {
                amplitude_n,
                duration_s,
            },
            1e-4,
        )
    };
    assert_eq!(
        field_of(&pulse(-5.0, 1e-5)),
        "excitation.half_sine_force.amplitude_n"
    );
    // A pulse of zero duration.
    assert_eq!(
        field_of(&pulse(5.0, 0.0)),
        "excitation.half_sine_force.duration_s"
    );
    // A taper that shrinks the last of 30 spheres 0.5^29 times, and one that merely tapers.
    let mut spec = monodisperse(30, None, true);
    spec.taper = Some(TaperSpec { ratio: 0.5 });
    let err = striker(spec.clone()).validate().unwrap_err();
    assert_eq!(err.field, "chain.taper.ratio");
    assert!(err.message.contains("vanish"), "{}", err.message);
    spec.taper = Some(TaperSpec { ratio: 0.9 });
    striker(spec).validate().unwrap();
    // Two flat faces in contact without an explicit law.
    let tall = ParticleType::Cylinder(CylinderType {
        material: Material::STEEL_SS304,
        diameter_m: 8e-3,
        height_m: 9.6e-3,
        mass_kg: Some(3.77e-3),
        density_kg_m3: None,
    });
    let flat = chain(
        &[("ball", sphere(STEEL, 8e-3, 2.085e-3)), ("tall", tall)],
        vec![
            SequenceItem::Type("ball".into()),
            SequenceItem::Type("tall".into()),
            SequenceItem::Type("tall".into()),
            SequenceItem::Type("ball".into()),
        ],
        Some("ball"),
        vec![],
    );
    let err = striker(flat.clone()).validate().unwrap_err();
    assert_eq!(err.field, "chain.contacts");
    assert!(err.message.contains("tall"), "{}", err.message);
    // With a law for the pair it runs.
    let mut fixed = flat;
    fixed.contacts = vec![rule("tall", "tall", Some(power_law(2e7, 1.0)), None)];
    striker(fixed).validate().unwrap();
}

/// A run stopped after its leading pulses ends its record at the summary instant at which the last
/// of them was seen to pass, not at the end of the step that contains that instant, so that the
/// record does not depend on the step sizes. In this tapered chain (the sweep example's ratio 0.96)
/// the force at the last sphere is rising again when the wall's pulse has passed: a record reaching
/// to the end of the last step put its maximum wherever that step happened to end (3.5 % apart
/// between rtol 1e-10 and 1e-12).
#[test]
fn a_stopped_record_ends_where_the_last_pulse_passed_at_any_tolerance() {
    let scene = |rtol: f64| -> Scene {
        serde_json::from_value(serde_json::json!({
            "chain": {
                "particles": {"ball": {"sphere": {
                    "diameter_m": 0.008, "density_kg_m3": 7780,
                    "material": {"youngs_modulus_pa": 2e11, "poisson_ratio": 0.28}}}},
                "sequence": [{"repeat": 30, "of": ["ball"]}],
                "striker": "ball",
                "taper": {"ratio": 0.96}
            },
            "physics": {"gravity": false, "damping_kg_s": 0.0, "wall": true},
            "striker_velocity_m_s": 0.5,
            "duration_s": 0.002,
            "integrator": {"method": "dop853", "rtol": rtol},
            "record": {
                "probes": [
                    {"kind": "particle_force", "particle": 6},
                    {"kind": "particle_force", "particle": 30},
                    {"kind": "wall_force"}
                ],
                "history": true,
                "history_interval_s": 2e-7,
                "stop_after_leading_pulses": true
            }
        }))
        .unwrap()
    };
    let coarse = run(&scene(1e-10)).unwrap();
    let fine = run(&scene(1e-12)).unwrap();
    let (hc, hf) = (coarse.history.unwrap(), fine.history.unwrap());
    // The same instants, ending at the same one, at either tolerance.
    assert!(
        hc.time_s == hf.time_s,
        "the records end at {:?} s and {:?} s",
        hc.time_s.last(),
        hf.time_s.last()
    );
    let last = *hf.time_s.last().unwrap();
    assert!(last < fine.t_end_s && last < coarse.t_end_s);
    // The force at the last sphere is rising again at the record's end.
    let at_last = &hf.values[1][hf.values[1].len() - 2..];
    assert!(at_last[1] > at_last[0], "{at_last:?}");
    for (c, f) in coarse.probes.iter().zip(&fine.probes) {
        assert!(
            (c.record_max / f.record_max - 1.0).abs() < 1e-6,
            "record maximum {} at rtol 1e-10, {} at 1e-12",
            c.record_max,
            f.record_max
        );
        assert!((c.leading_peak / f.leading_peak - 1.0).abs() < 1e-6);
    }
}

/// `mass_factors` scale each particle's mass and nothing else: the paper's chain with every
/// cylinder ×1.5 builds the same masses, laws and static state as the chain whose cylinder type
/// weighs 1.5 times as much, and a factor list of the wrong length, or a factor that is not a
/// positive number, is refused naming the field.
#[test]
fn mass_factors_scale_each_particle_and_nothing_else() {
    let physics = PhysicsSpec::default();
    let plain = ChainSpec::chain_055(6);
    let n = Chain::build(&plain, &physics).unwrap().n_particles();
    let ChainSpec::Dimer(mut d) = plain.clone() else {
        unreachable!()
    };
    // Particles 3, 5, … are the cylinders (particle 1 the striker, 2 the first sphere).
    d.mass_factors = (1..=n)
        .map(|p| if p % 2 == 1 && p > 1 { 1.5 } else { 1.0 })
        .collect();
    let factored = Chain::build(&ChainSpec::Dimer(d.clone()), &physics).unwrap();
    let ChainSpec::Dimer(mut heavy) = plain.clone() else {
        unreachable!()
    };
    let m_c = heavy.cylinder.mass_kg(heavy.sphere.mass_kg);
    heavy.cylinder.mass =
        chainsweep_solver::chain::model::CylinderMass::Explicit { mass_kg: 1.5 * m_c };
    // The same height: the geometry, hence the Hertz laws, are the type's.
    heavy.cylinder.height_m = Some(d.cylinder.height(d.sphere.mass_kg));
    let by_type = Chain::build(&ChainSpec::Dimer(heavy), &physics).unwrap();
    for p in 0..n {
        let rel = (factored.mass[p] - by_type.mass[p]).abs() / by_type.mass[p];
        assert!(
            rel < 1e-15,
            "particle {}: {} against {}",
            p + 1,
            factored.mass[p],
            by_type.mass[p]
        );
    }
    assert_eq!(factored.stiffness, by_type.stiffness);
    for (a, b) in factored.static_overlap.iter().zip(&by_type.static_overlap) {
        assert!(
            (a - b).abs() <= 1e-15 * b.abs().max(1e-12),
            "{a} against {b}"
        );
    }
    let mut short = d.clone();
    short.mass_factors.pop();
    let e = Chain::build(&ChainSpec::Dimer(short), &physics).unwrap_err();
    assert_eq!(e.field, "chain.mass_factors", "{e:?}");
    let mut negative = d;
    negative.mass_factors[3] = -1.0;
    let e = Chain::build(&ChainSpec::Dimer(negative), &physics).unwrap_err();
    assert_eq!(e.field, "chain.mass_factors[3]", "{e:?}");
}

/// `size_factors` scale a particle as if it were cut larger or smaller from the same material:
/// a striker scaled by 1.1 on a sphere scaled by 0.9 collides as Hertz's closed form says two
/// spheres of those diameters and of masses scaled by the cube collide (the contact's duration
/// and peak overlap), and the laws follow the scaled radii.
#[test]
fn size_factors_scale_diameters_masses_and_hertz_laws_together() {
    let (d, m) = (8e-3, 2.085e-3);
    let (f1, f2) = (1.1, 0.9);
    let mut spec = chain(
        &[("ball", sphere(STEEL, d, m))],
        vec![repeat(1, "ball")],
        Some("ball"),
        vec![],
    );
    spec.size_factors = vec![f1, f2];
    let built = Chain::build(&ChainSpec::Sequence(spec.clone()), &free()).unwrap();
    let (r1, r2) = (0.5 * d * f1, 0.5 * d * f2);
    let a = hertz_coefficient(STEEL, Some(r1), STEEL, Some(r2));
    let (m1, m2) = (m * f1.powi(3), m * f2.powi(3));
    assert!((built.stiffness[0] / a - 1.0).abs() < 1e-14);
    assert!((built.mass[0] / m1 - 1.0).abs() < 1e-15 && (built.mass[1] / m2 - 1.0).abs() < 1e-15);
    let v0 = 0.3;
    let exact = PowerLawImpact::new(m1, m2, a, 1.5, v0);
    let timer = two_body(&spec, &free(), v0, exact.peak_overlap_m);
    let duration = timer.opened_at.unwrap();
    assert!(
        (duration / exact.duration_s - 1.0).abs() < 1e-8,
        "{duration} vs {}",
        exact.duration_s
    );
    assert!((timer.peak_overlap / exact.peak_overlap_m - 1.0).abs() < 1e-9);
}

/// In the paper's chain, every sphere ×1.02 by `size_factors` builds the same masses, laws and
/// static state as the chain whose sphere type is 2 % larger and 1.02³ as heavy (the cylinders
/// kept as they are); a list of the wrong length, or a factor out of range, is refused naming
/// the field.
#[test]
fn size_factors_match_a_scaled_type_and_bad_lists_name_their_field() {
    let physics = PhysicsSpec::default();
    let plain = ChainSpec::chain_055(6);
    let n = Chain::build(&plain, &physics).unwrap().n_particles();
    let ChainSpec::Dimer(mut d) = plain.clone() else {
        unreachable!()
    };
    // The cylinders' mass and height as the plain chain has them, explicitly: under a
    // mass-ratio convention they follow the sphere type's mass.
    let m_c = d.cylinder.mass_kg(d.sphere.mass_kg);
    d.cylinder.height_m = Some(d.cylinder.height(d.sphere.mass_kg));
    d.cylinder.mass = chainsweep_solver::chain::model::CylinderMass::Explicit { mass_kg: m_c };
    let mut by_type = d.clone();
    // Particles 2, 4, … are the spheres (particle 1 the striker).
    d.size_factors = (1..=n)
        .map(|p| if p % 2 == 0 { 1.02 } else { 1.0 })
        .collect();
    let factored = Chain::build(&ChainSpec::Dimer(d.clone()), &physics).unwrap();
    by_type.sphere.diameter_m *= 1.02;
    by_type.sphere.mass_kg *= 1.02f64.powi(3);
    let by_type = Chain::build(&ChainSpec::Dimer(by_type), &physics).unwrap();
    let close = |a: f64, b: f64| (a - b).abs() <= 4e-15 * b.abs().max(1e-300);
    for p in 0..n {
        assert!(
            close(factored.mass[p], by_type.mass[p]),
            "mass of particle {}",
            p + 1
        );
    }
    for c in 0..factored.stiffness.len() {
        assert!(
            close(factored.stiffness[c], by_type.stiffness[c]),
            "contact {}: {} against {}",
            c + 1,
            factored.stiffness[c],
            by_type.stiffness[c]
        );
        assert!(close(factored.static_overlap[c], by_type.static_overlap[c]));
    }
    assert!(factored.stiffness[0] != Chain::build(&plain, &physics).unwrap().stiffness[0]);
    let mut short = d.clone();
    short.size_factors.pop();
    let e = Chain::build(&ChainSpec::Dimer(short), &physics).unwrap_err();
    assert_eq!(e.field, "chain.size_factors", "{e:?}");
    let mut zero = d;
    zero.size_factors[3] = 0.0;
    let e = Chain::build(&ChainSpec::Dimer(zero), &physics).unwrap_err();
    assert_eq!(e.field, "chain.size_factors[3]", "{e:?}");
}
