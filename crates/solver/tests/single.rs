//! One particle on a wall — the experiment that calibrates restitution and plasticity — is a
//! chain: a sphere dropped on the wall rebounds at `e v0` under Tsuji's law (1e-6), at Thornton's
//! closed-form restitution under his plastic law (1e-6), elastically under Hertz's with the
//! two-body impact's duration `2.943 δm/v0` (1e-4); it rests on the wall under its weight and
//! between two walls under a precompression at the load it carries (1e-12); a force, an actuator
//! and a moving base drive it with ledgers that close; ROS34PW2 and the spectrum take it too; and a
//! particle with nothing to touch is refused naming the field.

use chainsweep_solver::chain::drive::{DriveSpec, Harmonic, Waveform};
use chainsweep_solver::chain::model::{Chain, PhysicsSpec};
use chainsweep_solver::chain::sequence::SequenceSpec;
use chainsweep_solver::contact::{thornton_restitution, DissipationSpec, LawSpec};
use chainsweep_solver::observe::probes::{Preload, Probe};
use chainsweep_solver::problems::{monodisperse, rule};
use chainsweep_solver::scene::solve::run;
use chainsweep_solver::scene::{Excitation, IntegratorSpec, Scene};
use chainsweep_solver::spectrum::LinearChain;
use chainsweep_solver::{AdaptiveOptions, ChainSpec};

fn one() -> SequenceSpec {
    monodisperse(1, None, false)
}

fn bare() -> PhysicsSpec {
    PhysicsSpec {
        gravity: false,
        wall: true,
        ..PhysicsSpec::default()
    }
}

/// `spec` struck at `v0` towards its wall (a δ-force impulse), no gravity, run for `duration_s`.
fn dropped(spec: SequenceSpec, physics: PhysicsSpec, v0: f64, duration_s: f64) -> Scene {
    let mut s = Scene::excited(spec, Excitation::Impulse { velocity_m_s: v0 }, duration_s);
    s.physics = physics;
    s.integrator = IntegratorSpec::Dop853(AdaptiveOptions::new(1e-12));
    s.record.probes = vec![
        Probe::Velocity { particle: 1 },
        Probe::ContactForce { contact: 1 },
    ];
    s
}

/// Rebound velocity over impact velocity of a run long past its impact.
fn restitution(s: &Scene, v0: f64) -> f64 {
    let out = run(s).unwrap();
    let m = s.validate().unwrap().mass[0];
    (2.0 * out.final_energy.kinetic / m).sqrt() / v0
}

#[test]
fn a_sphere_dropped_on_the_wall_rebounds_as_its_law_says() {
    let v0 = 0.3;
    // Hertz: elastic, and the contact lasts the two-body impact's duration (the wall's reduced
    // mass is the sphere's).
    let s = dropped(one(), bare(), v0, 2e-4);
    let out = run(&s).unwrap();
    assert!((restitution(&s, v0) - 1.0).abs() < 1e-9);
    let chain = s.validate().unwrap();
    let a = chain.stiffness[0];
    let m = chain.mass[0];
    let peak = (1.25 * m * v0 * v0 / a).powf(0.4);
    let duration = 2.943 * peak / v0;
    // The force peaks at half the contact.
    let t_peak = out.probes[1].record_max_time_s;
    assert!(
        (2.0 * t_peak / duration - 1.0).abs() < 1e-4,
        "{t_peak} {duration}"
    );
    assert!(
        (out.max_overlap_m / peak - 1.0).abs() < 1e-9,
        "{}",
        out.max_overlap_m
    );
    assert!(out.energy_drift_max < 1e-9, "{}", out.energy_drift_max);

    // Tsuji's damping: e v0.
    for e in [0.3, 0.7, 0.95] {
        let physics = PhysicsSpec {
            dissipation: Some(DissipationSpec::Tsuji { restitution: e }),
            ..bare()
        };
        let got = restitution(&dropped(one(), physics, v0, 2e-4), v0);
        assert!((got / e - 1.0).abs() < 1e-6, "e = {e}: {got}");
    }

    // Thornton's plastic law at five times the yield velocity: his closed form.
    let v_y = v0 / 5.0;
    let mut spec = one();
    spec.contacts = vec![rule(
        "ball",
        "wall",
        Some(LawSpec::Thornton {
            yield_pressure_pa: None,
            yield_velocity_m_s: Some(v_y),
        }),
        None,
    )];
    let got = restitution(&dropped(spec, bare(), v0, 2e-4), v0);
    let want = thornton_restitution(v_y / v0);
    assert!((got / want - 1.0).abs() < 1e-6, "{got} against {want}");
}

fn top_walled() -> SequenceSpec {
    let mut spec = one();
    spec.top_wall_material = Some(spec.wall_material);
    spec
}

#[test]
fn one_particle_rests_on_its_walls_at_the_load_it_carries() {
    for (spec, physics, load_below, load_above) in [
        (
            one(),
            PhysicsSpec {
                gravity: true,
                ..bare()
            },
            None,
            None,
        ),
        (
            top_walled(),
            PhysicsSpec {
                precompression_force_n: 3.0,
                ..bare()
            },
            Some(3.0),
            Some(3.0),
        ),
        (
            top_walled(),
            PhysicsSpec {
                precompression_force_n: 3.0,
                gravity: true,
                ..bare()
            },
            None,
            Some(3.0),
        ),
    ] {
        let chain = Chain::build(&ChainSpec::Sequence(spec.clone()), &physics).unwrap();
        let weight = chain.mass[0] * chain.gravity_m_s2;
        let below = load_below.unwrap_or(physics.precompression_force_n + weight);
        let mut s = Scene::excited(spec, Excitation::Impulse { velocity_m_s: 1e-9 }, 1e-5);
        s.physics = physics;
        s.record.probes = (1..=chain.n_contacts())
            .map(|contact| Probe::ContactForce { contact })
            .collect();
        s.record.preload = Preload::Include;
        s.record.history = true;
        s.record.history_interval_s = 1e-6;
        let h = run(&s).unwrap().history.unwrap();
        assert!(
            (h.values[0][0] / below - 1.0).abs() < 1e-12,
            "{}",
            h.values[0][0]
        );
        if let Some(above) = load_above {
            assert!(
                (h.values[1][0] / above - 1.0).abs() < 1e-12,
                "{}",
                h.values[1][0]
            );
        }
    }
}

fn harmonic(amplitude: f64) -> Waveform {
    Waveform::Harmonic(Harmonic {
        amplitude,
        frequency_hz: 2e3,
        phase_rad: 0.0,
        ramp_periods: 2.0,
    })
}

#[test]
fn one_particle_is_driven_by_every_drive_and_integrated_by_every_method() {
    let physics = PhysicsSpec {
        precompression_force_n: 2.0,
        damping_kg_s: 2.0,
        ..bare()
    };
    for drive in [
        DriveSpec::ForceN(harmonic(0.5)),
        DriveSpec::ActuatorM(harmonic(1e-8)),
        DriveSpec::BaseM(harmonic(1e-8)),
    ] {
        for integrator in [
            IntegratorSpec::Dop853(AdaptiveOptions::new(1e-10)),
            IntegratorSpec::Ros34pw2(AdaptiveOptions::new(1e-8)),
        ] {
            let mut s = Scene::excited(top_walled(), Excitation::Drive(drive.clone()), 5e-3);
            s.physics = physics;
            s.integrator = integrator;
            s.record.probes = vec![Probe::Displacement { particle: 1 }, Probe::WallForce];
            let out = run(&s).unwrap();
            assert!(
                out.probes[0].record_max > 0.0 && out.probes[1].record_max.is_finite(),
                "{drive:?}: {:?}",
                out.probes
            );
            assert!(
                out.energy_drift_max < 1e-5,
                "{drive:?} {integrator:?}: drift {}",
                out.energy_drift_max
            );
        }
    }
    // Its spectrum: one mode, on both walls' springs.
    let chain = Chain::build(&ChainSpec::Sequence(top_walled()), &physics).unwrap();
    let lin = LinearChain::of(&chain).unwrap();
    let omega = lin.spectrum(false).angular_frequency_rad_s;
    let want = ((lin.wall_stiffness + lin.top_stiffness) / chain.mass[0]).sqrt();
    assert_eq!(omega.len(), 1);
    assert!(
        (omega[0] / want - 1.0).abs() < 1e-12,
        "{omega:?} against {want}"
    );
}

#[test]
fn a_particle_with_nothing_to_touch_is_refused_naming_the_field() {
    let physics = PhysicsSpec {
        wall: false,
        ..bare()
    };
    let err = Chain::build(&ChainSpec::Sequence(one()), &physics).unwrap_err();
    assert_eq!(err.field, "chain.sequence", "{err:?}");
    assert!(err.message.contains("single particle"), "{err:?}");
}
